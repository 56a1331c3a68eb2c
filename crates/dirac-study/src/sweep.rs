//! Parameter sweeps: the points (a Cartesian grid or given points), what each run returns (the
//! reductions of signals or whole trajectories), shards of the points for batch schedulers, and
//! the table they make.
//!
//! Every point is run from the same base model with its parameters set, in its own simulation:
//! its numbers depend on nothing but the model and the point, so they are the same whichever
//! process, machine or shard ran it, and the table's rows come in point order.

use std::fmt;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use dirac_output::{format_time, format_value};
use dirac_sim::Sink;

use crate::{Model, RunSettings, StudyError};

/// One swept parameter and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// `<part>.<parameter>`, e.g. `R1.r`.
    pub name: String,
    /// Its values, in order.
    pub values: Vec<f64>,
}

impl FromStr for Axis {
    type Err = StudyError;

    /// `R1.r=1,2,5` or `C1.c=1e-6:1e-5:10` (see [`parse_values`]).
    fn from_str(spec: &str) -> Result<Self, StudyError> {
        let (name, values) = spec.split_once('=').ok_or_else(|| {
            StudyError::Sweep(format!(
                "`{spec}`: write `<part>.<parameter>=<values>`, e.g. `R1.r=1,2,5` or `C1.c=1e-6:1e-5:10`"
            ))
        })?;
        let name = name.trim();
        if name.is_empty() {
            return Err(StudyError::Sweep(format!("`{spec}`: no parameter name")));
        }
        Ok(Self {
            name: name.to_string(),
            values: parse_values(values)
                .map_err(|e| StudyError::Sweep(format!("`{name}`: {e}")))?,
        })
    }
}

fn number(text: &str) -> Result<f64, StudyError> {
    let text = text.trim();
    let value = text
        .parse::<f64>()
        .ok()
        .or_else(|| dirac_netlist::parse_spice_number(text))
        .ok_or_else(|| StudyError::Sweep(format!("`{text}` is not a number")))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(StudyError::Sweep(format!("`{text}` is not finite")))
    }
}

/// Values written as a list `1,2,5`, a linear range `start:stop:count` (`count` points, both
/// ends included: `start + (stop − start)·i/(count − 1)`, the last exactly `stop`) or a
/// geometric range `start:stop:count:log` (`start·(stop/start)^(i/(count − 1))`, both ends
/// positive). Numbers take SPICE suffixes (`1u`, `10k`).
///
/// # Errors
/// [`StudyError::Sweep`] for text that is none of these.
pub fn parse_values(spec: &str) -> Result<Vec<f64>, StudyError> {
    let spec = spec.trim();
    if spec.contains(':') {
        let fields: Vec<&str> = spec.split(':').collect();
        let log = match fields.get(3).map(|s| s.trim()) {
            None => false,
            Some("log") => true,
            Some(other) => {
                return Err(StudyError::Sweep(format!(
                    "`{spec}`: the fourth field of a range must be `log`, not `{other}`"
                )));
            }
        };
        if !(3..=4).contains(&fields.len()) {
            return Err(StudyError::Sweep(format!(
                "`{spec}`: a range is `start:stop:count` or `start:stop:count:log`"
            )));
        }
        let (a, b) = (number(fields[0])?, number(fields[1])?);
        let count: usize = fields[2].trim().parse().map_err(|_| {
            StudyError::Sweep(format!(
                "`{spec}`: the count `{}` must be a whole number",
                fields[2]
            ))
        })?;
        if count == 0 {
            return Err(StudyError::Sweep(format!(
                "`{spec}`: the count must be at least 1"
            )));
        }
        if log && !(a > 0.0 && b > 0.0) {
            return Err(StudyError::Sweep(format!(
                "`{spec}`: a geometric range needs positive ends"
            )));
        }
        if count == 1 {
            return Ok(vec![a]);
        }
        let last = (count - 1) as f64;
        return Ok((0..count)
            .map(|i| {
                if i + 1 == count {
                    b
                } else if log {
                    a * (b / a).powf(i as f64 / last)
                } else {
                    a + (b - a) * (i as f64 / last)
                }
            })
            .collect());
    }
    let values: Vec<f64> = spec
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(number)
        .collect::<Result<_, _>>()?;
    if values.is_empty() {
        return Err(StudyError::Sweep(format!("`{spec}`: no values")));
    }
    Ok(values)
}

