//! Lumped linear circuit elements and independent sources on their branch charge `q`.
//!
//! Sign convention (passive, as in SPICE): the branch current `q̇` flows from the element's `+`
//! terminal through the element to its `−` terminal; the voltage across is `v₊ − v₋`. In a node
//! the element's port enters with sign `−1` at its `+` terminal and `+1` at its `−` terminal (the
//! current leaves the `+` node and arrives at the `−` node). A dissipative or source element acts
//! on its charge with the generalised force `−(v₊ − v₋)`; the network supplies `+(v₊ − v₋)` through
//! the KCL multipliers (the node potentials).

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::{Check, PartError, Subsystem};
use serde::{Deserialize, Serialize};

use crate::waveform::Waveform;
use crate::{flux_branch_force, flux_branch_jacobian};

/// Inductor: `L = ½ L q̇²` (flux linkage `p = L q̇`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Inductor {
    /// Inductance.
    pub l: f64,
}

impl Inductor {
    /// An inductor of inductance `l` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `l` otherwise.
    pub fn new(l: f64) -> Result<Self, PartError> {
        Ok(Self {
            l: Check::new("inductor").positive("l", l)?,
        })
    }
}

/// Resistor: no Lagrangian, force `−R q̇` (degenerate: its charge is fixed by KCL).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Resistor {
    /// Resistance.
    pub r: f64,
}

impl Resistor {
    /// A resistor of resistance `r` (non-negative and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `r` otherwise.
    pub fn new(r: f64) -> Result<Self, PartError> {
        Ok(Self {
            r: Check::new("resistor").non_negative("r", r)?,
        })
    }
}

/// Capacitor: `L = −q²/(2C)` (degenerate: no kinetic term; voltage `q/C`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Capacitor {
    /// Capacitance.
    pub c: f64,
}

impl Capacitor {
    /// A capacitor of capacitance `c` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `c` otherwise.
    pub fn new(c: f64) -> Result<Self, PartError> {
        Ok(Self {
            c: Check::new("capacitor").positive("c", c)?,
        })
    }
}

/// Independent voltage source `V(t)` (SPICE `V n+ n− …`): `v₊ − v₋ = V(t)`, force `−V(t)` on its
/// charge.
///
/// With the passive convention its branch current flows from `+` through the source to `−`, so a
/// source delivering power has a negative branch current (`q̇ < 0`): the current leaves its `+`
/// terminal into the circuit, exactly as SPICE reports `I(V1) < 0` for a supplying source. The
/// force is affine with `t` entering additively, so the model is linear whatever the waveform.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct VoltageSource {
    /// The source voltage `V(t)`.
    pub waveform: Waveform,
}

impl VoltageSource {
    /// A source of waveform `waveform` ([`Waveform::check`]).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the waveform value out of range.
    pub fn new(waveform: Waveform) -> Result<Self, PartError> {
        waveform.check("voltage_source", "waveform")?;
        Ok(Self { waveform })
    }

    /// A DC source of `v` volts.
    ///
    /// # Errors
    /// See [`VoltageSource::new`].
    pub fn dc(v: f64) -> Result<Self, PartError> {
        Self::new(Waveform::Dc(v))
    }
}

