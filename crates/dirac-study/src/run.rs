//! Running a model as the command line does: settings by name over the file's own, the start
//! the file asks for, rows from the first output time on.

use dirac_core::{Discretisation, Model as _};
use dirac_graph::{Assembler, Representation};
use dirac_netlist::{Circuit, Element, Measure, SourceSpec, build_circuit, waveform};
use dirac_sim::{
    Composition, Execution, IntegratorOptions, NaturalModes, RunError, RunSummary, Scheme, Signal,
    Simulation, Sink, Splitting, Start, StartRamp, Trajectory, TruncationControl,
};

use crate::model::Built;
use crate::{Model, RunSettings, StudyError};

/// A run's settings resolved against the file, before anything is assembled: what
/// [`Model::prepare_plan`] will set up (front ends check the run's size against it first).
#[derive(Debug, Clone)]
pub struct RunPlan {
    /// The representation or splitting.
    pub execution: Execution,
    /// Discretisation, scheme and step size.
    pub options: IntegratorOptions,
    /// The end time.
    pub t_end: f64,
    /// The signals recorded.
    pub signals: Vec<Signal>,
    /// Rows before this time are not passed on (a netlist's `.tran` TSTART).
    pub first_output: f64,
    /// Steps per output row ([`Model::steps_per_row`]): every row is passed on at 1, every
    /// `m`-th at `m` (a netlist whose `.tran` TMAX is shorter than TSTEP).
    pub steps_per_row: usize,
    /// The time between rows: `h · steps_per_row`, exactly a netlist's TSTEP where it sets the
    /// rows (row `j` is at `j` times it, not at a sum of steps).
    pub output_step: f64,
    /// The start ramp is the model's choice: a netlist run that did not ask for it or against
    /// it takes it when the modal check finds a damped mode the method would leave ringing,
    /// as SPICE damps every start with a backward-Euler step ([`Model::prepare_plan`]).
    pub start_ramp_auto: bool,
    /// The ramps after source breakpoints are the model's choice: a netlist run that did not
    /// ask against ramps takes them when the modal check finds a damped mode the method would
    /// leave ringing, as SPICE restarts with a tiny step after every breakpoint
    /// ([`Model::prepare_plan`], [`dirac_sim::IntegratorOptions::corner_ramp`]).
    pub corner_ramp_auto: bool,
    /// Refuse the run when the method would amplify a mode of the model over it
    /// ([`RunSettings::force`] not set; see [`Model::prepare_plan`]).
    pub refuse_unstable: bool,
}

impl RunPlan {
    /// Number of steps to the end time, `round(t_end/h)`.
    #[must_use]
    pub fn steps(&self) -> u64 {
        (self.t_end / self.options.h).round() as u64
    }

    /// Number of rows passed on: from the first output time to the end time.
    #[must_use]
    pub fn output_rows(&self) -> u64 {
        ((self.t_end - self.first_output) / self.output_step)
            .round()
            .max(0.0) as u64
            + 1
    }
}

/// A run set up and ready to step: the simulation, its signals, its end time.
#[derive(Debug)]
pub struct Prepared {
    simulation: Simulation,
    signals: Vec<Signal>,
    t_end: f64,
    first_output: f64,
    steps_per_row: usize,
    output_step: f64,
    /// A netlist's `.meas` cards, the signals they read beyond `signals` (recorded but not
    /// passed on), and their results once run.
    measures: Vec<Measure>,
    measured_signals: Vec<Signal>,
    measurements: Vec<Measurement>,
    /// The natural modes, when the set-up already computed them (the automatic start ramp).
    modes: Option<NaturalModes>,
}

impl Prepared {
    /// The warnings of the set-up (dropped redundant constraints, repaired initial values).
    #[must_use]
    pub fn warnings(&self) -> &[String] {
        self.simulation.warnings()
    }

    /// The signals recorded.
    #[must_use]
    pub fn signals(&self) -> &[Signal] {
        &self.signals
    }

    /// The end time.
    #[must_use]
    pub fn t_end(&self) -> f64 {
        self.t_end
    }

    /// The step size.
    #[must_use]
    pub fn h(&self) -> f64 {
        self.simulation.options().h
    }

    /// The execution (representation or splitting).
    #[must_use]
    pub fn execution(&self) -> Execution {
        self.simulation.execution()
    }

    /// The integrator options.
    #[must_use]
    pub fn options(&self) -> &IntegratorOptions {
        self.simulation.options()
    }

