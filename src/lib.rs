//! `dirac`: forced discrete Dirac variational integrators for interconnected mechanical and
//! electrical systems.
//!
//! Start from the [`prelude`]: it brings the parts, the interconnection graph and the run layer.
//! A model is parts joined at their ports ([`graph::Interconnection`], or
//! [`parts::CircuitBuilder`] for a circuit written as a netlist reads); a [`sim::Simulation`]
//! runs it in any representation and returns a trajectory of named signals.
//!
//! ```
//! use dirac::prelude::*;
//!
//! // A 1 µF capacitor charged to 1 V discharging through 1 kΩ: v(t) = e^{−t/RC}.
//! let mut c = CircuitBuilder::new();
//! c.resistor("R1", "1", "0", 1e3)?;
//! c.capacitor("C1", "1", "0", 1e-6)?;
//! let graph = c.build()?;
//! let v = Signal::new("v(1)", Probe::effort(&graph, "1")?);
//! let mut sim = Simulation::new(graph, Representation::Monolithic, IntegratorOptions::new(Discretisation::midpoint(), 1e-5));
//! sim.set_position("C1", "q", 1e-6)?;
//! let (trajectory, _) = sim.run(1e-3, &[v])?;
//! let end = trajectory.signal("v(1)").and_then(|v| v.last().copied()).unwrap_or(f64::NAN);
//! assert!((end - (-1.0_f64).exp()).abs() < 1e-4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The crates behind it, one idea each:
//! - [`core`] (`dirac-core`): models, constraints, discretisations, step equations;
//! - [`graph`] (`dirac-graph`): subsystems, the interconnection graph, the assembler;
//! - [`solve`] (`dirac-solve`): Newton with dense and sparse LU;
//! - [`sim`] (`dirac-sim`): the integrator and the run layer ([`sim::Simulation`]);
//! - [`parts`] (`dirac-components`): stock parts with checked parameters;
//! - [`netlist`] (`dirac-netlist`): SPICE-subset netlists → circuits;
//! - [`scene`] (`dirac-scene`): TOML scene files → interconnections;
//! - [`output`] (`dirac-output`): CSV and charts of trajectories.

pub use dirac_components as parts;
pub use dirac_core as core;
pub use dirac_graph as graph;
pub use dirac_netlist as netlist;
pub use dirac_output as output;
pub use dirac_scene as scene;
pub use dirac_sim as sim;
pub use dirac_solve as solve;

/// What a program that builds and runs a model needs, in one `use dirac::prelude::*`.
pub mod prelude {
    pub use dirac_components::{
        Capacitor, CircuitBuilder, CoupledInductors, CurrentSource, Damper, DcMotor, Diode,
        ForceSource, Ground, IdealGear, IdealTransformer, Inductor, Inertia, Mass, PartError,
        Pendulum, Resistor, Spring, VoltageSource, Waveform,
    };
    pub use dirac_core::{Discretisation, Flavour};
    pub use dirac_graph::{GraphError, Interconnection, Representation, Subsystem};
    pub use dirac_scene::Scene;
    pub use dirac_sim::{
        Execution, IntegratorOptions, Probe, RunError, RunSummary, Scheme, Signal, Simulation,
        Splitting, Start, Trajectory,
    };
}

/// The README's programs, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// Includes each page of docs/ as the documentation of an item, so that its Rust code blocks are
/// compiled and run as doctests, and lists the pages for `docs_checked` (one list for both).
macro_rules! doctested_pages {
    ($($item:ident = $page:literal),* $(,)?) => {
        /// The Rust code blocks of every page in docs/, compiled and run as doctests.
        #[cfg(doctest)]
        mod docs {
            $(
                #[doc = include_str!(concat!("../docs/", $page))]
                pub struct $item;
            )*
        }

        /// The pages of docs/ included as doctests.
        #[cfg(test)]
        const DOCTESTED_PAGES: &[&str] = &[$($page),*];
    };
}

doctested_pages! {
    Audit = "audit.md",
    Guide = "guide.md",
    Hardening = "hardening.md",
    Math = "math.md",
    Paper = "paper.md",
    Performance = "performance.md",
    Python = "python.md",
    Results = "results.md",
    Rigid = "rigid.md",
    Speed = "speed.md",
}

