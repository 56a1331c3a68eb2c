//! Natural modes of a model linearised at a state, and what a step size does to each of them
//! (docs/math.md §8): the basis of `dirac check`'s step-size report and `dirac run`'s warnings.
//!
//! Linearised about `(q*, v*, λ*)` the forced, constrained Euler–Lagrange equations
//! `d/dt ∂L/∂v = ∂L/∂q + f − Aᵀλ`, `A v = 0` (or `g(q) = 0`) give, for a perturbation
//! `δq = x e^{st}` with `s ≠ 0`,
//!
//! ```text
//! (M s² + D s + K) x + Aᵀ μ = 0,     A x = 0,
//! M = ∂²L/∂v²,   D = (∂²L/∂v∂q − ∂²L/∂q∂v) − ∂f/∂v,   K = −∂²L/∂q² − ∂f/∂q + Σₐ λₐ ∂Aᵃ/∂q.
//! ```
//!
//! On the kernel of `A` (`x = N y`) this is the quadratic pencil `Nᵀ(M s² + D s + K)N`, whose
//! mass matrix is singular wherever a coordinate has no kinetic term (capacitor and resistor
//! charges, massless endpoints). Those directions are split off (the mass matrix's range and
//! kernel), the pencil is written first order in the reduced positions and the velocities of the
//! massive directions only, and the directions with neither mass nor damping are eliminated as
//! algebraic unknowns (a Schur complement), leaving an ordinary eigenproblem whose eigenvalues are
//! the finite natural frequencies `s`.

use dirac_core::{Constraints, ForceJacobian, LagrangianHessian, Model, NoConstraints, Triplets};
use nalgebra::{Complex, DMatrix, DVector, Schur, SymmetricEigen};
use thiserror::Error;

use crate::derivatives::Derivatives;
use crate::integrator::{Integrator, IntegratorOptions};

/// Most coordinates a modal analysis takes: the dense eigenproblem costs `O(n³)` (about 0.1 s at
/// this size); larger models are not analysed.
pub const MODAL_LIMIT: usize = 300;

/// Fewest steps per period of the fastest oscillation below which `dirac run` warns (a
/// second-order method's phase error then exceeds about 3 % per period).
pub const MIN_STEPS_PER_PERIOD: f64 = 10.0;

/// A damped mode whose per-step factor under the method has at least this magnitude while the
/// exact factor `e^{−h/τ}` is below [`FAST_DECAY_EXACT`] is reported as ringing or lingering.
/// 0.5 caught midpoint's ringing (`R(−10) = −0.67`) but not gauss2's lingering (`R(−10) =
/// +0.30`), which left a tenth of an excited mode in each row after a source corner.
pub const SLOW_METHOD_DAMPING: f64 = 0.1;

/// Exact per-step factor `e^{−h/τ}` below which a damped mode counts as much faster than `h`
/// (`h > 3τ`).
pub const FAST_DECAY_EXACT: f64 = 0.05;

/// Modes slower than this, in radians per step (`|s| h`), are static for step-size purposes
/// (a period of more than 6·10⁷ steps); it also absorbs the `√ε`-size splitting of multiple zero
/// eigenvalues (a free mass).
const STATIC_MODE: f64 = 1e-7;

/// An eigenvalue with `|Im s|` above this fraction of `|s|` is an oscillation (a double real
/// root splits by about `√ε |s|` in rounding).
const OSCILLATORY: f64 = 1e-6;

/// Relative rank threshold of the scaled constraint matrix, mass matrix and pencil (entries are
/// O(1) after scaling; rounding of the decompositions is about 1e-15).
const RANK_TOL: f64 = 1e-12;

/// How many of the fastest modes of each kind get the name of their dominant coordinate.
const NAMED_MODES: usize = 6;

/// A modal analysis that could not be done.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModesError {
    /// The model has more coordinates than [`MODAL_LIMIT`].
    #[error("{coordinates} coordinates: more than the {limit} a dense modal analysis takes")]
    TooLarge {
        /// Coordinates of the model.
        coordinates: usize,
        /// The limit.
        limit: usize,
    },
    /// The linearised equations do not determine a motion (a coordinate in no equation) or need
    /// differentiated algebraic relations (higher index).
    #[error("the linearised model is singular or of higher index ({0})")]
    Singular(String),
    /// The eigenvalue iteration did not converge.
    #[error("the eigenvalue iteration did not converge on {0} unknowns")]
    NotConverged(usize),
    /// The time scale is not positive and finite.
    #[error("time scale must be positive and finite, got {0}")]
    TimeScale(f64),
}

/// What kind of motion a mode is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeKind {
    /// A (possibly damped) oscillation: a complex pair `s = σ ± iω`.
    Oscillation,
    /// A real decaying mode `s = −1/τ`.
    Decay,
    /// A real growing mode `s = +1/τ` (an unstable equilibrium, such as an inverted pendulum).
    Growth,
}

