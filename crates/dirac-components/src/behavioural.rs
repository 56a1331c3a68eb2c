//! Behavioural sources (SPICE `B`, and `E`/`G` written with `VALUE=`, `VOL=`, `CUR=` or `POLY`):
//! an output voltage or current that is an arbitrary expression of sensed voltages, sensed
//! currents and time.
//!
//! The part generalises the linear controlled sources of [`crate::controlled`]: it has one output
//! branch (port `i`) and one sensing branch per control (ports `ic0`, `ic1`, …), sensed exactly as
//! there — a voltage by a branch `(q_c, φ_c)` that carries no current (`f_{q_c} = −φ̇_c`,
//! `f_{φ_c} = −q̇_c`, so `φ̇_c` is the voltage), a current by a short `q_c` in series with the
//! controlling element (no force, `q̇_c` is the current). With `x` the controlling rates and
//! `y = e(x, t)` the expression, a voltage output has `f_q = −y` and a current output an output
//! flux `φ` with `f_q = −φ̇`, `f_φ = y − q̇`. Each step applies its force quadrature to `y` at the
//! quadrature nodes' rates, as to any force; the force Jacobian carries `∂e/∂x` from forward-mode
//! differentiation of the expression, so Newton converges quadratically on a smooth expression.
//!
//! [`Expression`] follows ngspice's B-source arithmetic (`inpptree.c`, `ptfuncs.c` of
//! ngspice-39): `a ^ b` and `pow(a, b)` are `|a|^b`, `pwr(a, b)` is `sgn(a)·|a|^b`, comparisons
//! are 1 or 0, `u`, `u2`, `uramp` are the unit step, the clipped ramp and the ramp. Square roots
//! and logarithms of negative numbers are not defined (ngspice stops with "out of range"): they
//! evaluate to NaN, which Newton reports as a non-finite residual at the step it occurs. As in
//! ngspice, `ln 0` is −1e99 and a divisor is moved 1e-32 away from zero, so an iterate passing
//! through such a point (a Newton start at 0 V) is finite; an infinite slope there counts as
//! ±1e12.

use dirac_core::{ForceJacobian, Model};
use dirac_graph::{PartError, Subsystem};

use crate::{flux_branch_force, flux_branch_jacobian};

/// A one-argument function of an [`Expression`] (ngspice's names in brackets).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Function {
    /// `−a`.
    Neg,
    /// `|a|` (`abs`).
    Abs,
    /// The sign, −1, 0 or 1 (`sgn`).
    Sgn,
    /// `√a` (`sqrt`; NaN below 0).
    Sqrt,
    /// `eᵃ` (`exp`).
    Exp,
    /// Natural logarithm (`ln`, `log`; NaN below 0).
    Ln,
    /// Decimal logarithm (`log10`; NaN below 0).
    Log10,
    /// `sin`.
    Sin,
    /// `cos`.
    Cos,
    /// `tan`.
    Tan,
    /// `asin`.
    Asin,
    /// `acos`.
    Acos,
    /// `atan`.
    Atan,
    /// `sinh`.
    Sinh,
    /// `cosh`.
    Cosh,
    /// `tanh`.
    Tanh,
    /// `asinh`.
    Asinh,
    /// `acosh`.
    Acosh,
    /// `atanh`.
    Atanh,
    /// Unit step: 0 below 0, ½ at 0, 1 above (`u`).
    Step,
    /// Clipped ramp: 0 up to 0, `a` on (0, 1], 1 above (`u2`).
    ClippedRamp,
    /// Ramp: 0 below 0, `a` above (`uramp`).
    Ramp,
    /// `ceil`.
    Ceil,
    /// `floor`.
    Floor,
    /// Nearest integer, halves to even (`nint`).
    Round,
    /// 1 where `a = 0`, else 0 (`==`, `!`, `&&`).
    IsZero,
    /// 1 where `a ≠ 0`, else 0 (`!=`, `||`).
    IsNonZero,
    /// 1 where `a > 0` (`>`).
    IsPositive,
    /// 1 where `a < 0` (`<`).
    IsNegative,
    /// 1 where `a ≥ 0` (`>=`).
    IsNonNegative,
    /// 1 where `a ≤ 0` (`<=`).
    IsNonPositive,
}

/// A two-argument operation of an [`Expression`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operator {
    /// `a + b`.
    Add,
    /// `a − b`.
    Sub,
    /// `a · b`.
    Mul,
    /// `a / b`.
    Div,
    /// `|a|^b` (ngspice's `^`, `**` and `pow`).
    Pow,
    /// `sgn(a)·|a|^b` (`pwr`).
    Pwr,
    /// The smaller (`min`).
    Min,
    /// The larger (`max`).
    Max,
}

impl Function {
    /// `f(a)`.
    #[must_use]
    pub fn apply(self, a: f64) -> f64 {
        unary(self, Dual::flat(a)).v
    }
}

impl Operator {
    /// `a op b`.
    #[must_use]
    pub fn apply(self, a: f64, b: f64) -> f64 {
        binary(self, Dual::flat(a), Dual::flat(b)).v
    }
}

