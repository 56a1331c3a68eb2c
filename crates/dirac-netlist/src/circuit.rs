//! A parsed netlist turned into an interconnection of stock parts, ready to simulate.

use std::collections::HashMap;

use dirac_components::{
    BehaviouralSource, Capacitor, Cccs, Ccvs, CircuitBuilder, Control, CoupledInductors,
    CurrentSource, Diode, DiodeParameters, Inductor, PartError, Resistor, Vccs, Vcvs,
    VoltageSource, Waveform,
};
use dirac_core::Model;
use dirac_graph::{ConnectionId, GraphError, Interconnection, PortRef, Subsystem, SubsystemId};
use dirac_sim::{
    Discretisation, Execution, IntegratorOptions, Probe, RunError, Signal, Simulation, Start,
    TruncationControl,
};
use thiserror::Error;

use crate::{ControlledSource, Element, Measure, Netlist, OptionCard, Sensing, SourceSpec, Tran};

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
    /// A signal names a node or element the circuit does not have, or is not of a known form.
    #[error("unknown signal `{signal}`: {reason}")]
    UnknownSignal {
        /// The signal as written.
        signal: String,
        /// Why, with what is available.
        reason: String,
    },
    /// A `.print`/`.probe`/`.save` signal that cannot be recorded.
    #[error("{file}:{line}:{column}: {message}")]
    BadOutput {
        /// File name.
        file: String,
        /// Line.
        line: usize,
        /// Column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// An element's value is outside what its part accepts (a negative capacitance, a waveform
    /// value that is not finite).
    #[error("{file}:{line}:{column}: element `{element}`: {source}")]
    Part {
        /// File name.
        file: String,
        /// Line of the element's card.
        line: usize,
        /// Column.
        column: usize,
        /// The element as written.
        element: String,
        /// What the part's constructor refused.
        source: Box<PartError>,
    },
    /// A controlled source senses a node that no element's current reaches: the sensing branch
    /// draws no current, so nothing fixes that node's voltage (ngspice: "singular matrix").
    #[error(
        "{file}:{line}:{column}: `{element}` senses node `{node}`, which no element connects to the circuit, so its voltage is not defined"
    )]
    SensedOnly {
        /// File name.
        file: String,
        /// Line of the controlled source's card.
        line: usize,
        /// Column.
        column: usize,
        /// The controlled source as written.
        element: String,
        /// The node.
        node: String,
    },
    /// Voltage sources (`V`, and `E`, `H` and `B … V=` outputs) in a loop: their voltages around
    /// it are fixed twice and their currents by nothing (ngspice: "singular matrix").
    #[error(
        "{file}:{line}:{column}: `{element}` closes a loop of voltage sources ({members}): their \
         currents are not determined (the voltages around the loop are fixed twice); put a \
         resistor in the loop or remove one of them"
    )]
    VoltageLoop {
        /// File name.
        file: String,
        /// Line of the card that closes the loop.
        line: usize,
        /// Column.
        column: usize,
        /// That element as written.
        element: String,
        /// The loop's elements as written, in order around it.
        members: String,
    },
    /// A diode's model parameters cannot be used.
    #[error("diode `{element}`: {source}")]
    Diode {
        /// The diode.
        element: String,
        /// What is wrong with its model.
        source: dirac_components::DiodeError,
    },
    /// An `.options`/`.temp` value that is not a number or is out of range.
    #[error("{file}:{line}:{column}: {message}")]
    BadOption {
        /// File name.
        file: String,
        /// Line.
        line: usize,
        /// Column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Assembling the graph failed.
    #[error(transparent)]
    Graph(#[from] GraphError),
}

/// The device conditions `.temp` and `.options temp= tnom= gmin=` set (ngspice's defaults:
/// 27 °C, 27 °C, 1e-12 S).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceConditions {
    /// Circuit temperature (°C).
    pub temp: f64,
    /// Nominal temperature of models that do not give `TNOM` (°C).
    pub tnom: f64,
    /// Conductance across every junction (S).
    pub gmin: f64,
}

