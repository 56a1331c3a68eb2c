//! The SPICE-subset netlist reader: [`parse_netlist`] turns netlist text into a flat [`Netlist`]
//! (subcircuits expanded, parameters evaluated to `f64`), and [`build_circuit`] turns a netlist into
//! a [`Circuit`]: an interconnection of stock parts with its initial state, its recorded signals
//! and its analyses, ready for [`dirac_sim::Simulation`].
//!
//! # Supported subset
//!
//! Element cards (the first letter gives the type; names are case-insensitive):
//!
//! | card | meaning |
//! | --- | --- |
//! | `Rname n1 n2 [r=]value [m=M]` | resistor (a zero value is an error; `m` in parallel) |
//! | `Lname n1 n2 [l=]value [IC=i0] [m=M]` | inductor, optional initial current |
//! | `Cname n1 n2 [c=]value [IC=v0] [m=M]` | capacitor, optional initial voltage |
//! | `Vname n+ n- [[DC] v] [SIN(..)\|PULSE(..)\|EXP(..)\|PWL(..)] [AC ..]` | voltage source |
//! | `Iname n+ n- ...` | current source, same forms as `V` |
//! | `Kname L1 L2 k` | coupling of two inductors, `-1 < k < 1` |
//! | `Ename n+ n- nc+ nc- gain` | voltage-controlled voltage source (linear form) |
//! | `Gname n+ n- nc+ nc- gm` | voltage-controlled current source (linear form) |
//! | `Fname n+ n- vname gain` | current-controlled current source; `vname` is a `V`, `E` or `H` |
//! | `Hname n+ n- vname r` | current-controlled voltage source; `vname` is a `V`, `E` or `H` |
//! | `Dname anode cathode model [area] [area=A] [m=M] [off]` | diode; `model` names a `.model NAME D(...)`; the junction scaled by area·m (area defaults to the model's `AREA`); `off` ignored |
//! | `Qname c b e [s] model [area] [area=A] [m=M] [temp=T] [off]` | bipolar transistor (Gummel–Poon); `model` names a `.model NAME NPN\|PNP(...)`; a fourth word naming a model is the model, else the substrate node |
//! | `Xname n1 n2 ... SUB [params:] [a=..]` | subcircuit instance |
//!
//! Source functions: `SIN(VO VA [FREQ [TD [THETA [PHASE]]]])`, `PULSE(V1 V2 [TD [TR [TF [PW
//! [PER [NP]]]]]])`, `EXP(V1 V2 [TD1 [TAU1 [TD2 [TAU2]]]])`, `PWL(t1 v1 t2 v2 ...) [r=R] [td=TD]`, with
//! or without parentheses, values separated by blanks or commas; see [`SourceSpec`] for the exact (ngspice) definitions and defaults. When both a DC
//! value and a transient function are given, the function is used (with a warning). An `AC`
//! specification is ignored with a warning. A source without any value is `DC 0` (with a warning).
//!
//! Control cards:
//!
//! - `.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]` (at most one; see [`Tran::steps_per_row`]);
//! - `.ic V(node)=value ...`;
//! - `.param name=expr ...`, see below;
//! - `.model NAME D(IS=.. N=.. RS=.. ...)`: the SPICE level-1 junction diode with ngspice's names
//!   and aliases (`IS`/`JS`, `N`, `RS`, `CJO`/`CJ0`/`CJ`, `VJ`/`PB`, `M`/`MJ`, `FC`, `TT`, `BV`,
//!   `IBV`/`IB`, `NBV`, `EG`, `XTI`, `TNOM`/`TREF`, `TCV`, `TRS1`/`TRS`, `TRS2`, `TTT1`, `TTT2`,
//!   `TM1`, `TM2`, `LEVEL=1`), parentheses optional, parameters separated by blanks or commas;
//!   any other parameter is kept in [`DiodeModel::ignored`] with a warning saying what it would
//!   change;
//! - `.global n1 ...` (nodes that keep their name inside subcircuits; `gnd` is ground anyway);
//! - `.temp T` and `.options temp=T tnom=T gmin=G` (circuit temperature, the default `TNOM` and
//!   the junction conductance, see [`DeviceConditions`]);
//! - `.subckt NAME n1 n2 ... [params:] [a=1 ...]` ... `.ends [NAME]`, nestable (a port named
//!   `gnd` or `0` is ground, as ngspice reads it, with a warning at an instance that connects
//!   another node to it);
//! - `.end` (anything after it is ignored).
//!
//! - `.op` (the DC operating point, [`Netlist::op`]);
//! - `.options`/`.option`/`.opt` (kept as pairs in [`Netlist::options`]; [`build_circuit`] maps
//!   `method` and warns about the rest);
//! - `.print`, `.plot`, `.probe`, `.save` (the signals they name are kept in
//!   [`Netlist::outputs`] and become the recorded signals);
//! - `.meas`/`.measure` of a transient (see [`Measure`]; other analyses and forms are ignored with a
//!   warning).
//!
//! Accepted and **ignored with a recorded [`Warning`]**: `.nodeset`, `.width`, `.title`,
//! whole `.control` ... `.endc` blocks, and other analyses (`.ac`, `.dc`, `.noise`, `.tf`, `.four`,
//! ...) in a netlist that also has `.tran` or `.op` (alone, they are refused).
//!
//! Everything else is an error of kind [`ErrorKind::Unsupported`] whose message contains "not
//! supported": other element types (`M Q J B T S W A U O Z`, ...), the nonlinear forms of `E F G
//! H` (`POLY(…)`, `VALUE=`, `TABLE {…}`, ...; the same words as node names are read), other dot-cards (`.include`, `.lib`, `.func`, ...), other source
//! functions (`SFFM`, `AM`, `TRNOISE`, ...), model types other than `D`, instance parameters other
//! than `IC=` on `L`/`C`.
//!
//! # Lexical rules
//!
//! - The first line is the title (SPICE convention) and is never parsed as a card.
//! - Lines whose first non-blank character is `*` are comments; `;`, `//` and a `$` that opens the
//!   line or follows a blank start a comment that runs to the end of the line (as ngspice reads
//!   them; a `$` inside a word is not one).
//! - A line starting with `+` continues the previous card.
//! - Names and keywords are case-insensitive. Node and element names are normalised to lowercase;
//!   the ground node is `0` or `gnd`, normalised to `"0"`.
//! - Numbers take SPICE engineering suffixes `f p n u m k meg g t` (and `mil`), any case, with
//!   `m` = milli and `meg` = mega; letters after the suffix are ignored (`10uF`, `1kOhm`, `5V`).
//!   See [`parse_spice_number`].
//!
//! # Parameters and expressions
//!
//! `.param a=1k b={2*a} c = sqrt(a) + 1` defines parameters. Values are expressions with `+ - * /`,
//! `^` or `**` (right-associative, binding tighter than unary minus: `-2^2 = -4`), parentheses,
//! unary minus, the functions `sqrt exp log ln log10 sin cos tan atan abs` (`log` is the natural
//! logarithm, as in ngspice) and `min max pow`, numbers with suffixes and references to other
//! parameters (in any order; cycles are errors). In element values and source arguments an
//! expression is written `{expr}` or `'expr'`, or bare without blanks (`2*r0`, `rval`). In
//! `.param`, `.subckt`/`X` parameters and `.model` parameters a bare expression may contain blanks.
//!
//! # Subcircuits
//!
//! `X` instances are expanded in place. Elements inside get hierarchical names (`x1.r2`,
//! `x1.x2.c1`), internal nodes are prefixed the same way (`x1.n3`), ports are replaced by the
//! instance's nodes, and ground stays global. Instance parameters override the subcircuit's
//! defaults and are evaluated in the caller's scope; an instance may only pass parameters the
//! subcircuit declares. Scoping is dynamic: a name not found in an instance's scope (its
//! parameters and body `.param`s) is looked up in the enclosing instance, up to the top level; the
//! same holds for `.subckt` and `.model` definitions.
//!
//! # Errors and warnings
//!
//! Errors are [`NetlistError`]s with line, column, offending text and an [`ErrorKind`]; `Display`
//! gives `file:line:column: message`, e.g. ``file.cir:12:5: card `M1 d g s 0 nmos` not
//! supported``. Positions inside a subcircuit body refer to the definition's lines.

