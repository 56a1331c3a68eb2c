//! Choice of linear solver by system size.

use dirac_solve::{DenseLu, LinearSolveError, LinearSolver, SparseLu};

/// Which linear solver the Newton iteration uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverChoice {
    /// Dense up to [`DenseLu::AUTO_LIMIT`] unknowns, sparse LU above; an integrator's steps with
    /// a constant Jacobian (a linear circuit), factorised once, take sparse LU at every size,
    /// unless they only build the affine step map (`IntegratorOptions::affine_map`).
    #[default]
    Auto,
    /// Always dense LU.
    Dense,
    /// Always sparse LU (faer).
    Sparse,
}

/// Dense or sparse LU behind one [`LinearSolver`].
#[derive(Debug)]
pub enum AutoLu {
    /// Dense partial-pivoting LU.
    Dense(DenseLu),
    /// Sparse LU on faer (boxed: its workspace is large).
    Sparse(Box<SparseLu>),
}

impl AutoLu {
    /// The solver for a system of `n` unknowns.
    #[must_use]
    pub fn for_size(choice: SolverChoice, n: usize) -> Self {
        match choice {
            SolverChoice::Dense => Self::Dense(DenseLu::new()),
            SolverChoice::Sparse => Self::Sparse(Box::default()),
            SolverChoice::Auto if n <= DenseLu::AUTO_LIMIT => Self::Dense(DenseLu::new()),
            SolverChoice::Auto => Self::Sparse(Box::default()),
        }
    }

    /// The same solver with pivots up to `tol` (relative, see
    /// [`DenseLu::with_pivot_tolerance`]) counted as zero.
    #[must_use]
    pub fn with_pivot_tolerance(self, tol: f64) -> Self {
        match self {
            Self::Dense(s) => Self::Dense(s.with_pivot_tolerance(tol)),
            Self::Sparse(s) => Self::Sparse(Box::new((*s).with_pivot_tolerance(tol))),
        }
    }
}

impl LinearSolver for AutoLu {
    fn analyse(
        &mut self,
        n: usize,
        rows: &[usize],
        cols: &[usize],
    ) -> Result<(), LinearSolveError> {
        match self {
            Self::Dense(s) => s.analyse(n, rows, cols),
            Self::Sparse(s) => s.analyse(n, rows, cols),
        }
    }
    fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        match self {
            Self::Dense(s) => s.factor(values),
            Self::Sparse(s) => s.factor(values),
        }
    }
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinearSolveError> {
        match self {
            Self::Dense(s) => s.solve_in_place(rhs),
            Self::Sparse(s) => s.solve_in_place(rhs),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Auto` is dense up to `DenseLu::AUTO_LIMIT` unknowns and sparse above; explicit choices
    /// hold at any size; both solve the same system to round-off.
    #[test]
    fn auto_choice_follows_the_size() {
        let limit = DenseLu::AUTO_LIMIT;
        assert!(matches!(
            AutoLu::for_size(SolverChoice::Auto, limit),
            AutoLu::Dense(_)
        ));
        assert!(matches!(
            AutoLu::for_size(SolverChoice::Auto, limit + 1),
            AutoLu::Sparse(_)
        ));
        assert!(matches!(
            AutoLu::for_size(SolverChoice::Sparse, 2),
            AutoLu::Sparse(_)
        ));
        assert!(matches!(
            AutoLu::for_size(SolverChoice::Dense, 10 * limit),
            AutoLu::Dense(_)
        ));
        // [[4, 1], [2, 3]] x = [1, 2]: x = (1/10, 6/10).
        for choice in [SolverChoice::Dense, SolverChoice::Sparse] {
            let mut lu = AutoLu::for_size(choice, 2);
            lu.analyse(2, &[0, 0, 1, 1], &[0, 1, 0, 1]).unwrap();
            lu.factor(&[4.0, 1.0, 2.0, 3.0]).unwrap();
            let mut x = [1.0, 2.0];
            lu.solve_in_place(&mut x).unwrap();
            assert!(
                (x[0] - 0.1).abs() <= 1e-15 && (x[1] - 0.6).abs() <= 1e-15,
                "{x:?}"
            );
        }
    }
}
