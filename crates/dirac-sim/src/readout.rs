//! Values at `t_k`: velocities and constraint multipliers from `(q_k, p_k, t_k)` by the algebraic
//! relations of the continuous model (MATH §7).
//!
//! A step's multiplier `Λ_k` is an impulse over `[t_k, t_{k+1}]` and its rate `(q_{k+1} − q_k)/h` a
//! mean over the step: read at `t_k` both are biased (by `O(h²)`, by `O(h)` at a source corner). The
//! state `(q_k, p_k)` itself is exact to the scheme's order, and at fixed `(q, p, t)` the continuous
//! Lagrange–Dirac equations fix the velocity `v` and the multiplier `λ` (a node potential, a joint
//! force) algebraically. With unknowns `(v, γ, a, λ)` (`γ` the unknown constraint impulse hidden in
//! `p`, `a` the acceleration) they are
//!
//! ```text
//! R1:  ∂L/∂v(q, v) − p − Aᵀγ                    = 0    momentum, up to a constraint impulse
//! R2:  A v                                      = 0    the constraints on velocities
//! R3:  ∂²L/∂v² a + ∂²L/∂v∂q v − ∂L/∂q − f + Aᵀλ = 0    Euler–Lagrange (forced, constrained)
//! R4:  A a + (∂A/∂q · v) v                      = 0    the constraints differentiated once
//! ```
//!
//! (the sign of `λ` is the step's: `ṗ = ∂L/∂q + f − Aᵀλ`, so a KCL multiplier is the node
//! potential). R1 fixes the velocities of kinetic directions (inductor currents, masses) modulo
//! constraint impulses; R3 in degenerate directions (no kinetic term: resistors, capacitors,
//! sources) is an algebraic relation between forces and multipliers that fixes the degenerate
//! rates; R3 in kinetic directions with R4 fixes the multipliers a constraint needs an acceleration
//! for (a node joining only inductors, a joint between masses).
//!
//! Not every unknown is determined: an acceleration of a degenerate coordinate appears only in R4,
//! and `γ` may be a pure gauge. Which unknowns are free and which equations only restate others is a
//! property of the pattern, found once by a Dulmage–Mendelsohn analysis
//! ([`dirac_solve::Structure`]): free unknowns are fixed at zero, redundant equations are left out of
//! the solve and kept as consistency checks. A velocity or multiplier that falls in the
//! under-determined part needs the time derivative of an algebraic relation (an index-2 quantity:
//! the current of a capacitor across a voltage source, the potential between an inductor and a
//! current source); [`Readout::velocity_determined`] and [`Readout::multiplier_determined`] say so,
//! and the caller reads those from the steps instead.

use dirac_core::{Constraints, Model, Triplets};
use dirac_solve::{
    LinearSolveError, Newton, NewtonError, NewtonOptions, NewtonStats, NonlinearSystem, Precision,
    Structure,
};

use std::sync::Arc;

use crate::derivatives::Derivatives;
use crate::linear::{AutoLu, SolverChoice};
use crate::sharing::Sharing;

/// Marks a full-system unknown or equation left out of the reduced solve.
const OUT: usize = usize::MAX;

/// Which block of the readout system an unknown or equation belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadoutRow {
    /// R1 of coordinate `i` (momentum).
    Momentum(usize),
    /// R2 of constraint `a` (velocities).
    Constraint(usize),
    /// R3 of coordinate `i` (forces).
    Force(usize),
    /// R4 of constraint `a` (accelerations).
    Acceleration(usize),
    /// R5 of constraint `a`: the charge shared along shifted coordinates keeps it.
    Sharing(usize),
}

/// The algebraic readout of one model with its (active) constraint rows.
#[derive(Debug)]
pub struct Readout {
    plan: Arc<ReadoutPlan>,
    /// Magnitude of the terms of the last solve's equations (for relative tests).
    scale: f64,
    newton: Newton<AutoLu>,
    reduced: Vec<f64>,
    work: Work,
    stats: NewtonStats,
    /// Per full unknown, whether the last solve determined it to [`READOUT_PRECISION`].
    precise: Vec<bool>,
}

/// The relative precision (round-off jitter over scale, [`Newton::precision`]) below which a
/// value read from `(q_k, p_k, t_k)` is taken as determined by that state: `10⁶·ε`, a condition
/// number of 10⁶ from the state to the value. A value above it is fixed by the state only through
/// a coefficient lost among the others (a node potential behind an off diode, read as `i/g`
/// from a winding current with `g` = 1e-12 S): the state's own error, which is not round-off
/// but the scheme's (the midpoint rule leaves such a stiff mode ringing at ±1e-10 A about its
/// slow value), then reaches the value magnified a million times or more, so it is read from the
/// steps instead (see [`Readout::velocity_precise`]). Well-determined values sit near `ε` to
/// `10³·ε`.
pub const READOUT_PRECISION: f64 = 1e6 * f64::EPSILON;

/// Largest residual, relative to its equation's terms, at which a readout whose Newton iteration
/// ran out of iterations is still taken: a diode's diffusion charge (`TT` without `CJO`) can make
/// the exact iteration cycle between two or three iterates 4e-13 apart at a residual of 4e-13 of
/// the terms, which the per-equation tests (`1e-14`) never pass. Its values are then not taken
/// as precise ([`Readout::velocity_precise`]): a run reads them from the steps.
pub const READOUT_STALL: f64 = 1e-10;