mod error;
mod expr;
mod flatten;
mod lexer;
mod measure;
mod parser;
mod source;
mod units;

mod circuit;

pub use circuit::{Circuit, CircuitError, DeviceConditions, build_circuit, waveform};
use dirac_components::{BehaviouralSource, BjtCore, MosfetChannel};
pub use dirac_components::{Expression, Output};
pub use error::{ErrorKind, NetlistError, Pos, Warning};
pub use flatten::MOSFET_INSTANCE_KEYS;
pub use measure::{Crossing, Edge, Event, Level, Measure, MeasureKind, Occurrence, Statistic};
pub use parser::{OptionCard, OutputRequest};
pub use source::SourceSpec;
pub use units::{parse_spice_number, parse_spice_quantity};

/// Diode model parameters from `.model NAME D(...)`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiodeModel {
    /// The model's name, lowercased.
    pub name: String,
    /// The SPICE level-1 parameters given, ngspice's defaults for the rest (`TNOM` 27 °C unless
    /// given; see [`DiodeModel::tnom_given`]).
    pub card: dirac_components::DiodeParameters,
    /// Whether the card gave `TNOM` (else `.options tnom=` applies).
    pub tnom_given: bool,
    /// Other parameters given (`IKF`, `KF`, ...), lowercased, which are not used; each produced
    /// a warning saying what it would change.
    pub ignored: Vec<(String, f64)>,
    /// The element's own temperature (°C): `temp=` on its card, or the circuit's plus `dtemp=`
    /// (a MOSFET's junctions: the device's). `None`: the circuit's.
    pub temp: Option<f64>,
}

