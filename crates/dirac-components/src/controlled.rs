//! Linear controlled sources (SPICE `E`, `G`, `F`, `H`) on branch charges and fluxes.
//!
//! Each part has an output branch (port `i`, coordinate 0, passive convention as in
//! [`crate::electrical`]) and a controlling branch (port `ic`) that the netlist connects where the
//! control is sensed:
//!
//! - a **voltage** is sensed by a branch that carries no current, placed across the controlling
//!   nodes: charge `q_c` and flux `φ_c` with forces `f_{q_c} = −φ̇_c`, `f_{φ_c} = −q̇_c` (a 0 A
//!   [`crate::CurrentSource`]), so `φ̇_c` is the controlling voltage;
//! - a **current** is sensed by a branch of zero voltage (a short: no Lagrangian, no force),
//!   placed in series with the controlling element, so `q̇_c` is the controlling current.
//!
//! The output is then a voltage (force `−k·x` on `q`, as [`crate::VoltageSource`] with the value
//! `k·x`) or a current (an output flux `φ` with `f_q = −φ̇`, `f_φ = k·x − q̇`, as
//! [`crate::CurrentSource`]), where `x` is the controlling rate. Every force is linear in the
//! rates and the parts have no Lagrangian, so each step applies the discretisation's force
//! quadrature to `k·x` exactly as to an independent source's value: on the midpoint rule the
//! output of a step is `k` times the step's mean controlling voltage (or current). The parts are
//! not passive and do no work of their own beyond what their output branch delivers.

use crate::{flux_branch_force, flux_branch_jacobian};
use dirac_core::{ForceJacobian, Model};
use dirac_graph::{Check, PartError, Subsystem};
use serde::{Deserialize, Serialize};

/// The Lagrangian part shared by every controlled source: none (all coordinates degenerate).
macro_rules! no_lagrangian {
    ($n:expr, [$($name:expr),*]) => {
        fn dim(&self) -> usize {
            $n
        }
        zero_lagrangian!();
        fn has_force(&self) -> bool {
            true
        }
        fn is_linear(&self) -> bool {
            true
        }
        fn is_autonomous(&self) -> bool {
            true
        }
        fn coordinate_name(&self, i: usize) -> String {
            [$($name),*][i].into()
        }
    };
}

/// A finite coefficient (any sign, zero included) of part `part`.
fn coefficient(part: &'static str, name: &str, value: f64) -> Result<f64, PartError> {
    Check::new(part).finite(name, value)
}

/// Voltage-controlled voltage source (SPICE `E n+ n− nc+ nc− gain`):
/// `v₊ − v₋ = gain·(v_{c+} − v_{c−})`.
///
/// Coordinates `[q, q_c, φ_c]`: the output charge, and the sensing branch's charge and flux.
/// Ports: `i` (coordinate 0, the output current from `+` through the source to `−`), `ic`
/// (coordinate 1, the sensing branch, which carries no current). Forces `f_q = −gain·φ̇_c`,
/// `f_{q_c} = −φ̇_c`, `f_{φ_c} = −q̇_c`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Vcvs {
    /// Voltage gain.
    pub gain: f64,
}

