//! Nonlinear circuit elements: a junction diode and a saturating inductor.

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::Subsystem;
use serde::{Deserialize, Serialize};

/// `ln(e − 1)`: the curve parameter of the diode at zero current.
const X0: f64 = 0.541_324_854_612_918_1;

/// Below this argument `ln(1 + eˣ) = eˣ(1 − eˣ/2 + …)` is evaluated by its expansion.
const SMALL: f64 = -36.0;

/// `ln(1 + eˣ)` without overflow.
fn softplus(x: f64) -> f64 {
    if x > 0.0 {
        x + (-x).exp().ln_1p()
    } else {
        x.exp().ln_1p()
    }
}

/// `1/(1 + e⁻ˣ)` without overflow.
fn logistic(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

/// `ln(ln(1 + eˣ))`, accurate for very negative `x` (where it is `x − eˣ/2` to double precision).
fn ln_softplus(x: f64) -> f64 {
    if x < SMALL {
        x - 0.5 * x.exp()
    } else {
        softplus(x).ln()
    }
}

/// `logistic(x)/softplus(x)`, the derivative of [`ln_softplus`].
fn ln_softplus_slope(x: f64) -> f64 {
    if x < SMALL {
        1.0 - 0.5 * x.exp()
    } else {
        logistic(x) / softplus(x)
    }
}

/// Junction diode (Shockley law with series resistance):
///
/// ```text
/// i = I_s (exp(v_j / (n V_t)) − 1),       v₊ − v₋ = v_j + R_s i.
/// ```
///
/// **Formulation.** Writing the diode as a current-controlled force `−v(q̇)` needs the inverse
/// `v_j = nV_t ln(1 + i/I_s)`, undefined for `i ≤ −I_s` (a Newton iterate in reverse bias leaves the
/// domain); as a voltage-controlled branch `i = I_s(e^{v/nV_t} − 1)`, a Newton iterate from rest
/// overshoots into `e^{200}` and crawls back by `nV_t` per iteration. Both are poor for the step's
/// plain Newton method. This part instead parametrises the characteristic curve by the rate `w` of
/// an internal coordinate `u`, with `x = w/I_s + ln(e − 1)` and `s(x) = ln(1 + eˣ)` (softplus):
///
/// ```text
/// i(w)   = I_s (s(x) − 1),           v_j(w) = n V_t ln s(x).
/// ```
///
/// Since `e^{v_j/nV_t} = s(x) = 1 + i/I_s`, every `w` is a point of the exact Shockley curve and
/// every point of the curve is reached once (`s` maps ℝ onto (0, ∞)); `w = 0` is the origin
/// `i = v_j = 0`. Both functions grow at most linearly in `w` (`i ≈ w` in forward bias,
/// `v_j ≈ nV_t·w/I_s` in reverse), so Newton neither overflows nor leaves a domain, and their
/// derivatives are exact and smooth everywhere. The part has coordinates `(q, u)`, no Lagrangian
/// and the forces
///
/// ```text
/// f_q = −v_j(u̇) − R_s q̇,     f_u = i(u̇) − q̇.
/// ```
///
/// The degenerate `u` equation (`p_u = 0`) is `f_u = 0`, i.e. `q̇ = i(u̇)`; the `q` equation makes
/// the terminal voltage `v_j + R_s i`. The forces do work `−(v_j + R_s i) i ≤ 0`: the diode
/// dissipates. With the midpoint rule each step satisfies the Shockley law exactly at the
/// step's mean rates.
///
/// Ports: `i` (coordinate 0: the current from anode `+` to cathode `−`). Coordinate 1 is `u`
/// (only its rate means anything; start it at 0).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct Diode {
    /// Saturation current `I_s` (A), e.g. `1e-14`.
    pub is: f64,
    /// Emission coefficient `n` (1–2).
    pub n: f64,
    /// Thermal voltage `V_t = kT/q` (V), 0.025852 at 300 K.
    pub vt: f64,
    /// Series resistance `R_s` (Ω).
    pub rs: f64,
}

