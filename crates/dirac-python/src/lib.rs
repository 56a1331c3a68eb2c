//! `dirac._dirac`: the extension module of the `dirac` Python package (PyO3, abi3).
//!
//! It exposes [`dirac_study`] to Python: a [`Model`] read from a netlist or scene (or from text
//! built in Python) with parameters set by name, run with the GIL released, compared, checked,
//! and a [`Sweep`] whose points any process can run. Trajectories cross into Python as one
//! `bytes` buffer of native-endian `f64` per column (wrapped by `numpy.frombuffer` without a
//! copy on the Python side); the pure-Python layer (`python/dirac`) adds the `Trajectory` class,
//! pickling, executors and pandas.
//!
//! Errors become the Python exceptions of `dirac._errors`: `InputError` (a `ValueError`) with
//! `file`, `line`, `column`, `parameter` where known, and `SimulationError` with `step`, `time`
//! and `residual`.

use std::path::PathBuf;

use dirac_sim::{Probe, RunError, RunSummary, Signal, SimError, Sink, SteadyStateError};
use dirac_solve::NewtonError;
use dirac_study::{
    Measurement, Method, Model, Output, Outputs, Plan, RepresentationChoice, RunSettings,
    SourceKind, StudyError, Sweep, TableWriter, parse_composition, parse_scheme,
};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

/// The name of the energy column a run records when asked for the energy drift.
const ENERGY: &str = "energy";

/// Where an input error points: file, line, column (any of them may be unknown).
#[derive(Default)]
struct Place {
    file: Option<String>,
    line: Option<usize>,
    column: Option<usize>,
}

/// `file:line:column: ` at the start of a message (how every reader prefixes its errors).
fn place_in_message(message: &str) -> Place {
    let mut fields = message.splitn(4, ':');
    let (Some(file), Some(line), Some(column)) = (fields.next(), fields.next(), fields.next())
    else {
        return Place::default();
    };
    match (line.trim().parse(), column.trim().parse()) {
        (Ok(line), Ok(column)) => Place {
            file: Some(file.to_string()),
            line: Some(line),
            column: Some(column),
        },
        _ => Place::default(),
    }
}

fn place(e: &StudyError) -> Place {
    match e {
        StudyError::Netlist(n) => Place {
            file: Some(n.file.clone()),
            line: Some(n.line),
            column: Some(n.column),
        },
        StudyError::Scene(s) => match s.location() {
            Some(at) => Place {
                file: Some(at.file.clone()),
                line: Some(at.line),
                column: Some(at.column),
            },
            None => place_in_message(&s.to_string()),
        },
        StudyError::Io { file, .. } | StudyError::FileType { file } => Place {
            file: Some(file.clone()),
            ..Place::default()
        },
        other => place_in_message(&other.to_string()),
    }
}

/// Step, time and residual of a numerical failure, where the error states them.
fn numerical_fields(e: &RunError) -> (Option<usize>, Option<f64>, Option<f64>) {
    let residual = |n: &NewtonError| match n {
        NewtonError::NotConverged { residual, .. } | NewtonError::Linear { residual, .. } => {
            Some(*residual)
        }
        NewtonError::NonFiniteResidual { .. } => Some(f64::NAN),
    };
    match e {
        RunError::Sim(SimError::Newton {
            step, t, source, ..
        }) => (Some(*step), Some(*t), residual(source)),
        RunError::Sim(SimError::StepRejected { step, t, .. }) => (Some(*step), Some(*t), None),
        RunError::Readout(r) => (r.step, Some(r.t), residual(&r.source)),
        RunError::SteadyState(SteadyStateError::NotConverged { source, .. }) => {
            (None, Some(0.0), residual(source))
        }
        RunError::SteadyState(SteadyStateError::NotIsolated { residual, .. }) => {
            (None, Some(0.0), Some(*residual))
        }
        _ => (None, None, None),
    }
}

/// An operating point as `(signal, value)` pairs, with the set-up's warnings.
type PointAndWarnings = (Vec<(String, f64)>, Vec<String>);

/// The Python exception for `e`: `SimulationError` for a numerical failure, `InputError` else.
fn to_py(e: StudyError) -> PyErr {
    Python::attach(|py| match exception(py, &e) {
        Ok(err) | Err(err) => err,
    })
}

