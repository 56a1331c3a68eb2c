//! The integrator: state, initialisation and the step loop.

use dirac_core::{
    ConstraintKind, Constraints, Discretisation, Flavour, ForcedDiracStep, LagrangianHessian,
    Model, RowSubset, Triplets, analyse_rows,
};
use dirac_solve::{
    LinearSolveError, Newton, NewtonError, NewtonOptions, NewtonStats, NonlinearSystem, Structure,
};

use crate::composition::Composition;
use crate::error::SimError;
use crate::explicit::ExplicitStep;
use crate::linear::{AutoLu, SolverChoice};
use crate::truncation::{History, TruncationControl, Verdict};

/// Relative size below which a reduced constraint row counts as linearly dependent.
const REDUNDANCY_TOL: f64 = 1e-10;

/// Largest `|g(q₀)|` (relative to `1 + ‖q₀‖∞`) accepted for a holonomic constraint at start.
const HOLONOMIC_TOL: f64 = 1e-10;

/// Which forced discrete Dirac scheme advances the state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Scheme {
    /// The (+) step: constraint forms at `q_k`.
    #[default]
    Plus,
    /// The (−) step: constraint forms at `q_{k+1}` (look-ahead form, MATH §4).
    Minus,
    /// The composition (−) over `h/2`, then (+) over `h/2`: both kinematic constraints sit at the
    /// midpoint `q_{k+½}` and the map is symmetric. For constant forms it gives the same positions
    /// as (+)/(−) with two half steps; for q-dependent forms it removes the one-sided energy drift
    /// of (+) (which dissipates) and (−) (which gains): on the vertical rolling disk it conserves
    /// the energy exactly.
    Symmetric,
}

impl From<Flavour> for Scheme {
    fn from(f: Flavour) -> Self {
        match f {
            Flavour::Plus => Self::Plus,
            Flavour::Minus => Self::Minus,
        }
    }
}

/// How a nonlinear step's Newton iteration is started from the previous steps' solutions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Predictor {
    /// `4x_k − 6x_{k−1} + 4x_{k−2} − x_{k−3}`: the unknowns extrapolated in `k` by the cubic
    /// through the last four solutions (error `O(h⁴)` relative to the unknowns; a lower degree
    /// while fewer solutions follow each other).
    Extrapolation,
    /// The previous step's path polynomial `q(t_k + σh) = q_k + Σ ℓ_l(σ) Z^l` evaluated at the next
    /// step's control points `σ = 1 + d_l` (error `O(h^{s+1})`); multipliers extrapolate in `k`
    /// as with [`Predictor::Extrapolation`]. Used with one substep per step and no constraint
    /// rows; otherwise every unknown extrapolates in `k`.
    #[default]
    Polynomial,
}

/// How to integrate: discretisation, flavour, step size and solver settings.
#[derive(Debug, Clone, PartialEq)]
pub struct IntegratorOptions {
    /// Path and quadrature for `L_d` and `f_d^±`.
    pub discretisation: Discretisation,
    /// (+), (−) or symmetric forced discrete Dirac scheme (irrelevant without constraints).
    pub scheme: Scheme,
    /// Step size `h`.
    pub h: f64,
    /// Dense or sparse linear algebra.
    pub solver: SolverChoice,
    /// Newton tolerances. [`IntegratorOptions::new`] takes the defaults with
    /// [`NewtonOptions::accept_at_equation_roundoff`] on; steps of models with update limits
    /// (exponential devices) run with it off whatever is set here.
    pub newton: NewtonOptions,
    /// Opt-in: for small linear autonomous models with constant constraint forms, precompute the
    /// step as a fixed affine map of `(q_k, p_k)` and apply it by matrix–vector products (see
    /// [`Integrator::uses_affine_map`]). About 5× faster on the seed RLC loop, but the rounded map
    /// has eigenvalues off the unit circle by ~ε, so invariants drift systematically (~kε after k
    /// steps: LC tank energy 4.5e-11 after 10⁶ steps) where the Newton path's rounding is a random
    /// walk (5.5e-13). Off by default.
    pub affine_map: bool,
    /// Land a substep on every source breakpoint ([`dirac_core::Model::next_breakpoint`]) inside a
    /// step (on by default). Off, a corner inside a step is seen only through the quadrature of
    /// the force, which costs `O(h·jump)` at that step whatever the order.
    pub breakpoints: bool,
    /// The step as a composition of substeps `γᵢ h` (each one step of `scheme`); a single step by
    /// default. With the symmetric scheme (or no constraints) the compositions of
    /// [`Composition`] raise the order of a second-order discretisation to 4, 6 or 8.
    pub composition: Composition,
    /// Step a separable model ([`Model::separable`]) without constraints explicitly when the
    /// discretisation is the trapezoid rule: Störmer–Verlet, the same map as the Newton path to
    /// round-off at one force evaluation per substep (see [`Integrator::uses_explicit`]). On by
    /// default; off forces the Newton path (for comparisons).
    pub explicit: bool,
    /// The Newton start of nonlinear steps (the solution is the same to the Newton tolerance;
    /// the iteration count differs).
    pub predictor: Predictor,
    /// Split the first step into geometrically growing substeps (see [`StartRamp`]), so that
    /// the fast modes of an initial state off the slow manifold are damped instead of ringing
    /// through the run. Off by default.
    pub start_ramp: Option<StartRamp>,
    /// Take the stretch after every source breakpoint (to the end of its step, or to the next
    /// breakpoint) as the ramp's geometrically growing substeps, as SPICE restarts with a tiny
    /// step after a breakpoint: a corner of a source puts about `τ·Δ(slope)` into every damped
    /// mode of time constant `τ`, which rings through the run when `τ ≪ h`. Needs
    /// [`IntegratorOptions::breakpoints`]. Off by default.
    pub corner_ramp: Option<StartRamp>,
    /// Redo a substep as `2^m` equal pieces when its estimated local truncation error exceeds
    /// SPICE's tolerance (see [`TruncationControl`]): resolves a diode switching on inside a
    /// step, as SPICE's step control does, while the output grid stays `t_k = t₀ + k h`. Off by
    /// default; a netlist with diodes turns it on.
    pub truncation: Option<TruncationControl>,
}

/// The start ramp: the first step `[t₀, t₀ + h]` taken as `per_level` equal substeps in each of
/// the `levels + 1` chunks `h·2^−levels, h·2^−levels, h·2^−(levels−1), …, h/2` (which sum to
/// `h`, so the output grid `t_k = t₀ + k h` is unchanged).
///
/// Midpoint and Gauss–Legendre steps are A-stable but not L-stable: a mode `e^{λt}` with
/// `|λ| h ≫ 1` is multiplied by `|R(λh)| → 1` per step and rings for the whole run. On the
/// ramp some substeps have `|λ δ|` near the value where `|R|` is smallest, so every mode with
/// a time constant down to about a quarter of the smallest substep is damped by the product of
/// `|R(λδᵢ)|` over the substeps: at most 1e-8 for the midpoint rule with the default
/// (32 levels, 3 substeps per level: 99 substeps, 32 distinct sizes, floor about `h·2e−11`),
/// smaller for Gauss 2–4 (docs/math.md, "Start ramp").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartRamp {
    /// Halvings from `h/2` down to the smallest chunk `h·2^−levels` (taken between 1 and
    /// [`StartRamp::MAX_LEVELS`]).
    pub levels: u32,
    /// Equal substeps per chunk (at least 1).
    pub per_level: u32,
}

impl Default for StartRamp {
    fn default() -> Self {
        Self {
            levels: 32,
            per_level: 3,
        }
    }
}

impl StartRamp {
    /// Most levels used: a chunk below `h·2^−52` is below the rounding of `t₀ + h` and would add
    /// only round-off.
    pub const MAX_LEVELS: u32 = 52;

    fn levels(&self) -> u32 {
        self.levels.clamp(1, Self::MAX_LEVELS)
    }

    /// The ramp whose smallest chunk resolves a damped mode `ratio` times faster than the
    /// stretch it ramps (`ratio = h/τ`): `⌈log₂ ratio⌉ + 2` levels (at least 1, at most the
    /// default 32), 3 substeps per level. A ramp after a corner needs no more: slower modes meet
    /// a substep near `2τ` as well, and faster ones than the modal analysis found do not exist.
    #[must_use]
    pub fn for_ratio(ratio: f64) -> Self {
        let default = Self::default();
        let levels = if ratio.is_finite() && ratio > 1.0 {
            (ratio.log2().ceil() as u32).saturating_add(2)
        } else {
            1
        };
        Self {
            levels: levels.clamp(1, default.levels),
            per_level: default.per_level,
        }
    }

    /// The ramp over `stretch` from `start` to `target` (`target − start` up to rounding): each
    /// substep's size (`fraction(j)` of the stretch) and end time, the last one ending on
    /// `target` exactly.
    fn pieces(self, start: f64, stretch: f64, target: f64) -> impl Iterator<Item = (f64, f64)> {
        let pieces = self.substeps();
        let mut t = start;
        (0..pieces).map(move |j| {
            let size = self.fraction(j) * stretch;
            t = if j + 1 == pieces { target } else { t + size };
            (size, t)
        })
    }

    /// Substeps the ramp takes: `per_level · (levels + 1)`.
    #[must_use]
    pub fn substeps(&self) -> usize {
        self.per_level.max(1) as usize * (self.levels() as usize + 1)
    }

    /// Size of substep `j` (`0 ≤ j < substeps()`) as a fraction of `h`.
    #[must_use]
    pub fn fraction(&self, j: usize) -> f64 {
        let levels = self.levels() as i32;
        let chunk = j / self.per_level.max(1) as usize;
        // Chunk 0 is 2^−levels; chunk c ≥ 1 is 2^−(levels − c + 1).
        let exponent = if chunk == 0 {
            -levels
        } else {
            -(levels - chunk as i32 + 1)
        };
        2f64.powi(exponent) / f64::from(self.per_level.max(1))
    }
}

impl IntegratorOptions {
    /// Options with the (+) flavour, automatic solver choice and default tolerances.
    #[must_use]
    pub fn new(discretisation: Discretisation, h: f64) -> Self {
        Self {
            discretisation,
            scheme: Scheme::Plus,
            h,
            solver: SolverChoice::Auto,
            newton: NewtonOptions {
                accept_at_equation_roundoff: true,
                ..NewtonOptions::default()
            },
            affine_map: false,
            breakpoints: true,
            composition: Composition::single(),
            explicit: true,
            predictor: Predictor::Polynomial,
            start_ramp: None,
            corner_ramp: None,
            truncation: None,
        }
    }

    /// Controls the truncation error by refining substeps (see
    /// [`IntegratorOptions::truncation`]); `None` keeps every step at `h`.
    #[must_use]
    pub fn truncation(mut self, control: Option<TruncationControl>) -> Self {
        self.truncation = control;
        self
    }

    /// Ramps the first step up from tiny substeps (see [`StartRamp`]); `None` takes `h` at once.
    #[must_use]
    pub fn start_ramp(mut self, ramp: Option<StartRamp>) -> Self {
        self.start_ramp = ramp;
        self
    }

    /// Ramps the stretch after every source breakpoint up from tiny substeps (see
    /// [`IntegratorOptions::corner_ramp`]); `None` steps on at once.
    #[must_use]
    pub fn corner_ramp(mut self, ramp: Option<StartRamp>) -> Self {
        self.corner_ramp = ramp;
        self
    }

    /// Chooses the Newton start of nonlinear steps (see [`IntegratorOptions::predictor`]).
    #[must_use]
    pub fn predictor(mut self, predictor: Predictor) -> Self {
        self.predictor = predictor;
        self
    }

    /// Allows or forbids the explicit path (see [`IntegratorOptions::explicit`]).
    #[must_use]
    pub fn explicit(mut self, on: bool) -> Self {
        self.explicit = on;
        self
    }

    /// Lands substeps on source breakpoints (see [`IntegratorOptions::breakpoints`]).
    #[must_use]
    pub fn breakpoints(mut self, on: bool) -> Self {
        self.breakpoints = on;
        self
    }

    /// Composes the step from substeps `γᵢ h` (see [`IntegratorOptions::composition`]).
    #[must_use]
    pub fn composition(mut self, composition: Composition) -> Self {
        self.composition = composition;
        self
    }

    /// Sets the flavour of a single-stage scheme.
    #[must_use]
    pub fn flavour(mut self, flavour: Flavour) -> Self {
        self.scheme = flavour.into();
        self
    }

    /// Applies the step as a precomputed affine map when the model qualifies (see
    /// [`IntegratorOptions::affine_map`]).
    #[must_use]
    pub fn affine_map(mut self, on: bool) -> Self {
        self.affine_map = on;
        self
    }

