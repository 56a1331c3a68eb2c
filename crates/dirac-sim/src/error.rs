//! Errors of the time stepper.

use dirac_solve::NewtonError;
use thiserror::Error;

/// Failure of a simulation, with where and when it happened.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimError {
    /// Newton failed in a step; `likely_cause` explains what usually produces this failure.
    #[error("step {step} (t = {}): {source}; {likely_cause}", Time(*.t))]
    Newton {
        /// Index of the step that failed (0 is the first step).
        step: usize,
        /// Time at the start of that step.
        t: f64,
        /// The solver's report.
        source: NewtonError,
        /// A short hint naming the likely cause.
        likely_cause: String,
    },
    /// A step solved to a root its model rejects ([`dirac_core::Model::check_step`]: a root of
    /// the step equations that the motion does not take), even as the smallest pieces.
    #[error("step {step} (t = {}): the step's solution was rejected: {reason}", Time(*.t))]
    StepRejected {
        /// Index of the step (0 is the first step).
        step: usize,
        /// Time at the start of the rejected (sub)step.
        t: f64,
        /// The model's reason, naming the part.
        reason: String,
    },
    /// The initial data violate a constraint that cannot be repaired by projecting velocities.
    #[error("inconsistent initial condition: {constraint} is violated by {residual:.3e}")]
    InconsistentInitialCondition {
        /// Name of the violated constraint.
        constraint: String,
        /// Its residual.
        residual: f64,
    },
    /// A constraint row has no nonzero coefficient: it constrains nothing.
    #[error("constraint `{constraint}` is empty (all its coefficients are zero)")]
    EmptyConstraint {
        /// Name of the empty row.
        constraint: String,
    },
    /// Vectors of the wrong length were given.
    #[error("{what} has length {got}, expected {expected}")]
    Dimension {
        /// Which argument.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The model dimension.
        expected: usize,
    },
    /// The interconnection could not be assembled.
    #[error(transparent)]
    Graph(#[from] dirac_graph::GraphError),
    /// A recorded value is NaN or infinite (the state left the model's domain).
    #[error("t = {}: `{what}` is not finite (the state left the model's domain)", Time(*.t))]
    NonFinite {
        /// The signal.
        what: String,
        /// The time of the row.
        t: f64,
    },
    /// The step's Newton matrix is singular whatever the values: its pattern matches only
    /// `rank` of its `size` equations to unknowns of their own (a coordinate nothing determines,
    /// or relations that fix the same unknowns twice). A bad model, found before the first step.
    #[error("structurally singular model: {}", structural(.undetermined, .overdetermined, *.rank, *.size))]
    StructurallySingular {
        /// The unknowns no set of the equations determines, named (coordinates, multipliers).
        undetermined: Vec<String>,
        /// The equations that over-determine their unknowns, named.
        overdetermined: Vec<String>,
        /// Structural rank of the Newton matrix.
        rank: usize,
        /// Its size.
        size: usize,
    },
    /// A non-positive or non-finite step size.
    #[error("step size must be positive and finite, got {0}")]
    StepSize(f64),
}

/// A time for messages: rounded to 12 significant digits, so that `t₀ + k·h` prints as `0.9`
/// rather than `0.8999999999999999`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Time(pub f64);

impl std::fmt::Display for Time {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rounded: f64 = format!("{:.11e}", self.0).parse().unwrap_or(self.0);
        write!(f, "{rounded}")
    }
}

/// At most this many names of each part of a structurally singular model are listed.
const NAMES_SHOWN: usize = 6;

/// The message of [`SimError::StructurallySingular`].
fn structural(
    undetermined: &[String],
    overdetermined: &[String],
    rank: usize,
    size: usize,
) -> String {
    let list = |names: &[String]| {
        let mut s = names
            .iter()
            .take(NAMES_SHOWN)
            .cloned()
            .collect::<Vec<_>>()
            .join(", ");
        if names.len() > NAMES_SHOWN {
            s.push_str(&format!(" and {} more", names.len() - NAMES_SHOWN));
        }
        s
    };
    let mut parts = Vec::new();
    if !undetermined.is_empty() {
        parts.push(format!(
            "nothing determines {} (a coordinate with neither inertia, potential, dissipation nor constraint, an unconnected port, or too few relations)",
            list(undetermined)
        ));
    }
    if !overdetermined.is_empty() {
        parts.push(format!(
            "no unknown is left to {} (redundant or contradicting relations, or an equation without any term)",
            list(overdetermined)
        ));
    }
    format!(
        "{} (the step's Newton matrix has structural rank {rank} of {size}, so every step would fail)",
        parts.join("; ")
    )
}