    /// The natural modes at the prepared state (see [`Simulation::natural_modes`]); they do
    /// not change the rows of the run.
    ///
    /// # Errors
    /// A staggered execution, a model too large for the modal analysis, a failing readout.
    pub fn natural_modes(&mut self) -> Result<NaturalModes, RunError> {
        match &self.modes {
            Some(modes) => Ok(modes.clone()),
            None => self.simulation.natural_modes(),
        }
    }

    /// Number of output rows before the first output time is applied, `round(t_end/h) + 1`
    /// with one row every [`Prepared::steps_per_row`] steps.
    #[must_use]
    pub fn rows(&self) -> usize {
        (self.t_end / self.output_step).round() as usize + 1
    }

    /// Steps per output row (see [`Model::steps_per_row`]).
    #[must_use]
    pub fn steps_per_row(&self) -> usize {
        self.steps_per_row
    }

    /// Runs to the end time, streaming every row at or after the first output time (a
    /// netlist's `.tran` TSTART) to `sink`.
    ///
    /// # Errors
    /// A step, readout or the sink failing.
    pub fn run_into(&mut self, sink: &mut dyn Sink) -> Result<RunSummary, StudyError> {
        self.run_into_watched(sink, &mut |_| Ok(()))
    }

    /// [`Prepared::run_into`], calling `watch` with the step index before every step's row,
    /// passed on or not, and with 0 before the first (the command line's progress bar and interrupt
    /// check); an error from `watch` stops the run as a sink's does.
    ///
    /// # Errors
    /// See [`Prepared::run_into`].
    pub fn run_into_watched(
        &mut self,
        sink: &mut dyn Sink,
        watch: &mut dyn FnMut(usize) -> Result<(), String>,
    ) -> Result<RunSummary, StudyError> {
        let mut all = self.signals.clone();
        all.extend(self.measured_signals.iter().cloned());
        let mut samples = Samples::for_measures(&self.measures, &all);
        let mut skip = FromTime {
            inner: sink,
            first: self.first_output,
            every: self.steps_per_row.max(1),
            spacing: self.output_step,
            passed: self.signals.len(),
            samples: &mut samples,
            watch,
        };
        let summary = self.simulation.run_into(self.t_end, &all, &mut skip)?;
        samples.merge_inner_samples(&self.simulation);
        let corners = samples.corners_between_samples(&self.simulation);
        self.measurements = self
            .measures
            .iter()
            .map(|m| Measurement {
                name: m.name.clone(),
                value: samples.evaluate(m),
                corner: samples.corner_read(m, &corners),
            })
            .collect();
        Ok(summary)
    }

    /// The results of a netlist's `.meas` cards after a run, in card order (empty before).
    #[must_use]
    pub fn measurements(&self) -> &[Measurement] {
        &self.measurements
    }

    /// Runs to the end time and keeps every row.
    ///
    /// # Errors
    /// See [`Prepared::run_into`].
    pub fn run(&mut self) -> Result<(Trajectory, RunSummary), StudyError> {
        let mut trajectory = Trajectory::new();
        let summary = self.run_into(&mut trajectory)?;
        Ok((trajectory, summary))
    }
}

/// One `.meas` result: its value, or why it could not be taken (ngspice reports such a measure
/// as failed and goes on).
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// The result's name.
    pub name: String,
    /// The value, or why there is none.
    pub value: Result<f64, String>,
    /// A source corner (a breakpoint) inside a step the value reads across, which the samples
    /// (the states at the steps) do not resolve: the value is then off by up to that step's
    /// worth of the signal's change (docs/audit.md item 51).
    pub corner: Option<f64>,
}

impl Measurement {
    /// The warning a front end gives for a value read across [`Measurement::corner`].
    #[must_use]
    pub fn corner_warning(&self) -> Option<String> {
        let corner = self.corner.filter(|_| self.value.is_ok())?;
        Some(format!(
            "`.meas {}` reads across a source corner inside a step (t = {corner:e}), which the \
             steps' states do not resolve: it may be off by up to a step's change of the signal; \
             put the corner on the step grid or take a smaller step (TMAX)",
            self.name
        ))
    }
}

/// Distance, in steps, within which a sample's time is a source corner's.
const CORNER_SNAP: f64 = 1e-9;

