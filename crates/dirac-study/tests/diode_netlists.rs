//! Every bundled diode netlist run as the command line runs it (`Model::plan` at the file's own
//! `.tran` settings, the file's start and representation, [`Model::simulation`]) but with every
//! step at `h` (`--fixed-step`: the truncation-error control would take some steps as several
//! smaller midpoint steps, whose quadrature this check does not see from outside), checked after
//! every step with the step's own midpoint quadrature (`q̄ = q_k + Z/2`, `v̄ = Z/h`,
//! `t̄ = t_k + h/2`, `Z` the increments the step solved):
//!
//! * **passivity** of every diode: [`Diode::terminal_dissipation`]`(ī, v̄_j, Δp_φ/h)`, the power
//!   into its terminals `ī·(v̄_j + R_S ī)` less its junction's charging power `v̄_j Δp_φ/h`, is not
//!   negative (to the round-off of those two terms);
//! * the **device relation** of every diode, `ī − Δp_φ/h = i_D(v̄_j) + GMIN v̄_j`, to round-off of
//!   its terms (as `rectifier_steps_keep_the_relations` in `dirac-sim/tests/diode.rs` asserts);
//! * the **discrete power balance** of the whole circuit: the work of every part's own forces,
//!   `h v̄·f(q̄, v̄, t̄)` (a source's supply, a resistor's `−h R ī²`, a diode's
//!   `−h·`[`Diode::dissipation`]`(ī, v̄_j)`), equals the change of stored energy,
//!   `Σ v̄·Δp − h v̄·∂L/∂q(q̄, v̄)` (a capacitor's `Z(2q_k + Z)/2C`, a junction's `v̄_j Δp_φ`, an
//!   inductor's `ī Δφ`), to round-off of the largest term. These are the per-part terms of the
//!   hand-built circuits of `dirac-sim/tests/diode.rs`, written once through the
//!   `dirac_core::Model` trait so that any netlist's parts are accounted; the node impulses do no
//!   work because KCL holds.
//!
//! The checker ([`account`]) judges a step from its data alone; the negative controls at the end
//! feed it real steps changed so that a diode produces energy or the bookkeeping is wrong, and
//! require it to fail.

use dirac_components::Diode;
use dirac_graph::{Interconnection, SubsystemId};
use dirac_sim::{Discretisation, Execution, Simulation};
use dirac_study::{Model, RunSettings};

/// The bundled netlists with diodes.
const NETLISTS: &[&str] = &[
    "diode_halfwave.cir",
    "diode_bridge.cir",
    "diode_clamp.cir",
    "diode_peak.cir",
    "diode_clippers.cir",
    "diode_doubler.cir",
    "diode_tripler.cir",
    "diode_pulse_charge.cir",
    "diode_500v.cir",
    "diode_transformer.cir",
    "rectifier.cir",
];

/// Round-off of a relation between a few terms, relative to the largest: each step's Newton
/// converges to within a few ε of each equation's terms; the hand-built circuits of
/// `dirac-sim/tests/diode.rs` use the same bound (measured there 8.9e-15 on the device relation,
/// 8.4e-15 on the power balance).
const RELATION_TOL: f64 = 1e-13;

