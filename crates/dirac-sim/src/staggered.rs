//! Staggered co-simulation: subsystems stepped one after another with frozen partners.

use dirac_core::Model;
use dirac_graph::{Assembler, FrozenCouplingModel, Interconnection, SharedConstraints};

use crate::error::SimError;
use crate::integrator::{Integrator, IntegratorOptions};

/// Order in which subsystems see their partners' updates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Splitting {
    /// Subsystem `i` sees the new values of subsystems `j < i` and the old values of `j > i`.
    GaussSeidel,
    /// Every subsystem sees its partners' values from the start of the step.
    Jacobi,
}

/// Co-simulation of an interconnection whose subsystems are joined by coupling elements only.
///
/// Each subsystem is integrated on its own; a coupling acts on it as a force with the partner port
/// frozen at its last known position and flow over the step (zero-order hold). This is what
/// co-simulation tools do, and it is *not* equivalent to the monolithic model: the difference is
/// the split error this type exists to measure.
pub struct Staggered {
    parts: Vec<Integrator<FrozenCouplingModel, SharedConstraints>>,
    splitting: Splitting,
    h: f64,
    velocity: Vec<Vec<f64>>,
    snapshot_q: Vec<Vec<f64>>,
    snapshot_v: Vec<Vec<f64>>,
}

impl Staggered {
    /// Builds the per-subsystem integrators.
    pub fn new(
        graph: &Interconnection,
        options: &IntegratorOptions,
        splitting: Splitting,
    ) -> Result<Self, SimError> {
        let plan = Assembler::staggered(graph)?;
        let mut parts = Vec::with_capacity(plan.models.len());
        for model in plan.models {
            let constraints = model.constraints();
            parts.push(Integrator::new(model, constraints, options.clone())?);
        }
        let dims: Vec<usize> = parts.iter().map(|p| p.model().dim()).collect();
        Ok(Self {
            splitting,
            h: options.h,
            velocity: dims.iter().map(|&n| vec![0.0; n]).collect(),
            snapshot_q: dims.iter().map(|&n| vec![0.0; n]).collect(),
            snapshot_v: dims.iter().map(|&n| vec![0.0; n]).collect(),
            parts,
        })
    }

    /// Consistent initialisation of every subsystem from positions and velocities.
    pub fn initialise(&mut self, q: &[Vec<f64>], v: &[Vec<f64>], t: f64) -> Result<(), SimError> {
        for (i, part) in self.parts.iter_mut().enumerate() {
            part.initialise(&q[i], &v[i], t)?;
            self.velocity[i].copy_from_slice(&v[i]);
        }
        Ok(())
    }

    fn freeze(&self, i: usize, use_snapshot: bool) {
        let model = self.parts[i].model();
        for (l, link) in model.links().iter().enumerate() {
            let j = link.partner.0;
            let (q, v) = if use_snapshot {
                (&self.snapshot_q[j][..], &self.snapshot_v[j][..])
            } else {
                (self.parts[j].q(), &self.velocity[j][..])
            };
            let x: f64 = link.partner_port.iter().map(|&(k, c)| c * q[k]).sum();
            let w: f64 = link.partner_port.iter().map(|&(k, c)| c * v[k]).sum();
            model.freeze(l, x, w);
        }
    }

    /// Advances every subsystem by one step.
    pub fn step(&mut self) -> Result<(), SimError> {
        if self.splitting == Splitting::Jacobi {
            for (j, part) in self.parts.iter().enumerate() {
                self.snapshot_q[j].copy_from_slice(part.q());
                self.snapshot_v[j].copy_from_slice(&self.velocity[j]);
            }
        }
        for i in 0..self.parts.len() {
            self.freeze(i, self.splitting == Splitting::Jacobi);
            let before = self.parts[i].q().to_vec();
            self.parts[i].step()?;
            for (k, (new, old)) in self.parts[i].q().iter().zip(&before).enumerate() {
                self.velocity[i][k] = (new - old) / self.h;
            }
        }
        Ok(())
    }

    /// The per-part integrators, in graph order.
    #[must_use]
    pub fn parts(&self) -> &[Integrator<FrozenCouplingModel, SharedConstraints>] {
        &self.parts
    }

    /// The time of the current state.
    #[must_use]
    pub fn time(&self) -> f64 {
        self.parts.first().map_or(0.0, Integrator::t)
    }

    /// Steps taken since initialisation.
    #[must_use]
    pub fn steps_taken(&self) -> usize {
        self.parts.first().map_or(0, Integrator::steps_taken)
    }

    /// Positions of every subsystem, concatenated in graph order.
    #[must_use]
    pub fn positions(&self) -> Vec<f64> {
        self.parts
            .iter()
            .flat_map(|p| p.q().iter().copied())
            .collect()
    }

    /// Momenta of every subsystem, concatenated in graph order.
    #[must_use]
    pub fn momenta(&self) -> Vec<f64> {
        self.parts
            .iter()
            .flat_map(|p| p.p().iter().copied())
            .collect()
    }
}
