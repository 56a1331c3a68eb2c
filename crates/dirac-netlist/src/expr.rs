//! Parameter and behavioural arithmetic: parsing `.param`, `{...}` and B-source expressions,
//! evaluating the former and turning the latter into a [`dirac_components::Expression`].
//!
//! Grammar, loosest first (ngspice's, from `inpptree-parser.y` and what its `.param` reader
//! computes):
//!
//! ```text
//! cond    := or ('?' cond ':' cond)?
//! or      := and ('||' and)*
//! and     := eq ('&&' eq)*
//! eq      := rel (('==' | '!=') rel)*
//! rel     := sum (('<' | '<=' | '>' | '>=') sum)*
//! sum     := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+' | '!') unary | power
//! power   := primary (('^' | '**') operand)*        left-associative: 2^3^2 = 64
//! operand := ('-' | '+' | '!') operand | primary
//! primary := number | name | name '(' cond (',' cond)* ')' | '(' cond ')'
//!          | v '(' node [',' node] ')' | i '(' element ')'
//! ```
//!
//! so `-2^2` is -4 and `2^-1` is 0.5. `a ^ b` is `|a|^b`, as ngspice-39 computes it in both
//! places (`.param p = {(-2)^3}` is 8); `pow(a, b)` is the real power in a parameter (−8) and
//! `|a|^b` in a B source, `pwr(a, b)` is `|a|^b` in a parameter (8) and `sgn(a)·|a|^b` in a B
//! source (−8), as there. Comparisons and `!`, `&&`, `||` give 1 or 0. Numbers take
//! SPICE suffixes (`1k`, `10uF`). Names are case-insensitive parameter references (in a B
//! source `time`, `temper`, `hertz`, `pi` and `e` come first, as in ngspice). Functions: [`FUNCTIONS`], `min max pow pwr` and `ternary_fcn`. `v(…)` and `i(…)`
//! (node voltages and element currents) are read by B sources only.

use super::error::{ErrorKind, NetlistError, Pos};
use super::lexer::Spanned;
use super::units::parse_number_prefix;
use dirac_components::{Expression, Function, Operator};

/// The one-argument functions by name.
pub(crate) const FUNCTIONS: [(&str, Function); 32] = [
    ("abs", Function::Abs),
    ("sgn", Function::Sgn),
    ("sqrt", Function::Sqrt),
    ("exp", Function::Exp),
    ("ln", Function::Ln),
    ("log", Function::Ln),
    ("log10", Function::Log10),
    ("sin", Function::Sin),
    ("cos", Function::Cos),
    ("tan", Function::Tan),
    ("asin", Function::Asin),
    ("acos", Function::Acos),
    ("atan", Function::Atan),
    ("arctan", Function::Atan),
    ("sinh", Function::Sinh),
    ("cosh", Function::Cosh),
    ("tanh", Function::Tanh),
    ("asinh", Function::Asinh),
    ("acosh", Function::Acosh),
    ("atanh", Function::Atanh),
    ("u", Function::Step),
    ("u2", Function::ClippedRamp),
    ("uramp", Function::Ramp),
    ("ceil", Function::Ceil),
    ("floor", Function::Floor),
    ("nint", Function::Round),
    ("eq0", Function::IsZero),
    ("ne0", Function::IsNonZero),
    ("gt0", Function::IsPositive),
    ("lt0", Function::IsNegative),
    ("ge0", Function::IsNonNegative),
    ("le0", Function::IsNonPositive),
];

/// What a B source reads of the circuit: `v(a)`, `v(a, b)` or `i(name)` (names lowercased as
/// written; the netlist maps them into subcircuit scope).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Probe {
    /// The voltage from the first node to the second (ground when absent).
    Voltage(String, Option<String>),
    /// The current of an element.
    Current(String),
}

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Num(f64),
    /// A parameter reference (lowercased name) and where it is.
    Param(String, Pos),
    /// A circuit quantity and where it is.
    Probe(Probe, Pos),
    Call1(Function, Box<Expr>),
    Bin(Operator, Box<Expr>, Box<Expr>),
    /// `pow(a, b)`, whose meaning depends on where it is read (see the module's doc).
    PowCall(Box<Expr>, Box<Expr>),
    Ternary(Box<Expr>, Box<Expr>, Box<Expr>),
    /// `pwl(a, x₀, y₀, …)`: the argument, the points' coordinates (constants) and where it is.
    Pwl(Box<Expr>, Vec<Expr>, Pos),
    /// A call of a function no built-in has this name of: a `.func` resolved where it is
    /// evaluated (lowercased name, arguments, position).
    UserCall(String, Vec<Expr>, Pos),
}

/// A `.func name(params) {body}` definition.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FuncDef {
    /// The parameters' names, lowercased.
    pub params: Vec<String>,
    /// The body.
    pub body: Expr,
}

/// What an expression's names resolve to where it is evaluated: parameters and `.func`s.
pub(crate) trait Env {
    /// The value of parameter `name` (lowercased), found at `pos`.
    fn param(&self, name: &str, pos: Pos) -> Result<f64, NetlistError>;
    /// The `.func` named `name` (lowercased), if one is in scope.
    fn function(&self, name: &str) -> Option<std::rc::Rc<FuncDef>>;
    /// The circuit's temperature in °C (a B source's `temper`).
    fn temperature(&self) -> f64;
}

