//! Errors in building or assembling an interconnection.

use thiserror::Error;

use crate::part_error::PartError;

/// A modelling error, naming the subsystem, port or connection at fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GraphError {
    /// A part's parameter is out of range.
    #[error(transparent)]
    Part(#[from] PartError),
    /// Two subsystems share a name.
    #[error("subsystem `{0}` is defined twice")]
    DuplicateSubsystem(String),
    /// A connection names a subsystem that does not exist.
    #[error("unknown subsystem `{0}`")]
    UnknownSubsystem(String),
    /// A connection names a port the subsystem does not have.
    #[error("subsystem `{subsystem}` has no port `{port}`")]
    UnknownPort {
        /// The subsystem.
        subsystem: String,
        /// The missing port.
        port: String,
    },
    /// A port refers to a coordinate the subsystem does not have.
    #[error("port `{port}` of `{subsystem}` uses coordinate {coordinate}, but the model has {dim}")]
    PortOutOfRange {
        /// The subsystem.
        subsystem: String,
        /// The port.
        port: String,
        /// The offending coordinate.
        coordinate: usize,
        /// The model's dimension.
        dim: usize,
    },
    /// A node joins fewer than two ports.
    #[error("connection `{0}` joins fewer than two ports")]
    TooFewPorts(String),
    /// A holonomic connection reads no port or too many, or has no rows.
    #[error(
        "constraint `{connection}` reads {ports} ports and has {rows} rows (it needs 1 to {max} ports and at least one row)",
        max = crate::interconnection::MAX_CONSTRAINT_PORTS
    )]
    ConstraintShape {
        /// The connection.
        connection: String,
        /// Ports it reads.
        ports: usize,
        /// Rows it has.
        rows: usize,
    },
    /// Staggered co-simulation cannot split a constraint between subsystems.
    #[error(
        "staggered co-simulation needs coupling elements between subsystems; connection `{0}` is a node, joint or holonomic constraint"
    )]
    StaggeredNeedsCouplings(String),
    /// Initial data have the wrong length.
    #[error("initial data for `{subsystem}` have length {got}, expected {expected}")]
    InitialDimension {
        /// The subsystem.
        subsystem: String,
        /// Given length.
        got: usize,
        /// Model dimension.
        expected: usize,
    },
}
