//! Building a scene: parts → subsystems, connections → graph edges, settings → integrator options,
//! signal names → indices into the global state.

use std::collections::{HashMap, HashSet};

use dirac_components::{
    Capacitor, Cccs, Ccvs, CoupledInductors, CurrentSource, Damper, DcMotor, Diode, ForceSource,
    Ground, IdealGear, IdealTransformer, Inductor, Inertia, Mass, PartError, Pendulum,
    PlanarLinkage, Resistor, RollingDisk, SaturatingInductor, Spring, Vccs, Vcvs, VoltageSource,
    Waveform,
};
use dirac_core::Discretisation;
use dirac_graph::{
    Connection, ConnectionId, Interconnection, PortRef, Representation, Subsystem, SubsystemId,
};
use dirac_rigid::{COORDINATES, Joint, JointKind, Side, rotation_index};
use dirac_sim::{
    Composition, Execution, IntegratorOptions, Probe, RunError, Scheme, Signal, Simulation,
    Splitting, Start, StartRamp,
};

use super::error::{Location, Origin, SceneError, listed};
use super::model::{
    CompositionSpec, ConnectionKind, DiscretisationSpec, ElementSpec, InertiaSpec, Initial,
    InitialSpec, Part, PartKind, RepresentationSpec, RigidBodyParams, RigidJointSpec, RotationSpec,
    Scene, SchemeSpec, SplittingSpec, WaveformSpec,
};

/// Largest order accepted for Gauss and Lobatto discretisations.
pub const MAX_ORDER: usize = 20;

/// A scene ready to run: the interconnection, its initial state, the integrator settings and the
/// signals to record.
#[derive(Debug, Clone)]
pub struct BuiltScene {
    /// Parts (one subsystem each, in scene order) joined by the connections (in scene order).
    pub graph: Interconnection,
    /// Initial positions per part.
    pub q0: Vec<Vec<f64>>,
    /// Initial velocities per part.
    pub v0: Vec<Vec<f64>>,
    /// Which initial positions the scene states (the others may be moved to make the start
    /// consistent).
    pub given_q: Vec<Vec<bool>>,
    /// Which initial velocities the scene states.
    pub given_v: Vec<Vec<bool>>,
    /// Discretisation, scheme and step size.
    pub options: IntegratorOptions,
    /// Representation (or staggered splitting).
    pub execution: Execution,
    /// Where the run starts (`initial = "given"` or `"equilibrium"`).
    pub start: Start,
    /// End time.
    pub t_end: f64,
    /// The signals `[record]` asks for (by default every coordinate and every flow port), then
    /// `energy`, `power(<part>)`, `constraint_residual` and `force(<connection>)` when asked for.
    pub signals: Vec<Signal>,
    /// The rigid joints by connection name (each is in `graph` as the connections `{name}[k]`,
    /// one per row; see [`dirac_rigid::Joint::connect_rows`]).
    pub rigid_joints: Vec<(String, dirac_rigid::Joint)>,
}

impl BuiltScene {
    /// Step size.
    #[must_use]
    pub fn h(&self) -> f64 {
        self.options.h
    }

    /// Number of steps, `round(t_end / h)`.
    #[must_use]
    pub fn steps(&self) -> usize {
        (self.t_end / self.options.h).round() as usize
    }

    /// A simulation of this scene (its execution, options, start and initial values).
    ///
    /// # Errors
    /// When the initial values do not fit the parts (a programming error of this crate).
    pub fn simulation(&self) -> Result<Simulation, RunError> {
        self.simulation_with(self.execution, self.options.clone(), self.start)
    }

    /// A simulation of this scene in another execution, with other options or start.
    ///
    /// # Errors
    /// When the initial values do not fit the parts (a programming error of this crate).
    pub fn simulation_with(
        &self,
        execution: Execution,
        options: IntegratorOptions,
        start: Start,
    ) -> Result<Simulation, RunError> {
        let mut sim = Simulation::new(self.graph.clone(), execution, options).start(start);
        sim.set_initial(&self.q0, &self.v0, &self.given_q, &self.given_v)?;
        Ok(sim)
    }

    /// The signal named `name`: `part.coordinate` (its value), `part.coordinate'` (its rate),
    /// `part.port` (a port's flow), `energy`, `power(<part>)`, `constraint_residual` or
    /// `force(<connection>)`; for a rigid body also `body.wx|wy|wz` (angular velocity, space
    /// axes) and `body.w1|w2|w3` (body axes), for a rigid joint `joint.fx|fy|fz` (the force on
    /// its body `b`, space axes), `joint.angle` or `joint.slide` (its coordinate) and `force(joint[k])` (the
    /// multiplier of row `k`).
    ///
    /// # Errors
    /// [`SceneError::BadSignal`] or [`SceneError::UnknownPart`] saying what exists.
    pub fn signal(&self, name: &str) -> Result<Signal, SceneError> {
        resolve_signal(&self.graph, &self.rigid_joints, self.execution, name, None)
    }
}

/// `Position` of coordinate `c` of part `part`.
fn position(part: SubsystemId, c: usize) -> Probe {
    Probe::Position {
        part,
        coordinate: c,
    }
}

/// A rigid body's angular velocity component `which`: `wx`, `wy`, `wz` in space axes
/// (`ω = vee(Ṙ Rᵀ)`), `w1`, `w2`, `w3` in body axes (`Ω = vee(Rᵀ Ṙ)`); sums of products of
/// rotation entries and their rates at `t_k`.
fn angular_velocity(part: SubsystemId, which: &str) -> Option<Probe> {
    let r = |i: usize, j: usize| position(part, rotation_index(i, j));
    let rate = |i: usize, j: usize| Probe::Velocity {
        part,
        coordinate: rotation_index(i, j),
    };
    // vee(W) = (W₃₂, W₁₃, W₂₁); (Ṙ Rᵀ)_ab = Σ_j Ṙ_aj R_bj, (Rᵀ Ṙ)_ab = Σ_i R_ia Ṙ_ib.
    let (a, b, space) = match which {
        "wx" => (2, 1, true),
        "wy" => (0, 2, true),
        "wz" => (1, 0, true),
        "w1" => (2, 1, false),
        "w2" => (0, 2, false),
        "w3" => (1, 0, false),
        _ => return None,
    };
    let terms = (0..3)
        .map(|k| {
            let product = if space {
                Probe::Product(Box::new(rate(a, k)), Box::new(r(b, k)))
            } else {
                Probe::Product(Box::new(r(k, a)), Box::new(rate(k, b)))
            };
            (product, 1.0)
        })
        .collect();
    Some(Probe::Sum(terms))
}