/// Every step's time and the values the measures read, from the first output time on, and the
/// same at the ends of the substeps inside steps (source corners, pieces of refined steps, ramp
/// substeps; nothing is kept without measures).
struct Samples {
    /// The signals the measures read, and where each sits in a recorded row.
    names: Vec<String>,
    read: Vec<usize>,
    t: Vec<f64>,
    columns: Vec<Vec<f64>>,
    /// `(t, values read)` at the substeps' ends inside steps, in the order they came.
    inner: Vec<(f64, Vec<f64>)>,
    /// Samples at source corners where a column's value was not determined by the state there
    /// and was interpolated between the steps around it: `(t, column)`.
    filled: Vec<(f64, usize)>,
}

impl Samples {
    /// Room for the signals `measures` read, among the `recorded` ones.
    fn for_measures(measures: &[Measure], recorded: &[Signal]) -> Self {
        let (mut names, mut read) = (Vec::new(), Vec::new());
        for name in measures.iter().flat_map(Measure::signals) {
            if names.contains(&name) {
                continue;
            }
            if let Some(i) = recorded.iter().position(|s| s.name == name) {
                names.push(name);
                read.push(i);
            }
        }
        Self {
            columns: vec![Vec::new(); names.len()],
            names,
            read,
            t: Vec::new(),
            inner: Vec::new(),
            filled: Vec::new(),
        }
    }

    /// Puts the inner samples strictly between the first and the last step time among the
    /// steps' in time order. A value the state there does not determine (`NaN`: one the rows
    /// read from the steps) is interpolated between the steps around it, as before; at a source
    /// corner of `simulation` that is kept in `filled`, so that a measure reading it there still
    /// warns of the corner.
    fn merge_inner_samples(&mut self, simulation: &Simulation) {
        let snap = CORNER_SNAP * simulation.options().h;
        let is_corner = |t: f64| {
            simulation
                .next_breakpoint(t - snap)
                .is_some_and(|b| b <= t + snap)
        };
        let (Some(&first), Some(&last)) = (self.t.first(), self.t.last()) else {
            return;
        };
        let mut inner: Vec<_> = std::mem::take(&mut self.inner)
            .into_iter()
            .filter(|(t, _)| *t > first && *t < last)
            .collect();
        if inner.is_empty() {
            return;
        }
        inner.sort_by(|a, b| a.0.total_cmp(&b.0));
        // One merge pass over the steps' samples (a pulse train has a corner in many steps).
        let steps = std::mem::take(&mut self.t);
        let columns = std::mem::take(&mut self.columns);
        self.t = Vec::with_capacity(steps.len() + inner.len());
        self.columns = vec![Vec::with_capacity(steps.len() + inner.len()); columns.len()];
        let mut next = inner.into_iter().peekable();
        for (i, &t) in steps.iter().enumerate() {
            while let Some((ti, values)) = next.next_if(|(ti, _)| *ti <= t) {
                if ti < t {
                    self.t.push(ti);
                    // Between steps i − 1 and i (the first step is before every sample kept).
                    let w = (ti - steps[i - 1]) / (t - steps[i - 1]);
                    for (j, (column, value)) in self.columns.iter_mut().zip(values).enumerate() {
                        if value.is_finite() {
                            column.push(value);
                        } else {
                            let (a, b) = (columns[j][i - 1], columns[j][i]);
                            column.push(a + w * (b - a));
                            if is_corner(ti) {
                                self.filled.push((ti, j));
                            }
                        }
                    }
                }
            }
            self.t.push(t);
            for (column, step_column) in self.columns.iter_mut().zip(&columns) {
                column.push(step_column[i]);
            }
        }
    }

    fn column(&self, name: &str) -> &[f64] {
        self.names
            .iter()
            .position(|n| n == name)
            .and_then(|i| self.columns.get(i))
            .map_or(&[], Vec::as_slice)
    }

    fn evaluate(&self, measure: &Measure) -> Result<f64, String> {
        measure.evaluate(&self.t, &|name| self.column(name))
    }

    /// The source breakpoints strictly between two samples (not on a step time), in order.
    fn corners_between_samples(&self, simulation: &Simulation) -> Vec<f64> {
        let (Some(&first), Some(&last)) = (self.t.first(), self.t.last()) else {
            return Vec::new();
        };
        let snap = CORNER_SNAP * simulation.options().h;
        let mut out = Vec::new();
        let mut at = first;
        while let Some(b) = simulation.next_breakpoint(at) {
            if b >= last || out.len() >= 100_000 || b <= at {
                break;
            }
            let i = self.t.partition_point(|&ti| ti < b);
            let on_sample = [i.checked_sub(1), Some(i)]
                .into_iter()
                .flatten()
                .filter_map(|j| self.t.get(j))
                .any(|&tj| (tj - b).abs() <= snap);
            if !on_sample {
                out.push(b);
            }
            at = b;
        }
        out
    }

