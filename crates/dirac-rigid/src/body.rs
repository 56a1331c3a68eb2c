//! A rigid body on `ℝ³ × SO(3)`, with `SO(3)` embedded in `ℝ⁹` and `RᵀR = I` as six holonomic
//! constraints of the part.

use dirac_core::{ConstraintKind, Constraints, LagrangianHessian, Model, Triplets};
use dirac_graph::Subsystem;

use crate::error::RigidError;
use crate::so3::{self, Mat3};

/// Names of a body's twelve coordinates (and of the ports that are those coordinates): the centre
/// of mass `x, y, z`, then the rotation `R` column by column, `rij = R[i][j]`.
pub const COORDINATES: [&str; 12] = [
    "x", "y", "z", "r11", "r21", "r31", "r12", "r22", "r32", "r13", "r23", "r33",
];

/// Index of `R[i][j]` in a body's coordinates.
#[must_use]
pub const fn rotation_index(i: usize, j: usize) -> usize {
    3 + 3 * j + i
}

/// A rigid body: mass `m`, inertia tensor `J` about the centre of mass in body axes, and a uniform
/// gravity field `g`.
///
/// Configuration `(x, R) ∈ ℝ³ × SO(3)`: `x` the centre of mass, `R` the rotation from body to space
/// axes, stored as twelve coordinates (see [`COORDINATES`]). With `Ṙ = R Ω̂` (`Ω` the body
/// angular velocity) the Lagrangian is
///
/// ```text
/// L = ½ m |ẋ|² + ½ tr(Ṙ J_d Ṙᵀ) + m g·x,        J_d = ½ tr(J) I − J,
/// ```
///
/// since `½ tr(Ω̂ J_d Ω̂ᵀ) = ½ Ωᵀ J Ω`. `J_d = ∫ ρ r rᵀ` is the body's second moment of mass. `L` is
/// quadratic in `(q, q̇)` on all of `ℝ¹²`: the body is an ordinary linear model plus the six
/// holonomic constraints `RᵀR = I` ([`Orthonormality`]). With a linear path and the trapezoid rule
/// the discrete Lagrangian is `(m/2h)|Δx|² + (1/h) tr((I − F) J_d) + (h/2) m g·(x_k + x_{k+1})`
/// with `F = R_kᵀ R_{k+1}`: the Lie group variational integrator of Lee, Leok & McClamroch, whose
/// constrained discrete Euler–Lagrange equations in `ℝ¹²` are the group equations because the
/// constraint forces are normal to `SO(3)` (docs/math.md §10).
///
/// `J_d` must be positive definite (strict triangle inequalities `J₁ < J₂ + J₃`, …): a body whose
/// mass lies on a line or a point has a rotation no kinetic term determines.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBody {
    mass: f64,
    inertia: Mat3,
    second_moment: Mat3,
    gravity: [f64; 3],
    points: Vec<(String, [f64; 3])>,
}

