//! Quadrature rules on the unit interval `[0, 1]`.

use std::f64::consts::PI;
use std::fmt;

/// Family of a [`QuadratureRule`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QuadratureKind {
    /// Gauss–Legendre with `n` interior nodes (exact to degree `2n − 1`); `n = 1` is the midpoint rule.
    Gauss(usize),
    /// Gauss–Lobatto with `n ≥ 2` nodes including both ends (exact to degree `2n − 3`); `n = 2` is the
    /// trapezoid rule, `n = 3` Simpson's rule.
    Lobatto(usize),
}

/// Nodes `cᵢ ∈ [0, 1]` and weights `bᵢ` (summing to one) of a quadrature rule.
///
/// A discretisation evaluates `L_d = h Σ bᵢ L(qⁱ, vⁱ)` and `f_d^± = h Σ bᵢ f(qⁱ, vⁱ)·∂qⁱ/∂q_{1,0}` on the
/// same nodes and weights, which is what makes it equivalence-preserving.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureRule {
    kind: QuadratureKind,
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl QuadratureRule {
    /// The midpoint rule (Gauss, one node).
    #[must_use]
    pub fn midpoint() -> Self {
        Self::gauss(1)
    }

    /// The trapezoid rule (Lobatto, two nodes).
    #[must_use]
    pub fn trapezoid() -> Self {
        Self::lobatto(2)
    }

    /// Simpson's rule (Lobatto, three nodes).
    #[must_use]
    pub fn simpson() -> Self {
        Self::lobatto(3)
    }

    /// Gauss–Legendre with `n ≥ 1` nodes.
    ///
    /// # Panics
    /// If `n == 0`.
    #[must_use]
    pub fn gauss(n: usize) -> Self {
        assert!(n >= 1, "Gauss quadrature needs at least one node");
        let mut nodes = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        for i in 0..n {
            // Newton on P_n from the Chebyshev-like initial guess; converges in a few steps.
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, dp) = legendre(n, x);
            nodes.push(0.5 * (1.0 - x));
            weights.push(1.0 / ((1.0 - x * x) * dp * dp));
        }
        Self::sorted(QuadratureKind::Gauss(n), nodes, weights)
    }

    /// Gauss–Lobatto with `n ≥ 2` nodes (both ends included).
    ///
    /// # Panics
    /// If `n < 2`.
    #[must_use]
    pub fn lobatto(n: usize) -> Self {
        assert!(n >= 2, "Lobatto quadrature needs at least two nodes");
        let deg = n - 1;
        let mut nodes = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        for i in 0..n {
            // Interior nodes are roots of P'_{n−1}; iterate x ← x − (x P_N − P_{N−1})/(n P_N)
            // from the Chebyshev–Gauss–Lobatto points (ends stay fixed).
            let mut x = (PI * i as f64 / deg as f64).cos();
            if i != 0 && i != deg {
                for _ in 0..100 {
                    let (p, _) = legendre(deg, x);
                    let (pm, _) = legendre(deg - 1, x);
                    let dx = (x * p - pm) / (n as f64 * p);
                    x -= dx;
                    if dx.abs() < 1e-16 {
                        break;
                    }
                }
            }
            let (p, _) = legendre(deg, x);
            nodes.push(0.5 * (1.0 - x));
            weights.push(1.0 / (deg as f64 * n as f64 * p * p));
        }
        Self::sorted(QuadratureKind::Lobatto(n), nodes, weights)
    }

    fn sorted(kind: QuadratureKind, mut nodes: Vec<f64>, mut weights: Vec<f64>) -> Self {
        // Insertion sort of the pairs by node, in place (a handful of nodes).
        for i in 1..nodes.len() {
            let mut j = i;
            while j > 0 && nodes[j - 1].total_cmp(&nodes[j]).is_gt() {
                nodes.swap(j - 1, j);
                weights.swap(j - 1, j);
                j -= 1;
            }
        }
        // Pin symmetric nodes exactly (c and 1 − c), and the ends, to keep symmetric rules symmetric.
        let n = nodes.len();
        for i in 0..n / 2 {
            let c = 0.5 * (nodes[i] + 1.0 - nodes[n - 1 - i]);
            nodes[i] = c;
            nodes[n - 1 - i] = 1.0 - c;
        }
        if n % 2 == 1 {
            nodes[n / 2] = 0.5;
        }
        Self {
            kind,
            nodes,
            weights,
        }
    }

    /// The family and node count.
    #[must_use]
    pub fn kind(&self) -> QuadratureKind {
        self.kind
    }

    /// Nodes in `[0, 1]`, increasing.
    #[must_use]
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// Weights, summing to one.
    #[must_use]
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Highest polynomial degree integrated exactly.
    #[must_use]
    pub fn exactness(&self) -> usize {
        match self.kind {
            QuadratureKind::Gauss(n) => 2 * n - 1,
            QuadratureKind::Lobatto(n) => 2 * n - 3,
        }
    }
}

impl fmt::Display for QuadratureRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            QuadratureKind::Gauss(1) => write!(f, "midpoint"),
            QuadratureKind::Lobatto(2) => write!(f, "trapezoid"),
            QuadratureKind::Lobatto(3) => write!(f, "simpson"),
            QuadratureKind::Gauss(n) => write!(f, "gauss{n}"),
            QuadratureKind::Lobatto(n) => write!(f, "lobatto{n}"),
        }
    }
}

/// Legendre polynomial `P_n(x)` and its derivative, by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    if n == 0 {
        return (1.0, 0.0);
    }
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    let dp = if (1.0 - x * x).abs() < 1e-300 {
        // At the ends: P_n'(±1) = (±1)^{n−1} n(n+1)/2.
        let s = if x > 0.0 || n % 2 == 1 { 1.0 } else { -1.0 };
        s * (n * (n + 1)) as f64 / 2.0
    } else {
        n as f64 * (x * p1 - p0) / (x * x - 1.0)
    };
    (p1, dp)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each rule integrates monomials up to its exactness degree exactly and misses the next one.
    #[test]
    fn exactness_degrees() {
        let rules: Vec<QuadratureRule> = (1..=6)
            .map(QuadratureRule::gauss)
            .chain((2..=6).map(QuadratureRule::lobatto))
            .collect();
        for rule in rules {
            let integrate = |d: i32| -> f64 {
                rule.nodes()
                    .iter()
                    .zip(rule.weights())
                    .map(|(c, b)| b * c.powi(d))
                    .sum()
            };
            let e = rule.exactness() as i32;
            for d in 0..=e {
                let err = (integrate(d) - 1.0 / f64::from(d + 1)).abs();
                assert!(err < 1e-14, "{rule}: degree {d} error {err}");
            }
            let err = (integrate(e + 1) - 1.0 / f64::from(e + 2)).abs();
            assert!(err > 1e-8, "{rule}: degree {} should not be exact", e + 1);
        }
    }

    #[test]
    fn classic_rules() {
        assert_eq!(QuadratureRule::midpoint().nodes(), &[0.5]);
        assert_eq!(QuadratureRule::trapezoid().nodes(), &[0.0, 1.0]);
        let s = QuadratureRule::simpson();
        assert_eq!(s.nodes(), &[0.0, 0.5, 1.0]);
        for (w, e) in s.weights().iter().zip([1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0]) {
            assert!((w - e).abs() < 1e-15);
        }
    }
}
