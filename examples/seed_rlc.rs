//! The seed paper's RLC loop (§4): (+) or (−) forced discrete Dirac integrator, midpoint rule.
//!
//! `cargo run --release --example seed_rlc -- --flavour plus|minus`
//!
//! L = 0.75, C = 3, R = 0.1, h = 0.05, 1000 steps, q_C(0) = 1, zero current; coordinates
//! (q_C, q_L, q_R) with ω¹ = dq_L − dq_R, ω² = dq_R − dq_C and force −R v_R. Prints `t,qC,exact`
//! CSV (exact: L q̈ + R q̇ + q/C = 0; t = k·h, run through `Simulation`) and `max_err=<value>` as the last line on stderr; writes
//! docs/figures/seed_rlc_<flavour>.{svg,png}.

use std::error::Error;
use std::io::Write;

use dirac::prelude::*;
use dirac_problems::{RlcLoop, rlc_exact};

fn parse_flavour() -> Result<Flavour, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().position(|a| a == "--flavour") {
        None => Ok(Flavour::Plus),
        Some(i) => match args.get(i + 1).map(String::as_str) {
            Some("plus" | "+") => Ok(Flavour::Plus),
            Some("minus" | "-") => Ok(Flavour::Minus),
            other => Err(format!(
                "--flavour expects `plus` or `minus`, got {other:?}"
            )),
        },
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let flavour = parse_flavour()?;
    let rlc = RlcLoop::seed();
    let (h, t_end) = (0.05, 50.0);
    let mut g = Interconnection::new();
    g.add_subsystem(Subsystem::new("rlc", rlc).with_constraints(RlcLoop::kcl()))?;
    let q_c = [Signal::new("qC", Probe::position(&g, "rlc", "qC")?)];
    let options = IntegratorOptions::new(Discretisation::midpoint(), h).flavour(flavour);
    let mut sim = Simulation::new(g, Representation::Monolithic, options);
    sim.set_position("rlc", "qC", 1.0)?;
    for coordinate in ["qC", "qL", "qR"] {
        sim.set_velocity("rlc", coordinate, 0.0)?;
    }
    let (run, _) = sim.run(t_end, &q_c)?;
    let rows: Vec<(f64, f64, f64)> = (0..run.len())
        .map(|k| (run.t()[k], run.row(k)[0], rlc_exact(&rlc, 1.0, run.t()[k])))
        .collect();
    let mut out = std::io::stdout().lock();
    writeln!(out, "t,qC,exact")?;
    let mut max_err: f64 = 0.0;
    for (t, q, e) in &rows {
        writeln!(out, "{t},{q},{e}")?;
        max_err = max_err.max((q - e).abs());
    }
    let name = match flavour {
        Flavour::Plus => "plus",
        Flavour::Minus => "minus",
    };
    let exact: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.2)).collect();
    let simulated: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
    let path = format!("docs/figures/seed_rlc_{name}");
    let sign = if name == "plus" { "+" } else { "−" };
    let chart =
        dirac_output::LineChart::new(format!("Seed RLC loop, ({sign}) Dirac, midpoint, h = 0.05"))
            .x_label("t")
            .y_label("q_C")
            .with_series(dirac_output::Series::new("exact", exact))
            .with_series(
                dirac_output::Series::new("simulated", simulated)
                    .style(dirac_output::LineStyle::Dotted),
            );
    chart.save_svg(format!("{path}.svg"))?;
    chart.save_png(format!("{path}.png"))?;
    eprintln!("figures: {path}.svg, {path}.png");
    eprintln!("max_err={max_err:e}");
    Ok(())
}