fn exception(py: Python<'_>, e: &StudyError) -> PyResult<PyErr> {
    let errors = py.import("dirac._errors")?;
    let kwargs = PyDict::new(py);
    let class = if let StudyError::Run(run) = e
        && run.is_numerical()
    {
        let (step, time, residual) = numerical_fields(run);
        kwargs.set_item("step", step)?;
        kwargs.set_item("time", time)?;
        kwargs.set_item("residual", residual)?;
        errors.getattr("SimulationError")?
    } else {
        let at = place(e);
        kwargs.set_item("file", at.file)?;
        kwargs.set_item("line", at.line)?;
        kwargs.set_item("column", at.column)?;
        let parameter = match e {
            StudyError::UnknownParameter { name, .. } | StudyError::BadParameter { name, .. } => {
                Some(name.clone())
            }
            _ => None,
        };
        kwargs.set_item("parameter", parameter)?;
        errors.getattr("InputError")?
    };
    Ok(PyErr::from_value(
        class.call((e.to_string(),), Some(&kwargs))?,
    ))
}

fn settings(
    method: Option<&str>,
    representation: Option<&str>,
    scheme: Option<&str>,
    h: Option<f64>,
    t_end: Option<f64>,
    signals: Option<Vec<String>>,
    composition: Option<&str>,
) -> Result<RunSettings, StudyError> {
    Ok(RunSettings {
        representation: representation
            .map(str::parse::<RepresentationChoice>)
            .transpose()?,
        method: method.map(str::parse::<Method>).transpose()?,
        scheme: scheme.map(parse_scheme).transpose()?,
        h,
        t_end,
        signals,
        composition: composition.map(parse_composition).transpose()?,
        ..RunSettings::default()
    })
}

/// A sink keeping every column apart, and the energy column (when recorded) as running extremes.
struct Columns {
    t: Vec<f64>,
    columns: Vec<Vec<f64>>,
    /// Index of the energy column among the recorded ones.
    energy: Option<usize>,
    energy_first: Option<f64>,
    energy_last: f64,
    energy_drift: f64,
}

impl Sink for Columns {
    fn begin(&mut self, names: &[String]) -> Result<(), String> {
        let kept = names.len() - usize::from(self.energy.is_some());
        self.columns = vec![Vec::new(); kept];
        Ok(())
    }

    fn row(&mut self, _k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        self.t.push(t);
        for (column, &v) in self.columns.iter_mut().zip(values) {
            column.push(v);
        }
        if let Some(c) = self.energy {
            let e = values[c];
            let first = *self.energy_first.get_or_insert(e);
            self.energy_last = e;
            self.energy_drift = self.energy_drift.max((e - first).abs());
        }
        Ok(())
    }
}

fn f64_bytes<'py>(py: Python<'py>, values: &[f64]) -> PyResult<Bound<'py, PyBytes>> {
    PyBytes::new_with(py, values.len() * 8, |buffer| {
        for (chunk, v) in buffer.chunks_exact_mut(8).zip(values) {
            chunk.copy_from_slice(&v.to_ne_bytes());
        }
        Ok(())
    })
}

fn summary_dict<'py>(
    py: Python<'py>,
    summary: &RunSummary,
    columns: &Columns,
    measurements: &[Measurement],
    execution: String,
    h: f64,
    t_end: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("steps", summary.steps)?;
    d.set_item("newton_iterations", summary.newton_iterations)?;
    d.set_item("factorisations", summary.factorisations)?;
    d.set_item("readout_iterations", summary.readout_iterations)?;
    d.set_item("breakpoint_substeps", summary.breakpoint_substeps)?;
    d.set_item("step_cuts", summary.step_cuts)?;
    d.set_item("refinements", summary.refinements)?;
    d.set_item("substeps", summary.substeps)?;
    d.set_item("ramp_substeps", summary.ramp_substeps)?;
    d.set_item("turn_checks", summary.turn_checks)?;
    d.set_item("spurious_roots", summary.spurious_roots)?;
    d.set_item("max_constraint_residual", summary.max_constraint_residual)?;
    d.set_item("wall_s", summary.wall_s)?;
    let mut warnings = summary.warnings.clone();
    warnings.extend(measurements.iter().filter_map(Measurement::corner_warning));
    d.set_item("warnings", warnings)?;
    d.set_item("execution", execution)?;
    d.set_item("h", h)?;
    d.set_item("t_end", t_end)?;
    let energy = columns.energy_first.is_some();
    d.set_item("energy_start", columns.energy_first)?;
    d.set_item("energy_end", energy.then_some(columns.energy_last))?;
    d.set_item("energy_drift", energy.then_some(columns.energy_drift))?;
    let measures = PyDict::new(py);
    for m in measurements {
        measures.set_item(&m.name, m.value.as_ref().ok().copied())?;
    }
    d.set_item("measures", measures)?;
    Ok(d)
}

