//! Ready-made mechanisms: the graphs and consistent initial states of the bundled 3D examples.

use dirac_graph::Interconnection;

use crate::body::RigidBody;
use crate::error::RigidError;
use crate::joint::{Joint, JointFrame, JointKind, Side};
use crate::so3::{self, Mat3};

/// An interconnection with a consistent initial state: positions and rates per subsystem, in the
/// graph's subsystem order (the layout `AssembledSystem::global_vector` takes).
#[derive(Debug, Clone)]
pub struct Mechanism {
    /// The parts and joints.
    pub graph: Interconnection,
    /// Initial positions per subsystem.
    pub q0: Vec<Vec<f64>>,
    /// Initial rates per subsystem.
    pub v0: Vec<Vec<f64>>,
}

impl Mechanism {
    /// The subsystem names, in graph order.
    #[must_use]
    pub fn names(&self) -> Vec<String> {
        self.graph
            .subsystems()
            .iter()
            .map(|s| s.name().to_string())
            .collect()
    }
}

/// A chain of `links` identical bodies hanging from a revolute joint at the origin, each joined
/// to the next by a revolute joint; every joint turns about the same body axis.
///
/// Link `i`'s centre of mass sits on its own joint; the next joint is `length` along the link's
/// body `x` axis. At rest every joint is bent by `angle`. With the default
/// ([`PendulumChain::dart`]) this is the 10-link chain of DART's variational-integrator benchmark
/// (dartsim/dart PR #2764: links 0.3 apart, mass 0.7, inertia 0.02 I, joints about `y` bent by
/// 0.4 rad, gravity −9.81 `e_z`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PendulumChain {
    /// Number of links.
    pub links: usize,
    /// Distance between successive joints.
    pub length: f64,
    /// Mass of a link.
    pub mass: f64,
    /// Principal moments of a link about its centre of mass.
    pub moments: [f64; 3],
    /// Initial bend of every joint.
    pub angle: f64,
    /// Joint axis in body axes.
    pub axis: [f64; 3],
    /// Gravity.
    pub gravity: [f64; 3],
}

impl PendulumChain {
    /// DART's benchmark chain with `links` links.
    #[must_use]
    pub fn dart(links: usize) -> Self {
        Self {
            links,
            length: 0.3,
            mass: 0.7,
            moments: [0.02; 3],
            angle: 0.4,
            axis: [0.0, 1.0, 0.0],
            gravity: [0.0, 0.0, -9.81],
        }
    }

    /// The body of one link.
    ///
    /// # Errors
    /// When the mass or moments are not admissible.
    pub fn link(&self) -> Result<RigidBody, RigidError> {
        Ok(RigidBody::principal(self.mass, self.moments)?.with_gravity(self.gravity))
    }

    /// The name of link `i`.
    #[must_use]
    pub fn link_name(i: usize) -> String {
        format!("link{i}")
    }

    /// The joints: `j0` from the ground to link 0, then `j{i}` from link `i − 1` to link `i`.
    #[must_use]
    pub fn joints(&self) -> Vec<(String, Joint)> {
        let at = |origin| JointFrame::with_axis(origin, self.axis);
        (0..self.links)
            .map(|i| {
                let a = if i == 0 {
                    Side::ground(at([0.0; 3]))
                } else {
                    Side::body(Self::link_name(i - 1), at([self.length, 0.0, 0.0]))
                };
                let joint = Joint::new(
                    JointKind::Revolute,
                    a,
                    Side::body(Self::link_name(i), at([0.0; 3])),
                );
                (format!("j{i}"), joint)
            })
            .collect()
    }

    /// The chain at rest with every joint bent by [`PendulumChain::angle`].
    ///
    /// # Errors
    /// When the link is not admissible (see [`RigidBody::new`]).
    pub fn build(&self) -> Result<Mechanism, RigidError> {
        let link = self.link()?;
        let mut graph = Interconnection::new();
        let prototype = link.subsystem("link0");
        for i in 0..self.links {
            graph.add_subsystem(prototype.renamed(Self::link_name(i)))?;
        }
        for (name, joint) in self.joints() {
            joint.connect(&mut graph, &name)?;
        }
        let (mut q0, mut v0) = (Vec::new(), Vec::new());
        let mut x = [0.0; 3];
        let mut r: Mat3 = so3::IDENTITY;
        for _ in 0..self.links {
            let turn = so3::from_axis_angle(so3::apply(&r, &self.axis), self.angle);
            r = so3::mul(&turn, &r);
            q0.push(RigidBody::coordinates(x, &r));
            v0.push(vec![0.0; 12]);
            let step = so3::apply(&r, &[self.length, 0.0, 0.0]);
            x = [0, 1, 2].map(|k| x[k] + step[k]);
        }
        Ok(Mechanism { graph, q0, v0 })
    }
}

