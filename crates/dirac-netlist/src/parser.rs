//! Cards to a hierarchical syntax tree (subcircuits still unexpanded, expressions unevaluated).

use super::error::{ErrorKind, NetlistError, Pos, Warning};
use super::expr::{ExprTok, FuncDef};
use super::lexer::{Card, Cursor, Lexed, Spanned};
use super::measure::{Crossing, Edge, Event, Level, Measure, MeasureKind, Occurrence, Statistic};
use dirac_components::Output;

/// A name as written and normalised (lowercase; ground `gnd` → `0` for nodes).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Name {
    pub orig: String,
    pub norm: String,
    pub pos: Pos,
}

impl Name {
    /// A name already normalised (lowercase, ground as `0`) found at `pos`.
    pub(crate) fn at(norm: &str, pos: Pos) -> Self {
        Self {
            orig: norm.to_owned(),
            norm: norm.to_owned(),
            pos,
        }
    }

    fn plain(s: &Spanned) -> Self {
        Self {
            orig: s.text.clone(),
            norm: s.lower(),
            pos: s.start(),
        }
    }

    fn node(s: &Spanned) -> Self {
        let lower = s.lower();
        let norm = if lower == "gnd" {
            "0".to_owned()
        } else {
            lower
        };
        Self {
            orig: s.text.clone(),
            norm,
            pos: s.start(),
        }
    }
}

/// A source's waveform as written.
#[derive(Debug, Clone)]
pub(crate) enum SourceFn {
    Dc(ExprTok),
    Sin(Vec<ExprTok>),
    Pulse(Vec<ExprTok>),
    Exp(Vec<ExprTok>),
    Sffm(Vec<ExprTok>),
    Am(Vec<ExprTok>),
    /// The points, then the `r=` and `td=` options.
    Pwl(Vec<ExprTok>, Option<ExprTok>, Option<ExprTok>),
}

/// What kind of element a card is, with its element-specific fields.
#[derive(Debug, Clone)]
pub(crate) enum ElemKind {
    /// Value and instance parameters.
    R(ExprTok, Instance),
    /// Value, `IC=` and instance parameters.
    L(ExprTok, Option<ExprTok>, Instance),
    C(ExprTok, Option<ExprTok>, Instance),
    V(SourceFn),
    I(SourceFn),
    K(Name, Name, ExprTok),
    /// Model, area factor, `m=`, `temp=`, `dtemp=`.
    D(Name, DiodeInstance),
    /// `M` (drain, gate, source, bulk): model and instance parameters (`L=`, `W=`, …).
    M(Name, Vec<(Name, ExprTok)>),
    /// `Q` (collector, base, emitter): the words after them (an optional substrate node, the
    /// model, an optional area, told apart when the models are known) and the instance
    /// parameters (`AREA=`, `M=`, …).
    Q(Vec<Name>, Vec<(Name, ExprTok)>),
    X(Name, Vec<(Name, ExprTok)>),
    /// `E` (voltage gain) and `G` (transconductance): the card's nodes are the output pair,
    /// then the controlling pair.
    E(ExprTok),
    G(ExprTok),
    /// `F` (current gain) and `H` (transresistance): the controlling voltage source, the value.
    F(Name, ExprTok),
    H(Name, ExprTok),
    /// `B … V=expr`/`I=expr`, `E … VALUE=`/`VOL=`, `G … VALUE=`/`CUR=`: the output's kind and
    /// its expression.
    Behavioural(Output, ExprTok),
    /// `E`, `G`, `F`, `H` with `POLY(n)`: the output's kind, the `n` controls (node pairs for `E`
    /// and `G`, which follow the output pair in the card's nodes; source names for `F` and `H`)
    /// and the coefficients in SPICE's order.
    Poly(Output, PolyControls, Vec<ExprTok>),
    /// `E`/`G` with `TABLE {expr} = (x₀, y₀) (x₁, y₁) …`: the output's kind, the expression and
    /// the points' coordinates in order.
    Table(Output, ExprTok, Vec<ExprTok>),
}

/// The controls of a `POLY(n)` source.
#[derive(Debug, Clone)]
pub(crate) enum PolyControls {
    /// `n` controlling node pairs (the card's nodes after the output pair).
    Nodes(usize),
    /// `n` controlling voltage sources.
    Sources(Vec<Name>),
}

/// A `D` card's instance parameters: the area factor, the multiplicity `m`, the instance
/// temperature `temp` or its offset `dtemp` from the circuit's.
#[derive(Debug, Clone, Default)]
pub(crate) struct DiodeInstance {
    pub area: Option<ExprTok>,
    pub m: Option<ExprTok>,
    pub temp: Option<ExprTok>,
    pub dtemp: Option<ExprTok>,
}

/// The instance parameters ngspice reads on R, L and C cards besides the value (and `IC=`): the
/// multiplicity `m` (that many in parallel), `scale`, the temperature coefficients `tc1`, `tc2`
/// (and a resistor's exponential `tce`) and the instance temperature `temp` or offset `dtemp`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Instance {
    pub m: Option<ExprTok>,
    pub scale: Option<ExprTok>,
    pub tc1: Option<ExprTok>,
    pub tc2: Option<ExprTok>,
    pub tce: Option<ExprTok>,
    pub temp: Option<ExprTok>,
    pub dtemp: Option<ExprTok>,
}

/// An element card.
#[derive(Debug, Clone)]
pub(crate) struct ElemCard {
    pub name: Name,
    pub nodes: Vec<Name>,
    pub kind: ElemKind,
}

/// A `.model NAME TYPE(...)` card.
#[derive(Debug, Clone)]
pub(crate) struct ModelDef {
    pub name: Name,
    /// The model type as written (`D`, `NMOS`, `PMOS`, `NPN`, `PNP`, or a type no element dirac
    /// reads uses: `SW`, …).
    pub kind: Name,
    /// The parameters (of a `D`, `NMOS`, `PMOS`, `NPN` or `PNP` model; other types' are not
    /// read).
    pub params: Vec<(Name, ExprTok)>,
}

/// A `.subckt` definition.
#[derive(Debug, Clone)]
pub(crate) struct SubcktDef {
    pub name: Name,
    pub ports: Vec<Name>,
    pub defaults: Vec<(Name, ExprTok)>,
    pub body: Block,
}

/// A `.tran` card.
#[derive(Debug, Clone)]
pub(crate) struct TranCard {
    pub values: Vec<ExprTok>,
    pub uic: bool,
}

/// The contents of the top level or of one subcircuit body.
#[derive(Debug, Clone, Default)]
pub(crate) struct Block {
    pub elements: Vec<ElemCard>,
    pub params: Vec<(Name, ExprTok)>,
    /// `.func` definitions, in card order (a later one of the same name replaces it).
    pub funcs: Vec<(Name, FuncDef)>,
    pub models: Vec<ModelDef>,
    pub subckts: Vec<SubcktDef>,
    pub ics: Vec<(Name, ExprTok)>,
}

/// A parsed netlist before flattening.
#[derive(Debug)]
pub(crate) struct Parsed {
    pub title: String,
    pub top: Block,
    pub tran: Option<TranCard>,
    pub op: bool,
    pub options: Vec<OptionCard>,
    pub outputs: Vec<OutputRequest>,
    /// `.meas` cards of a transient, values as written.
    pub measures: Vec<Measure<ExprTok>>,
    /// Nodes of `.global` cards, normalised (ground names excluded).
    pub globals: Vec<String>,
    pub warnings: Vec<Warning>,
}

/// One `key[=value]` of an `.options` card, lowercased.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OptionCard {
    /// The option's name.
    pub key: String,
    /// Its value, if written `key=value`.
    pub value: Option<String>,
    /// Where it was written.
    pub pos: Pos,
}

/// A signal named by `.print`, `.probe`, `.save` or `.plot` (`v(out)`, `v(a,b)`, `i(vin)`),
/// lowercased, blanks removed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputRequest {
    /// The signal as written, normalised (`v(a,b)`).
    pub signal: String,
    /// Where it was written.
    pub pos: Pos,
}

