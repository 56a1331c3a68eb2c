//! Step-loop benchmarks: `cargo bench --bench step`.
//!
//! - `oscillator_step`: one step of the damped oscillator (m = k = 1, c = 0.01, h = 0.05) for the
//!   midpoint rule and Gauss s = 2, 3;
//! - `double_pendulum_step`: one step of the double pendulum of benchmark scene D2 (h = 0.0125),
//!   nonlinear: modified Newton with kept factorisations and the default predictor;
//! - `seed_rlc_run`: the seed paper's RLC loop, 1000 (+) midpoint steps including set-up;
//!   `seed_rlc_run_affine_map`: the same with the opt-in precomputed affine step map.
//!
//! divan's allocation profiler reports allocations per iteration: the step loop must show none.

use dirac::core::{Discretisation, NoConstraints};
use dirac::sim::{Integrator, IntegratorOptions, SolverChoice};
use dirac_problems::{DampedOscillator, DoublePendulum, RlcLoop};
use divan::{AllocProfiler, Bencher, black_box};

#[global_allocator]
static ALLOC: AllocProfiler = AllocProfiler::system();

fn main() {
    divan::main();
}

fn discretisation(name: &str) -> Discretisation {
    match name {
        "gauss2" => Discretisation::gauss(2),
        "gauss3" => Discretisation::gauss(3),
        "gauss4" => Discretisation::gauss(4),
        _ => Discretisation::midpoint(),
    }
}

#[divan::bench(args = ["midpoint", "gauss2", "gauss3"])]
fn oscillator_step(bencher: Bencher, name: &str) {
    let osc = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 0.01,
    };
    let mut sim = Integrator::new(
        osc,
        NoConstraints,
        IntegratorOptions::new(discretisation(name), 0.05),
    )
    .expect("valid options");
    sim.set_state(&[1.0], &[0.0], 0.0).expect("state");
    // Warm up: the first step analyses the pattern and sizes every buffer.
    sim.step().expect("step");
    bencher.bench_local(|| {
        sim.step().expect("step");
        black_box(sim.q()[0])
    });
}

#[divan::bench(args = ["midpoint", "gauss2", "gauss4"])]
fn double_pendulum_step(bencher: Bencher, name: &str) {
    let mut sim = Integrator::new(
        DoublePendulum::unit(),
        NoConstraints,
        IntegratorOptions::new(discretisation(name), 0.0125),
    )
    .expect("valid options");
    sim.initialise(&[1.0, 0.5], &[0.0, 0.0], 0.0)
        .expect("state");
    // Warm up past the predictor's start (two steps) so every buffer is sized.
    for _ in 0..3 {
        sim.step().expect("step");
    }
    bencher.bench_local(|| {
        sim.step().expect("step");
        black_box(sim.q()[0])
    });
}

#[divan::bench(args = [SolverChoice::Dense, SolverChoice::Sparse])]
fn seed_rlc_run(bencher: Bencher, solver: SolverChoice) {
    bencher.bench_local(|| {
        let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).solver(solver);
        let mut sim =
            Integrator::new(RlcLoop::seed(), RlcLoop::kcl(), options).expect("valid options");
        sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0)
            .expect("consistent");
        for _ in 0..1000 {
            sim.step().expect("step");
        }
        black_box(sim.q()[0])
    });
}

/// The seed RLC run with the opt-in affine step map (precomputed discrete state-space form).
#[divan::bench]
fn seed_rlc_run_affine_map(bencher: Bencher) {
    bencher.bench_local(|| {
        let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).affine_map(true);
        let mut sim =
            Integrator::new(RlcLoop::seed(), RlcLoop::kcl(), options).expect("valid options");
        sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0)
            .expect("consistent");
        for _ in 0..1000 {
            sim.step().expect("step");
        }
        black_box(sim.q()[0])
    });
}

#[divan::bench(args = [SolverChoice::Dense, SolverChoice::Sparse])]
fn seed_rlc_step(bencher: Bencher, solver: SolverChoice) {
    let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).solver(solver);
    let mut sim = Integrator::new(RlcLoop::seed(), RlcLoop::kcl(), options).expect("valid options");
    sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0)
        .expect("consistent");
    sim.step().expect("step");
    bencher.bench_local(|| {
        sim.step().expect("step");
        black_box(sim.q()[0])
    });
}
