//! A model loaded from a netlist or a scene, with parameters set by name.

use std::path::Path;

use dirac_graph::Interconnection;
use dirac_netlist::{
    Circuit, ControlledSource, Element, MOSFET_INSTANCE_KEYS, Netlist, SourceSpec, build_circuit,
    parse_netlist, parse_netlist_with,
};
use dirac_scene::{BuiltScene, Scene, SceneError};
use dirac_sim::{Execution, Signal, Start};

use crate::StudyError;

/// What a model was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SourceKind {
    /// A SPICE-subset netlist.
    Netlist,
    /// A scene (TOML).
    Scene,
}

impl SourceKind {
    /// `"netlist"` or `"scene"`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Netlist => "netlist",
            Self::Scene => "scene",
        }
    }
}

/// The kind of file at `path`, by its extension.
///
/// # Errors
/// [`StudyError::FileType`] for anything but `.cir`, `.sp`, `.net`, `.spice` and `.toml`.
pub fn kind_of(path: &Path) -> Result<SourceKind, StudyError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("cir" | "sp" | "net" | "spice") => Ok(SourceKind::Netlist),
        Some("toml") => Ok(SourceKind::Scene),
        _ => Err(StudyError::FileType {
            file: path.display().to_string(),
        }),
    }
}

/// The built form of a model.
#[derive(Debug, Clone)]
pub(crate) enum Built {
    Netlist {
        netlist: Box<Netlist>,
        circuit: Box<Circuit>,
    },
    Scene {
        table: Box<toml::Table>,
        scene: Box<BuiltScene>,
    },
}

/// A netlist or scene, read once, with parameters set by name (`R1.r`, `C1.c`,
/// `V1.waveform.amplitude`): the unit that is run, compared, checked, swept and shipped to other
/// processes (its source text and its parameter changes describe it completely, see
/// [`Model::restore`]).
///
/// Parameter names are `<part>.<parameter>` with the scene format's names. In a scene, `<part>`
/// is a part's `name` (or a coupling's, whose element keys it reaches directly) and
/// `<parameter>` a key of its table (`r`, `c`, `q0`; nested keys with dots:
/// `waveform.frequency`). A netlist's elements take the names of the scene parts they become
/// (`dirac convert`): `R1.r`, `L1.l`, `C1.c`, `L1.ic`, `C1.ic`, `K1.k`, `D1.is`, `D1.n`, `D1.rs`,
/// `V1.waveform` (a DC value) and `V1.waveform.<key>` for `SIN` (`offset`, `amplitude`,
/// `frequency`, `delay`, `damping`, `phase`) and `PULSE` (`v1`, `v2`, `delay`, `rise`, `fall`,
/// `width`, `period`); element names are case-insensitive and hierarchical (`X1.R2.r`). A
/// netlist's top-level `.param` is set by its own name (`wn`, as ngspice's `.step param wn`)
/// and a MOSFET's instance parameters as `M1.w` (`l`, `w`, `ad`, `as`, `pd`, `ps`, `nrd`,
/// `nrs`, `m`): the text is read again with that value, so every expression that uses it
/// follows (a MOSFET's `W={wn}` and the junctions and capacitances derived from it).
#[derive(Debug, Clone)]
pub struct Model {
    name: String,
    kind: SourceKind,
    text: String,
    overrides: Vec<(String, f64)>,
    pub(crate) built: Built,
    parse_warnings: Vec<String>,
}

