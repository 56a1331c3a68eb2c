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