impl RigidBody {
    /// A body of mass `mass` and inertia tensor `inertia` (body axes, about the centre of mass),
    /// without gravity.
    ///
    /// # Errors
    /// When the mass is not positive, the tensor not symmetric or `J_d` not positive definite.
    pub fn new(mass: f64, inertia: Mat3) -> Result<Self, RigidError> {
        if !(mass > 0.0 && mass.is_finite()) {
            return Err(RigidError::Mass(mass));
        }
        let bad = |reason: &str| RigidError::Inertia {
            inertia,
            reason: reason.into(),
        };
        if inertia.iter().flatten().any(|x| !x.is_finite()) {
            return Err(bad("an entry is not finite"));
        }
        let scale = inertia
            .iter()
            .flatten()
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        let asymmetric =
            |(i, j): (usize, usize)| (inertia[i][j] - inertia[j][i]).abs() > 1e-12 * scale;
        if [(1, 0), (2, 0), (2, 1)].into_iter().any(asymmetric) {
            return Err(bad("it is not symmetric"));
        }
        let trace = inertia[0][0] + inertia[1][1] + inertia[2][2];
        let mut second_moment = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                second_moment[i][j] = 0.5 * trace * so3::IDENTITY[i][j] - inertia[i][j];
            }
        }
        // Sylvester's criterion on J_d.
        let m = &second_moment;
        let minors = [m[0][0], m[0][0] * m[1][1] - m[0][1] * m[1][0], so3::det(m)];
        if minors.iter().any(|d| *d <= 0.0) {
            return Err(bad(
                "J_d = ½tr(J)I − J is not positive definite (principal moments must satisfy strict triangle inequalities: no mass on a line or point)",
            ));
        }
        Ok(Self {
            mass,
            inertia,
            second_moment,
            gravity: [0.0; 3],
            points: Vec::new(),
        })
    }

    /// A body with principal moments `moments` along its body axes.
    ///
    /// # Errors
    /// As [`RigidBody::new`].
    pub fn principal(mass: f64, moments: [f64; 3]) -> Result<Self, RigidError> {
        let [a, b, c] = moments;
        Self::new(mass, [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]])
    }

    /// A solid cuboid of side lengths `sides` along the body axes.
    ///
    /// # Errors
    /// As [`RigidBody::new`] (a degenerate box).
    pub fn cuboid(mass: f64, sides: [f64; 3]) -> Result<Self, RigidError> {
        let [a, b, c] = sides.map(|s| s * s * mass / 12.0);
        Self::principal(mass, [b + c, a + c, a + b])
    }

    /// The body in the uniform gravity field `g` (acceleration, e.g. `[0, 0, −9.81]`).
    #[must_use]
    pub fn with_gravity(mut self, g: [f64; 3]) -> Self {
        self.gravity = g;
        self
    }

    /// Adds a body-fixed point `r` (body axes, from the centre of mass) with ports `name.x`,
    /// `name.y`, `name.z`: the space position `x + R r`, linear in the coordinates. Springs,
    /// dampers and forces on a point attach to these ports.
    #[must_use]
    pub fn with_point(mut self, name: impl Into<String>, r: [f64; 3]) -> Self {
        self.points.push((name.into(), r));
        self
    }

    /// Mass.
    #[must_use]
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// Inertia tensor about the centre of mass, body axes.
    #[must_use]
    pub fn inertia(&self) -> &Mat3 {
        &self.inertia
    }

    /// `J_d = ½ tr(J) I − J`.
    #[must_use]
    pub fn second_moment(&self) -> &Mat3 {
        &self.second_moment
    }

    /// Gravity.
    #[must_use]
    pub fn gravity(&self) -> [f64; 3] {
        self.gravity
    }

    /// This body as a subsystem named `name`: the model, the six orthonormality constraints, a
    /// port for each coordinate (named as in [`COORDINATES`]) and three ports per body point.
    #[must_use]
    pub fn subsystem(&self, name: impl Into<String>) -> Subsystem {
        let mut s = Subsystem::new(name, self.clone()).with_constraints(Orthonormality);
        for (i, c) in COORDINATES.iter().enumerate() {
            s = s.with_port(*c, i);
        }
        for (point, r) in &self.points {
            for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                let mut coefficients = vec![(i, 1.0)];
                for (j, rj) in r.iter().enumerate() {
                    if *rj != 0.0 {
                        coefficients.push((rotation_index(i, j), *rj));
                    }
                }
                s = s.with_combination_port(format!("{point}.{axis}"), coefficients);
            }
        }
        s
    }

    /// The coordinates of the pose `(x, R)`.
    #[must_use]
    pub fn coordinates(position: [f64; 3], rotation: &Mat3) -> Vec<f64> {
        let mut q = vec![0.0; 12];
        q[..3].copy_from_slice(&position);
        for i in 0..3 {
            for j in 0..3 {
                q[rotation_index(i, j)] = rotation[i][j];
            }
        }
        q
    }

    /// The coordinate rates of the centre-of-mass velocity `velocity` and the **body** angular
    /// velocity `omega` at rotation `rotation` (`Ṙ = R Ω̂`).
    #[must_use]
    pub fn rates(rotation: &Mat3, velocity: [f64; 3], omega: [f64; 3]) -> Vec<f64> {
        let rdot = so3::mul(rotation, &so3::hat(&omega));
        Self::coordinates(velocity, &rdot)
    }

    /// The position `x` in a body's coordinates `q` (twelve entries).
    #[must_use]
    pub fn position(q: &[f64]) -> [f64; 3] {
        [q[0], q[1], q[2]]
    }

    /// The rotation `R` in a body's coordinates `q` (twelve entries).
    #[must_use]
    pub fn rotation(q: &[f64]) -> Mat3 {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = q[rotation_index(i, j)];
            }
        }
        r
    }

    /// The angle (radians) by which the body turns from coordinates `q0` to `q1`: the angle of
    /// `R₀ᵀR₁`, from its trace `1 + 2 cos θ`.
    #[must_use]
    pub fn turn(q0: &[f64], q1: &[f64]) -> f64 {
        let (r0, r1) = (Self::rotation(q0), Self::rotation(q1));
        let trace: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| r0[i][j] * r1[i][j])
            .sum();
        ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos()
    }

    /// The body angular velocity `Ω = vee(Rᵀ Ṙ)` from coordinates and their rates.
    #[must_use]
    pub fn body_angular_velocity(q: &[f64], v: &[f64]) -> [f64; 3] {
        let r = Self::rotation(q);
        let rdot = Self::rotation(v);
        so3::vee(&so3::mul(&so3::transpose(&r), &rdot))
    }

    /// The body angular momentum `Π` carried by the momentum covector `p` (twelve entries) at `q`:
    /// the pairing of `p` with the tangent vectors `R η̂`, `⟨p, R η̂⟩ = Π·η`. Components of `p`
    /// normal to `SO(3)` (constraint impulses) do not contribute. For `p = ∂L/∂q̇` it is `J Ω`.
    #[must_use]
    pub fn body_angular_momentum(q: &[f64], p: &[f64]) -> [f64; 3] {
        let r = Self::rotation(q);
        let pr = Self::rotation(p);
        let a = so3::mul(&so3::transpose(&r), &pr);
        [a[2][1] - a[1][2], a[0][2] - a[2][0], a[1][0] - a[0][1]]
    }

    /// The angular momentum about the space origin, `x × p_x + R Π`, of the state `(q, p)` (twelve
    /// entries each): the momentum map of rotations of space, conserved when nothing breaks that
    /// symmetry.
    #[must_use]
    pub fn spatial_angular_momentum(q: &[f64], p: &[f64]) -> [f64; 3] {
        let orbital = so3::cross(&Self::position(q), &[p[0], p[1], p[2]]);
        let spin = so3::apply(&Self::rotation(q), &Self::body_angular_momentum(q, p));
        [0, 1, 2].map(|i| orbital[i] + spin[i])
    }

    /// A covector `p` (twelve entries) carrying linear momentum `momentum` and body angular
    /// momentum `pi` at rotation `rotation` (the tangential representative `P_R = ½ R Π̂`).
    #[must_use]
    pub fn momentum(rotation: &Mat3, momentum: [f64; 3], pi: [f64; 3]) -> Vec<f64> {
        let half = so3::mul(rotation, &so3::hat(&pi.map(|c| 0.5 * c)));
        Self::coordinates(momentum, &half)
    }

    /// Kinetic energy `½ m |ẋ|² + ½ Ωᵀ J Ω` at `(q, v)`.
    #[must_use]
    pub fn kinetic_energy(&self, q: &[f64], v: &[f64]) -> f64 {
        let w = Self::body_angular_velocity(q, v);
        let jw = so3::apply(&self.inertia, &w);
        0.5 * self.mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + 0.5 * so3::dot(&w, &jw)
    }

    /// Potential energy `−m g·x` at `q`.
    #[must_use]
    pub fn potential_energy(&self, q: &[f64]) -> f64 {
        -self.mass * so3::dot(&self.gravity, &Self::position(q))
    }
}

