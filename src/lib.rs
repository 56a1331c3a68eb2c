//! `dirac`: forced discrete Dirac variational integrators for interconnected mechanical and
//! electrical systems.
//!
//! This facade re-exports the workspace crates:
//! - [`core`] (`dirac-core`): models, constraints, discretisations, step equations;
//! - [`graph`] (`dirac-graph`): subsystems, the interconnection graph, the assembler;
//! - [`solve`] (`dirac-solve`): Newton with dense and sparse LU;
//! - [`sim`] (`dirac-sim`): the integrator.

pub use dirac_core as core;
pub use dirac_graph as graph;
pub use dirac_sim as sim;
pub use dirac_solve as solve;

#[cfg(test)]
mod tests {
    //! The facade's paths end to end (graph → assembler → integrator), against the exact discrete
    //! solution. Two unit masses on unit wall springs joined by a spring κ have normal modes
    //! `x₁ + x₂` (ω² = 1) and `x₁ − x₂` (ω² = 1 + 2κ). The midpoint rule maps each mode, started
    //! at rest, to `cos(kθ)` with `tan(θ/2) = ωh/2` exactly (a Cayley rotation), so from
    //! `x = (1, 0)`: `x₁,k = ½(cos kθ₁ + cos kθ₂)`, `x₂,k = ½(cos kθ₁ − cos kθ₂)`.

    use crate::core::Discretisation;
    use crate::graph::{Assembler, Interconnection, LinearSpring, Representation};
    use crate::sim::{Integrator, IntegratorOptions};
    use dirac_components::Mass;

    /// Round-off over 1000 steps of order-one positions (measured 1.1e-14).
    const ROUND_OFF: f64 = 1e-12;

    #[test]
    fn coupled_masses_follow_the_exact_midpoint_solution() {
        let (kappa, h, steps) = (0.6, 0.1, 1000);
        let mut g = Interconnection::new();
        for name in ["A", "B"] {
            g.add_subsystem(
                Mass {
                    m: 1.0,
                    k: 1.0,
                    c: 0.0,
                }
                .subsystem(name),
            )
            .unwrap();
        }
        let (a, b) = (g.port("A", "x").unwrap(), g.port("B", "x").unwrap());
        g.coupling(
            "k",
            a,
            b,
            LinearSpring {
                k: kappa,
                rest: 0.0,
            },
        );
        let theta = |w: f64| 2.0 * (0.5 * w * h).atan();
        let (t1, t2) = (theta(1.0), theta((1.0 + 2.0 * kappa).sqrt()));
        let names = ["A".to_string(), "B".to_string()];
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let system = Assembler::assemble(&g, rep).unwrap();
            let q = system
                .global_vector(&[vec![1.0], vec![0.0]], &names)
                .unwrap();
            let mut sim = Integrator::new(
                system.model.clone(),
                system.constraints.clone(),
                IntegratorOptions::new(Discretisation::midpoint(), h),
            )
            .unwrap();
            sim.initialise(&q, &vec![0.0; q.len()], 0.0).unwrap();
            let mut worst = 0.0_f64;
            for k in 1..=steps {
                sim.step().unwrap();
                let (c1, c2) = ((k as f64 * t1).cos(), (k as f64 * t2).cos());
                let x = system.subsystem_positions(sim.q());
                worst = worst
                    .max((x[0] - 0.5 * (c1 + c2)).abs())
                    .max((x[1] - 0.5 * (c1 - c2)).abs());
            }
            println!("{rep}: largest deviation from the exact midpoint solution {worst:.2e}");
            assert!(worst <= ROUND_OFF, "{rep}: {worst:e}");
        }
    }
}