/// The space components of a joint side's body-fixed vector `v` (a point when `point`, else a
/// direction), as probes linear in the body's coordinates (constants for the ground).
fn side_vector(graph: &Interconnection, side: &Side, v: [f64; 3], point: bool) -> [Probe; 3] {
    let body = side.body.as_ref().and_then(|b| graph.subsystem_id(b));
    [0, 1, 2].map(|i| match body {
        Some(id) => {
            let mut terms: Vec<(Probe, f64)> = (0..3)
                .map(|j| (position(id, rotation_index(i, j)), v[j]))
                .collect();
            if point {
                terms.push((position(id, i), 1.0));
            }
            Probe::Sum(terms)
        }
        None => Probe::Constant(v[i]),
    })
}

/// `u · w` of two probe vectors.
fn dot_probe(u: [Probe; 3], w: [Probe; 3]) -> Probe {
    Probe::Sum(
        u.into_iter()
            .zip(w)
            .map(|(a, b)| (Probe::Product(Box::new(a), Box::new(b)), 1.0))
            .collect(),
    )
}

/// `joint.fx|fy|fz`, `joint.angle` or `joint.slide` of the rigid joint `j` named `name`.
fn rigid_joint_signal(
    graph: &Interconnection,
    name: &str,
    j: &Joint,
    quantity: &str,
    execution: Execution,
) -> Result<Probe, String> {
    let axis = |side: &Side, k: usize| {
        let f = side.frame.axes;
        side_vector(graph, side, [f[0][k], f[1][k], f[2][k]], false)
    };
    let rotational = matches!(
        j.kind,
        JointKind::Revolute | JointKind::Cylindrical | JointKind::Planar
    );
    match quantity {
        "fx" | "fy" | "fz" if j.has_point_rows() => {
            if matches!(execution, Execution::Staggered(_)) {
                return Err("a joint's force is its multiplier, which a staggered run does not have; record it in the monolithic, constraint or force representation".into());
            }
            let k = usize::from(quantity.as_bytes()[1] - b'x');
            let row = format!("{name}[{k}]");
            graph
                .connection_id(&row)
                .map(Probe::Effort)
                .ok_or_else(|| format!("the joint has no row `{row}`"))
        }
        "angle" if rotational => Ok(Probe::Atan2 {
            y: Box::new(dot_probe(axis(&j.b, 0), axis(&j.a, 1))),
            x: Box::new(dot_probe(axis(&j.b, 0), axis(&j.a, 0))),
        }),
        "slide" if j.kind == JointKind::Prismatic => {
            let pa = side_vector(graph, &j.a, j.a.frame.origin, true);
            let pb = side_vector(graph, &j.b, j.b.frame.origin, true);
            let gap = pb
                .into_iter()
                .zip(pa)
                .map(|(b, a)| Probe::Sum(vec![(b, 1.0), (a, -1.0)]));
            let gap: Vec<Probe> = gap.collect();
            let gap: [Probe; 3] = gap
                .try_into()
                .map_err(|_| "a point has three components".to_string())?;
            Ok(dot_probe(gap, axis(&j.a, 2)))
        }
        _ => {
            let mut offered = Vec::new();
            if j.has_point_rows() {
                offered.extend(["fx", "fy", "fz"]);
            }
            if rotational {
                offered.push("angle");
            }
            if j.kind == JointKind::Prismatic {
                offered.push("slide");
            }
            Err(format!(
                "the {:?} joint `{name}` has no signal `{quantity}`; it offers {} and `force({name}[k])` for row k",
                j.kind,
                listed(offered)
            ))
        }
    }
}

/// Parameter checks of one rigid-body item (the stock parts check themselves through their
/// constructors), errors placed at the parameter's value.
struct Check<'a> {
    item: String,
    origin: &'a Origin,
}

impl Check<'_> {
    fn fail(&self, key: &str, value: f64, requirement: &'static str) -> SceneError {
        SceneError::BadParameter {
            at: self.origin.field(key),
            item: self.item.clone(),
            parameter: key.to_string(),
            value,
            requirement,
        }
    }

    fn finite(&self, key: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.fail(key, v, "must be finite"))
        }
    }

    fn positive(&self, key: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.fail(key, v, "must be positive and finite"))
        }
    }
}

/// Flow signals of the ports of `sub` not named like one of its coordinates.
fn flow_ports(sub: &Subsystem, names: &[String], s: usize) -> Vec<Signal> {
    sub.ports()
        .iter()
        .enumerate()
        .filter(|(_, p)| !names.contains(&p.name))
        .map(|(port, p)| {
            Signal::new(
                format!("{}.{}", sub.name(), p.name),
                Probe::Flow(PortRef {
                    subsystem: SubsystemId(s),
                    port,
                }),
            )
        })
        .collect()
}

