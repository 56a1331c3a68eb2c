//! Circuits written as a netlist reads: each branch between two named nodes, in terminal order.

use std::collections::HashMap;

use dirac_graph::{GraphError, Interconnection, PortRef, Subsystem, SubsystemId};

use crate::electrical::{Capacitor, CurrentSource, Inductor, Resistor, VoltageSource};
use crate::waveform::Waveform;

/// Builds an [`Interconnection`] of circuit parts from branches between named nodes, the way a
/// netlist reads: `c.resistor("R1", "1", "0", 10.0)?` is the card `R1 1 0 10`.
///
/// A branch's current flows from its first terminal through the part to its second (SPICE's
/// passive convention: for a source, from `+` through the source to `−`), so the part's port
/// enters the KCL row of its first node with sign `−1` and of its second with `+1`; this is the
/// one place that rule is written. Nodes `"0"` and `"gnd"` are ground, the reference: it gets no
/// KCL row (that row is the sum of the others). [`CircuitBuilder::build`] adds one KCL node per
/// other node, named after it, in the order the nodes first appear; the potential of node `n` is
/// then the effort of the connection named `n`.
///
/// ```
/// use dirac_components::CircuitBuilder;
///
/// let mut c = CircuitBuilder::new();
/// c.voltage_source("V1", "in", "0", 5.0.into())?;
/// c.resistor("R1", "in", "out", 1e3)?;
/// c.capacitor("C1", "out", "0", 1e-6)?;
/// let graph = c.build()?;
/// assert_eq!(graph.subsystems().len(), 3);
/// assert!(graph.connection_id("out").is_some());
/// assert!(graph.connection_id("0").is_none()); // ground has no KCL row
/// # Ok::<(), dirac_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, Default)]
#[must_use]
pub struct CircuitBuilder {
    graph: Interconnection,
    nodes: Vec<String>,
    terminals: HashMap<String, Vec<(PortRef, f64)>>,
}

impl CircuitBuilder {
    /// An empty circuit.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether `node` is ground (`0` or `gnd`, any case).
    #[must_use]
    pub fn is_ground(node: &str) -> bool {
        node == "0" || node.eq_ignore_ascii_case("gnd")
    }

    /// Adds a part without connecting it (connect its ports with [`CircuitBuilder::connect`]);
    /// returns its handle.
    ///
    /// # Errors
    /// [`GraphError::DuplicateSubsystem`] when the name is taken.
    pub fn add(&mut self, part: Subsystem) -> Result<SubsystemId, GraphError> {
        self.graph.add_subsystem(part)
    }

    /// Connects port `port` of part `part` between nodes `from` and `to`: its flow leaves `from`,
    /// runs through the part and enters `to`.
    ///
    /// # Errors
    /// [`GraphError::UnknownSubsystem`] or [`GraphError::UnknownPort`].
    pub fn connect(
        &mut self,
        part: &str,
        port: &str,
        from: &str,
        to: &str,
    ) -> Result<PortRef, GraphError> {
        let p = self.graph.port(part, port)?;
        for (node, sign) in [(from, -1.0), (to, 1.0)] {
            if Self::is_ground(node) {
                continue;
            }
            if !self.terminals.contains_key(node) {
                self.nodes.push(node.to_string());
            }
            self.terminals
                .entry(node.to_string())
                .or_default()
                .push((p, sign));
        }
        Ok(p)
    }

    /// Adds a two-terminal part (its port `i`) from node `from` to node `to`.
    ///
    /// # Errors
    /// A duplicate name.
    pub fn branch(
        &mut self,
        part: Subsystem,
        from: &str,
        to: &str,
    ) -> Result<SubsystemId, GraphError> {
        let name = part.name().to_string();
        let id = self.add(part)?;
        self.connect(&name, "i", from, to)?;
        Ok(id)
    }

    /// Resistor `name` of `r` ohms from `from` to `to` (SPICE `R`).
    ///
    /// # Errors
    /// [`GraphError::Part`] for a resistance out of range, or a duplicate name.
    pub fn resistor(
        &mut self,
        name: &str,
        from: &str,
        to: &str,
        r: f64,
    ) -> Result<SubsystemId, GraphError> {
        self.branch(Resistor::new(r)?.subsystem(name), from, to)
    }

