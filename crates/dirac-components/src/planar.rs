//! Planar mechanisms: a Cartesian pendulum and rigid bodies joined by pin joints.
//!
//! Both use holonomic constraints (`ConstraintKind::Holonomic`): the step enforces `g(q_{k+1}) = 0`
//! exactly, with the constraint force along `dg` (the constrained discrete Euler–Lagrange
//! equations, equivalent to SHAKE/RATTLE for the midpoint rule), so bodies never drift apart.
//! `multiplier_hessian` and `contracted_derivative` are written out exactly, which Galerkin paths
//! of degree ≥ 2 (multipliers at interior control points) and the (−) flavour need.

use dirac_core::{ConstraintKind, Constraints, LagrangianHessian, Model, Triplets};
use dirac_graph::{Check, PartError, Subsystem};
use serde::{Deserialize, Serialize};

/// A point mass `m` on a massless rod of length `ℓ` about a fixed pivot, in Cartesian
/// coordinates `(x, y)` (`y` up) under gravity `g`:
///
/// ```text
/// L = ½ m (ẋ² + ẏ²) − m g y,      g_rod(x, y) = ½ ((x − x_p)² + (y − y_p)² − ℓ²) = 0.
/// ```
///
/// Ports `x` (coordinate 0) and `y` (coordinate 1): the bob's position; a force source or a
/// spring on either acts on the bob.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Pendulum {
    /// Bob mass.
    pub m: f64,
    /// Rod length `ℓ`.
    pub length: f64,
    /// Gravitational acceleration (acting towards `−y`; 9.81 when a file leaves it out).
    #[serde(default = "crate::serde_defaults::gravity")]
    pub g: f64,
    /// Pivot position `(x_p, y_p)` (the origin when a file leaves it out).
    #[serde(default)]
    pub pivot: [f64; 2],
}

impl Pendulum {
    /// A bob of mass `m` on a rod of length `length` (both positive and finite) about `pivot`,
    /// under gravity `g` (finite) towards `−y`.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(m: f64, length: f64, g: f64, pivot: [f64; 2]) -> Result<Self, PartError> {
        let c = Check::new("pendulum");
        Ok(Self {
            m: c.positive("m", m)?,
            length: c.positive("length", length)?,
            g: c.finite("g", g)?,
            pivot: [
                c.finite("pivot[0]", pivot[0])?,
                c.finite("pivot[1]", pivot[1])?,
            ],
        })
    }

    /// The bob position at angle `α` from the downward vertical (counter-clockwise positive).
    #[must_use]
    pub fn position(&self, alpha: f64) -> [f64; 2] {
        let (s, c) = alpha.sin_cos();
        [
            self.pivot[0] + self.length * s,
            self.pivot[1] - self.length * c,
        ]
    }

    /// The angle from the downward vertical at bob position `q`.
    #[must_use]
    pub fn angle(&self, q: &[f64]) -> f64 {
        (q[0] - self.pivot[0]).atan2(self.pivot[1] - q[1])
    }

    /// This part as a subsystem named `name` with ports `x`, `y`.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_constraints(self)
            .with_port("x", 0)
            .with_port("y", 1)
    }
}

impl Model for Pendulum {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * self.m * (v[0] * v[0] + v[1] * v[1]) - self.m * self.g * q[1]
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lq[1] = -self.m * self.g;
        lv[0] = self.m * v[0];
        lv[1] = self.m * v[1];
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.vv.add(0, 0, self.m);
        h.vv.add(1, 1, self.m);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["x", "y"][i].into()
    }
}

impl Constraints for Pendulum {
    fn count(&self) -> usize {
        1
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::Holonomic
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        out.add(0, 0, q[0] - self.pivot[0]);
        out.add(0, 1, q[1] - self.pivot[1]);
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        let (dx, dy) = (q[0] - self.pivot[0], q[1] - self.pivot[1]);
        out[0] = 0.5 * (dx * dx + dy * dy - self.length * self.length);
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
        "rod".into()
    }
}