/// Resolves `part.coordinate`, `part.coordinate'`, `part.port` (a flow), `energy`,
/// `power(<part>)`, `constraint_residual` or `force(<connection>)`.
fn resolve_signal(
    graph: &Interconnection,
    joints: &[(String, dirac_rigid::Joint)],
    execution: Execution,
    name: &str,
    at: Option<Location>,
) -> Result<Signal, SceneError> {
    let bad = |reason: String| SceneError::BadSignal {
        at: at.clone(),
        signal: name.to_string(),
        reason,
    };
    match name {
        "energy" => return Ok(Signal::new(name, Probe::Energy)),
        "constraint_residual" => return Ok(Signal::new(name, Probe::ConstraintResidual)),
        _ => {}
    }
    if let Some(part) = name
        .strip_prefix("power(")
        .and_then(|r| r.strip_suffix(')'))
    {
        let Some(id) = graph.subsystem_id(part) else {
            return Err(SceneError::UnknownPart {
                at,
                reference: name.to_string(),
                part: part.to_string(),
            });
        };
        return Ok(Signal::new(name, Probe::Power(id)));
    }
    if let Some(c) = name
        .strip_prefix("force(")
        .and_then(|r| r.strip_suffix(')'))
        .filter(|c| joints.iter().any(|(j, _)| j == c))
    {
        return Err(bad(format!(
            "`{c}` is a rigid joint: record `{c}.fx`, `{c}.fy`, `{c}.fz` (its reaction force) or `force({c}[k])` (the multiplier of its row k)"
        )));
    }
    if let Some(c) = name
        .strip_prefix("force(")
        .and_then(|r| r.strip_suffix(')'))
    {
        let Some(id) = graph.connection_id(c) else {
            return Err(bad(format!(
                "no connection is named `{c}`; the connections are {}",
                listed(graph.connections().iter().map(Connection::name))
            )));
        };
        return match &graph.connections()[id.0] {
            Connection::Coupling { .. } => Ok(Signal::new(name, Probe::CouplingForce(id))),
            _ if matches!(execution, Execution::Staggered(_)) => Err(bad(
                "the force of a node or joint is its multiplier, which a staggered run does not have; record it in the monolithic, constraint or force representation".into(),
            )),
            _ => Ok(Signal::new(name, Probe::Effort(id))),
        };
    }
    if let Some((joint, quantity)) = name.split_once('.')
        && graph.subsystem_id(joint).is_none()
        && let Some((_, j)) = joints.iter().find(|(n, _)| n == joint)
    {
        return rigid_joint_signal(graph, joint, j, quantity, execution)
            .map(|probe| Signal::new(name, probe))
            .map_err(bad);
    }
    let Some((part, rest)) = name.split_once('.') else {
        return Err(bad(
            "write `part.coordinate`, `part.coordinate'`, `part.port`, `energy`, `power(part)`, `constraint_residual` or `force(connection)`".into(),
        ));
    };
    let (base, rate) = match rest.strip_suffix('\'') {
        Some(b) => (b, true),
        None => (rest, false),
    };
    let Some(id) = graph.subsystem_id(part) else {
        return Err(SceneError::UnknownPart {
            at,
            reference: name.to_string(),
            part: part.to_string(),
        });
    };
    let sub = &graph.subsystems()[id.0];
    let model = sub.model();
    let names: Vec<String> = (0..model.dim()).map(|i| model.coordinate_name(i)).collect();
    if let Some(coordinate) = names.iter().position(|c| c == base) {
        let probe = if rate {
            Probe::Velocity {
                part: id,
                coordinate,
            }
        } else {
            Probe::Position {
                part: id,
                coordinate,
            }
        };
        return Ok(Signal::new(name, probe));
    }
    if !rate
        && names.len() == COORDINATES.len()
        && names.iter().zip(COORDINATES).all(|(a, b)| a == b)
        && let Some(probe) = angular_velocity(id, base)
    {
        return Ok(Signal::new(name, probe));
    }
    if let Some(port) = sub.port_index(base) {
        if rate {
            return Err(bad(format!(
                "port `{base}` is already a flow; its derivative is not recordable"
            )));
        }
        return Ok(Signal::new(
            name,
            Probe::Flow(PortRef {
                subsystem: id,
                port,
            }),
        ));
    }
    Err(bad(format!(
        "part `{part}` has no coordinate or port `{base}`; its coordinates are {} and its ports {}",
        listed(&names),
        listed(sub.ports().iter().map(|p| p.name.as_str()))
    )))
}

/// A part's refusal of a parameter, placed at the parameter's value in the scene (`prefix` is the
/// key of the table the part's parameters sit in: empty for a part, `element.` for a coupling).
fn placed(item: String, origin: &Origin, prefix: &str, e: PartError) -> SceneError {
    match e {
        PartError::Parameter {
            parameter,
            value,
            requirement,
            ..
        } => {
            let parameter = format!("{prefix}{parameter}");
            SceneError::BadParameter {
                at: origin.field(&parameter),
                item,
                parameter,
                value,
                requirement,
            }
        }
        other => SceneError::Graph(other.into()),
    }
}

/// The runtime waveform a scene's waveform table describes (checked by the source that uses it).
fn waveform(w: &WaveformSpec) -> Waveform {
    match w {
        WaveformSpec::Dc(v) => Waveform::Dc(*v),
        WaveformSpec::Sin {
            offset,
            amplitude,
            frequency,
            delay,
            damping,
            phase,
        } => Waveform::Sin {
            offset: *offset,
            amplitude: *amplitude,
            frequency: *frequency,
            delay: *delay,
            damping: *damping,
            phase_deg: *phase,
        },
        WaveformSpec::Pulse {
            v1,
            v2,
            delay,
            rise,
            fall,
            width,
            period,
            pulses,
        } => Waveform::Pulse {
            v1: *v1,
            v2: *v2,
            delay: *delay,
            rise: *rise,
            fall: *fall,
            width: *width,
            period: period.unwrap_or(f64::INFINITY),
            pulses: pulses.unwrap_or(f64::INFINITY),
        },
        WaveformSpec::Exp {
            v1,
            v2,
            rise_delay,
            rise_tau,
            fall_delay,
            fall_tau,
        } => Waveform::Exp {
            v1: *v1,
            v2: *v2,
            rise_delay: *rise_delay,
            rise_tau: *rise_tau,
            fall_delay: *fall_delay,
            fall_tau: *fall_tau,
        },
        WaveformSpec::Sffm {
            offset,
            amplitude,
            carrier,
            index,
            signal,
            carrier_phase,
            signal_phase,
        } => Waveform::Sffm {
            offset: *offset,
            amplitude: *amplitude,
            carrier: *carrier,
            index: *index,
            signal: *signal,
            carrier_phase_deg: *carrier_phase,
            signal_phase_deg: *signal_phase,
        },
        WaveformSpec::Am {
            amplitude,
            offset,
            modulation,
            carrier,
            delay,
            phase,
        } => Waveform::Am {
            amplitude: *amplitude,
            offset: *offset,
            modulation: *modulation,
            carrier: *carrier,
            delay: *delay,
            phase_deg: *phase,
        },
        WaveformSpec::Pwl {
            points,
            delay,
            repeat,
        } => Waveform::Pwl {
            points: points.iter().map(|p| (p[0], p[1])).collect(),
            delay: *delay,
            repeat: *repeat,
        },
    }
}

/// A to-ground part's subsystem: port `x`, or `theta` when rotational.
fn to_ground<M>(part: M, name: String, rotational: bool) -> Subsystem
where
    M: dirac_core::Model + Send + Sync + 'static,
{
    let port = if rotational { "theta" } else { "x" };
    Subsystem::new(name, part).with_port(port, 0)
}

