//! Stepping a built scene in any representation, staggered included, and recording its signals.

use std::time::Instant;

use dirac_graph::{AssembledConstraints, AssembledModel, AssembledSystem, Assembler};
use dirac_sim::{Integrator, Staggered};

use super::build::{BuiltScene, Execution, Quantity, Recording, SceneSignal};
use super::error::SceneError;
use super::record::{Placement, Recorder};
use crate::run::{RowEmitter, RunSummary};

enum Engine {
    Assembled {
        system: Box<AssembledSystem>,
        sim: Box<Integrator<AssembledModel, AssembledConstraints>>,
    },
    Staggered(Box<Staggered>),
}

/// A built scene being stepped: one [`Integrator`] on the assembled system, or a [`Staggered`]
/// co-simulation, behind one interface. Positions and momenta are those of the parts, in scene
/// order (the constraint representation's endpoint coordinates dropped, their momenta pulled back
/// to the partner ports), so every representation reports the same vectors.
pub struct SceneSimulation {
    engine: Engine,
    h: f64,
    steps: usize,
}

impl SceneSimulation {
    /// Assembles (or splits) the scene and initialises it consistently from its `q0`, `v0` at
    /// `t = 0` (velocities projected onto the constraints, `p = ∂L/∂v`).
    pub fn new(built: &BuiltScene) -> Result<Self, SceneError> {
        let engine = match built.execution {
            Execution::Assembled(representation) => {
                let system = Assembler::assemble(&built.graph, representation)?;
                let names: Vec<String> = built
                    .graph
                    .subsystems()
                    .iter()
                    .map(|s| s.name().to_string())
                    .collect();
                let q0 = system.global_vector(&built.q0, &names)?;
                let v0 = system.global_vector(&built.v0, &names)?;
                let mut sim = Integrator::new(
                    system.model.clone(),
                    system.constraints.clone(),
                    built.options.clone(),
                )?;
                sim.initialise(&q0, &v0, 0.0)?;
                Engine::Assembled {
                    system: Box::new(system),
                    sim: Box::new(sim),
                }
            }
            Execution::Staggered(splitting) => {
                let mut sim = Staggered::new(&built.graph, &built.options, splitting)?;
                sim.initialise(&built.q0, &built.v0, 0.0)?;
                Engine::Staggered(Box::new(sim))
            }
        };
        Ok(Self {
            engine,
            h: built.h(),
            steps: 0,
        })
    }

    /// Advances one step.
    pub fn step(&mut self) -> Result<(), SceneError> {
        match &mut self.engine {
            Engine::Assembled { sim, .. } => {
                sim.step()?;
            }
            Engine::Staggered(sim) => sim.step()?,
        }
        self.steps += 1;
        Ok(())
    }

    /// Steps taken.
    #[must_use]
    pub fn steps_taken(&self) -> usize {
        self.steps
    }

    /// The time `k h` after `k` steps.
    #[must_use]
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.h
    }

    /// Positions of every part, concatenated in scene order.
    #[must_use]
    pub fn positions(&self) -> Vec<f64> {
        match &self.engine {
            Engine::Assembled { system, sim } => system.subsystem_positions(sim.q()).to_vec(),
            Engine::Staggered(sim) => sim.positions(),
        }
    }

    /// Momenta of every part, concatenated in scene order (endpoint momenta pulled back to the
    /// partner ports in the constraint representation).
    #[must_use]
    pub fn momenta(&self) -> Vec<f64> {
        match &self.engine {
            Engine::Assembled { system, sim } => system.subsystem_momenta(sim.p()),
            Engine::Staggered(sim) => sim.momenta(),
        }
    }

    /// Warnings of the set-up (constraint rows dropped as redundant).
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        match &self.engine {
            Engine::Assembled { sim, .. } => sim.warnings().to_vec(),
            Engine::Staggered(_) => Vec::new(),
        }
    }

    /// Max-norm of the last step's discrete constraint equations (0 for a staggered run, whose
    /// parts' internal residuals are not exposed).
    pub fn constraint_residual(&mut self) -> f64 {
        match &mut self.engine {
            Engine::Assembled { sim, .. } => sim.last_constraint_residual(),
            Engine::Staggered(_) => 0.0,
        }
    }

    /// The assembled system and its integrator (multipliers, interaction forces, Newton
    /// counters), or `None` for a staggered run.
    #[must_use]
    pub fn assembled(
        &self,
    ) -> Option<(
        &AssembledSystem,
        &Integrator<AssembledModel, AssembledConstraints>,
    )> {
        match &self.engine {
            Engine::Assembled { system, sim } => Some((system, sim)),
            Engine::Staggered(_) => None,
        }
    }
}

