//! Coupling elements: a potential and/or a force of two port coordinates.

/// An element between two ports `a` and `b`, acting through their coordinates `x_a`, `x_b` and
/// flows `v_a`, `v_b`: a potential `V(x_a, x_b)` and/or a non-potential force `(f_a, f_b)`.
///
/// In the monolithic and constraint representations `V` sits inside the Lagrangian; in the
/// interaction-force representation it acts as the forces `−∂V/∂x_a`, `−∂V/∂x_b`.
pub trait CouplingElement: Send + Sync {
    /// Whether the element has a potential.
    fn has_potential(&self) -> bool {
        false
    }
    /// `V(x_a, x_b)`.
    fn potential(&self, _xa: f64, _xb: f64) -> f64 {
        0.0
    }
    /// `(∂V/∂x_a, ∂V/∂x_b)`.
    fn potential_gradient(&self, _xa: f64, _xb: f64) -> [f64; 2] {
        [0.0; 2]
    }
    /// Hessian of `V` in `(x_a, x_b)`.
    fn potential_hessian(&self, _xa: f64, _xb: f64) -> [[f64; 2]; 2] {
        [[0.0; 2]; 2]
    }
    /// Whether the element has a non-potential force.
    fn has_force(&self) -> bool {
        false
    }
    /// `(f_a, f_b)`.
    fn force(&self, _x: [f64; 2], _v: [f64; 2], _t: f64) -> [f64; 2] {
        [0.0; 2]
    }
    /// Whether the force depends on the flows `v_a`, `v_b` (a damper). Conservative default: any
    /// force does. An element whose force depends on `(x, t)` only keeps a model separable
    /// ([`dirac_core::Model::separable`]).
    fn force_depends_on_velocity(&self) -> bool {
        self.has_force()
    }
    /// `(∂f/∂x, ∂f/∂v)`, each 2×2 with rows `(f_a, f_b)`.
    fn force_jacobian(&self, _x: [f64; 2], _v: [f64; 2], _t: f64) -> [[[f64; 2]; 2]; 2] {
        [[[0.0; 2]; 2]; 2]
    }
    /// True when `V` is quadratic and the force affine.
    fn is_linear(&self) -> bool;
    /// True when the force does not depend on `t`.
    fn is_autonomous(&self) -> bool {
        false
    }
    /// The first time after `t` at which the force stops being smooth in time (see
    /// [`dirac_core::Model::next_breakpoint`]).
    fn next_breakpoint(&self, _t: f64) -> Option<f64> {
        None
    }
    /// A short description for diagnostics.
    fn describe(&self) -> String;
}

/// Linear spring `V = ½k(x_a − x_b − ℓ)²`: a coupling for this crate's tests, which cannot use the
/// parts of `dirac-components` (that crate depends on this one).
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LinearSpring {
    /// Stiffness.
    pub(crate) k: f64,
    /// Rest offset `ℓ`.
    pub(crate) rest: f64,
}

#[cfg(test)]
impl CouplingElement for LinearSpring {
    fn has_potential(&self) -> bool {
        true
    }
    fn potential(&self, xa: f64, xb: f64) -> f64 {
        let d = xa - xb - self.rest;
        0.5 * self.k * d * d
    }
    fn potential_gradient(&self, xa: f64, xb: f64) -> [f64; 2] {
        let g = self.k * (xa - xb - self.rest);
        [g, -g]
    }
    fn potential_hessian(&self, _xa: f64, _xb: f64) -> [[f64; 2]; 2] {
        [[self.k, -self.k], [-self.k, self.k]]
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        format!("spring k = {}", self.k)
    }
}

/// Linear damper `f_a = −c(v_a − v_b) = −f_b`: a coupling for this crate's tests.
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LinearDamper {
    /// Damping coefficient.
    pub(crate) c: f64,
}

#[cfg(test)]
impl CouplingElement for LinearDamper {
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _x: [f64; 2], v: [f64; 2], _t: f64) -> [f64; 2] {
        let f = -self.c * (v[0] - v[1]);
        [f, -f]
    }
    fn force_jacobian(&self, _x: [f64; 2], _v: [f64; 2], _t: f64) -> [[[f64; 2]; 2]; 2] {
        [[[0.0; 2]; 2], [[-self.c, self.c], [self.c, -self.c]]]
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        format!("damper c = {}", self.c)
    }
}

#[cfg(test)]
mod tests {
    //! The stock elements' derivatives against central differences of their potential and force.

    use super::*;

    /// Central differences at δ = 1e-6 of order-one functions: exact for the quadratic spring up
    /// to round-off ε/δ ≈ 2e-10.
    const DIFFERENCES: f64 = 1e-8;

    #[test]
    fn spring_derivatives_match_its_potential() {
        let s = LinearSpring { k: 2.5, rest: 0.3 };
        let (xa, xb, d) = (0.9, -0.4, 1e-6);
        let g = s.potential_gradient(xa, xb);
        let num = [
            (s.potential(xa + d, xb) - s.potential(xa - d, xb)) / (2.0 * d),
            (s.potential(xa, xb + d) - s.potential(xa, xb - d)) / (2.0 * d),
        ];
        // V = ½k(x_a − x_b − ℓ)² = ½·2.5·(1.3 − 0.3)².
        assert!((s.potential(xa, xb) - 1.25).abs() <= 1e-15);
        let h = s.potential_hessian(xa, xb);
        for i in 0..2 {
            assert!((g[i] - num[i]).abs() <= DIFFERENCES, "{g:?} vs {num:?}");
            let shifted = |e: f64| {
                let (a, b) = if i == 0 { (xa + e, xb) } else { (xa, xb + e) };
                s.potential_gradient(a, b)
            };
            let (p, m) = (shifted(d), shifted(-d));
            for r in 0..2 {
                let num = (p[r] - m[r]) / (2.0 * d);
                assert!((h[r][i] - num).abs() <= DIFFERENCES, "{h:?}");
            }
        }
    }

    #[test]
    fn damper_jacobian_matches_its_force() {
        let c = LinearDamper { c: 0.7 };
        let (x, v, d) = ([0.2, -0.1], [1.3, -0.4], 1e-6);
        // f_a = −c(v_a − v_b) = −0.7·1.7.
        assert!((c.force(x, v, 0.0)[0] + 0.7 * 1.7).abs() <= 1e-15);
        let [jq, jv] = c.force_jacobian(x, v, 0.0);
        for i in 0..2 {
            let (mut vp, mut vm) = (v, v);
            vp[i] += d;
            vm[i] -= d;
            let (fp, fm) = (c.force(x, vp, 0.0), c.force(x, vm, 0.0));
            for r in 0..2 {
                assert!((jv[r][i] - (fp[r] - fm[r]) / (2.0 * d)).abs() <= DIFFERENCES);
                assert_eq!(jq[r][i], 0.0);
            }
        }
    }
}