/// Deepest nesting of `.func` calls (a function calling itself ends here).
const MAX_CALL_DEPTH: usize = 50;

/// Most `.func` calls one evaluation may expand: functions that each call the one before twice
/// would otherwise take time (and, inlined into a B source, memory) exponential in their number.
const MAX_CALLS: usize = 10_000;

/// An expression with its source text and position, as written in a card.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ExprTok {
    pub expr: Expr,
    pub text: String,
    pub pos: Pos,
    /// Nesting depth of `expr` (a bound on the recursion of evaluating it).
    pub depth: usize,
}

impl ExprTok {
    /// Parses the expression in `span`.
    pub fn parse(span: &Spanned) -> Result<Self, NetlistError> {
        let expr = parse(span)?;
        Ok(Self {
            depth: nesting(&expr),
            expr,
            text: span.text.clone(),
            pos: span.start(),
        })
    }
}

/// The nesting depth of an expression tree, counted without recursion (a long sum is a tree as
/// deep as it has terms).
fn nesting(e: &Expr) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(e, 1)];
    while let Some((e, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let below = depth + 1;
        match e {
            Expr::Num(_) | Expr::Param(..) | Expr::Probe(..) => {}
            Expr::Call1(_, a) => stack.push((a, below)),
            Expr::Bin(_, a, b) | Expr::PowCall(a, b) => {
                stack.extend([(&**a, below), (&**b, below)]);
            }
            Expr::Ternary(c, a, b) => stack.extend([(&**c, below), (&**a, below), (&**b, below)]),
            Expr::Pwl(a, rest, _) => {
                stack.push((a, below));
                stack.extend(rest.iter().map(|r| (r, below)));
            }
            Expr::UserCall(_, args, _) => stack.extend(args.iter().map(|a| (a, below))),
        }
    }
    deepest
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    /// A number's value and its text as written (`.3u`), which messages quote.
    Num(f64, String),
    Ident(String),
    /// `v(…)` or `i(…)`.
    Probe(Probe),
    Plus,
    Minus,
    Star,
    Slash,
    Pow,
    LParen,
    RParen,
    Comma,
    Question,
    Colon,
    Not,
    And,
    Or,
    /// A comparison, as the function of `a − b` ngspice builds for it.
    Compare(Function, &'static str),
}

impl Tok {
    fn describe(&self) -> String {
        let symbol = match self {
            Tok::Num(_, text) => return format!("number `{text}`"),
            Tok::Ident(s) => s,
            Tok::Probe(Probe::Voltage(..)) => "v(…)",
            Tok::Probe(Probe::Current(..)) => "i(…)",
            Tok::Plus => "+",
            Tok::Minus => "-",
            Tok::Star => "*",
            Tok::Slash => "/",
            Tok::Pow => "^",
            Tok::LParen => "(",
            Tok::RParen => ")",
            Tok::Comma => ",",
            Tok::Question => "?",
            Tok::Colon => ":",
            Tok::Not => "!",
            Tok::And => "&&",
            Tok::Or => "||",
            Tok::Compare(_, s) => s,
        };
        format!("`{symbol}`")
    }
}

/// The probe `v(…)`/`i(…)` whose name `name` ends at `chars[i]`, if one opens there: its
/// arguments (blank- or comma-separated names, lowercased) and the index after its `)`.
fn probe(
    span: &Spanned,
    chars: &[char],
    name: &str,
    mut i: usize,
) -> Result<Option<(Probe, usize)>, NetlistError> {
    if name != "v" && name != "i" {
        return Ok(None);
    }
    while chars.get(i).is_some_and(|c| c.is_whitespace()) {
        i += 1;
    }
    if chars.get(i) != Some(&'(') {
        return Ok(None);
    }
    let open = i;
    let Some(close) = (open..chars.len()).find(|&k| chars[k] == ')') else {
        return Err(NetlistError::syntax(
            span.pos_at(open),
            "(",
            format!("unterminated `{name}(`: missing `)` in `{}`", span.text),
        ));
    };
    let inside: String = chars[open + 1..close].iter().collect();
    let args: Vec<String> = inside
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|a| !a.is_empty())
        .map(|a| {
            let a = a.to_lowercase();
            if a == "gnd" { "0".to_owned() } else { a }
        })
        .collect();
    let bad = |what: &str| {
        Err(NetlistError::syntax(
            span.pos_at(open),
            format!("{name}({inside})"),
            format!("`{name}({inside})` {what} in `{}`", span.text),
        ))
    };
    let p = match (name, args.as_slice()) {
        ("v", [a]) => Probe::Voltage(a.clone(), None),
        ("v", [a, b]) => Probe::Voltage(a.clone(), Some(b.clone())),
        ("v", _) => return bad("must name one or two nodes"),
        ("i", [a]) => Probe::Current(a.clone()),
        _ => return bad("must name one element"),
    };
    Ok(Some((p, close + 1)))
}