    /// The first of `corners` inside a stretch `measure` reads between two samples, or a
    /// corner sample at a stretch's end where a value it reads was interpolated.
    fn corner_read(&self, measure: &Measure, corners: &[f64]) -> Option<f64> {
        let signals = measure.signals();
        let filled: Vec<f64> = self
            .filled
            .iter()
            .filter(|(_, j)| signals.contains(&self.names[*j]))
            .map(|&(t, _)| t)
            .collect();
        if corners.is_empty() && filled.is_empty() {
            return None;
        }
        measure
            .stretches(&self.t, &|name| self.column(name))
            .into_iter()
            .find_map(|(a, b)| {
                let inside = corners.iter().copied().find(|&c| c > a && c < b);
                inside.or_else(|| filled.iter().copied().find(|&c| c >= a && c <= b))
            })
    }
}

/// Passes on every `every`-th step's row at or after `first`, numbered and timed on the output
/// grid (row `j` at `j·spacing`, not a sum of substeps), with its first `passed` values; keeps
/// every step's values from `first` on in `samples` (the measures); shows every step index to
/// `watch`.
struct FromTime<'a> {
    inner: &'a mut dyn Sink,
    first: f64,
    every: usize,
    spacing: f64,
    passed: usize,
    samples: &'a mut Samples,
    watch: &'a mut dyn FnMut(usize) -> Result<(), String>,
}

impl Sink for FromTime<'_> {
    fn begin(&mut self, names: &[String]) -> Result<(), String> {
        (self.watch)(0)?;
        self.inner.begin(&names[..self.passed])
    }

    fn row(&mut self, k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        (self.watch)(k)?;
        if t < self.first * (1.0 - 1e-12) {
            return Ok(());
        }
        if !self.samples.read.is_empty() {
            self.samples.t.push(t);
            for (column, &i) in self.samples.columns.iter_mut().zip(&self.samples.read) {
                column.push(values[i]);
            }
        }
        if !k.is_multiple_of(self.every) {
            return Ok(());
        }
        let values = &values[..self.passed];
        if self.every == 1 {
            return self.inner.row(k, t, values);
        }
        let j = k / self.every;
        self.inner.row(j, j as f64 * self.spacing, values)
    }

    fn samples_from(&self) -> Option<f64> {
        (!self.samples.read.is_empty()).then_some(self.first * (1.0 - 1e-12))
    }

    fn sample(&mut self, t: f64, values: &[f64]) -> Result<(), String> {
        let read = self.samples.read.iter().map(|&i| values[i]).collect();
        self.samples.inner.push((t, read));
        Ok(())
    }
}

/// An operating point: each signal's value at the steady state, and what the set-up warned of.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatingPoint {
    /// `(signal, value)` in the order of the model's signals.
    pub values: Vec<(String, f64)>,
    /// The set-up's warnings (for a mechanism: a steady state that is not isolated).
    pub warnings: Vec<String>,
}

/// One representation's deviation from the monolithic run (`dirac compare`).
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// `monolithic`, `constraint`, `force`, `staggered-gs`, `staggered-jacobi`.
    pub execution: String,
    /// Largest absolute difference from the monolithic run over every signal and row; `None`
    /// when this execution could not run.
    pub max_abs_deviation: Option<f64>,
    /// Why it could not run.
    pub note: Option<String>,
}

/// The size of one representation of a model (`dirac check`).
#[derive(Debug, Clone, PartialEq)]
pub struct RepresentationSize {
    /// `monolithic`, `constraint` or `force`.
    pub representation: String,
    /// Coordinates of the assembled system.
    pub coordinates: usize,
    /// Constraint rows of the assembled system.
    pub constraint_rows: usize,
}

/// What `dirac check` reports about a model.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// Number of parts.
    pub parts: usize,
    /// Number of connections.
    pub connections: usize,
    /// Sizes in each assembled representation.
    pub representations: Vec<RepresentationSize>,
    /// Coordinates without a kinetic term (algebraic or first-order directions).
    pub degenerate: Vec<String>,
    /// The file's signals.
    pub signals: Vec<String>,
    /// Where the run starts.
    pub start: Start,
    /// A netlist's `.tran` step and end time.
    pub tran: Option<(f64, f64)>,
}

