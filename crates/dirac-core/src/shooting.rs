//! Shooting discretisation (the paper's §3 numerics, after Leok & Shingel): the path between `q0`
//! and `q1` is the solution of the forced Euler–Lagrange equations computed by a one-step map.
//!
//! For a regular model written as [`GenericModel<N>`], the acceleration `a(q, v, t)` solves
//!
//! ```text
//! ∂²L/∂v² a = ∂L/∂q − (∂²L/∂v∂q) v + f(q, v, t).
//! ```
//!
//! A one-step map `Φ_τ` of order `p` (Taylor-2, Taylor-4 or classical RK4) approximates the flow of
//! `(q̇, v̇) = (v, a)`. Given `q0, q1`, the shooting velocity `v0` solves `Φ_h(q0, v0)|_q = q1`, the
//! stage points are `(qⁱ, vⁱ) = Φ_{cᵢh}(q0, v0)` at the quadrature nodes `cᵢ`, and
//!
//! ```text
//! L_d   = h Σᵢ bᵢ L(qⁱ, vⁱ)
//! f_d^± = h Σᵢ bᵢ f(qⁱ, vⁱ, t0 + cᵢh)·∂qⁱ/∂q_{1,0}
//! ```
//!
//! The step (forced discrete Hamiltonian map, MATH §3) solves `p0 = −D₁L_d − f_d⁻` for `q1` and
//! sets `p1 = D₂L_d + f_d⁺`.
//!
//! # Exact derivatives
//! Everything is computed by forward-mode dual numbers, nested where needed:
//! - the Lagrangian's first and second derivatives inside `a` by `partial_hessian`/`hessian` over
//!   whatever dual type is being propagated;
//! - the time derivatives `ȧ, ä, a⃛` along the flow (Taylor maps) by Taylor mode: `a` is evaluated
//!   on `Dual`, `Dual2`, `Dual3` numbers in `t` seeded with the Taylor coefficients known so far;
//! - `v0(q0, q1)` in dual arithmetic: Newton in `f64`, then three fixed-point iterations
//!   `v ← v − J⁻¹(Φ_h(q0, v) − q1)` in the dual type with the converged `f64` Jacobian `J`
//!   (each iteration makes one more derivative order exact);
//! - the step residual and its Jacobian from the auxiliary function
//!   `H(a, b) = L_d(a, b) + h Σᵢ bᵢ f(qⁱ(q0, b), vⁱ(q0, b))·qⁱ(a, b)` (force arguments frozen at
//!   `a = q0`): `R = p0 + ∂H/∂a` and `∂R/∂q1 = ∂²H/∂a∂b`, one hyper-dual evaluation.
//!
//! # Limitation: explicit time dependence in Taylor maps
//! [`GenericModel::force`] takes `t` as an `f64`, so the Taylor maps cannot differentiate a force
//! with respect to explicit time: their coefficients `ȧ, ä, …` are computed with the force's time
//! frozen at `t0`. That is exact for autonomous forces; for forces that depend explicitly on `t`
//! the path loses accuracy and the integrator its order (Simpson + Taylor-4 is observed to drop from
//! 4 to about 3 on a nonlinear driven test problem; see the unit tests). RK4 evaluates the force at
//! its stage times and keeps its order; use it for such forces. The quadrature always evaluates the
//! force at `t0 + cᵢh`.

use std::fmt;

use nalgebra::{Const, SMatrix, SVector};
use num_dual::{
    Derivative, Dual, Dual2, Dual2Vec, Dual3, DualNum, DualSVec, HyperDualVec, hessian,
    partial_hessian,
};
use thiserror::Error;

use crate::auto::GenericModel;
use crate::quadrature::QuadratureRule;

/// Scalars the shooting routines propagate: `f64` and (nested) dual numbers over `f64`.
trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// Fixed-point iterations applied in dual arithmetic after the `f64` shooting solve; each makes
/// one more derivative order exact, and the step needs second derivatives.
const DUAL_REFINEMENTS: usize = 3;

/// Maximum Newton iterations of the `f64` shooting solve.
const SHOOTING_MAX_ITERATIONS: usize = 50;

/// Failure inside the shooting discretisation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ShootingError {
    /// `∂²L/∂v²` is singular: the Euler–Lagrange equations do not determine the acceleration.
    #[error(
        "∂²L/∂v² is singular at q = {q:?}, v = {v:?} (relative pivot {pivot:.3e}): shooting needs a regular Lagrangian"
    )]
    DegenerateLagrangian {
        /// Position.
        q: Vec<f64>,
        /// Velocity.
        v: Vec<f64>,
        /// Smallest relative pivot met.
        pivot: f64,
    },
    /// The inner boundary-value solve `Φ_h(q0, v0) = q1` did not converge.
    #[error(
        "shooting solve Φ_h(q0, v0) = q1 did not converge: last velocity update {update:.3e} after {iterations} iterations (step too large for the nonlinearity?)"
    )]
    NotConverged {
        /// Newton iterations taken.
        iterations: usize,
        /// Max-norm of the last velocity update.
        update: f64,
    },
    /// `∂Φ_h/∂v0` is singular, so `v0` is not determined by `q1`.
    #[error("∂Φ_h/∂v0 is singular: the one-step map cannot be inverted for the shooting velocity")]
    SingularShootingJacobian,
    /// A NaN or infinity appeared (the state left the model's domain).
    #[error("non-finite value in the shooting solve: the state left the model's domain")]
    NonFinite,
    /// A non-positive or non-finite step size.
    #[error("step size must be positive and finite, got {0}")]
    StepSize(f64),
}

/// One-step map `Φ_τ` used to shoot from `(q0, v0)`.
///
/// The Taylor maps come in two readings of "Taylor's method of order p" for `q̈ = a(q, q̇, t)`:
///
/// - [`OneStepMap::Taylor2`], [`OneStepMap::Taylor4`] (the paper's): the path is the Taylor
///   polynomial of degree `p` of `q`, `q(τ) = Σ_{k≤p} τᵏ/k! q⁽ᵏ⁾(0)`, and `v(τ)` is its time
///   derivative (degree `p − 1`, so the velocity is of order `p − 1`, as the paper states). These
///   reproduce the paper's Table 1 to a few per cent; Taylor-2 needs only `a`, Taylor-4 also `ȧ, ä`.
/// - [`OneStepMap::Taylor2System`], [`OneStepMap::Taylor4System`]: Taylor's method of order `p`
///   applied to the first-order system `(q̇, v̇) = (v, a)`, i.e. `v(τ)` also carries the `τᵖ` term
///   (Taylor-2 adds `τ²/2 ȧ`, Taylor-4 adds `τ⁴/24 a⃛`). Same order of the integrator, different
///   error constants (see `docs/paper.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OneStepMap {
    /// Degree-2 Taylor polynomial path: `q + τv + τ²/2 a`, velocity `v + τa`.
    Taylor2,
    /// Degree-4 Taylor polynomial path (`ȧ, ä` along the flow by Taylor-mode duals), velocity its
    /// derivative.
    Taylor4,
    /// Second-order Taylor on `(q, v)`: `q + τv + τ²/2 a`, `v + τa + τ²/2 ȧ`.
    Taylor2System,
    /// Fourth-order Taylor on `(q, v)` (needs `ȧ, ä, a⃛`).
    Taylor4System,
    /// Classical fourth-order Runge–Kutta on `(q, v)`, one step of size `τ`.
    Rk4,
}

