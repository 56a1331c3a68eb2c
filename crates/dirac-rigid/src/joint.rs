//! Joints between rigid bodies (or a body and the ground) as holonomic constraints on the bodies'
//! ports, and the couplings that expose a joint's angle or slide to one-dimensional parts.

use dirac_graph::{ConnectionId, Interconnection, PortConstraint, PortRef};

use crate::body::{COORDINATES, RigidBody};
use crate::error::RigidError;
use crate::rows::{Affine3, Dot, column};
use crate::so3::{self, Mat3};

/// A frame fixed in a body (or in space, for the ground): an origin and three orthonormal axes,
/// both in the body's coordinates (from its centre of mass, body axes).
///
/// Joint axes are the frame's third axis `z`; angles are measured from the `x` axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFrame {
    /// The origin.
    pub origin: [f64; 3],
    /// The axes as columns.
    pub axes: Mat3,
}

impl JointFrame {
    /// The frame at `origin` with the body's own axes.
    #[must_use]
    pub fn at(origin: [f64; 3]) -> Self {
        Self {
            origin,
            axes: so3::IDENTITY,
        }
    }

    /// The frame at `origin` whose `z` axis is along `axis` (its `x` axis is
    /// [`so3::perpendicular`] to it).
    #[must_use]
    pub fn with_axis(origin: [f64; 3], axis: [f64; 3]) -> Self {
        Self {
            origin,
            axes: so3::frame_with_z(axis),
        }
    }

    /// The frame at `origin` whose `z` axis is along `z` and whose `x` axis is `x` with its
    /// component along `z` removed (`x` must not be parallel to `z`).
    #[must_use]
    pub fn oriented(origin: [f64; 3], z: [f64; 3], x: [f64; 3]) -> Self {
        Self {
            origin,
            axes: so3::frame_with_zx(z, x),
        }
    }

    /// The frame at `origin` with axes `axes` (columns).
    #[must_use]
    pub fn new(origin: [f64; 3], axes: Mat3) -> Self {
        Self { origin, axes }
    }
}

/// One side of a joint: a body (by subsystem name) or the ground, and the joint frame on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Side {
    /// The body's subsystem name, or `None` for the ground (the frame is then in space).
    pub body: Option<String>,
    /// The joint frame in the body (or in space).
    pub frame: JointFrame,
}

impl Side {
    /// The joint frame `frame` on the body named `body`.
    #[must_use]
    pub fn body(body: impl Into<String>, frame: JointFrame) -> Self {
        Self {
            body: Some(body.into()),
            frame,
        }
    }

    /// The joint frame `frame` fixed in space.
    #[must_use]
    pub fn ground(frame: JointFrame) -> Self {
        Self { body: None, frame }
    }
}

/// What relative motion a joint allows between its frames `A` (side `a`) and `B` (side `b`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// The origins coincide (3 rows); any relative rotation.
    Spherical,
    /// The origins coincide and the `z` axes stay aligned (5 rows): rotation about `z`.
    Revolute,
    /// The origins coincide and `A`'s `x` axis stays perpendicular to `B`'s `y` axis (4 rows):
    /// rotations about those two axes (a Hooke joint).
    Universal,
    /// The `z` axes stay on one line (4 rows): rotation about and sliding along `z`.
    Cylindrical,
    /// The axes stay parallel and `B`'s origin on `A`'s `z` axis (5 rows): sliding along `z`.
    Prismatic,
    /// The `z` axes stay parallel and `B`'s origin in `A`'s `xy` plane (3 rows): planar motion.
    Planar,
    /// The frames coincide (6 rows).
    Fixed,
}

/// A joint between two sides. The frames are meant to coincide in the reference configuration
/// (where each kind's rows vanish); the initial state must satisfy the rows, which the
/// integrator checks.
///
/// Every row is affine or bilinear in the bodies' coordinates and is enforced at position level
/// (`ConstraintKind::Holonomic`). Rows are chosen so their number equals the constrained degrees
/// of freedom near the reference configuration: axis alignment is written as two orthogonality
/// rows, not as the three components of `R_a e − R_b e`, whose dependent combination turns with
/// the axis (docs/math.md §10.4).
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// The kind.
    pub kind: JointKind,
    /// Side `a`.
    pub a: Side,
    /// Side `b`.
    pub b: Side,
}

/// Port offsets of the two sides in a joint constraint's port list (`None`: ground).
fn offsets(a: &Side, b: &Side, first: usize) -> (Option<usize>, Option<usize>) {
    let oa = a.body.as_ref().map(|_| first);
    let ob = b
        .body
        .as_ref()
        .map(|_| first + if oa.is_some() { 12 } else { 0 });
    (oa, ob)
}

