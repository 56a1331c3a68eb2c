//! Joint rows as dot products of vectors affine in the port values of two bodies.

use crate::body::rotation_index;
use crate::so3::Mat3;

/// A 3-vector affine in the port values `x`: component `k` is `c[k] + Σ a xᵢ` over
/// `terms[k] = [(i, a), …]`.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Affine3 {
    pub c: [f64; 3],
    pub terms: [Vec<(usize, f64)>; 3],
}

impl Affine3 {
    /// A constant vector.
    pub fn constant(c: [f64; 3]) -> Self {
        Self {
            c,
            terms: Default::default(),
        }
    }

    /// The body point `x + R r` of a body whose twelve ports start at `offset`.
    pub fn point(offset: usize, r: [f64; 3]) -> Self {
        let mut v = Self::default();
        for k in 0..3 {
            v.terms[k].push((offset + k, 1.0));
            for (j, rj) in r.iter().enumerate() {
                if *rj != 0.0 {
                    v.terms[k].push((offset + rotation_index(k, j), *rj));
                }
            }
        }
        v
    }

    /// The body-fixed direction `R e` of a body whose ports start at `offset`.
    pub fn direction(offset: usize, e: [f64; 3]) -> Self {
        let mut v = Self::default();
        for k in 0..3 {
            for (j, ej) in e.iter().enumerate() {
                if *ej != 0.0 {
                    v.terms[k].push((offset + rotation_index(k, j), *ej));
                }
            }
        }
        v
    }

    /// `self − other`.
    pub fn minus(&self, other: &Self) -> Self {
        let mut v = self.clone();
        for k in 0..3 {
            v.c[k] -= other.c[k];
            v.terms[k].extend(other.terms[k].iter().map(|&(i, a)| (i, -a)));
        }
        v
    }

    /// The value at `x`.
    pub fn eval(&self, x: &[f64]) -> [f64; 3] {
        [0, 1, 2].map(|k| self.c[k] + self.terms[k].iter().map(|&(i, a)| a * x[i]).sum::<f64>())
    }

    /// Whether the vector is constant.
    pub fn is_constant(&self) -> bool {
        self.terms.iter().all(Vec::is_empty)
    }
}

/// A row `u(x)·w(x) − target`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Dot {
    pub u: Affine3,
    pub w: Affine3,
    pub target: f64,
}

impl Dot {
    pub fn new(u: Affine3, w: Affine3) -> Self {
        Self { u, w, target: 0.0 }
    }

    pub fn value(&self, x: &[f64]) -> f64 {
        let (u, w) = (self.u.eval(x), self.w.eval(x));
        u[0] * w[0] + u[1] * w[1] + u[2] * w[2] - self.target
    }

    /// Emits `s·∂g/∂xᵢ` as `(i, value)` (fixed sequence).
    pub fn gradient(&self, x: &[f64], s: f64, emit: &mut dyn FnMut(usize, f64)) {
        let (u, w) = (self.u.eval(x), self.w.eval(x));
        for k in 0..3 {
            for &(i, a) in &self.u.terms[k] {
                emit(i, s * a * w[k]);
            }
            for &(i, a) in &self.w.terms[k] {
                emit(i, s * a * u[k]);
            }
        }
    }

    /// Emits `s·∂²g/∂xᵢ∂xⱼ` as `(i, j, value)`, both triangles (fixed sequence).
    pub fn hessian(&self, s: f64, emit: &mut dyn FnMut(usize, usize, f64)) {
        for k in 0..3 {
            for &(i, a) in &self.u.terms[k] {
                for &(j, b) in &self.w.terms[k] {
                    emit(i, j, s * a * b);
                    emit(j, i, s * a * b);
                }
            }
        }
    }

    /// Whether the row is affine in `x`.
    pub fn is_linear(&self) -> bool {
        self.u.is_constant() || self.w.is_constant()
    }
}

/// Column `k` of `m`.
pub(crate) fn column(m: &Mat3, k: usize) -> [f64; 3] {
    [m[0][k], m[1][k], m[2][k]]
}