/// The points of a sweep: parameter names and one value per name for each point.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    names: Vec<String>,
    points: Vec<Vec<f64>>,
}

impl Plan {
    /// The Cartesian product of the axes, the first axis varying slowest (as nested loops, or
    /// Python's `itertools.product`).
    ///
    /// # Errors
    /// No axes, an axis without values, or a parameter named twice.
    pub fn grid(axes: &[Axis]) -> Result<Self, StudyError> {
        if axes.is_empty() {
            return Err(StudyError::Sweep(
                "a sweep needs at least one parameter".into(),
            ));
        }
        if let Some(a) = axes.iter().find(|a| a.values.is_empty()) {
            return Err(StudyError::Sweep(format!("`{}` has no values", a.name)));
        }
        let names: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
        check_names(&names)?;
        let mut points: Vec<Vec<f64>> = vec![Vec::new()];
        for axis in axes {
            points = points
                .into_iter()
                .flat_map(|p| {
                    axis.values.iter().map(move |&v| {
                        let mut q = p.clone();
                        q.push(v);
                        q
                    })
                })
                .collect();
        }
        Ok(Self { names, points })
    }

    /// Given points, each with one value per name.
    ///
    /// # Errors
    /// No names, a parameter named twice, a point of the wrong length, a value that is not
    /// finite.
    pub fn given(names: Vec<String>, points: Vec<Vec<f64>>) -> Result<Self, StudyError> {
        if names.is_empty() {
            return Err(StudyError::Sweep(
                "a sweep needs at least one parameter".into(),
            ));
        }
        check_names(&names)?;
        for (i, p) in points.iter().enumerate() {
            if p.len() != names.len() {
                return Err(StudyError::Sweep(format!(
                    "point {i} has {} values for {} parameters",
                    p.len(),
                    names.len()
                )));
            }
            if let Some(v) = p.iter().find(|v| !v.is_finite()) {
                return Err(StudyError::Sweep(format!("point {i}: {v} is not finite")));
            }
        }
        Ok(Self { names, points })
    }

    /// The parameter names.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The points, in order.
    #[must_use]
    pub fn points(&self) -> &[Vec<f64>] {
        &self.points
    }

    /// Number of points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points of shard `index` of `count` (0-based): the contiguous block
    /// `[index·len/count, (index + 1)·len/count)`, so the shards in order are the whole sweep.
    ///
    /// # Errors
    /// `count` zero or `index` not below it.
    pub fn shard(&self, index: usize, count: usize) -> Result<Range<usize>, StudyError> {
        if count == 0 || index >= count {
            return Err(StudyError::Sweep(format!(
                "shard {index}/{count}: write I/N with 0 ≤ I < N"
            )));
        }
        let n = self.points.len();
        Ok(index * n / count..(index + 1) * n / count)
    }
}

fn check_names(names: &[String]) -> Result<(), StudyError> {
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(StudyError::Sweep(format!("parameter `{n}` is given twice")));
        }
        if matches!(n.as_str(), "point" | "t") {
            return Err(StudyError::Sweep(format!(
                "`{n}` names a column of the sweep table, not a parameter"
            )));
        }
    }
    Ok(())
}

/// `I/N`: shard `I` of `N`, 0-based (a Slurm array task `I` of `--array=0-(N-1)`).
///
/// # Errors
/// [`StudyError::Sweep`] for text of another form or `I ≥ N`.
pub fn parse_shard(spec: &str) -> Result<(usize, usize), StudyError> {
    let bad = || {
        StudyError::Sweep(format!(
            "shard `{spec}`: write I/N with 0 ≤ I < N, e.g. 3/10"
        ))
    };
    let (i, n) = spec.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// How a run's signal becomes one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reduction {
    /// The value in the last row (at the end time).
    Final,
    /// The smallest value over the rows.
    Min,
    /// The largest value over the rows.
    Max,
    /// The largest absolute value over the rows.
    Peak,
    /// The mean of the rows (every row weighs the same).
    Mean,
    /// The root mean square of the rows.
    Rms,
}

