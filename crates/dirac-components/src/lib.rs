//! Stock parts with hand-written derivatives, each a subsystem with named ports.
//!
//! Every part is a [`dirac_core::Model`] (and, where it has internal constraints, a
//! [`dirac_core::Constraints`]) whose gradients, Hessians, force Jacobians and constraint
//! derivatives are written out by hand, with a `subsystem(name)` constructor that returns a
//! [`dirac_graph::Subsystem`] ready for an [`dirac_graph::Interconnection`]. Each part's tests
//! check it against a closed form (an exact discrete solution, an exact invariant, a DC solution
//! computed independently), not against the integrator's own output.
//!
//! # Conventions
//!
//! **Electrical** two-terminal parts use their branch charge `q` as coordinate; port `i` is its
//! current `q̇`, flowing from the `+` terminal through the part to the `−` terminal (the passive
//! convention, as SPICE orients `V` and `I` sources). In an `Interconnection::node` the port enters
//! with sign `−1` at the node of its `+` terminal and `+1` at the node of its `−` terminal. A part
//! acts on its charge with the generalised force `−(v₊ − v₋)`: a resistor `−R q̇`, a voltage source
//! `−V(t)`. Electrical ground is just a node (no part).
//!
//! **Mechanical** parts use a position `x` (port `x`) or an angle `θ` (port `theta`); their flows
//! are velocities. Each part is one physical element: a [`Mass`] is only a mass. One [`Spring`]
//! type (linear `k` plus the Duffing term `k₃`) and one [`Damper`] type serve both as
//! [`dirac_graph::CouplingElement`]s between two ports and as to-ground parts joined to a body's
//! port; [`Ground`] is the fixed frame (a wall), so a wall spring is a spring coupled to a ground.
//!
//! **Parameters** are checked by the constructors (`Resistor::new(r)`, `Spring::new(k, k3,
//! rest)`, …), which return a [`PartError`] naming the part and the parameter; the parts are
//! `#[non_exhaustive]`, so code outside this crate cannot build one by a struct literal that skips
//! the checks (their fields stay readable). [`CircuitBuilder`] wires circuit parts between named
//! nodes in terminal order, as a netlist reads.
//!
//! | part | coordinates | ports |
//! |---|---|---|
//! | [`Resistor`], [`Inductor`], [`Capacitor`] | `q` | `i` |
//! | [`VoltageSource`] (DC, SIN, PULSE, PWL: [`Waveform`]) | `q` | `i` |
//! | [`CurrentSource`] | `q`, flux `φ` | `i` |
//! | [`CoupledInductors`] | `q₁`, `q₂` | `i1`, `i2` |
//! | [`Diode`] (SPICE level 1: [`DiodeParameters`]) | `q`, junction flux `φ` | `i` |
//! | [`BjtCore`] (Gummel–Poon: [`Bjt`], [`BjtParameters`]) | `q_c`, `φ_bc`, `q_b`, `φ_be` | `i`, `ib` |
//! | [`SaturatingInductor`] | `q` | `i` |
//! | [`Mass`] / [`Inertia`] (no spring or damper of their own) | `x` / `θ` | `x` / `theta` |
//! | [`Spring`] (linear + cubic), [`Damper`], [`ForceSource`] | `x` (to ground) | `x` or `theta` |
//! | [`Ground`] | `x` (pinned) | `x` or `theta` |
//! | [`Pendulum`] (Cartesian, holonomic rod) | `x`, `y` | `x`, `y` |
//! | [`PlanarLinkage`] (rigid bodies + pin joints) | `(xᵢ, yᵢ, θᵢ)` | `{body}.x`, `{body}.y`, `{body}.theta` |
//! | [`DcMotor`] (gyrator) | `q`, `θ` | `i`, `theta` |
//! | [`IdealTransformer`] (one-form) | `q₁`, `q₂` | `i1`, `i2` |
//! | [`IdealGear`] (holonomic) | `θ₁`, `θ₂` | `theta1`, `theta2` |
//!
//! # A user-written part
//!
//! A part that is not in the library needs only `L(q, v)` and `f(q, v, t)`, written generically;
//! [`dirac_core::AutoDiff`] supplies exact derivatives and the result is a subsystem like any
//! other:
//!
//! ```
//! use dirac_core::{AutoDiff, GenericModel};
//! use dirac_components::{Inertia, Spring};
//! use dirac_graph::{Interconnection, Subsystem};
//! use num_dual::DualNum;
//!
//! /// Pendulum on a shaft: L = ½ J θ̇² + m g ℓ cos θ, f = −c θ̇.
//! struct Bob { j: f64, mgl: f64, c: f64 }
//! impl GenericModel<1> for Bob {
//!     fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
//!         v[0] * v[0] * (0.5 * self.j) + q[0].cos() * self.mgl
//!     }
//!     fn has_force(&self) -> bool { true }
//!     fn force<D: DualNum<Primitive = f64> + Copy>(&self, _q: &[D; 1], v: &[D; 1], _t: f64) -> [D; 1] {
//!         [v[0] * (-self.c)]
//!     }
//! }
//!
//! let mut g = Interconnection::new();
//! g.add_subsystem(Subsystem::new("bob", AutoDiff::new(Bob { j: 1.0, mgl: 9.81, c: 0.1 }))
//!     .with_port("theta", 0))?;
//! g.add_subsystem(Inertia::new(0.5)?.subsystem("rotor"))?;
//! let (a, b) = (g.port("bob", "theta")?, g.port("rotor", "theta")?);
//! g.coupling("shaft", a, b, Spring::linear(20.0)?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The crate's tests run such a part (a driven Duffing oscillator) beside stock parts and match
//! the hand-written equivalent to 1e-12.

