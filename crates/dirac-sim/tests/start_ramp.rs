//! The start ramp (`IntegratorOptions::start_ramp`): the first step taken as geometrically
//! growing substeps, so that the stiff modes of an initial state off the slow manifold are
//! damped instead of ringing through the run (midpoint and Gauss steps are A-stable but not
//! L-stable). Checked against the exact solution of a stiff RC ladder, against the midpoint
//! recursion written out by hand on a driven RC, and for the output grid and the run counters.

mod common;

use dirac_components::{Capacitor, Resistor, Waveform};
use dirac_graph::{Interconnection, Representation};
use dirac_sim::{
    Discretisation, Execution, IntegratorOptions, Probe, RunSummary, Signal, Simulation, StartRamp,
    Trajectory,
};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Resistances and capacitances of the stiff ladder: `R_i = C_i = 10^{−(i−1)}`, time constants
/// from about 1 s down to about 1e-6 s (|λ| h from 1e-2 to 2e4 at h = 0.01).
fn ladder_values(n: usize) -> (Vec<f64>, Vec<f64>) {
    let r: Vec<f64> = (0..n).map(|i| 10f64.powi(-(i as i32))).collect();
    (r.clone(), r)
}

/// The ladder of `n` sections: `R_1` from ground to node 1 (a shorted source: the model is then
/// autonomous, which the affine map needs), `R_{i+1}` from node i to node i + 1, `C_i` from node
/// i to ground. Signals: the capacitor charges.
fn ladder(n: usize) -> (Interconnection, Vec<Signal>) {
    let (r, c) = ladder_values(n);
    let mut g = Interconnection::new();
    for i in 0..n {
        g.add_subsystem(Resistor::new(r[i]).unwrap().subsystem(format!("R{i}")))
            .unwrap();
        g.add_subsystem(Capacitor::new(c[i]).unwrap().subsystem(format!("C{i}")))
            .unwrap();
    }
    let port = |g: &Interconnection, p: &str| g.port(p, "i").unwrap();
    for i in 0..n {
        let mut ends = vec![
            (port(&g, &format!("R{i}")), 1.0),
            (port(&g, &format!("C{i}")), -1.0),
        ];
        if i + 1 < n {
            ends.push((port(&g, &format!("R{}", i + 1)), -1.0));
        }
        g.node(format!("n{}", i + 1), ends).unwrap();
    }
    let signals = (0..n)
        .map(|i| {
            Signal::new(
                format!("q{i}"),
                Probe::position(&g, &format!("C{i}"), "q").unwrap(),
            )
        })
        .collect();
    (g, signals)
}

/// Runs the ladder from `v_C,i(0) = i + 1` to `t_end`; returns the trajectory of the charges, the
/// capacitor voltages at `t_end` and the run summary.
fn run_ladder(
    n: usize,
    options: IntegratorOptions,
    t_end: f64,
) -> (Trajectory, Vec<f64>, RunSummary) {
    let (g, signals) = ladder(n);
    let (_, c) = ladder_values(n);
    let mut sim = Simulation::new(g, Execution::Assembled(Representation::Monolithic), options);
    for (i, ci) in c.iter().enumerate() {
        sim.set_position(&format!("C{i}"), "q", ci * (i + 1) as f64)
            .unwrap();
    }
    let (trajectory, summary) = sim.run(t_end, &signals).unwrap();
    let last = trajectory.len() - 1;
    let v = trajectory
        .row(last)
        .iter()
        .zip(&c)
        .map(|(q, ci)| q / ci)
        .collect();
    (trajectory, v, summary)
}

/// The exact solution `v(t) = C^{−1/2} V e^{−Λt} Vᵀ C^{1/2} v(0)` of `C v̇ = −G v` by the
/// eigen-decomposition `S = C^{−1/2} G C^{−1/2} = V Λ Vᵀ` (symmetric positive definite), with
/// the modal amplitudes `Vᵀ C^{1/2} v(0)`, the eigenvalues and the matrix `C^{−1/2} V` that maps
/// modal errors back to voltages.
struct Exact {
    v: Vec<f64>,
    amplitudes: Vec<f64>,
    lambdas: Vec<f64>,
    to_voltages: DMatrix<f64>,
}