impl DeviceConditions {
    /// Reads `temp`, `tnom` and `gmin` from the netlist's options (a `.temp` card is the option
    /// `temp`; the last value given counts).
    ///
    /// # Errors
    /// A value that is not a number, a temperature below absolute zero or a negative `gmin`.
    pub fn read(netlist: &Netlist, file: &str) -> Result<Self, CircuitError> {
        let mut out = Self {
            temp: 27.0,
            tnom: 27.0,
            gmin: Diode::GMIN,
        };
        for option in &netlist.options {
            let key = option.key.as_str();
            if !DEVICE_OPTIONS.contains(&key) {
                continue;
            }
            let fail = |message| bad_option(netlist.file_of(option.pos, file), option, message);
            let text = option.value.as_deref().unwrap_or("");
            let value = crate::parse_spice_number(text)
                .ok_or_else(|| fail(format!("`{key}` needs a number, got `{text}`")))?;
            // MOSFET geometry defaults, applied when the netlist is flattened.
            match crate::flatten::mos_default_check(key, value) {
                Some(Ok(())) => continue,
                Some(Err(requirement)) => {
                    return Err(fail(format!("{key} = {value} {requirement}")));
                }
                None => {}
            }
            match key {
                "gmin" if value >= 0.0 => out.gmin = value,
                "gmin" => return Err(fail(format!("gmin = {value} must not be negative"))),
                _ if value <= -273.15 => {
                    return Err(fail(format!(
                        "{key} = {value} °C is at or below absolute zero"
                    )));
                }
                "temp" => out.temp = value,
                _ => out.tnom = value,
            }
        }
        Ok(out)
    }
}

/// Refuses a loop of voltage-defined branches (`V`, and `E`, `H`, `B … V=` outputs), naming the
/// card that closes it and the loop: the branches are joined one by one, and one whose nodes
/// are already joined through earlier ones closes a loop along that path.
fn voltage_loops(netlist: &Netlist) -> Result<(), CircuitError> {
    // Adjacency of the voltage branches kept so far: node → (neighbour, element index).
    let mut joined: HashMap<&str, Vec<(&str, usize)>> = HashMap::new();
    for (e, element) in netlist.elements.iter().enumerate() {
        let voltage = match element {
            Element::V { .. } => true,
            Element::Controlled { source, .. } => source.drives_voltage(),
            _ => false,
        };
        let Some((a, b)) = element.terminals().filter(|_| voltage) else {
            continue;
        };
        if let Some(path) = branch_path(&joined, a, b) {
            let origin = &netlist.origins[e];
            let members: Vec<&str> = path
                .iter()
                .chain(std::iter::once(&e))
                .map(|&k| netlist.origins[k].name.as_str())
                .collect();
            return Err(CircuitError::VoltageLoop {
                file: origin.file.clone(),
                line: origin.line,
                column: origin.column,
                element: origin.name.clone(),
                members: members.join(", "),
            });
        }
        join(&mut joined, a, b, e);
    }
    Ok(())
}

/// Adds branch `e` between nodes `a` and `b` to the adjacency `joined`.
fn join<'a>(
    joined: &mut HashMap<&'a str, Vec<(&'a str, usize)>>,
    a: &'a str,
    b: &'a str,
    e: usize,
) {
    joined.entry(a).or_default().push((b, e));
    joined.entry(b).or_default().push((a, e));
}

/// The elements along a path of `joined` branches (node → neighbour and element index) from
/// `from` to `to` (breadth first), if any (empty when the nodes are the same).
fn branch_path(
    joined: &HashMap<&str, Vec<(&str, usize)>>,
    from: &str,
    to: &str,
) -> Option<Vec<usize>> {
    let mut came: HashMap<&str, Option<(&str, usize)>> = HashMap::from([(from, None)]);
    let mut queue = std::collections::VecDeque::from([from]);
    while let Some(node) = queue.pop_front() {
        if node == to {
            let mut path = Vec::new();
            let mut at = node;
            while let Some(Some((previous, e))) = came.get(at).copied() {
                path.push(e);
                at = previous;
            }
            return Some(path);
        }
        for &(next, e) in joined.get(node).map_or(&[][..], Vec::as_slice) {
            if !came.contains_key(next) {
                came.insert(next, Some((node, e)));
                queue.push_back(next);
            }
        }
    }
    None
}

/// The error for an `.options` value, at the card's position.
fn bad_option(file: String, option: &OptionCard, message: String) -> CircuitError {
    CircuitError::BadOption {
        file,
        line: option.pos.line,
        column: option.pos.column,
        message,
    }
}