/// The `.tran` analysis card.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tran {
    /// `TSTEP`, the output (printing) step in seconds.
    pub tstep: f64,
    /// `TSTOP`, the final time in seconds.
    pub tstop: f64,
    /// `TSTART`, the first output time (default 0).
    pub tstart: f64,
    /// `TMAX`, the largest internal step, if given.
    pub tmax: Option<f64>,
    /// `UIC`: start from the given initial conditions instead of an operating point.
    pub uic: bool,
}

impl Tran {
    /// ngspice's largest internal step: `TMAX` when given, else the smaller of `TSTEP` and
    /// `(TSTOP − TSTART)/50` (ngspice-39's `TRANinit`).
    #[must_use]
    pub fn max_step(&self) -> f64 {
        self.tmax
            .unwrap_or_else(|| self.tstep.min((self.tstop - self.tstart) / 50.0))
    }

    /// Where a run to `t` ends: on the TSTEP grid (the nearest multiple) when its rows come
    /// from [`Tran::steps_per_row`] steps each, so that the last row is a row; `t` otherwise.
    #[must_use]
    pub fn run_end(&self, t: f64) -> f64 {
        if self.steps_per_row() > 1 {
            (t / self.tstep).round() * self.tstep
        } else {
            t
        }
    }

    /// Steps per output row: the fewest equal substeps of `TSTEP` that are no longer than
    /// [`Tran::max_step`] (1 when `TSTEP` is short enough). A deck that asks for rows every
    /// `TSTEP` but for steps of at most `TMAX` (or of a fiftieth of the interval) is stepped at
    /// `TSTEP/m` and printed every `m` steps, so the rows are on ngspice's output grid and the
    /// steps no longer than ngspice's.
    #[must_use]
    pub fn steps_per_row(&self) -> usize {
        let ratio = self.tstep / self.max_step();
        // A ratio that is a whole number up to rounding (`1e-3 / 1e-5`) takes that number.
        let m = (ratio * (1.0 - 1e-12)).ceil();
        if m.is_finite() && m >= 1.0 {
            m as usize
        } else {
            1
        }
    }
}