/// The joint's point and axes on one side as affine functions of the port values.
struct SideVectors {
    point: Affine3,
    axes: [Affine3; 3],
}

impl SideVectors {
    fn new(side: &Side, offset: Option<usize>) -> Self {
        let f = &side.frame;
        match offset {
            Some(o) => Self {
                point: Affine3::point(o, f.origin),
                axes: [0, 1, 2].map(|k| Affine3::direction(o, column(&f.axes, k))),
            },
            None => Self {
                point: Affine3::constant(f.origin),
                axes: [0, 1, 2].map(|k| Affine3::constant(column(&f.axes, k))),
            },
        }
    }
}

impl Joint {
    /// A joint of `kind` between `a` and `b`.
    #[must_use]
    pub fn new(kind: JointKind, a: Side, b: Side) -> Self {
        Self { kind, a, b }
    }

    /// Number of constraint rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        match self.kind {
            JointKind::Spherical | JointKind::Planar => 3,
            JointKind::Universal | JointKind::Cylindrical => 4,
            JointKind::Revolute | JointKind::Prismatic => 5,
            JointKind::Fixed => 6,
        }
    }

    fn check(&self, name: &str) -> Result<(), RigidError> {
        if self.a.body.is_none() && self.b.body.is_none() {
            return Err(RigidError::GroundToGround(name.into()));
        }
        for (side, s) in [('a', &self.a), ('b', &self.b)] {
            let error = so3::orthonormality_error(&s.frame.axes);
            let det = so3::det(&s.frame.axes);
            if error > 1e-12 || det <= 0.0 {
                return Err(RigidError::Frame {
                    joint: name.into(),
                    side,
                    error,
                    det,
                });
            }
        }
        Ok(())
    }

    /// The twelve coordinate ports of each body side (`a` first).
    fn body_ports(&self, g: &Interconnection) -> Result<Vec<PortRef>, RigidError> {
        let mut ports = Vec::with_capacity(24);
        for side in [&self.a, &self.b] {
            if let Some(body) = &side.body {
                for c in COORDINATES {
                    ports.push(g.port(body, c)?);
                }
            }
        }
        Ok(ports)
    }

    /// The rows as dot products of port-affine vectors, with their names; body ports start at
    /// port `first`.
    fn dots(&self, first: usize) -> Vec<(Dot, &'static str)> {
        let (oa, ob) = offsets(&self.a, &self.b, first);
        let (a, b) = (SideVectors::new(&self.a, oa), SideVectors::new(&self.b, ob));
        let unit = |k: usize| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            Affine3::constant(e)
        };
        let gap = a.point.minus(&b.point);
        let along = b.point.minus(&a.point);
        let point = || {
            vec![
                (Dot::new(gap.clone(), unit(0)), "Δx = 0"),
                (Dot::new(gap.clone(), unit(1)), "Δy = 0"),
                (Dot::new(gap.clone(), unit(2)), "Δz = 0"),
            ]
        };
        let axis = || {
            vec![
                (
                    Dot::new(b.axes[2].clone(), a.axes[0].clone()),
                    "z_b·x_a = 0",
                ),
                (
                    Dot::new(b.axes[2].clone(), a.axes[1].clone()),
                    "z_b·y_a = 0",
                ),
            ]
        };
        let orientation = || {
            vec![
                (
                    Dot::new(a.axes[0].clone(), b.axes[1].clone()),
                    "x_a·y_b = 0",
                ),
                (
                    Dot::new(a.axes[0].clone(), b.axes[2].clone()),
                    "x_a·z_b = 0",
                ),
                (
                    Dot::new(a.axes[1].clone(), b.axes[2].clone()),
                    "y_a·z_b = 0",
                ),
            ]
        };
        let on_line = || {
            vec![
                (Dot::new(along.clone(), a.axes[0].clone()), "Δ·x_a = 0"),
                (Dot::new(along.clone(), a.axes[1].clone()), "Δ·y_a = 0"),
            ]
        };
        match self.kind {
            JointKind::Spherical => point(),
            JointKind::Revolute => [point(), axis()].concat(),
            JointKind::Universal => {
                let mut rows = point();
                rows.push((
                    Dot::new(a.axes[0].clone(), b.axes[1].clone()),
                    "x_a·y_b = 0",
                ));
                rows
            }
            JointKind::Cylindrical => [axis(), on_line()].concat(),
            JointKind::Prismatic => [orientation(), on_line()].concat(),
            JointKind::Planar => {
                let mut rows = axis();
                rows.push((Dot::new(along.clone(), a.axes[2].clone()), "Δ·z_a = 0"));
                rows
            }
            JointKind::Fixed => [point(), orientation()].concat(),
        }
    }

    /// Adds the joint to `g` as the holonomic connection `name`.
    ///
    /// # Errors
    /// When both sides are the ground, a frame is not a rotation, or a body is not in `g`.
    pub fn connect(&self, g: &mut Interconnection, name: &str) -> Result<ConnectionId, RigidError> {
        self.check(name)?;
        let ports = self.body_ports(g)?;
        let (dots, names): (Vec<_>, Vec<_>) = self.dots(0).into_iter().unzip();
        Ok(g.holonomic(name, ports, DotRows { dots, names })?)
    }

    /// Adds the joint to `g` as one holonomic connection per row, named `{name}[k]` (the rows of
    /// [`Joint::connect`], in its order), so that each row's multiplier can be recorded on its own:
    /// for the spherical, revolute, universal and fixed kinds rows 0, 1, 2 are `Δx, Δy, Δz = 0`
    /// with `Δ = O_A − O_B` in space axes, and their multipliers are the components of the force
    /// the joint exerts on body `B` (minus that on `A`). The motion is that of [`Joint::connect`]:
    /// the same rows enter the same step equations.
    ///
    /// # Errors
    /// As [`Joint::connect`].
    pub fn connect_rows(
        &self,
        g: &mut Interconnection,
        name: &str,
    ) -> Result<Vec<ConnectionId>, RigidError> {
        self.check(name)?;
        let ports = self.body_ports(g)?;
        self.dots(0)
            .into_iter()
            .enumerate()
            .map(|(k, (dot, row))| {
                let rows = DotRows {
                    dots: vec![dot],
                    names: vec![row],
                };
                Ok(g.holonomic(format!("{name}[{k}]"), ports.clone(), rows)?)
            })
            .collect()
    }

    /// Whether rows 0, 1, 2 are the coincidence of the joint origins (spherical, revolute,
    /// universal, fixed), so that their multipliers are a reaction force.
    #[must_use]
    pub fn has_point_rows(&self) -> bool {
        matches!(
            self.kind,
            JointKind::Spherical | JointKind::Revolute | JointKind::Universal | JointKind::Fixed
        )
    }

    /// Adds a coupling `name` that ties the one-dimensional port `coordinate` (a motor shaft, a
    /// rotational spring's or torque source's angle, a linear actuator) to the joint's own
    /// coordinate: the angle `φ` of `B`'s `x` axis about `A`'s `z` axis from `A`'s `x` axis
    /// (revolute, cylindrical, planar), or the slide `s = (O_B − O_A)·z_A` (prismatic).
    ///
    /// The angle row is `cos θ (x_B·y_A) − sin θ (x_B·x_A) = 0`, i.e. `sin(φ − θ) = 0` once the
    /// joint holds: position level, with no branch cut, and with derivative `−cos(φ − θ) = −1`
    /// in `θ`, so the port's coordinate is determined. It also holds at `θ = φ + π`: start the
    /// port at [`Joint::coordinate`]. Its multiplier is the torque (or force) the port exerts on
    /// the joint.
    ///
    /// # Errors
    /// As [`Joint::connect`]; also for joint kinds without a single coordinate (spherical,
    /// universal, fixed), reported as [`RigidError::NoJointCoordinate`].
    pub fn couple_coordinate(
        &self,
        g: &mut Interconnection,
        name: &str,
        coordinate: PortRef,
    ) -> Result<ConnectionId, RigidError> {
        self.check(name)?;
        let (oa, ob) = offsets(&self.a, &self.b, 1);
        let (a, b) = (SideVectors::new(&self.a, oa), SideVectors::new(&self.b, ob));
        let row = match self.kind {
            JointKind::Revolute | JointKind::Cylindrical | JointKind::Planar => {
                CoordinateRow::Angle {
                    cosine: Dot::new(b.axes[0].clone(), a.axes[0].clone()),
                    sine: Dot::new(b.axes[0].clone(), a.axes[1].clone()),
                }
            }
            JointKind::Prismatic => {
                CoordinateRow::Slide(Dot::new(b.point.minus(&a.point), a.axes[2].clone()))
            }
            kind => {
                return Err(RigidError::NoJointCoordinate {
                    joint: name.into(),
                    kind,
                });
            }
        };
        let mut ports = vec![coordinate];
        ports.extend(self.body_ports(g)?);
        Ok(g.holonomic(name, ports, row)?)
    }

    /// The joint's coordinate (angle or slide, see [`Joint::couple_coordinate`]) at the bodies'
    /// coordinates `qa`, `qb` (twelve entries each; ignored for a ground side). `None` for kinds
    /// without one.
    #[must_use]
    pub fn coordinate(&self, qa: &[f64], qb: &[f64]) -> Option<f64> {
        let world = |side: &Side, q: &[f64]| {
            let f = &side.frame;
            match side.body {
                Some(_) => {
                    let r = RigidBody::rotation(q);
                    let p = so3::apply(&r, &f.origin);
                    let x = RigidBody::position(q);
                    ([0, 1, 2].map(|i| x[i] + p[i]), so3::mul(&r, &f.axes))
                }
                None => (f.origin, f.axes),
            }
        };
        let (pa, ea) = world(&self.a, qa);
        let (pb, eb) = world(&self.b, qb);
        match self.kind {
            JointKind::Revolute | JointKind::Cylindrical | JointKind::Planar => {
                let xb = column(&eb, 0);
                Some(so3::dot(&xb, &column(&ea, 1)).atan2(so3::dot(&xb, &column(&ea, 0))))
            }
            JointKind::Prismatic => {
                let d = [0, 1, 2].map(|i| pb[i] - pa[i]);
                Some(so3::dot(&d, &column(&ea, 2)))
            }
            _ => None,
        }
    }
}