impl Vcvs {
    /// A source of voltage gain `gain` (finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `gain` otherwise.
    pub fn new(gain: f64) -> Result<Self, PartError> {
        Ok(Self {
            gain: coefficient("vcvs", "gain", gain)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i` (output) and `ic` (sensing branch).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port("ic", 1)
    }
}

impl Model for Vcvs {
    no_lagrangian!(3, ["q", "q_c", "phi_c"]);
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.gain * v[2];
        flux_branch_force(v, 1, f);
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 2, -self.gain);
        flux_branch_jacobian(1, j);
    }
}

/// Voltage-controlled current source (SPICE `G n+ n− nc+ nc− gm`): the current
/// `gm·(v_{c+} − v_{c−})` flows from `+` through the source to `−`.
///
/// Coordinates `[q, φ, q_c, φ_c]`. Ports: `i` (coordinate 0), `ic` (coordinate 2, the sensing
/// branch). Forces `f_q = −φ̇`, `f_φ = gm·φ̇_c − q̇`, `f_{q_c} = −φ̇_c`, `f_{φ_c} = −q̇_c`; `φ̇` is the
/// voltage across the output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Vccs {
    /// Transconductance in siemens.
    pub gm: f64,
}

impl Vccs {
    /// A source of transconductance `gm` (finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `gm` otherwise.
    pub fn new(gm: f64) -> Result<Self, PartError> {
        Ok(Self {
            gm: coefficient("vccs", "gm", gm)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i` (output) and `ic` (sensing branch).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port("ic", 2)
    }
}

impl Model for Vccs {
    no_lagrangian!(4, ["q", "phi", "q_c", "phi_c"]);
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        flux_branch_force(v, 0, f);
        f[1] += self.gm * v[3];
        flux_branch_force(v, 2, f);
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        flux_branch_jacobian(0, j);
        j.v.add(1, 3, self.gm);
        flux_branch_jacobian(2, j);
    }
}

/// Current-controlled current source (SPICE `F n+ n− vname gain`): the current `gain·i_c` flows
/// from `+` through the source to `−`, where `i_c` is the current through the sensing branch.
///
/// Coordinates `[q, φ, q_c]`. Ports: `i` (coordinate 0), `ic` (coordinate 2, the sensing branch:
/// a short, placed in series with the controlling element). Forces `f_q = −φ̇`,
/// `f_φ = gain·q̇_c − q̇`, `f_{q_c} = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Cccs {
    /// Current gain.
    pub gain: f64,
}

impl Cccs {
    /// A source of current gain `gain` (finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `gain` otherwise.
    pub fn new(gain: f64) -> Result<Self, PartError> {
        Ok(Self {
            gain: coefficient("cccs", "gain", gain)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i` (output) and `ic` (sensing branch).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port("ic", 2)
    }
}

impl Model for Cccs {
    no_lagrangian!(3, ["q", "phi", "q_c"]);
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        flux_branch_force(v, 0, f);
        f[1] += self.gain * v[2];
        f[2] = 0.0;
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        flux_branch_jacobian(0, j);
        j.v.add(1, 2, self.gain);
    }
}

/// Current-controlled voltage source (SPICE `H n+ n− vname r`): `v₊ − v₋ = r·i_c`, where `i_c`
/// is the current through the sensing branch.
///
/// Coordinates `[q, q_c]`. Ports: `i` (coordinate 0), `ic` (coordinate 1, the sensing branch: a
/// short in series with the controlling element). Forces `f_q = −r·q̇_c`, `f_{q_c} = 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Ccvs {
    /// Transresistance in ohms.
    pub r: f64,
}

impl Ccvs {
    /// A source of transresistance `r` (finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming `r` otherwise.
    pub fn new(r: f64) -> Result<Self, PartError> {
        Ok(Self {
            r: coefficient("ccvs", "r", r)?,
        })
    }

    /// This part as a subsystem named `name` with ports `i` (output) and `ic` (sensing branch).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port("ic", 1)
    }
}

impl Model for Ccvs {
    no_lagrangian!(2, ["q", "q_c"]);
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[1];
        f[1] = 0.0;
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 1, -self.r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::check_model;

    /// Hand-written force Jacobians against central differences of the forces.
    #[test]
    fn jacobians_match_differences() {
        let q = [0.3, -1.2, 0.7, 2.1];
        let v = [1.1, -0.4, 0.9, -2.3];
        check_model(&Vcvs::new(-37.0).unwrap(), &q[..3], &v[..3], 0.2);
        check_model(&Vccs::new(2.5e-3).unwrap(), &q, &v, 0.2);
        check_model(&Cccs::new(4.0).unwrap(), &q[..3], &v[..3], 0.2);
        check_model(&Ccvs::new(-1e3).unwrap(), &q[..2], &v[..2], 0.2);
    }

    #[test]
    fn coefficients_must_be_finite() {
        assert!(Vcvs::new(f64::NAN).is_err());
        assert!(Vccs::new(f64::INFINITY).is_err());
        assert!(Cccs::new(0.0).is_ok());
        assert!(Ccvs::new(-2.0).is_ok());
    }
}