/// A planar rigid body: mass `m` and moment of inertia `j` about its centre of mass.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PlanarBody {
    /// Name (prefix of its ports).
    pub name: String,
    /// Mass.
    pub m: f64,
    /// Moment of inertia about the centre of mass.
    pub j: f64,
}

/// What a pin holds a body point to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// A fixed point of the plane.
    Ground([f64; 2]),
    /// A point of another body, in that body's frame (relative to its centre of mass).
    Body {
        /// Index of the body.
        body: usize,
        /// The point in the body frame.
        point: [f64; 2],
    },
}

/// A pin joint: body point `point` (body frame) coincides with `anchor`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pin {
    /// Index of the pinned body.
    pub body: usize,
    /// The pinned point in the body frame.
    pub point: [f64; 2],
    /// Where it is pinned.
    pub anchor: Anchor,
}

/// `R(θ) r` and `R'(θ) r` for a body-frame point `r`.
fn rotate(theta: f64, r: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let (s, c) = theta.sin_cos();
    (
        [c * r[0] - s * r[1], s * r[0] + c * r[1]],
        [-s * r[0] - c * r[1], c * r[0] - s * r[1]],
    )
}

/// Several planar rigid bodies under gravity, joined to the ground and to each other by pin
/// joints, as one subsystem.
///
/// Body `i` has coordinates `(xᵢ, yᵢ, θᵢ)` (centre of mass and orientation, `y` up) at
/// `3i, 3i + 1, 3i + 2`, and
///
/// ```text
/// L = Σᵢ ½ mᵢ (ẋᵢ² + ẏᵢ²) + ½ Jᵢ θ̇ᵢ² − mᵢ g yᵢ.
/// ```
///
/// A pin holding body point `r` (body frame) of body `a` to an anchor adds two holonomic rows
///
/// ```text
/// g = X_a + R(θ_a) r − P                     (ground point P)
/// g = X_a + R(θ_a) r − X_b − R(θ_b) s        (point s of body b).
/// ```
///
/// Their covectors are `[I, R'(θ_a) r]` (and `−[I, R'(θ_b) s]`), and the only second derivatives
/// are `∂²g/∂θ_a² = −R(θ_a) r` (and `+R(θ_b) s`): that is all `multiplier_hessian` and
/// `contracted_derivative` stamp. Keeping the bodies and pins inside one subsystem keeps the
/// closed-chain bookkeeping (and the rows' nonlinearity) local; the bodies' coordinates are still
/// ports, so motors, springs, or other subsystems attach to them.
///
/// Ports: `"{name}.x"`, `"{name}.y"`, `"{name}.theta"` for each body.
///
/// ```
/// use dirac_components::PlanarLinkage;
/// // A two-rod chain hanging from the origin (rods of length 1 along their body x axes).
/// let mut chain = PlanarLinkage::new(9.81)?;
/// let a = chain.add_body("a", 1.0, 1.0 / 12.0)?;
/// let b = chain.add_body("b", 1.0, 1.0 / 12.0)?;
/// chain.pin_to_ground(a, [-0.5, 0.0], [0.0, 0.0]);
/// chain.pin(b, [-0.5, 0.0], a, [0.5, 0.0]);
/// let mut q = vec![0.0; 6];
/// let down = -std::f64::consts::FRAC_PI_2;
/// chain.place(&mut q, a, down, [-0.5, 0.0], [0.0, 0.0]);
/// let elbow = chain.point(&q, a, [0.5, 0.0]);
/// chain.place(&mut q, b, down, [-0.5, 0.0], elbow);
/// assert!((q[4] + 1.5).abs() < 1e-15); // b's centre 1.5 below the pivot
/// let part = chain.subsystem("chain");
/// assert_eq!(part.ports().len(), 6);
/// # Ok::<(), dirac_components::PartError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlanarLinkage {
    bodies: Vec<PlanarBody>,
    pins: Vec<Pin>,
    gravity: f64,
}