/// Joint rows: dot products of port-affine vectors.
struct DotRows {
    dots: Vec<Dot>,
    names: Vec<&'static str>,
}

impl PortConstraint for DotRows {
    fn rows(&self) -> usize {
        self.dots.len()
    }
    fn values(&self, x: &[f64], g: &mut [f64]) {
        for (out, d) in g.iter_mut().zip(&self.dots) {
            *out = d.value(x);
        }
    }
    fn jacobian(&self, x: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
        for (a, d) in self.dots.iter().enumerate() {
            d.gradient(x, 1.0, &mut |i, v| emit(a, i, v));
        }
    }
    fn hessian(&self, _x: &[f64], lambda: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
        for (d, l) in self.dots.iter().zip(lambda) {
            d.hessian(*l, emit);
        }
    }
    fn is_linear(&self) -> bool {
        self.dots.iter().all(Dot::is_linear)
    }
    fn row_name(&self, a: usize) -> String {
        self.names[a].into()
    }
}

/// The row tying port 0 (`θ` or `s`) to a joint's angle or slide.
enum CoordinateRow {
    /// `cos θ · sine − sin θ · cosine`, with `cosine = x_B·x_A`, `sine = x_B·y_A`.
    Angle { cosine: Dot, sine: Dot },
    /// `(O_B − O_A)·z_A − s`.
    Slide(Dot),
}

