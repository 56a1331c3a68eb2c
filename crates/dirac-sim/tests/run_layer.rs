//! The run layer on circuits with exact solutions: values at `t_k` from the algebraic relations.

use dirac_components::{Capacitor, Inductor, Resistor};
use dirac_graph::{Interconnection, Representation};
use dirac_problems::{RlcLoop, rlc_exact};
use dirac_sim::{Discretisation, Execution, IntegratorOptions, Probe, Signal, Simulation};

/// A two-terminal part from `plus` to `minus`: the port signs in each node (the branch flow
/// leaves its `+` node and enters its `−` node).
fn wire(g: &mut Interconnection, nodes: &[(&str, &[(&str, f64)])]) {
    for (name, ports) in nodes {
        let ports = ports
            .iter()
            .map(|(part, sign)| (g.port(part, "i").expect("port"), *sign))
            .collect();
        g.node(*name, ports).expect("node");
    }
}

/// The seed RLC loop as parts: C1 from 1 to 0, L1 from 1 to 2, R1 from 2 to 0.
fn seed() -> Interconnection {
    let rlc = RlcLoop::seed();
    let mut g = Interconnection::new();
    g.add_subsystem(Capacitor::new(rlc.c).unwrap().subsystem("C1"))
        .expect("C1");
    g.add_subsystem(Inductor::new(rlc.l).unwrap().subsystem("L1"))
        .expect("L1");
    g.add_subsystem(Resistor::new(rlc.r).unwrap().subsystem("R1"))
        .expect("R1");
    wire(
        &mut g,
        &[
            ("1", &[("C1", -1.0), ("L1", -1.0)]),
            ("2", &[("L1", 1.0), ("R1", -1.0)]),
        ],
    );
    g
}

/// `i_L = −q̇_C` of the exact solution.
fn exact_current(rlc: &RlcLoop, q0: f64, t: f64) -> f64 {
    let gamma = rlc.r / (2.0 * rlc.l);
    let w = (1.0 / (rlc.l * rlc.c) - gamma * gamma).sqrt();
    q0 * (w * w + gamma * gamma) / w * (-gamma * t).exp() * (w * t).sin()
}

fn signals(g: &Interconnection) -> Vec<Signal> {
    vec![
        Signal::new("q(c1)", Probe::position(g, "C1", "q").expect("q")),
        Signal::new("i(l1)", Probe::flow(g, "L1", "i").expect("i")),
        Signal::new("v(1)", Probe::effort(g, "1").expect("v1")),
        Signal::new("v(2)", Probe::effort(g, "2").expect("v2")),
    ]
}

/// Row 0 is the initial state exactly (charge 3, no current, v(1) = q/C = 1, v(2) = R·i = 0);
/// at every t_k the readouts satisfy the circuit's algebraic relations to round-off
/// (v(1) = q_C/C, v(2) = R·i_L); the inductor current converges to the exact one at order 2
/// (midpoint) and 4 (Gauss 2), measured at the output times themselves.
#[test]
fn seed_loop_readouts_are_the_state_at_each_output_time() {
    let rlc = RlcLoop::seed();
    let q0 = 3.0;
    let mut errors = Vec::new();
    for (d, hs) in [
        (Discretisation::midpoint(), [0.05, 0.025]),
        (Discretisation::gauss(2), [0.2, 0.1]),
    ] {
        let mut e = Vec::new();
        for h in hs {
            let g = seed();
            let mut sim = Simulation::new(
                g.clone(),
                Execution::Assembled(Representation::Monolithic),
                IntegratorOptions::new(d.clone(), h),
            );
            sim.set_position("C1", "q", q0).expect("C1.q");
            let (run, summary) = sim.run(10.0, &signals(&g)).expect("runs");
            assert_eq!(run.row(0), [q0, 0.0, 1.0, 0.0]);
            let mut worst: f64 = 0.0;
            for (k, &t) in run.t().iter().enumerate() {
                let r = run.row(k);
                assert!(
                    (r[2] - r[0] / rlc.c).abs() <= 1e-14,
                    "v(1) = q/C at t = {t}"
                );
                assert!(
                    (r[3] - rlc.r * r[1]).abs() <= 1e-15,
                    "v(2) = R i at t = {t}"
                );
                worst = worst.max((r[1] - exact_current(&rlc, q0, t)).abs());
                let _ = rlc_exact(&rlc, q0, t);
            }
            println!("{d} h = {h}: max |i_L − exact| = {worst:.3e}; {summary:?}");
            e.push(worst);
        }
        errors.push(e[0] / e[1]);
    }
    println!("error ratios under halving: {errors:?}");
    assert!(
        (errors[0] - 4.0).abs() < 0.2,
        "midpoint ratio {}",
        errors[0]
    );
    assert!((errors[1] - 16.0).abs() < 1.5, "gauss2 ratio {}", errors[1]);
}

