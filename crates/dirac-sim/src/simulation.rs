//! The run layer: from an interconnection, a representation and integrator options to a
//! trajectory of named signals. This is the one place where a model is run; the command line, the
//! scene and netlist readers, the benchmarks and the examples all go through it.
//!
//! A [`Simulation`] assembles the graph (or splits it for co-simulation), sets the initial state
//! (given by part and coordinate, or the steady state), makes it consistent with the model's
//! algebraic relations, and steps it. Every recorded row `k` is the state at `t_k = t_0 + k·h`,
//! read by the algebraic relations at `(q_k, p_k, t_k)` ([`crate::Readout`]): row 0 is the initial
//! state itself.

use std::time::Instant;

use dirac_core::{Constraints, Model, RowSubset};
use dirac_graph::{
    AssembledConstraints, AssembledModel, AssembledSystem, Assembler, ConnectionId, GraphError,
    Interconnection, Representation, StructureMemo,
};
use thiserror::Error;

use crate::error::SimError;
use crate::integrator::{InnerState, Integrator, IntegratorOptions};
use crate::modes::{MODAL_LIMIT, MethodResponse, ModesError, NaturalModes};
use std::collections::VecDeque;
use std::sync::Arc;

use crate::readout::{Readout, ReadoutError, ReadoutPlan, ReadoutRow};
use crate::signal::{Signal, Snapshot};
use crate::staggered::{Splitting, Staggered};
use crate::steady::{SteadyState, SteadyStateError};
use crate::trajectory::{Sink, Trajectory};

/// How the interconnection is turned into equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Execution {
    /// One assembled system in the given representation.
    Assembled(Representation),
    /// Co-simulation of the parts, each stepped against frozen partners.
    Staggered(Splitting),
}

impl From<Representation> for Execution {
    fn from(representation: Representation) -> Self {
        Self::Assembled(representation)
    }
}

impl From<Splitting> for Execution {
    fn from(splitting: Splitting) -> Self {
        Self::Staggered(splitting)
    }
}

impl std::fmt::Display for Execution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Assembled(r) => write!(f, "{r}"),
            Self::Staggered(Splitting::GaussSeidel) => f.write_str("staggered-gs"),
            Self::Staggered(Splitting::Jacobi) => f.write_str("staggered-jacobi"),
        }
    }
}

/// Where the run starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Start {
    /// From the positions and velocities given (zero where none is given), made consistent with
    /// the algebraic relations where they leave room (SPICE's `UIC`).
    #[default]
    Given,
    /// From the steady state with the sources frozen at `t_0` (SPICE's DC operating point; static
    /// equilibrium of a mechanism), MATH §7. Positions given for cyclic coordinates are kept.
    SteadyState,
}

/// A failed run: bad input (a signal, a setting, an inconsistent start) or a numerical failure.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RunError {
    /// The integrator failed (a step's Newton iteration, a setting).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The interconnection could not be assembled.
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// The values at an output time could not be computed.
    #[error(transparent)]
    Readout(#[from] ReadoutError),
    /// The steady state could not be found.
    #[error(transparent)]
    SteadyState(#[from] SteadyStateError),
    /// A signal names something the model does not have.
    #[error("unknown signal: {0}")]
    UnknownSignal(String),
    /// Initial data that contradict an algebraic relation of the model and cannot be repaired
    /// (every value involved was given).
    #[error("contradictory initial data: {0}")]
    ContradictoryStart(String),
    /// Algebraic relations of the model that contradict each other whatever the state.
    #[error("inconsistent model: {0}")]
    InconsistentModel(String),
    /// Step size, end time or start that cannot be run.
    #[error("{0}")]
    Settings(String),
    /// The sink refused a row.
    #[error("writing output: {0}")]
    Output(String),
    /// The natural modes could not be computed.
    #[error("natural modes: {0}")]
    Modes(#[from] ModesError),
}

impl RunError {
    /// Whether this is a numerical failure (exit code 1) rather than bad input (exit code 2).
    #[must_use]
    pub fn is_numerical(&self) -> bool {
        match self {
            Self::Sim(SimError::Newton { .. } | SimError::StepRejected { .. })
            | Self::Readout(_) => true,
            Self::SteadyState(e) => e.is_numerical(),
            _ => false,
        }
    }
}

/// What a run cost and what it found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSummary {
    /// Steps taken.
    pub steps: usize,
    /// Newton updates of the steps.
    pub newton_iterations: usize,
    /// Numeric factorisations of the steps.
    pub factorisations: usize,
    /// Newton updates of the readouts at the output times.
    pub readout_iterations: usize,
    /// Substeps that ended on a source breakpoint.
    pub breakpoint_substeps: usize,
    /// Substeps retried as two halves after a Newton failure.
    pub step_cuts: usize,
    /// Substeps of the start ramp (`IntegratorOptions::start_ramp`; 0 without one).
    pub ramp_substeps: usize,
    /// Substeps the truncation-error test rejected and took again in pieces
    /// (`IntegratorOptions::truncation`; 0 without it).
    pub refinements: usize,
    /// Substeps accepted, of every kind: the run's time points after `t₀` (equal to `steps`
    /// when no step was split).
    pub substeps: usize,
    /// Solved substeps that turned a rigid body by more than 0.25 rad and were checked against
    /// two half steps.
    pub turn_checks: usize,
    /// Solved substeps rejected (and cut) as roots of a rigid body's step equations that the
    /// motion does not take.
    pub spurious_roots: usize,
    /// Largest discrete constraint residual over the steps (when tracked).
    pub max_constraint_residual: Option<f64>,
    /// Wall time of set-up and stepping, in seconds.
    pub wall_s: f64,
    /// Warnings of the set-up (redundant constraints the model wrote, repaired initial values).
    pub warnings: Vec<String>,
}

impl RunSummary {
    /// Mean Newton updates per step.
    #[must_use]
    pub fn newton_iterations_per_step(&self) -> f64 {
        self.newton_iterations as f64 / self.steps.max(1) as f64
    }
}

/// Initial values of one part: positions and velocities, and which of them were given.
#[derive(Debug, Clone, PartialEq)]
struct PartStart {
    q: Vec<f64>,
    v: Vec<f64>,
    given_q: Vec<bool>,
    given_v: Vec<bool>,
}

/// A model ready to run: the graph, how to assemble it, how to step it and where to start.
pub struct Simulation {
    graph: Interconnection,
    offsets: Vec<usize>,
    execution: Execution,
    options: IntegratorOptions,
    t0: f64,
    start: Start,
    initial: Vec<PartStart>,
    holds: Vec<(ConnectionId, f64)>,
    track_residual: bool,
    engine: Option<Engine>,
    warnings: Vec<String>,
    last_residual: f64,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("execution", &self.execution)
            .field("h", &self.options.h)
            .field("t0", &self.t0)
            .field("start", &self.start)
            .finish_non_exhaustive()
    }
}

impl Simulation {
    /// A simulation of `graph` in `execution` (a [`Representation`], a [`Splitting`] or an
    /// [`Execution`]) with `options`, starting at `t = 0` from rest (every position and velocity
    /// zero, none given) unless told otherwise.
    #[must_use]
    pub fn new(
        graph: Interconnection,
        execution: impl Into<Execution>,
        options: IntegratorOptions,
    ) -> Self {
        let execution = execution.into();
        let initial = graph
            .subsystems()
            .iter()
            .map(|s| {
                let n = s.model().dim();
                PartStart {
                    q: vec![0.0; n],
                    v: vec![0.0; n],
                    given_q: vec![false; n],
                    given_v: vec![false; n],
                }
            })
            .collect();
        Self {
            offsets: graph.coordinate_offsets(),
            graph,
            execution,
            options,
            t0: 0.0,
            start: Start::Given,
            initial,
            holds: Vec::new(),
            track_residual: false,
            engine: None,
            warnings: Vec::new(),
            last_residual: 0.0,
        }
    }

    /// The interconnection.
    #[must_use]
    pub fn graph(&self) -> &Interconnection {
        &self.graph
    }

    /// The integrator options.
    #[must_use]
    pub fn options(&self) -> &IntegratorOptions {
        &self.options
    }

    /// The execution (representation or staggered splitting).
    #[must_use]
    pub fn execution(&self) -> Execution {
        self.execution
    }

    /// Starts at `t0` instead of 0.
    #[must_use]
    pub fn starting_at(mut self, t0: f64) -> Self {
        self.t0 = t0;
        self.engine = None;
        self
    }

    /// Chooses the start (given values or the steady state).
    #[must_use]
    pub fn start(mut self, start: Start) -> Self {
        self.start = start;
        self.engine = None;
        self
    }

    /// Tracks the discrete constraint residual of every step (a diagnostic that re-evaluates the
    /// step equations; on for the [`crate::Probe::ConstraintResidual`] signal).
    #[must_use]
    pub fn track_residual(mut self, on: bool) -> Self {
        self.track_residual = on;
        self
    }

    fn part(&mut self, part: &str, coordinate: &str) -> Result<(usize, usize), RunError> {
        let id = self
            .graph
            .subsystem_id(part)
            .ok_or_else(|| RunError::UnknownSignal(format!("no part `{part}`")))?;
        let c = self.graph.coordinate_index(id, coordinate).ok_or_else(|| {
            RunError::UnknownSignal(format!("part `{part}` has no coordinate `{coordinate}`"))
        })?;
        self.engine = None;
        Ok((id.0, c))
    }

    /// Sets the initial position of coordinate `coordinate` of part `part` (it counts as given).
    ///
    /// # Errors
    /// When the part or coordinate does not exist.
    pub fn set_position(
        &mut self,
        part: &str,
        coordinate: &str,
        value: f64,
    ) -> Result<(), RunError> {
        let (s, c) = self.part(part, coordinate)?;
        self.initial[s].q[c] = value;
        self.initial[s].given_q[c] = true;
        Ok(())
    }

    /// Sets the initial velocity (rate) of coordinate `coordinate` of part `part`.
    ///
    /// # Errors
    /// When the part or coordinate does not exist.
    pub fn set_velocity(
        &mut self,
        part: &str,
        coordinate: &str,
        value: f64,
    ) -> Result<(), RunError> {
        let (s, c) = self.part(part, coordinate)?;
        self.initial[s].v[c] = value;
        self.initial[s].given_v[c] = true;
        Ok(())
    }

    /// Sets every part's initial positions and velocities at once (per part, in graph order);
    /// `given` says which values were stated (the others may be moved to make the start
    /// consistent).
    ///
    /// # Errors
    /// [`GraphError::InitialDimension`] when a part's vectors have the wrong length.
    pub fn set_initial(
        &mut self,
        q: &[Vec<f64>],
        v: &[Vec<f64>],
        given_q: &[Vec<bool>],
        given_v: &[Vec<bool>],
    ) -> Result<(), RunError> {
        for (s, part) in self.initial.iter_mut().enumerate() {
            let n = part.q.len();
            for (what, got) in [
                (&q.get(s), q.get(s).map(Vec::len)),
                (&v.get(s), v.get(s).map(Vec::len)),
            ] {
                let _ = what;
                if got != Some(n) {
                    return Err(GraphError::InitialDimension {
                        subsystem: self.graph.subsystems()[s].name().to_string(),
                        got: got.unwrap_or(0),
                        expected: n,
                    }
                    .into());
                }
            }
            part.q.clone_from(&q[s]);
            part.v.clone_from(&v[s]);
            part.given_q = given_q.get(s).cloned().unwrap_or_else(|| vec![true; n]);
            part.given_v = given_v.get(s).cloned().unwrap_or_else(|| vec![true; n]);
            part.given_q.resize(n, true);
            part.given_v.resize(n, true);
        }
        self.engine = None;
        Ok(())
    }

