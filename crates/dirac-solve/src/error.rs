//! Typed errors of the linear and nonlinear solvers.

use thiserror::Error;

use crate::triplets::PatternMismatch;

/// Failure of a linear solve. Indices are equation (row) or unknown (column) indices of the system.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LinearSolveError {
    /// A row of the matrix has no nonzero entry: that equation constrains nothing.
    #[error("equation {row} has no nonzero entry")]
    EmptyRow {
        /// The empty row.
        row: usize,
    },
    /// A column has no entry: no equation determines that unknown.
    #[error("unknown {col} appears in no equation")]
    EmptyColumn {
        /// The empty column.
        col: usize,
    },
    /// The pattern admits no nonsingular matrix (structural rank deficiency).
    #[error("matrix is structurally singular near unknown {index}")]
    StructurallySingular {
        /// Index reported by the symbolic factorisation.
        index: usize,
    },
    /// A pivot vanished (relative to the row scale) during numeric factorisation.
    #[error("matrix is numerically singular at pivot {index}")]
    NumericallySingular {
        /// The elimination step (unknown index) whose pivot vanished.
        index: usize,
    },
    /// The solve produced NaN or infinity.
    #[error("linear solve produced a non-finite value in unknown {index}")]
    NonFinite {
        /// First non-finite entry of the solution.
        index: usize,
    },
    /// The triplet stream does not match the analysed pattern.
    #[error(transparent)]
    Pattern(#[from] PatternMismatch),
    /// The back end failed for another, reported reason.
    #[error("sparse factorisation failed: {0}")]
    Backend(String),
}

/// Failure of a Newton solve.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum NewtonError {
    /// Newton ran out of iterations.
    #[error(
        "Newton did not converge in {iterations} iterations (residual {residual:.3e}; equation {worst_equation} is {relative_residual:.1e} of the size of its terms)"
    )]
    NotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Max-norm of the last residual.
        residual: f64,
        /// The largest residual relative to the size of its equation's terms
        /// (`|F_i| / Σ_j |J_ij x_j|`, with the last Jacobian evaluated).
        relative_residual: f64,
        /// Equation with the largest relative residual.
        worst_equation: usize,
    },
    /// The residual became NaN or infinite.
    #[error("residual is not finite in equation {equation} after {iterations} iterations")]
    NonFiniteResidual {
        /// First non-finite equation.
        equation: usize,
        /// Iterations performed.
        iterations: usize,
    },
    /// The Newton matrix could not be factorised or solved.
    #[error("Newton matrix: {source} (residual {residual:.3e} in equation {worst_equation})")]
    Linear {
        /// Underlying linear-solver failure.
        source: LinearSolveError,
        /// Max-norm of the residual when it failed.
        residual: f64,
        /// Equation with the largest residual when it failed.
        worst_equation: usize,
    },
}