/// A part's subsystem and default initial positions; parameters are checked by the part's
/// constructor and a refusal is placed at the parameter's value.
fn part_subsystem(part: &Part) -> Result<(Subsystem, Vec<f64>), SceneError> {
    let item = || format!("part `{}` ({})", part.name, part.kind.type_name());
    let at = |e: PartError| placed(item(), &part.origin, "", e);
    let name = part.name.clone();
    let zeros = |n: usize| vec![0.0; n];
    Ok(match &part.kind {
        PartKind::Resistor(p) => (Resistor::new(p.r).map_err(at)?.subsystem(name), zeros(1)),
        PartKind::Inductor(p) => (Inductor::new(p.l).map_err(at)?.subsystem(name), zeros(1)),
        PartKind::Capacitor(p) => (Capacitor::new(p.c).map_err(at)?.subsystem(name), zeros(1)),
        PartKind::VoltageSource(p) => (
            VoltageSource::new(waveform(&p.waveform))
                .map_err(at)?
                .subsystem(name),
            zeros(1),
        ),
        PartKind::CurrentSource(p) => (
            CurrentSource::new(waveform(&p.waveform))
                .map_err(at)?
                .subsystem(name),
            zeros(2),
        ),
        PartKind::CoupledInductors(p) => (
            CoupledInductors::new(p.l1, p.l2, p.k)
                .map_err(at)?
                .subsystem(name),
            zeros(2),
        ),
        PartKind::Diode(p) => {
            // Built as a netlist's `D` element is; a refusal is placed at the key it names.
            let check = dirac_graph::Check::new("diode");
            let gmin = check.non_negative("gmin", p.gmin).map_err(at)?;
            let card = p.card();
            let diode = Diode::at_temperature(&card, p.temp)
                .map_err(|e| {
                    let key = match e.parameter {
                        "TEMP/TNOM" if e.value < p.temp => "tnom".to_string(),
                        "TEMP/TNOM" => "temp".to_string(),
                        name => name.to_ascii_lowercase(),
                    };
                    at(check.fail(&key, e.value, e.reason))
                })?
                .diode
                .with_gmin(gmin);
            (diode.subsystem(name), zeros(2))
        }
        PartKind::SaturatingInductor(p) => (
            SaturatingInductor::new(p.l0, p.l_inf, p.i_sat)
                .map_err(at)?
                .subsystem(name),
            zeros(1),
        ),
        PartKind::Mass(p) => (Mass::new(p.m).map_err(at)?.subsystem(name), zeros(1)),
        PartKind::Inertia(p) => (Inertia::new(p.j).map_err(at)?.subsystem(name), zeros(1)),
        PartKind::Spring(p) => {
            let s = Spring::new(p.k, p.k3, p.rest).map_err(at)?;
            (to_ground(s, name, p.rotational), zeros(1))
        }
        PartKind::Damper(p) => {
            let d = Damper::new(p.c).map_err(at)?;
            (to_ground(d, name, p.rotational), zeros(1))
        }
        PartKind::ForceSource(p) => {
            let f = ForceSource::new(waveform(&p.waveform)).map_err(at)?;
            (to_ground(f, name, p.rotational), zeros(1))
        }
        PartKind::Ground(p) => {
            let g = Ground::at(p.position).map_err(at)?;
            let sub = if p.rotational {
                g.rotational_subsystem(name)
            } else {
                g.subsystem(name)
            };
            (sub, vec![g.position])
        }
        PartKind::Pendulum(p) => {
            let pendulum = Pendulum::new(p.m, p.length, p.g, p.pivot).map_err(at)?;
            // At rest hanging straight down unless `q0` says otherwise.
            let hanging = pendulum.position(0.0).to_vec();
            (pendulum.subsystem(name), hanging)
        }
        PartKind::PlanarLinkage(p) => {
            let mut linkage = PlanarLinkage::new(p.g).map_err(at)?;
            let mut index: HashMap<&str, usize> = HashMap::new();
            for (i, b) in p.bodies.iter().enumerate() {
                let key = |k: &str| format!("bodies[{i}].{k}");
                if b.name.is_empty() || index.insert(b.name.as_str(), i).is_some() {
                    return Err(SceneError::BadName {
                        at: part.origin.field(&key("name")),
                        what: "body",
                        name: b.name.clone(),
                        reason: "body names must be non-empty and unique within the linkage",
                    });
                }
                linkage.add_body(b.name.clone(), b.m, b.j).map_err(at)?;
            }
            for (i, pin) in p.pins.iter().enumerate() {
                let key = |k: &str| format!("pins[{i}].{k}");
                let body = |field: &str, name: &str| {
                    index
                        .get(name)
                        .copied()
                        .ok_or_else(|| SceneError::UnknownPart {
                            at: part.origin.field(&key(field)),
                            reference: name.to_string(),
                            part: format!("{}.{name}", part.name),
                        })
                };
                let a = body("body", &pin.body)?;
                let bad_pin = |reason: &str| SceneError::BadConnection {
                    at: part.origin.field(&format!("pins[{i}]")),
                    connection: format!("{}/pin {i}", part.name),
                    reason: reason.to_string(),
                };
                match (&pin.ground, &pin.to, &pin.at) {
                    (Some(g), None, None) => linkage.pin_to_ground(a, pin.point, *g),
                    (None, Some(to), Some(at)) => {
                        let b = body("to", to)?;
                        if a == b {
                            return Err(bad_pin("a body cannot be pinned to itself"));
                        }
                        linkage.pin(a, pin.point, b, *at);
                    }
                    _ => {
                        return Err(bad_pin(
                            "a pin needs either `ground = [x, y]` or both `to = \"body\"` and `at = [x, y]`",
                        ));
                    }
                }
            }
            let n = 3 * p.bodies.len();
            (linkage.subsystem(name), zeros(n))
        }
        PartKind::DcMotor(p) => (
            DcMotor::new(p.k, p.r, p.l, p.j, p.b)
                .map_err(at)?
                .subsystem(name),
            zeros(2),
        ),
        PartKind::IdealTransformer(p) => (
            IdealTransformer::new(p.n).map_err(at)?.subsystem(name),
            zeros(2),
        ),
        PartKind::IdealGear(p) => (
            IdealGear::new(p.ratio).map_err(at)?.subsystem(name),
            zeros(2),
        ),
        PartKind::Vcvs(p) => (Vcvs::new(p.gain).map_err(at)?.subsystem(name), zeros(3)),
        PartKind::Vccs(p) => (Vccs::new(p.gm).map_err(at)?.subsystem(name), zeros(4)),
        PartKind::Cccs(p) => (Cccs::new(p.gain).map_err(at)?.subsystem(name), zeros(3)),
        PartKind::Ccvs(p) => (Ccvs::new(p.r).map_err(at)?.subsystem(name), zeros(2)),
        PartKind::RollingDisk(p) => (
            RollingDisk::new(p.m, p.i, p.j, p.radius)
                .map_err(at)?
                .subsystem(name),
            zeros(4),
        ),
        PartKind::RigidBody(p) => {
            let c = Check {
                item: format!("part `{}` (rigid_body)", part.name),
                origin: &part.origin,
            };
            let body = rigid_body(part, p, &c)?;
            let (q, _) = rigid_initial(p, &c)?;
            (body.subsystem(name), q)
        }
    })
}

