//! Building a scene: parts → subsystems, connections → graph edges, settings → integrator options,
//! signal names → indices into the global state.

use std::collections::{HashMap, HashSet};

use dirac_components::{
    Capacitor, CoupledInductors, CurrentSource, Damper, DcMotor, Diode, ForceSource, Ground,
    IdealGear, IdealTransformer, Inductor, Inertia, Mass, Pendulum, PlanarLinkage, Resistor,
    RollingDisk, SaturatingInductor, Spring, VoltageSource, Waveform,
};
use dirac_core::Discretisation;
use dirac_graph::{
    Connection, ConnectionId, Interconnection, LinearSpring, PortRef, Representation, Subsystem,
    SubsystemId,
};
use dirac_sim::{
    Execution, IntegratorOptions, Probe, RunError, Scheme, Signal, Simulation, Splitting, Start,
};

use super::error::{Location, Origin, SceneError, listed};
use super::model::{
    ConnectionKind, DiscretisationSpec, ElementSpec, Initial, InitialSpec, Part, PartKind,
    RepresentationSpec, Scene, SchemeSpec, SplittingSpec, WaveformSpec,
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
    /// `force(<connection>)`.
    ///
    /// # Errors
    /// [`SceneError::BadSignal`] or [`SceneError::UnknownPart`] saying what exists.
    pub fn signal(&self, name: &str) -> Result<Signal, SceneError> {
        resolve_signal(&self.graph, self.execution, name, None)
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

/// Parameter checks of one item, errors placed at the parameter's value.
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

    fn non_negative(&self, key: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.fail(key, v, "must be non-negative and finite"))
        }
    }

    fn nonzero(&self, key: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v != 0.0 {
            Ok(v)
        } else {
            Err(self.fail(key, v, "must be non-zero and finite"))
        }
    }

    fn waveform(&self, key: &str, w: &WaveformSpec) -> Result<Waveform, SceneError> {
        let k = |name: &str| format!("{key}.{name}");
        Ok(match w {
            WaveformSpec::Dc(v) => Waveform::Dc(self.finite(key, *v)?),
            WaveformSpec::Sin {
                offset,
                amplitude,
                frequency,
                delay,
                damping,
                phase,
            } => Waveform::Sin {
                offset: self.finite(&k("offset"), *offset)?,
                amplitude: self.finite(&k("amplitude"), *amplitude)?,
                frequency: self.non_negative(&k("frequency"), *frequency)?,
                delay: self.finite(&k("delay"), *delay)?,
                damping: self.finite(&k("damping"), *damping)?,
                phase_deg: self.finite(&k("phase"), *phase)?,
            },
            WaveformSpec::Pulse {
                v1,
                v2,
                delay,
                rise,
                fall,
                width,
                period,
            } => {
                let period = match period {
                    Some(p) if p.is_nan() || *p <= 0.0 => {
                        return Err(self.fail(&k("period"), *p, "must be positive"));
                    }
                    Some(p) => *p,
                    None => f64::INFINITY,
                };
                Waveform::Pulse {
                    v1: self.finite(&k("v1"), *v1)?,
                    v2: self.finite(&k("v2"), *v2)?,
                    delay: self.finite(&k("delay"), *delay)?,
                    rise: self.non_negative(&k("rise"), *rise)?,
                    fall: self.non_negative(&k("fall"), *fall)?,
                    width: self.non_negative(&k("width"), *width)?,
                    period,
                }
            }
            WaveformSpec::Pwl(points) => {
                if points.is_empty() {
                    return Err(self.fail(&k("points"), 0.0, "must hold at least one point"));
                }
                for (i, p) in points.iter().enumerate() {
                    let at = format!("{key}.points[{i}]");
                    self.finite(&at, p[0])?;
                    self.finite(&at, p[1])?;
                    if i > 0 && p[0] < points[i - 1][0] {
                        return Err(self.fail(&at, p[0], "must not come before the previous time"));
                    }
                }
                Waveform::Pwl(points.iter().map(|p| (p[0], p[1])).collect())
            }
        })
    }
}

