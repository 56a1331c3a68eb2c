//! The interconnection graph: subsystems and connections between their ports (petgraph).

use std::collections::HashMap;
use std::sync::Arc;

use petgraph::graph::{NodeIndex, UnGraph};

use crate::coupling::CouplingElement;
use crate::error::GraphError;
use crate::memo::StructureMemo;
use crate::port_constraint::PortConstraint;
use crate::subsystem::Subsystem;

/// Handle of a subsystem in an [`Interconnection`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SubsystemId(pub usize);

/// Handle of a connection in an [`Interconnection`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ConnectionId(pub usize);

/// A port of a subsystem, resolved to indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PortRef {
    /// The subsystem.
    pub subsystem: SubsystemId,
    /// Index into the subsystem's ports.
    pub port: usize,
}

/// A connection between ports.
#[derive(Clone)]
pub enum Connection {
    /// An electrical node: `Σ sᵢ flowᵢ = 0` (KCL), `sᵢ = +1` for flow into the node.
    Node {
        /// Node name.
        name: String,
        /// `(port, sign)` pairs.
        ports: Vec<(PortRef, f64)>,
    },
    /// A rigid joint: `flow_a = flow_b`.
    Joint {
        /// Joint name.
        name: String,
        /// First port.
        a: PortRef,
        /// Second port.
        b: PortRef,
    },
    /// A coupling element acting on the two port coordinates.
    Coupling {
        /// Element name.
        name: String,
        /// First port.
        a: PortRef,
        /// Second port.
        b: PortRef,
        /// The element.
        element: Arc<dyn CouplingElement>,
    },
    /// A holonomic constraint `g(x) = 0` on the values of several ports (a joint between rigid
    /// bodies), enforced at position level.
    Holonomic {
        /// Constraint name.
        name: String,
        /// The ports whose values `x` the constraint reads, in its order.
        ports: Vec<PortRef>,
        /// The constraint.
        constraint: Arc<dyn PortConstraint>,
    },
}

/// Most ports a [`Connection::Holonomic`] may read (their values are gathered on the stack).
pub const MAX_CONSTRAINT_PORTS: usize = 32;

impl Connection {
    /// The connection's name.
    #[must_use]
    pub fn name(&self) -> &str {
        match self {
            Self::Node { name, .. }
            | Self::Joint { name, .. }
            | Self::Coupling { name, .. }
            | Self::Holonomic { name, .. } => name,
        }
    }

    /// The ports it touches.
    #[must_use]
    pub fn ports(&self) -> Vec<PortRef> {
        match self {
            Self::Node { ports, .. } => ports.iter().map(|(p, _)| *p).collect(),
            Self::Holonomic { ports, .. } => ports.clone(),
            Self::Joint { a, b, .. } | Self::Coupling { a, b, .. } => vec![*a, *b],
        }
    }
}

impl std::fmt::Debug for Connection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Node { name, ports } => f
                .debug_struct("Node")
                .field("name", name)
                .field("ports", ports)
                .finish(),
            Self::Joint { name, a, b } => f
                .debug_struct("Joint")
                .field("name", name)
                .field("a", a)
                .field("b", b)
                .finish(),
            Self::Coupling {
                name,
                a,
                b,
                element,
            } => f
                .debug_struct("Coupling")
                .field("name", name)
                .field("a", a)
                .field("b", b)
                .field("element", &element.describe())
                .finish(),
            Self::Holonomic {
                name,
                ports,
                constraint,
            } => f
                .debug_struct("Holonomic")
                .field("name", name)
                .field("ports", ports)
                .field("rows", &constraint.rows())
                .finish(),
        }
    }
}

/// Graph vertices: subsystems and connections (a bipartite graph, so a node joining many ports is
/// one vertex with many edges).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Vertex {
    Subsystem(SubsystemId),
    Connection(ConnectionId),
}

/// Subsystems joined at their ports.
#[derive(Debug, Clone, Default)]
pub struct Interconnection {
    subsystems: Vec<Subsystem>,
    connections: Vec<Connection>,
    by_name: HashMap<String, SubsystemId>,
    graph: UnGraph<Vertex, usize>,
    vertex_of_subsystem: Vec<NodeIndex>,
    memo: StructureMemo,
}