impl OneStepMap {
    /// Order `p` of the map.
    #[must_use]
    pub fn order(self) -> usize {
        match self {
            OneStepMap::Taylor2 | OneStepMap::Taylor2System => 2,
            OneStepMap::Taylor4 | OneStepMap::Taylor4System | OneStepMap::Rk4 => 4,
        }
    }
}

impl fmt::Display for OneStepMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OneStepMap::Taylor2 => write!(f, "taylor2"),
            OneStepMap::Taylor4 => write!(f, "taylor4"),
            OneStepMap::Taylor2System => write!(f, "taylor2-system"),
            OneStepMap::Taylor4System => write!(f, "taylor4-system"),
            OneStepMap::Rk4 => write!(f, "rk4"),
        }
    }
}

/// A one-step map plus the quadrature rules for `L_d` and for `f_d^±`.
///
/// [`ShootingDiscretisation::new`] uses one rule for both, which makes the integrator
/// equivalence-preserving: models whose `(L, f)` differ by moving a potential between `L` and `f`
/// produce the same `(q_k, p_k)` to round-off (paper §3, MATH §2). Mixing rules is possible only
/// through [`ShootingDiscretisation::non_equivalence_preserving`], which exists to reproduce the
/// paper's counterexamples (Figures 2 and 3).
#[derive(Debug, Clone, PartialEq)]
pub struct ShootingDiscretisation {
    map: OneStepMap,
    lagrangian_rule: QuadratureRule,
    force_rule: QuadratureRule,
}

impl ShootingDiscretisation {
    /// Equivalence-preserving: the same `rule` for `L_d` and `f_d^±`.
    #[must_use]
    pub fn new(map: OneStepMap, rule: QuadratureRule) -> Self {
        Self {
            map,
            force_rule: rule.clone(),
            lagrangian_rule: rule,
        }
    }

    /// Trapezoid quadrature with second-order Taylor shooting (the paper's second-order method).
    #[must_use]
    pub fn trapezoid_taylor2() -> Self {
        Self::new(OneStepMap::Taylor2, QuadratureRule::trapezoid())
    }

    /// Simpson quadrature with fourth-order Taylor shooting (the paper's fourth-order method).
    #[must_use]
    pub fn simpson_taylor4() -> Self {
        Self::new(OneStepMap::Taylor4, QuadratureRule::simpson())
    }

    /// **Not** equivalence-preserving: `lagrangian_rule` for `L_d`, `force_rule` for `f_d^±`.
    ///
    /// The resulting trajectory depends on how a conservative force is represented (as a potential
    /// in `L` or as an external force), which is what the paper's Figures 2 and 3 demonstrate. Use
    /// it only to study that effect. When the two rules coincide this equals
    /// [`ShootingDiscretisation::new`].
    #[must_use]
    pub fn non_equivalence_preserving(
        map: OneStepMap,
        lagrangian_rule: QuadratureRule,
        force_rule: QuadratureRule,
    ) -> Self {
        Self {
            map,
            lagrangian_rule,
            force_rule,
        }
    }

    /// The one-step map.
    #[must_use]
    pub fn map(&self) -> OneStepMap {
        self.map
    }

    /// Quadrature rule of `L_d`.
    #[must_use]
    pub fn lagrangian_rule(&self) -> &QuadratureRule {
        &self.lagrangian_rule
    }

    /// Quadrature rule of `f_d^±`.
    #[must_use]
    pub fn force_rule(&self) -> &QuadratureRule {
        &self.force_rule
    }

    /// Whether `L_d` and `f_d^±` use the same rule.
    #[must_use]
    pub fn is_equivalence_preserving(&self) -> bool {
        self.lagrangian_rule == self.force_rule
    }

    /// Expected order `min(p, order of the quadrature)` (paper §3), for the equivalence-preserving
    /// case; with mixed rules the lower quadrature order of the two is used. It is what the
    /// paper's argument guarantees for autonomous forces; the polynomial Taylor paths
    /// ([`OneStepMap::Taylor2`], [`OneStepMap::Taylor4`]) can converge faster when the quadrature
    /// allows it (Simpson + Taylor-2 was observed at order 3 to 4), and explicitly time-dependent
    /// forces cost Taylor maps order (see the module documentation).
    #[must_use]
    pub fn order(&self) -> usize {
        let quad = self
            .lagrangian_rule
            .exactness()
            .min(self.force_rule.exactness())
            + 1;
        self.map.order().min(quad)
    }
}

