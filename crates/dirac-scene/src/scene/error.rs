//! Errors of the scene front end, with source positions.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use dirac_graph::GraphError;
use dirac_sim::SimError;
use thiserror::Error;

use dirac_sim::RunError;

/// A place in a scene file: file name, 1-based line and 1-based column (in characters).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Location {
    /// The file name given to [`crate::Scene::parse`].
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column, counted in characters.
    pub column: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// `"file:line:col: "` before a message, or nothing for an item that did not come from a file.
fn place(at: &Option<Location>) -> String {
    at.as_ref().map_or_else(String::new, |l| format!("{l}: "))
}

/// Where an item of a scene came from: the position of its table and of every key and value
/// inside it (by path: `c`, `waveform.period`, `ports[1]`, `q0.x`).
///
/// Source positions are not part of a scene's meaning: two origins always compare equal, so a
/// scene parsed from a file equals the same scene parsed from its serialisation, and an item built
/// in code (with `Origin::default()`) equals one read from a file.
#[derive(Debug, Clone, Default)]
pub struct Origin {
    file: Option<Arc<str>>,
    at: Option<(usize, usize)>,
    fields: BTreeMap<String, (usize, usize)>,
    keys: BTreeMap<String, (usize, usize)>,
}

impl PartialEq for Origin {
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}

impl Origin {
    pub(crate) fn new(
        file: Arc<str>,
        at: (usize, usize),
        fields: BTreeMap<String, (usize, usize)>,
        keys: BTreeMap<String, (usize, usize)>,
    ) -> Self {
        Self {
            file: Some(file),
            at: Some(at),
            fields,
            keys,
        }
    }

    fn location(&self, at: Option<(usize, usize)>) -> Option<Location> {
        let (line, column) = at?;
        Some(Location {
            file: self.file.as_deref()?.to_string(),
            line,
            column,
        })
    }

    /// The position of the item itself (its table header or opening brace).
    #[must_use]
    pub fn item(&self) -> Option<Location> {
        self.location(self.at)
    }

    /// The position of the key of the value at `path` (a table entry), or of the item.
    #[must_use]
    pub fn key(&self, path: &str) -> Option<Location> {
        self.location(self.keys.get(path).copied().or(self.at))
    }

    /// The position of the value at `path` inside the item, if it was written.
    #[must_use]
    pub fn known_field(&self, path: &str) -> Option<Location> {
        self.location(Some(*self.fields.get(path)?))
    }

    /// The position of the value at `path` inside the item, or of the item if that value was not
    /// written (a default).
    #[must_use]
    pub fn field(&self, path: &str) -> Option<Location> {
        self.location(self.fields.get(path).copied().or(self.at))
    }
}

