//! Rigid bodies in three dimensions for `dirac`.
//!
//! A [`RigidBody`] has configuration `(x, R) ∈ ℝ³ × SO(3)`, with `SO(3)` embedded in `ℝ⁹` and the
//! six constraints `RᵀR = I` as holonomic constraints of the part ([`Orthonormality`]). The
//! Lagrangian `½ m|ẋ|² + ½ tr(Ṙ J_d Ṙᵀ) + m g·x` (with `J_d = ½ tr(J) I − J`) is quadratic, so
//! every discretisation of `dirac_core` applies unchanged; with a linear path and the trapezoid
//! rule the forced discrete Dirac step **is** the Lie group variational integrator of Lee, Leok &
//! McClamroch (the constraint forces are normal to `SO(3)`), forces included through the same
//! quadrature. `R` stays on `SO(3)` to the Newton tolerance at every step.
//!
//! Bodies expose their coordinates and body-fixed points as ports (linear in the coordinates), so
//! springs, dampers and forces are ordinary `dirac_graph` couplings. [`Joint`]s are holonomic
//! connections (`dirac_graph::Interconnection::holonomic`) whose rows are affine or bilinear in
//! the coordinates; [`Joint::couple_coordinate`] ties a joint's angle or slide to a
//! one-dimensional port (a DC motor, a gear, a rotational spring or torque source).

mod body;
mod error;
mod joint;
pub mod mechanisms;
mod rows;
pub mod so3;

pub use body::{COORDINATES, Orthonormality, RigidBody, rotation_index};
pub use error::RigidError;
pub use joint::{Joint, JointFrame, JointKind, Side};
