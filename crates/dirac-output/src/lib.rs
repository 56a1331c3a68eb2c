//! Output of `dirac` runs: CSV tables and line charts.
//!
//! - [`CsvSink`] streams a run's rows as CSV (a [`dirac_sim::Sink`]): header `t,<signal>,…`, names
//!   such as `v(a,b)` quoted, times printed as `t₀ + k·h` without float noise (`0.15`, not
//!   `0.15000000000000002`), values in the shortest form that reads back to the same `f64`.
//! - [`Table::read`] reads such a file back, with `file:line:column` errors.
//! - [`LineChart`] draws series to SVG or PNG with a bundled font (no system fonts needed).
//! - [`animate::svg_frames`] draws a three-dimensional motion as a sequence of projected SVG
//!   frames.

pub mod animate;
mod chart;
mod table;

pub use chart::*;
pub use table::{CsvSink, Table, TableError, format_time, format_value};
