//! Dense LU with partial pivoting on preallocated storage, for small step systems.

use crate::error::LinearSolveError;
use crate::newton::LinearSolver;

/// Dense LU factorisation with partial pivoting, allocation-free after [`LinearSolver::analyse`].
///
/// For the small systems of a few-dof model (one step of a 1-dof oscillator is a 1×1 system) this
/// beats any sparse path; it is chosen automatically below [`DenseLu::AUTO_LIMIT`] unknowns.
#[derive(Debug, Clone)]
pub struct DenseLu {
    /// Pivots not above this (rows equilibrated to unit max-norm) count as zero.
    pivot_tol: f64,
    n: usize,
    rows: Vec<usize>,
    cols: Vec<usize>,
    a: Vec<f64>,
    /// `1/U_kk`: the back substitution multiplies instead of dividing (a division's latency sits
    /// on the substitution's dependency chain).
    inv_pivot: Vec<f64>,
    perm: Vec<usize>,
    work: Vec<f64>,
}

impl DenseLu {
    /// Systems with at most this many unknowns use the dense path by default (measured crossover
    /// against `SparseLu` on banded KKT systems: about 30 unknowns).
    pub const AUTO_LIMIT: usize = 32;

    /// Pivots smaller than this (rows are equilibrated to unit max-norm) count as zero, unless
    /// [`DenseLu::with_pivot_tolerance`] says otherwise.
    pub const PIVOT_TOL: f64 = 1e-14;

    /// A solver with no pattern yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The same solver with pivots up to `tol` counted as zero. A caller that judges the
    /// precision of every unknown itself (the readout, by the round-off jitter of each) lowers it
    /// so that one ill-determined unknown does not stop the solve of the others.
    #[must_use]
    pub fn with_pivot_tolerance(mut self, tol: f64) -> Self {
        self.pivot_tol = tol;
        self
    }
}

impl Default for DenseLu {
    fn default() -> Self {
        Self {
            pivot_tol: Self::PIVOT_TOL,
            n: 0,
            rows: Vec::new(),
            cols: Vec::new(),
            a: Vec::new(),
            inv_pivot: Vec::new(),
            perm: Vec::new(),
            work: Vec::new(),
        }
    }
}

impl LinearSolver for DenseLu {
    fn analyse(
        &mut self,
        n: usize,
        rows: &[usize],
        cols: &[usize],
    ) -> Result<(), LinearSolveError> {
        self.n = n;
        self.rows = rows.to_vec();
        self.cols = cols.to_vec();
        self.a = vec![0.0; n * n];
        self.inv_pivot = vec![0.0; n];
        self.perm = (0..n).collect();
        self.work = vec![0.0; n];
        Ok(())
    }

    fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        let n = self.n;
        let a = &mut self.a;
        a.fill(0.0);
        for ((&r, &c), &v) in self.rows.iter().zip(&self.cols).zip(values) {
            a[c * n + r] += v;
        }
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for k in 0..n {
            let mut piv = k;
            let mut best = a[k * n + k].abs();
            for i in k + 1..n {
                let x = a[k * n + i].abs();
                if x > best {
                    best = x;
                    piv = i;
                }
            }
            if best.is_nan() || best <= self.pivot_tol {
                return Err(LinearSolveError::NumericallySingular { index: k });
            }
            if piv != k {
                self.perm.swap(k, piv);
                for j in 0..n {
                    a.swap(j * n + k, j * n + piv);
                }
            }
            let inv = 1.0 / a[k * n + k];
            self.inv_pivot[k] = inv;
            for i in k + 1..n {
                a[k * n + i] *= inv;
            }
            for j in k + 1..n {
                let akj = a[j * n + k];
                if akj != 0.0 {
                    for i in k + 1..n {
                        a[j * n + i] -= a[k * n + i] * akj;
                    }
                }
            }
        }
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinearSolveError> {
        let n = self.n;
        let a = &self.a;
        // y = P b through the preallocated buffer.
        for (yk, &pk) in self.work.iter_mut().zip(&self.perm) {
            *yk = rhs[pk];
        }
        rhs.copy_from_slice(&self.work);
        // Forward substitution with the unit lower factor, column by column.
        for k in 0..n {
            let yk = rhs[k];
            if yk != 0.0 {
                for (r, l) in rhs[k + 1..].iter_mut().zip(&a[k * n + k + 1..(k + 1) * n]) {
                    *r -= l * yk;
                }
            }
        }
        // Backward substitution with the upper factor.
        for k in (0..n).rev() {
            let col = &a[k * n..k * n + k];
            rhs[k] *= self.inv_pivot[k];
            let xk = rhs[k];
            if xk != 0.0 {
                for (r, u) in rhs[..k].iter_mut().zip(&col[..k]) {
                    *r -= u * xk;
                }
            }
        }
        // A non-finite entry makes the sum non-finite (so may a finite overflow: then look).
        if !rhs.iter().sum::<f64>().is_finite()
            && let Some(index) = rhs.iter().position(|x| !x.is_finite())
        {
            return Err(LinearSolveError::NonFinite { index });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(n: usize) -> (Vec<usize>, Vec<usize>) {
        let mut r = Vec::new();
        let mut c = Vec::new();
        for j in 0..n {
            for i in 0..n {
                r.push(i);
                c.push(j);
            }
        }
        (r, c)
    }

    #[test]
    fn solves_a_system_that_needs_pivoting() {
        // A = [[0, 2, 1], [1, 1, 0], [3, 0, 1]] (column-major triplets), x = (1, -2, 3).
        let a = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
        let x = [1.0, -2.0, 3.0];
        let (r, c) = pattern(3);
        let vals: Vec<f64> = r.iter().zip(&c).map(|(&i, &j)| a[i][j]).collect();
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i][j] * x[j]).sum())
            .collect();
        let mut lu = DenseLu::new();
        lu.analyse(3, &r, &c).unwrap();
        lu.factor(&vals).unwrap();
        lu.solve_in_place(&mut b).unwrap();
        for (got, want) in b.iter().zip(&x) {
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
    }

    /// The finiteness check of a solve: a NaN in the right-hand side is an error, while finite
    /// entries whose sum overflows are a valid solution (the check sums the entries first).
    #[test]
    fn a_nan_solution_is_an_error_and_an_overflowing_sum_is_not() {
        // A = I: the solution is the right-hand side.
        let (r, c) = pattern(3);
        let vals: Vec<f64> = r
            .iter()
            .zip(&c)
            .map(|(i, j)| if i == j { 1.0 } else { 0.0 })
            .collect();
        let mut lu = DenseLu::new();
        lu.analyse(3, &r, &c).unwrap();
        lu.factor(&vals).unwrap();
        let mut b = [1.0, f64::NAN, 2.0];
        assert!(matches!(
            lu.solve_in_place(&mut b),
            Err(LinearSolveError::NonFinite { .. })
        ));
        let mut big = [f64::MAX, f64::MAX, -1.0];
        assert_eq!(lu.solve_in_place(&mut big), Ok(()));
        assert_eq!(big, [f64::MAX, f64::MAX, -1.0]);
    }

    #[test]
    fn singular_matrix_is_an_error_not_nan() {
        let (r, c) = pattern(2);
        let vals = [1.0, 2.0, 2.0, 4.0];
        let mut lu = DenseLu::new();
        lu.analyse(2, &r, &c).unwrap();
        assert_eq!(
            lu.factor(&vals),
            Err(LinearSolveError::NumericallySingular { index: 1 })
        );
    }
}
