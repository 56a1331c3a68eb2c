//! Newton's method on a [`NonlinearSystem`] with a pluggable [`LinearSolver`].

use crate::error::{LinearSolveError, NewtonError};
use crate::triplets::Triplets;

/// A square nonlinear system `F(x) = 0` with an exact Jacobian given as triplets.
pub trait NonlinearSystem {
    /// Number of unknowns (and equations).
    fn len(&self) -> usize;

    /// Whether the system has no unknowns.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Evaluates `r = F(x)`.
    fn residual(&mut self, x: &[f64], r: &mut [f64]);

    /// Stamps the Jacobian `∂F/∂x` at `x` into `jac`, always with the same `(row, col)` sequence.
    fn jacobian(&mut self, x: &[f64], jac: &mut Triplets);

    /// True when the Jacobian does not depend on `x` nor change between solves (linear models at
    /// fixed step size): the factorisation is then computed once and reused.
    fn jacobian_is_constant(&self) -> bool {
        false
    }

    /// Typical magnitude of the residual's entries, used for the relative residual test.
    fn residual_scale(&self) -> f64 {
        1.0
    }
}

/// A linear solver that factorises a matrix given as triplets (duplicates summed).
pub trait LinearSolver {
    /// Analyses the pattern: called once per pattern, may allocate.
    fn analyse(&mut self, n: usize, rows: &[usize], cols: &[usize])
    -> Result<(), LinearSolveError>;
    /// Numeric factorisation from values in the order of the analysed pattern. Must not allocate.
    fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError>;
    /// Solves `A x = b` in place. Must not allocate.
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinearSolveError>;
}

/// Tolerances of [`Newton`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Maximum number of Newton updates per solve.
    pub max_iterations: usize,
    /// Converged when `‖F(x)‖∞ ≤ residual_tol · residual_scale`.
    pub residual_tol: f64,
    /// Also converged when the last update satisfies `‖Δx‖∞ ≤ update_tol · (1 + ‖x‖∞)` (with an
    /// exact Jacobian the error is then of order `update_tol²`: the residual sits at round-off).
    pub update_tol: f64,
    /// For systems whose Jacobian is constant (`F` affine), accept the iterate after one update
    /// without evaluating the residual again: Newton is exact on affine maps, so the check would
    /// only confirm round-off. The update is still checked for finiteness by the linear solver.
    pub affine_shortcut: bool,
    /// Modified Newton for systems whose Jacobian varies: keep the last factorisation (across
    /// iterations and across solves, e.g. from the previous time step) while it contracts, and
    /// refactorise at the current iterate when the residual contracts by less than
    /// [`NewtonOptions::max_contraction`] per iteration. Iterates computed with a kept
    /// factorisation are accepted only when the last update was at round-off in every unknown,
    /// so the converged result is as accurate as with a fresh Jacobian every iteration; only the
    /// cost changes (one residual and two triangular solves per iteration instead of a Jacobian
    /// and a factorisation).
    pub reuse_jacobian: bool,
    /// Largest contraction `θ = ‖Δx_{i+1}‖/‖Δx_i‖` of updates from a kept factorisation
    /// tolerated before it is refreshed (it is also refreshed when the residual grows).
    pub max_contraction: f64,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            max_iterations: 25,
            residual_tol: 1e-14,
            update_tol: 1e-11,
            affine_shortcut: true,
            reuse_jacobian: true,
            max_contraction: 0.25,
        }
    }
}

/// Counters of one or more Newton solves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NewtonStats {
    /// Linear solves (Newton updates).
    pub iterations: usize,
    /// Numeric factorisations.
    pub factorisations: usize,
    /// Residual evaluations.
    pub residual_evaluations: usize,
}

impl NewtonStats {
    /// Adds another solve's counters.
    pub fn accumulate(&mut self, other: &NewtonStats) {
        self.iterations += other.iterations;
        self.factorisations += other.factorisations;
        self.residual_evaluations += other.residual_evaluations;
    }
}

