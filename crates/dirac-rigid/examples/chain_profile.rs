//! One chain length of the DART benchmark chain, stepped long enough to profile:
//! `cargo run --release -p dirac-rigid --example chain_profile -- LINKS STEPS`, e.g. under
//! `perf record -g` (docs/rigid.md, "Where the time goes"). Prints the mean cost of a step after
//! 100 warm-up steps and the Newton work per step.

use dirac_core::Discretisation;
use dirac_graph::{Assembler, Representation};
use dirac_rigid::mechanisms::PendulumChain;
use dirac_sim::{Integrator, IntegratorOptions};

fn main() {
    let arg = |i: usize, default: usize| {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let (links, steps) = (arg(1, 32), arg(2, 500));
    let m = PendulumChain::dart(links).build().expect("chain");
    let system = Assembler::assemble(&m.graph, Representation::Monolithic).expect("assembles");
    let names = m.names();
    let q = system.global_vector(&m.q0, &names).expect("q0");
    let v = system.global_vector(&m.v0, &names).expect("v0");
    let options = IntegratorOptions::new(Discretisation::trapezoid(), 1e-3);
    let mut sim = Integrator::new(system.model, system.constraints, options).expect("options");
    sim.initialise(&q, &v, 0.0).expect("consistent start");
    for _ in 0..100 {
        sim.step().expect("step");
    }
    let before = sim.stats();
    let start = std::time::Instant::now();
    for _ in 0..steps {
        sim.step().expect("step");
    }
    let micros = start.elapsed().as_secs_f64() * 1e6 / steps as f64;
    let s = sim.stats();
    println!(
        "{links} links: {micros:.1} µs per step, {:.2} µs per body; {:.2} Newton iterations and {:.3} factorisations per step",
        micros / links as f64,
        (s.iterations - before.iterations) as f64 / steps as f64,
        (s.factorisations - before.factorisations) as f64 / steps as f64
    );
}