impl Model {
    /// The execution `settings` ask for, else the file's own.
    ///
    /// # Errors
    /// A staggered run of a netlist (a circuit's nodes are constraints, not couplings).
    pub fn execution_for(&self, settings: &RunSettings) -> Result<Execution, StudyError> {
        let own = self.execution();
        let execution = settings
            .representation
            .map_or(own, |choice| choice.execution(Some(own)));
        if matches!(execution, Execution::Staggered(_))
            && matches!(self.built, Built::Netlist { .. })
        {
            return Err(StudyError::Settings(format!(
                "{}: staggered co-simulation needs coupling elements between subsystems; a circuit's nodes are constraints",
                self.name()
            )));
        }
        Ok(execution)
    }

    /// The signals a netlist's `.meas` cards read that `recorded` does not hold.
    ///
    /// # Errors
    /// A signal the circuit cannot record (checked when the netlist was read, so not expected).
    fn measured_signals(&self, recorded: &[Signal]) -> Result<Vec<Signal>, StudyError> {
        let Some(circuit) = self.circuit() else {
            return Ok(Vec::new());
        };
        let mut out: Vec<Signal> = Vec::new();
        for name in circuit.measures.iter().flat_map(Measure::signals) {
            let signal = circuit.signal(&name)?;
            if !recorded.iter().chain(&out).any(|s| s.name == signal.name) {
                out.push(signal);
            }
        }
        Ok(out)
    }

    /// Steps per output row: a netlist's `.tran` rows come every TSTEP, from steps no longer
    /// than ngspice's largest internal step (TMAX, else the smaller of TSTEP and a fiftieth of
    /// the output interval; [`dirac_netlist::Tran::steps_per_row`]), so a deck that asks for
    /// `.tran 1m 10m 0 10u` is stepped at 10 µs and printed every millisecond. 1 for a scene,
    /// and whenever `settings` set the step size (then every step is a row).
    #[must_use]
    pub fn steps_per_row(&self, settings: &RunSettings) -> usize {
        match (&self.built, settings.h) {
            (Built::Netlist { circuit, .. }, None) => circuit.tran.map_or(1, |t| t.steps_per_row()),
            _ => 1,
        }
    }

    /// Integrator options and end time: the file's, changed by `settings`. A netlist's step is
    /// `.tran` TSTEP divided by [`Model::steps_per_row`].
    ///
    /// # Errors
    /// No step size or end time (a netlist without `.tran` and none given), or values that are
    /// not positive and finite.
    pub fn options_for(
        &self,
        settings: &RunSettings,
    ) -> Result<(IntegratorOptions, f64), StudyError> {
        let name = self.name();
        let (h, t_end, discretisation, scheme, ramp, truncation, composition) = match &self.built {
            Built::Netlist { circuit, .. } => {
                let tran = circuit.tran_settings();
                let every = self.steps_per_row(settings);
                let t_end = settings.t_end.or(tran.map(|t| t.1));
                (
                    settings.h.or(tran.map(|t| t.0 / every as f64)),
                    // Rows every TSTEP from `m` steps each: the run ends on that grid.
                    match circuit.tran.filter(|_| every > 1) {
                        Some(card) => t_end.map(|t| card.run_end(t)),
                        None => t_end,
                    },
                    circuit
                        .method
                        .clone()
                        .unwrap_or_else(Discretisation::midpoint),
                    Scheme::Plus,
                    None,
                    match settings.truncation {
                        Some(on) => on.then_some(circuit.truncation),
                        None => circuit.default_truncation(),
                    },
                    Composition::single(),
                )
            }
            Built::Scene { scene, .. } => (
                Some(settings.h.unwrap_or(scene.options.h)),
                Some(settings.t_end.unwrap_or(scene.t_end)),
                scene.options.discretisation.clone(),
                scene.options.scheme,
                scene.options.start_ramp,
                settings
                    .truncation
                    .and_then(|on| on.then(TruncationControl::default)),
                scene.options.composition.clone(),
            ),
        };
        let missing = |setting| StudyError::MissingSetting {
            file: name.to_string(),
            setting,
        };
        let h = h.ok_or_else(|| missing("h"))?;
        let t_end = t_end.ok_or_else(|| missing("t_end"))?;
        if !(h > 0.0 && h.is_finite()) {
            return Err(StudyError::Settings(format!(
                "step size must be positive and finite, got {h}"
            )));
        }
        if !(t_end >= 0.0 && t_end.is_finite()) {
            return Err(StudyError::Settings(format!(
                "end time must be non-negative and finite, got {t_end}"
            )));
        }
        let discretisation = settings
            .method
            .map_or(discretisation, crate::Method::discretisation);
        let scheme = settings.scheme.unwrap_or(scheme);
        let ramp = match settings.start_ramp {
            Some(on) => on.then(StartRamp::default),
            None => ramp,
        };
        Ok((
            IntegratorOptions::new(discretisation, h)
                .scheme(scheme)
                .start_ramp(ramp)
                .truncation(truncation)
                .composition(settings.composition.clone().unwrap_or(composition)),
            t_end,
        ))
    }