impl Interconnection {
    /// An empty interconnection.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a subsystem; its name must be unique and its ports must name existing coordinates.
    pub fn add_subsystem(&mut self, subsystem: Subsystem) -> Result<SubsystemId, GraphError> {
        if self.by_name.contains_key(&subsystem.name) {
            return Err(GraphError::DuplicateSubsystem(subsystem.name.clone()));
        }
        let dim = subsystem.model.dim();
        for port in &subsystem.ports {
            if let Some(&(coordinate, _)) = port.coefficients.iter().find(|(c, _)| *c >= dim) {
                return Err(GraphError::PortOutOfRange {
                    subsystem: subsystem.name.clone(),
                    port: port.name.clone(),
                    coordinate,
                    dim,
                });
            }
        }
        let id = SubsystemId(self.subsystems.len());
        self.memo = StructureMemo::default();
        self.by_name.insert(subsystem.name.clone(), id);
        self.vertex_of_subsystem
            .push(self.graph.add_node(Vertex::Subsystem(id)));
        self.subsystems.push(subsystem);
        Ok(id)
    }

    /// Analyses of this graph's structure stored by the run layer (see [`StructureMemo`]); shared
    /// with this graph's clones until either changes.
    #[must_use]
    pub fn memo(&self) -> &StructureMemo {
        &self.memo
    }

    /// Resolves `subsystem.port` names to a [`PortRef`].
    pub fn port(&self, subsystem: &str, port: &str) -> Result<PortRef, GraphError> {
        let &id = self
            .by_name
            .get(subsystem)
            .ok_or_else(|| GraphError::UnknownSubsystem(subsystem.to_string()))?;
        let index =
            self.subsystems[id.0]
                .port_index(port)
                .ok_or_else(|| GraphError::UnknownPort {
                    subsystem: subsystem.to_string(),
                    port: port.to_string(),
                })?;
        Ok(PortRef {
            subsystem: id,
            port: index,
        })
    }

    fn add_connection(&mut self, connection: Connection) -> ConnectionId {
        let id = ConnectionId(self.connections.len());
        self.memo = StructureMemo::default();
        let v = self.graph.add_node(Vertex::Connection(id));
        for p in connection.ports() {
            self.graph
                .add_edge(v, self.vertex_of_subsystem[p.subsystem.0], p.port);
        }
        self.connections.push(connection);
        id
    }

    /// An electrical node joining ports with signs (`+1`: the port's flow enters the node).
    pub fn node(
        &mut self,
        name: impl Into<String>,
        ports: Vec<(PortRef, f64)>,
    ) -> Result<ConnectionId, GraphError> {
        let name = name.into();
        if ports.len() < 2 {
            return Err(GraphError::TooFewPorts(name));
        }
        Ok(self.add_connection(Connection::Node { name, ports }))
    }

    /// A rigid joint: equal port flows.
    pub fn joint(&mut self, name: impl Into<String>, a: PortRef, b: PortRef) -> ConnectionId {
        self.add_connection(Connection::Joint {
            name: name.into(),
            a,
            b,
        })
    }

    /// A coupling element between two ports.
    pub fn coupling(
        &mut self,
        name: impl Into<String>,
        a: PortRef,
        b: PortRef,
        element: impl CouplingElement + 'static,
    ) -> ConnectionId {
        self.add_connection(Connection::Coupling {
            name: name.into(),
            a,
            b,
            element: Arc::new(element),
        })
    }

    /// A holonomic constraint `g(x) = 0` on the values `x` of `ports` (in that order), such as a
    /// joint between rigid bodies. Fails when it reads no port, more than
    /// [`MAX_CONSTRAINT_PORTS`], or has no rows.
    pub fn holonomic(
        &mut self,
        name: impl Into<String>,
        ports: Vec<PortRef>,
        constraint: impl PortConstraint + 'static,
    ) -> Result<ConnectionId, GraphError> {
        let name = name.into();
        if ports.is_empty() || ports.len() > MAX_CONSTRAINT_PORTS || constraint.rows() == 0 {
            return Err(GraphError::ConstraintShape {
                connection: name,
                ports: ports.len(),
                rows: constraint.rows(),
            });
        }
        Ok(self.add_connection(Connection::Holonomic {
            name,
            ports,
            constraint: Arc::new(constraint),
        }))
    }

