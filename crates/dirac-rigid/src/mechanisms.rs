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
