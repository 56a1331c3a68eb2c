//! Parameter arithmetic: parsing and evaluating `.param` and `{...}` expressions.
//!
//! Grammar, loosest first:
//!
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary (('^' | '**') unary)?        right-associative: 2^3^2 = 2^9
//! primary := number | name | name '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//!
//! so `-2^2` is -4 and `2^-1` is 0.5. Numbers take SPICE suffixes (`1k`, `10uF`). Names are
//! case-insensitive parameter references. Functions: `sqrt exp log ln log10 sin cos tan atan abs`
//! (one argument; `log` and `ln` are the natural logarithm, as in ngspice) and `min max pow` (two
//! arguments).

use super::error::{ErrorKind, NetlistError, Pos};
use super::lexer::Spanned;
use super::units::parse_number_prefix;

/// A one-argument function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Func1 {
    Sqrt,
    Exp,
    Ln,
    Log10,
    Sin,
    Cos,
    Tan,
    Atan,
    Abs,
}

/// A two-argument function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Func2 {
    Min,
    Max,
    Pow,
}

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Num(f64),
    /// A parameter reference (lowercased name) and where it is.
    Param(String, Pos),
    Neg(Box<Expr>),
    Bin(BinOp, Box<Expr>, Box<Expr>),
    Call1(Func1, Box<Expr>),
    Call2(Func2, Box<Expr>, Box<Expr>),
}

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

/// The nesting depth of an expression tree.
fn nesting(e: &Expr) -> usize {
    match e {
        Expr::Num(_) | Expr::Param(..) => 1,
        Expr::Neg(a) | Expr::Call1(_, a) => 1 + nesting(a),
        Expr::Bin(_, a, b) | Expr::Call2(_, a, b) => 1 + nesting(a).max(nesting(b)),
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    /// A number's value and its text as written (`.3u`), which messages quote.
    Num(f64, String),
    Ident(String),
    Plus,
    Minus,
    Star,
    Slash,
    Pow,
    LParen,
    RParen,
    Comma,
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Num(_, text) => format!("number `{text}`"),
            Tok::Ident(s) => format!("`{s}`"),
            Tok::Plus => "`+`".into(),
            Tok::Minus => "`-`".into(),
            Tok::Star => "`*`".into(),
            Tok::Slash => "`/`".into(),
            Tok::Pow => "`^`".into(),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Comma => "`,`".into(),
        }
    }
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
        let tok = if c.is_ascii_digit()
            || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()))
        {
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
            Tok::Ident(chars[start..i].iter().collect::<String>().to_lowercase())
        } else {
            i += 1;
            match c {
                '+' => Tok::Plus,
                '-' => Tok::Minus,
                '*' if chars.get(i) == Some(&'*') => {
                    i += 1;
                    Tok::Pow
                }
                '*' => Tok::Star,
                '/' => Tok::Slash,
                '^' => Tok::Pow,
                '(' => Tok::LParen,
                ')' => Tok::RParen,
                ',' => Tok::Comma,
                _ => {
                    return Err(NetlistError::syntax(
                        span.pos_at(start),
                        c.to_string(),
                        format!("unexpected character `{c}` in expression `{}`", span.text),
                    ));
                }
            }
        };
        toks.push((tok, start));
    }
    Ok(toks)
}

/// Deepest nesting of parentheses and unary operators accepted in one expression.
const MAX_DEPTH: usize = 100;