/// A token of a `.meas` card: a word (a keyword, a signal, a value) or `=`.
enum MeasTok {
    Word(Spanned),
    Eq,
}

/// A `.meas` card's tokens after its keyword, read front to back.
struct MeasTokens {
    tokens: std::iter::Peekable<std::vec::IntoIter<MeasTok>>,
    card: String,
    start: Pos,
}

/// `RISE=`/`FALL=`/`CROSS=` (or a bare `LAST`), `VAL=`, `TD=`, `FROM=`, `TO=`, `AT=` of a
/// `.meas` card, each with the word it came from.
#[derive(Default)]
struct MeasParams {
    edge: Option<(Edge, Occurrence)>,
    val: Option<ExprTok>,
    td: Option<ExprTok>,
    from: Option<ExprTok>,
    to: Option<ExprTok>,
    at: Option<ExprTok>,
    given: Vec<(String, Spanned)>,
}

impl MeasParams {
    /// Refuses a parameter outside `allowed` (lowercase names).
    fn only(&self, tokens: &MeasTokens, allowed: &[&str]) -> Result<(), NetlistError> {
        match self
            .given
            .iter()
            .find(|(k, _)| !allowed.contains(&k.as_str()))
        {
            Some((key, word)) => Err(tokens.error(
                word,
                &format!(
                    "`{}` does not apply here (this form takes {})",
                    key.to_uppercase(),
                    allowed.join(", ").to_uppercase()
                ),
            )),
            None => Ok(()),
        }
    }
}

/// The statistic a `.meas` keyword names.
fn statistic(word: &str) -> Option<Statistic> {
    Some(match word {
        "avg" => Statistic::Avg,
        "min" => Statistic::Min,
        "max" => Statistic::Max,
        "pp" => Statistic::Pp,
        "rms" => Statistic::Rms,
        "integ" | "integral" => Statistic::Integ,
        "min_at" => Statistic::MinAt,
        "max_at" => Statistic::MaxAt,
        _ => return None,
    })
}

/// A signal as an output card keeps it (`v(a,b)`: lowercase, no blanks).
fn signal_name(word: &Spanned) -> String {
    word.lower()
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect()
}

/// Whether a word names a signal (`v(…)`, `i(…)`) rather than a value.
fn is_signal(word: &str) -> bool {
    let lower = word.to_ascii_lowercase();
    (lower.starts_with("v(") || lower.starts_with("i(")) && lower.ends_with(')')
}

impl MeasTokens {
    fn error(&self, at: &Spanned, message: &str) -> NetlistError {
        NetlistError::syntax(
            at.start(),
            at.text.clone(),
            format!("{message} in `.meas` card `{}`", self.card),
        )
    }

    fn end_error(&self, message: &str) -> NetlistError {
        NetlistError::syntax(
            self.start,
            self.card.clone(),
            format!("{message} in `.meas` card `{}`", self.card),
        )
    }

    fn word(&mut self, what: &str) -> Result<Spanned, NetlistError> {
        match self.tokens.next() {
            Some(MeasTok::Word(w)) => Ok(w),
            Some(MeasTok::Eq) => Err(self.end_error(&format!("`=` where {what} belongs"))),
            None => Err(self.end_error(&format!("missing {what}"))),
        }
    }

    fn peek_word(&mut self) -> Option<String> {
        match self.tokens.peek() {
            Some(MeasTok::Word(w)) => Some(w.lower()),
            _ => None,
        }
    }

    fn eq(&mut self, after: &Spanned) -> Result<(), NetlistError> {
        match self.tokens.next() {
            Some(MeasTok::Eq) => Ok(()),
            _ => Err(self.error(after, &format!("expected `=` after `{}`", after.text))),
        }
    }

    /// A signal name ([`signal_name`]).
    fn signal(&mut self) -> Result<String, NetlistError> {
        let word = self.word("a signal such as v(out)")?;
        if !is_signal(&word.text) {
            return Err(self.error(&word, "expected a signal such as `v(out)` or `i(v1)`"));
        }
        Ok(signal_name(&word))
    }

    fn value(&mut self, key: &Spanned) -> Result<ExprTok, NetlistError> {
        self.eq(key)?;
        let word = self.word(&format!("the value of `{}`", key.text))?;
        ExprTok::parse(&word)
    }

    /// `key=value` parameters up to a word of `stop` or the end.
    fn params(&mut self, stop: &[&str]) -> Result<MeasParams, NetlistError> {
        let mut p = MeasParams::default();
        while let Some(next) = self.peek_word() {
            if stop.contains(&next.as_str()) {
                break;
            }
            let key = self.word("a parameter")?;
            let lower = key.lower();
            if lower == "last" {
                p.edge = Some((Edge::Cross, Occurrence::Last));
                p.given.push(("cross".into(), key));
                continue;
            }
            match lower.as_str() {
                "rise" | "fall" | "cross" => {
                    self.eq(&key)?;
                    let value = self.word(&format!("the value of `{}`", key.text))?;
                    let occurrence = if value.lower() == "last" {
                        Occurrence::Last
                    } else {
                        match value.text.parse::<usize>() {
                            Ok(n) if n >= 1 => Occurrence::Nth(n),
                            _ => {
                                return Err(self.error(
                                    &value,
                                    &format!("`{}=` takes a count from 1 or LAST", key.text),
                                ));
                            }
                        }
                    };
                    let edge = match lower.as_str() {
                        "rise" => Edge::Rise,
                        "fall" => Edge::Fall,
                        _ => Edge::Cross,
                    };
                    p.edge = Some((edge, occurrence));
                }
                "val" => p.val = Some(self.value(&key)?),
                "td" => p.td = Some(self.value(&key)?),
                "from" => p.from = Some(self.value(&key)?),
                "to" => p.to = Some(self.value(&key)?),
                "at" => p.at = Some(self.value(&key)?),
                _ => {
                    return Err(
                        self.error(&key, &format!("unknown `.meas` parameter `{}`", key.text))
                    );
                }
            }
            p.given.push((lower, key));
        }
        Ok(p)
    }

    /// `signal=level` (a value or a signal) and its parameters up to a word of `stop`.
    fn crossing(&mut self, stop: &[&str]) -> Result<Crossing<ExprTok>, NetlistError> {
        let signal = self.signal()?;
        match self.tokens.next() {
            Some(MeasTok::Eq) => {}
            _ => return Err(self.end_error(&format!("expected `=` after `{signal}`"))),
        }
        let level = self.word("the level crossed")?;
        let level = if is_signal(&level.text) {
            Level::Signal(signal_name(&level))
        } else {
            Level::Value(ExprTok::parse(&level)?)
        };
        let params = self.params(stop)?;
        params.only(self, &["rise", "fall", "cross", "td"])?;
        Ok(Crossing {
            signal,
            level,
            td: params.td,
            edge: params.edge,
        })
    }

    /// A `TRIG`/`TARG` event: `AT=time`, or `signal VAL=level` and its parameters.
    fn event(&mut self, stop: &[&str]) -> Result<Event<ExprTok>, NetlistError> {
        if self.peek_word().as_deref() == Some("at") {
            let params = self.params(stop)?;
            params.only(self, &["at"])?;
            return params
                .at
                .map(Event::At)
                .ok_or_else(|| self.end_error("missing `AT=`"));
        }
        let signal = self.signal()?;
        let params = self.params(stop)?;
        params.only(self, &["val", "rise", "fall", "cross", "td"])?;
        let val = params
            .val
            .ok_or_else(|| self.end_error(&format!("missing `VAL=` for `{signal}`")))?;
        Ok(Event::Crossing(Crossing {
            signal,
            level: Level::Value(val),
            td: params.td,
            edge: params.edge,
        }))
    }

