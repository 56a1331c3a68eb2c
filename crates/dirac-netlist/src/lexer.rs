//! Physical lines to logical cards, and a character cursor over one card.
//!
//! - The first line is the title and is not parsed.
//! - `;`, `//`, and `$` at the start of a line or after a blank start a comment that runs to the
//!   end of the line (ngspice reads all three; `$` is HSPICE's); a line whose first non-blank
//!   character is `*` is a comment line; blank lines are skipped.
//! - A line whose first non-blank character is `+` continues the previous card (comment and blank
//!   lines in between are allowed).
//! - `.control` ... `.endc` blocks are skipped with a warning; `.end` stops reading.
//!
//! Every character of a card keeps its original line and column, so errors point into the source
//! even across continuation lines.

use super::error::{ErrorKind, NetlistError, Pos, Warning};

/// Characters that end a word (node name, element name, keyword).
fn is_word_delimiter(c: char) -> bool {
    c.is_whitespace() || matches!(c, ',' | '=' | '(' | ')' | '{' | '}' | '\'')
}

/// A run of characters with their source positions.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Spanned {
    pub text: String,
    pub positions: Vec<Pos>,
    /// The position just after the last character (or of the construct, if empty).
    pub end: Pos,
}

impl Spanned {
    /// Position of the first character (or `end` if empty).
    pub fn start(&self) -> Pos {
        self.positions.first().copied().unwrap_or(self.end)
    }

    /// Position of the `i`-th character, or `end` past the last one.
    pub fn pos_at(&self, i: usize) -> Pos {
        self.positions.get(i).copied().unwrap_or(self.end)
    }

    /// The text, lowercased.
    pub fn lower(&self) -> String {
        self.text.to_lowercase()
    }
}

/// One card: a logical line after comment removal and continuation joining.
#[derive(Debug, Clone)]
pub(crate) struct Card {
    pub chars: Vec<char>,
    pub positions: Vec<Pos>,
}

impl Card {
    /// Position of the first character.
    pub fn start(&self) -> Pos {
        self.positions.first().copied().unwrap_or(Pos::new(1, 1))
    }

    /// Position of character `i`, or just past the last one.
    pub fn pos_at(&self, i: usize) -> Pos {
        match self.positions.get(i) {
            Some(p) => *p,
            None => match self.positions.last() {
                Some(p) => Pos::new(p.line, p.column + 1),
                None => Pos::new(1, 1),
            },
        }
    }

    /// The card's text (continuations joined by a space).
    pub fn text(&self) -> String {
        self.chars.iter().collect::<String>().trim().to_owned()
    }

    /// The first word, lowercased.
    pub fn first_word(&self) -> String {
        self.chars
            .iter()
            .take_while(|c| !c.is_whitespace())
            .collect::<String>()
            .to_lowercase()
    }
}

/// The result of splitting a source into cards.
#[derive(Debug)]
pub(crate) struct Lexed {
    pub title: String,
    pub cards: Vec<Card>,
    pub warnings: Vec<Warning>,
    /// The netlist's name, then each included file's path, as positions number them.
    pub files: Vec<String>,
}

/// Deepest nesting of `.include` and `.lib` files.
const MAX_INCLUDE_DEPTH: usize = 20;

/// Largest file an `.include` or `.lib` reads (a model library is far smaller).
const MAX_INCLUDE_BYTES: u64 = 64 << 20;

/// First word of a line, lowercased.
fn first_word_of(line: &str) -> String {
    line.split_whitespace().next().unwrap_or("").to_lowercase()
}

/// Splits `source` (the netlist `name`) into the title and cards, reading the files its
/// `.include FILE` and `.lib FILE SECTION` cards name (relative to the directory of the file that
/// names them) in their place, as ngspice does.
pub(crate) fn lex(source: &str, name: &str) -> Result<Lexed, NetlistError> {
    let source = source.strip_prefix('\u{feff}').unwrap_or(source);
    let mut lines = source
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l));
    let title = lines.next().unwrap_or("").trim().to_owned();
    let mut out = Lexed {
        title,
        cards: Vec::new(),
        warnings: Vec::new(),
        files: vec![name.to_owned()],
    };
    let numbered: Vec<(usize, &str)> = lines.enumerate().map(|(i, l)| (i + 2, l)).collect();
    let mut stack = vec![std::path::PathBuf::from(name)];
    read_lines(&numbered, 0, &mut stack, &mut out).map_err(|e| e.in_files(&out.files))?;
    Ok(out)
}