/// An expression of the controlling rates `x₀, x₁, …` and time `t`.
#[derive(Debug, Clone, PartialEq)]
pub enum Expression {
    /// A number.
    Constant(f64),
    /// The `k`-th controlling rate (a sensed voltage or current).
    Control(usize),
    /// Time.
    Time,
    /// `f(a)`.
    Unary(Function, Box<Expression>),
    /// `a op b`.
    Binary(Operator, Box<Expression>, Box<Expression>),
    /// `c ? a : b`: `a` where `c ≠ 0`, else `b`.
    Conditional(Box<Expression>, Box<Expression>, Box<Expression>),
    /// `pwl(a, x₀, y₀, x₁, y₁, …)`: the polyline through the points (`x` strictly increasing, at
    /// least two), extended beyond its ends along its first and last segments, as ngspice's
    /// `pwl` function computes it.
    Piecewise(Box<Expression>, Vec<(f64, f64)>),
    /// An `E`/`G` `TABLE`: ngspice's XSPICE `pwl` model as ngspice-39 builds it for one
    /// (`limit=TRUE`, `fraction=TRUE`, `input_domain=0.1`): the polyline through the points
    /// (`x` strictly increasing, at least two), flat beyond the ends, each corner rounded by a
    /// parabola over ±10 % of the shorter adjacent segment.
    Table(Box<Expression>, Vec<(f64, f64)>),
}

/// A value and its derivative along one direction.
#[derive(Debug, Clone, Copy)]
struct Dual {
    v: f64,
    d: f64,
}

impl Dual {
    fn flat(v: f64) -> Self {
        Self { v, d: 0.0 }
    }
}

/// `|a|^(b−1)` with ngspice's sign for `a < 0` (`pwr`): the factor of `b·da` in `d|a|^b`.
fn power_slope(a: f64, b: f64) -> f64 {
    if a < 0.0 {
        -(-a).powf(b - 1.0)
    } else {
        a.powf(b - 1.0)
    }
}

impl Expression {
    /// The value at rates `x` and time `t`.
    #[must_use]
    pub fn value(&self, x: &[f64], t: f64) -> f64 {
        self.dual(x, t, None).v
    }

    /// The value and its derivative with respect to `x[k]`.
    #[must_use]
    pub fn value_and_derivative(&self, x: &[f64], t: f64, k: usize) -> (f64, f64) {
        let r = self.dual(x, t, Some(k));
        (r.v, r.d)
    }

    /// The number of controls the expression reads (one more than the largest index).
    #[must_use]
    pub fn controls(&self) -> usize {
        match self {
            Self::Constant(_) | Self::Time => 0,
            Self::Control(k) => k + 1,
            Self::Unary(_, a) => a.controls(),
            Self::Binary(_, a, b) => a.controls().max(b.controls()),
            Self::Conditional(c, a, b) => c.controls().max(a.controls()).max(b.controls()),
            Self::Piecewise(a, _) | Self::Table(a, _) => a.controls(),
        }
    }

    /// Whether the expression reads time.
    #[must_use]
    pub fn reads_time(&self) -> bool {
        match self {
            Self::Constant(_) | Self::Control(_) => false,
            Self::Time => true,
            Self::Unary(_, a) => a.reads_time(),
            Self::Binary(_, a, b) => a.reads_time() || b.reads_time(),
            Self::Conditional(c, a, b) => c.reads_time() || a.reads_time() || b.reads_time(),
            Self::Piecewise(a, _) | Self::Table(a, _) => a.reads_time(),
        }
    }

    fn dual(&self, x: &[f64], t: f64, k: Option<usize>) -> Dual {
        match self {
            Self::Constant(c) => Dual::flat(*c),
            Self::Control(j) => Dual {
                v: x[*j],
                d: if k == Some(*j) { 1.0 } else { 0.0 },
            },
            Self::Time => Dual::flat(t),
            Self::Unary(f, a) => unary(*f, a.dual(x, t, k)),
            Self::Binary(op, a, b) => binary(*op, a.dual(x, t, k), b.dual(x, t, k)),
            Self::Conditional(c, a, b) => {
                if c.dual(x, t, k).v != 0.0 {
                    a.dual(x, t, k)
                } else {
                    b.dual(x, t, k)
                }
            }
            Self::Table(a, points) => {
                let a = a.dual(x, t, k);
                let (v, slope) = smooth_table(points, a.v);
                Dual { v, d: slope * a.d }
            }
            Self::Piecewise(a, points) => {
                let a = a.dual(x, t, k);
                let ((x0, y0), (x1, y1)) = segment(points, a.v);
                let slope = (y1 - y0) / (x1 - x0);
                Dual {
                    v: y0 + slope * (a.v - x0),
                    d: slope * a.d,
                }
            }
        }
    }
}