/// A part's subsystem and default initial positions.
fn part_subsystem(part: &Part) -> Result<(Subsystem, Vec<f64>), SceneError> {
    let c = Check {
        item: format!("part `{}` ({})", part.name, part.kind.type_name()),
        origin: &part.origin,
    };
    let name = part.name.clone();
    let zeros = |n: usize| vec![0.0; n];
    Ok(match &part.kind {
        PartKind::Resistor(p) => (
            Resistor {
                r: c.non_negative("r", p.r)?,
            }
            .subsystem(name),
            zeros(1),
        ),
        PartKind::Inductor(p) => (
            Inductor {
                l: c.positive("l", p.l)?,
            }
            .subsystem(name),
            zeros(1),
        ),
        PartKind::Capacitor(p) => (
            Capacitor {
                c: c.positive("c", p.c)?,
            }
            .subsystem(name),
            zeros(1),
        ),
        PartKind::VoltageSource(p) => (
            VoltageSource::new(c.waveform("waveform", &p.waveform)?).subsystem(name),
            zeros(1),
        ),
        PartKind::CurrentSource(p) => (
            CurrentSource::new(c.waveform("waveform", &p.waveform)?).subsystem(name),
            zeros(2),
        ),
        PartKind::CoupledInductors(p) => {
            if p.k.is_nan() || p.k.abs() > 1.0 {
                return Err(c.fail("k", p.k, "must lie in [-1, 1]"));
            }
            (
                CoupledInductors {
                    l1: c.positive("l1", p.l1)?,
                    l2: c.positive("l2", p.l2)?,
                    k: p.k,
                }
                .subsystem(name),
                zeros(2),
            )
        }
        PartKind::Diode(p) => (
            Diode {
                is: c.positive("is", p.is)?,
                n: c.positive("n", p.n)?,
                vt: c.positive("vt", p.vt)?,
                rs: c.non_negative("rs", p.rs)?,
            }
            .subsystem(name),
            zeros(2),
        ),
        PartKind::SaturatingInductor(p) => {
            let l0 = c.positive("l0", p.l0)?;
            let l_inf = c.non_negative("l_inf", p.l_inf)?;
            if l_inf > l0 {
                return Err(c.fail("l_inf", l_inf, "must not exceed `l0`"));
            }
            (
                SaturatingInductor {
                    l0,
                    l_inf,
                    i_sat: c.positive("i_sat", p.i_sat)?,
                }
                .subsystem(name),
                zeros(1),
            )
        }
        PartKind::Mass(p) => (
            Mass {
                m: c.positive("m", p.m)?,
                k: c.non_negative("k", p.k)?,
                c: c.non_negative("c", p.c)?,
            }
            .subsystem(name),
            zeros(1),
        ),
        PartKind::Inertia(p) => (
            Inertia {
                j: c.positive("j", p.j)?,
                k: c.non_negative("k", p.k)?,
                c: c.non_negative("c", p.c)?,
            }
            .subsystem(name),
            zeros(1),
        ),
        PartKind::Spring(p) => {
            let s = Spring {
                k: c.non_negative("k", p.k)?,
                k3: c.finite("k3", p.k3)?,
                rest: c.finite("rest", p.rest)?,
            };
            let sub = if p.rotational {
                s.rotational_subsystem(name)
            } else {
                s.subsystem(name)
            };
            (sub, zeros(1))
        }
        PartKind::Damper(p) => {
            let d = Damper {
                c: c.non_negative("c", p.c)?,
            };
            let sub = if p.rotational {
                d.rotational_subsystem(name)
            } else {
                d.subsystem(name)
            };
            (sub, zeros(1))
        }
        PartKind::ForceSource(p) => {
            let f = ForceSource::new(c.waveform("waveform", &p.waveform)?);
            let sub = if p.rotational {
                f.rotational_subsystem(name)
            } else {
                f.subsystem(name)
            };
            (sub, zeros(1))
        }
        PartKind::Ground(p) => {
            let g = Ground {
                position: c.finite("position", p.position)?,
            };
            let sub = if p.rotational {
                g.rotational_subsystem(name)
            } else {
                g.subsystem(name)
            };
            (sub, vec![g.position])
        }
        PartKind::Pendulum(p) => {
            let pendulum = Pendulum {
                m: c.positive("m", p.m)?,
                length: c.positive("length", p.length)?,
                g: c.finite("g", p.g)?,
                pivot: [
                    c.finite("pivot[0]", p.pivot[0])?,
                    c.finite("pivot[1]", p.pivot[1])?,
                ],
            };
            // At rest hanging straight down unless `q0` says otherwise.
            let hanging = pendulum.position(0.0).to_vec();
            (pendulum.subsystem(name), hanging)
        }
        PartKind::PlanarLinkage(p) => {
            let mut linkage = PlanarLinkage::new(c.finite("g", p.g)?);
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
                linkage.add_body(
                    b.name.clone(),
                    c.positive(&key("m"), b.m)?,
                    c.positive(&key("j"), b.j)?,
                );
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
            DcMotor {
                k: c.finite("k", p.k)?,
                r: c.non_negative("r", p.r)?,
                l: c.non_negative("l", p.l)?,
                j: c.non_negative("j", p.j)?,
                b: c.non_negative("b", p.b)?,
            }
            .subsystem(name),
            zeros(2),
        ),
        PartKind::IdealTransformer(p) => (
            IdealTransformer {
                n: c.nonzero("n", p.n)?,
            }
            .subsystem(name),
            zeros(2),
        ),
        PartKind::IdealGear(p) => (
            IdealGear {
                ratio: c.nonzero("ratio", p.ratio)?,
            }
            .subsystem(name),
            zeros(2),
        ),
        PartKind::RollingDisk(p) => (
            RollingDisk {
                m: c.positive("m", p.m)?,
                i: c.positive("i", p.i)?,
                j: c.positive("j", p.j)?,
                radius: c.positive("radius", p.radius)?,
            }
            .subsystem(name),
            zeros(4),
        ),
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
    let c = Check {
        item: format!("part `{}` ({})", part.name, part.kind.type_name()),
        origin: &part.origin,
    };
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
        c.finite(&path, *v)?;
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
            let zeros = vec![0.0; names.len()];
            let (q, gq) = initial(part, "q0", part.q0.as_ref(), &names, default_q)?;
            let (v, gv) = initial(part, "v0", part.v0.as_ref(), &names, zeros)?;
            q0.push(q);
            given_q.push(gq);
            v0.push(v);
            given_v.push(gv);
            graph.add_subsystem(subsystem)?;
        }

        let mut connections: HashMap<&str, (ConnectionId, &super::model::Connection)> =
            HashMap::new();
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
                ConnectionKind::Coupling { a, b, element } => {
                    let (pa, pb) = (port(a, c.origin.field("a"))?, port(b, c.origin.field("b"))?);
                    if pa == pb {
                        return Err(bad("couples a port to itself"));
                    }
                    let check = Check {
                        item: format!("coupling `{}`", c.name),
                        origin: &c.origin,
                    };
                    match element {
                        ElementSpec::Spring(s) => {
                            let k = check.non_negative("element.k", s.k)?;
                            let k3 = check.finite("element.k3", s.k3)?;
                            let rest = check.finite("element.rest", s.rest)?;
                            if k3 == 0.0 {
                                graph.coupling(c.name.clone(), pa, pb, LinearSpring { k, rest })
                            } else {
                                graph.coupling(c.name.clone(), pa, pb, Spring { k, k3, rest })
                            }
                        }
                        ElementSpec::Damper(d) => {
                            let damper = Damper {
                                c: check.non_negative("element.c", d.c)?,
                            };
                            graph.coupling(c.name.clone(), pa, pb, damper)
                        }
                        ElementSpec::ForceSource(f) => {
                            let w = check.waveform("element.waveform", &f.waveform)?;
                            graph.coupling(c.name.clone(), pa, pb, ForceSource::new(w))
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
            options: IntegratorOptions::new(discretisation, sim.h).scheme(scheme),
            execution,
            start,
            t_end: sim.t_end,
            signals,
        })
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