/// Newton's method with row equilibration, pattern analysis once, and factorisation reuse.
///
/// All buffers are sized on the first solve; later solves of a system of the same size do not
/// allocate.
#[derive(Debug, Clone)]
pub struct Newton<S: LinearSolver> {
    solver: S,
    options: NewtonOptions,
    residual: Vec<f64>,
    update: Vec<f64>,
    jacobian: Triplets,
    scaled: Vec<f64>,
    row_scale: Vec<f64>,
    analysed: bool,
    factored: bool,
}

impl<S: LinearSolver> Newton<S> {
    /// A Newton solver around `solver`.
    pub fn new(solver: S, options: NewtonOptions) -> Self {
        Self {
            solver,
            options,
            residual: Vec::new(),
            update: Vec::new(),
            jacobian: Triplets::new(),
            scaled: Vec::new(),
            row_scale: Vec::new(),
            analysed: false,
            factored: false,
        }
    }

    /// Forgets the pattern and any reused factorisation (call when the system changes shape).
    pub fn reset(&mut self) {
        self.analysed = false;
        self.factored = false;
        self.jacobian = Triplets::new();
    }

    /// Forgets a reused factorisation (call when a constant Jacobian changes, e.g. a new `h`).
    pub fn invalidate_factorisation(&mut self) {
        self.factored = false;
    }

    /// Number of Jacobian entries stamped per evaluation (0 before the first factorisation);
    /// duplicates count once per stamp.
    #[must_use]
    pub fn pattern_len(&self) -> usize {
        self.jacobian.len()
    }

    /// The options in use.
    #[must_use]
    pub fn options(&self) -> &NewtonOptions {
        &self.options
    }

    /// The last residual evaluated (after an affine shortcut: the residual at the initial guess).
    #[must_use]
    pub fn last_residual(&self) -> &[f64] {
        &self.residual
    }

    /// Solves `F(x) = 0` starting from `x` (updated in place).
    pub fn solve<F: NonlinearSystem + ?Sized>(
        &mut self,
        system: &mut F,
        x: &mut [f64],
    ) -> Result<NewtonStats, NewtonError> {
        let n = system.len();
        if self.residual.len() != n {
            self.residual = vec![0.0; n];
            self.update = vec![0.0; n];
            self.row_scale = vec![0.0; n];
            self.reset();
        }
        let mut stats = NewtonStats::default();
        let tol = self.options.residual_tol * system.residual_scale();
        let mut last_update = f64::INFINITY;
        let reuse = system.jacobian_is_constant();
        let modified = self.options.reuse_jacobian && !reuse;
        // Whether the last update came from a Jacobian factorised at that update's iterate.
        let mut exact_update = false;
        let mut previous_rnorm = f64::INFINITY;
        // The update before `last_update`, if both came from the same kept factorisation: their
        // ratio estimates the contraction θ of the modified iteration.
        let mut previous_update = f64::NAN;
        let mut kept_iterations = 0;
        // Whether the last update moved every unknown by at most KEPT_ACCEPT relative to itself.
        let mut at_roundoff = false;
        for iteration in 0..=self.options.max_iterations {
            system.residual(x, &mut self.residual);
            stats.residual_evaluations += 1;
            let (rnorm, worst) = max_norm(&self.residual);
            if !rnorm.is_finite() {
                return Err(NewtonError::NonFiniteResidual {
                    equation: worst,
                    iterations: iteration,
                });
            }
            // The warm-start guess is accepted only if it is exact: an absolute residual test on
            // the guess would freeze small-scale systems near steady state (rates off by
            // tol/(h·coefficient)). Every later iterate follows at least one update; one from a
            // kept factorisation converges only linearly, so a small residual alone does not
            // accept it (the error could still be tol/θ-sized), only the error estimate below.
            if rnorm == 0.0 || (iteration > 0 && (exact_update || !modified) && rnorm <= tol) {
                return Ok(stats);
            }
            // NaN when unknown: every comparison below is then false.
            let theta = last_update / previous_update;
            if iteration > 0 {
                let xnorm = x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                if exact_update || !modified {
                    if last_update <= self.options.update_tol * (1.0 + xnorm) {
                        return Ok(stats);
                    }
                } else if theta <= 0.5 && at_roundoff {
                    return Ok(stats);
                }
            }
            if iteration == self.options.max_iterations {
                return Err(NewtonError::NotConverged {
                    iterations: iteration,
                    residual: rnorm,
                    worst_equation: worst,
                });
            }
            let refresh = !self.factored
                || if modified {
                    rnorm > previous_rnorm
                        || theta > self.options.max_contraction
                        || kept_iterations >= MAX_KEPT_ITERATIONS
                } else {
                    !reuse
                };
            if refresh {
                self.factorise(system, x)
                    .map_err(|source| NewtonError::Linear {
                        source,
                        residual: rnorm,
                        worst_equation: worst,
                    })?;
                stats.factorisations += 1;
                kept_iterations = 0;
            } else {
                kept_iterations += 1;
            }
            previous_update = if refresh || exact_update || iteration == 0 {
                f64::NAN
            } else {
                last_update
            };
            exact_update = refresh;
            previous_rnorm = rnorm;
            for ((u, r), s) in self
                .update
                .iter_mut()
                .zip(&self.residual)
                .zip(&self.row_scale)
            {
                *u = r * s;
            }
            self.solver
                .solve_in_place(&mut self.update)
                .map_err(|source| NewtonError::Linear {
                    source,
                    residual: rnorm,
                    worst_equation: worst,
                })?;
            stats.iterations += 1;
            let mut unorm = 0.0_f64;
            at_roundoff = true;
            for (xi, u) in x.iter_mut().zip(&self.update) {
                *xi -= u;
                unorm = unorm.max(u.abs());
                at_roundoff &= u.abs() <= KEPT_ACCEPT * xi.abs();
            }
            last_update = unorm;
            if reuse && self.options.affine_shortcut {
                return Ok(stats);
            }
        }
        unreachable_converged()
    }