impl PortConstraint for CoordinateRow {
    fn rows(&self) -> usize {
        1
    }
    fn values(&self, x: &[f64], g: &mut [f64]) {
        g[0] = match self {
            Self::Angle { cosine, sine } => {
                let (s, c) = x[0].sin_cos();
                c * sine.value(x) - s * cosine.value(x)
            }
            Self::Slide(d) => d.value(x) - x[0],
        };
    }
    fn jacobian(&self, x: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
        match self {
            Self::Angle { cosine, sine } => {
                let (s, c) = x[0].sin_cos();
                emit(0, 0, -s * sine.value(x) - c * cosine.value(x));
                sine.gradient(x, c, &mut |i, v| emit(0, i, v));
                cosine.gradient(x, -s, &mut |i, v| emit(0, i, v));
            }
            Self::Slide(d) => {
                emit(0, 0, -1.0);
                d.gradient(x, 1.0, &mut |i, v| emit(0, i, v));
            }
        }
    }
    fn hessian(&self, x: &[f64], lambda: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
        let l = lambda[0];
        match self {
            Self::Angle { cosine, sine } => {
                let (s, c) = x[0].sin_cos();
                emit(0, 0, l * (-c * sine.value(x) + s * cosine.value(x)));
                let mut mixed = |i: usize, v: f64| {
                    emit(0, i, v);
                    emit(i, 0, v);
                };
                sine.gradient(x, -l * s, &mut mixed);
                cosine.gradient(x, -l * c, &mut mixed);
                sine.hessian(l * c, emit);
                cosine.hessian(-l * s, emit);
            }
            Self::Slide(d) => d.hessian(l, emit),
        }
    }
    fn is_linear(&self) -> bool {
        match self {
            Self::Angle { .. } => false,
            Self::Slide(d) => d.is_linear(),
        }
    }
    fn row_name(&self, _a: usize) -> String {
        match self {
            Self::Angle { .. } => "sin(φ − θ) = 0".into(),
            Self::Slide(_) => "s_joint − s = 0".into(),
        }
    }
}
