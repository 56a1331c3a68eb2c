//! Energy-converting two-port parts: a DC motor (gyrator), an ideal transformer and an ideal gear.

use dirac_core::{ConstraintKind, Constraints, ForceJacobian, LagrangianHessian, Model, Triplets};
use dirac_graph::{Check, PartError, Subsystem};
use serde::{Deserialize, Serialize};

/// Permanent-magnet DC motor: armature (resistance `R`, inductance `L`) on charge `q`, rotor
/// (inertia `J`, viscous friction `b`) on angle `θ`, coupled by one motor constant `k`:
///
/// ```text
/// L = ½ L q̇² + ½ J θ̇²,
/// f_q = −R q̇ − k θ̇        (back-EMF k·ω opposes the armature current),
/// f_θ =  k q̇ − b θ̇        (torque k·i drives the shaft).
/// ```
///
/// The coupling is a gyrator: the pair `(−k θ̇, +k q̇)` is a non-potential force that does no
/// work, `f_q q̇ + f_θ θ̇ = 0` for the gyrator terms, at every `(q̇, θ̇)`. It cannot be a term of
/// the Lagrangian (`k θ q̇` would give torque `k i` but a back-EMF of the wrong sign). Because the
/// midpoint force rule evaluates both halves at the same mean rates `(ī, ω̄)`, the discrete work of
/// the gyrator, `h(−k ω̄ ī + k ī ω̄)`, is zero too: the discrete power balance of a motor circuit
/// contains only the sources, `R` and `b`. Terminal voltage (passive, `+` to `−`):
/// `v = R i + L di/dt + k ω`; with a positive voltage the shaft turns in `+θ`.
///
/// `L` or `J` may be zero when the circuit or the load supplies the dynamics (the coordinate is
/// then degenerate). Ports: `i` (coordinate 0, armature current), `theta` (coordinate 1, shaft).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct DcMotor {
    /// Motor constant `k` (V·s/rad = N·m/A).
    pub k: f64,
    /// Armature resistance.
    pub r: f64,
    /// Armature inductance.
    pub l: f64,
    /// Rotor inertia.
    pub j: f64,
    /// Viscous friction.
    #[serde(default, skip_serializing_if = "crate::serde_defaults::is_zero")]
    pub b: f64,
}