struct Parser<'a> {
    span: &'a Spanned,
    toks: Vec<(Tok, usize)>,
    k: usize,
    depth: usize,
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

    fn expr(&mut self) -> Result<Expr, NetlistError> {
        let mut lhs = self.term()?;
        loop {
            let op = match self.peek() {
                Some(Tok::Plus) => BinOp::Add,
                Some(Tok::Minus) => BinOp::Sub,
                _ => return Ok(lhs),
            };
            self.k += 1;
            let rhs = self.term()?;
            lhs = Expr::Bin(op, Box::new(lhs), Box::new(rhs));
        }
    }

    fn term(&mut self) -> Result<Expr, NetlistError> {
        let mut lhs = self.unary()?;
        loop {
            let op = match self.peek() {
                Some(Tok::Star) => BinOp::Mul,
                Some(Tok::Slash) => BinOp::Div,
                _ => return Ok(lhs),
            };
            self.k += 1;
            let rhs = self.unary()?;
            lhs = Expr::Bin(op, Box::new(lhs), Box::new(rhs));
        }
    }

    fn unary(&mut self) -> Result<Expr, NetlistError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(NetlistError::syntax(
                self.pos(),
                self.span.text.clone(),
                format!("expression nested more than {MAX_DEPTH} levels deep"),
            ));
        }
        let e = self.unary_inner();
        self.depth -= 1;
        e
    }

    fn unary_inner(&mut self) -> Result<Expr, NetlistError> {
        match self.peek() {
            Some(Tok::Minus) => {
                self.k += 1;
                Ok(Expr::Neg(Box::new(self.unary()?)))
            }
            Some(Tok::Plus) => {
                self.k += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Expr, NetlistError> {
        let base = self.primary()?;
        if self.peek() == Some(&Tok::Pow) {
            self.k += 1;
            let exponent = self.unary()?;
            return Ok(Expr::Bin(BinOp::Pow, Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn expect(&mut self, tok: Tok, wanted: &str) -> Result<(), NetlistError> {
        if self.peek() == Some(&tok) {
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
            Some(Tok::LParen) => {
                self.k += 1;
                let e = self.expr()?;
                self.expect(Tok::RParen, "`)`")?;
                Ok(e)
            }
            Some(Tok::Ident(name)) => {
                self.k += 1;
                if self.peek() != Some(&Tok::LParen) {
                    return Ok(Expr::Param(name, pos));
                }
                self.k += 1;
                let mut args = vec![self.expr()?];
                while self.peek() == Some(&Tok::Comma) {
                    self.k += 1;
                    args.push(self.expr()?);
                }
                self.expect(Tok::RParen, "`)` or `,`")?;
                call(&name, args, pos, self.span)
            }
            _ => Err(self.unexpected("a number, a name or `(`")),
        }
    }
}

fn call(name: &str, mut args: Vec<Expr>, pos: Pos, span: &Spanned) -> Result<Expr, NetlistError> {
    let f1 = match name {
        "sqrt" => Some(Func1::Sqrt),
        "exp" => Some(Func1::Exp),
        "log" | "ln" => Some(Func1::Ln),
        "log10" => Some(Func1::Log10),
        "sin" => Some(Func1::Sin),
        "cos" => Some(Func1::Cos),
        "tan" => Some(Func1::Tan),
        "atan" => Some(Func1::Atan),
        "abs" => Some(Func1::Abs),
        _ => None,
    };
    let f2 = match name {
        "min" => Some(Func2::Min),
        "max" => Some(Func2::Max),
        "pow" => Some(Func2::Pow),
        _ => None,
    };
    let wrong_count = |n: usize| {
        NetlistError::syntax(
            pos,
            name,
            format!(
                "function `{name}` takes {n} argument{}, got {} in expression `{}`",
                if n == 1 { "" } else { "s" },
                args.len(),
                span.text
            ),
        )
    };
    if let Some(f) = f1 {
        if args.len() != 1 {
            return Err(wrong_count(1));
        }
        let a = args.remove(0);
        return Ok(Expr::Call1(f, Box::new(a)));
    }
    if let Some(f) = f2 {
        if args.len() != 2 {
            return Err(wrong_count(2));
        }
        let b = args.remove(1);
        let a = args.remove(0);
        return Ok(Expr::Call2(f, Box::new(a), Box::new(b)));
    }
    Err(NetlistError::new(
        ErrorKind::UnknownFunction,
        pos,
        name,
        format!("unknown function `{name}` in expression `{}`", span.text),
    ))
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
    let e = p.expr()?;
    if p.k < p.toks.len() {
        return Err(p.unexpected("an operator or the end of the expression"));
    }
    Ok(e)
}

/// Evaluates `expr`, resolving parameter names with `lookup` (given the lowercased name and its
/// position).
pub(crate) fn eval(
    expr: &Expr,
    lookup: &dyn Fn(&str, Pos) -> Result<f64, NetlistError>,
) -> Result<f64, NetlistError> {
    Ok(match expr {
        Expr::Num(v) => *v,
        Expr::Param(name, pos) => lookup(name, *pos)?,
        Expr::Neg(a) => -eval(a, lookup)?,
        Expr::Bin(op, a, b) => {
            let a = eval(a, lookup)?;
            let b = eval(b, lookup)?;
            match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                BinOp::Pow => a.powf(b),
            }
        }
        Expr::Call1(f, a) => {
            let a = eval(a, lookup)?;
            match f {
                Func1::Sqrt => a.sqrt(),
                Func1::Exp => a.exp(),
                Func1::Ln => a.ln(),
                Func1::Log10 => a.log10(),
                Func1::Sin => a.sin(),
                Func1::Cos => a.cos(),
                Func1::Tan => a.tan(),
                Func1::Atan => a.atan(),
                Func1::Abs => a.abs(),
            }
        }
        Expr::Call2(f, a, b) => {
            let a = eval(a, lookup)?;
            let b = eval(b, lookup)?;
            match f {
                Func2::Min => a.min(b),
                Func2::Max => a.max(b),
                Func2::Pow => a.powf(b),
            }
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

    fn value(text: &str) -> f64 {
        let e = parse(&span(text)).expect("parses");
        eval(&e, &|name, pos| match name {
            "a" => Ok(2.0),
            "b" => Ok(3.0),
            _ => Err(NetlistError::new(
                ErrorKind::UnknownParam,
                pos,
                name,
                "unknown",
            )),
        })
        .expect("evaluates")
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(value("1+2*3"), 7.0);
        assert_eq!(value("(1+2)*3"), 9.0);
        assert_eq!(value("10-4-3"), 3.0);
        assert_eq!(value("24/4/3"), 2.0);
        assert_eq!(value("2^3^2"), 512.0);
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
        let err = parse(&span("2*foo(1)")).expect_err("bad");
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
