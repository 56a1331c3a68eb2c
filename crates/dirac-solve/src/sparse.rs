//! Sparse LU on faer (being written; this stub only lets the workspace build).

use crate::error::LinearSolveError;
use crate::newton::LinearSolver;

/// Sparse LU (stub).
#[derive(Debug, Default)]
pub struct SparseLu;

impl LinearSolver for SparseLu {
    fn analyse(&mut self, _: usize, _: &[usize], _: &[usize]) -> Result<(), LinearSolveError> {
        Err(LinearSolveError::Backend("not yet".into()))
    }
    fn factor(&mut self, _: &[f64]) -> Result<(), LinearSolveError> {
        Err(LinearSolveError::Backend("not yet".into()))
    }
    fn solve_in_place(&mut self, _: &mut [f64]) -> Result<(), LinearSolveError> {
        Err(LinearSolveError::Backend("not yet".into()))
    }
}
