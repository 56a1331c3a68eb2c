//! Translational mechanical parts.

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::Subsystem;

/// A point mass on a line, optionally tied to a wall by a spring and a damper:
/// `L = ½ m ẋ² − ½ k x²`, `f = −c ẋ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mass {
    /// Mass.
    pub m: f64,
    /// Wall spring stiffness (0 for none).
    pub k: f64,
    /// Wall damper coefficient (0 for none).
    pub c: f64,
}

impl Mass {
    /// This part as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("x", 0)
    }
}

impl Model for Mass {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.m * v[0] * v[0] - 0.5 * self.k * q[0] * q[0]
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = -self.k * q[0];
        lv[0] = self.m * v[0];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -self.k);
        h.vv.add(0, 0, self.m);
    }
    fn has_force(&self) -> bool {
        self.c != 0.0
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.c * v[0];
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.c);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "x".into()
    }
}