    /// Holds the potential of node `connection` at `value` while the steady state is solved
    /// (SPICE's `.ic V(node)=value` without `UIC`); the hold is released for the transient.
    pub fn hold(&mut self, connection: ConnectionId, value: f64) {
        self.holds.push((connection, value));
        self.engine = None;
    }

    /// Builds the engine and the initial state if not done yet.
    ///
    /// # Errors
    /// Assembly, an inconsistent or contradictory start, a steady state that cannot be found.
    pub fn prepare(&mut self) -> Result<(), RunError> {
        if self.engine.is_some() {
            return Ok(());
        }
        if !(self.options.h > 0.0 && self.options.h.is_finite()) {
            return Err(RunError::Settings(format!(
                "step size must be positive and finite, got {}",
                self.options.h
            )));
        }
        self.warnings.clear();
        let engine = match self.execution {
            Execution::Assembled(representation) => {
                Engine::Assembled(Box::new(self.build_assembled(representation)?))
            }
            Execution::Staggered(splitting) => {
                if self.start == Start::SteadyState {
                    return Err(RunError::Settings(
                        "a staggered run starts from given values; compute the steady state in an assembled representation".into(),
                    ));
                }
                let mut staggered = Staggered::new(&self.graph, &self.options, splitting)?;
                let q: Vec<Vec<f64>> = self.initial.iter().map(|p| p.q.clone()).collect();
                let v: Vec<Vec<f64>> = self.initial.iter().map(|p| p.v.clone()).collect();
                staggered.initialise(&q, &v, self.t0)?;
                let readouts = staggered
                    .parts()
                    .iter()
                    .map(|part| {
                        let rest = vec![0.0; part.q().len()];
                        Readout::new(
                            part.model(),
                            part.active_constraints(),
                            part.q(),
                            &rest,
                            self.t0,
                        )
                    })
                    .collect();
                Engine::Staggered(Box::new(StaggeredEngine {
                    staggered,
                    readouts,
                }))
            }
        };
        self.engine = Some(engine);
        self.last_residual = 0.0;
        Ok(())
    }

    /// The assembled engine with a consistent initial state.
    fn build_assembled(
        &mut self,
        representation: Representation,
    ) -> Result<AssembledEngine, RunError> {
        let system = Assembler::assemble(&self.graph, representation)?;
        let names: Vec<String> = self
            .graph
            .subsystems()
            .iter()
            .map(|s| s.name().to_string())
            .collect();
        let q_parts: Vec<Vec<f64>> = self.initial.iter().map(|p| p.q.clone()).collect();
        let v_parts: Vec<Vec<f64>> = self.initial.iter().map(|p| p.v.clone()).collect();
        let q = system.global_vector(&q_parts, &names)?;
        let v = system.global_vector(&v_parts, &names)?;
        let mut integrator = Integrator::new(
            system.model.clone(),
            system.constraints.clone(),
            self.options.clone(),
        )?;
        // A given start keeps its stated rates (SPICE's inductor `IC=` with `UIC`) and moves only
        // the others onto the constraints; a steady state computes every rate afresh.
        let held = if self.start == Start::Given {
            self.given_global(&system).1
        } else {
            Vec::new()
        };
        integrator.initialise_holding(&q, &v, &held, self.t0)?;
        // A model whose step matrix is singular whatever the values is refused before the first
        // step (docs/audit.md item 18). The rest of the set-up still runs: when it refuses the
        // model on its own (a loop of voltage sources of different values, an impossible start),
        // that diagnosis is the more specific one; when it fails numerically or succeeds, the
        // structural one is reported.
        let structural = integrator.check_structure().err();
        match self.prepare_assembled(system, integrator, q, v) {
            Err(e) if structural.is_some() && !e.is_numerical() => Err(e),
            result => match structural {
                Some(e) => Err(e.into()),
                None => result,
            },
        }
    }

    /// The rest of [`Simulation::build_assembled`]: the steady state or a consistent given start,
    /// the readout and the warnings.
    fn prepare_assembled(
        &mut self,
        system: AssembledSystem,
        mut integrator: Integrator<AssembledModel, AssembledConstraints>,
        mut q: Vec<f64>,
        mut v: Vec<f64>,
    ) -> Result<AssembledEngine, RunError> {
        let connection_rows = connection_active_rows(&system, integrator.active_constraints());
        if self.start == Start::SteadyState {
            let holds: Vec<(usize, f64)> = self
                .holds
                .iter()
                .filter_map(|&(c, value)| {
                    connection_rows
                        .get(c.0)
                        .copied()
                        .flatten()
                        .map(|r| (r, value))
                })
                .collect();
            let steady = SteadyState::solve(
                integrator.model(),
                integrator.active_constraints(),
                &q,
                self.t0,
                &holds,
            )?;
            if !steady.isolated {
                self.warnings.push(
                    "the steady state is not isolated: its Newton matrix is singular there, so a symmetry leaves it free to move along some direction (a body turned about the axis of gravity, a link spun about its own axis), or it is a degenerate point (a bifurcation); this is the equilibrium the proximal iteration of stiffness stepping reached from the start".to_string(),
                );
            }
            q.clone_from(&steady.q);
            v.clone_from(&steady.v);
            integrator.initialise(&q, &v, self.t0)?;
        }
        let representation = system.representation;
        let mut engine = AssembledEngine {
            start_q: integrator.q().to_vec(),
            start_v: v.clone(),
            t0: self.t0,
            system,
            integrator,
            readout: None,
            inner_readout: None,
            plan: None,
            replay_start_solve: false,
            memo: self.graph.memo().clone(),
            representation,
            connection_rows,
        };
        if self.start == Start::Given {
            // The start can violate an algebraic relation only where the readout system has a
            // redundant equation (one that restates others); without one there is nothing to
            // check, and the readout is built when a signal first needs it.
            let plan = (!engine.fully_kinetic())
                .then(|| engine.plan())
                .filter(|plan| plan.has_consistency_conditions());
            if let Some(plan) = plan {
                let given = self.given_global(&engine.system);
                let e = &mut engine;
                let readout = e.readout.insert(e.fresh_readout(plan));
                self.make_consistent(&mut e.integrator, readout, &mut q, &mut v, &given)?;
            } else {
                engine.replay_start_solve = true;
            }
        }
        self.warn_redundant(&engine.system, &engine.integrator);
        Ok(engine)
    }

