//! The explicit Störmer–Verlet path of separable models.
//!
//! For `L = ½vᵀMv − V(q)` with a constant `M` and forces `f(q, t)`, the trapezoid rule's step
//! equation is linear in `q_{k+1}` with the matrix `M/h`, so the explicit update
//! `M v̄ = p_k + h/2 F_k`, `q_{k+1} = q_k + h v̄`, `p_{k+1} = M v̄ + h/2 F_{k+1}` (with
//! `F = ∂L/∂q + f`) is the same map as the Newton path's. These tests check that it is taken
//! exactly where it applies, that it gives the Newton trajectory to round-off (single steps and
//! Yoshida compositions), that its discrete power balance holds to round-off, and that moving a
//! coupling potential between `L` and the forces (monolithic vs interaction-force) leaves the
//! explicit trajectory unchanged.

#![allow(clippy::needless_range_loop)] // 2×2 matrix formulas read best with indices.

use dirac_components::{ForceSource, Mass, Spring, Waveform};
use dirac_core::{ForceJacobian, LagrangianHessian, Model, NoConstraints, Triplets};
use dirac_graph::{Interconnection, Representation};
use dirac_problems::DampedOscillator;
use dirac_sim::{
    Composition, Discretisation, Execution, Integrator, IntegratorOptions, Simulation,
};

/// Largest difference between the explicit and the Newton trajectories, relative to the state's
/// size. The Newton path solves the same linear equation (one update from the guess, accepted at
/// `update_tol = 1e-11` relative with an exact Jacobian, so its error is at round-off) with
/// row-scaled LU: measured 6.6e-15 over 2000 forced Hénon–Heiles steps, 2.4e-14 with Yoshida 6
/// (7 substeps a step) and 1.2e-14 on the split chain; the bound leaves 4× for round-off
/// accumulation on other platforms.
const SAME_MAP_TOL: f64 = 1e-13;

/// Largest defect of the discrete power balance relative to the kinetic energy scale: every
/// term is a product of rounded state values, measured 3.1e-17 absolute at a kinetic scale of
/// 7.4e-2 (4.2e-16 relative) over 2000 steps.
const POWER_BALANCE_TOL: f64 = 1e-14;

/// The Hénon–Heiles system on `(x, y)` with a non-diagonal constant mass matrix
/// `M = [[2, ½], [½, 1]]` (so the explicit path uses its LU branch) and a periodic forcing of
/// `x`: `L = ½vᵀMv − ½(x² + y²) − x²y + y³/3`, `f = (a cos(ωt), 0)`.
#[derive(Debug, Clone, Copy)]
struct HenonHeiles {
    /// Forcing amplitude on `x`.
    a: f64,
}

const MASS: [[f64; 2]; 2] = [[2.0, 0.5], [0.5, 1.0]];
const OMEGA: f64 = 1.3;

impl HenonHeiles {
    fn potential(q: &[f64]) -> f64 {
        let (x, y) = (q[0], q[1]);
        0.5 * (x * x + y * y) + x * x * y - y * y * y / 3.0
    }
    fn gradient(q: &[f64]) -> [f64; 2] {
        let (x, y) = (q[0], q[1]);
        [x + 2.0 * x * y, y + x * x - y * y]
    }
    /// `F(q, t) = −∇V + f`.
    fn total_force(&self, q: &[f64], t: f64) -> [f64; 2] {
        let g = Self::gradient(q);
        [-g[0] + self.a * (OMEGA * t).cos(), -g[1]]
    }
}

impl Model for HenonHeiles {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let mut t = 0.0;
        for i in 0..2 {
            for j in 0..2 {
                t += 0.5 * v[i] * MASS[i][j] * v[j];
            }
        }
        t - Self::potential(q)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let g = Self::gradient(q);
        lq[0] = -g[0];
        lq[1] = -g[1];
        for i in 0..2 {
            lv[i] = MASS[i][0] * v[0] + MASS[i][1] * v[1];
        }
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        let (x, y) = (q[0], q[1]);
        h.qq.add(0, 0, -(1.0 + 2.0 * y));
        h.qq.add(0, 1, -2.0 * x);
        h.qq.add(1, 0, -2.0 * x);
        h.qq.add(1, 1, -(1.0 - 2.0 * y));
        for i in 0..2 {
            for j in 0..2 {
                h.vv.add(i, j, MASS[i][j]);
            }
        }
    }
    fn has_force(&self) -> bool {
        self.a != 0.0
    }
    fn force(&self, _q: &[f64], _v: &[f64], t: f64, f: &mut [f64]) {
        f[0] = self.a * (OMEGA * t).cos();
        f[1] = 0.0;
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, _j: &mut ForceJacobian) {}
    fn is_autonomous(&self) -> bool {
        self.a == 0.0
    }
    fn separable(&self) -> Option<Triplets> {
        let mut m = Triplets::new();
        for i in 0..2 {
            for j in 0..2 {
                m.add(i, j, MASS[i][j]);
            }
        }
        Some(m)
    }
}