    /// Sets the scheme.
    #[must_use]
    pub fn scheme(mut self, scheme: Scheme) -> Self {
        self.scheme = scheme;
        self
    }

    /// Sets the linear solver.
    #[must_use]
    pub fn solver(mut self, solver: SolverChoice) -> Self {
        self.solver = solver;
        self
    }
}

/// What one step cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepReport {
    /// Newton counters of this step.
    pub newton: NewtonStats,
}

/// Advances `(q_k, p_k, t_k)` of a model with constraints by forced discrete Dirac steps.
///
/// Without constraints each step is the forced discrete Hamiltonian map
/// `p_k = −D₁L_d − f_d⁻`, `p_{k+1} = D₂L_d + f_d⁺`. In the (−) flavour the carried momentum is
/// `p̃_k` (without the constraint impulse of the previous step, MATH §4); compare momenta of the
/// two flavours only after projecting onto the constraint distribution.
#[derive(Debug)]
pub struct Integrator<M, C> {
    model: M,
    constraints: RowSubset<C>,
    options: IntegratorOptions,
    warnings: Vec<String>,
    stages: Vec<Stage>,
    control_nodes: Vec<f64>,
    q: Vec<f64>,
    p: Vec<f64>,
    v0: Vec<f64>,
    t0: f64,
    t: f64,
    k: usize,
    p_next: Vec<f64>,
    stats: NewtonStats,
    affine: Affine,
    /// The explicit Störmer–Verlet step, when the model qualifies.
    explicit: Option<ExplicitStep>,
    /// Constraint impulses of the last step (all substeps and multiplier blocks), per active row.
    impulse: Vec<f64>,
    /// The state at the start of the step (restored when a substep fails and is cut).
    saved_q: Vec<f64>,
    saved_p: Vec<f64>,
    saved_impulse: Vec<f64>,
    counters: StepCounters,
    /// Coordinates whose momentum is a constant of the model, with that constant (see
    /// [`Integrator::free_momenta`]).
    free_momenta: Vec<(usize, f64)>,
    /// Accepted points of the judged components (with [`IntegratorOptions::truncation`]).
    history: Option<History>,
    /// The states at the ends of the substeps inside the last step, when asked for (see
    /// [`Integrator::record_inner_states`]).
    inner_states: Option<Vec<InnerState>>,
}

/// The state `(t, q, p)` at the end of a substep inside a step: a source breakpoint the substeps
/// land on, a piece of a step the truncation-error control refined, a ramp's substep.
#[derive(Debug, Clone, PartialEq)]
pub struct InnerState {
    /// Its time, strictly between two grid points.
    pub t: f64,
    /// Positions there.
    pub q: Vec<f64>,
    /// Momenta there.
    pub p: Vec<f64>,
}

/// How often steps were split: at source breakpoints and after Newton failures.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepCounters {
    /// Substeps ending on a breakpoint of a source (a step containing one corner takes two).
    pub breakpoint_substeps: usize,
    /// Times a substep failed and was retried as two halves.
    pub step_cuts: usize,
    /// Substeps of the start ramp and of the ramps after breakpoints ([`StartRamp`],
    /// [`IntegratorOptions::corner_ramp`]; 0 without them).
    pub ramp_substeps: usize,
    /// Substeps the truncation-error test rejected and redone as `2^m` pieces
    /// ([`IntegratorOptions::truncation`]).
    pub refinements: usize,
    /// Substeps accepted, of every kind (a step at `h`, a piece of a split step, a breakpoint
    /// substep, a ramp substep): the time points of the run after `t₀`.
    pub substeps: usize,
    /// Solved substeps that turned a body by more than 0.25 rad and were checked against
    /// two half steps ([`Model::step_turns`]).
    pub turn_checks: usize,
    /// Solved substeps rejected as roots of the step equations that the motion does not take:
    /// by the model's own check (a quarter turn) or the half-step check. Each was cut.
    pub spurious_roots: usize,
}

/// Breakpoints closer than this fraction of `h` to a grid point or to each other are merged
/// (a substep that short would only add round-off).
const BREAKPOINT_SNAP: f64 = 1e-9;

/// How many times a failing substep is halved before the failure is reported (down to h/1024).
const MAX_CUT_DEPTH: u32 = 10;

/// A solved step that turns some body by more than this many radians ([`Model::step_turns`]) is
/// checked against two half steps before it is kept ([`Integrator::verify_step`]).
const VERIFY_TURN: f64 = 0.25;
/// The check's bound, body by body: the angle between the full step's end and the two half
/// steps' end, as a fraction of the half steps' own turn of that body (or of
/// [`VERIFY_FLOOR`], when that turn is smaller), above which the full step is taken for a
/// spurious root.
const VERIFY_RATIO: f64 = 0.5;
/// The turn below which a body's disagreement is judged against this angle instead of its own
/// turn: on the motion's branch the two ends of a body that barely turns differ by far less
/// than `VERIFY_RATIO` of it, while a ratio against a turn near zero would judge round-off.
const VERIFY_FLOOR: f64 = 0.05;

/// Largest state dimension `2n` (and unknown count) for which the step is applied as a dense map.
const AFFINE_LIMIT: usize = 32;

/// The step of a linear autonomous model with constant forms at fixed `h` as a fixed linear map of
/// `z = (q_k, p_k)`: unknowns `x = X z` and `p_{k+1} = P z` (a discrete state-space realisation,
/// built by pushing the `2n` basis states through the Newton step once).
#[derive(Debug, Clone, Default)]
enum Affine {
    /// Not decided yet (decided at the first step).
    #[default]
    Unknown,
    /// The model does not qualify.
    No,
    /// Row-major maps `x = X z + x₀`, `p_{k+1} = P z + p₀` (the offsets come from constant terms,
    /// e.g. gravity).
    Map {
        /// `unknowns × 2n`.
        x: Vec<f64>,
        /// `n × 2n`.
        p: Vec<f64>,
        /// `x₀`.
        x0: Vec<f64>,
        /// `p₀`.
        p0: Vec<f64>,
        /// `z = (q_k, p_k)`.
        z: Vec<f64>,
    },
}

/// The end momentum of a step with a constant Newton matrix as an affine map of the unknowns.
#[derive(Debug)]
struct LinearEnd {
    /// `E = ∂p_{k+1}/∂x`, stamped at the first step (empty until then), by rows: row `r`'s
    /// entries are `start[r]..start[r + 1]` of `cols` and `values`, in the order stamped.
    start: Vec<usize>,
    cols: Vec<usize>,
    values: Vec<f64>,
    /// The guess `x₀` of the current step.
    guess: Vec<f64>,
    /// `p_{k+1}(x₀)`.
    at_guess: Vec<f64>,
}

impl LinearEnd {
    /// Keeps `E` (triplets with one row per momentum) by rows, each row's entries in stamped
    /// order.
    fn set_jacobian(&mut self, jacobian: &Triplets) {
        let n = self.at_guess.len();
        let mut start = vec![0; n + 1];
        for &r in jacobian.rows() {
            start[r + 1] += 1;
        }
        for r in 0..n {
            start[r + 1] += start[r];
        }
        let mut next = start.clone();
        self.cols = vec![0; jacobian.len()];
        self.values = vec![0.0; jacobian.len()];
        for (r, c, e) in jacobian.iter() {
            self.cols[next[r]] = c;
            self.values[next[r]] = e;
            next[r] += 1;
        }
        self.start = start;
    }

    /// `p_{k+1}(x) = p_{k+1}(x₀) + E (x − x₀)` into `p`. Row by row with the sum in a register:
    /// the same additions in the same order as entry by entry into `p`, without a store and a
    /// reload per entry.
    fn end_momentum(&self, x: &[f64], p: &mut [f64]) {
        for (r, (pr, at)) in p.iter_mut().zip(&self.at_guess).enumerate() {
            let range = self.start[r]..self.start[r + 1];
            *pr = self.cols[range.clone()]
                .iter()
                .zip(&self.values[range])
                .fold(*at, |acc, (&c, e)| acc + e * (x[c] - self.guess[c]));
        }
    }
}

/// One substep of a scheme: its step equations, its Newton solver (which keeps that substep's
/// pattern and, for linear models, its factorisation) and its unknowns.
#[derive(Debug)]
struct Stage {
    step: ForcedDiracStep,
    newton: Newton<AutoLu>,
    /// The last solution (increments, then multipliers), which is also the next step's guess.
    x: Vec<f64>,
    /// For a constant Newton matrix, the end momentum is affine in the unknowns:
    /// `p_{k+1}(x) = p_{k+1}(x₀) + E (x − x₀)`. `p_{k+1}(x₀)` comes with the residual at the guess
    /// `x₀`, so a step evaluates the model once instead of twice.
    linear_end: LinearEnd,
    /// The solutions of the steps before the last, most recent first (nonlinear models only:
    /// the predictor extrapolates them in `k`).
    past: Vec<f64>,
    /// How many blocks of `past` hold solutions of regular steps that follow each other.
    known: usize,
    /// Work space for the predictor and for diagnostics that re-evaluate the step equations.
    scratch: Vec<f64>,
    /// This substep's size as a fraction of `h` (a composition's `γᵢ`, halved by the symmetric
    /// scheme).
    fraction: f64,
    /// Newton for substeps of other sizes (landing on a breakpoint, a cut step), so the regular
    /// step keeps its factorisation.
    aux: Option<(Newton<AutoLu>, f64)>,
    /// The Newton the step-doubling check's halves solve with (swapped in for `aux`), so that
    /// the check leaves `aux`'s factorisation and its contraction record as they were.
    check_aux: Option<(Newton<AutoLu>, f64)>,
    /// The size of the last solve (the guess of the next one is scaled from it).
    last_size: f64,
    /// Row-major `s × s` map from the last increments `Z^{l'}` to the predicted next ones:
    /// `ℓ_{l'}(1 + d_l) − δ_{l' s}` (empty unless the increments use the path polynomial).
    extrapolation: Vec<f64>,
    /// For a model that checks its steps ([`Model::check_step`]): the guess of the last solve
    /// (put back when its root is rejected, so the pieces of the cut start from it) and the
    /// end position of the step being checked. Empty otherwise.
    checked_guess: Vec<f64>,
    checked_end: Vec<f64>,
    /// The checked step's turn of each body ([`Model::step_turns`]), kept between steps for its
    /// storage.
    checked_turns: Vec<f64>,
}

impl Stage {
    /// Readies the auxiliary Newton for a solve of `size`: created on first use (with `solver`
    /// and the regular Newton's options), its factorisation dropped when the size changes.
    fn ready_aux(&mut self, solver: SolverChoice, size: f64) {
        let options = *self.newton.options();
        let unknowns = self.step.unknowns();
        let (newton, aux_size) = self.aux.get_or_insert_with(|| {
            (
                Newton::new(AutoLu::for_size(solver, unknowns), options),
                size,
            )
        });
        if *aux_size != size {
            newton.invalidate_factorisation();
            *aux_size = size;
        }
    }

    /// Keeps the guess `x` of the solve about to start, for a model that checks its steps.
    fn keep_guess(&mut self) {
        if !self.checked_guess.is_empty() {
            self.checked_guess.copy_from_slice(&self.x);
        }
    }

    /// Pushes the current solution `x` to the front of `past`.
    fn remember(&mut self) {
        let u = self.x.len();
        self.past.copy_within(..(PAST_DEPTH - 1) * u, u);
        self.past[..u].copy_from_slice(&self.x);
        self.known = (self.known + 1).min(PAST_DEPTH);
    }

    /// Moves the extrapolated guess `x` back toward the last solution (the constant-increment
    /// guess, `past[0]`) as far as the model's limits on a Newton update ask
    /// ([`Model::update_fraction`]: a junction's `pnjlim`): a cubic in `k` through a fast
    /// discharge (a node falling 3.4 → 1.8 → 0.56 V in two steps) guessed a junction several
    /// volts forward, a residual of 2e112 from which the limited Newton never recovered (a CMOS
    /// XOR gate under gauss2, audit item 40).
    fn limit_guess<M: Model + ?Sized>(&mut self, model: &M) {
        let u = self.x.len();
        for (d, (&guess, &last)) in self
            .scratch
            .iter_mut()
            .zip(self.x.iter().zip(&self.past[..u]))
        {
            *d = last - guess;
        }
        let alpha = self
            .step
            .update_fraction(model, &self.past[..u], &self.scratch);
        if alpha < 1.0 {
            for (x, (&last, &d)) in self
                .x
                .iter_mut()
                .zip(self.past[..u].iter().zip(&self.scratch))
            {
                *x = last - alpha * d;
            }
        }
    }