/// The rigid body of a `rigid_body` part.
fn rigid_body(
    part: &Part,
    p: &RigidBodyParams,
    c: &Check<'_>,
) -> Result<dirac_rigid::RigidBody, SceneError> {
    let m = c.positive("m", p.m)?;
    let inertia = match p.inertia {
        InertiaSpec::Principal(j) => {
            let mut t = [[0.0; 3]; 3];
            for (i, ji) in j.iter().enumerate() {
                t[i][i] = c.finite(&format!("inertia[{i}]"), *ji)?;
            }
            t
        }
        InertiaSpec::Tensor(t) => t,
    };
    let bad = |reason: String| SceneError::BadRigid {
        at: part.origin.field("inertia"),
        item: c.item.clone(),
        reason,
    };
    let mut body = dirac_rigid::RigidBody::new(m, inertia).map_err(|e| bad(e.to_string()))?;
    let g = p.gravity;
    for (i, gi) in g.iter().enumerate() {
        c.finite(&format!("gravity[{i}]"), *gi)?;
    }
    body = body.with_gravity(g);
    for (name, r) in &p.points {
        if name.is_empty() || name.contains('.') {
            return Err(SceneError::BadName {
                at: part.origin.key(&format!("points.{name}")),
                what: "body point",
                name: name.clone(),
                reason: "point names must be non-empty and without `.`",
            });
        }
        for (i, ri) in r.iter().enumerate() {
            c.finite(&format!("points.{name}[{i}]"), *ri)?;
        }
        body = body.with_point(name.clone(), *r);
    }
    Ok(body)
}

/// The rotation of a [`RotationSpec`], checked to be one.
fn rotation(spec: &RotationSpec, c: &Check<'_>) -> Result<dirac_rigid::so3::Mat3, SceneError> {
    use dirac_rigid::so3;
    let r = match spec {
        RotationSpec::AxisAngle { axis, angle } => {
            let n = so3::dot(axis, axis).sqrt();
            if !(n.is_finite() && n > 0.0 && angle.is_finite()) {
                return Err(c.fail(
                    "rotation.axis",
                    n,
                    "must be a finite non-zero axis with a finite angle",
                ));
            }
            so3::from_axis_angle(*axis, *angle)
        }
        RotationSpec::Quaternion(q) => {
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(n.is_finite() && n > 0.0) {
                return Err(c.fail("rotation", n, "must be a finite non-zero quaternion"));
            }
            so3::from_quaternion(*q)
        }
        RotationSpec::Matrix(m) => *m,
    };
    let error = so3::orthonormality_error(&r);
    if !(error <= 1e-12 && so3::det(&r) > 0.0) {
        return Err(c.fail(
            "rotation",
            error,
            "is not a rotation (‖RᵀR − I‖ must be below 1e-12 and det R = +1)",
        ));
    }
    Ok(r)
}

/// The initial coordinates and rates a `rigid_body` part states through `position`, `rotation`,
/// `velocity` and `angular_velocity` (defaults: at rest at the origin, unrotated).
fn rigid_initial(p: &RigidBodyParams, c: &Check<'_>) -> Result<(Vec<f64>, Vec<f64>), SceneError> {
    use dirac_rigid::{RigidBody, so3};
    let r = match &p.rotation {
        Some(spec) => rotation(spec, c)?,
        None => so3::IDENTITY,
    };
    let x = p.position.unwrap_or([0.0; 3]);
    let v = p.velocity.unwrap_or([0.0; 3]);
    let w = p.angular_velocity.unwrap_or([0.0; 3]);
    for (key, vector) in [("position", x), ("velocity", v), ("angular_velocity", w)] {
        for (i, value) in vector.iter().enumerate() {
            c.finite(&format!("{key}[{i}]"), *value)?;
        }
    }
    Ok((RigidBody::coordinates(x, &r), RigidBody::rates(&r, v, w)))
}

/// The joint frame on one side of a rigid joint.
fn joint_frame(
    origin: Option<[f64; 3]>,
    axis: Option<[f64; 3]>,
    reference: Option<[f64; 3]>,
    side: char,
    c: &Check<'_>,
) -> Result<dirac_rigid::JointFrame, SceneError> {
    use dirac_rigid::{JointFrame, so3};
    let origin = origin.unwrap_or([0.0; 3]);
    let z = axis.unwrap_or([0.0, 0.0, 1.0]);
    let nz = so3::dot(&z, &z).sqrt();
    for (i, v) in origin.iter().enumerate() {
        c.finite(&format!("origin_{side}[{i}]"), *v)?;
    }
    if !(nz.is_finite() && nz > 0.0) {
        return Err(c.fail(
            &format!("axis_{side}"),
            nz,
            "must be a finite non-zero vector",
        ));
    }
    let z = z.map(|v| v / nz);
    let x = match reference {
        Some(x) => {
            let along = so3::dot(&x, &z);
            let rest = [0, 1, 2].map(|i| x[i] - along * z[i]);
            let n = so3::dot(&rest, &rest).sqrt();
            if !(n.is_finite() && n > 1e-9 * so3::dot(&x, &x).sqrt()) {
                return Err(c.fail(
                    &format!("ref_{side}"),
                    n,
                    "must be finite and not parallel to the axis",
                ));
            }
            x
        }
        None => so3::perpendicular(&z),
    };
    Ok(JointFrame::oriented(origin, z, x))
}