/// One natural mode of the linearised model.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// Real part `σ` of the eigenvalue, in 1/time.
    pub re: f64,
    /// Imaginary part `ω ≥ 0` (one of a conjugate pair), in rad/time.
    pub im: f64,
    /// Oscillation, decay or growth.
    pub kind: ModeKind,
    /// The coordinate with the largest (scaled) amplitude in the mode, for the fastest modes.
    pub coordinate: Option<String>,
}

impl Mode {
    /// `|s|`, the mode's rate in rad/time.
    #[must_use]
    pub fn rate(&self) -> f64 {
        self.re.hypot(self.im)
    }

    /// The period `2π/ω` of an oscillation.
    #[must_use]
    pub fn period(&self) -> Option<f64> {
        (self.kind == ModeKind::Oscillation).then(|| std::f64::consts::TAU / self.im)
    }

    /// The time constant `1/|σ|` of a real mode.
    #[must_use]
    pub fn time_constant(&self) -> Option<f64> {
        (self.kind != ModeKind::Oscillation).then(|| 1.0 / self.re.abs())
    }

    /// The damping ratio `ζ = −σ/|s|` (0 undamped, 1 critically damped).
    #[must_use]
    pub fn damping_ratio(&self) -> f64 {
        -self.re / self.rate()
    }

    /// Steps of size `h` per period (oscillations) or per time constant (real modes).
    #[must_use]
    pub fn steps(&self, h: f64) -> f64 {
        self.period().or(self.time_constant()).unwrap_or(0.0) / h
    }
}

/// Growth over a run beyond which [`NaturalModes::instability`] refuses it: a mode seeded at
/// round-off (1e-16 of the state) then reaches 1e-10 of it, and any seed from the start or a
/// source corner is magnified a million times.
pub const UNSTABLE_GROWTH: f64 = 1e6;

/// The natural modes of a model at one state, fastest first.
#[derive(Debug, Clone, PartialEq)]
pub struct NaturalModes {
    /// Every mode with `|s| h ≥ 1e-7` for the time scale `h` of the analysis, fastest first (one
    /// per conjugate pair).
    pub modes: Vec<Mode>,
    /// Dimension of the first-order system the eigenvalues come from.
    pub dimension: usize,
    /// Eigenvalues left out as static (`|s| h < 1e-7`: conserved charges, free motions,
    /// gauges), conjugate pairs counted once.
    pub static_modes: usize,
}