    /// Replaces the unknowns from `from` on by their extrapolation in `k` from the last solution
    /// and the known past ones (a polynomial of degree `known`, at most `PAST_DEPTH`), and
    /// remembers the last solution.
    fn extrapolate_in_k(&mut self, from: usize) {
        let u = self.x.len();
        let weights: &[f64] = match self.known {
            0 => &[1.0],
            1 => &[2.0, -1.0],
            2 => &[3.0, -3.0, 1.0],
            _ => &[4.0, -6.0, 4.0, -1.0],
        };
        for idx in from..u {
            let mut e = weights[0] * self.x[idx];
            for (j, w) in weights[1..].iter().enumerate() {
                e += w * self.past[j * u + idx];
            }
            self.scratch[idx] = e;
        }
        self.remember();
        self.x[from..].copy_from_slice(&self.scratch[from..]);
    }

    fn new<M: Model, C: Constraints>(
        model: &M,
        constraints: &C,
        options: &IntegratorOptions,
        flavour: Flavour,
        h: f64,
    ) -> Self {
        let step = ForcedDiracStep::new(model, constraints, &options.discretisation, flavour, h);
        let unknowns = step.unknowns();
        let path = options.discretisation.path();
        let s = path.degree();
        let mut extrapolation = Vec::new();
        // The previous path is extrapolated over the next step only when the steps of this
        // stage follow each other (one substep per step).
        let contiguous =
            options.composition.gammas().len() == 1 && options.scheme != Scheme::Symmetric;
        if options.predictor == Predictor::Polynomial && contiguous && constraints.count() == 0 {
            for &d in &path.control_nodes()[1..] {
                for j in 1..=s {
                    let end = if j == s { 1.0 } else { 0.0 };
                    extrapolation.push(path.basis(1.0 + d, j) - end);
                }
            }
        }
        let checked = |len: usize| {
            if model.has_step_check() {
                vec![0.0; len]
            } else {
                Vec::new()
            }
        };
        Self {
            extrapolation,
            checked_guess: checked(unknowns),
            checked_end: checked(model.dim()),
            checked_turns: Vec::new(),
            fraction: h / options.h,
            aux: None,
            check_aux: None,
            last_size: h,
            newton: Newton::new(
                AutoLu::for_size(
                    stage_solver(
                        options.solver,
                        step.jacobian_is_constant(model, constraints),
                    ),
                    unknowns,
                ),
                newton_options(model, options, !contiguous),
            ),
            x: vec![0.0; unknowns],
            past: vec![0.0; PAST_DEPTH * unknowns],
            known: 0,
            scratch: vec![0.0; unknowns],
            linear_end: LinearEnd {
                start: Vec::new(),
                cols: Vec::new(),
                values: Vec::new(),
                guess: vec![0.0; unknowns],
                at_guess: vec![0.0; model.dim()],
            },
            step,
        }
    }

    /// The substeps of `options.scheme`.
    fn for_scheme<M: Model, C: Constraints>(
        model: &M,
        constraints: &C,
        options: &IntegratorOptions,
    ) -> Vec<Self> {
        let mut stages = Vec::new();
        for &gamma in options.composition.gammas() {
            let h = gamma * options.h;
            match options.scheme {
                Scheme::Plus => {
                    stages.push(Self::new(model, constraints, options, Flavour::Plus, h))
                }
                Scheme::Minus => {
                    stages.push(Self::new(model, constraints, options, Flavour::Minus, h));
                }
                Scheme::Symmetric => {
                    stages.push(Self::new(
                        model,
                        constraints,
                        options,
                        Flavour::Minus,
                        0.5 * h,
                    ));
                    stages.push(Self::new(
                        model,
                        constraints,
                        options,
                        Flavour::Plus,
                        0.5 * h,
                    ));
                }
            }
        }
        stages
    }
}

struct StepSystem<'a, M: ?Sized, C: ?Sized> {
    model: &'a M,
    constraints: &'a C,
    step: &'a mut ForcedDiracStep,
    constant: bool,
    /// When set, the first residual evaluation (at the guess) also writes the end momentum there.
    end_momentum: Option<&'a mut [f64]>,
}

impl<M: Model + ?Sized, C: Constraints + ?Sized> NonlinearSystem for StepSystem<'_, M, C> {
    fn len(&self) -> usize {
        self.step.unknowns()
    }
    fn residual(&mut self, x: &[f64], r: &mut [f64]) {
        match self.end_momentum.take() {
            Some(p1) => {
                self.step
                    .residual_and_end_momentum(self.model, self.constraints, x, r, p1);
            }
            None => self.step.residual(self.model, self.constraints, x, r),
        }
    }
    fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
        self.step.jacobian(self.model, self.constraints, x, jac);
    }
    fn jacobian_is_constant(&self) -> bool {
        self.constant
    }
    fn constant_magnitudes(&mut self, out: &mut [f64]) {
        self.step.constant_magnitudes(self.constraints, out);
    }
    fn update_fraction(&mut self, x: &[f64], update: &[f64]) -> f64 {
        if self.constant || !self.model.has_update_limit() {
            return 1.0;
        }
        self.step.update_fraction(self.model, x, update)
    }
}

impl<M: Model, C: Constraints> Integrator<M, C> {
    /// An integrator at `q = 0, p = 0, t = 0`; set the state with [`Integrator::initialise`] or
    /// [`Integrator::set_state`], which also check the constraint rows at the initial point.
    pub fn new(model: M, constraints: C, options: IntegratorOptions) -> Result<Self, SimError> {
        if !(options.h > 0.0 && options.h.is_finite()) {
            return Err(SimError::StepSize(options.h));
        }
        let constraints = RowSubset::new(constraints, &[]);
        let stages = Stage::for_scheme(&model, &constraints, &options);
        let explicit = explicit_step(&model, &constraints, &options);
        let n = model.dim();
        Ok(Self {
            explicit,
            control_nodes: options.discretisation.path().control_nodes().to_vec(),
            model,
            constraints,
            options,
            warnings: Vec::new(),
            stages,
            q: vec![0.0; n],
            p: vec![0.0; n],
            v0: vec![0.0; n],
            t0: 0.0,
            t: 0.0,
            k: 0,
            p_next: vec![0.0; n],
            stats: NewtonStats::default(),
            affine: Affine::Unknown,
            impulse: Vec::new(),
            saved_q: vec![0.0; n],
            saved_p: vec![0.0; n],
            saved_impulse: Vec::new(),
            inner_states: None,
            counters: StepCounters::default(),
            free_momenta: Vec::new(),
            history: None,
        })
    }

    fn check_len(&self, what: &'static str, v: &[f64]) -> Result<(), SimError> {
        if v.len() == self.model.dim() {
            Ok(())
        } else {
            Err(SimError::Dimension {
                what,
                got: v.len(),
                expected: self.model.dim(),
            })
        }
    }

    /// Checks that `q` satisfies every holonomic constraint of the full set (before redundant rows
    /// are dropped, so two contradicting constraints are reported rather than pruned).
    fn check_positions(&self, q: &[f64]) -> Result<(), SimError> {
        let full = self.constraints.inner();
        let m = full.count();
        if m == 0 {
            return Ok(());
        }
        let mut g = vec![0.0; m];
        full.values(q, &mut g);
        let qn = q.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        for (a, ga) in g.iter().enumerate() {
            if full.kind(a) == ConstraintKind::Holonomic && ga.abs() > HOLONOMIC_TOL * (1.0 + qn) {
                return Err(SimError::InconsistentInitialCondition {
                    constraint: full.name(a),
                    residual: *ga,
                });
            }
        }
        Ok(())
    }

    /// Checks the constraint rows at `q`: empty rows are an error; rows that depend linearly on
    /// earlier ones (KCL written at every node, a closed kinematic loop) are dropped with a
    /// warning naming them, and the step equations are rebuilt without them.
    fn prune_constraints(&mut self, q: &[f64]) -> Result<(), SimError> {
        let full = self.constraints.inner();
        let m = full.count();
        if m == 0 {
            return Ok(());
        }
        let mut forms = Triplets::new();
        forms.begin();
        full.forms(q, &mut forms);
        let analysis = analyse_rows(m, self.model.dim(), &forms, REDUNDANCY_TOL);
        if let Some(&a) = analysis.empty.first() {
            return Err(SimError::EmptyConstraint {
                constraint: full.name(a),
            });
        }
        let unchanged = self.constraints.count() + analysis.dependent.len() == m
            && analysis
                .dependent
                .iter()
                .all(|a| !self.constraints.kept().contains(a));
        if unchanged {
            return Ok(());
        }
        for &a in &analysis.dependent {
            self.warnings.push(format!(
                "constraint {} is linearly dependent on the others at the initial point; dropped",
                full.name(a)
            ));
        }
        self.constraints.set_dropped(&analysis.dependent);
        self.stages = Stage::for_scheme(&self.model, &self.constraints, &self.options);
        self.explicit = explicit_step(&self.model, &self.constraints, &self.options);
        self.affine = Affine::Unknown;
        Ok(())
    }

    /// Warnings raised while setting up (dropped redundant constraints).
    #[must_use]
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Sets `(q, p, t)` directly. `p` must satisfy the primary constraints `p = ∂L/∂v` in
    /// degenerate directions; prefer [`Integrator::initialise`] from velocities.
    pub fn set_state(&mut self, q: &[f64], p: &[f64], t: f64) -> Result<(), SimError> {
        self.check_len("q", q)?;
        self.check_len("p", p)?;
        self.check_positions(q)?;
        self.prune_constraints(q)?;
        self.q.copy_from_slice(q);
        self.p.copy_from_slice(p);
        self.v0.fill(0.0);
        self.free_momenta = self.free_momenta(q, p);
        self.t0 = t;
        self.t = t;
        self.k = 0;
        self.start_history();
        Ok(())
    }

    /// Consistent initialisation from positions and velocities: checks holonomic constraints at
    /// `q`, projects `v` onto `ker A(q)` (Euclidean projection), and sets `p = ∂L/∂v(q, v)`.
    pub fn initialise(&mut self, q: &[f64], v: &[f64], t: f64) -> Result<(), SimError> {
        self.initialise_holding(q, v, &[], t)
    }

    /// [`Integrator::initialise`] keeping the velocities marked in `held` (an inductor's stated
    /// `IC=` current) at their values: only the others move onto `ker A(q)`, by the least
    /// Euclidean change. An empty `held` holds none.
    ///
    /// Held velocities that violate a constraint no free velocity enters (two inductors in
    /// series stated with different currents) contradict each other; they are released and
    /// reconciled by the least change, as without `held`.
    ///
    /// # Errors
    /// As [`Integrator::initialise`]: [`SimError::InconsistentInitialCondition`] when the
    /// velocities cannot satisfy the constraints.
    pub fn initialise_holding(
        &mut self,
        q: &[f64],
        v: &[f64],
        held: &[bool],
        t: f64,
    ) -> Result<(), SimError> {
        self.check_len("q", q)?;
        self.check_len("v", v)?;
        self.check_positions(q)?;
        self.prune_constraints(q)?;
        let n = q.len();
        let m = self.constraints.count();
        let projected = if m > 0 && v.iter().any(|x| *x != 0.0) {
            project_velocity(&self.constraints, q, v, held)?
        } else {
            v.to_vec()
        };
        let mut lq = vec![0.0; n];
        let mut p = vec![0.0; n];
        self.model
            .lagrangian_gradient(q, &projected, &mut lq, &mut p);
        self.q.copy_from_slice(q);
        self.p.copy_from_slice(&p);
        self.v0.copy_from_slice(&projected);
        self.free_momenta = self.free_momenta(q, &p);
        self.t0 = t;
        self.t = t;
        self.k = 0;
        self.start_history();
        Ok(())
    }

    /// Coordinates whose velocity enters neither a second derivative of `L` nor a constraint row
    /// (the junction flux of a diode without charge, a current source's flux), with their
    /// momentum `p = ∂L/∂v`, which is then a constant. Such a coordinate's step equations say
    /// its force vanishes and leave its momentum at that constant; a solved step leaves its
    /// round-off there instead, which the next step would have to cancel, so the error would
    /// random-walk and, through a tiny conductance (a reverse-biased junction's GMIN), move a
    /// voltage by millivolts. The momentum is reset to the constant after every substep.
    fn free_momenta(&self, q: &[f64], p: &[f64]) -> Vec<(usize, f64)> {
        let n = q.len();
        let mut involved = vec![false; n];
        let mut hessian = LagrangianHessian::default();
        hessian.begin();
        self.model.lagrangian_hessian(q, &self.v0, &mut hessian);
        for (i, j, _) in hessian.vv.iter() {
            involved[i] = true;
            involved[j] = true;
        }
        for (_, j, _) in hessian.qv.iter() {
            involved[j] = true;
        }
        let mut forms = Triplets::new();
        forms.begin();
        self.constraints.inner().forms(q, &mut forms);
        for (_, j, _) in forms.iter() {
            involved[j] = true;
        }
        (0..n)
            .filter(|&i| !involved[i])
            .map(|i| (i, p[i]))
            .collect()
    }