/// One element of the flat netlist. Names are hierarchical and lowercase (`r1`, `x1.r2`); nodes
/// are lowercase, ground is `"0"`, internal subcircuit nodes are prefixed (`x1.n3`).
#[derive(Debug, Clone, PartialEq)]
pub enum Element {
    /// Resistor, `value` in Ω.
    R {
        /// Element name.
        name: String,
        /// First node.
        n1: String,
        /// Second node.
        n2: String,
        /// Resistance in Ω (non-zero).
        value: f64,
    },
    /// Inductor, `value` in H; current flows from `n1` through the inductor to `n2`.
    L {
        /// Element name.
        name: String,
        /// First node.
        n1: String,
        /// Second node.
        n2: String,
        /// Inductance in H.
        value: f64,
        /// Initial current (`IC=`), if given.
        ic: Option<f64>,
    },
    /// Capacitor, `value` in F.
    C {
        /// Element name.
        name: String,
        /// First node.
        n1: String,
        /// Second node.
        n2: String,
        /// Capacitance in F.
        value: f64,
        /// Initial voltage `V(n1) - V(n2)` (`IC=`), if given.
        ic: Option<f64>,
    },
    /// Independent voltage source: `V(n_plus) - V(n_minus) = source(t)`.
    V {
        /// Element name.
        name: String,
        /// Positive node.
        n_plus: String,
        /// Negative node.
        n_minus: String,
        /// The waveform.
        source: SourceSpec,
    },
    /// Independent current source: `source(t)` flows from `n_plus` through the source to
    /// `n_minus` (SPICE convention).
    I {
        /// Element name.
        name: String,
        /// Positive node.
        n_plus: String,
        /// Negative node.
        n_minus: String,
        /// The waveform.
        source: SourceSpec,
    },
    /// Mutual coupling of two inductors: `M = k·sqrt(L1·L2)`.
    K {
        /// Element name.
        name: String,
        /// Hierarchical name of the first inductor (an [`Element::L`] of this netlist).
        l1: String,
        /// Hierarchical name of the second inductor.
        l2: String,
        /// Coupling coefficient in `[-1, 1]`.
        k: f64,
    },
    /// Diode from `anode` to `cathode`.
    D {
        /// Element name.
        name: String,
        /// Anode node.
        anode: String,
        /// Cathode node.
        cathode: String,
        /// The model's parameters.
        model: DiodeModel,
    },
    /// A linear controlled source (`E`, `G`, `F`, `H`) with output from `n_plus` to `n_minus`.
    Controlled {
        /// Element name.
        name: String,
        /// Positive output node.
        n_plus: String,
        /// Negative output node.
        n_minus: String,
        /// What controls it and how.
        source: ControlledSource,
    },
}

