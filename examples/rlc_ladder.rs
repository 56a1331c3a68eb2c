//! RLC ladder of N sections assembled from N section subsystems, driven by a 1 V DC source.
//!
//! `cargo run --release --example rlc_ladder -- --sections N --steps 1000`
//!
//! Each section: series R = 0.1 and L = 1, then a shunt C = 1 to ground; KCL at every internal
//! node; h = 0.01, midpoint, (+) flavour, monolithic representation. Prints
//! `sections,steps,wall_s,v1_end` (`wall_s`: assembly, initialisation and stepping; `v1_end`: the
//! first shunt capacitor's voltage at t_end) and, on stderr, the unknown count and solver counters.

use std::error::Error;
use std::time::Instant;

use dirac::core::Discretisation;
use dirac::graph::{Assembler, Representation};
use dirac::sim::{Integrator, IntegratorOptions};
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
    let system = Assembler::assemble(&g, Representation::Monolithic)?;
    let n = system.coordinates();
    let options = IntegratorOptions::new(Discretisation::midpoint(), 0.01);
    let mut sim = Integrator::new(system.model.clone(), system.constraints.clone(), options)?;
    sim.initialise(&vec![0.0; n], &vec![0.0; n], 0.0)?;
    let setup = start.elapsed().as_secs_f64();
    for _ in 0..steps {
        sim.step()?;
    }
    let wall = start.elapsed().as_secs_f64();
    // First shunt capacitor: S1.qc, global index 1 + 1.
    let v1 = sim.q()[system.global_index(dirac::graph::SubsystemId(1), 1)] / section.c;
    let stats = sim.stats();
    eprintln!(
        "coordinates {n}, constraints {}, setup {setup:.3} s, {:.3} us/step/section, Newton iterations/step {:.2}, factorisations {}",
        system.constraint_rows(),
        (wall - setup) / steps as f64 / sections as f64 * 1e6,
        stats.iterations as f64 / steps as f64,
        stats.factorisations
    );
    println!("sections,steps,wall_s,v1_end");
    println!("{sections},{steps},{wall:.3},{v1}");
    Ok(())
}
