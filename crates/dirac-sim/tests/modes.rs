//! Natural modes of linearised models against closed forms, and the method responses the
//! step-size warnings quote (docs/math.md §8).
//!
//! The modal analysis reduces `M s² + D s + K` to the kernel of the constraints, splits off the
//! directions without kinetic term and eliminates the algebraic ones; its eigenvalues must be the
//! exact natural frequencies of circuits and mechanisms whose spectra are known in closed form.
//! Each test names a mutation that makes it fail (run with `cargo test --release -p dirac-sim
//! --test modes` after applying it).

use std::f64::consts::{PI, TAU};

use dirac_components::{
    Capacitor, Ground, Inductor, Mass, Pendulum, Resistor, Spring, VoltageSource,
};
use dirac_graph::{Interconnection, Representation};
use dirac_sim::{
    Discretisation, Execution, IntegratorOptions, MethodResponse, ModeKind, NaturalModes,
    Simulation,
};

/// Relative accuracy of the eigenvalues of these small pencils. Measured: ≤ 2e-16 on the LC tank,
/// seed loop and pendulum, ≤ 8e-15 on the chains, 4.5e-14 on the RC ladder's slowest time
/// constant (7000 steps of h: rounding is relative to the step's scale, so slow modes carry
/// ~ε/(|s|h)); 1e-12 leaves a margin of 20.
const EIGEN_TOL: f64 = 1e-12;

/// A loop of two-terminal parts joined in the order given (node `k` joins part `k`'s `−` end to
/// part `k+1`'s `+` end).
fn series_loop(parts: Vec<dirac_graph::Subsystem>) -> Interconnection {
    let mut g = Interconnection::new();
    let names: Vec<String> = parts.iter().map(|p| p.name().to_string()).collect();
    for p in parts {
        g.add_subsystem(p).expect("part");
    }
    for k in 0..names.len() {
        let next = (k + 1) % names.len();
        let a = g.port(&names[k], "i").expect("port");
        let b = g.port(&names[next], "i").expect("port");
        g.node(format!("n{k}"), vec![(a, 1.0), (b, -1.0)])
            .expect("node");
    }
    g
}

fn modes(graph: Interconnection, representation: Representation, h: f64) -> NaturalModes {
    let mut sim = Simulation::new(
        graph,
        Execution::Assembled(representation),
        IntegratorOptions::new(Discretisation::midpoint(), h),
    );
    sim.natural_modes().unwrap_or_else(|e| panic!("{e}"))
}