fn tokenize(span: &Spanned) -> Result<Vec<(Tok, usize)>, NetlistError> {
    let chars: Vec<char> = span.text.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        let next = chars.get(i + 1).copied();
        let tok = if c.is_ascii_digit() || (c == '.' && next.is_some_and(|d| d.is_ascii_digit())) {
            match parse_number_prefix(&chars[i..]) {
                Some((v, used)) => {
                    i += used;
                    Tok::Num(v, chars[start..i].iter().collect())
                }
                None => {
                    return Err(NetlistError::syntax(
                        span.pos_at(i),
                        c.to_string(),
                        "malformed number",
                    ));
                }
            }
        } else if c.is_alphabetic() || c == '_' {
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let name = chars[start..i].iter().collect::<String>().to_lowercase();
            match probe(span, &chars, &name, i)? {
                Some((p, after)) => {
                    i = after;
                    Tok::Probe(p)
                }
                None => Tok::Ident(name),
            }
        } else {
            let two = |second: char| next == Some(second);
            let (tok, used) = match c {
                '+' => (Tok::Plus, 1),
                '-' => (Tok::Minus, 1),
                '*' if two('*') => (Tok::Pow, 2),
                '*' => (Tok::Star, 1),
                '/' => (Tok::Slash, 1),
                '^' => (Tok::Pow, 1),
                // Braces inside an expression group as parentheses do (ngspice substitutes a
                // `{param}` in a B source's expression by its value before parsing it).
                '(' | '{' => (Tok::LParen, 1),
                ')' | '}' => (Tok::RParen, 1),
                ',' => (Tok::Comma, 1),
                '?' => (Tok::Question, 1),
                ':' => (Tok::Colon, 1),
                '&' if two('&') => (Tok::And, 2),
                '|' if two('|') => (Tok::Or, 2),
                '=' if two('=') => (Tok::Compare(Function::IsZero, "=="), 2),
                '!' if two('=') => (Tok::Compare(Function::IsNonZero, "!="), 2),
                '!' => (Tok::Not, 1),
                '<' if two('=') => (Tok::Compare(Function::IsNonPositive, "<="), 2),
                '<' => (Tok::Compare(Function::IsNegative, "<"), 1),
                '>' if two('=') => (Tok::Compare(Function::IsNonNegative, ">="), 2),
                '>' => (Tok::Compare(Function::IsPositive, ">"), 1),
                _ => {
                    return Err(NetlistError::syntax(
                        span.pos_at(start),
                        c.to_string(),
                        format!("unexpected character `{c}` in expression `{}`", span.text),
                    ));
                }
            };
            i += used;
            tok
        };
        toks.push((tok, start));
        if toks.len() > MAX_TOKENS {
            return Err(NetlistError::syntax(
                span.pos_at(start),
                span.text.chars().take(40).collect::<String>(),
                format!("expression longer than {MAX_TOKENS} tokens"),
            ));
        }
    }
    Ok(toks)
}

/// Longest expression read, in tokens (a bound on the time and memory of reading one).
const MAX_TOKENS: usize = 100_000;

/// Deepest expression tree accepted: evaluating walks it recursively (a sum of 15 000 terms, a
/// tree that deep, overflowed the stack).
const MAX_TREE_DEPTH: usize = 1000;

/// Deepest an expression may reach once its `.func` calls are expanded (its own depth plus the
/// depths of the bodies it calls into), so evaluating it stays far from the stack's end.
const MAX_REACH: usize = 4000;

/// Deepest nesting of parentheses and unary operators accepted in one expression.
const MAX_DEPTH: usize = 100;

struct Parser<'a> {
    span: &'a Spanned,
    toks: Vec<(Tok, usize)>,
    k: usize,
    depth: usize,
}

fn call1(f: Function, a: Expr) -> Expr {
    Expr::Call1(f, Box::new(a))
}