impl Model for RigidBody {
    fn dim(&self) -> usize {
        12
    }

    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let mut l = 0.0;
        for i in 0..3 {
            l += 0.5 * self.mass * v[i] * v[i] + self.mass * self.gravity[i] * q[i];
            for j in 0..3 {
                for k in 0..3 {
                    l += 0.5
                        * self.second_moment[j][k]
                        * v[rotation_index(i, j)]
                        * v[rotation_index(i, k)];
                }
            }
        }
        l
    }

    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[3..].fill(0.0);
        for i in 0..3 {
            lq[i] = self.mass * self.gravity[i];
            lv[i] = self.mass * v[i];
            for j in 0..3 {
                let jd = &self.second_moment[j];
                lv[rotation_index(i, j)] = jd[0] * v[rotation_index(i, 0)]
                    + jd[1] * v[rotation_index(i, 1)]
                    + jd[2] * v[rotation_index(i, 2)];
            }
        }
    }

    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        for i in 0..3 {
            h.vv.add(i, i, self.mass);
        }
        for j in 0..3 {
            for k in 0..3 {
                let jd = self.second_moment[j][k];
                // The pattern depends only on the body (zeros of J_d are never stamped).
                if jd != 0.0 {
                    for i in 0..3 {
                        h.vv.add(rotation_index(i, j), rotation_index(i, k), jd);
                    }
                }
            }
        }
    }

    fn is_linear(&self) -> bool {
        true
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    fn has_step_check(&self) -> bool {
        true
    }

    /// Rejects a step that turns the body by a quarter turn or more. The step's rotation
    /// `F = R₀ᵀR₁` solves `F J_d − J_d Fᵀ = h Π̂` (the LGVI equation, docs/math.md §10), which
    /// besides the rotation near the identity has roots near half turns; from a guess a few
    /// tenths of a radian off, Newton can land on one (the spatial four-bar at h = 0.03 did,
    /// its crank turning 2.5 rad in one step and its energy jumping from 0.59 to 2.97 J). No step
    /// that turns a body by more than a quarter turn is accurate, so the bound rejects only
    /// spurious roots and steps too long to be of use; the integrator cuts either.
    fn check_step(&self, q0: &[f64], q1: &[f64]) -> Result<(), String> {
        let turn = Self::turn(q0, q1);
        if turn < std::f64::consts::FRAC_PI_2 {
            Ok(())
        } else {
            Err(format!(
                "turned by {turn:.3} rad in one step (a quarter turn or more: a root of the step \
                 equations that the motion does not take, or a step too long for the rotation)"
            ))
        }
    }

    /// The body's one turn, [`RigidBody::turn`].
    fn step_turns(&self, q0: &[f64], q1: &[f64], turns: &mut Vec<f64>) {
        turns.push(Self::turn(q0, q1));
    }

    fn coordinate_name(&self, i: usize) -> String {
        COORDINATES[i].into()
    }
}