    /// After `FIND signal`: `WHEN signal=level …` or `AT=time`.
    fn event_after_find(&mut self) -> Result<Event<ExprTok>, NetlistError> {
        if self.peek_word().as_deref() == Some("when") {
            self.word("WHEN")?;
            return Ok(Event::Crossing(self.crossing(&[])?));
        }
        let params = self.params(&[])?;
        params.only(self, &["at"])?;
        params
            .at
            .map(Event::At)
            .ok_or_else(|| self.end_error("`FIND` needs `WHEN signal=value` or `AT=time`"))
    }

    fn finish(&mut self) -> Result<(), NetlistError> {
        match self.tokens.next() {
            None => Ok(()),
            Some(MeasTok::Word(w)) => Err(self.error(&w, &format!("unexpected `{}`", w.text))),
            Some(MeasTok::Eq) => Err(self.end_error("unexpected `=`")),
        }
    }
}

/// The `key[=value]` pairs of an `.options` card (after its keyword).
fn option_pairs(card: &Card, text: &str) -> Vec<OptionCard> {
    let start = card.start();
    let body = text.split_once(char::is_whitespace).map_or("", |(_, b)| b);
    let mut out = Vec::new();
    let normalised = body.replace(" =", "=").replace("= ", "=");
    for word in normalised.split_whitespace() {
        let (key, value) = match word.split_once('=') {
            Some((k, v)) => (k.to_ascii_lowercase(), Some(v.to_ascii_lowercase())),
            None => (word.to_ascii_lowercase(), None),
        };
        out.push(OptionCard {
            key,
            value,
            pos: start,
        });
    }
    out
}

/// The signals of an output card: every `name(args)` group, plus bare words other than an
/// analysis name (`tran`, `dc`, `ac`, `op`, `noise`, `all`).
fn output_requests(card: &Card, text: &str) -> Vec<OutputRequest> {
    let start = card.start();
    let body = text.split_once(char::is_whitespace).map_or("", |(_, b)| b);
    let mut out = Vec::new();
    let mut chars = body.chars().peekable();
    let mut word = String::new();
    while let Some(c) = chars.next() {
        if c == '(' {
            let mut group = format!("{}(", word.to_ascii_lowercase());
            for d in chars.by_ref() {
                if d == ')' {
                    break;
                }
                if !d.is_whitespace() {
                    group.push(d.to_ascii_lowercase());
                }
            }
            group.push(')');
            out.push(OutputRequest {
                signal: group,
                pos: start,
            });
            word.clear();
        } else if c.is_whitespace() || c == ',' {
            if !word.is_empty() {
                let w = word.to_ascii_lowercase();
                if !["tran", "dc", "ac", "op", "noise", "all"].contains(&w.as_str()) {
                    out.push(OutputRequest {
                        signal: w,
                        pos: start,
                    });
                }
                word.clear();
            }
        } else {
            word.push(c);
        }
    }
    if !word.is_empty() {
        let w = word.to_ascii_lowercase();
        if !["tran", "dc", "ac", "op", "noise", "all"].contains(&w.as_str()) {
            out.push(OutputRequest {
                signal: w,
                pos: start,
            });
        }
    }
    out
}

/// Checks that a parameter name can be referred to in expressions (`[A-Za-z_][A-Za-z0-9_]*`).
fn param_name(s: &Spanned, card: &str) -> Result<Name, NetlistError> {
    let mut chars = s.text.chars();
    let ok = chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && chars.all(|c| c.is_alphanumeric() || c == '_');
    if ok {
        Ok(Name::plain(s))
    } else {
        Err(NetlistError::syntax(
            s.start(),
            s.text.clone(),
            format!(
                "`{}` is not a valid parameter name in card `{card}`",
                s.text
            ),
        ))
    }
}

/// Dot-cards accepted and ignored with a warning.
const IGNORED_DOT_CARDS: &[&str] = &[".nodeset", ".width", ".title"];

/// Analyses other than `.tran` and `.op`: a deck that also asks for one of those runs them, with a
/// warning that these are not run; a deck that asks only for these is refused at the first.
const OTHER_ANALYSES: &[&str] = &[
    ".ac", ".dc", ".noise", ".tf", ".sens", ".disto", ".pz", ".four", ".fourier", ".sp",
];

/// Dot-cards that name the signals to record.
const OUTPUT_DOT_CARDS: &[&str] = &[".print", ".plot", ".probe", ".save"];

struct CardParser<'a> {
    card: &'a Card,
    cur: Cursor<'a>,
    text: String,
}

/// `name=value` assignments in card order.
type Assignments = Vec<(Name, ExprTok)>;
impl<'a> CardParser<'a> {
    fn new(card: &'a Card) -> Self {
        Self {
            card,
            cur: Cursor::new(card),
            text: card.text(),
        }
    }

    fn syntax(&mut self, message: impl Into<String>) -> NetlistError {
        let pos = self.cur.pos();
        let rest = self.cur.rest().text;
        let rest = if rest.is_empty() {
            self.text.clone()
        } else {
            rest
        };
        NetlistError::syntax(
            pos,
            rest,
            format!("{} in card `{}`", message.into(), self.text),
        )
    }

    fn word(&mut self, what: &str) -> Result<Spanned, NetlistError> {
        match self.cur.word() {
            Some(w) => Ok(w),
            None => Err(if self.cur.at_end() {
                self.syntax(format!("missing {what}"))
            } else {
                self.syntax(format!("expected {what}"))
            }),
        }
    }

    fn node(&mut self) -> Result<Name, NetlistError> {
        self.word("node").map(|w| Name::node(&w))
    }

    fn value(&mut self, what: &str) -> Result<ExprTok, NetlistError> {
        match self.cur.value()? {
            Some(v) => ExprTok::parse(&v),
            None => Err(if self.cur.at_end() {
                self.syntax(format!("missing {what}"))
            } else {
                self.syntax(format!("expected {what}"))
            }),
        }
    }

    /// `name=value`, `what` naming the name in the error when it is missing.
    fn assignment(&mut self, what: &str) -> Result<(Name, ExprTok), NetlistError> {
        let name = Name::plain(&self.word(what)?);
        if !self.cur.eat('=') {
            return Err(self.syntax(format!("expected `=` after `{}`", name.orig)));
        }
        let value = self.assigned_value(&name)?;
        Ok((name, value))
    }

    fn assigned_value(&mut self, name: &Name) -> Result<ExprTok, NetlistError> {
        match self.cur.assigned_value()? {
            Some(v) => ExprTok::parse(&v),
            None => Err(self.syntax(format!("missing value for `{}`", name.orig))),
        }
    }

    /// Trailing `NAME=value` parameters, of which only `allowed` are supported.
    fn trailing_params(&mut self, allowed: &[&str]) -> Result<Vec<(Name, ExprTok)>, NetlistError> {
        let mut out = Vec::new();
        while !self.cur.at_end() {
            let Some(w) = self.cur.word() else {
                return Err(self.syntax("unexpected text"));
            };
            let name = Name::plain(&w);
            if !self.cur.eat('=') {
                return Err(NetlistError::syntax(
                    name.pos,
                    name.orig.clone(),
                    format!("unexpected `{}` in card `{}`", name.orig, self.text),
                ));
            }
            if !allowed.contains(&name.norm.as_str()) {
                return Err(NetlistError::unsupported_in(
                    name.pos,
                    &name.orig,
                    &format!("parameter `{}`", name.orig),
                    &self.text,
                ));
            }
            let value = self.assigned_value(&name)?;
            out.push((name, value));
        }
        Ok(out)
    }