fn bin(op: Operator, a: Expr, b: Expr) -> Expr {
    Expr::Bin(op, Box::new(a), Box::new(b))
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.k).map(|(t, _)| t)
    }

    fn pos(&self) -> Pos {
        match self.toks.get(self.k) {
            Some((_, i)) => self.span.pos_at(*i),
            None => self.span.end,
        }
    }

    fn unexpected(&self, wanted: &str) -> NetlistError {
        let (found, text) = match self.peek() {
            Some(t) => (t.describe(), t.describe().trim_matches('`').to_owned()),
            None => ("end of expression".to_owned(), String::new()),
        };
        NetlistError::syntax(
            self.pos(),
            text,
            format!(
                "expected {wanted}, found {found} in expression `{}`",
                self.span.text
            ),
        )
    }

    /// Counts one level of nesting for `inner` (each unary level, so each parenthesis).
    fn nested(
        &mut self,
        inner: impl FnOnce(&mut Self) -> Result<Expr, NetlistError>,
    ) -> Result<Expr, NetlistError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(NetlistError::syntax(
                self.pos(),
                self.span.text.clone(),
                format!("expression nested more than {MAX_DEPTH} levels deep"),
            ));
        }
        let e = inner(self);
        self.depth -= 1;
        e
    }

    fn cond(&mut self) -> Result<Expr, NetlistError> {
        let c = self.or()?;
        if self.peek() != Some(&Tok::Question) {
            return Ok(c);
        }
        self.k += 1;
        // Each branch is a level of nesting, as a parenthesis is.
        let a = self.nested(Self::cond)?;
        self.expect(&Tok::Colon, "`:`")?;
        let b = self.nested(Self::cond)?;
        Ok(Expr::Ternary(Box::new(c), Box::new(a), Box::new(b)))
    }

    fn or(&mut self) -> Result<Expr, NetlistError> {
        // ngspice: a || b is ne0(ne0(a) + ne0(b)).
        self.logical(&Tok::Or, Function::IsNonZero, Self::and)
    }

    fn and(&mut self) -> Result<Expr, NetlistError> {
        // ngspice: a && b is eq0(eq0(a) + eq0(b)).
        self.logical(&Tok::And, Function::IsZero, |p| p.comparison(true))
    }

    /// Operands of `inner` joined by `tok`, each pair as `f(f(a) + f(b))`.
    fn logical(
        &mut self,
        tok: &Tok,
        f: Function,
        inner: impl Fn(&mut Self) -> Result<Expr, NetlistError>,
    ) -> Result<Expr, NetlistError> {
        let mut lhs = inner(self)?;
        while self.peek() == Some(tok) {
            self.k += 1;
            let rhs = inner(self)?;
            lhs = call1(f, bin(Operator::Add, call1(f, lhs), call1(f, rhs)));
        }
        Ok(lhs)
    }

    /// `==`/`!=` (`equality`) over `<`, `<=`, `>`, `>=` (otherwise), each `f(a − b)`.
    fn comparison(&mut self, equality: bool) -> Result<Expr, NetlistError> {
        let operand = |p: &mut Self| {
            if equality {
                p.comparison(false)
            } else {
                p.sum()
            }
        };
        let mut lhs = operand(self)?;
        while let Some(Tok::Compare(f, symbol)) = self.peek() {
            let f = *f;
            if (*symbol == "==" || *symbol == "!=") != equality {
                break;
            }
            self.k += 1;
            let rhs = operand(self)?;
            lhs = call1(f, bin(Operator::Sub, lhs, rhs));
        }
        Ok(lhs)
    }

    fn sum(&mut self) -> Result<Expr, NetlistError> {
        let mut lhs = self.term()?;
        loop {
            let op = match self.peek() {
                Some(Tok::Plus) => Operator::Add,
                Some(Tok::Minus) => Operator::Sub,
                _ => return Ok(lhs),
            };
            self.k += 1;
            let rhs = self.term()?;
            lhs = bin(op, lhs, rhs);
        }
    }

    fn term(&mut self) -> Result<Expr, NetlistError> {
        let mut lhs = self.unary(false)?;
        loop {
            let op = match self.peek() {
                Some(Tok::Star) => Operator::Mul,
                Some(Tok::Slash) => Operator::Div,
                _ => return Ok(lhs),
            };
            self.k += 1;
            let rhs = self.unary(false)?;
            lhs = bin(op, lhs, rhs);
        }
    }

    /// A unary operator, then a power (`operand`: a primary, the right side of `^`).
    fn unary(&mut self, operand: bool) -> Result<Expr, NetlistError> {
        self.nested(|p| match p.peek() {
            Some(Tok::Minus) => {
                p.k += 1;
                Ok(call1(Function::Neg, p.unary(operand)?))
            }
            Some(Tok::Plus) => {
                p.k += 1;
                p.unary(operand)
            }
            Some(Tok::Not) => {
                p.k += 1;
                Ok(call1(Function::IsZero, p.unary(operand)?))
            }
            _ if operand => p.primary(),
            _ => p.power(),
        })
    }

    fn power(&mut self) -> Result<Expr, NetlistError> {
        let mut base = self.primary()?;
        while self.peek() == Some(&Tok::Pow) {
            self.k += 1;
            let exponent = self.unary(true)?;
            base = bin(Operator::Pow, base, exponent);
        }
        Ok(base)
    }

    fn expect(&mut self, tok: &Tok, wanted: &str) -> Result<(), NetlistError> {
        if self.peek() == Some(tok) {
            self.k += 1;
            Ok(())
        } else {
            Err(self.unexpected(wanted))
        }
    }

    fn primary(&mut self) -> Result<Expr, NetlistError> {
        let pos = self.pos();
        match self.peek().cloned() {
            Some(Tok::Num(v, _)) => {
                self.k += 1;
                Ok(Expr::Num(v))
            }
            Some(Tok::Probe(p)) => {
                self.k += 1;
                Ok(Expr::Probe(p, pos))
            }
            Some(Tok::LParen) => {
                self.k += 1;
                let e = self.cond()?;
                self.expect(&Tok::RParen, "`)`")?;
                Ok(e)
            }
            Some(Tok::Ident(name)) => {
                self.k += 1;
                if self.peek() != Some(&Tok::LParen) {
                    return Ok(Expr::Param(name, pos));
                }
                self.k += 1;
                let mut args = vec![self.cond()?];
                while self.peek() == Some(&Tok::Comma) {
                    self.k += 1;
                    args.push(self.cond()?);
                }
                self.expect(&Tok::RParen, "`)` or `,`")?;
                call(&name, args, pos, self.span)
            }
            _ => Err(self.unexpected("a number, a name or `(`")),
        }
    }
}

