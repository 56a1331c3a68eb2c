//! Time stepping for `dirac`: runs forced discrete Dirac steps with Newton's method.
//!
//! [`Integrator`] owns the state `(q_k, p_k, t_k)` of a model with constraints and advances it with
//! a [`dirac_core::ForcedDiracStep`] solved by [`dirac_solve::Newton`]. The linear solver is dense
//! for small systems and sparse LU (faer) above [`dirac_solve::DenseLu::AUTO_LIMIT`] unknowns; for linear models at fixed `h` the
//! factorisation is computed once for the whole run.

mod composition;
mod error;
mod integrator;
mod linear;
mod shooting;
mod staggered;

pub use composition::{Composition, CompositionError};
pub use dirac_core::{Discretisation, Flavour};
pub use error::SimError;
pub use integrator::{Integrator, IntegratorOptions, Scheme, StepCounters, StepReport};
pub use linear::{AutoLu, SolverChoice};
pub use shooting::ShootingIntegrator;
pub use staggered::{Splitting, Staggered};
