//! Reproduces Figure 2 of Parks & Leok: a unit oscillator whose spring is split between the
//! Lagrangian and an external force, `L = ½v² − (1 − α)½q²`, `f = −αq`, `α = 0, 0.1, …, 1`
//! (every `α` has the same equations of motion). `q0 = 1`, `p0 = 0`, `h = 0.05`, 2000 steps,
//! second-order Taylor shooting:
//!
//! - `ep`: trapezoid quadrature on `L_d` and on `f_d^±` (equivalence-preserving);
//! - `non-ep`: trapezoid on `L_d`, midpoint on `f_d^±`.
//!
//! `max_dev` = max over steps of `|q − q_{α=0}| + |p − p_{α=0}|` against the same
//! discretisation's `α = 0` run (where the force vanishes, so both constructions agree).
//! Prints CSV `discretisation,alpha,max_dev` and writes `docs/figures/paper_fig2_alpha.{svg,png}`
//! (deviation against α) and `docs/figures/paper_fig2_deviation_t.{svg,png}` (`q_α(t) − q_{α=0}(t)`
//! over the run).
//!
//! Run: `cargo run --release --example paper_fig2_alpha`

use std::error::Error;
use std::path::Path;

use dirac::core::{OneStepMap, QuadratureRule, ShootingDiscretisation};
use dirac::sim::ShootingIntegrator;
use dirac_output::{LegendPosition, LineChart, LineStyle, Series};
use dirac_problems::SplitOscillator;

const H: f64 = 0.05;
const STEPS: usize = 2000;

/// `(t, q, p)` at every step, including the initial state.
type Trajectory = Vec<(f64, f64, f64)>;

fn run(alpha: f64, discretisation: &ShootingDiscretisation) -> Result<Trajectory, Box<dyn Error>> {
    let mut sim = ShootingIntegrator::new(SplitOscillator { alpha }, discretisation.clone(), H)?;
    sim.set_state([1.0], [0.0], 0.0);
    let mut out = Vec::with_capacity(STEPS + 1);
    sim.run(STEPS, |_, t, q, p| out.push((t, q[0], p[0])))?;
    Ok(out)
}

fn main() -> Result<(), Box<dyn Error>> {
    let alphas: Vec<f64> = (0..=10).map(|i| f64::from(i) / 10.0).collect();
    let ep = ShootingDiscretisation::new(OneStepMap::Taylor2, QuadratureRule::trapezoid());
    let non_ep = ShootingDiscretisation::non_equivalence_preserving(
        OneStepMap::Taylor2,
        QuadratureRule::trapezoid(),
        QuadratureRule::midpoint(),
    );
    println!("discretisation,alpha,max_dev");
    let mut deviation_chart =
        LineChart::new("Figure 2: deviation from the α = 0 run (h = 0.05, 2000 steps)")
            .x_label("α (fraction of the spring written as an external force)")
            .y_label("max_k |q − q_α=0| + |p − p_α=0|")
            .log_y(true)
            .legend(LegendPosition::LowerRight);
    let mut trajectory_chart = LineChart::new("Figure 2: q_α(t) − q_α=0(t) for α = 0.2, 0.6, 1")
        .x_label("t")
        .y_label("q_α(t) − q_α=0(t)")
        .size(1100, 600)
        .legend(LegendPosition::LowerLeft);
    // Deviations at round-off are drawn at this floor so that they show on the log axis.
    let floor = 1e-17;
    for (name, discretisation) in [("ep", &ep), ("non-ep", &non_ep)] {
        let reference = run(0.0, discretisation)?;
        let mut points = Vec::new();
        for &alpha in &alphas {
            let traj = run(alpha, discretisation)?;
            let max_dev = traj
                .iter()
                .zip(&reference)
                .map(|(a, b)| (a.1 - b.1).abs() + (a.2 - b.2).abs())
                .fold(0.0_f64, f64::max);
            println!("{name},{alpha:.1},{max_dev:.6e}");
            points.push((alpha, max_dev.max(floor)));
            // Position deviation over time for a few α (ep: α = 1 only, it is at round-off).
            let shown = (name == "non-ep" && [0.2, 0.6, 1.0].contains(&alpha))
                || (name == "ep" && alpha == 1.0);
            if shown {
                let dev: Vec<(f64, f64)> = traj
                    .iter()
                    .zip(&reference)
                    .map(|(a, b)| (a.0, a.1 - b.1))
                    .collect();
                let series = Series::new(format!("{name}, α = {alpha:.1}"), dev);
                trajectory_chart.push(if name == "ep" {
                    series.color(0, 0, 0).style(LineStyle::Dashed)
                } else {
                    series.width(1)
                });
            }
        }
        let (color, style) = if name == "ep" {
            ((31, 119, 180), LineStyle::Solid)
        } else {
            ((214, 39, 40), LineStyle::Solid)
        };
        deviation_chart.push(
            Series::new(
                if name == "ep" {
                    "ep: trapezoid on L_d and f_d (round-off)"
                } else {
                    "non-ep: trapezoid on L_d, midpoint on f_d"
                },
                points,
            )
            .color(color.0, color.1, color.2)
            .style(style)
            .markers(true),
        );
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/figures");
    std::fs::create_dir_all(&dir)?;
    deviation_chart.save_svg(dir.join("paper_fig2_alpha.svg"))?;
    deviation_chart.save_png(dir.join("paper_fig2_alpha.png"))?;
    trajectory_chart.save_svg(dir.join("paper_fig2_deviation_t.svg"))?;
    trajectory_chart.save_png(dir.join("paper_fig2_deviation_t.png"))?;
    eprintln!(
        "# wrote {}",
        dir.join("paper_fig2_{alpha,deviation_t}.{svg,png}")
            .display()
    );
    Ok(())
}