impl Model {
    /// Reads the netlist or scene at `path` (by its extension).
    ///
    /// # Errors
    /// A file that cannot be read, or whose content is not a valid netlist or scene.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, StudyError> {
        Self::from_file_reporting(path, &mut |_| {})
    }

    /// [`Model::from_file`], handing each of the reader's warnings (`file:line:column: ...`) to
    /// `report` as soon as the text is read, before a netlist is built: a netlist that reads
    /// but cannot become a circuit still shows them (the command line prints them so).
    ///
    /// # Errors
    /// See [`Model::from_file`].
    pub fn from_file_reporting(
        path: impl AsRef<Path>,
        report: &mut dyn FnMut(&str),
    ) -> Result<Self, StudyError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| StudyError::Io {
            file: name.clone(),
            message: e.to_string(),
        })?;
        let text = String::from_utf8(bytes).map_err(|e| StudyError::Io {
            file: name.clone(),
            message: format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        })?;
        Self::read(kind_of(path)?, &name, &text, &[], report)
    }

    /// A netlist from its text; `name` is used in messages (`name:line:column`).
    ///
    /// # Errors
    /// Text that is not a valid netlist, or a netlist that cannot become a circuit.
    pub fn netlist(text: &str, name: &str) -> Result<Self, StudyError> {
        Self::restore(SourceKind::Netlist, name, text, &[])
    }

    /// A scene from its TOML text; `name` is used in messages (`name:line:column`).
    ///
    /// # Errors
    /// Text that is not a valid scene.
    pub fn scene(text: &str, name: &str) -> Result<Self, StudyError> {
        Self::restore(SourceKind::Scene, name, text, &[])
    }

    /// The model read from `text` with the parameter changes `overrides` applied in order: the
    /// inverse of ([`Model::kind`], [`Model::name`], [`Model::text`], [`Model::overrides`]).
    ///
    /// # Errors
    /// Text that is not valid, or a parameter change that is not.
    pub fn restore(
        kind: SourceKind,
        name: &str,
        text: &str,
        overrides: &[(String, f64)],
    ) -> Result<Self, StudyError> {
        Self::read(kind, name, text, overrides, &mut |_| {})
    }

    /// [`Model::restore`], handing the reader's warnings to `report` before building.
    fn read(
        kind: SourceKind,
        name: &str,
        text: &str,
        overrides: &[(String, f64)],
        report: &mut dyn FnMut(&str),
    ) -> Result<Self, StudyError> {
        let (built, parse_warnings) = match kind {
            SourceKind::Netlist => {
                let netlist = parse_netlist(text, name)?;
                let warnings: Vec<String> = netlist
                    .warnings
                    .iter()
                    .map(|w| format!("{}:{}:{}: {}", w.file, w.line, w.column, w.message))
                    .collect();
                for w in &warnings {
                    report(w);
                }
                let circuit = build_circuit(&netlist, name)?;
                (
                    Built::Netlist {
                        netlist: Box::new(netlist),
                        circuit: Box::new(circuit),
                    },
                    warnings,
                )
            }
            SourceKind::Scene => {
                let scene = Scene::parse(text, name)?.build()?;
                let table: toml::Table =
                    text.parse().map_err(|e: toml::de::Error| StudyError::Io {
                        file: name.to_string(),
                        message: e.to_string(),
                    })?;
                (
                    Built::Scene {
                        table: Box::new(table),
                        scene: Box::new(scene),
                    },
                    Vec::new(),
                )
            }
        };
        let mut model = Self {
            name: name.to_string(),
            kind,
            text: text.to_string(),
            overrides: Vec::new(),
            built,
            parse_warnings,
        };
        for (parameter, value) in overrides {
            model.set_parameter(parameter, *value)?;
        }
        Ok(model)
    }

    /// The name used in messages (the file's path for a file).
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Netlist or scene.
    #[must_use]
    pub fn kind(&self) -> SourceKind {
        self.kind
    }

    /// The source text as read (before any parameter change).
    #[must_use]
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The parameter changes applied since reading, in order (one entry per name, the last value).
    #[must_use]
    pub fn overrides(&self) -> &[(String, f64)] {
        &self.overrides
    }

    /// The interconnection of parts.
    #[must_use]
    pub fn graph(&self) -> &Interconnection {
        match &self.built {
            Built::Netlist { circuit, .. } => &circuit.graph,
            Built::Scene { scene, .. } => &scene.graph,
        }
    }

    /// The built circuit, for a netlist.
    #[must_use]
    pub fn circuit(&self) -> Option<&Circuit> {
        match &self.built {
            Built::Netlist { circuit, .. } => Some(circuit),
            Built::Scene { .. } => None,
        }
    }

    /// The built scene, for a scene.
    #[must_use]
    pub fn built_scene(&self) -> Option<&BuiltScene> {
        match &self.built {
            Built::Scene { scene, .. } => Some(scene),
            Built::Netlist { .. } => None,
        }
    }

    /// The scene as TOML with the parameter changes applied (`None` for a netlist).
    #[must_use]
    pub fn scene_toml(&self) -> Option<String> {
        match &self.built {
            Built::Scene { table, .. } => Some(table.to_string()),
            Built::Netlist { .. } => None,
        }
    }

    /// What the reader noticed: netlist cards accepted but ignored (`file:line:column: ...`) and
    /// netlist options dirac does differently.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut out = self.parse_warnings.clone();
        if let Built::Netlist { circuit, .. } = &self.built {
            out.extend(circuit.warnings.iter().cloned());
        }
        out
    }

    /// The file's own signals: `.print`/`.probe`/`.save` or the netlist contract's default; a
    /// scene's `[record]`.
    #[must_use]
    pub fn default_signals(&self) -> Vec<Signal> {
        match &self.built {
            Built::Netlist { circuit, .. } => circuit.signals.clone(),
            Built::Scene { scene, .. } => scene.signals.clone(),
        }
    }

    /// The signal named `name` (`v(out)`, `i(l1)`, `q(c1)`, `v(a,b)` in a netlist; `C1.q`,
    /// `L1.i`, `A.x'`, `energy`, `power(R1)`, `force(n1)` in a scene).
    ///
    /// # Errors
    /// A name that is not a signal of this model, saying what exists.
    pub fn signal(&self, name: &str) -> Result<Signal, StudyError> {
        Ok(match &self.built {
            Built::Netlist { circuit, .. } => circuit.signal(name)?,
            Built::Scene { scene, .. } => scene.signal(name)?,
        })
    }

    /// The signals named in `names`.
    ///
    /// # Errors
    /// The first name that is not a signal of this model.
    pub fn signals(&self, names: &[String]) -> Result<Vec<Signal>, StudyError> {
        names.iter().map(|n| self.signal(n)).collect()
    }

    /// Where the file's run starts: a netlist without `UIC` at its operating point, a scene as its
    /// `initial` says.
    #[must_use]
    pub fn start(&self) -> Start {
        match &self.built {
            Built::Netlist { circuit, .. } => circuit.start(),
            Built::Scene { scene, .. } => scene.start,
        }
    }

    /// The file's own execution (a netlist's is monolithic).
    #[must_use]
    pub fn execution(&self) -> Execution {
        match &self.built {
            Built::Netlist { .. } => Execution::Assembled(dirac_graph::Representation::Monolithic),
            Built::Scene { scene, .. } => scene.execution,
        }
    }

    /// The first output time: a netlist's `.tran` TSTART, else 0.
    #[must_use]
    pub fn first_output_time(&self) -> f64 {
        match &self.built {
            Built::Netlist { circuit, .. } => circuit.tran.map_or(0.0, |t| t.tstart),
            Built::Scene { .. } => 0.0,
        }
    }

    /// Whether the file asks only for the operating point (a netlist with `.op` and no `.tran`).
    #[must_use]
    pub fn operating_point_only(&self) -> bool {
        matches!(&self.built, Built::Netlist { circuit, .. } if circuit.op && circuit.tran.is_none())
    }

    /// Sets parameter `name` (`R1.r`, see the type's documentation) to `value`, checking the
    /// changed model as the reader checks a file.
    ///
    /// # Errors
    /// [`StudyError::UnknownParameter`] for a name that names nothing (with what exists),
    /// [`StudyError::BadParameter`] for a value the part does not accept.
    pub fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), StudyError> {
        let bad = |reason: String| StudyError::BadParameter {
            name: name.to_string(),
            value,
            reason,
        };
        if !value.is_finite() {
            return Err(bad("parameters must be finite".into()));
        }
        match &mut self.built {
            Built::Netlist { netlist, circuit } if read_again(netlist, name) => {
                // A `.param` or a MOSFET's instance parameter: the text read again with every
                // such value set so far and this one, then the element values set so far, in
                // their order.
                let mut again: Vec<(String, f64)> = self
                    .overrides
                    .iter()
                    .filter(|(n, _)| read_again(netlist, n))
                    .cloned()
                    .collect();
                again.push((name.to_string(), value));
                let mut changed = parse_netlist_with(&self.text, &self.name, &again)
                    .map_err(|e| bad(e.to_string()))?;
                for (n, v) in self
                    .overrides
                    .iter()
                    .filter(|(n, _)| !read_again(netlist, n))
                {
                    *netlist_slot(&mut changed, n)?.value = *v;
                }
                **circuit = build_circuit(&changed, &self.name)?;
                **netlist = changed;
            }
            Built::Netlist { netlist, circuit } => {
                let mut changed = netlist.clone();
                let slot = netlist_slot(&mut changed, name)?;
                *slot.value = value;
                if let Some(requirement) = slot.requirement
                    && !requirement.holds(value)
                {
                    return Err(bad(format!("{} {}", slot.what, requirement.text())));
                }
                **circuit = build_circuit(&changed, &self.name)?;
                *netlist = changed;
            }
            Built::Scene { table, scene } => {
                let mut changed = table.clone();
                *scene_slot(&mut changed, name, true)? = toml::Value::Float(value);
                let text = changed.to_string();
                let rebuilt = Scene::parse(&text, &self.name)
                    .and_then(|s| s.build())
                    .map_err(|e| bad(without_location(&e)))?;
                **scene = rebuilt;
                *table = changed;
            }
        }
        match self.overrides.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = value,
            None => self.overrides.push((name.to_string(), value)),
        }
        Ok(())
    }

    /// A copy with the parameters `names` set to `values`.
    ///
    /// # Errors
    /// See [`Model::set_parameter`]; [`StudyError::Sweep`] when the lengths differ.
    pub fn with_parameters(&self, names: &[String], values: &[f64]) -> Result<Self, StudyError> {
        if names.len() != values.len() {
            return Err(StudyError::Sweep(format!(
                "{} parameter names but {} values",
                names.len(),
                values.len()
            )));
        }
        let mut model = self.clone();
        for (n, v) in names.iter().zip(values) {
            model.set_parameter(n, *v)?;
        }
        Ok(model)
    }

    /// The current value of parameter `name`.
    ///
    /// # Errors
    /// [`StudyError::UnknownParameter`] for a name that names nothing, or names a value that is
    /// not a number.
    pub fn parameter(&self, name: &str) -> Result<f64, StudyError> {
        match &self.built {
            Built::Netlist { netlist, .. } => {
                let mut copy = netlist.as_ref().clone();
                Ok(*netlist_slot(&mut copy, name)?.value)
            }
            Built::Scene { table, .. } => {
                let mut copy = table.as_ref().clone();
                let slot = scene_slot(&mut copy, name, false)?;
                slot.as_float()
                    .or_else(|| slot.as_integer().map(|i| i as f64))
                    .ok_or_else(|| StudyError::UnknownParameter {
                        name: name.to_string(),
                        reason: format!("its value `{slot}` is not a number"),
                    })
            }
        }
    }

    /// Every numeric parameter the model states, with its value, in file order.
    #[must_use]
    pub fn parameters(&self) -> Vec<(String, f64)> {
        match &self.built {
            Built::Netlist { netlist, .. } => netlist_parameters(netlist),
            Built::Scene { table, .. } => scene_parameters(table),
        }
    }
}