/// The rigid joint a connection describes.
fn rigid_joint(
    kind: dirac_rigid::JointKind,
    spec: &RigidJointSpec,
    c: &Check<'_>,
) -> Result<dirac_rigid::Joint, SceneError> {
    use dirac_rigid::{Joint, Side};
    let fa = joint_frame(spec.origin_a, spec.axis_a, spec.ref_a, 'a', c)?;
    let fb = joint_frame(spec.origin_b, spec.axis_b, spec.ref_b, 'b', c)?;
    let a = match &spec.a {
        Some(body) => Side::body(body.clone(), fa),
        None => Side::ground(fa),
    };
    Ok(Joint::new(kind, a, Side::body(spec.b.clone(), fb)))
}

/// The joint kind and spec of a rigid-joint connection.
fn rigid_kind(kind: &ConnectionKind) -> Option<(dirac_rigid::JointKind, &RigidJointSpec)> {
    use dirac_rigid::JointKind;
    Some(match kind {
        ConnectionKind::Spherical(s) => (JointKind::Spherical, s),
        ConnectionKind::Revolute(s) => (JointKind::Revolute, s),
        ConnectionKind::Universal(s) => (JointKind::Universal, s),
        ConnectionKind::Cylindrical(s) => (JointKind::Cylindrical, s),
        ConnectionKind::Prismatic(s) => (JointKind::Prismatic, s),
        ConnectionKind::Planar(s) => (JointKind::Planar, s),
        ConnectionKind::Fixed(s) => (JointKind::Fixed, s),
        _ => return None,
    })
}

/// The initial vector `key` (`q0` or `v0`) of `part` with coordinates `names`.
fn initial(
    part: &Part,
    key: &'static str,
    given: Option<&Initial>,
    names: &[String],
    default: Vec<f64>,
) -> Result<(Vec<f64>, Vec<bool>), SceneError> {
    let length = |got: usize| SceneError::InitialLength {
        at: part.origin.field(key),
        part: part.name.clone(),
        key,
        got,
        coordinates: listed(names),
    };
    let mut stated =
        vec![given.is_some() && !matches!(given, Some(Initial::Named(_))); names.len()];
    let out = match given {
        None => default,
        Some(Initial::Value(v)) => {
            if names.len() != 1 {
                return Err(length(1));
            }
            vec![*v]
        }
        Some(Initial::List(values)) => {
            if values.len() != names.len() {
                return Err(length(values.len()));
            }
            values.clone()
        }
        Some(Initial::Named(values)) => {
            let mut out = default;
            for (name, v) in values {
                let Some(i) = names.iter().position(|n| n == name) else {
                    return Err(SceneError::UnknownCoordinate {
                        at: part.origin.key(&format!("{key}.{name}")),
                        part: part.name.clone(),
                        coordinate: name.clone(),
                        available: listed(names),
                    });
                };
                out[i] = *v;
                stated[i] = true;
            }
            out
        }
    };
    for (i, v) in out.iter().enumerate() {
        let path = match given {
            Some(Initial::Named(_)) => format!("{key}.{}", names[i]),
            Some(Initial::List(_)) => format!("{key}[{i}]"),
            _ => key.to_string(),
        };
        if !v.is_finite() {
            return Err(SceneError::BadParameter {
                at: part.origin.field(&path),
                item: format!("part `{}` ({})", part.name, part.kind.type_name()),
                parameter: path,
                value: *v,
                requirement: "must be finite",
            });
        }
    }
    Ok((out, stated))
}

fn discretisation(scene: &Scene) -> Result<Discretisation, SceneError> {
    let s = &scene.simulation;
    let bad = |reason: String| SceneError::BadSetting {
        at: s.origin.field("order"),
        setting: "order",
        reason,
    };
    let order = s.order.unwrap_or(2);
    Ok(match s.discretisation {
        DiscretisationSpec::Midpoint
        | DiscretisationSpec::Trapezoid
        | DiscretisationSpec::Simpson => {
            if order != 2 {
                return Err(bad(format!(
                    "{order} given, but a linear path has order 2 (use `gauss` or `lobatto` for higher orders)"
                )));
            }
            match s.discretisation {
                DiscretisationSpec::Midpoint => Discretisation::midpoint(),
                DiscretisationSpec::Trapezoid => Discretisation::trapezoid(),
                _ => Discretisation::simpson(),
            }
        }
        DiscretisationSpec::Gauss | DiscretisationSpec::Lobatto => {
            if order < 2 || !order.is_multiple_of(2) || order > MAX_ORDER {
                return Err(bad(format!(
                    "{order} given; Gauss and Lobatto discretisations have even orders 2, 4, …, {MAX_ORDER}"
                )));
            }
            if s.discretisation == DiscretisationSpec::Gauss {
                Discretisation::gauss(order / 2)
            } else {
                Discretisation::lobatto(order / 2)
            }
        }
    })
}

fn execution(scene: &Scene) -> Result<Execution, SceneError> {
    let s = &scene.simulation;
    Ok(match s.representation {
        RepresentationSpec::Staggered => {
            let splitting = match s.splitting.unwrap_or_default() {
                SplittingSpec::GaussSeidel => Splitting::GaussSeidel,
                SplittingSpec::Jacobi => Splitting::Jacobi,
            };
            if let Some(c) = scene
                .connections
                .iter()
                .find(|c| !matches!(c.kind, ConnectionKind::Coupling { .. }))
            {
                return Err(SceneError::BadConnection {
                    at: c.origin.item(),
                    connection: c.name.clone(),
                    reason: "a staggered co-simulation needs coupling elements between parts; nodes and joints cannot be split (use another representation)".into(),
                });
            }
            Execution::Staggered(splitting)
        }
        other => {
            if s.splitting.is_some() {
                return Err(SceneError::BadSetting {
                    at: s.origin.field("splitting"),
                    setting: "splitting",
                    reason: "only a staggered representation has a splitting".into(),
                });
            }
            Execution::Assembled(match other {
                RepresentationSpec::Constraint => Representation::Constraint,
                RepresentationSpec::Force => Representation::InteractionForce,
                _ => Representation::Monolithic,
            })
        }
    })
}