/// Newton iterations a readout may take. A junction approached from a forward voltage above
/// its solution descends by about one `N·V_t` per exact Newton iteration (SPICE's `pnjlim`
/// limits only rises above `V_crit`, so nothing speeds the descent): a guess 1 V high with
/// `N = 1.8` takes 22 iterations, which the steps' limit of 25 left no room for
/// (`diode_transformer.cir`'s readout at t = 63.9 ms, once the limiter stopped damping
/// unlimited updates at random). 100 covers 4 V at that slope; a readout iteration is cheap.
const READOUT_ITERATIONS: usize = 100;

/// Pivots the readout's LU treats as zero when its relations are nonlinear: `ε²` of their
/// (equilibrated) row. Larger tiny pivots are let through, and the unknowns they leave
/// ill-determined are found by their round-off jitter instead (so one of them does not stop the
/// readout of the others). Linear relations keep the LU's own tolerance and are not judged: their
/// conditioning is the same at every state.
const READOUT_PIVOT_TOL: f64 = f64::EPSILON * f64::EPSILON;

/// What the structural analysis of the readout system found: which unknowns and equations are
/// solved, which are free or redundant. A function of the pattern alone, so it is shared by every
/// readout of the same model and constraint rows (the run layer keeps it with the graph).
#[derive(Debug)]
pub(crate) struct ReadoutPlan {
    n: usize,
    m: usize,
    /// Full index of each reduced unknown / equation.
    cols: Vec<usize>,
    rows: Vec<usize>,
    /// Reduced index of each full unknown / equation (`OUT` when not solved for).
    col_slot: Vec<usize>,
    row_slot: Vec<usize>,
    velocity_determined: Vec<bool>,
    multiplier_determined: Vec<bool>,
    /// The shifts of degenerate positions the readout may make (charge sharing).
    sharing: Sharing,
    /// Equations left out of the solve because others already fix their unknowns.
    redundant: Vec<usize>,
    /// Every equation of the over-determined part (the redundant ones and those they restate).
    overdetermined: Vec<usize>,
    constant: bool,
}

impl ReadoutPlan {
    /// Where each block sits in the full system.
    fn layout(&self) -> Layout<'_> {
        Layout {
            n: self.n,
            m: self.m,
            sharing: &self.sharing,
        }
    }

    /// Whether some equation is left out as a restatement of others (else a start cannot
    /// violate an algebraic relation the readout checks).
    pub(crate) fn has_consistency_conditions(&self) -> bool {
        !self.redundant.is_empty()
    }

    /// See [`Readout::velocity_determined`].
    pub(crate) fn velocity_determined(&self, i: usize) -> bool {
        self.velocity_determined[i]
    }

    /// See [`Readout::multiplier_determined`].
    pub(crate) fn multiplier_determined(&self, a: usize) -> bool {
        self.multiplier_determined[a]
    }

    /// Whether a solve can find a value ill-conditioned at its state (see
    /// [`Readout::velocity_precise`]): only nonlinear relations are judged, since linear ones
    /// keep one conditioning for the run and a singular one is refused by the LU.
    pub(crate) fn judges_precision(&self) -> bool {
        !self.constant
    }
}

/// Buffers of one residual or Jacobian evaluation.
#[derive(Debug, Default)]
struct Work {
    full: Vec<f64>,
    residual: Vec<f64>,
    lq: Vec<f64>,
    lv: Vec<f64>,
    f: Vec<f64>,
    /// `∂²L`, the force Jacobian and the forms at the state being read.
    at: Derivatives,
    contracted: Triplets,
    /// The positions shifted by the sharing unknowns of `full` ([`Work::take_shifted`]).
    shifted: Vec<f64>,
}

/// A readout that could not be computed: the state `(q_k, p_k)` the steps reached has no
/// velocities and multipliers that satisfy the model's algebraic relations.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{}values at t = {} could not be computed: {source}; {equation}; {likely_cause}",
    StepPrefix(*.step),
    crate::error::Time(*.t)
)]
pub struct ReadoutError {
    /// The output row (step index) whose values failed, when known.
    pub step: Option<usize>,
    /// Time of the state.
    pub t: f64,
    /// The solver's report.
    pub source: NewtonError,
    /// The equation with the largest residual, or the unknown no equation fixes, named.
    pub equation: String,
    /// What usually produces this failure.
    pub likely_cause: String,
}

impl ReadoutError {
    /// The same error located at output row `step`.
    #[must_use]
    pub fn at_step(mut self, step: usize) -> Self {
        self.step = Some(step);
        self
    }
}

/// `"step k: "` when the step is known.
struct StepPrefix(Option<usize>);

impl std::fmt::Display for StepPrefix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(k) => write!(f, "step {k}: "),
            None => Ok(()),
        }
    }
}

impl Readout {
    /// Analyses the readout equations of `model` with `constraints` (their pattern, evaluated at
    /// `q`, `v`, `t`; patterns are fixed, so any point serves).
    pub fn new<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Self {
        let work = Work::stamped(model, constraints, q, v, t);
        let plan = Arc::new(ReadoutPlan::analyse(model, constraints, &work));
        Self::from_parts(plan, work)
    }

    /// The structural analysis [`Readout::new`] makes, alone (the pattern stamped at `q`, `v`,
    /// `t`).
    pub(crate) fn analyse<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Arc<ReadoutPlan> {
        let work = Work::stamped(model, constraints, q, v, t);
        Arc::new(ReadoutPlan::analyse(model, constraints, &work))
    }