/// Appends the cards of `lines` (numbered as in file `file`) to `out`, following includes;
/// `stack` holds the paths being read, innermost last.
fn read_lines(
    lines: &[(usize, &str)],
    file: usize,
    stack: &mut Vec<std::path::PathBuf>,
    out: &mut Lexed,
) -> Result<(), NetlistError> {
    let mut control: Option<Pos> = None;
    // Inside a `.lib NAME` … `.endl` section definition (read only through `.lib FILE NAME`).
    let mut section: Option<Pos> = None;
    for &(line_no, raw) in lines {
        let at = |column: usize| Pos::in_source(file, line_no, column);
        let line = &raw[..inline_comment(raw)];
        let trimmed = line.trim_start();
        let word = first_word_of(trimmed);
        if control.is_some() {
            if word == ".endc" {
                control = None;
            }
            continue;
        }
        if section.is_some() {
            if word == ".endl" {
                section = None;
            }
            continue;
        }
        if trimmed.is_empty() || trimmed.starts_with('*') {
            continue;
        }
        let lead = line.chars().count() - trimmed.chars().count();
        if let Some(rest) = trimmed.strip_prefix('+') {
            let plus = at(lead + 1);
            let Some(card) = out.cards.last_mut() else {
                return Err(NetlistError::syntax(
                    plus,
                    "+",
                    "continuation line `+` without a card to continue",
                ));
            };
            card.chars.push(' ');
            card.positions.push(plus);
            for (k, c) in rest.chars().enumerate() {
                card.chars.push(c);
                card.positions.push(at(lead + 2 + k));
            }
            continue;
        }
        let start = at(lead + 1);
        match word.as_str() {
            ".end" => break,
            ".control" => {
                out.warnings.push(Warning::new(
                    start,
                    ".control",
                    "`.control` ... `.endc` block ignored",
                ));
                control = Some(start);
                continue;
            }
            ".include" | ".inc" | ".lib" => {
                let words: Vec<&str> = trimmed.split_whitespace().skip(1).collect();
                match (word.as_str(), words.as_slice()) {
                    (".lib", [_section]) => section = Some(start),
                    (".lib", [path, name]) => {
                        include(path, Some(name), start, stack, out)?;
                    }
                    (".include" | ".inc", [path]) => include(path, None, start, stack, out)?,
                    _ => {
                        return Err(NetlistError::syntax(
                            start,
                            trimmed.trim_end(),
                            format!(
                                "expected `{word} {}` in `{}`",
                                if word == ".lib" {
                                    "FILE SECTION"
                                } else {
                                    "FILE"
                                },
                                trimmed.trim_end()
                            ),
                        ));
                    }
                }
                continue;
            }
            _ => {}
        }
        let mut card = Card {
            chars: Vec::new(),
            positions: Vec::new(),
        };
        for (k, c) in trimmed.trim_end().chars().enumerate() {
            card.chars.push(c);
            card.positions.push(at(lead + 1 + k));
        }
        out.cards.push(card);
    }
    if let Some(start) = control {
        return Err(NetlistError::new(
            ErrorKind::Syntax,
            start,
            ".control",
            "`.control` block without `.endc`",
        ));
    }
    if let Some(start) = section {
        return Err(NetlistError::new(
            ErrorKind::Syntax,
            start,
            ".lib",
            "`.lib` section without `.endl`",
        ));
    }
    Ok(())
}