    /// The trailing instance parameters of an R (`letter`), L or C card, and an L's or C's `IC=`.
    /// A resistor's `ac=` (its AC resistance) and `noisy=` are read and ignored with a warning.
    fn instance(
        &mut self,
        letter: char,
        warnings: &mut Vec<Warning>,
    ) -> Result<(Instance, Option<ExprTok>), NetlistError> {
        let mut allowed = vec!["m", "scale", "tc1", "tc2", "temp", "dtemp"];
        allowed.extend_from_slice(if letter == 'r' {
            &["tce", "ac", "noisy"]
        } else {
            &["ic"]
        });
        let (mut instance, mut ic) = (Instance::default(), None);
        for (name, v) in self.trailing_params(&allowed)? {
            let slot = match name.norm.as_str() {
                "m" => &mut instance.m,
                "scale" => &mut instance.scale,
                "tc1" => &mut instance.tc1,
                "tc2" => &mut instance.tc2,
                "tce" => &mut instance.tce,
                "temp" => &mut instance.temp,
                "dtemp" => &mut instance.dtemp,
                "ic" => &mut ic,
                _ => {
                    warnings.push(Warning::new(
                        name.pos,
                        name.orig.clone(),
                        format!(
                            "`{}` ignored in card `{}` (it matters to AC and noise analyses only)",
                            name.orig, self.text
                        ),
                    ));
                    continue;
                }
            };
            *slot = Some(v);
        }
        Ok((instance, ic))
    }

    fn finish(&mut self) -> Result<(), NetlistError> {
        if self.cur.at_end() {
            Ok(())
        } else {
            Err(self.syntax("unexpected text"))
        }
    }

    /// The nonlinear form of a controlled source (`POLY(n)`, `VALUE=`, `VOL=`, `CUR=`, `TABLE`,
    /// `LAPLACE`, …) whose keyword stands where the linear form's next node or name would, if
    /// one does: a form's keyword opens its arguments (`POLY(2)`, `VALUE={…}`, `TABLE {…}`); the
    /// same word followed by anything else is a node or source name, as ngspice reads it.
    fn nonlinear_form(&mut self) -> Option<String> {
        const FORMS: [&str; 9] = [
            "poly",
            "value",
            "vol",
            "cur",
            "table",
            "laplace",
            "freq",
            "tablefile",
            "smoothbsp",
        ];
        self.cur
            .peek_word_and_next()
            .filter(|(w, next)| {
                FORMS.contains(&w.as_str()) && matches!(next, Some('(' | '=' | '{' | '\''))
            })
            .map(|(w, _)| w)
    }

    /// The nonlinear forms of `E`, `G` (`letter`), `F` and `H` after the output nodes: `POLY(n)`
    /// for all four, `VALUE=`/`VOL=` for `E`, `VALUE=`/`CUR=` for `G`. `None` for the linear form;
    /// every other form is refused at its keyword.
    fn controlled_form(
        &mut self,
        letter: char,
        nodes: &mut Vec<Name>,
    ) -> Result<Option<ElemKind>, NetlistError> {
        let Some(form) = self.nonlinear_form() else {
            return Ok(None);
        };
        let output = if matches!(letter, 'e' | 'h') {
            Output::Voltage
        } else {
            Output::Current
        };
        let keyword = self.word("node")?;
        match form.as_str() {
            "poly" => {
                let n = self.poly_dimension()?;
                let controls = if matches!(letter, 'e' | 'g') {
                    for _ in 0..2 * n {
                        nodes.push(self.node()?);
                    }
                    PolyControls::Nodes(n)
                } else {
                    PolyControls::Sources(
                        (0..n)
                            .map(|_| {
                                self.word("controlling voltage source")
                                    .map(|w| Name::plain(&w))
                            })
                            .collect::<Result<_, _>>()?,
                    )
                };
                let mut coefficients = Vec::new();
                while !self.cur.at_end() {
                    coefficients.push(self.value("coefficient")?);
                }
                if coefficients.is_empty() {
                    return Err(self.syntax("missing POLY coefficients"));
                }
                Ok(Some(ElemKind::Poly(output, controls, coefficients)))
            }
            "table" if matches!(letter, 'e' | 'g') => self.table(output).map(Some),
            "value" | "vol" if letter == 'e' => self.behavioural(output).map(Some),
            "value" | "cur" if letter == 'g' => self.behavioural(output).map(Some),
            _ => Err(NetlistError::unsupported_in(
                keyword.start(),
                &keyword.text,
                &format!(
                    "the form `{}` (E and G sources read the linear form, VALUE=, VOL= (E), \
                     CUR= (G), TABLE and POLY(n); F and H the linear form and POLY(n))",
                    keyword.text
                ),
                &self.text,
            )),
        }
    }

    /// `{expr} = (x₀, y₀) (x₁, y₁) …` after `TABLE` (the `=` optional, as ngspice allows `TABLE =
    /// {expr}` too): the expression and the coordinates.
    fn table(&mut self, output: Output) -> Result<ElemKind, NetlistError> {
        self.cur.eat('=');
        if self.cur.peek() != Some('{') {
            return Err(self.syntax("expected `{expression}` after TABLE"));
        }
        let expr = self.value("table expression")?;
        let mut points = Vec::new();
        while !self.cur.at_end() {
            if self.cur.eat('(') || self.cur.eat(')') || self.cur.eat('=') {
                continue;
            }
            points.push(self.value("table point")?);
        }
        if points.is_empty() || points.len() % 2 == 1 {
            return Err(self.syntax(format!(
                "TABLE needs (x, y) pairs, got {} number{}",
                points.len(),
                if points.len() == 1 { "" } else { "s" }
            )));
        }
        Ok(ElemKind::Table(output, expr, points))
    }

    /// `(n)` after `POLY`: the number of controls, a positive integer.
    fn poly_dimension(&mut self) -> Result<usize, NetlistError> {
        if !self.cur.eat('(') {
            return Err(self.syntax("expected `(` after POLY"));
        }
        let pos = self.cur.pos();
        let n = self.cur.word().map(|w| w.text).unwrap_or_default();
        if !self.cur.eat(')') {
            return Err(self.syntax("expected `)` after POLY's dimension"));
        }
        match n.parse::<usize>() {
            Ok(n) if (1..=20).contains(&n) => Ok(n),
            _ => Err(NetlistError::bad_value(
                pos,
                n.clone(),
                format!("POLY's dimension must be an integer from 1 to 20, got `{n}`"),
            )),
        }
    }

    /// `.func name(a, b, …) {body}` (also `= {body}`, `'body'` or a bare body to the end of the
    /// card): the function's name and definition.
    fn func(&mut self) -> Result<(Name, FuncDef), NetlistError> {
        let name = Name::plain(&self.word("function name")?);
        if crate::expr::built_in(&name.norm) {
            return Err(NetlistError::syntax(
                name.pos,
                name.orig.clone(),
                format!(
                    "`{}` is a built-in function: a .func cannot redefine it (ngspice refuses \
                     it too)",
                    name.orig
                ),
            ));
        }
        if !self.cur.eat('(') {
            return Err(self.syntax("expected `(` and the function's parameters"));
        }
        let mut params: Vec<String> = Vec::new();
        while !self.cur.eat(')') {
            let param = self.word("parameter name or `)`")?;
            if params.contains(&param.lower()) {
                return Err(NetlistError::syntax(
                    param.start(),
                    param.text.clone(),
                    format!("parameter `{}` listed twice", param.text),
                ));
            }
            params.push(param.lower());
        }
        self.cur.eat('=');
        let Some(span) = self.cur.expression()? else {
            return Err(self.syntax("missing function body"));
        };
        let body = ExprTok::parse(&span)?.expr;
        self.finish()?;
        Ok((name, FuncDef { params, body }))
    }

    /// `=expr` (or `={expr}`, `'expr'`, `{expr}`) to the end of the card: a behavioural output.
    fn behavioural(&mut self, output: Output) -> Result<ElemKind, NetlistError> {
        self.cur.eat('=');
        let Some(span) = self.cur.expression()? else {
            return Err(self.syntax("missing expression"));
        };
        let expr = ExprTok::parse(&span)?;
        self.finish()?;
        Ok(ElemKind::Behavioural(output, expr))
    }