fn relative(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// An LC tank (L = 0.75, C = 3, KCL at both nodes, one of them redundant) oscillates with period
/// `2π√(LC)`; adding R = 0.1 gives the damped pair `s = −R/2L ± i√(1/LC − (R/2L)²)` of the seed
/// loop. Mutation: C = 3.003 in the tank moves the period by 5e-4 (fails).
#[test]
fn lc_tank_and_seed_loop_have_their_closed_form_frequencies() {
    let (l, c, r) = (0.75, 3.0, 0.1);
    let tank = series_loop(vec![
        Inductor::new(l).unwrap().subsystem("L1"),
        Capacitor::new(c).unwrap().subsystem("C1"),
    ]);
    let found = modes(tank, Representation::Monolithic, 0.05);
    let oscillations: Vec<_> = found.of_kind(ModeKind::Oscillation).collect();
    assert_eq!(oscillations.len(), 1, "{found:?}");
    assert_eq!(found.fastest(ModeKind::Decay), None);
    let period = oscillations[0].period().expect("oscillation");
    assert!(
        relative(period, TAU * (l * c).sqrt()) < EIGEN_TOL,
        "{period}"
    );
    assert!(relative(oscillations[0].steps(0.05), TAU * 1.5 / 0.05) < EIGEN_TOL);
    assert!(
        oscillations[0].re.abs() < EIGEN_TOL,
        "{:?}",
        oscillations[0]
    );

    let seed = series_loop(vec![
        Capacitor::new(c).unwrap().subsystem("C1"),
        Inductor::new(l).unwrap().subsystem("L1"),
        Resistor::new(r).unwrap().subsystem("R1"),
    ]);
    let found = modes(seed, Representation::Monolithic, 0.05);
    let mode = found.fastest(ModeKind::Oscillation).expect("oscillation");
    let gamma = r / (2.0 * l);
    let omega = (1.0 / (l * c) - gamma * gamma).sqrt();
    assert!(relative(mode.re, -gamma) < EIGEN_TOL, "{mode:?}");
    assert!(relative(mode.im, omega) < EIGEN_TOL, "{mode:?}");
    assert_eq!(found.modes.len(), 1, "{found:?}");
}

/// An RC ladder of N sections (series R, shunt C to ground) driven by a voltage source, open at
/// its far end, has the time constants `τ_k = RC / (4 sin²((2k−1)π/(4N+2)))`, k = 1…N (the
/// Dirichlet–Neumann path Laplacian); the source's own coordinate is algebraic once linearised.
/// Mutation: `D` without `−∂f/∂v` (modes.rs) leaves no decay at all (fails; the seed loop and
/// warning tests fail too).
#[test]
fn rc_ladder_time_constants_are_the_path_laplacian_spectrum() {
    let (r, c, n) = (2.0, 0.5, 6);
    let found = modes(rc_ladder(n, r, c), Representation::Monolithic, 1e-3);
    assert_eq!(found.fastest(ModeKind::Oscillation), None, "{found:?}");
    let mut taus: Vec<f64> = found
        .of_kind(ModeKind::Decay)
        .map(|m| m.time_constant().expect("decay"))
        .collect();
    taus.sort_by(f64::total_cmp);
    let mut exact: Vec<f64> = (1..=n)
        .map(|k| {
            let s = ((2 * k - 1) as f64 * PI / (4 * n + 2) as f64).sin();
            r * c / (4.0 * s * s)
        })
        .collect();
    exact.sort_by(f64::total_cmp);
    assert_eq!(taus.len(), n, "{taus:?}");
    for (t, e) in taus.iter().zip(&exact) {
        assert!(relative(*t, *e) < EIGEN_TOL, "{t} vs {e}");
    }
}

/// A 1 V source driving `n` sections of series `R` (node k−1 to k) and shunt `C` (node k to
/// ground).
fn rc_ladder(n: usize, r: f64, c: f64) -> Interconnection {
    let mut g = Interconnection::new();
    g.add_subsystem(VoltageSource::dc(1.0).unwrap().subsystem("V"))
        .expect("V");
    for k in 1..=n {
        g.add_subsystem(Resistor::new(r).unwrap().subsystem(format!("R{k}")))
            .expect("R");
        g.add_subsystem(Capacitor::new(c).unwrap().subsystem(format!("C{k}")))
            .expect("C");
    }
    let port = |g: &Interconnection, name: String| g.port(&name, "i").expect("port");
    let mut ground = vec![(port(&g, "V".into()), 1.0)];
    for k in 0..=n {
        // Node k: the + end of R(k+1) and C(k) leave it, the − end of R(k) enters it.
        let mut ports = Vec::new();
        if k == 0 {
            ports.push((port(&g, "V".into()), -1.0));
        } else {
            ports.push((port(&g, format!("R{k}")), 1.0));
            ports.push((port(&g, format!("C{k}")), -1.0));
            ground.push((port(&g, format!("C{k}")), 1.0));
        }
        if k < n {
            ports.push((port(&g, format!("R{}", k + 1)), -1.0));
        }
        g.node(format!("n{k}"), ports).expect("node");
    }
    g.node("ground", ground).expect("ground");
    g
}

/// A chain of N masses with springs k between neighbours and to both walls (one ground at 0, a
/// spring coupling from each end mass) vibrates at
/// `ω_j = 2√(k/m) sin(jπ/(2(N+1)))`. In the constraint representation every spring acts on a
/// massless endpoint joined to its mass: the same spectrum after the degenerate directions are
/// eliminated. Mutation: the constraint kernel replaced by the identity (modes.rs `kernel`) fails
/// in the constraint representation (and every constrained test).
#[test]
fn spring_chain_frequencies_in_two_representations() {
    let (m, k, n) = (2.0, 8.0, 7);
    let mut g = Interconnection::new();
    let spring = Spring::linear(k).expect("spring");
    for i in 0..n {
        g.add_subsystem(Mass::new(m).expect("mass").subsystem(format!("M{i}")))
            .expect("mass");
    }
    for i in 1..n {
        let a = g.port(&format!("M{}", i - 1), "x").expect("port");
        let b = g.port(&format!("M{i}"), "x").expect("port");
        g.coupling(format!("k{i}"), a, b, spring);
    }
    g.add_subsystem(Ground::origin().subsystem("wall"))
        .expect("wall");
    let wall = g.port("wall", "x").expect("port");
    for i in [0, n - 1] {
        let a = g.port(&format!("M{i}"), "x").expect("port");
        g.coupling(format!("wall{i}"), a, wall, spring);
    }
    let mut exact: Vec<f64> = (1..=n)
        .map(|j| 2.0 * (k / m).sqrt() * (j as f64 * PI / (2 * (n + 1)) as f64).sin())
        .collect();
    exact.sort_by(f64::total_cmp);
    for representation in [Representation::Monolithic, Representation::Constraint] {
        let found = modes(g.clone(), representation, 0.01);
        let mut omegas: Vec<f64> = found.of_kind(ModeKind::Oscillation).map(|m| m.im).collect();
        omegas.sort_by(f64::total_cmp);
        assert_eq!(omegas.len(), n, "{representation}: {found:?}");
        for (w, e) in omegas.iter().zip(&exact) {
            assert!(relative(*w, *e) < EIGEN_TOL, "{representation}: {w} vs {e}");
        }
    }
}

/// A Cartesian pendulum (position-level constraint `½(x² + y² − ℓ²) = 0`) hanging at rest has
/// `ω = √(g/ℓ)`: all its stiffness comes from the constraint's curvature times the multiplier
/// (the rod tension), none from the Lagrangian. Mutation: leaving out the curvature term
/// (`K` without `Σ λ ∂A/∂q`) leaves no oscillation at all.
#[test]
fn pendulum_frequency_comes_from_the_constraint_curvature() {
    let pendulum = Pendulum::new(0.7, 1.3, 9.81, [0.0, 0.0]).expect("pendulum");
    let mut g = Interconnection::new();
    g.add_subsystem(pendulum.subsystem("P")).expect("pendulum");
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), 0.01),
    );
    sim.set_position("P", "y", -1.3).expect("y");
    let found = sim.natural_modes().unwrap_or_else(|e| panic!("{e}"));
    let mode = found.fastest(ModeKind::Oscillation).expect("swing");
    assert!(
        relative(mode.im, (9.81_f64 / 1.3).sqrt()) < EIGEN_TOL,
        "{mode:?}"
    );
    assert_eq!(found.modes.len(), 1, "{found:?}");
}