/// A motor-driven two-link arm: a column on a vertical revolute joint, turned by a DC motor on a
/// voltage source through a gear, and an arm on a horizontal hinge at the column's top, with a
/// rotational damper on the hinge. Spun up, the arm swings out like a centrifugal governor.
///
/// Subsystems, in order: `V` (source), `M` (motor), `G` (gear, `θ_column = ratio · θ_motor`),
/// `column`, `arm`, `D` (hinge damper). Connections: the armature loop (nodes `a`, `gnd`), the
/// shaft (`M.theta = G.theta1`), the joints `base` and `hinge`, and the couplings `drive`
/// (`G.theta2` to the base angle) and `hinge damping` (`D.theta` to the hinge angle).
///
/// In the steady state the motor turns at `ω_m = V k / (k² + R b)` (its torque balances its own
/// friction) and the arm rides at the relative equilibrium `cos α* = m g d / (ω² (B − A))` from
/// the downward vertical, `ω = ratio · ω_m`, with `A` the arm's moment about its long axis and
/// `B` about the hinge axis, both at the hinge ([`MotorArm::steady_state`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MotorArm {
    /// The motor.
    pub motor: dirac_components::DcMotor,
    /// Source voltage.
    pub voltage: f64,
    /// Gear ratio `θ_column / θ_motor`.
    pub ratio: f64,
    /// Column: mass and side lengths (x, y, z); it stands on the origin, `z` up.
    pub column: (f64, [f64; 3]),
    /// Arm: mass and side lengths (along its length first).
    pub arm: (f64, [f64; 3]),
    /// Viscous damping of the hinge.
    pub hinge_damping: f64,
    /// Initial arm angle from the downward vertical.
    pub initial_angle: f64,
    /// Gravitational acceleration (along −z).
    pub g: f64,
}

impl MotorArm {
    /// The bundled example: a 6 V motor (k = 0.5, R = 1, L = 0.01, J = 1e-3, b = 0.02) through a
    /// 0.8 gear, a 1 kg column 0.5 m tall, a 0.5 kg arm 0.4 m long, hinge damping 0.05 N·m·s.
    ///
    /// # Errors
    /// None in practice: the motor's constants pass [`dirac_components::DcMotor::new`]'s checks.
    pub fn governor() -> Result<Self, RigidError> {
        Ok(Self {
            motor: dirac_components::DcMotor::new(0.5, 1.0, 0.01, 1e-3, 0.02)?,
            voltage: 6.0,
            ratio: 0.8,
            column: (1.0, [0.1, 0.1, 0.5]),
            arm: (0.5, [0.4, 0.03, 0.03]),
            hinge_damping: 0.05,
            initial_angle: 0.2,
            g: 9.81,
        })
    }

    /// The base joint (ground to column, about z).
    #[must_use]
    pub fn base(&self) -> Joint {
        let h = self.column.1[2];
        Joint::new(
            JointKind::Revolute,
            Side::ground(JointFrame::at([0.0; 3])),
            Side::body("column", JointFrame::at([0.0, 0.0, -0.5 * h])),
        )
    }

    /// The hinge (column top to the arm's end, about the column's y axis).
    #[must_use]
    pub fn hinge(&self) -> Joint {
        let (h, len) = (self.column.1[2], self.arm.1[0]);
        let y = [0.0, 1.0, 0.0];
        Joint::new(
            JointKind::Revolute,
            Side::body("column", JointFrame::with_axis([0.0, 0.0, 0.5 * h], y)),
            Side::body("arm", JointFrame::with_axis([-0.5 * len, 0.0, 0.0], y)),
        )
    }

