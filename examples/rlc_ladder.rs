//! RLC ladder of N sections assembled from N section subsystems, driven by a 1 V DC source.
//!
//! `cargo run --release --example rlc_ladder -- --sections N --steps 1000`
//!
//! Each section: series R = 0.1 and L = 1, then a shunt C = 1 to ground; KCL at every internal
//! node; h = 0.01, midpoint, (+) flavour, monolithic representation, run through `Simulation`.
//! Prints `sections,steps,wall_s,v1_end` (`wall_s`: assembly, initialisation and stepping;
//! `v1_end`: the first shunt capacitor's voltage at t_end) and, on stderr, the unknown count and
//! solver counters.

use std::error::Error;
use std::time::Instant;

use dirac::prelude::*;
use dirac_problems::{LadderSection, rlc_ladder};

fn arg(name: &str, default: usize) -> Result<usize, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => args
            .get(i + 1)
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| format!("{name} expects a positive integer")),
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let sections = arg("--sections", 1000)?;
    let steps = arg("--steps", 1000)?;
    if sections == 0 {
        return Err("--sections must be at least 1".into());
    }
    let start = Instant::now();
    let section = LadderSection {
        r: 0.1,
        l: 1.0,
        c: 1.0,
    };
    let g = rlc_ladder(sections, section)?;
    // First shunt capacitor's charge: part S1, coordinate qc.
    let q1 = Signal::new("S1.qc", Probe::position(&g, "S1", "qc")?);
    let h = 0.01;
    let mut sim = Simulation::new(
        g,
        Representation::Monolithic,
        IntegratorOptions::new(Discretisation::midpoint(), h),
    );
    sim.prepare()?;
    let setup = start.elapsed().as_secs_f64();
    let mut q1_end = f64::NAN;
    let summary = sim.run_into(
        steps as f64 * h,
        &[q1],
        &mut |_: usize, _: f64, q: &[f64]| {
            q1_end = q[0];
            Ok(())
        },
    )?;
    let wall = start.elapsed().as_secs_f64();
    let v1 = q1_end / section.c;
    let (n, rows) = sim.assembled().map_or((0, 0), |(system, _)| {
        (system.coordinates(), system.constraint_rows())
    });
    eprintln!(
        "coordinates {n}, constraints {rows}, setup {setup:.3} s, {:.3} us/step/section, Newton iterations/step {:.2}, factorisations {}",
        (wall - setup) / steps as f64 / sections as f64 * 1e6,
        summary.newton_iterations_per_step(),
        summary.factorisations
    );
    println!("sections,steps,wall_s,v1_end");
    println!("{sections},{steps},{wall:.3},{v1}");
    Ok(())
}
