//! Defaults of the parts' serde forms (the scene format's): a parameter left out of a file takes
//! the value a part's usual constructor would, and a zero cubic term, rest offset or friction is
//! not written.

/// Standard gravity, m/s² (the pendulum's `g` when not given).
pub(crate) fn gravity() -> f64 {
    9.81
}

/// Whether a parameter is exactly zero, so that serialising leaves it out.
pub(crate) fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

#[cfg(test)]
mod tests {
    //! The parts' serde forms are the scene format's parameter tables: a table read into a part
    //! equals the part its constructor builds from the same numbers (defaults included), a key the
    //! part does not have is refused, and writing leaves out exactly the zero optional terms.

    use crate::{DcMotor, Pendulum, Resistor, Spring};

    /// Mutation: dropping `default = "crate::serde_defaults::gravity"` from `Pendulum::g` fails
    /// with "missing field `g`"; dropping `skip_serializing_if` from `Spring::k3` writes
    /// `k3 = 0.0`.
    #[test]
    fn parts_read_and_write_their_parameter_tables() {
        let pendulum: Pendulum = toml::from_str("m = 2\nlength = 0.5").expect("reads");
        assert_eq!(
            pendulum,
            Pendulum::new(2.0, 0.5, 9.81, [0.0, 0.0]).expect("valid")
        );
        let motor: DcMotor = toml::from_str("k = 0.1\nr = 1\nl = 0.01\nj = 0.02").expect("reads");
        assert_eq!(
            motor,
            DcMotor::new(0.1, 1.0, 0.01, 0.02, 0.0).expect("valid")
        );
        let spring = Spring::new(3.0, 0.0, 0.0).expect("valid");
        assert_eq!(toml::to_string(&spring).expect("writes"), "k = 3.0\n");
        let duffing = Spring::new(3.0, 0.5, 0.0).expect("valid");
        assert_eq!(
            toml::to_string(&duffing).expect("writes"),
            "k = 3.0\nk3 = 0.5\n"
        );
        let unknown = toml::from_str::<Resistor>("r = 1\nR = 2").expect_err("unknown key");
        assert!(unknown.message().contains("unknown field `R`"), "{unknown}");
    }
}