/// A netlist or scene, with parameters set by name (`R1.r`, `C1.c`, `V1.waveform.amplitude`).
#[pyclass(name = "Model", module = "dirac._dirac")]
struct PyModel {
    inner: Model,
}

/// One row of `compare`: execution, largest deviation (if it ran), why not.
type ComparisonRow = (String, Option<f64>, Option<String>);

/// What `Model.run` returns: names, times, columns, summary.
type RunResult<'py> = (
    Vec<String>,
    Bound<'py, PyBytes>,
    Vec<Bound<'py, PyBytes>>,
    Bound<'py, PyDict>,
);

#[pymethods]
impl PyModel {
    /// Reads the netlist (`.cir`, `.sp`, `.net`, `.spice`) or scene (`.toml`) at `path`.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        Ok(Self {
            inner: Model::from_file(path).map_err(to_py)?,
        })
    }

    /// The model of kind `kind` (`"netlist"` or `"scene"`) read from `text` (`name` in
    /// messages) with the parameter changes `overrides` applied in order.
    #[staticmethod]
    #[pyo3(signature = (kind, name, text, overrides = Vec::new()))]
    fn restore(
        kind: &str,
        name: &str,
        text: &str,
        overrides: Vec<(String, f64)>,
    ) -> PyResult<Self> {
        let kind = match kind {
            "netlist" => SourceKind::Netlist,
            "scene" => SourceKind::Scene,
            other => {
                return Err(to_py(StudyError::Settings(format!(
                    "unknown model kind `{other}`; expected `netlist` or `scene`"
                ))));
            }
        };
        Ok(Self {
            inner: Model::restore(kind, name, text, &overrides).map_err(to_py)?,
        })
    }

    /// `"netlist"` or `"scene"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.inner.kind().name()
    }

    /// The name used in messages (the file's path for a file).
    #[getter]
    fn name(&self) -> &str {
        self.inner.name()
    }

    /// The source text as read.
    #[getter]
    fn text(&self) -> &str {
        self.inner.text()
    }

    /// The parameter changes since reading, in order.
    #[getter]
    fn overrides(&self) -> Vec<(String, f64)> {
        self.inner.overrides().to_vec()
    }

    /// Sets parameter `name` to `value`, checked as the reader checks a file.
    fn set_parameter(&mut self, name: &str, value: f64) -> PyResult<()> {
        self.inner.set_parameter(name, value).map_err(to_py)
    }

    /// The current value of parameter `name`.
    fn parameter(&self, name: &str) -> PyResult<f64> {
        self.inner.parameter(name).map_err(to_py)
    }

    /// Every numeric parameter the model states, with its value, in file order.
    fn parameters(&self) -> Vec<(String, f64)> {
        self.inner.parameters()
    }

    /// The file's own signals.
    fn default_signals(&self) -> Vec<String> {
        self.inner
            .default_signals()
            .into_iter()
            .map(|s| s.name)
            .collect()
    }

    /// What the reader noticed (ignored netlist cards, options dirac does differently).
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings()
    }

    /// The scene as TOML with the parameter changes applied (`None` for a netlist).
    fn scene_toml(&self) -> Option<String> {
        self.inner.scene_toml()
    }

    /// Runs the model with the GIL released; returns the signal names, the times and one
    /// column per signal (native `f64` bytes) and the run's summary.
    #[pyo3(signature = (method = None, representation = None, scheme = None, h = None, t_end = None, signals = None, energy = false, start_ramp = None, refine = None, composition = None, force = false))]
    #[allow(clippy::too_many_arguments)]
    fn run<'py>(
        &self,
        py: Python<'py>,
        method: Option<&str>,
        representation: Option<&str>,
        scheme: Option<&str>,
        h: Option<f64>,
        t_end: Option<f64>,
        signals: Option<Vec<String>>,
        energy: bool,
        start_ramp: Option<bool>,
        refine: Option<bool>,
        composition: Option<&str>,
        force: bool,
    ) -> PyResult<RunResult<'py>> {
        let settings = settings(
            method,
            representation,
            scheme,
            h,
            t_end,
            signals,
            composition,
        )
        .map(|s| RunSettings {
            start_ramp,
            truncation: refine,
            force,
            ..s
        })
        .map_err(to_py)?;
        let model = &self.inner;
        let outcome = py.detach(|| -> Result<_, StudyError> {
            let extra = energy.then(|| Signal::new(ENERGY, Probe::Energy));
            let mut prepared = model.prepare_with(&settings, extra)?;
            let names: Vec<String> = prepared.signals().iter().map(|s| s.name.clone()).collect();
            let mut columns = Columns {
                t: Vec::with_capacity(prepared.rows()),
                columns: Vec::new(),
                energy: energy.then(|| names.len() - 1),
                energy_first: None,
                energy_last: f64::NAN,
                energy_drift: 0.0,
            };
            let summary = prepared.run_into(&mut columns)?;
            let kept = names.len() - usize::from(energy);
            Ok((
                names[..kept].to_vec(),
                columns,
                summary,
                prepared.measurements().to_vec(),
                prepared.execution().to_string(),
                prepared.h(),
                prepared.t_end(),
            ))
        });
        let (names, columns, summary, measurements, execution, h, t_end) =
            outcome.map_err(to_py)?;
        let t = f64_bytes(py, &columns.t)?;
        let data = columns
            .columns
            .iter()
            .map(|c| f64_bytes(py, c))
            .collect::<PyResult<Vec<_>>>()?;
        let summary = summary_dict(py, &summary, &columns, &measurements, execution, h, t_end)?;
        Ok((names, t, data, summary))
    }

    /// Runs every representation (and for a scene both staggered splittings) and returns each
    /// one's largest deviation from the monolithic run: `(execution, deviation or None, note)`.
    #[pyo3(signature = (method = None, h = None, t_end = None, signals = None, composition = None))]
    fn compare(
        &self,
        py: Python<'_>,
        method: Option<&str>,
        h: Option<f64>,
        t_end: Option<f64>,
        signals: Option<Vec<String>>,
        composition: Option<&str>,
    ) -> PyResult<Vec<ComparisonRow>> {
        let settings =
            settings(method, None, None, h, t_end, signals, composition).map_err(to_py)?;
        let model = &self.inner;
        let results = py.detach(|| model.compare(&settings)).map_err(to_py)?;
        Ok(results
            .into_iter()
            .map(|c| (c.execution, c.max_abs_deviation, c.note))
            .collect())
    }

    /// What `dirac check` reports, as a dict.
    fn check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let report = self.inner.check().map_err(to_py)?;
        let d = PyDict::new(py);
        d.set_item("parts", report.parts)?;
        d.set_item("connections", report.connections)?;
        let sizes = PyDict::new(py);
        for r in &report.representations {
            let entry = PyDict::new(py);
            entry.set_item("coordinates", r.coordinates)?;
            entry.set_item("constraint_rows", r.constraint_rows)?;
            sizes.set_item(&r.representation, entry)?;
        }
        d.set_item("representations", sizes)?;
        d.set_item("degenerate", report.degenerate)?;
        d.set_item("signals", report.signals)?;
        d.set_item(
            "start",
            match report.start {
                dirac_sim::Start::Given => "given",
                dirac_sim::Start::SteadyState => "steady-state",
            },
        )?;
        d.set_item("tran", report.tran)?;
        Ok(d)
    }

    /// The operating point (steady state with the sources at t = 0): `(signal, value)` pairs
    /// and the set-up's warnings.
    fn operating_point(&self, py: Python<'_>) -> PyResult<PointAndWarnings> {
        let model = &self.inner;
        let point = py.detach(|| model.operating_point()).map_err(to_py)?;
        Ok((point.values, point.warnings))
    }
}

