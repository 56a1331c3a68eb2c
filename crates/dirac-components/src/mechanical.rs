//! One-dimensional mechanical parts: translational (position `x`, port `x`) and rotational
//! (angle `θ`, port `theta`). The same element serves both domains; only the port name differs
//! (force ↔ torque, mass ↔ inertia, `N/m` ↔ `N·m/rad`).
//!
//! Springs, dampers and force sources come in two forms:
//!
//! - as [`CouplingElement`]s between two ports (`Interconnection::coupling`), acting on the
//!   difference `x_a − x_b`: in the monolithic and constraint representations a spring's potential
//!   sits in the Lagrangian, in the interaction-force representation it acts as forces;
//! - as to-ground parts: a one-coordinate subsystem whose coordinate is the element's free end,
//!   tied to a body's port by `Interconnection::joint`; the other end is fixed at the origin.

use dirac_core::{ConstraintKind, Constraints, ForceJacobian, LagrangianHessian, Model, Triplets};
use dirac_graph::{Check, CouplingElement, PartError, Subsystem};
use serde::{Deserialize, Serialize};

use crate::waveform::Waveform;

/// A point mass on a line: `L = ½ m ẋ²`, nothing else. A wall spring or a damper is another part:
/// a [`Spring`] or [`Damper`] coupled to a [`Ground`] (or joined as a to-ground part).
///
/// Port `x` (its position; flow: its velocity).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Mass {
    /// Mass.
    pub m: f64,
}

impl Mass {
    /// A mass `m` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `m` otherwise.
    pub fn new(m: f64) -> Result<Self, PartError> {
        Ok(Self {
            m: Check::new("mass").positive("m", m)?,
        })
    }

    /// This part as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("x", 0)
    }
}

/// A rotor of moment of inertia `J` about a fixed axis: `L = ½ J θ̇²`. A torsional spring or a
/// bearing's friction to the frame is another part ([`Spring`], [`Damper`] to a [`Ground`]).
///
/// Port `theta` (its angle; flow: its angular velocity).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Inertia {
    /// Moment of inertia.
    pub j: f64,
}

impl Inertia {
    /// A rotor of moment of inertia `j` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `j` otherwise.
    pub fn new(j: f64) -> Result<Self, PartError> {
        Ok(Self {
            j: Check::new("inertia").positive("j", j)?,
        })
    }

    /// This part as a subsystem named `name` with port `theta`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("theta", 0)
    }
}

macro_rules! inertial_model {
    ($t:ty, $m:ident, $name:literal) => {
        impl Model for $t {
            fn dim(&self) -> usize {
                1
            }
            fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
                0.5 * self.$m * v[0] * v[0]
            }
            fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
                lq[0] = 0.0;
                lv[0] = self.$m * v[0];
            }
            fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
                h.vv.add(0, 0, self.$m);
            }
            fn is_linear(&self) -> bool {
                true
            }
            fn is_autonomous(&self) -> bool {
                true
            }
            fn coordinate_name(&self, _i: usize) -> String {
                $name.into()
            }
            /// Separable: `M = [m]`, no potential, no force.
            fn separable(&self) -> Option<Triplets> {
                let mut mass = Triplets::new();
                mass.add(0, 0, self.$m);
                Some(mass)
            }
        }
    };
}
inertial_model!(Mass, m, "x");
inertial_model!(Inertia, j, "theta");

/// A spring with a linear and a cubic (Duffing) term, on the extension `d = x_a − x_b − ℓ`:
///
/// ```text
/// V(d) = ½ k d² + ¼ k₃ d⁴,     force on a: −V'(d) = −(k d + k₃ d³).
/// ```
///
/// `k₃ > 0` hardens, `k₃ < 0` softens (then only locally stable). As a [`CouplingElement`] it acts
/// between two ports; as a to-ground part ([`Spring::subsystem`]) its coordinate `x` is the free
/// end and `d = x − ℓ` (the other end at the origin). Rotational springs are the same with angles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Spring {
    /// Linear stiffness `k`.
    pub k: f64,
    /// Cubic stiffness `k₃` (0 for a linear spring).
    #[serde(default, skip_serializing_if = "crate::serde_defaults::is_zero")]
    pub k3: f64,
    /// Rest offset `ℓ`.
    #[serde(default, skip_serializing_if = "crate::serde_defaults::is_zero")]
    pub rest: f64,
}