impl DcMotor {
    /// A motor of constant `k` (finite) with armature resistance `r`, inductance `l`, rotor
    /// inertia `j` and viscous friction `b` (each non-negative and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(k: f64, r: f64, l: f64, j: f64, b: f64) -> Result<Self, PartError> {
        let c = Check::new("dc_motor");
        Ok(Self {
            k: c.finite("k", k)?,
            r: c.non_negative("r", r)?,
            l: c.non_negative("l", l)?,
            j: c.non_negative("j", j)?,
            b: c.non_negative("b", b)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i` and `theta`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port("theta", 1)
    }
}

impl Model for DcMotor {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.l * v[0] * v[0] + 0.5 * self.j * v[1] * v[1]
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.fill(0.0);
        lv[0] = self.l * v[0];
        lv[1] = self.j * v[1];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.vv.add(0, 0, self.l);
        h.vv.add(1, 1, self.j);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[0] - self.k * v[1];
        f[1] = self.k * v[0] - self.b * v[1];
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.r);
        j.v.add(0, 1, -self.k);
        j.v.add(1, 0, self.k);
        j.v.add(1, 1, -self.b);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q", "theta"][i].into()
    }
}

/// Ideal transformer of turns ratio `n = N₂/N₁`: two winding charges `(q₁, q₂)`, no Lagrangian,
/// and the internal one-form constraint
///
/// ```text
/// q̇₁ + n q̇₂ = 0          (i₁ = −n i₂),
/// ```
///
/// whose multiplier `μ` acts on the windings as the efforts `(μ, nμ)`: the port voltages are
/// `v₁ = −μ`, `v₂ = −nμ`, so `v₂ = n v₁` and `v₁ i₁ + v₂ i₂ = 0` (lossless). Both windings use the
/// passive convention with the dotted terminal as `+`.
///
/// **Why a two-coordinate subsystem** (not a graph connection): a transformer has four terminals
/// in two galvanically separate windings; each winding is a branch that takes part in KCL at its
/// own two nodes, which a bare node row between two other ports cannot express. A one-form (rather
/// than holonomic `q₁ + n q₂ = 0`) leaves the charges' offsets free: only currents are related.
/// The ratio holds to round-off at every step. Being ideal (no magnetising inductance), it passes
/// DC; use [`crate::CoupledInductors`] for a physical transformer.
///
/// Ports: `i1` (coordinate 0, primary), `i2` (coordinate 1, secondary).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct IdealTransformer {
    /// Turns ratio `n = N₂/N₁` (`v₂ = n v₁`).
    pub n: f64,
}

impl IdealTransformer {
    /// A transformer of turns ratio `n` (non-zero and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `n` otherwise.
    pub fn new(n: f64) -> Result<Self, PartError> {
        Ok(Self {
            n: Check::new("ideal_transformer").nonzero("n", n)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i1`, `i2`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(self)
            .with_port("i1", 0)
            .with_port("i2", 1)
    }
}

impl Model for IdealTransformer {
    fn dim(&self) -> usize {
        2
    }
    zero_lagrangian!();
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q1", "q2"][i].into()
    }
}

impl Constraints for IdealTransformer {
    fn count(&self) -> usize {
        1
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::OneForm
    }
    fn forms(&self, _q: &[f64], out: &mut Triplets) {
        out.add(0, 0, 1.0);
        out.add(0, 1, self.n);
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn name(&self, _a: usize) -> String {
        "turns ratio".into()
    }
}

/// Ideal gear (or belt) of ratio `r`: two massless shaft angles `(θ₁, θ₂)` and the holonomic
/// constraint
///
/// ```text
/// θ₂ − r θ₁ = 0,
/// ```
///
/// whose multiplier `λ` applies the torques `(−rλ, λ)`: `τ₁ = −r τ₂` on the two sides, lossless
/// (`τ₁ ω₁ + τ₂ ω₂ = 0`). The reflected inertia of a load `J₂` on side 2 is `r² J₂`. Holonomic (not
/// a one-form) because the angles themselves are meshed: the relation holds at position level every
/// step, with no round-off drift of the alignment. Start with `θ₂ = r θ₁`.
///
/// Ports: `theta1` (coordinate 0, input), `theta2` (coordinate 1, output).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct IdealGear {
    /// Ratio `r = θ₂/θ₁` (negative for an external mesh that reverses direction).
    pub ratio: f64,
}

impl IdealGear {
    /// A gear of ratio `ratio = θ₂/θ₁` (non-zero and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `ratio` otherwise.
    pub fn new(ratio: f64) -> Result<Self, PartError> {
        Ok(Self {
            ratio: Check::new("ideal_gear").nonzero("ratio", ratio)?,
        })
    }

    /// This part as a subsystem named `name` with ports `theta1`, `theta2`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(self)
            .with_port("theta1", 0)
            .with_port("theta2", 1)
    }
}

impl Model for IdealGear {
    fn dim(&self) -> usize {
        2
    }
    zero_lagrangian!();
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["theta1", "theta2"][i].into()
    }
}

impl Constraints for IdealGear {
    fn count(&self) -> usize {
        1
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::Holonomic
    }
    fn forms(&self, _q: &[f64], out: &mut Triplets) {
        out.add(0, 0, -self.ratio);
        out.add(0, 1, 1.0);
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        out[0] = q[1] - self.ratio * q[0];
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn name(&self, _a: usize) -> String {
        "gear mesh".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::electrical::{Resistor, VoltageSource};
    use crate::mechanical::{ForceSource, Ground, Inertia};
    use crate::planar::PlanarLinkage;
    use crate::testing::{Run, check_constraints, check_model, node, rel};
    use crate::waveform::Waveform;
    use dirac_core::Discretisation;
    use dirac_graph::{Interconnection, Representation};
    use dirac_sim::IntegratorOptions;

    /// Unit-scale motor (critically damped: `L J s² + R J s + k² = (s/2 + 1)²`). Momenta of order
    /// one keep the step's absolute Newton tolerance (1e-14 on momentum residuals) far below the
    /// asserted 1e-12: a residual δp moves a rate by δp/L.
    const MOTOR: DcMotor = DcMotor {
        k: 1.0,
        r: 2.0,
        l: 0.5,
        j: 0.5,
        b: 0.0,
    };

    fn joint(g: &mut Interconnection, a: (&str, &str), b: (&str, &str)) {
        let (pa, pb) = (g.port(a.0, a.1).unwrap(), g.port(b.0, b.1).unwrap());
        g.joint(format!("{}-{}", a.0, b.0), pa, pb);
    }

    /// A source across the motor's armature (`+` to `+`).
    fn motor_on_source(motor: DcMotor, source: VoltageSource) -> Interconnection {
        let mut g = Interconnection::new();
        g.add_subsystem(source.subsystem("V")).unwrap();
        g.add_subsystem(motor.subsystem("M")).unwrap();
        node(&mut g, "a", &[("V", "i", -1.0), ("M", "i", -1.0)]);
        node(&mut g, "gnd", &[("V", "i", 1.0), ("M", "i", 1.0)]);
        g
    }

    #[test]
    fn hand_written_derivatives() {
        let motor = DcMotor { b: 0.2, ..MOTOR };
        check_model(&motor, &[0.1, 0.2], &[0.3, -0.4], 0.0);
        let t = IdealTransformer { n: 3.0 };
        check_model(&t, &[0.1, 0.2], &[0.3, -0.4], 0.0);
        check_constraints(&t, &[0.1, 0.2], &[0.5], &[0.3, -0.4]);
        let gear = IdealGear { ratio: -2.5 };
        check_model(&gear, &[0.1, 0.2], &[0.3, -0.4], 0.0);
        check_constraints(&gear, &[0.1, 0.2], &[0.5], &[0.3, -0.4]);
    }

    /// Motor with friction on a SIN source: with the armature loop momentum `P = p_q − p_V` and
    /// `E = P²/2L + p_θ²/2J`, the discrete power balance
    /// `E_{k+1} − E_k = h (V(t_k+h/2) ī − R ī² − b ω̄²)` holds to round-off — the gyrator's
    /// `∓k ω̄ ī` cancel exactly.
    #[test]
    fn motor_power_balance() {
        let motor = DcMotor { b: 0.05, ..MOTOR };
        let w = Waveform::sin(1.0, 12.0, 3.0);
        let g = motor_on_source(motor, VoltageSource::new(w.clone()).unwrap());
        let h = 1e-3;
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0, 0.0]]);
        let energy = |run: &Run| {
            let p = run.p(1, 0) - run.p(0, 0);
            p * p / (2.0 * motor.l) + run.p(1, 1).powi(2) / (2.0 * motor.j)
        };
        let (mut worst, mut scale): (f64, f64) = (0.0, 1e-300);
        for k in 0..2000 {
            let (e0, q, th) = (energy(&run), run.q(1, 0), run.q(1, 1));
            run.step();
            let (i, om) = ((run.q(1, 0) - q) / h, (run.q(1, 1) - th) / h);
            let v = w.value((k as f64 + 0.5) * h);
            let e1 = energy(&run);
            worst = worst.max((e1 - e0 - h * (v * i - motor.r * i * i - motor.b * om * om)).abs());
            scale = scale.max(e1);
        }
        println!("motor power balance: max defect {worst:.2e} (energy scale {scale:.2e})");
        assert!(worst < 1e-13 * scale, "{worst:e}");
    }

    /// No-load (b = 0) from a DC source: the steady state is `ω = V/k`, `i = 0` (the back-EMF
    /// balances the source), reached to 1e-12 after 200 electromechanical time constants.
    #[test]
    fn motor_no_load_speed() {
        let v = 6.0;
        let g = motor_on_source(MOTOR, VoltageSource::dc(v).unwrap());
        let h = 0.01;
        // Newton takes at least one (affine, exact) update per step, so the rates converge to the
        // fixed point instead of freezing where the warm start's residual first looks small.
        let options = IntegratorOptions::new(Discretisation::midpoint(), h);
        let mut run = Run::new(
            &g,
            Representation::Monolithic,
            options,
            &[vec![0.0], vec![0.0, 0.0]],
        );
        for _ in 0..10_000 {
            run.step();
        }
        // Mean rates of the last step from the solved increments (differences of the accumulated
        // positions would lose digits: θ ≈ 600 rad while Δθ ≈ 0.06).
        let z = run.integrator().last_unknowns();
        let (i, om) = (z[run.index(1, 0)] / h, z[run.index(1, 1)] / h);
        println!("no-load: ω = {om:.15} (V/k = {}), i = {i:.2e}", v / MOTOR.k);
        assert!(rel(om, v / MOTOR.k, 1e-300) < 1e-12 && i.abs() < 1e-12 * v / MOTOR.r);
    }

    /// Locked rotor (shaft joined to a rotational [`Ground`]): `θ` stays at 0 (to round-off), the
    /// armature current follows the midpoint rational map of `L di/dt = V − R i` to its steady
    /// value `V/R`: `ī_k = V/R + ρᵏ(ī₀ − V/R)`, `ρ = (L − hR/2)/(L + hR/2)`, `ī₀ = (hV/2)/(L + hR/2)`.
    #[test]
    fn motor_locked_rotor_current() {
        let v = 6.0;
        let mut g = motor_on_source(MOTOR, VoltageSource::dc(v).unwrap());
        g.add_subsystem(Ground::origin().rotational_subsystem("G"))
            .unwrap();
        joint(&mut g, ("M", "theta"), ("G", "theta"));
        let h = 0.01;
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0, 0.0], vec![0.0]]);
        let (l, r) = (MOTOR.l, MOTOR.r);
        let rho = (l - h * r / 2.0) / (l + h * r / 2.0);
        let i0 = (h * v / 2.0) / (l + h * r / 2.0);
        let mut worst: f64 = 0.0;
        let mut i = 0.0;
        for k in 0..2000 {
            let q = run.q(1, 0);
            run.step();
            i = (run.q(1, 0) - q) / h;
            worst = worst.max((i - (v / r + rho.powi(k) * (i0 - v / r))).abs() / (v / r));
            assert!(run.q(1, 1).abs() < 1e-15);
        }
        println!(
            "locked rotor: i = {i:.15} (V/R = {}), max deviation from the rational map {worst:.2e}",
            v / r
        );
        assert!(worst < 1e-12 && rel(i, v / r, 1e-300) < 1e-12);
    }

    /// Across domains: a DC source drives the motor, which turns a rigid rod pinned at its end
    /// (a one-body [`PlanarLinkage`]) through a gear `θ_rod = r θ_motor`. The discrete fixed point
    /// is the static equilibrium: no speed, hence no back-EMF, so `i = V/R`, the motor torque `kV/R`
    /// reaches the rod as `kV/(R r)` and holds it where `m g d sin α* = kV/(R r)`
    /// (`d = ℓ/2`; α from the downward vertical). Asserted to 1e-10 after the transient has decayed
    /// (damping by the back-EMF, `k²/(R r²)` at the rod).
    #[test]
    fn motor_lifts_rod_through_gear() {
        let motor = DcMotor {
            k: 1.0,
            r: 2.0,
            l: 0.01,
            j: 0.01,
            b: 0.0,
        };
        let (v, ratio, m, len, grav, h) = (3.0, 0.5, 1.0, 1.2, 9.81, 0.01);
        let mut rod = PlanarLinkage::new(grav).unwrap();
        let body = rod.add_body("rod", m, m * len * len / 12.0).unwrap();
        let pivot_point = [-len / 2.0, 0.0];
        rod.pin_to_ground(body, pivot_point, [0.0, 0.0]);
        let mut q_rod = vec![0.0; 3];
        let hanging = -std::f64::consts::FRAC_PI_2;
        rod.place(&mut q_rod, body, hanging, pivot_point, [0.0, 0.0]);
        let mut g = motor_on_source(motor, VoltageSource::dc(v).unwrap());
        g.add_subsystem(IdealGear { ratio }.subsystem("G")).unwrap();
        g.add_subsystem(rod.subsystem("L")).unwrap();
        joint(&mut g, ("M", "theta"), ("G", "theta1"));
        joint(&mut g, ("G", "theta2"), ("L", "rod.theta"));
        let q0 = vec![
            vec![0.0],
            vec![0.0, hanging / ratio],
            vec![hanging / ratio, hanging],
            q_rod,
        ];
        let mut run = Run::midpoint(&g, h, &q0);
        for _ in 0..4000 {
            run.step();
        }
        let alpha = run.q(3, 2) - hanging;
        let exact = (motor.k * v / (motor.r * ratio * m * grav * len / 2.0)).asin();
        let z = run.integrator().last_unknowns();
        let i = z[run.index(1, 0)] / h;
        println!("motor-gear-rod: α = {alpha:.15} (closed form {exact:.15}), i = {i:.15}");
        assert!((alpha - exact).abs() < 1e-10 && (i - v / motor.r).abs() < 1e-10);
        assert!((run.q(2, 1) - ratio * run.q(2, 0)).abs() < 1e-14);
    }

    /// SIN source on the primary, resistor on the secondary: every step `v₂ = n V`, so the load
    /// current is `n V(t_k+h/2)/R_L`, the primary current `n² V/R_L` (the load reflected as
    /// `R_L/n²`), and `Δq₁ = −n Δq₂` to round-off.
    #[test]
    fn transformer_ratios() {
        let (n, rl, h) = (2.5, 8.0, 1e-3);
        let w = Waveform::sin(0.5, 10.0, 50.0);
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::new(w.clone()).unwrap().subsystem("V"))
            .unwrap();
        g.add_subsystem(IdealTransformer { n }.subsystem("T"))
            .unwrap();
        g.add_subsystem(Resistor { r: rl }.subsystem("RL")).unwrap();
        node(&mut g, "a", &[("V", "i", -1.0), ("T", "i1", -1.0)]);
        node(&mut g, "g1", &[("V", "i", 1.0), ("T", "i1", 1.0)]);
        node(&mut g, "c", &[("T", "i2", -1.0), ("RL", "i", -1.0)]);
        node(&mut g, "g2", &[("T", "i2", 1.0), ("RL", "i", 1.0)]);
        let mut run = Run::midpoint(&g, h, &[vec![0.0], vec![0.0, 0.0], vec![0.0]]);
        let (mut worst_i, mut worst_ratio): (f64, f64) = (0.0, 0.0);
        for k in 0..200 {
            let (q1, q2, ql) = (run.q(1, 0), run.q(1, 1), run.q(2, 0));
            run.step();
            let (d1, d2, dl) = (run.q(1, 0) - q1, run.q(1, 1) - q2, run.q(2, 0) - ql);
            let vs = w.value((k as f64 + 0.5) * h);
            let scale = 10.5 * n * n / rl;
            worst_i = worst_i.max((dl / h - n * vs / rl).abs() / scale);
            worst_i = worst_i.max((d1 / h - n * n * vs / rl).abs() / scale);
            worst_ratio = worst_ratio.max((d1 + n * d2).abs() / (scale * h));
        }
        println!(
            "transformer: max current error {worst_i:.2e}, max ratio residual {worst_ratio:.2e}"
        );
        assert!(
            worst_i < 1e-12 && worst_ratio < 1e-14,
            "{worst_i:e} {worst_ratio:e}"
        );
    }

    /// Constant torque on `J₁` geared (ratio r) to `J₂`: the input sees `J₁ + r² J₂`, so
    /// `θ₁ = T t²/(2(J₁ + r²J₂))` exactly (the midpoint rule integrates quadratics exactly), and
    /// `θ₂ = r θ₁` to round-off.
    #[test]
    fn gear_ratio_and_reflected_inertia() {
        let (j1, j2, r, torque, h) = (0.2, 0.05, -3.0, 1.5, 0.01);
        let mut g = Interconnection::new();
        g.add_subsystem(Inertia::new(j1).unwrap().subsystem("J1"))
            .unwrap();
        g.add_subsystem(IdealGear { ratio: r }.subsystem("G"))
            .unwrap();
        g.add_subsystem(Inertia::new(j2).unwrap().subsystem("J2"))
            .unwrap();
        g.add_subsystem(
            ForceSource::constant(torque)
                .unwrap()
                .rotational_subsystem("T"),
        )
        .unwrap();
        joint(&mut g, ("J1", "theta"), ("G", "theta1"));
        joint(&mut g, ("G", "theta2"), ("J2", "theta"));
        joint(&mut g, ("T", "theta"), ("J1", "theta"));
        let q0 = vec![vec![0.0], vec![0.0, 0.0], vec![0.0], vec![0.0]];
        let mut run = Run::midpoint(&g, h, &q0);
        let (mut worst, mut worst_ratio): (f64, f64) = (0.0, 0.0);
        for k in 1..=1000 {
            run.step();
            let t = k as f64 * h;
            let exact = torque * t * t / (2.0 * (j1 + r * r * j2));
            worst = worst.max((run.q(0, 0) - exact).abs() / exact);
            worst_ratio = worst_ratio.max((run.q(2, 0) - r * run.q(0, 0)).abs() / exact.abs());
        }
        println!("gear: max relative θ₁ error {worst:.2e}, max |θ₂ − rθ₁|/θ₁ {worst_ratio:.2e}");
        assert!(
            worst < 1e-12 && worst_ratio < 1e-14,
            "{worst:e} {worst_ratio:e}"
        );
    }
}