/// A linear controlled source's control and coefficient (ngspice's linear forms).
#[derive(Debug, Clone, PartialEq)]
pub enum ControlledSource {
    /// `E n+ n− nc+ nc− gain`: `V(n+) − V(n−) = gain·(V(nc+) − V(nc−))`.
    Vcvs {
        /// Positive controlling node.
        c_plus: String,
        /// Negative controlling node.
        c_minus: String,
        /// Voltage gain.
        gain: f64,
    },
    /// `G n+ n− nc+ nc− gm`: the current `gm·(V(nc+) − V(nc−))` flows from `n+` through the
    /// source to `n−`.
    Vccs {
        /// Positive controlling node.
        c_plus: String,
        /// Negative controlling node.
        c_minus: String,
        /// Transconductance in S.
        gm: f64,
    },
    /// `F n+ n− vname gain`: the current `gain·I(vname)` flows from `n+` through the source to
    /// `n−`, with `I(vname)` the current of voltage source `vname` from its `+` node through it to
    /// its `−` node (SPICE's sign).
    Cccs {
        /// Hierarchical name of the controlling voltage source (a `V`, or an `E` or `H` output).
        control: String,
        /// Current gain.
        gain: f64,
    },
    /// `H n+ n− vname r`: `V(n+) − V(n−) = r·I(vname)`.
    Ccvs {
        /// Hierarchical name of the controlling voltage source (a `V`, or an `E` or `H` output).
        control: String,
        /// Transresistance in Ω.
        r: f64,
    },
    /// `B n+ n− V=expr` or `I=expr`, `E`/`G` with `VALUE=`, `VOL=`, `CUR=` or `POLY(n)`, `F`/`H`
    /// with `POLY(n)`: a voltage `V(n+) − V(n−)` or a current from `n+` through the source to
    /// `n−` that is an expression of sensed voltages and currents and of time.
    Behavioural {
        /// Voltage or current.
        output: Output,
        /// What the expression's controls are, in the order of [`Expression::Control`]'s index.
        controls: Vec<Sensing>,
        /// The output's value.
        expression: Expression,
    },
    /// An `M` card's channel: the level-1 drain current flows from `n+` (the inner drain)
    /// through the channel to `n−` (the inner source), a function of the gate–source and
    /// bulk–source voltages. The card's junctions, overlap capacitances and series resistances
    /// are elements of their own (`D`, `C`, `R` named `"<m> bd"`, `"<m> cgs"`, `"<m> rd"`, …).
    Mosfet {
        /// Gate node.
        gate: String,
        /// Bulk node.
        bulk: String,
        /// The inner source node (`n−`), which the gate and bulk voltages are taken against.
        source: String,
        /// The drain current.
        channel: MosfetChannel,
    },
    /// A `Q` card's core: the collector current flows from `n+` (the inner collector) to `n−`
    /// (the inner emitter) and the base current from the inner base to the inner emitter, both
    /// functions of the base–emitter and base–collector voltages, with the junction charges.
    /// The card's series resistances and substrate junction are elements of their own (`R`, `D`
    /// named `"<q> rb"`, `"<q> sub"`, …).
    Bjt {
        /// The inner base node, whose branch to the inner emitter carries the base current.
        base: String,
        /// The inner emitter node (`n−`).
        emitter: String,
        /// The currents and charges (boxed: far larger than the other variants).
        core: Box<BjtCore>,
    },
}

/// What one control of a controlled source senses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sensing {
    /// The voltage `V(plus) − V(minus)`.
    Voltage {
        /// Positive node.
        plus: String,
        /// Negative node.
        minus: String,
    },
    /// The current of a voltage source (a `V`, or the output of an `E`, `H` or voltage `B`
    /// source; hierarchical name) from its `+` node through it to its `−` node.
    Current {
        /// The source.
        source: String,
    },
}

/// A borrowed view of one control: what [`ControlledSource::sensing`] lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensed<'a> {
    /// The voltage from the first node to the second.
    Voltage(&'a str, &'a str),
    /// The current of the named voltage source.
    Current(&'a str),
}

impl Sensing {
    /// This control as a borrowed view.
    #[must_use]
    pub fn view(&self) -> Sensed<'_> {
        match self {
            Self::Voltage { plus, minus } => Sensed::Voltage(plus, minus),
            Self::Current { source } => Sensed::Current(source),
        }
    }
}

impl ControlledSource {
    /// Each sensing branch: the part's port for it and what it senses (one for the linear forms,
    /// at port `ic`; one per control for a behavioural source, at ports `ic0`, `ic1`, …; a BJT's
    /// base branch, port `ib`, which is not a sensing branch but is wired as one).
    #[must_use]
    pub fn sensing(&self) -> Vec<(String, Sensed<'_>)> {
        match self {
            Self::Vcvs {
                c_plus, c_minus, ..
            }
            | Self::Vccs {
                c_plus, c_minus, ..
            } => vec![("ic".into(), Sensed::Voltage(c_plus, c_minus))],
            Self::Cccs { control, .. } | Self::Ccvs { control, .. } => {
                vec![("ic".into(), Sensed::Current(control))]
            }
            Self::Behavioural { controls, .. } => controls
                .iter()
                .enumerate()
                .map(|(k, c)| (BehaviouralSource::control_port(k), c.view()))
                .collect(),
            Self::Mosfet {
                gate, bulk, source, ..
            } => vec![
                (
                    MosfetChannel::GATE_PORT.into(),
                    Sensed::Voltage(gate, source),
                ),
                (
                    MosfetChannel::BULK_PORT.into(),
                    Sensed::Voltage(bulk, source),
                ),
            ],
            // Not a sensing branch: it carries the base current.
            Self::Bjt { base, emitter, .. } => {
                vec![(BjtCore::BASE_PORT.into(), Sensed::Voltage(base, emitter))]
            }
        }
    }