    /// Starts the truncation-error history at the current state (see
    /// [`IntegratorOptions::truncation`]); none when the control is off or nothing stores energy.
    fn start_history(&mut self) {
        self.history = self.options.truncation.and_then(|_| {
            let mut history = History::for_model(
                &self.model,
                self.active_constraints(),
                &self.q,
                &self.v0,
                self.t,
            );
            history.start(self.t, &self.q, &self.p);
            (!history.is_empty()).then_some(history)
        });
    }

    /// Puts the constant momenta back after a substep (see [`Integrator::free_momenta`]).
    fn reset_free_momenta(&mut self) {
        for &(i, p) in &self.free_momenta {
            self.p[i] = p;
        }
    }

    /// Advances one step (one or two substeps, depending on the scheme).
    ///
    /// A state component that lands in the subnormal range (below `f64::MIN_POSITIVE` ≈ 2.2e-308
    /// in magnitude) is set to zero: a decaying circuit otherwise ends in a round-off limit cycle
    /// among subnormal numbers, where every operation is several times slower (the damped seed
    /// loop: 3.44 µs per step against 0.80 over 10⁷ steps), and a subnormal number carries fewer
    /// significant bits than the state's round-off anyway.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let report = self.step_unflushed()?;
        flush_subnormals(&mut self.q);
        flush_subnormals(&mut self.p);
        Ok(report)
    }

    fn step_unflushed(&mut self) -> Result<StepReport, SimError> {
        if let Some(states) = &mut self.inner_states {
            states.clear();
        }
        if matches!(self.affine, Affine::Unknown) {
            self.affine = self.build_affine()?;
        }
        self.impulse.clear();
        self.impulse.resize(self.constraints.count(), 0.0);
        let ramp = self.options.start_ramp.filter(|_| self.k == 0);
        if let (None, Affine::Map { x, p, x0, p0, z }) = (ramp, &mut self.affine) {
            let n = self.q.len();
            z[..n].copy_from_slice(&self.q);
            z[n..].copy_from_slice(&self.p);
            let stage = &mut self.stages[0];
            for ((xi, row), o) in stage.x.iter_mut().zip(x.chunks_exact(2 * n)).zip(x0.iter()) {
                *xi = o + row.iter().zip(z.iter()).map(|(a, b)| a * b).sum::<f64>();
            }
            for ((pi, row), o) in self.p.iter_mut().zip(p.chunks_exact(2 * n)).zip(p0.iter()) {
                *pi = o + row.iter().zip(z.iter()).map(|(a, b)| a * b).sum::<f64>();
            }
            stage.step.set_start(&self.q, &self.p, self.t);
            stage.step.end_position(&stage.x, &mut self.q);
            Self::add_impulse(&mut self.impulse, stage);
            self.k += 1;
            self.t = self.t0 + self.k as f64 * self.options.h;
            self.counters.substeps += 1;
            return Ok(StepReport {
                newton: NewtonStats::default(),
            });
        }
        let h = self.options.h;
        let t_end = self.t0 + (self.k + 1) as f64 * h;
        // An explicit step that nothing splits (no start ramp, no source breakpoint ahead, no
        // error control) is one pass over its substeps, without the general path's bookkeeping
        // (about 6 % of a Hénon–Heiles step); if it fails, the general path takes it again and
        // cuts it.
        let unsplit = !self.options.breakpoints
            || (self.options.corner_ramp.is_none() && self.model.next_breakpoint(self.t).is_none());
        if ramp.is_none() && self.explicit.is_some() && self.history.is_none() && unsplit {
            let start = self.t;
            let size = t_end - start;
            self.saved_q.copy_from_slice(&self.q);
            self.saved_p.copy_from_slice(&self.p);
            if self.explicit_advance(size, self.is_regular(size)).is_ok() {
                self.counters.substeps += 1;
                self.k += 1;
                self.t = t_end;
                return Ok(StepReport {
                    newton: NewtonStats::default(),
                });
            }
            self.q.copy_from_slice(&self.saved_q);
            self.p.copy_from_slice(&self.saved_p);
            self.t = start;
        }
        let mut stats = NewtonStats::default();
        match ramp {
            Some(ramp) => {
                for (size, end) in ramp.pieces(self.t, h, t_end) {
                    self.advance_to(size, end, false, &mut stats)?;
                    self.counters.ramp_substeps += 1;
                }
            }
            None => {
                let size = t_end - self.t;
                self.advance_to(size, t_end, true, &mut stats)?;
            }
        }
        self.k += 1;
        // t_k = t₀ + k h, not a running sum (which drifts by ~k·ε·h).
        self.t = t_end;
        self.stats.accumulate(&stats);
        Ok(StepReport { newton: stats })
    }

    /// Advances from `t` to `end` by one substep of `size` (`end − t` up to rounding), split
    /// at the source breakpoints inside it when [`IntegratorOptions::breakpoints`] is on. With
    /// `corners` and [`IntegratorOptions::corner_ramp`], the stretch after a breakpoint (one
    /// inside the substep, or one at `t`) is taken as the ramp's substeps.
    fn advance_to(
        &mut self,
        size: f64,
        end: f64,
        corners: bool,
        stats: &mut NewtonStats,
    ) -> Result<(), SimError> {
        let h = self.options.h;
        let start = self.t;
        let corner_ramp = self
            .options
            .corner_ramp
            .filter(|_| corners && self.options.breakpoints);
        let mut after_corner = corner_ramp.is_some() && self.corner_at(start);
        loop {
            let t = self.t;
            let mut corner = if self.options.breakpoints {
                self.model.next_breakpoint(t)
            } else {
                None
            };
            while let Some(b) = corner.filter(|b| *b <= t + BREAKPOINT_SNAP * h) {
                corner = self.model.next_breakpoint(b);
            }
            let stop = corner.filter(|b| *b < end - BREAKPOINT_SNAP * h);
            match (corner_ramp.filter(|_| after_corner), stop) {
                (Some(ramp), _) => {
                    let target = stop.unwrap_or(end);
                    self.ramp_to(ramp, target, stats)?;
                }
                (None, Some(b)) => stats.accumulate(&self.advance(b - t, 0)?),
                (None, None) => {
                    // Unsplit, the substep keeps its exact size (the ramp's repeated sizes
                    // then reuse one factorisation).
                    let rest = if t == start { size } else { end - t };
                    stats.accumulate(&self.advance(rest, 0)?);
                }
            }
            let Some(b) = stop else { break };
            self.counters.breakpoint_substeps += 1;
            self.t = b;
            after_corner = true;
            // A source's derivative jumps here: differences across it are no estimate.
            if let Some(history) = &mut self.history {
                history.restart(b, &self.q, &self.p);
            }
        }
        self.t = end;
        Ok(())
    }

    /// Whether a source breakpoint lies at `t` (within the snapping distance).
    fn corner_at(&self, t: f64) -> bool {
        let snap = BREAKPOINT_SNAP * self.options.h;
        self.model
            .next_breakpoint(t - snap)
            .is_some_and(|b| b <= t + snap)
    }

    /// Advances from `t` to `target` by the ramp's substeps (`ramp.fraction(j)` of the stretch,
    /// the last one ending on `target` exactly).
    fn ramp_to(
        &mut self,
        ramp: StartRamp,
        target: f64,
        stats: &mut NewtonStats,
    ) -> Result<(), SimError> {
        for (size, end) in ramp.pieces(self.t, target - self.t, target) {
            stats.accumulate(&self.advance(size, 0)?);
            self.t = end;
            self.counters.ramp_substeps += 1;
        }
        Ok(())
    }

    /// Advances by `size` (every substep of the scheme, scaled), halving it up to
    /// [`MAX_CUT_DEPTH`] times while Newton fails.
    /// Whether a substep of `size` from the current time is the regular step: `t_{k+1} − t_k` is
    /// `h` up to the rounding of the times, a few ulps of `t` (at t = 10⁴ and h = 0.0125 that is
    /// 1.5e-10 of h), and is still taken with its predictor and kept factorisation.
    fn is_regular(&self, size: f64) -> bool {
        let h = self.options.h;
        (size - h).abs() <= 1e-12 * h + 4.0 * f64::EPSILON * (self.t.abs() + size.abs())
    }

    fn advance(&mut self, size: f64, depth: u32) -> Result<NewtonStats, SimError> {
        let regular = self.is_regular(size);
        // The state before this attempt, restored if it fails (preallocated for the first
        // attempt, so a step that needs no cut allocates nothing).
        let saved = if self.explicit.is_none() && self.stages.len() == 1 && self.history.is_none() {
            Saved::Untouched
        } else if depth == 0 {
            self.saved_q.copy_from_slice(&self.q);
            self.saved_p.copy_from_slice(&self.p);
            self.saved_impulse.clone_from(&self.impulse);
            Saved::Buffers
        } else {
            Saved::Copy(self.q.clone(), self.p.clone(), self.impulse.clone())
        };
        let t = self.t;
        let mut stats = NewtonStats::default();
        // Explicit steps take every substep in one pass; implicit ones solve them one by one.
        let result = if self.explicit.is_some() {
            self.explicit_advance(size, regular)
        } else {
            self.implicit_advance(size, regular, &mut stats)
        };
        let error = match result {
            Ok(()) => return self.accept_or_refine(size, depth, t, saved, stats),
            Err(e) => e,
        };
        let retry = matches!(
            &error,
            SimError::Newton {
                source: NewtonError::NotConverged { .. }
                    | NewtonError::NonFiniteResidual { .. }
                    | NewtonError::Linear {
                        source: LinearSolveError::NumericallySingular { .. }
                            | LinearSolveError::NonFinite { .. },
                        ..
                    },
                ..
            } | SimError::StepRejected { .. }
        );
        if !retry || depth >= MAX_CUT_DEPTH {
            return Err(match error {
                SimError::Newton {
                    step,
                    t,
                    source,
                    likely_cause,
                } if depth > 0 => SimError::Newton {
                    step,
                    t,
                    source,
                    likely_cause: format!(
                        "{likely_cause} (the step was cut {depth} times, to h/{}, without success)",
                        1u64 << depth
                    ),
                },
                SimError::StepRejected { step, t, reason } if depth > 0 => SimError::StepRejected {
                    step,
                    t,
                    reason: format!(
                        "{reason}; the step was cut {depth} times, to h/{}, without success",
                        1u64 << depth
                    ),
                },
                other => other,
            });
        }
        self.restore(&saved, t);
        self.counters.step_cuts += 1;
        self.advance_in_pieces(size, depth, 1, t, stats)
    }

    /// Puts back the state before a failed or rejected attempt at time `t`.
    fn restore(&mut self, saved: &Saved, t: f64) {
        match saved {
            Saved::Untouched => {}
            Saved::Buffers => {
                self.q.copy_from_slice(&self.saved_q);
                self.p.copy_from_slice(&self.saved_p);
                self.impulse.clone_from(&self.saved_impulse);
            }
            Saved::Copy(q, p, impulse) => {
                self.q.copy_from_slice(q);
                self.p.copy_from_slice(p);
                self.impulse.clone_from(impulse);
            }
        }
        self.t = t;
    }

    /// Advances from `t` by `size` as `2^halvings` equal pieces, each one [`Integrator::advance`]
    /// at depth `depth + halvings`, adding their cost to `stats`.
    fn advance_in_pieces(
        &mut self,
        size: f64,
        depth: u32,
        halvings: u32,
        t: f64,
        mut stats: NewtonStats,
    ) -> Result<NewtonStats, SimError> {
        let pieces = 1u64 << halvings;
        let piece = size / pieces as f64;
        for j in 0..pieces {
            self.t = t + j as f64 * piece;
            stats.accumulate(&self.advance(piece, depth + halvings)?);
        }
        Ok(stats)
    }

    /// After a solved substep of `size` from `t`: keeps it, or, when the truncation-error test
    /// rejects it (and `depth` leaves room), restores the state and takes it as `2^m` pieces.
    fn accept_or_refine(
        &mut self,
        size: f64,
        depth: u32,
        t: f64,
        saved: Saved,
        mut stats: NewtonStats,
    ) -> Result<NewtonStats, SimError> {
        let rule = self
            .options
            .truncation
            .filter(|rule| depth < rule.max_depth && self.history.is_some());
        let short = self.history.as_ref().is_some_and(History::is_short);
        let verdict = match (rule, &self.history) {
            (Some(rule), Some(_)) if short => {
                self.judge_halves(&rule, size, t, &saved, None, &mut stats)
            }
            (Some(rule), Some(history)) => {
                let window = YOUNG_STEPS * self.options.h;
                match history.judge(&rule, t + size, (&self.q, &self.p), window) {
                    Verdict::Doubtful(only) => {
                        self.judge_halves(&rule, size, t, &saved, Some(&only), &mut stats)
                    }
                    verdict => verdict,
                }
            }
            _ => Verdict::Accept,
        };
        let verdict = match (verdict, rule) {
            (Verdict::Split(m), Some(rule)) => Some(m.min(rule.max_depth - depth)),
            _ => None,
        };
        if let Some(halvings) = verdict {
            self.restore(&saved, t);
            self.counters.refinements += 1;
            return self.advance_in_pieces(size, depth, halvings, t, stats);
        }
        self.counters.substeps += 1;
        if let Some(history) = &mut self.history {
            history.push(t + size, &self.q, &self.p);
        }
        let step_end = self.t0 + (self.k + 1) as f64 * self.options.h;
        if let Some(states) = &mut self.inner_states
            && t + size < step_end - BREAKPOINT_SNAP * self.options.h
        {
            states.push(InnerState {
                t: t + size,
                q: self.q.clone(),
                p: self.p.clone(),
            });
        }
        Ok(stats)
    }

    /// Judges the substep of `size` from `t` just solved by taking it again as two halves from
    /// the `saved` start ([`History::judge_halves`]); the whole substep's end is put back
    /// whatever the verdict (a split restores the start itself). Halves that fail to solve
    /// split the substep too.
    fn judge_halves(
        &mut self,
        rule: &TruncationControl,
        size: f64,
        t: f64,
        saved: &Saved,
        only: Option<&[usize]>,
        stats: &mut NewtonStats,
    ) -> Verdict {
        let whole = (self.q.clone(), self.p.clone(), self.impulse.clone());
        // The stages' steps (their start, which diagnostics such as the constraint residual
        // read after the step) and last solutions (which the next substep's guess is made
        // from): put back with the whole substep, and the halves solved with their own Newton,
        // so that a check that keeps it changes nothing after it but the Newton counts.
        let kept: Vec<_> = self
            .stages
            .iter()
            .map(|stage| {
                (
                    stage.step.clone(),
                    stage.x.clone(),
                    stage.past.clone(),
                    stage.known,
                    stage.last_size,
                )
            })
            .collect();
        let counters = self.counters;
        for stage in &mut self.stages {
            std::mem::swap(&mut stage.aux, &mut stage.check_aux);
        }
        self.restore(saved, t);
        let half = 0.5 * size;
        let mut solved = Ok(());
        for j in 0..2 {
            self.t = t + f64::from(j) * half;
            solved = if self.explicit.is_some() {
                self.explicit_advance(half, false)
            } else {
                self.implicit_advance(half, false, stats)
            };
            if solved.is_err() {
                break;
            }
        }
        let verdict = match (solved, &self.history) {
            (Ok(()), Some(history)) => {
                let (whole, halves) = ((&whole.0[..], &whole.1[..]), (&self.q[..], &self.p[..]));
                history.judge_halves(rule, t + size, whole, halves, only)
            }
            (Ok(()), None) => Verdict::Accept,
            (Err(_), _) => Verdict::Split(1),
        };
        let (q, p, impulse) = whole;
        self.q = q;
        self.p = p;
        self.impulse = impulse;
        // The halves are no accepted substeps: their turn checks are not the run's.
        self.counters = counters;
        for (stage, (step, x, past, known, last_size)) in self.stages.iter_mut().zip(kept) {
            std::mem::swap(&mut stage.aux, &mut stage.check_aux);
            stage.step = step;
            stage.x = x;
            stage.past = past;
            stage.known = known;
            stage.last_size = last_size;
        }
        self.t = t + size;
        verdict
    }

    /// Substep `i` at a size other than its regular one, solved with the stage's auxiliary Newton
    /// (the regular factorisation is kept).
    fn substep_sized(&mut self, i: usize, size: f64) -> Result<NewtonStats, SimError> {
        let stage = &mut self.stages[i];
        let nominal = stage.step.step_size();
        stage.step.set_step_size(size);
        stage.step.set_start(&self.q, &self.p, self.t);
        if self.k == 0 && stage.last_size == nominal {
            stage
                .step
                .straight_guess(&self.control_nodes, &self.v0, &mut stage.x);
        } else {
            let ratio = size / stage.last_size;
            for x in &mut stage.x {
                *x *= ratio;
            }
        }
        let solver = stage_solver(
            self.options.solver,
            stage
                .step
                .jacobian_is_constant(&self.model, &self.constraints),
        );
        stage.ready_aux(solver, size);
        stage.keep_guess();
        let result = self.solve_stage(i, false, true);
        let stage = &mut self.stages[i];
        stage.step.set_step_size(nominal);
        stage.last_size = size;
        let mut stats = result?;
        self.check_step(i)?;
        stats.accumulate(&self.verify_step(i, size)?);
        let stage = &mut self.stages[i];
        stage.step.set_step_size(size);
        stage
            .step
            .end_momentum(&self.model, &stage.x, &mut self.p_next);
        stage.step.end_position(&stage.x, &mut self.q);
        stage.step.set_step_size(nominal);
        // The next regular step starts its predictor afresh from this solution.
        stage.known = 0;
        Self::add_impulse(&mut self.impulse, stage);
        std::mem::swap(&mut self.p, &mut self.p_next);
        self.reset_free_momenta();
        self.t += size;
        Ok(stats)
    }

    /// Stage `i`'s solved substep from the current state, judged by the model
    /// ([`Model::check_step`]); a rejected solution is replaced by the guess it started from
    /// (the cut's pieces scale it), and the state is untouched.
    fn check_step(&mut self, i: usize) -> Result<(), SimError> {
        let stage = &mut self.stages[i];
        if stage.checked_guess.is_empty() {
            return Ok(());
        }
        stage.step.end_position(&stage.x, &mut stage.checked_end);
        match self.model.check_step(&self.q, &stage.checked_end) {
            Ok(()) => Ok(()),
            Err(reason) => Err(self.reject_root(i, reason)),
        }
    }

    /// Stage `i`'s solved substep of `size` (checked by [`Integrator::check_step`], the state
    /// untouched), checked against two half steps when it turns some body by more than
    /// [`VERIFY_TURN`]; returns the half steps' Newton cost. The discrete rigid body's step
    /// equations have roots besides the one the motion takes; at a long step Newton can land on
    /// one that turns a body by less than a quarter turn (the spatial four-bar at h = 0.03: its
    /// crank turned 1.27 rad in one step and its energy jumped from 0.56 to 0.93 J). Two half
    /// steps from the same state land within their local error of the full step's end on the
    /// motion's branch, and far from it when the full step took another root: the step is
    /// rejected (and cut) when, for some body, the angle between the two ends exceeds
    /// [`VERIFY_RATIO`] of the half steps' turn of that body (at least [`VERIFY_FLOOR`]), or when
    /// a half step fails. Body by body, so that a body spinning fast beside the mechanism does
    /// not raise the bound for the others. The half steps are solved aside (the stage's
    /// auxiliary Newton) and leave the solution, the state and the predictor as they were.
    fn verify_step(&mut self, i: usize, size: f64) -> Result<NewtonStats, SimError> {
        let stage = &mut self.stages[i];
        if stage.checked_guess.is_empty() {
            return Ok(NewtonStats::default());
        }
        stage.checked_turns.clear();
        self.model
            .step_turns(&self.q, &stage.checked_end, &mut stage.checked_turns);
        let full_turn = stage.checked_turns.iter().copied().fold(0.0, f64::max);
        if full_turn <= VERIFY_TURN {
            return Ok(NewtonStats::default());
        }
        self.counters.turn_checks += 1;
        let full_turns = std::mem::take(&mut stage.checked_turns);
        let full = stage.x.clone();
        let mut stats = NewtonStats::default();
        let halves = self.half_steps(i, size, &full, &mut stats);
        let stage = &mut self.stages[i];
        stage.step.set_start(&self.q, &self.p, self.t);
        stage.x.copy_from_slice(&full);
        let reason = match &halves {
            Ok(end) => {
                let (mut apart, mut turns) = (Vec::new(), Vec::new());
                self.model.step_turns(&stage.checked_end, end, &mut apart);
                self.model.step_turns(&self.q, end, &mut turns);
                apart
                    .iter()
                    .zip(&turns)
                    .zip(&full_turns)
                    .find(|((a, t), _)| **a > VERIFY_RATIO * t.max(VERIFY_FLOOR))
                    .map(|((apart, turn), full)| format!(
                        "a body turned by {full:.3} rad in one step, where two half steps turn it by {turn:.3} rad and end {apart:.3} rad away: a root of the step equations that the motion does not take"
                    ))
            }
            Err(why) => Some(format!(
                "a body turned by {full_turn:.3} rad in one step, and the two half steps that check it failed ({why})"
            )),
        };
        stage.checked_turns = full_turns;
        match reason {
            None => Ok(stats),
            Some(reason) => Err(self.reject_root(i, reason)),
        }
    }

    /// Rejects stage `i`'s solved substep as a root off the motion's branch: the solution is
    /// replaced by the guess it started from (the cut's pieces scale it) and counted.
    fn reject_root(&mut self, i: usize, reason: String) -> SimError {
        let stage = &mut self.stages[i];
        stage.x.copy_from_slice(&stage.checked_guess);
        self.counters.spurious_roots += 1;
        SimError::StepRejected {
            step: self.k,
            t: self.t,
            reason,
        }
    }

    /// The end position of two half steps of stage `i` from the current state, the first from
    /// the full step's solution `full` scaled to its size; the stage's step size, start and
    /// solution are left to the caller to put back.
    fn half_steps(
        &mut self,
        i: usize,
        size: f64,
        full: &[f64],
        stats: &mut NewtonStats,
    ) -> Result<Vec<f64>, String> {
        let half = size / 2.0;
        let (mut q, mut p) = (self.q.clone(), self.p.clone());
        let mut end = vec![0.0; q.len()];
        let mut p_end = vec![0.0; p.len()];
        let stage = &mut self.stages[i];
        let nominal = stage.step.step_size();
        for (x, f) in stage.x.iter_mut().zip(full) {
            *x = 0.5 * f;
        }
        stage.ready_aux(stage_solver(self.options.solver, false), half);
        let mut outcome = Ok(());
        for piece in 0..2 {
            let stage = &mut self.stages[i];
            stage.step.set_step_size(half);
            stage
                .step
                .set_start(&q, &p, self.t + f64::from(piece) * half);
            let solved = self.solve_stage(i, false, true);
            let stage = &mut self.stages[i];
            match solved {
                Ok(solved) => stats.accumulate(&solved),
                Err(e) => {
                    outcome = Err(e.to_string());
                    break;
                }
            }
            stage.step.end_position(&stage.x, &mut end);
            if let Err(why) = self.model.check_step(&q, &end) {
                outcome = Err(why);
                break;
            }
            stage.step.end_momentum(&self.model, &stage.x, &mut p_end);
            q.copy_from_slice(&end);
            p.copy_from_slice(&p_end);
        }
        self.stages[i].step.set_step_size(nominal);
        outcome.map(|()| q)
    }

    /// Adds every multiplier block of stage `stage`'s solution to `impulse`.
    fn add_impulse(impulse: &mut [f64], stage: &Stage) {
        let m = impulse.len();
        for j in 0..stage.step.degree() {
            let o = stage.step.multiplier_offset(j);
            for (acc, l) in impulse.iter_mut().zip(&stage.x[o..o + m]) {
                *acc += l;
            }
        }
    }

    /// Solves stage `i`'s step equations from its current start and guess, reporting a failure
    /// with the step, the time and the likely cause.
    /// With `end_momentum`, the residual at the guess also writes `p_{k+1}` there into the
    /// stage's [`LinearEnd`].
    fn solve_stage(
        &mut self,
        i: usize,
        end_momentum: bool,
        aux: bool,
    ) -> Result<NewtonStats, SimError> {
        let stage = &mut self.stages[i];
        let newton = match (&mut stage.aux, aux) {
            (Some((newton, _)), true) => newton,
            _ => &mut stage.newton,
        };
        let mut system = StepSystem {
            model: &self.model,
            constraints: &self.constraints,
            constant: stage
                .step
                .jacobian_is_constant(&self.model, &self.constraints),
            step: &mut stage.step,
            end_momentum: end_momentum.then_some(&mut stage.linear_end.at_guess[..]),
        };
        match newton.solve(&mut system, &mut stage.x) {
            Ok(stats) => Ok(stats),
            Err(source) => {
                // A model that checks its steps starts the cut's pieces from the guess, as after
                // a rejected root: the iterate Newton gave up on can lie anywhere (on a rigid
                // body, turned by radians), and scaled down it still points there.
                if !stage.checked_guess.is_empty() {
                    stage.x.copy_from_slice(&stage.checked_guess);
                }
                let likely_cause = self.likely_cause(&source);
                Err(SimError::Newton {
                    step: self.k,
                    t: self.t,
                    source,
                    likely_cause,
                })
            }
        }
    }

    /// Advances by `size` through every substep of the scheme, each a Newton solve (at its
    /// regular size, or scaled to `size`), adding their cost to `stats`; stops at the first failure.
    fn implicit_advance(
        &mut self,
        size: f64,
        regular: bool,
        stats: &mut NewtonStats,
    ) -> Result<(), SimError> {
        for i in 0..self.stages.len() {
            let solved = if regular {
                self.substep(i)
            } else {
                let fraction = self.stages[i].fraction;
                self.substep_sized(i, fraction * size)
            }?;
            stats.accumulate(&solved);
        }
        Ok(())
    }

    /// Advances by `size` with the explicit Störmer–Verlet step, every substep of the scheme in
    /// one pass (no Newton iteration): at their regular sizes, or scaled to `size`.
    fn explicit_advance(&mut self, size: f64, regular: bool) -> Result<(), SimError> {
        let t = self.t;
        let n = self.q.len();
        let Some(explicit) = &mut self.explicit else {
            return Ok(());
        };
        let sizes = self.stages.iter().map(|stage| {
            if regular {
                stage.step.step_size()
            } else {
                stage.fraction * size
            }
        });
        let composed = explicit.compose(&self.model, &mut self.q, &mut self.p, t, sizes);
        if let Some(last) = self.stages.last_mut() {
            last.x[..n].copy_from_slice(explicit.last_increment());
        }
        if let Err(equation) = composed {
            let source = NewtonError::NonFiniteResidual {
                equation,
                iterations: 0,
            };
            let likely_cause = self.likely_cause(&source);
            return Err(SimError::Newton {
                step: self.k,
                t,
                source,
                likely_cause,
            });
        }
        self.t += size;
        Ok(())
    }

    fn substep(&mut self, i: usize) -> Result<NewtonStats, SimError> {
        let stage = &mut self.stages[i];
        stage.step.set_start(&self.q, &self.p, self.t);
        // After the first step the guess extrapolates the previous solutions (the last still in
        // `stage.x`): constant (the increments of a constant velocity) after one step, then of
        // one degree more per step up to a cubic in k, which saves Newton iterations on
        // nonlinear models; linear models are solved exactly by one update from any guess.
        let constant = stage
            .step
            .jacobian_is_constant(&self.model, &self.constraints);
        let nominal = stage.step.step_size();
        if stage.last_size != nominal {
            // After a substep of another size: scale its solution, extrapolate nothing.
            let ratio = nominal / stage.last_size;
            for x in &mut stage.x {
                *x *= ratio;
            }
            stage.remember();
            stage.known = 1;
            stage.last_size = nominal;
        } else if self.k == 0 {
            stage
                .step
                .straight_guess(&self.control_nodes, &self.v0, &mut stage.x);
            stage.known = 0;
        } else if !constant {
            // Increments from the previous path polynomial (when chosen), multipliers (and,
            // for the other predictors, increments) extrapolated in k.
            let n = self.q.len();
            let s = stage.step.degree();
            let polynomial = if stage.extrapolation.is_empty() {
                0
            } else {
                s * n
            };
            stage.extrapolate_in_k(polynomial);
            for (l, row) in stage.extrapolation.chunks_exact(s).enumerate() {
                for i in 0..n {
                    stage.x[l * n + i] = row
                        .iter()
                        .enumerate()
                        .map(|(j, e)| e * stage.past[j * n + i])
                        .sum();
                }
            }
            if self.model.has_update_limit() && stage.known > 1 {
                stage.limit_guess(&self.model);
            }
        }
        if constant {
            stage.linear_end.guess.copy_from_slice(&stage.x);
        }
        stage.keep_guess();
        let mut stats = self.solve_stage(i, constant, false)?;
        self.check_step(i)?;
        if !constant {
            stats.accumulate(&self.verify_step(i, nominal)?);
        }
        let stage = &mut self.stages[i];
        if constant {
            let end = &mut stage.linear_end;
            if end.start.is_empty() {
                let mut jacobian = Triplets::new();
                stage
                    .step
                    .end_momentum_jacobian(&self.model, &stage.x, &mut jacobian);
                end.set_jacobian(&jacobian);
            }
            end.end_momentum(&stage.x, &mut self.p_next);
        } else {
            stage
                .step
                .end_momentum(&self.model, &stage.x, &mut self.p_next);
        }
        stage.step.end_position(&stage.x, &mut self.q);
        Self::add_impulse(&mut self.impulse, stage);
        std::mem::swap(&mut self.p, &mut self.p_next);
        self.t += stage.step.step_size();
        self.reset_free_momenta();
        Ok(stats)
    }

    /// Whether steps are explicit Störmer–Verlet steps: the model is separable
    /// ([`Model::separable`], nonsingular mass matrix), no constraint row is active, the
    /// discretisation is the trapezoid rule and [`IntegratorOptions::explicit`] is on. Such steps
    /// do no Newton iterations (every substep of a composition is explicit too).
    #[must_use]
    pub fn uses_explicit(&self) -> bool {
        self.explicit.is_some()
    }

    /// Whether steps are applied as a precomputed linear map (linear autonomous model, constant
    /// constraint forms, one substep, `2n` and the unknown count at most 32). Such steps do no
    /// Newton iterations; [`Integrator::stats`] counts only the set-up.
    #[must_use]
    pub fn uses_affine_map(&self) -> bool {
        matches!(self.affine, Affine::Map { .. })
    }

    /// Builds the affine step map if the model qualifies: the Newton step (exact in one update on
    /// an affine map) is applied to each basis state `e_i` of `(q, p)`.
    fn build_affine(&mut self) -> Result<Affine, SimError> {
        let n = self.q.len();
        // The explicit path is exact and as cheap; the rounded affine map drifts (see
        // [`IntegratorOptions::affine_map`]).
        let qualifies = self.options.affine_map
            && self.options.truncation.is_none()
            && self.explicit.is_none()
            && self.stages.len() == 1
            && self.model.is_autonomous()
            && self.stages[0]
                .step
                .jacobian_is_constant(&self.model, &self.constraints)
            && 2 * n <= AFFINE_LIMIT
            && self.stages[0].step.unknowns() <= AFFINE_LIMIT;
        if !qualifies {
            return Ok(Affine::No);
        }
        let unknowns = self.stages[0].step.unknowns();
        // The stage's solver now only builds the map (2n + 1 solves of one factorisation), so
        // the per-step gain of sparse LU on a constant Jacobian (see [`stage_solver`]) never comes
        // and its symbolic analysis is pure set-up cost: `Auto` follows the size rule here.
        if self.options.solver == SolverChoice::Auto {
            let stage = &mut self.stages[0];
            let options = *stage.newton.options();
            stage.newton = Newton::new(AutoLu::for_size(SolverChoice::Auto, unknowns), options);
        }
        let mut x = vec![0.0; unknowns * 2 * n];
        let mut p = vec![0.0; n * 2 * n];
        let mut column = vec![0.0; 2 * n];
        let mut x0 = vec![0.0; unknowns];
        let mut p0 = vec![0.0; n];
        // Column 2n is the response to z = 0 (the offset); columns 0..2n the responses to e_c.
        for c in (0..=2 * n).rev() {
            column.fill(0.0);
            if c < 2 * n {
                column[c] = 1.0;
            }
            let stage = &mut self.stages[0];
            stage.step.set_start(&column[..n], &column[n..], self.t);
            stage.x.fill(0.0);
            let stats = self.solve_stage(0, false, false)?;
            self.stats.accumulate(&stats);
            let stage = &mut self.stages[0];
            stage
                .step
                .end_momentum(&self.model, &stage.x, &mut self.p_next);
            if c == 2 * n {
                x0.copy_from_slice(&stage.x);
                p0.copy_from_slice(&self.p_next);
                continue;
            }
            for r in 0..unknowns {
                x[r * 2 * n + c] = stage.x[r] - x0[r];
            }
            for r in 0..n {
                p[r * 2 * n + c] = self.p_next[r] - p0[r];
            }
        }
        Ok(Affine::Map {
            x,
            p,
            x0,
            p0,
            z: vec![0.0; 2 * n],
        })
    }

    /// Checks that every substep's Newton matrix can be regular: its pattern (which entries the
    /// model and the constraints stamp, whatever their values; the pattern is fixed, see
    /// [`Triplets`]) must match every equation to its own unknown. When it cannot, the matrix is
    /// singular at every state and every step would fail; the error names the unknowns no
    /// equation set determines (the under-determined part of the Dulmage–Mendelsohn partition)
    /// and the equations that fix their unknowns more than once (the over-determined part).
    /// Call it after [`Integrator::initialise`] (the constraint rows it keeps set the pattern).
    ///
    /// # Errors
    /// [`SimError::StructurallySingular`] when a pattern has no perfect matching.
    pub fn check_structure(&mut self) -> Result<(), SimError> {
        let mut jacobian = Triplets::new();
        for i in 0..self.stages.len() {
            let stage = &mut self.stages[i];
            stage.step.set_start(&self.q, &self.p, self.t);
            jacobian.begin();
            stage
                .step
                .jacobian(&self.model, &self.constraints, &stage.x, &mut jacobian);
            let size = stage.step.unknowns();
            // A zero-free diagonal is a perfect matching: full structural rank, nothing to
            // diagnose (the common case of models with a mass on every coordinate). Otherwise
            // (multiplier rows) a matching search decides, and the partition below is built only
            // when it finds none.
            let mut on_diagonal = vec![false; size];
            for (&r, &c) in jacobian.rows().iter().zip(jacobian.cols()) {
                if r == c {
                    on_diagonal[r] = true;
                }
            }
            if on_diagonal.iter().all(|&d| d)
                || Structure::has_perfect_matching(size, jacobian.rows(), jacobian.cols())
            {
                continue;
            }
            let entries: Vec<(usize, usize)> = jacobian
                .rows()
                .iter()
                .copied()
                .zip(jacobian.cols().iter().copied())
                .collect();
            let structure = Structure::analyse(size, size, &entries, &vec![0; size]);
            if structure.rank() == size {
                continue;
            }
            let mut undetermined: Vec<String> = Vec::new();
            for col in (0..size).filter(|&c| structure.is_underdetermined_col(c)) {
                let name = self.describe_unknown(col);
                if !undetermined.contains(&name) {
                    undetermined.push(name);
                }
            }
            let mut overdetermined: Vec<String> = Vec::new();
            for row in (0..size).filter(|&r| structure.is_overdetermined_row(r)) {
                let name = self.describe_equation(row);
                if !overdetermined.contains(&name) {
                    overdetermined.push(name);
                }
            }
            return Err(SimError::StructurallySingular {
                rank: structure.rank(),
                size,
                undetermined,
                overdetermined,
            });
        }
        Ok(())
    }

    /// Describes equation `row` of the step system.
    #[must_use]
    pub fn describe_equation(&self, row: usize) -> String {
        let n = self.model.dim();
        let s = self.stages[0].step.degree();
        if row < s * n {
            format!(
                "momentum balance of coordinate `{}` at control point {}",
                self.model.coordinate_name(row % n),
                row / n
            )
        } else {
            let m = self.constraints.count().max(1);
            let a = (row - s * n) % m;
            format!("constraint `{}`", self.constraints.name(a))
        }
    }

    /// Describes unknown `col` of the step system.
    #[must_use]
    pub fn describe_unknown(&self, col: usize) -> String {
        let n = self.model.dim();
        let s = self.stages[0].step.degree();
        if col < s * n {
            format!("coordinate `{}`", self.model.coordinate_name(col % n))
        } else {
            let m = self.constraints.count().max(1);
            format!(
                "multiplier of constraint `{}`",
                self.constraints.name((col - s * n) % m)
            )
        }
    }

    fn likely_cause(&self, error: &NewtonError) -> String {
        let linear = self.model.is_linear();
        let first = self.k == 0;
        match error {
            NewtonError::Linear {
                source,
                worst_equation,
                ..
            } => match source {
                LinearSolveError::EmptyRow { row } => format!(
                    "singular model: {} has no entries (an empty constraint row)",
                    self.describe_equation(*row)
                ),
                LinearSolveError::EmptyColumn { col } => format!(
                    "singular model: {} appears in no equation (a degenerate direction with neither potential nor constraint)",
                    self.describe_unknown(*col)
                ),
                LinearSolveError::NumericallySingular { index }
                | LinearSolveError::StructurallySingular { index }
                | LinearSolveError::NonFinite { index } => {
                    let unknown = self.describe_unknown(
                        (*index).min(self.stages[0].step.unknowns().saturating_sub(1)),
                    );
                    let equation = self.describe_equation(*worst_equation);
                    if linear || matches!(source, LinearSolveError::StructurallySingular { .. }) {
                        format!(
                            "singular model: the Newton matrix is singular near {unknown} (largest residual in {equation}): a coordinate no equation determines, or redundant or contradicting constraints"
                        )
                    } else if first {
                        format!(
                            "the Newton matrix is singular near {unknown} at the start (largest residual in {equation}): a coordinate no equation determines, redundant or contradicting constraints, or initial data at a singular point of a nonlinear part"
                        )
                    } else {
                        format!(
                            "the Newton matrix became singular near {unknown} (largest residual in {equation}), having been regular on the steps before: a nonlinear part reached a singular point of its characteristic (an inductor at its saturation flux, say) or the step is too large for it"
                        )
                    }
                }
                LinearSolveError::Pattern(_) => {
                    "a model or constraint emitted a different derivative pattern between calls"
                        .into()
                }
                LinearSolveError::Backend(_) => "the sparse solver failed".into(),
            },
            NewtonError::NotConverged { worst_equation, .. } => {
                let equation = self.describe_equation(*worst_equation);
                if first {
                    format!(
                        "largest residual in {equation}: initial data inconsistent with a nonlinear part, a step too large for the nonlinearity, or constraints that cannot all hold"
                    )
                } else {
                    format!(
                        "largest residual in {equation}: step too large for a nonlinear part, or constraints that cannot all hold"
                    )
                }
            }
            NewtonError::NonFiniteResidual { equation, .. } => format!(
                "the model returned NaN or infinity in {}: the state left the model's domain",
                self.describe_equation(*equation)
            ),
        }
    }

    /// `q_k`.
    #[must_use]
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// The carried momentum `p_k` (`p̃_k` in the (−) flavour).
    #[must_use]
    pub fn p(&self) -> &[f64] {
        &self.p
    }

    /// `t_k`.
    #[must_use]
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Steps taken since initialisation.
    #[must_use]
    pub fn steps_taken(&self) -> usize {
        self.k
    }

    /// Whether each step keeps the states at the ends of its substeps inside it ([`InnerState`];
    /// off by default): a signal read there is a sample of the motion that the states at `t_k`
    /// miss (a `.meas` trigger on an edge inside a step, a diode's recovery spike that the
    /// truncation-error control resolved in pieces).
    pub fn record_inner_states(&mut self, on: bool) {
        self.inner_states = on.then(Vec::new);
    }

    /// The states at the ends of the substeps inside the last step, in time order, when
    /// [`Integrator::record_inner_states`] is on (empty otherwise); taken, not copied.
    pub fn take_inner_states(&mut self) -> Vec<InnerState> {
        self.inner_states
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Newton counters accumulated since construction.
    #[must_use]
    pub fn stats(&self) -> NewtonStats {
        self.stats
    }

    /// How often steps were split at breakpoints or cut after a Newton failure.
    #[must_use]
    pub fn counters(&self) -> StepCounters {
        self.counters
    }

    /// The constraint impulses of the last step, one per active row: the sum of every
    /// multiplier block of every substep (divided by `h`, the mean constraint force over the
    /// step).
    #[must_use]
    pub fn last_step_impulses(&self) -> &[f64] {
        &self.impulse
    }

    /// Where the mean constraint force of a step ([`Integrator::last_step_impulses`] over `h`)
    /// sits in time, as a fraction `c` of `h` after `t_k`: it approximates the multiplier at
    /// `t_k + c·h` to `O(h²)`. A Galerkin step's multiplier blocks weigh the constraint force
    /// with the basis of the control points they belong to (`Λʲ ≈ h Σᵢ bᵢ ℓⱼ(cᵢ) λ(cᵢ)`); the
    /// (+) step has no block for its end point, whose share `w = Σᵢ bᵢ ℓ_s(cᵢ)` the next step's
    /// first block carries, so its impulse is centred at `½ − w` (the midpoint rule: `0`, the
    /// impulse on `p_k`; a quadratic path on `0, ½, 1`: `⅓`), the (−) step's at `½ + w`, the
    /// symmetric pair's at `½`. A composition averages its substeps' centres by their `γᵢ`.
    #[must_use]
    pub fn impulse_centre(&self) -> f64 {
        let path = self.options.discretisation.path();
        let rule = self.options.discretisation.force_rule();
        let s = path.degree();
        let w: f64 = rule
            .nodes()
            .iter()
            .zip(rule.weights())
            .map(|(&c, &b)| b * path.basis(c, s))
            .sum();
        let within = match self.options.scheme {
            Scheme::Plus => 0.5 - w,
            Scheme::Minus => 0.5 + w,
            Scheme::Symmetric => 0.5,
        };
        let mut start = 0.0;
        let mut centre = 0.0;
        for &gamma in self.options.composition.gammas() {
            centre += gamma * (start + gamma * within);
            start += gamma;
        }
        centre
    }

    /// The step size `h`.
    #[must_use]
    pub fn step_size(&self) -> f64 {
        self.options.h
    }

    /// The model.
    #[must_use]
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The constraints as given (including any dropped as redundant).
    #[must_use]
    pub fn constraints(&self) -> &C {
        self.constraints.inner()
    }

    /// The constraint rows in use, after redundant ones were dropped.
    #[must_use]
    pub fn active_constraints(&self) -> &RowSubset<C> {
        &self.constraints
    }

    /// Unknowns of one Newton solve (largest over substeps): `s(n + m)`.
    #[must_use]
    pub fn unknowns(&self) -> usize {
        self.stages
            .iter()
            .map(|s| s.step.unknowns())
            .max()
            .unwrap_or(0)
    }

    /// Jacobian entries stamped per evaluation (largest over substeps; 0 before the first step).
    #[must_use]
    pub fn jacobian_entries(&self) -> usize {
        self.stages
            .iter()
            .map(|s| s.newton.pattern_len())
            .max()
            .unwrap_or(0)
    }

    /// Multipliers `Λ⁰` of the last step for every row of the constraint set as given
    /// (zero for rows dropped as redundant): the impulses `Λ⁰ₐ Aᵃ(q_k)` the constraints applied.
    #[must_use]
    pub fn last_multipliers_full(&self) -> Vec<f64> {
        let mut full = vec![0.0; self.constraints.inner().count()];
        for (&a, &l) in self.constraints.kept().iter().zip(self.last_multipliers()) {
            full[a] = l;
        }
        full
    }

    /// Max-norm of the discrete constraint equations at the accepted solution of the last step
    /// (over all substeps): `ωᵃ(q_*)·(q_{k+1} − q_k)` for one-forms, `gᵃ(q_{k+1})` for holonomic
    /// rows, at every control point. Re-evaluates the step equations (a diagnostic, not free).
    pub fn last_constraint_residual(&mut self) -> f64 {
        let mut worst: f64 = 0.0;
        for stage in &mut self.stages {
            worst = worst.max(stage.step.constraint_residual(
                &self.model,
                &self.constraints,
                &stage.x,
                &mut stage.scratch,
            ));
        }
        worst
    }

    /// The unknowns of the last solved substep (increments, then multipliers).
    #[must_use]
    pub fn last_unknowns(&self) -> &[f64] {
        self.stages.last().map_or(&[], |s| &s.x)
    }

    /// Multipliers `Λ⁰` of the first substep of the last step: the constraint impulses at `q_k`,
    /// one per active constraint row.
    #[must_use]
    pub fn last_multipliers(&self) -> &[f64] {
        let stage = &self.stages[0];
        let o = stage.step.multiplier_offset(0);
        &stage.x[o..o + self.constraints.count()]
    }

    /// The step equations of each substep (for diagnostics and tests).
    pub fn step_equations(&self) -> impl Iterator<Item = &ForcedDiracStep> {
        self.stages.iter().map(|s| &s.step)
    }
}