/// Whether `name` is a built-in function (or `v`, `i`), which a `.func` may not redefine.
pub(crate) fn built_in(name: &str) -> bool {
    FUNCTIONS.iter().any(|(n, _)| *n == name)
        || matches!(
            name,
            "min" | "max" | "pow" | "pwr" | "ternary_fcn" | "pwl" | "v" | "i"
        )
}

fn call(name: &str, args: Vec<Expr>, pos: Pos, span: &Spanned) -> Result<Expr, NetlistError> {
    let arity = if FUNCTIONS.iter().any(|(n, _)| *n == name) {
        1
    } else {
        match name {
            "min" | "max" | "pow" | "pwr" => 2,
            "ternary_fcn" => 3,
            "pwl" if args.len() >= 5 && args.len() % 2 == 1 => args.len(),
            "pwl" => {
                return Err(NetlistError::syntax(
                    pos,
                    name,
                    format!(
                        "`pwl` takes its argument and two points at least (x, y pairs), got {} \
                         arguments in expression `{}`",
                        args.len(),
                        span.text
                    ),
                ));
            }
            // A `.func`, resolved where the expression is evaluated.
            _ => return Ok(Expr::UserCall(name.to_owned(), args, pos)),
        }
    };
    if args.len() != arity {
        return Err(NetlistError::syntax(
            pos,
            name,
            format!(
                "function `{name}` takes {arity} argument{}, got {} in expression `{}`",
                if arity == 1 { "" } else { "s" },
                args.len(),
                span.text
            ),
        ));
    }
    let mut args = args.into_iter();
    let mut arg = || Box::new(args.next().unwrap_or(Expr::Num(0.0)));
    Ok(match name {
        "min" => Expr::Bin(Operator::Min, arg(), arg()),
        "max" => Expr::Bin(Operator::Max, arg(), arg()),
        "pwr" => Expr::Bin(Operator::Pwr, arg(), arg()),
        "pow" => Expr::PowCall(arg(), arg()),
        "ternary_fcn" => Expr::Ternary(arg(), arg(), arg()),
        "pwl" => {
            let a = arg();
            Expr::Pwl(a, args.collect(), pos)
        }
        _ => {
            let f = FUNCTIONS
                .iter()
                .find(|(n, _)| *n == name)
                .map_or(Function::Abs, |(_, f)| *f);
            Expr::Call1(f, arg())
        }
    })
}

/// Parses the whole of `span` as an expression.
pub(crate) fn parse(span: &Spanned) -> Result<Expr, NetlistError> {
    let toks = tokenize(span)?;
    let mut p = Parser {
        span,
        toks,
        k: 0,
        depth: 0,
    };
    let e = p.cond()?;
    if p.k < p.toks.len() {
        return Err(p.unexpected("an operator or the end of the expression"));
    }
    let depth = nesting(&e);
    if depth > MAX_TREE_DEPTH {
        return Err(NetlistError::syntax(
            span.start(),
            span.text.chars().take(40).collect::<String>(),
            format!(
                "expression nested {depth} levels deep (a sum or product of that many terms \
                 counts as that deep); at most {MAX_TREE_DEPTH} are read"
            ),
        ));
    }
    Ok(e)
}

/// The `.func` a call names, with its arguments checked against its parameters.
fn user_function<T>(
    bound: &Bound<'_, T>,
    name: &str,
    args: usize,
    pos: Pos,
) -> Result<std::rc::Rc<FuncDef>, NetlistError> {
    let Some(def) = bound.env.function(name) else {
        return Err(NetlistError::new(
            ErrorKind::UnknownFunction,
            pos,
            name,
            format!("unknown function `{name}` (neither built in nor defined by a .func)"),
        ));
    };
    if def.params.len() != args {
        return Err(NetlistError::syntax(
            pos,
            name,
            format!(
                "function `{name}` takes {} argument{}, got {args}",
                def.params.len(),
                if def.params.len() == 1 { "" } else { "s" },
            ),
        ));
    }
    if bound.depth >= MAX_CALL_DEPTH {
        return Err(NetlistError::new(
            ErrorKind::RecursiveParam,
            pos,
            name,
            format!(
                "function `{name}`: calls nested more than {MAX_CALL_DEPTH} deep (does it call \
                 itself?)"
            ),
        ));
    }
    if bound.reach + nesting(&def.body) > MAX_REACH {
        return Err(NetlistError::new(
            ErrorKind::Unsupported,
            pos,
            name,
            format!("function `{name}`: its calls, expanded, nest deeper than {MAX_REACH} levels"),
        ));
    }
    bound.calls.set(bound.calls.get() + 1);
    if bound.calls.get() > MAX_CALLS {
        return Err(NetlistError::new(
            ErrorKind::Unsupported,
            pos,
            name,
            format!("function `{name}`: an expression expanding to more than {MAX_CALLS} calls"),
        ));
    }
    Ok(def)
}

