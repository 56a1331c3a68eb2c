//! Exact derivatives of user-written generic models by forward-mode dual numbers.

use nalgebra::SVector;
use num_dual::{DualNum, gradient, hessian, jacobian, partial_hessian};

use crate::model::{ForceJacobian, LagrangianHessian, Model};

/// A model written once as generic functions of `(q, v)`, differentiated automatically.
///
/// Write `L(q, v)` (and optionally `f(q, v, t)`) over any scalar `D` that behaves like `f64`;
/// [`AutoDiff`] evaluates them on dual numbers of small static dimension to obtain exact gradients,
/// Hessians and force Jacobians (no finite differences). `N` is the number of coordinates.
///
/// ```
/// use dirac_core::{AutoDiff, GenericModel, Model};
/// use num_dual::DualNum;
///
/// /// Damped pendulum: L = ½v² + cos q, f = −c v.
/// struct Pendulum { c: f64 }
/// impl GenericModel<1> for Pendulum {
///     fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
///         v[0] * v[0] * 0.5 + q[0].cos()
///     }
///     fn has_force(&self) -> bool { true }
///     fn force<D: DualNum<Primitive = f64> + Copy>(&self, _q: &[D; 1], v: &[D; 1], _t: f64) -> [D; 1] {
///         [v[0] * (-self.c)]
///     }
/// }
/// let model = AutoDiff::new(Pendulum { c: 0.1 });
/// let (mut lq, mut lv) = ([0.0], [0.0]);
/// model.lagrangian_gradient(&[0.3], &[2.0], &mut lq, &mut lv);
/// assert!((lq[0] + 0.3f64.sin()).abs() < 1e-15 && (lv[0] - 2.0).abs() < 1e-15);
/// ```
pub trait GenericModel<const N: usize> {
    /// `L(q, v)`.
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; N], v: &[D; N]) -> D;

    /// Whether [`GenericModel::force`] is nonzero.
    fn has_force(&self) -> bool {
        false
    }

    /// `f(q, v, t)`; zero unless overridden.
    fn force<D: DualNum<Primitive = f64> + Copy>(
        &self,
        _q: &[D; N],
        _v: &[D; N],
        _t: f64,
    ) -> [D; N] {
        [D::from(0.0); N]
    }

    /// True when `L` is quadratic and `f` affine in `(q, v)` (see [`Model::is_linear`]).
    fn is_linear(&self) -> bool {
        false
    }
}

/// Adapter that turns a [`GenericModel`] into a [`Model`] with exact automatic derivatives.
///
/// Hessian blocks are obtained separately over `q`, over `v`, and mixed, each with duals of
/// dimension `N`, which keeps the cost near `3N²` dual operations per Lagrangian operation rather
/// than the `4N²` of a naive Hessian over `(q, v)`. Stock parts write derivatives by hand instead.
#[derive(Debug, Clone)]
pub struct AutoDiff<G, const N: usize> {
    inner: G,
}

impl<G: GenericModel<N>, const N: usize> AutoDiff<G, N> {
    /// Wraps a generic model.
    pub fn new(inner: G) -> Self {
        Self { inner }
    }

    /// The wrapped model.
    pub fn inner(&self) -> &G {
        &self.inner
    }
}

fn arr<T: Copy, const N: usize>(v: &SVector<T, N>) -> [T; N] {
    std::array::from_fn(|i| v[i])
}

fn lift<D: DualNum<Primitive = f64> + Copy, const N: usize>(x: &[f64]) -> [D; N] {
    std::array::from_fn(|i| D::from(x[i]))
}

fn svec<const N: usize>(x: &[f64]) -> SVector<f64, N> {
    SVector::from_fn(|i, _| x[i])
}

impl<G: GenericModel<N>, const N: usize> Model for AutoDiff<G, N> {
    fn dim(&self) -> usize {
        N
    }

    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let q: [f64; N] = std::array::from_fn(|i| q[i]);
        let v: [f64; N] = std::array::from_fn(|i| v[i]);
        self.inner.lagrangian(&q, &v)
    }

    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let g = &self.inner;
        let (_, gq) = gradient(|z| g.lagrangian(&arr(&z), &lift(v)), &svec::<N>(q));
        let (_, gv) = gradient(|z| g.lagrangian(&lift(q), &arr(&z)), &svec::<N>(v));
        lq.copy_from_slice(gq.as_slice());
        lv.copy_from_slice(gv.as_slice());
    }

    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], out: &mut LagrangianHessian) {
        let g = &self.inner;
        let (_, _, hqq) = hessian(|z| g.lagrangian(&arr(&z), &lift(v)), &svec::<N>(q));
        let (_, _, hvv) = hessian(|z| g.lagrangian(&lift(q), &arr(&z)), &svec::<N>(v));
        let (_, _, _, hqv) = partial_hessian(
            |(a, b)| g.lagrangian(&arr(&a), &arr(&b)),
            (&svec::<N>(q), &svec::<N>(v)),
        );
        for j in 0..N {
            for i in 0..N {
                out.qq.add(i, j, hqq[(i, j)]);
                out.qv.add(i, j, hqv[(i, j)]);
                out.vv.add(i, j, hvv[(i, j)]);
            }
        }
    }

    fn has_force(&self) -> bool {
        self.inner.has_force()
    }

    fn force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        let q: [f64; N] = std::array::from_fn(|i| q[i]);
        let v: [f64; N] = std::array::from_fn(|i| v[i]);
        f.copy_from_slice(&self.inner.force(&q, &v, t));
    }

    fn force_jacobian(&self, q: &[f64], v: &[f64], t: f64, out: &mut ForceJacobian) {
        let g = &self.inner;
        let (_, jq) = jacobian(
            |z| SVector::from(g.force(&arr(&z), &lift(v), t)),
            &svec::<N>(q),
        );
        let (_, jv) = jacobian(
            |z| SVector::from(g.force(&lift(q), &arr(&z), t)),
            &svec::<N>(v),
        );
        for j in 0..N {
            for i in 0..N {
                out.q.add(i, j, jq[(i, j)]);
                out.v.add(i, j, jv[(i, j)]);
            }
        }
    }

    fn is_linear(&self) -> bool {
        self.inner.is_linear()
    }
}