impl NaturalModes {
    /// Linearises `model` with `constraints` at positions `q`, velocities `v`, multipliers
    /// `lambda` (one per constraint row, sign as in the step: `ṗ = ∂L/∂q + f − Aᵀλ`) and time
    /// `t`, and computes its natural modes; `time_scale` (the step size) scales the problem so
    /// that rank decisions are made at the resolution that matters.
    ///
    /// Away from an equilibrium this is the frozen-coefficient linearisation: the derivatives of
    /// `A(q)·v*` and of the coefficients along the motion are left out.
    ///
    /// # Errors
    /// [`ModesError`]: too many coordinates, a singular or higher-index linearisation, no
    /// convergence of the eigenvalue iteration.
    pub fn analyse<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        state: (&[f64], &[f64], &[f64]),
        t: f64,
        time_scale: f64,
    ) -> Result<Self, ModesError> {
        let (q, v, lambda) = state;
        let n = model.dim();
        if n > MODAL_LIMIT {
            return Err(ModesError::TooLarge {
                coordinates: n,
                limit: MODAL_LIMIT,
            });
        }
        if !(time_scale > 0.0 && time_scale.is_finite()) {
            return Err(ModesError::TimeScale(time_scale));
        }
        let lin = Linearisation::new(model, constraints, q, v, lambda, t, time_scale);
        let reduced = lin.reduce()?;
        let mut modes = Vec::new();
        let mut static_modes = 0;
        let eigenvalues = reduced.eigenvalues()?;
        for s in &eigenvalues {
            if s.norm() < STATIC_MODE {
                if s.im >= 0.0 {
                    static_modes += 1;
                }
                continue;
            }
            let kind = if s.im.abs() > OSCILLATORY * s.norm() {
                if s.im < 0.0 {
                    continue;
                }
                ModeKind::Oscillation
            } else if s.re < 0.0 {
                ModeKind::Decay
            } else {
                ModeKind::Growth
            };
            modes.push((
                *s,
                Mode {
                    re: s.re / time_scale,
                    im: if kind == ModeKind::Oscillation {
                        s.im / time_scale
                    } else {
                        0.0
                    },
                    kind,
                    coordinate: None,
                },
            ));
        }
        modes.sort_by(|a, b| b.1.rate().total_cmp(&a.1.rate()));
        for kind in [ModeKind::Oscillation, ModeKind::Decay, ModeKind::Growth] {
            for (s, mode) in modes
                .iter_mut()
                .filter(|(_, m)| m.kind == kind)
                .take(NAMED_MODES)
            {
                mode.coordinate = reduced
                    .dominant_coordinate(*s, &lin)
                    .map(|i| model.coordinate_name(i));
            }
        }
        Ok(Self {
            modes: modes.into_iter().map(|(_, m)| m).collect(),
            dimension: reduced.t.nrows(),
            static_modes,
        })
    }

    /// The fastest mode of `kind`, if any.
    #[must_use]
    pub fn fastest(&self, kind: ModeKind) -> Option<&Mode> {
        self.modes.iter().find(|m| m.kind == kind)
    }

    /// The modes of `kind`, fastest first.
    pub fn of_kind(&self, kind: ModeKind) -> impl Iterator<Item = &Mode> {
        self.modes.iter().filter(move |m| m.kind == kind)
    }

    /// Whether the method leaves the fastest damped mode, much faster than `h`, ringing or
    /// lingering (damped by less than [`SLOW_METHOD_DAMPING`] per step, as midpoint and Gauss
    /// steps do): the case of the warning of [`NaturalModes::warnings`] that the start ramp
    /// ([`crate::StartRamp`]) addresses.
    #[must_use]
    pub fn leaves_ringing(&self, options: &IntegratorOptions) -> bool {
        self.fastest(ModeKind::Decay).is_some_and(|mode| {
            let tau = mode.time_constant().unwrap_or(f64::INFINITY);
            (-options.h / tau).exp() < FAST_DECAY_EXACT
                && MethodResponse::decay(options, tau)
                    .is_some_and(|r| (SLOW_METHOD_DAMPING..=1.0).contains(&r.abs()))
        })
    }

    /// The ramp for the stretch after a source breakpoint (see
    /// [`crate::IntegratorOptions::corner_ramp`]) when the method would leave the fastest damped
    /// mode ringing ([`NaturalModes::leaves_ringing`]): sized to reach that mode's time constant
    /// ([`crate::StartRamp::for_ratio`]).
    #[must_use]
    pub fn corner_ramp(&self, options: &IntegratorOptions) -> Option<crate::StartRamp> {
        self.leaves_ringing(options)
            .then(|| self.ramp_to_fastest_decay(options))
            .flatten()
    }

    /// The ramp whose smallest substeps reach the fastest damped mode at `options.h`
    /// ([`crate::StartRamp::for_ratio`]), whether or not the method would leave that mode
    /// ringing: the size of a start ramp asked for. A deeper ramp damps no mode more and takes
    /// substeps below the round-off of the state's own time scale, where Newton cannot
    /// converge (audit 43). `None` without a damped mode.
    #[must_use]
    pub fn ramp_to_fastest_decay(&self, options: &IntegratorOptions) -> Option<crate::StartRamp> {
        let tau = self.fastest(ModeKind::Decay)?.time_constant()?;
        Some(crate::StartRamp::for_ratio(options.h / tau))
    }

    /// The step-size warnings for a run with `options`: the fastest oscillation resolved by
    /// fewer than [`MIN_STEPS_PER_PERIOD`] steps, and damped modes much faster than `h` that the
    /// method damps too little.
    #[must_use]
    pub fn warnings(&self, options: &IntegratorOptions) -> Vec<String> {
        let h = options.h;
        let mut out = Vec::new();
        if let Some(mode) = self.fastest(ModeKind::Oscillation)
            && mode.steps(h) < MIN_STEPS_PER_PERIOD
        {
            let response = MethodResponse::oscillation(options, mode.im);
            let effect = match response {
                MethodResponse::Phase { frequency_error } => format!(
                    "a variational integrator keeps its amplitude bounded (no blow-up) but its phase drifts: the discrete frequency is off by {:+.2} % ({:.2} rad of phase per period)",
                    100.0 * frequency_error,
                    std::f64::consts::TAU * frequency_error.abs()
                ),
                MethodResponse::Unstable { growth } => format!(
                    "the composed step is unstable at this resolution: the mode grows by {growth:.3} per step"
                ),
                MethodResponse::Failed => "the method's response could not be computed".to_string(),
            };
            out.push(format!(
                "the fastest oscillation{} has period {:.4e}, only {:.2} steps of h = {h:e}: {effect}; resolve it with h ≤ {:.3e} (10 steps per period)",
                named(mode),
                mode.period().unwrap_or(0.0),
                mode.steps(h),
                mode.period().unwrap_or(0.0) / MIN_STEPS_PER_PERIOD,
            ));
        }
        if let Some(mode) = self.fastest(ModeKind::Decay) {
            let tau = mode.time_constant().unwrap_or(f64::INFINITY);
            let exact = (-h / tau).exp();
            if exact < FAST_DECAY_EXACT
                && let Some(r) = MethodResponse::decay(options, tau)
                && r.abs() >= SLOW_METHOD_DAMPING
            {
                let head = format!(
                    "the fastest damped mode{} has time constant {tau:.4e}, {:.3e} steps of h = {h:e}: the exact motion damps it by e^(-h/τ) = {exact:.2e} per step, but {}",
                    named(mode),
                    mode.steps(h),
                    options.discretisation,
                );
                out.push(if r.abs() > 1.0 {
                    format!(
                        "{head} amplifies it by {:.3e} per step: the run is unstable and will blow up; use h ≤ {tau:.3e} (one step per time constant) or the midpoint rule (`--method midpoint`), which damps every decaying mode",
                        r.abs(),
                    )
                } else {
                    let behaviour = if r < 0.0 {
                        "rings: it flips sign every step"
                    } else {
                        "lingers"
                    };
                    let remedy = if options.start_ramp.is_some() && options.corner_ramp.is_some() {
                        "the start ramp damps it at the start and the ramps after breakpoints at source corners; a switching device can still excite it: use a smaller h there"
                    } else if options.start_ramp.is_some() {
                        "the start ramp damps it at the start; a source corner or a switching device can still excite it: use a smaller h there"
                    } else {
                        "use a smaller h, start consistently, or damp the start with the start ramp (`--start-ramp`, scene key `start_ramp`)"
                    };
                    format!(
                        "{head} is not L-stable and damps it only by {r:.3} per step, so it {behaviour} for about {:.0} steps (inconsistent initial data, source corners); {remedy}",
                        steps_to_decay(r),
                    )
                });
            }
        }
        out
    }

    /// Why a run of `steps` steps with `options` cannot give a trajectory: the method amplifies
    /// a mode of the model (the trapezoid rule, explicit on a degenerate Lagrangian, multiplies
    /// a decay of time constant `τ` by `1 − h/τ` per step; an unstable composition an
    /// oscillation) by more than [`UNSTABLE_GROWTH`] over the run. `None` when every mode stays
    /// bounded, or grows by less over so few steps.
    #[must_use]
    pub fn instability(&self, options: &IntegratorOptions, steps: usize) -> Option<String> {
        let h = options.h;
        let over_run = |per_step: f64| per_step.ln() * steps as f64 > UNSTABLE_GROWTH.ln();
        if let Some(mode) = self.fastest(ModeKind::Decay) {
            let tau = mode.time_constant().unwrap_or(f64::INFINITY);
            if let Some(r) = MethodResponse::decay(options, tau)
                && over_run(r.abs())
            {
                return Some(format!(
                    "{} amplifies the damped mode{} of time constant {tau:.4e} by {:.3e} per step at h = {h:e} ({:.3e} steps per time constant), so this run of {steps} steps would blow up; use h ≤ {tau:.3e} or the midpoint rule (`--method midpoint`), which damps every decaying mode (forcing the run, `--force` or `force=True`, takes it anyway)",
                    options.discretisation,
                    named(mode),
                    r.abs(),
                    mode.steps(h),
                ));
            }
        }
        if let Some(mode) = self.fastest(ModeKind::Oscillation)
            && let MethodResponse::Unstable { growth } =
                MethodResponse::oscillation(options, mode.im)
            && over_run(growth)
        {
            return Some(format!(
                "the step is unstable on the oscillation{} of period {:.4e}: it grows by {growth:.3} per step at h = {h:e}, so this run of {steps} steps would blow up; use h ≤ {:.3e} (10 steps per period) (forcing the run, `--force` or `force=True`, takes it anyway)",
                named(mode),
                mode.period().unwrap_or(0.0),
                mode.period().unwrap_or(0.0) / MIN_STEPS_PER_PERIOD,
            ));
        }
        None
    }
}