impl Reduction {
    /// Every reduction.
    pub const ALL: [Self; 6] = [
        Self::Final,
        Self::Min,
        Self::Max,
        Self::Peak,
        Self::Mean,
        Self::Rms,
    ];

    /// `final`, `min`, `max`, `peak`, `mean`, `rms`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Final => "final",
            Self::Min => "min",
            Self::Max => "max",
            Self::Peak => "peak",
            Self::Mean => "mean",
            Self::Rms => "rms",
        }
    }
}

/// One output column of a reduced sweep: a reduction of a signal, written `max(v(2))`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Output {
    /// The reduction.
    pub reduction: Reduction,
    /// The signal's name in the model.
    pub signal: String,
}

impl fmt::Display for Output {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}({})", self.reduction.name(), self.signal)
    }
}

impl FromStr for Output {
    type Err = StudyError;

    /// `max(v(2))`, `final(C1.q)`.
    fn from_str(s: &str) -> Result<Self, StudyError> {
        let s = s.trim();
        let names: Vec<&str> = Reduction::ALL.iter().map(|r| r.name()).collect();
        let bad = || {
            StudyError::Sweep(format!(
                "output `{s}`: write `<reduction>(<signal>)`, e.g. `max(v(2))`, with a reduction among {}",
                names.join(", ")
            ))
        };
        let (head, rest) = s.split_once('(').ok_or_else(bad)?;
        let signal = rest.strip_suffix(')').ok_or_else(bad)?.trim();
        let reduction = Reduction::ALL
            .iter()
            .copied()
            .find(|r| r.name().eq_ignore_ascii_case(head.trim()))
            .ok_or_else(bad)?;
        if signal.is_empty() {
            return Err(bad());
        }
        Ok(Self {
            reduction,
            signal: signal.to_string(),
        })
    }
}

/// What every run of a sweep returns.
#[derive(Debug, Clone, PartialEq)]
pub enum Outputs {
    /// One row per point: the reductions (by default the final value of every recorded signal),
    /// then a netlist's `.meas` results (NaN where a measure could not be taken).
    Reduced(Vec<Output>),
    /// Every row of every run: `t` and the recorded signals, the point's rows in time order.
    Trajectories,
}

/// A sweep ready to run: the base model, the points, the run settings and the outputs.
#[derive(Debug, Clone)]
pub struct Sweep {
    model: Model,
    plan: Plan,
    settings: RunSettings,
    outputs: Outputs,
    signal_names: Vec<String>,
    columns: Vec<usize>,
    /// The names of a netlist's `.meas` cards, columns after the reductions.
    measures: Vec<String>,
}