    /// Warns about constraint rows dropped as linearly dependent, except the one row per closed
    /// group of nodes that is always redundant: KCL written at every node of a circuit (ground
    /// included) sums to zero, so one of its rows restates the others by construction.
    fn warn_redundant(
        &mut self,
        system: &AssembledSystem,
        integrator: &Integrator<AssembledModel, AssembledConstraints>,
    ) {
        let all = integrator.constraints().count();
        let mut is_kept = vec![false; all];
        for &r in integrator.active_constraints().kept() {
            if let Some(k) = is_kept.get_mut(r) {
                *k = true;
            }
        }
        let dropped: Vec<usize> = (0..all).filter(|&r| !is_kept[r]).collect();
        if dropped.is_empty() {
            return;
        }
        // Groups of node connections that share a coordinate (union–find over their rows).
        let nodes: Vec<usize> = (0..system.connection_count())
            .filter(|&c| {
                matches!(
                    self.graph.connections()[c],
                    dirac_graph::Connection::Node { .. }
                )
            })
            .collect();
        let mut parent: Vec<usize> = (0..nodes.len()).collect();
        fn find(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut owner: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
        for (k, &c) in nodes.iter().enumerate() {
            for &(i, _) in system.connection_entries(c).unwrap_or(&[]) {
                if let Some(&other) = owner.get(&i) {
                    let (a, b) = (find(&mut parent, k), find(&mut parent, other));
                    parent[a] = b;
                } else {
                    owner.insert(i, k);
                }
            }
        }
        // A group is closed when its rows sum to zero (every branch enters one node and leaves
        // another).
        // Rows written twice (up to sign) count once here: the second copy is the user's.
        let mut sums: std::collections::HashMap<usize, std::collections::HashMap<usize, f64>> =
            std::collections::HashMap::new();
        let mut seen: Vec<Vec<(usize, u64)>> = Vec::new();
        for (k, &c) in nodes.iter().enumerate() {
            let entries = system.connection_entries(c).unwrap_or(&[]);
            let mut key: Vec<(usize, u64)> = entries
                .iter()
                .map(|&(i, v)| (i, v.abs().to_bits()))
                .collect();
            key.sort_unstable();
            if seen.contains(&key) {
                continue;
            }
            seen.push(key);
            let g = find(&mut parent, k);
            let sum = sums.entry(g).or_default();
            for &(i, coefficient) in entries {
                *sum.entry(i).or_insert(0.0) += coefficient;
            }
        }
        let mut silent: std::collections::HashSet<usize> = sums
            .iter()
            .filter(|(_, sum)| sum.values().all(|v| v.abs() <= 1e-12))
            .map(|(g, _)| *g)
            .collect();
        let constraints = integrator.constraints();
        for row in dropped {
            let group = nodes
                .iter()
                .position(|&c| system.connection_row(c) == Some(row))
                .map(|k| find(&mut parent, k));
            if let Some(g) = group
                && silent.remove(&g)
            {
                continue;
            }
            self.warnings.push(format!(
                "constraint {} is linearly dependent on the others at the initial point; dropped",
                constraints.name(row)
            ));
        }
    }

    /// Which global positions and velocities were given (endpoint coordinates of the constraint
    /// representation follow their partner ports: not given, never moved on their own).
    fn given_global(&self, system: &AssembledSystem) -> (Vec<bool>, Vec<bool>) {
        let n = system.coordinates();
        let mut gq = vec![true; n];
        let mut gv = vec![true; n];
        for (s, part) in self.initial.iter().enumerate() {
            let o = self.offsets[s];
            gq[o..o + part.q.len()].copy_from_slice(&part.given_q);
            gv[o..o + part.v.len()].copy_from_slice(&part.given_v);
        }
        (gq, gv)
    }

    /// Checks the algebraic relations at the start; where they fail, moves the initial values
    /// that were not given (least change), warning for each, or reports the contradiction.
    fn make_consistent(
        &mut self,
        integrator: &mut Integrator<AssembledModel, AssembledConstraints>,
        readout: &mut Readout,
        q: &mut Vec<f64>,
        v: &mut Vec<f64>,
        given: &(Vec<bool>, Vec<bool>),
    ) -> Result<(), RunError> {
        let t0 = self.t0;
        let violations = |integrator: &Integrator<AssembledModel, AssembledConstraints>,
                          readout: &mut Readout|
         -> Result<Vec<(ReadoutRow, f64)>, RunError> {
            readout.solve(
                integrator.model(),
                integrator.active_constraints(),
                integrator.q(),
                integrator.p(),
                t0,
            )?;
            Ok(readout.consistency_residuals(
                integrator.model(),
                integrator.active_constraints(),
                integrator.q(),
                integrator.p(),
                t0,
            ))
        };
        let first = violations(integrator, readout)?;
        let scale = readout.scale().max(f64::MIN_POSITIVE);
        let tolerance = CONSISTENCY_TOL * scale;
        let worst = |r: &[(ReadoutRow, f64)]| r.iter().fold(0.0_f64, |m, (_, x)| m.max(x.abs()));
        if worst(&first) <= tolerance {
            return Ok(());
        }
        let model = integrator.model().clone();
        let rows: Vec<ReadoutRow> = first
            .iter()
            .filter(|(_, x)| x.abs() > tolerance)
            .map(|(r, _)| *r)
            .collect();
        let involved = readout.involved(&rows);
        let describe = |kind: Unknown, q: &[f64], v: &[f64]| match kind {
            Unknown::Position(i) => format!("{} = {}", model.coordinate_name(i), q[i]),
            Unknown::Velocity(i) => format!("{}' = {}", model.coordinate_name(i), v[i]),
        };
        let candidates: Vec<Unknown> = involved
            .iter()
            .copied()
            .filter(|u| match *u {
                Unknown::Position(i) => !given.0[i],
                Unknown::Velocity(i) => !given.1[i],
            })
            .collect();
        let names: Vec<String> = involved.iter().map(|&u| describe(u, q, v)).collect();
        let relation = rows
            .iter()
            .map(|r| readout.describe_row(&model, integrator.active_constraints(), *r))
            .collect::<Vec<_>>()
            .join("; ");
        if involved.is_empty() {
            return Err(RunError::InconsistentModel(format!(
                "{relation} cannot hold together with the model's other relations whatever the initial state (a cut set of current sources, or a loop of voltage sources, fixes one value twice)"
            )));
        }
        if candidates.is_empty() {
            return Err(RunError::ContradictoryStart(format!(
                "{} (all given) violate {relation}",
                names.join(", ")
            )));
        }
        let before: Vec<String> = candidates.iter().map(|&u| describe(u, q, v)).collect();
        let mut residual = first;
        for _ in 0..CONSISTENCY_ITERATIONS {
            let r0: Vec<f64> = residual.iter().map(|(_, x)| *x).collect();
            if worst(&residual) <= REPAIR_TOL * scale {
                break;
            }
            let mut columns = Vec::with_capacity(candidates.len());
            for &u in &candidates {
                let (values, i) = match u {
                    Unknown::Position(i) => (&mut *q, i),
                    Unknown::Velocity(i) => (&mut *v, i),
                };
                let saved = values[i];
                // A step that moves the relations by FD_STEP of their own size.
                let slope = readout.sensitivity(u);
                let delta = if slope > 0.0 {
                    FD_STEP * scale / slope
                } else {
                    FD_STEP * saved.abs().max(q_scale(values)).max(f64::MIN_POSITIVE)
                };
                values[i] += delta;
                integrator.initialise(q, v, t0)?;
                let perturbed = violations(integrator, readout)?;
                match u {
                    Unknown::Position(i) => q[i] = saved,
                    Unknown::Velocity(i) => v[i] = saved,
                }
                columns.push(
                    perturbed
                        .iter()
                        .zip(&r0)
                        .map(|((_, a), b)| (a - b) / delta)
                        .collect::<Vec<f64>>(),
                );
            }
            let step = least_norm(&columns, &r0);
            if step.iter().any(|d| !d.is_finite()) {
                break;
            }
            for (&u, d) in candidates.iter().zip(&step) {
                match u {
                    Unknown::Position(i) => q[i] -= d,
                    Unknown::Velocity(i) => v[i] -= d,
                }
            }
            integrator.initialise(q, v, t0)?;
            residual = violations(integrator, readout)?;
        }
        if worst(&residual) > tolerance {
            return Err(RunError::ContradictoryStart(format!(
                "{} violate {relation}, and moving {} cannot repair it",
                names.join(", "),
                before.join(", ")
            )));
        }
        for (b, &u) in before.iter().zip(&candidates) {
            let after = describe(u, q, v);
            if *b != after {
                self.warnings.push(format!(
                    "initial value {b} is inconsistent with {relation}; set to {}",
                    after.split(" = ").nth(1).unwrap_or(&after)
                ));
            }
        }
        Ok(())
    }

    /// The natural modes of the model linearised at the current state (after
    /// [`Simulation::prepare`]: the initial or operating point), with the step size as time
    /// scale; see [`NaturalModes::analyse`].
    ///
    /// # Errors
    /// Set-up failures, a staggered execution (analyse an assembled one), a readout that cannot
    /// be computed, or [`ModesError`].
    pub fn natural_modes(&mut self) -> Result<NaturalModes, RunError> {
        self.prepare()?;
        let h = self.options.h;
        match &mut self.engine {
            Some(Engine::Assembled(e)) => {
                let n = e.integrator.model().dim();
                if n > MODAL_LIMIT {
                    // Refused before the readout solve, which costs a factorisation at this size.
                    return Err(ModesError::TooLarge {
                        coordinates: n,
                        limit: MODAL_LIMIT,
                    }
                    .into());
                }
                // The solve is on the side: the first recorded row must not depend on whether
                // the modes were asked for (the CLI asks, the library's callers need not).
                e.readout()?;
                let (integrator, Some(readout)) = (&e.integrator, e.readout.as_mut()) else {
                    return Err(RunError::Settings("readout not built".into()));
                };
                let guess = readout.start_guess();
                let solved = readout.solve(
                    integrator.model(),
                    integrator.active_constraints(),
                    integrator.q(),
                    integrator.p(),
                    integrator.t(),
                );
                readout.restore_start_guess(&guess);
                solved?;
                let modes = NaturalModes::analyse(
                    integrator.model(),
                    integrator.active_constraints(),
                    (integrator.q(), readout.velocities(), readout.multipliers()),
                    integrator.t(),
                    h,
                )?;
                Ok(modes)
            }
            _ => Err(RunError::Settings(
                "natural modes need an assembled representation (monolithic, constraint or force)"
                    .into(),
            )),
        }
    }

    /// The warnings of the set-up (call after [`Simulation::prepare`] or a run).
    #[must_use]
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The state at the current time, read by the algebraic relations.
    ///
    /// # Errors
    /// Set-up failures, or a readout that cannot be computed.
    pub fn snapshot(&mut self) -> Result<Snapshot, RunError> {
        let mut snapshot = Snapshot::default();
        self.snapshot_into(&mut snapshot, Fill::ALL, &mut Vec::new())?;
        Ok(snapshot)
    }

    /// Fills `snapshot` with the current state (reusing its buffers): always the positions, the
    /// readout (velocities and multipliers) and the momenta as `fill` asks (else left as they
    /// were); `imprecise` receives the velocities and efforts the readout did not determine to
    /// [`crate::READOUT_PRECISION`].
    fn snapshot_into(
        &mut self,
        snapshot: &mut Snapshot,
        fill: Fill,
        imprecise: &mut Vec<Entry>,
    ) -> Result<(), RunError> {
        self.prepare()?;
        let residual = self.last_residual;
        let connections = self.graph.connections().len();
        let engine = self
            .engine
            .as_mut()
            .ok_or_else(|| RunError::Settings("not prepared".into()))?;
        engine.snapshot(snapshot, connections, residual, fill, imprecise)
    }

    /// The model's first source breakpoint after `t` (a PULSE or PWL corner; `None` when there
    /// is none, before the simulation is prepared, or for a staggered run).
    #[must_use]
    pub fn next_breakpoint(&self, t: f64) -> Option<f64> {
        self.engine.as_ref().and_then(|e| e.next_breakpoint(t))
    }

    /// The time of the current state.
    #[must_use]
    pub fn time(&self) -> f64 {
        self.engine.as_ref().map_or(self.t0, Engine::time)
    }

    /// Advances one step `h` (landing on source breakpoints, cutting the step when Newton fails).
    ///
    /// # Errors
    /// The step's Newton failure, with the step, time, residual and likely cause.
    pub fn step(&mut self) -> Result<(), RunError> {
        self.prepare()?;
        let track = self.track_residual;
        let engine = self
            .engine
            .as_mut()
            .ok_or_else(|| RunError::Settings("not prepared".into()))?;
        self.last_residual = engine.step(track)?;
        Ok(())
    }

    /// Checks that this simulation can record `signals` (a staggered run has no multipliers).
    ///
    /// # Errors
    /// [`RunError::UnknownSignal`] naming the first signal it cannot record.
    pub fn check_signals(&self, signals: &[Signal]) -> Result<(), RunError> {
        if let (Execution::Staggered(_), Some(signal)) = (
            self.execution,
            signals.iter().find(|s| s.probe.needs_multipliers()),
        ) {
            return Err(RunError::UnknownSignal(format!(
                "`{}` is the multiplier of a node or joint, which a staggered run does not have; record it in the monolithic, constraint or force representation",
                signal.name
            )));
        }
        Ok(())
    }

    /// Runs to `t_end` and collects `signals` at every output time.
    ///
    /// # Errors
    /// See [`Simulation::run_into`].
    pub fn run(
        &mut self,
        t_end: f64,
        signals: &[Signal],
    ) -> Result<(Trajectory, RunSummary), RunError> {
        let mut trajectory = Trajectory::new();
        let summary = self.run_into(t_end, signals, &mut trajectory)?;
        Ok((trajectory, summary))
    }

    /// Runs from the start to `t_end` (`round((t_end − t_0)/h)` steps) and streams `signals` at
    /// every output time `t_k = t_0 + k·h` to `sink`.
    ///
    /// Values the algebraic relations cannot fix at `t_k` (index-2 quantities: the current of a
    /// capacitor across a voltage source, the potential between an inductor and a current source)
    /// are read from the two steps around `t_k`, linear in time between where each step's mean
    /// sits (the nearest two at the ends; no step is taken past `t_end`); asking for one delays
    /// each row by a step. So are values the relations fix only through a coefficient lost among
    /// the others at this state (a node potential behind an off diode:
    /// [`crate::READOUT_PRECISION`]), row by row, with a warning naming the signal.
    ///
    /// # Errors
    /// Bad settings or signals, an inconsistent start, a step or readout that fails, or the sink.
    pub fn run_into(
        &mut self,
        t_end: f64,
        signals: &[Signal],
        sink: &mut dyn Sink,
    ) -> Result<RunSummary, RunError> {
        let started = Instant::now();
        if !(t_end.is_finite() && t_end >= self.t0) {
            return Err(RunError::Settings(format!(
                "end time {t_end} must be finite and not before the start {}",
                self.t0
            )));
        }
        if signals
            .iter()
            .any(|s| matches!(s.probe, crate::Probe::ConstraintResidual))
        {
            self.track_residual = true;
        }
        self.check_signals(signals)?;
        // An engine prepared but not stepped yet (`prepare`, `natural_modes`) is the start
        // state: reuse it instead of assembling and initialising again.
        let fresh = matches!(
            &self.engine,
            Some(Engine::Assembled(e)) if e.integrator.steps_taken() == 0
        );
        if !fresh {
            self.engine = None;
        }
        self.prepare()?;
        let h = self.options.h;
        let steps = ((t_end - self.t0) / h).round() as usize;
        let names: Vec<String> = signals.iter().map(|s| s.name.clone()).collect();
        sink.begin(&names).map_err(RunError::Output)?;
        let per_signal = self.signal_entries(signals);
        // Sorted, so that a row's ill-conditioned entries are looked up, not scanned for.
        let mut read: Vec<Entry> = per_signal.iter().flatten().copied().collect();
        read.sort_unstable();
        read.dedup();
        let deferred = self.deferred_entries(&read);
        // Step means are kept when a row may need them: a deferred value, or a readout whose
        // nonlinear relations may leave a value ill-conditioned at some state.
        let track = !deferred.is_empty()
            || (!read.is_empty()
                && self
                    .engine
                    .as_mut()
                    .is_some_and(Engine::readout_judges_precision));
        let mut values = vec![0.0; signals.len()];
        let mut max_residual: f64 = 0.0;
        let fill = Fill {
            readout: !read.is_empty(),
            momenta: signals.iter().any(|s| s.probe.reads_momenta()),
        };
        // Means of the last steps, kept whenever rows read a readout: a value the state at t_k
        // does not determine precisely (`imprecise`) is read from them, as the deferred ones.
        let mut means = Means {
            steps,
            centre: self.engine.as_ref().map_or(0.5, Engine::impulse_centre),
            ..Means::default()
        };
        let mut before: Vec<f64> = Vec::new();
        let mut imprecise: Vec<Entry> = Vec::new();
        let mut completed: Vec<Entry> = Vec::new();
        let mut from_steps = FromSteps::new(signals.len());
        let mut agreement = Agreement::new(&read);
        // A staggered run keeps no constraint forces to compare with, and a run of fewer than
        // two steps has no pair of steps around a row.
        let compare = track && steps >= 2 && matches!(self.engine, Some(Engine::Assembled(_)));
        // Rows with values from the steps, in order, waiting for the steps' means they need.
        let mut pending: VecDeque<(usize, Snapshot, Vec<Entry>)> = VecDeque::new();
        let mut snapshot = Snapshot::default();
        let samples_from = sink
            .samples_from()
            .filter(|_| matches!(self.engine, Some(Engine::Assembled(_))));
        if let Some(Engine::Assembled(e)) = &mut self.engine {
            e.integrator.record_inner_states(samples_from.is_some());
        }
        let mut inner = InnerSamples::default();
        for k in 0..=steps {
            self.snapshot_into(&mut snapshot, fill, &mut imprecise)
                .map_err(|e| match e {
                    RunError::Readout(r) => RunError::Readout(r.at_step(k)),
                    other => other,
                })?;
            let t_k = self.t0 + k as f64 * h;
            completed.clone_from(&deferred);
            for entry in &imprecise {
                if read.binary_search(entry).is_ok() && !completed.contains(entry) {
                    completed.push(*entry);
                }
            }
            // With the check on, every row waits for the step after it.
            if !compare && completed.is_empty() && pending.is_empty() {
                self.emit(k, t_k, &snapshot, signals, &mut values, sink)?;
            } else {
                if !completed.is_empty() {
                    from_steps.record(t_k, &completed, &deferred, &per_signal);
                }
                pending.push_back((k, snapshot.clone(), completed.clone()));
            }
            // A run of no steps whose row 0 needs a step's mean takes one step.
            if k < steps || !pending.is_empty() && means.taken == 0 {
                max_residual = max_residual.max(self.step_with_mean(
                    track,
                    &snapshot,
                    &mut before,
                    &mut means,
                )?);
                // Not the extra step a run of no steps takes past its end for a mean.
                if let Some(from) = samples_from.filter(|_| k < steps) {
                    let entries = (&per_signal[..], &deferred[..]);
                    self.sample_inner_states(signals, entries, fill, from, &mut inner, sink)?;
                }
            }
            while let Some((row, _, entries)) = pending.front() {
                if !means.can_complete(*row, entries) || compare && !Agreement::ready(*row, &means)
                {
                    break;
                }
                let Some((row, mut values_at, entries)) = pending.pop_front() else {
                    break;
                };
                for &entry in &entries {
                    values_at.set(entry, means.value(row, entry));
                }
                let t = self.t0 + row as f64 * h;
                if compare {
                    agreement.check(row, t, &mut values_at, &entries, &means, &self.options);
                }
                self.emit(row, t, &values_at, signals, &mut values, sink)?;
            }
        }
        from_steps.warn(signals, &mut self.warnings);
        agreement.warn(signals, &per_signal, &mut self.warnings);
        self.warn_spurious_roots();
        let mut summary = self.summary();
        summary.max_constraint_residual = self.track_residual.then_some(max_residual);
        summary.wall_s = started.elapsed().as_secs_f64();
        Ok(summary)
    }

    /// Passes `sink` the signals at the ends of the substeps inside the step just taken
    /// ([`Sink::sample`]) from time `from` on: `NaN` for a signal that reads a value the state
    /// there does not determine (one of `deferred`, which the rows read from the steps, or one
    /// the readout finds imprecise; `per_signal` lists each signal's entries), and nothing for a
    /// state whose readout fails (the rows are the run's result; a sample is an extra).
    fn sample_inner_states(
        &mut self,
        signals: &[Signal],
        (per_signal, deferred): (&[Vec<Entry>], &[Entry]),
        fill: Fill,
        from: f64,
        buffers: &mut InnerSamples,
        sink: &mut dyn Sink,
    ) -> Result<(), RunError> {
        let connections = self.graph.connections().len();
        let Some(Engine::Assembled(e)) = &mut self.engine else {
            return Ok(());
        };
        for state in e.integrator.take_inner_states() {
            if state.t < from {
                continue;
            }
            let InnerSamples {
                snapshot,
                imprecise,
                values,
            } = &mut *buffers;
            if e.snapshot_at(&state, snapshot, connections, fill, imprecise)
                .is_err()
            {
                continue;
            }
            values.clear();
            for (signal, entries) in signals.iter().zip(per_signal) {
                let undetermined = entries
                    .iter()
                    .any(|entry| deferred.contains(entry) || imprecise.contains(entry));
                values.push(if undetermined {
                    f64::NAN
                } else {
                    snapshot.evaluate(&self.graph, &self.offsets, &signal.probe)
                });
            }
            sink.sample(state.t, values).map_err(RunError::Output)?;
        }
        Ok(())
    }

    fn emit(
        &self,
        k: usize,
        t: f64,
        snapshot: &Snapshot,
        signals: &[Signal],
        values: &mut [f64],
        sink: &mut dyn Sink,
    ) -> Result<(), RunError> {
        for (value, signal) in values.iter_mut().zip(signals) {
            *value = snapshot.evaluate(&self.graph, &self.offsets, &signal.probe);
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(RunError::Sim(SimError::NonFinite {
                what: signals[bad].name.clone(),
                t,
            }));
        }
        sink.row(k, t, values).map_err(RunError::Output)
    }

    /// Per signal, the snapshot entries it reads.
    fn signal_entries(&self, signals: &[Signal]) -> Vec<Vec<Entry>> {
        signals
            .iter()
            .map(|signal| {
                let entries = std::cell::RefCell::new(Vec::new());
                signal.probe.visit(
                    &self.graph,
                    &self.offsets,
                    &mut |i| entries.borrow_mut().push(Entry::Velocity(i)),
                    &mut |c| entries.borrow_mut().push(Entry::Effort(c.0)),
                );
                entries.into_inner()
            })
            .collect()
    }

    /// Entries of `read` that the algebraic relations do not fix (structurally).
    fn deferred_entries(&mut self, read: &[Entry]) -> Vec<Entry> {
        if read.is_empty() {
            return Vec::new();
        }
        let Some(engine) = &mut self.engine else {
            return Vec::new();
        };
        engine.analyse_readout();
        let engine = &*engine;
        read.iter()
            .copied()
            .filter(|entry| match *entry {
                Entry::Velocity(i) => !engine.velocity_determined(i),
                Entry::Effort(c) => !engine.effort_determined(ConnectionId(c)),
            })
            .collect()
    }

    /// Takes one step; with `track`, records its mean rates and constraint forces in `means`
    /// (from the positions of `snapshot`, the state it starts from). Returns the step's
    /// constraint residual.
    fn step_with_mean(
        &mut self,
        track: bool,
        snapshot: &Snapshot,
        before: &mut Vec<f64>,
        means: &mut Means,
    ) -> Result<f64, RunError> {
        if !track {
            self.step()?;
            return Ok(self.last_residual);
        }
        before.clone_from(&snapshot.q);
        let (t, h) = (self.time(), self.options.h);
        // Where a source corner meets the step: on either grid point (a corner there splits no
        // step) or inside it (the step lands on it in substeps). Values have a kink or a jump
        // there, so no interpolation across it is smooth.
        let near = |from: f64, to: f64| {
            self.engine
                .as_ref()
                .and_then(|e| e.next_breakpoint(from))
                .is_some_and(|b| b <= to)
        };
        let margin = BREAKPOINT_MARGIN * h;
        let mut corner = Corners {
            start: near(t - margin, t + margin),
            inside: near(t + margin, t + h - margin),
            end: near(t + h - margin, t + h + margin),
            split: false,
            after_split: false,
        };
        let substeps = |s: &Self| s.engine.as_ref().map_or(0, Engine::extra_substeps);
        let before_substeps = substeps(self);
        self.step()?;
        // A step taken in substeps (a ramp after a corner or at the start, a refinement of the
        // truncation-error control, a cut), and the step after one, gives no constraint force
        // centred where a regular step's is: the substeps' impulses sit elsewhere, and the next
        // step's first block carries the share of the last substep (a PULSE's node read from
        // such means came out at 3/4 of its flat top, a DC supply's at 5/8 after a refinement).
        // Its mean rate is a mean like any other.
        corner.split = substeps(self) > before_substeps;
        corner.after_split = means.last.back().is_some_and(|m| m.corner.split);
        means.record(|mean| {
            mean.corner = corner;
            self.step_mean_into(before, h, mean)
        })?;
        Ok(self.last_residual)
    }

    /// Writes into `mean` the mean rates and constraint forces over the step just taken from
    /// positions `before` (reusing its buffers).
    fn step_mean_into(&self, before: &[f64], h: f64, mean: &mut StepMean) -> Result<(), RunError> {
        let engine = self
            .engine
            .as_ref()
            .ok_or_else(|| RunError::Settings("not prepared".into()))?;
        engine.positions_into(&mut mean.rates);
        for (rate, b) in mean.rates.iter_mut().zip(before) {
            *rate = (*rate - b) / h;
        }
        engine.mean_efforts_into(self.graph.connections().len(), h, &mut mean.efforts);
        Ok(())
    }

    /// Warns when steps landed on roots of a rigid body's step equations that the motion does
    /// not take (they were cut), or else when steps turned a body by more than 0.25 rad (checked
    /// and kept): either way the step is long for the rotation. A step that turns a body by `θ`
    /// reads its rate to about `θ²/6` (a principal spin's discrete rate is `sin θ/h` for a mean
    /// rate `θ/h`): 1 % at 0.25 rad.
    fn warn_spurious_roots(&mut self) {
        let summary = self.counters();
        if summary.spurious_roots > 0 {
            self.warnings.push(format!(
                "{} step(s) landed on a root of a rigid body's step equations that the motion does not take (a turn of a quarter turn or more, or far from two half steps; {} step(s) turned a body by more than 0.25 rad and were checked) and were cut: h = {:e} is long for the rotation, and the run's accuracy there is coarse; use a smaller h, or the truncation-error refinement (`--refine`) to control it",
                summary.spurious_roots, summary.turn_checks, self.options.h
            ));
        } else if summary.turn_checks > 0 {
            self.warnings.push(format!(
                "{} step(s) turned a body by more than 0.25 rad (each checked against two half steps and kept): h = {:e} resolves the rotation coarsely (a step turning a body by θ is off its rate by about θ²/6, 1 % at 0.25 rad); use a smaller h (the truncation-error refinement, `--refine`, cuts the steps whose error it estimates, which a steady spin does not show)",
                summary.turn_checks, self.options.h
            ));
        }
    }

    /// Counters so far.
    #[must_use]
    pub fn summary(&self) -> RunSummary {
        RunSummary {
            warnings: self.warnings.clone(),
            ..self.counters()
        }
    }

    /// [`Simulation::summary`] without the warnings.
    fn counters(&self) -> RunSummary {
        let mut summary = RunSummary::default();
        if let Some(engine) = &self.engine {
            engine.add_counters(&mut summary);
        }
        summary
    }

    /// Positions of every part at the current time, concatenated in graph order (the same
    /// layout in every representation).
    #[must_use]
    pub fn positions(&self) -> Vec<f64> {
        self.engine
            .as_ref()
            .map_or_else(Vec::new, Engine::positions)
    }

    /// Momenta of every part at the current time, concatenated in graph order (endpoint momenta
    /// of the constraint representation pulled back to their partner ports).
    #[must_use]
    pub fn momenta(&self) -> Vec<f64> {
        self.engine.as_ref().map_or_else(Vec::new, Engine::momenta)
    }

    /// [`Simulation::positions`] and [`Simulation::momenta`] into the given buffers (cleared
    /// first; both empty before [`Simulation::prepare`]). A loop that reads the state of an
    /// assembled run after every [`Simulation::step`] this way allocates nothing (a staggered
    /// run still gathers its momenta into a new vector).
    pub fn state_into(&self, positions: &mut Vec<f64>, momenta: &mut Vec<f64>) {
        positions.clear();
        momenta.clear();
        if let Some(engine) = &self.engine {
            engine.positions_into(positions);
            engine.momenta_into(momenta);
        }
    }

    /// The assembled system and its integrator (for diagnostics), if the execution is assembled
    /// and prepared.
    #[must_use]
    pub fn assembled(
        &self,
    ) -> Option<(
        &AssembledSystem,
        &Integrator<AssembledModel, AssembledConstraints>,
    )> {
        match &self.engine {
            Some(Engine::Assembled(e)) => Some((&e.system, &e.integrator)),
            _ => None,
        }
    }
}

/// Relative size of an algebraic relation's residual at the start above which the start counts
/// as inconsistent (round-off of the readout is ~1e-15 relative).
const CONSISTENCY_TOL: f64 = 1e-9;

/// Relative residual the repair of an inconsistent start aims for (round-off of the relations).
const REPAIR_TOL: f64 = 1e-14;

/// Gauss–Newton iterations of the consistent-start repair (one suffices for linear relations up
/// to the finite-difference round-off; a second reaches round-off).
const CONSISTENCY_ITERATIONS: usize = 4;

/// Relative finite-difference step of the repair's sensitivities (exact for linear relations).
const FD_STEP: f64 = 1e-6;

fn q_scale(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// An initial value that enters an algebraic relation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Unknown {
    /// Global position `i`.
    Position(usize),
    /// Global velocity `i`.
    Velocity(usize),
}

/// The minimum-norm `x` with `Σ_j columns[j]·x_j = r` (least squares when inconsistent):
/// `x = Gᵀ (G Gᵀ)⁻¹ r`, by Gaussian elimination with partial pivoting on the small Gram matrix.
fn least_norm(columns: &[Vec<f64>], r: &[f64]) -> Vec<f64> {
    let m = r.len();
    let mut gram = vec![vec![0.0; m + 1]; m];
    for (a, row) in gram.iter_mut().enumerate() {
        for b in 0..m {
            row[b] = columns.iter().map(|c| c[a] * c[b]).sum();
        }
        row[m] = r[a];
    }
    let trace: f64 = (0..m)
        .map(|a| gram[a][a])
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    for row in gram.iter_mut().enumerate() {
        row.1[row.0] += 1e-14 * trace;
    }
    for col in 0..m {
        let pivot = (col..m)
            .max_by(|&a, &b| gram[a][col].abs().total_cmp(&gram[b][col].abs()))
            .unwrap_or(col);
        gram.swap(col, pivot);
        let p = gram[col][col];
        if p == 0.0 {
            continue;
        }
        let (top, bottom) = gram.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for row in bottom.iter_mut() {
            let f = row[col] / p;
            for (x, y) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * y;
            }
        }
    }
    let mut y = vec![0.0; m];
    for row in (0..m).rev() {
        let s: f64 = (row + 1..m).map(|k| gram[row][k] * y[k]).sum();
        y[row] = if gram[row][row] == 0.0 {
            0.0
        } else {
            (gram[row][m] - s) / gram[row][row]
        };
    }
    columns
        .iter()
        .map(|c| c.iter().zip(&y).map(|(a, b)| a * b).sum())
        .collect()
}

