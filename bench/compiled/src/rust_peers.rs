//! The Rust peers: diffsol (BDF, TR-BDF2, ESDIRK34, TSIT45) and the `differential-equations`
//! crate's adaptive Gauss–Legendre Runge–Kutta of orders 4 and 6, with Rust closures for the
//! right-hand side and the Jacobian (scenes.rs).

use std::time::Instant;

use differential_equations::prelude::*;
use diffsol::{
    FaerSparseLU, FaerSparseMat, NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod,
    OdeSolverStopReason,
};

use crate::ffi::Run;
use crate::scenes::Scene;

/// Steps a diffsol solver to the scene's end time, recording every accepted step (or only the
/// end with `every = false`).
macro_rules! drive {
    ($solver:expr, $scene:expr, $every:expr, $start:expr) => {{
        let mut s = $solver;
        let scene: &Scene = $scene;
        let d = scene.dim();
        s.set_stop_time(scene.t_end).map_err(|e| e.to_string())?;
        let mut t = vec![0.0];
        let mut y = scene.y0.clone();
        loop {
            let reason = s.step().map_err(|e| e.to_string())?;
            if $every || matches!(reason, OdeSolverStopReason::TstopReached) {
                let st = s.state();
                if !$every {
                    y.clear();
                    t.clear();
                }
                t.push(st.t);
                y.extend((0..d).map(|i| st.y[i]));
            }
            if matches!(reason, OdeSolverStopReason::TstopReached) {
                break;
            }
        }
        let wall_s = $start.elapsed().as_secs_f64();
        let stats = s.get_statistics();
        Ok(Run {
            t,
            y,
            steps: stats.number_of_steps,
            newton_iterations: stats.number_of_nonlinear_solver_iterations,
            wall_s,
        })
    }};
}

macro_rules! diffsol_run {
    ($m:ty, $ls:ty, $scene:expr, $method:expr, $rtol:expr, $coloring:expr, $every:expr) => {{
        let scene: &Scene = $scene;
        let start = Instant::now();
        let problem = OdeBuilder::<$m>::new()
            .rtol($rtol)
            .atol([$rtol * 1e-3])
            .use_coloring($coloring)
            .rhs_implicit(
                |x: &[f64], _p: &[f64], t: f64, y: &mut [f64]| scene.rhs(t, x, y),
                |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| scene.jac_mul(t, x, v, y),
            )
            .init(
                |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&scene.y0),
                scene.dim(),
            )
            .build()
            .map_err(|e| e.to_string())?;
        match $method {
            "BDF" => drive!(
                problem.bdf::<$ls>().map_err(|e| e.to_string())?,
                scene,
                $every,
                start
            ),
            "TR-BDF2" => drive!(
                problem.tr_bdf2::<$ls>().map_err(|e| e.to_string())?,
                scene,
                $every,
                start
            ),
            "ESDIRK34" => drive!(
                problem.esdirk34::<$ls>().map_err(|e| e.to_string())?,
                scene,
                $every,
                start
            ),
            "TSIT45" => drive!(
                problem.tsit45().map_err(|e| e.to_string())?,
                scene,
                $every,
                start
            ),
            other => Err(format!("unknown diffsol method {other}")),
        }
    }};
}

/// diffsol `method` at `rtol` (atol = rtol·1e-3): dense nalgebra matrices for the small scenes,
/// faer sparse matrices (sparsity found by diffsol's colouring) for the ladders.
pub fn diffsol(scene: &Scene, method: &str, rtol: f64) -> Result<Run, String> {
    let every = scene.needs_every_point();
    if scene.n > 0 {
        diffsol_run!(
            FaerSparseMat<f64>,
            FaerSparseLU<f64>,
            scene,
            method,
            rtol,
            true,
            every
        )
    } else {
        diffsol_run!(
            NalgebraMat<f64>,
            NalgebraLU<f64>,
            scene,
            method,
            rtol,
            false,
            every
        )
    }
}

struct Rhs<'a>(&'a Scene);

impl ODE<f64, Vec<f64>> for Rhs<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        self.0.rhs(t, y, dydt);
    }
    fn jacobian(&self, t: f64, y: &Vec<f64>, j: &mut Matrix<f64>) {
        let d = y.len();
        let mut e = vec![0.0; d];
        let mut col = vec![0.0; d];
        for c in 0..d {
            e[c] = 1.0;
            self.0.jac_mul(t, y, &e, &mut col);
            for (r, v) in col.iter().enumerate() {
                j[(r, c)] = *v;
            }
            e[c] = 0.0;
        }
    }
}

/// At most this many steps per Gauss–Legendre run: the crate keeps every step as a `Vec`, and its
/// controller takes ~10⁴ steps per unit time on the pendulum, so a long run would need 10⁸.
const GL_MAX_STEPS: usize = 2_000_000;

/// Adaptive Gauss–Legendre of order 4 or 6 (`differential-equations` 0.7) at `rtol`
/// (atol = rtol·1e-3), analytic Jacobian; records every accepted step.
pub fn gauss_legendre(scene: &Scene, order: usize, rtol: f64) -> Result<Run, String> {
    let start = Instant::now();
    let ode = Rhs(scene);
    let y0 = scene.y0.clone();
    let problem = IVP::ode(&ode, 0.0, scene.t_end, y0);
    let sol = match order {
        4 => problem
            .method(
                ImplicitRungeKutta::gauss_legendre_4()
                    .rtol(rtol)
                    .atol(rtol * 1e-3)
                    .max_steps(GL_MAX_STEPS),
            )
            .solve(),
        6 => problem
            .method(
                ImplicitRungeKutta::gauss_legendre_6()
                    .rtol(rtol)
                    .atol(rtol * 1e-3)
                    .max_steps(GL_MAX_STEPS),
            )
            .solve(),
        _ => return Err(format!("Gauss–Legendre order {order}")),
    }
    .map_err(|e| format!("{e:?}"))?;
    let wall_s = start.elapsed().as_secs_f64();
    let steps = sol.steps.accepted;
    let y = sol.y.iter().flatten().copied().collect();
    Ok(Run {
        t: sol.t,
        y,
        steps,
        newton_iterations: 0,
        wall_s,
    })
}