fn exact(n: usize, t: f64) -> Exact {
    let (r, c) = ladder_values(n);
    // Conductances: R_1 from the grounded source to node 1, R_{i+1} between nodes i and i + 1.
    let mut g = DMatrix::<f64>::zeros(n, n);
    g[(0, 0)] = 1.0 / r[0];
    for i in 0..n {
        if i + 1 < n {
            let gi = 1.0 / r[i + 1];
            g[(i, i)] += gi;
            g[(i + 1, i + 1)] += gi;
            g[(i, i + 1)] -= gi;
            g[(i + 1, i)] -= gi;
        }
    }
    let s = DMatrix::from_fn(n, n, |i, j| g[(i, j)] / (c[i] * c[j]).sqrt());
    let eigen = SymmetricEigen::new(s);
    let w0 = DVector::from_fn(n, |i, _| c[i].sqrt() * (i + 1) as f64);
    let amplitudes = eigen.eigenvectors.transpose() * w0;
    let decayed = DVector::from_fn(n, |j, _| amplitudes[j] * (-eigen.eigenvalues[j] * t).exp());
    let to_voltages = DMatrix::from_fn(n, n, |i, j| eigen.eigenvectors[(i, j)] / c[i].sqrt());
    let v = &to_voltages * decayed;
    Exact {
        v: v.iter().copied().collect(),
        amplitudes: amplitudes.iter().copied().collect(),
        lambdas: eigen.eigenvalues.iter().copied().collect(),
        to_voltages,
    }
}

fn max_gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Error constant of the s-stage Gauss method on `y' = λy`: `R(z) − e^z ≈ c z^{2s+1}` with
/// `c = (s!)² / ((2s)! (2s + 1)!)` (1/12 for the midpoint rule).
fn error_constant(s: usize) -> f64 {
    let f = |k: usize| (1..=k).map(|x| x as f64).product::<f64>();
    f(s).powi(2) / (f(2 * s) * f(2 * s + 1))
}

/// A stiff RC ladder (time constants ~1 s to ~1e-6 s) started with `v_C,i(0) = i`, far from
/// its slow manifold, to t = 1 at h = 0.01. Without the ramp the midpoint and Gauss 2 steps
/// leave the fastest mode ringing (`|R(λh)| ≈ 1 − 4/(|λ|h)` per step, still above 0.9 after
/// 100 steps): an O(1) error. With the default ramp the error is the truncation error of the
/// resolved modes (`t |λ|^{2s+1} h^{2s} c_s` per unit amplitude, leading order, doubled) plus
/// the ramp's damping bound (1e-8 per unit amplitude, docs/math.md) on the others.
#[test]
fn ramp_damps_the_stiff_start_to_the_truncation_error() {
    let (n, h, t_end) = (4, 0.01, 1.0);
    let reference = exact(n, t_end);
    for s in [1, 2] {
        let discretisation = if s == 1 {
            Discretisation::midpoint()
        } else {
            Discretisation::gauss(s)
        };
        let options = IntegratorOptions::new(discretisation, h);
        let (_, plain, _) = run_ladder(n, options.clone(), t_end);
        let (_, ramped, summary) =
            run_ladder(n, options.start_ramp(Some(StartRamp::default())), t_end);
        // Modal error bound: resolved modes (|λ|h ≤ 0.1) by the leading truncation term, the
        // others by the ramp's damping bound (their exact value at t = 1 is below e^{−10}·|a|).
        let modal: Vec<f64> = reference
            .lambdas
            .iter()
            .zip(&reference.amplitudes)
            .map(|(&l, a)| {
                let truncation = 2.0
                    * t_end
                    * l.powi(2 * s as i32 + 1)
                    * h.powi(2 * s as i32)
                    * error_constant(s)
                    * (-l * t_end).exp();
                if l * h <= 0.1 {
                    a.abs() * truncation
                } else {
                    a.abs() * 1e-8
                }
            })
            .collect();
        let tolerance = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| reference.to_voltages[(i, j)].abs() * modal[j])
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        let (e_plain, e_ramped) = (
            max_gap(&plain, &reference.v),
            max_gap(&ramped, &reference.v),
        );
        println!(
            "gauss{s}: error at t = 1 without ramp {e_plain:.3e}, with ramp {e_ramped:.3e} (tolerance {tolerance:.3e}; {} ramp substeps; λ {:?})",
            summary.ramp_substeps, reference.lambdas
        );
        assert!(
            e_plain > 0.1,
            "gauss{s}: the control must ring: {e_plain:e}"
        );
        assert!(
            e_ramped <= tolerance,
            "gauss{s}: {e_ramped:e} > {tolerance:e}"
        );
    }
}