/// The active row (in the integrator's pruned set) of each connection, if it has one.
fn connection_active_rows<C: Constraints>(
    system: &AssembledSystem,
    active: &RowSubset<C>,
) -> Vec<Option<usize>> {
    // Active index of each full row (a table: a search per connection is quadratic on a
    // 10⁵-node circuit).
    let mut active_of = vec![None; system.constraint_rows()];
    for (k, &row) in active.kept().iter().enumerate() {
        if let Some(slot) = active_of.get_mut(row) {
            *slot = Some(k);
        }
    }
    (0..system.connection_count())
        .map(|c| {
            system
                .connection_row(c)
                .and_then(|row| active_of.get(row).copied().flatten())
        })
        .collect()
}

/// The means of the last steps of a run, and how a value at `t_k` is read from them (see
/// [`Simulation::run_into`]).
#[derive(Default)]
struct Means {
    /// Steps of the run (`N`): means `m_0 … m_{N−1}`, step `j` from `t_j` to `t_{j+1}`.
    steps: usize,
    /// Where a step's mean constraint force sits in it ([`Integrator::impulse_centre`]).
    centre: f64,
    /// Steps taken so far (the index of the next mean).
    taken: usize,
    /// The last [`Means::KEPT`] means, oldest first.
    last: VecDeque<StepMean>,
}

