//! The vertical rolling disk: a nonholonomic part with q-dependent constraint forms.

use dirac_core::{ConstraintKind, Constraints, LagrangianHessian, Model, Triplets};
use dirac_graph::{Check, PartError, Subsystem};
use serde::{Deserialize, Serialize};

/// Rolling without slipping for a vertical disk on `q = (x, y, θ, φ)` (contact point, rolling angle,
/// heading): `ẋ = R cos φ θ̇`, `ẏ = R sin φ θ̇`, i.e. the one-forms `ω¹ = dx − R cos φ dθ` and
/// `ω² = dy − R sin φ dθ`. They depend on `φ`, so the (+) and (−) schemes differ on them; the
/// symmetric scheme conserves the disk's energy (see docs/math.md §3).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct RollingConstraint {
    /// Disk radius.
    pub radius: f64,
}

impl RollingConstraint {
    /// Rolling without slipping at radius `radius` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `radius` otherwise.
    pub fn new(radius: f64) -> Result<Self, PartError> {
        Ok(Self {
            radius: Check::new("rolling_disk").positive("radius", radius)?,
        })
    }
}

impl Constraints for RollingConstraint {
    fn count(&self) -> usize {
        2
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::OneForm
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        let (s, c) = q[3].sin_cos();
        out.add(0, 0, 1.0);
        out.add(0, 2, -self.radius * c);
        out.add(1, 1, 1.0);
        out.add(1, 2, -self.radius * s);
    }
    fn is_constant(&self) -> bool {
        false
    }
    fn multiplier_hessian(&self, q: &[f64], lambda: &[f64], out: &mut Triplets) {
        // ∂/∂φ of (λ₁ ω¹ + λ₂ ω²)_θ = λ₁ R sin φ − λ₂ R cos φ.
        let (s, c) = q[3].sin_cos();
        out.add(2, 3, self.radius * (lambda[0] * s - lambda[1] * c));
    }
    fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
        let (s, c) = q[3].sin_cos();
        out.add(0, 3, self.radius * s * w[2]);
        out.add(1, 3, -self.radius * c * w[2]);
    }
    fn name(&self, a: usize) -> String {
        ["roll-x", "roll-y"][a].to_string()
    }
}

/// A vertical disk rolling without slipping: `L = ½m(ẋ² + ẏ²) + ½Iθ̇² + ½Jφ̇²` with the
/// [`RollingConstraint`] as internal constraints.
///
/// Ports (and coordinates): `x`, `y`, `theta`, `phi`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct RollingDisk {
    /// Mass.
    pub m: f64,
    /// Moment of inertia about the rolling axis.
    pub i: f64,
    /// Moment of inertia about the vertical axis.
    pub j: f64,
    /// Radius.
    pub radius: f64,
}

impl RollingDisk {
    /// A disk of mass `m`, inertias `i` (rolling axis) and `j` (vertical axis) and radius
    /// `radius`, each positive and finite.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(m: f64, i: f64, j: f64, radius: f64) -> Result<Self, PartError> {
        let c = Check::new("rolling_disk");
        Ok(Self {
            m: c.positive("m", m)?,
            i: c.positive("i", i)?,
            j: c.positive("j", j)?,
            radius: c.positive("radius", radius)?,
        })
    }

    fn masses(&self) -> [f64; 4] {
        [self.m, self.m, self.i, self.j]
    }

    /// Kinetic energy `Σ pᵢ²/(2mᵢ)` of momenta `p`.
    #[must_use]
    pub fn energy(&self, p: &[f64]) -> f64 {
        self.masses()
            .iter()
            .zip(p)
            .map(|(m, p)| 0.5 * p * p / m)
            .sum()
    }

    /// This part as a subsystem named `name`, with its rolling constraints and ports
    /// `x`, `y`, `theta`, `phi`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(RollingConstraint {
                radius: self.radius,
            })
            .with_port("x", 0)
            .with_port("y", 1)
            .with_port("theta", 2)
            .with_port("phi", 3)
    }
}

