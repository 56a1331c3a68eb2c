//! Degenerate LC tank: energy conserved to round-off over 10⁶ steps.
//!
//! `cargo run --release --example lc_tank`
//!
//! q = (q_C, q_L), L = ½ L v_L² − q_C²/(2C) (no kinetic term for q_C), one-form dq_L − dq_C,
//! L = C = 1, q_C(0) = 1, h = 0.1, (+) midpoint. Energy uses the loop momentum P = p_C + p_L.
//! Prints `steps,t_end,max_rel_energy_error,newton_iterations_per_step,factorisations`.

use std::error::Error;

use dirac::core::Discretisation;
use dirac::sim::{Integrator, IntegratorOptions};
use dirac_problems::LcTank;

fn main() -> Result<(), Box<dyn Error>> {
    let tank = LcTank { l: 1.0, c: 1.0 };
    let steps = 1_000_000;
    let mut sim = Integrator::new(
        tank,
        LcTank::kcl(),
        IntegratorOptions::new(Discretisation::midpoint(), 0.1),
    )?;
    sim.initialise(&[1.0, 0.0], &[0.0, 0.0], 0.0)?;
    let e0 = tank.energy(sim.q(), sim.p());
    let mut worst: f64 = 0.0;
    for _ in 0..steps {
        sim.step()?;
        worst = worst.max((tank.energy(sim.q(), sim.p()) - e0).abs() / e0);
    }
    let stats = sim.stats();
    println!("steps,t_end,max_rel_energy_error,newton_iterations_per_step,factorisations");
    println!(
        "{steps},{},{worst:e},{},{}",
        sim.t(),
        stats.iterations as f64 / steps as f64,
        stats.factorisations
    );
    Ok(())
}
