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

    /// The largest fraction `α ∈ (0, 1]` of the Newton update from `x` to `x − update` that the
    /// system accepts (SPICE's junction limiting, expressed as a damping of the whole update, so
    /// the direction stays Newton's). Newton then moves to `x − α·update`; an iterate reached with
    /// `α < 1` is never accepted by the update test (only by the residual test). The default
    /// accepts every update.
    fn update_fraction(&mut self, _x: &[f64], _update: &[f64]) -> f64 {
        1.0
    }

    /// Writes, per equation, the size of its terms that do not depend on the unknowns (a carried
    /// momentum, the positions inside a holonomic constraint); Newton adds `Σ_j |J_ij x_j|` for
    /// the rest when it judges a residual against the size of its equation. Zero by default.
    fn constant_magnitudes(&mut self, out: &mut [f64]) {
        out.fill(0.0);
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
///
/// An iterate is accepted when one of three tests passes, none of which depends on the units or
/// the overall size of the system:
///
/// - the residual is exactly zero;
/// - **update test:** the last update was undamped, came from a Jacobian evaluated at the iterate
///   it started from, and moved every unknown by at most `update_tol · max(|x_old|, |x_new|)` of
///   that unknown (with an exact Jacobian the remaining error is then of order `update_tol²`);
///   for an unknown that is small next to the other terms of its equations the size is taken from
///   those equations instead (`Newton::unknown_scales`: the update then moves none of them by more
///   than `update_tol` of their terms), and every unknown may also move by a few times the jitter
///   that round-off in the residual gives it (`Newton::noise_floor`: the precision to which the
///   Newton matrix determines it, e.g. a joint multiplier that the `M/h²` stiffness of its
///   constraint ties to the round-off of the positions);
/// - **residual test:** after an update from a Jacobian at its own iterate, every equation
///   satisfies `|F_i(x)| ≤ residual_tol · (c_i + Σ_j |J_ij x_j|)`, with `c_i` the size of its
///   terms that do not depend on the unknowns ([`NonlinearSystem::constant_magnitudes`]): its
///   residual is at round-off relative to the size of its own terms (a residual of 1e-22 in an
///   equation whose terms are 1e-8 is converged; one of 1e-15 in an equation whose terms are
///   1e-14 is not); or, when the update was also at round-off of the largest unknown
///   (`‖Δx‖∞ ≤ update_tol·‖x‖∞`), within a looser 5e-11 of its terms (equations whose terms
///   cancel inside the model) plus `4ε·‖x‖∞·Σ_j |J_ij|`, the change of the equation when every
///   unknown moves by the absolute precision it has in that regime (equations whose terms all
///   vanish at the root). The iterate is then polished by one more update from the
///   factorisation at hand, so its error is round-off, not the tolerance.
///
/// Every test is relative to each equation or unknown, or (the round-off floor) to the largest
/// unknown: no absolute floor, which would accept any state of a system whose values are all
/// small (a circuit carrying picoamperes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Maximum number of Newton updates per solve.
    pub max_iterations: usize,
    /// Relative residual of the residual test (per equation, against its own terms).
    pub residual_tol: f64,
    /// Relative size of the last update, per unknown, of the update test.
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
    /// Largest contraction of a factorisation carried over from an earlier solve that later
    /// solves still start from (measured on its updates above round-off). Above it, a solve
    /// refactorises at its guess before the first update, as RADAU5 recomputes its Jacobian when
    /// the last step's contraction exceeded `THET`: a factorisation that gains fewer than two
    /// digits per update needs about eight updates from a 1e-6 guess error to round-off, where
    /// one from a fresh Jacobian needs two or three (its updates contract with the guess error
    /// itself). RADAU5 suggests 1e-3 for cheap Jacobians and 0.1 for costly ones. `None`
    /// (off) by default: whether it pays depends on what a Jacobian costs against an
    /// update (dirac-sim turns it on at 1e-2 for the substeps of compositions). Every ninth such
    /// solve starts from the carried factorisation again to re-measure its contraction, and the
    /// refresh stops while the last refreshed solve contracted by more than a quarter of the
    /// carried contraction (a poor guess: a fresh Jacobian then gains nothing); then every ninth
    /// solve refactorises at its start to re-measure that.
    pub start_contraction: Option<f64>,
    /// Also accept an iterate of a kept factorisation once its last update (at `4ε` of the
    /// largest unknown) moved every unknown by at most `4ε` of its scale `s_j` in its equations
    /// ([`Newton::precision`]), i.e. every equation by round-off of its terms, where the strict
    /// rule asks `4ε` of every unknown itself. An unknown much smaller than the others in its
    /// equations (a double pendulum's slow angle increment next to the fast one) then need not
    /// wait for a refreshed factorisation: its updates stall at the round-off that the residual's
    /// rounding gives it. With it, a kept iterate is also accepted once its update moved no
    /// unknown by more than `4ε` of its scale plus its round-off jitter `η_j`
    /// ([`Newton::precision`]; the scales taken at least once per solve, the jitter once per
    /// factorisation while no equation's terms shrink below half of those it was estimated
    /// with), provided the factorisation was seen to contract by at most a half in
    /// this solve, on updates at least 100 times that size and measured in the same units: the
    /// iterate's error is then at most the update, and one more update from the residual at
    /// hand (returned) shrinks it by the contraction, so that no remainder of the kept
    /// factorisation biases every step alike. In a chain's ill-conditioned steps the joint
    /// multipliers' updates settle at their jitter, far above `4ε`, while the absolute updates'
    /// ratios read as poor contraction; this spares the refactorisation either would take. Off by
    /// default: an exponential device relation that reads such an unknown (a diode's junction at
    /// a small current) is not at round-off when its equations are (docs/audit.md item 22);
    /// dirac-sim turns it on for steps of models without update limits.
    pub accept_at_equation_roundoff: bool,
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
            start_contraction: None,
            accept_at_equation_roundoff: false,
        }
    }
}

/// How precisely a Newton matrix determines each unknown ([`Newton::precision`]).
#[derive(Debug, Clone, Copy)]
pub struct Precision<'a> {
    /// Per unknown, its round-off jitter `η_j`.
    pub jitter: &'a [f64],
    /// Per unknown, its scale `s_j` in the equations it weighs in.
    pub scale: &'a [f64],
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
    /// Updates shortened by [`NonlinearSystem::update_fraction`] (junction limiting).
    pub limited: usize,
}