/// `(q_k, p_k)` for `steps` steps from `q = (0.1, −0.2)`, `v = (0.1, 0.1)` (energy about 0.05, below the escape energy 1/6).
fn run(model: HenonHeiles, options: IntegratorOptions, steps: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    let explicit = options.explicit;
    let mut sim = Integrator::new(model, NoConstraints, options).expect("options");
    sim.initialise(&[0.1, -0.2], &[0.1, 0.1], 0.0)
        .expect("initial state");
    assert_eq!(sim.uses_explicit(), explicit, "path taken");
    let mut out = vec![(sim.q().to_vec(), sim.p().to_vec())];
    for _ in 0..steps {
        let report = sim.step().expect("step");
        if explicit {
            assert_eq!(report.newton.iterations, 0, "an explicit step iterates");
        }
        out.push((sim.q().to_vec(), sim.p().to_vec()));
    }
    out
}

fn max_deviation(a: &[(Vec<f64>, Vec<f64>)], b: &[(Vec<f64>, Vec<f64>)]) -> f64 {
    let mut worst: f64 = 0.0;
    for ((qa, pa), (qb, pb)) in a.iter().zip(b) {
        let scale = qa.iter().chain(pa).fold(1.0_f64, |m, x| m.max(x.abs()));
        for (x, y) in qa.iter().chain(pa).zip(qb.iter().chain(pb)) {
            worst = worst.max((x - y).abs() / scale);
        }
    }
    worst
}

/// The explicit step is the Newton path's trapezoid map, to round-off, for a single step and a
/// sixth-order Yoshida composition of it, forced and unforced. Mutations (in `explicit.rs`,
/// `compose`): the merged and end kicks `(hᵢ + hᵢ₊₁)/2 F` scaled by 1.001 give a deviation of
/// 7.2e-3; the start kick scaled by 1.001, 7.2e-3; the end force evaluated at `t_k` instead of
/// `t_k + h`, 1.2e-2 (forced run). A merged kick of `hᵢ₊₁` instead of `(hᵢ + hᵢ₊₁)/2` (single
/// steps unchanged) fails `compositions.rs` (observed order 1.98 for the triple jump).
#[test]
fn explicit_path_equals_the_newton_path() {
    let h = 0.05;
    for composition in [Composition::single(), Composition::yoshida6()] {
        for a in [0.0, 0.05] {
            let model = HenonHeiles { a };
            let options = IntegratorOptions::new(Discretisation::trapezoid(), h)
                .composition(composition.clone());
            let fast = run(model, options.clone(), 2000);
            let newton = run(model, options.explicit(false), 2000);
            let dev = max_deviation(&fast, &newton);
            println!(
                "explicit vs Newton, {} substeps, a = {a}: {dev:.2e}",
                composition.gammas().len()
            );
            assert!(dev <= SAME_MAP_TOL, "deviation {dev:e}");
        }
    }
}

/// Kinetic energy as a function of the momentum: `½ pᵀM⁻¹p`, and the `M⁻¹`-norm.
fn inverse_mass_form(a: &[f64], b: &[f64]) -> f64 {
    let det = MASS[0][0] * MASS[1][1] - MASS[0][1] * MASS[1][0];
    let inv = [
        [MASS[1][1] / det, -MASS[0][1] / det],
        [-MASS[1][0] / det, MASS[0][0] / det],
    ];
    let mut s = 0.0;
    for i in 0..2 {
        for j in 0..2 {
            s += a[i] * inv[i][j] * b[j];
        }
    }
    s
}

