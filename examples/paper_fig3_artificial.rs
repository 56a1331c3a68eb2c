//! Reproduces Figure 3 of Parks & Leok: an artificial potential `100 q⁵` added to the unit
//! oscillator's Lagrangian and cancelled by the external force `+500 q⁴`, so the equations of
//! motion are those of `q̈ = −q` (`dirac_problems::ArtificialPotential { a: 100 }`).
//! `q0 = 1`, `p0 = 0`, `h = 0.05`, `t ∈ [0, 100]`, RK4 shooting:
//!
//! - `ep`: trapezoid quadrature on `L_d` and on `f_d^±` (equivalence-preserving, second order);
//! - `non-ep`: Simpson on `L_d`, trapezoid on `f_d^±`.
//!
//! Prints CSV `discretisation,max_err` with `max_err = max_k |q_k − cos t_k|` (`nan` if the run
//! fails; the reason goes to stderr) and writes `docs/figures/paper_fig3_artificial.{svg,png}`
//! (the whole run) and `docs/figures/paper_fig3_artificial_zoom.{svg,png}` (`t ≤ 5`).
//!
//! Run: `cargo run --release --example paper_fig3_artificial`

use std::error::Error;
use std::path::Path;

use dirac::core::{OneStepMap, QuadratureRule, ShootingDiscretisation, ShootingStep};
use dirac::sim::ShootingIntegrator;
use dirac_output::{LegendPosition, LineChart, LineStyle, Series};
use dirac_problems::ArtificialPotential;

const H: f64 = 0.05;
const T_END: f64 = 100.0;

/// Samples the step residual `p_k + D₁L_d + f_d⁻` over `q_{k+1} ∈ q_k ± 3` to tell a Newton
/// failure from a step that has no solution at all.
fn diagnose(
    model: &ArtificialPotential,
    discretisation: &ShootingDiscretisation,
    q: f64,
    p: f64,
    t: f64,
) {
    let Ok(mut step) = ShootingStep::<1>::new(discretisation.clone(), H) else {
        return;
    };
    step.set_start(&[q], &[p], t);
    let samples: Vec<(f64, f64)> = (-300..=300)
        .map(|i| q + f64::from(i) * 0.01)
        .filter_map(|q1| step.residual(model, &[q1]).ok().map(|r| (q1, r[0])))
        .collect();
    let sign_change = samples
        .windows(2)
        .any(|w| w[0].1.signum() != w[1].1.signum());
    let closest = samples
        .iter()
        .copied()
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    if let (false, Some((q1, r))) = (sign_change, closest) {
        eprintln!(
            "#   diagnosis: no q_(k+1) in [{:.2}, {:.2}] solves the step: the residual p_k + D1 L_d + f_d- never changes sign; \
             |residual| is smallest ({:.3e}) at q_(k+1) = {q1:.3}, a fold of the non-equivalence-preserving discrete Legendre transform",
            q - 3.0,
            q + 3.0,
            r.abs()
        );
    } else {
        eprintln!(
            "#   diagnosis: the residual changes sign in q_k ± 3: a solution exists, Newton missed it"
        );
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let model = ArtificialPotential { a: 100.0 };
    let steps = (T_END / H).round() as usize;
    let runs = [
        (
            "ep",
            ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::trapezoid()),
        ),
        (
            "non-ep",
            ShootingDiscretisation::non_equivalence_preserving(
                OneStepMap::Rk4,
                QuadratureRule::simpson(),
                QuadratureRule::trapezoid(),
            ),
        ),
    ];
    let exact: Vec<(f64, f64)> = (0..=steps)
        .map(|k| k as f64 * H)
        .map(|t| (t, t.cos()))
        .collect();
    let mut chart = LineChart::new(
        "Figure 3: artificial potential 100q⁵ cancelled by a force (RK4 shooting, h = 0.05)",
    )
    .x_label("t")
    .y_label("q")
    .size(1100, 600)
    .y_range(-1.75, 1.1)
    .legend(LegendPosition::LowerRight)
    .with_series(
        Series::new("exact: cos t", exact.clone())
            .color(0, 0, 0)
            .width(3),
    );
    let mut zoom =
        LineChart::new("Figure 3 (first 5 time units): the non-ep step has no solution at t = 2.5")
            .x_label("t")
            .y_label("q")
            .x_range(0.0, 5.0)
            .legend(LegendPosition::UpperRight)
            .with_series(
                Series::new(
                    "exact: cos t",
                    exact.into_iter().filter(|p| p.0 <= 5.0).collect(),
                )
                .color(0, 0, 0)
                .width(3),
            );
    println!("discretisation,max_err");
    for (i, (name, discretisation)) in runs.into_iter().enumerate() {
        let mut sim = ShootingIntegrator::new(model, discretisation.clone(), H)?;
        sim.set_state([1.0], [0.0], 0.0);
        let mut trajectory = Vec::with_capacity(steps + 1);
        let mut max_err = 0.0_f64;
        let outcome = sim.run(steps, |_, t, q, _| {
            trajectory.push((t, q[0]));
            max_err = max_err.max((q[0] - t.cos()).abs());
        });
        match outcome {
            Ok(()) => println!("{name},{max_err:.6e}"),
            Err(e) => {
                println!("{name},nan");
                eprintln!(
                    "# {name} failed after {} steps (t = {:.2}, max |q − cos t| so far {max_err:.3e}): {e}",
                    sim.steps_taken(),
                    sim.t()
                );
                diagnose(&model, &discretisation, sim.q()[0], sim.p()[0], sim.t());
            }
        }
        let (color, style) = [
            ((31, 119, 180), LineStyle::Dashed),
            ((214, 39, 40), LineStyle::Solid),
        ][i];
        let mut label = if name == "ep" {
            "ep: trapezoid on L_d and f_d".to_string()
        } else {
            "non-ep: Simpson on L_d, trapezoid on f_d".to_string()
        };
        if let Some(&(t_last, _)) = trajectory.last().filter(|_| sim.steps_taken() < steps) {
            label.push_str(&format!(" (no step solution after t = {t_last:.2})"));
        }
        let early: Vec<(f64, f64)> = trajectory.iter().copied().filter(|p| p.0 <= 5.0).collect();
        zoom.push(
            Series::new(label.clone(), early)
                .color(color.0, color.1, color.2)
                .style(style)
                .markers(name == "non-ep"),
        );
        chart.push(
            Series::new(label, trajectory)
                .color(color.0, color.1, color.2)
                .style(style),
        );
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/figures");
    std::fs::create_dir_all(&dir)?;
    chart.save_svg(dir.join("paper_fig3_artificial.svg"))?;
    chart.save_png(dir.join("paper_fig3_artificial.png"))?;
    zoom.save_svg(dir.join("paper_fig3_artificial_zoom.svg"))?;
    zoom.save_png(dir.join("paper_fig3_artificial_zoom.png"))?;
    eprintln!(
        "# wrote {}",
        dir.join("paper_fig3_artificial{,_zoom}.{svg,png}")
            .display()
    );
    Ok(())
}