/// The ramp changes neither the number of rows nor their times (`t_k = t₀ + k h` exactly), and
/// the run counters report its substeps: `per_level · (levels + 1)`.
#[test]
fn ramp_keeps_the_grid_and_is_counted() {
    let (n, h, t_end) = (3, 0.01, 0.5);
    let options = IntegratorOptions::new(Discretisation::midpoint(), h);
    let (plain, _, plain_summary) = run_ladder(n, options.clone(), t_end);
    for ramp in [
        StartRamp::default(),
        StartRamp {
            levels: 4,
            per_level: 2,
        },
    ] {
        let (ramped, _, summary) = run_ladder(n, options.clone().start_ramp(Some(ramp)), t_end);
        assert_eq!(ramped.t(), plain.t(), "the grid must not move");
        assert_eq!(summary.steps, plain_summary.steps);
        assert_eq!(summary.ramp_substeps, ramp.substeps());
        assert_eq!(
            ramp.substeps(),
            (ramp.per_level * (ramp.levels + 1)) as usize
        );
        let total: f64 = (0..ramp.substeps()).map(|j| ramp.fraction(j)).sum();
        assert!((total - 1.0).abs() <= 1e-15, "fractions sum to {total}");
    }
    assert_eq!(plain_summary.ramp_substeps, 0);
    assert_eq!(StartRamp::default().substeps(), 99);
    // Levels are taken between 1 and MAX_LEVELS: no substep of size 0.
    let deep = StartRamp {
        levels: 4000,
        per_level: 1,
    };
    assert_eq!(deep.substeps(), StartRamp::MAX_LEVELS as usize + 1);
    assert!((0..deep.substeps()).all(|j| deep.fraction(j) > 0.0));
}

/// One midpoint step of size `d` of the series RC driven by `wave` from `(q, t)`, in place:
/// `(q₊ − q)/d = (v − (q + q₊)/(2C))/R`, so `q₊ = (q (1 − a) + d v / R)/(1 + a)` with
/// `a = d/(2RC)` and `v` the source at `t + d/2`. Returns the step's power-balance residual
/// `|E(q₊) − E(q) − d (v − R ī) ī|` (`E = q²/2C`, `ī = (q₊ − q)/d`).
fn rc_midpoint_substep(wave: &Waveform, r: f64, c: f64, q: &mut f64, t: &mut f64, d: f64) -> f64 {
    let energy = |q: f64| q * q / (2.0 * c);
    let v = wave.value(*t + 0.5 * d);
    let a = d / (2.0 * r * c);
    let next = (*q * (1.0 - a) + d * v / r) / (1.0 + a);
    let i = (next - *q) / d;
    let balance = energy(next) - energy(*q) - d * (v - r * i) * i;
    *q = next;
    *t += d;
    balance.abs()
}

