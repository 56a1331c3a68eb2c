//! Interconnection of subsystems (MATH §5).
//!
//! A [`Subsystem`] is a model on its own coordinates with internal constraints and named
//! [`Port`]s; it knows nothing of the graph. An [`Interconnection`] joins ports by connections:
//! electrical nodes (KCL), rigid joints (equal port velocities), coupling elements (springs,
//! dampers, any potential or force of two port coordinates) and holonomic constraints on several
//! port values ([`PortConstraint`]: joints between rigid bodies). The [`Assembler`] turns one graph into
//! an ordinary [`dirac_core::Model`] plus [`dirac_core::Constraints`] on the global coordinates, in
//! the representation asked for:
//!
//! - [`Representation::Monolithic`]: coupling potentials inside the one Lagrangian;
//! - [`Representation::Constraint`]: each coupling acts on a massless endpoint coordinate that a joint
//!   ties to the partner port; the joint multipliers are the interaction forces;
//! - [`Representation::InteractionForce`]: coupling potentials applied as equal-and-opposite forces,
//!   discretised by the same quadrature as `L_d`.
//!
//! With an equivalence-preserving discretisation all three give the same discrete trajectory
//! (positions; momenta modulo constraint impulses). Staggered co-simulation, which is not
//! equivalent on purpose, lives in `dirac-sim`'s consumers (see [`StaggeredPlan`]).

mod assembler;
mod coupling;
mod error;
mod interconnection;
mod memo;
mod part_error;
mod port_constraint;
mod subsystem;

pub use assembler::{
    AssembledConstraints, AssembledModel, AssembledSystem, Assembler, FrozenCouplingModel,
    Representation, SharedConstraints, StaggeredLink, StaggeredPlan,
};
pub use coupling::CouplingElement;
pub use error::GraphError;
pub use interconnection::{
    Connection, ConnectionId, Interconnection, MAX_CONSTRAINT_PORTS, PortRef, SubsystemId,
};
pub use memo::StructureMemo;
pub use part_error::{Check, PartError};
pub use port_constraint::PortConstraint;
pub use subsystem::{Port, Subsystem};
