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