/// `" (in x)"` for a mode with a named coordinate.
fn named(mode: &Mode) -> String {
    mode.coordinate
        .as_ref()
        .map_or_else(String::new, |c| format!(" (in {c})"))
}

/// Steps for a per-step factor `r` to shrink a mode by `e`.
fn steps_to_decay(r: f64) -> f64 {
    if r.abs() >= 1.0 {
        f64::INFINITY
    } else {
        -1.0 / r.abs().ln()
    }
}

/// What one step of the method does to a mode, from the method's step on a one-coordinate model
/// with the mode's rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MethodResponse {
    /// An oscillation stays on the unit circle and advances by `θ = ωh (1 + frequency_error)`.
    Phase {
        /// `θ/(ωh) − 1`.
        frequency_error: f64,
    },
    /// An oscillation whose discrete map has an eigenvalue off the unit circle.
    Unstable {
        /// The larger eigenvalue magnitude of the step map.
        growth: f64,
    },
    /// The probe step failed.
    Failed,
}

impl MethodResponse {
    /// The response of `options`' step to an undamped oscillation of angular frequency `omega`:
    /// the step map of `L = ½v² − ½ω²q²` from `(q, p) = (1, 0)` and `(0, 1)`.
    #[must_use]
    pub fn oscillation(options: &IntegratorOptions, omega: f64) -> Self {
        let step = |q: f64, v: f64| -> Option<(f64, f64)> {
            let mut integrator = Integrator::new(
                Probe::Oscillator { k: omega * omega },
                NoConstraints,
                regular_step(options),
            )
            .ok()?;
            integrator.initialise(&[q], &[v], 0.0).ok()?;
            integrator.step().ok()?;
            Some((integrator.q()[0], integrator.p()[0]))
        };
        let (Some((a, c)), Some((b, d))) = (step(1.0, 0.0), step(0.0, 1.0)) else {
            return Self::Failed;
        };
        let trace = a + d;
        let det = a * d - b * c;
        let discriminant = trace * trace - 4.0 * det;
        if discriminant < 0.0 && (det - 1.0).abs() < 1e-6 {
            let theta = (0.5 * trace / det.sqrt()).clamp(-1.0, 1.0).acos();
            Self::Phase {
                frequency_error: theta / (omega * options.h) - 1.0,
            }
        } else {
            let root = discriminant.max(0.0).sqrt();
            let growth = if discriminant < 0.0 {
                det.abs().sqrt()
            } else {
                (0.5 * (trace.abs() + root)).max(0.5 * (trace.abs() - root).abs())
            };
            Self::Unstable { growth }
        }
    }