/// A circuit built from a netlist: the parts joined at their nodes, the initial state, the signals
/// to record and the analyses the netlist asks for.
#[derive(Debug, Clone)]
pub struct Circuit {
    /// Parts (one subsystem per element; two coupled inductors form one part) joined by KCL nodes
    /// (every non-ground node; ground is the reference and has no row).
    pub graph: Interconnection,
    /// Initial positions per part (capacitor charges from `IC=` or `.ic`).
    pub q0: Vec<Vec<f64>>,
    /// Initial rates per part (inductor currents from `IC=`).
    pub v0: Vec<Vec<f64>>,
    /// Which initial positions were stated (a capacitor's `IC=` or `.ic` on both its nodes).
    pub given_q: Vec<Vec<bool>>,
    /// Which initial rates were stated (an inductor's `IC=`).
    pub given_v: Vec<Vec<bool>>,
    /// The signals to record: those of `.print`/`.probe`/`.save` if any, else the contract's
    /// default: `v(<node>)` for every non-ground node, `i(<name>)` for every inductor and voltage
    /// source (`V`, and the controlled `E` and `H`), `q(<name>)` for every capacitor.
    pub signals: Vec<Signal>,
    /// The `.tran` card, if any.
    pub tran: Option<Tran>,
    /// The `.meas` cards of the transient; every signal they read is one of the circuit's.
    pub measures: Vec<Measure>,
    /// Whether the netlist asks for the operating point (`.op`).
    pub op: bool,
    /// Node potentials `.ic` holds while the operating point is solved (without `UIC`).
    pub holds: Vec<(ConnectionId, f64)>,
    /// The discretisation `.options method=` maps to, if any.
    pub method: Option<Discretisation>,
    /// The truncation-error tolerances of `.options reltol= abstol= chgtol= trtol=` (SPICE's
    /// defaults otherwise); whether a run uses them by default is
    /// [`Circuit::default_truncation`].
    pub truncation: TruncationControl,
    /// Temperature and `GMIN` of the diodes.
    pub conditions: DeviceConditions,
    /// Notes on what the netlist asks that dirac does differently (`.options` it does not use,
    /// diode parameters limited at the circuit temperature).
    pub warnings: Vec<String>,
    defaults: Vec<Signal>,
    diodes: Vec<(String, SubsystemId, Diode)>,
    nodes: HashMap<String, ConnectionId>,
    branches: HashMap<String, Branch>,
    capacitors: Vec<String>,
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
            np,
        } => Waveform::Pulse {
            v1: *v1,
            v2: *v2,
            delay: *td,
            rise: *tr,
            fall: *tf,
            width: *pw,
            period: if *per > 0.0 { *per } else { f64::INFINITY },
            pulses: if *np > 0.0 { *np } else { f64::INFINITY },
        },
        SourceSpec::Exp {
            v1,
            v2,
            td1,
            tau1,
            td2,
            tau2,
        } => Waveform::Exp {
            v1: *v1,
            v2: *v2,
            rise_delay: *td1,
            rise_tau: *tau1,
            fall_delay: *td2,
            fall_tau: *tau2,
        },
        SourceSpec::Sffm {
            vo,
            va,
            fc,
            mdi,
            fs,
            phasec,
            phases,
        } => Waveform::Sffm {
            offset: *vo,
            amplitude: *va,
            carrier: *fc,
            index: *mdi,
            signal: *fs,
            carrier_phase_deg: *phasec,
            signal_phase_deg: *phases,
        },
        SourceSpec::Am {
            va,
            vo,
            mf,
            fc,
            td,
            phases,
            ..
        } => Waveform::Am {
            amplitude: *va,
            offset: *vo,
            modulation: *mf,
            carrier: *fc,
            delay: *td,
            phase_deg: *phases,
        },
        SourceSpec::Pwl { points, td, r } => Waveform::Pwl {
            points: points.clone(),
            delay: *td,
            repeat: *r,
        },
    }
}

/// Where an element's branch lives: subsystem, port and coordinate.
#[derive(Debug, Clone)]
struct Branch {
    subsystem: usize,
    port: &'static str,
    coordinate: usize,
    /// Whether the element is a capacitor (it has a charge signal `q(name)`).
    capacitor: bool,
}

impl Circuit {
    /// The start the netlist asks for: the given values with `UIC`, else the operating point.
    #[must_use]
    pub fn start(&self) -> Start {
        if self.tran.is_some_and(|t| t.uic) {
            Start::Given
        } else {
            Start::SteadyState
        }
    }

    /// The step and end time of `.tran`, if any.
    #[must_use]
    pub fn tran_settings(&self) -> Option<(f64, f64)> {
        self.tran.map(|t| (t.tstep, t.tstop))
    }

    /// A simulation of this circuit with the netlist's start, initial values and `.ic` holds.
    ///
    /// # Errors
    /// When the initial values do not fit the parts (a programming error of this crate).
    pub fn simulation(
        &self,
        execution: Execution,
        options: IntegratorOptions,
        start: Start,
    ) -> Result<Simulation, RunError> {
        let mut sim = Simulation::new(self.graph.clone(), execution, options).start(start);
        sim.set_initial(&self.q0, &self.v0, &self.given_q, &self.given_v)?;
        for &(c, v) in &self.holds {
            sim.hold(c, v);
        }
        Ok(sim)
    }