/// A scene that cannot be read, built or run.
///
/// `Display` starts with `file:line:column: ` whenever the offending item came from a file, and
/// otherwise names the part, port or connection at fault.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// What the operating system said.
        message: String,
    },
    /// TOML syntax, an unknown key, a value of the wrong type or a missing key.
    #[error("{at}: {message}")]
    Toml {
        /// Where.
        at: Location,
        /// What toml/serde said.
        message: String,
    },
    /// A part's `type` names no stock part.
    #[error("{}unknown part type `{type_name}`; the stock parts are {expected}", place(.at))]
    UnknownPartType {
        /// Where the `type` value is.
        at: Option<Location>,
        /// The unknown type.
        type_name: String,
        /// The known types, listed.
        expected: String,
    },
    /// A `type` (of a connection or coupling element) or a waveform `shape` that is not known.
    #[error("{}unknown {what} `{name}`; expected one of {expected}", place(.at))]
    UnknownKind {
        /// Where.
        at: Option<Location>,
        /// What kind of thing: "connection type", "coupling element", "waveform shape".
        what: &'static str,
        /// The unknown name.
        name: String,
        /// The known names, listed.
        expected: String,
    },
    /// Two parts (or two connections) share a name.
    #[error("{}{what} `{name}` is defined twice{}", place(.at), .first.as_ref().map_or_else(String::new, |l| format!(" (first at {l})")))]
    DuplicateName {
        /// Where the second definition is.
        at: Option<Location>,
        /// "part" or "connection".
        what: &'static str,
        /// The name.
        name: String,
        /// Where the first definition is.
        first: Option<Location>,
    },
    /// A name that cannot be used (empty, or a part name containing `.`).
    #[error("{}bad {what} name `{name}`: {reason}", place(.at))]
    BadName {
        /// Where.
        at: Option<Location>,
        /// "part" or "connection".
        what: &'static str,
        /// The name.
        name: String,
        /// Why not.
        reason: &'static str,
    },
    /// A reference names a part the scene does not have.
    #[error("{}unknown part `{part}` in `{reference}`", place(.at))]
    UnknownPart {
        /// Where the reference is.
        at: Option<Location>,
        /// The reference as written (`R9.i`).
        reference: String,
        /// The part it names.
        part: String,
    },
    /// A reference names a port its part does not have.
    #[error("{}part `{part}` has no port `{port}`; its ports are {available}", place(.at))]
    UnknownPort {
        /// Where the reference is.
        at: Option<Location>,
        /// The part.
        part: String,
        /// The missing port.
        port: String,
        /// The part's ports, listed.
        available: String,
    },
    /// An initial value or a signal names a coordinate the part does not have.
    #[error("{}part `{part}` has no coordinate `{coordinate}`; its coordinates are {available}", place(.at))]
    UnknownCoordinate {
        /// Where.
        at: Option<Location>,
        /// The part.
        part: String,
        /// The missing coordinate.
        coordinate: String,
        /// The part's coordinates, listed.
        available: String,
    },
    /// A port reference that is not of the form `part.port`.
    #[error("{}bad port reference `{reference}`: write `part.port`, e.g. `L1.i` or `A.x`", place(.at))]
    BadReference {
        /// Where.
        at: Option<Location>,
        /// The reference as written.
        reference: String,
    },
    /// A signal to record that does not name a coordinate, a rate or a flow.
    #[error("{}cannot record `{signal}`: {reason}", place(.at))]
    BadSignal {
        /// Where.
        at: Option<Location>,
        /// The signal as written.
        signal: String,
        /// Why not.
        reason: String,
    },
    /// A parameter outside its range (a negative capacitance, a non-finite value, ...).
    #[error("{}{item}: `{parameter}` = {value} {requirement}", place(.at))]
    BadParameter {
        /// Where the value is.
        at: Option<Location>,
        /// The part or connection, e.g. ``part `C1` (capacitor)``.
        item: String,
        /// The parameter's key.
        parameter: String,
        /// The value given.
        value: f64,
        /// What it must be, e.g. "must be positive".
        requirement: &'static str,
    },
    /// Initial data of the wrong length.
    #[error("{}part `{part}`: `{key}` has {got} value(s), one for each coordinate is needed ({coordinates})", place(.at))]
    InitialLength {
        /// Where.
        at: Option<Location>,
        /// The part.
        part: String,
        /// `q0` or `v0`.
        key: &'static str,
        /// Values given.
        got: usize,
        /// The part's coordinates, listed.
        coordinates: String,
    },
    /// A connection that cannot work: a node with fewer than two ports, a port joined to itself,
    /// a zero sign.
    #[error("{}connection `{connection}`: {reason}", place(.at))]
    BadConnection {
        /// Where.
        at: Option<Location>,
        /// The connection's name.
        connection: String,
        /// What is wrong.
        reason: String,
    },
    /// A node joins fewer than two ports.
    #[error("{}node `{node}` joins {count} port(s); a node needs at least two", place(.at))]
    TooFewPorts {
        /// Where.
        at: Option<Location>,
        /// The node.
        node: String,
        /// Ports given.
        count: usize,
    },
    /// A setting of `[simulation]` that is out of range or inconsistent.
    #[error("{}[simulation] `{setting}`: {reason}", place(.at))]
    BadSetting {
        /// Where.
        at: Option<Location>,
        /// The key.
        setting: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The scene could not be written as TOML.
    #[error("cannot write the scene as TOML: {0}")]
    Serialise(String),
    /// A rigid body or joint that cannot be built (an inertia that no body has, a frame that is
    /// not a rotation, a joint with no coordinate to couple).
    #[error("{}{item}: {reason}", place(.at))]
    BadRigid {
        /// Where.
        at: Option<Location>,
        /// The part or connection.
        item: String,
        /// What is wrong.
        reason: String,
    },
    /// The interconnection could not be built or assembled.
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// The simulation could not be set up, or a step failed numerically.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The runner failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The output sink refused a row.
    #[error("writing output: {0}")]
    Output(String),
}

impl SceneError {
    /// True for a numerical failure (a step's Newton iteration failed), false for bad input. A CLI
    /// exits with 1 for the former and 2 for the latter.
    #[must_use]
    pub fn is_numerical(&self) -> bool {
        matches!(
            self,
            Self::Sim(SimError::Newton { .. } | SimError::StepRejected { .. })
                | Self::Run(RunError::Sim(
                    SimError::Newton { .. } | SimError::StepRejected { .. }
                ))
        )
    }

    /// The source position of the error, if it has one.
    #[must_use]
    pub fn location(&self) -> Option<&Location> {
        match self {
            Self::Toml { at, .. } => Some(at),
            Self::UnknownPartType { at, .. }
            | Self::UnknownKind { at, .. }
            | Self::DuplicateName { at, .. }
            | Self::BadName { at, .. }
            | Self::UnknownPart { at, .. }
            | Self::UnknownPort { at, .. }
            | Self::UnknownCoordinate { at, .. }
            | Self::BadReference { at, .. }
            | Self::BadSignal { at, .. }
            | Self::BadParameter { at, .. }
            | Self::InitialLength { at, .. }
            | Self::BadConnection { at, .. }
            | Self::TooFewPorts { at, .. }
            | Self::BadSetting { at, .. }
            | Self::BadRigid { at, .. } => at.as_ref(),
            _ => None,
        }
    }
}

/// `` `a`, `b`, `c` `` for error messages.
pub(crate) fn listed<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> String {
    let names: Vec<String> = names
        .into_iter()
        .map(|n| format!("`{}`", n.as_ref()))
        .collect();
    if names.is_empty() {
        "(none)".to_string()
    } else {
        names.join(", ")
    }
}