    /// The factor by which `options`' step multiplies a first-order mode of time constant `tau`:
    /// one step of `L = −q²/2`, `f = −τ q̇` (that is `τ q̇ + q = 0`) from a consistent start.
    #[must_use]
    pub fn decay(options: &IntegratorOptions, tau: f64) -> Option<f64> {
        let mut integrator = Integrator::new(
            Probe::Decay { c: tau },
            NoConstraints,
            regular_step(options),
        )
        .ok()?;
        integrator.initialise(&[1.0], &[0.0], 0.0).ok()?;
        integrator.step().ok()?;
        Some(integrator.q()[0])
    }
}

/// `options` without the ramps of the first step and after breakpoints and without the
/// truncation-error control: the probes ask what the regular step does to a mode, which a ramped
/// or refined first step would hide (the control judges a probe's first step by two halves and
/// refined it, so the midpoint rule seemed to damp a mode 4e4 times faster than the step by 0.84
/// instead of leaving it at −1).
fn regular_step(options: &IntegratorOptions) -> IntegratorOptions {
    options
        .clone()
        .start_ramp(None)
        .corner_ramp(None)
        .truncation(None)
}

/// One-coordinate models that measure a method's response to a mode.
#[derive(Debug, Clone, Copy)]
enum Probe {
    /// `L = ½v² − ½kq²`.
    Oscillator { k: f64 },
    /// `L = −q²/2`, `f = −c v`.
    Decay { c: f64 },
}

impl Model for Probe {
    fn dim(&self) -> usize {
        1
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        match *self {
            Self::Oscillator { k } => 0.5 * v[0] * v[0] - 0.5 * k * q[0] * q[0],
            Self::Decay { .. } => -0.5 * q[0] * q[0],
        }
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        match *self {
            Self::Oscillator { k } => {
                lq[0] = -k * q[0];
                lv[0] = v[0];
            }
            Self::Decay { .. } => {
                lq[0] = -q[0];
                lv[0] = 0.0;
            }
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], hessian: &mut LagrangianHessian) {
        match *self {
            Self::Oscillator { k } => {
                hessian.qq.add(0, 0, -k);
                hessian.vv.add(0, 0, 1.0);
            }
            Self::Decay { .. } => hessian.qq.add(0, 0, -1.0),
        }
    }
    fn has_force(&self) -> bool {
        matches!(self, Self::Decay { .. })
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = match *self {
            Self::Oscillator { .. } => 0.0,
            Self::Decay { c } => -c * v[0],
        };
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, jacobian: &mut ForceJacobian) {
        if let Self::Decay { c } = *self {
            jacobian.v.add(0, 0, -c);
        }
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
}

/// `M`, `D`, `K` and the constraint rows at a state, in scaled coordinates `q = S q̃` and
/// dimensionless time `t/τ` (so eigenvalues come out as `s τ`).
struct Linearisation {
    m: DMatrix<f64>,
    d: DMatrix<f64>,
    k: DMatrix<f64>,
    a: DMatrix<f64>,
}

/// Sums `entries` into a dense `rows × cols` matrix, optionally transposed.
fn dense(
    rows: usize,
    cols: usize,
    entries: &Triplets,
    transpose: bool,
    scale: f64,
) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(rows, cols);
    for (i, j, value) in entries.iter() {
        let (i, j) = if transpose { (j, i) } else { (i, j) };
        if i < rows && j < cols {
            out[(i, j)] += scale * value;
        }
    }
    out
}

