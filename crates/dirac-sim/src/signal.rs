//! What a run records: named signals resolved against an interconnection, evaluated on the state at
//! each output time.

use dirac_graph::{Connection, ConnectionId, Interconnection, PortRef, SubsystemId};

use crate::simulation::RunError;

/// What a recorded column measures. Every probe is a value at `t_k` computed from the state
/// `(q_k, v_k, λ_k, t_k)` (see [`crate::Readout`]), the same in every representation.
#[derive(Debug, Clone, PartialEq)]
pub enum Probe {
    /// A coordinate of a part: a charge, a position, an angle.
    Position {
        /// The part.
        part: SubsystemId,
        /// Its local coordinate.
        coordinate: usize,
    },
    /// The discrete momentum `p_k` conjugate to a coordinate (a flux linkage, a linear or angular
    /// momentum): the state variable the integrator carries, so conserved momenta are read
    /// without the readout's Legendre solve (MATH: `p_k = −D₁L_d − f_d⁻`, `p_{k+1} = D₂L_d + f_d⁺`).
    Momentum {
        /// The part.
        part: SubsystemId,
        /// Its local coordinate.
        coordinate: usize,
    },
    /// The rate of a coordinate: a current, a velocity.
    Velocity {
        /// The part.
        part: SubsystemId,
        /// Its local coordinate.
        coordinate: usize,
    },
    /// The flow of a port (its combination of rates): a branch current, a point's velocity.
    Flow(PortRef),
    /// The multiplier of a node or joint: a node's potential; for a joint, the force its first
    /// port exerts on its second (the second port feels `+λ`, the first `−λ`).
    Effort(ConnectionId),
    /// Total energy: `Σ (v·∂L/∂v − L)` over the parts plus the coupling potentials.
    Energy,
    /// The power of a part's own forces, `f·v` (negative when it dissipates).
    Power(SubsystemId),
    /// The largest discrete constraint residual of the step that arrived at `t_k` (0 at `t_0`).
    ConstraintResidual,
    /// The force a coupling element exerts on its first port, `−∂V/∂x_a + f_a`.
    CouplingForce(ConnectionId),
    /// A linear combination of probes (`v(a,b)`, a sign flip).
    Sum(Vec<(Probe, f64)>),
    /// A constant (the ground node's potential).
    Constant(f64),
    /// The product of two probes (a rigid body's angular velocity `vee(Ṙ Rᵀ)` is a sum of
    /// products of rotation entries and their rates).
    Product(Box<Probe>, Box<Probe>),
    /// The Euclidean length `√(Σ xᵢ²)` of probes (a point's distance from the origin, a
    /// pendulum's length), accumulated with `hypot` so that it neither overflows nor underflows.
    Norm(Vec<Probe>),
    /// The angle `atan2(y, x)` of two probes, in `(−π, π]` (a joint's angle from the dot products
    /// of its frames' axes).
    Atan2 {
        /// The sine side.
        y: Box<Probe>,
        /// The cosine side.
        x: Box<Probe>,
    },
}

/// A recorded column: its name and what it measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Column header, e.g. `v(out)` or `C1.q`.
    pub name: String,
    /// What it measures.
    pub probe: Probe,
}

impl Signal {
    /// A signal named `name` measuring `probe`.
    #[must_use]
    pub fn new(name: impl Into<String>, probe: Probe) -> Self {
        Self {
            name: name.into(),
            probe,
        }
    }
}