/// The linear solver of a stage's Newton iteration. A constant Jacobian is factorised once per
/// step size, so a step costs its triangular solves, and sparse ones beat dense ones at every size
/// measured (midpoint steps of the RLC ladder of 1 to 10 sections, 3 to 30 unknowns: 5 to 27 %
/// cheaper; a one-unknown oscillator ties); otherwise `choice` decides (for a Jacobian stamped
/// again, dense and sparse tie on small systems, see [`DenseLu::AUTO_LIMIT`]). A stage that only
/// builds the affine step map gets the size rule's solver instead ([`Integrator::build_affine`]).
///
/// [`DenseLu::AUTO_LIMIT`]: dirac_solve::DenseLu::AUTO_LIMIT
fn stage_solver(choice: SolverChoice, constant_jacobian: bool) -> SolverChoice {
    match choice {
        SolverChoice::Auto if constant_jacobian => SolverChoice::Sparse,
        other => other,
    }
}

/// Grid steps after a source corner inside a step within which a substep that the truncation
/// test passes narrowly is judged again by step doubling ([`History::judge`]).
const YOUNG_STEPS: f64 = 2.0;

/// The state before an attempt of [`Integrator::advance`], to put back if the attempt fails or
/// is rejected.
enum Saved {
    /// Nothing to put back: a single implicit substep writes the state only once its solve has
    /// succeeded, and without a truncation rule an accepted substep is never taken back.
    Untouched,
    /// In the integrator's preallocated buffers (a first attempt).
    Buffers,
    /// A copy (a cut attempt, while the buffers hold the first attempt's state).
    Copy(Vec<f64>, Vec<f64>, Vec<f64>),
}

