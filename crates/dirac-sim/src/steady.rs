//! The steady state of a forced Lagrange–Dirac system (MATH §7): SPICE's DC operating point for a
//! circuit, static equilibrium for a mechanism.
//!
//! Sources are frozen at `t_0`. A coordinate is *cyclic* when nothing `q`-dependent contains it (no
//! potential, no `q`-dependent force or constraint): inductor, resistor and source charges, a free
//! shaft angle. At the steady state every momentum is constant, every non-cyclic coordinate is at
//! rest and cyclic coordinates move at constant rates, so with unknowns
//! `(q_noncyclic, v_cyclic, λ)` the equations are
//!
//! ```text
//! ∂L/∂qᵢ(q, v) + fᵢ(q, v, t₀) − (Aᵀλ)ᵢ = 0     for every coordinate,
//! A(q) v = 0 (one-forms),   g(q) = 0 (holonomic rows).
//! ```
//!
//! For a circuit this is modified nodal analysis with capacitors open (`q̇_C = 0`) and inductors
//! shorted (`ṗ_L = 0`). A node potential held by `.ic` adds the equation `λ_a = value` and an
//! injection current into that node's KCL row. Singular exactly where SPICE's is: a structural
//! analysis names the node with no DC path or the equations that cannot hold together before
//! Newton starts. Newton's method runs with the models' own update limits (SPICE's junction
//! limiting) and, when it fails, continuation: gmin stepping (a conductance `g` from every node
//! to ground, a compliance in every one-form row, decreased to 0), then source stepping for a
//! circuit or stiffness stepping for a model with holonomic rows.

use dirac_core::{ConstraintKind, Constraints, Model, Triplets};
use dirac_solve::{
    LinearSolveError, LinearSolver, Newton, NewtonError, NewtonOptions, NewtonStats,
    NonlinearSystem, Structure,
};
use thiserror::Error;

use crate::derivatives::Derivatives;
use crate::linear::{AutoLu, SolverChoice};

/// A steady state that could not be found.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SteadyStateError {
    /// Some value is fixed by no equation (a node with no DC path, a floating mass).
    #[error("no steady state: {unknowns} not fixed by any equation ({hint})")]
    Undetermined {
        /// The unknowns no equation fixes, named.
        unknowns: String,
        /// What usually causes it and what to do.
        hint: String,
    },
    /// Equations that fix the same values differently (a current source into capacitors only,
    /// a loop of voltage sources).
    #[error("no steady state: {equations} cannot hold ({hint})")]
    Contradictory {
        /// The equations, named, with their residuals.
        equations: String,
        /// What usually causes it.
        hint: String,
    },
    /// The equations hold to round-off but their matrix is singular there: the steady state is
    /// not isolated (a symmetry leaves a direction free).
    #[error(
        "no isolated steady state: the equations hold to {residual:.1e} (of {start:.1e} at the start) where their matrix is singular ({source}): a symmetry leaves the steady state free to move along some direction (a body turned about the axis of gravity, a shaft at any angle), or the point is a bifurcation; fix that direction (a spring, a joint) or start from given values (UIC)"
    )]
    NotIsolated {
        /// The solver's report.
        source: NewtonError,
        /// The largest residual where it stopped.
        residual: f64,
        /// The largest residual at the start.
        start: f64,
    },
    /// Stiffness stepping's proximal iteration kept moving the mechanism by about the same
    /// amount with every solve: each solve lowers the potential of the applied forces by at least
    /// the spring's energy, so a motion that does not settle is one along which the applied
    /// forces do unbounded work (a drive turning a shaft that nothing holds).
    #[error(
        "no static equilibrium: the applied forces keep moving {coordinates} without settling ({solves} solves of stiffness stepping's proximal iteration, each moving the mechanism by {step:.3e} or more, the last {last:.3e}): a drive or load on a motion that nothing holds (a motor turning a free shaft) has a steady motion, not a static equilibrium; hold that motion (a spring, a stop) or simulate it (`dirac run`)"
    )]
    NoEquilibrium {
        /// The coordinates the last solve moved most, named, with their total travel.
        coordinates: String,
        /// Proximal solves taken.
        solves: usize,
        /// The smallest move of a solve (largest coordinate change).
        step: f64,
        /// The last solve's move.
        last: f64,
    },
    /// Newton's method failed, even with gmin stepping.
    #[error(
        "steady state: Newton did not converge ({source}); largest residuals: {residuals}; try UIC (start from given values) or check the nonlinear parts' parameters"
    )]
    NotConverged {
        /// The solver's last report.
        source: NewtonError,
        /// The equations with the largest residuals, named, with their values.
        residuals: String,
    },
}

impl SteadyStateError {
    /// Whether this is a numerical failure (exit code 1) rather than a model without a steady
    /// state (bad input, exit code 2).
    #[must_use]
    pub fn is_numerical(&self) -> bool {
        matches!(self, Self::NotConverged { .. } | Self::NotIsolated { .. })
    }
}