    fn factorise<F: NonlinearSystem + ?Sized>(
        &mut self,
        system: &mut F,
        x: &[f64],
    ) -> Result<(), LinearSolveError> {
        let n = system.len();
        self.jacobian.begin();
        system.jacobian(x, &mut self.jacobian);
        self.jacobian.finish()?;
        if !self.analysed {
            self.jacobian.freeze();
            let mut col_seen = vec![false; n];
            for &c in self.jacobian.cols() {
                col_seen[c] = true;
            }
            if let Some(col) = col_seen.iter().position(|s| !s) {
                return Err(LinearSolveError::EmptyColumn { col });
            }
            self.solver
                .analyse(n, self.jacobian.rows(), self.jacobian.cols())?;
            self.scaled = vec![0.0; self.jacobian.len()];
            self.analysed = true;
        }
        // Row equilibration: scale every row to unit max-norm so partial pivoting compares like
        // with like (momentum equations and constraint rows differ in units by ~M/h).
        self.row_scale.fill(0.0);
        for (r, _, v) in self.jacobian.iter() {
            self.row_scale[r] = self.row_scale[r].max(v.abs());
        }
        for (row, s) in self.row_scale.iter_mut().enumerate() {
            if s.is_nan() || *s <= 0.0 {
                return Err(LinearSolveError::EmptyRow { row });
            }
            *s = 1.0 / *s;
        }
        for ((out, &r), &v) in self
            .scaled
            .iter_mut()
            .zip(self.jacobian.rows())
            .zip(self.jacobian.values())
        {
            *out = v * self.row_scale[r];
        }
        self.solver.factor(&self.scaled)?;
        self.factored = true;
        Ok(())
    }
}

/// An iterate from a kept factorisation is accepted when the update that produced it changed
/// every unknown by at most this much relative to its value (a floating-point fixed point; with
/// contraction θ ≤ ½ the remaining error is below the update). Unknowns converging to exactly
/// zero never pass this test: their solve falls back to a fresh factorisation.
const KEPT_ACCEPT: f64 = 4.0 * f64::EPSILON;

/// Iterations on one kept factorisation before it is refreshed regardless of contraction.
const MAX_KEPT_ITERATIONS: usize = 8;

/// The loop above returns on every path; this keeps the compiler satisfied without a panic.
fn unreachable_converged() -> Result<NewtonStats, NewtonError> {
    Err(NewtonError::NotConverged {
        iterations: 0,
        residual: f64::NAN,
        worst_equation: 0,
    })
}

