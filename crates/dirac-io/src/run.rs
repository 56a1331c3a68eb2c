//! Running a circuit and streaming its signals.

use std::time::Instant;

use dirac_core::{Discretisation, Model};
use dirac_graph::{Assembler, Representation};
use dirac_sim::{Integrator, IntegratorOptions, Scheme, SimError};
use thiserror::Error;

use crate::circuit::{Circuit, Signal, SignalKind};

/// A failed circuit run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RunError {
    /// The model could not be set up or a step failed numerically.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The interconnection could not be assembled.
    #[error(transparent)]
    Graph(#[from] dirac_graph::GraphError),
    /// Step size or end time missing or invalid.
    #[error("{0}")]
    Settings(String),
    /// The output sink failed.
    #[error("writing output: {0}")]
    Output(String),
}

/// Receiver of output rows `(t, values)`.
type RowSink<'a> = dyn FnMut(f64, &[f64]) -> Result<(), String> + 'a;

/// Turns per-step values into output rows `t = 0, h, …, N h`.
///
/// The values computed after step `k` (which goes from `t_k` to `t_{k+1}`) form row `k` for
/// `k ≥ 1`. Row 0 waits for rows 1 and 2: entries the initial state knows (`known`) are kept,
/// the others are extrapolated linearly, `2·row₁ − row₂`.
pub(crate) struct RowEmitter {
    h: f64,
    steps: usize,
    known: Vec<Option<f64>>,
    pending: Vec<Vec<f64>>,
}

impl RowEmitter {
    /// An emitter for `steps` steps of size `h`; with no steps, row 0 (unknown entries as 0) is
    /// written at once.
    pub(crate) fn new(
        h: f64,
        steps: usize,
        known: Vec<Option<f64>>,
        row: &mut RowSink<'_>,
    ) -> Result<Self, String> {
        if steps == 0 {
            let zeros: Vec<f64> = known.iter().map(|v| v.unwrap_or(0.0)).collect();
            row(0.0, &zeros)?;
        }
        Ok(Self {
            h,
            steps,
            known,
            pending: Vec::new(),
        })
    }

    /// Fixes row 0's entry `index` to `value` instead of extrapolating it.
    pub(crate) fn know(&mut self, index: usize, value: f64) {
        if let Some(k) = self.known.get_mut(index) {
            *k = Some(value);
        }
    }

    /// Takes the values computed after step `k` (`k = 0 … steps`).
    pub(crate) fn push(
        &mut self,
        k: usize,
        values: &[f64],
        row: &mut RowSink<'_>,
    ) -> Result<(), String> {
        if k == 0 {
            return Ok(());
        }
        if k > 2 {
            return row(k as f64 * self.h, values);
        }
        self.pending.push(values.to_vec());
        if k == 2 || k == self.steps {
            let first = self.pending[0].clone();
            let second = self
                .pending
                .get(1)
                .cloned()
                .unwrap_or_else(|| first.clone());
            let extrapolated: Vec<f64> = self
                .known
                .iter()
                .zip(first.iter().zip(&second))
                .map(|(known, (a, b))| known.unwrap_or(2.0 * a - b))
                .collect();
            row(0.0, &extrapolated)?;
            for (j, r) in self.pending.drain(..).enumerate() {
                row((j + 1) as f64 * self.h, &r)?;
            }
        }
        Ok(())
    }
}

/// How to run a circuit.
#[derive(Debug, Clone)]
pub struct RunSettings {
    /// Step size.
    pub h: f64,
    /// End time.
    pub t_end: f64,
    /// Representation to assemble.
    pub representation: Representation,
    /// Discretisation.
    pub discretisation: Discretisation,
    /// Dirac scheme.
    pub scheme: Scheme,
}

/// Counters of a finished run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Steps taken (including one step past `t_end` that completes the last row).
    pub steps: usize,
    /// Mean Newton updates per step.
    pub newton_iterations_per_step: f64,
    /// Numeric factorisations.
    pub factorisations: usize,
    /// Max over steps of the discrete constraint residual.
    pub max_constraint_residual: f64,
    /// Wall time of set-up and stepping, in seconds.
    pub wall_s: f64,
    /// Warnings (dropped redundant constraints).
    pub warnings: Vec<String>,
}