    /// A readout with a plan analysed before (for the same model and constraint rows), its
    /// buffers stamped at `q`, `v`, `t`.
    pub(crate) fn with_plan<M: Model + ?Sized, C: Constraints + ?Sized>(
        plan: Arc<ReadoutPlan>,
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Self {
        Self::from_parts(plan, Work::stamped(model, constraints, q, v, t))
    }

    /// The structural analysis this readout solves by.
    pub(crate) fn plan(&self) -> &Arc<ReadoutPlan> {
        &self.plan
    }

    fn from_parts(plan: Arc<ReadoutPlan>, mut work: Work) -> Self {
        work.full.resize(plan.layout().unknowns(), 0.0);
        work.residual.resize(plan.layout().equations(), 0.0);
        let options = NewtonOptions {
            reuse_jacobian: false,
            update_tol: 1e-13,
            max_iterations: READOUT_ITERATIONS,
            ..NewtonOptions::default()
        };
        Self {
            newton: Newton::new(
                if plan.constant {
                    AutoLu::for_size(SolverChoice::Auto, plan.rows.len())
                } else {
                    AutoLu::for_size(SolverChoice::Auto, plan.rows.len())
                        .with_pivot_tolerance(READOUT_PIVOT_TOL)
                },
                options,
            ),
            reduced: vec![0.0; plan.rows.len()],
            precise: vec![true; plan.layout().unknowns()],
            plan,
            scale: 0.0,
            work,
            stats: NewtonStats::default(),
        }
    }

    /// Solves for the velocities and multipliers at `(q, p, t)`, starting from the last solution.
    ///
    /// # Errors
    /// When Newton fails (a singular system at this state, or no convergence).
    pub fn solve<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        q: &[f64],
        p: &[f64],
        t: f64,
    ) -> Result<(), ReadoutError> {
        let mut system = System {
            layout: self.plan.layout(),
            model,
            constraints,
            q,
            p,
            t,
            cols: &self.plan.cols,
            rows: &self.plan.rows,
            col_slot: &self.plan.col_slot,
            row_slot: &self.plan.row_slot,
            work: &mut self.work,
            constant: self.plan.constant,
            at_zero: false,
        };
        if self.plan.rows.is_empty() {
            system.scatter(&self.reduced);
            return Ok(());
        }
        if self.plan.constant {
            // Affine: one update from zero is exact, and the residual at zero needs no products.
            self.reduced.fill(0.0);
            system.at_zero = true;
        }
        let solved = self
            .newton
            .solve(&mut system, &mut self.reduced)
            .and_then(|stats| {
                self.stats.accumulate(&stats);
                if self.plan.constant {
                    // Linear relations: their conditioning does not move with the state, and a
                    // singular one is refused by the LU's pivot test, as before (`precise`
                    // stays true).
                    return Ok(());
                }
                let precision =
                    self.newton
                        .precision(&mut system, &self.reduced)
                        .map_err(|source| NewtonError::Linear {
                            source,
                            residual: 0.0,
                            worst_equation: 0,
                        })?;
                self.precise.fill(true);
                if let Some(Precision { jitter, scale }) = precision {
                    // Judged against the unknown's scale, but never below the largest unknown's
                    // size: an unknown whose equations' terms all vanish (a body's rate about a
                    // still axis) has no scale of its own, and only values ill-conditioned
                    // against the whole readout are read from the steps.
                    let largest = self.reduced.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                    for ((&c, eta), s) in self.plan.cols.iter().zip(jitter).zip(scale) {
                        self.precise[c] = *eta <= READOUT_PRECISION * s.max(largest);
                    }
                }
                Ok(())
            });
        match solved {
            Ok(()) => {
                system.scatter(&self.reduced);
                Ok(())
            }
            Err(NewtonError::NotConverged {
                relative_residual, ..
            }) if relative_residual <= READOUT_STALL
                && !self.plan.constant
                && self.reduced.iter().all(|x| x.is_finite()) =>
            {
                // Cycling at round-off: the iterate satisfies the relations to far better than
                // any value is read, but Newton cannot certify its digits, so no value of it is
                // taken as precise (a run reads them from the steps).
                self.precise.fill(false);
                system.scatter(&self.reduced);
                Ok(())
            }
            Err(source) => {
                let (equation, likely_cause) = self.explain(model, constraints, &source);
                Err(ReadoutError {
                    step: None,
                    t,
                    source,
                    equation,
                    likely_cause,
                })
            }
        }
    }

    /// Velocities `v` at the state of the last [`Readout::solve`].
    #[must_use]
    pub fn velocities(&self) -> &[f64] {
        &self.work.full[..self.plan.n]
    }

    /// The shifts of positions (coordinate, shift) the last [`Readout::solve`] read the state
    /// with: the charge shared along a loop of junction and capacitor charges that the steps
    /// leave split otherwise (see the module's documentation). Empty for most models.
    pub fn position_shifts(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        let d0 = 2 * self.plan.n + 2 * self.plan.m;
        self.plan
            .sharing
            .coords
            .iter()
            .zip(&self.work.full[d0..])
            .map(|(&i, &d)| (i, d))
    }

    /// Multipliers `λ` (one per constraint row) at the state of the last [`Readout::solve`].
    #[must_use]
    pub fn multipliers(&self) -> &[f64] {
        let o = 2 * self.plan.n + self.plan.m;
        &self.work.full[o..o + self.plan.m]
    }

    /// Accelerations `a`, where a multiplier needed them (0 elsewhere: only what the velocities and
    /// multipliers depend on is solved).
    #[must_use]
    pub fn accelerations(&self) -> &[f64] {
        let o = self.plan.n + self.plan.m;
        &self.work.full[o..o + self.plan.n]
    }

