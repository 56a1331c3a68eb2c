//! Two pendulums coupled by a quartic spring: a nonlinear test of derivatives.

use dirac_core::{ForceJacobian, GenericModel, LagrangianHessian, Model};
use num_dual::DualNum;

/// `L = ½(v₁² + v₂²) + g(cos q₁ + cos q₂) − ¼κ(q₁ − q₂)⁴ + ε v₁ v₂ q₁`, `f = −c(v₁, v₂) · (1 + q₁²)`.
///
/// The velocity–position coupling `ε v₁ v₂ q₁` makes `∂²L/∂q∂v` nonzero and the force depends on
/// both `q` and `v`, so every derivative block is exercised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuarticPendulums {
    /// Gravity over length.
    pub g: f64,
    /// Quartic spring constant.
    pub kappa: f64,
    /// Velocity–position coupling.
    pub eps: f64,
    /// Damping.
    pub c: f64,
}

/// The same model written only as generic `L` and `f` (derivatives by `AutoDiff`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuarticPendulumsGeneric(pub QuarticPendulums);

impl Model for QuarticPendulums {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let d = q[0] - q[1];
        0.5 * (v[0] * v[0] + v[1] * v[1]) + self.g * (q[0].cos() + q[1].cos())
            - 0.25 * self.kappa * d.powi(4)
            + self.eps * v[0] * v[1] * q[0]
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let d3 = self.kappa * (q[0] - q[1]).powi(3);
        lq[0] = -self.g * q[0].sin() - d3 + self.eps * v[0] * v[1];
        lq[1] = -self.g * q[1].sin() + d3;
        lv[0] = v[0] + self.eps * v[1] * q[0];
        lv[1] = v[1] + self.eps * v[0] * q[0];
    }
    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        let d2 = 3.0 * self.kappa * (q[0] - q[1]).powi(2);
        h.qq.add(0, 0, -self.g * q[0].cos() - d2);
        h.qq.add(0, 1, d2);
        h.qq.add(1, 0, d2);
        h.qq.add(1, 1, -self.g * q[1].cos() - d2);
        h.qv.add(0, 0, self.eps * v[1]);
        h.qv.add(0, 1, self.eps * v[0]);
        h.vv.add(0, 0, 1.0);
        h.vv.add(0, 1, self.eps * q[0]);
        h.vv.add(1, 0, self.eps * q[0]);
        h.vv.add(1, 1, 1.0);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        let s = 1.0 + q[0] * q[0];
        f[0] = -self.c * v[0] * s;
        f[1] = -self.c * v[1] * s;
    }
    fn force_jacobian(&self, q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
        let s = 1.0 + q[0] * q[0];
        j.q.add(0, 0, -self.c * v[0] * 2.0 * q[0]);
        j.q.add(1, 0, -self.c * v[1] * 2.0 * q[0]);
        j.v.add(0, 0, -self.c * s);
        j.v.add(1, 1, -self.c * s);
    }
}

impl GenericModel<2> for QuarticPendulumsGeneric {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2]) -> D {
        let p = &self.0;
        let d = q[0] - q[1];
        (v[0] * v[0] + v[1] * v[1]) * 0.5 + (q[0].cos() + q[1].cos()) * p.g
            - d.powi(4) * (0.25 * p.kappa)
            + v[0] * v[1] * q[0] * p.eps
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2], _t: f64) -> [D; 2] {
        let s = q[0] * q[0] + 1.0;
        [v[0] * s * (-self.0.c), v[1] * s * (-self.0.c)]
    }
}
