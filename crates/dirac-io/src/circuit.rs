//! A parsed netlist turned into an interconnection of stock parts, ready to simulate.

use std::collections::HashMap;

use dirac_components::{
    Capacitor, CoupledInductors, CurrentSource, Diode, DiodeParameters, Inductor, Resistor,
    VoltageSource, Waveform,
};
use dirac_graph::{GraphError, Interconnection, PortRef, Subsystem};
use thiserror::Error;

use crate::netlist::{Element, Netlist, SourceSpec};

/// A netlist that cannot be turned into a circuit model.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CircuitError {
    /// An inductor appears in more than one `K` card.
    #[error(
        "{file}:{line}:{column}: inductor `{inductor}` is coupled by more than one K card (not supported)"
    )]
    MultipleCoupling {
        /// File name.
        file: String,
        /// Line of the second K card.
        line: usize,
        /// Column.
        column: usize,
        /// The inductor.
        inductor: String,
    },
    /// The netlist has no `.tran` card and no step size was given.
    #[error("{file}: no .tran card: give the step and end time")]
    NoTran {
        /// File name.
        file: String,
    },
    /// A diode's model parameters cannot be used.
    #[error("diode `{element}`: {source}")]
    Diode {
        /// The diode.
        element: String,
        /// What is wrong with its model.
        source: dirac_components::DiodeError,
    },
    /// Assembling the graph failed.
    #[error(transparent)]
    Graph(#[from] GraphError),
}

/// What a recorded column measures.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SignalKind {
    /// Potential of a node (from its KCL multiplier).
    NodeVoltage {
        /// Index of the node's connection in the graph.
        connection: usize,
    },
    /// Current of a branch: the rate of its charge coordinate.
    BranchCurrent {
        /// Subsystem index.
        subsystem: usize,
        /// Local coordinate.
        coordinate: usize,
    },
    /// Charge of a capacitor.
    Charge {
        /// Subsystem index.
        subsystem: usize,
        /// Local coordinate.
        coordinate: usize,
    },
}

/// A named output column: `v(node)`, `i(name)` or `q(name)`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signal {
    /// Column header, e.g. `v(out)`.
    pub name: String,
    /// What it measures.
    pub kind: SignalKind,
}

/// A circuit built from a netlist: the graph, initial data and the output columns.
#[derive(Debug, Clone)]
pub struct Circuit {
    /// Parts (one subsystem per element; two coupled inductors form one part) joined by KCL nodes.
    pub graph: Interconnection,
    /// Initial positions per subsystem (capacitor charges from `IC=` or `.ic`).
    pub q0: Vec<Vec<f64>>,
    /// Initial rates per subsystem (inductor currents from `IC=`).
    pub v0: Vec<Vec<f64>>,
    /// Output columns in the contract's order: `v(node)` for every non-ground node, then `i(name)`
    /// for every inductor and voltage source, then `q(name)` for every capacitor.
    pub signals: Vec<Signal>,
    /// Step size from `.tran` (`TSTEP`).
    pub h: Option<f64>,
    /// End time from `.tran` (`TSTOP`).
    pub t_end: Option<f64>,
}

/// The runtime waveform of a parsed source.
#[must_use]
pub fn waveform(spec: &SourceSpec) -> Waveform {
    match spec {
        SourceSpec::Dc(v) => Waveform::Dc(*v),
        SourceSpec::Sin {
            vo,
            va,
            freq,
            td,
            theta,
            phase,
        } => Waveform::Sin {
            offset: *vo,
            amplitude: *va,
            frequency: *freq,
            delay: *td,
            damping: *theta,
            phase_deg: *phase,
        },
        SourceSpec::Pulse {
            v1,
            v2,
            td,
            tr,
            tf,
            pw,
            per,
        } => Waveform::Pulse {
            v1: *v1,
            v2: *v2,
            delay: *td,
            rise: *tr,
            fall: *tf,
            width: *pw,
            period: if *per > 0.0 { *per } else { f64::INFINITY },
        },
        SourceSpec::Pwl(points) => Waveform::Pwl(points.clone()),
    }
}

/// Where an element's branch lives: subsystem and port.
struct Branch {
    subsystem: usize,
    port: &'static str,
    coordinate: usize,
}