    /// The controlling node pairs, with the port of each one's sensing branch.
    #[must_use]
    pub fn sensed_voltages(&self) -> Vec<(String, &str, &str)> {
        self.sensing()
            .into_iter()
            .filter_map(|(port, s)| match s {
                Sensed::Voltage(plus, minus) => Some((port, plus, minus)),
                Sensed::Current(_) => None,
            })
            .collect()
    }

    /// Whether the output is a voltage (its branch current is then a source current that other
    /// sources may sense, and a default output column).
    #[must_use]
    pub fn drives_voltage(&self) -> bool {
        match self {
            Self::Vcvs { .. } | Self::Ccvs { .. } => true,
            Self::Vccs { .. } | Self::Cccs { .. } | Self::Mosfet { .. } | Self::Bjt { .. } => false,
            Self::Behavioural { output, .. } => *output == Output::Voltage,
        }
    }
}

/// The name of a node or element that a card creates inside itself (a MOSFET's inner drain
/// `"m1 drain"`, its junction `"m1 bd"`, a controlling source's sensing node `"v1 sense 0"`): the
/// card's hierarchical name, a space, `what`. No netlist can write a name with a space, so these
/// never collide with one and get no default output column.
pub(crate) fn inner_name(card: &str, what: &str) -> String {
    format!("{card} {what}")
}

/// Whether `name` was made by [`inner_name`].
pub(crate) fn is_inner_name(name: &str) -> bool {
    name.contains(' ')
}

impl Element {
    /// The element's hierarchical, lowercase name.
    pub fn name(&self) -> &str {
        match self {
            Element::R { name, .. }
            | Element::L { name, .. }
            | Element::C { name, .. }
            | Element::V { name, .. }
            | Element::I { name, .. }
            | Element::K { name, .. }
            | Element::D { name, .. }
            | Element::Controlled { name, .. } => name,
        }
    }

    /// The branch's `(from, to)` nodes: its current flows from the first through the element to
    /// the second (`None` for `K`, which has no branch of its own).
    pub fn terminals(&self) -> Option<(&str, &str)> {
        match self {
            Element::R { n1, n2, .. } | Element::L { n1, n2, .. } | Element::C { n1, n2, .. } => {
                Some((n1, n2))
            }
            Element::V {
                n_plus, n_minus, ..
            }
            | Element::I {
                n_plus, n_minus, ..
            }
            | Element::Controlled {
                n_plus, n_minus, ..
            } => Some((n_plus, n_minus)),
            Element::D { anode, cathode, .. } => Some((anode, cathode)),
            Element::K { .. } => None,
        }
    }

    /// The nodes the element connects, in card order (none for `K`).
    pub fn nodes(&self) -> Vec<&str> {
        match self {
            Element::R { n1, n2, .. } | Element::L { n1, n2, .. } | Element::C { n1, n2, .. } => {
                vec![n1, n2]
            }
            Element::V {
                n_plus, n_minus, ..
            }
            | Element::I {
                n_plus, n_minus, ..
            } => vec![n_plus, n_minus],
            Element::K { .. } => Vec::new(),
            Element::D { anode, cathode, .. } => vec![anode, cathode],
            Element::Controlled {
                n_plus,
                n_minus,
                source,
                ..
            } => {
                let mut nodes = vec![n_plus.as_str(), n_minus.as_str()];
                for (_, a, b) in source.sensed_voltages() {
                    nodes.extend([a, b]);
                }
                nodes
            }
        }
    }
}

/// Where an element came from: its name as written (hierarchical, original case, e.g. `X1.R2`)
/// and the position of its card (inside the subcircuit definition for expanded elements).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Origin {
    /// The element's hierarchical name with the original spelling.
    pub name: String,
    /// 1-based line of the element's card.
    pub line: usize,
    /// 1-based column of the element's name.
    pub column: usize,
    /// The file of the card: the netlist's name, or the path of the included file it is in.
    pub file: String,
    /// Which of [`Netlist::files`] `file` is.
    pub(crate) file_index: usize,
}

