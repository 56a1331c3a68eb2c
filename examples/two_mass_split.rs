//! Two masses on walls joined by a spring, built from two subsystems and compared across
//! representations.
//!
//! `cargo run --release --example two_mass_split`
//!
//! m₁ = m₂ = 1, wall springs k₁ = k₂ = 1, coupling spring k = 1, x(0) = (1, 0), v(0) = 0, h = 0.1,
//! 1000 steps, midpoint, (+) flavour; each wall spring is a spring coupled to a ground, and every
//! run goes through `Simulation`. Prints `representation,max_dev` (max over steps of the
//! position deviation from the monolithic model) for `constraint` (massless endpoint of A joined
//! to B), `force` (coupling as interaction forces), `staggered-gs` and `staggered-jacobi`
//! (co-simulation), and writes docs/figures/two_mass_split.svg. The size of each assembled
//! representation (coordinates, constraint rows, unknowns, Jacobian entries) goes to stderr.

use std::error::Error;

use dirac::prelude::*;

/// The two masses, a wall (one ground at 0) with a spring from each mass, and the coupling spring.
fn graph() -> Result<Interconnection, Box<dyn Error>> {
    let mut g = Interconnection::new();
    g.add_subsystem(Mass::new(1.0)?.subsystem("A"))?;
    g.add_subsystem(Mass::new(1.0)?.subsystem("B"))?;
    g.add_subsystem(Ground::origin().subsystem("wall"))?;
    let (a, b, wall) = (g.port("A", "x")?, g.port("B", "x")?, g.port("wall", "x")?);
    g.coupling("spring", a, b, Spring::linear(1.0)?);
    g.coupling("wall-A", a, wall, Spring::linear(1.0)?);
    g.coupling("wall-B", b, wall, Spring::linear(1.0)?);
    Ok(g)
}

/// Positions `(x_A, x_B)` at every t_k, run through the run layer in `execution`.
fn run(
    g: &Interconnection,
    execution: Execution,
    options: &IntegratorOptions,
    t_end: f64,
) -> Result<Vec<Vec<f64>>, Box<dyn Error>> {
    let signals = [
        Signal::new("A.x", Probe::position(g, "A", "x")?),
        Signal::new("B.x", Probe::position(g, "B", "x")?),
    ];
    let mut sim = Simulation::new(g.clone(), execution, options.clone());
    sim.set_position("A", "x", 1.0)?;
    let (trajectory, _) = sim.run(t_end, &signals)?;
    if let Some((system, integrator)) = sim.assembled() {
        eprintln!(
            "{execution}: {} coordinates, {} constraint rows, {} unknowns per step, {} Jacobian entries",
            system.coordinates(),
            system.constraint_rows(),
            integrator.unknowns(),
            integrator.jacobian_entries()
        );
    }
    Ok((0..trajectory.len())
        .map(|k| trajectory.row(k).to_vec())
        .collect())
}

fn main() -> Result<(), Box<dyn Error>> {
    let g = graph()?;
    let (h, t_end) = (0.1, 100.0);
    let options = IntegratorOptions::new(Discretisation::midpoint(), h).flavour(Flavour::Plus);
    let assembled = |r| run(&g, Execution::Assembled(r), &options, t_end);
    let staggered = |s| run(&g, Execution::Staggered(s), &options, t_end);
    let mono = assembled(Representation::Monolithic)?;
    let runs = [
        ("constraint", assembled(Representation::Constraint)?),
        ("force", assembled(Representation::InteractionForce)?),
        ("staggered-gs", staggered(Splitting::GaussSeidel)?),
        ("staggered-jacobi", staggered(Splitting::Jacobi)?),
    ];
    println!("representation,max_dev");
    let mut chart =
        dirac_output::LineChart::new("Two-mass split: deviation of x1 from monolithic, h = 0.1")
            .x_label("t")
            .y_label("|x - x_monolithic|")
            .log_y(true);
    for (name, run) in &runs {
        let dev = run
            .iter()
            .zip(&mono)
            .map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
            })
            .fold(0.0_f64, f64::max);
        println!("{name},{dev:e}");
        let series: Vec<(f64, f64)> = run
            .iter()
            .zip(&mono)
            .enumerate()
            .step_by(5)
            .map(|(k, (a, b))| (k as f64 * h, (a[0] - b[0]).abs().max(1e-17)))
            .collect();
        chart.push(dirac_output::Series::new(*name, series));
    }
    chart.save_svg("docs/figures/two_mass_split.svg")?;
    Ok(())
}