    /// The signals of the operating point: `v(<node>)` for every non-ground node, `i(<name>)`
    /// for every inductor and voltage source (as SPICE's `.op` prints them), then those of
    /// `.print`/`.probe`/`.save` not among them (`i(d1)`, `v(a,b)`).
    #[must_use]
    pub fn operating_point_signals(&self) -> Vec<Signal> {
        let mut out: Vec<Signal> = self
            .defaults
            .iter()
            .filter(|s| !s.name.starts_with("q("))
            .cloned()
            .collect();
        for signal in &self.signals {
            if !out.iter().any(|s| s.name == signal.name) {
                out.push(signal.clone());
            }
        }
        out
    }

    /// The truncation-error control a run uses unless told otherwise: on for a circuit with
    /// diodes, whose switching instants need the short steps SPICE's step control takes there;
    /// off for a linear circuit, whose midpoint steps at `h` already have the trapezoid rule's
    /// error at the same step.
    #[must_use]
    pub fn default_truncation(&self) -> Option<TruncationControl> {
        (!self.diodes.is_empty()).then_some(self.truncation)
    }

    /// The diodes as built (at the circuit's temperature, with its `GMIN`): element name, part
    /// and device, in card order.
    pub fn diodes(&self) -> impl Iterator<Item = (&str, SubsystemId, &Diode)> {
        self.diodes
            .iter()
            .map(|(name, s, d)| (name.as_str(), *s, d))
    }

    /// The contract's default signals (whatever `.print`/`.probe`/`.save` chose instead).
    #[must_use]
    pub fn default_signals(&self) -> &[Signal] {
        &self.defaults
    }

    /// Resolves a signal name: `v(node)`, `v(a,b)` (a difference), `i(element)` (the branch
    /// current from its first node through it to its second, for every element), `q(capacitor)`.
    /// Names are case-insensitive; the ground node (`0`, `gnd`) reads 0.
    ///
    /// # Errors
    /// [`CircuitError::UnknownSignal`] naming what is missing and what is available.
    pub fn signal(&self, name: &str) -> Result<Signal, CircuitError> {
        let lower: String = name
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_lowercase();
        let unknown = |reason: String| CircuitError::UnknownSignal {
            signal: name.to_string(),
            reason,
        };
        let inner = lower
            .strip_suffix(')')
            .and_then(|s| s.split_once('('))
            .ok_or_else(|| {
                unknown("expected v(node), v(a,b), i(element) or q(capacitor)".into())
            })?;
        let probe = match inner {
            ("v", args) => match args.split_once(',') {
                Some((a, b)) => Probe::Sum(vec![
                    (self.potential(a, &unknown)?, 1.0),
                    (self.potential(b, &unknown)?, -1.0),
                ]),
                None => self.potential(args, &unknown)?,
            },
            ("i", element) => {
                let b = self.branches.get(element).ok_or_else(|| {
                    unknown(format!(
                        "no element `{element}`; elements: {}",
                        self.element_list()
                    ))
                })?;
                Probe::Flow(self.port_of(b)?)
            }
            ("q", element) => {
                if !self.branches.get(element).is_some_and(|b| b.capacitor) {
                    return Err(unknown(format!(
                        "`{element}` is not a capacitor; capacitors: {}",
                        self.capacitors.join(", ")
                    )));
                }
                let b = &self.branches[element];
                Probe::Position {
                    part: dirac_graph::SubsystemId(b.subsystem),
                    coordinate: b.coordinate,
                }
            }
            (kind, _) => {
                return Err(unknown(format!(
                    "`{kind}(…)` is not a signal kind; use v(node), v(a,b), i(element) or q(capacitor)"
                )));
            }
        };
        Ok(Signal::new(lower, probe))
    }

    fn potential(
        &self,
        node: &str,
        unknown: &impl Fn(String) -> CircuitError,
    ) -> Result<Probe, CircuitError> {
        if node == "0" || node == "gnd" {
            return Ok(Probe::Constant(0.0));
        }
        let c = self.nodes.get(node).ok_or_else(|| {
            let mut names: Vec<&String> = self.nodes.keys().collect();
            names.sort();
            let names: Vec<&str> = names.iter().map(|s| s.as_str()).collect();
            unknown(format!("no node `{node}`; nodes: {}", names.join(", ")))
        })?;
        Ok(Probe::Effort(*c))
    }

    fn port_of(&self, b: &Branch) -> Result<PortRef, CircuitError> {
        let name = self.graph.subsystems()[b.subsystem].name();
        Ok(self.graph.port(name, b.port)?)
    }

    fn element_list(&self) -> String {
        let mut names: Vec<&str> = self.branches.keys().map(String::as_str).collect();
        names.sort_unstable();
        names.join(", ")
    }
}

/// The linear two-terminal parts whose model a netlist shares between elements of equal value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Kind {
    Resistor,
    Inductor,
    Capacitor,
}

