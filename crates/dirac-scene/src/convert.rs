//! Netlist → scene conversion (`dirac convert`).

use std::collections::HashMap;
use std::fmt::Write;

use dirac_components::{Diode, DiodeParameters};
use dirac_netlist::{
    CircuitError, ControlledSource, DeviceConditions, DiodeModel, Element, Netlist, SourceSpec,
};

use crate::{Scene, SceneError};

/// Why a netlist could not be converted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvertError {
    /// The netlist cannot become a circuit (same checks as `dirac run`).
    #[error(transparent)]
    Circuit(#[from] CircuitError),
    /// The netlist has no `.tran` card, so the scene would have no step size.
    #[error("{0}: no .tran card; a scene needs h and t_end")]
    NoTran(String),
    /// A behavioural source (`B`, or `E`/`F`/`G`/`H` with `VALUE=` or `POLY`), which has no scene
    /// part.
    #[error(
        "{file}:{line}:{column}: `{element}` is a behavioural source (B, or E F G H with VALUE=, \
         VOL=, CUR= or POLY): scenes have no part for its expression; run the netlist itself"
    )]
    Behavioural {
        /// The netlist file.
        file: String,
        /// Line of the element's card.
        line: usize,
        /// Column of the element's name.
        column: usize,
        /// The element as written.
        element: String,
    },
    /// A bipolar transistor, which scenes have no part for.
    #[error(
        "{file}:{line}:{column}: `{element}` is a bipolar transistor: scenes have no part for it; \
         run the netlist itself"
    )]
    Bjt {
        /// The netlist file.
        file: String,
        /// Line of the element's card.
        line: usize,
        /// Column of the element's name.
        column: usize,
        /// The element as written.
        element: String,
    },
    /// A MOSFET, which scenes have no part for.
    #[error(
        "{file}:{line}:{column}: `{element}` is a MOSFET: scenes have no part for it; run the \
         netlist itself"
    )]
    Mosfet {
        /// The netlist file.
        file: String,
        /// Line of the element's card.
        line: usize,
        /// Column of the element's name.
        column: usize,
        /// The element as written.
        element: String,
    },
    /// The generated scene did not parse back (a bug in the converter).
    #[error("generated scene is invalid: {0}")]
    Invalid(#[from] SceneError),
}

/// A scene part or connection name: netlist names lowercased, hierarchy dots as underscores.
fn ident(name: &str) -> String {
    name.replace('.', "_")
}