/// The segment of `points` that `pwl` uses at `a`: ngspice's bisection (`PTpwl`), the first or
/// last segment outside the points, the one to the right of a point met exactly.
fn segment(points: &[(f64, f64)], a: f64) -> ((f64, f64), (f64, f64)) {
    let (mut k0, mut k1) = (0, points.len().saturating_sub(1));
    while k1 - k0 > 1 {
        let k = (k0 + k1) / 2;
        if points[k].0 > a {
            k1 = k;
        } else {
            k0 = k;
        }
    }
    (points[k0], points[k1])
}

/// The value and slope of an `E`/`G` `TABLE` at `a` (XSPICE's `pwl` code model, `cfunc.mod`, with
/// `limit`, `fraction` and `input_domain = 0.1`; its corner parabola is `cm_smooth_corner`).
fn smooth_table(points: &[(f64, f64)], a: f64) -> (f64, f64) {
    let n = points.len();
    // The points with one more at each end, as far out as the neighbouring one, at the same y.
    let at = |i: usize| -> (f64, f64) {
        match i {
            0 => (2.0 * points[0].0 - points[1].0, points[0].1),
            i if i == n + 1 => (2.0 * points[n - 1].0 - points[n - 2].0, points[n - 1].1),
            i => points[i - 1],
        }
    };
    let size = n + 2;
    if a <= (at(0).0 + at(1).0) / 2.0 {
        return (at(0).1, 0.0);
    }
    if a >= (at(size - 2).0 + at(size - 1).0) / 2.0 {
        return (at(size - 1).1, 0.0);
    }
    for i in 1..size - 1 {
        let ((x0, y0), (x1, y1), (x2, y2)) = (at(i - 1), at(i), at(i + 1));
        if a >= (x1 + x2) / 2.0 {
            continue;
        }
        let (lower, upper) = (x1 - x0, x2 - x1);
        let (lower_slope, upper_slope) = ((y1 - y0) / lower, (y2 - y1) / upper);
        let domain = 0.1 * lower.min(upper);
        if a < x1 - domain {
            return (y1 + (a - x1) * lower_slope, lower_slope);
        }
        if a >= x1 + domain {
            return (y1 + (a - x1) * upper_slope, upper_slope);
        }
        let x_upper = x1 + domain;
        let y_upper = y1 + upper_slope * domain;
        let p = (upper_slope - lower_slope) / 4.0 / domain;
        let q = upper_slope - 2.0 * p * x_upper;
        let r = y_upper - p * x_upper * x_upper - q * x_upper;
        return (p * a * a + q * a + r, 2.0 * p * a + q);
    }
    (at(size - 1).1, 0.0)
}

/// `f(a)` with its derivative (zero where `f` is piecewise constant).
fn unary(f: Function, a: Dual) -> Dual {
    let Dual { v, d } = a;
    let (value, slope) = match f {
        Function::Neg => (-v, -1.0),
        Function::Abs => (v.abs(), if v < 0.0 { -1.0 } else { 1.0 }),
        Function::Sqrt => {
            let r = if v < 0.0 { f64::NAN } else { v.sqrt() };
            (r, 0.5 / r)
        }
        Function::Exp => {
            let e = v.exp();
            (e, e)
        }
        Function::Ln => (logarithm(v, f64::ln), 1.0 / v),
        Function::Log10 => (
            logarithm(v, f64::log10),
            1.0 / (v * std::f64::consts::LN_10),
        ),
        Function::Sin => (v.sin(), v.cos()),
        Function::Cos => (v.cos(), -v.sin()),
        Function::Tan => {
            let tan = v.tan();
            (tan, 1.0 + tan * tan)
        }
        Function::Asin => (v.asin(), 1.0 / (1.0 - v * v).sqrt()),
        Function::Acos => (v.acos(), -1.0 / (1.0 - v * v).sqrt()),
        Function::Atan => (v.atan(), 1.0 / (1.0 + v * v)),
        Function::Sinh => (v.sinh(), v.cosh()),
        Function::Cosh => (v.cosh(), v.sinh()),
        Function::Tanh => {
            let tanh = v.tanh();
            (tanh, 1.0 - tanh * tanh)
        }
        Function::Asinh => (v.asinh(), 1.0 / (v * v + 1.0).sqrt()),
        Function::Acosh => (v.acosh(), 1.0 / (v * v - 1.0).sqrt()),
        Function::Atanh => (v.atanh(), 1.0 / (1.0 - v * v)),
        Function::ClippedRamp => match v {
            v if v <= 0.0 => (0.0, 0.0),
            v if v <= 1.0 => (v, 1.0),
            _ => (1.0, 0.0),
        },
        Function::Ramp => {
            if v < 0.0 {
                (0.0, 0.0)
            } else {
                (v, 1.0)
            }
        }
        Function::Sgn
        | Function::Step
        | Function::Ceil
        | Function::Floor
        | Function::Round
        | Function::IsZero
        | Function::IsNonZero
        | Function::IsPositive
        | Function::IsNegative
        | Function::IsNonNegative
        | Function::IsNonPositive => (piecewise_constant(f, v), 0.0),
    };
    // At a singular point with a finite value (√0, ln 0 as ngspice reads it) the slope is taken
    // as ±STEEP, so a Newton iterate that passes there (a start at 0 V) gets a finite step.
    let slope = if value.is_finite() && !slope.is_finite() && !slope.is_nan() {
        STEEP.copysign(slope)
    } else {
        slope
    };
    Dual {
        v: value,
        // A flat argument keeps a flat result even where the slope is infinite (√0, ln 0).
        d: if d == 0.0 { 0.0 } else { slope * d },
    }
}

