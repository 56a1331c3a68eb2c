//! Checked constructors of the nonlinear parts ([`Diode`], [`SaturatingInductor`]), kept apart
//! from their models in `nonlinear.rs`.

use dirac_graph::{Check, PartError};

use crate::nonlinear::{Diode, SaturatingInductor};

impl Diode {
    /// A diode of saturation current `is`, emission coefficient `n` and thermal voltage `vt`
    /// (each positive and finite) with series resistance `rs` (non-negative and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(is: f64, n: f64, vt: f64, rs: f64) -> Result<Self, PartError> {
        let c = Check::new("diode");
        Ok(Self {
            is: c.positive("is", is)?,
            n: c.positive("n", n)?,
            vt: c.positive("vt", vt)?,
            rs: c.non_negative("rs", rs)?,
        })
    }
}

impl SaturatingInductor {
    /// An inductor of small-signal inductance `l0` (positive and finite) saturating to `l_inf`
    /// (in `[0, l0]`) around the current `i_sat` (positive and finite).
    ///
    /// # Errors
    /// [`PartError::Parameter`] naming the parameter out of range.
    pub fn new(l0: f64, l_inf: f64, i_sat: f64) -> Result<Self, PartError> {
        let c = Check::new("saturating_inductor");
        let l0 = c.positive("l0", l0)?;
        let l_inf = c.non_negative("l_inf", l_inf)?;
        if l_inf > l0 {
            return Err(c.fail("l_inf", l_inf, "must not exceed `l0`"));
        }
        Ok(Self {
            l0,
            l_inf,
            i_sat: c.positive("i_sat", i_sat)?,
        })
    }
}
