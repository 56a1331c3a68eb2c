//! Helpers shared by the integration tests.
#![allow(dead_code)]

use dirac::core::{Constraints, Discretisation, Flavour, Model};
use dirac::sim::{Integrator, IntegratorOptions};

/// Integrator options for `discretisation`, `flavour` and step `h`.
pub fn options(discretisation: Discretisation, flavour: Flavour, h: f64) -> IntegratorOptions {
    IntegratorOptions::new(discretisation, h).flavour(flavour)
}

/// Runs `steps` steps from `(q0, p0)` and returns every state `(q_k, p_k)`, k = 0..=steps.
pub fn trajectory<M: Model, C: Constraints>(
    model: M,
    constraints: C,
    options: IntegratorOptions,
    q0: &[f64],
    p0: &[f64],
    steps: usize,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut sim = Integrator::new(model, constraints, options).expect("valid options");
    sim.set_state(q0, p0, 0.0).expect("consistent state");
    let mut out = vec![(q0.to_vec(), p0.to_vec())];
    for _ in 0..steps {
        sim.step().expect("step converges");
        out.push((sim.q().to_vec(), sim.p().to_vec()));
    }
    out
}

/// Least-squares slope of log(err) against log(h).
pub fn fitted_slope(h: &[f64], err: &[f64]) -> f64 {
    let x: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let y: Vec<f64> = err.iter().map(|v| v.ln()).collect();
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Max-norm of the difference of two vectors.
pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}
