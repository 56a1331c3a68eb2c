//! Time-unaware Newton solver for the implicit step equations of `dirac`.
//!
//! This crate knows residuals and Jacobians, not Lagrangians: a [`NonlinearSystem`] supplies `F(x)`
//! and the Jacobian as a fixed stream of triplets ([`Triplets`]); [`Newton`] solves `F(x) = 0` with
//! a [`LinearSolver`] back end (dense LU for small systems, sparse LU on faer for large ones).
//!
//! The Jacobian pattern is analysed once; afterwards values are refilled in place, rows are
//! equilibrated, and for systems whose Jacobian is constant the factorisation is reused for the
//! whole run. Every solve is checked for non-finite values, so a numerically singular matrix is
//! reported as an error instead of propagating NaN.
//!
//! [`Structure`] analyses a pattern without values (maximum matching, Dulmage–Mendelsohn partition):
//! which unknowns no equation can fix and which equations over-determine theirs.

mod dense;
mod error;
mod newton;
mod ordering;
mod pivoting;
mod sparse;
mod structure;
mod triplets;

pub use dense::DenseLu;
pub use error::{LinearSolveError, NewtonError};
pub use newton::{LinearSolver, Newton, NewtonOptions, NewtonStats, NonlinearSystem, Precision};
pub use sparse::SparseLu;
pub use structure::Structure;
pub use triplets::{PatternMismatch, Triplets};