/// Reads the file `path` named at `at` (quotes removed; relative to the directory of the file
/// being read, the last of `stack`) and appends its cards, or, with `section`, those between its
/// `.lib SECTION` and the next `.endl`.
fn include(
    path: &str,
    section: Option<&str>,
    at: Pos,
    stack: &mut Vec<std::path::PathBuf>,
    out: &mut Lexed,
) -> Result<(), NetlistError> {
    let fail = |message: String| NetlistError::new(ErrorKind::Include, at, path, message);
    let unquoted = path.trim_matches(|c| c == '"' || c == '\'');
    let base = stack
        .last()
        .and_then(|p| p.parent())
        .map(std::path::Path::to_path_buf)
        .unwrap_or_default();
    let resolved = base.join(unquoted);
    if stack.len() > MAX_INCLUDE_DEPTH {
        return Err(fail(format!(
            "`{unquoted}`: includes nested more than {MAX_INCLUDE_DEPTH} deep"
        )));
    }
    let canonical = resolved.canonicalize().unwrap_or_else(|_| resolved.clone());
    if section.is_none()
        && stack
            .iter()
            .any(|p| p.canonicalize().unwrap_or_else(|_| p.clone()) == canonical)
    {
        return Err(fail(format!("`{unquoted}` includes itself")));
    }
    // A regular file of reasonable size only (not a device or pipe that never ends).
    let metadata = std::fs::metadata(&resolved)
        .map_err(|e| fail(format!("cannot read `{}`: {e}", resolved.display())))?;
    if !metadata.is_file() || metadata.len() > MAX_INCLUDE_BYTES {
        return Err(fail(format!(
            "`{}` is not a regular file of at most {MAX_INCLUDE_BYTES} bytes",
            resolved.display()
        )));
    }
    let text = std::fs::read_to_string(&resolved)
        .map_err(|e| fail(format!("cannot read `{}`: {e}", resolved.display())))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let numbered: Vec<(usize, &str)> = text
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .collect();
    let lines: Vec<(usize, &str)> = match section {
        None => numbered,
        Some(name) => {
            let opens = |l: &str| {
                let mut words = l.split_whitespace();
                words.next().is_some_and(|w| w.eq_ignore_ascii_case(".lib"))
                    && words.next().is_some_and(|w| w.eq_ignore_ascii_case(name))
                    && words.next().is_none()
            };
            let Some(first) = numbered.iter().position(|(_, l)| opens(l)) else {
                return Err(fail(format!(
                    "`{}` has no `.lib {name}` section",
                    resolved.display()
                )));
            };
            numbered[first + 1..]
                .iter()
                .take_while(|(_, l)| first_word_of(l.trim_start()) != ".endl")
                .copied()
                .collect()
        }
    };
    out.files.push(resolved.display().to_string());
    let index = out.files.len() - 1;
    stack.push(resolved);
    let read = read_lines(&lines, index, stack, out);
    stack.pop();
    read
}