/// One part per (kind, value) made so far; every further element of that kind and value is the
/// same part renamed ([`Subsystem::renamed`]: the model object is shared, not copied). A ladder of
/// 10⁵ equal sections then holds three model objects instead of 3·10⁵ separately allocated ones,
/// and the assembled model's loop over its parts reads the same few objects.
#[derive(Default)]
struct SharedParts(HashMap<(Kind, u64), Subsystem>);

impl SharedParts {
    /// The part `name` of `kind` and `value`: a renamed copy of an earlier one of the same kind
    /// and value (bit for bit), else `make(value)`.
    fn part(
        &mut self,
        kind: Kind,
        value: f64,
        name: &str,
        make: impl FnOnce(f64) -> Result<Subsystem, PartError>,
    ) -> Result<Subsystem, PartError> {
        let key = (kind, value.to_bits());
        if let Some(prototype) = self.0.get(&key) {
            return Ok(prototype.renamed(name));
        }
        let part = make(value)?;
        self.0.insert(key, part.clone());
        Ok(part)
    }
}

/// The `.options` the devices read ([`DeviceConditions::read`], and the MOSFET geometry defaults
/// the flattening applies): not warned about as ignored.
const DEVICE_OPTIONS: [&str; 7] = ["temp", "tnom", "gmin", "defl", "defw", "defad", "defas"];