/// Max-norm and the index where it is attained; a NaN or infinity wins (and is returned).
fn max_norm(v: &[f64]) -> (f64, usize) {
    let mut best = 0.0;
    let mut at = 0;
    for (i, x) in v.iter().enumerate() {
        let a = x.abs();
        if a > best || a.is_nan() {
            best = a;
            at = i;
            if !a.is_finite() {
                break;
            }
        }
    }
    (best, at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DenseLu;

    /// F(x) = (x0² + x1² − 4, x0 − x1): root (√2, √2).
    struct Circle;
    impl NonlinearSystem for Circle {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] * x[0] + x[1] * x[1] - 4.0;
            r[1] = x[0] - x[1];
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 2.0 * x[0]);
            jac.add(0, 1, 2.0 * x[1]);
            jac.add(1, 0, 1.0);
            jac.add(1, 1, -1.0);
        }
    }

    fn exact_newton() -> NewtonOptions {
        NewtonOptions {
            reuse_jacobian: false,
            ..NewtonOptions::default()
        }
    }

    #[test]
    fn converges_quadratically_to_the_root() {
        let mut newton = Newton::new(DenseLu::new(), exact_newton());
        let mut x = [1.0, 2.0];
        let stats = newton.solve(&mut Circle, &mut x).unwrap();
        assert!((x[0] - 2f64.sqrt()).abs() < 1e-15 && (x[1] - 2f64.sqrt()).abs() < 1e-15);
        assert!(stats.iterations <= 6, "{stats:?}");
    }

    /// `x² + y² = ρ², x = y` for a slowly growing ρ: a sequence of warm-started solves, as in
    /// time stepping.
    struct GrowingCircle(f64);
    impl NonlinearSystem for GrowingCircle {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] * x[0] + x[1] * x[1] - self.0 * self.0;
            r[1] = x[0] - x[1];
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            Circle.jacobian(x, jac);
        }
    }

    /// Modified Newton keeps factorisations across warm-started solves and still lands on the
    /// root to round-off, with far fewer factorisations than exact Newton.
    #[test]
    fn modified_newton_reuses_factorisations_and_reaches_round_off() {
        let mut modified = Newton::new(DenseLu::new(), NewtonOptions::default());
        let mut exact = Newton::new(DenseLu::new(), exact_newton());
        let (mut xm, mut xe) = ([1.4, 1.4], [1.4, 1.4]);
        let (mut sm, mut se) = (NewtonStats::default(), NewtonStats::default());
        for k in 0..200 {
            let rho = 2.0 + 1e-3 * f64::from(k);
            sm.accumulate(&modified.solve(&mut GrowingCircle(rho), &mut xm).unwrap());
            se.accumulate(&exact.solve(&mut GrowingCircle(rho), &mut xe).unwrap());
            let root = rho / 2f64.sqrt();
            for x in [xm, xe] {
                assert!(
                    (x[0] - root).abs() <= 2.0 * f64::EPSILON * root,
                    "{x:?} vs {root}"
                );
            }
        }
        assert!(
            sm.factorisations * 10 <= se.factorisations,
            "modified {sm:?}, exact {se:?}"
        );
    }

    /// Two unknowns, one equation repeated: the Newton matrix is singular.
    struct Redundant;
    impl NonlinearSystem for Redundant {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] + x[1] - 1.0;
            r[1] = 2.0 * x[0] + 2.0 * x[1] - 2.0;
        }
        fn jacobian(&mut self, _: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 1.0);
            jac.add(0, 1, 1.0);
            jac.add(1, 0, 2.0);
            jac.add(1, 1, 2.0);
        }
    }

    #[test]
    fn singular_newton_matrix_is_a_typed_error() {
        let mut newton = Newton::new(DenseLu::new(), NewtonOptions::default());
        let mut x = [0.0, 0.0];
        let err = newton.solve(&mut Redundant, &mut x).unwrap_err();
        assert!(matches!(
            err,
            NewtonError::Linear {
                source: LinearSolveError::NumericallySingular { .. },
                ..
            }
        ));
    }
}