impl Spring {
    /// A spring `V(d) = ½ k d² + ¼ k₃ d⁴` on `d = x_a − x_b − rest`: `k` non-negative, `k3` and
    /// `rest` finite.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(k: f64, k3: f64, rest: f64) -> Result<Self, PartError> {
        let c = Check::new("spring");
        Ok(Self {
            k: c.non_negative("k", k)?,
            k3: c.finite("k3", k3)?,
            rest: c.finite("rest", rest)?,
        })
    }

    /// A linear spring of stiffness `k` and zero rest offset.
    ///
    /// # Errors
    /// See [`Spring::new`].
    pub fn linear(k: f64) -> Result<Self, PartError> {
        Self::new(k, 0.0, 0.0)
    }

    /// A Duffing spring `k d + k₃ d³` with zero rest offset.
    ///
    /// # Errors
    /// See [`Spring::new`].
    pub fn cubic(k: f64, k3: f64) -> Result<Self, PartError> {
        Self::new(k, k3, 0.0)
    }

    /// The same spring with rest offset `rest` (finite).
    ///
    /// # Errors
    /// See [`Spring::new`].
    pub fn with_rest(self, rest: f64) -> Result<Self, PartError> {
        Self::new(self.k, self.k3, rest)
    }

    /// `V(d)` at extension `d` (rest offset already subtracted).
    #[must_use]
    pub fn energy(&self, d: f64) -> f64 {
        let d2 = d * d;
        0.5 * self.k * d * d + 0.25 * self.k3 * d2 * d2
    }

    /// `V'(d)`, the tension.
    #[must_use]
    pub fn tension(&self, d: f64) -> f64 {
        self.k * d + self.k3 * d * d * d
    }

    /// `V''(d)`, the tangent stiffness.
    #[must_use]
    pub fn stiffness(&self, d: f64) -> f64 {
        self.k + 3.0 * self.k3 * d * d
    }

    /// The spring to ground as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("x", 0)
    }

    /// The torsional spring to ground as a subsystem named `name` with port `theta`.
    pub fn rotational_subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("theta", 0)
    }
}

impl CouplingElement for Spring {
    fn has_potential(&self) -> bool {
        true
    }
    fn potential(&self, xa: f64, xb: f64) -> f64 {
        self.energy(xa - xb - self.rest)
    }
    fn potential_gradient(&self, xa: f64, xb: f64) -> [f64; 2] {
        let g = self.tension(xa - xb - self.rest);
        [g, -g]
    }
    fn potential_hessian(&self, xa: f64, xb: f64) -> [[f64; 2]; 2] {
        let s = self.stiffness(xa - xb - self.rest);
        [[s, -s], [-s, s]]
    }
    fn is_linear(&self) -> bool {
        self.k3 == 0.0
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        if self.k3 == 0.0 {
            format!("spring k = {}", self.k)
        } else {
            format!("spring k = {}, k3 = {}", self.k, self.k3)
        }
    }
}

impl Model for Spring {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], _v: &[f64]) -> f64 {
        -self.energy(q[0] - self.rest)
    }
    fn lagrangian_gradient(&self, q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = -self.tension(q[0] - self.rest);
        lv[0] = 0.0;
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -self.stiffness(q[0] - self.rest));
    }
    fn is_linear(&self) -> bool {
        self.k3 == 0.0
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "x".into()
    }
}

/// A linear viscous damper: force `−c (v_a − v_b)` on port a (and the opposite on b) as a
/// [`CouplingElement`], or `−c ẋ` on its coordinate as a to-ground part.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Damper {
    /// Damping coefficient.
    pub c: f64,
}

impl Damper {
    /// A damper of coefficient `c` (non-negative and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `c` otherwise.
    pub fn new(c: f64) -> Result<Self, PartError> {
        Ok(Self {
            c: Check::new("damper").non_negative("c", c)?,
        })
    }