    /// ngspice's options after `PWL(…)`, `r=R` (repeat from time `R`) and `td=TD` (delay), in
    /// either order, each at most once.
    fn pwl_options(&mut self) -> Result<(Option<ExprTok>, Option<ExprTok>), NetlistError> {
        let (mut repeat, mut delay) = (None, None);
        while let Some(w) = self.cur.peek_word() {
            let slot = match w.as_str() {
                "r" => &mut repeat,
                "td" => &mut delay,
                _ => break,
            };
            let Some(word) = self.cur.word() else { break };
            let name = Name::plain(&word);
            if !self.cur.eat('=') {
                return Err(NetlistError::syntax(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "PWL option `{}` needs `=value` in card `{}`",
                        name.orig, self.text
                    ),
                ));
            }
            if slot.is_some() {
                return Err(NetlistError::syntax(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "PWL option `{}` given twice in card `{}`",
                        name.orig, self.text
                    ),
                ));
            }
            *slot = Some(self.assigned_value(&name)?);
        }
        Ok((repeat, delay))
    }

    /// Reads the arguments of `SIN`/`PULSE`/`PWL`: in parentheses, or to the end of the card.
    fn function_args(&mut self) -> Result<Vec<ExprTok>, NetlistError> {
        let mut args = Vec::new();
        let open = self.cur.pos();
        if self.cur.eat('(') {
            loop {
                if self.cur.eat(')') {
                    return Ok(args);
                }
                if self.cur.at_end() {
                    return Err(NetlistError::syntax(
                        open,
                        "(",
                        format!("unbalanced `(` in card `{}`", self.text),
                    ));
                }
                args.push(self.value("value")?);
            }
        }
        while !self.cur.at_end() {
            args.push(self.value("value")?);
        }
        Ok(args)
    }

    fn source(&mut self, warnings: &mut Vec<Warning>) -> Result<SourceFn, NetlistError> {
        let mut dc: Option<ExprTok> = None;
        let mut tran: Option<SourceFn> = None;
        while !self.cur.at_end() {
            let pos = self.cur.pos();
            let word = self.cur.peek_word();
            match word.as_deref() {
                Some("dc") => {
                    self.cur.word();
                    if dc.is_some() {
                        return Err(NetlistError::syntax(
                            pos,
                            "DC",
                            format!("two DC values in card `{}`", self.text),
                        ));
                    }
                    dc = Some(self.value("DC value")?);
                }
                Some("ac") => {
                    self.cur.word();
                    let mut n = 0;
                    while n < 2 && !self.cur.at_end() {
                        let w = self.cur.peek_word();
                        if matches!(
                            w.as_deref(),
                            Some("dc" | "sin" | "sine" | "pulse" | "pwl" | "exp" | "sffm" | "am")
                        ) {
                            break;
                        }
                        self.value("AC value")?;
                        n += 1;
                    }
                    warnings.push(Warning::new(
                        pos,
                        "AC",
                        format!("AC specification ignored in card `{}`", self.text),
                    ));
                }
                Some(f @ ("sin" | "sine" | "pulse" | "pwl" | "exp" | "sffm" | "am")) => {
                    let f = f.to_owned();
                    let kw = self.cur.word().map(|w| w.text).unwrap_or_default();
                    if tran.is_some() {
                        return Err(NetlistError::syntax(
                            pos,
                            kw,
                            format!("two transient functions in card `{}`", self.text),
                        ));
                    }
                    let args = self.function_args()?;
                    let range = match f.as_str() {
                        "pulse" => (2, 8),
                        "sffm" | "am" => (2, 7),
                        "pwl" => (2, usize::MAX),
                        _ => (2, 6),
                    };
                    if args.len() < range.0 || args.len() > range.1 {
                        let wanted = if f == "pwl" {
                            "at least 2".to_owned()
                        } else {
                            format!("{} to {}", range.0, range.1)
                        };
                        return Err(NetlistError::syntax(
                            pos,
                            kw.clone(),
                            format!(
                                "`{kw}` takes {wanted} values, got {} in card `{}`",
                                args.len(),
                                self.text
                            ),
                        ));
                    }
                    if f == "pwl" && args.len() % 2 != 0 {
                        return Err(NetlistError::syntax(
                            pos,
                            kw.clone(),
                            format!(
                                "`{kw}` needs time-value pairs, got {} values in card `{}`",
                                args.len(),
                                self.text
                            ),
                        ));
                    }
                    tran = Some(match f.as_str() {
                        "pulse" => SourceFn::Pulse(args),
                        "exp" => SourceFn::Exp(args),
                        "sffm" => SourceFn::Sffm(args),
                        "am" => SourceFn::Am(args),
                        "pwl" => {
                            let (repeat, delay) = self.pwl_options()?;
                            SourceFn::Pwl(args, repeat, delay)
                        }
                        _ => SourceFn::Sin(args),
                    });
                }
                Some(
                    f @ ("trnoise" | "trrandom" | "external" | "distof1" | "distof2" | "portnum"
                    | "z0" | "pat"),
                ) => {
                    let f = f.to_uppercase();
                    let kw = self.cur.word().map(|w| w.text).unwrap_or_default();
                    return Err(NetlistError::unsupported_in(
                        pos,
                        &kw,
                        &format!("source function `{f}`"),
                        &self.text,
                    ));
                }
                _ => {
                    if dc.is_some() {
                        return Err(self.syntax("unexpected text"));
                    }
                    dc = Some(self.value("value")?);
                }
            }
        }
        match (dc, tran) {
            (Some(dc), Some(f)) => {
                warnings.push(Warning::new(
                    dc.pos,
                    dc.text.clone(),
                    format!(
                        "DC value ignored in favour of the transient function in card `{}`",
                        self.text
                    ),
                ));
                Ok(f)
            }
            (None, Some(f)) => Ok(f),
            (Some(dc), None) => Ok(SourceFn::Dc(dc)),
            (None, None) => {
                let pos = self.card.start();
                warnings.push(Warning::new(
                    pos,
                    self.text.clone(),
                    format!(
                        "source without a value taken as DC 0 in card `{}`",
                        self.text
                    ),
                ));
                let zero = Spanned {
                    text: "0".into(),
                    positions: vec![pos],
                    end: pos,
                };
                Ok(SourceFn::Dc(ExprTok::parse(&zero)?))
            }
        }
    }

    /// Reads a device card's `off` (a hint for the operating point's Newton start, which
    /// dirac's does not take), with a warning that it is ignored.
    fn eat_off(&mut self, warnings: &mut Vec<Warning>) -> bool {
        let off = self.cur.eat_keyword("off");
        if off {
            warnings.push(Warning::new(
                self.card.start(),
                self.text.clone(),
                format!("`off` ignored in card `{}`", self.text),
            ));
        }
        off
    }

    fn element(&mut self, warnings: &mut Vec<Warning>) -> Result<ElemCard, NetlistError> {
        let name_span = self.word("element name")?;
        let name = Name::plain(&name_span);
        let letter = name.norm.chars().next().unwrap_or(' ');
        let two_nodes =
            |p: &mut Self| -> Result<Vec<Name>, NetlistError> { Ok(vec![p.node()?, p.node()?]) };
        let (nodes, kind) = match letter {
            'r' => {
                let nodes = two_nodes(self)?;
                // ngspice also reads the value as `r=…`, then instance parameters.
                self.cur.eat_assignment_of("r");
                let value = self.value("resistance")?;
                let (instance, _) = self.instance(letter, warnings)?;
                (nodes, ElemKind::R(value, instance))
            }
            'l' | 'c' => {
                let nodes = two_nodes(self)?;
                self.cur
                    .eat_assignment_of(if letter == 'l' { "l" } else { "c" });
                let value = self.value(if letter == 'l' {
                    "inductance"
                } else {
                    "capacitance"
                })?;
                let (instance, ic) = self.instance(letter, warnings)?;
                if letter == 'l' {
                    (nodes, ElemKind::L(value, ic, instance))
                } else {
                    (nodes, ElemKind::C(value, ic, instance))
                }
            }
            'v' | 'i' => {
                let nodes = two_nodes(self)?;
                let f = self.source(warnings)?;
                if letter == 'v' {
                    (nodes, ElemKind::V(f))
                } else {
                    (nodes, ElemKind::I(f))
                }
            }
            'k' => {
                let l1 = Name::plain(&self.word("inductor name")?);
                let l2 = Name::plain(&self.word("inductor name")?);
                let k = self.value("coupling coefficient")?;
                self.finish()?;
                (Vec::new(), ElemKind::K(l1, l2, k))
            }
            'd' => {
                let nodes = two_nodes(self)?;
                let model = Name::plain(&self.word("model name")?);
                // ngspice's instance parameters: an area factor (positional or `area=`), a
                // multiplicity `m=` (both scale the junction), the instance temperature `temp=`
                // or `dtemp=`, and `off` (a hint for the operating point's Newton start, which
                // dirac's does not take).
                let mut instance = DiodeInstance::default();
                while !self.cur.at_end() {
                    if self.eat_off(warnings) {
                        continue;
                    }
                    if self.cur.eat_assignment_of("area") {
                        instance.area = Some(self.value("area factor")?);
                    } else if self.cur.eat_assignment_of("m") {
                        instance.m = Some(self.value("multiplicity")?);
                    } else if self.cur.eat_assignment_of("temp") {
                        instance.temp = Some(self.value("instance temperature")?);
                    } else if self.cur.eat_assignment_of("dtemp") {
                        instance.dtemp = Some(self.value("instance temperature offset")?);
                    } else if instance.area.is_none()
                        && self.cur.peek_word().is_none_or(|w| {
                            w.starts_with(|c: char| {
                                c.is_ascii_digit() || matches!(c, '.' | '-' | '+')
                            })
                        })
                    {
                        instance.area = Some(self.value("area factor")?);
                    } else {
                        let pos = self.cur.pos();
                        let rest = self.cur.rest().text;
                        return Err(NetlistError::unsupported_in(
                            pos,
                            &rest,
                            &format!("diode instance parameters `{rest}`"),
                            &self.text,
                        ));
                    }
                }
                (nodes, ElemKind::D(model, instance))
            }
            'e' | 'g' => {
                let mut nodes = two_nodes(self)?;
                if let Some(kind) = self.controlled_form(letter, &mut nodes)? {
                    return Ok(ElemCard { name, nodes, kind });
                }
                nodes.extend(two_nodes(self)?);
                let value = self.value(if letter == 'e' {
                    "voltage gain"
                } else {
                    "transconductance"
                })?;
                self.finish()?;
                let kind = if letter == 'e' {
                    ElemKind::E(value)
                } else {
                    ElemKind::G(value)
                };
                (nodes, kind)
            }
            'f' | 'h' => {
                let mut nodes = two_nodes(self)?;
                if let Some(kind) = self.controlled_form(letter, &mut nodes)? {
                    return Ok(ElemCard { name, nodes, kind });
                }
                let control = Name::plain(&self.word("controlling voltage source")?);
                let value = self.value(if letter == 'f' {
                    "current gain"
                } else {
                    "transresistance"
                })?;
                self.finish()?;
                let kind = if letter == 'f' {
                    ElemKind::F(control, value)
                } else {
                    ElemKind::H(control, value)
                };
                (nodes, kind)
            }
            'b' => {
                let nodes = two_nodes(self)?;
                let keyword = self.word("`V=` or `I=`")?;
                let output = match keyword.lower().as_str() {
                    "v" => Output::Voltage,
                    "i" => Output::Current,
                    _ => {
                        return Err(NetlistError::syntax(
                            keyword.start(),
                            keyword.text.clone(),
                            format!(
                                "expected `V=` or `I=` after the nodes of `{}`, found `{}`",
                                name.orig, keyword.text
                            ),
                        ));
                    }
                };
                (nodes, self.behavioural(output)?)
            }
            'm' => {
                let nodes = vec![self.node()?, self.node()?, self.node()?, self.node()?];
                let model_word = self.word("model name")?;
                let model = Name::plain(&model_word);
                let count = |what: &str| {
                    format!(
                        "`{}` needs four nodes (drain, gate, source, bulk) and then its model \
                         name; {what}",
                        name.orig
                    )
                };
                if self.cur.peek() == Some('=') {
                    return Err(NetlistError::syntax(
                        model_word.start(),
                        model_word.text.clone(),
                        count(&format!(
                            "`{}=` came where the model name belongs",
                            model_word.text
                        )),
                    ));
                }
                // `L=`, `W=`, `AD=`, … (read when the model is known); `off` is a hint for the
                // operating point's Newton start, which dirac's does not take.
                let mut params = Vec::new();
                while !self.cur.at_end() {
                    if let Some((word, next)) = self.cur.peek_word_and_next()
                        && params.is_empty()
                        && word != "off"
                        && next != Some('=')
                    {
                        let pos = self.cur.pos();
                        return Err(NetlistError::syntax(
                            pos,
                            word.clone(),
                            count(&format!(
                                "`{word}` follows `{}`, which was read as the model",
                                model.orig
                            )),
                        ));
                    }
                    if self.eat_off(warnings) {
                        continue;
                    }
                    params.push(self.assignment("instance parameter")?);
                }
                (nodes, ElemKind::M(model, params))
            }
            'q' => {
                let nodes = vec![self.node()?, self.node()?, self.node()?];
                // Then `[substrate] model [area]`, `off`, and `name=value` parameters; which
                // word is the model is decided when the models are known (as ngspice does:
                // a fourth word that names a model is the model).
                let mut words = Vec::new();
                let mut params = Vec::new();
                while !self.cur.at_end() {
                    if self.eat_off(warnings) {
                        continue;
                    }
                    let is_assignment = self
                        .cur
                        .peek_word_and_next()
                        .is_some_and(|(_, next)| next == Some('='));
                    if is_assignment || !params.is_empty() {
                        let (key, value) = self.assignment("instance parameter")?;
                        // `IC=vbe,vce` (the comma reads as a blank): the second value is read
                        // and, like the first, ignored.
                        if key.norm == "ic"
                            && self.cur.peek_word_and_next().is_some_and(|(w, next)| {
                                next != Some('=') && crate::parse_spice_number(&w).is_some()
                            })
                        {
                            self.word("initial V_CE")?;
                        }
                        params.push((key, value));
                    } else {
                        words.push(Name::plain(&self.word("model name")?));
                    }
                }
                if words.is_empty() || words.len() > 3 {
                    return Err(self.syntax(format!(
                        "`{}` needs three nodes (collector, base, emitter), an optional substrate \
                         node, its model name and an optional area",
                        name.orig
                    )));
                }
                (nodes, ElemKind::Q(words, params))
            }
            'x' => {
                let (mut words, params) =
                    self.words_then_assignments("node or subcircuit name", |_, _| Ok(()))?;
                let Some(sub) = words.pop() else {
                    return Err(self.syntax("missing subcircuit name"));
                };
                let nodes = words.iter().map(Name::node).collect();
                (nodes, ElemKind::X(Name::plain(&sub), params))
            }
            _ => {
                return Err(NetlistError::unsupported_card(
                    self.card.start(),
                    &self.text,
                ));
            }
        };
        Ok(ElemCard { name, nodes, kind })
    }

    /// Plain words, then `name=value` assignments (optionally after the keyword `params:`), to
    /// the end of the card: the shape of an `X` instance and of a `.subckt` header. A plain word
    /// after `params:` or after an assignment is an error naming it; `check` sees each plain word
    /// (with the card's text) as it is read, so errors come in card order.
    fn words_then_assignments(
        &mut self,
        what: &str,
        mut check: impl FnMut(&Spanned, &str) -> Result<(), NetlistError>,
    ) -> Result<(Vec<Spanned>, Assignments), NetlistError> {
        let mut words: Vec<Spanned> = Vec::new();
        let mut assignments = Vec::new();
        let mut params_mode = false;
        while !self.cur.at_end() {
            if self.cur.eat_keyword("params:") {
                params_mode = true;
                continue;
            }
            let w = self.word(what)?;
            if self.cur.eat('=') {
                let pname = param_name(&w, &self.text)?;
                let v = self.assigned_value(&pname)?;
                assignments.push((pname, v));
            } else if params_mode || !assignments.is_empty() {
                return Err(NetlistError::syntax(
                    w.start(),
                    w.text.clone(),
                    format!(
                        "expected `name=value`, found `{}` in card `{}`",
                        w.text, self.text
                    ),
                ));
            } else {
                check(&w, &self.text)?;
                words.push(w);
            }
        }
        Ok((words, assignments))
    }

    fn params(&mut self) -> Result<Vec<(Name, ExprTok)>, NetlistError> {
        let mut out = Vec::new();
        while !self.cur.at_end() {
            let w = self.word("parameter name")?;
            let name = param_name(&w, &self.text)?;
            if !self.cur.eat('=') {
                return Err(self.syntax(format!("expected `=` after `{}`", name.orig)));
            }
            let v = self.assigned_value(&name)?;
            out.push((name, v));
        }
        Ok(out)
    }

    fn model(&mut self, warnings: &mut Vec<Warning>) -> Result<ModelDef, NetlistError> {
        let name = Name::plain(&self.word("model name")?);
        let ty = self.word("model type")?;
        let kind = Name::plain(&ty);
        if !matches!(kind.norm.as_str(), "d" | "nmos" | "pmos" | "npn" | "pnp") {
            // A model library (an `.include`d one most often) holds models of devices dirac does
            // not read; an element that uses one is refused at its own card.
            warnings.push(Warning::new(
                ty.start(),
                &ty.text,
                format!(
                    "model `{}` of type `{}` ignored: dirac reads no device of that type",
                    name.orig, ty.text
                ),
            ));
            return Ok(ModelDef {
                name,
                kind,
                params: Vec::new(),
            });
        }
        let open = self.cur.pos();
        let paren = self.cur.eat('(');
        let mut params = Vec::new();
        loop {
            if paren && self.cur.eat(')') {
                break;
            }
            if self.cur.at_end() {
                if paren {
                    return Err(NetlistError::syntax(
                        open,
                        "(",
                        format!("unbalanced `(` in card `{}`", self.text),
                    ));
                }
                break;
            }
            params.push(self.assignment("model parameter")?);
        }
        self.finish()?;
        Ok(ModelDef { name, kind, params })
    }

    fn subckt(&mut self) -> Result<SubcktDef, NetlistError> {
        let name = Name::plain(&self.word("subcircuit name")?);
        let mut ports: Vec<Name> = Vec::new();
        let (_, defaults) = self.words_then_assignments("port or parameter", |w, card| {
            let port = Name::node(w);
            if ports.iter().any(|p| p.norm == port.norm) {
                return Err(NetlistError::syntax(
                    port.pos,
                    port.orig.clone(),
                    format!("port `{}` listed twice in card `{card}`", port.orig),
                ));
            }
            ports.push(port);
            Ok(())
        })?;
        Ok(SubcktDef {
            name,
            ports,
            defaults,
            body: Block::default(),
        })
    }

    fn tran(&mut self) -> Result<TranCard, NetlistError> {
        let mut values = Vec::new();
        let mut uic = false;
        while !self.cur.at_end() {
            if self.cur.eat_keyword("uic") {
                uic = true;
                continue;
            }
            if uic {
                return Err(self.syntax("unexpected text after `uic`"));
            }
            values.push(self.value("time")?);
        }
        if values.len() < 2 || values.len() > 4 {
            return Err(NetlistError::syntax(
                self.card.start(),
                self.text.clone(),
                format!(
                    "`.tran` takes TSTEP TSTOP [TSTART [TMAX]] [UIC], got {} values in card `{}`",
                    values.len(),
                    self.text
                ),
            ));
        }
        Ok(TranCard { values, uic })
    }

    /// A `.meas`/`.measure` card of a transient (see [`Measure`]); `None`, with a warning, for
    /// another analysis or a form not computed (`PARAM=`, `DERIV`, `ERR`).
    fn measure(
        &mut self,
        warnings: &mut Vec<Warning>,
    ) -> Result<Option<Measure<ExprTok>>, NetlistError> {
        let start = self.card.start();
        let mut tokens = Vec::new();
        loop {
            self.cur.skip_ws();
            if self.cur.at_end() {
                break;
            }
            if self.cur.eat('=') {
                tokens.push(MeasTok::Eq);
            } else if !self.cur.eat(',') {
                match self.cur.value()? {
                    Some(word) => tokens.push(MeasTok::Word(word)),
                    None => return Err(self.syntax("unexpected character")),
                }
            }
        }
        let mut tokens = MeasTokens {
            tokens: tokens.into_iter().peekable(),
            card: self.text.clone(),
            start,
        };
        let ignored = |why: String| Warning::new(start, self.text.clone(), why);
        let first = tokens.word("the analysis or the result's name")?;
        let name = match first.lower().as_str() {
            "tran" => tokens.word("the result's name")?,
            analysis @ ("ac" | "dc" | "sp" | "noise" | "op") => {
                warnings.push(ignored(format!(
                    "`.meas {analysis}` ignored (dirac runs `.tran` and `.op`): `{}`",
                    self.text
                )));
                return Ok(None);
            }
            _ => first,
        };
        let kind_word = tokens.word("a measure (TRIG, WHEN, FIND, AVG, ...)")?;
        let kind = match kind_word.lower().as_str() {
            "trig" | "delay" => {
                let trig = tokens.event(&["targ"])?;
                let targ_word = tokens.word("TARG")?;
                if targ_word.lower() != "targ" {
                    return Err(tokens.error(&targ_word, "expected `TARG`"));
                }
                let targ = tokens.event(&[])?;
                MeasureKind::Delay { trig, targ }
            }
            "when" => MeasureKind::When(tokens.crossing(&[])?),
            "find" => {
                let signal = tokens.signal()?;
                let at = tokens.event_after_find()?;
                MeasureKind::Find { signal, at }
            }
            word => match statistic(word) {
                Some(statistic) => {
                    let signal = tokens.signal()?;
                    let params = tokens.params(&[])?;
                    params.only(&tokens, &["from", "to", "td"])?;
                    if params.td.is_some() {
                        warnings.push(ignored(format!(
                            "`TD=` on `{}` ignored, as ngspice-39 ignores it there (the window \
                             is FROM= to TO=): `{}`",
                            kind_word.text, self.text
                        )));
                    }
                    MeasureKind::Statistic {
                        statistic,
                        signal,
                        from: params.from,
                        to: params.to,
                    }
                }
                None => {
                    warnings.push(ignored(format!(
                        "`.meas` {} not computed, ignored (dirac computes TRIG/TARG, WHEN, FIND \
                         and AVG, MIN, MAX, PP, RMS, INTEG, MIN_AT, MAX_AT): `{}`",
                        kind_word.text, self.text
                    )));
                    return Ok(None);
                }
            },
        };
        tokens.finish()?;
        Ok(Some(Measure {
            name: name.lower(),
            pos: start,
            text: self.text.clone(),
            kind,
        }))
    }

    fn ic(&mut self) -> Result<Vec<(Name, ExprTok)>, NetlistError> {
        let mut out = Vec::new();
        if self.cur.at_end() {
            return Err(self.syntax("missing `V(node)=value`"));
        }
        while !self.cur.at_end() {
            let pos = self.cur.pos();
            let ok = self.cur.eat_keyword("v") && self.cur.eat('(');
            if !ok {
                return Err(NetlistError::syntax(
                    pos,
                    self.text.clone(),
                    format!("expected `V(node)=value` in card `{}`", self.text),
                ));
            }
            let node = self.node()?;
            if !self.cur.eat(')') {
                return Err(self.syntax("expected `)`"));
            }
            if !self.cur.eat('=') {
                return Err(self.syntax("expected `=`"));
            }
            let v = self.value("initial voltage")?;
            out.push((node, v));
        }
        Ok(out)
    }
}

