//! Time stepping with the shooting discretisation (the paper's §3 numerics).

use dirac_core::{
    GenericModel, ShootingDiscretisation, ShootingError, ShootingStep, momentum,
    velocity_from_momentum,
};
use dirac_solve::{
    DenseLu, Newton, NewtonError, NewtonOptions, NewtonStats, NonlinearSystem, Triplets,
};

use crate::error::SimError;
use crate::integrator::StepReport;

/// Advances `(q_k, p_k, t_k)` of an unconstrained [`GenericModel`] by the forced discrete
/// Hamiltonian map of a [`ShootingDiscretisation`]:
/// `p_k = −D₁L_d − f_d⁻` is solved for `q_{k+1}` by Newton on the exact Jacobian, then
/// `p_{k+1} = D₂L_d + f_d⁺`.
///
/// Shooting failures (a degenerate Lagrangian, a shooting solve that does not converge) are
/// reported as [`SimError::Newton`] with the shooting error in `likely_cause`.
#[derive(Debug)]
pub struct ShootingIntegrator<G, const N: usize> {
    model: G,
    step: ShootingStep<N>,
    newton: Newton<DenseLu>,
    q: [f64; N],
    p: [f64; N],
    q_prev: [f64; N],
    v0: [f64; N],
    t: f64,
    k: usize,
    stats: NewtonStats,
}

/// The step equations as a [`NonlinearSystem`]; shooting failures are kept for the error report
/// and surface to Newton as non-finite values.
struct ShootingSystem<'a, G, const N: usize> {
    model: &'a G,
    step: &'a ShootingStep<N>,
    constant: bool,
    error: Option<ShootingError>,
}

impl<G: GenericModel<N>, const N: usize> NonlinearSystem for ShootingSystem<'_, G, N> {
    fn len(&self) -> usize {
        N
    }

    fn residual(&mut self, x: &[f64], r: &mut [f64]) {
        let q1: [f64; N] = std::array::from_fn(|i| x[i]);
        match self.step.residual(self.model, &q1) {
            Ok(res) => r.copy_from_slice(&res),
            Err(e) => {
                self.error = Some(e);
                r.fill(f64::NAN);
            }
        }
    }

    fn jacobian(&mut self, x: &[f64], jac: &mut Triplets) {
        let q1: [f64; N] = std::array::from_fn(|i| x[i]);
        let values = match self.step.residual_and_jacobian(self.model, &q1) {
            Ok((_, j)) => j,
            Err(e) => {
                self.error = Some(e);
                [[f64::NAN; N]; N]
            }
        };
        for (i, row) in values.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                jac.add(i, j, *v);
            }
        }
    }

    fn jacobian_is_constant(&self) -> bool {
        self.constant
    }
}

impl<G: GenericModel<N>, const N: usize> ShootingIntegrator<G, N> {
    /// An integrator at `q = 0, p = 0, t = 0` with default Newton tolerances.
    pub fn new(model: G, discretisation: ShootingDiscretisation, h: f64) -> Result<Self, SimError> {
        Self::with_newton(model, discretisation, h, NewtonOptions::default())
    }

    /// An integrator with explicit Newton tolerances.
    pub fn with_newton(
        model: G,
        discretisation: ShootingDiscretisation,
        h: f64,
        newton: NewtonOptions,
    ) -> Result<Self, SimError> {
        let step = ShootingStep::new(discretisation, h).map_err(|_| SimError::StepSize(h))?;
        Ok(Self {
            model,
            step,
            newton: Newton::new(DenseLu::new(), newton),
            q: [0.0; N],
            p: [0.0; N],
            q_prev: [0.0; N],
            v0: [0.0; N],
            t: 0.0,
            k: 0,
            stats: NewtonStats::default(),
        })
    }

    /// Sets `(q, p, t)`. The first step's guess uses the velocity of `p` (inverse Legendre
    /// transform), or `v = 0` when that cannot be computed.
    pub fn set_state(&mut self, q: [f64; N], p: [f64; N], t: f64) {
        self.q = q;
        self.p = p;
        self.v0 = velocity_from_momentum(&self.model, &q, &p).unwrap_or([0.0; N]);
        self.t = t;
        self.k = 0;
    }