impl fmt::Display for ShootingDiscretisation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_equivalence_preserving() {
            write!(f, "{}-{}", self.lagrangian_rule, self.map)
        } else {
            write!(
                f,
                "{}/{}-{}",
                self.lagrangian_rule, self.force_rule, self.map
            )
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Small dense helpers over generic scalars.

fn zero<S: Scalar>() -> S {
    S::from(0.0)
}

fn re_arr<S: Scalar, const N: usize>(x: &[S; N]) -> [f64; N] {
    std::array::from_fn(|i| x[i].re())
}

fn lift_arr<S: Scalar, const N: usize>(x: &[f64; N]) -> [S; N] {
    std::array::from_fn(|i| S::from(x[i]))
}

fn max_abs<const N: usize>(x: &[f64; N]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// Solves `m x = b` by Gaussian elimination with partial pivoting on the real parts.
/// Returns the smallest relative pivot on failure.
fn solve_small<S: Scalar, const N: usize>(
    mut m: [[S; N]; N],
    mut b: [S; N],
) -> Result<[S; N], f64> {
    let scale = m.iter().flatten().fold(0.0_f64, |a, x| a.max(x.re().abs()));
    if scale.is_nan() || scale <= 0.0 || scale.is_infinite() {
        return Err(0.0);
    }
    for k in 0..N {
        let mut piv = k;
        let mut best = m[k][k].re().abs();
        for (i, row) in m.iter().enumerate().skip(k + 1) {
            let x = row[k].re().abs();
            if x > best {
                best = x;
                piv = i;
            }
        }
        if best.is_nan() || best <= 1e-13 * scale {
            return Err(best / scale);
        }
        m.swap(k, piv);
        b.swap(k, piv);
        let inv = m[k][k].recip();
        let (pivot_row, bk) = (m[k], b[k]);
        for (row, bi) in m.iter_mut().zip(b.iter_mut()).skip(k + 1) {
            // No shortcut for a zero real part: dual parts of the factor may still be nonzero.
            let factor = row[k] * inv;
            for (x, p) in row.iter_mut().zip(pivot_row.iter()).skip(k) {
                *x -= *p * factor;
            }
            *bi -= bk * factor;
        }
    }
    let mut x = [zero::<S>(); N];
    for k in (0..N).rev() {
        let mut s = b[k];
        for j in k + 1..N {
            s -= m[k][j] * x[j];
        }
        x[k] = s / m[k][k];
    }
    Ok(x)
}

/// `y = A x` with an `f64` matrix and a generic vector.
fn mat_vec<S: Scalar, const N: usize>(a: &SMatrix<f64, N, N>, x: &[S; N]) -> [S; N] {
    std::array::from_fn(|i| {
        let mut s = zero::<S>();
        for (j, xj) in x.iter().enumerate() {
            s += *xj * a[(i, j)];
        }
        s
    })
}

fn svec<S: Scalar, const N: usize>(x: &[S; N]) -> SVector<S, N> {
    SVector::from_fn(|i, _| x[i])
}

fn arr<S: Scalar, const N: usize>(x: &SVector<S, N>) -> [S; N] {
    std::array::from_fn(|i| x[i])
}

/// Acceleration of the forced Euler–Lagrange equations at `(q, v, t)`, in any scalar type.
fn acceleration<G: GenericModel<N>, S: Scalar, const N: usize>(
    model: &G,
    q: &[S; N],
    v: &[S; N],
    t: f64,
) -> Result<[S; N], ShootingError> {
    let (qs, vs) = (svec(q), svec(v));
    let (_, lq, _, lqv) =
        partial_hessian(|(a, b)| model.lagrangian(&arr(&a), &arr(&b)), (&qs, &vs));
    let (_, _, lvv) = hessian(
        |b: SVector<Dual2Vec<S, Const<N>>, N>| {
            let qc: [Dual2Vec<S, Const<N>>; N] = std::array::from_fn(|i| Dual2Vec::from_re(q[i]));
            model.lagrangian(&qc, &arr(&b))
        },
        &vs,
    );
    let f = if model.has_force() {
        model.force(q, v, t)
    } else {
        [zero::<S>(); N]
    };
    // rhs_i = ∂L/∂q_i − Σ_j ∂²L/∂v_i∂q_j v_j + f_i   (lqv[(j, i)] = ∂²L/∂q_j∂v_i)
    let rhs: [S; N] = std::array::from_fn(|i| {
        let mut r = lq[i] + f[i];
        for (j, vj) in v.iter().enumerate() {
            r -= lqv[(j, i)] * *vj;
        }
        r
    });
    let m: [[S; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| lvv[(i, j)]));
    solve_small(m, rhs).map_err(|pivot| ShootingError::DegenerateLagrangian {
        q: re_arr(q).to_vec(),
        v: re_arr(v).to_vec(),
        pivot,
    })
}

/// The one-step map prepared at `(q0, v0, t0)`: Taylor coefficients, or the RK4 start.
#[derive(Debug, Clone, Copy)]
enum Prepared<S, const N: usize> {
    /// `c[k] = dᵏq/dtᵏ(t0)`; `q(τ)` uses `c[0..=q_degree]`, `v(τ)` uses `c[1..=v_degree + 1]`.
    Taylor {
        c: [[S; N]; 6],
        q_degree: usize,
        v_degree: usize,
    },
    /// Start of an RK4 step.
    Rk4 { q: [S; N], v: [S; N], t: f64 },
}

fn prepare<G: GenericModel<N>, S: Scalar, const N: usize>(
    map: OneStepMap,
    model: &G,
    q0: &[S; N],
    v0: &[S; N],
    t0: f64,
) -> Result<Prepared<S, N>, ShootingError> {
    let z = [zero::<S>(); N];
    match map {
        OneStepMap::Rk4 => Ok(Prepared::Rk4 {
            q: *q0,
            v: *v0,
            t: t0,
        }),
        taylor => {
            // Highest derivative q⁽ᵏ⁾ needed, and the polynomial degrees of q(τ) and v(τ).
            let (top, q_degree, v_degree) = match taylor {
                OneStepMap::Taylor2 => (2, 2, 1),
                OneStepMap::Taylor2System => (3, 2, 2),
                OneStepMap::Taylor4 => (4, 4, 3),
                _ => (5, 4, 4),
            };
            let mut c = [z; 6];
            c[0] = *q0;
            c[1] = *v0;
            c[2] = acceleration(model, q0, v0, t0)?;
            if top >= 3 {
                // ȧ: a(q(t), v(t)) on Dual numbers in t with q' = v, v' = a.
                let q: [Dual<S>; N] = std::array::from_fn(|i| Dual::new(c[0][i], c[1][i]));
                let v: [Dual<S>; N] = std::array::from_fn(|i| Dual::new(c[1][i], c[2][i]));
                let a1 = acceleration(model, &q, &v, t0)?;
                c[3] = std::array::from_fn(|i| a1[i].eps);
            }
            if top >= 4 {
                // ä: second-order duals seeded with (q, q', q'') and (v, v', v'').
                let q: [Dual2<S>; N] =
                    std::array::from_fn(|i| Dual2::new(c[0][i], c[1][i], c[2][i]));
                let v: [Dual2<S>; N] =
                    std::array::from_fn(|i| Dual2::new(c[1][i], c[2][i], c[3][i]));
                let a2 = acceleration(model, &q, &v, t0)?;
                c[4] = std::array::from_fn(|i| a2[i].v2);
            }
            if top >= 5 {
                // a⃛: third-order duals.
                let q: [Dual3<S>; N] =
                    std::array::from_fn(|i| Dual3::new(c[0][i], c[1][i], c[2][i], c[3][i]));
                let v: [Dual3<S>; N] =
                    std::array::from_fn(|i| Dual3::new(c[1][i], c[2][i], c[3][i], c[4][i]));
                let a3 = acceleration(model, &q, &v, t0)?;
                c[5] = std::array::from_fn(|i| a3[i].v3);
            }
            Ok(Prepared::Taylor {
                c,
                q_degree,
                v_degree,
            })
        }
    }
}

fn axpy<S: Scalar, const N: usize>(x: &[S; N], a: f64, y: &[S; N]) -> [S; N] {
    std::array::from_fn(|i| x[i] + y[i] * a)
}

/// `Φ_τ` applied to the prepared start.
fn evaluate<G: GenericModel<N>, S: Scalar, const N: usize>(
    model: &G,
    prepared: &Prepared<S, N>,
    tau: f64,
) -> Result<([S; N], [S; N]), ShootingError> {
    match prepared {
        Prepared::Taylor {
            c,
            q_degree,
            v_degree,
        } => {
            let mut q = c[0];
            let mut v = c[1];
            let mut w = 1.0;
            for k in 1..=*q_degree.max(v_degree) {
                w *= tau / k as f64;
                if k <= *q_degree {
                    q = axpy(&q, w, &c[k]);
                }
                if k <= *v_degree {
                    v = axpy(&v, w, &c[k + 1]);
                }
            }
            Ok((q, v))
        }
        Prepared::Rk4 { q, v, t } => {
            if tau == 0.0 {
                return Ok((*q, *v));
            }
            let half = 0.5 * tau;
            let k1q = *v;
            let k1v = acceleration(model, q, v, *t)?;
            let (q2, v2) = (axpy(q, half, &k1q), axpy(v, half, &k1v));
            let k2q = v2;
            let k2v = acceleration(model, &q2, &v2, t + half)?;
            let (q3, v3) = (axpy(q, half, &k2q), axpy(v, half, &k2v));
            let k3q = v3;
            let k3v = acceleration(model, &q3, &v3, t + half)?;
            let (q4, v4) = (axpy(q, tau, &k3q), axpy(v, tau, &k3v));
            let k4q = v4;
            let k4v = acceleration(model, &q4, &v4, t + tau)?;
            let s = tau / 6.0;
            let qn =
                std::array::from_fn(|i| q[i] + (k1q[i] + (k2q[i] + k3q[i]) * 2.0 + k4q[i]) * s);
            let vn =
                std::array::from_fn(|i| v[i] + (k1v[i] + (k2v[i] + k3v[i]) * 2.0 + k4v[i]) * s);
            Ok((qn, vn))
        }
    }
}

fn dual_eps<const N: usize>(d: &DualSVec<f64, N>) -> [f64; N] {
    match &d.eps.0 {
        Some(m) => std::array::from_fn(|i| m[i]),
        None => [0.0; N],
    }
}

/// Solves `Φ_h(q0, v0)|_q = q1` for `v0` in `f64` by Newton with exact `∂Φ_h/∂v0`.
/// Returns `v0` and the inverse Jacobian at the solution.
fn shoot_f64<G: GenericModel<N>, const N: usize>(
    map: OneStepMap,
    model: &G,
    q0: &[f64; N],
    q1: &[f64; N],
    t0: f64,
    h: f64,
) -> Result<([f64; N], SMatrix<f64, N, N>), ShootingError> {
    let mut v: [f64; N] = std::array::from_fn(|i| (q1[i] - q0[i]) / h);
    let q0d: [DualSVec<f64, N>; N] = lift_arr(q0);
    let mut last = f64::INFINITY;
    for iteration in 0..SHOOTING_MAX_ITERATIONS {
        let vd: [DualSVec<f64, N>; N] =
            std::array::from_fn(|i| DualSVec::<f64, N>::from_re(v[i]).derivative(i));
        let prepared = prepare(map, model, &q0d, &vd, t0)?;
        let (qh, _) = evaluate(model, &prepared, h)?;
        let mut jac = SMatrix::<f64, N, N>::zeros();
        let mut r = [0.0; N];
        for i in 0..N {
            r[i] = qh[i].re - q1[i];
            let e = dual_eps(&qh[i]);
            for j in 0..N {
                jac[(i, j)] = e[j];
            }
        }
        if r.iter().any(|x| !x.is_finite()) || jac.iter().any(|x| !x.is_finite()) {
            return Err(ShootingError::NonFinite);
        }
        let inv = jac
            .try_inverse()
            .ok_or(ShootingError::SingularShootingJacobian)?;
        if inv.iter().any(|x| !x.is_finite()) {
            return Err(ShootingError::SingularShootingJacobian);
        }
        let dv = mat_vec(&inv, &r);
        let mut unorm = 0.0_f64;
        for i in 0..N {
            v[i] -= dv[i];
            unorm = unorm.max(dv[i].abs());
        }
        // Converged once the update is at round-off of v (one more iteration has been applied, so
        // the Jacobian is that of the converged point to working precision).
        if unorm <= 1e-14 * (1.0 + max_abs(&v)) || (iteration > 0 && unorm == 0.0) {
            return Ok((v, inv));
        }
        // Stagnation at round-off: the update stopped decreasing while already tiny.
        if unorm >= last && unorm <= 1e-11 * (1.0 + max_abs(&v)) {
            return Ok((v, inv));
        }
        last = unorm;
    }
    Err(ShootingError::NotConverged {
        iterations: SHOOTING_MAX_ITERATIONS,
        update: last,
    })
}

/// `v0(q0, q1)` in the scalar type `S`, and the map prepared at `(q0, v0)`.
fn shoot<G: GenericModel<N>, S: Scalar, const N: usize>(
    map: OneStepMap,
    model: &G,
    q0: &[S; N],
    q1: &[S; N],
    t0: f64,
    h: f64,
) -> Result<Prepared<S, N>, ShootingError> {
    let (v_re, inv) = shoot_f64(map, model, &re_arr(q0), &re_arr(q1), t0, h)?;
    let mut v: [S; N] = lift_arr(&v_re);
    if S::NDERIV > 0 {
        for _ in 0..DUAL_REFINEMENTS {
            let prepared = prepare(map, model, q0, &v, t0)?;
            let (qh, _) = evaluate(model, &prepared, h)?;
            let r: [S; N] = std::array::from_fn(|i| qh[i] - q1[i]);
            let dv = mat_vec(&inv, &r);
            for i in 0..N {
                v[i] -= dv[i];
            }
        }
    }
    prepare(map, model, q0, &v, t0)
}

/// Which parts of the auxiliary function to include.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Parts {
    lagrangian: bool,
    force: bool,
}

const ALL: Parts = Parts {
    lagrangian: true,
    force: true,
};

// ---------------------------------------------------------------------------------------------

/// The equations of one shooting step from `(q_k, p_k, t_k)`: unknown `q_{k+1}`.
///
/// `residual(q1) = p_k + D₁L_d(q_k, q1) + f_d⁻(q_k, q1)` vanishes at the solution, whose exact
/// Jacobian comes from [`ShootingStep::residual_and_jacobian`]; then
/// `p_{k+1} = D₂L_d + f_d⁺` ([`ShootingStep::end_momentum`]). Evaluation does not allocate.
#[derive(Debug, Clone)]
pub struct ShootingStep<const N: usize> {
    discretisation: ShootingDiscretisation,
    h: f64,
    q0: [f64; N],
    p0: [f64; N],
    t0: f64,
}

impl<const N: usize> ShootingStep<N> {
    /// A step of size `h`.
    pub fn new(discretisation: ShootingDiscretisation, h: f64) -> Result<Self, ShootingError> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(ShootingError::StepSize(h));
        }
        Ok(Self {
            discretisation,
            h,
            q0: [0.0; N],
            p0: [0.0; N],
            t0: 0.0,
        })
    }

    /// The discretisation.
    #[must_use]
    pub fn discretisation(&self) -> &ShootingDiscretisation {
        &self.discretisation
    }

    /// Step size.
    #[must_use]
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Sets the start `(q_k, p_k, t_k)`.
    pub fn set_start(&mut self, q: &[f64; N], p: &[f64; N], t: f64) {
        self.q0 = *q;
        self.p0 = *p;
        self.t0 = t;
    }

    /// `q_k`.
    #[must_use]
    pub fn start_position(&self) -> &[f64; N] {
        &self.q0
    }

    /// `p_k`.
    #[must_use]
    pub fn start_momentum(&self) -> &[f64; N] {
        &self.p0
    }

    /// `t_k`.
    #[must_use]
    pub fn start_time(&self) -> f64 {
        self.t0
    }

    /// `h Σᵢ bᵢ L(qⁱ(a, b), vⁱ(a, b)) + h Σᵢ bᵢ f(freeze(qⁱ), freeze(vⁱ), t0 + cᵢh)·qⁱ(a, b)`.
    fn auxiliary<G: GenericModel<N>, S: Scalar>(
        &self,
        model: &G,
        a: &[S; N],
        b: &[S; N],
        freeze: impl Fn(&S) -> S,
        parts: Parts,
    ) -> Result<S, ShootingError> {
        let d = &self.discretisation;
        let (h, t0) = (self.h, self.t0);
        let prepared = shoot(d.map, model, a, b, t0, h)?;
        let mut total = zero::<S>();
        if parts.lagrangian {
            let rule = &d.lagrangian_rule;
            for (&c, &w) in rule.nodes().iter().zip(rule.weights()) {
                let (q, v) = evaluate(model, &prepared, c * h)?;
                total += model.lagrangian(&q, &v) * w;
            }
        }
        if parts.force && model.has_force() {
            let rule = &d.force_rule;
            for (&c, &w) in rule.nodes().iter().zip(rule.weights()) {
                let (q, v) = evaluate(model, &prepared, c * h)?;
                let qf: [S; N] = std::array::from_fn(|i| freeze(&q[i]));
                let vf: [S; N] = std::array::from_fn(|i| freeze(&v[i]));
                let f = model.force(&qf, &vf, t0 + c * h);
                for i in 0..N {
                    total += f[i] * q[i] * w;
                }
            }
        }
        let total = total * h;
        if total.re().is_finite() {
            Ok(total)
        } else {
            Err(ShootingError::NonFinite)
        }
    }

    /// `∂/∂a` (`wrt_start`) or `∂/∂b` of the auxiliary function with all force arguments frozen.
    fn first_derivative<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
        wrt_start: bool,
        parts: Parts,
    ) -> Result<[f64; N], ShootingError> {
        let seeded: [DualSVec<f64, N>; N] = std::array::from_fn(|i| {
            let x = if wrt_start { self.q0[i] } else { q1[i] };
            DualSVec::<f64, N>::from_re(x).derivative(i)
        });
        let (a, b): ([DualSVec<f64, N>; N], [DualSVec<f64, N>; N]) = if wrt_start {
            (seeded, lift_arr(q1))
        } else {
            (lift_arr(&self.q0), seeded)
        };
        let value = self.auxiliary(model, &a, &b, |x| DualSVec::from_re(x.re), parts)?;
        let g = dual_eps(&value);
        if g.iter().all(|x| x.is_finite()) {
            Ok(g)
        } else {
            Err(ShootingError::NonFinite)
        }
    }

    /// The step residual `p_k + D₁L_d(q_k, q1) + f_d⁻(q_k, q1)`.
    pub fn residual<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<[f64; N], ShootingError> {
        let g = self.first_derivative(model, q1, true, ALL)?;
        Ok(std::array::from_fn(|i| self.p0[i] + g[i]))
    }

    /// The residual and its exact Jacobian `J[i][j] = ∂rᵢ/∂q1ⱼ`.
    pub fn residual_and_jacobian<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<([f64; N], [[f64; N]; N]), ShootingError> {
        type H<const N: usize> = HyperDualVec<f64, Const<N>, Const<N>>;
        let a: [H<N>; N] = std::array::from_fn(|i| H::<N>::from_re(self.q0[i]).derivative1(i));
        let b: [H<N>; N] = std::array::from_fn(|i| H::<N>::from_re(q1[i]).derivative2(i));
        // Freezing the force arguments at a = q0 drops their a-derivatives (eps1 and eps1eps2).
        let freeze = |x: &H<N>| H::<N>::new(x.re, Derivative::none(), x.eps2, Derivative::none());
        let value = self.auxiliary(model, &a, &b, freeze, ALL)?;
        let mut r = self.p0;
        let mut jac = [[0.0; N]; N];
        if let Some(e1) = &value.eps1.0 {
            for i in 0..N {
                r[i] += e1[i];
            }
        }
        if let Some(e12) = &value.eps1eps2.0 {
            for i in 0..N {
                for j in 0..N {
                    jac[i][j] = e12[(i, j)];
                }
            }
        }
        if r.iter().chain(jac.iter().flatten()).all(|x| x.is_finite()) {
            Ok((r, jac))
        } else {
            Err(ShootingError::NonFinite)
        }
    }

    /// `p_{k+1} = D₂L_d(q_k, q1) + f_d⁺(q_k, q1)`.
    pub fn end_momentum<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<[f64; N], ShootingError> {
        self.first_derivative(model, q1, false, ALL)
    }

    /// `L_d(q_k, q1)`.
    pub fn discrete_lagrangian<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<f64, ShootingError> {
        let parts = Parts {
            lagrangian: true,
            force: false,
        };
        self.auxiliary::<G, f64>(model, &self.q0, q1, |x| *x, parts)
    }

    /// The discrete forces `(f_d⁻, f_d⁺)` at `(q_k, q1)`.
    pub fn discrete_forces<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<([f64; N], [f64; N]), ShootingError> {
        let parts = Parts {
            lagrangian: false,
            force: true,
        };
        Ok((
            self.first_derivative(model, q1, true, parts)?,
            self.first_derivative(model, q1, false, parts)?,
        ))
    }

    /// The shooting velocity `v0` with `Φ_h(q_k, v0)|_q = q1`.
    pub fn shooting_velocity<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
    ) -> Result<[f64; N], ShootingError> {
        let d = &self.discretisation;
        shoot_f64(d.map, model, &self.q0, q1, self.t0, self.h).map(|(v, _)| v)
    }

    /// `Φ_τ(q_k, v0)` for the shooting velocity of `(q_k, q1)`: the path the step uses.
    pub fn path_point<G: GenericModel<N>>(
        &self,
        model: &G,
        q1: &[f64; N],
        tau: f64,
    ) -> Result<([f64; N], [f64; N]), ShootingError> {
        let d = &self.discretisation;
        let prepared = shoot::<G, f64, N>(d.map, model, &self.q0, q1, self.t0, self.h)?;
        evaluate(model, &prepared, tau)
    }
}

