//! Small models shared by the unit tests.

use dirac_core::{ForceJacobian, LagrangianHessian, Model};

/// Point masses on a line, `L = Σ ½ mᵢvᵢ² − ½ kᵢxᵢ²`; the force is NaN where `x₀ > nan_above`
/// and at the time `nan_at` (to within 1e-12).
pub struct Masses {
    pub m: Vec<f64>,
    pub k: Vec<f64>,
    pub nan_above: f64,
    pub nan_at: f64,
}

impl Masses {
    pub fn new(m: &[f64], k: &[f64]) -> Self {
        Self {
            m: m.to_vec(),
            k: k.to_vec(),
            nan_above: f64::INFINITY,
            nan_at: f64::NAN,
        }
    }
}

impl Model for Masses {
    fn dim(&self) -> usize {
        self.m.len()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        (0..self.dim())
            .map(|i| 0.5 * self.m[i] * v[i] * v[i] - 0.5 * self.k[i] * q[i] * q[i])
            .sum()
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        for i in 0..self.dim() {
            lq[i] = -self.k[i] * q[i];
            lv[i] = self.m[i] * v[i];
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        for i in 0..self.dim() {
            h.qq.add(i, i, -self.k[i]);
            h.vv.add(i, i, self.m[i]);
        }
    }
    fn has_force(&self) -> bool {
        self.nan_above.is_finite() || self.nan_at.is_finite()
    }
    fn force(&self, q: &[f64], _v: &[f64], t: f64, f: &mut [f64]) {
        let poisoned = q[0] > self.nan_above || (t - self.nan_at).abs() < 1e-12;
        f.fill(if poisoned { f64::NAN } else { 0.0 });
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, _j: &mut ForceJacobian) {}
    fn coordinate_name(&self, i: usize) -> String {
        format!("x{i}")
    }
}