impl Probe {
    /// The coordinate `coordinate` (by name) of part `part` (by name).
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] naming the part or coordinate that does not exist.
    pub fn position(
        graph: &Interconnection,
        part: &str,
        coordinate: &str,
    ) -> Result<Self, RunError> {
        let (part, coordinate) = coordinate_of(graph, part, coordinate)?;
        Ok(Self::Position { part, coordinate })
    }

    /// The momentum conjugate to coordinate `coordinate` of part `part`.
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] naming the part or coordinate that does not exist.
    pub fn momentum(
        graph: &Interconnection,
        part: &str,
        coordinate: &str,
    ) -> Result<Self, RunError> {
        let (part, coordinate) = coordinate_of(graph, part, coordinate)?;
        Ok(Self::Momentum { part, coordinate })
    }

    /// The rate of coordinate `coordinate` of part `part`.
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] naming the part or coordinate that does not exist.
    pub fn velocity(
        graph: &Interconnection,
        part: &str,
        coordinate: &str,
    ) -> Result<Self, RunError> {
        let (part, coordinate) = coordinate_of(graph, part, coordinate)?;
        Ok(Self::Velocity { part, coordinate })
    }

    /// The flow of port `port` of part `part`.
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] naming the part or port that does not exist.
    pub fn flow(graph: &Interconnection, part: &str, port: &str) -> Result<Self, RunError> {
        graph
            .port(part, port)
            .map(Self::Flow)
            .map_err(|e| RunError::UnknownSignal(e.to_string()))
    }

    /// The multiplier of the node or joint named `connection` (of the first row of a holonomic
    /// constraint, e.g. the torque of a joint-angle coupling), or the force of a coupling.
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] when there is no such connection.
    pub fn effort(graph: &Interconnection, connection: &str) -> Result<Self, RunError> {
        let id = graph
            .connection_id(connection)
            .ok_or_else(|| RunError::UnknownSignal(format!("no connection `{connection}`")))?;
        match graph.connections()[id.0] {
            Connection::Node { .. } | Connection::Joint { .. } | Connection::Holonomic { .. } => {
                Ok(Self::Effort(id))
            }
            Connection::Coupling { .. } => Ok(Self::CouplingForce(id)),
        }
    }

    /// The power of part `part`.
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] when there is no such part.
    pub fn power(graph: &Interconnection, part: &str) -> Result<Self, RunError> {
        graph
            .subsystem_id(part)
            .map(Self::Power)
            .ok_or_else(|| RunError::UnknownSignal(format!("no part `{part}`")))
    }

    /// Whether evaluating this probe needs the multipliers of an assembled system.
    #[must_use]
    pub fn needs_multipliers(&self) -> bool {
        match self {
            Self::Effort(_) => true,
            Self::Sum(terms) => terms.iter().any(|(p, _)| p.needs_multipliers()),
            Self::Norm(terms) => terms.iter().any(Self::needs_multipliers),
            Self::Product(a, b) | Self::Atan2 { y: a, x: b } => {
                a.needs_multipliers() || b.needs_multipliers()
            }
            _ => false,
        }
    }

    /// Whether evaluating this probe reads a momentum (recorded rows copy the momenta only
    /// then).
    #[must_use]
    pub fn reads_momenta(&self) -> bool {
        match self {
            Self::Momentum { .. } => true,
            Self::Sum(terms) => terms.iter().any(|(p, _)| p.reads_momenta()),
            Self::Norm(terms) => terms.iter().any(Self::reads_momenta),
            Self::Product(a, b) | Self::Atan2 { y: a, x: b } => {
                a.reads_momenta() || b.reads_momenta()
            }
            _ => false,
        }
    }

    /// Calls `velocity(global subsystem coordinate)` and `multiplier(connection)` for every
    /// velocity and multiplier this probe reads.
    pub(crate) fn visit(
        &self,
        graph: &Interconnection,
        offsets: &[usize],
        velocity: &mut impl FnMut(usize),
        multiplier: &mut impl FnMut(ConnectionId),
    ) {
        match self {
            Self::Velocity { part, coordinate } => velocity(offsets[part.0] + coordinate),
            Self::Flow(port) => {
                for &(i, _) in &graph.subsystems()[port.subsystem.0].ports()[port.port].coefficients
                {
                    velocity(offsets[port.subsystem.0] + i);
                }
            }
            Self::Effort(c) => multiplier(*c),
            Self::Energy => {
                let total: usize = graph.subsystems().iter().map(|s| s.model().dim()).sum();
                (0..total).for_each(&mut *velocity);
            }
            Self::Power(part) => {
                let o = offsets[part.0];
                (o..o + graph.subsystems()[part.0].model().dim()).for_each(&mut *velocity);
            }
            Self::CouplingForce(c) => {
                for p in graph.connections()[c.0].ports() {
                    for &(i, _) in &graph.subsystems()[p.subsystem.0].ports()[p.port].coefficients {
                        velocity(offsets[p.subsystem.0] + i);
                    }
                }
            }
            Self::Sum(terms) => {
                for (p, _) in terms {
                    p.visit(graph, offsets, velocity, multiplier);
                }
            }
            Self::Norm(terms) => {
                for p in terms {
                    p.visit(graph, offsets, velocity, multiplier);
                }
            }
            Self::Product(a, b) | Self::Atan2 { y: a, x: b } => {
                a.visit(graph, offsets, velocity, multiplier);
                b.visit(graph, offsets, velocity, multiplier);
            }
            Self::Position { .. }
            | Self::Momentum { .. }
            | Self::ConstraintResidual
            | Self::Constant(_) => {}
        }
    }
}

fn coordinate_of(
    graph: &Interconnection,
    part: &str,
    coordinate: &str,
) -> Result<(SubsystemId, usize), RunError> {
    let id = graph
        .subsystem_id(part)
        .ok_or_else(|| RunError::UnknownSignal(format!("no part `{part}`")))?;
    let c = graph.coordinate_index(id, coordinate).ok_or_else(|| {
        let model = graph.subsystems()[id.0].model();
        let names: Vec<String> = (0..model.dim()).map(|i| model.coordinate_name(i)).collect();
        RunError::UnknownSignal(format!(
            "part `{part}` has no coordinate `{coordinate}` (it has {})",
            names.join(", ")
        ))
    })?;
    Ok((id, c))
}

