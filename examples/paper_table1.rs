//! Reproduces Table 1 of Parks & Leok: convergence of the shooting-based forced variational
//! integrators on the damped oscillator `m = k = 1`, `c = 0.01`, `q0 = 1`, `p0 = 0`.
//!
//! - `trap-taylor2`: trapezoid quadrature, second-order Taylor shooting;
//! - `simpson-taylor4`: Simpson quadrature, fourth-order Taylor shooting.
//!
//! The error is the Euclidean norm of `(q − q_exact, p − p_exact)` at `t = 5T` with `T` the damped
//! period `2π/ω_d` and `h = T / steps_per_period` (see `docs/paper.md` for why this measure).
//! Prints CSV `integrator,steps_per_period,error,ratio` (ratio = previous error / this error,
//! empty in the first row of each integrator) and writes `docs/figures/paper_table1.{svg,png}`.
//!
//! Run: `cargo run --release --example paper_table1`

use std::error::Error;
use std::path::Path;

use dirac::core::ShootingDiscretisation;
use dirac::sim::ShootingIntegrator;
use dirac_output::{LegendPosition, LineChart, LineStyle, Series};
use dirac_problems::DampedOscillator;

const STEPS_PER_PERIOD: [usize; 4] = [20, 40, 80, 160];
const PERIODS: usize = 5;

/// The paper's Table 1 errors.
const PAPER_SECOND: [f64; 4] = [0.2275, 0.0557, 0.0138, 0.0035];
const PAPER_FOURTH: [f64; 4] = [0.6551e-4, 0.0516e-4, 0.0034e-4, 0.0002e-4];

fn main() -> Result<(), Box<dyn Error>> {
    let model = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 0.01,
    };
    let period = model.period();
    let methods = [
        (
            "trap-taylor2",
            ShootingDiscretisation::trapezoid_taylor2(),
            PAPER_SECOND,
        ),
        (
            "simpson-taylor4",
            ShootingDiscretisation::simpson_taylor4(),
            PAPER_FOURTH,
        ),
    ];
    println!("integrator,steps_per_period,error,ratio");
    let mut chart =
        LineChart::new("Table 1: error at t = 5T, damped oscillator (m = k = 1, c = 0.01)")
            .x_label("steps per period")
            .y_label("‖(q, p) − exact‖ at t = 5T")
            .log_log()
            .x_ticks(STEPS_PER_PERIOD.iter().map(|&n| n as f64).collect())
            .legend(LegendPosition::LowerLeft);
    for (i, (name, discretisation, paper)) in methods.into_iter().enumerate() {
        let mut ours = Vec::new();
        let mut previous: Option<f64> = None;
        for &n in &STEPS_PER_PERIOD {
            let h = period / n as f64;
            let mut sim = ShootingIntegrator::new(model, discretisation.clone(), h)?;
            sim.set_state([1.0], [0.0], 0.0);
            sim.run(PERIODS * n, |_, _, _, _| {})?;
            let (qe, pe) = model.exact(1.0, 0.0, sim.t());
            let (dq, dp) = (sim.q()[0] - qe, sim.p()[0] - pe);
            let error = dq.hypot(dp);
            let ratio = previous.map_or(String::new(), |e| format!("{:.4}", e / error));
            println!("{name},{n},{error:.6e},{ratio}");
            eprintln!(
                "# {name} n = {n}: |q − q_exact| = {:.4e}, |p − p_exact| = {:.4e}",
                dq.abs(),
                dp.abs()
            );
            previous = Some(error);
            ours.push((n as f64, error));
        }
        let color = [(31, 119, 180), (214, 39, 40)][i];
        chart.push(Series::new(format!("{name} (ours)"), ours).color(color.0, color.1, color.2));
        let paper_points = STEPS_PER_PERIOD
            .iter()
            .zip(paper)
            .map(|(&n, e)| (n as f64, e))
            .collect();
        chart.push(
            Series::new(format!("{name} (paper, Table 1)"), paper_points)
                .color(color.0, color.1, color.2)
                .style(LineStyle::Dotted)
                .markers(true),
        );
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/figures");
    std::fs::create_dir_all(&dir)?;
    chart.save_svg(dir.join("paper_table1.svg"))?;
    chart.save_png(dir.join("paper_table1.png"))?;
    eprintln!("# wrote {}", dir.join("paper_table1.{svg,png}").display());
    Ok(())
}