/// The message of a scene error without its `file:line:column: ` prefix (the position is in
/// the regenerated text of a changed scene, which the user never saw).
fn without_location(e: &SceneError) -> String {
    let message = e.to_string();
    match e.location() {
        Some(at) => message
            .strip_prefix(&format!("{at}: "))
            .map_or_else(|| message.clone(), str::to_string),
        None => message,
    }
}

/// Whether the netlist parameter `name` is set by reading the text again: a top-level `.param`
/// (everything that uses it follows) or a MOSFET's instance parameter (its junctions and
/// capacitances are derived from the geometry when the card is read).
fn read_again(netlist: &Netlist, name: &str) -> bool {
    if netlist
        .parameters
        .iter()
        .any(|(p, _)| p.eq_ignore_ascii_case(name))
    {
        return true;
    }
    let lower = name.to_ascii_lowercase();
    netlist.elements.iter().any(|e| {
        matches!(
            e,
            Element::Controlled {
                source: ControlledSource::Mosfet { .. },
                ..
            }
        ) && lower
            .strip_prefix(e.name())
            .and_then(|rest| rest.strip_prefix('.'))
            .is_some_and(|key| MOSFET_INSTANCE_KEYS.contains(&key))
    })
}

/// A range a netlist value must lie in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Requirement {
    Positive,
    NonZero,
    NonNegative,
    UnitInterval,
}

