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

/// The user guide's Rust examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../docs/guide.md")]
pub struct GuideDoctests;