use dirac_components::{CurrentSource, VoltageSource, Waveform};
use dirac_sim::{RunError, Start};

/// A 1 V source directly across a 1 µF capacitor, no initial charge given, with a 1 kΩ load:
/// the start is repaired to q = C·V (with a warning naming the charge), the run does not ring
/// (q stays at C·V to round-off), the node reads the source's value, and the source current (an
/// index-2 quantity here: C·dV/dt plus the load) reads −V/R.
#[test]
fn source_across_capacitor_starts_consistent_and_does_not_ring() {
    let mut g = Interconnection::new();
    g.add_subsystem(VoltageSource::dc(1.0).unwrap().subsystem("V1"))
        .expect("V1");
    g.add_subsystem(Capacitor::new(1e-6).unwrap().subsystem("C1"))
        .expect("C1");
    g.add_subsystem(Resistor::new(1e3).unwrap().subsystem("R1"))
        .expect("R1");
    wire(
        &mut g,
        &[("in", &[("V1", -1.0), ("C1", -1.0), ("R1", -1.0)])],
    );
    let signals = vec![
        Signal::new("q(c1)", Probe::position(&g, "C1", "q").expect("q")),
        Signal::new("v(in)", Probe::effort(&g, "in").expect("v")),
        Signal::new("i(v1)", Probe::flow(&g, "V1", "i").expect("i")),
    ];
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), 1e-5),
    );
    let (run, _) = sim.run(1e-3, &signals).expect("runs");
    println!("warnings: {:?}", sim.warnings());
    assert_eq!(sim.warnings().len(), 1, "{:?}", sim.warnings());
    assert!(
        sim.warnings()[0].contains("C1.q = 0"),
        "{:?}",
        sim.warnings()
    );
    for k in 0..run.len() {
        let r = run.row(k);
        assert!((r[0] - 1e-6).abs() <= 1e-20, "row {k}: q = {}", r[0]);
        assert!((r[1] - 1.0).abs() <= 1e-15, "row {k}: v = {}", r[1]);
        assert!((r[2] + 1e-3).abs() <= 1e-15, "row {k}: i = {}", r[2]);
    }
}

/// Two capacitors in parallel with different initial charges (both given): contradictory, and
/// the error names both charges.
#[test]
fn parallel_capacitors_with_different_charges_are_contradictory() {
    let mut g = Interconnection::new();
    g.add_subsystem(Capacitor::new(1.0).unwrap().subsystem("C1"))
        .expect("C1");
    g.add_subsystem(Capacitor::new(1.0).unwrap().subsystem("C2"))
        .expect("C2");
    wire(&mut g, &[("a", &[("C1", -1.0), ("C2", -1.0)])]);
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), 0.1),
    );
    sim.set_position("C1", "q", 1.0).expect("q1");
    sim.set_position("C2", "q", 2.0).expect("q2");
    let err = sim.prepare().expect_err("contradictory");
    println!("{err}");
    assert!(matches!(err, RunError::ContradictoryStart(_)), "{err:?}");
    let text = err.to_string();
    assert!(text.contains("C1.q") && text.contains("C2.q"), "{text}");
}

/// Operating point of a current divider: 1 mA into R1 = 1 kΩ ∥ R2 = 3 kΩ gives 0.75 V, branch
/// currents 0.75 mA and 0.25 mA; with a capacitor in parallel the capacitor is open and charged
/// to 0.75 V (q = 0.75 µC) and the transient starts at rest (no drift over the run).
#[test]
fn steady_state_of_a_current_divider() {
    let mut g = Interconnection::new();
    g.add_subsystem(CurrentSource::dc(1e-3).unwrap().subsystem("I1"))
        .expect("I1");
    g.add_subsystem(Resistor::new(1e3).unwrap().subsystem("R1"))
        .expect("R1");
    g.add_subsystem(Resistor::new(3e3).unwrap().subsystem("R2"))
        .expect("R2");
    g.add_subsystem(Capacitor::new(1e-6).unwrap().subsystem("C1"))
        .expect("C1");
    // I n+ n−: current leaves through its − terminal; here I1 from 0 to a pushes 1 mA into a.
    wire(
        &mut g,
        &[(
            "a",
            &[("I1", 1.0), ("R1", -1.0), ("R2", -1.0), ("C1", -1.0)],
        )],
    );
    let signals = vec![
        Signal::new("v(a)", Probe::effort(&g, "a").expect("v")),
        Signal::new("i(r1)", Probe::flow(&g, "R1", "i").expect("i")),
        Signal::new("i(r2)", Probe::flow(&g, "R2", "i").expect("i")),
        Signal::new("q(c1)", Probe::position(&g, "C1", "q").expect("q")),
    ];
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), 1e-4),
    )
    .start(Start::SteadyState);
    let (run, _) = sim.run(1e-2, &signals).expect("runs");
    for k in 0..run.len() {
        let r = run.row(k);
        assert!((r[0] - 0.75).abs() <= 1e-12, "row {k}: v = {}", r[0]);
        assert!((r[1] - 0.75e-3).abs() <= 1e-15, "row {k}: i1 = {}", r[1]);
        assert!((r[2] - 0.25e-3).abs() <= 1e-15, "row {k}: i2 = {}", r[2]);
        assert!((r[3] - 0.75e-6).abs() <= 1e-18, "row {k}: q = {}", r[3]);
    }
}