impl Means {
    /// Means kept: row `k` reads steps `k − 2` to `k + 1` (the step before its pair, the pair,
    /// and the step after it, a corner row's second pair); rows 0 and 1 read steps 0 to 3.
    const KEPT: usize = 4;

    /// Records the next step's mean as `fill` writes it, into the buffers of the oldest one once
    /// [`Means::KEPT`] are held (it is no longer needed).
    fn record(
        &mut self,
        fill: impl FnOnce(&mut StepMean) -> Result<(), RunError>,
    ) -> Result<(), RunError> {
        let mut mean = if self.last.len() == Self::KEPT {
            self.last.pop_front().unwrap_or_default()
        } else {
            StepMean::default()
        };
        fill(&mut mean)?;
        self.last.push_back(mean);
        self.taken += 1;
        Ok(())
    }

    /// The two steps `(a, a + 1)` whose means give `entry` at `t_k` (`None`: a single step).
    /// Around `t_k` they are steps `k − 1` and `k`; at the ends the nearest two. A constraint
    /// force skips step 0 when the run has three or more: its impulse lacks the share of the
    /// step before the start (the (+) step's first block carries it), so it holds only part of
    /// the force.
    fn pair(&self, k: usize, entry: Entry) -> Option<usize> {
        let n = self.steps;
        if n < 2 {
            return None;
        }
        let low = usize::from(matches!(entry, Entry::Effort(_)) && n >= 3);
        Some(k.saturating_sub(1).clamp(low, n - 2))
    }

    /// The mean of step `j`, if kept.
    fn mean(&self, j: usize) -> Option<&StepMean> {
        let oldest = self.taken.checked_sub(self.last.len())?;
        self.last.get(j.checked_sub(oldest)?)
    }

    /// Whether the means row `k` needs for `entries` have been taken.
    fn can_complete(&self, k: usize, entries: &[Entry]) -> bool {
        entries.iter().all(|&entry| match self.pair(k, entry) {
            Some(a) => self.taken >= a + 2,
            None => self.taken >= 1,
        })
    }

    /// `entry` at `t_k`: linear in time through the means of its two steps, a rate centred at
    /// `½` of its step, a constraint force at [`Means::centre`] (`O(h²)`).
    fn value(&self, k: usize, entry: Entry) -> f64 {
        match self.pair(k, entry) {
            Some(a) => match (self.mean(a), self.mean(a + 1)) {
                (Some(first), Some(second)) => {
                    let centre = match entry {
                        Entry::Velocity(_) => 0.5,
                        Entry::Effort(_) => self.centre,
                    };
                    let (x, y) = (first.get(entry), second.get(entry));
                    x + (k as f64 - a as f64 - centre) * (y - x)
                }
                _ => f64::NAN,
            },
            None => self.mean(0).map_or(f64::NAN, |m| m.get(entry)),
        }
    }
}

/// Per signal, the output rows where a value it reads was not determined by the state at `t_k`
/// to [`crate::READOUT_PRECISION`] and came from the steps instead: the run's warning.
struct FromSteps {
    /// Rows and the first time, per signal.
    rows: Vec<(usize, f64)>,
}

impl FromSteps {
    fn new(signals: usize) -> Self {
        Self {
            rows: vec![(0, f64::NAN); signals],
        }
    }

    /// Counts row `t` for every signal that reads one of `completed` that is not `deferred`
    /// (those are documented, not a finding of this run).
    fn record(
        &mut self,
        t: f64,
        completed: &[Entry],
        deferred: &[Entry],
        per_signal: &[Vec<Entry>],
    ) {
        for (count, entries) in self.rows.iter_mut().zip(per_signal) {
            if entries
                .iter()
                .any(|e| completed.contains(e) && !deferred.contains(e))
            {
                if count.0 == 0 {
                    count.1 = t;
                }
                count.0 += 1;
            }
        }
    }

    fn warn(&self, signals: &[Signal], warnings: &mut Vec<String>) {
        for ((rows, first), signal) in self.rows.iter().zip(signals) {
            if *rows > 0 {
                warnings.push(format!(
                    "`{}` at {rows} step time(s) t_k (first t = {}) is not determined precisely by the state at t_k (a condition number above 1e6: it depends on the state only through a coefficient lost among the others, e.g. a node behind an off diode; or the relations' Newton iteration cycled at round-off, e.g. a diode's diffusion charge without junction charge): read there from the means of the adjacent steps, accurate to O(h²)",
                    signal.name,
                    crate::error::Time(*first),
                ));
            }
        }
    }
}

/// Largest disagreement, as a share of the value's size (a potential's largest `|value|` from the
/// steps so far, a rate's local size: see [`LOCAL_FLOOR`]), between a value read from the state
/// at `t_k` and the same value from the means of the two steps around `t_k` that keeps the
/// state's value; beyond it the row takes the steps' value and the run warns. Both are
/// second-order samples of one smooth value, so on a resolved run they differ by `O(h²)`:
/// measured at most 4 % of the value's largest size on the bundled netlists away from source
/// corners (see [`Agreement::from_steps`] for the rows near a corner), 25 % where
/// `diode_pulse_charge.cir`'s junction snaps off within one step (an event ngspice at the same
/// step does not resolve either). A state carrying a mode faster than the step that the
/// method does not damp (a current left in a winding behind a diode that switched off, which
/// Gauss methods keep since `R(∞) = +1`) makes them differ by more than the value itself: 185 %
/// on `diode_transformer.cir` under gauss2.
const AGREEMENT: f64 = 0.1;

/// [`AGREEMENT`] for a signal after its first row that took the steps' value: the mode found
/// decays over many steps (like `1/k` under gauss2), so its later disagreements are smaller but
/// no less wrong.
const AGREEMENT_AFTER: f64 = 0.01;

/// The steps' value of a potential is an interpolation of their means, off by about an eighth of
/// their second difference where the value is smooth; a disagreement below this many second
/// differences (a value growing tenfold per step at a diode's first turn-on, from 1e-11 V) is no
/// finding.
const CURVATURE: f64 = 8.0;

/// [`AGREEMENT_AFTER`] under a method for which [`means_average_out`]: the steps' means are then
/// the better value wherever they differ from the state by more than their own uncertainty (the
/// margin of [`CURVATURE_AFTER`]). On the sine clamp of [`CURVATURE_AFTER`] the source current's
/// worst error against ngspice at h/50 after the first period went from 1.2e-5 A (at 1 %) to
/// 1.05e-6 A, the accuracy of the charge's own differences.
const AGREEMENT_ALTERNATING: f64 = 1e-3;

/// [`CURVATURE`] for a signal after its first row that took the steps' value, under a method for
/// which [`means_average_out`]. The steps' interpolation is off by about an eighth of a second
/// difference, so one second difference is still eight times that; a state that carries the mode
/// off by more is the worse value. On a diode clamp whose junction mode rings under the midpoint
/// rule (`SIN(0 5 10k)` into 100 nF and a diode with `CJO`, `TT`, `RS`, h = 0.1 µs) the state's
/// source current sat at 0.98 of eight second differences from the steps' (2 % of the current,
/// every period) where the steps' value was within 3e-7 A of ngspice's at h/50. Not under gauss2
/// (`R(∞) = +1`: the means carry a lingering mode as the state does) nor Gauss 3 (its state is more
/// accurate than the means at a switching instant): taking the means at one second difference
/// made `diode_tripler.cir`'s source current worse at all 11 and 10 rows it changed.
const CURVATURE_AFTER: f64 = 1.0;