/// The momentum `p = ∂L/∂v(q, v)`.
#[must_use]
pub fn momentum<G: GenericModel<N>, const N: usize>(
    model: &G,
    q: &[f64; N],
    v: &[f64; N],
) -> [f64; N] {
    let vd: [DualSVec<f64, N>; N] =
        std::array::from_fn(|i| DualSVec::<f64, N>::from_re(v[i]).derivative(i));
    let qd: [DualSVec<f64, N>; N] = lift_arr(q);
    dual_eps(&model.lagrangian(&qd, &vd))
}

/// The velocity with `∂L/∂v(q, v) = p` (inverse Legendre transform), by Newton from `v = 0`.
pub fn velocity_from_momentum<G: GenericModel<N>, const N: usize>(
    model: &G,
    q: &[f64; N],
    p: &[f64; N],
) -> Result<[f64; N], ShootingError> {
    let mut v = [0.0; N];
    let mut last = f64::INFINITY;
    for iteration in 0..SHOOTING_MAX_ITERATIONS {
        let (_, lv, lvv) = hessian(
            |b: SVector<Dual2Vec<f64, Const<N>>, N>| {
                let qc: [Dual2Vec<f64, Const<N>>; N] = lift_arr(q);
                model.lagrangian(&qc, &arr(&b))
            },
            &SVector::from(v),
        );
        let r: [f64; N] = std::array::from_fn(|i| lv[i] - p[i]);
        let m: [[f64; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| lvv[(i, j)]));
        let dv = solve_small(m, r).map_err(|pivot| ShootingError::DegenerateLagrangian {
            q: q.to_vec(),
            v: v.to_vec(),
            pivot,
        })?;
        let mut unorm = 0.0_f64;
        for i in 0..N {
            v[i] -= dv[i];
            unorm = unorm.max(dv[i].abs());
        }
        if !unorm.is_finite() {
            return Err(ShootingError::NonFinite);
        }
        if unorm <= 1e-14 * (1.0 + max_abs(&v)) || (iteration > 0 && unorm >= last && unorm < 1e-11)
        {
            return Ok(v);
        }
        last = unorm;
    }
    Err(ShootingError::NotConverged {
        iterations: SHOOTING_MAX_ITERATIONS,
        update: last,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::DualNum;

    /// Damped Duffing-like model with a velocity-dependent mass term and a nonlinear force:
    /// `L = ½(1 + 0.1 q²) v² − ½q² − 0.2 q⁴`, `f = −0.3 v − 0.1 q² v`.
    struct Nonlinear;
    impl GenericModel<1> for Nonlinear {
        fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
            (q[0] * q[0] * 0.1 + 1.0) * v[0] * v[0] * 0.5 - q[0] * q[0] * 0.5 - q[0].powi(4) * 0.2
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force<D: DualNum<Primitive = f64> + Copy>(
            &self,
            q: &[D; 1],
            v: &[D; 1],
            _t: f64,
        ) -> [D; 1] {
            [v[0] * (-0.3) - q[0] * q[0] * v[0] * 0.1]
        }
    }

    /// Two coupled coordinates with a non-diagonal, q-dependent mass matrix and a mixed q–v term.
    struct Coupled;
    impl GenericModel<2> for Coupled {
        fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2]) -> D {
            let m12 = q[0].cos() * 0.3;
            (v[0] * v[0] * 2.0 + v[1] * v[1] + m12 * v[0] * v[1] * 2.0) * 0.5 + q[1] * v[0] * 0.2
                - q[0] * q[0] * 0.5
                - (q[1] - q[0]).powi(2) * 0.7
                - q[1].powi(4) * 0.1
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force<D: DualNum<Primitive = f64> + Copy>(
            &self,
            q: &[D; 2],
            v: &[D; 2],
            t: f64,
        ) -> [D; 2] {
            [
                v[0] * (-0.2) + q[1] * 0.1,
                v[1] * (-0.1) * q[0] + (t * 0.5).sin() * 0.05,
            ]
        }
    }

    fn all_discretisations() -> Vec<ShootingDiscretisation> {
        let mut out = Vec::new();
        for map in [
            OneStepMap::Taylor2,
            OneStepMap::Taylor4,
            OneStepMap::Taylor2System,
            OneStepMap::Taylor4System,
            OneStepMap::Rk4,
        ] {
            for rule in [
                QuadratureRule::trapezoid(),
                QuadratureRule::simpson(),
                QuadratureRule::midpoint(),
            ] {
                out.push(ShootingDiscretisation::new(map, rule));
            }
            out.push(ShootingDiscretisation::non_equivalence_preserving(
                map,
                QuadratureRule::simpson(),
                QuadratureRule::trapezoid(),
            ));
        }
        out
    }

    #[test]
    fn acceleration_matches_hand_derivation() {
        // M(q) = 1 + 0.1q²: M a = ∂L/∂q − ∂²L/∂v∂q v + f = 0.1 q v² − q − 0.8 q³ − 0.2 q v² + f.
        let (q, v): (f64, f64) = (0.7, -1.3);
        let a = acceleration(&Nonlinear, &[q], &[v], 0.0).unwrap()[0];
        let f = -0.3 * v - 0.1 * q * q * v;
        let expected =
            (0.1 * q * v * v - q - 0.8 * q.powi(3) - 0.2 * q * v * v + f) / (1.0 + 0.1 * q * q);
        assert!((a - expected).abs() < 1e-14, "{a} vs {expected}");
    }

    /// The Euler–Lagrange acceleration of [`Coupled`], derived by hand: with
    /// `m₁₂ = 0.3 cos q₀`, `M = [[2, m₁₂], [m₁₂, 1]]` and
    /// `M a = (−q₀ + 1.4(q₁ − q₀) − 0.2 v₁ + f₀,  0.2 v₀ − 1.4(q₁ − q₀) − 0.4 q₁³ + 0.3 sin q₀ v₀² + f₁)`
    /// (the `∂m₁₂/∂q₀ v₀v₁` terms of `∂L/∂q₀` and `d/dt ∂L/∂v₀` cancel).
    fn coupled_acceleration(q: [f64; 2], v: [f64; 2], t: f64) -> [f64; 2] {
        let m12 = 0.3 * q[0].cos();
        let f = [
            -0.2 * v[0] + 0.1 * q[1],
            -0.1 * v[1] * q[0] + 0.05 * (0.5 * t).sin(),
        ];
        let b = [
            -q[0] + 1.4 * (q[1] - q[0]) - 0.2 * v[1] + f[0],
            0.2 * v[0] - 1.4 * (q[1] - q[0]) - 0.4 * q[1].powi(3)
                + 0.3 * q[0].sin() * v[0] * v[0]
                + f[1],
        ];
        let det = 2.0 - m12 * m12;
        [(b[0] - m12 * b[1]) / det, (2.0 * b[1] - m12 * b[0]) / det]
    }

    /// The two-coordinate model's acceleration against the hand derivation, at several states:
    /// checks the mixed `∂²L/∂q∂v` block and its index order, which the one-coordinate model
    /// cannot.
    #[test]
    fn coupled_acceleration_matches_hand_derivation() {
        for (q, v, t) in [
            ([0.4, -0.2], [0.3, 0.5], 0.3),
            ([-1.1, 0.7], [-0.8, 1.2], 2.0),
            ([2.0, 1.5], [0.0, -0.4], -0.5),
        ] {
            let a = acceleration(&Coupled, &q, &v, t).unwrap();
            let expected = coupled_acceleration(q, v, t);
            for i in 0..2 {
                assert!((a[i] - expected[i]).abs() < 1e-14, "{a:?} vs {expected:?}");
            }
        }
    }

    /// Taylor coefficients of the flow against finite differences of RK4 with tiny steps; the
    /// zeroth (the acceleration) against the hand derivation.
    #[test]
    fn taylor_coefficients_match_the_flow() {
        let (q0, v0) = ([0.4, -0.2], [0.3, 0.5]);
        let Prepared::Taylor { c, .. } =
            prepare(OneStepMap::Taylor4System, &Coupled, &q0, &v0, 0.3).unwrap()
        else {
            panic!("expected Taylor coefficients");
        };
        // Reference derivatives of a(t) by central differences of the accurate flow.
        let flow = |tau: f64| -> [f64; 2] {
            let steps = 200;
            let dt = tau / steps as f64;
            let (mut q, mut v) = (q0, v0);
            for _ in 0..steps {
                let p = Prepared::Rk4 { q, v, t: 0.3 };
                // time frozen at 0.3 to match the Taylor map's convention
                let (qn, vn) = evaluate(&Frozen(&Coupled), &p, dt).unwrap();
                q = qn;
                v = vn;
            }
            acceleration(&Frozen(&Coupled), &q, &v, 0.3).unwrap()
        };
        let e = 2e-2;
        let (am2, am1, a0, ap1, ap2) =
            (flow(-2.0 * e), flow(-e), flow(0.0), flow(e), flow(2.0 * e));
        for i in 0..2 {
            let d1 = (ap1[i] - am1[i]) / (2.0 * e);
            let d2 = (ap1[i] - 2.0 * a0[i] + am1[i]) / (e * e);
            let d3 = (ap2[i] - 2.0 * ap1[i] + 2.0 * am1[i] - am2[i]) / (2.0 * e * e * e);
            assert!((c[2][i] - coupled_acceleration(q0, v0, 0.3)[i]).abs() < 1e-14);
            assert!((c[3][i] - d1).abs() < 1e-3, "ȧ {} vs {d1}", c[3][i]);
            assert!((c[4][i] - d2).abs() < 1e-3, "ä {} vs {d2}", c[4][i]);
            assert!((c[5][i] - d3).abs() < 2e-2, "a⃛ {} vs {d3}", c[5][i]);
        }
    }

    /// The `Coupled` model with its force's time dependence frozen (for the reference flow).
    struct Frozen<'a>(&'a Coupled);
    impl GenericModel<2> for Frozen<'_> {
        fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2]) -> D {
            self.0.lagrangian(q, v)
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force<D: DualNum<Primitive = f64> + Copy>(
            &self,
            q: &[D; 2],
            v: &[D; 2],
            _t: f64,
        ) -> [D; 2] {
            self.0.force(q, v, 0.3)
        }
    }

    #[test]
    fn shooting_hits_the_end_point() {
        for d in all_discretisations() {
            let mut step = ShootingStep::<2>::new(d.clone(), 0.1).unwrap();
            step.set_start(&[0.4, -0.2], &[0.0, 0.0], 0.0);
            let q1 = [0.43, -0.17];
            let (q, _) = step.path_point(&Coupled, &q1, 0.1).unwrap();
            assert!(
                (q[0] - q1[0]).abs() < 1e-14 && (q[1] - q1[1]).abs() < 1e-14,
                "{d}"
            );
        }
    }

    /// Residual = p0 + D₁L_d + f_d⁻ with D₁L_d from central differences of L_d; the Jacobian
    /// against central differences of the residual; p1 = D₂L_d + f_d⁺ likewise.
    #[test]
    fn residual_jacobian_and_momentum_match_finite_differences() {
        let h = 0.1;
        let (q0, p0) = ([0.4, -0.2], [0.25, -0.6]);
        let q1 = [0.43, -0.17];
        let e = 1e-5;
        for d in all_discretisations() {
            let mut step = ShootingStep::<2>::new(d.clone(), h).unwrap();
            step.set_start(&q0, &p0, 0.2);
            let (r, jac) = step.residual_and_jacobian(&Coupled, &q1).unwrap();
            let r_only = step.residual(&Coupled, &q1).unwrap();
            let (fm, fp) = step.discrete_forces(&Coupled, &q1).unwrap();
            let p1 = step.end_momentum(&Coupled, &q1).unwrap();
            for i in 0..2 {
                assert!((r[i] - r_only[i]).abs() < 1e-13, "{d}: {r:?} vs {r_only:?}");
                // D₁L_d by differences in q0.
                let ld_at = |dq: f64, second: bool| {
                    let mut s = step.clone();
                    let (mut a, mut b) = (q0, q1);
                    if second {
                        b[i] += dq;
                    } else {
                        a[i] += dq;
                    }
                    s.set_start(&a, &p0, 0.2);
                    s.discrete_lagrangian(&Coupled, &b).unwrap()
                };
                let d1 = (ld_at(e, false) - ld_at(-e, false)) / (2.0 * e);
                let d2 = (ld_at(e, true) - ld_at(-e, true)) / (2.0 * e);
                assert!(
                    (r[i] - (p0[i] + d1 + fm[i])).abs() < 1e-8,
                    "{d}: residual {i}"
                );
                assert!((p1[i] - (d2 + fp[i])).abs() < 1e-8, "{d}: momentum {i}");
                for j in 0..2 {
                    let mut qp = q1;
                    let mut qm = q1;
                    qp[j] += e;
                    qm[j] -= e;
                    let fd = (step.residual(&Coupled, &qp).unwrap()[i]
                        - step.residual(&Coupled, &qm).unwrap()[i])
                        / (2.0 * e);
                    let tol = 1e-6 * (1.0 + fd.abs());
                    assert!(
                        (jac[i][j] - fd).abs() < tol,
                        "{d}: J[{i}][{j}] = {} vs {fd}",
                        jac[i][j]
                    );
                }
            }
        }
    }

    /// f_d^± against the definition h Σ bᵢ f(qⁱ, vⁱ)·∂qⁱ/∂q_{0,1}, with ∂qⁱ/∂q by differences.
    #[test]
    fn discrete_forces_match_their_definition() {
        let h = 0.1;
        let (q0, q1) = ([0.4], [0.47]);
        for d in all_discretisations() {
            let mut step = ShootingStep::<1>::new(d.clone(), h).unwrap();
            step.set_start(&q0, &[0.0], 0.0);
            let (fm, fp) = step.discrete_forces(&Nonlinear, &q1).unwrap();
            let e = 1e-6;
            let rule = d.force_rule();
            let (mut em, mut ep) = (0.0, 0.0);
            for (&c, &b) in rule.nodes().iter().zip(rule.weights()) {
                let (q, v) = step.path_point(&Nonlinear, &q1, c * h).unwrap();
                let f = Nonlinear.force(&q, &v, c * h)[0];
                let shifted = |a: f64, b1: f64| {
                    let mut s = step.clone();
                    s.set_start(&[a], &[0.0], 0.0);
                    s.path_point(&Nonlinear, &[b1], c * h).unwrap().0[0]
                };
                let dq0 = (shifted(q0[0] + e, q1[0]) - shifted(q0[0] - e, q1[0])) / (2.0 * e);
                let dq1 = (shifted(q0[0], q1[0] + e) - shifted(q0[0], q1[0] - e)) / (2.0 * e);
                em += h * b * f * dq0;
                ep += h * b * f * dq1;
            }
            assert!((fm[0] - em).abs() < 1e-8, "{d}: {} vs {em}", fm[0]);
            assert!((fp[0] - ep).abs() < 1e-8, "{d}: {} vs {ep}", fp[0]);
        }
    }

    #[test]
    fn legendre_round_trip() {
        let (q, v) = ([0.4, -0.2], [0.3, 0.5]);
        let p = momentum(&Coupled, &q, &v);
        let back = velocity_from_momentum(&Coupled, &q, &p).unwrap();
        assert!((back[0] - v[0]).abs() < 1e-13 && (back[1] - v[1]).abs() < 1e-13);
    }

    /// `L = ½v² − ½q² + 0.1q³`, `f = ½cos(2t) q² + 0.3 sin(t) v + cos 3t`, or the same with the
    /// force's time frozen at `frozen` (an autonomous twin).
    struct Driven {
        frozen: Option<f64>,
    }
    impl GenericModel<1> for Driven {
        fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
            (v[0] * v[0] - q[0] * q[0]) * 0.5 + q[0].powi(3) * 0.1
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force<D: DualNum<Primitive = f64> + Copy>(
            &self,
            q: &[D; 1],
            v: &[D; 1],
            t: f64,
        ) -> [D; 1] {
            let t = self.frozen.unwrap_or(t);
            [q[0] * q[0] * (0.5 * (2.0 * t).cos()) + v[0] * (0.3 * t.sin()) + (3.0 * t).cos()]
        }
    }

    /// `q` at `t = 4` after `steps` steps from `q = 1`, `p = 0` (scalar Newton on the exact Jacobian).
    fn driven_end(model: &Driven, d: &ShootingDiscretisation, steps: usize) -> f64 {
        let h = 4.0 / steps as f64;
        let mut step = ShootingStep::<1>::new(d.clone(), h).unwrap();
        let (mut q, mut p, mut t) = (1.0, 0.0, 0.0);
        for _ in 0..steps {
            step.set_start(&[q], &[p], t);
            let mut q1 = q + h * p;
            for _ in 0..30 {
                let (r, j) = step.residual_and_jacobian(model, &[q1]).unwrap();
                let dq = r[0] / j[0][0];
                q1 -= dq;
                if dq.abs() < 1e-15 {
                    break;
                }
            }
            p = step.end_momentum(model, &[q1]).unwrap()[0];
            q = q1;
            t += h;
        }
        q
    }

    /// Observed order from 40, 80, 160 steps (differences of successive runs).
    fn driven_order(model: &Driven, d: &ShootingDiscretisation) -> f64 {
        let e: Vec<f64> = [40, 80, 160]
            .iter()
            .map(|&n| driven_end(model, d, n))
            .collect();
        ((e[0] - e[1]).abs() / (e[1] - e[2]).abs()).log2()
    }

    /// The documented limitation: Taylor maps freeze the force's explicit time at `t0`, so with an
    /// explicitly time-dependent force Simpson + Taylor-4 drops from order 4 to about 3, while RK4
    /// shooting keeps order 4. On the autonomous twin both are fourth order.
    #[test]
    fn explicit_time_dependence_taylor_versus_rk4() {
        let (driven, autonomous) = (Driven { frozen: None }, Driven { frozen: Some(0.7) });
        let rk4 = ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::simpson());
        let taylor4 = ShootingDiscretisation::simpson_taylor4();
        let orders = [
            driven_order(&driven, &rk4),
            driven_order(&driven, &taylor4),
            driven_order(&autonomous, &rk4),
            driven_order(&autonomous, &taylor4),
        ];
        assert!((orders[0] - 4.0).abs() < 0.2, "{orders:?}");
        assert!((orders[1] - 3.0).abs() < 0.2, "{orders:?}");
        assert!((orders[2] - 4.0).abs() < 0.2, "{orders:?}");
        assert!((orders[3] - 4.0).abs() < 0.2, "{orders:?}");
    }

    /// A Lagrangian without kinetic term is reported, not divided by zero.
    struct Degenerate;
    impl GenericModel<1> for Degenerate {
        fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], _v: &[D; 1]) -> D {
            q[0] * q[0] * 0.5
        }
    }

    #[test]
    fn degenerate_lagrangian_is_a_typed_error() {
        let mut step =
            ShootingStep::<1>::new(ShootingDiscretisation::trapezoid_taylor2(), 0.1).unwrap();
        step.set_start(&[1.0], &[0.0], 0.0);
        let err = step.residual(&Degenerate, &[1.0]).unwrap_err();
        assert!(
            matches!(err, ShootingError::DegenerateLagrangian { .. }),
            "{err}"
        );
        assert!(matches!(
            ShootingStep::<1>::new(ShootingDiscretisation::trapezoid_taylor2(), -1.0),
            Err(ShootingError::StepSize(_))
        ));
    }
}