/// Runs `circuit` and calls `row(t, values)` for `t = 0, h, …, t_end` with the values of
/// `signals` (a subset of `circuit.signals`, in the order given).
///
/// Node voltages come from the KCL multipliers: in the (+) scheme the multiplier of the step that
/// starts at `t_k`, divided by `h`, is a second-order estimate of the node potential at `t_k`.
/// Branch currents at `t_k` are the mean of the two adjacent steps' rates. Charges are states.
/// Row 0 takes charges and inductor currents from the initial state and extrapolates the rest
/// linearly from rows 1 and 2.
pub fn run_circuit(
    circuit: &Circuit,
    settings: &RunSettings,
    signals: &[Signal],
    mut row: impl FnMut(f64, &[f64]) -> Result<(), String>,
) -> Result<RunSummary, RunError> {
    let start = Instant::now();
    if !(settings.h > 0.0 && settings.h.is_finite() && settings.t_end >= 0.0) {
        return Err(RunError::Settings(format!(
            "step size {} and end time {} must be positive and finite",
            settings.h, settings.t_end
        )));
    }
    let steps = (settings.t_end / settings.h).round() as usize;
    let system = Assembler::assemble(&circuit.graph, settings.representation)?;
    let names: Vec<String> = circuit
        .graph
        .subsystems()
        .iter()
        .map(|s| s.name().to_string())
        .collect();
    let q0 = system.global_vector(&circuit.q0, &names)?;
    let v0 = system.global_vector(&circuit.v0, &names)?;
    let n = q0.len();
    let mut p0 = vec![0.0; n];
    let mut lq = vec![0.0; n];
    system.model.lagrangian_gradient(&q0, &v0, &mut lq, &mut p0);
    let options =
        IntegratorOptions::new(settings.discretisation.clone(), settings.h).scheme(settings.scheme);
    let mut sim = Integrator::new(system.model.clone(), system.constraints.clone(), options)?;
    sim.set_state(&q0, &p0, 0.0)?;

    let h = settings.h;
    let index = |kind: &SignalKind| -> usize {
        match *kind {
            SignalKind::BranchCurrent {
                subsystem,
                coordinate,
            }
            | SignalKind::Charge {
                subsystem,
                coordinate,
            } => system.global_index(dirac_graph::SubsystemId(subsystem), coordinate),
            SignalKind::NodeVoltage { .. } => 0,
        }
    };
    let columns: Vec<(SignalKind, usize, Option<usize>)> = signals
        .iter()
        .map(|s| {
            let row = match s.kind {
                SignalKind::NodeVoltage { connection } => system.connection_row(connection),
                _ => None,
            };
            (s.kind.clone(), index(&s.kind), row)
        })
        .collect();
    let width = columns.len();
    let mut rate_prev = v0.clone();
    let mut rate = vec![0.0; n];
    let mut values = vec![0.0; width];
    let mut max_residual: f64 = 0.0;
    // Row 0: charges are states; everything else is extrapolated from rows 1 and 2.
    let known: Vec<Option<f64>> = columns
        .iter()
        .map(|(kind, i, _)| matches!(kind, SignalKind::Charge { .. }).then(|| q0[*i]))
        .collect();
    let mut emitter = RowEmitter::new(h, steps, known, &mut row).map_err(RunError::Output)?;
    // Step k goes from t_k to t_{k+1}; row k (k ≥ 1) is complete once step k is solved.
    for k in 0..=steps {
        let before = sim.q().to_vec();
        sim.step()?;
        max_residual = max_residual.max(sim.last_constraint_residual());
        for ((r, a), b) in rate.iter_mut().zip(sim.q()).zip(&before) {
            *r = (a - b) / h;
        }
        let multipliers = sim.last_multipliers_full();
        for (value, (kind, i, row)) in values.iter_mut().zip(&columns) {
            *value = match kind {
                SignalKind::NodeVoltage { .. } => row.map_or(0.0, |r| multipliers[r] / h),
                SignalKind::BranchCurrent { .. } => 0.5 * (rate_prev[*i] + rate[*i]),
                SignalKind::Charge { .. } => before[*i],
            };
        }
        std::mem::swap(&mut rate_prev, &mut rate);
        emitter
            .push(k, &values, &mut row)
            .map_err(RunError::Output)?;
    }
    let stats = sim.stats();
    let taken = sim.steps_taken();
    Ok(RunSummary {
        steps: taken,
        newton_iterations_per_step: stats.iterations as f64 / taken.max(1) as f64,
        factorisations: stats.factorisations,
        max_constraint_residual: max_residual,
        wall_s: start.elapsed().as_secs_f64(),
        warnings: sim.warnings().to_vec(),
    })
}