impl PlanarLinkage {
    /// An empty linkage under gravity `gravity` (finite, towards `−y`).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `g` otherwise.
    pub fn new(gravity: f64) -> Result<Self, PartError> {
        Ok(Self {
            bodies: Vec::new(),
            pins: Vec::new(),
            gravity: Check::new("planar_linkage").finite("g", gravity)?,
        })
    }

    /// Adds a body of mass `m` and central inertia `j` (both positive and finite); returns its
    /// index.
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `bodies[i].m` or `bodies[i].j` (`i` the new index).
    pub fn add_body(
        &mut self,
        name: impl Into<String>,
        m: f64,
        j: f64,
    ) -> Result<usize, PartError> {
        let c = Check::new("planar_linkage");
        let i = self.bodies.len();
        self.bodies.push(PlanarBody {
            name: name.into(),
            m: c.positive(&format!("bodies[{i}].m"), m)?,
            j: c.positive(&format!("bodies[{i}].j"), j)?,
        });
        Ok(i)
    }

    /// Pins body point `point` (body frame) of `body` to the fixed point `at`.
    ///
    /// # Panics
    /// If `body` is not a body of this linkage.
    pub fn pin_to_ground(&mut self, body: usize, point: [f64; 2], at: [f64; 2]) {
        assert!(body < self.bodies.len(), "no body {body}");
        self.pins.push(Pin {
            body,
            point,
            anchor: Anchor::Ground(at),
        });
    }

    /// Pins point `point_a` of body `a` to point `point_b` of body `b` (body frames).
    ///
    /// # Panics
    /// If `a` or `b` is not a body of this linkage, or `a == b`.
    pub fn pin(&mut self, a: usize, point_a: [f64; 2], b: usize, point_b: [f64; 2]) {
        assert!(a < self.bodies.len() && b < self.bodies.len() && a != b);
        self.pins.push(Pin {
            body: a,
            point: point_a,
            anchor: Anchor::Body {
                body: b,
                point: point_b,
            },
        });
    }

    /// The bodies.
    #[must_use]
    pub fn bodies(&self) -> &[PlanarBody] {
        &self.bodies
    }

    /// The pins.
    #[must_use]
    pub fn pins(&self) -> &[Pin] {
        &self.pins
    }

    /// World position of body point `point` (body frame) of `body` at configuration `q`.
    #[must_use]
    pub fn point(&self, q: &[f64], body: usize, point: [f64; 2]) -> [f64; 2] {
        let (r, _) = rotate(q[3 * body + 2], point);
        [q[3 * body] + r[0], q[3 * body + 1] + r[1]]
    }

    /// Sets `body`'s angle to `theta` and its centre so that body point `point` lies at `at`
    /// (builds consistent initial configurations, body by body along a chain).
    pub fn place(&self, q: &mut [f64], body: usize, theta: f64, point: [f64; 2], at: [f64; 2]) {
        let (r, _) = rotate(theta, point);
        q[3 * body] = at[0] - r[0];
        q[3 * body + 1] = at[1] - r[1];
        q[3 * body + 2] = theta;
    }

    /// This linkage as a subsystem named `name` with ports `"{body}.x"`, `"{body}.y"`,
    /// `"{body}.theta"` for each body.
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        let mut s = Subsystem::new(name, self.clone());
        for (i, b) in self.bodies.iter().enumerate() {
            s = s
                .with_port(format!("{}.x", b.name), 3 * i)
                .with_port(format!("{}.y", b.name), 3 * i + 1)
                .with_port(format!("{}.theta", b.name), 3 * i + 2);
        }
        s.with_constraints(self)
    }
}

