//! The pendulum chain of DART's variational-integrator benchmark (dartsim/dart PR #2764):
//! `cargo bench -p dirac-rigid --bench chain`.
//!
//! Before the timings, a report (skipped with `CHAIN_REPORT=0`):
//!
//! - the 10-link chain at h = 1e-3 for 10⁵ steps (trapezoid rule: the LGVI): the energy band
//!   `max |E − E₀| / |E₀|` sampled every 1000 steps as DART samples it, and at every step, with the
//!   least-squares drift of the samples; `E` is evaluated at `(q_k, p_k)`: the velocity is the
//!   `M`-orthogonal projection of `M⁻¹p_k` onto the constraints' tangent space;
//! - Newton work per step for N = 2 … 128 links over 300 steps: the default modified Newton
//!   (iterations and factorisations) and exact Newton (a fresh Jacobian every iteration).
//!
//! Then divan times one step of the N-link chain (after 100 warm-up steps).

use dirac_core::{Constraints, Discretisation, LagrangianHessian, Model, Triplets};
use dirac_graph::{AssembledConstraints, AssembledModel, Assembler, Representation};
use dirac_rigid::mechanisms::PendulumChain;
use dirac_sim::{Integrator, IntegratorOptions};
use divan::{Bencher, black_box};
use nalgebra::{DMatrix, DVector};

type Chain = Integrator<AssembledModel, AssembledConstraints>;

fn chain(links: usize, exact_newton: bool) -> Chain {
    let m = PendulumChain::dart(links).build().expect("chain");
    let system = Assembler::assemble(&m.graph, Representation::Monolithic).expect("assembles");
    let names = m.names();
    let q = system.global_vector(&m.q0, &names).expect("q0");
    let v = system.global_vector(&m.v0, &names).expect("v0");
    let mut options = IntegratorOptions::new(Discretisation::trapezoid(), 1e-3);
    options.newton.reuse_jacobian = !exact_newton;
    let mut sim = Integrator::new(system.model, system.constraints, options).expect("options");
    sim.initialise(&q, &v, 0.0).expect("consistent start");
    sim
}

/// `E = ½ vᵀMv − L(q, 0) + …` at `(q_k, p_k)`: `v` solves `[M Aᵀ; A 0][v; μ] = [p; 0]` (the
/// velocity of the discrete Legendre transform on the constraints' tangent space), then
/// `E = v·∂L/∂v − L`.
fn energy(sim: &Chain) -> f64 {
    let (q, p) = (sim.q(), sim.p());
    let n = q.len();
    let model = sim.model();
    let mut h = LagrangianHessian::default();
    h.begin();
    model.lagrangian_hessian(q, &vec![0.0; n], &mut h);
    let c = sim.active_constraints();
    let m = c.count();
    let mut kkt = DMatrix::zeros(n + m, n + m);
    for (r, col, val) in h.vv.iter() {
        kkt[(r, col)] += val;
    }
    let mut forms = Triplets::new();
    forms.begin();
    c.forms(q, &mut forms);
    for (a, j, val) in forms.iter() {
        kkt[(n + a, j)] += val;
        kkt[(j, n + a)] += val;
    }
    let mut rhs = DVector::zeros(n + m);
    for i in 0..n {
        rhs[i] = p[i];
    }
    let v = kkt.lu().solve(&rhs).expect("KKT matrix is regular");
    let v: Vec<f64> = v.iter().take(n).copied().collect();
    let (mut lq, mut lv) = (vec![0.0; n], vec![0.0; n]);
    model.lagrangian_gradient(q, &v, &mut lq, &mut lv);
    v.iter().zip(&lv).map(|(a, b)| a * b).sum::<f64>() - model.lagrangian(q, &v)
}

fn report() {
    let steps = 100_000;
    let mut sim = chain(10, false);
    let e0 = energy(&sim);
    let (mut band_sampled, mut band_all) = (0.0_f64, 0.0_f64);
    let mut samples = Vec::new();
    let start = std::time::Instant::now();
    for k in 0..steps {
        if k % 1000 == 0 {
            let dev = (energy(&sim) - e0) / e0.abs();
            band_sampled = band_sampled.max(dev.abs());
            samples.push(dev);
        }
        sim.step().expect("step");
        if k % 10 == 0 {
            band_all = band_all.max(((energy(&sim) - e0) / e0.abs()).abs());
        }
    }
    let elapsed = start.elapsed();
    let n = samples.len() as f64;
    let (sx, sy) = samples
        .iter()
        .enumerate()
        .fold((0.0, 0.0), |(a, b), (i, y)| (a + i as f64, b + y));
    let (sxx, sxy) = samples
        .iter()
        .enumerate()
        .fold((0.0, 0.0), |(a, b), (i, y)| {
            (a + (i * i) as f64, b + i as f64 * y)
        });
    let slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    let stats = sim.stats();
    println!(
        "10-link chain, h = 1e-3, 1e5 steps: E0 = {e0:.6} J; energy band {:.3} % (sampled every 1000 steps), {:.3} % (every 10 steps); drift {:.2e} per 1000 steps (trend over the run {:.2e}); {:.2} Newton iterations and {:.3} factorisations per step; wall {:.1} s (incl. the energy readouts)",
        100.0 * band_sampled,
        100.0 * band_all,
        slope,
        slope * n,
        stats.iterations as f64 / steps as f64,
        stats.factorisations as f64 / steps as f64,
        elapsed.as_secs_f64()
    );
    println!(
        "links, modified Newton: iterations/step, factorisations/step; exact Newton: iterations/step"
    );
    for links in [2, 4, 8, 16, 32, 64, 128] {
        let mut row = Vec::new();
        for exact in [false, true] {
            let mut sim = chain(links, exact);
            let steps = 300;
            for _ in 0..steps {
                sim.step().expect("step");
            }
            let s = sim.stats();
            row.push((
                s.iterations as f64 / steps as f64,
                s.factorisations as f64 / steps as f64,
            ));
        }
        println!(
            "{links:4}: {:.2}, {:.3}; {:.2}",
            row[0].0, row[0].1, row[1].0
        );
    }
}

fn main() {
    if std::env::var("CHAIN_REPORT").map_or(true, |v| v != "0") {
        report();
    }
    divan::main();
}

/// One step of the N-link chain (trapezoid rule, h = 1e-3, default modified Newton).
#[divan::bench(args = [2, 4, 8, 16, 32, 64, 128], sample_count = 40, sample_size = 5)]
fn chain_step(bencher: Bencher, links: usize) {
    let mut sim = chain(links, false);
    for _ in 0..100 {
        sim.step().expect("step");
    }
    bencher.bench_local(|| {
        sim.step().expect("step");
        black_box(sim.q()[0])
    });
}
