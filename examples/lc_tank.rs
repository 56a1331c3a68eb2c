//! Degenerate LC tank: energy conserved to round-off over 10⁶ steps.
//!
//! `cargo run --release --example lc_tank`
//!
//! q = (q_C, q_L), L = ½ L v_L² − q_C²/(2C) (no kinetic term for q_C), one-form dq_L − dq_C,
//! L = C = 1, q_C(0) = 1, h = 0.1, (+) midpoint, run through `Simulation` as one part with its
//! loop constraint. Energy uses the loop momentum P = p_C + p_L: `P²/(2L) + q_C²/(2C)` recorded
//! from the momentum and position probes. Prints
//! `steps,t_end,max_rel_energy_error,newton_iterations_per_step,factorisations`.

use std::error::Error;

use dirac::prelude::*;
use dirac_problems::LcTank;

fn main() -> Result<(), Box<dyn Error>> {
    let tank = LcTank { l: 1.0, c: 1.0 };
    let (h, steps) = (0.1, 1_000_000);
    let mut g = Interconnection::new();
    g.add_subsystem(Subsystem::new("tank", tank).with_constraints(LcTank::kcl()))?;
    let q_c = Probe::position(&g, "tank", "qC")?;
    let loop_p = Probe::Sum(vec![
        (Probe::momentum(&g, "tank", "qC")?, 1.0),
        (Probe::momentum(&g, "tank", "qL")?, 1.0),
    ]);
    let energy = Probe::Sum(vec![
        (
            Probe::Product(Box::new(loop_p.clone()), Box::new(loop_p)),
            1.0 / (2.0 * tank.l),
        ),
        (
            Probe::Product(Box::new(q_c.clone()), Box::new(q_c)),
            1.0 / (2.0 * tank.c),
        ),
    ]);
    let mut sim = Simulation::new(
        g,
        Representation::Monolithic,
        IntegratorOptions::new(Discretisation::midpoint(), h),
    );
    sim.set_position("tank", "qC", 1.0)?;
    let mut e0 = None;
    let mut worst: f64 = 0.0;
    let summary = sim.run_into(
        steps as f64 * h,
        &[Signal::new("energy", energy)],
        &mut |_: usize, _: f64, e: &[f64]| {
            let e0 = *e0.get_or_insert(e[0]);
            worst = worst.max((e[0] - e0).abs() / e0);
            Ok(())
        },
    )?;
    println!("steps,t_end,max_rel_energy_error,newton_iterations_per_step,factorisations");
    println!(
        "{},{},{worst:e},{},{}",
        summary.steps,
        sim.time(),
        summary.newton_iterations_per_step(),
        summary.factorisations
    );
    Ok(())
}