    /// Whether the last solve determined velocity `i` to [`READOUT_PRECISION`] (else the state
    /// fixes it only through a coefficient lost in round-off, and the caller reads it from the
    /// steps, as it does a velocity that is not [`Readout::velocity_determined`]).
    #[must_use]
    pub fn velocity_precise(&self, i: usize) -> bool {
        self.precise[i]
    }

    /// Whether the last solve determined multiplier `a` to [`READOUT_PRECISION`] (see
    /// [`Readout::velocity_precise`]).
    #[must_use]
    pub fn multiplier_precise(&self, a: usize) -> bool {
        self.precise[2 * self.plan.n + self.plan.m + a]
    }

    /// Whether velocity `i` follows from the algebraic relations (else it needs a differentiated
    /// relation: an index-2 quantity).
    #[must_use]
    pub fn velocity_determined(&self, i: usize) -> bool {
        self.plan.velocity_determined[i]
    }

    /// Whether multiplier `a` follows from the algebraic relations.
    #[must_use]
    pub fn multiplier_determined(&self, a: usize) -> bool {
        self.plan.multiplier_determined[a]
    }

    /// The equations left out of the solve (they restate others: consistency conditions).
    #[must_use]
    pub fn redundant_equations(&self) -> Vec<ReadoutRow> {
        let layout = self.plan.layout();
        self.plan
            .redundant
            .iter()
            .map(|&r| layout.kind(r))
            .collect()
    }