impl Requirement {
    fn holds(self, v: f64) -> bool {
        match self {
            Self::Positive => v > 0.0,
            Self::NonZero => v != 0.0,
            Self::NonNegative => v >= 0.0,
            Self::UnitInterval => (-1.0..=1.0).contains(&v),
        }
    }

    fn text(self) -> &'static str {
        match self {
            Self::Positive => "must be positive",
            Self::NonZero => "must not be zero",
            Self::NonNegative => "must not be negative",
            Self::UnitInterval => "must lie in [-1, 1]",
        }
    }
}

/// A netlist value a parameter name reaches, with what it is and the range it must lie in.
struct NetlistSlot<'a> {
    value: &'a mut f64,
    what: String,
    requirement: Option<Requirement>,
}

/// The parameter keys of an element, in the scene format's names.
fn element_keys(element: &Element) -> Vec<&'static str> {
    match element {
        Element::R { .. } => vec!["r"],
        Element::L { .. } => vec!["l", "ic"],
        Element::C { .. } => vec!["c", "ic"],
        Element::K { .. } => vec!["k"],
        Element::D { .. } => vec!["is", "n", "rs"],
        Element::Controlled { source, .. } => match source {
            ControlledSource::Vcvs { .. } | ControlledSource::Cccs { .. } => vec!["gain"],
            ControlledSource::Vccs { .. } => vec!["gm"],
            ControlledSource::Ccvs { .. } => vec!["r"],
            // An expression has no one number to sweep.
            ControlledSource::Behavioural { .. } => Vec::new(),
            ControlledSource::Mosfet { .. } => MOSFET_INSTANCE_KEYS.to_vec(),
            ControlledSource::Bjt { .. } => Vec::new(),
        },
        Element::V { source, .. } | Element::I { source, .. } => match source {
            SourceSpec::Dc(_) => vec!["waveform"],
            SourceSpec::Sin { .. } => vec![
                "waveform.offset",
                "waveform.amplitude",
                "waveform.frequency",
                "waveform.delay",
                "waveform.damping",
                "waveform.phase",
            ],
            SourceSpec::Pulse { .. } => vec![
                "waveform.v1",
                "waveform.v2",
                "waveform.delay",
                "waveform.rise",
                "waveform.fall",
                "waveform.width",
                "waveform.period",
            ],
            SourceSpec::Exp { .. } => vec![
                "waveform.v1",
                "waveform.v2",
                "waveform.rise_delay",
                "waveform.rise_tau",
                "waveform.fall_delay",
                "waveform.fall_tau",
            ],
            SourceSpec::Sffm { .. } => vec![
                "waveform.offset",
                "waveform.amplitude",
                "waveform.carrier",
                "waveform.index",
                "waveform.signal",
            ],
            SourceSpec::Am { .. } => vec![
                "waveform.amplitude",
                "waveform.offset",
                "waveform.modulation",
                "waveform.carrier",
                "waveform.delay",
            ],
            SourceSpec::Pwl { .. } => Vec::new(),
        },
    }
}