/// A `.subckt` being read, with the position of its card.
struct Open {
    def: SubcktDef,
    start: Pos,
    text: String,
}

fn add_subckt(block: &mut Block, def: SubcktDef) -> Result<(), NetlistError> {
    if block.subckts.iter().any(|s| s.name.norm == def.name.norm) {
        return Err(NetlistError::new(
            ErrorKind::DuplicateDefinition,
            def.name.pos,
            def.name.orig.clone(),
            format!("subcircuit `{}` defined twice", def.name.orig),
        ));
    }
    block.subckts.push(def);
    Ok(())
}

/// Parses the cards of `lexed` into a syntax tree.
pub(crate) fn parse(lexed: Lexed) -> Result<Parsed, NetlistError> {
    let mut warnings = lexed.warnings;
    let mut top = Block::default();
    let mut stack: Vec<Open> = Vec::new();
    let mut tran: Option<TranCard> = None;
    let mut op = false;
    let mut globals = Vec::new();
    let mut options = Vec::new();
    let mut outputs = Vec::new();
    let mut measures = Vec::new();
    let mut other_analyses: Vec<(Pos, String, String)> = Vec::new();

    for card in &lexed.cards {
        let mut p = CardParser::new(card);
        let first = card.first_word();
        let start = card.start();
        if first.starts_with('.') {
            let kw = p.cur.word().map(|w| w.lower()).unwrap_or_default();
            let block = match stack.last_mut() {
                Some(open) => &mut open.def.body,
                None => &mut top,
            };
            match kw.as_str() {
                ".param" => {
                    let params = p.params()?;
                    if params.is_empty() {
                        return Err(p.syntax("missing `name=value`"));
                    }
                    for (name, value) in params {
                        if block.params.iter().any(|(n, _)| n.norm == name.norm) {
                            warnings.push(Warning::new(
                                name.pos,
                                name.orig.clone(),
                                format!(
                                    "parameter `{}` redefined; the last definition is used",
                                    name.orig
                                ),
                            ));
                            block.params.retain(|(n, _)| n.norm != name.norm);
                        }
                        block.params.push((name, value));
                    }
                }
                ".func" => {
                    let (name, def) = p.func()?;
                    if let Some(k) = block.funcs.iter().position(|(n, _)| n.norm == name.norm) {
                        warnings.push(Warning::new(
                            name.pos,
                            name.orig.clone(),
                            format!(
                                "function `{}` redefined; the last definition is used",
                                name.orig
                            ),
                        ));
                        block.funcs.remove(k);
                    }
                    block.funcs.push((name, def));
                }
                ".model" => {
                    let model = p.model(&mut warnings)?;
                    if block.models.iter().any(|m| m.name.norm == model.name.norm) {
                        return Err(NetlistError::new(
                            ErrorKind::DuplicateDefinition,
                            model.name.pos,
                            model.name.orig.clone(),
                            format!("model `{}` defined twice", model.name.orig),
                        ));
                    }
                    block.models.push(model);
                }
                ".ic" => {
                    let ics = p.ic()?;
                    block.ics.extend(ics);
                }
                ".tran" => {
                    if let Some(open) = stack.last() {
                        return Err(NetlistError::new(
                            ErrorKind::Unsupported,
                            start,
                            p.text.clone(),
                            format!(
                                "`.tran` inside `.subckt {}` opened at line {}: is its `.ends` missing? (`.tran` belongs at the top level)",
                                open.def.name.orig, open.start.line
                            ),
                        ));
                    }
                    if tran.is_some() {
                        return Err(NetlistError::new(
                            ErrorKind::Unsupported,
                            start,
                            p.text.clone(),
                            format!("a second `.tran` card `{}` not supported", p.text),
                        ));
                    }
                    tran = Some(p.tran()?);
                }
                ".subckt" => {
                    let def = p.subckt()?;
                    stack.push(Open {
                        def,
                        start,
                        text: p.text.clone(),
                    });
                }
                ".ends" => {
                    let Some(open) = stack.pop() else {
                        return Err(NetlistError::syntax(
                            start,
                            p.text.clone(),
                            "`.ends` without `.subckt`",
                        ));
                    };
                    if let Some(w) = p.cur.word()
                        && w.lower() != open.def.name.norm
                    {
                        return Err(NetlistError::syntax(
                            w.start(),
                            w.text.clone(),
                            format!(
                                "`.ends {}` closes subcircuit `{}`",
                                w.text, open.def.name.orig
                            ),
                        ));
                    }
                    p.finish()?;
                    let parent = match stack.last_mut() {
                        Some(o) => &mut o.def.body,
                        None => &mut top,
                    };
                    add_subckt(parent, open.def)?;
                }
                ".endc" => {
                    return Err(NetlistError::syntax(
                        start,
                        p.text.clone(),
                        "`.endc` without `.control`",
                    ));
                }
                ".op" => op = true,
                ".global" => {
                    // Global nodes keep their name inside subcircuits; ground is global already.
                    while let Some(w) = p.cur.word() {
                        let node = Name::node(&w);
                        if node.norm != "0" && !globals.contains(&node.norm) {
                            globals.push(node.norm);
                        }
                    }
                }
                ".temp" => {
                    // The circuit temperature, read like `.options temp=`.
                    let value = p.word("temperature")?;
                    p.finish()?;
                    options.push(OptionCard {
                        key: "temp".to_owned(),
                        value: Some(value.text.to_ascii_lowercase()),
                        pos: start,
                    });
                }
                ".options" | ".option" | ".opt" => options.extend(option_pairs(card, &p.text)),
                k if OUTPUT_DOT_CARDS.contains(&k) => {
                    outputs.extend(output_requests(card, &p.text))
                }
                ".meas" | ".measure" if !stack.is_empty() => {
                    warnings.push(Warning::new(
                        start,
                        p.text.clone(),
                        format!("`.meas` inside a subcircuit ignored (measures belong at the top level): `{}`", p.text),
                    ));
                }
                ".meas" | ".measure" => {
                    if let Some(m) = p.measure(&mut warnings)? {
                        if let Some(k) = measures
                            .iter()
                            .position(|o: &Measure<ExprTok>| o.name == m.name)
                        {
                            warnings.push(Warning::new(
                                start,
                                p.text.clone(),
                                format!(
                                    "`.meas {}` defined twice; the last definition is used",
                                    m.name
                                ),
                            ));
                            measures.remove(k);
                        }
                        measures.push(m);
                    }
                }
                k if OTHER_ANALYSES.contains(&k) => {
                    other_analyses.push((start, p.text.clone(), k.to_owned()));
                }
                k if IGNORED_DOT_CARDS.contains(&k) => {
                    warnings.push(Warning::new(
                        start,
                        p.text.clone(),
                        format!("`{k}` card ignored: `{}`", p.text),
                    ));
                }
                _ => return Err(NetlistError::unsupported_card(start, &p.text)),
            }
        } else {
            let element = p.element(&mut warnings)?;
            let block = match stack.last_mut() {
                Some(open) => &mut open.def.body,
                None => &mut top,
            };
            block.elements.push(element);
        }
    }
    if let Some(open) = stack.pop() {
        return Err(NetlistError::syntax(
            open.start,
            open.text,
            format!("`.subckt {}` without `.ends`", open.def.name.orig),
        ));
    }
    for (pos, text, kind) in other_analyses {
        if tran.is_none() && !op {
            return Err(NetlistError::unsupported_card(pos, &text));
        }
        warnings.push(Warning::new(
            pos,
            text.clone(),
            format!("`{kind}` analysis not run (dirac runs `.tran` and `.op`): `{text}`"),
        ));
    }
    Ok(Parsed {
        title: lexed.title,
        top,
        tran,
        op,
        options,
        outputs,
        measures,
        globals,
        warnings,
    })
}