    /// A simulation of this model in `execution` with `options`, starting at `start`, with the
    /// file's initial values (and a netlist's `.ic` holds).
    ///
    /// # Errors
    /// Initial values that do not fit the parts.
    pub fn simulation(
        &self,
        execution: Execution,
        options: IntegratorOptions,
        start: Start,
    ) -> Result<Simulation, StudyError> {
        Ok(match &self.built {
            Built::Netlist { circuit, .. } => circuit.simulation(execution, options, start)?,
            Built::Scene { scene, .. } => scene.simulation_with(execution, options, start)?,
        })
    }

    /// The signals `settings` name, else the file's.
    ///
    /// # Errors
    /// A name that is not a signal of this model.
    pub fn signals_for(&self, settings: &RunSettings) -> Result<Vec<Signal>, StudyError> {
        match &settings.signals {
            Some(names) => self.signals(names),
            None => Ok(self.default_signals()),
        }
    }

    /// Sets up the run `settings` ask for: the execution, options, start and signals, the
    /// consistent initial state.
    ///
    /// # Errors
    /// Bad settings or signals, an inconsistent start, a steady state that cannot be found.
    pub fn prepare(&self, settings: &RunSettings) -> Result<Prepared, StudyError> {
        self.prepare_with(settings, None)
    }

    /// [`Model::prepare`], recording `extra` after the signals `settings` name (the Python
    /// package records the energy this way for the run's energy drift, whatever the model's
    /// signal names are).
    ///
    /// # Errors
    /// See [`Model::prepare`].
    pub fn prepare_with(
        &self,
        settings: &RunSettings,
        extra: Option<Signal>,
    ) -> Result<Prepared, StudyError> {
        let mut plan = self.plan(settings)?;
        plan.signals.extend(extra);
        self.prepare_plan(plan)
    }

    /// The run `settings` ask for, resolved against the file's own settings: execution,
    /// options, end time, signals and first output time. Nothing is assembled yet.
    ///
    /// # Errors
    /// Bad settings or signal names.
    pub fn plan(&self, settings: &RunSettings) -> Result<RunPlan, StudyError> {
        let execution = self.execution_for(settings)?;
        let (options, t_end) = self.options_for(settings)?;
        let signals = self.signals_for(settings)?;
        let steps_per_row = self.steps_per_row(settings);
        let output_step = match (&self.built, steps_per_row) {
            (Built::Netlist { circuit, .. }, 2..) => circuit.tran.map_or(options.h, |t| t.tstep),
            _ => options.h,
        };
        Ok(RunPlan {
            execution,
            options,
            t_end,
            signals,
            first_output: self.first_output_time(),
            steps_per_row,
            output_step,
            start_ramp_auto: matches!(self.built, Built::Netlist { .. })
                && settings.start_ramp.is_none(),
            corner_ramp_auto: matches!(self.built, Built::Netlist { .. })
                && settings.start_ramp != Some(false),
            refuse_unstable: !settings.force,
        })
    }

