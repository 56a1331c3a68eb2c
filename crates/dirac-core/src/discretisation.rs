//! One path approximation and one quadrature rule: the discretisation of `L` and `f` together.

use std::fmt;

use crate::path::PolynomialPath;
use crate::quadrature::{QuadratureKind, QuadratureRule};

/// A Galerkin discretisation: a polynomial path of degree `s` plus the quadrature rules used for
/// `L_d` and for `f_d^±`.
///
/// Built through the ordinary constructors, the *same* rule serves the Lagrangian and the force:
///
/// ```text
/// L_d   = h Σᵢ bᵢ L(qⁱ, vⁱ)
/// f_d^± = h Σᵢ bᵢ f(qⁱ, vⁱ, t_k + cᵢh) · ∂qⁱ/∂q_{k+1}, ∂qⁱ/∂q_k
/// ```
///
/// which makes the integrator equivalence-preserving: moving a potential between `L` and `f`
/// leaves the discrete trajectory unchanged (MATH §2). Only
/// [`Discretisation::non_equivalence_preserving`] mixes rules, for experiments.
///
/// Orders (for `L_d` and `f_d^±` of the same order `r`, the step map has order `r`): the linear path
/// gives order 2 with any rule at least as exact as the trapezoid rule; degree `s` with `s` Gauss
/// nodes or `s + 1` Lobatto nodes gives `2s`; degree `s` with `s` Lobatto nodes gives `2s − 2`.
///
/// ```
/// use dirac_core::Discretisation;
/// let d = Discretisation::gauss(2);
/// assert_eq!(d.order(), 4);
/// assert!(d.is_equivalence_preserving());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Discretisation {
    path: PolynomialPath,
    lagrangian_rule: QuadratureRule,
    force_rule: QuadratureRule,
}

impl Discretisation {
    /// Degree-`s` path with `rule` for both `L_d` and `f_d^±` (equivalence-preserving).
    #[must_use]
    pub fn galerkin(degree: usize, rule: QuadratureRule) -> Self {
        Self {
            path: PolynomialPath::new(degree),
            force_rule: rule.clone(),
            lagrangian_rule: rule,
        }
    }

    /// Linear path, midpoint rule (order 2; symplectic midpoint on `(q, p)` for `L = ½vᵀMv − V`).
    #[must_use]
    pub fn midpoint() -> Self {
        Self::galerkin(1, QuadratureRule::midpoint())
    }

    /// Linear path, trapezoid rule (order 2; Störmer–Verlet for `L = ½vᵀMv − V`).
    #[must_use]
    pub fn trapezoid() -> Self {
        Self::galerkin(1, QuadratureRule::trapezoid())
    }

    /// Linear path, Simpson's rule (order 2: the linear path limits it).
    #[must_use]
    pub fn simpson() -> Self {
        Self::galerkin(1, QuadratureRule::simpson())
    }

    /// Degree-`s` path with `s` Gauss nodes: order `2s`.
    #[must_use]
    pub fn gauss(s: usize) -> Self {
        Self::galerkin(s, QuadratureRule::gauss(s))
    }

    /// Degree-`s` path with `s + 1` Lobatto nodes (Lobatto IIIA–IIIB): order `2s`.
    #[must_use]
    pub fn lobatto(s: usize) -> Self {
        Self::galerkin(s, QuadratureRule::lobatto(s + 1))
    }

    /// A deliberately **non**-equivalence-preserving discretisation: `lagrangian_rule` for `L_d`
    /// and a different `force_rule` for `f_d^±` on the same path.
    ///
    /// The resulting integrator still has order `min` of the two, but its trajectory depends on
    /// how a force is represented (potential in `L` or external force), so interconnected models
    /// built from it disagree with their monolithic form. It exists to reproduce the paper's
    /// Figures 2–3 and as a negative control in tests; do not use it for models.
    #[must_use]
    pub fn non_equivalence_preserving(
        degree: usize,
        lagrangian_rule: QuadratureRule,
        force_rule: QuadratureRule,
    ) -> Self {
        Self {
            path: PolynomialPath::new(degree),
            lagrangian_rule,
            force_rule,
        }
    }

    /// The path approximation.
    #[must_use]
    pub fn path(&self) -> &PolynomialPath {
        &self.path
    }

    /// Quadrature used for `L_d`.
    #[must_use]
    pub fn lagrangian_rule(&self) -> &QuadratureRule {
        &self.lagrangian_rule
    }

    /// Quadrature used for `f_d^±`.
    #[must_use]
    pub fn force_rule(&self) -> &QuadratureRule {
        &self.force_rule
    }

    /// True when `L_d` and `f_d^±` share nodes and weights.
    #[must_use]
    pub fn is_equivalence_preserving(&self) -> bool {
        self.lagrangian_rule == self.force_rule
    }

    /// Order of the step map: `min(2s, exactness + 1)` over both rules.
    #[must_use]
    pub fn order(&self) -> usize {
        let s = self.path.degree();
        let rule_order = self
            .lagrangian_rule
            .exactness()
            .min(self.force_rule.exactness())
            + 1;
        (2 * s).min(rule_order)
    }

    /// Whether this is the trapezoid rule on the linear path (both rules Lobatto with 2 nodes):
    /// Störmer–Verlet on a separable model, which needs no Newton iteration there.
    #[must_use]
    pub fn is_trapezoid(&self) -> bool {
        self.path.degree() == 1
            && self.lagrangian_rule.kind() == QuadratureKind::Lobatto(2)
            && self.force_rule.kind() == QuadratureKind::Lobatto(2)
    }

    /// Whether the unforced step map is symmetric (self-adjoint): symmetric rules on any path.
    #[must_use]
    pub fn is_symmetric(&self) -> bool {
        true
    }
}

impl fmt::Display for Discretisation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = self.path.degree();
        let named = match (s, self.lagrangian_rule.kind()) {
            (1, QuadratureKind::Gauss(1)) => Some("midpoint".to_string()),
            (1, QuadratureKind::Lobatto(2)) => Some("trapezoid".to_string()),
            (1, QuadratureKind::Lobatto(3)) => Some("simpson".to_string()),
            (s, QuadratureKind::Gauss(n)) if n == s => Some(format!("gauss{s}")),
            (s, QuadratureKind::Lobatto(n)) if n == s + 1 => Some(format!("lobatto{s}")),
            _ => None,
        };
        match (named, self.is_equivalence_preserving()) {
            (Some(name), true) => write!(f, "{name}"),
            _ => write!(
                f,
                "galerkin{s}-{}-{}",
                self.lagrangian_rule, self.force_rule
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orders_and_names() {
        assert_eq!(Discretisation::midpoint().order(), 2);
        assert_eq!(Discretisation::simpson().order(), 2);
        assert_eq!(Discretisation::gauss(3).order(), 6);
        assert_eq!(Discretisation::lobatto(2).order(), 4);
        assert_eq!(
            Discretisation::galerkin(3, QuadratureRule::lobatto(3)).order(),
            4
        );
        assert_eq!(Discretisation::gauss(2).to_string(), "gauss2");
        let mix = Discretisation::non_equivalence_preserving(
            1,
            QuadratureRule::trapezoid(),
            QuadratureRule::midpoint(),
        );
        assert!(!mix.is_equivalence_preserving());
        assert_eq!(mix.to_string(), "galerkin1-trapezoid-midpoint");
    }
}
