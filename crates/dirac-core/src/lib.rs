//! Core of `dirac`: models, discretisations and the equations of one forced discrete Dirac step.
//!
//! - [`Model`]: a Lagrangian `L(q, v)` and a force `f(q, v, t)` with exact derivatives (hand-written
//!   for stock parts, automatic through [`AutoDiff`] for user models written as [`GenericModel`]).
//! - [`Constraints`]: constraint one-forms `ωᵃ(q)` and holonomic constraints `g(q) = 0`.
//! - [`Discretisation`]: one polynomial path plus one quadrature rule, shared by `L_d` and `f_d^±`
//!   so that the integrator is equivalence-preserving by construction.
//! - [`ForcedDiracStep`]: residual and Jacobian of one (+) or (−) forced discrete Dirac step; with no
//!   constraints it is the forced discrete Hamiltonian map.
//!
//! Notation and signs follow `shared/docs/MATH.md` (Parks & Leok, forced Dirac variational
//! integrators).

mod auto;
mod constraints;
mod discretisation;
mod model;
mod path;
mod quadrature;
mod rank;
mod shooting;
mod step;

pub use auto::{AutoDiff, GenericModel};
pub use constraints::{ConstraintKind, Constraints, LinearForms, NoConstraints};
pub use discretisation::Discretisation;
pub use model::{ForceJacobian, LagrangianHessian, Model};
pub use path::PolynomialPath;
pub use quadrature::{QuadratureKind, QuadratureRule};
pub use rank::{RowAnalysis, RowSubset, analyse_rows};
pub use shooting::{
    OneStepMap, ShootingDiscretisation, ShootingError, ShootingStep, momentum,
    velocity_from_momentum,
};
pub use step::{Flavour, ForcedDiracStep};

/// Re-export of the triplet stream type models stamp derivatives into.
pub use dirac_solve::Triplets;