/// Builds the circuit of `netlist` (read from `file`).
///
/// # Errors
/// An inductor coupled twice, a `.print`/`.probe`/`.save` signal that does not exist, or a graph
/// that cannot be built.
pub fn build_circuit(netlist: &Netlist, file: &str) -> Result<Circuit, CircuitError> {
    // Inductors joined by a K card become one CoupledInductors part.
    let mut coupled: HashMap<&str, (usize, usize)> = HashMap::new();
    for (e, element) in netlist.elements.iter().enumerate() {
        if let Element::K { l1, l2, .. } = element {
            for (winding, l) in [l1, l2].into_iter().enumerate() {
                if coupled.insert(l.as_str(), (e, winding)).is_some() {
                    let origin = &netlist.origins[e];
                    return Err(CircuitError::MultipleCoupling {
                        file: origin.file.clone(),
                        line: origin.line,
                        column: origin.column,
                        inductor: l.clone(),
                    });
                }
            }
        }
    }
    let conditions = DeviceConditions::read(netlist, file)?;
    let mut notes = Vec::new();
    let mut circuit = CircuitBuilder::new();
    let mut q0 = Vec::new();
    let mut v0 = Vec::new();
    let mut given_q = Vec::new();
    let mut given_v = Vec::new();
    let mut branches: HashMap<String, Branch> = HashMap::new();
    let mut k_subsystem: HashMap<usize, (usize, String)> = HashMap::new();
    let mut capacitors = Vec::new();
    let mut diodes = Vec::new();
    let located = |e: usize, source: PartError| {
        let origin = &netlist.origins[e];
        CircuitError::Part {
            file: origin.file.clone(),
            line: origin.line,
            column: origin.column,
            element: origin.name.clone(),
            source: Box::new(source),
        }
    };

    let mut add = |circuit: &mut CircuitBuilder,
                   s: Subsystem,
                   q: (Vec<f64>, Vec<bool>),
                   v: (Vec<f64>, Vec<bool>)|
     -> Result<usize, GraphError> {
        let id = circuit.add(s)?;
        q0.push(q.0);
        given_q.push(q.1);
        v0.push(v.0);
        given_v.push(v.1);
        Ok(id.0)
    };
    let none = |n: usize| (vec![0.0; n], vec![false; n]);
    // K parts first need both inductor values: find them.
    for (e, element) in netlist.elements.iter().enumerate() {
        let Element::K { name, l1, l2, k } = element else {
            continue;
        };
        let ((v1, ic1), (v2, ic2)) = (
            netlist.inductor(l1).unwrap_or((0.0, None)),
            netlist.inductor(l2).unwrap_or((0.0, None)),
        );
        let part = CoupledInductors::new(v1, v2, *k).map_err(|err| located(e, err))?;
        let s = add(
            &mut circuit,
            part.subsystem(name.clone()),
            none(2),
            (
                vec![ic1.unwrap_or(0.0), ic2.unwrap_or(0.0)],
                vec![ic1.is_some(), ic2.is_some()],
            ),
        )?;
        k_subsystem.insert(e, (s, name.clone()));
    }
    let connected: std::collections::HashSet<&str> = netlist
        .elements
        .iter()
        .filter_map(Element::terminals)
        .flat_map(|(a, b)| [a, b])
        .collect();
    for (e, element) in netlist.elements.iter().enumerate() {
        let Element::Controlled { source, .. } = element else {
            continue;
        };
        // A BJT's base branch carries current: its base is a terminal, not a sensed node.
        if matches!(source, ControlledSource::Bjt { .. }) {
            continue;
        }
        let sensed = source.sensed_voltages();
        for node in sensed.iter().flat_map(|&(_, a, b)| [a, b]) {
            if !CircuitBuilder::is_ground(node) && !connected.contains(node) {
                let origin = &netlist.origins[e];
                return Err(CircuitError::SensedOnly {
                    file: origin.file.clone(),
                    line: origin.line,
                    column: origin.column,
                    element: origin.name.clone(),
                    node: node.to_string(),
                });
            }
        }
    }
    voltage_loops(netlist)?;
    // Voltage sources whose current controls an F or H source: each of those gets a sensing
    // branch (a short) in series, wired once every part exists.
    let sensors = netlist.sensing_shorts();
    // Every other element is a part of its own between its two nodes, in card order; a coupled
    // inductor is a winding of its K part. The builder sets the port signs from terminal order.
    // Resistors, inductors and capacitors of equal value share one model object.
    let mut shared = SharedParts::default();
    // Connections that wait for a part added later (a sensing short).
    let mut pending: Vec<(String, String, String, String)> = Vec::new();
    for (e, element) in netlist.elements.iter().enumerate() {
        let check = |part: Result<Subsystem, PartError>| part.map_err(|err| located(e, err));
        let mut device = None;
        let (name, part, q, v) = match element {
            Element::R { name, value, .. } => (
                name,
                check(shared.part(Kind::Resistor, *value, name, |r| {
                    Resistor::new(r).map(|p| p.subsystem(name.clone()))
                }))?,
                none(1),
                none(1),
            ),
            Element::L {
                name,
                value,
                ic,
                n1,
                n2,
            } => {
                if let Some(&(k, winding)) = coupled.get(name.as_str()) {
                    let (subsystem, part) = &k_subsystem[&k];
                    let port = if winding == 0 { "i1" } else { "i2" };
                    circuit.connect(part, port, n1, n2)?;
                    branches.insert(
                        name.clone(),
                        Branch {
                            subsystem: *subsystem,
                            port,
                            coordinate: winding,
                            capacitor: false,
                        },
                    );
                    continue;
                }
                (
                    name,
                    check(shared.part(Kind::Inductor, *value, name, |l| {
                        Inductor::new(l).map(|p| p.subsystem(name.clone()))
                    }))?,
                    none(1),
                    (vec![ic.unwrap_or(0.0)], vec![ic.is_some()]),
                )
            }
            Element::C {
                name,
                n1,
                n2,
                value,
                ic,
            } => {
                capacitors.push(name.clone());
                let volts = netlist.capacitor_voltage(n1, n2, *ic);
                (
                    name,
                    check(shared.part(Kind::Capacitor, *value, name, |c| {
                        Capacitor::new(c).map(|p| p.subsystem(name.clone()))
                    }))?,
                    (vec![value * volts.unwrap_or(0.0)], vec![volts.is_some()]),
                    none(1),
                )
            }
            Element::V { name, source, .. } => (
                name,
                check(VoltageSource::new(waveform(source)).map(|p| p.subsystem(name.clone())))?,
                none(1),
                none(1),
            ),
            Element::I { name, source, .. } => (
                name,
                check(CurrentSource::new(waveform(source)).map(|p| p.subsystem(name.clone())))?,
                none(2),
                none(2),
            ),
            Element::D {
                name,
                model,
                anode,
                cathode,
            } => {
                let card = DiodeParameters {
                    tnom: if model.tnom_given {
                        model.card.tnom
                    } else {
                        conditions.tnom
                    },
                    ..model.card
                };
                let celsius = model.temp.unwrap_or(conditions.temp);
                let built =
                    Diode::at_temperature(&card, celsius).map_err(|e| CircuitError::Diode {
                        element: name.clone(),
                        source: e,
                    })?;
                notes.extend(
                    built
                        .warnings
                        .into_iter()
                        .map(|w| format!("diode `{name}`: {w}")),
                );
                let diode = built.diode.with_gmin(conditions.gmin);
                device = Some(diode);
                // `.ic` across a junction that stores charge gives its initial voltage (its
                // charge is a momentum, `p_φ = Q_j(v_j)`), as across a capacitor.
                let volts = diode
                    .has_charge()
                    .then(|| netlist.capacitor_voltage(anode, cathode, None))
                    .flatten();
                (
                    name,
                    diode.subsystem(name.clone()),
                    none(2),
                    (
                        vec![0.0, volts.unwrap_or(0.0)],
                        vec![false, volts.is_some()],
                    ),
                )
            }
            Element::Controlled { name, source, .. } => {
                let (part, dim) = match source {
                    ControlledSource::Vcvs { gain, .. } => {
                        (Vcvs::new(*gain).map(|p| p.subsystem(name.clone())), 3)
                    }
                    ControlledSource::Vccs { gm, .. } => {
                        (Vccs::new(*gm).map(|p| p.subsystem(name.clone())), 4)
                    }
                    ControlledSource::Cccs { gain, .. } => {
                        (Cccs::new(*gain).map(|p| p.subsystem(name.clone())), 3)
                    }
                    ControlledSource::Ccvs { r, .. } => {
                        (Ccvs::new(*r).map(|p| p.subsystem(name.clone())), 2)
                    }
                    ControlledSource::Behavioural {
                        output,
                        controls,
                        expression,
                    } => {
                        let kinds = controls
                            .iter()
                            .map(|c| match c {
                                Sensing::Voltage { .. } => Control::Voltage,
                                Sensing::Current { .. } => Control::Current,
                            })
                            .collect();
                        let part = BehaviouralSource::new(*output, kinds, expression.clone());
                        let dim = part.as_ref().map_or(0, Model::dim);
                        (part.map(|p| p.subsystem(name.clone())), dim)
                    }
                    ControlledSource::Mosfet { channel, .. } => {
                        (Ok(channel.subsystem(name.clone())), channel.dim())
                    }
                    ControlledSource::Bjt { core, .. } => {
                        let core = (**core).with_gmin(conditions.gmin);
                        (Ok(core.subsystem(name.clone())), core.dim())
                    }
                };
                (name, check(part)?, none(dim), none(dim))
            }
            Element::K { .. } => continue,
        };
        let s = add(&mut circuit, part, q, v)?;
        if let Some(diode) = device {
            diodes.push((name.clone(), SubsystemId(s), diode));
        }
        if let Some((a, b)) = element.terminals() {
            match sensors.get(name.as_str()) {
                // Through nodes no netlist can name (they get no signal).
                Some(shorts) => pending.extend(crate::sensed_chain(name, a, b, shorts, |k| {
                    crate::inner_name(name, &format!("sense {k}"))
                })),
                None => {
                    circuit.connect(name, "i", a, b)?;
                }
            }
        }
        if let Element::Controlled { source, .. } = element {
            for (port, a, b) in source.sensed_voltages() {
                circuit.connect(name, &port, a, b)?;
            }
        }
        branches.insert(
            name.clone(),
            Branch {
                subsystem: s,
                port: "i",
                coordinate: 0,
                capacitor: matches!(element, Element::C { .. }),
            },
        );
    }
    for (part, port, from, to) in &pending {
        circuit.connect(part, port, from, to)?;
    }
    // A node on a single element (ngspice warns and solves it): KCL says that element carries no
    // current. A 0 A source from the node to ground keeps that row and gives the node its
    // potential (the source's voltage, a multiplier of the row).
    // A controlled source's sensing branch counts: it draws no current but closes the node's
    // equations (a node between a source and the input it drives is not open).
    let mut terminals: HashMap<&str, Vec<usize>> = HashMap::new();
    for (e, element) in netlist.elements.iter().enumerate() {
        let sensed = match element {
            Element::Controlled { source, .. } => source.sensed_voltages(),
            _ => Vec::new(),
        };
        let sensed = sensed.into_iter().map(|(_, a, b)| (a, b));
        for (a, b) in element.terminals().into_iter().chain(sensed) {
            terminals.entry(a).or_default().push(e);
            terminals.entry(b).or_default().push(e);
        }
    }
    for node in netlist.nodes() {
        let Some(&[only]) = terminals.get(node.as_str()).map(Vec::as_slice) else {
            continue;
        };
        if CircuitBuilder::is_ground(&node) {
            continue;
        }
        let name = format!("open({node})");
        notes.push(format!(
            "node `{node}` connects to a single element ({}), which therefore carries no current",
            netlist.elements[only].name()
        ));
        let source = CurrentSource::new(Waveform::Dc(0.0)).map_err(|err| located(only, err))?;
        add(
            &mut circuit,
            source.subsystem(name.clone()),
            none(2),
            none(2),
        )?;
        circuit.connect(&name, "i", &node, "0")?;
    }
    // KCL at every non-ground node, in order of first appearance (`Netlist::nodes`' order).
    let graph = circuit.build()?;
    let mut nodes = HashMap::new();
    let mut signals = Vec::new();
    for (i, node) in graph.connections().iter().enumerate() {
        let connection = ConnectionId(i);
        let node = node.name().to_string();
        if crate::is_inner_name(&node) {
            continue;
        }
        signals.push(Signal::new(format!("v({node})"), Probe::Effort(connection)));
        nodes.insert(node, connection);
    }
    let holds = netlist
        .ic
        .iter()
        .filter_map(|(node, value)| nodes.get(node).map(|c| (*c, *value)))
        .collect();
    let mut circuit = Circuit {
        graph,
        q0,
        v0,
        given_q,
        given_v,
        signals: Vec::new(),
        tran: netlist.tran,
        measures: Vec::new(),
        op: netlist.op,
        holds,
        method: None,
        truncation: TruncationControl::default(),
        conditions,
        warnings: notes,
        defaults: Vec::new(),
        diodes,
        nodes,
        branches,
        capacitors,
    };
    // Voltage sources include the controlled ones (E, H), whose branch currents ngspice's `.op`
    // prints as well.
    for element in &netlist.elements {
        let name = match element {
            Element::L { name, .. } | Element::V { name, .. } => name,
            Element::Controlled { name, source, .. } if source.drives_voltage() => name,
            _ => continue,
        };
        signals.push(circuit.signal(&format!("i({name})"))?);
    }
    for element in &netlist.elements {
        if let Element::C { name, .. } = element
            && !crate::is_inner_name(name)
        {
            signals.push(circuit.signal(&format!("q({name})"))?);
        }
    }
    circuit.defaults.clone_from(&signals);
    circuit.signals = if netlist.outputs.is_empty() {
        signals
    } else {
        let mut chosen: Vec<Signal> = Vec::new();
        for request in &netlist.outputs {
            let signal = circuit
                .signal(&request.signal)
                .map_err(|e| CircuitError::BadOutput {
                    file: netlist.file_of(request.pos, file),
                    line: request.pos.line,
                    column: request.pos.column,
                    message: e.to_string(),
                })?;
            if !chosen.iter().any(|s| s.name == signal.name) {
                chosen.push(signal);
            }
        }
        chosen
    };
    for measure in &netlist.measures {
        for name in measure.signals() {
            circuit.signal(&name).map_err(|e| CircuitError::BadOutput {
                file: netlist.file_of(measure.pos, file),
                line: measure.pos.line,
                column: measure.pos.column,
                message: format!("`.meas {}`: {e}", measure.name),
            })?;
        }
    }
    circuit.measures.clone_from(&netlist.measures);
    circuit.read_options(netlist, file)?;
    Ok(circuit)
}