/// A node joined only through capacitors has no DC path: the steady state is refused, naming it.
#[test]
fn floating_node_has_no_dc_path() {
    let mut g = Interconnection::new();
    g.add_subsystem(
        VoltageSource::new(Waveform::Dc(1.0))
            .unwrap()
            .subsystem("V1"),
    )
    .expect("V1");
    g.add_subsystem(Capacitor::new(1e-6).unwrap().subsystem("C1"))
        .expect("C1");
    g.add_subsystem(Capacitor::new(1e-6).unwrap().subsystem("C2"))
        .expect("C2");
    wire(
        &mut g,
        &[
            ("in", &[("V1", -1.0), ("C1", -1.0)]),
            ("mid", &[("C1", 1.0), ("C2", -1.0)]),
        ],
    );
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), 1e-4),
    )
    .start(Start::SteadyState);
    let err = sim.prepare().expect_err("no DC path");
    println!("{err}");
    assert!(err.to_string().contains("node `mid`"), "{err}");
    assert!(!err.is_numerical());
}

/// Set-up does only what the run needs (audit item 15). On the seed loop started from a given
/// charge the readout system has no redundant equation, so there is nothing to check at the start
/// (its structural analysis says so, and is kept with the graph): a run that records only the
/// capacitor charge never solves a readout (no readout iterations), while one that records a node
/// potential does, with row 0 the initial state exactly. Later simulations of clones of the same
/// graph find the analysis there instead of storing another, and record the same rows bit for bit.
/// Mutations: building the readout and solving the start check eagerly (as before) gives readout
/// iterations on the charge-only run; skipping the memo lookup stores a second analysis.
#[test]
fn readout_is_built_only_when_needed_and_its_analysis_is_kept_with_the_graph() {
    let g = seed();
    let run = |signals: &[Signal]| {
        let mut sim = Simulation::new(
            g.clone(),
            Execution::Assembled(Representation::Monolithic),
            IntegratorOptions::new(Discretisation::midpoint(), 0.05),
        );
        sim.set_position("C1", "q", 3.0).expect("C1.q");
        sim.run(1.0, signals).expect("runs")
    };
    let charge = [Signal::new(
        "q(c1)",
        Probe::position(&g, "C1", "q").expect("q"),
    )];
    let (_, summary) = run(&charge);
    assert_eq!(summary.readout_iterations, 0, "no signal needs a readout");
    assert_eq!(g.memo().len(), 1, "the analysis is stored with the graph");
    let (first, summary) = run(&signals(&g));
    assert!(summary.readout_iterations > 0);
    assert_eq!(first.row(0), [3.0, 0.0, 1.0, 0.0]);
    assert_eq!(g.memo().len(), 1, "and found there by the second run");
    let (second, _) = run(&signals(&g));
    assert_eq!(g.memo().len(), 1, "and by the third");
    for k in 0..first.len() {
        assert_eq!(first.row(k), second.row(k), "row {k}");
    }
}

/// A model without constraints and with a kinetic term in every coordinate (a damped oscillator)
/// has readout equations that match one to one, so a given start has nothing to check and set-up
/// does not even analyse their structure (the graph's memo stays empty); the velocity read at
/// t_0 is the given one, and a later run that records it gets the same rows as the first.
/// Mutation: dropping the `fully_kinetic` shortcut stores an analysis in the memo.
#[test]
fn fully_kinetic_model_needs_no_readout_analysis_at_the_start() {
    let mut g = Interconnection::new();
    g.add_subsystem(dirac_graph::Subsystem::new(
        "P",
        dirac_problems::DampedOscillator {
            m: 2.0,
            k: 1.0,
            c: 0.1,
        },
    ))
    .expect("P");
    let run = |signals: &[Signal]| {
        let mut sim = Simulation::new(
            g.clone(),
            Execution::Assembled(Representation::Monolithic),
            IntegratorOptions::new(Discretisation::gauss(2), 0.1),
        );
        sim.set_position("P", "q0", 1.0).expect("q");
        sim.set_velocity("P", "q0", 0.5).expect("v");
        sim.run(1.0, signals).expect("runs")
    };
    let position = [Signal::new("x", Probe::position(&g, "P", "q0").expect("x"))];
    let (_, summary) = run(&position);
    assert_eq!(summary.readout_iterations, 0);
    assert!(g.memo().is_empty(), "no structural analysis");
    let both = [
        position[0].clone(),
        Signal::new("v", Probe::velocity(&g, "P", "q0").expect("v")),
    ];
    let (first, _) = run(&both);
    assert_eq!(first.row(0), [1.0, 0.5]);
    let (second, _) = run(&both);
    for k in 0..first.len() {
        assert_eq!(first.row(k), second.row(k), "row {k}");
    }
}