impl Sweep {
    /// A sweep of `model` over `plan` with `settings`; `outputs` `None` means the final value of
    /// every signal the settings (or the file) record. The first point's model is built to check
    /// the parameter names and signals before anything runs.
    ///
    /// # Errors
    /// A parameter or signal the model does not have, or a value it rejects at the first point.
    pub fn new(
        model: Model,
        plan: Plan,
        settings: RunSettings,
        outputs: Option<Outputs>,
    ) -> Result<Self, StudyError> {
        let recorded: Vec<String> = model
            .signals_for(&settings)?
            .into_iter()
            .map(|s| s.name)
            .collect();
        let outputs = outputs.unwrap_or_else(|| {
            Outputs::Reduced(
                recorded
                    .iter()
                    .map(|s| Output {
                        reduction: Reduction::Final,
                        signal: s.clone(),
                    })
                    .collect(),
            )
        });
        // The signals each run records, and for each output the column it reduces.
        let (signal_names, columns) = match &outputs {
            Outputs::Trajectories => (recorded.clone(), (0..recorded.len()).collect()),
            Outputs::Reduced(list) => {
                let mut names: Vec<String> = Vec::new();
                let mut columns = Vec::new();
                for output in list {
                    let signal = model.signal(&output.signal)?;
                    let c = names
                        .iter()
                        .position(|n| *n == signal.name)
                        .unwrap_or_else(|| {
                            names.push(signal.name.clone());
                            names.len() - 1
                        });
                    columns.push(c);
                }
                (names, columns)
            }
        };
        let mut settings = settings;
        settings.signals = Some(signal_names.clone());
        if let Some(first) = plan.points().first() {
            model.with_parameters(plan.names(), first)?;
        } else {
            for name in plan.names() {
                model.parameter(name)?;
            }
        }
        let measures = match (&outputs, model.circuit()) {
            (Outputs::Reduced(_), Some(circuit)) => {
                circuit.measures.iter().map(|m| m.name.clone()).collect()
            }
            _ => Vec::new(),
        };
        Ok(Self {
            model,
            plan,
            settings,
            outputs,
            signal_names,
            columns,
            measures,
        })
    }

    /// The points.
    #[must_use]
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The base model.
    #[must_use]
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The outputs.
    #[must_use]
    pub fn outputs(&self) -> &Outputs {
        &self.outputs
    }

    /// The table's columns: `point`, the parameters, then the outputs (`max(v(2))`) or `t` and the
    /// signals.
    #[must_use]
    pub fn columns(&self) -> Vec<String> {
        let mut out = vec!["point".to_string()];
        out.extend(self.plan.names().iter().cloned());
        match &self.outputs {
            Outputs::Reduced(list) => {
                out.extend(list.iter().map(Output::to_string));
                out.extend(self.measures.iter().cloned());
            }
            Outputs::Trajectories => {
                out.push("t".to_string());
                out.extend(self.signal_names.iter().cloned());
            }
        }
        out
    }

    /// The steps point `index` would take (`t_end / h` of its run; a parameter may set either,
    /// or a netlist's TMAX), for a front end to refuse a run too long before it starts.
    ///
    /// # Errors
    /// A point that does not exist, or a parameter value the model rejects.
    pub fn point_steps(&self, index: usize) -> Result<u64, StudyError> {
        let (_, model) = self.point_model(index)?;
        Ok(model.plan(&self.settings)?.steps())
    }

    /// Point `index`'s parameter values and the model with them set.
    fn point_model(&self, index: usize) -> Result<(&[f64], Model), StudyError> {
        let point = self.plan.points().get(index).ok_or_else(|| {
            StudyError::Sweep(format!(
                "point {index} does not exist (the sweep has {})",
                self.plan.len()
            ))
        })?;
        Ok((point, self.model.with_parameters(self.plan.names(), point)?))
    }

    /// Runs point `index` and returns its table rows (one for reductions; one per output time for
    /// trajectories), each with the columns of [`Sweep::columns`].
    ///
    /// # Errors
    /// A parameter value the model rejects, or the run failing.
    pub fn run_point(&self, index: usize) -> Result<Vec<Vec<f64>>, StudyError> {
        self.run_point_watched(index, &mut |_| Ok(()))
    }