impl Linearisation {
    fn new<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        lambda: &[f64],
        t: f64,
        tau: f64,
    ) -> Self {
        let n = model.dim();
        let rows = constraints.count();
        let Derivatives {
            hessian,
            force: jacobian,
            forms,
        } = Derivatives::at(model, constraints, q, v, t);
        let mut curvature = Triplets::new();
        curvature.begin();
        if !constraints.is_constant() && lambda.len() == rows {
            constraints.multiplier_hessian(q, lambda, &mut curvature);
        }
        let m = dense(n, n, &hessian.vv, false, 1.0);
        let d = dense(n, n, &hessian.qv, true, 1.0)
            - dense(n, n, &hessian.qv, false, 1.0)
            - dense(n, n, &jacobian.v, false, 1.0);
        let k = dense(n, n, &curvature, false, 1.0)
            - dense(n, n, &hessian.qq, false, 1.0)
            - dense(n, n, &jacobian.q, false, 1.0);
        let mut a = dense(rows, n, &forms, false, 1.0);
        // Coordinate scales: each coordinate's largest term at the time scale τ becomes 1.
        let scale: Vec<f64> = (0..n)
            .map(|i| {
                let mut size = 0.0_f64;
                for j in 0..n {
                    for (matrix, factor) in [(&m, tau * tau), (&d, tau), (&k, 1.0)] {
                        size = size
                            .max(matrix[(i, j)].abs() / factor)
                            .max(matrix[(j, i)].abs() / factor);
                    }
                }
                if size > 0.0 && size.is_finite() {
                    1.0 / size.sqrt()
                } else {
                    1.0
                }
            })
            .collect();
        let scaled = |matrix: &DMatrix<f64>, factor: f64| {
            DMatrix::from_fn(n, n, |i, j| matrix[(i, j)] * scale[i] * scale[j] / factor)
        };
        for j in 0..n {
            for r in 0..rows {
                a[(r, j)] *= scale[j];
            }
        }
        for r in 0..rows {
            let size = a.row(r).amax();
            if size > 0.0 {
                a.row_mut(r).scale_mut(1.0 / size);
            }
        }
        Self {
            m: scaled(&m, tau * tau),
            d: scaled(&d, tau),
            k: scaled(&k, 1.0),
            a,
        }
    }

    /// An orthonormal basis (columns) of the kernel of the constraint rows.
    fn kernel(&self) -> DMatrix<f64> {
        let n = self.m.nrows();
        if self.a.nrows() == 0 {
            return DMatrix::identity(n, n);
        }
        // Pad to square so that the SVD returns a full Vᵀ.
        let mut padded = DMatrix::zeros(n.max(self.a.nrows()), n);
        padded.rows_mut(0, self.a.nrows()).copy_from(&self.a);
        let svd = padded.svd(false, true);
        let Some(vt) = svd.v_t else {
            return DMatrix::identity(n, n);
        };
        let largest = svd.singular_values.max();
        let columns: Vec<DVector<f64>> = (0..n)
            .filter(|&i| svd.singular_values[i] <= RANK_TOL * largest)
            .map(|i| vt.row(i).transpose())
            .collect();
        if columns.is_empty() {
            DMatrix::zeros(n, 0)
        } else {
            DMatrix::from_columns(&columns)
        }
    }

    /// The ordinary eigenproblem of the finite modes (see the module documentation).
    fn reduce(&self) -> Result<Reduced, ModesError> {
        let basis = self.kernel();
        let r = basis.ncols();
        let project = |x: &DMatrix<f64>| basis.transpose() * x * &basis;
        let (mr, dr, kr) = (project(&self.m), project(&self.d), project(&self.k));
        let symmetric = (&mr + mr.transpose()) * 0.5;
        let eigen = SymmetricEigen::new(symmetric);
        let largest = eigen.eigenvalues.amax();
        let massive: Vec<usize> = (0..r)
            .filter(|&i| eigen.eigenvalues[i].abs() > RANK_TOL * largest.max(1.0))
            .collect();
        let massless: Vec<usize> = (0..r).filter(|i| !massive.contains(i)).collect();
        let r1 = massive.len();
        let u1 = eigen.eigenvectors.select_columns(&massive);
        let u2 = eigen.eigenvectors.select_columns(&massless);
        let size = r + r1;
        // Unknowns z = (y, w): reduced positions and the velocities w = s·U1ᵀy.
        // Rows: U1ᵀ(·) [massive], U2ᵀ(·) [massless], s·U1ᵀy − w = 0 [definition].
        let mut b = DMatrix::zeros(size, size);
        let mut a = DMatrix::zeros(size, size);
        let lambda1 = u1.transpose() * &mr * &u1;
        b.view_mut((0, 0), (r1, r))
            .copy_from(&(u1.transpose() * &dr));
        b.view_mut((0, r), (r1, r1)).copy_from(&lambda1);
        b.view_mut((r1, 0), (r - r1, r))
            .copy_from(&(u2.transpose() * &dr));
        b.view_mut((r, 0), (r1, r)).copy_from(&u1.transpose());
        a.view_mut((0, 0), (r1, r))
            .copy_from(&(-(u1.transpose() * &kr)));
        a.view_mut((r1, 0), (r - r1, r))
            .copy_from(&(-(u2.transpose() * &kr)));
        a.view_mut((r, r), (r1, r1))
            .copy_from(&DMatrix::identity(r1, r1));
        let cols = balance(&mut a, &mut b);
        Reduced::eliminate(&a, &b, &cols, basis)
    }
}

