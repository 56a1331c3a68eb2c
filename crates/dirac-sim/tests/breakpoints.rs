//! Steps land on source corners. What that does to the discrete invariants: each piece is an
//! ordinary midpoint step of its own size, so the discrete power balance holds on every piece and
//! every representation sees the same pieces (the same trajectory).

mod common;

use dirac_components::{ForceSource, Mass, Spring, Waveform};
use dirac_graph::{Interconnection, Representation};
use dirac_sim::{Discretisation, Execution, IntegratorOptions, Probe, Signal, Simulation};

/// A series RC driven by a PWL source with corners at 0.25 h and 2.6 h. The run must equal the
/// midpoint recursion written out by hand with the steps split at the corners,
/// `(q₊ − q)/δ = (V(t + δ/2) − (q + q₊)/(2C))/R`, to round-off; without landing it does not
/// (negative control), and the error against the exact solution is smaller with landing.
#[test]
fn pieces_are_midpoint_steps_of_their_own_size() {
    let (r, c, h) = (1.0, 1.0, 0.1);
    let points = vec![
        (0.0, 0.0),
        (0.025, 1.0),
        (0.26, 1.0),
        (0.26, -0.5),
        (1.0, 0.3),
    ];
    let wave = Waveform::pwl(points.clone());
    let (g, signals) = common::source_rc(wave.clone(), r, c);
    let run = |landing: bool| {
        let mut sim = Simulation::new(
            g.clone(),
            Execution::Assembled(Representation::Monolithic),
            IntegratorOptions::new(Discretisation::midpoint(), h).breakpoints(landing),
        );
        let (trajectory, summary) = sim.run(1.0, &signals).unwrap();
        (trajectory.column(0), summary)
    };
    // The hand recursion with the pieces split at every corner inside a step.
    let corners: Vec<f64> = points.iter().map(|p| p.0).collect();
    let mut q = 0.0;
    let mut expected = vec![q];
    for k in 0..10 {
        let (t0, t1) = (k as f64 * h, (k + 1) as f64 * h);
        let mut cuts: Vec<f64> = corners
            .iter()
            .copied()
            .filter(|&b| b > t0 + 1e-12 && b < t1 - 1e-12)
            .collect();
        cuts.dedup();
        let mut t = t0;
        for end in cuts.into_iter().chain(std::iter::once(t1)) {
            let d = end - t;
            let v = wave.value(t + 0.5 * d);
            // (q₊ − q)/d = (v − (q + q₊)/(2C))/R  ⇒  q₊ = (q (1 − a) + d v / R)/(1 + a), a = d/(2RC)
            let a = d / (2.0 * r * c);
            q = (q * (1.0 - a) + d * v / r) / (1.0 + a);
            t = end;
        }
        expected.push(q);
    }
    let (landed, summary) = run(true);
    let (plain, _) = run(false);
    let gap = |x: &[f64]| {
        x.iter()
            .zip(&expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    println!(
        "landed: {:.2e} from the hand recursion ({} breakpoint substeps); without landing {:.2e}",
        gap(&landed),
        summary.breakpoint_substeps,
        gap(&plain)
    );
    assert!(gap(&landed) <= 1e-15, "{landed:?}\n{expected:?}");
    assert!(gap(&plain) > 1e-4, "the control must differ");
    assert_eq!(summary.breakpoint_substeps, 2);
}

/// A pulse force on the first of two masses joined by a spring: monolithic, constraint and
/// interaction-force representations land on the same corners and give the same positions to
/// round-off, corners inside steps included.
#[test]
fn representations_agree_across_corners() {
    let mut g = Interconnection::new();
    g.add_subsystem(Mass::new(1.0).unwrap().subsystem("A"))
        .unwrap();
    g.add_subsystem(Mass::new(2.0).unwrap().subsystem("B"))
        .unwrap();
    g.add_subsystem(Mass::new(1.0).unwrap().subsystem("W"))
        .unwrap();
    let (a, b, w) = (
        g.port("A", "x").unwrap(),
        g.port("B", "x").unwrap(),
        g.port("W", "x").unwrap(),
    );
    g.coupling("spring", a, b, Spring::linear(3.0).unwrap());
    g.coupling(
        "push",
        w,
        a,
        ForceSource::new(Waveform::pulse(0.0, 1.0, 0.013, 0.002, 0.031, 0.05, 0.2)).unwrap(),
    );
    let signals = vec![
        Signal::new("A", Probe::position(&g, "A", "x").unwrap()),
        Signal::new("B", Probe::position(&g, "B", "x").unwrap()),
    ];
    let run = |representation| {
        let mut sim = Simulation::new(
            g.clone(),
            Execution::Assembled(representation),
            IntegratorOptions::new(Discretisation::midpoint(), 0.01),
        );
        let (trajectory, summary) = sim.run(1.0, &signals).unwrap();
        assert!(summary.breakpoint_substeps > 10);
        trajectory
    };
    let mono = run(Representation::Monolithic);
    for representation in [Representation::Constraint, Representation::InteractionForce] {
        let other = run(representation);
        let mut worst: f64 = 0.0;
        for k in 0..mono.len() {
            for (x, y) in mono.row(k).iter().zip(other.row(k)) {
                worst = worst.max((x - y).abs());
            }
        }
        println!("{representation}: max |Δx| = {worst:.2e}");
        // Round-off of order-one positions over 100 steps (measured ~1e-16).
        assert!(worst <= 1e-13, "{representation}: {worst:e}");
    }
}

/// A sink that keeps rows and, when asked to, the samples at corners inside steps.
#[derive(Default)]
struct Recorder {
    wants: bool,
    rows: Vec<(f64, Vec<f64>)>,
    samples: Vec<(f64, Vec<f64>)>,
}

impl dirac_sim::Sink for Recorder {
    fn begin(&mut self, _names: &[String]) -> Result<(), String> {
        Ok(())
    }

    fn row(&mut self, _k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        self.rows.push((t, values.to_vec()));
        Ok(())
    }

    fn samples_from(&self) -> Option<f64> {
        self.wants.then_some(0.0)
    }

    fn sample(&mut self, t: f64, values: &[f64]) -> Result<(), String> {
        self.samples.push((t, values.to_vec()));
        Ok(())
    }
}

/// The states the steps land on at corners inside them reach a sink that asks for them
/// (`Sink::sample`): one sample per corner strictly inside a step, at the corner's time, with
/// the charge of the hand recursion of `pieces_are_midpoint_steps_of_their_own_size` there and
/// the source's own value on its node; the rows are the same with samples or without.
#[test]
fn inner_states_inside_steps_are_samples_and_leave_the_rows_alone() {
    let (r, c, h) = (1.0, 1.0, 0.1);
    let points = vec![
        (0.0, 0.0),
        (0.025, 1.0),
        (0.26, 1.0),
        (0.33, -0.5),
        (1.0, 0.3),
    ];
    let wave = Waveform::pwl(points.clone());
    let (g, mut signals) = common::source_rc(wave.clone(), r, c);
    signals.push(Signal::new("v(in)", Probe::effort(&g, "in").unwrap()));
    let run = |wants: bool| {
        let mut sim = Simulation::new(
            g.clone(),
            Execution::Assembled(Representation::Monolithic),
            IntegratorOptions::new(Discretisation::midpoint(), h),
        );
        let mut sink = Recorder {
            wants,
            ..Recorder::default()
        };
        sim.run_into(1.0, &signals, &mut sink).unwrap();
        sink
    };
    let sampled = run(true);
    let plain = run(false);
    assert_eq!(sampled.rows, plain.rows);
    assert!(plain.samples.is_empty());
    // The hand recursion, keeping the charge at each corner inside a step.
    let mut q = 0.0;
    let mut at_corners = Vec::new();
    for k in 0..10 {
        let (t0, t1) = (k as f64 * h, (k + 1) as f64 * h);
        let cuts: Vec<f64> = points
            .iter()
            .map(|p| p.0)
            .filter(|&b| b > t0 + 1e-12 && b < t1 - 1e-12)
            .collect();
        let mut t = t0;
        for end in cuts.iter().copied().chain(std::iter::once(t1)) {
            let d = end - t;
            let a = d / (2.0 * r * c);
            q = (q * (1.0 - a) + d * wave.value(t + 0.5 * d) / r) / (1.0 + a);
            t = end;
            if cuts.contains(&end) {
                at_corners.push((end, q));
            }
        }
    }
    assert_eq!(sampled.samples.len(), 3, "{:?}", sampled.samples);
    for ((t, values), (corner, charge)) in sampled.samples.iter().zip(&at_corners) {
        assert_eq!(t, corner);
        assert!(
            (values[0] - charge).abs() <= 1e-15,
            "{t}: {} against {charge}",
            values[0]
        );
        assert!(
            (values[1] - wave.value(*t)).abs() <= 1e-15,
            "{t}: {}",
            values[1]
        );
    }
}
