//! Constrained mechanical systems: the vertical rolling disk and the Cartesian pendulum.

use dirac_core::{ConstraintKind, Constraints, LagrangianHessian, Model, Triplets};

/// Free motion with a diagonal mass matrix and a linear potential: `L = ½ Σ mᵢvᵢ² − Σ gᵢqᵢ`.
///
/// With no constraints the motion is uniform (plus constant acceleration); the constraint sets
/// below make it a rolling disk or a pendulum.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeMasses {
    /// Masses (or inertias) `mᵢ`.
    pub masses: Vec<f64>,
    /// Constant generalised weights `gᵢ` (potential `Σ gᵢ qᵢ`).
    pub weights: Vec<f64>,
    /// Coordinate names.
    pub names: Vec<&'static str>,
}

impl FreeMasses {
    /// Energy `Σ pᵢ²/(2mᵢ) + Σ gᵢqᵢ`.
    #[must_use]
    pub fn energy(&self, q: &[f64], p: &[f64]) -> f64 {
        self.masses
            .iter()
            .zip(&self.weights)
            .enumerate()
            .map(|(i, (m, g))| 0.5 * p[i] * p[i] / m + g * q[i])
            .sum()
    }
}

impl Model for FreeMasses {
    fn dim(&self) -> usize {
        self.masses.len()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        self.masses
            .iter()
            .zip(&self.weights)
            .enumerate()
            .map(|(i, (m, g))| 0.5 * m * v[i] * v[i] - g * q[i])
            .sum()
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        for i in 0..self.masses.len() {
            lq[i] = -self.weights[i];
            lv[i] = self.masses[i] * v[i];
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        for (i, m) in self.masses.iter().enumerate() {
            h.vv.add(i, i, *m);
        }
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        self.names
            .get(i)
            .map_or_else(|| format!("q{i}"), |s| (*s).to_string())
    }
}

/// Unit-length pendulum in Cartesian coordinates `(x, y)`: `x² + y² = ℓ²`, either at position
/// level (`g(q) = ½(x² + y² − ℓ²)`, holonomic) or as the one-form `x dx + y dy` (Dirac form).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleConstraint {
    /// Pendulum length `ℓ`.
    pub length: f64,
    /// How the constraint is enforced.
    pub kind: ConstraintKind,
}

impl CircleConstraint {
    /// The point mass `L = ½(ẋ² + ẏ²) − g y`.
    #[must_use]
    pub fn model(mass: f64, gravity: f64) -> FreeMasses {
        FreeMasses {
            masses: vec![mass, mass],
            weights: vec![0.0, mass * gravity],
            names: vec!["x", "y"],
        }
    }

    /// The constraint residual `√(x² + y²) − ℓ`.
    #[must_use]
    pub fn drift(&self, q: &[f64]) -> f64 {
        q[0].hypot(q[1]) - self.length
    }
}

impl Constraints for CircleConstraint {
    fn count(&self) -> usize {
        1
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        self.kind
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        out.add(0, 0, q[0]);
        out.add(0, 1, q[1]);
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        out[0] = 0.5 * (q[0] * q[0] + q[1] * q[1] - self.length * self.length);
    }
    fn is_constant(&self) -> bool {
        false
    }
    fn multiplier_hessian(&self, _q: &[f64], lambda: &[f64], out: &mut Triplets) {
        out.add(0, 0, lambda[0]);
        out.add(1, 1, lambda[0]);
    }
    fn contracted_derivative(&self, _q: &[f64], w: &[f64], out: &mut Triplets) {
        out.add(0, 0, w[0]);
        out.add(0, 1, w[1]);
    }
    fn name(&self, _a: usize) -> String {
        "circle".to_string()
    }
}