/// Controls whose rates a force evaluation gathers on the stack.
const INLINE_CONTROLS: usize = 8;

/// The magnitude ngspice-39 gives `ln 0` (`PTlog`: −1e99).
const SINGULAR: f64 = 1e99;

/// The slope taken where a function's is infinite at a finite value: steep, yet within the range
/// the sparse LU's pivot checks accept beside the circuit's unit-sized entries.
const STEEP: f64 = 1e12;

/// What ngspice-39 adds to a divisor away from zero before dividing (`PTfudge_factor`: GMIN·1e-20
/// with its default GMIN), so that `1/v(a)` at a Newton start of 0 V is large, not infinite.
const DIVISION_FUDGE: f64 = 1e-32;

/// A logarithm as ngspice-39 evaluates it: not defined below 0 (NaN, which Newton reports), −1e99
/// at 0.
fn logarithm(v: f64, log: fn(f64) -> f64) -> f64 {
    if v < 0.0 {
        f64::NAN
    } else if v == 0.0 {
        -SINGULAR
    } else {
        log(v)
    }
}

fn piecewise_constant(f: Function, v: f64) -> f64 {
    let indicator = |b: bool| if b { 1.0 } else { 0.0 };
    match f {
        Function::Sgn => {
            if v > 0.0 {
                1.0
            } else if v < 0.0 {
                -1.0
            } else {
                0.0
            }
        }
        Function::Step => {
            if v > 0.0 {
                1.0
            } else if v < 0.0 {
                0.0
            } else {
                0.5
            }
        }
        Function::Ceil => v.ceil(),
        Function::Floor => v.floor(),
        Function::Round => v.round_ties_even(),
        Function::IsZero => indicator(v == 0.0),
        Function::IsNonZero => indicator(v != 0.0),
        Function::IsPositive => indicator(v > 0.0),
        Function::IsNegative => indicator(v < 0.0),
        Function::IsNonNegative => indicator(v >= 0.0),
        Function::IsNonPositive => indicator(v <= 0.0),
        _ => f64::NAN,
    }
}

/// `a op b` with its derivative; an infinite slope at a finite value (`√`-like powers at 0, a
/// divisor at 0) taken as ±STEEP, as [`unary`] does.
fn binary(op: Operator, a: Dual, b: Dual) -> Dual {
    let mut r = binary_exact(op, a, b);
    let at_zero_divisor = op == Operator::Div && b.v == 0.0;
    if r.v.is_finite() && (r.d.is_infinite() || (at_zero_divisor && r.d.abs() > STEEP)) {
        r.d = STEEP.copysign(r.d);
    }
    r
}

fn binary_exact(op: Operator, a: Dual, b: Dual) -> Dual {
    match op {
        Operator::Add => Dual {
            v: a.v + b.v,
            d: a.d + b.d,
        },
        Operator::Sub => Dual {
            v: a.v - b.v,
            d: a.d - b.d,
        },
        Operator::Mul => Dual {
            v: a.v * b.v,
            d: a.d * b.v + a.v * b.d,
        },
        Operator::Div => {
            let divisor = b.v + DIVISION_FUDGE.copysign(if b.v >= 0.0 { 1.0 } else { -1.0 });
            Dual {
                v: a.v / divisor,
                d: (a.d * divisor - a.v * b.d) / (divisor * divisor),
            }
        }
        Operator::Pow | Operator::Pwr => {
            let magnitude = a.v.abs().powf(b.v);
            let v = if op == Operator::Pwr && a.v < 0.0 {
                -magnitude
            } else {
                magnitude
            };
            // d|a|^b/da = b·sgn(a)·|a|^(b−1), d(sgn(a)|a|^b)/da = b·|a|^(b−1); ngspice's
            // derivative (inpptree.c) takes sgn(0) = +1.
            let da = if a.d == 0.0 {
                0.0
            } else if op == Operator::Pow {
                b.v * power_slope(a.v, b.v) * a.d
            } else {
                b.v * a.v.abs().powf(b.v - 1.0) * a.d
            };
            let db = if b.d == 0.0 {
                0.0
            } else {
                v * a.v.abs().ln() * b.d
            };
            Dual { v, d: da + db }
        }
        Operator::Min => {
            if a.v > b.v {
                b
            } else {
                a
            }
        }
        Operator::Max => {
            if a.v > b.v {
                a
            } else {
                b
            }
        }
    }
}

/// What a behavioural source drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// A voltage `v₊ − v₋ = e` (SPICE `B … V=`, `E … VALUE=`).
    Voltage,
    /// A current `e` from `+` through the source to `−` (SPICE `B … I=`, `G … VALUE=`).
    Current,
}