impl NewtonStats {
    /// Adds another solve's counters.
    pub fn accumulate(&mut self, other: &NewtonStats) {
        self.iterations += other.iterations;
        self.factorisations += other.factorisations;
        self.residual_evaluations += other.residual_evaluations;
        self.limited += other.limited;
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
    /// `Σ_j |J_ij x_j|` per equation (the size of its terms) for the residual test.
    magnitude: Vec<f64>,
    /// `Σ_j |J_ij|` per equation, for the residual test's round-off floor.
    row_sum: Vec<f64>,
    /// Per unknown, the jitter of a Newton update caused by round-off in the residual (see
    /// [`Newton::noise_floor`]); a second buffer for the other sign pattern.
    noise: Vec<f64>,
    noise_probe: Vec<f64>,
    /// The term sizes `noise` was estimated with: a kept estimate stays in use only while no
    /// equation's terms shrank below half of these (the jitter scales with them).
    noise_magnitude: Vec<f64>,
    /// Per unknown, `min_i (c_i + Σ_k |J_ik x_k|) / |J_ij|` over the equations it enters (see
    /// [`Newton::unknown_scales`]).
    unknown_scale: Vec<f64>,
    analysed: bool,
    factored: bool,
    /// The largest contraction measured on a factorisation carried over from an earlier solve
    /// (NaN: not measured), for [`NewtonOptions::start_contraction`].
    carried_contraction: f64,
    /// The largest contraction measured on the last solve that refactorised at its start (NaN:
    /// not measured): when it is no better than the carried one (the guess itself is poor, so a
    /// fresh Jacobian contracts no faster), solves keep starting from the carried factorisation.
    fresh_contraction: f64,
    /// Solves since the start not chosen by the rule (fresh or carried) was last tried, to
    /// re-measure its contraction.
    since_probe: usize,
    /// Whether `noise` holds the jitter of the factorisation at hand (it changes little between
    /// the iterates and solves that keep one factorisation, so it is estimated once for each,
    /// and again where an equation's terms shrank below half of `noise_magnitude`).
    noise_current: bool,
    /// Whether `unknown_scale` holds the scales at an iterate of the current solve (the kept
    /// updates' round-off test takes them once per solve).
    scales_current: bool,
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
            magnitude: Vec::new(),
            row_sum: Vec::new(),
            noise: Vec::new(),
            noise_probe: Vec::new(),
            noise_magnitude: Vec::new(),
            noise_current: false,
            scales_current: false,
            unknown_scale: Vec::new(),
            analysed: false,
            factored: false,
            carried_contraction: f64::NAN,
            fresh_contraction: f64::NAN,
            since_probe: 0,
        }
    }

    /// Forgets the pattern and any reused factorisation (call when the system changes shape).
    pub fn reset(&mut self) {
        self.analysed = false;
        self.invalidate_factorisation();
        self.jacobian = Triplets::new();
    }

    /// Forgets a reused factorisation (call when a constant Jacobian changes, e.g. a new `h`).
    pub fn invalidate_factorisation(&mut self) {
        self.factored = false;
        self.noise_current = false;
        self.carried_contraction = f64::NAN;
        self.fresh_contraction = f64::NAN;
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
            self.magnitude = vec![0.0; n];
            self.row_sum = vec![0.0; n];
            self.noise = vec![0.0; n];
            self.noise_probe = vec![0.0; n];
            self.noise_magnitude = vec![0.0; n];
            self.unknown_scale = vec![0.0; n];
            self.reset();
        }
        let mut stats = NewtonStats::default();
        let mut last_update = f64::INFINITY;
        let reuse = system.jacobian_is_constant();
        let modified = self.options.reuse_jacobian && !reuse;
        // Whether the last update came from a Jacobian factorised at that update's iterate.
        let mut exact_update = false;
        // Whether the last update was shortened by the system's limits.
        let mut damped = false;
        // Whether the last update passed the per-unknown update test.
        let mut small_update = false;
        let mut previous_rnorm = f64::INFINITY;
        // The update before `last_update`, if both came from the same kept factorisation: their
        // ratio estimates the contraction θ of the modified iteration.
        let mut previous_update = f64::NAN;
        let mut kept_iterations = 0;
        // Whether the last update moved every unknown by at most KEPT_ACCEPT relative to itself.
        let mut at_roundoff = false;
        // Whether the last kept update was at round-off of every unknown's scale in its
        // equations ([`NewtonOptions::accept_at_equation_roundoff`]).
        let mut at_equation_roundoff = false;
        // Which contraction the updates of the first factorisation of this solve measure, for
        // the next solves' start: the carried factorisation's, or a start refresh's.
        let mut measuring = (modified && self.factored).then_some(Measuring::Carried);
        // Whether no contraction was measured yet in this solve (the first replaces the last
        // solve's, later ones raise it).
        let mut first_measurement = true;
        // NaN (not measured) counts as paying.
        let refresh_pays = self.fresh_contraction.is_nan()
            || self.fresh_contraction <= 0.25 * self.carried_contraction;
        if let Some(limit) = self.options.start_contraction
            && measuring.is_some()
            && self.carried_contraction > limit
        {
            // Every ninth solve starts the other way, so neither measurement goes stale.
            let probe = self.since_probe >= START_PROBE;
            self.since_probe = if probe { 0 } else { self.since_probe + 1 };
            if refresh_pays != probe {
                self.factored = false;
                measuring = Some(Measuring::Fresh);
            }
        }
        // The last two updates from the factorisation in use, each in units of its round-off
        // ([`Newton::update_over_noise`]; NaN: none, or not asked for). Their ratio measures the
        // contraction that certifies an iterate at round-off: in absolute units the largest
        // unknowns' updates dominate the ratio, and where the matrix is ill-conditioned (a
        // chain's joint multipliers) those lag behind the rest, which has converged.
        let mut last_over_noise = f64::NAN;
        let mut previous_over_noise = f64::NAN;
        // The largest such contraction measured on the factorisation in use in this solve (NaN:
        // none). Not carried from an earlier solve: the system may have changed since.
        let mut contraction_seen = f64::NAN;
        self.scales_current = false;
        // Whether the last update, from a kept factorisation, moved no unknown by more than its
        // round-off.
        let mut within_noise = false;
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
            // The warm-start guess is accepted only if it is exact. Every later iterate follows
            // at least one update; one from a kept factorisation converges only linearly, so only
            // a round-off-sized update accepts it.
            if rnorm == 0.0 {
                return Ok(stats);
            }
            // NaN when unknown: every comparison below is then false.
            let theta = last_update / previous_update;
            // Measured on an earlier update well above round-off (an infinite later one counts,
            // as no contraction).
            let kept_theta = last_over_noise / previous_over_noise;
            if !kept_theta.is_nan()
                && previous_over_noise.is_finite()
                && previous_over_noise > MEASURABLE_OVER_NOISE
            {
                contraction_seen = if contraction_seen.is_nan() {
                    kept_theta
                } else {
                    contraction_seen.max(kept_theta)
                };
            }
            if iteration > 0 && !damped {
                if exact_update || !modified {
                    if small_update {
                        return Ok(stats);
                    }
                } else if theta <= 0.5 && (at_roundoff || at_equation_roundoff) {
                    return Ok(stats);
                } else if within_noise && contraction_seen <= KEPT_NOISE_CONTRACTION {
                    // The iterate's error is the kept factorisation's remainder, a smooth
                    // function of the state that would bias every step the same way; one more
                    // update from the residual at hand shrinks it by the contraction.
                    return self.final_update(x, stats, rnorm, worst);
                }
            }
            if iteration == self.options.max_iterations {
                let (relative, equation) = if self.jacobian.is_empty() {
                    (f64::NAN, worst)
                } else {
                    // The residual test at the last iterate, with a Jacobian stamped there: an
                    // iteration slowed by damping (junction limiting) can reach round-off only
                    // on its last update, which the loop would otherwise never test.
                    let fresh = self.stamp(system, x).is_ok();
                    let (relative, equation) = self.relative_residual(system, x);
                    if fresh && relative <= self.options.residual_tol && self.factor().is_ok() {
                        stats.factorisations += 1;
                        return self.final_update(x, stats, rnorm, worst);
                    }
                    (relative, equation)
                };
                return Err(NewtonError::NotConverged {
                    iterations: iteration,
                    residual: rnorm,
                    relative_residual: relative,
                    worst_equation: equation,
                });
            }
            let refresh = !self.factored
                || if modified {
                    damped
                        || rnorm > previous_rnorm
                        || theta > self.options.max_contraction
                        || kept_iterations >= MAX_KEPT_ITERATIONS
                } else {
                    !reuse
                };
            // A contraction is measured only on updates well above round-off (two updates at
            // round-off have a ratio near 1 whatever the factorisation).
            if let Some(which) = measuring
                && theta.is_finite()
                && last_update > MEASURABLE_UPDATE * max_norm(x).0
            {
                let contraction = match which {
                    Measuring::Carried => &mut self.carried_contraction,
                    Measuring::Fresh => &mut self.fresh_contraction,
                };
                *contraction = if first_measurement {
                    theta
                } else {
                    contraction.max(theta)
                };
                first_measurement = false;
            }
            if refresh && iteration > 0 {
                measuring = None;
            }
            if refresh {
                self.stamp(system, x)
                    .map_err(|source| NewtonError::Linear {
                        source,
                        residual: rnorm,
                        worst_equation: worst,
                    })?;
            }
            // The residual test, after an update from a Jacobian at its own iterate (an iterate of
            // a kept factorisation earns it only through one more exact update). The terms are
            // sized with the Jacobian just stamped at this iterate, or with the one the last,
            // undamped update came from. A passing iterate is polished by one more update from
            // the factorisation at hand, which takes its error from the size of the residual
            // test to round-off.
            let residual_converged =
                iteration > 0 && (exact_update || !modified) && (refresh || reuse || !damped) && {
                    let relative = self.relative_residual(system, x).0;
                    relative <= self.options.residual_tol
                        || (!damped
                            && last_update <= self.options.update_tol * max_norm(x).0
                            && self.stagnated(system, x))
                };
            if refresh {
                self.factor().map_err(|source| NewtonError::Linear {
                    source,
                    residual: rnorm,
                    worst_equation: worst,
                })?;
                stats.factorisations += 1;
                kept_iterations = 0;
            } else {
                kept_iterations += 1;
            }
            previous_update = if refresh || exact_update || damped || iteration == 0 {
                f64::NAN
            } else {
                last_update
            };
            previous_over_noise = if refresh || damped || iteration == 0 {
                f64::NAN
            } else {
                last_over_noise
            };
            if refresh {
                contraction_seen = f64::NAN;
            }
            exact_update = refresh;
            previous_rnorm = rnorm;
            self.solve_update().map_err(|source| NewtonError::Linear {
                source,
                residual: rnorm,
                worst_equation: worst,
            })?;
            stats.iterations += 1;
            // Newton is exact on an affine map: the one update is the solution, and the size
            // tests below (a serial pass over the unknowns) would decide nothing.
            if residual_converged || (reuse && self.options.affine_shortcut) {
                self.apply_update(x);
                return Ok(stats);
            }
            let alpha = if reuse {
                1.0
            } else {
                let a = system.update_fraction(x, &self.update);
                // A NaN fraction is ignored (the residual check catches a bad iterate); zero or
                // negative fractions would stall the iteration.
                if a.is_nan() {
                    1.0
                } else {
                    a.clamp(f64::MIN_POSITIVE, 1.0)
                }
            };
            damped = alpha < 1.0;
            if damped {
                stats.limited += 1;
            }
            let mut unorm = 0.0_f64;
            at_roundoff = true;
            small_update = true;
            let tol = self.options.update_tol;
            for (xi, u) in x.iter_mut().zip(&self.update) {
                let step = alpha * u;
                let old = *xi;
                *xi -= step;
                let a = step.abs();
                unorm = unorm.max(a);
                at_roundoff &= a <= KEPT_ACCEPT * xi.abs();
                small_update &= a <= tol * old.abs().max(xi.abs());
            }
            last_update = unorm;
            // An update's size against its round-off ([`NewtonOptions::accept_at_equation_roundoff`]):
            // the contraction's measure, and for a kept factorisation that contracted by at most
            // a half, the test that accepts its iterate (the error left is at most the update
            // over `1 − θ`). The scales are taken once per solve, the jitter once per
            // factorisation.
            last_over_noise = if self.options.accept_at_equation_roundoff && modified && !damped {
                if !self.noise_current || !self.scales_current {
                    self.term_sizes(system, x);
                    self.unknown_scales(x);
                    // A jitter estimated where the equations' terms were more than twice
                    // today's (an earlier solve of a changed system) would allow too much.
                    self.noise_current &= self
                        .magnitude
                        .iter()
                        .zip(&self.noise_magnitude)
                        .all(|(now, then)| *now >= 0.5 * then);
                    self.current_noise_floor(rnorm, worst)?;
                }
                self.update_over_noise()
            } else {
                f64::NAN
            };
            // The test at `4ε` of every unknown's scale at this iterate, asked only of an update
            // within the round-off the factorisation's scales allow (a stricter test).
            at_equation_roundoff = !exact_update
                && !at_roundoff
                && last_over_noise <= 1.0
                && unorm <= KEPT_ACCEPT * max_norm(x).0
                && {
                    self.term_sizes(system, x);
                    self.unknown_scales(x);
                    self.update
                        .iter()
                        .zip(&self.unknown_scale)
                        .all(|(u, scale)| u.abs() <= KEPT_ACCEPT * scale)
                };
            within_noise = !exact_update && last_over_noise <= 1.0;
            // An unknown that is small next to the terms of the equations it enters (a joint
            // multiplier of 1e-4 in momentum rows of size 1) is resolved once its update moves
            // none of them by more than `update_tol` of their terms; and no update can do better
            // than the jitter that round-off in the residual gives it (asked only once Newton has
            // had an update to converge with).
            if !small_update && !damped && !reuse && (exact_update || !modified) {
                self.term_sizes(system, x);
                self.unknown_scales(x);
                let noise = iteration > 0;
                if noise {
                    self.current_noise_floor(rnorm, worst)?;
                }
                small_update = self
                    .update
                    .iter()
                    .zip(&self.unknown_scale)
                    .zip(&self.noise)
                    .all(|((u, scale), eta)| {
                        let jitter = if noise { NOISE_MARGIN * eta } else { 0.0 };
                        u.abs() <= tol * scale + jitter
                    });
            }
        }
        unreachable_converged()
    }

    /// How precisely the Newton matrix at hand determines each unknown at `x` (a solution just
    /// returned by [`Newton::solve`]): per unknown, its round-off jitter `η_j`
    /// (`|J⁻¹ δF|` with every residual carrying the round-off of its own terms, the jitter the
    /// update test allows) and its scale `s_j` in the equations it weighs in (see
    /// [`NewtonOptions`]). `η_j/s_j`
    /// near `ε` is a well-determined unknown; near 1, one that the equations fix only through a
    /// coefficient lost in round-off (a node potential read through an off diode's 1e-12 S).
    /// `None` when no factorisation is at hand (the warm start was exact).
    ///
    /// # Errors
    /// A failing triangular solve.
    pub fn precision<F: NonlinearSystem + ?Sized>(
        &mut self,
        system: &mut F,
        x: &[f64],
    ) -> Result<Option<Precision<'_>>, LinearSolveError> {
        if !self.factored || self.noise.len() != x.len() {
            return Ok(None);
        }
        self.term_sizes(system, x);
        self.unknown_scales(x);
        self.noise_floor()?;
        Ok(Some(Precision {
            jitter: &self.noise,
            scale: &self.unknown_scale,
        }))
    }

    /// The Newton update from the factorisation at hand and the last residual, into `update`
    /// (rows scaled as the factorisation's).
    fn solve_update(&mut self) -> Result<(), LinearSolveError> {
        for ((u, r), s) in self
            .update
            .iter_mut()
            .zip(&self.residual)
            .zip(&self.row_scale)
        {
            *u = r * s;
        }
        self.solver.solve_in_place(&mut self.update)
    }

    /// The update from the factorisation at hand and the last residual (of largest entry
    /// `residual`, in `worst`), applied and counted: the iterate `solve` returns.
    fn final_update(
        &mut self,
        x: &mut [f64],
        mut stats: NewtonStats,
        residual: f64,
        worst: usize,
    ) -> Result<NewtonStats, NewtonError> {
        self.solve_update().map_err(|source| NewtonError::Linear {
            source,
            residual,
            worst_equation: worst,
        })?;
        stats.iterations += 1;
        self.apply_update(x);
        Ok(stats)
    }

    /// `x ← x − update`, the whole update.
    fn apply_update(&self, x: &mut [f64]) {
        for (xi, u) in x.iter_mut().zip(&self.update) {
            *xi -= u;
        }
    }

    /// Fills `magnitude` with the size of every equation's terms at `x`,
    /// `m_i = c_i + Σ_j |J_ij x_j|` (`c` from [`NonlinearSystem::constant_magnitudes`], `J` the
    /// last stamped Jacobian): the yardstick of the residual test, the unknowns' scales and the
    /// noise floor.
    fn term_sizes<F: NonlinearSystem + ?Sized>(&mut self, system: &mut F, x: &[f64]) {
        system.constant_magnitudes(&mut self.magnitude);
        for (r, c, v) in self.jacobian.iter() {
            self.magnitude[r] += (v * x[c]).abs();
        }
    }

    /// The largest `|F_i(x)| / (c_i + Σ_j |J_ij x_j|)` over the equations (`c` the system's
    /// [`NonlinearSystem::constant_magnitudes`]), with the equation where it is attained (the
    /// last residual and the last stamped Jacobian; an equation whose terms all vanish counts as
    /// infinitely far unless its residual is zero too).
    fn relative_residual<F: NonlinearSystem + ?Sized>(
        &mut self,
        system: &mut F,
        x: &[f64],
    ) -> (f64, usize) {
        self.term_sizes(system, x);
        let mut worst = 0.0;
        let mut at = 0;
        for (i, (r, m)) in self.residual.iter().zip(&self.magnitude).enumerate() {
            let ratio = if *r == 0.0 { 0.0 } else { r.abs() / m };
            if ratio > worst || ratio.is_nan() {
                worst = ratio;
                at = i;
            }
        }
        (worst, at)
    }

    /// Per unknown `j`, the size of the unknown as the equations it weighs in see it:
    /// `s_j = max(|x_j|, min_i (c_i + Σ_k |J_ik x_k|) / |J_ij|)` over the equations where its
    /// coefficient is at least `SCALE_COEFFICIENT` of the equation's largest. `m_i / |J_ij|` is
    /// the change of `x_j` that moves equation `i` by the size of its terms, so an update below
    /// `update_tol·s_j` changes *every* such equation by less than `update_tol` of its terms. It
    /// differs from `|x_j|` only for an unknown that is small next to the other terms of all its
    /// equations (a joint multiplier of 1e-4 in momentum rows of size 1), whose relative
    /// resolution no equation needs. The minimum matters: with the largest ratio instead, a
    /// Galerkin increment that enters another coordinate's row through a small coupling was
    /// judged against that row, `1/h` times its own size, and iterates 1e-8 off were accepted;
    /// the double pendulum's energy then drifted by 3.2e-9 over 64 000 gauss2 steps instead of
    /// staying at 1.8e-10 (`dirac-sim/tests/long_run_energy.rs`). Equations where the unknown
    /// barely enters (a junction voltage through the 1e-12 S of GMIN) say nothing about its size
    /// and are left out.
    /// Reads the term sizes [`Newton::term_sizes`] left at `x`.
    fn unknown_scales(&mut self, x: &[f64]) {
        self.scales_current = true;
        self.unknown_scale.fill(f64::INFINITY);
        for (r, c, v) in self.jacobian.iter() {
            let a = v.abs();
            if a * self.row_scale[r] >= SCALE_COEFFICIENT {
                let s = self.magnitude[r] / a;
                if s < self.unknown_scale[c] {
                    self.unknown_scale[c] = s;
                }
            }
        }
        for (s, xi) in self.unknown_scale.iter_mut().zip(x) {
            *s = if s.is_finite() {
                s.max(xi.abs())
            } else {
                xi.abs()
            };
        }
    }

    /// The largest ratio of the last update of an unknown to its round-off: `4ε` of its scale
    /// plus its jitter (from [`Newton::unknown_scales`] and [`Newton::noise_floor`]). At most 1
    /// once no unknown moved by more than round-off can resolve.
    fn update_over_noise(&self) -> f64 {
        self.update
            .iter()
            .zip(&self.unknown_scale)
            .zip(&self.noise)
            .fold(0.0, |worst, ((u, scale), eta)| {
                worst.max(u.abs() / (KEPT_ACCEPT * scale + eta))
            })
    }

    /// [`Newton::noise_floor`] unless it is known for the factorisation at hand; a failing
    /// solve is reported with the iterate's largest residual `residual` (equation `worst`).
    fn current_noise_floor(&mut self, residual: f64, worst: usize) -> Result<(), NewtonError> {
        if !self.noise_current {
            self.noise_floor().map_err(|source| NewtonError::Linear {
                source,
                residual,
                worst_equation: worst,
            })?;
            self.noise_current = true;
        }
        Ok(())
    }

    /// Per unknown, how far a Newton update moves it when every residual carries the round-off of
    /// evaluating its own terms, `ε·(c_i + Σ_j |J_ij x_j|)`: `η = |J⁻¹ δF|` with `δF_i` that size
    /// and a fixed sign per equation, the largest over three sign patterns: two pseudo-random ones
    /// (one pattern can cancel in an unknown; two rarely both do) and one with every sign equal,
    /// for errors that add up coherently through `J⁻¹` (along a chain of 128 rigid links, where a
    /// body's coordinates carry the round-off of every joint row between it and the root: with
    /// the random patterns alone the estimate fell 13–30 times short there, exact updates stayed
    /// above the allowed jitter, and a step took up to 39 updates and 12 factorisations;
    /// docs/rigid.md). This is the precision to which Newton can
    /// determine each unknown from the factorisation at hand, in the unknown's own units: a
    /// constraint multiplier inherits the round-off of the positions times the stiffness `M/h²`
    /// of the equation that fixes it, a node charge that of the currents in its KCL row. Two
    /// solves with the current factorisation; no new one. Reads the term sizes
    /// [`Newton::term_sizes`] left at the current iterate.
    fn noise_floor(&mut self) -> Result<(), LinearSolveError> {
        self.noise_magnitude.copy_from_slice(&self.magnitude);
        self.noise.fill(0.0);
        for pattern in [0x9E37_79B9_7F4A_7C15_u64, 0xD1B5_4A32_D192_ED03, 0] {
            let mut state = pattern;
            for ((p, m), s) in self
                .noise_probe
                .iter_mut()
                .zip(&self.magnitude)
                .zip(&self.row_scale)
            {
                // xorshift64: a fixed, reproducible sign per equation.
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let sign = if state & 1 == 0 { 1.0 } else { -1.0 };
                *p = sign * f64::EPSILON * m * s;
            }
            self.solver.solve_in_place(&mut self.noise_probe)?;
            for (eta, p) in self.noise.iter_mut().zip(&self.noise_probe) {
                *eta = eta.max(p.abs());
            }
        }
        Ok(())
    }

    /// The residual test's second tier, for an iterate whose last undamped exact update was at
    /// round-off of the largest unknown: every equation satisfies
    /// `|F_i| ≤ STAGNATION_RESIDUAL·(c_i + Σ_j |J_ij x_j|) + ROUNDOFF·‖x‖∞·Σ_j |J_ij|`. The second
    /// term is the change of `F_i` when every unknown moves by the absolute precision the
    /// unknowns have in that regime (`ROUNDOFF·‖x‖∞`); it has the units of `F_i` and matters only
    /// in an equation whose terms all vanish at the root (a joint row `Δx = 0` between bodies at
    /// rest), where no relative test can pass.
    fn stagnated<F: NonlinearSystem + ?Sized>(&mut self, system: &mut F, x: &[f64]) -> bool {
        self.term_sizes(system, x);
        self.row_sum.fill(0.0);
        for (r, _, v) in self.jacobian.iter() {
            self.row_sum[r] += v.abs();
        }
        let floor = ROUNDOFF * max_norm(x).0;
        self.residual
            .iter()
            .zip(&self.magnitude)
            .zip(&self.row_sum)
            .all(|((r, m), s)| r.abs() <= STAGNATION_RESIDUAL * m + floor * s)
    }

    /// Stamps the Jacobian at `x` (analysing the pattern on the first call).
    fn stamp<F: NonlinearSystem + ?Sized>(
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
        Ok(())
    }

    /// Factorises the stamped Jacobian.
    fn factor(&mut self) -> Result<(), LinearSolveError> {
        // A failed attempt leaves no factorisation (the solver may have overwritten its factors):
        // the next solve refactorises.
        self.factored = false;
        self.noise_current = false;
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

/// The residual test's second tier: an undamped exact update at round-off of the largest unknown
/// (`‖Δx‖∞ ≤ update_tol·‖x‖∞`) with every equation within this fraction of its terms. It accepts
/// unknowns that sit far below the others (a body's vertical creep next to its joint forces),
/// whose updates are round-off of the larger ones and never pass the per-unknown test, in
/// equations whose terms cancel inside the model (a torque `Λ cos θ` at `θ` near `−π/2`
/// evaluated from a `θ` that carries an absolute error `ε|θ|`): the double rod chain's interior
/// momentum row sits at 5.5e-13 of `Σ|J_ij x_j|` there. An error in a small unknown that large
/// would still show: a diode's reverse current off by 1e-12 A is 1e-3 of its row.
const STAGNATION_RESIDUAL: f64 = 5e-11;

/// The absolute precision, relative to the largest unknown `‖x‖∞`, that every unknown has once
/// the updates are at round-off of the largest one: an update solved from a system that mixes
/// unknowns of all sizes carries an absolute error of a few `ε·‖x‖∞` in every component, so a
/// small unknown (a body's position that should be 0 next to O(1) momenta and forces) sits at
/// `±ε‖x‖∞`, and an equation made only of such unknowns keeps a residual of that size with every
/// term ≈ 0 (the bundled four-bar's joint row: 1.1e-16). Four ulps leave room for the solve's
/// error growth; the floor applies only in the at-round-off regime and is followed by a
/// polishing update.
const ROUNDOFF: f64 = 4.0 * f64::EPSILON;

/// The smallest coefficient, relative to its equation's largest, through which an equation sets
/// an unknown's scale in [`Newton::unknown_scales`]: `√ε`, below which the unknown's share of the
/// equation is lost in the round-off of the larger terms' product with any update.
const SCALE_COEFFICIENT: f64 = 1.5e-8;

/// How many times its round-off jitter ([`Newton::noise_floor`]) an update may move an unknown
/// and still count as converged: the estimate takes one ulp of each equation's terms, while a
/// residual that sums a handful of terms carries a few.
const NOISE_MARGIN: f64 = 8.0;

/// The largest contraction of a kept factorisation, measured in units of round-off on updates
/// well above it, whose iterate is accepted once its update is within round-off.
const KEPT_NOISE_CONTRACTION: f64 = 0.5;

/// The smallest update, in units of its round-off jitter ([`Newton::update_over_noise`]), whose
/// ratio to the one before counts as a measured contraction for the kept-iterate test.
const MEASURABLE_OVER_NOISE: f64 = 100.0;

/// Iterations on one kept factorisation before it is refreshed regardless of contraction.
const MAX_KEPT_ITERATIONS: usize = 8;

/// The factorisation whose contraction a solve measures ([`NewtonOptions::start_contraction`]).
#[derive(Debug, Clone, Copy)]
enum Measuring {
    /// One carried over from an earlier solve.
    Carried,
    /// One formed at the solve's guess because the carried one contracted poorly.
    Fresh,
}

/// Smallest update, relative to the largest unknown, whose ratio to the update before counts as
/// a measured contraction for [`NewtonOptions::start_contraction`].
const MEASURABLE_UPDATE: f64 = 1e4 * f64::EPSILON;

/// How many solves start the way [`NewtonOptions::start_contraction`] chooses before one starts
/// the other way, to re-measure the contraction it would give.
const START_PROBE: usize = 8;

/// The loop above returns on every path; this keeps the compiler satisfied without a panic.
fn unreachable_converged() -> Result<NewtonStats, NewtonError> {
    Err(NewtonError::NotConverged {
        iterations: 0,
        residual: f64::NAN,
        relative_residual: f64::NAN,
        worst_equation: 0,
    })
}

/// Max-norm and the index where it is attained; a NaN or infinity wins (the first one, and is
/// returned).
///
/// Blocks of [`NORM_BLOCK`] entries are reduced lane-wise (independent maxima and sums of the
/// magnitudes), so the pass vectorises; a block whose sum is not finite (it holds a NaN or an
/// infinity, or its finite magnitudes overflowed) is searched for a non-finite entry, and only
/// the block holding the maximum is searched for its index. Vectors of at most [`SHORT_NORM`]
/// entries (a few-dof model's step) take one plain pass instead: the blocked pass's set-up and
/// second search cost more than the whole vector there.
#[inline]
pub(crate) fn max_norm(v: &[f64]) -> (f64, usize) {
    if v.len() <= SHORT_NORM {
        let mut best = 0.0;
        let mut at = 0;
        for (i, x) in v.iter().enumerate() {
            let a = x.abs();
            if !a.is_finite() {
                return (a, i);
            }
            if a > best {
                best = a;
                at = i;
            }
        }
        return (best, at);
    }
    blocked_max_norm(v)
}

/// Vectors up to this length take [`max_norm`]'s plain pass.
const SHORT_NORM: usize = 16;

/// [`max_norm`]'s blocked pass.
fn blocked_max_norm(v: &[f64]) -> (f64, usize) {
    let mut best = 0.0;
    let mut best_block = 0;
    for (b, block) in v.chunks(NORM_BLOCK).enumerate() {
        let mut lanes = [0.0_f64; 4];
        let mut sums = [0.0_f64; 4];
        let quads = block.chunks_exact(4);
        let tail = quads.remainder();
        for quad in quads {
            for i in 0..4 {
                let a = quad[i].abs();
                lanes[i] = if a > lanes[i] { a } else { lanes[i] };
                sums[i] += a;
            }
        }
        for (i, x) in tail.iter().enumerate() {
            let a = x.abs();
            lanes[i] = if a > lanes[i] { a } else { lanes[i] };
            sums[i] += a;
        }
        if !sums.iter().sum::<f64>().is_finite()
            && let Some(i) = block.iter().position(|x| !x.is_finite())
        {
            return (block[i].abs(), b * NORM_BLOCK + i);
        }
        let m = lanes
            .iter()
            .fold(0.0_f64, |m, &a| if a > m { a } else { m });
        if m > best {
            best = m;
            best_block = b;
        }
    }
    let at = v
        .chunks(NORM_BLOCK)
        .nth(best_block)
        .and_then(|block| block.iter().position(|x| x.abs() == best))
        .map_or(0, |i| best_block * NORM_BLOCK + i);
    (best, at)
}

/// Entries per block of [`max_norm`]'s pass.
const NORM_BLOCK: usize = 64;

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

    /// The blocked max-norm against the plain scan it replaces: the largest magnitude and the
    /// first index attaining it, or the first NaN or infinity, over lengths around the block
    /// and lane sizes.
    #[test]
    fn max_norm_finds_the_first_largest_entry_or_the_first_non_finite_one() {
        // The specification: the first non-finite entry if there is one, else the largest
        // magnitude and the first index attaining it.
        fn plain(v: &[f64]) -> (f64, usize) {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return (v[i].abs(), i);
            }
            let largest = v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            let at = v.iter().position(|x| x.abs() == largest).unwrap_or(0);
            (largest, at)
        }
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for len in [0, 1, 3, 4, 5, 16, 17, 63, 64, 65, 130, 1000] {
            let mut v: Vec<f64> = (0..len).map(|_| next()).collect();
            assert_eq!(max_norm(&v), plain(&v), "len {len}");
            if len < 3 {
                continue;
            }
            // A tie: the first index wins.
            let (m, at) = plain(&v);
            v[len - 1] = -m;
            assert_eq!(max_norm(&v).1, at, "tie, len {len}");
            // Finite magnitudes whose sum overflows are no non-finite entry.
            let mut huge = v.clone();
            huge[0] = f64::MAX;
            huge[1] = -f64::MAX;
            assert_eq!(max_norm(&huge), plain(&huge), "overflowing sum, len {len}");
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut w = v.clone();
                w[len / 2] = bad;
                w[len - 1] = f64::NAN;
                let (norm, at) = max_norm(&w);
                assert_eq!(at, len / 2, "len {len}, {bad}");
                assert!(norm.is_nan() == bad.is_nan() && !norm.is_finite());
            }
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

    /// `x₀ + 0.1x₀³ = a`, `x₁ = sin x₀ − sin 1`: near `x₀ = 1` the second unknown is a small
    /// difference of terms of size 0.84 (as a Galerkin increment is of positions), so round-off
    /// in its equation moves it by about 1e-16, far more than `4ε` of itself.
    struct SmallDifference(f64);
    impl NonlinearSystem for SmallDifference {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] + 0.1 * x[0] * x[0] * x[0] - self.0;
            r[1] = x[1] - (x[0].sin() - 1f64.sin());
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 1.0 + 0.3 * x[0] * x[0]);
            jac.add(1, 0, -x[0].cos());
            jac.add(1, 1, 1.0);
        }
    }

    /// A kept factorisation whose updates of the small unknown stall at its round-off is
    /// refreshed under the strict rule whenever they stall above `4ε` of the unknown, and kept
    /// with `accept_at_equation_roundoff`, whose roots agree with exact Newton's to round-off of
    /// the equations. Measured over 60 warm-started solves (x₁ from 4e-7 to 2.5e-5): 13
    /// factorisations and 212 updates strict, 1 and 195 with the option; both sets of roots
    /// within 1.2e-16 of exact Newton's in x₁. Mutation: ignoring the option gives 13 and fails.
    #[test]
    fn updates_at_round_off_of_their_equations_accept_a_kept_iterate_when_asked() {
        let factorisations = |accept: bool| {
            let options = NewtonOptions {
                accept_at_equation_roundoff: accept,
                ..NewtonOptions::default()
            };
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut reference = Newton::new(DenseLu::new(), exact_newton());
            let mut x = [1.0, 0.0];
            let mut total = NewtonStats::default();
            let mut worst: f64 = 0.0;
            for k in 1..=60 {
                let a = 1.1 + 1e-6 * f64::from(k);
                let mut exact = x;
                total.accumulate(&newton.solve(&mut SmallDifference(a), &mut x).unwrap());
                reference
                    .solve(&mut SmallDifference(a), &mut exact)
                    .unwrap();
                assert!((x[0] - exact[0]).abs() <= 4.0 * f64::EPSILON * exact[0]);
                worst = worst.max((x[1] - exact[1]).abs());
            }
            println!(
                "accept_at_equation_roundoff {accept}: {total:?}, worst x₁ difference {worst:e}"
            );
            assert!(worst <= 4.0 * f64::EPSILON, "x₁ off by {worst:e}");
            total.factorisations
        };
        let (strict, relaxed) = (factorisations(false), factorisations(true));
        assert!(
            relaxed <= 2 && 5 * relaxed <= strict,
            "{relaxed} factorisations with the option, {strict} without"
        );
    }

    /// `a·((x − 1) + (x − 1)³)` whose equation has constant terms of size `m`: root 1 for every
    /// `a` and `m`, which change between solves.
    struct Rescaled {
        a: f64,
        m: f64,
    }
    impl Rescaled {
        /// Terms of the size of the coefficient.
        fn new(a: f64) -> Self {
            Self { a, m: a.abs() }
        }
    }
    impl NonlinearSystem for Rescaled {
        fn len(&self) -> usize {
            1
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            let e = x[0] - 1.0;
            r[0] = self.a * (e + e * e * e);
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            let e = x[0] - 1.0;
            jac.add(0, 0, self.a * (1.0 + 3.0 * e * e));
        }
        fn constant_magnitudes(&mut self, out: &mut [f64]) {
            out[0] = self.m;
        }
    }

    /// A kept iterate is accepted at round-off only on a contraction measured in the same solve.
    /// The first solve (a = 1, from 1e-3 off) measures its factorisation's contraction as 2e-6;
    /// the second (a = 0.01, from 1.5e-13 off) keeps that factorisation, whose contraction on the
    /// new system is 0.99. Carried into the second solve, the first's measurement accepted its
    /// first kept update, 1.5e-15, with the root 1.47e-13 (662 ulps) away, 55 ulps at a = 0.1
    /// (found in review); now the root is exact Newton's, 1 to `4ε`.
    #[test]
    fn a_kept_iterate_is_not_accepted_on_an_earlier_solves_contraction() {
        for a in [0.1, 0.01] {
            let options = NewtonOptions {
                accept_at_equation_roundoff: true,
                ..NewtonOptions::default()
            };
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.0 + 1e-3];
            newton.solve(&mut Rescaled::new(1.0), &mut x).unwrap();
            let mut x = [1.0 + 1.5e-15 / a];
            let stats = newton.solve(&mut Rescaled::new(a), &mut x).unwrap();
            assert!(
                (x[0] - 1.0).abs() <= 4.0 * f64::EPSILON,
                "a = {a}: root off by {:e} ({stats:?})",
                x[0] - 1.0
            );
        }
    }

    /// The round-off jitter that admits a kept iterate is estimated once per factorisation, from
    /// the equations' term sizes at the time. A first solve whose equation carries terms of 1e6
    /// estimates a jitter of 2e-10; the second (terms of 1, the factorisation kept) accepted its
    /// iterate within that jitter, 2.3e-12 (10 376 ulps) from the root (found in review). The
    /// estimate is now renewed once an equation's terms shrink below half of those it was made
    /// with: the root to `4ε`.
    #[test]
    fn a_jitter_estimated_for_larger_terms_is_not_kept() {
        let options = NewtonOptions {
            accept_at_equation_roundoff: true,
            ..NewtonOptions::default()
        };
        let mut newton = Newton::new(DenseLu::new(), options);
        let mut x = [1.0 + 1e-3];
        newton
            .solve(&mut Rescaled { a: 1.0, m: 1e6 }, &mut x)
            .unwrap();
        let mut x = [1.0 + 1.8e-7];
        let stats = newton
            .solve(&mut Rescaled { a: 1.2, m: 1.0 }, &mut x)
            .unwrap();
        assert!(
            (x[0] - 1.0).abs() <= 4.0 * f64::EPSILON,
            "root off by {:e} ({stats:?})",
            x[0] - 1.0
        );
    }

    /// 100 solves of the circle whose radius grows 3 % per solve, so a factorisation carried
    /// from the solve before contracts by about 3e-2, from two kinds of guess: the new root to
    /// 1e-6 (as a good predictor gives), and the last root (3 % off). Returns the counters with
    /// `start_contraction` 1e-2 and with the default (the carried factorisation always kept).
    fn growing_circle_runs(predicted: bool) -> [NewtonStats; 2] {
        let refreshed = NewtonOptions {
            start_contraction: Some(1e-2),
            ..NewtonOptions::default()
        };
        [refreshed, NewtonOptions::default()].map(|options| {
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.4, 1.4];
            let mut total = NewtonStats::default();
            for k in 0..100 {
                let rho = 2.0 * 1.03f64.powi(k);
                let root = rho / 2f64.sqrt();
                if predicted {
                    x = [root * (1.0 + 1e-6); 2];
                }
                total.accumulate(&newton.solve(&mut GrowingCircle(rho), &mut x).unwrap());
                assert!(
                    (x[0] - root).abs() <= 2.0 * f64::EPSILON * root,
                    "{x:?} vs {root}"
                );
            }
            total
        })
    }

    /// From a good guess, a poorly contracting carried factorisation is replaced at the start of
    /// the next solves, which then take far fewer updates to the same round-off root (every
    /// ninth re-measures the carried one); from a poor guess a fresh Jacobian contracts no
    /// faster, and the solves keep the carried factorisation. Measured: 307 updates against 794
    /// (good guess; 89 factorisations against 50); 111 factorisations against 100 (poor guess;
    /// the extra ones are every ninth solve's probe of a fresh start). Mutation: dropping the
    /// `fresh_contraction` comparison refactorises the poor-guess solves at every start (188
    /// factorisations, 987 updates). (Measuring contractions also on updates at round-off,
    /// whose ratios are near 1, passes here; `dirac-sim/tests/predictor.rs`
    /// `composed_substeps_start_from_a_fresh_jacobian` fails on it.)
    #[test]
    fn a_poorly_contracting_carried_factorisation_is_refreshed_at_the_start() {
        let [fresh, carried] = growing_circle_runs(true);
        println!("good guess: default {fresh:?}, carried only {carried:?}");
        assert!(
            fresh.iterations * 2 <= carried.iterations,
            "{fresh:?} {carried:?}"
        );
        let [fresh, carried] = growing_circle_runs(false);
        println!("poor guess: default {fresh:?}, carried only {carried:?}");
        assert!(
            fresh.factorisations * 5 <= carried.factorisations * 6,
            "{fresh:?} {carried:?}"
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

    /// `x² − 2 = 0` from `x = 1.5` with every update damped to `1 − 1e-9` of itself (as junction
    /// limiting does), for every iteration limit from 1 to 8: a solve either converges to `√2`
    /// within round-off or fails with a residual above the residual test's tolerance. An iterate
    /// that first reaches round-off on the last allowed iteration is converged (it returned
    /// `NotConverged` at 1e-16 of its terms before: the limit was checked before the test).
    #[test]
    fn an_iterate_at_round_off_on_the_last_iteration_is_converged() {
        struct Damped;
        impl NonlinearSystem for Damped {
            fn len(&self) -> usize {
                1
            }
            fn residual(&mut self, x: &[f64], r: &mut [f64]) {
                r[0] = x[0] * x[0] - 2.0;
            }
            fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
                jac.add(0, 0, 2.0 * x[0]);
            }
            fn update_fraction(&mut self, _x: &[f64], _update: &[f64]) -> f64 {
                1.0 - 1e-9
            }
        }
        let mut converged = 0;
        for limit in 1..=8 {
            let options = NewtonOptions {
                max_iterations: limit,
                ..NewtonOptions::default()
            };
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.5];
            match newton.solve(&mut Damped, &mut x) {
                Ok(_) => {
                    assert!(
                        (x[0] - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON,
                        "limit {limit}: {x:?}"
                    );
                    converged += 1;
                }
                Err(NewtonError::NotConverged {
                    relative_residual, ..
                }) => assert!(
                    relative_residual > options.residual_tol,
                    "limit {limit}: refused at {relative_residual:e} of its terms"
                ),
                Err(e) => panic!("limit {limit}: {e}"),
            }
        }
        assert!(converged >= 4, "{converged} of 8 limits converged");
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

    /// `F(x) = x³ − b` componentwise on two unknowns, whose Jacobian is stamped as the singular
    /// `[[1, 1], [1, 1]]` while `broken` is set.
    struct Breakable {
        b: f64,
        broken: bool,
    }
    impl NonlinearSystem for Breakable {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            for (r, x) in r.iter_mut().zip(x) {
                *r = x * x * x - self.b;
            }
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            for (i, xi) in x.iter().enumerate() {
                for j in 0..2 {
                    let value = if self.broken {
                        1.0
                    } else if i == j {
                        3.0 * xi * xi
                    } else {
                        0.0
                    };
                    jac.add(i, j, value);
                }
            }
        }
    }

    /// A factorisation that fails leaves Newton without one: the next solve refactorises. It
    /// used to keep the flag of the factorisation before, so the next solve reused factors the
    /// failed attempt had overwritten: the sparse LU refused ("solve called without a
    /// successful factorisation", seen on a rigid chain's cut step at h = 0.05), the dense LU
    /// solved with a half-eliminated matrix.
    #[test]
    fn a_failed_factorisation_is_not_reused() {
        fn check<S: LinearSolver>(solver: S, name: &str) {
            let mut newton = Newton::new(solver, NewtonOptions::default());
            let mut system = Breakable {
                b: 8.0,
                broken: false,
            };
            let mut x = [1.5, 2.5];
            newton.solve(&mut system, &mut x).unwrap();
            // The kept factorisation (at x = 2) takes x from 2 towards the root −2 of b = −8
            // slowly, so Newton refactorises, at the singular stamp.
            system.b = -8.0;
            system.broken = true;
            assert!(matches!(
                newton.solve(&mut system, &mut x),
                Err(NewtonError::Linear {
                    source: LinearSolveError::NumericallySingular { .. },
                    ..
                })
            ));
            system.b = 8.0;
            system.broken = false;
            let mut x = [1.5, 2.5];
            let solved = newton.solve(&mut system, &mut x);
            assert!(solved.is_ok(), "{name}: {solved:?}");
            assert!(
                x.iter().all(|v| (v - 2.0).abs() <= 4.0 * f64::EPSILON),
                "{name}: {x:?}"
            );
        }
        check(DenseLu::new(), "dense");
        check(crate::SparseLu::new(), "sparse");
    }

    /// `F(x) = s (x³ − 8)` with `s = 1e-20`: every residual is far below any absolute tolerance,
    /// so only tests relative to the equation's own terms can tell the root `x = 2` from the
    /// start `x = 1`. Newton must reach the root to round-off, exactly as for `s = 1`.
    ///
    /// Mutation: an absolute residual test `‖F‖ ≤ 1e-14` accepts `x = 1.99…` after one or two
    /// updates (error 1e-1).
    struct Scaled(f64);
    impl NonlinearSystem for Scaled {
        fn len(&self) -> usize {
            1
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = self.0 * (x[0] * x[0] * x[0] - 8.0);
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, self.0 * 3.0 * x[0] * x[0]);
        }
    }

    #[test]
    fn tiny_systems_converge_like_unit_ones() {
        for s in [1.0, 1e-20, 1e20] {
            for options in [NewtonOptions::default(), exact_newton()] {
                let mut newton = Newton::new(DenseLu::new(), options);
                let mut x = [1.0];
                let stats = newton.solve(&mut Scaled(s), &mut x).unwrap();
                assert!(
                    (x[0] - 2.0).abs() <= 2.0 * f64::EPSILON,
                    "s = {s}: {x:?} {stats:?}"
                );
            }
        }
    }

    /// `a³ = 8` and `b + (1 + δ) − 1 = 0`, where `δ = ±ε` alternates between evaluations (the
    /// round-off any model's residual carries): `b = 0` up to that noise, so no update of `b` is
    /// ever small relative to `b` itself, and the per-unknown update test never passes. The
    /// residual test does: `ε` against terms of size 2 (reported through
    /// `constant_magnitudes`) is converged.
    ///
    /// Mutation: without the residual test the solve reports `NotConverged`.
    struct ZeroUnknown {
        evaluations: usize,
    }
    impl NonlinearSystem for ZeroUnknown {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            self.evaluations += 1;
            let delta = if self.evaluations.is_multiple_of(2) {
                f64::EPSILON
            } else {
                -f64::EPSILON / 2.0
            };
            r[0] = x[0] * x[0] * x[0] - 8.0;
            r[1] = x[1] + (1.0 + delta) - 1.0;
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 3.0 * x[0] * x[0]);
            jac.add(1, 1, 1.0);
        }
        fn constant_magnitudes(&mut self, out: &mut [f64]) {
            out[0] = 8.0;
            out[1] = 2.0;
        }
    }

    #[test]
    fn unknown_converging_to_zero_is_accepted_by_the_residual_test() {
        for options in [NewtonOptions::default(), exact_newton()] {
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.0, 3.0];
            let stats = newton
                .solve(&mut ZeroUnknown { evaluations: 0 }, &mut x)
                .unwrap();
            assert!((x[0] - 2.0).abs() <= 2.0 * f64::EPSILON, "{x:?}");
            assert!(x[1].abs() <= 2.0 * f64::EPSILON, "{x:?} {stats:?}");
        }
    }

    /// `eˣ = e²⁰` from `x = 0` (or 0.5): the first Newton update asks for `x ≈ 4.9e8` and the residual
    /// overflows. With a limit of 2 per update (a stand-in for junction limiting) Newton walks
    /// up and converges; every limited update is counted, and none of them is taken for
    /// convergence although each is small next to the requested one.
    ///
    /// Mutation: applying the unlimited update (`α = 1`) gives `NonFiniteResidual`.
    struct Exponential {
        limit: Option<f64>,
    }
    impl NonlinearSystem for Exponential {
        fn len(&self) -> usize {
            1
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0].exp() - 20f64.exp();
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, x[0].exp());
        }
        fn update_fraction(&mut self, _x: &[f64], update: &[f64]) -> f64 {
            self.limit.map_or(1.0, |l| (l / update[0].abs()).min(1.0))
        }
    }

    #[test]
    fn limited_updates_reach_the_root() {
        let mut newton = Newton::new(DenseLu::new(), exact_newton());
        let mut x = [0.0];
        let err = newton
            .solve(&mut Exponential { limit: None }, &mut x)
            .unwrap_err();
        assert!(
            matches!(err, NewtonError::NonFiniteResidual { .. }),
            "{err}"
        );
        let mut x = [0.5];
        let stats = newton
            .solve(&mut Exponential { limit: Some(2.0) }, &mut x)
            .unwrap();
        assert!((x[0] - 20.0).abs() <= 4.0 * f64::EPSILON * 20.0, "{x:?}");
        assert!(
            stats.limited >= 9 && stats.limited < stats.iterations,
            "{stats:?}"
        );
    }

    /// A system that shortens its first update to 1e-13 of itself: that update moves `x` by far
    /// less than the update test's tolerance, yet the iterate is nowhere near the root. It must
    /// not be accepted.
    ///
    /// Mutation: letting a damped update pass the update test returns `x ≈ 1`.
    struct Stall {
        first: bool,
    }
    impl NonlinearSystem for Stall {
        fn len(&self) -> usize {
            1
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] * x[0] - 4.0;
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 2.0 * x[0]);
        }
        fn update_fraction(&mut self, _x: &[f64], _update: &[f64]) -> f64 {
            if std::mem::replace(&mut self.first, false) {
                1e-13
            } else {
                1.0
            }
        }
    }

    #[test]
    fn a_damped_update_is_never_convergence() {
        for options in [NewtonOptions::default(), exact_newton()] {
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.0];
            let stats = newton.solve(&mut Stall { first: true }, &mut x).unwrap();
            assert!((x[0] - 2.0).abs() <= 2.0 * f64::EPSILON, "{x:?} {stats:?}");
            assert_eq!(stats.limited, 1);
        }
    }

    /// A joint-like row whose terms all vanish at the root, next to an O(1) unknown:
    /// `a² = 2`, `u = w`, and `u + w = 0` evaluated as `((a + u) − a) + w`, the way a model
    /// evaluates a relative position from coordinates of size `a` (so `u` is resolved only to the
    /// absolute precision `ε·|a|`). At the root `u = w = 0`: every term of the last row vanishes,
    /// its residual stays at the round-off of `a` and no test relative to the row's own terms can
    /// pass. The round-off floor of the residual test's second tier accepts it.
    ///
    /// Mutation: `ROUNDOFF = 0.0` gives `NotConverged` (25 iterations).
    struct VanishingRow;
    impl NonlinearSystem for VanishingRow {
        fn len(&self) -> usize {
            3
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] * x[0] - 2.0;
            r[1] = x[1] - x[2];
            r[2] = ((x[0] + x[1]) - x[0]) + x[2];
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 2.0 * x[0]);
            jac.add(1, 1, 1.0);
            jac.add(1, 2, -1.0);
            jac.add(2, 1, 1.0);
            jac.add(2, 2, 1.0);
        }
        fn constant_magnitudes(&mut self, out: &mut [f64]) {
            out.copy_from_slice(&[2.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn row_whose_terms_all_vanish_converges() {
        for options in [NewtonOptions::default(), exact_newton()] {
            let mut newton = Newton::new(DenseLu::new(), options);
            let mut x = [1.0, 0.3, -0.2];
            let stats = newton.solve(&mut VanishingRow, &mut x).unwrap();
            println!("vanishing row: {x:?} {stats:?}");
            assert!((x[0] - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON, "{x:?}");
            // The small unknowns are resolved to the absolute precision `ε·|a|` the model gives
            // them.
            assert!(x[1].abs() <= 4.0 * f64::EPSILON && x[2].abs() <= 4.0 * f64::EPSILON);
        }
    }

    /// `F_i(x) = d_i x_i − b_i` with `|b_i|` reported as each equation's constant terms: at the
    /// root every equation's terms add up to `m_i = 2|b_i|`, and a round-off of `ε·m_i` in `F_i`
    /// moves `x_i` by exactly `ε·m_i/|d_i| = 2ε|x_i|`, whatever the sign patterns. The noise
    /// floor must give that per unknown, for coefficients `d_i` twelve orders of magnitude apart
    /// (row equilibration must not leak into the unknowns' units).
    ///
    /// Mutation: leaving out the row scale in the probe right-hand side gives `η_i = 2ε|x_i|·|d_i|`
    /// and fails for every `d_i ≠ 1`.
    struct Diagonal {
        d: Vec<f64>,
        b: Vec<f64>,
    }
    impl NonlinearSystem for Diagonal {
        fn len(&self) -> usize {
            self.d.len()
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = self.d[i] * x[i] - self.b[i];
            }
        }
        fn jacobian(&mut self, _x: &[f64], jac: &mut Triplets) {
            for (i, d) in self.d.iter().enumerate() {
                jac.add(i, i, *d);
            }
        }
        fn constant_magnitudes(&mut self, out: &mut [f64]) {
            for (o, b) in out.iter_mut().zip(&self.b) {
                *o = b.abs();
            }
        }
    }

    #[test]
    fn noise_floor_is_the_round_off_of_each_unknown() {
        let mut system = Diagonal {
            d: vec![1e6, -3.0, 1e-6, 7.0],
            b: vec![2.0, 5e-3, -4e-9, 0.25],
        };
        let mut newton = Newton::new(DenseLu::new(), exact_newton());
        let mut x = [0.0; 4];
        newton.solve(&mut system, &mut x).unwrap();
        newton.term_sizes(&mut system, &x);
        newton.noise_floor().unwrap();
        for (i, (eta, xi)) in newton.noise.iter().zip(&x).enumerate() {
            let expected = 2.0 * f64::EPSILON * xi.abs();
            assert!(
                (eta - expected).abs() <= 1e-12 * expected,
                "unknown {i}: η = {eta:e}, expected {expected:e}"
            );
        }
    }

    /// `F_0 = x_0 + g·x_1 − 1` with `g = 1e-12` (a GMIN-like coupling) and `F_1 = x_1 − 2`, each
    /// with its constant reported: at the root (`x_0 = 1 − 2g`) `m_0 = 1 + (1 − 2g) + 2g = 2` and
    /// `m_1 = 2 + 2`. The scale of `x_0` is `m_0/1 = 2`; `x_1` enters row 0 only through `g` (below `√ε` of the row),
    /// so its scale is `m_1/1 = 4`, not `m_0/g = 2e12`, which would accept any update of `x_1`.
    ///
    /// Mutation: dropping the coefficient filter gives `s_1 = 2e12`.
    struct Weak;
    impl NonlinearSystem for Weak {
        fn len(&self) -> usize {
            2
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            r[0] = x[0] + 1e-12 * x[1] - 1.0;
            r[1] = x[1] - 2.0;
        }
        fn jacobian(&mut self, _x: &[f64], jac: &mut Triplets) {
            jac.add(0, 0, 1.0);
            jac.add(0, 1, 1e-12);
            jac.add(1, 1, 1.0);
        }
        fn constant_magnitudes(&mut self, out: &mut [f64]) {
            out[0] = 1.0;
            out[1] = 2.0;
        }
    }

    #[test]
    fn unknown_scales_come_from_the_equations_they_weigh_in() {
        let mut newton = Newton::new(DenseLu::new(), exact_newton());
        let mut x = [0.0; 2];
        newton.solve(&mut Weak, &mut x).unwrap();
        newton.term_sizes(&mut Weak, &x);
        newton.unknown_scales(&x);
        let expected = [2.0, 4.0];
        for (j, (s, e)) in newton.unknown_scale.iter().zip(expected).enumerate() {
            assert!(
                (s - e).abs() <= 4.0 * f64::EPSILON * e,
                "s_{j} = {s:e}, expected {e:e}"
            );
        }
    }
}