/// Each ramp substep is an ordinary midpoint step of its own size, so the discrete power
/// balance `E(q₊) − E(q) = δ (V(t + δ/2) − R ī) ī` (ī = (q₊ − q)/δ) holds on every substep and,
/// summed, over the ramped first step. A sine-driven series RC with the ramp must equal the
/// midpoint recursion written out by hand over the ramp's substeps to round-off; the per-substep
/// power balance of that recursion is checked too.
#[test]
fn ramp_substeps_are_midpoint_steps_and_balance_power() {
    let (r, c, h) = (1e-3, 1.0, 0.1);
    let wave = Waveform::sin(0.0, 1.0, 1.0);
    let (g, signals) = common::source_rc(wave.clone(), r, c);
    let ramp = StartRamp::default();
    let q0 = 2.0;
    let mut sim = Simulation::new(
        g,
        Execution::Assembled(Representation::Monolithic),
        IntegratorOptions::new(Discretisation::midpoint(), h).start_ramp(Some(ramp)),
    );
    sim.set_position("C", "q", q0).unwrap();
    let (trajectory, summary) = sim.run(1.0, &signals).unwrap();
    let run = trajectory.column(0);
    // The hand recursion: the ramp's substeps, then steps of h.
    let mut q = q0;
    let mut t = 0.0;
    let mut expected = vec![q];
    let mut worst_balance: f64 = 0.0;
    let mut substep = |q: &mut f64, t: &mut f64, d: f64| {
        let balance = rc_midpoint_substep(&wave, r, c, q, t, d);
        worst_balance = worst_balance.max(balance / (q0 * q0 / (2.0 * c)));
    };
    for j in 0..ramp.substeps() {
        substep(&mut q, &mut t, ramp.fraction(j) * h);
    }
    expected.push(q);
    for k in 1..10 {
        t = k as f64 * h;
        substep(&mut q, &mut t, h);
        expected.push(q);
    }
    let gap = max_gap(&run, &expected);
    println!(
        "driven RC with ramp: {gap:.2e} from the hand recursion, power balance per substep {worst_balance:.2e} ({} ramp substeps)",
        summary.ramp_substeps
    );
    assert!(gap <= 1e-14 * q0, "{run:?}\n{expected:?}");
    assert!(worst_balance <= 1e-13, "power balance {worst_balance:e}");
}

/// The opt-in affine map and the ramp combine: the ramp's substeps on Newton, the regular steps
/// on the map. An RC ladder under a DC source (autonomous, linear) gives the same voltages either
/// way to round-off, and the mapped run does Newton iterations only for the ramp and the map's
/// set-up.
#[test]
fn ramp_combines_with_the_affine_map() {
    let (n, h, t_end) = (3, 0.01, 1.0);
    let ramped = IntegratorOptions::new(Discretisation::midpoint(), h)
        .start_ramp(Some(StartRamp::default()));
    let (_, newton, newton_summary) = run_ladder(n, ramped.clone(), t_end);
    let (_, mapped, mapped_summary) = run_ladder(n, ramped.affine_map(true), t_end);
    let gap = max_gap(&newton, &mapped);
    println!(
        "affine + ramp: {gap:.2e} from Newton + ramp; Newton iterations {} (mapped) against {}",
        mapped_summary.newton_iterations, newton_summary.newton_iterations
    );
    assert!(gap <= 1e-12, "{gap:e}");
    assert_eq!(mapped_summary.ramp_substeps, newton_summary.ramp_substeps);
    assert!(
        mapped_summary.newton_iterations < newton_summary.newton_iterations,
        "the regular steps must run on the map"
    );
}

