//! Checked constructor of the saturating inductor ([`SaturatingInductor`]), kept apart from its
//! model in `nonlinear.rs` (the diode checks its card in `Diode::at_temperature`).

use dirac_graph::{Check, PartError};

use crate::nonlinear::SaturatingInductor;

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
