//! The `[record]` quantities beyond signals: total energy, power per part, the constraint
//! residual and interaction forces, evaluated from the parts' states step by step.
//!
//! Each step `[t_k, t_{k+1}]` is summarised by its midpoint state `q̄ = (q_k + q_{k+1})/2`,
//! `v̄ = (q_{k+1} − q_k)/h`, `t̄ = t_k + h/2` (the midpoint discretisation's own quadrature point).
//! A row at `t_k` reports the mean of the two steps around `t_k`, like a rate (row 0 is
//! extrapolated), except the constraint residual and the multiplier forces of nodes and joints,
//! which belong to the step starting at `t_k`.

use dirac_graph::{Connection, Interconnection};

use super::build::{BuiltScene, Execution, Recording};
use super::error::SceneError;
use super::run::SceneSimulation;

/// How a recorded column is placed on the time grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Placement {
    /// Mean of the steps before and after `t_k`.
    Averaged,
    /// The value of the step starting at `t_k`; row 0 takes the first step's value when
    /// `first_row` is set, else it is extrapolated (a multiplier's first step is a start-up
    /// value, as for the netlist runner's node potentials).
    StepStart {
        /// Whether row 0 takes the first step's value.
        first_row: bool,
    },
}

#[derive(Debug, Clone, Copy)]
enum Column {
    Energy,
    Power(usize),
    Residual,
    /// Multiplier of a node or joint: the force it transmits (for a circuit node, its potential).
    MultiplierForce(usize),
    /// The force a coupling element exerts on its first port.
    CouplingForce(usize),
}

/// Evaluates the requested quantities of a scene's steps.
pub(crate) struct Recorder<'a> {
    graph: &'a Interconnection,
    offsets: Vec<usize>,
    columns: Vec<(String, Column)>,
    h: f64,
    q_mid: Vec<f64>,
    v_mid: Vec<f64>,
    gradient: (Vec<f64>, Vec<f64>),
    force: Vec<f64>,
}

impl<'a> Recorder<'a> {
    /// The recorder for `recording` on `built`. Forces of nodes and joints need the multipliers of
    /// an assembled representation; asking for them in a staggered run is an error.
    pub(crate) fn new(built: &'a BuiltScene, recording: &Recording) -> Result<Self, SceneError> {
        let graph = &built.graph;
        let mut columns = Vec::new();
        if recording.energy {
            columns.push(("energy".to_string(), Column::Energy));
        }
        for id in &recording.power {
            let name = graph.subsystems()[id.0].name();
            columns.push((format!("power({name})"), Column::Power(id.0)));
        }
        if recording.residuals {
            columns.push(("constraint_residual".to_string(), Column::Residual));
        }
        for id in &recording.forces {
            let connection = &graph.connections()[id.0];
            let name = format!("force({})", connection.name());
            match connection {
                Connection::Coupling { .. } => columns.push((name, Column::CouplingForce(id.0))),
                Connection::Node { .. } | Connection::Joint { .. } => {
                    if matches!(built.execution, Execution::Staggered(_)) {
                        return Err(SceneError::BadSignal {
                            at: None,
                            signal: name,
                            reason: "the force of a node or joint is its multiplier, which a staggered run does not have; record it in the monolithic, constraint or force representation".into(),
                        });
                    }
                    columns.push((name, Column::MultiplierForce(id.0)));
                }
            }
        }
        let dim = graph.subsystems().iter().map(|s| s.model().dim()).sum();
        let widest = graph
            .subsystems()
            .iter()
            .map(|s| s.model().dim())
            .max()
            .unwrap_or(0);
        let offsets = graph.coordinate_offsets();
        Ok(Self {
            graph,
            offsets,
            columns,
            h: built.h(),
            q_mid: vec![0.0; dim],
            v_mid: vec![0.0; dim],
            gradient: (vec![0.0; widest], vec![0.0; widest]),
            force: vec![0.0; widest],
        })
    }

    /// Column names, in output order.
    pub(crate) fn names(&self) -> Vec<String> {
        self.columns.iter().map(|(n, _)| n.clone()).collect()
    }