    /// [`Sweep::run_point`], calling `watch` before every step's row as
    /// [`crate::Prepared::run_into_watched`] does (a front end's interrupt check); an error from it
    /// stops the point.
    ///
    /// # Errors
    /// See [`Sweep::run_point`].
    pub fn run_point_watched(
        &self,
        index: usize,
        watch: &mut dyn FnMut(usize) -> Result<(), String>,
    ) -> Result<Vec<Vec<f64>>, StudyError> {
        let (point, model) = self.point_model(index)?;
        let mut prepared = model.prepare(&self.settings)?;
        let mut head = vec![index as f64];
        head.extend_from_slice(point);
        match &self.outputs {
            Outputs::Trajectories => {
                let mut rows = Vec::with_capacity(prepared.rows());
                let mut sink = |_k: usize, t: f64, values: &[f64]| {
                    let mut row = head.clone();
                    row.push(t);
                    row.extend_from_slice(values);
                    rows.push(row);
                    Ok(())
                };
                prepared.run_into_watched(&mut sink, watch)?;
                Ok(rows)
            }
            Outputs::Reduced(list) => {
                let mut reducer = Reducer::new(self.signal_names.len());
                prepared.run_into_watched(&mut reducer, watch)?;
                let mut row = head;
                row.extend(
                    list.iter()
                        .zip(&self.columns)
                        .map(|(o, &c)| reducer.value(o.reduction, c)),
                );
                row.extend(
                    prepared
                        .measurements()
                        .iter()
                        .map(|m| m.value.clone().unwrap_or(f64::NAN)),
                );
                Ok(vec![row])
            }
        }
    }

    /// The rows a failed point leaves in the table with `keep_going`: its parameters and NaN
    /// outputs (none for trajectories).
    #[must_use]
    pub fn failed_rows(&self, index: usize) -> Vec<Vec<f64>> {
        match &self.outputs {
            Outputs::Trajectories => Vec::new(),
            Outputs::Reduced(list) => {
                let mut row = vec![index as f64];
                row.extend_from_slice(&self.plan.points()[index]);
                row.extend(std::iter::repeat_n(
                    f64::NAN,
                    list.len() + self.measures.len(),
                ));
                vec![row]
            }
        }
    }
}

/// Running reductions of every column of a run.
struct Reducer {
    rows: usize,
    last: Vec<f64>,
    min: Vec<f64>,
    max: Vec<f64>,
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

impl Reducer {
    fn new(width: usize) -> Self {
        Self {
            rows: 0,
            last: vec![f64::NAN; width],
            min: vec![f64::INFINITY; width],
            max: vec![f64::NEG_INFINITY; width],
            sum: vec![0.0; width],
            sum_sq: vec![0.0; width],
        }
    }

    fn value(&self, reduction: Reduction, c: usize) -> f64 {
        if self.rows == 0 {
            return f64::NAN;
        }
        let n = self.rows as f64;
        match reduction {
            Reduction::Final => self.last[c],
            Reduction::Min => self.min[c],
            Reduction::Max => self.max[c],
            Reduction::Peak => self.max[c].abs().max(self.min[c].abs()),
            Reduction::Mean => self.sum[c] / n,
            Reduction::Rms => (self.sum_sq[c] / n).sqrt(),
        }
    }
}

impl Sink for Reducer {
    fn begin(&mut self, _names: &[String]) -> Result<(), String> {
        Ok(())
    }

    fn row(&mut self, _k: usize, _t: f64, values: &[f64]) -> Result<(), String> {
        self.rows += 1;
        for (c, &v) in values.iter().enumerate() {
            self.last[c] = v;
            self.min[c] = self.min[c].min(v);
            self.max[c] = self.max[c].max(v);
            self.sum[c] += v;
            self.sum_sq[c] += v * v;
        }
        Ok(())
    }
}

/// Writes sweep tables as CSV: the header, then rows with the point index as an integer, `t` as
/// `dirac run` prints times and every other value in the shortest form that reads back to the
/// same `f64` (so a merged table and a table written from Python are the same bytes).
#[derive(Debug)]
pub struct TableWriter<W: Write> {
    writer: csv::Writer<W>,
    time_column: Option<usize>,
}

impl<W: Write> TableWriter<W> {
    /// Writes `columns` as the header.
    ///
    /// # Errors
    /// The writer failing.
    pub fn new(out: W, columns: &[String]) -> std::io::Result<Self> {
        let mut writer = csv::WriterBuilder::new().from_writer(out);
        writer
            .write_record(columns)
            .map_err(std::io::Error::other)?;
        Ok(Self {
            writer,
            time_column: columns.iter().position(|c| c == "t"),
        })
    }