/// Discrete power balance of the trapezoid rule. From `p_{k+1} − p_k = h/2 (F_k + F_{k+1})` and
/// `M v̄ = p_k + h/2 F_k = p_{k+1} − h/2 F_{k+1}`:
///
/// ```text
/// T̃_{k+1} − T̃_k = ½ (F_k + F_{k+1})·(q_{k+1} − q_k),   T̃ = ½ pᵀM⁻¹p − (h²/8) FᵀM⁻¹F,
/// ```
///
/// the modified kinetic energy changes by the trapezoid-rule work of every force (potential and
/// external) along the step, exactly. Checked with a time-dependent forcing and a non-diagonal
/// mass matrix. Mutations (in `explicit.rs`): the start or the end kick scaled by 1.001 gives a
/// defect of 1.85e-6; the end force evaluated at `t_k` instead of `t_k + h`, 2.27e-5.
#[test]
fn discrete_power_balance_holds() {
    let h = 0.05;
    let model = HenonHeiles { a: 0.05 };
    let traj = run(
        model,
        IntegratorOptions::new(Discretisation::trapezoid(), h),
        2000,
    );
    let modified_kinetic = |q: &[f64], p: &[f64], t: f64| {
        let f = model.total_force(q, t);
        0.5 * inverse_mass_form(p, p) - h * h / 8.0 * inverse_mass_form(&f, &f)
    };
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for (k, w) in traj.windows(2).enumerate() {
        let (t0, t1) = (k as f64 * h, (k + 1) as f64 * h);
        let ((q0, p0), (q1, p1)) = (&w[0], &w[1]);
        let (f0, f1) = (model.total_force(q0, t0), model.total_force(q1, t1));
        let work: f64 = (0..2)
            .map(|i| 0.5 * (f0[i] + f1[i]) * (q1[i] - q0[i]))
            .sum();
        let change = modified_kinetic(q1, p1, t1) - modified_kinetic(q0, p0, t0);
        scale = scale.max(0.5 * inverse_mass_form(p0, p0));
        worst = worst.max((change - work).abs());
    }
    println!("trapezoid power balance: max defect {worst:.2e} (kinetic scale {scale:.2e})");
    assert!(
        worst <= POWER_BALANCE_TOL * scale,
        "defect {worst:e} at scale {scale:e}"
    );
}

/// Two masses joined by a hardening spring, the first pushed by a sine force: as parts. The
/// coupling potential sits in `L` (monolithic) or acts as forces (interaction force); either way
/// the assembled model is separable and steps explicitly.
fn split_chain() -> Interconnection {
    let mut g = Interconnection::new();
    for (name, m) in [("m1", 1.5), ("m2", 0.5), ("m3", 2.0)] {
        g.add_subsystem(Mass::new(m).expect("mass").subsystem(name))
            .expect("subsystem");
    }
    let (a, b, c) = (
        g.port("m1", "x").expect("x"),
        g.port("m2", "x").expect("x"),
        g.port("m3", "x").expect("x"),
    );
    g.coupling("k12", a, b, Spring::new(3.0, 2.0, 0.0).expect("spring"));
    g.coupling("k23", b, c, Spring::linear(1.0).expect("spring"));
    let push = ForceSource::new(Waveform::Sin {
        offset: 0.0,
        amplitude: 0.5,
        frequency: 0.7,
        delay: 0.0,
        damping: 0.0,
        phase_deg: 0.0,
    })
    .expect("source");
    g.coupling("push", a, c, push);
    g
}

fn chain_run(representation: Representation, explicit: bool) -> (Vec<Vec<f64>>, bool) {
    let g = split_chain();
    let options = IntegratorOptions::new(Discretisation::trapezoid(), 0.02)
        .composition(Composition::yoshida4())
        .explicit(explicit);
    let mut sim = Simulation::new(g, Execution::Assembled(representation), options);
    sim.set_position("m1", "x", 0.3).expect("m1");
    sim.set_velocity("m2", "x", 0.4).expect("m2");
    sim.prepare().expect("prepares");
    let uses = sim.assembled().expect("assembled").1.uses_explicit();
    let mut states = Vec::new();
    let (mut q, mut p) = (Vec::new(), Vec::new());
    for _ in 0..1000 {
        sim.step().expect("steps");
        let mut s = sim.positions();
        s.extend(sim.momenta());
        // The allocation-free read gives the same state.
        sim.state_into(&mut q, &mut p);
        assert_eq!((q.as_slice(), p.as_slice()), s.split_at(q.len()));
        states.push(s);
    }
    (states, uses)
}

/// `Simulation::state_into` reads the pulled-back state in the constraint representation (whose
/// endpoint momenta are added back to their partner ports): the same positions and momenta as the
/// monolithic run's to round-off (`chain_run` checks `state_into` against `positions` and
/// `momenta` at every step). Mutation: dropping the pull-back in `subsystem_momenta_into` gives
/// momenta that differ by the endpoint momenta: 1.5e-2 relative here.
#[test]
fn state_into_reads_the_pulled_back_state() {
    let (constraint, uses) = chain_run(Representation::Constraint, true);
    let (mono, _) = chain_run(Representation::Monolithic, true);
    assert!(!uses, "constraints take the Newton path");
    assert_eq!(constraint[0].len(), 6, "three masses: q and p");
    let mut worst: f64 = 0.0;
    for (a, b) in mono.iter().zip(&constraint) {
        let scale = a.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        for (x, y) in a.iter().zip(b) {
            worst = worst.max((x - y).abs() / scale);
        }
    }
    println!("split chain: monolithic vs constraint max deviation {worst:.2e}");
    assert!(worst <= SAME_MAP_TOL, "deviation {worst:e}");
}