/// The six holonomic constraints `RᵀR = I` on a body's coordinates: `½(|cⱼ|² − 1) = 0` and
/// `cⱼ·c_k = 0` (`j < k`) for the columns `cⱼ` of `R`.
///
/// Their zero set is `O(3)`; a rotation (det = +1) stays one by continuity. The constraint forces
/// `Σ λ dg` are the matrices `R S` with `S` symmetric: the normal space of `SO(3)` in `ℝ⁹`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Orthonormality;

/// The column pairs `(j, k)` of the six rows, in row order.
const PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

impl Constraints for Orthonormality {
    fn count(&self) -> usize {
        6
    }

    fn kind(&self, _a: usize) -> ConstraintKind {
        ConstraintKind::Holonomic
    }

    fn forms(&self, q: &[f64], out: &mut Triplets) {
        for (a, &(j, k)) in PAIRS.iter().enumerate() {
            for i in 0..3 {
                if j == k {
                    out.add(a, rotation_index(i, j), q[rotation_index(i, j)]);
                } else {
                    out.add(a, rotation_index(i, j), q[rotation_index(i, k)]);
                    out.add(a, rotation_index(i, k), q[rotation_index(i, j)]);
                }
            }
        }
    }

    fn values(&self, q: &[f64], out: &mut [f64]) {
        for (a, &(j, k)) in PAIRS.iter().enumerate() {
            let d: f64 = (0..3)
                .map(|i| q[rotation_index(i, j)] * q[rotation_index(i, k)])
                .sum();
            out[a] = if j == k { 0.5 * (d - 1.0) } else { d };
        }
    }

    fn is_constant(&self) -> bool {
        false
    }

    fn multiplier_hessian(&self, _q: &[f64], lambda: &[f64], out: &mut Triplets) {
        for (a, &(j, k)) in PAIRS.iter().enumerate() {
            for i in 0..3 {
                if j == k {
                    out.add(rotation_index(i, j), rotation_index(i, j), lambda[a]);
                } else {
                    out.add(rotation_index(i, j), rotation_index(i, k), lambda[a]);
                    out.add(rotation_index(i, k), rotation_index(i, j), lambda[a]);
                }
            }
        }
    }

    fn contracted_derivative(&self, _q: &[f64], w: &[f64], out: &mut Triplets) {
        for (a, &(j, k)) in PAIRS.iter().enumerate() {
            for i in 0..3 {
                if j == k {
                    out.add(a, rotation_index(i, j), w[rotation_index(i, j)]);
                } else {
                    out.add(a, rotation_index(i, k), w[rotation_index(i, j)]);
                    out.add(a, rotation_index(i, j), w[rotation_index(i, k)]);
                }
            }
        }
    }

    fn name(&self, a: usize) -> String {
        let (j, k) = PAIRS[a];
        if j == k {
            format!("|c{}| = 1", j + 1)
        } else {
            format!("c{}·c{} = 0", j + 1, k + 1)
        }
    }
}