    /// The arm's rotation at angle `alpha` from the downward vertical (column at rest).
    fn arm_rotation(alpha: f64) -> Mat3 {
        so3::from_axis_angle([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2 - alpha)
    }

    /// The arm's angle from the downward vertical in its coordinates.
    #[must_use]
    pub fn arm_angle(q_arm: &[f64]) -> f64 {
        let r = RigidBody::rotation(q_arm);
        (-r[2][0]).clamp(-1.0, 1.0).acos()
    }

    /// The steady state `(ω, α*)`: column speed and arm angle (0 when the arm cannot lift).
    #[must_use]
    pub fn steady_state(&self) -> (f64, f64) {
        let m = &self.motor;
        let omega = self.ratio * self.voltage * m.k / (m.k * m.k + m.r * m.b);
        let (mass, [len, t1, t2]) = self.arm;
        let d = 0.5 * len;
        let b = mass * (len * len + t1 * t1) / 12.0 + mass * d * d;
        let a = mass * (t1 * t1 + t2 * t2) / 12.0;
        let c = mass * self.g * d / (omega * omega * (b - a));
        (omega, if c < 1.0 { c.acos() } else { 0.0 })
    }

    /// The arm and its initial state.
    ///
    /// # Errors
    /// When a body is not admissible.
    pub fn build(&self) -> Result<Mechanism, RigidError> {
        use dirac_components::{Damper, IdealGear, VoltageSource};
        let gravity = [0.0, 0.0, -self.g];
        let column = RigidBody::cuboid(self.column.0, self.column.1)?.with_gravity(gravity);
        let arm = RigidBody::cuboid(self.arm.0, self.arm.1)?.with_gravity(gravity);
        let mut g = Interconnection::new();
        g.add_subsystem(VoltageSource::dc(self.voltage)?.subsystem("V"))?;
        g.add_subsystem(self.motor.subsystem("M"))?;
        g.add_subsystem(IdealGear::new(self.ratio)?.subsystem("G"))?;
        g.add_subsystem(column.subsystem("column"))?;
        g.add_subsystem(arm.subsystem("arm"))?;
        g.add_subsystem(Damper::new(self.hinge_damping)?.rotational_subsystem("D"))?;
        let (vi, mi) = (g.port("V", "i")?, g.port("M", "i")?);
        g.node("a", vec![(vi, -1.0), (mi, -1.0)])?;
        g.node("gnd", vec![(vi, 1.0), (mi, 1.0)])?;
        let (shaft, input) = (g.port("M", "theta")?, g.port("G", "theta1")?);
        g.joint("shaft", shaft, input);
        let (base, hinge) = (self.base(), self.hinge());
        base.connect(&mut g, "base")?;
        hinge.connect(&mut g, "hinge")?;
        let output = g.port("G", "theta2")?;
        base.couple_coordinate(&mut g, "drive", output)?;
        let damper = g.port("D", "theta")?;
        hinge.couple_coordinate(&mut g, "hinge damping", damper)?;
        let h = self.column.1[2];
        let q_column = RigidBody::coordinates([0.0, 0.0, 0.5 * h], &so3::IDENTITY);
        let r_arm = Self::arm_rotation(self.initial_angle);
        let to_com = so3::apply(&r_arm, &[0.5 * self.arm.1[0], 0.0, 0.0]);
        let q_arm = RigidBody::coordinates([to_com[0], to_com[1], h + to_com[2]], &r_arm);
        let phi_base = base.coordinate(&[], &q_column).unwrap_or(0.0);
        let phi_hinge = hinge.coordinate(&q_column, &q_arm).unwrap_or(0.0);
        let q0 = vec![
            vec![0.0],
            vec![0.0, phi_base / self.ratio],
            vec![phi_base / self.ratio, phi_base],
            q_column,
            q_arm,
            vec![phi_hinge],
        ];
        let v0 = q0.iter().map(|q| vec![0.0; q.len()]).collect();
        Ok(Mechanism { graph: g, q0, v0 })
    }
}

/// A spatial pendulum chain: `links` uniform square rods joined end to end by spherical joints,
/// hanging from a spherical joint at the origin under gravity `−g e_z`.
///
/// Link `i` is a solid cuboid of length [`SphericalChain::length`] along its body `x` axis and
/// square cross-section [`SphericalChain::width`], with its centre of mass at its middle; joint
/// `j{i}` holds its end `(−length/2, 0, 0)` to the end `(length/2, 0, 0)` of link `i − 1` (to the
/// origin for `i = 0`). At the start link `i` points along `(sin α cos iβ, sin α sin iβ, −cos α)`
/// (`α` = [`SphericalChain::tilt`] from the downward vertical, azimuth advancing by
/// `β` = [`SphericalChain::twist`] per link: a helix, non-planar for `β ∉ {0, π}` and three or
/// more links), and the whole chain turns rigidly about the vertical at
/// [`SphericalChain::spin`] rad/s, a velocity every joint admits.
///
/// Gravity along `z` and the suspension point on the `z` axis leave the system invariant under
/// rotations about `z`, so the discrete Noether theorem keeps the vertical angular momentum about
/// the origin, `Σ e_z·(xᵢ × p_{x,i} + Rᵢ Πᵢ)` ([`RigidBody::spatial_angular_momentum`]), to
/// round-off.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalChain {
    /// Number of links.
    pub links: usize,
    /// Length of a link (distance between its two joints).
    pub length: f64,
    /// Side of a link's square cross-section.
    pub width: f64,
    /// Mass of a link.
    pub mass: f64,
    /// Initial angle of every link from the downward vertical.
    pub tilt: f64,
    /// Initial azimuth advance from one link to the next.
    pub twist: f64,
    /// Initial rate of the rigid rotation about the vertical.
    pub spin: f64,
    /// Gravitational acceleration (along −z).
    pub g: f64,
}