    /// The damper to ground as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("x", 0)
    }

    /// The rotational damper to ground as a subsystem named `name` with port `theta`.
    pub fn rotational_subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("theta", 0)
    }
}

impl CouplingElement for Damper {
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _x: [f64; 2], v: [f64; 2], _t: f64) -> [f64; 2] {
        let f = -self.c * (v[0] - v[1]);
        [f, -f]
    }
    fn force_jacobian(&self, _x: [f64; 2], _v: [f64; 2], _t: f64) -> [[[f64; 2]; 2]; 2] {
        [[[0.0; 2]; 2], [[-self.c, self.c], [self.c, -self.c]]]
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        format!("damper c = {}", self.c)
    }
}

impl Model for Damper {
    fn dim(&self) -> usize {
        1
    }
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.c * v[0];
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.c);
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "x".into()
    }
}

/// A prescribed force (or torque) `F(t)`.
///
/// As a to-ground part ([`ForceSource::subsystem`]) it pushes the port it is joined to with `+F(t)`
/// in the `+x` (or `+θ`) direction, reacting on the fixed frame. As a [`CouplingElement`] it is an
/// actuator between two ports: `+F(t)` on port a, `−F(t)` on port b (no net force on the pair).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ForceSource {
    /// The force `F(t)`.
    pub waveform: Waveform,
}

impl ForceSource {
    /// A source of waveform `waveform` ([`Waveform::check`]).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the waveform value out of range.
    pub fn new(waveform: Waveform) -> Result<Self, PartError> {
        waveform.check("force_source", "waveform")?;
        Ok(Self { waveform })
    }

    /// A constant force `f` (finite).
    ///
    /// # Errors
    /// See [`ForceSource::new`].
    pub fn constant(f: f64) -> Result<Self, PartError> {
        Self::new(Waveform::Dc(f))
    }

    /// The force source as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("x", 0)
    }

    /// The torque source as a subsystem named `name` with port `theta`.
    pub fn rotational_subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("theta", 0)
    }
}

impl CouplingElement for ForceSource {
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _x: [f64; 2], _v: [f64; 2], t: f64) -> [f64; 2] {
        let f = self.waveform.value(t);
        [f, -f]
    }
    fn force_depends_on_velocity(&self) -> bool {
        false
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.waveform.next_breakpoint(t)
    }
    fn describe(&self) -> String {
        format!("force source {:?}", self.waveform)
    }
}

impl Model for ForceSource {
    fn dim(&self) -> usize {
        1
    }
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], _v: &[f64], t: f64, f: &mut [f64]) {
        f[0] = self.waveform.value(t);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.waveform.next_breakpoint(t)
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "x".into()
    }
}

/// The fixed frame: one massless coordinate pinned at `position` by the holonomic constraint
/// `x − position = 0`.
///
/// **Why a pinned coordinate** (rather than a part with no coordinates): a port must name
/// coordinates to be joined or coupled in every representation (the constraint representation
/// ties a coupling's endpoint to the partner port's coordinate); a pinned coordinate also holds
/// the frame anywhere (not only at 0), its constraint multiplier is the reaction the frame
/// exerts, and the integrator checks at start that the initial position is the pinned one. The
/// row is holonomic, so the frame does not drift by round-off however long the run. Joining a
/// body's port to the ground locks it; a spring or damper coupling from a body to the ground is a
/// spring or damper to the wall.
///
/// Electrical ground needs no part: it is just a node (its KCL row is the redundant one).
///
/// Port `x` ([`Ground::subsystem`]) or `theta` ([`Ground::rotational_subsystem`]). Initial
/// position: `position`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct Ground {
    /// Where the frame is.
    pub position: f64,
}

impl Ground {
    /// The frame at `position` (finite): a wall.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `position` otherwise.
    pub fn at(position: f64) -> Result<Self, PartError> {
        Ok(Self {
            position: Check::new("ground").finite("position", position)?,
        })
    }

    /// The frame at the origin.
    #[must_use]
    pub fn origin() -> Self {
        Self { position: 0.0 }
    }

