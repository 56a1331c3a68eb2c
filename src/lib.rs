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