/// A sweep of a model over given points; every point can be run by any process.
#[pyclass(name = "Sweep", module = "dirac._dirac")]
struct PySweep {
    inner: Sweep,
}

#[pymethods]
impl PySweep {
    /// A sweep of `model` over `points` (one value per name each); `outputs` are reductions such
    /// as `"max(v(2))"` (default: the final value of every recorded signal), or with
    /// `trajectories` every row of every run.
    #[new]
    #[pyo3(signature = (model, names, points, method = None, representation = None, h = None, t_end = None, signals = None, outputs = None, trajectories = false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PyModel,
        names: Vec<String>,
        points: Vec<Vec<f64>>,
        method: Option<&str>,
        representation: Option<&str>,
        h: Option<f64>,
        t_end: Option<f64>,
        signals: Option<Vec<String>>,
        outputs: Option<Vec<String>>,
        trajectories: bool,
    ) -> PyResult<Self> {
        let build = || -> Result<Sweep, StudyError> {
            let settings = settings(method, representation, None, h, t_end, signals, None)?;
            let plan = Plan::given(names, points)?;
            let outputs = match (trajectories, outputs) {
                (true, Some(_)) => {
                    return Err(StudyError::Sweep(
                        "give reductions or ask for trajectories, not both".into(),
                    ));
                }
                (true, None) => Some(Outputs::Trajectories),
                (false, Some(list)) => Some(Outputs::Reduced(
                    list.iter()
                        .map(|o| o.parse::<Output>())
                        .collect::<Result<_, _>>()?,
                )),
                (false, None) => None,
            };
            Sweep::new(model.inner.clone(), plan, settings, outputs)
        };
        Ok(Self {
            inner: build().map_err(to_py)?,
        })
    }

    /// The table's columns: `point`, the parameters, then the outputs or `t` and the signals.
    fn columns(&self) -> Vec<String> {
        self.inner.columns()
    }

    fn __len__(&self) -> usize {
        self.inner.plan().len()
    }

    /// Runs the points `indices` (GIL released) and returns their table rows in order; with
    /// `keep_going` a failed point leaves its parameters and NaN outputs instead of raising.
    #[pyo3(signature = (indices, keep_going = false))]
    fn run_points(
        &self,
        py: Python<'_>,
        indices: Vec<usize>,
        keep_going: bool,
    ) -> PyResult<Vec<Vec<f64>>> {
        let sweep = &self.inner;
        py.detach(|| -> Result<Vec<Vec<f64>>, StudyError> {
            let mut rows = Vec::new();
            for i in indices {
                match sweep.run_point(i) {
                    Ok(r) => rows.extend(r),
                    Err(e) if keep_going && e.is_numerical() => rows.extend(sweep.failed_rows(i)),
                    Err(e) => return Err(e),
                }
            }
            Ok(rows)
        })
        .map_err(to_py)
    }
}