macro_rules! one_port {
    ($t:ty) => {
        impl $t {
            /// This part as a subsystem named `name` with port `i` (its branch current `q̇`, from
            /// its `+` to its `−` terminal).
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
    fn lagrangian_gradient_at(
        &self,
        offsets: &[usize],
        _q: &[f64],
        v: &[f64],
        lq: &mut [f64],
        lv: &mut [f64],
    ) {
        for &o in offsets {
            lq[o] = 0.0;
            lv[o] = self.l * v[o];
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.vv.add(0, 0, self.l);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
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
    fn lagrangian_gradient_at(
        &self,
        offsets: &[usize],
        _q: &[f64],
        _v: &[f64],
        lq: &mut [f64],
        lv: &mut [f64],
    ) {
        for &o in offsets {
            lq[o] = 0.0;
            lv[o] = 0.0;
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], _h: &mut LagrangianHessian) {}
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[0];
    }
    fn force_at(&self, offsets: &[usize], _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        for &o in offsets {
            f[o] = -self.r * v[o];
        }
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
    fn lagrangian_gradient_at(
        &self,
        offsets: &[usize],
        q: &[f64],
        _v: &[f64],
        lq: &mut [f64],
        lv: &mut [f64],
    ) {
        for &o in offsets {
            lq[o] = -q[o] / self.c;
            lv[o] = 0.0;
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -1.0 / self.c);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
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
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], _v: &[f64], t: f64, f: &mut [f64]) {
        f[0] = -self.waveform.value(t);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.waveform.next_breakpoint(t)
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "q".into()
    }
}

/// Independent current source `I(t)` (SPICE `I n+ n− …`): the branch current from `+` through the
/// source to `−` is prescribed, `q̇ = I(t)`, so the current `I(t)` leaves the source at its `−`
/// terminal, as in SPICE.
///
/// **Formulation.** Prescribing a flow is a time-dependent constraint `q̇ = I(t)`, which
/// [`dirac_core::Constraints`] cannot express (its one-forms are homogeneous, `ω·v = 0`, and
/// holonomic rows have no `t`). A stiff conductance `−G(q̇ − I)` would only approximate it. Instead
/// the source carries a second coordinate, its flux `φ` (`φ̇ = v₊ − v₋`, the voltage across the
/// source), and no Lagrangian; its forces are
///
/// ```text
/// f_q = −φ̇,          f_φ = I(t) − q̇.
/// ```
///
/// The `φ` equation of motion (degenerate, `p_φ = 0`) is `f_φ = 0`, i.e. `q̇ = I(t)`; the `q` equation
/// says the network's effort on the branch is `φ̇`. The pair does no work beyond `−φ̇ q̇`, the power
/// the source delivers. Discretely, with the midpoint rule and consistent momenta (`p_φ = 0`, as
/// `dirac_sim::Integrator::initialise` sets them), each step satisfies
/// `q_{k+1} − q_k = h I(t_k + h/2)` exactly: the source's charge is the same quadrature of `∫I dt`
/// the discretisation applies to every force, with no multiplier and no penalty. `Δφ/h` is the
/// step's mean voltage across the source. The model is linear (constant Newton matrix).
///
/// Limits: as in any circuit simulator, a loop-free cut set of current sources (two in series, or
/// one in series with nothing else) leaves the circuit without a solution: the Newton matrix is
/// singular. `φ` itself is a gauge (only `φ̇` enters); start it at 0.
///
/// Ports: `i` (coordinate 0, the branch current `q̇`). Coordinate 1 is `φ`.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CurrentSource {
    /// The source current `I(t)`.
    pub waveform: Waveform,
}

impl CurrentSource {
    /// A source of waveform `waveform` ([`Waveform::check`]).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the waveform value out of range.
    pub fn new(waveform: Waveform) -> Result<Self, PartError> {
        waveform.check("current_source", "waveform")?;
        Ok(Self { waveform })
    }

    /// A DC source of `i` amperes.
    ///
    /// # Errors
    /// See [`CurrentSource::new`].
    pub fn dc(i: f64) -> Result<Self, PartError> {
        Self::new(Waveform::Dc(i))
    }

    /// This part as a subsystem named `name` with port `i` (its branch current, from `+` to `−`).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("i", 0)
    }
}

impl Model for CurrentSource {
    fn dim(&self) -> usize {
        2
    }
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        flux_branch_force(v, 0, f);
        f[1] += self.waveform.value(t);
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        flux_branch_jacobian(0, j);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.waveform.next_breakpoint(t)
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q", "phi"][i].into()
    }
}