    /// Residuals of the left-out equations at the last solution: nonzero values say the state
    /// violates an algebraic relation (an inconsistent start), with the equation's kind.
    pub fn consistency_residuals<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        q: &[f64],
        p: &[f64],
        t: f64,
    ) -> Vec<(ReadoutRow, f64)> {
        let layout = self.plan.layout();
        let shifted = self.work.take_shifted(q, layout.sharing);
        let q = positions(q, &shifted);
        self.work
            .stamp(model, constraints, q, self.velocities_owned().as_slice(), t);
        let full = std::mem::take(&mut self.work.full);
        let mut residual = std::mem::take(&mut self.work.residual);
        layout.residual(&mut self.work, model, q, p, t, &full, &mut residual);
        self.work.shifted = shifted;
        self.scale = term_scale(p, &self.work);
        let out = self
            .plan
            .redundant
            .iter()
            .map(|&r| (layout.kind(r), residual[r]))
            .collect();
        self.work.full = full;
        self.work.residual = residual;
        out
    }

    fn velocities_owned(&self) -> Vec<f64> {
        self.velocities().to_vec()
    }

    /// Magnitude of the terms of the equations at the last [`Readout::consistency_residuals`]
    /// (momenta, forces): the scale against which a residual is small.
    #[must_use]
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The state's positions and velocities that enter the over-determined equations (those that
    /// fix some value more than once): what may be moved to make a start consistent.
    #[must_use]
    pub(crate) fn involved(&self, _violated: &[ReadoutRow]) -> Vec<crate::simulation::Unknown> {
        use crate::simulation::Unknown;
        let layout = self.plan.layout();
        let mut out = Vec::new();
        let mut push = |u: Unknown| {
            if !out.contains(&u) {
                out.push(u);
            }
        };
        for &r in &self.plan.overdetermined {
            match layout.kind(r) {
                ReadoutRow::Force(i) => {
                    for (row, j, _) in self.work.at.hessian.qq.iter() {
                        if row == i {
                            push(Unknown::Position(j));
                        }
                    }
                    for (row, j, _) in self.work.at.force.q.iter() {
                        if row == i {
                            push(Unknown::Position(j));
                        }
                    }
                }
                ReadoutRow::Momentum(i) => {
                    for (j, col, _) in self.work.at.hessian.qv.iter() {
                        if col == i {
                            push(Unknown::Position(j));
                        }
                    }
                    for (row, j, _) in self.work.at.hessian.vv.iter() {
                        if row == i {
                            push(Unknown::Velocity(j));
                        }
                    }
                }
                ReadoutRow::Constraint(_)
                | ReadoutRow::Acceleration(_)
                | ReadoutRow::Sharing(_) => {}
            }
        }
        out
    }

    /// The largest derivative of an over-determined equation with respect to the state's value
    /// `unknown` (the scale of a finite-difference step that moves that equation visibly).
    #[must_use]
    pub(crate) fn sensitivity(&self, unknown: crate::simulation::Unknown) -> f64 {
        use crate::simulation::Unknown;
        let layout = self.plan.layout();
        let mut worst: f64 = 0.0;
        for &r in &self.plan.overdetermined {
            match (layout.kind(r), unknown) {
                (ReadoutRow::Force(i), Unknown::Position(j)) => {
                    for (row, col, value) in self
                        .work
                        .at
                        .hessian
                        .qq
                        .iter()
                        .chain(self.work.at.force.q.iter())
                    {
                        if row == i && col == j {
                            worst = worst.max(value.abs());
                        }
                    }
                }
                (ReadoutRow::Momentum(i), Unknown::Position(j)) => {
                    for (row, col, value) in self.work.at.hessian.qv.iter() {
                        if row == j && col == i {
                            worst = worst.max(value.abs());
                        }
                    }
                }
                (ReadoutRow::Momentum(i), Unknown::Velocity(j)) => {
                    for (row, col, value) in self.work.at.hessian.vv.iter() {
                        if row == i && col == j {
                            worst = worst.max(value.abs());
                        }
                    }
                }
                _ => {}
            }
        }
        worst
    }

    /// Names an equation of the readout system.
    #[must_use]
    pub fn describe_row<M: Model + ?Sized, C: Constraints + ?Sized>(
        &self,
        model: &M,
        constraints: &C,
        row: ReadoutRow,
    ) -> String {
        let layout = self.plan.layout();
        self.describe(model, constraints, layout.row(row))
    }

    /// Newton counters of every solve so far.
    #[must_use]
    /// The reduced unknowns the next nonlinear solve starts from (the last solution).
    pub(crate) fn start_guess(&self) -> Vec<f64> {
        self.reduced.clone()
    }

    /// Restores a start saved by [`Readout::start_guess`], so that a solve made on the side (the
    /// natural modes) leaves the next readout exactly as it would have been without it.
    pub(crate) fn restore_start_guess(&mut self, guess: &[f64]) {
        self.reduced.copy_from_slice(guess);
    }

    pub fn stats(&self) -> NewtonStats {
        self.stats
    }

    /// Names equation `r` of the full system.
    /// The equation or unknown at fault in a failed solve, named, and the likely cause.
    fn explain<M: Model + ?Sized, C: Constraints + ?Sized>(
        &self,
        model: &M,
        constraints: &C,
        error: &NewtonError,
    ) -> (String, String) {
        let domain = "the state left the model's domain: the step before it was too large for a nonlinear part, or a part was driven past its limit (a saturating inductor past its saturation flux, say)";
        match error {
            NewtonError::NotConverged { worst_equation, .. } => (
                self.plan.rows.get(*worst_equation).map_or_else(
                    || "no equation named".to_string(),
                    |&r| {
                        format!(
                            "largest residual in {}",
                            self.describe(model, constraints, r)
                        )
                    },
                ),
                format!("no velocities satisfy the relations at this state: {domain}"),
            ),
            NewtonError::NonFiniteResidual { equation, .. } => (
                self.plan.rows.get(*equation).map_or_else(
                    || "no equation named".to_string(),
                    |&r| {
                        format!(
                            "NaN or infinity in {}",
                            self.describe(model, constraints, r)
                        )
                    },
                ),
                domain.to_string(),
            ),
            NewtonError::Linear { source, .. } => {
                let index = match source {
                    LinearSolveError::NumericallySingular { index }
                    | LinearSolveError::StructurallySingular { index }
                    | LinearSolveError::NonFinite { index } => Some(*index),
                    LinearSolveError::EmptyColumn { col } => Some(*col),
                    _ => None,
                };
                (
                    index.and_then(|c| self.plan.cols.get(c)).map_or_else(
                        || "the readout system is singular at this state".to_string(),
                        |&c| {
                            format!(
                                "{} is not determined by the relations at this state",
                                self.describe_unknown(model, constraints, c)
                            )
                        },
                    ),
                    format!(
                        "the relations are singular here although they were not at the start: {domain}"
                    ),
                )
            }
        }
    }

    /// Names full unknown `c` of `(v, γ, a, λ)`.
    fn describe_unknown<M: Model + ?Sized, C: Constraints + ?Sized>(
        &self,
        model: &M,
        constraints: &C,
        c: usize,
    ) -> String {
        let (n, m) = (self.plan.n, self.plan.m);
        if c < n {
            format!("the rate of `{}`", model.coordinate_name(c))
        } else if c < n + m {
            format!("the impulse of constraint `{}`", constraints.name(c - n))
        } else if c < 2 * n + m {
            format!("the acceleration of `{}`", model.coordinate_name(c - n - m))
        } else if c < 2 * n + 2 * m {
            format!(
                "the multiplier of constraint `{}`",
                constraints.name(c - 2 * n - m)
            )
        } else {
            format!(
                "the charge shared along `{}`",
                model.coordinate_name(self.plan.sharing.coords[c - 2 * n - 2 * m])
            )
        }
    }

    fn describe<M: Model + ?Sized, C: Constraints + ?Sized>(
        &self,
        model: &M,
        constraints: &C,
        r: usize,
    ) -> String {
        let layout = self.plan.layout();
        match layout.kind(r) {
            ReadoutRow::Momentum(i) => {
                format!("momentum of `{}`", model.coordinate_name(i))
            }
            ReadoutRow::Constraint(a) => format!("constraint `{}`", constraints.name(a)),
            ReadoutRow::Force(i) => format!("force balance of `{}`", model.coordinate_name(i)),
            ReadoutRow::Acceleration(a) => {
                format!("constraint `{}` (differentiated)", constraints.name(a))
            }
            ReadoutRow::Sharing(a) => {
                format!("constraint `{}` on the shared charge", constraints.name(a))
            }
        }
    }
}