/// What a behavioural source senses at one control.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// A voltage, by a branch that carries no current across the two nodes.
    Voltage,
    /// A current, by a short in series with the controlling element.
    Current,
}

impl Control {
    /// Coordinates of the sensing branch.
    fn dim(self) -> usize {
        match self {
            Self::Voltage => 2,
            Self::Current => 1,
        }
    }
}

/// A source whose output voltage or current is an [`Expression`] of sensed voltages and currents
/// and of time (SPICE `B`).
///
/// Coordinates: the output charge `q` (and for a current output its flux `φ`), then per control
/// `q_c` (and for a voltage control `φ_c`). Ports: `i` (coordinate 0) and `ic0`, `ic1`, … (each
/// control's `q_c`).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct BehaviouralSource {
    /// What it drives.
    pub output: Output,
    /// What it senses, in the order of [`Expression::Control`]'s index.
    pub controls: Vec<Control>,
    /// The output's value.
    pub expression: Expression,
    /// Per control, the coordinate of its rate `x_k` (`φ_c` or `q_c`).
    rates: Vec<usize>,
    /// The times at which the expression stops being smooth in time, ascending.
    corners: Vec<f64>,
}

impl BehaviouralSource {
    /// A source driving `output` with `expression` of `controls`.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `expression` when it reads a control that `controls` does
    /// not list (the value is the control's index), or holds a number that is not finite.
    pub fn new(
        output: Output,
        controls: Vec<Control>,
        expression: Expression,
    ) -> Result<Self, PartError> {
        if expression.controls() > controls.len() {
            return Err(PartError::Parameter {
                part: "behavioural",
                parameter: "expression".into(),
                value: (expression.controls() - 1) as f64,
                requirement: "reads a control the source does not sense",
            });
        }
        if let Some(value) = badly_ordered(&expression) {
            return Err(PartError::Parameter {
                part: "behavioural",
                parameter: "expression".into(),
                value,
                requirement: "needs pwl points at strictly increasing x, two at least",
            });
        }
        if let Some(value) = first_non_finite(&expression) {
            return Err(PartError::Parameter {
                part: "behavioural",
                parameter: "expression".into(),
                value,
                requirement: "must hold finite numbers only",
            });
        }
        let mut rates = Vec::with_capacity(controls.len());
        let mut at = output_dim(output);
        for c in &controls {
            rates.push(at + c.dim() - 1);
            at += c.dim();
        }
        let mut corners = Vec::new();
        time_corners(&expression, &mut corners);
        corners.retain(|c| c.is_finite());
        corners.sort_by(f64::total_cmp);
        corners.dedup();
        Ok(Self {
            output,
            controls,
            expression,
            rates,
            corners,
        })
    }

    /// The port of control `k`.
    #[must_use]
    pub fn control_port(k: usize) -> String {
        format!("ic{k}")
    }

    /// This part as a subsystem named `name` with ports `i` (output) and `ic0`, `ic1`, …
    /// (sensing branches).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        let mut at = output_dim(self.output);
        let ports: Vec<(String, usize)> = self
            .controls
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let port = (Self::control_port(k), at);
                at += c.dim();
                port
            })
            .collect();
        let mut subsystem = Subsystem::new(name, self).with_port("i", 0);
        for (port, coordinate) in ports {
            subsystem = subsystem.with_port(port, coordinate);
        }
        subsystem
    }

    /// Calls `f` with the controlling rates read from `v`: on the stack for up to
    /// [`INLINE_CONTROLS`] controls (the force is evaluated at every quadrature node of every
    /// Newton iteration), in a vector beyond.
    fn with_rates<R>(&self, v: &[f64], f: impl FnOnce(&[f64]) -> R) -> R {
        let n = self.rates.len();
        if n <= INLINE_CONTROLS {
            let mut x = [0.0; INLINE_CONTROLS];
            for (slot, &i) in x.iter_mut().zip(&self.rates) {
                *slot = v[i];
            }
            f(&x[..n])
        } else {
            f(&self.rates.iter().map(|&i| v[i]).collect::<Vec<f64>>())
        }
    }
}

fn output_dim(output: Output) -> usize {
    match output {
        Output::Voltage => 1,
        Output::Current => 2,
    }
}

/// `(a, b)` when `e` is `a·t + b` in time alone (no control), checked on three times.
fn affine_in_time(e: &Expression) -> Option<(f64, f64)> {
    if e.controls() > 0 || !e.reads_time() {
        return None;
    }
    let at = |t: f64| e.value(&[], t);
    let (b, slope) = (at(0.0), at(1.0) - at(0.0));
    let check = at(2.0);
    let affine = (check - (b + 2.0 * slope)).abs() <= 1e-12 * (1.0 + check.abs());
    (affine && slope != 0.0 && slope.is_finite() && b.is_finite()).then_some((slope, b))
}