    /// The fixed frame as a subsystem named `name` with port `x`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(self)
            .with_port("x", 0)
    }

    /// The fixed frame as a subsystem named `name` with port `theta`.
    pub fn rotational_subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(self)
            .with_port("theta", 0)
    }
}

impl Model for Ground {
    fn dim(&self) -> usize {
        1
    }
    zero_lagrangian!();
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, _i: usize) -> String {
        "x".into()
    }
}

impl Constraints for Ground {
    fn count(&self) -> usize {
        1
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::Holonomic
    }
    fn forms(&self, _q: &[f64], out: &mut Triplets) {
        out.add(0, 0, 1.0);
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        out[0] = q[0] - self.position;
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn name(&self, _a: usize) -> String {
        "pinned".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Run, check_constraints, check_model};
    use dirac_core::Discretisation;
    use dirac_graph::{Interconnection, Representation};
    use dirac_sim::IntegratorOptions;

    fn joint(g: &mut Interconnection, a: (&str, &str), b: (&str, &str)) {
        let (pa, pb) = (g.port(a.0, a.1).unwrap(), g.port(b.0, b.1).unwrap());
        g.joint(format!("{}-{}", a.0, b.0), pa, pb);
    }

    fn coupling(
        g: &mut Interconnection,
        a: (&str, &str),
        b: (&str, &str),
        e: impl CouplingElement + 'static,
    ) {
        let (pa, pb) = (g.port(a.0, a.1).unwrap(), g.port(b.0, b.1).unwrap());
        g.coupling(format!("{}-{}", a.0, b.0), pa, pb, e);
    }

    #[test]
    fn hand_written_derivatives() {
        let (q, v) = ([0.3], [-0.8]);
        check_model(&Mass { m: 2.0 }, &q, &v, 0.0);
        check_model(&Inertia { j: 2.0 }, &q, &v, 0.0);
        let spring = Spring {
            k: 2.0,
            k3: 5.0,
            rest: 0.1,
        };
        check_model(&spring, &q, &v, 0.0);
        check_model(&Damper { c: 0.7 }, &q, &v, 0.0);
        check_model(
            &ForceSource::new(Waveform::sin(0.0, 1.0, 1.0)).unwrap(),
            &q,
            &v,
            0.3,
        );
        let ground = Ground { position: 0.3 };
        check_model(&ground, &q, &v, 0.0);
        check_constraints(&ground, &[0.7], &[1.3], &[0.2]);
        // The coupling form: gradient and Hessian of V(x_a, x_b) by differences.
        let (xa, xb, e) = (0.9, -0.4, 1e-6);
        let g = spring.potential_gradient(xa, xb);
        let hs = spring.potential_hessian(xa, xb);
        let dv = (spring.potential(xa + e, xb) - spring.potential(xa - e, xb)) / (2.0 * e);
        assert!((g[0] - dv).abs() < 1e-6 * g[0].abs());
        let dg = (spring.potential_gradient(xa, xb + e)[0]
            - spring.potential_gradient(xa, xb - e)[0])
            / (2.0 * e);
        assert!((hs[0][1] - dg).abs() < 1e-6 * hs[0][1].abs());
    }

    /// Mass on a linear spring and a damper to ground (both as to-ground parts joined to the mass):
    /// with the joint momentum `P = p_m + p_s + p_d` and `E = P²/2m + ½k(x − ℓ)²`, the midpoint
    /// power balance `E_{k+1} − E_k = −h c v̄²` holds to round-off.
    #[test]
    fn spring_damper_power_balance() {
        let (m, k, c, rest, h) = (2.0, 3.0, 0.4, 0.5, 0.05);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m).unwrap().subsystem("M"))
            .unwrap();
        g.add_subsystem(Spring { k, k3: 0.0, rest }.subsystem("S"))
            .unwrap();
        g.add_subsystem(Damper { c }.subsystem("D")).unwrap();
        joint(&mut g, ("M", "x"), ("S", "x"));
        joint(&mut g, ("M", "x"), ("D", "x"));
        let x0 = 1.7;
        let mut run = Run::midpoint(&g, h, &[vec![x0], vec![x0], vec![x0]]);
        let energy = |run: &Run| {
            let p = run.p(0, 0) + run.p(1, 0) + run.p(2, 0);
            let x = run.q(0, 0);
            p * p / (2.0 * m) + 0.5 * k * (x - rest) * (x - rest)
        };
        let e_start = energy(&run);
        let mut worst: f64 = 0.0;
        for _ in 0..1000 {
            let (e0, x) = (energy(&run), run.q(0, 0));
            run.step();
            let vbar = (run.q(0, 0) - x) / h;
            worst = worst.max((energy(&run) - e0 + h * c * vbar * vbar).abs());
            assert_eq!(run.q(1, 0), run.q(0, 0));
        }
        println!("spring-damper power balance: max defect {worst:.2e} (E₀ = {e_start})");
        assert!(worst < 1e-14 * e_start, "{worst:e}");
    }

    /// Mass coupled by a spring (rest ℓ) to a [`Ground`] at `w`: in all three representations
    /// `x_k = w + ℓ + (x₀ − w − ℓ) cos kθ`, `tan(θ/2) = ωh/2`, to round-off, and the frame does not
    /// move.
    #[test]
    fn spring_to_ground_all_representations() {
        let (m, k, w, rest, h, x0) = (0.5, 2.0, -1.0, 0.75, 0.05, 0.5);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m).unwrap().subsystem("M"))
            .unwrap();
        g.add_subsystem(Ground { position: w }.subsystem("G"))
            .unwrap();
        coupling(&mut g, ("M", "x"), ("G", "x"), Spring { k, k3: 0.0, rest });
        let omega = (k / m).sqrt();
        let theta = 2.0 * (omega * h / 2.0).atan();
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let options = IntegratorOptions::new(Discretisation::midpoint(), h);
            let mut run = Run::new(&g, rep, options, &[vec![x0], vec![w]]);
            let mut worst: f64 = 0.0;
            for n in 1..=1000 {
                run.step();
                let exact = w + rest + (x0 - w - rest) * (n as f64 * theta).cos();
                worst = worst.max((run.q(0, 0) - exact).abs());
                assert_eq!(run.q(1, 0), w);
            }
            println!("{rep}: max |x − exact| = {worst:.2e}");
            assert!(worst < 1e-12, "{rep}: {worst:e}");
        }
    }

    /// The same balance with the spring and the damper as coupling elements from the mass to a
    /// [`Ground`] at `w`: `E = p_m²/2m + ½k(x − w − ℓ)²` loses exactly `h c v̄²` per step in the
    /// monolithic, constraint and interaction-force representations (the frame's impulses never
    /// reach `p_m`).
    #[test]
    fn couplings_to_ground_power_balance() {
        let (m, k, c, w, rest, h, x0) = (2.0, 3.0, 0.4, 0.25, 0.5, 0.05, 1.7);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m).unwrap().subsystem("M"))
            .unwrap();
        g.add_subsystem(Ground { position: w }.subsystem("G"))
            .unwrap();
        coupling(&mut g, ("M", "x"), ("G", "x"), Spring { k, k3: 0.0, rest });
        coupling(&mut g, ("M", "x"), ("G", "x"), Damper { c });
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let options = IntegratorOptions::new(Discretisation::midpoint(), h);
            let mut run = Run::new(&g, rep, options, &[vec![x0], vec![w]]);
            let energy = |run: &Run| {
                let d = run.q(0, 0) - w - rest;
                run.p(0, 0).powi(2) / (2.0 * m) + 0.5 * k * d * d
            };
            let e_start = energy(&run);
            let mut worst: f64 = 0.0;
            for _ in 0..1000 {
                let (e0, x) = (energy(&run), run.q(0, 0));
                run.step();
                let vbar = (run.q(0, 0) - x) / h;
                worst = worst.max((energy(&run) - e0 + h * c * vbar * vbar).abs());
            }
            println!("{rep}: couplings to ground, max power-balance defect {worst:.2e}");
            assert!(worst < 1e-14 * e_start, "{rep}: {worst:e}");
        }
    }

    /// Rotor on a torsional spring to a rotational ground: `θ_k = θ₀ cos kθ` exactly.
    #[test]
    fn torsional_oscillator_discrete_phase() {
        let (j, k, h, th0) = (0.2, 5.0, 0.01, 0.3);
        let mut g = Interconnection::new();
        g.add_subsystem(Inertia::new(j).unwrap().subsystem("J"))
            .unwrap();
        g.add_subsystem(Ground::origin().rotational_subsystem("G"))
            .unwrap();
        coupling(
            &mut g,
            ("J", "theta"),
            ("G", "theta"),
            Spring::linear(k).unwrap(),
        );
        let mut run = Run::midpoint(&g, h, &[vec![th0], vec![0.0]]);
        let phase = 2.0 * ((k / j).sqrt() * h / 2.0).atan();
        let mut worst: f64 = 0.0;
        for n in 1..=1000 {
            run.step();
            worst = worst.max((run.q(0, 0) - th0 * (n as f64 * phase).cos()).abs());
        }
        println!("torsional oscillator: max |θ − θ₀ cos kθ| = {worst:.2e}");
        assert!(worst < 1e-13, "{worst:e}");
    }

    /// Two free masses joined by a Duffing spring: the Lagrangian is translation invariant, so the
    /// discrete total momentum is conserved exactly and the centre of mass moves uniformly:
    /// `x_cm,k = x_cm,0 + k h P/(m₁ + m₂)` to round-off.
    #[test]
    fn duffing_coupling_conserves_momentum() {
        let (m1, m2, h) = (1.0, 3.0, 0.02);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m1).unwrap().subsystem("A"))
            .unwrap();
        g.add_subsystem(Mass::new(m2).unwrap().subsystem("B"))
            .unwrap();
        coupling(
            &mut g,
            ("A", "x"),
            ("B", "x"),
            Spring {
                k: 1.0,
                k3: 4.0,
                rest: 1.0,
            },
        );
        let mut sim = dirac_sim::Simulation::new(
            g,
            Representation::Monolithic,
            IntegratorOptions::new(Discretisation::midpoint(), h),
        );
        let (xa, xb, va, vb) = (0.0, 2.0, 0.3, -0.5);
        for (part, x, v) in [("A", xa, va), ("B", xb, vb)] {
            sim.set_position(part, "x", x).unwrap();
            sim.set_velocity(part, "x", v).unwrap();
        }
        let p = m1 * va + m2 * vb;
        let cm0 = (m1 * xa + m2 * xb) / (m1 + m2);
        // Round-off of the momentum update accumulates over the run: a few ulps of the momenta per
        // step, 2000 steps (measured 1.02e-13 at step 1982; an asymmetric spring force off by
        // 1e-9 of itself breaks it by orders of magnitude more).
        let steps = 2000;
        let momentum_tol = steps as f64 * 4.0 * f64::EPSILON * (m1 * va.abs() + m2 * vb.abs());
        let mut worst: f64 = 0.0;
        for n in 1..=steps {
            sim.step().unwrap();
            let (q, mom) = (sim.positions(), sim.momenta());
            let drift = (mom[0] + mom[1] - p).abs();
            assert!(
                drift < momentum_tol,
                "step {n}: total momentum off by {drift:e}"
            );
            let cm = (m1 * q[0] + m2 * q[1]) / (m1 + m2);
            worst = worst.max((cm - cm0 - n as f64 * h * p / (m1 + m2)).abs());
        }
        println!("Duffing pair: max centre-of-mass deviation {worst:.2e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// Damped mass (a damper to ground joined to it) on a Duffing spring to ground under a constant
    /// force: the discrete fixed point
    /// is the static equilibrium `k x + k₃ x³ = F`, whose real root is Cardano's
    /// `x = ∛(F/2k₃ + √D) + ∛(F/2k₃ − √D)`, `D = (F/2k₃)² + (k/3k₃)³`.
    #[test]
    fn duffing_static_equilibrium_under_constant_force() {
        let (m, c, k, k3, f, h) = (1.0, 2.0, 1.0, 3.0, 5.0, 0.05);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m).unwrap().subsystem("M"))
            .unwrap();
        g.add_subsystem(Spring::cubic(k, k3).unwrap().subsystem("S"))
            .unwrap();
        g.add_subsystem(ForceSource::constant(f).unwrap().subsystem("F"))
            .unwrap();
        g.add_subsystem(Damper::new(c).unwrap().subsystem("D"))
            .unwrap();
        joint(&mut g, ("M", "x"), ("S", "x"));
        joint(&mut g, ("M", "x"), ("F", "x"));
        joint(&mut g, ("M", "x"), ("D", "x"));
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0], vec![0.0], vec![0.0]]);
        for _ in 0..3000 {
            run.step();
        }
        let (a, d) = (
            f / (2.0 * k3),
            (f / (2.0 * k3)).powi(2) + (k / (3.0 * k3)).powi(3),
        );
        let exact = (a + d.sqrt()).cbrt() + (a - d.sqrt()).cbrt();
        let x = run.q(0, 0);
        println!(
            "Duffing equilibrium: x = {x}, Cardano {exact}, residual {:.2e}",
            x - exact
        );
        assert!((k * exact + k3 * exact.powi(3) - f).abs() < 1e-12);
        assert!((x - exact).abs() < 1e-12, "{x} vs {exact}");
    }

    /// A constant force switched on at rest on a mass–spring (a spring to ground joined to the
    /// mass): `x_k = (F/k)(1 − cos kθ)` exactly
    /// (a shifted discrete rotation); a constant torque on a free rotor: `θ_k = T(kh)²/2J` exactly
    /// (the midpoint rule integrates quadratics exactly); an actuator between two free masses
    /// leaves the total momentum at zero and separates them by `F t²/2 (1/m₁ + 1/m₂)`.
    #[test]
    fn force_and_torque_sources() {
        let (m, k, f, h) = (2.0, 8.0, 3.0, 0.01);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m).unwrap().subsystem("M"))
            .unwrap();
        g.add_subsystem(ForceSource::constant(f).unwrap().subsystem("F"))
            .unwrap();
        g.add_subsystem(Spring::linear(k).unwrap().subsystem("S"))
            .unwrap();
        joint(&mut g, ("M", "x"), ("F", "x"));
        joint(&mut g, ("M", "x"), ("S", "x"));
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0], vec![0.0]]);
        let theta = 2.0 * ((k / m).sqrt() * h / 2.0).atan();
        let mut worst: f64 = 0.0;
        for n in 1..=1000 {
            run.step();
            worst = worst.max((run.q(0, 0) - f / k * (1.0 - (n as f64 * theta).cos())).abs());
        }
        println!("step force on mass-spring: max deviation {worst:.2e}");
        assert!(worst < 1e-13, "{worst:e}");

        let (j, torque) = (0.5, 2.0);
        let mut g = Interconnection::new();
        g.add_subsystem(Inertia::new(j).unwrap().subsystem("J"))
            .unwrap();
        g.add_subsystem(
            ForceSource::constant(torque)
                .unwrap()
                .rotational_subsystem("T"),
        )
        .unwrap();
        joint(&mut g, ("J", "theta"), ("T", "theta"));
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0]]);
        for n in 1..=1000 {
            run.step();
            let t = n as f64 * h;
            assert!((run.q(0, 0) - torque * t * t / (2.0 * j)).abs() < 1e-12 * (1.0 + t * t));
        }

        let (m1, m2) = (1.0, 4.0);
        let mut g = Interconnection::new();
        g.add_subsystem(Mass::new(m1).unwrap().subsystem("A"))
            .unwrap();
        g.add_subsystem(Mass::new(m2).unwrap().subsystem("B"))
            .unwrap();
        coupling(
            &mut g,
            ("A", "x"),
            ("B", "x"),
            ForceSource::constant(f).unwrap(),
        );
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0]]);
        for n in 1..=1000 {
            run.step();
            let t = n as f64 * h;
            let sep = f * t * t / 2.0 * (1.0 / m1 + 1.0 / m2);
            assert!((run.q(0, 0) - run.q(1, 0) - sep).abs() < 1e-12 * (1.0 + sep));
            assert!((run.p(0, 0) + run.p(1, 0)).abs() < 1e-12);
        }
    }
}