/// Scales the rows and columns of the pencil `(a, b)` to unit max-norm (a few sweeps); returns
/// the column factors (balanced unknowns times them are the unknowns).
fn balance(a: &mut DMatrix<f64>, b: &mut DMatrix<f64>) -> Vec<f64> {
    let size = a.nrows();
    let mut cols = vec![1.0; size];
    for _ in 0..4 {
        for i in 0..size {
            let big = a.row(i).amax().max(b.row(i).amax());
            if big > 0.0 {
                a.row_mut(i).scale_mut(1.0 / big);
                b.row_mut(i).scale_mut(1.0 / big);
            }
        }
        for (j, col) in cols.iter_mut().enumerate() {
            let big = a.column(j).amax().max(b.column(j).amax());
            if big > 0.0 {
                a.column_mut(j).scale_mut(1.0 / big);
                b.column_mut(j).scale_mut(1.0 / big);
                *col /= big;
            }
        }
    }
    cols
}

/// `D T D⁻¹` with a diagonal `D` of powers of two that equalises the norms of each row and
/// column (Parlett–Reinsch, as LAPACK's `gebal`): the eigenvalues are the same, and their
/// rounding errors scale with the balanced norm instead of the largest entry.
fn similarity_balanced(t: &DMatrix<f64>) -> DMatrix<f64> {
    let mut b = t.clone();
    let size = b.nrows();
    let mut converged = false;
    let mut sweeps = 0;
    while !converged && sweeps < 100 {
        converged = true;
        sweeps += 1;
        for i in 0..size {
            let column: f64 = (0..size).filter(|&j| j != i).map(|j| b[(j, i)].abs()).sum();
            let row: f64 = (0..size).filter(|&j| j != i).map(|j| b[(i, j)].abs()).sum();
            if column == 0.0 || row == 0.0 {
                continue;
            }
            let mut f = 1.0;
            let (mut c, mut r) = (column, row);
            while c < r / 2.0 {
                c *= 2.0;
                r /= 2.0;
                f *= 2.0;
            }
            while c >= r * 2.0 {
                c /= 2.0;
                r *= 2.0;
                f /= 2.0;
            }
            if (c + r) < 0.95 * (column + row) {
                converged = false;
                b.column_mut(i).scale_mut(f);
                b.row_mut(i).scale_mut(1.0 / f);
            }
        }
    }
    b
}

/// The pencil `s b z = a z` reduced to `s ξ = T ξ`, with what it takes to map `ξ` back.
struct Reduced {
    t: DMatrix<f64>,
    /// `z = V [ξ; −X ξ]` (balanced unknowns), then `z_i · cols[i]`.
    v: DMatrix<f64>,
    x: DMatrix<f64>,
    cols: Vec<f64>,
    basis: DMatrix<f64>,
}