/// The state at one output time, in subsystem coordinates (every representation gives the same
/// layout): what probes are evaluated on.
#[derive(Debug, Clone, Default)]
pub struct Snapshot {
    /// `t_k`.
    pub t: f64,
    /// Positions of every part, concatenated in graph order.
    pub q: Vec<f64>,
    /// Velocities of every part, concatenated in graph order.
    pub v: Vec<f64>,
    /// Discrete momenta of every part, concatenated in graph order (endpoint momenta of the
    /// constraint representation pulled back to their partner ports).
    pub p: Vec<f64>,
    /// The multiplier of each connection that has a constraint row (`None` otherwise).
    pub efforts: Vec<Option<f64>>,
    /// The constraint residual of the step that arrived here.
    pub residual: f64,
}

impl Snapshot {
    /// Evaluates `probe` on this state.
    #[must_use]
    pub fn evaluate(&self, graph: &Interconnection, offsets: &[usize], probe: &Probe) -> f64 {
        match probe {
            Probe::Position { part, coordinate } => self.q[offsets[part.0] + coordinate],
            Probe::Momentum { part, coordinate } => self.p[offsets[part.0] + coordinate],
            Probe::Velocity { part, coordinate } => self.v[offsets[part.0] + coordinate],
            Probe::Flow(port) => graph.port_value(offsets, &self.v, *port),
            Probe::Effort(c) => self.efforts.get(c.0).copied().flatten().unwrap_or(0.0),
            Probe::Energy => energy(graph, offsets, &self.q, &self.v),
            Probe::Power(part) => power(graph, offsets, *part, &self.q, &self.v, self.t),
            Probe::ConstraintResidual => self.residual,
            Probe::CouplingForce(c) => coupling_force(graph, offsets, *c, &self.q, &self.v, self.t),
            Probe::Sum(terms) => terms
                .iter()
                .map(|(p, k)| k * self.evaluate(graph, offsets, p))
                .sum(),
            Probe::Norm(terms) => terms
                .iter()
                .fold(0.0, |r, p| r.hypot(self.evaluate(graph, offsets, p))),
            Probe::Constant(value) => *value,
            Probe::Product(a, b) => {
                self.evaluate(graph, offsets, a) * self.evaluate(graph, offsets, b)
            }
            Probe::Atan2 { y, x } => self
                .evaluate(graph, offsets, y)
                .atan2(self.evaluate(graph, offsets, x)),
        }
    }
}

/// `Σ_parts (v·∂L/∂v − L)(q, v) + Σ_couplings V(x_a, x_b)`.
fn energy(graph: &Interconnection, offsets: &[usize], q: &[f64], v: &[f64]) -> f64 {
    let mut total = 0.0;
    let mut lq = Vec::new();
    let mut lv = Vec::new();
    for (s, &o) in graph.subsystems().iter().zip(offsets) {
        let model = s.model();
        let n = model.dim();
        lq.resize(n, 0.0);
        lv.resize(n, 0.0);
        let (q, v) = (&q[o..o + n], &v[o..o + n]);
        model.lagrangian_gradient(q, v, &mut lq, &mut lv);
        let pv: f64 = lv.iter().zip(v).map(|(p, w)| p * w).sum();
        total += pv - model.lagrangian(q, v);
    }
    for connection in graph.connections() {
        if let Connection::Coupling { a, b, element, .. } = connection
            && element.has_potential()
        {
            let x = |p| graph.port_value(offsets, q, p);
            total += element.potential(x(*a), x(*b));
        }
    }
    total
}

/// `f(q, v, t)·v` of one part's own forces.
fn power(
    graph: &Interconnection,
    offsets: &[usize],
    part: SubsystemId,
    q: &[f64],
    v: &[f64],
    t: f64,
) -> f64 {
    let model = graph.subsystems()[part.0].model();
    if !model.has_force() {
        return 0.0;
    }
    let (o, n) = (offsets[part.0], model.dim());
    let mut f = vec![0.0; n];
    model.force(&q[o..o + n], &v[o..o + n], t, &mut f);
    f.iter().zip(&v[o..o + n]).map(|(f, v)| f * v).sum()
}

/// Force of a coupling element on its first port: `−∂V/∂x_a + f_a`.
fn coupling_force(
    graph: &Interconnection,
    offsets: &[usize],
    c: ConnectionId,
    q: &[f64],
    v: &[f64],
    t: f64,
) -> f64 {
    let Connection::Coupling { a, b, element, .. } = &graph.connections()[c.0] else {
        return 0.0;
    };
    let at = |values: &[f64], p| graph.port_value(offsets, values, p);
    let x = [at(q, *a), at(q, *b)];
    let w = [at(v, *a), at(v, *b)];
    let mut f = 0.0;
    if element.has_potential() {
        f -= element.potential_gradient(x[0], x[1])[0];
    }
    if element.has_force() {
        f += element.force(x, w, t)[0];
    }
    f
}