    /// Inductor `name` of `l` henries from `from` to `to` (SPICE `L`).
    ///
    /// # Errors
    /// [`GraphError::Part`] for an inductance out of range, or a duplicate name.
    pub fn inductor(
        &mut self,
        name: &str,
        from: &str,
        to: &str,
        l: f64,
    ) -> Result<SubsystemId, GraphError> {
        self.branch(Inductor::new(l)?.subsystem(name), from, to)
    }

    /// Capacitor `name` of `c` farads from `from` to `to` (SPICE `C`); its charge `q` is that of
    /// the `from` plate.
    ///
    /// # Errors
    /// [`GraphError::Part`] for a capacitance out of range, or a duplicate name.
    pub fn capacitor(
        &mut self,
        name: &str,
        from: &str,
        to: &str,
        c: f64,
    ) -> Result<SubsystemId, GraphError> {
        self.branch(Capacitor::new(c)?.subsystem(name), from, to)
    }

    /// Voltage source `name` with `v(plus) − v(minus) = V(t)` (SPICE `V`); its current is SPICE's
    /// `I(V)`, into `plus` through the source.
    ///
    /// # Errors
    /// [`GraphError::Part`] for a waveform out of range, or a duplicate name.
    pub fn voltage_source(
        &mut self,
        name: &str,
        plus: &str,
        minus: &str,
        waveform: Waveform,
    ) -> Result<SubsystemId, GraphError> {
        self.branch(VoltageSource::new(waveform)?.subsystem(name), plus, minus)
    }

    /// Current source `name` driving `I(t)` from `plus` through the source to `minus` (SPICE `I`).
    ///
    /// # Errors
    /// [`GraphError::Part`] for a waveform out of range, or a duplicate name.
    pub fn current_source(
        &mut self,
        name: &str,
        plus: &str,
        minus: &str,
        waveform: Waveform,
    ) -> Result<SubsystemId, GraphError> {
        self.branch(CurrentSource::new(waveform)?.subsystem(name), plus, minus)
    }

    /// The interconnection: the parts, then one KCL node per non-ground node, in the order the
    /// nodes first appeared.
    ///
    /// # Errors
    /// [`GraphError::TooFewPorts`] for a node with a single terminal (a dangling branch).
    pub fn build(mut self) -> Result<Interconnection, GraphError> {
        for node in self.nodes {
            let ports = self.terminals.remove(&node).unwrap_or_default();
            self.graph.node(node, ports)?;
        }
        Ok(self.graph)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dirac_graph::Connection;

    /// The sign rule: a branch's port is `−1` in its first node's row and `+1` in its second's,
    /// ground gets no row, and nodes come in order of first appearance. Swapping a resistor's
    /// terminals flips both signs (the mutation the test would catch).
    #[test]
    fn terminal_order_sets_the_signs() {
        let mut c = CircuitBuilder::new();
        c.voltage_source("V1", "a", "0", Waveform::Dc(1.0)).unwrap();
        c.resistor("R1", "a", "b", 2.0).unwrap();
        c.capacitor("C1", "b", "gnd", 3.0).unwrap();
        let g = c.build().unwrap();
        let rows: Vec<(String, Vec<(usize, f64)>)> = g
            .connections()
            .iter()
            .map(|con| match con {
                Connection::Node { name, ports } => (
                    name.clone(),
                    ports.iter().map(|(p, s)| (p.subsystem.0, *s)).collect(),
                ),
                other => panic!("unexpected {other:?}"),
            })
            .collect();
        assert_eq!(
            rows,
            vec![
                ("a".to_string(), vec![(0, -1.0), (1, -1.0)]),
                ("b".to_string(), vec![(1, 1.0), (2, -1.0)]),
            ]
        );
    }

    /// A parameter out of range is refused by the part's constructor and names the parameter; a
    /// dangling branch leaves a node with one terminal.
    #[test]
    fn bad_values_and_dangling_nodes_are_errors() {
        let mut c = CircuitBuilder::new();
        let e = c.capacitor("C1", "1", "0", -1.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "capacitor: `c` = -1 must be positive and finite"
        );
        c.resistor("R1", "1", "0", 1.0).unwrap();
        c.resistor("R2", "1", "2", 1.0).unwrap();
        assert!(matches!(c.build(), Err(GraphError::TooFewPorts(n)) if n == "2"));
    }
}