    /// Writes one row.
    ///
    /// # Errors
    /// The writer failing.
    pub fn row(&mut self, row: &[f64]) -> std::io::Result<()> {
        let fields: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, &v)| {
                if c == 0 {
                    format!("{}", v as u64)
                } else if Some(c) == self.time_column {
                    format_time(v)
                } else {
                    format_value(v)
                }
            })
            .collect();
        self.writer
            .write_record(&fields)
            .map_err(std::io::Error::other)
    }

    /// Flushes and returns the writer.
    ///
    /// # Errors
    /// The final flush failing.
    pub fn finish(self) -> std::io::Result<W> {
        self.writer.into_inner().map_err(|e| e.into_error())
    }
}

/// The file name of shard `index` of `count`: `shard-<I>-of-<N>.csv`, `I` zero-padded to the
/// width of `N` so that the names sort in shard order.
#[must_use]
pub fn shard_file_name(index: usize, count: usize) -> String {
    let width = count.to_string().len();
    format!("shard-{index:0width$}-of-{count}.csv")
}

/// Joins the shard files in `dir` into one table (as CSV text): checks that every shard of the
/// sweep is there once, that they share the header, and that their points are `0, 1, …` in
/// order.
///
/// # Errors
/// [`StudyError::Merge`] naming the missing, extra or inconsistent shard.
pub fn merge_shards(dir: &Path) -> Result<String, StudyError> {
    let name = dir.display().to_string();
    let fail = |message: String| StudyError::Merge {
        dir: name.clone(),
        message,
    };
    let entries = std::fs::read_dir(dir).map_err(|e| fail(e.to_string()))?;
    let mut shards: Vec<(usize, usize, PathBuf)> = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| fail(e.to_string()))?.path();
        let Some(file) = path.file_name().and_then(|f| f.to_str()) else {
            continue;
        };
        let Some(core) = file
            .strip_prefix("shard-")
            .and_then(|f| f.strip_suffix(".csv"))
        else {
            continue;
        };
        let parsed = core
            .split_once("-of-")
            .and_then(|(i, n)| Some((i.parse().ok()?, n.parse().ok()?)));
        match parsed {
            Some((i, n)) => shards.push((i, n, path)),
            None => return Err(fail(format!("`{file}` is not named shard-<I>-of-<N>.csv"))),
        }
    }
    let Some(&(_, count, _)) = shards.first() else {
        return Err(fail("no shard files (shard-<I>-of-<N>.csv)".into()));
    };
    if let Some((_, n, p)) = shards.iter().find(|(_, n, _)| *n != count) {
        return Err(fail(format!(
            "`{}` belongs to a sweep of {n} shards, others to one of {count}",
            p.display()
        )));
    }
    shards.sort_by_key(|s| s.0);
    for (expected, (i, _, p)) in shards.iter().enumerate() {
        if *i != expected {
            return Err(fail(if *i > expected {
                format!("shard {expected} of {count} is missing")
            } else {
                format!("shard {i} appears twice (`{}`)", p.display())
            }));
        }
    }
    if shards.len() != count {
        return Err(fail(format!(
            "shard {} of {count} is missing",
            shards.len()
        )));
    }
    let mut header: Option<String> = None;
    let mut out = String::new();
    let mut next_point = 0usize;
    for (i, _, path) in &shards {
        let text =
            std::fs::read_to_string(path).map_err(|e| fail(format!("{}: {e}", path.display())))?;
        let mut lines = text.lines();
        let Some(first) = lines.next() else {
            return Err(fail(format!("`{}` is empty", path.display())));
        };
        match &header {
            None => {
                out.push_str(first);
                out.push('\n');
                header = Some(first.to_string());
            }
            Some(h) if h != first => {
                return Err(fail(format!(
                    "shard {i} has the header `{first}`, shard 0 `{h}`: they are not the same sweep"
                )));
            }
            Some(_) => {}
        }
        for (n, line) in lines.enumerate() {
            let point: usize = line
                .split(',')
                .next()
                .and_then(|p| p.parse().ok())
                .ok_or_else(|| {
                    fail(format!(
                        "{}:{}: the first field must be the point index",
                        path.display(),
                        n + 2
                    ))
                })?;
            if point + 1 == next_point {
                // Another row of the same point (trajectories).
            } else if point == next_point {
                next_point += 1;
            } else {
                return Err(fail(format!(
                    "{}:{}: point {point} follows point {} (a shard is missing rows or belongs to another sweep)",
                    path.display(),
                    n + 2,
                    next_point as i64 - 1
                )));
            }
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lists, linear and geometric ranges: both ends exact, the count as asked, SPICE suffixes.
    #[test]
    fn values() {
        assert_eq!(parse_values("1,2,5").unwrap(), [1.0, 2.0, 5.0]);
        let v = parse_values("1e-6:1e-5:10").unwrap();
        assert_eq!(v.len(), 10);
        assert_eq!((v[0], v[9]), (1e-6, 1e-5));
        assert!((v[1] - 2e-6).abs() < 1e-21);
        assert_eq!(
            parse_values("1u:100u:3:log").unwrap()[1],
            1e-6 * 10f64.powf(1.0)
        );
        assert_eq!(parse_values("10k").unwrap(), [1e4]);
        assert!(parse_values("1:2").is_err());
        assert!(parse_values("1:2:0").is_err());
        assert!(parse_values("a,b").is_err());
        assert!(parse_values("0:1:3:log").is_err());
    }

    /// The grid is the product with the first axis slowest; shards tile it in order.
    #[test]
    fn grid_and_shards() {
        let plan = Plan::grid(&[
            "R1.r=1,2".parse().unwrap(),
            "C1.c=10,20,30".parse().unwrap(),
        ])
        .unwrap();
        assert_eq!(
            plan.points(),
            [
                [1.0, 10.0],
                [1.0, 20.0],
                [1.0, 30.0],
                [2.0, 10.0],
                [2.0, 20.0],
                [2.0, 30.0]
            ]
        );
        let tiles: Vec<Range<usize>> = (0..4).map(|i| plan.shard(i, 4).unwrap()).collect();
        assert_eq!(tiles, [0..1, 1..3, 3..4, 4..6]);
        assert_eq!(plan.shard(0, 10).unwrap(), 0..0);
        assert!(plan.shard(4, 4).is_err());
        assert_eq!(parse_shard("3/10").unwrap(), (3, 10));
        assert!(parse_shard("10/10").is_err());
        assert!(Plan::grid(&["R1.r=1".parse().unwrap(), "R1.r=2".parse().unwrap()]).is_err());
        assert_eq!(shard_file_name(3, 12), "shard-03-of-12.csv");
    }

    /// Outputs read back as written; unknown reductions list the known ones.
    #[test]
    fn outputs() {
        let o: Output = "max(v(2))".parse().unwrap();
        assert_eq!(o.reduction, Reduction::Max);
        assert_eq!(o.signal, "v(2)");
        assert_eq!(o.to_string(), "max(v(2))");
        let err = "median(v(2))".parse::<Output>().unwrap_err().to_string();
        assert!(err.contains("final, min, max, peak, mean, rms"), "{err}");
    }

    /// Each reduction of the rows 1, −3, 2: final 2, min −3, max 2, peak 3, mean 0, rms √(14/3).
    #[test]
    fn reductions() {
        let mut r = Reducer::new(1);
        for (k, v) in [1.0, -3.0, 2.0].into_iter().enumerate() {
            r.row(k, k as f64, &[v]).unwrap();
        }
        assert_eq!(r.value(Reduction::Final, 0), 2.0);
        assert_eq!(r.value(Reduction::Min, 0), -3.0);
        assert_eq!(r.value(Reduction::Max, 0), 2.0);
        assert_eq!(r.value(Reduction::Peak, 0), 3.0);
        assert_eq!(r.value(Reduction::Mean, 0), 0.0);
        assert_eq!(r.value(Reduction::Rms, 0), (14.0f64 / 3.0).sqrt());
    }
}
