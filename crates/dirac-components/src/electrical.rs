//! Lumped circuit elements on their branch charge `q` (current `q̇`).

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::Subsystem;

/// Inductor: `L = ½ L q̇²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inductor {
    /// Inductance.
    pub l: f64,
}

/// Resistor: no Lagrangian, force `−R q̇` (degenerate: its charge is fixed by KCL).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resistor {
    /// Resistance.
    pub r: f64,
}

/// Capacitor: `L = −q²/(2C)` (degenerate: no kinetic term).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capacitor {
    /// Capacitance.
    pub c: f64,
}

/// Ideal DC voltage source in a branch: force `+V` on its charge (it does work `V q̇`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoltageSource {
    /// Source voltage.
    pub v: f64,
}

macro_rules! one_port {
    ($t:ty) => {
        impl $t {
            /// This part as a subsystem named `name` with port `i` (its branch current).
            pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
                Subsystem::new(name, self).with_port("i", 0)
            }
        }
    };
}
one_port!(Inductor);
one_port!(Resistor);
one_port!(Capacitor);
one_port!(VoltageSource);

impl Model for Inductor {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.l * v[0] * v[0]
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lv[0] = self.l * v[0];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.vv.add(0, 0, self.l);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}

impl Model for Resistor {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, _q: &[f64], _v: &[f64]) -> f64 {
        0.0
    }
    fn lagrangian_gradient(&self, _q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lv[0] = 0.0;
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], _h: &mut LagrangianHessian) {}
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[0];
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.r);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}

impl Model for Capacitor {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], _v: &[f64]) -> f64 {
        -q[0] * q[0] / (2.0 * self.c)
    }
    fn lagrangian_gradient(&self, q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = -q[0] / self.c;
        lv[0] = 0.0;
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -1.0 / self.c);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}

impl Model for VoltageSource {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, _q: &[f64], _v: &[f64]) -> f64 {
        0.0
    }
    fn lagrangian_gradient(&self, _q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lv[0] = 0.0;
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], _h: &mut LagrangianHessian) {}
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], _v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = self.v;
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}