/// The `Model` methods of a part whose Lagrangian is zero (every coordinate degenerate: sources,
/// resistors, constraints): its dynamics are its forces and constraints alone.
macro_rules! zero_lagrangian {
    () => {
        fn lagrangian(&self, _q: &[f64], _v: &[f64]) -> f64 {
            0.0
        }
        fn lagrangian_gradient(&self, _q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
            lq.fill(0.0);
            lv.fill(0.0);
        }
        fn lagrangian_hessian(
            &self,
            _q: &[f64],
            _v: &[f64],
            _h: &mut dirac_core::LagrangianHessian,
        ) {
        }
    };
}

/// The forces of a branch `(q, φ)` at coordinates `at`, `at + 1` that stores no energy:
/// `f_q = −φ̇` makes `φ̇` the voltage across it and `f_φ = −q̇` balances its current, to which a
/// current output adds the current it drives. A voltage-sensing branch (no current) is exactly
/// this.
pub(crate) fn flux_branch_force(v: &[f64], at: usize, f: &mut [f64]) {
    f[at] = -v[at + 1];
    f[at + 1] = -v[at];
}

/// The rate Jacobian of [`flux_branch_force`].
pub(crate) fn flux_branch_jacobian(at: usize, j: &mut dirac_core::ForceJacobian) {
    j.v.add(at, at + 1, -1.0);
    j.v.add(at + 1, at, -1.0);
}

mod behavioural;
mod bjt;
mod checked;
mod circuit;
mod controlled;
mod diode;
mod electrical;
mod electromechanical;
mod mechanical;
mod mosfet;
mod nonlinear;
mod planar;
mod rolling;
mod serde_defaults;
#[cfg(test)]
mod testing;
#[cfg(test)]
mod user_part;
mod waveform;

pub use behavioural::{BehaviouralSource, Control, Expression, Function, Operator, Output};
pub use bjt::{Bjt, BjtCore, BjtCurrents, BjtError, BjtInstance, BjtParameters, BjtPolarity};
pub use circuit::CircuitBuilder;
pub use controlled::{Cccs, Ccvs, Vccs, Vcvs};
pub use diode::{Diode, DiodeBuild, DiodeError, DiodeParameters, ReverseCurrent};
pub use dirac_graph::PartError;
pub use electrical::{
    Capacitor, CoupledInductors, CurrentSource, Inductor, Resistor, VoltageSource,
};
pub use electromechanical::{DcMotor, IdealGear, IdealTransformer};
pub use mechanical::{Damper, ForceSource, Ground, Inertia, Mass, Spring};
pub use mosfet::{Mosfet, MosfetChannel, MosfetError, MosfetGeometry, MosfetParameters, Polarity};
pub use nonlinear::SaturatingInductor;
pub use planar::{Anchor, Pendulum, Pin, PlanarBody, PlanarLinkage};
pub use rolling::{RollingConstraint, RollingDisk};
pub use waveform::Waveform;