/// The steady state: positions, velocities and multipliers.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyState {
    /// Positions (cyclic coordinates keep the guess's values).
    pub q: Vec<f64>,
    /// Velocities (zero for non-cyclic coordinates).
    pub v: Vec<f64>,
    /// One multiplier per constraint row (node potentials, joint forces).
    pub multipliers: Vec<f64>,
    /// Whether each coordinate is cyclic.
    pub cyclic: Vec<bool>,
    /// Newton updates spent, gmin stepping included.
    pub iterations: usize,
    /// Continuation solves taken: gmin, source or stiffness steps (0 when plain Newton
    /// converged).
    pub gmin_steps: usize,
    /// Whether the steady state is isolated (its Newton matrix regular). A mechanism with a
    /// symmetry (a heavy top turned about the vertical, a link spun about its own axis) has a
    /// continuum of equilibria; the one given is where the proximal iteration of stiffness
    /// stepping settles from the start.
    pub isolated: bool,
}

/// Gmin stepping's first conductance (ngspice's `OldGmin`), its largest ratio between two
/// steps, the conductance after which it steps to none, and the smallest ratio it backs off to
/// before it gives up (ngspice's `dynamic_gmin`: 1e-2, `gminfactor` 10, `gmin` 1e-12, 1.00005).
const GMIN_START: f64 = 1e-2;
const GMIN_FACTOR: f64 = 10.0;
const GMIN_LAST: f64 = 1e-12;
const GMIN_SMALLEST_FACTOR: f64 = 1.00005;
/// Most solves gmin stepping takes before it gives up.
const GMIN_MOST_SOLVES: usize = 200;

impl SteadyState {
    /// Solves for the steady state of `model` with `constraints` at `t0`, from the guess `q`
    /// (cyclic positions are kept), holding constraint rows `holds` (`(row, value)`) at their
    /// values.
    ///
    /// # Errors
    /// [`SteadyStateError`]: undetermined or contradictory equations (bad input), or Newton's
    /// failure (numerical).
    pub fn solve<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        t0: f64,
        holds: &[(usize, f64)],
    ) -> Result<Self, SteadyStateError> {
        let n = model.dim();
        let m = constraints.count();
        let cyclic = classify(model, constraints, q, t0);
        let mut system = SteadySystem::new(model, constraints, q, t0, holds, cyclic.clone());
        let size = n + m + holds.len();
        system.analyse()?;
        let mut x = vec![0.0; size];
        for ((x, &q), &c) in x.iter_mut().zip(q).zip(&cyclic) {
            if !c {
                *x = q;
            }
        }
        if system.holonomic {
            system.balance_multipliers(&mut x);
        }
        let options = NewtonOptions {
            max_iterations: 50,
            reuse_jacobian: false,
            ..NewtonOptions::default()
        };
        let mut newton = Newton::new(AutoLu::for_size(SolverChoice::Auto, size), options);
        let mut iterations = 0;
        let start = x.clone();
        let mut steps = Steps {
            solves: 0,
            iterations: &mut iterations,
        };
        let outcome = match newton.solve(&mut system, &mut x) {
            Ok(stats) => {
                *steps.iterations += stats.iterations;
                Ok((stats, true))
            }
            Err(first) => {
                // Gmin acts on one-form rows only: without them every gmin solve would be
                // plain Newton's again.
                let one_forms = (0..m).any(|a| constraints.kind(a) == ConstraintKind::OneForm);
                let mut last = if one_forms {
                    gmin_stepping(&mut system, &mut newton, &start, &mut x, &mut steps, first)
                } else {
                    Err(first)
                };
                if last.is_err() && !system.holonomic {
                    last = source_stepping(&mut system, &mut newton, &mut x, &mut steps, last);
                }
                match last {
                    Ok(stats) => Ok((stats, true)),
                    Err(_) if system.holonomic => {
                        stiffness_stepping(&mut system, &mut newton, &start, &mut x, &mut steps)
                    }
                    Err(e) => Err(Unsettled::Newton(e)),
                }
            }
        };
        let gmin_steps = steps.solves;
        let isolated = match outcome {
            Ok((_, regular)) => regular,
            Err(Unsettled::Drift(drift)) => return Err(drift),
            Err(Unsettled::Newton(source)) => {
                let mut r = vec![0.0; size];
                system.residual(&x, &mut r);
                let largest = |r: &[f64]| r.iter().fold(0.0_f64, |big, v| big.max(v.abs()));
                let residual = largest(&r);
                let mut r0 = vec![0.0; size];
                system.residual(&start, &mut r0);
                let at_start = largest(&r0);
                let singular = matches!(
                    source,
                    NewtonError::Linear {
                        source: LinearSolveError::NumericallySingular { .. },
                        ..
                    }
                );
                // Round-off of the start's residual: the equations hold, their matrix is
                // singular.
                if singular && residual <= 1e-12 * at_start {
                    return Err(SteadyStateError::NotIsolated {
                        source,
                        residual,
                        start: at_start,
                    });
                }
                return Err(SteadyStateError::NotConverged {
                    source,
                    residuals: system.worst_equations(&r, 3),
                });
            }
        };
        system.check_redundant(&x)?;
        let (qs, vs) = system.state(&x);
        Ok(Self {
            q: qs,
            v: vs,
            multipliers: x[n..n + m].to_vec(),
            cyclic,
            iterations,
            gmin_steps,
            isolated,
        })
    }
}

/// The solves a continuation took and the Newton updates of those that converged.
struct Steps<'i> {
    solves: usize,
    iterations: &'i mut usize,
}