    /// Where each column sits on the time grid.
    pub(crate) fn placements(&self) -> Vec<Placement> {
        self.columns
            .iter()
            .map(|(_, c)| match c {
                Column::Residual => Placement::StepStart { first_row: true },
                Column::MultiplierForce(_) => Placement::StepStart { first_row: false },
                _ => Placement::Averaged,
            })
            .collect()
    }

    /// Values of the step from `before` (positions at `t`) to `after`, just taken by `sim`, whose
    /// constraint residual the caller has evaluated as `residual`.
    pub(crate) fn step_values(
        &mut self,
        sim: &SceneSimulation,
        before: &[f64],
        after: &[f64],
        t: f64,
        residual: f64,
        out: &mut [f64],
    ) {
        let h = self.h;
        for ((m, v), (b, a)) in self
            .q_mid
            .iter_mut()
            .zip(self.v_mid.iter_mut())
            .zip(before.iter().zip(after))
        {
            *m = 0.5 * (a + b);
            *v = (a - b) / h;
        }
        let t_mid = t + 0.5 * h;
        let wants_multipliers = self
            .columns
            .iter()
            .any(|(_, c)| matches!(c, Column::MultiplierForce(_)));
        let multipliers = sim
            .assembled()
            .filter(|_| wants_multipliers)
            .map(|(_, integrator)| integrator.last_multipliers_full());
        for (j, value) in out.iter_mut().enumerate() {
            *value = match self.columns[j].1 {
                Column::Energy => self.energy(),
                Column::Power(part) => self.power(part, t_mid),
                Column::Residual => residual,
                Column::MultiplierForce(c) => {
                    let row = sim.assembled().and_then(|(s, _)| s.connection_row(c));
                    match (row, &multipliers) {
                        (Some(r), Some(m)) => m.get(r).map_or(0.0, |l| l / h),
                        _ => 0.0,
                    }
                }
                Column::CouplingForce(c) => self.coupling_force(c, t_mid),
            };
        }
    }

    /// `Σ_parts (v̄·∂L/∂v − L)(q̄, v̄) + Σ_couplings V(x̄_a, x̄_b)`.
    fn energy(&mut self) -> f64 {
        let mut total = 0.0;
        for (s, &o) in self.graph.subsystems().iter().zip(&self.offsets) {
            let model = s.model();
            let n = model.dim();
            let (q, v) = (&self.q_mid[o..o + n], &self.v_mid[o..o + n]);
            let (lq, lv) = (&mut self.gradient.0[..n], &mut self.gradient.1[..n]);
            model.lagrangian_gradient(q, v, lq, lv);
            let pv: f64 = lv.iter().zip(v).map(|(p, w)| p * w).sum();
            total += pv - model.lagrangian(q, v);
        }
        for connection in self.graph.connections() {
            if let Connection::Coupling { a, b, element, .. } = connection
                && element.has_potential()
            {
                let x = |p| self.graph.port_value(&self.offsets, &self.q_mid, p);
                total += element.potential(x(*a), x(*b));
            }
        }
        total
    }

    /// `f(q̄, v̄, t̄)·v̄` of one part's own forces.
    fn power(&mut self, part: usize, t: f64) -> f64 {
        let s = &self.graph.subsystems()[part];
        let model = s.model();
        if !model.has_force() {
            return 0.0;
        }
        let (o, n) = (self.offsets[part], model.dim());
        let f = &mut self.force[..n];
        model.force(&self.q_mid[o..o + n], &self.v_mid[o..o + n], t, f);
        f.iter()
            .zip(&self.v_mid[o..o + n])
            .map(|(f, v)| f * v)
            .sum()
    }

    /// Force of a coupling element on its first port: `−∂V/∂x_a + f_a` at the step midpoint.
    fn coupling_force(&self, c: usize, t: f64) -> f64 {
        let Connection::Coupling { a, b, element, .. } = &self.graph.connections()[c] else {
            return 0.0;
        };
        let at = |values: &[f64], p| self.graph.port_value(&self.offsets, values, p);
        let x = [at(&self.q_mid, *a), at(&self.q_mid, *b)];
        let w = [at(&self.v_mid, *a), at(&self.v_mid, *b)];
        let mut f = 0.0;
        if element.has_potential() {
            f -= element.potential_gradient(x[0], x[1])[0];
        }
        if element.has_force() {
            f += element.force(x, w, t)[0];
        }
        f
    }
}