impl Circuit {
    /// Maps `.options method=` to a discretisation, reads the truncation-error tolerances and
    /// notes every option dirac does not use.
    ///
    /// # Errors
    /// A tolerance that is not a positive number.
    fn read_options(&mut self, netlist: &Netlist, file: &str) -> Result<(), CircuitError> {
        let mut control = TruncationControl::default();
        for option in &netlist.options {
            let at = format!(
                "{}:{}:{}",
                netlist.file_of(option.pos, file),
                option.pos.line,
                option.pos.column
            );
            let key = option.key.as_str();
            if let Some(slot) = match key {
                "reltol" => Some(&mut control.reltol),
                "abstol" => Some(&mut control.abstol),
                "chgtol" => Some(&mut control.chgtol),
                "trtol" => Some(&mut control.trtol),
                _ => None,
            } {
                let text = option.value.as_deref().unwrap_or("");
                *slot = crate::parse_spice_number(text)
                    .filter(|v| *v > 0.0 && v.is_finite())
                    .ok_or_else(|| {
                        bad_option(
                            netlist.file_of(option.pos, file),
                            option,
                            format!("`{key}` needs a positive number, got `{text}`"),
                        )
                    })?;
                if self.diodes.is_empty() {
                    self.warnings.push(format!(
                        "{at}: `.options {key}` used only by the truncation-error control, which is off for a circuit without diodes (turn it on with --refine)"
                    ));
                }
                continue;
            }
            match (key, option.value.as_deref()) {
                ("method", Some("trap" | "trapezoidal")) => {
                    // On linear circuits the trapezoidal rule and the midpoint rule give the same
                    // charges (both second order, A-stable, not L-stable).
                    self.method = Some(Discretisation::midpoint());
                }
                ("method", Some(other)) => self.warnings.push(format!(
                    "{at}: `.options method={other}` has no equivalent (dirac has no BDF/Gear method, which damps ringing that the midpoint rule keeps); using the midpoint rule; choose another with --method"
                )),
                (key, _) if DEVICE_OPTIONS.contains(&key) => {}
                (key, _) => self.warnings.push(format!(
                    "{at}: `.options {key}` ignored (dirac steps on the .tran TSTEP grid with its own Newton tolerances)"
                )),
            }
        }
        self.truncation = control;
        Ok(())
    }
}