/// The CSV `dirac run` writes for these columns: `t,<names>` and every value in the same form.
#[pyfunction]
fn csv_text(names: Vec<String>, t: Vec<f64>, columns: Vec<Vec<f64>>) -> PyResult<String> {
    let mut out = Vec::new();
    {
        let mut sink = dirac_output::CsvSink::new(&mut out);
        let mut row = vec![0.0; columns.len()];
        let write = |e: String| pyo3::exceptions::PyOSError::new_err(e);
        sink.begin(&names).map_err(write)?;
        for (k, &tk) in t.iter().enumerate() {
            for (slot, column) in row.iter_mut().zip(&columns) {
                *slot = column.get(k).copied().unwrap_or(f64::NAN);
            }
            sink.row(k, tk, &row).map_err(write)?;
        }
        sink.finish()
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.to_string()))?;
    }
    String::from_utf8(out).map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}

/// The CSV `dirac sweep` writes for a sweep table (point index as an integer, `t` as `dirac run`
/// prints times, every other value in the shortest form that reads back the same).
#[pyfunction]
fn table_text(columns: Vec<String>, rows: Vec<Vec<f64>>) -> PyResult<String> {
    let io = |e: std::io::Error| pyo3::exceptions::PyOSError::new_err(e.to_string());
    let mut writer = TableWriter::new(Vec::new(), &columns).map_err(io)?;
    for row in &rows {
        writer.row(row).map_err(io)?;
    }
    let out = writer.finish().map_err(io)?;
    String::from_utf8(out).map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}

/// Values written as `1,2,5`, `start:stop:count` or `start:stop:count:log` (SPICE suffixes
/// allowed), as `dirac sweep --param` reads them.
#[pyfunction]
fn parse_values(spec: &str) -> PyResult<Vec<f64>> {
    dirac_study::parse_values(spec).map_err(to_py)
}

#[pymodule]
fn _dirac(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModel>()?;
    m.add_class::<PySweep>()?;
    m.add_function(wrap_pyfunction!(csv_text, m)?)?;
    m.add_function(wrap_pyfunction!(table_text, m)?)?;
    m.add_function(wrap_pyfunction!(parse_values, m)?)?;
    Ok(())
}