impl Diode {
    /// The thermal voltage `kT/q` at 300 K, in volts.
    pub const VT_300K: f64 = 0.025_851_999_786;

    /// The Shockley current at junction voltage `v`.
    #[must_use]
    pub fn shockley(&self, v: f64) -> f64 {
        self.is * (v / (self.n * self.vt)).exp_m1()
    }

    /// The current `i(w)` at curve rate `w`.
    #[must_use]
    pub fn current(&self, w: f64) -> f64 {
        self.is * (softplus(w / self.is + X0) - 1.0)
    }

    /// The junction voltage `v_j(w)` at curve rate `w`.
    #[must_use]
    pub fn junction_voltage(&self, w: f64) -> f64 {
        self.n * self.vt * ln_softplus(w / self.is + X0)
    }

    /// This part as a subsystem named `name` with port `i` (anode `+` to cathode `−`).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("i", 0)
    }
}

impl Model for Diode {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, _q: &[f64], _v: &[f64]) -> f64 {
        0.0
    }
    fn lagrangian_gradient(&self, _q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.fill(0.0);
        lv.fill(0.0);
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], _h: &mut LagrangianHessian) {}
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.junction_voltage(v[1]) - self.rs * v[0];
        f[1] = self.current(v[1]) - v[0];
    }
    fn force_jacobian(&self, _q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
        let x = v[1] / self.is + X0;
        j.v.add(0, 0, -self.rs);
        j.v.add(0, 1, -self.n * self.vt / self.is * ln_softplus_slope(x));
        j.v.add(1, 0, -1.0);
        j.v.add(1, 1, logistic(x));
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q", "u"][i].into()
    }
}

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
    use crate::electrical::{Inductor, Resistor, VoltageSource};
    use crate::testing::{Run, check_model, node, rel};
    use dirac_graph::Interconnection;

    #[test]
    fn curve_functions() {
        assert!((softplus(X0) - 1.0).abs() < 1e-15);
        for x in [
            -800.0, -300.0, -40.0, -36.0, -35.9, -3.0, 0.0, 2.0, 50.0, 1e12,
        ] {
            assert!(softplus(x).is_finite() && ln_softplus(x).is_finite());
            assert!(ln_softplus_slope(x) > 0.0 && ln_softplus_slope(x) <= 1.0);
        }
        // The expansion branch joins the direct formula.
        let x = SMALL - 1e-3;
        let (a, b) = (ln_softplus(x), softplus(x).ln());
        assert!((a - b).abs() < 1e-15 * a.abs(), "{a} vs {b}");
        let (a, b) = (ln_softplus_slope(x), logistic(x) / softplus(x));
        assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        // Every curve point satisfies Shockley's law exactly.
        let d = Diode {
            is: 1e-12,
            n: 1.5,
            vt: Diode::VT_300K,
            rs: 0.0,
        };
        for w in [-1e-9, -1e-12, 0.0, 1e-13, 1e-3, 2.0] {
            let (i, v) = (d.current(w), d.junction_voltage(w));
            assert!(
                rel(d.shockley(v), i, 1e-30) < 1e-11,
                "w = {w}: {i} vs {}",
                d.shockley(v)
            );
        }
        assert_eq!(d.current(0.0), 0.0);
        assert!(d.junction_voltage(0.0).abs() < 1e-17);
    }

    #[test]
    fn hand_written_derivatives() {
        let d = Diode {
            is: 1e-3,
            n: 1.2,
            vt: Diode::VT_300K,
            rs: 0.5,
        };
        for w in [-0.05, -1e-3, 0.0, 2e-3, 0.4] {
            check_model(&d, &[0.1, 0.2], &[0.3, w], 0.0);
        }
        let s = SaturatingInductor {
            l0: 2.0,
            l_inf: 0.1,
            i_sat: 0.5,
        };
        for i in [-3.0, -0.2, 0.0, 0.4, 2.0] {
            check_model(&s, &[0.0], &[i], 0.0);
        }
    }

    /// DC operating point of `V — R — diode`, solved independently: `V = v + R·I_s(e^{v/nV_t} − 1)`
    /// for the junction voltage `v` by bisection (monotone, bracketed by 0 and V).
    fn dc_solution(d: &Diode, v_source: f64, r: f64) -> f64 {
        let (mut lo, mut hi) = (v_source.min(0.0), v_source.max(0.0));
        let residual = |v: f64| v_source - v - (r + d.rs) * d.shockley(v);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if residual(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        d.shockley(0.5 * (lo + hi))
    }

    fn diode_loop(d: Diode, v: f64, r: f64, inductor: Option<f64>) -> Interconnection {
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::dc(v).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
        g.add_subsystem(d.subsystem("D")).unwrap();
        node(&mut g, "a", &[("V", "i", -1.0), ("R", "i", -1.0)]);
        match inductor {
            None => node(&mut g, "b", &[("R", "i", 1.0), ("D", "i", -1.0)]),
            Some(l) => {
                g.add_subsystem(Inductor { l }.subsystem("L")).unwrap();
                node(&mut g, "b", &[("R", "i", 1.0), ("L", "i", -1.0)]);
                node(&mut g, "c", &[("L", "i", 1.0), ("D", "i", -1.0)]);
            }
        }
        node(&mut g, "gnd", &[("D", "i", 1.0), ("V", "i", 1.0)]);
        g
    }

    /// Source–resistor–diode loop, forward and reverse biased, from a cold start (zero current):
    /// every step's current equals the bisection DC solution (the loop is algebraic).
    #[test]
    fn dc_loop_matches_bisection() {
        let d = Diode {
            is: 1e-12,
            n: 1.5,
            vt: Diode::VT_300K,
            rs: 0.5,
        };
        let r = 10.0;
        // Newton stops on absolute residuals, so the current is accurate relative to the loop's
        // current scale V/R (not to a reverse current of ~I_s).
        for v in [5.0, 0.3, -5.0] {
            let exact = dc_solution(&d, v, r);
            let g = diode_loop(d, v, r, None);
            let mut run = Run::midpoint(&g, 1.0, &[vec![0.0], vec![0.0], vec![0.0, 0.0]]);
            let mut worst: f64 = 0.0;
            for _ in 0..5 {
                let q = run.q(2, 0);
                run.step();
                worst = worst.max(rel((run.q(2, 0) - q) / 1.0, exact, v.abs() / r));
            }
            println!(
                "diode DC V = {v}: I = {exact:.6e} A, max deviation/(V/R) {worst:.2e}, Newton iterations {}",
                run.sim.summary().newton_iterations
            );
            assert!(worst < 1e-12, "V = {v}: {worst:e}");
        }
    }

    /// The same loop with a series inductor, stepped from rest: the transient settles on the same
    /// DC solution (the discrete fixed point is exactly the DC equation).
    #[test]
    fn rl_diode_transient_settles_on_dc_solution() {
        let d = Diode {
            is: 1e-12,
            n: 1.5,
            vt: Diode::VT_300K,
            rs: 0.5,
        };
        let (v, r, l, h) = (5.0, 10.0, 1.0, 0.01);
        let exact = dc_solution(&d, v, r);
        let g = diode_loop(d, v, r, Some(l));
        let q0 = vec![vec![0.0], vec![0.0], vec![0.0, 0.0], vec![0.0]];
        let mut run = Run::midpoint(&g, h, &q0);
        let mut i = 0.0;
        for _ in 0..3000 {
            let q = run.q(2, 0);
            run.step();
            i = (run.q(2, 0) - q) / h;
        }
        println!("RL-diode steady state {i:.15e} vs DC {exact:.15e}");
        assert!(rel(i, exact, 1e-300) < 1e-12, "{i} vs {exact}");
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