/// The ramp after breakpoints (`IntegratorOptions::corner_ramp`): a series RC with τ = RC = 1e-3
/// at h = 0.1 (|λ|h = 100, where the midpoint rule damps by −0.96 per step) driven by a PWL ramp
/// 0 → 1 V with corners at t = 0.2 (a grid point) and t = 0.25 (inside a step), and the PWL's
/// first point at t = 0. The run must equal
/// the midpoint recursion written out by hand: regular steps, the step holding a corner split
/// there, and the stretch after each corner (to the end of its step) taken as the ramp's
/// substeps; the per-substep power balance is checked as above. Against the exact solution
/// (the lag `τ·slope` behind the source during the ramp decays as `e^(−t/τ)` after it), the
/// ramped rows are within 1e-9 V, where the unramped run still carries the lag's ringing.
#[test]
fn corner_ramp_substeps_are_midpoint_steps_and_damp_the_corner() {
    let (r, c, h, t_end) = (1e-3, 1.0, 0.1, 1.0);
    let tau = r * c;
    let wave = Waveform::pwl(vec![(0.0, 0.0), (0.2, 0.0), (0.25, 1.0)]);
    let ramp = StartRamp::for_ratio(h / tau);
    assert_eq!(ramp.levels, 9, "⌈log₂ 100⌉ + 2");
    let run = |corner_ramp: Option<StartRamp>| {
        let (g, signals) = common::source_rc(wave.clone(), r, c);
        let mut sim = Simulation::new(
            g,
            Execution::Assembled(Representation::Monolithic),
            IntegratorOptions::new(Discretisation::midpoint(), h).corner_ramp(corner_ramp),
        );
        sim.run(t_end, &signals).unwrap()
    };
    let (ramped, summary) = run(Some(ramp));
    let (plain, plain_summary) = run(None);
    assert_eq!(ramped.t(), plain.t(), "the grid must not move");
    // The PWL's first point (t = 0) is a breakpoint too: three stretches are ramped.
    assert_eq!(summary.ramp_substeps, 3 * ramp.substeps());
    assert_eq!(plain_summary.ramp_substeps, 0);

    let mut worst_balance: f64 = 0.0;
    let mut substep = |q: &mut f64, t: &mut f64, d: f64| {
        let balance = rc_midpoint_substep(&wave, r, c, q, t, d);
        worst_balance = worst_balance.max(balance / (c / 2.0));
    };
    let ramp_sizes = |stretch: f64| (0..ramp.substeps()).map(move |j| ramp.fraction(j) * stretch);
    // Step 0 starts on the PWL's first point, step 1 is regular, step 2 starts on the corner at
    // 0.2 and holds the one at 0.25; each stretch after a corner (0 … 0.1, 0.2 … 0.25,
    // 0.25 … 0.3) is ramped.
    let mut q = 0.0;
    let mut expected = vec![q];
    for k in 0..10 {
        let mut t = k as f64 * h;
        if k == 0 {
            for d in ramp_sizes(h) {
                substep(&mut q, &mut t, d);
            }
        } else if k == 2 {
            for d in ramp_sizes(0.05) {
                substep(&mut q, &mut t, d);
            }
            t = 0.25;
            for d in ramp_sizes(0.05) {
                substep(&mut q, &mut t, d);
            }
        } else {
            substep(&mut q, &mut t, h);
        }
        expected.push(q);
    }
    let gap = max_gap(&ramped.column(0), &expected);
    // After the ramp the source is constant: the exact charge is C·(1 − τ/0.05·e^(−(t−0.25)/τ)·
    // (1 − e^(−0.05/τ))), that is C to within e^(−50).
    let exact_gap = ramped.column(0)[3..]
        .iter()
        .map(|q| (q - c).abs())
        .fold(0.0, f64::max);
    let plain_gap = plain.column(0)[3..]
        .iter()
        .map(|q| (q - c).abs())
        .fold(0.0, f64::max);
    println!(
        "corner ramp: {gap:.2e} from the hand recursion, balance {worst_balance:.2e}, rows after the corner {exact_gap:.2e} from the exact charge (unramped {plain_gap:.2e})"
    );
    assert!(gap <= 1e-14, "{:?}\n{expected:?}", ramped.column(0));
    assert!(worst_balance <= 1e-13, "power balance {worst_balance:e}");
    assert!(exact_gap <= 1e-9, "{exact_gap:e}");
    assert!(plain_gap >= 1e-3, "the control must ring: {plain_gap:e}");
}