impl ReadoutPlan {
    /// The structural analysis of the readout equations whose derivatives `work` holds.
    fn analyse<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        work: &Work,
    ) -> Self {
        let n = model.dim();
        let m = constraints.count();
        let sharing = Sharing::find(n, m, &work.at.hessian.vv, &work.at.force.v, &work.at.forms);
        let layout = Layout {
            n,
            m,
            sharing: &sharing,
        };
        let (size, unknowns) = (layout.equations(), layout.unknowns());
        let mut pattern = Vec::new();
        layout.jacobian_entries(work, |r, c, _| pattern.push((r, c)));
        // Prefer to solve for outputs (velocities, multipliers) over accelerations, gauges and
        // shifts.
        let mut priority = vec![0u8; unknowns];
        priority[n..n + m].fill(2);
        priority[n + m..2 * n + m].fill(1);
        priority[2 * n + 2 * m..].fill(2);
        // Equations of sources first: where two equations fix one value (a capacitor across a
        // voltage source) the source's own equation is the one kept.
        let order: Vec<usize> = (0..n)
            .filter(|&i| model.depends_on_time(i))
            .map(|i| layout.row(ReadoutRow::Force(i)))
            .chain(0..size)
            .collect();
        let mut seen = vec![false; size];
        let order: Vec<usize> = order
            .into_iter()
            .filter(|&r| !std::mem::replace(&mut seen[r], true))
            .collect();
        let mut permuted_row = vec![0; size];
        for (k, &r) in order.iter().enumerate() {
            permuted_row[r] = k;
        }
        let permuted: Vec<(usize, usize)> =
            pattern.iter().map(|&(r, c)| (permuted_row[r], c)).collect();
        let structure = Structure::analyse(size, unknowns, &permuted, &priority);
        // The equation each matched unknown is solved from, and the unknowns of every equation.
        let mut row_of = vec![OUT; unknowns];
        for (c, r) in row_of.iter_mut().enumerate() {
            if let Some(k) = structure.matched_row(c) {
                *r = order[k];
            }
        }
        let mut row_cols: Vec<Vec<usize>> = vec![Vec::new(); size];
        for &(r, c) in &pattern {
            row_cols[r].push(c);
        }
        // Solve only what the outputs (determined velocities and multipliers) depend on: their
        // equations and, recursively, the unknowns those contain. Accelerations stay out unless a
        // multiplier needs them (a node joining only inductors, a joint between masses).
        let mut needed = vec![false; unknowns];
        let mut stack: Vec<usize> = (0..n)
            .chain(2 * n + m..2 * n + 2 * m)
            .filter(|&c| row_of[c] != OUT && !structure.is_underdetermined_col(c))
            .collect();
        for &c in &stack {
            needed[c] = true;
        }
        while let Some(c) = stack.pop() {
            for &d in &row_cols[row_of[c]] {
                if !needed[d] && row_of[d] != OUT {
                    needed[d] = true;
                    stack.push(d);
                }
            }
        }
        let mut col_slot = vec![OUT; unknowns];
        let mut cols = Vec::new();
        for (c, slot) in col_slot.iter_mut().enumerate() {
            if needed[c] {
                *slot = cols.len();
                cols.push(c);
            }
        }
        let mut rows: Vec<usize> = cols.iter().map(|&c| row_of[c]).collect();
        rows.sort_unstable();
        let mut row_slot = vec![OUT; size];
        for (slot, &r) in rows.iter().enumerate() {
            row_slot[r] = slot;
        }
        // Unmatched equations restate others: consistency checks, where they only involve what is
        // solved (an unmatched acceleration-level row would read unsolved accelerations as 0).
        let redundant: Vec<usize> = order
            .iter()
            .enumerate()
            .filter(|&(k, _)| structure.matched_col(k).is_none())
            .map(|(_, &r)| r)
            .filter(|&r| row_cols[r].iter().all(|&c| needed[c] || row_of[c] == OUT))
            .collect();
        let overdetermined = order
            .iter()
            .enumerate()
            .filter(|&(k, _)| structure.is_overdetermined_row(k))
            .map(|(_, &r)| r)
            .collect();
        let velocity_determined = (0..n)
            .map(|i| !structure.is_underdetermined_col(i))
            .collect();
        let multiplier_determined = (0..m)
            .map(|a| !structure.is_underdetermined_col(2 * n + m + a))
            .collect();
        let constant = model.is_linear() && constraints.is_constant();
        Self {
            n,
            m,
            cols,
            rows,
            col_slot,
            row_slot,
            velocity_determined,
            multiplier_determined,
            sharing,
            redundant,
            overdetermined,
            constant,
        }
    }
}

/// The positions a readout evaluates at: `shifted` from [`Work::take_shifted`], or `q` itself
/// when nothing is shifted.
fn positions<'a>(q: &'a [f64], shifted: &'a [f64]) -> &'a [f64] {
    if shifted.is_empty() { q } else { shifted }
}

/// The largest momentum, Lagrangian derivative or force of the last evaluation.
fn term_scale(p: &[f64], work: &Work) -> f64 {
    p.iter()
        .chain(&work.lq)
        .chain(&work.lv)
        .chain(&work.f)
        .fold(f64::MIN_POSITIVE, |a, x| a.max(x.abs()))
}

/// Positions of the blocks in the full system: `2n + 2m` equations and unknowns, then one
/// unknown per shifted coordinate and one equation per constraint row that a shift enters.
#[derive(Debug, Clone, Copy)]
struct Layout<'a> {
    n: usize,
    m: usize,
    sharing: &'a Sharing,
}