/// Names bound by a `.func` call: its parameters first, then the environment.
struct Bound<'a, T> {
    env: &'a dyn Env,
    names: &'a [String],
    values: &'a [T],
    /// Calls expanded (and, in a B source, argument terms copied) so far in this evaluation.
    calls: &'a std::cell::Cell<usize>,
    /// The depth of the function bodies entered to get here.
    reach: usize,
    /// How many calls are open.
    depth: usize,
}

impl<'a, T> Bound<'a, T> {
    /// No call open yet: names resolve in `env`.
    fn top(env: &'a dyn Env, calls: &'a std::cell::Cell<usize>) -> Self {
        Self {
            env,
            names: &[],
            values: &[],
            calls,
            reach: 0,
            depth: 0,
        }
    }

    /// Inside a call of `def` with the arguments `values`.
    fn enter<'b, U>(&'b self, def: &'b FuncDef, values: &'b [U]) -> Bound<'b, U> {
        Bound {
            env: self.env,
            names: &def.params,
            values,
            calls: self.calls,
            reach: self.reach + nesting(&def.body),
            depth: self.depth + 1,
        }
    }
}

/// Evaluates a parameter expression in `env`. `v(…)` and `i(…)` are refused: only B sources
/// read them.
pub(crate) fn eval(expr: &Expr, env: &dyn Env) -> Result<f64, NetlistError> {
    let calls = std::cell::Cell::new(0);
    evaluate(expr, &Bound::top(env, &calls))
}

fn evaluate(expr: &Expr, bound: &Bound<'_, f64>) -> Result<f64, NetlistError> {
    let go = |e: &Expr| evaluate(e, bound);
    Ok(match expr {
        Expr::Num(v) => *v,
        Expr::Param(name, pos) => match bound.names.iter().position(|n| n == name) {
            Some(k) => bound.values[k],
            None => bound.env.param(name, *pos)?,
        },
        Expr::Probe(p, pos) => {
            let text = match p {
                Probe::Voltage(..) => "v(…)",
                Probe::Current(..) => "i(…)",
            };
            return Err(NetlistError::new(
                ErrorKind::BadValue,
                *pos,
                text,
                format!(
                    "`{text}` reads the circuit while it runs: only a B source (or an E or G \
                     source's VALUE=) can use it, not a parameter, a value or a pwl point"
                ),
            ));
        }
        // A parameter's logarithm of 0 is −∞ (refused as not finite), not a B source's −1e99.
        Expr::Call1(f @ (Function::Ln | Function::Log10), a) => match go(a)? {
            0.0 => f64::NEG_INFINITY,
            x => f.apply(x),
        },
        Expr::Call1(f, a) => f.apply(go(a)?),
        // ngspice-39's parameter `pwr(x, y)` is |x|^y (`.param p = {pwr(-2,3)}` is 8), where a
        // B source's is sgn(x)·|x|^y.
        Expr::Bin(Operator::Pwr, a, b) => Operator::Pow.apply(go(a)?, go(b)?),
        // A parameter's division is exact (1/0 is refused as not finite); only a B source moves
        // its divisor off zero, as ngspice's `PTdivide` does.
        Expr::Bin(Operator::Div, a, b) => go(a)? / go(b)?,
        Expr::Bin(op, a, b) => op.apply(go(a)?, go(b)?),
        Expr::PowCall(a, b) => go(a)?.powf(go(b)?),
        Expr::Ternary(c, a, b) => {
            if go(c)? != 0.0 {
                go(a)?
            } else {
                go(b)?
            }
        }
        Expr::Pwl(a, rest, pos) => {
            let points = rest.iter().map(go).collect::<Result<Vec<f64>, _>>()?;
            increasing(&points, *pos)?;
            let table = pairs(&points);
            Expression::Piecewise(Box::new(Expression::Constant(go(a)?)), table).value(&[], 0.0)
        }
        Expr::UserCall(name, args, pos) => {
            let def = user_function(bound, name, args.len(), *pos)?;
            let values = args.iter().map(go).collect::<Result<Vec<f64>, _>>()?;
            evaluate(&def.body, &bound.enter(&def, &values))?
        }
    })
}

/// The number of nodes of an expression tree.
fn size(e: &Expression) -> usize {
    1 + match e {
        Expression::Constant(_) | Expression::Control(_) | Expression::Time => 0,
        Expression::Unary(_, a) | Expression::Piecewise(a, _) | Expression::Table(a, _) => size(a),
        Expression::Binary(_, a, b) => size(a) + size(b),
        Expression::Conditional(c, a, b) => size(c) + size(a) + size(b),
    }
}

/// Checks that the x of the points `x₀, y₀, x₁, y₁, …` of a `pwl` (at `pos`) or a `TABLE` rise
/// strictly, as the bisection for a point's segment needs.
pub(crate) fn increasing(points: &[f64], pos: Pos) -> Result<(), NetlistError> {
    let xs: Vec<f64> = points.iter().step_by(2).copied().collect();
    match xs.windows(2).position(|w| w[1] <= w[0]) {
        Some(k) => Err(NetlistError::bad_value(
            pos,
            "pwl",
            format!(
                "table points must rise strictly in x: point {} has x = {} after x = {}",
                k + 2,
                xs[k + 1],
                xs[k]
            ),
        )),
        None => Ok(()),
    }
}