/// Time constant, as a share of `h`, of the decay whose one-step factor tells whether the method
/// makes modes far faster than the step alternate.
const STIFF_PROBE: f64 = 1e-6;

/// Whether the steps' means are the better value where they and a state carrying a fast mode
/// disagree: the method makes modes far faster than the step alternate (`R(∞) < 0`), which the
/// means of adjacent steps average out, and it is of second order, so that their `O(h²)`
/// interpolation is as accurate as the state would be without the mode. (Gauss 3 alternates too,
/// but its state is of order 6.)
fn means_average_out(options: &IntegratorOptions) -> bool {
    options
        .discretisation
        .order()
        .max(options.composition.order())
        <= 2
        && MethodResponse::decay(options, STIFF_PROBE * options.h).is_some_and(|r| r < 0.0)
}

/// A rate's size in the test of [`AGREEMENT`] is the largest `|value|` of the means it is read
/// from, but not below this share of its largest size over the run so far: where it passes
/// close to zero the state and the steps may differ by round-off of its size elsewhere.
const LOCAL_FLOOR: f64 = 1e-3;

/// Share of the largest rate read below which a rate's disagreement is round-off (a chain's
/// out-of-plane rates sit at 1e-27 and move by 1e-30 between the state and the steps).
const RATE_ROUND_OFF: f64 = 1e-9;

/// A value at a row from the steps' means ([`Agreement::from_steps`]).
struct FromMeans {
    value: f64,
    /// A disagreement below it is no finding (the interpolation's own uncertainty).
    margin: f64,
    /// The largest `|value|` of the means used and of the value itself.
    local: f64,
}

impl FromMeans {
    fn new(value: f64, margin: f64, used: &[f64]) -> Self {
        let local = used.iter().fold(value.abs(), |m, u| m.max(u.abs()));
        Self {
            value,
            margin,
            local,
        }
    }
}

/// Share of `h` by which a breakpoint may sit outside a step and still count as on its end.
const BREAKPOINT_MARGIN: f64 = 1e-9;

/// Rows of a value that took the steps' value, the first time, the largest difference and the
/// size it was judged against there.
type Replaced = (usize, f64, f64, f64);

/// Per value read (a potential or a rate): its value from the state at `t_k` against its value
/// from the adjacent steps' means where those are a smooth sample (see
/// [`Agreement::from_steps`] and [`AGREEMENT`]); a row where they disagree beyond it takes the
/// steps' value, and the run warns.
struct Agreement {
    /// The values read.
    entries: Vec<Entry>,
    /// Per value: the largest `|value|` from the steps so far (the scale of the test).
    scale: Vec<f64>,
    /// Per value: rows that took the steps' value, the first time, the largest difference and
    /// the size it was judged against there.
    replaced: Vec<Replaced>,
    /// The largest `|value|` from the steps so far of any rate read.
    rates_scale: f64,
    /// [`means_average_out`] for the run's method, asked once a signal first takes the steps'
    /// value.
    alternates: Option<bool>,
    /// Per value, for the row being checked: the steps' value and the state's, where both are
    /// read (kept between rows for its storage).
    row: Vec<Option<(FromMeans, f64)>>,
    /// Per value: rows next to a corner or the start, where the steps give no value to take,
    /// whose state lies far outside the spread of the clean steps around them
    /// ([`Agreement::outlier`]); judged against the value's size at the end of the run.
    outliers: Vec<Vec<Outlier>>,
}

/// A row's value outside its clean steps' spread: the time, the excess, the steps' lowest and
/// highest value, and the share of the value's size the excess must exceed.
type Outlier = (f64, f64, f64, f64, f64);

/// A state's value next to a corner is a gross outlier when it lies outside the values of the
/// clean steps around it by more than this many times their spread…
const OUTLIER_SPREAD: f64 = 10.0;

/// …and by more than this share of the value's size (the largest `|value|` of those steps and of
/// the value's steps so far).
const OUTLIER_SIZE: f64 = 0.5;

/// [`OUTLIER_SIZE`] where a single step around the row is a clean sample.
const OUTLIER_SINGLE: f64 = 2.0;

impl Agreement {
    fn new(read: &[Entry]) -> Self {
        Self {
            scale: vec![0.0; read.len()],
            replaced: vec![(0, f64::NAN, 0.0, 0.0); read.len()],
            entries: read.to_vec(),
            rates_scale: 0.0,
            alternates: None,
            row: Vec::with_capacity(read.len()),
            outliers: vec![Vec::new(); read.len()],
        }
    }

    /// Whether `state`, `entry`'s value at row `k` from the state, lies outside the values of the
    /// steps around it that are a clean sample of it (no corner inside, for a potential none
    /// touching it and no substeps; among steps `k − 2 … k + 1`, and only those reached from
    /// `t_k` without passing a source corner: beyond one the motion is another, and a source's
    /// node at t = 0 was flagged against its value after the pulse's first edge) by more than
    /// [`OUTLIER_SPREAD`] times their spread: `Some((excess, lowest, highest, share))`, the
    /// excess to be judged against `share` of the value's size over the whole run
    /// ([`Agreement::warn`]). Used where [`Agreement::from_steps`] gives no value (a row next to
    /// a source corner or the start), so that such a row is not silently wrong: a mode the
    /// method does not damp, excited by a switching event inside a step (a diode turning off),
    /// can put the state's value hundreds of times outside the motion there (docs/audit.md
    /// item 52).
    fn outlier(k: usize, entry: Entry, state: f64, means: &Means) -> Option<(f64, f64, f64, f64)> {
        let a = means.pair(k, entry)?;
        let (lo, hi) = (a.saturating_sub(1), a + 2);
        let is_clean = |m: &StepMean| match entry {
            Entry::Effort(_) => !m.corner.disturbs_forces(),
            Entry::Velocity(_) => !m.corner.inside,
        };
        let mut clean: Vec<f64> = Vec::new();
        // Forward from t_k: steps k, k + 1, … up to a corner.
        for j in k.max(lo)..=hi {
            let Some(m) = means.mean(j) else { break };
            if m.corner.inside || j > k && m.corner.start {
                break;
            }
            if is_clean(m) {
                clean.push(m.get(entry));
            }
            if m.corner.end {
                break;
            }
        }
        // Backward: steps k − 1, k − 2, … down to a corner.
        for j in (lo..k.min(hi + 1)).rev() {
            let Some(m) = means.mean(j) else { break };
            if m.corner.inside || j + 1 < k && m.corner.end {
                break;
            }
            if is_clean(m) {
                clean.push(m.get(entry));
            }
            if m.corner.start {
                break;
            }
        }
        clean.retain(|v| v.is_finite());
        let lowest = clean.iter().copied().fold(f64::INFINITY, f64::min);
        let highest = clean.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let excess = (lowest - state).max(state - highest);
        // One clean step (the others touch the corner or its substeps) says little of the
        // motion's spread there: only a value beyond twice the whole range is flagged.
        let share = match clean.len() {
            0 => return None,
            1 => OUTLIER_SINGLE,
            _ => OUTLIER_SIZE,
        };
        (excess > OUTLIER_SPREAD * (highest - lowest)).then_some((excess, lowest, highest, share))
    }

    /// Whether the two steps after row `k` have been taken (its values can be compared: a row
    /// on a source corner is compared with the pairs on both sides of it; a potential's pair is
    /// never earlier than a rate's).
    fn ready(k: usize, means: &Means) -> bool {
        means
            .pair(k, Entry::Effort(0))
            .is_none_or(|a| means.taken >= (a + 3).min(means.steps))
    }

    /// `entry` at row `k` from the steps' means, and the size of a disagreement with the state
    /// that is no finding (`None`: the steps give no smooth sample of it there).
    ///
    /// Away from corners it is the interpolation of [`Means::value`], with [`CURVATURE`] second
    /// differences of the means as the margin. A step's mean rate is the mean over it of a value
    /// that is smooth unless a corner sits inside it, so a corner between the pair or inside one
    /// of the three steps puts a kink where the interpolation or its curvature assumes none (one
    /// between the first step and the pair only enlarges the curvature: the safe side). A rate on
    /// a corner row is the mean of its extrapolations from the pairs on either side, with
    /// [`CURVATURE`] times their difference as the margin (a value that jumps there is left to the
    /// state). A constraint force carries the impulse of a corner on the grid point it sits at,
    /// so it takes no step that touches one, nor a ramp's step or the step after it.
    fn from_steps(k: usize, entry: Entry, means: &Means) -> Option<FromMeans> {
        let a = means.pair(k, entry)?;
        let before = means.mean(a.checked_sub(1)?)?;
        let (x, y) = (means.mean(a)?, means.mean(a + 1)?);
        let inside = before.corner.inside || x.corner.inside || y.corner.inside;
        match entry {
            Entry::Effort(_) if [before, x, y].iter().any(|m| m.corner.disturbs_forces()) => None,
            Entry::Velocity(_) if inside => None,
            Entry::Velocity(_) if x.corner.end => {
                // Row k on a corner: the pairs (k − 2, k − 1) and (k, k + 1).
                let after = means.mean(a + 2)?;
                if a + 1 != k || before.corner.end || after.corner.start || after.corner.inside {
                    return None;
                }
                let left = before.get(entry) + 1.5 * (x.get(entry) - before.get(entry));
                let right = y.get(entry) - 0.5 * (after.get(entry) - y.get(entry));
                Some(FromMeans::new(
                    0.5 * (left + right),
                    CURVATURE * (left - right).abs(),
                    &[before, x, y, after].map(|m| m.get(entry)),
                ))
            }
            _ => {
                let [b, x, y] = [before, x, y].map(|m| m.get(entry));
                let curvature = (y - 2.0 * x + b).abs();
                Some(FromMeans::new(
                    means.value(k, entry),
                    CURVATURE * curvature,
                    &[b, x, y],
                ))
            }
        }
    }