impl Layout<'_> {
    /// Number of equations of the full system.
    fn equations(self) -> usize {
        2 * self.n + 2 * self.m + self.sharing.rows.len()
    }

    /// Number of unknowns of the full system.
    fn unknowns(self) -> usize {
        2 * self.n + 2 * self.m + self.sharing.coords.len()
    }

    fn row(self, kind: ReadoutRow) -> usize {
        match kind {
            ReadoutRow::Momentum(i) => i,
            ReadoutRow::Constraint(a) => self.n + a,
            ReadoutRow::Force(i) => self.n + self.m + i,
            ReadoutRow::Acceleration(a) => 2 * self.n + self.m + a,
            ReadoutRow::Sharing(a) => 2 * self.n + 2 * self.m + self.sharing.row_slot[a],
        }
    }

    fn kind(self, r: usize) -> ReadoutRow {
        let (n, m) = (self.n, self.m);
        if r < n {
            ReadoutRow::Momentum(r)
        } else if r < n + m {
            ReadoutRow::Constraint(r - n)
        } else if r < 2 * n + m {
            ReadoutRow::Force(r - n - m)
        } else if r < 2 * n + 2 * m {
            ReadoutRow::Acceleration(r - 2 * n - m)
        } else {
            ReadoutRow::Sharing(self.sharing.rows[r - 2 * n - 2 * m])
        }
    }

    /// The full residual at unknowns `x = (v, γ, a, λ, δ)`, with `q` the shifted positions
    /// ([`Work::take_shifted`]); `work` must hold the derivatives stamped at `(q, v)` (for the Hessian
    /// blocks and the impulses of the shifts).
    #[allow(clippy::too_many_arguments)]
    fn residual<M: Model + ?Sized>(
        self,
        work: &mut Work,
        model: &M,
        q: &[f64],
        p: &[f64],
        t: f64,
        x: &[f64],
        r: &mut [f64],
    ) {
        let (n, m) = (self.n, self.m);
        let (v, rest) = x.split_at(n);
        let (gamma, rest) = rest.split_at(m);
        let (a, rest) = rest.split_at(n);
        let (lambda, delta) = rest.split_at(m);
        model.lagrangian_gradient(q, v, &mut work.lq, &mut work.lv);
        if model.has_force() {
            model.force(q, v, t, &mut work.f);
        } else {
            work.f.fill(0.0);
        }
        r.fill(0.0);
        let (r1, rest) = r.split_at_mut(n);
        let (r2, rest) = rest.split_at_mut(m);
        let (r3, rest) = rest.split_at_mut(n);
        let (r4, r5) = rest.split_at_mut(m);
        for i in 0..n {
            r1[i] = work.lv[i] - p[i];
            r3[i] = -work.lq[i] - work.f[i];
        }
        let sharing = self.sharing;
        if !sharing.coords.is_empty() {
            for (i, k, value) in sharing.impulses(&work.at.force.v) {
                r1[i] -= value * delta[k];
            }
            for (l, k, value) in sharing.flows(&work.at.forms) {
                r5[l] += value * delta[k];
            }
        }
        for (row, j, value) in work.at.forms.iter() {
            r1[j] -= value * gamma[row];
            r2[row] += value * v[j];
            r3[j] += value * lambda[row];
            r4[row] += value * a[j];
        }
        for (i, j, value) in work.at.hessian.vv.iter() {
            r3[i] += value * a[j];
        }
        for (j, i, value) in work.at.hessian.qv.iter() {
            r3[i] += value * v[j];
        }
        for (row, l, value) in work.contracted.iter() {
            r4[row] += value * v[l];
        }
    }

    /// Calls `emit(row, col, value)` for every Jacobian entry (full indices), in a fixed order.
    fn jacobian_entries(self, work: &Work, mut emit: impl FnMut(usize, usize, f64)) {
        let (n, m) = (self.n, self.m);
        let (v0, g0, a0, l0) = (0, n, n + m, 2 * n + m);
        let (r1, r2, r3, r4) = (0, n, n + m, 2 * n + m);
        for (i, j, value) in work.at.hessian.vv.iter() {
            emit(r1 + i, v0 + j, value);
            emit(r3 + i, a0 + j, value);
        }
        for (j, i, value) in work.at.hessian.qv.iter() {
            // ∂/∂v of ∂²L/∂v∂q·v (third derivatives of L left out: the readout's Newton is then
            // a chord method in that term, converging to the same solution) and of −∂L/∂q.
            emit(r3 + i, v0 + j, value);
            emit(r3 + j, v0 + i, -value);
        }
        for (i, j, value) in work.at.force.v.iter() {
            emit(r3 + i, v0 + j, -value);
        }
        for (a, j, value) in work.at.forms.iter() {
            emit(r1 + j, g0 + a, -value);
            emit(r2 + a, v0 + j, value);
            emit(r3 + j, l0 + a, value);
            emit(r4 + a, a0 + j, value);
        }
        for (a, l, value) in work.contracted.iter() {
            emit(r4 + a, v0 + l, value);
        }
        let sharing = self.sharing;
        if sharing.coords.is_empty() {
            return;
        }
        // The shifts: positions move the terms that depend on them (second derivatives of the
        // constraints left out, a chord in that term as above), rates push momenta.
        let (d0, r5) = (2 * n + 2 * m, 2 * n + 2 * m);
        for (j, i, value) in work.at.hessian.qv.iter() {
            if let Some(k) = sharing.shift(j) {
                emit(r1 + i, d0 + k, value);
            }
        }
        for (i, j, value) in work.at.hessian.qq.iter().chain(work.at.force.q.iter()) {
            if let Some(k) = sharing.shift(j) {
                emit(r3 + i, d0 + k, -value);
            }
        }
        for (i, k, value) in sharing.impulses(&work.at.force.v) {
            emit(r1 + i, d0 + k, -value);
        }
        for (l, k, value) in sharing.flows(&work.at.forms) {
            emit(r5 + l, d0 + k, value);
        }
    }
}

