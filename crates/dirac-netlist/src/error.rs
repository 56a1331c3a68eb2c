//! Errors and warnings of the netlist front end, with source positions.

use std::fmt;

use thiserror::Error;

/// A position in the netlist source: 1-based line and 1-based column (in characters; a tab counts
/// as one column) of one of its files (0: the netlist itself, `k`: the `k`-th file it includes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pos {
    /// 1-based line number.
    pub line: usize,
    /// 1-based column number, counted in characters.
    pub column: usize,
    /// Which file (see [`Netlist::files`](super::Netlist::files)).
    pub file: usize,
}

impl Pos {
    /// A position from a line and a column of the netlist itself.
    pub const fn new(line: usize, column: usize) -> Self {
        Self {
            line,
            column,
            file: 0,
        }
    }

    /// A position in file `file`.
    pub(crate) const fn in_source(file: usize, line: usize, column: usize) -> Self {
        Self { line, column, file }
    }
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

/// What went wrong, for matching on; the human-readable detail is in [`NetlistError::message`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A card, element type, source function, model type or parameter outside the supported subset
    /// (for example `M`, `Q`, `E`, `.ac`, `.include`, `SFFM(...)`). The message says "not supported".
    Unsupported,
    /// Malformed input: a missing node or value, an unbalanced parenthesis, a stray `.ends`, an
    /// expression that does not parse, ...
    Syntax,
    /// An expression refers to a parameter that is not defined in scope, or an `X` instance passes a
    /// parameter the subcircuit does not declare.
    UnknownParam,
    /// A parameter's definition depends on itself.
    RecursiveParam,
    /// An expression calls a function that is not known.
    UnknownFunction,
    /// A value that is not acceptable: non-finite, a zero resistance, a coupling factor outside
    /// `[-1, 1]`, a non-positive `.tran` step, decreasing `PWL` times, ...
    BadValue,
    /// A diode refers to a `.model` that is not defined (or is not a diode model).
    MissingModel,
    /// An `X` instance refers to a subcircuit that is not defined.
    UnknownSubckt,
    /// A subcircuit instantiates itself, directly or through others.
    RecursiveSubckt,
    /// An `X` instance has a different number of nodes than the subcircuit has ports.
    PortMismatch,
    /// Two elements have the same (case-insensitive, hierarchical) name.
    DuplicateElement,
    /// Two `.subckt` or two `.model` definitions with the same name in the same scope.
    DuplicateDefinition,
    /// A `K` card names an element that is not an inductor of the netlist.
    UnknownElement,
    /// A `.ic` names a node that no element connects to (or the ground node).
    UnknownNode,
    /// An `.include` or `.lib` file that cannot be read, a `.lib` section it does not have, or a
    /// file that includes itself.
    Include,
}

/// A netlist error: where it is, the offending text, what kind it is and a message.
///
/// `Display` gives `file:line:column: message`, for example
/// ``file.cir:12:5: card `M1 d g s 0 nmos` not supported``.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct NetlistError {
    /// The file: the name the caller gave to [`parse_netlist`](super::parse_netlist), or the
    /// path of an included file the error is in.
    pub file: String,
    /// 1-based line of the offending text.
    pub line: usize,
    /// 1-based column of the offending text.
    pub column: usize,
    /// The offending text (a whole card for unsupported cards, otherwise the token at fault).
    pub text: String,
    /// What kind of error this is.
    pub kind: ErrorKind,
    /// Human-readable description (without the position prefix).
    pub message: String,
    /// Which file of the netlist's sources `file` names.
    file_index: usize,
}

impl NetlistError {
    /// An error at `pos` with no file name yet (the front end fills it in at the end).
    pub(crate) fn new(
        kind: ErrorKind,
        pos: Pos,
        text: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            file: String::new(),
            line: pos.line,
            column: pos.column,
            text: text.into(),
            kind,
            message: message.into(),
            file_index: pos.file,
        }
    }

    /// A syntax error at `pos`.
    pub(crate) fn syntax(pos: Pos, text: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Syntax, pos, text, message)
    }

    /// A whole card that is outside the supported subset.
    pub(crate) fn unsupported_card(pos: Pos, card: &str) -> Self {
        Self::new(
            ErrorKind::Unsupported,
            pos,
            card,
            format!("card `{card}` not supported"),
        )
    }

    /// A feature `what` (e.g. "source function `SFFM`") inside `card` that is not supported.
    pub(crate) fn unsupported_in(pos: Pos, text: &str, what: &str, card: &str) -> Self {
        Self::new(
            ErrorKind::Unsupported,
            pos,
            text,
            format!("{what} in card `{card}` not supported"),
        )
    }

    /// A value that is not acceptable.
    pub(crate) fn bad_value(pos: Pos, text: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(ErrorKind::BadValue, pos, text, message)
    }

    /// The position of the error.
    pub fn pos(&self) -> Pos {
        Pos::in_source(self.file_index, self.line, self.column)
    }

    /// Names the error's file among `files` (the netlist's, then the included ones).
    pub(crate) fn in_files(mut self, files: &[String]) -> Self {
        self.file = files.get(self.file_index).cloned().unwrap_or_default();
        self
    }
}

/// A warning: something accepted but ignored (output-control cards such as `.options`, `.print`,
/// `.control` blocks; `AC` specifications; unused diode model parameters; redefined parameters).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    /// The file it is in: the netlist's name as given, or an included file's path.
    pub file: String,
    /// 1-based line of the card.
    pub line: usize,
    /// 1-based column of the card or token.
    pub column: usize,
    /// The card or token the warning is about.
    pub text: String,
    /// Human-readable description.
    pub message: String,
    /// Which file of the netlist's sources `file` names.
    pub(crate) file_index: usize,
}

impl Warning {
    pub(crate) fn new(pos: Pos, text: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            file: String::new(),
            line: pos.line,
            column: pos.column,
            text: text.into(),
            message: message.into(),
            file_index: pos.file,
        }
    }

    /// Names the warning's file among `files`.
    pub(crate) fn in_files(mut self, files: &[String]) -> Self {
        self.file = files.get(self.file_index).cloned().unwrap_or_default();
        self
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: warning: {}",
            self.file, self.line, self.column, self.message
        )
    }
}
