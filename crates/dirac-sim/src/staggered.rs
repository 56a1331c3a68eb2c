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

#[cfg(test)]
mod tests {
    //! One staggered step against the midpoint step solved by hand: a body of mass m at x₀ with
    //! momentum p₀, pulled by a spring κ towards a partner frozen at x_f, moves to
    //! `x₁ = (m x₀/h + p₀ − ½hκ(x₀/2 − x_f)) / (m/h + ¼hκ)` with
    //! `p₁ = m(x₁ − x₀)/h − ½hκ(x̄ − x_f)`.

    use super::*;
    use crate::test_models::Masses;
    use dirac_components::Spring;
    use dirac_core::Discretisation;
    use dirac_graph::{GraphError, Subsystem};

    const KAPPA: f64 = 3.0;

    /// Mass 1 at x = 0 and mass 2 at x = 1, at rest, joined by a spring κ (rest length 0).
    fn pair() -> Interconnection {
        let mut g = Interconnection::new();
        for (name, m) in [("a", 1.0), ("b", 2.0)] {
            g.add_subsystem(Subsystem::new(name, Masses::new(&[m], &[0.0])).with_port("x", 0))
                .unwrap();
        }
        let (a, b) = (g.port("a", "x").unwrap(), g.port("b", "x").unwrap());
        g.coupling("s", a, b, Spring::linear(KAPPA).unwrap());
        g
    }

    /// The hand-solved midpoint step: `(x₁, p₁)`.
    fn by_hand(m: f64, x0: f64, p0: f64, xf: f64, h: f64) -> (f64, f64) {
        let x1 = (m * x0 / h + p0 - 0.5 * h * KAPPA * (0.5 * x0 - xf)) / (m / h + 0.25 * h * KAPPA);
        let p1 = m * (x1 - x0) / h - 0.5 * h * KAPPA * (0.5 * (x0 + x1) - xf);
        (x1, p1)
    }

    #[test]
    fn one_step_matches_the_hand_solution() {
        let h = 0.1;
        let options = IntegratorOptions::new(Discretisation::midpoint(), h);
        let (xa, pa) = by_hand(1.0, 0.0, 0.0, 1.0, h);
        for (splitting, b_sees) in [(Splitting::GaussSeidel, xa), (Splitting::Jacobi, 0.0)] {
            let mut sim = Staggered::new(&pair(), &options, splitting).unwrap();
            sim.initialise(&[vec![0.0], vec![1.0]], &[vec![0.0], vec![0.0]], 0.0)
                .unwrap();
            sim.step().unwrap();
            let (xb, pb) = by_hand(2.0, 1.0, 0.0, b_sees, h);
            let (q, p) = (sim.positions(), sim.momenta());
            // Round-off of a few operations on order-one values (measured 1.6e-15).
            for (got, want) in [(q[0], xa), (q[1], xb), (p[0], pa), (p[1], pb)] {
                assert!(
                    (got - want).abs() <= 1e-14,
                    "{splitting:?}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn nodes_and_joints_cannot_be_staggered() {
        let mut g = pair();
        let (a, b) = (g.port("a", "x").unwrap(), g.port("b", "x").unwrap());
        g.joint("j", a, b);
        let options = IntegratorOptions::new(Discretisation::midpoint(), 0.1);
        assert!(matches!(
            Staggered::new(&g, &options, Splitting::Jacobi),
            Err(SimError::Graph(GraphError::StaggeredNeedsCouplings(name))) if name == "j"
        ));
    }
}