impl Scene {
    /// Checks the scene and builds the interconnection, initial data, integrator options and
    /// signals. Every error names its place (file, line and column for a parsed scene; the part,
    /// port or connection otherwise).
    pub fn build(&self) -> Result<BuiltScene, SceneError> {
        let sim = &self.simulation;
        if !(sim.h.is_finite() && sim.h > 0.0) {
            return Err(SceneError::BadSetting {
                at: sim.origin.field("h"),
                setting: "h",
                reason: format!("{} given; the step size must be positive and finite", sim.h),
            });
        }
        if !(sim.t_end.is_finite() && sim.t_end >= 0.0) {
            return Err(SceneError::BadSetting {
                at: sim.origin.field("t_end"),
                setting: "t_end",
                reason: format!(
                    "{} given; the end time must be non-negative and finite",
                    sim.t_end
                ),
            });
        }
        let discretisation = discretisation(self)?;
        let execution = execution(self)?;
        let scheme = match sim.scheme {
            SchemeSpec::Plus => Scheme::Plus,
            SchemeSpec::Minus => Scheme::Minus,
            SchemeSpec::Symmetric => Scheme::Symmetric,
        };

        let mut graph = Interconnection::new();
        let (mut q0, mut v0) = (Vec::new(), Vec::new());
        let (mut given_q, mut given_v) = (Vec::new(), Vec::new());
        let mut seen: HashMap<&str, &Part> = HashMap::new();
        for part in &self.parts {
            if part.name.is_empty() || part.name.contains('.') || part.name.trim() != part.name {
                return Err(SceneError::BadName {
                    at: part.origin.field("name"),
                    what: "part",
                    name: part.name.clone(),
                    reason: "part names must be non-empty, without `.` and without surrounding spaces",
                });
            }
            if let Some(first) = seen.insert(part.name.as_str(), part) {
                return Err(SceneError::DuplicateName {
                    at: part.origin.field("name"),
                    what: "part",
                    name: part.name.clone(),
                    first: first.origin.field("name"),
                });
            }
            let (subsystem, default_q) = part_subsystem(part)?;
            let model = subsystem.model();
            let names: Vec<String> = (0..model.dim()).map(|i| model.coordinate_name(i)).collect();
            let mut default_v = vec![0.0; names.len()];
            // A rigid body's pose and motion keys state its coordinates and rates.
            let mut stated = (false, false);
            if let PartKind::RigidBody(p) = &part.kind {
                let c = Check {
                    item: format!("part `{}` (rigid_body)", part.name),
                    origin: &part.origin,
                };
                default_v = rigid_initial(p, &c)?.1;
                stated = (
                    p.position.is_some() || p.rotation.is_some(),
                    p.velocity.is_some() || p.angular_velocity.is_some(),
                );
            }
            let (q, mut gq) = initial(part, "q0", part.q0.as_ref(), &names, default_q)?;
            let (v, mut gv) = initial(part, "v0", part.v0.as_ref(), &names, default_v)?;
            if stated.0 {
                gq.fill(true);
            }
            if stated.1 {
                gv.fill(true);
            }
            q0.push(q);
            given_q.push(gq);
            v0.push(v);
            given_v.push(gv);
            graph.add_subsystem(subsystem)?;
        }

        let mut connections: HashMap<&str, (ConnectionId, &super::model::Connection)> =
            HashMap::new();
        // Rigid joints by name, for the joint-coordinate couplings (which may come first).
        let mut joints: HashMap<&str, dirac_rigid::Joint> = HashMap::new();
        let mut rigid_joints = Vec::new();
        for c in &self.connections {
            if let Some((kind, spec)) = rigid_kind(&c.kind) {
                let check = Check {
                    item: format!("joint `{}`", c.name),
                    origin: &c.origin,
                };
                joints.insert(c.name.as_str(), rigid_joint(kind, spec, &check)?);
            }
        }
        for c in &self.connections {
            if c.name.is_empty() {
                return Err(SceneError::BadName {
                    at: c.origin.field("name"),
                    what: "connection",
                    name: c.name.clone(),
                    reason: "connection names must be non-empty",
                });
            }
            if let Some((_, first)) = connections.get(c.name.as_str()) {
                return Err(SceneError::DuplicateName {
                    at: c.origin.field("name"),
                    what: "connection",
                    name: c.name.clone(),
                    first: first.origin.field("name"),
                });
            }
            let port = |reference: &str, at: Option<Location>| resolve_port(&graph, reference, at);
            let bad = |reason: &str| SceneError::BadConnection {
                at: c.origin.item(),
                connection: c.name.clone(),
                reason: reason.to_string(),
            };
            let id = match &c.kind {
                ConnectionKind::Node { ports } => {
                    if ports.len() < 2 {
                        return Err(SceneError::TooFewPorts {
                            at: c.origin.field("ports"),
                            node: c.name.clone(),
                            count: ports.len(),
                        });
                    }
                    let mut resolved = Vec::with_capacity(ports.len());
                    let mut distinct = HashSet::with_capacity(ports.len());
                    for (i, p) in ports.iter().enumerate() {
                        let at = field_of(
                            &c.origin,
                            &[&format!("ports[{i}][0]"), &format!("ports[{i}]")],
                        );
                        let r = port(&p.port, at.clone())?;
                        if !(p.sign.is_finite() && p.sign != 0.0) {
                            return Err(SceneError::BadConnection {
                                at: field_of(
                                    &c.origin,
                                    &[&format!("ports[{i}][1]"), &format!("ports[{i}]")],
                                ),
                                connection: c.name.clone(),
                                reason: format!(
                                    "the sign of `{}` must be non-zero and finite",
                                    p.port
                                ),
                            });
                        }
                        if !distinct.insert(r) {
                            return Err(SceneError::BadConnection {
                                at,
                                connection: c.name.clone(),
                                reason: format!("port `{}` appears twice", p.port),
                            });
                        }
                        resolved.push((r, p.sign));
                    }
                    graph.node(c.name.clone(), resolved)?
                }
                ConnectionKind::Joint { a, b } => {
                    let (pa, pb) = (port(a, c.origin.field("a"))?, port(b, c.origin.field("b"))?);
                    if pa == pb {
                        return Err(bad("joins a port to itself"));
                    }
                    graph.joint(c.name.clone(), pa, pb)
                }
                ConnectionKind::JointCoordinate { joint, port: p } => {
                    let Some(j) = joints.get(joint.as_str()) else {
                        return Err(SceneError::BadConnection {
                            at: c.origin.field("joint"),
                            connection: c.name.clone(),
                            reason: format!(
                                "no rigid joint is named `{joint}`; the rigid joints are {}",
                                listed(joints.keys())
                            ),
                        });
                    };
                    let pr = port(p, c.origin.field("port"))?;
                    j.couple_coordinate(&mut graph, &c.name, pr)
                        .map_err(|e| rigid_error(e, c))?
                }
                ConnectionKind::Spherical(_)
                | ConnectionKind::Revolute(_)
                | ConnectionKind::Universal(_)
                | ConnectionKind::Cylindrical(_)
                | ConnectionKind::Prismatic(_)
                | ConnectionKind::Planar(_)
                | ConnectionKind::Fixed(_) => {
                    let Some(j) = joints.get(c.name.as_str()) else {
                        return Err(bad("is not a rigid joint"));
                    };
                    for (key, body) in [("a", j.a.body.as_ref()), ("b", j.b.body.as_ref())] {
                        let Some(body) = body else { continue };
                        let at = c.origin.field(key);
                        let Some(sub) = graph.subsystems().iter().find(|s| s.name() == body) else {
                            return Err(SceneError::UnknownPart {
                                at,
                                reference: body.clone(),
                                part: body.clone(),
                            });
                        };
                        if sub.port_index("r33").is_none() {
                            return Err(SceneError::BadConnection {
                                at,
                                connection: c.name.clone(),
                                reason: format!("part `{body}` is not a rigid body"),
                            });
                        }
                    }
                    if j.a.body.is_some() && j.a.body == j.b.body {
                        return Err(bad("joins a body to itself"));
                    }
                    let rows = j
                        .connect_rows(&mut graph, &c.name)
                        .map_err(|e| rigid_error(e, c))?;
                    rigid_joints.push((c.name.clone(), j.clone()));
                    rows[0]
                }
                ConnectionKind::Coupling { a, b, element } => {
                    let (pa, pb) = (port(a, c.origin.field("a"))?, port(b, c.origin.field("b"))?);
                    if pa == pb {
                        return Err(bad("couples a port to itself"));
                    }
                    let at = |e: PartError| {
                        placed(format!("coupling `{}`", c.name), &c.origin, "element.", e)
                    };
                    match element {
                        ElementSpec::Spring(s) => {
                            let spring = Spring::new(s.k, s.k3, s.rest).map_err(at)?;
                            graph.coupling(c.name.clone(), pa, pb, spring)
                        }
                        ElementSpec::Damper(d) => {
                            let damper = Damper::new(d.c).map_err(at)?;
                            graph.coupling(c.name.clone(), pa, pb, damper)
                        }
                        ElementSpec::ForceSource(f) => {
                            let force = ForceSource::new(waveform(&f.waveform)).map_err(at)?;
                            graph.coupling(c.name.clone(), pa, pb, force)
                        }
                    }
                }
            };
            connections.insert(c.name.as_str(), (id, c));
        }

        let record = &self.record;
        let mut signals = if record.signals.is_empty() {
            let mut all = Vec::new();
            for (s, sub) in graph.subsystems().iter().enumerate() {
                let model = sub.model();
                let names: Vec<String> =
                    (0..model.dim()).map(|i| model.coordinate_name(i)).collect();
                for (i, c) in names.iter().enumerate() {
                    all.push(Signal::new(
                        format!("{}.{c}", sub.name()),
                        Probe::Position {
                            part: SubsystemId(s),
                            coordinate: i,
                        },
                    ));
                }
                all.extend(flow_ports(sub, &names, s));
            }
            all
        } else {
            record
                .signals
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    resolve_signal(
                        &graph,
                        &rigid_joints,
                        execution,
                        name,
                        record.origin.field(&format!("signals[{i}]")),
                    )
                })
                .collect::<Result<Vec<_>, _>>()?
        };
        if record.energy {
            signals.push(Signal::new("energy", Probe::Energy));
        }
        for (i, name) in record.power.iter().enumerate() {
            let label = format!("power({name})");
            signals.push(resolve_signal(
                &graph,
                &rigid_joints,
                execution,
                &label,
                record.origin.field(&format!("power[{i}]")),
            )?);
        }
        if record.residuals {
            signals.push(Signal::new(
                "constraint_residual",
                Probe::ConstraintResidual,
            ));
        }
        for (i, name) in record.forces.iter().enumerate() {
            let label = format!("force({name})");
            signals.push(resolve_signal(
                &graph,
                &rigid_joints,
                execution,
                &label,
                record.origin.field(&format!("forces[{i}]")),
            )?);
        }
        let start = match sim.initial {
            InitialSpec::Given => Start::Given,
            InitialSpec::Equilibrium => Start::SteadyState,
        };
        Ok(BuiltScene {
            graph,
            q0,
            v0,
            given_q,
            given_v,
            options: IntegratorOptions::new(discretisation, sim.h)
                .scheme(scheme)
                .start_ramp(sim.start_ramp.then(StartRamp::default))
                .composition(
                    sim.composition
                        .map_or_else(Composition::single, CompositionSpec::composition),
                ),
            execution,
            start,
            t_end: sim.t_end,
            signals,
            rigid_joints,
        })
    }
}