/// The midpoint rule advances an oscillation by `θ = 2 atan(ωh/2)` per step (MATH §6), and damps
/// a first-order mode `τq̇ + q = 0` by `R = (1 − h/2τ)/(1 + h/2τ)`; Gauss with two nodes damps it
/// by the (2,2) Padé approximant of `e^{−h/τ}`, which tends to +1 for fast modes. The probes
/// run the integrator itself, so they reproduce these closed forms to round-off. Mutation: the
/// probe's oscillator with `k = 1.001 ω²` fails the phase check.
#[test]
fn method_responses_are_the_closed_form_stability_functions() {
    const RESPONSE_TOL: f64 = 1e-12; // linear steps solved by LU: round-off only
    for wh in [0.1, 1.0, 3.0, 30.0] {
        let options = IntegratorOptions::new(Discretisation::midpoint(), 0.5);
        let omega = wh / 0.5;
        match MethodResponse::oscillation(&options, omega) {
            MethodResponse::Phase { frequency_error } => {
                let exact = 2.0 * (wh / 2.0).atan() / wh - 1.0;
                assert!(
                    (frequency_error - exact).abs() < RESPONSE_TOL,
                    "{wh}: {frequency_error} vs {exact}"
                );
            }
            other => panic!("{wh}: {other:?}"),
        }
    }
    for x in [0.01, 1.0, 10.0, 1e4] {
        let h = 0.2;
        let tau = h / x;
        let midpoint = IntegratorOptions::new(Discretisation::midpoint(), h);
        let r = MethodResponse::decay(&midpoint, tau).expect("probe");
        let exact = (1.0 - x / 2.0) / (1.0 + x / 2.0);
        assert!(
            (r - exact).abs() < RESPONSE_TOL,
            "midpoint {x}: {r} vs {exact}"
        );
        let gauss = IntegratorOptions::new(Discretisation::gauss(2), h);
        let r = MethodResponse::decay(&gauss, tau).expect("probe");
        let z = -x;
        let pade = (1.0 + z / 2.0 + z * z / 12.0) / (1.0 - z / 2.0 + z * z / 12.0);
        assert!((r - pade).abs() < RESPONSE_TOL, "gauss2 {x}: {r} vs {pade}");
    }
}