/// Equivalence across representations on the explicit path: the monolithic and the
/// interaction-force forms of the split chain both step explicitly and agree with each other
/// and with the Newton path to round-off. Mutation: the coupling force of the interaction-force
/// representation scaled by 1.001 (`stamp_coupling_force`) gives 8.6e-3.
#[test]
fn split_separable_model_is_equivalent_across_representations() {
    let (mono, mono_explicit) = chain_run(Representation::Monolithic, true);
    let (force, force_explicit) = chain_run(Representation::InteractionForce, true);
    let (newton, newton_explicit) = chain_run(Representation::Monolithic, false);
    assert!(mono_explicit && force_explicit && !newton_explicit);
    let mut worst: f64 = 0.0;
    for ((a, b), c) in mono.iter().zip(&force).zip(&newton) {
        let scale = a.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        for ((x, y), z) in a.iter().zip(b).zip(c) {
            worst = worst.max((x - y).abs().max((x - z).abs()) / scale);
        }
    }
    println!("split chain: monolithic vs force vs Newton max deviation {worst:.2e}");
    assert!(worst <= SAME_MAP_TOL, "deviation {worst:e}");
}

/// The explicit path is not taken where it does not apply: a velocity-dependent force (the
/// damped oscillator, which does not claim separability), the midpoint or Gauss rules, or the
/// option switched off.
#[test]
fn explicit_path_only_where_it_applies() {
    fn uses<M: Model>(model: M, d: Discretisation, on: bool) -> bool {
        Integrator::new(
            model,
            NoConstraints,
            IntegratorOptions::new(d, 0.05).explicit(on),
        )
        .expect("options")
        .uses_explicit()
    }
    let mass = || Mass::new(1.0).expect("mass");
    let damped = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 0.1,
    };
    assert!(uses(mass(), Discretisation::trapezoid(), true));
    assert!(uses(mass(), Discretisation::lobatto(1), true));
    assert!(uses(
        HenonHeiles { a: 0.1 },
        Discretisation::trapezoid(),
        true
    ));
    assert!(!uses(damped, Discretisation::trapezoid(), true));
    assert!(!uses(mass(), Discretisation::midpoint(), true));
    assert!(!uses(mass(), Discretisation::gauss(2), true));
    assert!(!uses(mass(), Discretisation::trapezoid(), false));
}

/// `L = ½v² − q⁴` with a force that is not finite beyond a wall at `q = 0.9` (as an overflowing
/// force would be): from `(q, p) = (0.5, 1)` the motion turns at `q = 0.866`; a Verlet step of
/// `h = 0.5` overshoots into the wall (`q = 0.9375`), two of `0.25` stay outside it.
#[derive(Debug, Clone, Copy)]
struct WalledQuartic;

impl Model for WalledQuartic {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * v[0] * v[0] - q[0].powi(4)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = if q[0] > 0.9 {
            f64::NAN
        } else {
            -4.0 * q[0].powi(3)
        };
        lv[0] = v[0];
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(0, 0, -12.0 * q[0] * q[0]);
        h.vv.add(0, 0, 1.0);
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn separable(&self) -> Option<Triplets> {
        let mut mass = Triplets::new();
        mass.add(0, 0, 1.0);
        Some(mass)
    }
}

/// An explicit step whose force turns non-finite is retried in cut pieces, as an implicit one
/// is: the step of 0.5 into the wall is cut once and lands where two steps of 0.25 land, bit for
/// bit. (Fails if the one-pass explicit step reports the failure instead of handing the step to
/// the cutting path, or if it leaves the failed attempt's state behind.)
#[test]
fn an_explicit_step_into_a_non_finite_force_is_cut_into_the_smaller_steps() {
    let start = |h: f64| {
        let options = IntegratorOptions::new(Discretisation::trapezoid(), h);
        let mut sim = Integrator::new(WalledQuartic, NoConstraints, options).expect("options");
        sim.initialise(&[0.5], &[1.0], 0.0).expect("initial state");
        assert!(sim.uses_explicit(), "explicit path");
        sim
    };
    let mut whole = start(0.5);
    whole.step().expect("the cut step succeeds");
    assert_eq!(whole.counters().step_cuts, 1);
    let mut halves = start(0.25);
    halves.step().expect("first half");
    halves.step().expect("second half");
    assert_eq!(halves.counters().step_cuts, 0);
    assert_eq!((whole.q(), whole.p()), (halves.q(), halves.p()));
    assert_eq!(whole.t(), 0.5);
}
