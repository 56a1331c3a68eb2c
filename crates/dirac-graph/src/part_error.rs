//! Parameter errors of parts: what a part's constructor refuses and why.

use thiserror::Error;

/// A part's parameter outside the range its physics needs (a negative capacitance, a coupling
/// coefficient above one, a value that is not finite), named by part type and parameter.
///
/// Parts check their parameters when they are built, so a model that reaches the integrator never
/// carries one. Readers place the error in their files: the scene reader at the parameter's value
/// (`parameter` is its key path inside the part's table, e.g. `waveform.period`), the netlist
/// reader at the element's card. It converts into [`crate::GraphError`], so code that builds an
/// interconnection needs one error type.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum PartError {
    /// A numeric parameter outside its range.
    #[error("{part}: `{parameter}` = {value} {requirement}")]
    Parameter {
        /// The part type, as a scene names it (`resistor`, `voltage_source`, `spring`).
        part: &'static str,
        /// The parameter (its key path for nested values: `waveform.points[2]`).
        parameter: String,
        /// The value given.
        value: f64,
        /// What it must be ("must be positive and finite").
        requirement: &'static str,
    },
}

impl PartError {
    /// The parameter at fault.
    #[must_use]
    pub fn parameter(&self) -> &str {
        match self {
            Self::Parameter { parameter, .. } => parameter,
        }
    }
}

/// Range checks shared by the parts' constructors; each returns the value when it is in range.
#[derive(Debug, Clone, Copy)]
pub struct Check {
    part: &'static str,
}

impl Check {
    /// Checks for part type `part`.
    #[must_use]
    pub fn new(part: &'static str) -> Self {
        Self { part }
    }

    /// The error for `parameter` = `value`, which must be `requirement`.
    #[must_use]
    pub fn fail(&self, parameter: &str, value: f64, requirement: &'static str) -> PartError {
        PartError::Parameter {
            part: self.part,
            parameter: parameter.to_string(),
            value,
            requirement,
        }
    }

    fn holds(
        &self,
        parameter: &str,
        value: f64,
        ok: bool,
        requirement: &'static str,
    ) -> Result<f64, PartError> {
        if ok {
            Ok(value)
        } else {
            Err(self.fail(parameter, value, requirement))
        }
    }

    /// `value` is finite.
    pub fn finite(&self, parameter: &str, value: f64) -> Result<f64, PartError> {
        self.holds(parameter, value, value.is_finite(), "must be finite")
    }

    /// `value` is positive and finite.
    pub fn positive(&self, parameter: &str, value: f64) -> Result<f64, PartError> {
        let ok = value.is_finite() && value > 0.0;
        self.holds(parameter, value, ok, "must be positive and finite")
    }

    /// `value` is non-negative and finite.
    pub fn non_negative(&self, parameter: &str, value: f64) -> Result<f64, PartError> {
        let ok = value.is_finite() && value >= 0.0;
        self.holds(parameter, value, ok, "must be non-negative and finite")
    }

    /// `value` is non-zero and finite.
    pub fn nonzero(&self, parameter: &str, value: f64) -> Result<f64, PartError> {
        let ok = value.is_finite() && value != 0.0;
        self.holds(parameter, value, ok, "must be non-zero and finite")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each check accepts the edge of its range and refuses the value just past it, NaN and ∞,
    /// and the error names the part, the parameter and the value.
    #[test]
    fn checks_accept_their_range_and_name_the_parameter() {
        let c = Check::new("capacitor");
        assert_eq!(c.positive("c", 1e-300), Ok(1e-300));
        assert_eq!(c.non_negative("c", 0.0), Ok(0.0));
        assert_eq!(c.nonzero("n", -2.0), Ok(-2.0));
        assert_eq!(c.finite("x", -1e300), Ok(-1e300));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(c.finite("x", bad).is_err());
            assert!(c.positive("c", bad).is_err());
            assert!(c.non_negative("c", bad).is_err());
            assert!(c.nonzero("n", bad).is_err());
        }
        assert!(c.positive("c", 0.0).is_err());
        assert!(c.non_negative("c", -1e-300).is_err());
        assert!(c.nonzero("n", 0.0).is_err());
        let e = c.positive("c", -3.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "capacitor: `c` = -3 must be positive and finite"
        );
        assert_eq!(e.parameter(), "c");
    }
}