    /// Sets up `plan` (from [`Model::plan`]): the simulation at the file's start, its signals
    /// checked, the consistent initial state. This is where every front end (the command
    /// line, the Python package, sweeps) turns a file into a run.
    ///
    /// # Errors
    /// Signals the simulation cannot record, an inconsistent start, a steady state that cannot
    /// be found.
    pub fn prepare_plan(&self, plan: RunPlan) -> Result<Prepared, StudyError> {
        let prepared = |options: IntegratorOptions| -> Result<Simulation, StudyError> {
            let mut simulation = self.simulation(plan.execution, options, self.start())?;
            simulation.check_signals(&plan.signals)?;
            simulation.prepare()?;
            Ok(simulation)
        };
        let mut simulation = prepared(plan.options.clone())?;
        // SPICE damps its start (a backward-Euler first step) and restarts with a tiny step
        // after every breakpoint; midpoint and Gauss steps do neither, so a netlist whose
        // fastest damped mode they would leave ringing takes the start ramp and the ramps after
        // breakpoints, both sized to reach that mode (`StartRamp::for_ratio`): the default
        // ramp's 32 levels went down to `h·2⁻³²/3` (4e-21 s on a CMOS deck), below the round-off
        // of the state's own time scale, where Gauss 3 and 4 could not converge (audit 43). A method that amplifies a mode (the trapezoid rule on a decay much
        // faster than h) would write a trajectory that blows up: refused before a step is
        // taken. Both decisions read the modes of the start state at this h, which are kept for
        // the front end's warnings (with the ramps or without, they are the same).
        // A start ramp asked for (`--start-ramp`, a scene's `start_ramp = true`) is sized the
        // same way where the modes are known, whether or not the method would leave the mode
        // ringing.
        let start_auto = plan.start_ramp_auto && plan.options.start_ramp.is_none();
        let start_asked = plan.options.start_ramp.is_some();
        let corner_auto =
            plan.corner_ramp_auto && plan.options.corner_ramp.is_none() && plan.options.breakpoints;
        let modes = (matches!(plan.execution, Execution::Assembled(_))
            && (start_auto || start_asked || corner_auto || plan.refuse_unstable))
            .then(|| simulation.natural_modes().ok())
            .flatten();
        if let Some(m) = &modes {
            let mut options = plan.options.clone();
            let sized = start_asked
                .then(|| m.ramp_to_fastest_decay(&plan.options))
                .flatten();
            if let Some(ramp) = sized {
                options = options.start_ramp(Some(ramp));
            }
            let corner = (start_auto || corner_auto)
                .then(|| m.corner_ramp(&plan.options))
                .flatten();
            if let Some(ramp) = corner {
                if start_auto {
                    options = options.start_ramp(Some(ramp));
                }
                if corner_auto {
                    options = options.corner_ramp(Some(ramp));
                }
            }
            if sized.is_some() || corner.is_some() {
                simulation = prepared(options)?;
            }
        }
        let steps = usize::try_from(plan.steps()).unwrap_or(usize::MAX);
        if let Some(why) = modes
            .as_ref()
            .filter(|_| plan.refuse_unstable)
            .and_then(|m| m.instability(simulation.options(), steps))
        {
            return Err(StudyError::Settings(why));
        }
        let measured_signals = self.measured_signals(&plan.signals)?;
        Ok(Prepared {
            simulation,
            signals: plan.signals,
            t_end: plan.t_end,
            first_output: plan.first_output,
            steps_per_row: plan.steps_per_row,
            output_step: plan.output_step,
            measured_signals,
            measures: self.circuit().map_or_else(Vec::new, |c| c.measures.clone()),
            measurements: Vec::new(),
            modes,
        })
    }

    /// Runs as `settings` ask and keeps every row.
    ///
    /// # Errors
    /// See [`Model::prepare`] and [`Prepared::run_into`].
    pub fn run(&self, settings: &RunSettings) -> Result<(Trajectory, RunSummary), StudyError> {
        self.prepare(settings)?.run()
    }

    /// The operating point (steady state with the sources at `t = 0`): a netlist's node voltages
    /// and inductor and source currents as SPICE's `.op` prints them, a scene's signals, with
    /// the set-up's warnings (a steady state that is not isolated, dropped redundant rows).
    ///
    /// # Errors
    /// A model without a steady state, or Newton failing to find it.
    pub fn operating_point(&self) -> Result<OperatingPoint, StudyError> {
        let settings = RunSettings {
            h: Some(1.0),
            t_end: Some(0.0),
            ..RunSettings::default()
        };
        let (options, _) = self.options_for(&settings)?;
        let signals = match &self.built {
            Built::Netlist { circuit, .. } => circuit.operating_point_signals(),
            Built::Scene { scene, .. } => scene.signals.clone(),
        };
        let mut simulation = match &self.built {
            // A DC operating point holds every independent source at its value at t = 0, as
            // ngspice's `.op` takes a transient function's time-zero value: a value the readout
            // takes from the steps (a source's current through a capacitor) then does not see
            // the source move over the step it is read from.
            Built::Netlist { netlist, .. } => {
                let mut held = netlist.as_ref().clone();
                for element in &mut held.elements {
                    if let Element::V { source, .. } | Element::I { source, .. } = element {
                        *source = SourceSpec::Dc(waveform(source).value(0.0));
                    }
                }
                build_circuit(&held, self.name())?.simulation(
                    self.execution(),
                    options,
                    Start::SteadyState,
                )?
            }
            Built::Scene { .. } => {
                self.simulation(self.execution(), options, Start::SteadyState)?
            }
        };
        let (trajectory, _) = simulation.run(0.0, &signals)?;
        Ok(OperatingPoint {
            values: signals
                .iter()
                .zip(trajectory.row(0))
                .map(|(s, v)| (s.name.clone(), *v))
                .collect(),
            warnings: simulation.warnings().to_vec(),
        })
    }