/// Sets the subnormal entries of `v` to zero (see [`Integrator::step`]); zeros keep their sign.
/// Written as a select so that the pass vectorises.
fn flush_subnormals(v: &mut [f64]) {
    for x in v {
        let tiny = x.abs() < f64::MIN_POSITIVE && *x != 0.0;
        *x = if tiny { 0.0 } else { *x };
    }
}

/// The explicit step if `options` allow it and the model and constraints qualify.
fn explicit_step<M: Model, C: Constraints>(
    model: &M,
    constraints: &RowSubset<C>,
    options: &IntegratorOptions,
) -> Option<ExplicitStep> {
    (options.explicit && constraints.count() == 0 && options.discretisation.is_trapezoid())
        .then(|| ExplicitStep::new(model, options.solver))
        .flatten()
}

/// Euclidean projection of `v` onto `ker A(q)`: solves `[I Aᵀ; A 0][w; μ] = [v; 0]`.
fn project_velocity<C: Constraints + ?Sized>(
    constraints: &C,
    q: &[f64],
    v: &[f64],
    held: &[bool],
) -> Result<Vec<f64>, SimError> {
    /// `min Σ_free (x_i − v_i)²` subject to `A x = 0` with the held `x_i = v_i`: the free rows
    /// carry `Aᵀλ`, the held rows do not.
    struct Projection {
        n: usize,
        m: usize,
        forms: Vec<(usize, usize, f64)>,
        held: Vec<bool>,
        v: Vec<f64>,
    }
    impl NonlinearSystem for Projection {
        fn len(&self) -> usize {
            self.n + self.m
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            let n = self.n;
            for i in 0..n {
                r[i] = x[i] - self.v[i];
            }
            r[n..].fill(0.0);
            for &(a, j, c) in &self.forms {
                if !self.held[j] {
                    r[j] += c * x[n + a];
                }
                r[n + a] += c * x[j];
            }
        }
        fn jacobian(&mut self, _x: &[f64], jac: &mut Triplets) {
            for i in 0..self.n {
                jac.add(i, i, 1.0);
            }
            for &(a, j, c) in &self.forms {
                if !self.held[j] {
                    jac.add(j, self.n + a, c);
                }
                jac.add(self.n + a, j, c);
            }
        }
        fn jacobian_is_constant(&self) -> bool {
            true
        }
    }
    let n = q.len();
    let mut held: Vec<bool> = held.to_vec();
    held.resize(n, false);
    let mut t = Triplets::new();
    t.begin();
    constraints.forms(q, &mut t);
    let all: Vec<(usize, usize, f64)> = t.iter().collect();
    // A row that only held velocities enter and that they violate (two series inductors stated
    // with different currents, two joined bodies with stated velocities that disagree) releases
    // them: the stated values contradict each other, and the least change reconciles them as for
    // unstated ones. A row they satisfy is left out of the projection.
    let rows = constraints.count();
    let (mut value, mut size) = (vec![0.0; rows], vec![0.0; rows]);
    for &(a, j, c) in &all {
        value[a] += c * v[j];
        size[a] += (c * v[j]).abs();
    }
    // Per row, whether a velocity that is not held enters it.
    let free_entries = |held: &[bool]| {
        let mut free = vec![false; rows];
        for &(a, j, c) in &all {
            free[a] |= !held[j] && c != 0.0;
        }
        free
    };
    let free_before = free_entries(&held);
    for &(a, j, _) in &all {
        if !free_before[a] && value[a].abs() > HELD_TOL * size[a] {
            held[j] = false;
        }
    }
    let free_entries = free_entries(&held);
    let mut index = vec![usize::MAX; rows];
    let mut m = 0;
    for a in 0..rows {
        if free_entries[a] {
            index[a] = m;
            m += 1;
        }
    }
    let forms = all
        .into_iter()
        .filter(|&(a, _, _)| free_entries[a])
        .map(|(a, j, c)| (index[a], j, c))
        .collect();
    let original: Vec<usize> = (0..rows).filter(|&a| free_entries[a]).collect();
    let mut system = Projection {
        n,
        m,
        forms,
        held,
        v: v.to_vec(),
    };
    let mut x = vec![0.0; n + m];
    x[..n].copy_from_slice(v);
    let mut newton = Newton::new(
        AutoLu::for_size(SolverChoice::Auto, n + m),
        NewtonOptions::default(),
    );
    match newton.solve(&mut system, &mut x) {
        Ok(_) => Ok(x[..n].to_vec()),
        Err(NewtonError::Linear { source, .. }) => {
            let constraint = match source {
                LinearSolveError::EmptyRow { row } | LinearSolveError::EmptyColumn { col: row }
                    if row >= n =>
                {
                    constraints.name(original[row - n])
                }
                _ => "the constraint set (rows are linearly dependent)".to_string(),
            };
            Err(SimError::InconsistentInitialCondition {
                constraint,
                residual: f64::NAN,
            })
        }
        Err(other) => Err(SimError::InconsistentInitialCondition {
            constraint: format!("velocity projection ({other})"),
            residual: f64::NAN,
        }),
    }
}