/// Builds the circuit of `netlist` (read from `file`).
pub fn build_circuit(netlist: &Netlist, file: &str) -> Result<Circuit, CircuitError> {
    // Inductors joined by a K card become one CoupledInductors part.
    let mut coupled: HashMap<&str, (usize, usize)> = HashMap::new();
    for (e, element) in netlist.elements.iter().enumerate() {
        if let Element::K { l1, l2, .. } = element {
            for (winding, l) in [l1, l2].into_iter().enumerate() {
                if coupled.insert(l.as_str(), (e, winding)).is_some() {
                    let origin = &netlist.origins[e];
                    return Err(CircuitError::MultipleCoupling {
                        file: file.to_string(),
                        line: origin.line,
                        column: origin.column,
                        inductor: l.clone(),
                    });
                }
            }
        }
    }
    let mut graph = Interconnection::new();
    let mut q0 = Vec::new();
    let mut v0 = Vec::new();
    let mut branches: HashMap<String, Branch> = HashMap::new();
    let mut k_subsystem: HashMap<usize, usize> = HashMap::new();

    let mut add = |graph: &mut Interconnection,
                   s: Subsystem,
                   q: Vec<f64>,
                   v: Vec<f64>|
     -> Result<usize, GraphError> {
        let id = graph.add_subsystem(s)?;
        q0.push(q);
        v0.push(v);
        Ok(id.0)
    };
    // K parts first need both inductor values: find them.
    for (e, element) in netlist.elements.iter().enumerate() {
        let Element::K { name, l1, l2, k } = element else {
            continue;
        };
        let ((v1, ic1), (v2, ic2)) = (
            netlist.inductor(l1).unwrap_or((0.0, None)),
            netlist.inductor(l2).unwrap_or((0.0, None)),
        );
        let part = CoupledInductors {
            l1: v1,
            l2: v2,
            k: *k,
        };
        let s = add(
            &mut graph,
            part.subsystem(name.clone()),
            vec![0.0, 0.0],
            vec![ic1.unwrap_or(0.0), ic2.unwrap_or(0.0)],
        )?;
        k_subsystem.insert(e, s);
    }
    for element in &netlist.elements {
        let (name, part, q, v): (&String, Subsystem, Vec<f64>, Vec<f64>) = match element {
            Element::R { name, value, .. } => (
                name,
                Resistor { r: *value }.subsystem(name.clone()),
                vec![0.0],
                vec![0.0],
            ),
            Element::L {
                name, value, ic, ..
            } => {
                if let Some(&(k, winding)) = coupled.get(name.as_str()) {
                    let subsystem = k_subsystem[&k];
                    let port = if winding == 0 { "i1" } else { "i2" };
                    branches.insert(
                        name.clone(),
                        Branch {
                            subsystem,
                            port,
                            coordinate: winding,
                        },
                    );
                    continue;
                }
                (
                    name,
                    Inductor { l: *value }.subsystem(name.clone()),
                    vec![0.0],
                    vec![ic.unwrap_or(0.0)],
                )
            }
            Element::C {
                name,
                n1,
                n2,
                value,
                ic,
            } => {
                let volts = netlist.capacitor_voltage(n1, n2, *ic).unwrap_or(0.0);
                (
                    name,
                    Capacitor { c: *value }.subsystem(name.clone()),
                    vec![value * volts],
                    vec![0.0],
                )
            }
            Element::V { name, source, .. } => (
                name,
                VoltageSource::new(waveform(source)).subsystem(name.clone()),
                vec![0.0],
                vec![0.0],
            ),
            Element::I { name, source, .. } => (
                name,
                CurrentSource::new(waveform(source)).subsystem(name.clone()),
                vec![0.0, 0.0],
                vec![0.0, 0.0],
            ),
            Element::D { name, model, .. } => {
                let card = DiodeParameters {
                    rs: model.rs,
                    ..DiodeParameters::new(model.is, model.n)
                };
                let diode = Diode::at_temperature(&card, 27.0)
                    .map_err(|e| CircuitError::Diode {
                        element: name.clone(),
                        source: e,
                    })?
                    .diode;
                (
                    name,
                    diode.subsystem(name.clone()),
                    vec![0.0, 0.0],
                    vec![0.0, 0.0],
                )
            }
            Element::K { .. } => continue,
        };
        let s = add(&mut graph, part, q, v)?;
        branches.insert(
            name.clone(),
            Branch {
                subsystem: s,
                port: "i",
                coordinate: 0,
            },
        );
    }
    // KCL at every non-ground node: a branch's flow leaves its first node and enters its second.
    let nodes = netlist.nodes();
    let mut terminals: HashMap<&str, Vec<(PortRef, f64)>> = HashMap::new();
    for element in &netlist.elements {
        let ends = element.terminals();
        let Some((a, b)) = ends else { continue };
        let branch = &branches[element.name()];
        let port = graph.port(graph.subsystems()[branch.subsystem].name(), branch.port)?;
        terminals.entry(a).or_default().push((port, -1.0));
        terminals.entry(b).or_default().push((port, 1.0));
    }
    let mut signals = Vec::new();
    for node in &nodes {
        let ports = terminals.remove(node.as_str()).unwrap_or_default();
        let connection = graph.node(node.clone(), ports)?;
        signals.push(Signal {
            name: format!("v({node})"),
            kind: SignalKind::NodeVoltage {
                connection: connection.0,
            },
        });
    }
    for element in &netlist.elements {
        if let Element::L { name, .. } | Element::V { name, .. } = element {
            let b = &branches[name];
            signals.push(Signal {
                name: format!("i({name})"),
                kind: SignalKind::BranchCurrent {
                    subsystem: b.subsystem,
                    coordinate: b.coordinate,
                },
            });
        }
    }
    for element in &netlist.elements {
        if let Element::C { name, .. } = element {
            let b = &branches[name];
            signals.push(Signal {
                name: format!("q({name})"),
                kind: SignalKind::Charge {
                    subsystem: b.subsystem,
                    coordinate: b.coordinate,
                },
            });
        }
    }
    Ok(Circuit {
        graph,
        q0,
        v0,
        signals,
        h: netlist.tran.as_ref().map(|t| t.tstep),
        t_end: netlist.tran.as_ref().map(|t| t.tstop),
    })
}