fn netlist(file: &str) -> Model {
    let path = format!(
        "{}/../../examples/netlists/{file}",
        env!("CARGO_MANIFEST_DIR")
    );
    Model::from_file(&path).unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// The netlist's run as `dirac run FILE --fixed-step` sets it up.
fn simulation(model: &Model) -> (Simulation, f64) {
    let plan = model
        .plan(&RunSettings {
            truncation: Some(false),
            ..RunSettings::default()
        })
        .expect("the file's own settings");
    assert_eq!(
        plan.execution,
        Execution::Assembled(dirac_graph::Representation::Monolithic),
        "a netlist runs monolithic: the step's unknowns are the parts' coordinates"
    );
    assert_eq!(plan.options.discretisation, Discretisation::midpoint());
    let t_end = plan.t_end;
    let sim = model
        .simulation(plan.execution, plan.options, model.start())
        .expect("simulation");
    (sim, t_end)
}

/// The diodes of a netlist: part and device.
fn diodes(model: &Model) -> Vec<(SubsystemId, Diode)> {
    let circuit = model.circuit().expect("a netlist");
    circuit
        .diodes()
        .map(|(name, s, d)| {
            assert_eq!(circuit.graph.subsystems()[s.0].name(), name);
            (s, *d)
        })
        .collect()
}

/// One solved step: where it started and what it solved.
#[derive(Debug, Clone)]
struct Step {
    t0: f64,
    h: f64,
    /// Positions at `t_k`.
    q0: Vec<f64>,
    /// Increments `q_{k+1} − q_k` as the step solved them (a difference of positions would lose
    /// small currents to cancellation).
    z: Vec<f64>,
    /// Momenta at `t_k` and `t_{k+1}`.
    p0: Vec<f64>,
    p1: Vec<f64>,
}

/// What [`account`] found on one step.
#[derive(Debug, Default)]
struct Account {
    /// Energy the parts' forces put in over the step (the sources' supply).
    supplied: f64,
    /// Energy the parts' forces took out (resistors, diodes, a source absorbing).
    dissipated: f64,
    /// Change of stored energy (capacitors, inductors, junction charge).
    stored: f64,
    /// `|supplied − dissipated − stored|` over the largest term.
    balance: f64,
    /// Per diode: [`Diode::terminal_dissipation`] (W; negative: the diode produced energy) and
    /// the larger of its two terms' sizes.
    passivity: Vec<(f64, f64)>,
    /// Per diode: the device relation's residual over its largest term.
    device: Vec<f64>,
}

/// The step's energy accounts and diode relations (see the module documentation).
fn account(graph: &Interconnection, diodes: &[(SubsystemId, Diode)], s: &Step) -> Account {
    let offsets = graph.coordinate_offsets();
    let t_mid = s.t0 + 0.5 * s.h;
    let mut out = Account::default();
    let mut size: f64 = 0.0;
    for (part, (subsystem, &o)) in graph.subsystems().iter().zip(&offsets).enumerate() {
        let model = subsystem.model();
        let n = model.dim();
        let q: Vec<f64> = (o..o + n).map(|i| s.q0[i] + 0.5 * s.z[i]).collect();
        let v: Vec<f64> = (o..o + n).map(|i| s.z[i] / s.h).collect();
        let (mut lq, mut lv) = (vec![0.0; n], vec![0.0; n]);
        model.lagrangian_gradient(&q, &v, &mut lq, &mut lv);
        for i in 0..n {
            let (dp, p) = (
                s.p1[o + i] - s.p0[o + i],
                s.p0[o + i].abs().max(s.p1[o + i].abs()),
            );
            let potential = s.h * v[i] * lq[i];
            out.stored += v[i] * dp - potential;
            // Δp is a difference of momenta: its round-off is relative to |v̄|·|p|.
            size = size.max(potential.abs()).max(v[i].abs() * p);
        }
        let work = match diodes.iter().find(|(d, _)| d.0 == part) {
            Some((_, d)) => {
                let (i, vj, i_c) = (v[0], v[1], (s.p1[o + 1] - s.p0[o + 1]) / s.h);
                let terminal = d.terminal_dissipation(i, vj, i_c);
                let terms = (i * (vj + d.series_resistance() * i))
                    .abs()
                    .max((vj * i_c).abs());
                out.passivity.push((terminal, terms));
                let j = d.junction_current(vj).0;
                let scale = i
                    .abs()
                    .max(i_c.abs())
                    .max(s.p0[o + 1].abs().max(s.p1[o + 1].abs()) / s.h)
                    .max(d.shockley(vj).0.abs())
                    .max(d.gmin() * vj.abs());
                out.device
                    .push((i - i_c - j).abs() / scale.max(f64::MIN_POSITIVE));
                -s.h * d.dissipation(i, vj)
            }
            None if model.has_force() => {
                let mut f = vec![0.0; n];
                model.force(&q, &v, t_mid, &mut f);
                s.h * f.iter().zip(&v).map(|(f, v)| f * v).sum::<f64>()
            }
            None => 0.0,
        };
        size = size.max(work.abs());
        if work > 0.0 {
            out.supplied += work;
        } else {
            out.dissipated -= work;
        }
    }
    size = size
        .max(out.supplied)
        .max(out.dissipated)
        .max(out.stored.abs());
    out.balance = (out.supplied - out.dissipated - out.stored).abs() / size.max(f64::MIN_POSITIVE);
    out
}

/// Whether the step's account passes: every diode passive and its relation kept, the balance
/// closed, each to [`RELATION_TOL`].
fn verdict(a: &Account) -> Result<(), String> {
    if let Some((k, (p, terms))) = a
        .passivity
        .iter()
        .enumerate()
        .find(|(_, (p, terms))| *p < -RELATION_TOL * terms)
    {
        return Err(format!(
            "diode {k} produces energy: dissipation {p:e} W (terms {terms:e} W)"
        ));
    }
    if let Some((k, r)) = a
        .device
        .iter()
        .enumerate()
        .find(|(_, r)| **r > RELATION_TOL)
    {
        return Err(format!("diode {k}: device relation off by {r:e}"));
    }
    if a.balance > RELATION_TOL {
        return Err(format!("power balance off by {:e}", a.balance));
    }
    Ok(())
}

/// Takes one step of `sim` and returns what it solved. Panics if the step was split (a
/// breakpoint substep or a cut: the last substep's unknowns would not be the step's).
fn step(sim: &mut Simulation, h: f64) -> Step {
    let (t0, q0, p0) = (sim.time(), sim.positions(), sim.momenta());
    let before = sim.summary();
    sim.step()
        .unwrap_or_else(|e| panic!("step at t = {t0:e}: {e}"));
    let after = sim.summary();
    assert_eq!(
        (
            after.step_cuts,
            after.breakpoint_substeps,
            after.refinements
        ),
        (
            before.step_cuts,
            before.breakpoint_substeps,
            before.refinements
        ),
        "the step at t = {t0:e} was split: its quadrature is not one midpoint"
    );
    let (_, integrator) = sim.assembled().expect("assembled");
    let z = integrator.last_unknowns()[..q0.len()].to_vec();
    let q1 = sim.positions();
    // The unknowns are laid out as the parts' coordinates: q_k + Z is q_{k+1}.
    for ((a, b), dz) in q0.iter().zip(&q1).zip(&z) {
        assert!(
            (a + dz - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(dz.abs()),
            "increments not in part order"
        );
    }
    Step {
        t0,
        h,
        q0,
        z,
        p0,
        p1: sim.momenta(),
    }
}

/// Runs `file` to its end, calling `visit` with every step.
fn run(file: &str, mut visit: impl FnMut(&Step)) -> (usize, f64, usize) {
    let model = netlist(file);
    let (mut sim, t_end) = simulation(&model);
    let h = sim.options().h;
    sim.prepare().unwrap_or_else(|e| panic!("{file}: {e}"));
    let steps = (t_end / h).round() as usize;
    for _ in 0..steps {
        visit(&step(&mut sim, h));
    }
    let summary = sim.summary();
    (
        steps,
        summary.newton_iterations_per_step(),
        summary.step_cuts,
    )
}

/// Every bundled diode netlist, every step: passivity of every diode, its device relation and the
/// circuit's power balance (see the module documentation). Prints per netlist the worst of each,
/// the energy supplied, dissipated and stored over the run, and Newton's cost.
///
/// Mutation: the diode's reverse current made positive in its force (`v_q − |i_D(v_φ)|`): the
/// half-wave rectifier still runs to the end and fails all three (least dissipation −3.3e-10 W,
/// device relation 2.0, balance 1.0e-8); the bridge then fails in Newton (its Jacobian no longer
/// matches the force).
#[test]
fn every_step_of_every_diode_netlist_keeps_passivity_and_the_power_balance() {
    let mut failures = Vec::new();
    for file in NETLISTS {
        let model = netlist(file);
        let graph = model.graph().clone();
        let devices = diodes(&model);
        assert!(!devices.is_empty(), "{file} has no diode");
        // The least dissipation (W) and the least dissipation relative to its terms.
        let (mut least, mut least_relative) = (f64::INFINITY, f64::INFINITY);
        let (mut device, mut balance) = (0.0_f64, 0.0_f64);
        let (mut supplied, mut dissipated, mut stored) = (0.0, 0.0, 0.0);
        let mut first_failure = None;
        let mut k = 0;
        let (steps, iterations, cuts) = run(file, |s| {
            let a = account(&graph, &devices, s);
            for &(p, terms) in &a.passivity {
                least = least.min(p);
                if terms > 0.0 {
                    least_relative = least_relative.min(p / terms);
                }
            }
            device = a.device.iter().copied().fold(device, f64::max);
            balance = balance.max(a.balance);
            supplied += a.supplied;
            dissipated += a.dissipated;
            stored += a.stored;
            if let (None, Err(e)) = (&first_failure, verdict(&a)) {
                first_failure = Some(format!("{file}: step {k} (t = {:e}): {e}", s.t0));
            }
            k += 1;
        });
        println!(
            "{file:<22} {steps:>5} steps, {iterations:.2} Newton iterations/step, {cuts} cuts; \
             least diode dissipation {least:.2e} W ({least_relative:.1e} of its terms), \
             worst device relation {device:.1e}, worst balance {balance:.1e}; \
             energy in {supplied:.4e} J = dissipated {dissipated:.4e} J + stored {stored:.4e} J"
        );
        failures.extend(first_failure);
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The step of `file` where its first diode carries the most current, and the netlist's parts.
fn conducting_step(file: &str) -> (Interconnection, Vec<(SubsystemId, Diode)>, Step) {
    let model = netlist(file);
    let devices = diodes(&model);
    let offset = model.graph().coordinate_offsets()[devices[0].0.0];
    let mut best: Option<Step> = None;
    run(file, |s| {
        if best
            .as_ref()
            .is_none_or(|b| s.z[offset].abs() > b.z[offset].abs())
        {
            best = Some(s.clone());
        }
    });
    (model.graph().clone(), devices, best.expect("a step"))
}

/// Negative controls: real steps, changed, fed to the checker. The unchanged step passes; the
/// first diode's current reversed (it then drives current against its junction voltage: it
/// produces energy) fails passivity, while [`Diode::dissipation`] of the same values stays
/// positive (why passivity is judged on the terminal power); a capacitor's charge increment
/// 1e-9 larger, or the junction charge's change dropped from the bookkeeping (the momentum of
/// the junction held), fails the power balance.
#[test]
fn the_checker_fails_a_diode_that_produces_energy_or_a_wrong_balance() {
    let (graph, devices, s) = conducting_step("diode_halfwave.cir");
    let offsets = graph.coordinate_offsets();
    verdict(&account(&graph, &devices, &s)).expect("the real step passes");
    let (d, o) = (devices[0].1, offsets[devices[0].0.0]);

    let mut reversed = s.clone();
    reversed.z[o] = -s.z[o];
    let a = account(&graph, &devices, &reversed);
    let (p, terms) = a.passivity[0];
    println!("diode current reversed: dissipation {p:.3e} W (terms {terms:.3e} W)");
    assert!(p < -RELATION_TOL * terms, "{a:?}");
    assert!(verdict(&a).is_err_and(|e| e.contains("produces energy")));
    assert!(d.dissipation(reversed.z[o] / s.h, s.z[o + 1] / s.h) > 0.0);

    let capacitor = graph.subsystem_id("c1").expect("c1");
    let c = offsets[capacitor.0];
    let mut charged = s.clone();
    charged.z[c] *= 1.0 + 1e-9;
    let a = account(&graph, &devices, &charged);
    println!("capacitor increment +1e-9: balance {:.2e}", a.balance);
    assert!(a.balance > RELATION_TOL && verdict(&a).is_err(), "{a:?}");

    let (graph, devices, s) = conducting_step("diode_pulse_charge.cir");
    verdict(&account(&graph, &devices, &s)).expect("the real step passes");
    let phi = graph.coordinate_offsets()[devices[0].0.0] + 1;
    assert!(s.p1[phi] != s.p0[phi], "the junction charge changes");
    let mut held = s.clone();
    held.p1[phi] = s.p0[phi];
    let a = account(&graph, &devices, &held);
    println!("junction charge change dropped: balance {:.2e}", a.balance);
    assert!(a.balance > RELATION_TOL && verdict(&a).is_err(), "{a:?}");
}

/// The default run refines some steps (the truncation-error control): such a step must be the
/// midpoint rule over its pieces. From the same state, `2^m` steps of `h/2^m` by an independent
/// fixed-step integrator of the same model end where the refined step ends, to Newton's
/// round-off; so the per-step passivity and power balance checked above at fixed steps (an
/// identity of each midpoint step, whatever its size) hold on every piece of the default run.
/// Steps refined more than once (pieces of unequal size) are left out. Measured: 3 of the
/// rectifier's 5 refined steps replayed, worst relative difference 1.4e-14.
#[test]
fn a_refined_step_is_the_midpoint_rule_over_its_pieces() {
    use dirac_sim::{Integrator, IntegratorOptions};
    let model = netlist("rectifier.cir");
    let plan = model
        .plan(&RunSettings::default())
        .expect("the file's own settings");
    assert!(
        plan.options.truncation.is_some(),
        "a netlist with a diode refines by default"
    );
    let h = plan.options.h;
    let steps = (plan.t_end / h).round() as usize;
    let mut sim = model
        .simulation(plan.execution, plan.options.clone(), model.start())
        .expect("simulation");
    sim.prepare().expect("prepare");
    let (mut checked, mut worst) = (0, 0.0_f64);
    for _ in 0..steps {
        let (t0, q0, p0) = (sim.time(), sim.positions(), sim.momenta());
        let before = sim.summary();
        sim.step().expect("step");
        let after = sim.summary();
        let pieces = after.substeps - before.substeps;
        if after.refinements != before.refinements + 1 || !pieces.is_power_of_two() {
            continue;
        }
        let (_, integrator) = sim.assembled().expect("assembled");
        let options = IntegratorOptions {
            h: h / pieces as f64,
            truncation: None,
            ..plan.options.clone()
        };
        let mut fixed = Integrator::new(
            integrator.model().clone(),
            integrator.constraints().clone(),
            options,
        )
        .expect("integrator");
        fixed.set_state(&q0, &p0, t0).expect("state");
        for _ in 0..pieces {
            fixed.step().expect("piece");
        }
        let (q1, p1) = (sim.positions(), sim.momenta());
        for (a, b) in q1.iter().chain(&p1).zip(fixed.q().iter().chain(fixed.p())) {
            let scale = a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
            worst = worst.max((a - b).abs() / scale.max(1e-12));
        }
        checked += 1;
    }
    println!(
        "rectifier: {checked} refined steps replayed as fixed pieces, worst relative difference {worst:.1e}"
    );
    assert!(checked >= 2, "refined steps found: {checked}");
    assert!(
        worst <= 1e-9,
        "a refined step differs from its pieces by {worst:e}"
    );
}