/// How far, relative to the size of its terms, a constraint row that only held velocities enter
/// may miss zero at the start before they count as contradictory and are released (round-off of
/// the stated values, e.g. two series inductors stated as `IC=1m` whose row is `i₁ − i₂`).
const HELD_TOL: f64 = 1e-12;

/// How many past solutions a stage keeps for its predictor (cubic extrapolation in `k`).
const PAST_DEPTH: usize = 3;

/// [`NewtonOptions::start_contraction`] for the stages of a scheme with several substeps per
/// step (`composed`: a composition, the symmetric scheme), unless `options.newton` sets one
/// (`Some(f64::INFINITY)` keeps every carried factorisation).
const COMPOSED_START_CONTRACTION: f64 = 1e-2;

/// The Newton options of `model`'s steps: `options.newton`, with a fresh Jacobian at the start
/// of a solve ([`NewtonOptions::start_contraction`]) on the substeps of a composition, where
/// each stage's carried factorisation is a whole step old: on D2 with Kahan–Li 8 (17 substeps,
/// h = 0.0125, 4000 steps) it cuts the instructions by 19 % (779 against 957 million). On a
/// one-stage run the factorisation is one step old and a Galerkin step's Jacobian costs several
/// updates, so it does not pay: +18 % (Gauss 2), +56 % (Gauss 3), +70 % (Gauss 4) on the same
/// run. A model whose updates are limited ([`Model::has_update_limit`], a junction) always
/// starts from the factorisation it carries: a Jacobian fresh at the extrapolated guess, with a
/// junction's exponential evaluated past its solution, is a worse Newton matrix than the
/// converged one of the step before (every diode netlist then cut steps).
fn newton_options<M: Model>(
    model: &M,
    options: &IntegratorOptions,
    composed: bool,
) -> NewtonOptions {
    let mut newton = options.newton;
    if newton.start_contraction.is_none() && composed {
        newton.start_contraction = Some(COMPOSED_START_CONTRACTION);
    }
    if model.has_update_limit() {
        newton.start_contraction = None;
        newton.accept_at_equation_roundoff = false;
    }
    newton
}