impl Model for PlanarLinkage {
    fn dim(&self) -> usize {
        3 * self.bodies.len()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let (vx, vy, w) = (v[3 * i], v[3 * i + 1], v[3 * i + 2]);
                0.5 * b.m * (vx * vx + vy * vy) + 0.5 * b.j * w * w
                    - b.m * self.gravity * q[3 * i + 1]
            })
            .sum()
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        for (i, b) in self.bodies.iter().enumerate() {
            lq[3 * i] = 0.0;
            lq[3 * i + 1] = -b.m * self.gravity;
            lq[3 * i + 2] = 0.0;
            lv[3 * i] = b.m * v[3 * i];
            lv[3 * i + 1] = b.m * v[3 * i + 1];
            lv[3 * i + 2] = b.j * v[3 * i + 2];
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        for (i, b) in self.bodies.iter().enumerate() {
            h.vv.add(3 * i, 3 * i, b.m);
            h.vv.add(3 * i + 1, 3 * i + 1, b.m);
            h.vv.add(3 * i + 2, 3 * i + 2, b.j);
        }
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        format!("{}.{}", self.bodies[i / 3].name, ["x", "y", "theta"][i % 3])
    }
}

impl Constraints for PlanarLinkage {
    fn count(&self) -> usize {
        2 * self.pins.len()
    }
    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::Holonomic
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        for (p, pin) in self.pins.iter().enumerate() {
            let a = pin.body;
            let (_, d) = rotate(q[3 * a + 2], pin.point);
            for (k, dk) in d.into_iter().enumerate() {
                out.add(2 * p + k, 3 * a + k, 1.0);
                out.add(2 * p + k, 3 * a + 2, dk);
            }
            if let Anchor::Body { body: b, point } = pin.anchor {
                let (_, d) = rotate(q[3 * b + 2], point);
                for (k, dk) in d.into_iter().enumerate() {
                    out.add(2 * p + k, 3 * b + k, -1.0);
                    out.add(2 * p + k, 3 * b + 2, -dk);
                }
            }
        }
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        for (p, pin) in self.pins.iter().enumerate() {
            let x = self.point(q, pin.body, pin.point);
            let y = match pin.anchor {
                Anchor::Ground(at) => at,
                Anchor::Body { body, point } => self.point(q, body, point),
            };
            out[2 * p] = x[0] - y[0];
            out[2 * p + 1] = x[1] - y[1];
        }
    }
    fn is_constant(&self) -> bool {
        self.pins.is_empty()
    }
    fn multiplier_hessian(&self, q: &[f64], lambda: &[f64], out: &mut Triplets) {
        // Σₐ λₐ ∂²gᵃ/∂θ²: −λ·R(θ_a) r for the pinned body, +λ·R(θ_b) s for a body anchor.
        for (p, pin) in self.pins.iter().enumerate() {
            let l = [lambda[2 * p], lambda[2 * p + 1]];
            let a = pin.body;
            let (r, _) = rotate(q[3 * a + 2], pin.point);
            out.add(3 * a + 2, 3 * a + 2, -(l[0] * r[0] + l[1] * r[1]));
            if let Anchor::Body { body: b, point } = pin.anchor {
                let (s, _) = rotate(q[3 * b + 2], point);
                out.add(3 * b + 2, 3 * b + 2, l[0] * s[0] + l[1] * s[1]);
            }
        }
    }
    fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
        // Σⱼ wⱼ ∂Aᵃⱼ/∂θ: only the θ columns of a row depend on θ.
        for (p, pin) in self.pins.iter().enumerate() {
            let a = pin.body;
            let (r, _) = rotate(q[3 * a + 2], pin.point);
            for (k, rk) in r.into_iter().enumerate() {
                out.add(2 * p + k, 3 * a + 2, -w[3 * a + 2] * rk);
            }
            if let Anchor::Body { body: b, point } = pin.anchor {
                let (s, _) = rotate(q[3 * b + 2], point);
                for (k, sk) in s.into_iter().enumerate() {
                    out.add(2 * p + k, 3 * b + 2, w[3 * b + 2] * sk);
                }
            }
        }
    }
    fn name(&self, a: usize) -> String {
        let pin = &self.pins[a / 2];
        let to = match pin.anchor {
            Anchor::Ground(_) => "ground".to_string(),
            Anchor::Body { body, .. } => self.bodies[body].name.clone(),
        };
        format!(
            "pin {} ({}–{to}, {})",
            a / 2,
            self.bodies[pin.body].name,
            ["x", "y"][a % 2]
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Run, check_constraints, check_model};
    use dirac_core::Discretisation;
    use dirac_graph::{Interconnection, Representation};
    use dirac_sim::IntegratorOptions;
    use std::f64::consts::{FRAC_PI_2, PI};

    const G: f64 = 9.81;

    /// Complete elliptic integral of the first kind `K(k) = π / (2 AGM(1, √(1 − k²)))`.
    fn elliptic_k(k: f64) -> f64 {
        let (mut a, mut b) = (1.0_f64, (1.0 - k * k).sqrt());
        for _ in 0..40 {
            let (an, bn) = (0.5 * (a + b), (a * b).sqrt());
            a = an;
            b = bn;
        }
        PI / (2.0 * a)
    }

    /// Mean period from upward zero crossings (linear interpolation) of an angle sampled every `h`.
    fn period(angles: &[f64], h: f64) -> f64 {
        let mut crossings = Vec::new();
        for (k, w) in angles.windows(2).enumerate() {
            if w[0] < 0.0 && w[1] >= 0.0 {
                crossings.push((k as f64 + w[0] / (w[0] - w[1])) * h);
            }
        }
        assert!(crossings.len() >= 3, "too few periods");
        (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
    }

    /// Runs a one-subsystem graph from rest at `q0` and samples `angle(q)` every step.
    fn sample(
        part: Subsystem,
        q0: &[f64],
        options: IntegratorOptions,
        steps: usize,
        angle: impl Fn(&[f64]) -> f64,
    ) -> (Vec<f64>, f64) {
        let mut g = Interconnection::new();
        g.add_subsystem(part).unwrap();
        let mut run =
            Run::tracking_residual(&g, Representation::Monolithic, options, &[q0.to_vec()]);
        let mut out = vec![angle(run.integrator().q())];
        let mut residual: f64 = 0.0;
        for _ in 0..steps {
            run.step();
            residual = residual.max(run.constraint_residual());
            out.push(angle(run.integrator().q()));
        }
        (out, residual)
    }

    #[test]
    fn hand_written_derivatives() {
        let p = Pendulum {
            m: 2.0,
            length: 1.5,
            g: G,
            pivot: [0.3, -0.2],
        };
        check_model(&p, &[0.4, -1.0], &[0.3, 0.2], 0.0);
        check_constraints(&p, &[0.4, -1.0], &[0.7], &[0.3, -0.9]);

        let mut l = PlanarLinkage::new(G).unwrap();
        let a = l.add_body("a", 2.0, 0.3).unwrap();
        let b = l.add_body("b", 1.0, 0.1).unwrap();
        let c = l.add_body("c", 0.5, 0.05).unwrap();
        l.pin_to_ground(a, [-0.5, 0.1], [0.2, 0.3]);
        l.pin(b, [-0.4, 0.0], a, [0.5, -0.1]);
        l.pin(c, [0.0, 0.2], b, [0.3, 0.05]);
        let q = [0.1, -0.2, 0.4, 0.7, -0.9, -1.1, 1.0, 1.2, 2.3];
        let v = [0.3, -0.1, 0.2, 0.5, 0.4, -0.6, 0.1, 0.2, 0.9];
        let lambda = [0.7, -1.3, 0.4, 2.0, -0.5, 0.8];
        check_model(&l, &q, &v, 0.0);
        check_constraints(&l, &q, &lambda, &v);
    }

    /// Cartesian pendulum released from 1 rad: the midpoint (holonomic) period converges to
    /// `T = 4√(ℓ/g) K(sin(α₀/2))` at second order. With `h = T₀/400` the relative error is of the
    /// size of the linear midpoint phase error `(ωh)²/12 ≈ 2e-5` (asserted below 1.5 times that),
    /// it drops by 4 when `h` halves, and the Richardson extrapolation
    /// `(4T(h/2) − T(h))/3` matches the elliptic period to 1e-8. The rod length holds to round-off.
    #[test]
    fn cartesian_pendulum_period_is_elliptic() {
        let p = Pendulum {
            m: 1.0,
            length: 2.0,
            g: G,
            pivot: [0.0, 0.0],
        };
        let alpha0: f64 = 1.0;
        let exact = 4.0 * (p.length / G).sqrt() * elliptic_k((alpha0 / 2.0).sin());
        let t0 = 2.0 * PI * (p.length / G).sqrt();
        let mut periods = Vec::new();
        for div in [400.0, 800.0] {
            let h = t0 / div;
            let options = IntegratorOptions::new(Discretisation::midpoint(), h);
            let steps = (10.0 * exact / h) as usize;
            let (angles, residual) =
                sample(p.subsystem("P"), &p.position(alpha0), options, steps, |q| {
                    p.angle(q)
                });
            assert!(residual < 1e-13, "rod residual {residual:e}");
            periods.push(period(&angles, h));
        }
        let (e1, e2) = ((periods[0] - exact) / exact, (periods[1] - exact) / exact);
        let extrapolated = (4.0 * periods[1] - periods[0]) / 3.0;
        let e_r = (extrapolated - exact) / exact;
        println!(
            "pendulum: T = {exact:.12} s, errors {e1:.3e} (h = T₀/400), {e2:.3e} (T₀/800), ratio {:.3}, Richardson {e_r:.2e}",
            e1 / e2
        );
        let scale = (2.0 * PI / 400.0_f64).powi(2) / 12.0;
        assert!(e1.abs() < 1.5 * scale && (3.8..4.2).contains(&(e1 / e2)) && e_r.abs() < 1e-8);
    }

    /// Rod of length ℓ pinned at one end (a one-body [`PlanarLinkage`]): a compound pendulum with
    /// `I_p = mℓ²/3`, `d = ℓ/2`, period `4√(I_p/mgd) K(sin(α₀/2))`; second-order convergence as for
    /// the point pendulum; pin residuals at round-off.
    #[test]
    fn compound_pendulum_period() {
        let (m, len) = (3.0, 1.2);
        let mut l = PlanarLinkage::new(G).unwrap();
        let rod = l.add_body("rod", m, m * len * len / 12.0).unwrap();
        l.pin_to_ground(rod, [-len / 2.0, 0.0], [0.0, 0.0]);
        let alpha0: f64 = 0.8;
        let mut q0 = vec![0.0; 3];
        l.place(
            &mut q0,
            rod,
            alpha0 - FRAC_PI_2,
            [-len / 2.0, 0.0],
            [0.0, 0.0],
        );
        let ip_over_mgd = (m * len * len / 3.0) / (m * G * len / 2.0);
        let exact = 4.0 * ip_over_mgd.sqrt() * elliptic_k((alpha0 / 2.0).sin());
        let t0 = 2.0 * PI * ip_over_mgd.sqrt();
        let mut periods = Vec::new();
        for div in [400.0, 800.0] {
            let h = t0 / div;
            let options = IntegratorOptions::new(Discretisation::midpoint(), h);
            let steps = (10.0 * exact / h) as usize;
            let (angles, residual) = sample(l.clone().subsystem("L"), &q0, options, steps, |q| {
                q[2] + FRAC_PI_2
            });
            assert!(residual < 1e-13, "pin residual {residual:e}");
            periods.push(period(&angles, h));
        }
        let (e1, e2) = ((periods[0] - exact) / exact, (periods[1] - exact) / exact);
        let e_r = ((4.0 * periods[1] - periods[0]) / 3.0 - exact) / exact;
        println!(
            "compound pendulum: T = {exact:.12} s, errors {e1:.3e}, {e2:.3e}, ratio {:.3}, Richardson {e_r:.2e}",
            e1 / e2
        );
        let scale = (2.0 * PI / 400.0_f64).powi(2) / 12.0;
        assert!(e1.abs() < 1.5 * scale && (3.8..4.2).contains(&(e1 / e2)) && e_r.abs() < 1e-8);
    }

    /// Two identical rods pinned in a chain (body 1 to the ground, body 2 to body 1's free end):
    /// the linearised modes solve `det(K − ω²M) = 0` with `M = mℓ²[4/3 1/2; 1/2 1/3]`,
    /// `K = mgℓ[3/2 0; 0 1/2]`, i.e. `ω² = (g/ℓ)(3 ∓ 6/√7)`. Released at amplitude ε = 1e-4 in
    /// either mode shape, the chain oscillates at that frequency: the midpoint error at `h = T/200`
    /// is of the size of the linear phase error `(ωh)²/12`, and after Richardson extrapolation in
    /// `h` the period matches to 1e-6 (measured ≤ 4e-8: what remains is the O(ε²) amplitude
    /// effect, 100 times larger at ε = 1e-3). Run with the fourth-order Gauss–Legendre path as
    /// well (its interior multipliers use `multiplier_hessian`), whose error at `h = T/100` is
    /// already below 1e-6.
    #[test]
    fn double_rod_chain_normal_modes() {
        let (m, len) = (1.0, 1.0);
        let mut l = PlanarLinkage::new(G).unwrap();
        let a = l.add_body("a", m, m * len * len / 12.0).unwrap();
        let b = l.add_body("b", m, m * len * len / 12.0).unwrap();
        let (top, bottom) = ([-len / 2.0, 0.0], [len / 2.0, 0.0]);
        l.pin_to_ground(a, top, [0.0, 0.0]);
        l.pin(b, top, a, bottom);
        let eps = 1e-4;
        for sign in [-1.0, 1.0] {
            let lam = 3.0 + sign * 6.0 / 7.0_f64.sqrt(); // ω²ℓ/g
            let omega = (lam * G / len).sqrt();
            let exact = 2.0 * PI / omega;
            let shape = (1.5 - 4.0 * lam / 3.0) / (lam / 2.0); // α₂/α₁
            let mut q0 = vec![0.0; 6];
            l.place(&mut q0, a, eps - FRAC_PI_2, top, [0.0, 0.0]);
            let elbow = l.point(&q0, a, bottom);
            l.place(&mut q0, b, eps * shape - FRAC_PI_2, top, elbow);
            let mut periods = Vec::new();
            for div in [200.0, 400.0] {
                let h = exact / div;
                let options = IntegratorOptions::new(Discretisation::midpoint(), h);
                let (angles, residual) = sample(
                    l.clone().subsystem("L"),
                    &q0,
                    options,
                    8 * div as usize,
                    |q| q[2] + FRAC_PI_2,
                );
                assert!(residual < 1e-13, "pin residual {residual:e}");
                periods.push(period(&angles, h));
            }
            let e1 = (periods[0] - exact) / exact;
            let e_r = ((4.0 * periods[1] - periods[0]) / 3.0 - exact) / exact;
            let h = exact / 100.0;
            let options = IntegratorOptions::new(Discretisation::gauss(2), h);
            let (angles, residual) = sample(l.clone().subsystem("L"), &q0, options, 800, |q| {
                q[2] + FRAC_PI_2
            });
            let e_gauss = (period(&angles, h) - exact) / exact;
            println!(
                "double rod mode ω² = {lam:.6} g/ℓ (α₂/α₁ = {shape:.4}): midpoint error {e1:.3e}, Richardson {e_r:.2e}; Gauss-2 at T/100 {e_gauss:.2e} (residual {residual:.1e})"
            );
            let scale = (2.0 * PI / 200.0_f64).powi(2) / 12.0;
            assert!(e1.abs() < 1.5 * scale && e_r.abs() < 1e-6 && e_gauss.abs() < 1e-6);
            assert!(residual < 1e-13);
        }
    }
}