/// Collects the times at which `e` stops being smooth in time: where the argument of a step, a
/// sign, a comparison, an absolute value or a ramp that is affine in time crosses its corner
/// (0, and 1 for `u2`), where two such arguments of `min`/`max` cross, and the points of a `pwl`
/// of time; as a `PULSE`'s corners, the integrator lands a step on each.
fn time_corners(e: &Expression, out: &mut Vec<f64>) {
    let root = |a: &Expression, level: f64, out: &mut Vec<f64>| {
        if let Some((slope, b)) = affine_in_time(a) {
            out.push((level - b) / slope);
        }
    };
    match e {
        Expression::Constant(_) | Expression::Control(_) | Expression::Time => {}
        Expression::Unary(f, a) => {
            match f {
                Function::Step
                | Function::Sgn
                | Function::Abs
                | Function::Ramp
                | Function::IsZero
                | Function::IsNonZero
                | Function::IsPositive
                | Function::IsNegative
                | Function::IsNonNegative
                | Function::IsNonPositive => root(a, 0.0, out),
                Function::ClippedRamp => {
                    root(a, 0.0, out);
                    root(a, 1.0, out);
                }
                _ => {}
            }
            time_corners(a, out);
        }
        Expression::Binary(op, a, b) => {
            if matches!(op, Operator::Min | Operator::Max) {
                let difference = Expression::Binary(Operator::Sub, a.clone(), b.clone());
                root(&difference, 0.0, out);
            }
            time_corners(a, out);
            time_corners(b, out);
        }
        Expression::Conditional(c, a, b) => {
            time_corners(c, out);
            time_corners(a, out);
            time_corners(b, out);
        }
        Expression::Piecewise(a, points) => {
            for &(x, _) in points {
                root(a, x, out);
            }
            time_corners(a, out);
        }
        Expression::Table(a, _) => time_corners(a, out),
    }
}

/// The first `x` of a `pwl` in `e` that does not exceed the one before it (or the only point's).
fn badly_ordered(e: &Expression) -> Option<f64> {
    match e {
        Expression::Constant(_) | Expression::Control(_) | Expression::Time => None,
        Expression::Unary(_, a) => badly_ordered(a),
        Expression::Binary(_, a, b) => badly_ordered(a).or_else(|| badly_ordered(b)),
        Expression::Conditional(c, a, b) => badly_ordered(c)
            .or_else(|| badly_ordered(a))
            .or_else(|| badly_ordered(b)),
        Expression::Piecewise(a, points) | Expression::Table(a, points) => {
            match points.as_slice() {
                [] => Some(f64::NAN),
                [(x, _)] => Some(*x),
                _ => points
                    .windows(2)
                    .find(|w| w[1].0 <= w[0].0)
                    .map(|w| w[1].0)
                    .or_else(|| badly_ordered(a)),
            }
        }
    }
}

/// The first number of `e` that is not finite.
fn first_non_finite(e: &Expression) -> Option<f64> {
    match e {
        Expression::Constant(c) => (!c.is_finite()).then_some(*c),
        Expression::Control(_) | Expression::Time => None,
        Expression::Unary(_, a) => first_non_finite(a),
        Expression::Binary(_, a, b) => first_non_finite(a).or_else(|| first_non_finite(b)),
        Expression::Conditional(c, a, b) => first_non_finite(c)
            .or_else(|| first_non_finite(a))
            .or_else(|| first_non_finite(b)),
        Expression::Piecewise(a, points) | Expression::Table(a, points) => points
            .iter()
            .flat_map(|&(x, y)| [x, y])
            .find(|v| !v.is_finite())
            .or_else(|| first_non_finite(a)),
    }
}