impl Work {
    /// `q` shifted by the sharing unknowns of `self.full`, in the buffer `self.shifted` taken out
    /// of `self` (to be handed back); left empty when the model has no shifts, where `q` itself
    /// serves (see [`positions`]).
    fn take_shifted(&mut self, q: &[f64], sharing: &Sharing) -> Vec<f64> {
        let mut out = std::mem::take(&mut self.shifted);
        out.clear();
        if !sharing.coords.is_empty() {
            out.extend_from_slice(q);
            let d0 = self.full.len() - sharing.coords.len();
            for (&j, &d) in sharing.coords.iter().zip(&self.full[d0..]) {
                out[j] += d;
            }
        }
        out
    }

    /// Buffers for a model of `model.dim()` coordinates and `constraints.count()` rows, with the
    /// derivatives stamped at `(q, v, t)`.
    fn stamped<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Self {
        let n = model.dim();
        let size = 2 * n + 2 * constraints.count();
        let mut work = Self {
            full: vec![0.0; size],
            residual: vec![0.0; size],
            lq: vec![0.0; n],
            lv: vec![0.0; n],
            f: vec![0.0; n],
            ..Self::default()
        };
        work.stamp(model, constraints, q, v, t);
        work
    }

    /// Stamps the Hessian, the force Jacobian, the forms and the contracted form derivative at
    /// `(q, v, t)`.
    fn stamp<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) {
        self.at.stamp(model, constraints, q, v, t);
        self.contracted.begin();
        constraints.contracted_derivative(q, v, &mut self.contracted);
        self.contracted.freeze();
    }
}

/// The reduced readout equations as a [`NonlinearSystem`].
struct System<'a, M: ?Sized, C: ?Sized> {
    layout: Layout<'a>,
    model: &'a M,
    constraints: &'a C,
    q: &'a [f64],
    p: &'a [f64],
    t: f64,
    cols: &'a [usize],
    rows: &'a [usize],
    col_slot: &'a [usize],
    row_slot: &'a [usize],
    work: &'a mut Work,
    constant: bool,
    /// The next residual is evaluated at `x = 0` (then only `∂L/∂v − p` and `−∂L/∂q − f` remain).
    at_zero: bool,
}

impl<M: Model + ?Sized, C: Constraints + ?Sized> System<'_, M, C> {
    /// Writes the reduced unknowns into the full vector (free unknowns at zero).
    fn scatter(&mut self, x: &[f64]) {
        self.work.full.fill(0.0);
        for (&c, &value) in self.cols.iter().zip(x) {
            self.work.full[c] = value;
        }
    }
}

impl<M: Model + ?Sized, C: Constraints + ?Sized> NonlinearSystem for System<'_, M, C> {
    fn len(&self) -> usize {
        self.rows.len()
    }

    fn residual(&mut self, x: &[f64], r: &mut [f64]) {
        if std::mem::take(&mut self.at_zero) {
            let (n, m) = (self.layout.n, self.layout.m);
            let work = &mut *self.work;
            work.full.fill(0.0);
            self.model
                .lagrangian_gradient(self.q, &work.full[..n], &mut work.lq, &mut work.lv);
            if self.model.has_force() {
                self.model
                    .force(self.q, &work.full[..n], self.t, &mut work.f);
            } else {
                work.f.fill(0.0);
            }
            for (out, &row) in r.iter_mut().zip(self.rows) {
                *out = if row < n {
                    work.lv[row] - self.p[row]
                } else if (n + m..2 * n + m).contains(&row) {
                    let i = row - n - m;
                    -work.lq[i] - work.f[i]
                } else {
                    0.0
                };
            }
            return;
        }
        self.scatter(x);
        let n = self.layout.n;
        let shifted = self.work.take_shifted(self.q, self.layout.sharing);
        let q = positions(self.q, &shifted);
        if !self.constant {
            let v = self.work.full[..n].to_vec();
            self.work.stamp(self.model, self.constraints, q, &v, self.t);
        }
        let full = std::mem::take(&mut self.work.full);
        let mut residual = std::mem::take(&mut self.work.residual);
        self.layout.residual(
            self.work,
            self.model,
            q,
            self.p,
            self.t,
            &full,
            &mut residual,
        );
        for (out, &row) in r.iter_mut().zip(self.rows) {
            *out = residual[row];
        }
        self.work.full = full;
        self.work.residual = residual;
        self.work.shifted = shifted;
    }

    fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
        self.scatter(x);
        if !self.constant {
            let shifted = self.work.take_shifted(self.q, self.layout.sharing);
            let v = self.work.full[..self.layout.n].to_vec();
            self.work.stamp(
                self.model,
                self.constraints,
                positions(self.q, &shifted),
                &v,
                self.t,
            );
            self.work.shifted = shifted;
        }
        let (rows, cols) = (self.row_slot, self.col_slot);
        self.layout.jacobian_entries(self.work, |r, c, value| {
            let (r, c) = (rows[r], cols[c]);
            if r != OUT && c != OUT {
                jac.add(r, c, value);
            }
        });
    }

    fn jacobian_is_constant(&self) -> bool {
        self.constant
    }

    fn update_fraction(&mut self, x: &[f64], update: &[f64]) -> f64 {
        if self.constant || !self.model.has_update_limit() {
            return 1.0;
        }
        let n = self.layout.n;
        let mut v = vec![0.0; n];
        let mut dv = vec![0.0; n];
        for ((&c, &value), &u) in self.cols.iter().zip(x).zip(update) {
            if c < n {
                v[c] = value;
                dv[c] = -u;
            }
        }
        let dq = vec![0.0; n];
        self.model.update_fraction(self.q, &v, &dq, &dv)
    }
}
