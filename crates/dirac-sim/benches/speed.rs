//! Per-step cost of the step paths: `cargo bench -p dirac-sim --bench speed`.
//!
//! Every benchmark times a block of [`STEPS`] steps of an integrator that has already taken its
//! first steps (buffers sized, factorisations kept), so divan's figure divided by `STEPS` is the
//! cost of one step in a long run.
//!
//! - `chain_step`: a chain of masses joined by hardening springs (assembled from parts, a separable
//!   model), trapezoid rule, on the explicit Störmer–Verlet path and on the Newton path;
//! - `double_pendulum_step`: the double pendulum of benchmark scene D2 (`h = 0.0125`) with Gauss
//!   `s = 3, 4` (nonlinear Galerkin steps).

use dirac_components::{Mass, Spring};
use dirac_core::NoConstraints;
use dirac_graph::{Assembler, Interconnection, Representation};
use dirac_problems::DoublePendulum;
use dirac_sim::{Discretisation, Integrator, IntegratorOptions};
use divan::{Bencher, black_box};

/// Steps per timed block.
const STEPS: usize = 100;

fn main() {
    divan::main();
}

/// `n` masses in a row, neighbours joined by a spring `k = 1, k₃ = 0.5`.
fn chain(n: usize) -> Interconnection {
    let mut g = Interconnection::new();
    for i in 0..n {
        let mass = Mass::new(1.0 + 0.1 * i as f64).expect("mass");
        g.add_subsystem(mass.subsystem(format!("m{i}")))
            .expect("mass");
    }
    for i in 1..n {
        let a = g.port(&format!("m{}", i - 1), "x").expect("port");
        let b = g.port(&format!("m{i}"), "x").expect("port");
        g.coupling(
            format!("k{i}"),
            a,
            b,
            Spring::new(1.0, 0.5, 0.0).expect("spring"),
        );
    }
    g
}

#[divan::bench(args = [("explicit", 3), ("newton", 3), ("explicit", 100), ("newton", 100)])]
fn chain_step(bencher: Bencher, (path, n): (&str, usize)) {
    let system = Assembler::assemble(&chain(n), Representation::Monolithic).expect("assembles");
    let options =
        IntegratorOptions::new(Discretisation::trapezoid(), 0.05).explicit(path == "explicit");
    let mut sim = Integrator::new(system.model, system.constraints, options).expect("options");
    let mut q = vec![0.0; n];
    q[0] = 0.5;
    sim.initialise(&q, &vec![0.0; n], 0.0).expect("state");
    assert_eq!(sim.uses_explicit(), path == "explicit");
    for _ in 0..3 {
        sim.step().expect("step");
    }
    bencher.bench_local(|| {
        for _ in 0..STEPS {
            sim.step().expect("step");
        }
        black_box(sim.q()[0])
    });
}

#[divan::bench(args = [3, 4])]
fn double_pendulum_step(bencher: Bencher, s: usize) {
    let mut sim = Integrator::new(
        DoublePendulum::unit(),
        NoConstraints,
        IntegratorOptions::new(Discretisation::gauss(s), 0.0125),
    )
    .expect("options");
    sim.initialise(&[1.0, 0.5], &[0.0, 0.0], 0.0)
        .expect("state");
    for _ in 0..3 {
        sim.step().expect("step");
    }
    bencher.bench_local(|| {
        for _ in 0..STEPS {
            sim.step().expect("step");
        }
        black_box(sim.q()[0])
    });
}