/// `dirac run`'s warnings: an LC tank stepped with 5 steps per period gets the phase warning
/// (and not with 50); an RC ladder stepped with h far above its fastest time constant gets the
/// ringing warning under the midpoint rule (and not with h below it). Mutation:
/// `MIN_STEPS_PER_PERIOD` = 4 silences the first case.
#[test]
fn warnings_fire_exactly_for_under_resolved_modes() {
    let (l, c): (f64, f64) = (0.75, 3.0);
    let period = TAU * (l * c).sqrt();
    let tank = || {
        series_loop(vec![
            Inductor::new(l).unwrap().subsystem("L1"),
            Capacitor::new(c).unwrap().subsystem("C1"),
        ])
    };
    for (steps, warned) in [(5.0, true), (50.0, false)] {
        let h = period / steps;
        let found = modes(tank(), Representation::Monolithic, h);
        let warnings = found.warnings(&IntegratorOptions::new(Discretisation::midpoint(), h));
        assert_eq!(warnings.len(), usize::from(warned), "{warnings:?}");
        if warned {
            assert!(warnings[0].contains("no blow-up"), "{}", warnings[0]);
            assert!(warnings[0].contains("phase"), "{}", warnings[0]);
        }
    }
    let (r, c) = (1.0, 1e-3);
    let fastest = {
        let s = (5.0 * PI / 14.0).sin();
        r * c / (4.0 * s * s)
    };
    for (h, warned) in [(100.0 * fastest, true), (0.1 * fastest, false)] {
        let found = modes(rc_ladder(3, r, c), Representation::Monolithic, h);
        let warnings = found.warnings(&IntegratorOptions::new(Discretisation::midpoint(), h));
        assert_eq!(warnings.len(), usize::from(warned), "{warnings:?}");
        if warned {
            assert!(warnings[0].contains("rings"), "{}", warnings[0]);
        }
    }
    // The trapezoid rule amplifies a decay it under-resolves: the warning says the run blows up
    // (it once read "damps it only by -99.000 per step … for about inf steps").
    let h = 100.0 * fastest;
    let trapezoid = IntegratorOptions::new(Discretisation::trapezoid(), h);
    let factor = MethodResponse::decay(&trapezoid, fastest).expect("probe");
    assert!(factor.abs() > 1.0, "{factor}");
    let found = modes(rc_ladder(3, r, c), Representation::Monolithic, h);
    let warnings = found.warnings(&trapezoid);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("amplifies") && warnings[0].contains("blow up"),
        "{}",
        warnings[0]
    );
}
