//! Nonlinear circuit elements: a saturating inductor (the junction diode is in `diode.rs`).

use dirac_core::{LagrangianHessian, Model};
use dirac_graph::Subsystem;
use serde::{Deserialize, Serialize};

/// `ln cosh x` without overflow.
fn ln_cosh(x: f64) -> f64 {
    let a = x.abs();
    a + (-2.0 * a).exp().ln_1p() - std::f64::consts::LN_2
}

/// Saturating inductor: flux linkage
///
/// ```text
/// φ(i) = L_∞ i + (L₀ − L_∞) I_sat tanh(i / I_sat)
/// ```
///
/// (incremental inductance `L₀` at zero current falling to `L_∞` in saturation). The Lagrangian is
/// the magnetic co-energy `L*(i) = ∫₀ⁱ φ = ½ L_∞ i² + (L₀ − L_∞) I_sat² ln cosh(i/I_sat)`, so the
/// momentum is the flux, `p = ∂L*/∂q̇ = φ(q̇)`, and the stored energy is the Legendre transform
///
/// ```text
/// E(i) = i φ(i) − L*(i) = ½ L_∞ i² + (L₀ − L_∞) I_sat (i tanh(i/I_sat) − I_sat ln cosh(i/I_sat)).
/// ```
///
/// `L_∞ > 0` keeps `∂²L/∂q̇²` bounded below (Newton stays well conditioned deep in saturation);
/// with `L_∞ = 0` the flux saturates at `L₀ I_sat` and a DC voltage drives the current to infinity
/// in finite time.
///
/// Port `i` (coordinate 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct SaturatingInductor {
    /// Small-signal inductance `L₀` at zero current.
    pub l0: f64,
    /// Saturated inductance `L_∞` (`0 ≤ L_∞ ≤ L₀`).
    pub l_inf: f64,
    /// Saturation current `I_sat`.
    pub i_sat: f64,
}

impl SaturatingInductor {
    /// The flux linkage `φ(i)`.
    #[must_use]
    pub fn flux(&self, i: f64) -> f64 {
        self.l_inf * i + (self.l0 - self.l_inf) * self.i_sat * (i / self.i_sat).tanh()
    }

    /// The co-energy `L*(i)` (the Lagrangian).
    #[must_use]
    pub fn co_energy(&self, i: f64) -> f64 {
        0.5 * self.l_inf * i * i
            + (self.l0 - self.l_inf) * self.i_sat.powi(2) * ln_cosh(i / self.i_sat)
    }

    /// The stored magnetic energy `E(i) = i φ(i) − L*(i)`.
    #[must_use]
    pub fn energy(&self, i: f64) -> f64 {
        let x = i / self.i_sat;
        0.5 * self.l_inf * i * i
            + (self.l0 - self.l_inf) * self.i_sat * (i * x.tanh() - self.i_sat * ln_cosh(x))
    }

    /// The incremental inductance `dφ/di`.
    #[must_use]
    pub fn incremental_inductance(&self, i: f64) -> f64 {
        let t = (i / self.i_sat).tanh();
        self.l_inf + (self.l0 - self.l_inf) * (1.0 - t * t)
    }

    /// This part as a subsystem named `name` with port `i`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("i", 0)
    }
}

impl Model for SaturatingInductor {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        self.co_energy(v[0])
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lv[0] = self.flux(v[0]);
    }
    fn lagrangian_hessian(&self, _q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        h.vv.add(0, 0, self.incremental_inductance(v[0]));
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::electrical::VoltageSource;
    use crate::testing::{Run, check_model, node, rel};
    use dirac_graph::Interconnection;

    #[test]
    fn hand_written_derivatives() {
        let s = SaturatingInductor {
            l0: 2.0,
            l_inf: 0.1,
            i_sat: 0.5,
        };
        for i in [-3.0, -0.2, 0.0, 0.4, 2.0] {
            check_model(&s, &[0.0], &[i], 0.0);
        }
    }

    /// A DC voltage across a saturating inductor with `L_∞ = 0`: the loop flux grows by exactly
    /// `hV` per step from `hV/2`, so `φ(ī_k) = (k + ½) h V` and
    /// `ī_k = I_sat atanh((k + ½) h V / (L₀ I_sat))` (continuous: `i(t) = I_sat atanh(Vt/L₀I_sat)`),
    /// to round-off up to 90 % of the saturation flux.
    #[test]
    fn saturating_inductor_under_dc_voltage() {
        let s = SaturatingInductor {
            l0: 2.0,
            l_inf: 0.0,
            i_sat: 0.5,
        };
        let (v, h) = (1.0, 0.001);
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::dc(v).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(s.subsystem("L")).unwrap();
        node(&mut g, "a", &[("V", "i", -1.0), ("L", "i", -1.0)]);
        node(&mut g, "gnd", &[("L", "i", 1.0), ("V", "i", 1.0)]);
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0]]);
        let (mut worst_flux, mut worst_i): (f64, f64) = (0.0, 0.0);
        let mut k = 0;
        loop {
            let flux = (k as f64 + 0.5) * h * v;
            let x = flux / (s.l0 * s.i_sat);
            if x > 0.9 {
                break;
            }
            let q = run.q(1, 0);
            run.step();
            let i = (run.q(1, 0) - q) / h;
            worst_flux = worst_flux.max((s.flux(i) - flux).abs() / (s.l0 * s.i_sat));
            worst_i = worst_i.max(rel(i, s.i_sat * x.atanh(), 1e-300));
            k += 1;
        }
        println!(
            "saturating inductor: {k} steps, max flux error {worst_flux:.2e} (of L₀I_sat), max relative current error {worst_i:.2e}"
        );
        // The flux identity is exact up to round-off accumulated over k steps (~k·ε); the current
        // amplifies it by dī/dφ = 1/(L₀(1 − x²)).
        assert!(
            worst_flux < 2e-12 && worst_i < 1e-11,
            "{worst_flux:e} {worst_i:e}"
        );
    }

    /// The energy is the Legendre transform of the co-energy and equals `∫₀ⁱ s dφ(s)` (composite
    /// Simpson, 2·10⁴ panels); small currents see the linear inductor `½ L₀ i²`.
    #[test]
    fn saturating_inductor_energy_closed_form() {
        let s = SaturatingInductor {
            l0: 2.0,
            l_inf: 0.2,
            i_sat: 0.5,
        };
        for i in [-2.0, -0.3, 0.7, 3.0] {
            let legendre = i * s.flux(i) - s.co_energy(i);
            assert!(rel(s.energy(i), legendre, 1e-12) < 1e-13);
            let n = 20_000;
            let hh = i / n as f64;
            let f = |x: f64| x * s.incremental_inductance(x);
            let mut sum = f(0.0) + f(i);
            for j in 1..n {
                sum += f(j as f64 * hh) * if j % 2 == 1 { 4.0 } else { 2.0 };
            }
            let quadrature = sum * hh / 3.0;
            assert!(rel(s.energy(i), quadrature, 1e-12) < 1e-12, "{i}");
        }
        let i = 1e-4;
        assert!(rel(s.energy(i), 0.5 * s.l0 * i * i, 1e-300) < 1e-7);
    }
}