/// Two magnetically coupled windings (SPICE `K L1 L2 k`) as one part on their two branch charges:
///
/// ```text
/// L = ½ L₁ q̇₁² + M q̇₁ q̇₂ + ½ L₂ q̇₂²,     M = k √(L₁ L₂),
/// ```
///
/// so the flux linkages are `p = [L₁ M; M L₂] q̇` and the stored energy is `½ q̇ᵀ [L₁ M; M L₂] q̇`.
/// Both windings use the passive convention with the dotted terminal as `+` (a current entering
/// both dots adds flux). `|k| < 1` keeps the inductance matrix positive definite; `|k| = 1` (ideal
/// coupling) makes the Lagrangian degenerate and then needs the circuit to fix one current.
///
/// Ports: `i1` (coordinate 0, winding 1's current), `i2` (coordinate 1, winding 2's current).
/// An unconnected winding is a superconducting short (its flux linkage is conserved), not an open
/// circuit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct CoupledInductors {
    /// Self-inductance of winding 1.
    pub l1: f64,
    /// Self-inductance of winding 2.
    pub l2: f64,
    /// Coupling coefficient `k`, `|k| ≤ 1`.
    pub k: f64,
}

impl CoupledInductors {
    /// Windings of self-inductance `l1`, `l2` (positive and finite) with coupling coefficient
    /// `k` in `[−1, 1]`.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(l1: f64, l2: f64, k: f64) -> Result<Self, PartError> {
        let c = Check::new("coupled_inductors");
        if k.is_nan() || k.abs() > 1.0 {
            return Err(c.fail("k", k, "must lie in [-1, 1]"));
        }
        Ok(Self {
            l1: c.positive("l1", l1)?,
            l2: c.positive("l2", l2)?,
            k,
        })
    }

    /// The mutual inductance `M = k √(L₁ L₂)`.
    #[must_use]
    pub fn mutual(&self) -> f64 {
        self.k * (self.l1 * self.l2).sqrt()
    }

    /// The magnetic energy `½ iᵀ L i` at winding currents `i`.
    #[must_use]
    pub fn energy(&self, i: [f64; 2]) -> f64 {
        0.5 * self.l1 * i[0] * i[0] + self.mutual() * i[0] * i[1] + 0.5 * self.l2 * i[1] * i[1]
    }

    /// This part as a subsystem named `name` with ports `i1`, `i2`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i1", 0)
            .with_port("i2", 1)
    }
}

impl Model for CoupledInductors {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        self.energy([v[0], v[1]])
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let m = self.mutual();
        lq.fill(0.0);
        lv[0] = self.l1 * v[0] + m * v[1];
        lv[1] = m * v[0] + self.l2 * v[1];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        let m = self.mutual();
        h.vv.add(0, 0, self.l1);
        h.vv.add(0, 1, m);
        h.vv.add(1, 0, m);
        h.vv.add(1, 1, self.l2);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q1", "q2"][i].into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Run, check_model, node, rel};
    use dirac_graph::Interconnection;

    /// A two-terminal element `part` placed from node `plus` to node `minus`: its port sign in
    /// the `+` node (`plus = true`) or the `−` node.
    fn between(part: &'static str, plus: bool) -> (&'static str, &'static str, f64) {
        (part, "i", if plus { -1.0 } else { 1.0 })
    }

    /// The one-pass evaluation of several instances (`lagrangian_gradient_at`, `force_at`, what
    /// an assembled netlist calls for all elements of equal kind and value) writes exactly what
    /// one call per instance writes, and nothing at the entries between the instances.
    /// Mutation: `self.l * v[o] * 1.001` in `Inductor::lagrangian_gradient_at` (or an offset
    /// shifted by one) fails the bitwise comparison.
    #[test]
    fn one_pass_evaluation_equals_one_call_per_instance() {
        fn check<M: Model>(model: &M) {
            let n = 7;
            let q: Vec<f64> = (0..n).map(|i| 0.37 * i as f64 - 1.1).collect();
            let v: Vec<f64> = (0..n).map(|i| 1.3 - 0.29 * i as f64).collect();
            let offsets = [0, 2, 3, 6];
            let (mut lq, mut lv, mut f) = (vec![9.0; n], vec![9.0; n], vec![9.0; n]);
            model.lagrangian_gradient_at(&offsets, &q, &v, &mut lq, &mut lv);
            model.force_at(&offsets, &q, &v, 0.5, &mut f);
            for i in 0..n {
                let (mut a, mut b, mut c) = ([9.0], [9.0], [9.0]);
                if offsets.contains(&i) {
                    model.lagrangian_gradient(&q[i..=i], &v[i..=i], &mut a, &mut b);
                    model.force(&q[i..=i], &v[i..=i], 0.5, &mut c);
                }
                assert_eq!(
                    (lq[i].to_bits(), lv[i].to_bits(), f[i].to_bits()),
                    (a[0].to_bits(), b[0].to_bits(), c[0].to_bits()),
                    "entry {i}"
                );
            }
        }
        check(&Inductor { l: 0.7 });
        check(&Resistor { r: 3.0 });
        check(&Capacitor { c: 0.2 });
    }