impl Steps<'_> {
    /// One continuation solve from `x` (Newton restarted), counted.
    fn solve<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        system: &mut SteadySystem<'_, M, C>,
        newton: &mut Newton<AutoLu>,
        x: &mut [f64],
    ) -> Result<NewtonStats, NewtonError> {
        newton.reset();
        self.solves += 1;
        let solved = newton.solve(system, x);
        if let Ok(stats) = &solved {
            *self.iterations += stats.iterations;
        }
        solved
    }
}

/// Gmin stepping as ngspice's `dynamic_gmin` does it: a conductance `g` from every node to
/// ground (a compliance in every one-form row), from [`GMIN_START`] down to none, each solve
/// from the last converged one. After a success the next `g` is the last over `factor`, and
/// `factor` grows by `√factor` (up to [`GMIN_FACTOR`]) when the solve was quick and shrinks to
/// `√factor` when it was slow; after a failure the solve is redone from the last converged
/// state at a `g` nearer to it (`factor` to its fourth root), until `factor` falls below
/// [`GMIN_SMALLEST_FACTOR`] (or [`GMIN_MOST_SOLVES`] are spent). A fixed schedule of decades
/// (the one before) failed on a chain of 31 CMOS inverters, which ngspice's adaptive steps
/// take. Returns the outcome (the last failure, or `first`, plain Newton's, when the solves
/// ran out while succeeding) and leaves `g` at none.
fn gmin_stepping<M: Model + ?Sized, C: Constraints + ?Sized>(
    system: &mut SteadySystem<'_, M, C>,
    newton: &mut Newton<AutoLu>,
    start: &[f64],
    x: &mut [f64],
    steps: &mut Steps<'_>,
    first: NewtonError,
) -> Result<NewtonStats, NewtonError> {
    let max_iterations = newton.options().max_iterations;
    let mut good = start.to_vec();
    let mut good_g = GMIN_START;
    let mut factor = GMIN_FACTOR;
    let mut g = GMIN_START / factor;
    let outcome = loop {
        x.copy_from_slice(&good);
        system.gmin = g;
        match steps.solve(system, newton, x) {
            Ok(stats) if g == 0.0 => break Ok(stats),
            Ok(stats) => {
                good.copy_from_slice(x);
                good_g = g;
                if stats.iterations <= max_iterations / 4 {
                    factor = (factor * factor.sqrt()).min(GMIN_FACTOR);
                }
                if stats.iterations > 3 * max_iterations / 4 {
                    factor = factor.sqrt();
                }
                g = if g <= GMIN_LAST {
                    0.0
                } else {
                    (g / factor).max(GMIN_LAST)
                };
                if steps.solves >= GMIN_MOST_SOLVES {
                    break Err(first);
                }
            }
            Err(e) => {
                if factor < GMIN_SMALLEST_FACTOR || steps.solves >= GMIN_MOST_SOLVES {
                    break Err(e);
                }
                factor = factor.sqrt().sqrt();
                g = good_g / factor;
            }
        }
    };
    system.gmin = 0.0;
    outcome
}

/// Source stepping's first fraction of the sources, the smallest it backs off to before it
/// gives up, and the most solves it takes.
const SOURCE_FIRST_STEP: f64 = 0.1;
const SOURCE_SMALLEST_STEP: f64 = 1e-6;
const SOURCE_MOST_SOLVES: usize = 200;

/// Source stepping, SPICE's fallback after gmin stepping: the equations' constant terms (the
/// independent sources, `.ic` holds; `F(0)` with every unknown zero) are scaled by `α` from 0,
/// where `x = 0` solves, to 1, each solve from the last converged one; the step in `α` grows by
/// half after a success and is quartered after a failure. For a model without holonomic rows
/// (their values at zero positions are not a source). Gmin stepping follows a path in the
/// conductance that can turn back (a chain of 31 CMOS inverters: a fold at g ≈ 5e-3), where
/// raising the supply from zero lets every stage settle in turn, as ngspice's `gillespie_src`
/// does. Returns the outcome (the last failure, or `last` when the solves ran out while
/// succeeding).
fn source_stepping<M: Model + ?Sized, C: Constraints + ?Sized>(
    system: &mut SteadySystem<'_, M, C>,
    newton: &mut Newton<AutoLu>,
    x: &mut [f64],
    steps: &mut Steps<'_>,
    last: Result<NewtonStats, NewtonError>,
) -> Result<NewtonStats, NewtonError> {
    let zero = vec![0.0; x.len()];
    let mut sources = vec![0.0; x.len()];
    system.residual(&zero, &mut sources);
    system.sources = sources;
    let mut good = zero;
    let (mut alpha, mut step, mut outcome) = (0.0_f64, SOURCE_FIRST_STEP, last);
    let before = steps.solves;
    while steps.solves - before < SOURCE_MOST_SOLVES && step >= SOURCE_SMALLEST_STEP {
        let next = (alpha + step).min(1.0);
        system.source_weight = 1.0 - next;
        x.copy_from_slice(&good);
        match steps.solve(system, newton, x) {
            Ok(stats) if next >= 1.0 => {
                outcome = Ok(stats);
                break;
            }
            Ok(_) => {
                good.copy_from_slice(x);
                alpha = next;
                step *= 1.5;
            }
            Err(e) => {
                outcome = Err(e);
                step /= 4.0;
            }
        }
    }
    system.sources.clear();
    outcome
}