    /// Runs every representation (and for a scene both staggered splittings) with the file's
    /// signals and reports each one's largest deviation from the monolithic run. The monolithic
    /// run is set up as [`Model::prepare_plan`] sets up every run (the refusal of a method that
    /// would blow up, a netlist's automatic ramps), and every other run takes its options.
    ///
    /// # Errors
    /// Bad settings, or the monolithic run failing.
    pub fn compare(&self, settings: &RunSettings) -> Result<Vec<Comparison>, StudyError> {
        let mut plan = self.plan(settings)?;
        plan.execution = Execution::Assembled(Representation::Monolithic);
        let (t_end, signals) = (plan.t_end, plan.signals.clone());
        let mut prepared = self.prepare_plan(plan)?;
        let options = prepared.options().clone();
        let reference = prepared.simulation.run(t_end, &signals)?.0;
        let collect = |execution: Execution| -> Result<Trajectory, StudyError> {
            let mut simulation = self.simulation(execution, options.clone(), self.start())?;
            Ok(simulation.run(t_end, &signals)?.0)
        };
        let mut results = Vec::new();
        for representation in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let run = collect(Execution::Assembled(representation))?;
            results.push(Comparison {
                execution: representation.to_string(),
                max_abs_deviation: Some(run.max_deviation(&reference)),
                note: None,
            });
        }
        for splitting in [Splitting::GaussSeidel, Splitting::Jacobi] {
            let execution = Execution::Staggered(splitting);
            let name = execution.to_string();
            if matches!(self.built, Built::Netlist { .. }) {
                results.push(Comparison {
                    execution: name,
                    max_abs_deviation: None,
                    note: Some("not applicable: a circuit's nodes are constraints between parts, not coupling elements".to_string()),
                });
                continue;
            }
            results.push(match collect(execution) {
                Ok(run) => Comparison {
                    execution: name,
                    max_abs_deviation: Some(run.max_deviation(&reference)),
                    note: None,
                },
                Err(why) => Comparison {
                    execution: name,
                    max_abs_deviation: None,
                    note: Some(why.to_string()),
                },
            });
        }
        Ok(results)
    }

    /// The coordinates of the monolithic system without a kinetic term (no diagonal entry in
    /// the velocity Hessian of the Lagrangian at rest): algebraic or first-order directions.
    ///
    /// # Errors
    /// An interconnection that cannot be assembled.
    pub fn degenerate_directions(&self) -> Result<Vec<String>, StudyError> {
        let system = Assembler::assemble(self.graph(), Representation::Monolithic)
            .map_err(|e| StudyError::Run(e.into()))?;
        let n = system.coordinates();
        let mut hessian = dirac_core::LagrangianHessian::default();
        hessian.begin();
        system
            .model
            .lagrangian_hessian(&vec![0.0; n], &vec![0.0; n], &mut hessian);
        let mut regular = vec![false; n];
        for (r, c, v) in hessian.vv.iter() {
            if r == c && v != 0.0 {
                regular[r] = true;
            }
        }
        Ok((0..n)
            .filter(|&i| !regular[i])
            .map(|i| system.model.coordinate_name(i))
            .collect())
    }

    /// Sizes of the assembled representations, degenerate directions, signals and start.
    ///
    /// # Errors
    /// An interconnection that cannot be assembled.
    pub fn check(&self) -> Result<CheckReport, StudyError> {
        let graph = self.graph();
        let mut representations = Vec::new();
        for representation in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let system = Assembler::assemble(graph, representation)
                .map_err(|e| StudyError::Run(e.into()))?;
            representations.push(RepresentationSize {
                representation: representation.to_string(),
                coordinates: system.coordinates(),
                constraint_rows: system.constraint_rows(),
            });
        }
        let degenerate = self.degenerate_directions()?;
        Ok(CheckReport {
            parts: graph.subsystems().len(),
            connections: graph.connections().len(),
            representations,
            degenerate,
            signals: self
                .default_signals()
                .iter()
                .map(|s| s.name.clone())
                .collect(),
            start: self.start(),
            tran: self.circuit().and_then(Circuit::tran_settings),
        })
    }
}