#[cfg(test)]
mod tests {
    //! The facade's path end to end (parts → graph → run layer, in every representation), against
    //! the exact discrete solution. Two unit masses tied to a wall (a ground at 0) by unit springs
    //! and joined by a spring κ have normal modes `x₁ + x₂` (ω² = 1) and `x₁ − x₂` (ω² = 1 + 2κ). The midpoint rule maps each mode, started
    //! at rest, to `cos(kθ)` with `tan(θ/2) = ωh/2` exactly (a Cayley rotation), so from
    //! `x = (1, 0)`: `x₁,k = ½(cos kθ₁ + cos kθ₂)`, `x₂,k = ½(cos kθ₁ − cos kθ₂)`.

    use crate::core::Discretisation;
    use crate::graph::{Interconnection, Representation};
    use crate::parts::{Ground, Mass, Spring};
    use crate::sim::{IntegratorOptions, Probe, Signal, Simulation};

    /// Round-off over 1000 steps of order-one positions (measured 1.1e-14).
    const ROUND_OFF: f64 = 1e-12;

    #[test]
    fn coupled_masses_follow_the_exact_midpoint_solution() {
        let (kappa, h, steps) = (0.6, 0.1, 1000);
        let mut g = Interconnection::new();
        for name in ["A", "B"] {
            g.add_subsystem(Mass::new(1.0).unwrap().subsystem(name))
                .unwrap();
        }
        g.add_subsystem(Ground::origin().subsystem("W")).unwrap();
        let (a, b) = (g.port("A", "x").unwrap(), g.port("B", "x").unwrap());
        let wall = g.port("W", "x").unwrap();
        g.coupling("k", a, b, Spring::linear(kappa).unwrap());
        g.coupling("A-W", a, wall, Spring::linear(1.0).unwrap());
        g.coupling("B-W", b, wall, Spring::linear(1.0).unwrap());
        let theta = |w: f64| 2.0 * (0.5 * w * h).atan();
        let (t1, t2) = (theta(1.0), theta((1.0 + 2.0 * kappa).sqrt()));
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let signals = [
                Signal::new("A.x", Probe::position(&g, "A", "x").unwrap()),
                Signal::new("B.x", Probe::position(&g, "B", "x").unwrap()),
            ];
            let mut sim = Simulation::new(
                g.clone(),
                rep,
                IntegratorOptions::new(Discretisation::midpoint(), h),
            );
            sim.set_position("A", "x", 1.0).unwrap();
            let (run, _) = sim.run(steps as f64 * h, &signals).unwrap();
            assert_eq!(run.len(), steps + 1);
            let mut worst = 0.0_f64;
            for k in 1..=steps {
                let (c1, c2) = ((k as f64 * t1).cos(), (k as f64 * t2).cos());
                let x = run.row(k);
                worst = worst
                    .max((x[0] - 0.5 * (c1 + c2)).abs())
                    .max((x[1] - 0.5 * (c1 - c2)).abs());
            }
            println!("{rep}: largest deviation from the exact midpoint solution {worst:.2e}");
            assert!(worst <= ROUND_OFF, "{rep}: {worst:e}");
        }
    }
}

#[cfg(test)]
mod docs_checked {
    //! Every page of docs/ is included as doctests, so a Rust code block added to any of them is
    //! compiled and run by `cargo test --doc -p dirac` (a page left out of `mod docs` would let its
    //! code rot unseen: issue 14).

    use super::DOCTESTED_PAGES;

    /// The doctested pages are exactly the Markdown files of docs/.
    ///
    /// Mutation: removing `Math = "math.md"` from `doctested_pages!` fails with
    /// `["math.md"]` listed as missing.
    #[test]
    fn every_docs_page_is_doctested() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs");
        let mut pages: Vec<String> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| name.ends_with(".md"))
            .collect();
        pages.sort();
        let missing: Vec<&String> = pages
            .iter()
            .filter(|p| !DOCTESTED_PAGES.contains(&p.as_str()))
            .collect();
        assert!(
            missing.is_empty(),
            "docs pages not included as doctests in src/lib.rs `mod docs`: {missing:?}"
        );
        assert_eq!(
            pages, DOCTESTED_PAGES,
            "src/lib.rs lists a page that is not in docs/"
        );
    }
}