    /// Sets `(q, v, t)` with `p = ∂L/∂v(q, v)`.
    pub fn initialise(&mut self, q: [f64; N], v: [f64; N], t: f64) {
        self.q = q;
        self.p = momentum(&self.model, &q, &v);
        self.v0 = v;
        self.t = t;
        self.k = 0;
    }

    /// Advances one step.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let h = self.step.step_size();
        self.step.set_start(&self.q, &self.p, self.t);
        let mut x: [f64; N] = if self.k == 0 {
            std::array::from_fn(|i| self.q[i] + h * self.v0[i])
        } else {
            std::array::from_fn(|i| 2.0 * self.q[i] - self.q_prev[i])
        };
        let mut system = ShootingSystem {
            model: &self.model,
            step: &self.step,
            constant: self.model.is_linear(),
            error: None,
        };
        let result = self.newton.solve(&mut system, &mut x);
        let shooting_error = system.error.take();
        let stats = match result {
            Ok(stats) => stats,
            Err(source) => {
                let likely_cause = likely_cause(&source, shooting_error.as_ref());
                return Err(self.newton_error(source, likely_cause));
            }
        };
        let p_next = match self.step.end_momentum(&self.model, &x) {
            Ok(p) => p,
            Err(e) => {
                let source = NewtonError::NonFiniteResidual {
                    equation: 0,
                    iterations: stats.iterations,
                };
                return Err(self.newton_error(source, format!("end momentum: {e}")));
            }
        };
        self.q_prev = self.q;
        self.q = x;
        self.p = p_next;
        self.k += 1;
        self.t = self.step.start_time() + h;
        self.stats.accumulate(&stats);
        Ok(StepReport { newton: stats })
    }

    fn newton_error(&self, source: NewtonError, likely_cause: String) -> SimError {
        SimError::Newton {
            step: self.k,
            t: self.t,
            source,
            likely_cause,
        }
    }

    /// Runs `steps` steps, calling `observe(k, t, q, p)` before the first and after every step.
    pub fn run(
        &mut self,
        steps: usize,
        mut observe: impl FnMut(usize, f64, &[f64; N], &[f64; N]),
    ) -> Result<(), SimError> {
        observe(self.k, self.t, &self.q, &self.p);
        for _ in 0..steps {
            self.step()?;
            observe(self.k, self.t, &self.q, &self.p);
        }
        Ok(())
    }

    /// `q_k`.
    #[must_use]
    pub fn q(&self) -> &[f64; N] {
        &self.q
    }

    /// `p_k`.
    #[must_use]
    pub fn p(&self) -> &[f64; N] {
        &self.p
    }

    /// `t_k`.
    #[must_use]
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Steps taken since the state was set.
    #[must_use]
    pub fn steps_taken(&self) -> usize {
        self.k
    }

    /// Newton counters accumulated since construction.
    #[must_use]
    pub fn stats(&self) -> NewtonStats {
        self.stats
    }

    /// The model.
    #[must_use]
    pub fn model(&self) -> &G {
        &self.model
    }

    /// The step equations (for diagnostics and tests).
    #[must_use]
    pub fn step_equations(&self) -> &ShootingStep<N> {
        &self.step
    }
}

fn likely_cause(error: &NewtonError, shooting: Option<&ShootingError>) -> String {
    if let Some(e) = shooting {
        return format!("shooting discretisation failed: {e}");
    }
    match error {
        NewtonError::NotConverged { .. } => {
            "Newton on q_{k+1} did not converge: the step may have no solution (a fold of the forced discrete Legendre transform) or be too large for the nonlinearity".into()
        }
        NewtonError::NonFiniteResidual { .. } => {
            "the model returned NaN or infinity: the state left the model's domain".into()
        }
        NewtonError::Linear { .. } => {
            "singular step Jacobian ∂²H/∂q0∂q1: the step size is too large or L_d is degenerate"
                .into()
        }
    }
}
