//! Two masses on walls joined by a spring, built from two subsystems and compared across
//! representations.
//!
//! `cargo run --release --example two_mass_split`
//!
//! m₁ = m₂ = 1, wall springs k₁ = k₂ = 1, coupling spring k = 1, x(0) = (1, 0), v(0) = 0, h = 0.1,
//! 1000 steps, midpoint, (+) flavour. Prints `representation,max_dev` (max over steps of the
//! position deviation from the monolithic model) for `constraint` (massless endpoint of A joined
//! to B), `force` (coupling as interaction forces), `staggered-gs` and `staggered-jacobi`
//! (co-simulation), and writes docs/figures/two_mass_split.svg. The size of each assembled
//! representation (coordinates, constraint rows, unknowns, Jacobian entries) goes to stderr.

use std::error::Error;

use dirac::core::{Discretisation, Flavour};
use dirac::graph::{Assembler, Interconnection, LinearSpring, Representation};
use dirac::sim::{Integrator, IntegratorOptions, Splitting, Staggered};
use dirac_components::Mass;

fn graph() -> Result<Interconnection, Box<dyn Error>> {
    let mut g = Interconnection::new();
    g.add_subsystem(
        Mass {
            m: 1.0,
            k: 1.0,
            c: 0.0,
        }
        .subsystem("A"),
    )?;
    g.add_subsystem(
        Mass {
            m: 1.0,
            k: 1.0,
            c: 0.0,
        }
        .subsystem("B"),
    )?;
    let (a, b) = (g.port("A", "x")?, g.port("B", "x")?);
    g.coupling("spring", a, b, LinearSpring { k: 1.0, rest: 0.0 });
    Ok(g)
}

fn assembled(
    g: &Interconnection,
    rep: Representation,
    options: &IntegratorOptions,
    steps: usize,
) -> Result<Vec<Vec<f64>>, Box<dyn Error>> {
    let system = Assembler::assemble(g, rep)?;
    let names = vec!["A".to_string(), "B".to_string()];
    let q = system.global_vector(&[vec![1.0], vec![0.0]], &names)?;
    let mut sim = Integrator::new(
        system.model.clone(),
        system.constraints.clone(),
        options.clone(),
    )?;
    sim.initialise(&q, &vec![0.0; q.len()], 0.0)?;
    let mut out = vec![system.subsystem_positions(sim.q()).to_vec()];
    for _ in 0..steps {
        sim.step()?;
        out.push(system.subsystem_positions(sim.q()).to_vec());
    }
    eprintln!(
        "{rep}: {} coordinates, {} constraint rows, {} unknowns per step, {} Jacobian entries",
        system.coordinates(),
        system.constraint_rows(),
        sim.unknowns(),
        sim.jacobian_entries()
    );
    Ok(out)
}

fn staggered(
    g: &Interconnection,
    splitting: Splitting,
    options: &IntegratorOptions,
    steps: usize,
) -> Result<Vec<Vec<f64>>, Box<dyn Error>> {
    let mut sim = Staggered::new(g, options, splitting)?;
    sim.initialise(&[vec![1.0], vec![0.0]], &[vec![0.0], vec![0.0]], 0.0)?;
    let mut out = vec![sim.positions()];
    for _ in 0..steps {
        sim.step()?;
        out.push(sim.positions());
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn Error>> {
    let g = graph()?;
    let (h, steps) = (0.1, 1000);
    let options = IntegratorOptions::new(Discretisation::midpoint(), h).flavour(Flavour::Plus);
    let mono = assembled(&g, Representation::Monolithic, &options, steps)?;
    let runs = [
        (
            "constraint",
            assembled(&g, Representation::Constraint, &options, steps)?,
        ),
        (
            "force",
            assembled(&g, Representation::InteractionForce, &options, steps)?,
        ),
        (
            "staggered-gs",
            staggered(&g, Splitting::GaussSeidel, &options, steps)?,
        ),
        (
            "staggered-jacobi",
            staggered(&g, Splitting::Jacobi, &options, steps)?,
        ),
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