impl Model for BehaviouralSource {
    fn dim(&self) -> usize {
        output_dim(self.output) + self.controls.iter().map(|c| c.dim()).sum::<usize>()
    }
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        !self.expression.reads_time()
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.corners.iter().copied().find(|&c| c > t)
    }
    fn force(&self, _q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        let y = self.with_rates(v, |x| self.expression.value(x, t));
        match self.output {
            Output::Voltage => f[0] = -y,
            Output::Current => {
                flux_branch_force(v, 0, f);
                f[1] += y;
            }
        }
        let mut at = output_dim(self.output);
        for c in &self.controls {
            match c {
                Control::Voltage => flux_branch_force(v, at, f),
                Control::Current => f[at] = 0.0,
            }
            at += c.dim();
        }
    }
    fn force_jacobian(&self, _q: &[f64], v: &[f64], t: f64, j: &mut ForceJacobian) {
        let (row, sign) = match self.output {
            Output::Voltage => (0, -1.0),
            Output::Current => {
                flux_branch_jacobian(0, j);
                (1, 1.0)
            }
        };
        self.with_rates(v, |x| {
            for (k, &rate) in self.rates.iter().enumerate() {
                let (_, slope) = self.expression.value_and_derivative(x, t, k);
                j.v.add(row, rate, sign * slope);
            }
        });
        let mut at = output_dim(self.output);
        for c in &self.controls {
            if *c == Control::Voltage {
                flux_branch_jacobian(at, j);
            }
            at += c.dim();
        }
    }
    fn coordinate_name(&self, i: usize) -> String {
        let out = output_dim(self.output);
        if i < out {
            return ["q", "phi"][i].into();
        }
        let mut at = out;
        for (k, c) in self.controls.iter().enumerate() {
            if i < at + c.dim() {
                return if i == at {
                    format!("q_c{k}")
                } else {
                    format!("phi_c{k}")
                };
            }
            at += c.dim();
        }
        format!("q{i}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::check_model;

    fn c(v: f64) -> Box<Expression> {
        Box::new(Expression::Constant(v))
    }
    fn x(k: usize) -> Box<Expression> {
        Box::new(Expression::Control(k))
    }
    fn bin(op: Operator, a: Box<Expression>, b: Box<Expression>) -> Box<Expression> {
        Box::new(Expression::Binary(op, a, b))
    }
    fn un(f: Function, a: Box<Expression>) -> Box<Expression> {
        Box::new(Expression::Unary(f, a))
    }

    /// Values as ngspice-39 printed them for `v(a) = −2` (`.op` of `b1 b 0 v = v(a)^3`, …):
    /// `^` and `pow` give 8, `pwr` −8, `2^3^2` 64 (left-associative, parsed elsewhere),
    /// `v(a) > −3 ? 5 : 6` 5, `log(−v(a))` 0.6931472.
    #[test]
    fn arithmetic_as_ngspice_evaluates_it() {
        let a = [-2.0];
        let pow = bin(Operator::Pow, x(0), c(3.0));
        assert_eq!(pow.value(&a, 0.0), 8.0);
        assert_eq!(bin(Operator::Pwr, x(0), c(3.0)).value(&a, 0.0), -8.0);
        let gt = un(Function::IsPositive, bin(Operator::Sub, x(0), c(-3.0)));
        let cond = Expression::Conditional(gt, c(5.0), c(6.0));
        assert_eq!(cond.value(&a, 0.0), 5.0);
        let log = un(Function::Ln, un(Function::Neg, x(0)));
        assert_eq!(log.value(&a, 0.0), std::f64::consts::LN_2);
        assert!(un(Function::Sqrt, x(0)).value(&a, 0.0).is_nan());
        assert_eq!(un(Function::Step, c(0.0)).value(&a, 0.0), 0.5);
        assert_eq!(un(Function::ClippedRamp, c(0.25)).value(&a, 0.0), 0.25);
        assert_eq!(un(Function::Round, c(2.5)).value(&a, 0.0), 2.0);
        // ngspice-39, `pwl(v(b)·s, -1,0, 0,1, 1,3)` at v(b) = −0.5: s = 1 → 0.5, s = 4 → −1 (the
        // first segment extended), s = −4 → 5 (the last one extended).
        let table = vec![(-1.0, 0.0), (0.0, 1.0), (1.0, 3.0)];
        for (scale, printed) in [(1.0, 0.5), (4.0, -1.0), (-4.0, 5.0)] {
            let e = Expression::Piecewise(bin(Operator::Mul, x(0), c(scale)), table.clone());
            assert_eq!(e.value(&[-0.5], 0.0), printed);
        }
    }

    /// Every smooth function's derivative against a central difference.
    #[test]
    fn derivatives_match_differences() {
        let functions = [
            Function::Neg,
            Function::Abs,
            Function::Sqrt,
            Function::Exp,
            Function::Ln,
            Function::Log10,
            Function::Sin,
            Function::Cos,
            Function::Tan,
            Function::Asin,
            Function::Acos,
            Function::Atan,
            Function::Sinh,
            Function::Cosh,
            Function::Tanh,
            Function::Asinh,
            Function::Atanh,
            Function::ClippedRamp,
            Function::Ramp,
        ];
        let operators = [
            Operator::Add,
            Operator::Sub,
            Operator::Mul,
            Operator::Div,
            Operator::Pow,
            Operator::Pwr,
            Operator::Min,
            Operator::Max,
        ];
        let mut expressions: Vec<Box<Expression>> =
            functions.iter().map(|&f| un(f, x(0))).collect();
        expressions.push(un(Function::Acosh, bin(Operator::Add, x(0), c(2.0))));
        let table = vec![(-1.0, 0.5), (0.5, 1.0), (1.0, -2.0)];
        expressions.push(Box::new(Expression::Piecewise(x(0), table.clone())));
        // On `wide`, 0.37 lies on the corner parabola at 0.4 (±0.14) and 0.61 on a straight piece.
        let wide = vec![(-1.0, 0.5), (0.4, 1.0), (2.0, -2.0)];
        expressions.push(Box::new(Expression::Table(x(0), wide)));
        expressions.push(Box::new(Expression::Table(x(0), table)));
        for op in operators {
            expressions.push(bin(op, x(0), x(1)));
            expressions.push(bin(op, un(Function::Neg, x(1)), x(0)));
        }
        for e in &expressions {
            for point in [[0.37, 1.3], [0.61, -0.8]] {
                for k in 0..2 {
                    let (_, slope) = e.value_and_derivative(&point, 0.0, k);
                    let step = 1e-6;
                    let (mut up, mut down) = (point, point);
                    up[k] += step;
                    down[k] -= step;
                    let difference = (e.value(&up, 0.0) - e.value(&down, 0.0)) / (2.0 * step);
                    if difference.is_nan() {
                        continue;
                    }
                    assert!(
                        (slope - difference).abs() < 1e-6 * (1.0 + slope.abs()),
                        "{e:?} at {point:?}, x{k}: {slope} against {difference}"
                    );
                }
            }
        }
    }

    /// The part's hand-assembled force Jacobian against central differences of its forces.
    #[test]
    fn jacobians_match_differences() {
        // y = x0·x1 + exp(x2)·t, a voltage output and a current output.
        let e = Expression::Binary(
            Operator::Add,
            bin(Operator::Mul, x(0), x(1)),
            bin(
                Operator::Mul,
                un(Function::Exp, x(2)),
                Box::new(Expression::Time),
            ),
        );
        let controls = vec![Control::Voltage, Control::Current, Control::Voltage];
        for output in [Output::Voltage, Output::Current] {
            let part = BehaviouralSource::new(output, controls.clone(), e.clone()).unwrap();
            let n = part.dim();
            let q: Vec<f64> = (0..n).map(|i| 0.1 * i as f64 - 0.2).collect();
            let v: Vec<f64> = (0..n).map(|i| 0.3 - 0.17 * i as f64).collect();
            check_model(&part, &q, &v, 0.7);
        }
        // More controls than are gathered on the stack: the same derivatives from a vector.
        let many = (1..10).fold(Expression::Control(0), |e, k| {
            Expression::Binary(Operator::Mul, Box::new(e), x(k))
        });
        let part =
            BehaviouralSource::new(Output::Current, vec![Control::Current; 10], many).unwrap();
        let n = part.dim();
        let q: Vec<f64> = (0..n).map(|i| 0.05 * i as f64).collect();
        let v: Vec<f64> = (0..n).map(|i| 1.0 - 0.03 * i as f64).collect();
        check_model(&part, &q, &v, 0.0);
    }

    /// A source of `k·x` behaves as the linear controlled source of the same gain: same forces.
    #[test]
    fn a_linear_expression_is_the_linear_source() {
        let part = BehaviouralSource::new(
            Output::Voltage,
            vec![Control::Voltage],
            Expression::Binary(Operator::Mul, c(-37.0), x(0)),
        )
        .unwrap();
        let linear = crate::Vcvs::new(-37.0).unwrap();
        let v = [0.3, -1.1, 2.5];
        let (mut f, mut g) = ([0.0; 3], [0.0; 3]);
        part.force(&[0.0; 3], &v, 0.0, &mut f);
        linear.force(&[0.0; 3], &v, 0.0, &mut g);
        assert_eq!(f, g);
    }

    /// Corners in time: `u(time − 1m)`, `time > 2m ? …`, `min(time, 3m)`, a `pwl` of time with
    /// points at 4m and 5m (time scaled by 1k), `u2` of an affine argument at both ends; none for a
    /// smooth `sin(time)` or an expression of controls.
    #[test]
    fn time_corners_are_breakpoints() {
        let t = || Box::new(Expression::Time);
        let e = Expression::Binary(
            Operator::Add,
            bin(
                Operator::Add,
                un(Function::Step, bin(Operator::Sub, t(), c(1e-3))),
                un(Function::IsPositive, bin(Operator::Sub, t(), c(2e-3))),
            ),
            bin(
                Operator::Add,
                bin(Operator::Min, t(), c(3e-3)),
                bin(
                    Operator::Add,
                    Box::new(Expression::Piecewise(
                        bin(Operator::Mul, t(), c(1e3)),
                        vec![(4.0, 0.0), (5.0, 1.0)],
                    )),
                    bin(
                        Operator::Add,
                        un(Function::ClippedRamp, bin(Operator::Mul, t(), c(100.0))),
                        bin(
                            Operator::Mul,
                            un(Function::Sin, t()),
                            un(Function::Step, x(0)),
                        ),
                    ),
                ),
            ),
        );
        let part = BehaviouralSource::new(Output::Voltage, vec![Control::Voltage], e).unwrap();
        let mut at = 0.0;
        let mut corners = Vec::new();
        while let Some(next) = part.next_breakpoint(at) {
            corners.push(next);
            at = next;
        }
        let expected = [1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 1e-2];
        assert_eq!(corners.len(), expected.len(), "{corners:?}");
        for (got, want) in corners.iter().zip(expected) {
            assert!((got - want).abs() <= 1e-15, "{corners:?}");
        }
    }

    #[test]
    fn expressions_must_match_their_controls() {
        assert!(BehaviouralSource::new(Output::Voltage, vec![], Expression::Control(0)).is_err());
        assert!(
            BehaviouralSource::new(Output::Voltage, vec![], Expression::Constant(f64::NAN))
                .is_err()
        );
        let table = |points: Vec<(f64, f64)>| Expression::Piecewise(c(0.0), points);
        for points in [vec![(0.0, 1.0)], vec![(0.0, 1.0), (0.0, 2.0)]] {
            assert!(BehaviouralSource::new(Output::Voltage, vec![], table(points)).is_err());
        }
    }
}