    #[test]
    fn hand_written_derivatives() {
        let (q, v) = ([0.3, -0.7], [1.1, 0.4]);
        check_model(&Inductor { l: 0.7 }, &q[..1], &v[..1], 0.0);
        check_model(&Resistor { r: 3.0 }, &q[..1], &v[..1], 0.0);
        check_model(&Capacitor { c: 0.2 }, &q[..1], &v[..1], 0.0);
        check_model(
            &VoltageSource::new(Waveform::sin(1.0, 2.0, 3.0)).unwrap(),
            &q[..1],
            &v[..1],
            0.1,
        );
        check_model(
            &CurrentSource::new(Waveform::sin(1.0, 2.0, 3.0)).unwrap(),
            &q,
            &v,
            0.1,
        );
        check_model(
            &CoupledInductors {
                l1: 2.0,
                l2: 0.5,
                k: 0.9,
            },
            &q,
            &v,
            0.0,
        );
    }

    /// RC discharge: the midpoint rule on `q̇ = −q/RC` is the rational map
    /// `q_{k+1} = ρ q_k`, `ρ = (1 − h/2RC)/(1 + h/2RC)`, and the Dirac step on the R–C loop
    /// reproduces it to round-off: `q_k = q₀ ρᵏ` (here to 1e-12 relative over 400 steps).
    #[test]
    fn rc_discharge_is_the_midpoint_rational_map() {
        let (r, c, h, q0) = (2.0, 0.5, 0.05, 1.5);
        let mut g = Interconnection::new();
        g.add_subsystem(Capacitor { c }.subsystem("C")).unwrap();
        g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
        node(&mut g, "top", &[between("C", true), between("R", true)]);
        node(&mut g, "gnd", &[between("C", false), between("R", false)]);
        let mut run = Run::midpoint(&g, h, &[vec![q0], vec![0.0]]);
        let a = h / (2.0 * r * c);
        let rho = (1.0 - a) / (1.0 + a);
        let mut worst: f64 = 0.0;
        for k in 1..=400 {
            run.step();
            let exact = q0 * rho.powi(k);
            worst = worst.max((run.q(0, 0) - exact).abs() / q0);
            // The resistor carries the capacitor's current: Δq_R = −Δq_C.
            assert!((run.q(1, 0) + run.q(0, 0) - q0).abs() < 1e-13);
        }
        println!("RC discharge: max |q_C − q₀ρᵏ|/q₀ = {worst:.2e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// LC tank: the midpoint rule rotates each mode by θ per step with `tan(θ/2) = ωh/2`, so from
    /// rest `q_k = q₀ cos(kθ)` exactly (1e-12 over 2000 steps, ~16 periods).
    #[test]
    fn lc_tank_discrete_phase() {
        let (l, c, h, q0) = (0.5, 2.0, 0.05, 1.0);
        let mut g = Interconnection::new();
        g.add_subsystem(Capacitor { c }.subsystem("C")).unwrap();
        g.add_subsystem(Inductor { l }.subsystem("L")).unwrap();
        node(&mut g, "a", &[between("C", true), between("L", true)]);
        node(&mut g, "b", &[between("C", false), between("L", false)]);
        let mut run = Run::midpoint(&g, h, &[vec![q0], vec![0.0]]);
        let omega = 1.0 / (l * c).sqrt();
        let theta = 2.0 * (omega * h / 2.0).atan();
        let mut worst: f64 = 0.0;
        for k in 1..=2000 {
            run.step();
            worst = worst.max((run.q(0, 0) - q0 * (k as f64 * theta).cos()).abs());
        }
        println!("LC tank: max |q_C − q₀cos kθ| = {worst:.2e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// A source across a resistor: each step's current is exactly `V(t_k + h/2)/R` (the midpoint
    /// force node), for every waveform. The resistor's `+` terminal sits on the source's `+`
    /// terminal, so a positive `V` drives a positive resistor current and a negative source
    /// current (SPICE orientation).
    #[test]
    fn voltage_source_waveforms_drive_a_resistor() {
        let waveforms = [
            Waveform::Dc(2.0),
            Waveform::Sin {
                offset: 0.5,
                amplitude: 2.0,
                frequency: 3.0,
                delay: 0.1,
                damping: 0.7,
                phase_deg: 20.0,
            },
            Waveform::pulse(-1.0, 3.0, 0.05, 0.1, 0.2, 0.3, 0.8),
            Waveform::pwl(vec![(0.0, 0.0), (0.3, 2.0), (0.3, -1.0), (0.9, 4.0)]),
        ];
        let (r, h) = (4.0, 0.01);
        for w in waveforms {
            let mut g = Interconnection::new();
            g.add_subsystem(VoltageSource::new(w.clone()).unwrap().subsystem("V"))
                .unwrap();
            g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
            node(&mut g, "a", &[between("V", true), between("R", true)]);
            node(&mut g, "gnd", &[between("V", false), between("R", false)]);
            let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0]]);
            for k in 0..150 {
                let q = run.q(1, 0);
                run.step();
                let i = (run.q(1, 0) - q) / h;
                let exact = w.value((k as f64 + 0.5) * h) / r;
                assert!((i - exact).abs() < 1e-12, "{w:?} step {k}: {i} vs {exact}");
                assert!((run.q(0, 0) + run.q(1, 0)).abs() < 1e-13);
            }
        }
    }

    /// DC source charging a capacitor through a resistor: `q_k = CV + (q₀ − CV) ρᵏ` exactly.
    #[test]
    fn rc_charging_from_dc_source() {
        let (v, r, c, h, q0) = (3.0, 1.0, 2.0, 0.1, -0.5);
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::dc(v).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
        g.add_subsystem(Capacitor { c }.subsystem("C")).unwrap();
        node(&mut g, "a", &[between("V", true), between("R", true)]);
        node(&mut g, "b", &[between("R", false), between("C", true)]);
        node(&mut g, "gnd", &[between("C", false), between("V", false)]);
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0], vec![q0]]);
        let a = h / (2.0 * r * c);
        let rho = (1.0 - a) / (1.0 + a);
        let mut worst: f64 = 0.0;
        for k in 1..=300 {
            run.step();
            let exact = c * v + (q0 - c * v) * rho.powi(k);
            worst = worst.max((run.q(2, 0) - exact).abs());
        }
        println!(
            "RC charging: max |q_C − exact| = {worst:.2e} (CV = {})",
            c * v
        );
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// A SIN current source into a capacitor: `q_C,k = h Σ_{j<k} I(t_j + h/2)`, which for
    /// `I = A sin ωt` sums in closed form to `A h sin²(kωh/2)/sin(ωh/2)`; the voltage across the
    /// source, `Δφ/h`, is exactly `−q̄_C/C` (its `+` terminal is the capacitor's `−`).
    #[test]
    fn current_source_charges_a_capacitor() {
        let (amp, freq, c, h) = (2.0, 1.5, 0.25, 0.01);
        let mut g = Interconnection::new();
        g.add_subsystem(
            CurrentSource::new(Waveform::sin(0.0, amp, freq))
                .unwrap()
                .subsystem("I"),
        )
        .unwrap();
        g.add_subsystem(Capacitor { c }.subsystem("C")).unwrap();
        // The source pushes its current out of its − terminal into node a.
        node(&mut g, "a", &[between("I", false), between("C", true)]);
        node(&mut g, "gnd", &[between("I", true), between("C", false)]);
        let mut run = Run::midpoint(&g, h, &[vec![0.0, 0.0], vec![0.0]]);
        let w = 2.0 * std::f64::consts::PI * freq;
        let (mut worst_q, mut worst_v): (f64, f64) = (0.0, 0.0);
        for k in 1..=1000 {
            let (qc0, phi0) = (run.q(1, 0), run.q(0, 1));
            run.step();
            let exact = amp * h * (k as f64 * w * h / 2.0).sin().powi(2) / (w * h / 2.0).sin();
            worst_q = worst_q.max((run.q(1, 0) - exact).abs());
            let v_source = (run.q(0, 1) - phi0) / h;
            let v_cap = 0.5 * (qc0 + run.q(1, 0)) / c;
            worst_v = worst_v.max((v_source + v_cap).abs());
        }
        println!(
            "current source: max |q_C − exact| = {worst_q:.2e}, max |v_I + v̄_C| = {worst_v:.2e}"
        );
        assert!(
            worst_q < 1e-12 && worst_v < 1e-11,
            "{worst_q:e} {worst_v:e}"
        );
    }

    /// A DC current source into a parallel RC: `C v̇ + v/R = I` under the midpoint rule,
    /// `q_k = IRC + (q₀ − IRC) ρᵏ` exactly.
    #[test]
    fn current_source_into_parallel_rc() {
        let (i, r, c, h) = (0.5, 2.0, 1.5, 0.1);
        let mut g = Interconnection::new();
        g.add_subsystem(CurrentSource::dc(i).unwrap().subsystem("I"))
            .unwrap();
        g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
        g.add_subsystem(Capacitor { c }.subsystem("C")).unwrap();
        node(
            &mut g,
            "a",
            &[between("I", false), between("R", true), between("C", true)],
        );
        node(
            &mut g,
            "gnd",
            &[between("I", true), between("R", false), between("C", false)],
        );
        let mut run = Run::midpoint(&g, h, &[vec![0.0, 0.0], vec![0.0], vec![0.0]]);
        let a = h / (2.0 * r * c);
        let rho = (1.0 - a) / (1.0 + a);
        let mut worst: f64 = 0.0;
        for k in 1..=400 {
            run.step();
            let exact = i * r * c * (1.0 - rho.powi(k));
            worst = worst.max((run.q(2, 0) - exact).abs());
            // The source's charge is exactly k h I.
            assert!((run.q(0, 0) - k as f64 * h * i).abs() < 1e-12);
        }
        println!("current source into RC: max |q_C − exact| = {worst:.2e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// Coupled inductors with the secondary left unconnected (a superconducting short): the
    /// secondary flux `M i₁ + L₂ i₂` is conserved exactly, so the primary sees
    /// `L_eff = L₁(1 − k²)` in series with R and a DC source. The midpoint loop currents are then
    /// `ī_k = V/R + ρᵏ(ī₀ − V/R)` with `ρ = (L_eff − hR/2)/(L_eff + hR/2)`,
    /// `ī₀ = (hV/2)/(L_eff + hR/2)`, and `ī₂ = −(M/L₂) ī₁` — all to round-off.
    #[test]
    fn coupled_inductors_flux_trapping() {
        let k_coupling = 0.8;
        let (v, r, l1, l2, h) = (2.0, 0.5, 1.0, 4.0, 0.02);
        let part = CoupledInductors {
            l1,
            l2,
            k: k_coupling,
        };
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::dc(v).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(Resistor { r }.subsystem("R")).unwrap();
        g.add_subsystem(part.subsystem("K")).unwrap();
        node(&mut g, "a", &[between("V", true), between("R", true)]);
        node(&mut g, "b", &[between("R", false), ("K", "i1", -1.0)]);
        node(&mut g, "gnd", &[("K", "i1", 1.0), between("V", false)]);
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0], vec![0.0, 0.0]]);
        let l_eff = l1 * (1.0 - k_coupling * k_coupling);
        let rho = (l_eff - h * r / 2.0) / (l_eff + h * r / 2.0);
        let i0 = (h * v / 2.0) / (l_eff + h * r / 2.0);
        let m = part.mutual();
        let (mut worst1, mut worst2): (f64, f64) = (0.0, 0.0);
        for k in 0..2000 {
            let (a, b) = (run.q(2, 0), run.q(2, 1));
            run.step();
            let (i1, i2) = ((run.q(2, 0) - a) / h, (run.q(2, 1) - b) / h);
            let exact = v / r + rho.powi(k) * (i0 - v / r);
            worst1 = worst1.max((i1 - exact).abs() / (v / r));
            worst2 = worst2.max((i2 + m / l2 * i1).abs() / (v / r));
        }
        println!("flux trapping: primary current {worst1:.2e}, secondary flux {worst2:.2e}");
        assert!(worst1 < 1e-12 && worst2 < 1e-12, "{worst1:e} {worst2:e}");
        // Steady state: i₁ = V/R, i₂ = −(M/L₂) V/R, energy ½ iᵀLi = ½ L_eff (V/R)².
        let i = [v / r, -m / l2 * v / r];
        assert!(rel(part.energy(i), 0.5 * l_eff * (v / r).powi(2), 1e-300) < 1e-14);
    }

    /// Coupled inductors between a SIN-driven primary loop and a resistive secondary loop:
    /// with loop momenta `P` (constraint impulses cancel) and `E = ½ Pᵀ L⁻¹ P`, the discrete power
    /// balance `E_{k+1} − E_k = h (V(t_k+h/2) ī₁ − R₁ ī₁² − R₂ ī₂²)` holds to round-off.
    #[test]
    fn coupled_inductors_power_balance() {
        let part = CoupledInductors {
            l1: 1.0,
            l2: 0.25,
            k: 0.95,
        };
        let (r1, r2, h) = (0.3, 0.7, 0.01);
        let w = Waveform::sin(0.0, 5.0, 2.0);
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::new(w.clone()).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(Resistor { r: r1 }.subsystem("R1")).unwrap();
        g.add_subsystem(part.subsystem("K")).unwrap();
        g.add_subsystem(Resistor { r: r2 }.subsystem("R2")).unwrap();
        // Primary loop J₁: V(−→+) → R1 (a→b) → winding 1 (b→g1).
        node(&mut g, "a", &[between("V", true), between("R1", true)]);
        node(&mut g, "b", &[between("R1", false), ("K", "i1", -1.0)]);
        node(&mut g, "g1", &[("K", "i1", 1.0), between("V", false)]);
        // Secondary loop J₂: winding 2 (c→g2) → R2 (g2→c).
        node(&mut g, "c", &[("K", "i2", -1.0), between("R2", false)]);
        node(&mut g, "g2", &[("K", "i2", 1.0), between("R2", true)]);
        let q0 = vec![vec![0.0], vec![0.0], vec![0.0, 0.0], vec![0.0]];
        let mut run = Run::midpoint(&g, h, &q0);
        let (l1, l2, m) = (part.l1, part.l2, part.mutual());
        let det = l1 * l2 - m * m;
        let energy = |run: &Run| {
            let p1 = run.p(2, 0) + run.p(1, 0) - run.p(0, 0);
            let p2 = run.p(2, 1) + run.p(3, 0);
            0.5 * (l2 * p1 * p1 - 2.0 * m * p1 * p2 + l1 * p2 * p2) / det
        };
        let (mut worst, mut scale): (f64, f64) = (0.0, 1e-300);
        for k in 0..1000 {
            let (e0, a, b) = (energy(&run), run.q(2, 0), run.q(2, 1));
            run.step();
            let (j1, j2) = ((run.q(2, 0) - a) / h, (run.q(2, 1) - b) / h);
            let vs = w.value((k as f64 + 0.5) * h);
            let work = h * (vs * j1 - r1 * j1 * j1 - r2 * j2 * j2);
            let e1 = energy(&run);
            worst = worst.max((e1 - e0 - work).abs());
            scale = scale.max(e1.abs());
        }
        println!(
            "coupled inductors: max power-balance defect {worst:.2e} (energy scale {scale:.2e})"
        );
        assert!(worst < 1e-13 * scale, "{worst:e} vs {scale:e}");
    }
}
