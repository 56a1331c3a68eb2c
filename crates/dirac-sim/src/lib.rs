//! Time stepping for `dirac`: runs forced discrete Dirac steps with Newton's method.
//!
//! [`Integrator`] owns the state `(q_k, p_k, t_k)` of a model with constraints and advances it with
//! a [`dirac_core::ForcedDiracStep`] solved by [`dirac_solve::Newton`]. The linear solver is dense
//! for small systems and sparse LU (faer) above [`dirac_solve::DenseLu::AUTO_LIMIT`] unknowns; for linear models at fixed `h` the
//! factorisation is computed once for the whole run.

mod composition;
mod derivatives;
mod error;
mod explicit;
mod integrator;
mod linear;
mod modes;
mod readout;
mod sharing;
mod shooting;
mod signal;
mod simulation;
mod staggered;
mod steady;
#[cfg(test)]
mod test_models;
mod trajectory;
mod truncation;

pub use composition::{Composition, CompositionError};
pub use dirac_core::{Discretisation, Flavour};
pub use error::{SimError, Time};
pub use integrator::{
    InnerState, Integrator, IntegratorOptions, Predictor, Scheme, StartRamp, StepCounters,
    StepReport,
};
pub use linear::{AutoLu, SolverChoice};
pub use modes::{
    FAST_DECAY_EXACT, MIN_STEPS_PER_PERIOD, MODAL_LIMIT, MethodResponse, Mode, ModeKind,
    ModesError, NaturalModes, SLOW_METHOD_DAMPING, UNSTABLE_GROWTH,
};
pub use readout::{READOUT_PRECISION, READOUT_STALL, Readout, ReadoutError, ReadoutRow};
pub use shooting::ShootingIntegrator;
pub use signal::{Probe, Signal, Snapshot};
pub use simulation::{Execution, RunError, RunSummary, Simulation, Start};
pub use staggered::{Splitting, Staggered};
pub use steady::{SteadyState, SteadyStateError};
pub use trajectory::{Sink, Trajectory};
pub use truncation::TruncationControl;