    /// The subsystem named `name`.
    #[must_use]
    pub fn subsystem_id(&self, name: &str) -> Option<SubsystemId> {
        self.by_name.get(name).copied()
    }

    /// The connection named `name` (the first, if names repeat).
    #[must_use]
    pub fn connection_id(&self, name: &str) -> Option<ConnectionId> {
        self.connections
            .iter()
            .position(|c| c.name() == name)
            .map(ConnectionId)
    }

    /// The local index of the coordinate named `coordinate` of subsystem `id`.
    #[must_use]
    pub fn coordinate_index(&self, id: SubsystemId, coordinate: &str) -> Option<usize> {
        let model = self.subsystems.get(id.0)?.model();
        (0..model.dim()).find(|&i| model.coordinate_name(i) == coordinate)
    }

    /// The subsystems, in insertion order.
    #[must_use]
    pub fn subsystems(&self) -> &[Subsystem] {
        &self.subsystems
    }

    /// The connections, in insertion order.
    #[must_use]
    pub fn connections(&self) -> &[Connection] {
        &self.connections
    }

    /// Where each subsystem's coordinates start when all subsystems' coordinates are concatenated
    /// in insertion order (the layout of the assembled state's subsystem part).
    #[must_use]
    pub fn coordinate_offsets(&self) -> Vec<usize> {
        let mut offsets = Vec::with_capacity(self.subsystems.len());
        let mut o = 0;
        for s in &self.subsystems {
            offsets.push(o);
            o += s.model().dim();
        }
        offsets
    }

    /// The value of `port` (its combination of coordinates) in `values`, all subsystems'
    /// coordinates concatenated at `offsets` ([`Interconnection::coordinate_offsets`]).
    #[must_use]
    pub fn port_value(&self, offsets: &[usize], values: &[f64], port: PortRef) -> f64 {
        let o = offsets[port.subsystem.0];
        self.subsystems[port.subsystem.0].ports()[port.port]
            .coefficients
            .iter()
            .map(|&(i, c)| c * values[o + i])
            .sum()
    }

    /// The subsystems adjacent to `id` through some connection.
    #[must_use]
    pub fn neighbours(&self, id: SubsystemId) -> Vec<SubsystemId> {
        let mut out = Vec::new();
        for c in self.graph.neighbors(self.vertex_of_subsystem[id.0]) {
            for s in self.graph.neighbors(c) {
                if let Vertex::Subsystem(other) = self.graph[s]
                    && other != id
                    && !out.contains(&other)
                {
                    out.push(other);
                }
            }
        }
        out
    }

    /// Number of connected components of the graph (isolated subsystems count as components).
    #[must_use]
    pub fn component_count(&self) -> usize {
        petgraph::algo::connected_components(&self.graph)
    }
}

#[cfg(test)]
mod tests {
    //! Building a graph: names and ports are checked when they are given, and the queries
    //! (offsets, port values, neighbours, components) agree with the layout written out by hand.

    use super::*;
    use crate::coupling::LinearSpring;
    use dirac_core::{LagrangianHessian, Model};

    /// `n` free unit masses (`L = ½|v|²`).
    struct Free(usize);