#[cfg(test)]
mod tests {
    //! The integrator's bookkeeping against values worked out by hand: option checks, the
    //! velocity projection, the time grid, multipliers of dropped rows, failure reports.

    use super::*;
    use crate::test_models::Masses;
    use dirac_core::{LinearForms, NoConstraints};

    /// `v₀ − v₁ = 0`, optionally written twice.
    fn joint(twice: bool) -> LinearForms {
        let mut forms = LinearForms::new(2);
        forms.push("joint", &[(0, 1.0), (1, -1.0)]);
        if twice {
            forms.push("joint again", &[(0, -2.0), (1, 2.0)]);
        }
        forms
    }

    fn options(h: f64) -> IntegratorOptions {
        IntegratorOptions::new(Discretisation::midpoint(), h)
    }

    #[test]
    fn bad_options_and_lengths_are_typed_errors() {
        for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
            let err = Integrator::new(Masses::new(&[1.0], &[1.0]), NoConstraints, options(h));
            assert!(matches!(err, Err(SimError::StepSize(_))), "h = {h}");
        }
        let mut sim = Integrator::new(
            Masses::new(&[1.0, 1.0], &[1.0, 1.0]),
            NoConstraints,
            options(0.1),
        )
        .unwrap();
        assert_eq!(
            sim.set_state(&[0.0], &[0.0, 0.0], 0.0),
            Err(SimError::Dimension {
                what: "q",
                got: 1,
                expected: 2
            })
        );
        assert_eq!(
            sim.initialise(&[0.0, 0.0], &[0.0; 3], 0.0),
            Err(SimError::Dimension {
                what: "v",
                got: 3,
                expected: 2
            })
        );
        assert_eq!(Scheme::from(Flavour::Minus), Scheme::Minus);
        assert_eq!(Scheme::from(Flavour::Plus), Scheme::default());
    }

    /// Masses 1 and 3 joined by `v₀ = v₁`, started with v = (1, 0): the Euclidean projection onto
    /// `ker A` is (½, ½), so p = M·(½, ½) = (½, 3/2).
    #[test]
    fn initialise_projects_the_velocities() {
        let mut sim = Integrator::new(
            Masses::new(&[1.0, 3.0], &[0.0, 0.0]),
            joint(false),
            options(0.1),
        )
        .unwrap();
        sim.initialise(&[0.0, 0.0], &[1.0, 0.0], 0.0).unwrap();
        assert!((sim.p()[0] - 0.5).abs() <= 1e-15 && (sim.p()[1] - 1.5).abs() <= 1e-15);
        // Free motion of the joined pair at the common velocity ½: x = t/2.
        for _ in 0..10 {
            sim.step().unwrap();
        }
        assert!((sim.q()[0] - 0.5).abs() <= 1e-14 && (sim.q()[1] - 0.5).abs() <= 1e-14);
    }

    /// `t_k = t₀ + k·h` exactly (a running sum of h drifts by about k·ε·h).
    #[test]
    fn time_is_computed_not_accumulated() {
        let (t0, h) = (1.0 / 3.0, 0.1);
        let mut sim =
            Integrator::new(Masses::new(&[1.0], &[1.0]), NoConstraints, options(h)).unwrap();
        sim.set_state(&[1.0], &[0.0], t0).unwrap();
        let mut sum = t0;
        let mut drifted = false;
        for k in 1..=1000 {
            sim.step().unwrap();
            sum += h;
            drifted |= sum != t0 + k as f64 * h;
            assert_eq!(sim.t(), t0 + k as f64 * h, "step {k}");
            assert_eq!(sim.steps_taken(), k);
        }
        assert!(drifted, "a running sum would have passed too");
    }

    /// A spring on mass 0 only, the pair joined twice (the second row is dropped with a warning):
    /// the joint's impulse on the free mass 1 is its whole momentum change, `Λ` (the row has
    /// coefficient −1 there and adds `−Λ·c`), and the dropped row reports 0.
    #[test]
    fn multipliers_of_dropped_rows_are_zero() {
        let mut sim = Integrator::new(
            Masses::new(&[1.0, 3.0], &[2.0, 0.0]),
            joint(true),
            options(0.05),
        )
        .unwrap();
        sim.initialise(&[0.4, 0.4], &[0.0, 0.0], 0.0).unwrap();
        assert_eq!(sim.warnings().len(), 1, "{:?}", sim.warnings());
        assert!(sim.warnings()[0].contains("joint again"));
        assert_eq!(sim.active_constraints().count(), 1);
        for _ in 0..20 {
            let p1 = sim.p()[1];
            sim.step().unwrap();
            let full = sim.last_multipliers_full();
            assert_eq!(full.len(), 2);
            assert_eq!(full[1], 0.0);
            assert_eq!(sim.last_multipliers(), &full[..1]);
            let gained = sim.p()[1] - p1;
            assert!(gained.abs() > 1e-3 && (full[0] - gained).abs() <= 1e-15);
        }
    }

    /// A step whose first attempt fails is taken again as two halves from the state before it:
    /// the force is NaN only at the midpoint time of step 3, which the full step's quadrature node
    /// hits and the halves' nodes miss. The run must equal one that takes steps 0–2 of `h`, two
    /// steps of `h/2` from the same state, and the rest of `h`, to round-off (the two solve the
    /// halves from different Newton guesses; a failed attempt that left anything behind in the
    /// state would show as a difference of the size of a step).
    #[test]
    fn a_cut_step_starts_again_from_the_state_before_it() {
        let h = 0.1;
        let (q0, p0) = ([0.3, -0.2], [0.5, 0.1]);
        // The same masses, poisoned at `nan_at`, stepped by `step`, from (q0, p0) at t = 0.
        let integrator = |nan_at: f64, step: f64| {
            let mut model = Masses::new(&[1.0, 2.0], &[1.0, 3.0]);
            model.nan_at = nan_at;
            let mut sim = Integrator::new(model, NoConstraints, options(step)).unwrap();
            sim.set_state(&q0, &p0, 0.0).unwrap();
            sim
        };
        let mut sim = integrator(3.0 * h + 0.5 * h, h);
        let mut whole = integrator(f64::NAN, h);
        let mut half = integrator(f64::NAN, 0.5 * h);
        for k in 0..6 {
            sim.step().unwrap();
            if k == 3 {
                half.set_state(whole.q(), whole.p(), whole.t()).unwrap();
                half.step().unwrap();
                half.step().unwrap();
                let (q, p) = (half.q().to_vec(), half.p().to_vec());
                whole.set_state(&q, &p, 4.0 * h).unwrap();
            } else {
                whole.step().unwrap();
            }
            for (a, b) in sim
                .q()
                .iter()
                .chain(sim.p())
                .zip(whole.q().iter().chain(whole.p()))
            {
                assert!((a - b).abs() <= 1e-14, "after step {k}: {a} against {b}");
            }
        }
        assert_eq!(sim.counters().step_cuts, 1);
        // Control: the unpoisoned run differs after step 3 (the halves are another scheme).
        let mut plain = integrator(f64::NAN, h);
        for _ in 0..6 {
            plain.step().unwrap();
        }
        assert!((plain.q()[0] - sim.q()[0]).abs() > 1e-6);
    }

    /// A model that returns NaN in a step: an error naming the step, its start time and the
    /// likely cause, and equations and unknowns described by name.
    #[test]
    fn a_non_finite_model_is_reported_with_step_and_time() {
        let mut model = Masses::new(&[1.0, 1.0], &[1.0, 1.0]);
        model.nan_above = 0.5;
        let mut sim = Integrator::new(model, joint(false), options(0.1)).unwrap();
        sim.initialise(&[0.0, 0.0], &[1.0, 1.0], 2.0).unwrap();
        let mut failure = None;
        for _ in 0..20 {
            if let Err(e) = sim.step() {
                failure = Some(e);
                break;
            }
        }
        // x₀ ≈ sin(t − 2) passes 0.5 in the sixth step (t from 2.5 to 2.6). The failing step is
        // retried in halved substeps first, and `t` is where the last failing substep started:
        // inside the step, not necessarily at its start.
        match failure {
            Some(SimError::Newton {
                step,
                t,
                source: NewtonError::NonFiniteResidual { .. },
                likely_cause,
            }) => {
                assert_eq!(step, 5);
                assert!((2.5..2.6).contains(&t), "t = {t}");
                assert!(likely_cause.contains("NaN"), "{likely_cause}");
            }
            other => panic!("expected a non-finite residual, got {other:?}"),
        }
        assert_eq!(
            sim.describe_equation(1),
            "momentum balance of coordinate `x1` at control point 0"
        );
        assert_eq!(sim.describe_equation(2), "constraint `joint`");
        assert_eq!(sim.describe_unknown(0), "coordinate `x0`");
        assert_eq!(sim.describe_unknown(2), "multiplier of constraint `joint`");
        assert_eq!(sim.unknowns(), 3);
    }
}
