//! CSV tables of trajectories: written while a run streams, read back for plots and comparisons.

use std::io::Write;

use dirac_sim::Sink;
use thiserror::Error;

/// A time `t` printed with 15 significant digits, then in the shortest form that reads back to
/// that value: `t₀ + k·h` without the last-bit noise of the product (`3 × 0.05` prints `0.15`).
#[must_use]
pub fn format_time(t: f64) -> String {
    let rounded: f64 = format!("{t:.14e}").parse().unwrap_or(t);
    format!("{rounded}")
}

/// A value in the shortest form that reads back to the same `f64`: positional notation for
/// magnitudes in `[1e-5, 1e16)` and zero, scientific notation otherwise (`1.5e-32`, not 31 zeros).
#[must_use]
pub fn format_value(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-5..1e16).contains(&a) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A [`Sink`] that writes CSV: the header `t,<names>` once, then one line per row.
#[derive(Debug)]
pub struct CsvSink<W: Write> {
    writer: csv::Writer<W>,
    record: Vec<String>,
    closed: bool,
}

impl<W: Write> CsvSink<W> {
    /// A sink writing to `out`.
    pub fn new(out: W) -> Self {
        Self {
            writer: csv::WriterBuilder::new().from_writer(out),
            record: Vec::new(),
            closed: false,
        }
    }

    /// Whether the reader went away (a broken pipe: `dirac run … | head`); the run stops then, and a
    /// command-line tool ends quietly.
    #[must_use]
    pub fn reader_closed(&self) -> bool {
        self.closed
    }

    fn error(&mut self, e: &csv::Error) -> String {
        if let csv::ErrorKind::Io(io) = e.kind()
            && io.kind() == std::io::ErrorKind::BrokenPipe
        {
            self.closed = true;
        }
        e.to_string()
    }

    /// Flushes and returns the underlying writer.
    ///
    /// # Errors
    /// When the final flush fails (a broken pipe has kind [`std::io::ErrorKind::BrokenPipe`]).
    pub fn finish(self) -> Result<W, std::io::Error> {
        self.writer
            .into_inner()
            .map_err(csv::IntoInnerError::into_error)
    }
}

impl<W: Write> Sink for CsvSink<W> {
    fn begin(&mut self, names: &[String]) -> Result<(), String> {
        let result = self
            .writer
            .write_record(std::iter::once("t").chain(names.iter().map(String::as_str)));
        result.map_err(|e| self.error(&e))
    }

    fn row(&mut self, _k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        self.record.clear();
        self.record.push(format_time(t));
        self.record.extend(values.iter().map(|v| format_value(*v)));
        let result = self.writer.write_record(&self.record);
        result.map_err(|e| self.error(&e))
    }
}

/// A CSV file that cannot be read as a table of numbers.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct TableError {
    /// The file name given.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column (field number).
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

/// A table of numbers with named columns, read from CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names, in order.
    pub names: Vec<String>,
    /// Rows, each with one value per column.
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// Reads CSV text with a header line; every other field must be a number.
    ///
    /// # Errors
    /// A [`TableError`] naming the line and field of the first problem.
    pub fn read(text: &str, file: &str) -> Result<Self, TableError> {
        let error = |line: usize, column: usize, message: String| TableError {
            file: file.to_string(),
            line,
            column,
            message,
        };
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(true)
            .from_reader(text.as_bytes());
        let names: Vec<String> = reader
            .headers()
            .map_err(|e| error(1, 1, e.to_string()))?
            .iter()
            .map(str::to_string)
            .collect();
        if names.is_empty() || names.iter().all(String::is_empty) {
            return Err(error(1, 1, "empty file: no header".into()));
        }
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line() as usize);
                error(line, 1, e.to_string())
            })?;
            let line = record
                .position()
                .map_or(rows.len() + 2, |p| p.line() as usize);
            if record.len() != names.len() {
                return Err(error(
                    line,
                    1,
                    format!("expected {} fields, found {}", names.len(), record.len()),
                ));
            }
            let mut values = Vec::with_capacity(record.len());
            for (c, field) in record.iter().enumerate() {
                let value: f64 = field
                    .trim()
                    .parse()
                    .map_err(|_| error(line, c + 1, format!("`{field}` is not a number")))?;
                values.push(value);
            }
            rows.push(values);
        }
        Ok(Self { names, rows })
    }

    /// The values of column `c`.
    #[must_use]
    pub fn column(&self, c: usize) -> Vec<f64> {
        self.rows.iter().map(|r| r[c]).collect()
    }

    /// The index of the column named `name` (case-insensitive).
    #[must_use]
    pub fn position(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n.eq_ignore_ascii_case(name))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Times lose the product's last-bit noise; names with commas are quoted and read back; values
    /// read back bit for bit.
    #[test]
    fn csv_round_trip() {
        assert_eq!(format_time(3.0 * 0.05), "0.15");
        assert_eq!(format_time(0.1 + 0.2), "0.3");
        assert_eq!(format_time(1e-9 * 12345.0), "0.000012345");
        assert_eq!(format_time(0.0), "0");
        assert_eq!(
            format_value(-1.4731819210970596e-32),
            "-1.4731819210970596e-32"
        );
        assert_eq!(format_value(0.25), "0.25");
        assert_eq!(format_value(3e20), "3e20");
        let mut sink = CsvSink::new(Vec::new());
        sink.begin(&["v(a,b)".into(), "i(l1)".into()]).unwrap();
        sink.row(0, 0.0, &[1.0 / 3.0, -2.5e-17]).unwrap();
        sink.row(1, 3.0 * 0.05, &[2.0, 1e300]).unwrap();
        let bytes = sink.finish().unwrap();
        let text = String::from_utf8(bytes).unwrap();
        assert!(text.starts_with("t,\"v(a,b)\",i(l1)\n"), "{text}");
        let table = Table::read(&text, "x.csv").unwrap();
        assert_eq!(table.names, ["t", "v(a,b)", "i(l1)"]);
        assert_eq!(table.rows[0], [0.0, 1.0 / 3.0, -2.5e-17]);
        assert_eq!(table.rows[1], [0.15, 2.0, 1e300]);
    }

    /// A field that is not a number is reported at its line and column.
    #[test]
    fn bad_field_is_located() {
        let e = Table::read("t,x\n0,1\n1,abc\n", "f.csv").unwrap_err();
        assert_eq!((e.line, e.column), (3, 2), "{e}");
        assert!(e.to_string().starts_with("f.csv:3:2:"), "{e}");
    }
}
