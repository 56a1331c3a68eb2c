//! Stock parts with hand-written derivatives, each a one-port (or few-port) subsystem.
//!
//! Electrical parts use the branch charge as coordinate: its velocity is the branch current, the
//! flow of the part's port `i`. Mechanical parts use a position (or angle): its velocity is the
//! flow of port `x`.

mod electrical;
mod mechanical;

pub use electrical::{Capacitor, Inductor, Resistor, VoltageSource};
pub use mechanical::Mass;