fn number(x: f64) -> String {
    // TOML needs a decimal point or exponent for floats; `{:?}` gives the shortest round-trip form.
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E', 'i', 'N']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// A scene diode with the model's card at the circuit's temperature and `GMIN`: every key whose
/// value differs from the scene's default.
fn diode(model: &DiodeModel, conditions: DeviceConditions) -> String {
    let c = &model.card;
    let d = DiodeParameters::default();
    let tnom = if model.tnom_given {
        c.tnom
    } else {
        conditions.tnom
    };
    let mut out = String::from("type = \"diode\"");
    let mut key = |name: &str, value: f64, default: f64| {
        if value.to_bits() != default.to_bits() {
            let _ = write!(out, "\n{name} = {}", number(value));
        }
    };
    key("is", c.is, d.is);
    key("n", c.n, d.n);
    key("rs", c.rs, d.rs);
    key("cjo", c.cjo, d.cjo);
    key("vj", c.vj, d.vj);
    key("m", c.m, d.m);
    key("fc", c.fc, d.fc);
    key("tt", c.tt, d.tt);
    if let Some(bv) = c.bv {
        key("bv", bv, f64::NAN); // NaN: a given value is always written
    }
    key("ibv", c.ibv, d.ibv);
    if let Some(nbv) = c.nbv {
        key("nbv", nbv, f64::NAN);
    }
    key("eg", c.eg, d.eg);
    key("xti", c.xti, d.xti);
    key("tcv", c.tcv, d.tcv);
    key("trs1", c.trs[0], d.trs[0]);
    key("trs2", c.trs[1], d.trs[1]);
    key("ttt1", c.ttt[0], d.ttt[0]);
    key("ttt2", c.ttt[1], d.ttt[1]);
    key("tm1", c.tm[0], d.tm[0]);
    key("tm2", c.tm[1], d.tm[1]);
    key("area", c.area, d.area);
    // The scene's `tnom` defaults to its `temp`, whose default is ngspice's 27 °C.
    let temp = model.temp.unwrap_or(conditions.temp);
    key("temp", temp, d.tnom);
    key("tnom", tnom, temp);
    key("gmin", conditions.gmin, Diode::GMIN);
    out
}

fn waveform(spec: &SourceSpec) -> String {
    match spec {
        SourceSpec::Dc(v) => number(*v),
        SourceSpec::Sin {
            vo,
            va,
            freq,
            td,
            theta,
            phase,
        } => format!(
            "{{ shape = \"sin\", offset = {}, amplitude = {}, frequency = {}, delay = {}, damping = {}, phase = {} }}",
            number(*vo),
            number(*va),
            number(*freq),
            number(*td),
            number(*theta),
            number(*phase)
        ),
        SourceSpec::Pulse {
            v1,
            v2,
            td,
            tr,
            tf,
            pw,
            per,
            np,
        } => {
            let period = if *per > 0.0 {
                format!(", period = {}", number(*per))
            } else {
                String::new()
            };
            let pulses = if *np > 0.0 {
                format!(", pulses = {}", number(*np))
            } else {
                String::new()
            };
            format!(
                "{{ shape = \"pulse\", v1 = {}, v2 = {}, delay = {}, rise = {}, fall = {}, width = {}{period}{pulses} }}",
                number(*v1),
                number(*v2),
                number(*td),
                number(*tr),
                number(*tf),
                number(*pw)
            )
        }
        SourceSpec::Exp {
            v1,
            v2,
            td1,
            tau1,
            td2,
            tau2,
        } => format!(
            "{{ shape = \"exp\", v1 = {}, v2 = {}, rise_delay = {}, rise_tau = {}, fall_delay = {}, fall_tau = {} }}",
            number(*v1),
            number(*v2),
            number(*td1),
            number(*tau1),
            number(*td2),
            number(*tau2)
        ),
        SourceSpec::Sffm {
            vo,
            va,
            fc,
            mdi,
            fs,
            phasec,
            phases,
        } => format!(
            "{{ shape = \"sffm\", offset = {}, amplitude = {}, carrier = {}, index = {}, signal = {}, carrier_phase = {}, signal_phase = {} }}",
            number(*vo),
            number(*va),
            number(*fc),
            number(*mdi),
            number(*fs),
            number(*phasec),
            number(*phases)
        ),
        SourceSpec::Am {
            va,
            vo,
            mf,
            fc,
            td,
            phases,
            ..
        } => format!(
            "{{ shape = \"am\", amplitude = {}, offset = {}, modulation = {}, carrier = {}, delay = {}, phase = {} }}",
            number(*va),
            number(*vo),
            number(*mf),
            number(*fc),
            number(*td),
            number(*phases)
        ),
        SourceSpec::Pwl { points, td, r } => {
            let list: Vec<String> = points
                .iter()
                .map(|(t, v)| format!("[{}, {}]", number(*t), number(*v)))
                .collect();
            let delay = if *td != 0.0 {
                format!(", delay = {}", number(*td))
            } else {
                String::new()
            };
            let repeat = r.map_or(String::new(), |r| format!(", repeat = {}", number(r)));
            format!(
                "{{ shape = \"pwl\", points = [{}]{delay}{repeat} }}",
                list.join(", ")
            )
        }
    }
}

/// The scene (TOML text) equivalent to `netlist`: one part per element (a `K` card and its two
/// inductors become one `coupled_inductors` part), one KCL node per non-ground node, the `.tran`
/// end time and the step the netlist's run takes (TSTEP, or TSTEP/m where ngspice's largest step
/// is shorter: [`dirac_netlist::Tran::steps_per_row`]), midpoint rule, (+) scheme, monolithic representation. The text is parsed back
/// before it is returned, so it is always a valid scene.
pub fn netlist_to_scene(netlist: &Netlist, file: &str) -> Result<String, ConvertError> {
    // Reuse the circuit builder's checks (coupling, nodes) so convert fails exactly where run would.
    dirac_netlist::build_circuit(netlist, file)?;
    let conditions = DeviceConditions::read(netlist, file)?;
    let tran = netlist
        .tran
        .as_ref()
        .ok_or_else(|| ConvertError::NoTran(file.to_string()))?;
    let mut out = String::new();
    let _ = writeln!(out, "# Converted from {file} by `dirac convert`.");
    if !netlist.title.is_empty() {
        let _ = writeln!(out, "# {}", netlist.title);
    }
    let _ = writeln!(
        out,
        "\n[simulation]\nrepresentation = \"monolithic\"\nscheme = \"plus\"\ndiscretisation = \"midpoint\""
    );
    // The netlist's run steps at TSTEP/m (ngspice's largest step, `Tran::steps_per_row`); the
    // scene takes the same steps, every one a row.
    let every = tran.steps_per_row();
    if every > 1 {
        let _ = writeln!(
            out,
            "# .tran TSTEP = {}: stepped at TSTEP/{every}, ngspice's largest internal step",
            number(tran.tstep)
        );
    }
    // …and ends where the netlist's run ends.
    let t_end = tran.run_end(tran.tstop);
    let _ = writeln!(
        out,
        "h = {}\nt_end = {}",
        number(tran.tstep / every as f64),
        number(t_end)
    );
    if !tran.uic {
        // Without UIC a SPICE transient starts from the DC operating point.
        let _ = writeln!(out, "initial = \"equilibrium\"");
    }

    // Inductors coupled by a K card: name → (K part, port).
    let mut coupled: HashMap<&str, (String, &str)> = HashMap::new();

    for element in &netlist.elements {
        if let Element::K { name, l1, l2, k } = element {
            let ((v1, i1), (v2, i2)) = (
                netlist.inductor(l1).unwrap_or((0.0, None)),
                netlist.inductor(l2).unwrap_or((0.0, None)),
            );
            let _ = writeln!(
                out,
                "\n[[part]]\nname = \"{}\"\ntype = \"coupled_inductors\"",
                ident(name)
            );
            let _ = writeln!(
                out,
                "l1 = {}\nl2 = {}\nk = {}",
                number(v1),
                number(v2),
                number(*k)
            );
            if i1.is_some() || i2.is_some() {
                let _ = writeln!(
                    out,
                    "v0 = [{}, {}]",
                    number(i1.unwrap_or(0.0)),
                    number(i2.unwrap_or(0.0))
                );
            }
            coupled.insert(l1.as_str(), (ident(name), "i1"));
            coupled.insert(l2.as_str(), (ident(name), "i2"));
        }
    }
    let mut port_of: HashMap<&str, String> = HashMap::new();
    for (element, origin) in netlist.elements.iter().zip(&netlist.origins) {
        let name = element.name();
        let part = ident(name);
        let body = match element {
            Element::R { value, .. } => format!("type = \"resistor\"\nr = {}", number(*value)),
            Element::L {
                name, value, ic, ..
            } => {
                if let Some((k, port)) = coupled.get(name.as_str()) {
                    port_of.insert(name, format!("{k}.{port}"));
                    continue;
                }
                let mut b = format!("type = \"inductor\"\nl = {}", number(*value));
                if let Some(i) = ic {
                    let _ = write!(b, "\nv0 = {}", number(*i));
                }
                b
            }
            Element::C {
                n1, n2, value, ic, ..
            } => {
                let mut b = format!("type = \"capacitor\"\nc = {}", number(*value));
                if let Some(v) = netlist.capacitor_voltage(n1, n2, *ic) {
                    let _ = write!(b, "\nq0 = {}", number(value * v));
                }
                b
            }
            Element::V { source, .. } => {
                format!("type = \"voltage_source\"\nwaveform = {}", waveform(source))
            }
            Element::I { source, .. } => {
                format!("type = \"current_source\"\nwaveform = {}", waveform(source))
            }
            Element::D { model, .. } => diode(model, conditions),
            Element::K { .. } => continue,
            Element::Controlled { source, .. } => match source {
                ControlledSource::Vcvs { gain, .. } => {
                    format!("type = \"vcvs\"\ngain = {}", number(*gain))
                }
                ControlledSource::Vccs { gm, .. } => {
                    format!("type = \"vccs\"\ngm = {}", number(*gm))
                }
                ControlledSource::Cccs { gain, .. } => {
                    format!("type = \"cccs\"\ngain = {}", number(*gain))
                }
                ControlledSource::Ccvs { r, .. } => format!("type = \"ccvs\"\nr = {}", number(*r)),
                ControlledSource::Behavioural { .. } => {
                    return Err(ConvertError::Behavioural {
                        file: origin.file.clone(),
                        line: origin.line,
                        column: origin.column,
                        element: origin.name.clone(),
                    });
                }
                ControlledSource::Bjt { .. } => {
                    return Err(ConvertError::Bjt {
                        file: origin.file.clone(),
                        line: origin.line,
                        column: origin.column,
                        element: origin.name.clone(),
                    });
                }
                ControlledSource::Mosfet { .. } => {
                    return Err(ConvertError::Mosfet {
                        file: origin.file.clone(),
                        line: origin.line,
                        column: origin.column,
                        element: origin.name.clone(),
                    });
                }
            },
        };
        let _ = writeln!(out, "\n[[part]]\nname = \"{part}\"\n{body}");
        port_of.insert(name, format!("{part}.i"));
    }
    // KCL: a branch's flow leaves its first node (−1) and enters its second (+1). A source whose
    // current controls F or H sources runs through their sensing shorts (`ic`) in series, joined
    // by nodes of its own (`{source}_sense_{k}`, as `dirac run` builds them); an E or G senses its
    // controlling nodes with its `ic` branch.
    let shorts = netlist.sensing_shorts();
    let taken: std::collections::HashSet<String> =
        netlist.nodes().iter().map(|n| ident(n)).collect();
    let mut terminals: HashMap<String, Vec<(String, f64)>> = HashMap::new();
    let mut internal: Vec<String> = Vec::new();
    let mut join = |from: &str, to: &str, port: String| {
        terminals
            .entry(from.to_owned())
            .or_default()
            .push((port.clone(), -1.0));
        terminals
            .entry(to.to_owned())
            .or_default()
            .push((port, 1.0));
    };
    for element in &netlist.elements {
        let name = element.name();
        if let Element::Controlled { source, .. } = element {
            for (port, a, b) in source.sensed_voltages() {
                join(a, b, format!("{}.{port}", ident(name)));
            }
        }
        let (Some((a, b)), Some(port)) = (element.terminals(), port_of.get(name)) else {
            continue;
        };
        let Some(chain) = shorts.get(name) else {
            join(a, b, port.clone());
            continue;
        };
        let branches = dirac_netlist::sensed_chain(name, a, b, chain, |k| {
            // A name no netlist node takes (one more `_` while one does).
            let mut node = format!("{}_sense_{k}", ident(name));
            while taken.contains(&node) {
                node.push('_');
            }
            internal.push(node.clone());
            node
        });
        for (part, port, from, to) in branches {
            join(&from, &to, format!("{}.{port}", ident(&part)));
        }
    }
    let named = netlist.nodes().into_iter().map(|n| (ident(&n), n));
    for (label, node) in named.chain(internal.into_iter().map(|n| (n.clone(), n))) {
        let ports = terminals.remove(node.as_str()).unwrap_or_default();
        let list: Vec<String> = ports
            .iter()
            .map(|(p, s)| format!("[\"{p}\", {}]", number(*s)))
            .collect();
        let _ = writeln!(
            out,
            "\n[[connection]]\ntype = \"node\"\nname = \"{label}\"\nports = [{}]",
            list.join(", ")
        );
    }
    Scene::parse(&out, file)?;
    Ok(out)
}