fn pairs(points: &[f64]) -> Vec<(f64, f64)> {
    points.chunks_exact(2).map(|p| (p[0], p[1])).collect()
}

/// A B source's expression as the part evaluates it: parameters and `.func`s resolved in `env`
/// (`time` is time), each probe replaced by the control `probe` numbers it with, `pow(a, b)` read
/// as `|a|^b`, `pwl` points evaluated as parameters.
pub(crate) fn behavioural(
    expr: &Expr,
    env: &dyn Env,
    probe: &mut dyn FnMut(&Probe, Pos) -> Result<usize, NetlistError>,
) -> Result<Expression, NetlistError> {
    let calls = std::cell::Cell::new(0);
    convert(expr, &Bound::top(env, &calls), probe)
}

fn convert(
    expr: &Expr,
    bound: &Bound<'_, Expression>,
    probe: &mut dyn FnMut(&Probe, Pos) -> Result<usize, NetlistError>,
) -> Result<Expression, NetlistError> {
    let env = bound.env;
    let mut go = |e: &Expr| convert(e, bound, probe).map(Box::new);
    Ok(match expr {
        Expr::Num(v) => Expression::Constant(*v),
        Expr::Param(name, pos) => match bound.names.iter().position(|n| n == name) {
            Some(k) => {
                // Each use of a parameter copies its argument: bound the copies, which nested
                // calls would otherwise multiply.
                bound.calls.set(bound.calls.get() + size(&bound.values[k]));
                if bound.calls.get() > MAX_CALLS * 100 {
                    return Err(NetlistError::new(
                        ErrorKind::Unsupported,
                        *pos,
                        name,
                        format!(
                            "an expression whose .func calls expand to more than {} terms",
                            MAX_CALLS * 100
                        ),
                    ));
                }
                bound.values[k].clone()
            }
            // ngspice's B-source names (`inpptree.c`): `time`, `temper`, `hertz` (0 outside an
            // AC analysis) and the constants `pi` and `e`, ahead of parameters (ngspice-39 reads
            // `e` as 2.718282 in a B source beside `.param e=5`).
            None => match name.as_str() {
                "time" => Expression::Time,
                "temper" => Expression::Constant(env.temperature()),
                "hertz" => Expression::Constant(0.0),
                "pi" => Expression::Constant(std::f64::consts::PI),
                "e" => Expression::Constant(std::f64::consts::E),
                _ => Expression::Constant(env.param(name, *pos)?),
            },
        },
        Expr::Probe(p, pos) => Expression::Control(probe(p, *pos)?),
        Expr::Call1(f, a) => Expression::Unary(*f, go(a)?),
        Expr::Bin(op, a, b) => Expression::Binary(*op, go(a)?, go(b)?),
        Expr::PowCall(a, b) => Expression::Binary(Operator::Pow, go(a)?, go(b)?),
        Expr::Ternary(c, a, b) => Expression::Conditional(go(c)?, go(a)?, go(b)?),
        Expr::Pwl(a, rest, pos) => {
            // The points are constants, read through the call's own parameters too (a `.func`
            // whose table takes its corners as arguments).
            let mut points = Vec::with_capacity(rest.len());
            for point in rest {
                let point = go(point)?;
                if point.controls() > 0 || point.reads_time() {
                    return Err(NetlistError::bad_value(
                        *pos,
                        "pwl",
                        "a pwl point must be a constant: it reads the circuit or time",
                    ));
                }
                points.push(point.value(&[], 0.0));
            }
            increasing(&points, *pos)?;
            Expression::Piecewise(go(a)?, pairs(&points))
        }
        Expr::UserCall(name, args, pos) => {
            let def = user_function(bound, name, args.len(), *pos)?;
            let values = args
                .iter()
                .map(|a| go(a).map(|b| *b))
                .collect::<Result<Vec<Expression>, _>>()?;
            convert(&def.body, &bound.enter(&def, &values), probe)?
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(text: &str) -> Spanned {
        let positions: Vec<Pos> = (0..text.chars().count())
            .map(|k| Pos::new(1, 10 + k))
            .collect();
        Spanned {
            text: text.to_owned(),
            end: Pos::new(1, 10 + positions.len()),
            positions,
        }
    }

    /// Parameters `a` = 2, `b` = 3 and the functions `f(x, y) = x·y + 1`, `g(x) = f(x, 2)·b`
    /// and `loop(x) = loop(x)`.
    struct Test;

    impl Env for Test {
        fn param(&self, name: &str, pos: Pos) -> Result<f64, NetlistError> {
            match name {
                "a" => Ok(2.0),
                "b" => Ok(3.0),
                _ => Err(NetlistError::new(
                    ErrorKind::UnknownParam,
                    pos,
                    name,
                    "unknown",
                )),
            }
        }
        fn temperature(&self) -> f64 {
            27.0
        }
        fn function(&self, name: &str) -> Option<std::rc::Rc<FuncDef>> {
            let (params, body) = match name {
                "f" => (vec!["x", "y"], "x*y+1"),
                "g" => (vec!["x"], "f(x,2)*b"),
                "loop" => (vec!["x"], "loop(x)"),
                _ => return None,
            };
            Some(std::rc::Rc::new(FuncDef {
                params: params.into_iter().map(String::from).collect(),
                body: parse(&span(body)).expect("parses"),
            }))
        }
    }

    fn value(text: &str) -> f64 {
        let e = parse(&span(text)).expect("parses");
        eval(&e, &Test).expect("evaluates")
    }

    /// `.func`s and `pwl` as ngspice-39 evaluates them (`.param p = {g(2)}` is 15 there with the
    /// same definitions and b = 3; `pwl(-0.5, -1,0, 0,1, 1,3)` is 0.5, at −2 it is −1, at 2 5).
    #[test]
    fn user_functions_and_tables() {
        assert_eq!(value("g(2)"), 15.0);
        assert_eq!(value("f(a, b) - a"), 5.0);
        assert_eq!(value("pwl(-0.5, -1,0, 0,1, 1,3)"), 0.5);
        assert_eq!(value("pwl(-2, -1,0, 0,1, 1,3)"), -1.0);
        assert_eq!(value("pwl(2, -1,0, 0,1, 1,3)"), 5.0);
        let e = parse(&span("loop(1)")).expect("parses");
        assert_eq!(
            eval(&e, &Test).expect_err("recursive").kind,
            ErrorKind::RecursiveParam
        );
        let e = parse(&span("f(1)")).expect("parses");
        assert_eq!(eval(&e, &Test).expect_err("arity").kind, ErrorKind::Syntax);
        assert_eq!(
            parse(&span("pwl(1, 2, 3)")).expect_err("short").kind,
            ErrorKind::Syntax
        );
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(value("1+2*3"), 7.0);
        assert_eq!(value("(1+2)*3"), 9.0);
        assert_eq!(value("10-4-3"), 3.0);
        assert_eq!(value("24/4/3"), 2.0);
        // ngspice-39: `.param q = {2^3^2}` is 64, `{(-2)^3}` and `{(-2)**3}` are 8,
        // `{pow(-2,3)}` is -8, `{3 > 2 ? 7 : 8}` is 7.
        assert_eq!(value("2^3^2"), 64.0);
        assert_eq!(value("(-2)^3"), 8.0);
        assert_eq!(value("(-2)**3"), 8.0);
        assert_eq!(value("pow(-2,3)"), -8.0);
        assert_eq!(value("3 > 2 ? 7 : 8"), 7.0);
        assert_eq!(value("a >= 2 && b <= 3 || !a"), 1.0);
        assert_eq!(value("a >= 2 && b < 3 || !a"), 0.0);
        assert_eq!(value("a == 2 ? b != 3 : 5"), 0.0);
        assert_eq!(value("2**3"), 8.0);
        assert_eq!(value("-2^2"), -4.0);
        assert_eq!(value("2^-1"), 0.5);
        assert_eq!(value("-a*b"), -6.0);
        assert_eq!(value("--a"), 2.0);
        assert_eq!(value("a*b^2+1"), 19.0);
        assert_eq!(value("1k*a"), 2000.0);
        assert_eq!(value("1e-3*B"), 3e-3);
    }

    #[test]
    fn functions() {
        assert_eq!(value("sqrt(16)"), 4.0);
        assert_eq!(value("exp(0)"), 1.0);
        assert_eq!(value("log(exp(2))"), 2.0);
        assert_eq!(value("abs(-a)"), 2.0);
        assert_eq!(value("sin(0)+cos(0)"), 1.0);
        assert_eq!(value("max(a, b) - min(a,b)"), 1.0);
        assert_eq!(value("pow(a,b)"), 8.0);
        assert_eq!(value("log10(1k)"), 3.0);
    }

    #[test]
    fn errors_point_at_the_token() {
        let err = parse(&span("1+*2")).expect_err("bad");
        assert_eq!((err.kind, err.pos()), (ErrorKind::Syntax, Pos::new(1, 12)));
        let err = parse(&span("(1+2")).expect_err("bad");
        assert_eq!((err.kind, err.pos()), (ErrorKind::Syntax, Pos::new(1, 14)));
        let foo = parse(&span("2*foo(1)")).expect("a .func call parses");
        let err = eval(&foo, &Test).expect_err("no such .func");
        assert_eq!(
            (err.kind, err.pos()),
            (ErrorKind::UnknownFunction, Pos::new(1, 12))
        );
        let err = parse(&span("sqrt(1,2)")).expect_err("bad");
        assert_eq!(err.kind, ErrorKind::Syntax);
        let err = parse(&span("1 2")).expect_err("bad");
        assert_eq!(err.pos(), Pos::new(1, 12));
        let err = parse(&span("1#")).expect_err("bad");
        assert_eq!(err.pos(), Pos::new(1, 11));
        // A number is quoted as written, not as its converted value.
        let err = parse(&span("1.2.3u")).expect_err("bad");
        assert!(err.to_string().contains("found number `.3u`"), "{err}");
        let deep = format!("{}1{}", "(".repeat(500), ")".repeat(500));
        assert_eq!(
            parse(&span(&deep)).expect_err("bad").kind,
            ErrorKind::Syntax
        );
        let ok = format!("{}1{}", "(".repeat(50), ")".repeat(50));
        assert!(parse(&span(&ok)).is_ok());
    }
}