    /// Compares row `k`'s values read from the state (not those in `completed`) with the
    /// steps' values, and takes the steps' value where they disagree beyond [`AGREEMENT`].
    fn check(
        &mut self,
        k: usize,
        t: f64,
        values_at: &mut Snapshot,
        completed: &[Entry],
        means: &Means,
        options: &IntegratorOptions,
    ) {
        let Self {
            entries,
            scale,
            replaced,
            rates_scale,
            alternates,
            row,
            outliers,
        } = self;
        // The row's values and the scales first: a rate is judged against the largest rate
        // read so far, this row's included, whatever the order the rates are listed in (a
        // chain's rate that is zero by symmetry, listed before the others, was judged against
        // round-off alone at the first row compared).
        row.clear();
        for ((&entry, scale), outlier) in entries
            .iter()
            .zip(scale.iter_mut())
            .zip(outliers.iter_mut())
        {
            let steps = (!completed.contains(&entry))
                .then(|| Self::from_steps(k, entry, means))
                .flatten();
            if steps.is_none()
                && !completed.contains(&entry)
                && let Some(state) = values_at.get(entry)
                && let Some((excess, lowest, highest, share)) =
                    Self::outlier(k, entry, state, means)
            {
                outlier.push((t, excess, lowest, highest, share));
            }
            let read = steps.zip(values_at.get(entry));
            if let Some((steps, _)) = &read {
                *scale = scale.max(steps.value.abs());
                if let Entry::Velocity(_) = entry {
                    *rates_scale = rates_scale.max(*scale);
                }
            }
            row.push(read);
        }
        for (((&entry, scale), replaced), read) in
            entries.iter().zip(scale).zip(replaced).zip(row.drain(..))
        {
            let Some((
                FromMeans {
                    value: steps,
                    margin,
                    local,
                },
                state,
            )) = read
            else {
                continue;
            };
            let difference = (state - steps).abs();
            // Once a signal's state has been found carrying such a mode, it is trusted less; under
            // a second-order method that makes the mode alternate, the steps' means average it
            // out to the state's own order, and they are taken at their own uncertainty.
            let (share, margin) = if replaced.0 == 0 {
                (AGREEMENT, margin)
            } else if *alternates.get_or_insert_with(|| means_average_out(options)) {
                (AGREEMENT_ALTERNATING, margin * CURVATURE_AFTER / CURVATURE)
            } else {
                (AGREEMENT_AFTER, margin)
            };
            // A potential or constraint force is judged against its largest size: the state's
            // value and the steps' differ by 4.9 % of it on `motor_arm.toml`'s drive force, more
            // than its local size allows. A rate is judged against its local size, bounded
            // below by the round-off of the largest rate read.
            let size = match entry {
                Entry::Effort(_) => *scale,
                Entry::Velocity(_) => local
                    .max(LOCAL_FLOOR * *scale)
                    .max(RATE_ROUND_OFF * *rates_scale),
            };
            if difference > share * size && difference > margin {
                values_at.set(entry, steps);
                if replaced.0 == 0 {
                    replaced.1 = t;
                }
                replaced.0 += 1;
                if difference > replaced.2 {
                    replaced.2 = difference;
                    replaced.3 = size;
                }
            }
        }
    }

    /// Warns, per signal, of the rows that took the steps' value and of those found far outside
    /// their steps' values.
    fn warn(&self, signals: &[Signal], per_signal: &[Vec<Entry>], warnings: &mut Vec<String>) {
        for (signal, entries) in signals.iter().zip(per_signal) {
            let mut rows = 0;
            let mut first = f64::NAN;
            let mut worst: Option<(f64, f64, f64)> = None;
            for ((entry, found), scale) in self.entries.iter().zip(&self.outliers).zip(&self.scale)
            {
                if !entries.contains(entry) {
                    continue;
                }
                for &(t, excess, lowest, highest, share) in found {
                    let size = scale.max(lowest.abs()).max(highest.abs());
                    if !(size > 0.0 && excess > share * size) {
                        continue;
                    }
                    if rows == 0 || t < first {
                        first = t;
                    }
                    rows += 1;
                    if worst.is_none_or(|w| excess > w.0) {
                        worst = Some((excess, lowest, highest));
                    }
                }
            }
            if let Some((excess, lowest, highest)) = worst {
                warnings.push(format!(
                    "`{}` at {rows} step time(s) t_k next to a source corner or the start (first t = {}), where no value from the steps can be taken: the state's value lies {excess:.3e} outside the values of the steps around it ({lowest:.4e} … {highest:.4e}): the state carries a mode the method does not damp, excited by an event inside a step (a diode switching off); those rows are not reliable: use a smaller step (TMAX), or another method (docs/audit.md item 52)",
                    signal.name,
                    crate::error::Time(first),
                ));
            }
        }
        // Few values, usually none, took the steps' value: look those up per signal, not every
        // value read (a 1000-section ladder reads thousands of values for thousands of signals).
        let taken: Vec<(&Entry, &Replaced)> = self
            .entries
            .iter()
            .zip(&self.replaced)
            .filter(|(_, r)| r.0 > 0)
            .collect();
        if taken.is_empty() {
            return;
        }
        for (signal, entries) in signals.iter().zip(per_signal) {
            let found = taken
                .iter()
                .filter(|(e, _)| entries.contains(e))
                .map(|(_, r)| **r)
                .max_by_key(|r| r.0);
            if let Some((rows, first, difference, scale)) = found {
                warnings.push(format!(
                    "`{}` at {rows} step time(s) t_k (first t = {}): the state at t_k and the steps around it disagree by up to {difference:.3e}, {:.0} % of the value's size {scale:.3e}: the state carries a mode faster than the step that the method does not damp (Gauss methods keep such a mode: a current left in a winding behind a diode that switched off) or an event the step does not resolve; read there from the means of the adjacent steps, accurate to O(h²) where the motion is smooth (the midpoint rule, whose stiff modes alternate and average out, or a smaller step avoids it)",
                    signal.name,
                    crate::error::Time(first),
                    100.0 * difference / scale,
                ));
            }
        }
    }
}

/// An entry of a snapshot filled from step means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Entry {
    Velocity(usize),
    Effort(usize),
}

/// Mean rates and constraint forces of one step.
#[derive(Default)]
struct StepMean {
    rates: Vec<f64>,
    efforts: Vec<Option<f64>>,
    /// Where source corners meet the step.
    corner: Corners,
}

/// Where source corners meet a step.
#[derive(Debug, Clone, Copy, Default)]
struct Corners {
    /// On the grid point it starts from.
    start: bool,
    /// Inside it.
    inside: bool,
    /// On the grid point it ends at.
    end: bool,
    /// The step was taken in substeps (a ramp, a refinement, a cut).
    split: bool,
    /// The step before it was.
    after_split: bool,
}

impl Corners {
    fn any(self) -> bool {
        self.start || self.inside || self.end
    }

    /// Whether the step's mean constraint force is no smooth sample (a corner, or substeps).
    fn disturbs_forces(self) -> bool {
        self.any() || self.split || self.after_split
    }
}

impl StepMean {
    fn get(&self, entry: Entry) -> f64 {
        match entry {
            Entry::Velocity(i) => self.rates[i],
            Entry::Effort(c) => self.efforts.get(c).copied().flatten().unwrap_or(0.0),
        }
    }
}

impl Snapshot {
    /// The value of `entry` (`None`: a connection without a constraint row).
    fn get(&self, entry: Entry) -> Option<f64> {
        match entry {
            Entry::Velocity(i) => self.v.get(i).copied(),
            Entry::Effort(c) => self.efforts.get(c).copied().flatten(),
        }
    }

    fn set(&mut self, entry: Entry, value: f64) {
        match entry {
            Entry::Velocity(i) => self.v[i] = value,
            Entry::Effort(c) => {
                if let Some(e) = self.efforts.get_mut(c) {
                    *e = Some(value);
                }
            }
        }
    }
}

/// What a snapshot computes besides the positions.
#[derive(Debug, Clone, Copy)]
struct Fill {
    /// Velocities and multipliers (a readout solve).
    readout: bool,
    /// Momenta in subsystem layout (a copy of the state).
    momenta: bool,
}

impl Fill {
    const ALL: Self = Self {
        readout: true,
        momenta: true,
    };
}

enum Engine {
    Assembled(Box<AssembledEngine>),
    Staggered(Box<StaggeredEngine>),
}

struct AssembledEngine {
    system: AssembledSystem,
    integrator: Integrator<AssembledModel, AssembledConstraints>,
    /// The readout, built when first needed (a signal that reads a rate or a multiplier, the
    /// natural modes, or a start to check).
    readout: Option<Readout>,
    /// A second readout for the states inside steps (see [`Sink::sample`]), so that reading them leaves the rows' readout, its guess and its
    /// factorisation as they were: the rows are the same with samples or without.
    inner_readout: Option<Readout>,
    /// Its structural analysis, when asked for before the readout itself.
    plan: Option<Arc<ReadoutPlan>>,
    /// The start state the readout's buffers are stamped at (as the eager set-up did).
    start_q: Vec<f64>,
    start_v: Vec<f64>,
    t0: f64,
    /// A given start whose check was skipped (nothing to check): the readout, when built before
    /// the first step, first solves at the start as that check did, so that its Newton iteration
    /// then starts from the same guess and the values read are the same to the last bit.
    replay_start_solve: bool,
    /// Where the graph keeps structural analyses (shared by its clones).
    memo: StructureMemo,
    representation: Representation,
    connection_rows: Vec<Option<usize>>,
}

/// A readout analysis stored in the graph's memo, valid for one representation and one set of
/// kept constraint rows.
struct MemoPlan {
    representation: Representation,
    kept: Vec<usize>,
    plan: Arc<ReadoutPlan>,
}

impl AssembledEngine {
    /// Whether the model is unconstrained with a kinetic term in every coordinate (the pattern
    /// of `∂²L/∂v²` holds its whole diagonal): the readout equations then match one to one
    /// (momentum `i` to velocity `i`, force balance `i` to acceleration `i`), so none is redundant
    /// and a start has nothing to check, which is known without the structural analysis.
    fn fully_kinetic(&self) -> bool {
        if self.integrator.active_constraints().count() > 0 {
            return false;
        }
        let n = self.integrator.model().dim();
        let mut hessian = dirac_core::LagrangianHessian::default();
        hessian.begin();
        self.integrator
            .model()
            .lagrangian_hessian(&self.start_q, &self.start_v, &mut hessian);
        hessian.freeze();
        let mut diagonal = vec![false; n];
        for (i, j, _) in hessian.vv.iter() {
            if i == j && i < n {
                diagonal[i] = true;
            }
        }
        diagonal.iter().all(|&d| d)
    }

    /// The readout's structural analysis: the readout's own, the graph's memo's (same
    /// representation and kept rows), or analysed now and stored there.
    fn plan(&mut self) -> Arc<ReadoutPlan> {
        if let Some(readout) = &self.readout {
            return Arc::clone(readout.plan());
        }
        if let Some(plan) = &self.plan {
            return Arc::clone(plan);
        }
        let kept = self.integrator.active_constraints().kept();
        let representation = self.representation;
        let plan = if let Some(memo) = self
            .memo
            .find(|m: &MemoPlan| m.representation == representation && m.kept == kept)
        {
            Arc::clone(&memo.plan)
        } else {
            let plan = Readout::analyse(
                self.integrator.model(),
                self.integrator.active_constraints(),
                &self.start_q,
                &self.start_v,
                self.t0,
            );
            self.memo.insert(Arc::new(MemoPlan {
                representation,
                kept: kept.to_vec(),
                plan: Arc::clone(&plan),
            }));
            plan
        };
        self.plan = Some(Arc::clone(&plan));
        plan
    }

    /// A readout of `plan` with its buffers stamped at the start state (as the eager set-up did).
    fn fresh_readout(&self, plan: Arc<ReadoutPlan>) -> Readout {
        Readout::with_plan(
            plan,
            self.integrator.model(),
            self.integrator.active_constraints(),
            &self.start_q,
            &self.start_v,
            self.t0,
        )
    }

    /// The readout, built on first use.
    ///
    /// # Errors
    /// The replayed solve at the start (see `replay_start_solve`) failing.
    fn readout(&mut self) -> Result<&mut Readout, RunError> {
        if self.readout.is_none() {
            let plan = self.plan();
            let mut readout = self.fresh_readout(plan);
            let integrator = &self.integrator;
            if std::mem::take(&mut self.replay_start_solve) && integrator.steps_taken() == 0 {
                readout.solve(
                    integrator.model(),
                    integrator.active_constraints(),
                    integrator.q(),
                    integrator.p(),
                    integrator.t(),
                )?;
                readout.consistency_residuals(
                    integrator.model(),
                    integrator.active_constraints(),
                    integrator.q(),
                    integrator.p(),
                    integrator.t(),
                );
            }
            self.readout = Some(readout);
        }
        self.readout
            .as_mut()
            .ok_or_else(|| RunError::Settings("readout not built".into()))
    }
}

/// Buffers of [`Simulation::sample_inner_states`], kept over a run.
#[derive(Default)]
struct InnerSamples {
    snapshot: Snapshot,
    imprecise: Vec<Entry>,
    values: Vec<f64>,
}