/// Runs `built` and calls `row(t, values)` for `t = 0, h, …, t_end` with the values of `signals`
/// (for example `built.signals`), in any execution, staggered included.
///
/// The rows follow the netlist runner's conventions ([`crate::run_circuit`]): a value at `t_k` is
/// the state `q_k`; a rate at `t_k` is the mean of the rates of the steps before and after `t_k`
/// (so one step past `t_end` is taken); row 0 takes values from the initial state and
/// extrapolates rates linearly from rows 1 and 2.
pub fn run_scene(
    built: &BuiltScene,
    signals: &[SceneSignal],
    row: impl FnMut(f64, &[f64]) -> Result<(), String>,
) -> Result<RunSummary, SceneError> {
    run_scene_recorded(built, signals, &Recording::default(), row)
}

/// Column names that [`run_scene_recorded`] appends after the signals for `recording`:
/// `energy`, `power(<part>)`, `constraint_residual`, `force(<connection>)`.
///
/// # Errors
/// Forces of nodes or joints asked of a staggered run (they are multipliers it does not have).
pub fn recorded_columns(
    built: &BuiltScene,
    recording: &Recording,
) -> Result<Vec<String>, SceneError> {
    Ok(Recorder::new(built, recording)?.names())
}

/// [`run_scene`] with the `[record]` quantities of `recording` appended to each row (see
/// [`recorded_columns`]).
///
/// Energy, power and coupling forces of a step are evaluated at its midpoint state
/// (`q̄ = (q_k + q_{k+1})/2`, `v̄ = (q_{k+1} − q_k)/h`); a row at `t_k` takes the mean of the two
/// steps around it, like a rate. The energy is `Σ (v̄·∂L/∂v − L)` over the parts plus the coupling
/// potentials; the power of a part is `f·v̄` of its own forces (negative when it dissipates). The
/// constraint residual and the forces of nodes and joints (their multipliers over `h`; for a
/// circuit node, its potential) belong to the step starting at `t_k`.
pub fn run_scene_recorded(
    built: &BuiltScene,
    signals: &[SceneSignal],
    recording: &Recording,
    mut row: impl FnMut(f64, &[f64]) -> Result<(), String>,
) -> Result<RunSummary, SceneError> {
    let start = Instant::now();
    let steps = built.steps();
    let h = built.h();
    let mut recorder = Recorder::new(built, recording)?;
    let placements = recorder.placements();
    let mut sim = SceneSimulation::new(built)?;
    let q0 = sim.positions();
    let n = q0.len();
    let mut rate_prev = vec![0.0; n];
    let mut rate = vec![0.0; n];
    let ns = signals.len();
    let mut values = vec![0.0; ns + placements.len()];
    let mut extra_prev = vec![0.0; placements.len()];
    let mut extra = vec![0.0; placements.len()];
    let mut max_residual: f64 = 0.0;
    // Row 0: states are known; rates and step averages are extrapolated from rows 1 and 2.
    let known: Vec<Option<f64>> = signals
        .iter()
        .map(|s| (s.quantity == Quantity::Value).then(|| q0[s.index]))
        .chain(placements.iter().map(|_| None))
        .collect();
    let output = |e: String| SceneError::Output(e);
    let mut emitter = RowEmitter::new(h, steps, known, &mut row).map_err(output)?;
    for k in 0..=steps {
        let before = sim.positions();
        sim.step()?;
        let residual = sim.constraint_residual();
        max_residual = max_residual.max(residual);
        let after = sim.positions();
        for ((r, a), b) in rate.iter_mut().zip(&after).zip(&before) {
            *r = (a - b) / h;
        }
        for (v, s) in values.iter_mut().zip(signals) {
            *v = match s.quantity {
                Quantity::Value => before[s.index],
                Quantity::Rate => 0.5 * (rate_prev[s.index] + rate[s.index]),
            };
        }
        if !placements.is_empty() {
            recorder.step_values(&sim, &before, &after, k as f64 * h, residual, &mut extra);
            for (j, placement) in placements.iter().enumerate() {
                values[ns + j] = match placement {
                    Placement::Averaged => 0.5 * (extra_prev[j] + extra[j]),
                    Placement::StepStart { first_row } => {
                        if k == 0 && *first_row {
                            emitter.know(ns + j, extra[j]);
                        }
                        extra[j]
                    }
                };
            }
            std::mem::swap(&mut extra_prev, &mut extra);
        }
        std::mem::swap(&mut rate_prev, &mut rate);
        emitter.push(k, &values, &mut row).map_err(output)?;
    }
    let taken = sim.steps_taken();
    let (iterations, factorisations) = sim.assembled().map_or((0, 0), |(_, s)| {
        let stats = s.stats();
        (stats.iterations, stats.factorisations)
    });
    Ok(RunSummary {
        steps: taken,
        newton_iterations_per_step: iterations as f64 / taken.max(1) as f64,
        factorisations,
        max_constraint_residual: max_residual,
        wall_s: start.elapsed().as_secs_f64(),
        warnings: sim.warnings(),
    })
}