use dirac_components::{Mass, Spring};

/// Two free masses `m_A = 1`, `m_B = 3` joined by a spring `k = 2`: the spring's forces are
/// equal and opposite, so the total momentum `p_A + p_B` is conserved by the discrete map to
/// round-off (a variational integrator inherits Noether's theorem for translations), while each
/// momentum swings. Row 0 is the initial state exactly: `p_A = 0`, `p_B = m_B·v_B = 1.5`.
///
/// Mutation: reading `v` instead of `p` in `Probe::Momentum` fails at row 0 (tests/mutations.md
/// M27).
#[test]
fn momentum_probe_conserves_the_total_momentum_of_a_free_pair() {
    // 2000 steps of round-off in a sum of size ~1.5: a few ulps per step at most.
    const CONSERVATION_TOL: f64 = 1e-12;
    let mut g = Interconnection::new();
    g.add_subsystem(Mass::new(1.0).unwrap().subsystem("A"))
        .expect("A");
    g.add_subsystem(Mass::new(3.0).unwrap().subsystem("B"))
        .expect("B");
    let (a, b) = (
        g.port("A", "x").expect("A.x"),
        g.port("B", "x").expect("B.x"),
    );
    g.coupling("spring", a, b, Spring::linear(2.0).unwrap());
    let (pa, pb) = (
        Probe::momentum(&g, "A", "x").expect("p_A"),
        Probe::momentum(&g, "B", "x").expect("p_B"),
    );
    let signals = [
        Signal::new("p_A", pa.clone()),
        Signal::new("p_B", pb.clone()),
        Signal::new("P", Probe::Sum(vec![(pa, 1.0), (pb, 1.0)])),
    ];
    let mut sim = Simulation::new(
        g,
        Representation::Monolithic,
        IntegratorOptions::new(Discretisation::midpoint(), 0.01),
    );
    sim.set_position("A", "x", 1.0).expect("A.x");
    sim.set_velocity("B", "x", 0.5).expect("B.x'");
    let (run, _) = sim.run(20.0, &signals).expect("runs");
    assert_eq!(run.row(0), [0.0, 1.5, 1.5]);
    let p_a = run.signal("p_A").expect("p_A");
    let swing = p_a.iter().fold(0.0_f64, |m, p| m.max(p.abs()));
    assert!(swing > 0.5, "p_A should swing, max |p_A| = {swing}");
    for (k, total) in run.signal("P").expect("P").iter().enumerate() {
        assert!(
            (total - 1.5).abs() <= CONSERVATION_TOL,
            "row {k}: p_A + p_B = {total}, drift {:e}",
            total - 1.5
        );
    }
}

/// `Probe::Norm` is the Euclidean length of its terms: a point at (3, 4, 12) is 13 from the
/// origin (a Pythagorean quadruple: exact in floating point), and lengths near `f64::MAX` do not
/// overflow (hypot, not `√(x² + y²)`).
///
/// Mutation: summing the terms instead (`r + x`) gives 11 and fails (tests/mutations.md M28).
#[test]
fn norm_probe_is_the_euclidean_length() {
    let mut g = Interconnection::new();
    for name in ["X", "Y", "Z"] {
        g.add_subsystem(Mass::new(1.0).unwrap().subsystem(name))
            .expect("part");
    }
    let offsets = g.coordinate_offsets();
    let position = |part| Probe::position(&g, part, "x").expect("x");
    let norm = Probe::Norm(vec![position("X"), position("Y"), position("Z")]);
    let mut snapshot = dirac_sim::Snapshot {
        q: vec![3.0, -4.0, 12.0],
        ..dirac_sim::Snapshot::default()
    };
    assert_eq!(snapshot.evaluate(&g, &offsets, &norm), 13.0);
    snapshot.q = vec![3e307, 4e307, 0.0];
    let big = snapshot.evaluate(&g, &offsets, &norm);
    assert!((big / 5e307 - 1.0).abs() <= f64::EPSILON, "{big}");
}
