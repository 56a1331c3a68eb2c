//! One-degree-of-freedom oscillators.

use dirac_core::{ForceJacobian, GenericModel, LagrangianHessian, Model};
use num_dual::DualNum;

/// Damped oscillator `L = ½mv² − ½kq²`, `f = −cv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampedOscillator {
    /// Mass.
    pub m: f64,
    /// Stiffness.
    pub k: f64,
    /// Damping coefficient.
    pub c: f64,
}

impl DampedOscillator {
    /// Exact `(q(t), p(t))` from `(q0, p0)` at `t = 0` (underdamped, `c² < 4km`).
    #[must_use]
    pub fn exact(&self, q0: f64, p0: f64, t: f64) -> (f64, f64) {
        let v0 = p0 / self.m;
        let gamma = self.c / (2.0 * self.m);
        let w0sq = self.k / self.m;
        let wd = (w0sq - gamma * gamma).sqrt();
        let a = q0;
        let b = (v0 + gamma * q0) / wd;
        let (s, c) = (wd * t).sin_cos();
        let e = (-gamma * t).exp();
        let q = e * (a * c + b * s);
        let v = e * ((-gamma * a + b * wd) * c + (-gamma * b - a * wd) * s);
        (q, self.m * v)
    }

    /// Damped period `2π/ω_d`.
    #[must_use]
    pub fn period(&self) -> f64 {
        let gamma = self.c / (2.0 * self.m);
        2.0 * std::f64::consts::PI / (self.k / self.m - gamma * gamma).sqrt()
    }

    /// Energy `p²/2m + kq²/2`.
    #[must_use]
    pub fn energy(&self, q: f64, p: f64) -> f64 {
        0.5 * p * p / self.m + 0.5 * self.k * q * q
    }
}

impl Model for DampedOscillator {
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
    fn is_autonomous(&self) -> bool {
        true
    }
}

/// Unit oscillator with the spring split between potential and force (paper Figure 2):
/// `L = ½v² − (1 − α)½q²`, `f = −αq`. Every `α` has the same equations of motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitOscillator {
    /// Fraction of the spring written as an external force.
    pub alpha: f64,
}

impl Model for SplitOscillator {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * v[0] * v[0] - (1.0 - self.alpha) * 0.5 * q[0] * q[0]
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = -(1.0 - self.alpha) * q[0];
        lv[0] = v[0];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -(1.0 - self.alpha));
        h.vv.add(0, 0, 1.0);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, q: &[f64], _v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.alpha * q[0];
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.q.add(0, 0, -self.alpha);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
}

impl GenericModel<1> for SplitOscillator {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
        v[0] * v[0] * 0.5 - q[0] * q[0] * (0.5 * (1.0 - self.alpha))
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force<D: DualNum<Primitive = f64> + Copy>(
        &self,
        q: &[D; 1],
        _v: &[D; 1],
        _t: f64,
    ) -> [D; 1] {
        [q[0] * (-self.alpha)]
    }
    fn is_linear(&self) -> bool {
        true
    }
}

/// Unit oscillator with an artificial potential `a q⁵` in `L` cancelled by the force `+5a q⁴`
/// (paper Figure 3, `a = 100`): the equations of motion are those of `q̈ = −q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArtificialPotential {
    /// Coefficient of the artificial potential.
    pub a: f64,
}

impl Model for ArtificialPotential {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * v[0] * v[0] - 0.5 * q[0] * q[0] - self.a * q[0].powi(5)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = -q[0] - 5.0 * self.a * q[0].powi(4);
        lv[0] = v[0];
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -1.0 - 20.0 * self.a * q[0].powi(3));
        h.vv.add(0, 0, 1.0);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, q: &[f64], _v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = 5.0 * self.a * q[0].powi(4);
    }
    fn force_jacobian(&self, q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.q.add(0, 0, 20.0 * self.a * q[0].powi(3));
    }
}

impl GenericModel<1> for ArtificialPotential {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
        v[0] * v[0] * 0.5 - q[0] * q[0] * 0.5 - q[0].powi(5) * self.a
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force<D: DualNum<Primitive = f64> + Copy>(
        &self,
        q: &[D; 1],
        _v: &[D; 1],
        _t: f64,
    ) -> [D; 1] {
        [q[0].powi(4) * (5.0 * self.a)]
    }
}

impl GenericModel<1> for DampedOscillator {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
        v[0] * v[0] * (0.5 * self.m) - q[0] * q[0] * (0.5 * self.k)
    }
    fn has_force(&self) -> bool {
        self.c != 0.0
    }
    fn force<D: DualNum<Primitive = f64> + Copy>(
        &self,
        _q: &[D; 1],
        v: &[D; 1],
        _t: f64,
    ) -> [D; 1] {
        [v[0] * (-self.c)]
    }
    fn is_linear(&self) -> bool {
        true
    }
}