    impl Model for Free {
        fn dim(&self) -> usize {
            self.0
        }
        fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
            0.5 * v.iter().map(|x| x * x).sum::<f64>()
        }
        fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
            lq.fill(0.0);
            lv.copy_from_slice(v);
        }
        fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
            for i in 0..self.0 {
                h.vv.add(i, i, 1.0);
            }
        }
    }

    fn part(name: &str, dim: usize) -> Subsystem {
        Subsystem::new(name, Free(dim))
    }

    /// The structure memo is shared by clones of an unchanged graph, and a graph that changes
    /// (a part or a connection added) starts an empty one while the clones made before keep
    /// theirs. Mutation: dropping the reset in `add_connection` leaves the stale entry in `g`
    /// after `joint`, and the second assertion on `g` fails.
    #[test]
    fn memo_is_shared_by_clones_and_dropped_on_change() {
        let mut g = Interconnection::new();
        let a = g.add_subsystem(part("a", 1).with_port("x", 0)).unwrap();
        let b = g.add_subsystem(part("b", 1).with_port("x", 0)).unwrap();
        let before = g.clone();
        g.memo().insert(std::sync::Arc::new(7_u32));
        assert_eq!(before.memo().find(|x: &u32| *x == 7).as_deref(), Some(&7));
        assert!(g.memo().find(|_: &u64| true).is_none(), "typed lookup");
        let (pa, pb) = (
            PortRef {
                subsystem: a,
                port: 0,
            },
            PortRef {
                subsystem: b,
                port: 0,
            },
        );
        g.joint("j", pa, pb);
        assert!(g.memo().is_empty(), "a changed graph keeps no analysis");
        assert_eq!(before.memo().len(), 1, "the earlier clone keeps its own");
        let mut h = before.clone();
        h.add_subsystem(part("c", 1)).unwrap();
        assert!(h.memo().is_empty());
    }

    #[test]
    fn names_and_ports_are_checked() {
        let mut g = Interconnection::new();
        g.add_subsystem(part("a", 2).with_port("x", 1)).unwrap();
        assert_eq!(
            g.add_subsystem(part("a", 1)),
            Err(GraphError::DuplicateSubsystem("a".into()))
        );
        assert_eq!(
            g.add_subsystem(part("b", 2).with_combination_port("y", vec![(0, 1.0), (2, 1.0)])),
            Err(GraphError::PortOutOfRange {
                subsystem: "b".into(),
                port: "y".into(),
                coordinate: 2,
                dim: 2
            })
        );
        assert_eq!(
            g.port("c", "x"),
            Err(GraphError::UnknownSubsystem("c".into()))
        );
        assert_eq!(
            g.port("a", "z"),
            Err(GraphError::UnknownPort {
                subsystem: "a".into(),
                port: "z".into()
            })
        );
        let x = g.port("a", "x").unwrap();
        assert_eq!(
            g.node("lonely", vec![(x, 1.0)]),
            Err(GraphError::TooFewPorts("lonely".into()))
        );
        // Failed additions leave nothing behind.
        assert_eq!(g.subsystems().len(), 1);
        assert!(g.connections().is_empty());
    }

    /// Four parts (dims 2, 1, 3, 1): a–b by a spring, b–c by a joint, d alone.
    #[test]
    fn layout_and_neighbours() {
        let mut g = Interconnection::new();
        g.add_subsystem(part("a", 2).with_combination_port("x", vec![(0, 2.0), (1, -1.0)]))
            .unwrap();
        g.add_subsystem(part("b", 1).with_port("x", 0)).unwrap();
        g.add_subsystem(part("c", 3).with_port("x", 2)).unwrap();
        g.add_subsystem(part("d", 1).with_port("x", 0)).unwrap();
        let port = |g: &Interconnection, s: &str| g.port(s, "x").unwrap();
        let (a, b, c) = (port(&g, "a"), port(&g, "b"), port(&g, "c"));
        let spring = g.coupling("s", a, b, LinearSpring { k: 1.0, rest: 0.0 });
        let joint = g.joint("j", b, c);
        assert_eq!((spring, joint), (ConnectionId(0), ConnectionId(1)));
        assert_eq!(g.connections()[1].name(), "j");
        assert_eq!(g.connections()[0].ports(), vec![a, b]);

        let offsets = g.coordinate_offsets();
        assert_eq!(offsets, vec![0, 2, 3, 6]);
        let values = [1.0, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0];
        assert_eq!(g.port_value(&offsets, &values, a), 2.0 * 1.0 - 3.0);
        assert_eq!(g.port_value(&offsets, &values, c), 13.0);
        assert_eq!(g.port_value(&offsets, &values, port(&g, "d")), 17.0);

        let mut nb = g.neighbours(SubsystemId(1));
        nb.sort();
        assert_eq!(nb, vec![SubsystemId(0), SubsystemId(2)]);
        assert_eq!(g.neighbours(SubsystemId(0)), vec![SubsystemId(1)]);
        assert!(g.neighbours(SubsystemId(3)).is_empty());
        // {a, b, c} and {d}.
        assert_eq!(g.component_count(), 2);
    }
}