impl Reduced {
    fn eliminate(
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        cols: &[f64],
        basis: DMatrix<f64>,
    ) -> Result<Self, ModesError> {
        let size = a.nrows();
        if size == 0 {
            return Ok(Self {
                t: DMatrix::zeros(0, 0),
                v: DMatrix::zeros(0, 0),
                x: DMatrix::zeros(0, 0),
                cols: Vec::new(),
                basis,
            });
        }
        let svd = b.clone().svd(true, true);
        let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
            return Err(ModesError::NotConverged(size));
        };
        let sigma = &svd.singular_values;
        let largest = sigma.max();
        let mut order: Vec<usize> = (0..size).collect();
        order.sort_by(|&i, &j| sigma[j].total_cmp(&sigma[i]));
        let rank = order
            .iter()
            .take_while(|&&i| sigma[i] > RANK_TOL * largest)
            .count();
        if rank == size {
            // No algebraic unknowns: T = b⁻¹a by LU mixes the blocks less than the rotations.
            let t = b
                .clone()
                .lu()
                .solve(a)
                .ok_or_else(|| ModesError::Singular("mass-damping block".into()))?;
            return Ok(Self {
                t,
                v: DMatrix::identity(size, size),
                x: DMatrix::zeros(0, size),
                cols: cols.to_vec(),
                basis,
            });
        }
        let u = u.select_columns(&order);
        let v = vt.transpose().select_columns(&order);
        let rotated = u.transpose() * a * &v;
        let a11 = rotated.view((0, 0), (rank, rank)).into_owned();
        let a12 = rotated.view((0, rank), (rank, size - rank)).into_owned();
        let a21 = rotated.view((rank, 0), (size - rank, rank)).into_owned();
        let a22 = rotated
            .view((rank, rank), (size - rank, size - rank))
            .into_owned();
        let x = if size > rank {
            let check = a22.clone().svd(false, false);
            let smallest = check.singular_values.min();
            if smallest <= RANK_TOL * rotated.amax().max(1.0) {
                return Err(ModesError::Singular(format!(
                    "{} algebraic unknowns, {} of them not determined by the algebraic equations",
                    size - rank,
                    check
                        .singular_values
                        .iter()
                        .filter(|&&s| s <= RANK_TOL * rotated.amax().max(1.0))
                        .count()
                )));
            }
            a22.lu()
                .solve(&a21)
                .ok_or_else(|| ModesError::Singular("algebraic block".into()))?
        } else {
            DMatrix::zeros(0, rank)
        };
        let mut t = a11 - a12 * &x;
        for i in 0..rank {
            let s = sigma[order[i]];
            t.row_mut(i).scale_mut(1.0 / s);
        }
        Ok(Self {
            t,
            v,
            x,
            cols: cols.to_vec(),
            basis,
        })
    }

    fn eigenvalues(&self) -> Result<Vec<Complex<f64>>, ModesError> {
        let size = self.t.nrows();
        if size == 0 {
            return Ok(Vec::new());
        }
        if self.t.iter().any(|x| !x.is_finite()) {
            return Err(ModesError::Singular("non-finite reduced matrix".into()));
        }
        let schur = Schur::try_new(
            similarity_balanced(&self.t),
            f64::EPSILON,
            100 * size.max(10),
        )
        .ok_or(ModesError::NotConverged(size))?;
        Ok(schur.complex_eigenvalues().iter().copied().collect())
    }

    /// The coordinate that holds the most of the mode: the largest `|xᵢ|²(|Mᵢᵢ||s|² + |Dᵢᵢ||s| +
    /// |Kᵢᵢ|)` (an energy-like weight that does not depend on the scaling) over the eigenvector
    /// `x` of `s`, found by two steps of inverse iteration.
    fn dominant_coordinate(&self, s: Complex<f64>, lin: &Linearisation) -> Option<usize> {
        let size = self.t.nrows();
        let shift = s * (1.0 + 1e-10) + Complex::new(1e-12, 1e-12);
        let matrix = DMatrix::from_fn(size, size, |i, j| {
            Complex::new(self.t[(i, j)], 0.0) - if i == j { shift } else { Complex::ZERO }
        });
        let lu = matrix.lu();
        let mut xi = DVector::from_element(size, Complex::new(1.0, 0.0));
        for _ in 0..2 {
            xi = lu.solve(&xi)?;
            let norm = xi.norm();
            if !(norm > 0.0 && norm.is_finite()) {
                return None;
            }
            xi /= Complex::new(norm, 0.0);
        }
        let rank = size;
        let eta = -(self.x.map(|e| Complex::new(e, 0.0)) * &xi);
        let mut zeta = DVector::zeros(self.v.nrows());
        zeta.rows_mut(0, rank).copy_from(&xi);
        zeta.rows_mut(rank, self.v.nrows() - rank).copy_from(&eta);
        let z = self.v.map(|e| Complex::new(e, 0.0)) * zeta;
        let r = self.basis.ncols();
        let y = DVector::from_fn(r, |i, _| z[i] * self.cols[i]);
        let q = self.basis.map(|e| Complex::new(e, 0.0)) * y;
        let rate = s.norm();
        let weight = |i: usize| {
            q[i].norm_sqr()
                * (lin.m[(i, i)].abs() * rate * rate
                    + lin.d[(i, i)].abs() * rate
                    + lin.k[(i, i)].abs())
        };
        (0..q.len()).max_by(|&i, &j| weight(i).total_cmp(&weight(j)))
    }
}