/// A cursor over one card's characters.
pub(crate) struct Cursor<'a> {
    card: &'a Card,
    i: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(card: &'a Card) -> Self {
        Self { card, i: 0 }
    }

    /// Skips whitespace and commas (commas separate values like blanks do).
    pub fn skip_ws(&mut self) {
        while let Some(&c) = self.card.chars.get(self.i) {
            if c.is_whitespace() || c == ',' {
                self.i += 1;
            } else {
                break;
            }
        }
    }

    /// True if only whitespace is left.
    pub fn at_end(&mut self) -> bool {
        self.skip_ws();
        self.i >= self.card.chars.len()
    }

    /// The next non-blank character, without consuming it.
    pub fn peek(&mut self) -> Option<char> {
        self.skip_ws();
        self.card.chars.get(self.i).copied()
    }

    /// The next character, without skipping anything.
    fn peek_raw(&self) -> Option<char> {
        self.card.chars.get(self.i).copied()
    }

    /// The position of the next non-blank character (or just past the end).
    pub fn pos(&mut self) -> Pos {
        self.skip_ws();
        self.card.pos_at(self.i)
    }

    /// Consumes `c` if it is the next non-blank character.
    pub fn eat(&mut self, c: char) -> bool {
        if self.peek() == Some(c) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn span(&self, from: usize, to: usize) -> Spanned {
        Spanned {
            text: self.card.chars[from..to].iter().collect(),
            positions: self.card.positions[from..to].to_vec(),
            end: self.card.pos_at(to),
        }
    }

    /// Reads a word (up to whitespace, `,`, `=`, parentheses, braces or a quote). `None` at the end
    /// of the card or if the next character is a delimiter.
    pub fn word(&mut self) -> Option<Spanned> {
        self.skip_ws();
        let from = self.i;
        while let Some(c) = self.peek_raw() {
            if is_word_delimiter(c) {
                break;
            }
            self.i += 1;
        }
        (self.i > from).then(|| self.span(from, self.i))
    }

    /// The next word, lowercased, without consuming it.
    pub fn peek_word(&mut self) -> Option<String> {
        let save = self.i;
        let w = self.word().map(|w| w.lower());
        self.i = save;
        w
    }

    /// Consumes `keyword=` (a word equal to `keyword`, lowercased, then `=`), or nothing.
    pub fn eat_assignment_of(&mut self, keyword: &str) -> bool {
        let save = self.i;
        if self.eat_keyword(keyword) && self.eat('=') {
            return true;
        }
        self.i = save;
        false
    }

    /// The next word (lowercased) and the next non-blank character after it, without consuming
    /// either.
    pub fn peek_word_and_next(&mut self) -> Option<(String, Option<char>)> {
        let save = self.i;
        let word = self.word().map(|w| w.lower());
        let next = self.peek();
        self.i = save;
        word.map(|w| (w, next))
    }

    /// Consumes a word if its lowercased text equals `keyword`.
    pub fn eat_keyword(&mut self, keyword: &str) -> bool {
        let save = self.i;
        match self.word() {
            Some(w) if w.lower() == keyword => true,
            _ => {
                self.i = save;
                false
            }
        }
    }

    /// The rest of the card from the next non-blank character.
    pub fn rest(&mut self) -> Spanned {
        self.skip_ws();
        let mut to = self.card.chars.len();
        while to > self.i && self.card.chars[to - 1].is_whitespace() {
            to -= 1;
        }
        self.span(self.i, to)
    }

    /// Reads `{...}` or `'...'` (the cursor is on the opening character); returns the inside.
    fn delimited(&mut self, open: char, close: char) -> Result<Spanned, NetlistError> {
        let open_pos = self.card.pos_at(self.i);
        self.i += 1;
        let from = self.i;
        while let Some(c) = self.peek_raw() {
            if c == close {
                let inside = self.span(from, self.i);
                self.i += 1;
                return Ok(inside);
            }
            self.i += 1;
        }
        Err(NetlistError::syntax(
            open_pos,
            open.to_string(),
            format!("unterminated `{open}`: missing `{close}`"),
        ))
    }

    /// Reads one value: `{expr}`, `'expr'` or a bare expression without blanks (parentheses may
    /// nest; it ends at a blank, `,`, `=` or an unmatched `)` or `}`). `None` if there is none.
    pub fn value(&mut self) -> Result<Option<Spanned>, NetlistError> {
        self.skip_ws();
        match self.peek_raw() {
            None => return Ok(None),
            Some('{') => return self.delimited('{', '}').map(Some),
            Some('\'') => return self.delimited('\'', '\'').map(Some),
            Some(_) => {}
        }
        let from = self.i;
        let mut depth = 0usize;
        while let Some(c) = self.peek_raw() {
            if c.is_whitespace() || (depth == 0 && matches!(c, ',' | '=' | '{' | '}' | '\'')) {
                break;
            }
            if c == '(' {
                depth += 1;
            } else if c == ')' {
                if depth == 0 {
                    break;
                }
                depth -= 1;
            }
            self.i += 1;
        }
        Ok((self.i > from).then(|| self.span(from, self.i)))
    }

    /// Reads a behavioural expression: `{expr}`, `'expr'`, or the rest of the card (blanks
    /// allowed). `None` if nothing is left.
    pub fn expression(&mut self) -> Result<Option<Spanned>, NetlistError> {
        self.skip_ws();
        match self.peek_raw() {
            None => Ok(None),
            Some('{') => self.delimited('{', '}').map(Some),
            Some('\'') => self.delimited('\'', '\'').map(Some),
            Some(_) => {
                let rest = self.rest();
                self.i = self.card.chars.len();
                Ok(Some(rest))
            }
        }
    }

    /// Whether a `name =` (not `==`) or `params:` starts at character `k` (after blanks/commas).
    fn assignment_ahead(&self, mut k: usize) -> bool {
        let chars = &self.card.chars;
        while k < chars.len() && (chars[k].is_whitespace() || chars[k] == ',') {
            k += 1;
        }
        let from = k;
        while k < chars.len() && !is_word_delimiter(chars[k]) {
            k += 1;
        }
        if k == from {
            return false;
        }
        let word: String = chars[from..k].iter().collect::<String>().to_lowercase();
        if word == "params:" {
            return true;
        }
        while k < chars.len() && chars[k].is_whitespace() {
            k += 1;
        }
        // A device's `off` flag after its last assignment (`M1 … W=10u off`) ends the value too:
        // no expression has two operands side by side.
        if word == "off" && (k == chars.len() || self.assignment_ahead(k)) {
            return true;
        }
        chars.get(k) == Some(&'=') && chars.get(k + 1) != Some(&'=')
    }

    /// Reads the value of a `name=value` assignment (`.param`, `.subckt` and `X` parameters,
    /// `.model` parameters): `{expr}`, `'expr'`, or a bare expression that may contain blanks and
    /// runs to the end of the card, to the next `name=` (or a device's `off` flag), or to an
    /// unmatched `)`.
    pub fn assigned_value(&mut self) -> Result<Option<Spanned>, NetlistError> {
        self.skip_ws();
        match self.peek_raw() {
            None => return Ok(None),
            Some('{') => return self.delimited('{', '}').map(Some),
            Some('\'') => return self.delimited('\'', '\'').map(Some),
            Some(_) => {}
        }
        let from = self.i;
        let mut depth = 0usize;
        while let Some(c) = self.peek_raw() {
            if depth == 0 {
                if matches!(c, ',' | '{' | '}' | '\'' | ')') {
                    break;
                }
                if c == '=' && self.card.chars.get(self.i + 1) != Some(&'=') {
                    break;
                }
                if c.is_whitespace() && self.assignment_ahead(self.i) {
                    break;
                }
            }
            if c == '(' {
                depth += 1;
            } else if c == ')' {
                depth = depth.saturating_sub(1);
            }
            self.i += 1;
        }
        let mut to = self.i;
        while to > from && self.card.chars[to - 1].is_whitespace() {
            to -= 1;
        }
        Ok((to > from).then(|| self.span(from, to)))
    }
}

