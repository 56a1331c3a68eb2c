//! The seed paper's series RLC loop as one system with KCL one-forms.

use dirac_core::{ForceJacobian, LagrangianHessian, LinearForms, Model};

/// Series RLC loop on `q = (q_C, q_L, q_R)`: `L = ½ L v_L² − q_C²/(2C)`, `f = (0, 0, −R v_R)`.
///
/// The Lagrangian is degenerate (no kinetic term for `q_C` or `q_R`); the loop is closed by the
/// constraint forms of [`RlcLoop::kcl`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlcLoop {
    /// Inductance.
    pub l: f64,
    /// Capacitance.
    pub c: f64,
    /// Resistance.
    pub r: f64,
}

impl RlcLoop {
    /// The seed paper's values `L = 0.75, C = 3, R = 0.1`.
    #[must_use]
    pub fn seed() -> Self {
        Self {
            l: 0.75,
            c: 3.0,
            r: 0.1,
        }
    }

    /// `ω¹ = dq_L − dq_R`, `ω² = dq_R − dq_C` (one loop current).
    #[must_use]
    pub fn kcl() -> LinearForms {
        let mut forms = LinearForms::new(3);
        forms.push("kcl(L,R)", &[(1, 1.0), (2, -1.0)]);
        forms.push("kcl(R,C)", &[(2, 1.0), (0, -1.0)]);
        forms
    }

    /// Stored energy with the loop momentum `P = p_C + p_L + p_R`: `P²/(2L) + q_C²/(2C)`.
    #[must_use]
    pub fn energy(&self, q: &[f64], p: &[f64]) -> f64 {
        let loop_p = p[0] + p[1] + p[2];
        loop_p * loop_p / (2.0 * self.l) + q[0] * q[0] / (2.0 * self.c)
    }
}

impl Model for RlcLoop {
    fn dim(&self) -> usize {
        3
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.l * v[1] * v[1] - q[0] * q[0] / (2.0 * self.c)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.copy_from_slice(&[-q[0] / self.c, 0.0, 0.0]);
        lv.copy_from_slice(&[0.0, self.l * v[1], 0.0]);
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -1.0 / self.c);
        h.vv.add(1, 1, self.l);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f.copy_from_slice(&[0.0, 0.0, -self.r * v[2]]);
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(2, 2, -self.r);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["qC", "qL", "qR"][i].to_string()
    }
}

/// Exact charge of `L q̈ + R q̇ + q/C = 0` with `q(0) = q0`, `q̇(0) = 0` (underdamped).
#[must_use]
pub fn rlc_exact(rlc: &RlcLoop, q0: f64, t: f64) -> f64 {
    let gamma = rlc.r / (2.0 * rlc.l);
    let wd = (1.0 / (rlc.l * rlc.c) - gamma * gamma).sqrt();
    q0 * (-gamma * t).exp() * ((wd * t).cos() + gamma / wd * (wd * t).sin())
}

/// Degenerate LC tank on `q = (q_C, q_L)`: `L = ½ L v_L² − q_C²/(2C)`, one-form `dq_L − dq_C`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LcTank {
    /// Inductance.
    pub l: f64,
    /// Capacitance.
    pub c: f64,
}

impl LcTank {
    /// The loop constraint `dq_L − dq_C`.
    #[must_use]
    pub fn kcl() -> LinearForms {
        let mut forms = LinearForms::new(2);
        forms.push("kcl(L,C)", &[(1, 1.0), (0, -1.0)]);
        forms
    }

    /// Energy with the loop momentum `P = p_C + p_L`.
    #[must_use]
    pub fn energy(&self, q: &[f64], p: &[f64]) -> f64 {
        let loop_p = p[0] + p[1];
        loop_p * loop_p / (2.0 * self.l) + q[0] * q[0] / (2.0 * self.c)
    }
}

impl Model for LcTank {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.l * v[1] * v[1] - q[0] * q[0] / (2.0 * self.c)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.copy_from_slice(&[-q[0] / self.c, 0.0]);
        lv.copy_from_slice(&[0.0, self.l * v[1]]);
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -1.0 / self.c);
        h.vv.add(1, 1, self.l);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["qC", "qL"][i].to_string()
    }
}

/// One section of an RLC ladder on `q = (q_s, q_c)`: a series resistor and inductor carrying the
/// branch charge `q_s`, and a shunt capacitor to ground with charge `q_c`.
/// `L = ½ L v_s² − q_c²/(2C)`, `f = (−R v_s, 0)`. Ports: `series` (`q_s`) and `shunt` (`q_c`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LadderSection {
    /// Series resistance.
    pub r: f64,
    /// Series inductance.
    pub l: f64,
    /// Shunt capacitance.
    pub c: f64,
}

impl Model for LadderSection {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.l * v[0] * v[0] - q[1] * q[1] / (2.0 * self.c)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lq[1] = -q[1] / self.c;
        lv[0] = self.l * v[0];
        lv[1] = 0.0;
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(1, 1, -1.0 / self.c);
        h.vv.add(0, 0, self.l);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[0];
        f[1] = 0.0;
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.r);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["qs", "qc"][i].to_string()
    }
}