fn netlist_slot<'a>(netlist: &'a mut Netlist, name: &str) -> Result<NetlistSlot<'a>, StudyError> {
    let unknown = |reason: String| StudyError::UnknownParameter {
        name: name.to_string(),
        reason,
    };
    let lower = name.to_ascii_lowercase();
    // Element names may contain dots (`x1.r2`), so the longest element name that prefixes the
    // parameter name is the element.
    let found = netlist
        .elements
        .iter()
        .enumerate()
        .filter(|(_, e)| {
            lower.len() > e.name().len() + 1
                && lower.starts_with(e.name())
                && lower.as_bytes()[e.name().len()] == b'.'
        })
        .max_by_key(|(_, e)| e.name().len())
        .map(|(i, _)| i);
    let Some(index) = found else {
        let names: Vec<&str> = netlist.origins.iter().map(|o| o.name.as_str()).collect();
        let params: Vec<&str> = netlist.parameters.iter().map(|(p, _)| p.as_str()).collect();
        return Err(unknown(format!(
            "no element is named `{}`; the elements are {}{}",
            name.rsplit_once('.').map_or(name, |(e, _)| e),
            names.join(", "),
            if params.is_empty() {
                String::new()
            } else {
                format!(", and the top-level .param names {}", params.join(", "))
            }
        )));
    };
    let element_name = netlist.origins[index].name.clone();
    let key = lower[netlist.elements[index].name().len() + 1..].to_string();
    let keys = element_keys(&netlist.elements[index]);
    let what = format!("`{element_name}.{key}`");
    let missing = |keys: &[&str]| {
        unknown(if keys.is_empty() {
            format!("element `{element_name}` has no parameter that can be set by name")
        } else {
            format!(
                "element `{element_name}` has no parameter `{key}`; its parameters are {}",
                keys.iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
    };
    use Requirement::{NonNegative, NonZero, Positive, UnitInterval};
    let (value, requirement): (&mut f64, Option<Requirement>) =
        match (&mut netlist.elements[index], key.as_str()) {
            (Element::R { value, .. }, "r") => (value, Some(NonZero)),
            (Element::L { value, .. }, "l") | (Element::C { value, .. }, "c") => {
                (value, Some(Positive))
            }
            (Element::L { ic, .. } | Element::C { ic, .. }, "ic") => (ic.get_or_insert(0.0), None),
            (Element::K { k, .. }, "k") => (k, Some(UnitInterval)),
            (Element::D { model, .. }, "is") => (&mut model.card.is, Some(Positive)),
            (Element::D { model, .. }, "n") => (&mut model.card.n, Some(Positive)),
            (Element::D { model, .. }, "rs") => (&mut model.card.rs, Some(NonNegative)),
            (Element::Controlled { source, .. }, key) => match (source, key) {
                (
                    ControlledSource::Vcvs { gain, .. } | ControlledSource::Cccs { gain, .. },
                    "gain",
                ) => (gain, None),
                (ControlledSource::Vccs { gm, .. }, "gm") => (gm, None),
                (ControlledSource::Ccvs { r, .. }, "r") => (r, None),
                _ => return Err(missing(&keys)),
            },
            (Element::V { source, .. } | Element::I { source, .. }, key) => match (source, key) {
                (SourceSpec::Dc(v), "waveform") => (v, None),
                (SourceSpec::Sin { vo, .. }, "waveform.offset") => (vo, None),
                (SourceSpec::Sin { va, .. }, "waveform.amplitude") => (va, None),
                (SourceSpec::Sin { freq, .. }, "waveform.frequency") => (freq, Some(NonNegative)),
                (SourceSpec::Sin { td, .. }, "waveform.delay") => (td, Some(NonNegative)),
                (SourceSpec::Sin { theta, .. }, "waveform.damping") => (theta, None),
                (SourceSpec::Sin { phase, .. }, "waveform.phase") => (phase, None),
                (SourceSpec::Pulse { v1, .. }, "waveform.v1") => (v1, None),
                (SourceSpec::Pulse { v2, .. }, "waveform.v2") => (v2, None),
                (SourceSpec::Pulse { td, .. }, "waveform.delay") => (td, Some(NonNegative)),
                (SourceSpec::Pulse { tr, .. }, "waveform.rise") => (tr, Some(NonNegative)),
                (SourceSpec::Pulse { tf, .. }, "waveform.fall") => (tf, Some(NonNegative)),
                (SourceSpec::Pulse { pw, .. }, "waveform.width") => (pw, Some(NonNegative)),
                (SourceSpec::Pulse { per, .. }, "waveform.period") => (per, Some(NonNegative)),
                (SourceSpec::Exp { v1, .. }, "waveform.v1") => (v1, None),
                (SourceSpec::Exp { v2, .. }, "waveform.v2") => (v2, None),
                (SourceSpec::Exp { td1, .. }, "waveform.rise_delay") => (td1, None),
                (SourceSpec::Exp { tau1, .. }, "waveform.rise_tau") => (tau1, Some(NonNegative)),
                (SourceSpec::Exp { td2, .. }, "waveform.fall_delay") => (td2, None),
                (SourceSpec::Exp { tau2, .. }, "waveform.fall_tau") => (tau2, Some(NonNegative)),
                (SourceSpec::Sffm { vo, .. }, "waveform.offset") => (vo, None),
                (SourceSpec::Sffm { va, .. }, "waveform.amplitude") => (va, None),
                (SourceSpec::Sffm { fc, .. }, "waveform.carrier") => (fc, Some(NonNegative)),
                (SourceSpec::Sffm { mdi, .. }, "waveform.index") => (mdi, None),
                (SourceSpec::Sffm { fs, .. }, "waveform.signal") => (fs, Some(NonNegative)),
                (SourceSpec::Am { va, .. }, "waveform.amplitude") => (va, None),
                (SourceSpec::Am { vo, .. }, "waveform.offset") => (vo, None),
                (SourceSpec::Am { mf, .. }, "waveform.modulation") => (mf, Some(NonNegative)),
                (SourceSpec::Am { fc, .. }, "waveform.carrier") => (fc, Some(NonNegative)),
                (SourceSpec::Am { td, .. }, "waveform.delay") => (td, None),
                _ => return Err(missing(&keys)),
            },
            _ => return Err(missing(&keys)),
        };
    Ok(NetlistSlot {
        value,
        what,
        requirement,
    })
}

fn netlist_parameters(netlist: &Netlist) -> Vec<(String, f64)> {
    let mut copy = netlist.clone();
    let mut out = netlist.parameters.clone();
    for (element, origin) in netlist.elements.iter().zip(&netlist.origins) {
        for key in element_keys(element) {
            let name = format!("{}.{key}", origin.name);
            let stated = match (element, key) {
                (Element::L { ic, .. } | Element::C { ic, .. }, "ic") => ic.is_some(),
                _ => true,
            };
            if stated && let Ok(slot) = netlist_slot(&mut copy, &name) {
                out.push((name, *slot.value));
            }
        }
    }
    out
}

/// The TOML value a scene parameter name reaches. With `create`, an absent key is added (so that
/// a default can be set; the scene reader then rejects keys the part does not have); without, an
/// absent key is an error.
fn scene_slot<'a>(
    table: &'a mut toml::Table,
    name: &str,
    create: bool,
) -> Result<&'a mut toml::Value, StudyError> {
    let unknown = |reason: String| StudyError::UnknownParameter {
        name: name.to_string(),
        reason,
    };
    let Some((item, path)) = name.split_once('.') else {
        return Err(unknown(
            "write `<part>.<parameter>`, e.g. `R1.r` or `V1.waveform.amplitude`".into(),
        ));
    };
    let named = |list: Option<&toml::Value>| -> Vec<String> {
        list.and_then(toml::Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(|t| t.get("name").and_then(toml::Value::as_str))
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default()
    };
    let parts = named(table.get("part"));
    let connections = named(table.get("connection"));
    let (list, index) = if let Some(i) = parts.iter().position(|p| p == item) {
        ("part", i)
    } else if let Some(i) = connections.iter().position(|c| c == item) {
        ("connection", i)
    } else {
        return Err(unknown(format!(
            "no part or connection is named `{item}`; the parts are {}",
            if parts.is_empty() {
                "(none)".to_string()
            } else {
                parts
                    .iter()
                    .map(|p| format!("`{p}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        )));
    };
    let mut target = table
        .get_mut(list)
        .and_then(toml::Value::as_array_mut)
        .and_then(|a| a.get_mut(index))
        .and_then(toml::Value::as_table_mut)
        .ok_or_else(|| unknown(format!("`{item}` is not a table")))?;
    if list == "connection" {
        // A coupling's parameters are its element's.
        let is_coupling = target.get("type").and_then(toml::Value::as_str) == Some("coupling");
        if !is_coupling {
            return Err(unknown(format!(
                "connection `{item}` is not a coupling; only a coupling element has parameters"
            )));
        }
        target = target
            .get_mut("element")
            .and_then(toml::Value::as_table_mut)
            .ok_or_else(|| unknown(format!("coupling `{item}` has no element table")))?;
    }
    let keys: Vec<&str> = path.split('.').collect();
    for (depth, key) in keys.iter().enumerate() {
        if matches!(*key, "name" | "type") {
            return Err(unknown(format!("`{key}` is not a numeric parameter")));
        }
        let last = depth + 1 == keys.len();
        if last {
            if !create && !target.contains_key(*key) {
                let keys: Vec<String> = target
                    .iter()
                    .filter(|(k, v)| {
                        !matches!(k.as_str(), "name" | "type") && (v.is_float() || v.is_integer())
                    })
                    .map(|(k, _)| format!("`{k}`"))
                    .collect();
                return Err(unknown(format!(
                    "`{item}` states no `{}`; its numeric parameters are {}",
                    path,
                    if keys.is_empty() {
                        "(none)".to_string()
                    } else {
                        keys.join(", ")
                    }
                )));
            }
            let value = target
                .entry((*key).to_string())
                .or_insert(toml::Value::Float(0.0));
            if !(value.is_float() || value.is_integer()) {
                return Err(unknown(format!(
                    "`{}` is `{value}`, not a number",
                    keys[..=depth].join(".")
                )));
            }
            return Ok(value);
        }
        target = target
            .get_mut(*key)
            .and_then(toml::Value::as_table_mut)
            .ok_or_else(|| {
                unknown(format!(
                    "`{item}.{}` is not a table of parameters",
                    keys[..=depth].join(".")
                ))
            })?;
    }
    Err(unknown("empty parameter path".into()))
}

fn scene_parameters(table: &toml::Table) -> Vec<(String, f64)> {
    fn walk(prefix: &str, t: &toml::Table, out: &mut Vec<(String, f64)>) {
        for (k, v) in t {
            if matches!(k.as_str(), "name" | "type") {
                continue;
            }
            let name = format!("{prefix}.{k}");
            match v {
                toml::Value::Float(x) => out.push((name, *x)),
                toml::Value::Integer(i) => out.push((name, *i as f64)),
                toml::Value::Table(inner) => walk(&name, inner, out),
                _ => {}
            }
        }
    }
    let mut out = Vec::new();
    for (list, element) in [("part", false), ("connection", true)] {
        for item in table
            .get(list)
            .and_then(toml::Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(toml::Value::as_table)
        {
            let Some(name) = item.get("name").and_then(toml::Value::as_str) else {
                continue;
            };
            if element {
                if let Some(e) = item.get("element").and_then(toml::Value::as_table) {
                    walk(name, e, &mut out);
                }
            } else {
                walk(name, item, &mut out);
            }
        }
    }
    out
}
