//! Constraint one-forms `ωᵃ(q)` (Dirac form) and holonomic constraints `g(q) = 0` (position level).

use dirac_solve::Triplets;

/// How a constraint row is enforced by the discrete step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConstraintKind {
    /// A linear constraint one-form `ωᵃ(q)·v = 0`, discretised with the retraction `q + hv`:
    /// `ωᵃ(q_k)·(q_{k+1} − q_k) = 0` in the (+) flavour, `ωᵃ(q_{k+1})·(q_k − q_{k+1}) = 0` in (−).
    /// Kirchhoff's current law, rolling without slipping, equal port velocities.
    OneForm,
    /// A holonomic constraint `gᵃ(q) = 0` enforced at position level, `gᵃ(q_{k+1}) = 0`, with the
    /// constraint force along `dgᵃ(q_k)` (the constrained discrete Euler–Lagrange equations).
    /// Its row of [`Constraints::forms`] is `dgᵃ`.
    Holonomic,
}

/// A set of `m` constraint rows on `Qⁿ`.
///
/// Every row has a covector `Aᵃ(q)` stamped by [`Constraints::forms`]: the one-form `ωᵃ` itself, or
/// `dgᵃ` for a holonomic row. Patterns must be the same on every call (emit zeros too).
pub trait Constraints {
    /// Number of rows `m`.
    fn count(&self) -> usize;

    /// How row `a` is enforced.
    fn kind(&self, a: usize) -> ConstraintKind;

    /// Stamps `Aᵃⱼ(q)` as entries `(a, j, value)`.
    fn forms(&self, q: &[f64], out: &mut Triplets);

    /// Writes `gᵃ(q)` for holonomic rows (entries of one-form rows are ignored).
    fn values(&self, _q: &[f64], _out: &mut [f64]) {}

    /// True when every `Aᵃ` is independent of `q` (KCL, joints between translational ports).
    fn is_constant(&self) -> bool;

    /// Stamps `Σₐ λₐ ∂Aᵃⱼ/∂q_l` as entries `(j, l, value)`. Nothing for constant forms.
    fn multiplier_hessian(&self, _q: &[f64], _lambda: &[f64], _out: &mut Triplets) {}

    /// Stamps `Σⱼ wⱼ ∂Aᵃⱼ/∂q_l` as entries `(a, l, value)`. Nothing for constant forms.
    fn contracted_derivative(&self, _q: &[f64], _w: &[f64], _out: &mut Triplets) {}

    /// Name of row `a`, for diagnostics.
    fn name(&self, a: usize) -> String {
        format!("constraint {a}")
    }
}

/// The empty constraint set: the step is the forced discrete Hamiltonian map.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoConstraints;

impl Constraints for NoConstraints {
    fn count(&self) -> usize {
        0
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::OneForm
    }
    fn forms(&self, _q: &[f64], _out: &mut Triplets) {}
    fn is_constant(&self) -> bool {
        true
    }
}

/// Constant linear one-forms given as a sparse matrix `A` (rows `a`, columns `j`): `A·v = 0`.
///
/// Kirchhoff's current law and rigid joints between translational ports have this form.
#[derive(Debug, Clone, Default)]
pub struct LinearForms {
    n: usize,
    entries: Vec<(usize, usize, f64)>,
    names: Vec<String>,
}

impl LinearForms {
    /// An empty set on `n` coordinates.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self {
            n,
            entries: Vec::new(),
            names: Vec::new(),
        }
    }

    /// Adds the row `Σ coefficients[j].1 · dq_{coefficients[j].0}` named `name`; returns its index.
    ///
    /// # Panics
    /// If a coordinate index is out of range (a programming error in the caller).
    pub fn push(&mut self, name: impl Into<String>, coefficients: &[(usize, f64)]) -> usize {
        let a = self.names.len();
        for &(j, c) in coefficients {
            assert!(j < self.n, "coordinate {j} out of range 0..{}", self.n);
            self.entries.push((a, j, c));
        }
        self.names.push(name.into());
        a
    }

    /// Number of coordinates.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.n
    }
}

impl Constraints for LinearForms {
    fn count(&self) -> usize {
        self.names.len()
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::OneForm
    }
    fn forms(&self, _q: &[f64], out: &mut Triplets) {
        for &(a, j, c) in &self.entries {
            out.add(a, j, c);
        }
    }
    fn is_constant(&self) -> bool {
        true
    }
    fn name(&self, a: usize) -> String {
        self.names[a].clone()
    }
}