/// A rigid-body error of connection `c`, placed at the connection.
fn rigid_error(e: dirac_rigid::RigidError, c: &super::model::Connection) -> SceneError {
    match e {
        dirac_rigid::RigidError::Graph(g) => SceneError::Graph(g),
        other => SceneError::BadRigid {
            at: c.origin.item(),
            item: format!("connection `{}`", c.name),
            reason: other.to_string(),
        },
    }
}

/// The first of `paths` the origin knows, else the item.
fn field_of(origin: &Origin, paths: &[&str]) -> Option<Location> {
    paths
        .iter()
        .find_map(|p| origin.known_field(p))
        .or_else(|| origin.item())
}

/// Resolves `part.port` in `graph`.
fn resolve_port(
    graph: &Interconnection,
    reference: &str,
    at: Option<Location>,
) -> Result<PortRef, SceneError> {
    let Some((part, port)) = reference.split_once('.') else {
        return Err(SceneError::BadReference {
            at,
            reference: reference.to_string(),
        });
    };
    let Some(sub) = graph.subsystem_id(part).map(|id| &graph.subsystems()[id.0]) else {
        return Err(SceneError::UnknownPart {
            at,
            reference: reference.to_string(),
            part: part.to_string(),
        });
    };
    if sub.port_index(port).is_none() {
        return Err(SceneError::UnknownPort {
            at,
            part: part.to_string(),
            port: port.to_string(),
            available: listed(sub.ports().iter().map(|p| p.name.as_str())),
        });
    }
    Ok(graph.port(part, port)?)
}