struct StaggeredEngine {
    staggered: Staggered,
    readouts: Vec<Readout>,
}

impl AssembledEngine {
    /// Fills `out` with the state `at` (positions, momenta as `fill` asks, the readout's
    /// velocities and multipliers) through the inner readout; `imprecise` receives the entries
    /// it did not determine to [`crate::READOUT_PRECISION`].
    fn snapshot_at(
        &mut self,
        at: &InnerState,
        out: &mut Snapshot,
        connections: usize,
        fill: Fill,
        imprecise: &mut Vec<Entry>,
    ) -> Result<(), RunError> {
        if !fill.readout {
            imprecise.clear();
            out.efforts.resize(connections, None);
            let state = (&at.q[..], &at.p[..], at.t);
            Self::fill_snapshot(out, &self.system, None, &[], state, fill, imprecise);
            return Ok(());
        }
        if self.inner_readout.is_none() {
            let plan = self.plan();
            self.inner_readout = Some(self.fresh_readout(plan));
        }
        let (Some(readout), integrator) = (self.inner_readout.as_mut(), &self.integrator) else {
            return Err(RunError::Settings("readout not built".into()));
        };
        readout.solve(
            integrator.model(),
            integrator.active_constraints(),
            &at.q,
            &at.p,
            at.t,
        )?;
        imprecise.clear();
        out.efforts.resize(connections, None);
        Self::fill_snapshot(
            out,
            &self.system,
            Some(readout),
            &self.connection_rows,
            (&at.q, &at.p, at.t),
            fill,
            imprecise,
        );
        Ok(())
    }

    /// Writes the state `(q, p, t)` into `out`: the parts' positions, their momenta as `fill`
    /// asks, and from `readout` (solved at that state, when given) the velocities, the
    /// positions' shifts and the connections' efforts, with the entries it did not determine
    /// precisely added to `imprecise` (`out.efforts` sized to the connections by the caller).
    fn fill_snapshot(
        out: &mut Snapshot,
        system: &AssembledSystem,
        readout: Option<&Readout>,
        connection_rows: &[Option<usize>],
        (q, p, t): (&[f64], &[f64], f64),
        fill: Fill,
        imprecise: &mut Vec<Entry>,
    ) {
        let parts = system.subsystem_coordinates();
        out.t = t;
        out.q.clear();
        out.q.extend_from_slice(&q[..parts]);
        if fill.momenta {
            out.p = system.subsystem_momenta(p);
        }
        out.v.resize(parts, 0.0);
        let Some(readout) = readout else {
            return;
        };
        out.v.copy_from_slice(&readout.velocities()[..parts]);
        for (i, shift) in readout.position_shifts() {
            if i < parts {
                out.q[i] += shift;
            }
        }
        let lambda = readout.multipliers();
        for (effort, row) in out.efforts.iter_mut().zip(connection_rows) {
            *effort = row.map(|r| lambda[r]);
        }
        if readout.plan().judges_precision() {
            imprecise.extend(
                (0..parts)
                    .filter(|&i| !readout.velocity_precise(i))
                    .map(Entry::Velocity),
            );
            imprecise.extend(
                connection_rows
                    .iter()
                    .enumerate()
                    .filter(|(_, row)| row.is_some_and(|r| !readout.multiplier_precise(r)))
                    .map(|(c, _)| Entry::Effort(c)),
            );
        }
    }
}

impl Engine {
    fn time(&self) -> f64 {
        match self {
            Self::Assembled(e) => e.integrator.t(),
            Self::Staggered(e) => e.staggered.time(),
        }
    }

    fn snapshot(
        &mut self,
        out: &mut Snapshot,
        connections: usize,
        residual: f64,
        fill: Fill,
        imprecise: &mut Vec<Entry>,
    ) -> Result<(), RunError> {
        out.residual = residual;
        imprecise.clear();
        out.efforts.resize(connections, None);
        match self {
            Self::Assembled(e) => {
                if fill.readout {
                    e.readout()?;
                    let (integrator, Some(readout)) = (&e.integrator, e.readout.as_mut()) else {
                        return Err(RunError::Settings("readout not built".into()));
                    };
                    readout.solve(
                        integrator.model(),
                        integrator.active_constraints(),
                        integrator.q(),
                        integrator.p(),
                        integrator.t(),
                    )?;
                }
                let integrator = &e.integrator;
                AssembledEngine::fill_snapshot(
                    out,
                    &e.system,
                    e.readout.as_ref().filter(|_| fill.readout),
                    &e.connection_rows,
                    (integrator.q(), integrator.p(), integrator.t()),
                    fill,
                    imprecise,
                );
                Ok(())
            }
            Self::Staggered(e) => {
                out.t = e.staggered.time();
                if fill.momenta {
                    out.p = e.staggered.momenta();
                }
                out.q.clear();
                out.v.clear();
                for (part, readout_of) in e.staggered.parts().iter().zip(&mut e.readouts) {
                    out.q.extend_from_slice(part.q());
                    if fill.readout {
                        readout_of.solve(
                            part.model(),
                            part.active_constraints(),
                            part.q(),
                            part.p(),
                            part.t(),
                        )?;
                        let offset = out.v.len();
                        out.v.extend_from_slice(readout_of.velocities());
                        imprecise.extend(
                            (0..part.q().len())
                                .filter(|&i| !readout_of.velocity_precise(i))
                                .map(|i| Entry::Velocity(offset + i)),
                        );
                    } else {
                        out.v.extend(std::iter::repeat_n(0.0, part.q().len()));
                    }
                }
                Ok(())
            }
        }
    }

    fn step(&mut self, track_residual: bool) -> Result<f64, RunError> {
        match self {
            Self::Assembled(e) => {
                e.integrator.step()?;
                Ok(if track_residual {
                    e.integrator.last_constraint_residual()
                } else {
                    0.0
                })
            }
            Self::Staggered(e) => {
                e.staggered.step()?;
                Ok(0.0)
            }
        }
    }

    fn positions(&self) -> Vec<f64> {
        let mut out = Vec::new();
        self.positions_into(&mut out);
        out
    }

    /// [`Engine::positions`] into `out` (reusing its buffer).
    fn positions_into(&self, out: &mut Vec<f64>) {
        out.clear();
        match self {
            Self::Assembled(e) => {
                out.extend_from_slice(e.system.subsystem_positions(e.integrator.q()));
            }
            Self::Staggered(e) => {
                for part in e.staggered.parts() {
                    out.extend_from_slice(part.q());
                }
            }
        }
    }

    fn momenta(&self) -> Vec<f64> {
        match self {
            Self::Assembled(e) => e.system.subsystem_momenta(e.integrator.p()),
            Self::Staggered(e) => e.staggered.momenta(),
        }
    }

    /// [`Engine::momenta`] into `out` (reusing its buffer when assembled).
    fn momenta_into(&self, out: &mut Vec<f64>) {
        match self {
            Self::Assembled(e) => e.system.subsystem_momenta_into(e.integrator.p(), out),
            Self::Staggered(e) => *out = e.staggered.momenta(),
        }
    }

    /// Substeps taken so far beyond one per step (ramps, refinements, cuts); for a staggered
    /// run, the parts' ramp substeps.
    fn extra_substeps(&self) -> usize {
        match self {
            Self::Assembled(e) => {
                let counters = e.integrator.counters();
                counters.substeps.saturating_sub(e.integrator.steps_taken())
            }
            Self::Staggered(e) => e
                .staggered
                .parts()
                .iter()
                .map(|p| p.counters().ramp_substeps)
                .sum(),
        }
    }

    /// The model's first source breakpoint after `t` (none for a staggered run, whose step
    /// means are not compared).
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        match self {
            Self::Assembled(e) => e.integrator.model().next_breakpoint(t),
            Self::Staggered(_) => None,
        }
    }

    /// See [`Integrator::impulse_centre`] (a staggered run has no constraint forces).
    fn impulse_centre(&self) -> f64 {
        match self {
            Self::Assembled(e) => e.integrator.impulse_centre(),
            Self::Staggered(_) => 0.5,
        }
    }

    /// The mean constraint force of each connection over the last step (`None` for one without
    /// a constraint row), into `out`.
    fn mean_efforts_into(&self, connections: usize, h: f64, out: &mut Vec<Option<f64>>) {
        out.clear();
        out.resize(connections, None);
        if let Self::Assembled(e) = self {
            let impulses = e.integrator.last_step_impulses();
            for (effort, row) in out.iter_mut().zip(&e.connection_rows) {
                *effort = row.and_then(|r| impulses.get(r)).map(|i| i / h);
            }
        }
    }

    /// Whether the readout judges the precision of its values (nonlinear relations; see
    /// [`ReadoutPlan::judges_precision`]).
    fn readout_judges_precision(&mut self) -> bool {
        match self {
            Self::Assembled(e) => e.plan().judges_precision(),
            Self::Staggered(e) => e.readouts.iter().any(|r| r.plan().judges_precision()),
        }
    }

    /// Makes the readout's structural analysis available to [`Engine::velocity_determined`] and
    /// [`Engine::effort_determined`].
    fn analyse_readout(&mut self) {
        if let Self::Assembled(e) = self {
            e.plan();
        }
    }

    /// Whether velocity `i` follows from the algebraic relations (after
    /// [`Engine::analyse_readout`]; assumed so before).
    fn velocity_determined(&self, i: usize) -> bool {
        match self {
            Self::Assembled(e) => e.plan.as_ref().is_none_or(|p| p.velocity_determined(i)),
            Self::Staggered(e) => {
                let mut offset = 0;
                for (part, readout) in e.staggered.parts().iter().zip(&e.readouts) {
                    let n = part.model().dim();
                    if i < offset + n {
                        return readout.velocity_determined(i - offset);
                    }
                    offset += n;
                }
                true
            }
        }
    }

    fn effort_determined(&self, c: ConnectionId) -> bool {
        match self {
            Self::Assembled(e) => e
                .connection_rows
                .get(c.0)
                .copied()
                .flatten()
                .is_none_or(|r| e.plan.as_ref().is_none_or(|p| p.multiplier_determined(r))),
            Self::Staggered(_) => true,
        }
    }

    fn add_counters(&self, summary: &mut RunSummary) {
        match self {
            Self::Assembled(e) => {
                let stats = e.integrator.stats();
                let counters = e.integrator.counters();
                summary.steps = e.integrator.steps_taken();
                summary.newton_iterations = stats.iterations;
                summary.factorisations = stats.factorisations;
                summary.readout_iterations = e.readout.as_ref().map_or(0, |r| r.stats().iterations);
                summary.breakpoint_substeps = counters.breakpoint_substeps;
                summary.step_cuts = counters.step_cuts;
                summary.ramp_substeps = counters.ramp_substeps;
                summary.refinements = counters.refinements;
                summary.substeps = counters.substeps;
                summary.turn_checks = counters.turn_checks;
                summary.spurious_roots = counters.spurious_roots;
            }
            Self::Staggered(e) => {
                for part in e.staggered.parts() {
                    let stats = part.stats();
                    let counters = part.counters();
                    summary.newton_iterations += stats.iterations;
                    summary.factorisations += stats.factorisations;
                    summary.breakpoint_substeps += counters.breakpoint_substeps;
                    summary.step_cuts += counters.step_cuts;
                    summary.ramp_substeps += counters.ramp_substeps;
                    summary.refinements += counters.refinements;
                    summary.substeps += counters.substeps;
                    summary.turn_checks += counters.turn_checks;
                    summary.spurious_roots += counters.spurious_roots;
                }
                summary.steps = e.staggered.steps_taken();
                summary.readout_iterations = e.readouts.iter().map(|r| r.stats().iterations).sum();
            }
        }
    }
}