/// A flat netlist: subcircuits expanded, parameters evaluated.
#[derive(Debug, Clone, PartialEq)]
pub struct Netlist {
    /// The title (first line).
    pub title: String,
    /// The elements in card order, subcircuit contents in place of their `X` card.
    pub elements: Vec<Element>,
    /// Where each element came from; `origins[i]` belongs to `elements[i]`.
    pub origins: Vec<Origin>,
    /// The `.tran` card, if any. When present, the defaults of every source waveform have been
    /// resolved with its `TSTEP` and `TSTOP` (see [`SourceSpec::resolved`]).
    pub tran: Option<Tran>,
    /// Node initial voltages from `.ic V(node)=value`, node names normalised, in card order (a
    /// repeated node keeps its first place and its last value).
    pub ic: Vec<(String, f64)>,
    /// Whether an `.op` card asks for the operating point.
    pub op: bool,
    /// `.options` pairs in card order (interpreted by [`build_circuit`]).
    pub options: Vec<OptionCard>,
    /// Signals named by `.print`, `.probe`, `.save` and `.plot`, in card order.
    pub outputs: Vec<OutputRequest>,
    /// The `.meas` cards of the transient, in card order, their values evaluated.
    pub measures: Vec<Measure>,
    /// The top-level `.param` values (names lowercase, in card order), after any value set by
    /// [`parse_netlist_with`]: the parameters a sweep can set by name.
    pub parameters: Vec<(String, f64)>,
    /// Things accepted but ignored.
    pub warnings: Vec<Warning>,
    /// The netlist's name as given to [`parse_netlist`], then the path of each file its `.include`
    /// and `.lib` cards read, in the order they were read ([`Pos::file`] indexes it).
    pub files: Vec<String>,
}

/// The branches of a source (named `source`, from node `a` to node `b`) whose current controls
/// other sources through the sensing shorts `shorts` (each a part and its port): `a` → the
/// source's port `i` → each sensing short → `b`, as `(part, port, from, to)`; `node(k)` names the
/// `k`-th node between them (from 1). One definition for `dirac run` ([`build_circuit`]) and for a
/// scene written from the netlist.
pub fn sensed_chain(
    source: &str,
    a: &str,
    b: &str,
    shorts: &[(&str, String)],
    mut node: impl FnMut(usize) -> String,
) -> Vec<(String, String, String, String)> {
    let mut from = a.to_owned();
    std::iter::once((source.to_owned(), "i".to_owned()))
        .chain(
            shorts
                .iter()
                .map(|(c, port)| ((*c).to_owned(), port.clone())),
        )
        .enumerate()
        .map(|(k, (part, port))| {
            let to = if k == shorts.len() {
                b.to_owned()
            } else {
                node(k + 1)
            };
            let from = std::mem::replace(&mut from, to.clone());
            (part, port, from, to)
        })
        .collect()
}

impl Netlist {
    /// Per voltage source (`V`, or an `E`, `H` or voltage `B` output) whose current controls
    /// other sources: the sensing shorts that go in series with it ([`sensed_chain`]), each as
    /// the controlled source and its port, in card order.
    #[must_use]
    pub fn sensing_shorts(&self) -> std::collections::HashMap<&str, Vec<(&str, String)>> {
        let mut shorts: std::collections::HashMap<&str, Vec<(&str, String)>> =
            std::collections::HashMap::new();
        for element in &self.elements {
            if let Element::Controlled { name, source, .. } = element {
                for (port, sensed) in source.sensing() {
                    if let Sensed::Current(control) = sensed {
                        shorts.entry(control).or_default().push((name, port));
                    }
                }
            }
        }
        shorts
    }

    /// Non-ground nodes in order of first appearance in [`elements`](Self::elements) (the natural
    /// column order for output).
    pub fn nodes(&self) -> Vec<String> {
        let mut seen = std::collections::HashSet::new();
        let mut out = Vec::new();
        for e in &self.elements {
            for n in e.nodes() {
                if n != "0" && seen.insert(n) {
                    out.push(n.to_owned());
                }
            }
        }
        out
    }