/// Springs of stiffness stepping before the last solve without one, as multiples of the
/// start's force scale per unit of its position scale, from stiff to soft.
const STIFFNESS_SCHEDULE: [f64; 9] = [1e2, 1e1, 1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];
/// The smallest ratio of the proximal iteration's last move to its largest that reads as a
/// mechanism the applied forces keep moving ([`SteadyStateError::NoEquilibrium`]).
const DRIFT_RATIO: f64 = 0.9;

/// How a continuation ended without a steady state.
enum Unsettled {
    /// Newton's last failure.
    Newton(NewtonError),
    /// Stiffness stepping's proximal iteration kept moving the mechanism
    /// ([`SteadyStateError::NoEquilibrium`]).
    Drift(SteadyStateError),
}

impl From<NewtonError> for Unsettled {
    fn from(e: NewtonError) -> Self {
        Self::Newton(e)
    }
}

/// Most solves of the proximal iteration after stiffness stepping.
const PROXIMAL_MOST_SOLVES: usize = 50;

/// The mechanical counterpart of gmin stepping, for a model with holonomic rows whose Newton
/// fails from its start (a pendulum released level: gravity normal to its rod, a balancing
/// multiplier of zero, a singular first matrix): a spring ties every non-cyclic coordinate to
/// its start and is relaxed along [`STIFFNESS_SCHEDULE`], then removed, each solve from the
/// last. The spring's scale is the start's largest applied force (multipliers at zero) per unit
/// of its largest position.
///
/// Where the solve without a spring fails (a continuum of equilibria: a hanging chain whose
/// links may spin about their own axes makes that matrix singular), or a spring of the schedule
/// fails after a stiffer one converged, the softest spring that converged stays and its anchor
/// follows the solution: each solve ties the coordinates to the last one (the
/// proximal point iteration; Adams' static solver adds a fraction of the mass matrix for the
/// same reason). At its fixed point the spring is slack, so the equations hold without it, and
/// along the free directions nothing moves. It stops once a solve moves no position by more
/// than Newton's update tolerance of the largest; a last solve without the spring then tells
/// whether the point is isolated. Returns the outcome and whether the steady state is isolated.
fn stiffness_stepping<M: Model + ?Sized, C: Constraints + ?Sized>(
    system: &mut SteadySystem<'_, M, C>,
    newton: &mut Newton<AutoLu>,
    start: &[f64],
    x: &mut [f64],
    steps: &mut Steps<'_>,
) -> Result<(NewtonStats, bool), Unsettled> {
    let n = system.n();
    // The force scale: the largest applied force (the residual's force rows with the
    // multipliers at zero: gravity on a hanging body), not the start's imbalance, which
    // vanishes for a start at or near an equilibrium and would leave every spring too soft to
    // hold the free directions.
    x.copy_from_slice(start);
    x[n..].fill(0.0);
    let mut r = vec![0.0; x.len()];
    system.residual(x, &mut r);
    let force = r[..n].iter().fold(0.0_f64, |big, v| big.max(v.abs()));
    x.copy_from_slice(start);
    let length = (0..n)
        .filter(|&j| !system.cyclic[j])
        .fold(0.0_f64, |big, j| big.max(start[j].abs()));
    let scale = if force > 0.0 && length > 0.0 {
        force / length
    } else {
        1.0
    };
    let outcome = relax_springs(system, newton, x, steps, scale, length);
    system.stiffness = 0.0;
    system.anchor.copy_from_slice(system.q0);
    outcome
}

/// [`stiffness_stepping`]'s solves, from the spring at the start's anchor to none; `length`
/// is the start's largest position (the yardstick of the proximal iteration's stop when the
/// solution's positions all vanish).
fn relax_springs<M: Model + ?Sized, C: Constraints + ?Sized>(
    system: &mut SteadySystem<'_, M, C>,
    newton: &mut Newton<AutoLu>,
    x: &mut [f64],
    steps: &mut Steps<'_>,
    scale: f64,
    length: f64,
) -> Result<(NewtonStats, bool), Unsettled> {
    // The softest spring that converged, and its solution; the first must.
    system.stiffness = STIFFNESS_SCHEDULE[0] * scale;
    steps.solve(system, newton, x)?;
    let (mut softest, mut held) = (system.stiffness, x.to_vec());
    let mut failure = None;
    for &k in &STIFFNESS_SCHEDULE[1..] {
        system.stiffness = k * scale;
        match steps.solve(system, newton, x) {
            Ok(_) => (softest, held) = (system.stiffness, x.to_vec()),
            Err(e) => {
                failure = Some(e);
                break;
            }
        }
    }
    let failure = match failure {
        Some(e) => e,
        None => {
            system.stiffness = 0.0;
            match steps.solve(system, newton, x) {
                Ok(stats) => return Ok((stats, true)),
                Err(e) => e,
            }
        }
    };
    // The proximal iteration from the softest spring that converged.
    x.copy_from_slice(&held);
    system.stiffness = softest;
    let tolerance = newton.options().update_tol;
    let mut converged = None;
    // The largest coordinate change of each solve.
    let mut moves = Vec::with_capacity(PROXIMAL_MOST_SOLVES);
    for _ in 0..PROXIMAL_MOST_SOLVES {
        for j in (0..system.n()).filter(|&j| !system.cyclic[j]) {
            system.anchor[j] = x[j];
        }
        let stats = steps.solve(system, newton, x)?;
        let (mut moved, mut largest) = (0.0_f64, length);
        for j in (0..system.n()).filter(|&j| !system.cyclic[j]) {
            moved = moved.max((x[j] - system.anchor[j]).abs());
            largest = largest.max(x[j].abs());
        }
        moves.push(moved);
        if moved <= tolerance * largest {
            converged = Some(stats);
            break;
        }
    }
    let Some(stats) = converged else {
        return Err(
            drift(system, &held, x, &moves).map_or(Unsettled::Newton(failure), Unsettled::Drift)
        );
    };
    // Whether the point is isolated: a solve without the spring from it. Where that fails (a
    // singular matrix, or a degenerate point where Newton only creeps), the point stays.
    system.stiffness = 0.0;
    let settled = x.to_vec();
    match steps.solve(system, newton, x) {
        Ok(stats) => Ok((stats, true)),
        Err(_) => {
            x.copy_from_slice(&settled);
            Ok((stats, false))
        }
    }
}