impl SphericalChain {
    /// The bundled chain (`examples/scenes/spatial_chain.toml` has five links): rods 0.3 m long,
    /// 0.02 m wide, 0.5 kg, tilted 0.6 rad, twisted 1.0 rad per link, turning at 2 rad/s.
    #[must_use]
    pub fn bundled(links: usize) -> Self {
        Self {
            links,
            length: 0.3,
            width: 0.02,
            mass: 0.5,
            tilt: 0.6,
            twist: 1.0,
            spin: 2.0,
            g: 9.81,
        }
    }

    /// The body of one link.
    ///
    /// # Errors
    /// When the mass or the sides are not admissible.
    pub fn link(&self) -> Result<RigidBody, RigidError> {
        Ok(
            RigidBody::cuboid(self.mass, [self.length, self.width, self.width])?
                .with_gravity([0.0, 0.0, -self.g]),
        )
    }

    /// The joints: `j0` from the ground to link 0, then `j{i}` from link `i − 1` to link `i`.
    #[must_use]
    pub fn joints(&self) -> Vec<(String, Joint)> {
        let half = 0.5 * self.length;
        (0..self.links)
            .map(|i| {
                let a = if i == 0 {
                    Side::ground(JointFrame::at([0.0; 3]))
                } else {
                    Side::body(
                        PendulumChain::link_name(i - 1),
                        JointFrame::at([half, 0.0, 0.0]),
                    )
                };
                let b = Side::body(
                    PendulumChain::link_name(i),
                    JointFrame::at([-half, 0.0, 0.0]),
                );
                (format!("j{i}"), Joint::new(JointKind::Spherical, a, b))
            })
            .collect()
    }

    /// The rotation of link `i` at the start: body `x` along the link's direction.
    #[must_use]
    pub fn rotation(&self, i: usize) -> Mat3 {
        let turn = so3::from_axis_angle([0.0, 0.0, 1.0], self.twist * i as f64);
        let tilt = so3::from_axis_angle([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2 - self.tilt);
        so3::mul(&turn, &tilt)
    }

    /// The chain at its initial pose, turning rigidly about the vertical.
    ///
    /// # Errors
    /// When the link is not admissible (see [`RigidBody::new`]).
    pub fn build(&self) -> Result<Mechanism, RigidError> {
        let link = self.link()?;
        let mut graph = Interconnection::new();
        let prototype = link.subsystem("link0");
        for i in 0..self.links {
            graph.add_subsystem(prototype.renamed(PendulumChain::link_name(i)))?;
        }
        for (name, joint) in self.joints() {
            joint.connect(&mut graph, &name)?;
        }
        let (mut q0, mut v0) = (Vec::new(), Vec::new());
        let axis = [0.0, 0.0, self.spin];
        let mut joint = [0.0; 3];
        for i in 0..self.links {
            let r = self.rotation(i);
            let along = so3::apply(&r, &[0.5 * self.length, 0.0, 0.0]);
            let x = [0, 1, 2].map(|k| joint[k] + along[k]);
            q0.push(RigidBody::coordinates(x, &r));
            let omega = so3::apply(&so3::transpose(&r), &axis);
            v0.push(RigidBody::rates(&r, so3::cross(&axis, &x), omega));
            joint = [0, 1, 2].map(|k| x[k] + along[k]);
        }
        Ok(Mechanism { graph, q0, v0 })
    }
}