    /// The name of the file `pos` is in: one of [`Netlist::files`], or `file` (the name the
    /// netlist was read as) for a netlist built without them.
    #[must_use]
    pub fn file_of(&self, pos: Pos, file: &str) -> String {
        match pos.file {
            0 => file.to_owned(),
            k => self
                .files
                .get(k)
                .cloned()
                .unwrap_or_else(|| file.to_owned()),
        }
    }

    /// The element with the given (case-insensitive, hierarchical) name.
    pub fn element(&self, name: &str) -> Option<&Element> {
        let name = name.to_lowercase();
        self.elements.iter().find(|e| e.name() == name)
    }

    /// Inductance and `IC=` current of the inductor named `name` (`None` if it is not one).
    pub fn inductor(&self, name: &str) -> Option<(f64, Option<f64>)> {
        match self.element(name) {
            Some(Element::L { value, ic, .. }) => Some((*value, *ic)),
            _ => None,
        }
    }

    /// Initial voltage `V(n1) − V(n2)` of a capacitor between `n1` and `n2` with `IC=` value `ic`:
    /// the `IC=` value if given, else from the `.ic` node voltages (ground is 0), else `None`.
    /// With `UIC`, a node `.ic` does not name counts as 0 V once the other one is named, as
    /// ngspice computes a capacitor's initial condition from its node vector, zero where `.ic`
    /// sets nothing (`.ic v(w)=1m` across `C1 s w` starts C1 at −1 mV).
    pub fn capacitor_voltage(&self, n1: &str, n2: &str, ic: Option<f64>) -> Option<f64> {
        let named = |n: &str| self.ic.iter().find(|(m, _)| m == n).map(|(_, v)| *v);
        let node = |n: &str| if n == "0" { Some(0.0) } else { named(n) };
        let uic = self.tran.is_some_and(|t| t.uic);
        ic.or_else(|| match (node(n1), node(n2)) {
            (Some(a), Some(b)) => Some(a - b),
            (Some(a), None) if uic && n1 != "0" => Some(a),
            (None, Some(b)) if uic && n2 != "0" => Some(-b),
            _ => None,
        })
    }
}

/// Parses SPICE netlist text into a flat [`Netlist`]. `file_name` is only used in error messages
/// (`file_name:line:column: ...`).
///
/// # Errors
///
/// The first problem found, as a [`NetlistError`]; see [`ErrorKind`] for the kinds.
pub fn parse_netlist(source: &str, file_name: &str) -> Result<Netlist, NetlistError> {
    parse_netlist_with(source, file_name, &[])
}

/// [`parse_netlist`] with values set by name (case-insensitive), as a sweep sets them: a
/// top-level `.param` (ngspice's `.step param`) replaces its card's expression, and everything
/// that depends on it is evaluated with the new value; `<mosfet>.<key>` (hierarchical,
/// `x1.m2.w`, with a key of [`MOSFET_INSTANCE_KEYS`]) replaces that card's instance parameter
/// before its junctions and capacitances are derived from it. Any other name is ignored
/// ([`Netlist::parameters`] lists the `.param` names).
///
/// # Errors
///
/// As [`parse_netlist`].
pub fn parse_netlist_with(
    source: &str,
    file_name: &str,
    parameters: &[(String, f64)],
) -> Result<Netlist, NetlistError> {
    let lexed = lexer::lex(source, file_name)?;
    let files = lexed.files.clone();
    let in_files = |e: NetlistError| e.in_files(&files);
    let parsed = parser::parse(lexed).map_err(in_files)?;
    let mut netlist = flatten::flatten(parsed, parameters).map_err(in_files)?;
    netlist.warnings = std::mem::take(&mut netlist.warnings)
        .into_iter()
        .map(|w| w.in_files(&files))
        .collect();
    for origin in &mut netlist.origins {
        origin.file = files.get(origin.file_index).cloned().unwrap_or_default();
    }
    netlist.files = files;
    Ok(netlist)
}