/// Where the line's inline comment starts (its length when it has none): at the first `;`, `//`,
/// or `$` that opens the line or follows a blank (ngspice's end-of-line comments; a `$` inside a
/// word is not one).
fn inline_comment(line: &str) -> usize {
    let bytes = line.as_bytes();
    (0..bytes.len())
        .find(|&k| match bytes[k] {
            b';' => true,
            b'/' => bytes.get(k + 1) == Some(&b'/'),
            b'$' => k == 0 || bytes[k - 1] == b' ' || bytes[k - 1] == b'\t',
            _ => false,
        })
        .unwrap_or(bytes.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn end_of_line_comments_in_three_styles() {
        let src = "t\nR1 a b 1k $ hspice\nR2 b c 2k // c++\nR3 c 0 3k ; spice\nV$1 a 0 1\n";
        let lexed = lex(src, "t.cir").expect("lexes");
        let texts: Vec<String> = lexed
            .cards
            .iter()
            .map(|c| c.text().trim().to_string())
            .collect();
        assert_eq!(texts, ["R1 a b 1k", "R2 b c 2k", "R3 c 0 3k", "V$1 a 0 1"]);
    }

    #[test]
    fn continuation_comments_and_positions() {
        let src = "title\n* comment\nR1 a b ; trailing\n\n  + 1k\nC1 a 0 1u\n.end\nM1 junk";
        let lexed = lex(src, "t.cir").expect("lexes");
        assert_eq!(lexed.title, "title");
        assert_eq!(lexed.cards.len(), 2);
        assert_eq!(lexed.cards[0].text(), "R1 a b  1k");
        let mut cur = Cursor::new(&lexed.cards[0]);
        for _ in 0..3 {
            cur.word();
        }
        let v = cur.value().expect("ok").expect("value");
        assert_eq!(v.text, "1k");
        assert_eq!(v.start(), Pos::new(5, 5));
    }

    #[test]
    fn assigned_values_stop_at_next_name() {
        let card = lex("t\n.param a = 2 * b c=3 d={x y}", "t.cir")
            .expect("lexes")
            .cards
            .remove(0);
        let mut cur = Cursor::new(&card);
        cur.word();
        let mut got = Vec::new();
        while let Some(name) = cur.word() {
            assert!(cur.eat('='));
            let v = cur.assigned_value().expect("ok").expect("value");
            got.push((name.text, v.text));
        }
        assert_eq!(
            got,
            vec![
                ("a".into(), "2 * b".into()),
                ("c".into(), "3".into()),
                ("d".into(), "x y".into())
            ]
        );
    }
}