impl Model for RollingDisk {
    fn dim(&self) -> usize {
        4
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        self.masses()
            .iter()
            .zip(v)
            .map(|(m, v)| 0.5 * m * v * v)
            .sum()
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.fill(0.0);
        for ((out, m), v) in lv.iter_mut().zip(self.masses()).zip(v) {
            *out = m * v;
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        for (i, m) in self.masses().into_iter().enumerate() {
            h.vv.add(i, i, m);
        }
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["x", "y", "theta", "phi"][i].to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dirac_core::{Discretisation, Flavour, ForcedDiracStep};
    use dirac_graph::{Interconnection, Representation};
    use dirac_sim::{IntegratorOptions, Scheme, Simulation};

    /// Largest difference allowed between the step Jacobian and central differences of the step
    /// residual (entries of order 1): the differences' truncation error `ε²/6·F'''` and
    /// round-off `ε_mach·|F|/ε` with ε = 10⁻⁶ are both about 10⁻¹⁰; measured 4.0e-11 (midpoint)
    /// and 1.9e-10 (Gauss 2).
    const JACOBIAN_TOL: f64 = 1e-8;

    /// The Jacobian of the discrete Dirac step is exact: `ForcedDiracStep::jacobian` on the disk
    /// (its curvature terms come from `multiplier_hessian` and `contracted_derivative`) against
    /// central differences of `ForcedDiracStep::residual`, for the (+) and (−) steps of the
    /// midpoint rule and of Gauss 2, at a generic state with every increment and multiplier
    /// non-zero. An inexact Jacobian would show as slow Newton convergence; this rules it out for
    /// the rolling disk's iteration counts (docs/hardening.md). Mutations: the sign of the
    /// `multiplier_hessian` entry flipped fails ((−) step, Gauss 2: entry (6, 7) is −0.0145
    /// against 0.0145; the (+) steps and the (−) midpoint step do not use that term); the
    /// `contracted_derivative` entries set to zero fail ((−) midpoint: entry (4, 3) is 0 against
    /// 1.44e-3).
    #[test]
    fn step_jacobian_matches_finite_differences() {
        const EPS: f64 = 1e-6;
        let disk = RollingDisk::new(1.0, 1.3, 0.7, 0.8).unwrap();
        let roll = RollingConstraint::new(0.8).unwrap();
        for discretisation in [Discretisation::midpoint(), Discretisation::gauss(2)] {
            for flavour in [Flavour::Plus, Flavour::Minus] {
                let mut step = ForcedDiracStep::new(&disk, &roll, &discretisation, flavour, 0.05);
                step.set_start(&[0.3, -0.2, 0.7, 0.9], &[0.4, -0.1, 0.8, 0.5], 0.0);
                let n = step.unknowns();
                let x: Vec<f64> = (0..n)
                    .map(|i| 0.03 * (1.7 * i as f64).sin() + 0.01)
                    .collect();
                let mut jacobian = Triplets::new();
                jacobian.begin();
                step.jacobian(&disk, &roll, &x, &mut jacobian);
                let mut analytic = vec![0.0; n * n];
                for (r, c, v) in jacobian.iter() {
                    analytic[r * n + c] += v;
                }
                let mut worst: f64 = 0.0;
                for c in 0..n {
                    let (mut up, mut down) = (x.clone(), x.clone());
                    up[c] += EPS;
                    down[c] -= EPS;
                    let (mut r_up, mut r_down) = (vec![0.0; n], vec![0.0; n]);
                    step.residual(&disk, &roll, &up, &mut r_up);
                    step.residual(&disk, &roll, &down, &mut r_down);
                    for r in 0..n {
                        let difference = (r_up[r] - r_down[r]) / (2.0 * EPS);
                        let error = (difference - analytic[r * n + c]).abs();
                        assert!(
                            error <= JACOBIAN_TOL,
                            "{flavour:?}, degree {}: entry ({r}, {c}) is {} against {difference} by differences",
                            discretisation.path().degree(),
                            analytic[r * n + c]
                        );
                        worst = worst.max(error);
                    }
                }
                println!(
                    "{flavour:?}, degree {}: largest difference {worst:.2e}",
                    discretisation.path().degree()
                );
            }
        }
    }

    /// Closed form: with φ̇ constant and the symmetric scheme, p_φ is conserved exactly, the rolling
    /// speed |θ̇| is conserved (energy), and the contact point moves on a circle of radius R θ̇/φ̇.
    #[test]
    fn disk_rolls_on_a_circle() {
        let disk = RollingDisk {
            m: 1.0,
            i: 1.0,
            j: 1.0,
            radius: 1.0,
        };
        let options =
            IntegratorOptions::new(Discretisation::midpoint(), 0.01).scheme(Scheme::Symmetric);
        let mut g = Interconnection::new();
        g.add_subsystem(disk.subsystem("disk")).unwrap();
        let mut sim = Simulation::new(g, Representation::Monolithic, options);
        for (coordinate, v) in ["x", "y", "theta", "phi"]
            .into_iter()
            .zip([1.0, 0.0, 1.0, 0.5])
        {
            sim.set_position("disk", coordinate, 0.0).unwrap();
            sim.set_velocity("disk", coordinate, v).unwrap();
        }
        sim.step().unwrap();
        let e1 = disk.energy(&sim.momenta());
        let (mut max_de, mut max_radius_err): (f64, f64) = (0.0, 0.0);
        for _ in 0..2000 {
            sim.step().unwrap();
            let (q, p) = (sim.positions(), sim.momenta());
            max_de = max_de.max((disk.energy(&p) - e1).abs());
            assert!((p[3] - 0.5).abs() <= 1e-12);
            // Circle centred at (0, R θ̇/φ̇) = (0, 2), radius 2 (for θ̇ = 1, φ̇ = 0.5, R = 1).
            let r = q[0].hypot(q[1] - 2.0);
            max_radius_err = max_radius_err.max((r - 2.0).abs());
        }
        assert!(max_de <= 1e-12, "energy change {max_de:e}");
        // Second-order discretisation error of the circle radius at h = 0.01.
        assert!(max_radius_err <= 1e-3, "radius error {max_radius_err:e}");
    }
}
