//! Errors in describing rigid bodies and joints.

use thiserror::Error;

/// A modelling error, naming the body or joint at fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RigidError {
    /// The mass is not positive and finite.
    #[error("rigid body mass must be positive and finite, got {0}")]
    Mass(f64),
    /// The inertia tensor is not a physical one.
    #[error("inertia tensor {inertia:?} is not admissible: {reason}")]
    Inertia {
        /// The tensor given.
        inertia: [[f64; 3]; 3],
        /// What is wrong with it.
        reason: String,
    },
    /// A body-fixed frame is not a rotation.
    #[error(
        "joint `{joint}`: the frame on side {side} is not a rotation (‖RᵀR − I‖ = {error:.1e}, det = {det})"
    )]
    Frame {
        /// The joint.
        joint: String,
        /// `a` or `b`.
        side: char,
        /// Its orthonormality error.
        error: f64,
        /// Its determinant.
        det: f64,
    },
    /// Both sides of a joint are the ground.
    #[error("joint `{0}` joins the ground to itself")]
    GroundToGround(String),
    /// A joint kind without a single coordinate was asked for one.
    #[error("joint `{joint}` is {kind:?}: it has no single angle or slide to couple")]
    NoJointCoordinate {
        /// The joint.
        joint: String,
        /// Its kind.
        kind: crate::joint::JointKind,
    },
    /// A graph operation failed (unknown body or port, bad connection, a part's parameter out of
    /// range).
    #[error(transparent)]
    Graph(#[from] dirac_graph::GraphError),
}

impl From<dirac_graph::PartError> for RigidError {
    fn from(e: dirac_graph::PartError) -> Self {
        Self::Graph(e.into())
    }
}