/// [`SteadyStateError::NoEquilibrium`] when the proximal iteration's solves (their largest
/// coordinate changes `moves`, all of [`PROXIMAL_MOST_SOLVES`]) kept moving the mechanism: the
/// last at least [`DRIFT_RATIO`] of the largest, where an iteration that approaches an
/// equilibrium shrinks its moves (geometrically, by `k/(k + μ)` along a direction of stiffness
/// `μ`: one that shrinks by less than 10 % over the solves has `μ` below 0.2 % of the spring,
/// the softest of the schedule that converged). Names the three coordinates the last solve
/// moved most, with their travel from `from` (the iteration's start) to `x`.
fn drift<M: Model + ?Sized, C: Constraints + ?Sized>(
    system: &SteadySystem<'_, M, C>,
    from: &[f64],
    x: &[f64],
    moves: &[f64],
) -> Option<SteadyStateError> {
    let largest = moves.iter().fold(0.0_f64, |big, m| big.max(*m));
    let last = *moves.last()?;
    if !(last >= DRIFT_RATIO * largest && last > 0.0) {
        return None;
    }
    let mut order: Vec<usize> = (0..system.n()).filter(|&j| !system.cyclic[j]).collect();
    order.sort_by(|&a, &b| {
        let change = |j: usize| (x[j] - system.anchor[j]).abs();
        change(b).total_cmp(&change(a))
    });
    let coordinates = order
        .iter()
        .take(3)
        .map(|&j| {
            format!(
                "{} (by {:.3e} in all)",
                system.unknown_name(j),
                x[j] - from[j]
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    Some(SteadyStateError::NoEquilibrium {
        coordinates,
        solves: moves.len(),
        step: moves.iter().fold(f64::INFINITY, |small, m| small.min(*m)),
        last,
    })
}

/// Which coordinates nothing `q`-dependent contains: evaluated from the derivative values at the
/// guess and at a perturbed point (an entry that is zero at both is taken as absent).
fn classify<M: Model + ?Sized, C: Constraints + ?Sized>(
    model: &M,
    constraints: &C,
    q: &[f64],
    t0: f64,
) -> Vec<bool> {
    let n = model.dim();
    let mut cyclic = vec![true; n];
    let perturbed: Vec<f64> = q
        .iter()
        .enumerate()
        .map(|(i, x)| x + 0.1 * (1.0 + x.abs()) * (0.37 + 0.11 * i as f64).sin())
        .collect();
    let rates: Vec<f64> = (0..n)
        .map(|i| 0.3 * (0.7 + 0.13 * i as f64).cos())
        .collect();
    let zeros = vec![0.0; n];
    for (qq, vv) in [(q, &zeros[..]), (&perturbed[..], &rates[..])] {
        let derivatives = Derivatives::at(model, constraints, qq, vv, t0);
        for (i, j, value) in derivatives.hessian.qq.iter() {
            if value != 0.0 {
                cyclic[i] = false;
                cyclic[j] = false;
            }
        }
        for (i, _, value) in derivatives.hessian.qv.iter() {
            if value != 0.0 {
                cyclic[i] = false;
            }
        }
        for (_, j, value) in derivatives.force.q.iter() {
            if value != 0.0 {
                cyclic[j] = false;
            }
        }
        for (a, j, value) in derivatives.forms.iter() {
            if value != 0.0 && constraints.kind(a) == ConstraintKind::Holonomic {
                cyclic[j] = false;
            }
        }
        if !constraints.is_constant() {
            let mut contracted = Triplets::new();
            contracted.begin();
            constraints.contracted_derivative(qq, vv, &mut contracted);
            for (_, l, value) in contracted.iter() {
                if value != 0.0 {
                    cyclic[l] = false;
                }
            }
        }
    }
    cyclic
}

/// The steady-state equations as a [`NonlinearSystem`] (unknowns: for each coordinate its position
/// or, when cyclic, its rate; then the multipliers; then one injection per held row).
struct SteadySystem<'a, M: ?Sized, C: ?Sized> {
    model: &'a M,
    constraints: &'a C,
    q0: &'a [f64],
    t0: f64,
    holds: &'a [(usize, f64)],
    cyclic: Vec<bool>,
    gmin: f64,
    /// Whether the model has holonomic rows: then a spring `stiffness` ties every non-cyclic
    /// coordinate to its start (stiffness stepping, the mechanical gmin stepping).
    holonomic: bool,
    stiffness: f64,
    /// The positions the spring ties the coordinates to: the start, then (the proximal
    /// iteration) the last solve's.
    anchor: Vec<f64>,
    /// Source stepping's `F(0)` (empty when off), of which `source_weight = 1 − α` is taken
    /// out of the residual: at `α = 0` the sources (every constant term of the equations) are
    /// off and `x = 0` solves.
    sources: Vec<f64>,
    source_weight: f64,
    q: Vec<f64>,
    v: Vec<f64>,
    lq: Vec<f64>,
    lv: Vec<f64>,
    f: Vec<f64>,
    /// The Lagrangian Hessian, force Jacobian and constraint forms at the loaded state.
    derivatives: Derivatives,
    curvature: Triplets,
    contracted: Triplets,
    g: Vec<f64>,
    redundant: Vec<usize>,
    /// One-form rows read as their integral `A (q − q₀) = 0`: in a mechanism with constant
    /// forms, a row whose coordinates are all at rest at the steady state (two shafts joined
    /// by their rates) holds trivially as `A v = 0`; its integral keeps them at their start's
    /// offset instead of leaving the row empty.
    integrated: Vec<bool>,
}

impl<'a, M: Model + ?Sized, C: Constraints + ?Sized> SteadySystem<'a, M, C> {
    fn new(
        model: &'a M,
        constraints: &'a C,
        q0: &'a [f64],
        t0: f64,
        holds: &'a [(usize, f64)],
        cyclic: Vec<bool>,
    ) -> Self {
        let n = model.dim();
        let m = constraints.count();
        Self {
            model,
            constraints,
            q0,
            t0,
            holds,
            holonomic: (0..m).any(|a| constraints.kind(a) == ConstraintKind::Holonomic),
            cyclic,
            gmin: 0.0,
            stiffness: 0.0,
            anchor: q0.to_vec(),
            sources: Vec::new(),
            source_weight: 0.0,
            q: q0.to_vec(),
            v: vec![0.0; n],
            lq: vec![0.0; n],
            lv: vec![0.0; n],
            f: vec![0.0; n],
            derivatives: Derivatives::default(),
            curvature: Triplets::new(),
            contracted: Triplets::new(),
            g: vec![0.0; m],
            redundant: Vec::new(),
            integrated: vec![false; m],
        }
    }

    fn n(&self) -> usize {
        self.model.dim()
    }

    fn m(&self) -> usize {
        self.constraints.count()
    }

    /// Positions and velocities from the unknowns.
    fn state(&self, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = self.n();
        let mut q = self.q0.to_vec();
        let mut v = vec![0.0; n];
        for i in 0..n {
            if self.cyclic[i] {
                v[i] = x[i];
            } else {
                q[i] = x[i];
            }
        }
        (q, v)
    }

    fn load(&mut self, x: &[f64]) {
        for ((((q, v), &x), &q0), &cyclic) in self
            .q
            .iter_mut()
            .zip(self.v.iter_mut())
            .zip(x)
            .zip(self.q0)
            .zip(&self.cyclic)
        {
            (*q, *v) = if cyclic { (q0, x) } else { (x, 0.0) };
        }
    }

    /// Stamps every derivative at the loaded state: [`Derivatives::stamp`], the constraints'
    /// curvature `λ·∂²g/∂q²` and their contracted derivative.
    fn stamp(&mut self, lambda: &[f64]) {
        self.derivatives
            .stamp(self.model, self.constraints, &self.q, &self.v, self.t0);
        self.curvature.begin();
        self.constraints
            .multiplier_hessian(&self.q, lambda, &mut self.curvature);
        self.curvature.freeze();
        self.contracted.begin();
        self.constraints
            .contracted_derivative(&self.q, &self.v, &mut self.contracted);
        self.contracted.freeze();
    }

    /// Calls `emit(row, col, value)` for every Jacobian entry; the gmin entries are flagged.
    fn entries(&self, mut emit: impl FnMut(usize, usize, f64, bool)) {
        let (n, m) = (self.n(), self.m());
        for (i, j, value) in self.derivatives.hessian.qq.iter() {
            if !self.cyclic[j] {
                emit(i, j, value, false);
            }
        }
        for (i, j, value) in self.derivatives.hessian.qv.iter() {
            if self.cyclic[j] {
                emit(i, j, value, false);
            }
        }
        for (i, j, value) in self.derivatives.force.q.iter() {
            if !self.cyclic[j] {
                emit(i, j, value, false);
            }
        }
        for (i, j, value) in self.derivatives.force.v.iter() {
            if self.cyclic[j] {
                emit(i, j, value, false);
            }
        }
        for (j, l, value) in self.curvature.iter() {
            if !self.cyclic[l] {
                emit(j, l, -value, false);
            }
        }
        for (a, j, value) in self.derivatives.forms.iter() {
            emit(j, n + a, -value, false);
            // Holonomic rows g(q) = 0 act on positions, one-forms A v = 0 on rates.
            let holonomic = self.constraints.kind(a) == ConstraintKind::Holonomic;
            if holonomic != self.cyclic[j] || self.integrated[a] {
                emit(n + a, j, value, false);
            }
        }
        for (a, l, value) in self.contracted.iter() {
            if self.constraints.kind(a) == ConstraintKind::OneForm && !self.cyclic[l] {
                emit(n + a, l, value, false);
            }
        }
        for a in 0..m {
            if self.constraints.kind(a) == ConstraintKind::OneForm {
                emit(n + a, n + a, self.gmin, true);
            }
        }
        if self.holonomic {
            for j in (0..n).filter(|&j| !self.cyclic[j]) {
                emit(j, j, -self.stiffness, true);
            }
        }
        for (k, &(a, _)) in self.holds.iter().enumerate() {
            emit(n + a, n + m + k, 1.0, false);
            emit(n + m + k, n + a, 1.0, false);
        }
    }

    /// Sets the multipliers of `x` to those that balance the forces at its positions in least
    /// squares, `min ‖∂L/∂q + f − Aᵀλ‖`: the augmented system `[[I, Aᵀ], [A, −δI]]` (`δ` tiny,
    /// for redundant rows). A mechanism's positions are held only through its constraints'
    /// curvature `λ·∂²g/∂q²`, which vanishes at `λ = 0`: from there the first Newton matrix of a
    /// hanging pendulum is singular. Left at zero when the solve fails (Newton reports).
    fn balance_multipliers(&mut self, x: &mut [f64]) {
        let (n, m) = (self.n(), self.m());
        let mut r = vec![0.0; x.len()];
        self.residual(x, &mut r);
        let largest = self
            .derivatives
            .forms
            .iter()
            .fold(0.0_f64, |big, (_, _, value)| big.max(value.abs()));
        let delta = 1e-10 * largest * largest;
        let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
        let mut push = |i: usize, j: usize, value: f64| {
            rows.push(i);
            cols.push(j);
            values.push(value);
        };
        for j in 0..n {
            push(j, j, 1.0);
        }
        for (a, j, value) in self.derivatives.forms.iter() {
            push(j, n + a, value);
            push(n + a, j, value);
        }
        for a in 0..m {
            push(n + a, n + a, -delta);
        }
        let mut rhs = vec![0.0; n + m];
        // The residual's force rows already subtract `Aᵀλ` of the multipliers in `x`: the
        // solve gives their correction.
        rhs[..n].copy_from_slice(&r[..n]);
        let mut lu = AutoLu::for_size(SolverChoice::Auto, n + m);
        let solved = lu
            .analyse(n + m, &rows, &cols)
            .and_then(|()| lu.factor(&values))
            .and_then(|()| lu.solve_in_place(&mut rhs));
        if solved.is_ok() && rhs.iter().all(|v| v.is_finite()) {
            for (l, d) in x[n..n + m].iter_mut().zip(&rhs[n..]) {
                *l += d;
            }
        }
    }

    /// Structural analysis before Newton: an unknown no equation fixes is an error naming it.
    fn analyse(&mut self) -> Result<(), SteadyStateError> {
        let (n, m) = (self.n(), self.m());
        let size = n + m + self.holds.len();
        let x: Vec<f64> = (0..size)
            .map(|i| {
                if i < n && !self.cyclic[i] {
                    self.q0[i]
                } else {
                    0.0
                }
            })
            .collect();
        self.load(&x);
        // Multipliers of one: the pattern must hold the constraints' curvature `λ·∂²g/∂q²`,
        // which at λ = 0 has no entries (a rigid body's rotation is held by the curvature of
        // its orthonormality and joint rows, which no other term reaches).
        self.stamp(&vec![1.0; m]);
        if self.holonomic && self.constraints.is_constant() {
            self.integrated = (0..m)
                .map(|a| self.constraints.kind(a) == ConstraintKind::OneForm)
                .collect();
            for (a, j, value) in self.derivatives.forms.iter() {
                if value != 0.0 && self.cyclic[j] {
                    self.integrated[a] = false;
                }
            }
        }
        let mut pattern = Vec::new();
        self.entries(|r, c, value, gmin| {
            if !gmin && value != 0.0 {
                pattern.push((r, c));
            }
        });
        let mut priority = vec![0u8; size];
        priority[..n].fill(1);
        let structure = Structure::analyse(size, size, &pattern, &priority);
        let undetermined: Vec<usize> = (0..size)
            .filter(|&c| structure.is_underdetermined_col(c))
            .collect();
        if !undetermined.is_empty() {
            let nodes: Vec<String> = undetermined
                .iter()
                .filter(|&&c| c >= n && c < n + m)
                .map(|&c| self.constraints.name(c - n))
                .collect();
            let others: Vec<String> = undetermined
                .iter()
                .filter(|&&c| c < n)
                .map(|&c| self.unknown_name(c))
                .collect();
            let (unknowns, hint) = if nodes.is_empty() {
                (
                    others.join(", ") + if others.len() == 1 { " is" } else { " are" },
                    "a coordinate with neither a restoring force nor a constraint, or a loop of inductors and voltage sources; give it a spring or a resistor, or start from given values (UIC)".to_string(),
                )
            } else {
                (
                    format!(
                        "the potential of {} {}",
                        nodes.join(", "),
                        if nodes.len() == 1 { "is" } else { "are" }
                    ),
                    "no DC path to ground: the node connects only through capacitors or current sources; add a resistor to ground, or start from given values (UIC)".to_string(),
                )
            };
            return Err(SteadyStateError::Undetermined { unknowns, hint });
        }
        self.redundant = structure.unmatched_rows().collect();
        Ok(())
    }

    /// After the solve: equations left out as redundant must hold too.
    fn check_redundant(&mut self, x: &[f64]) -> Result<(), SteadyStateError> {
        if self.redundant.is_empty() {
            return Ok(());
        }
        let mut r = vec![0.0; x.len()];
        self.residual(x, &mut r);
        let scale = self
            .lq
            .iter()
            .chain(&self.f)
            .chain(x)
            .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
        let bad: Vec<String> = self
            .redundant
            .iter()
            .filter(|&&row| r[row].abs() > 1e-9 * scale)
            .map(|&row| format!("{} (residual {:.3e})", self.equation_name(row), r[row]))
            .collect();
        if bad.is_empty() {
            return Ok(());
        }
        Err(SteadyStateError::Contradictory {
            equations: bad.join(", "),
            hint: "at steady state these equations fix the same value differently: a current source feeding a cut set of capacitors (or of current sources), or a loop of voltage sources with different values".into(),
        })
    }

    fn unknown_name(&self, c: usize) -> String {
        let n = self.n();
        if c < n {
            let name = self.model.coordinate_name(c);
            if self.cyclic[c] {
                format!("the rate of `{name}`")
            } else {
                format!("`{name}`")
            }
        } else if c < n + self.m() {
            format!("the multiplier of {}", self.constraints.name(c - n))
        } else {
            "a held node's injection".to_string()
        }
    }

    fn equation_name(&self, r: usize) -> String {
        let n = self.n();
        if r < n {
            format!("the force balance of `{}`", self.model.coordinate_name(r))
        } else if r < n + self.m() {
            self.constraints.name(r - n)
        } else {
            "a held node's value".to_string()
        }
    }

    /// The `count` equations with the largest residuals, named.
    fn worst_equations(&self, r: &[f64], count: usize) -> String {
        let mut order: Vec<usize> = (0..r.len()).collect();
        order.sort_by(|&a, &b| r[b].abs().total_cmp(&r[a].abs()));
        order
            .iter()
            .take(count)
            .map(|&row| format!("{} = {:.3e}", self.equation_name(row), r[row]))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl<M: Model + ?Sized, C: Constraints + ?Sized> NonlinearSystem for SteadySystem<'_, M, C> {
    fn len(&self) -> usize {
        self.n() + self.m() + self.holds.len()
    }

    fn residual(&mut self, x: &[f64], r: &mut [f64]) {
        let (n, m) = (self.n(), self.m());
        self.load(x);
        let lambda = &x[n..n + m];
        self.model
            .lagrangian_gradient(&self.q, &self.v, &mut self.lq, &mut self.lv);
        if self.model.has_force() {
            self.model.force(&self.q, &self.v, self.t0, &mut self.f);
        } else {
            self.f.fill(0.0);
        }
        for ((r, lq), f) in r.iter_mut().zip(&self.lq).zip(&self.f) {
            *r = lq + f;
        }
        if self.stiffness != 0.0 {
            for j in (0..n).filter(|&j| !self.cyclic[j]) {
                r[j] -= self.stiffness * (self.q[j] - self.anchor[j]);
            }
        }
        r[n..].fill(0.0);
        let forms = &mut self.derivatives.forms;
        forms.begin();
        self.constraints.forms(&self.q, forms);
        forms.freeze();
        for (a, j, value) in self.derivatives.forms.iter() {
            r[j] -= value * lambda[a];
            if self.integrated[a] {
                r[n + a] += value * (self.q[j] - self.q0[j]);
            } else if self.constraints.kind(a) == ConstraintKind::OneForm {
                r[n + a] += value * self.v[j];
            }
        }
        self.constraints.values(&self.q, &mut self.g);
        for a in 0..m {
            match self.constraints.kind(a) {
                ConstraintKind::Holonomic => r[n + a] = self.g[a],
                ConstraintKind::OneForm => r[n + a] += self.gmin * lambda[a],
            }
        }
        for (k, &(a, value)) in self.holds.iter().enumerate() {
            r[n + a] += x[n + m + k];
            r[n + m + k] = lambda[a] - value;
        }
        for (r, f) in r.iter_mut().zip(&self.sources) {
            *r -= self.source_weight * f;
        }
    }

    fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
        let (n, m) = (self.n(), self.m());
        self.load(x);
        self.stamp(&x[n..n + m]);
        self.entries(|r, c, value, _| jac.add(r, c, value));
    }

    fn update_fraction(&mut self, x: &[f64], update: &[f64]) -> f64 {
        if !self.model.has_update_limit() {
            return 1.0;
        }
        let n = self.n();
        self.load(x);
        let mut dq = vec![0.0; n];
        let mut dv = vec![0.0; n];
        for i in 0..n {
            if self.cyclic[i] {
                dv[i] = -update[i];
            } else {
                dq[i] = -update[i];
            }
        }
        self.model.update_fraction(&self.q, &self.v, &dq, &dv)
    }
}
