//! Run settings by name, as the command line and the Python package take them.

use std::fmt;
use std::str::FromStr;

use dirac_core::Discretisation;
use dirac_graph::Representation;
use dirac_sim::{Composition, Execution, Scheme, Splitting};

use crate::StudyError;

/// The discretisation of a run (`--method`, `method=`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Linear path, midpoint rule (order 2).
    Midpoint,
    /// Linear path, trapezoid rule (order 2).
    Trapezoid,
    /// Gauss–Galerkin with 2 nodes (order 4).
    Gauss2,
    /// Gauss–Galerkin with 3 nodes (order 6).
    Gauss3,
    /// Gauss–Galerkin with 4 nodes (order 8).
    Gauss4,
}

impl Method {
    /// Every method, in order of increasing order.
    pub const ALL: [Self; 5] = [
        Self::Midpoint,
        Self::Trapezoid,
        Self::Gauss2,
        Self::Gauss3,
        Self::Gauss4,
    ];

    /// The discretisation this method names.
    #[must_use]
    pub fn discretisation(self) -> Discretisation {
        match self {
            Self::Midpoint => Discretisation::midpoint(),
            Self::Trapezoid => Discretisation::trapezoid(),
            Self::Gauss2 => Discretisation::gauss(2),
            Self::Gauss3 => Discretisation::gauss(3),
            Self::Gauss4 => Discretisation::gauss(4),
        }
    }

    /// The name used on the command line and in Python.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Midpoint => "midpoint",
            Self::Trapezoid => "trapezoid",
            Self::Gauss2 => "gauss2",
            Self::Gauss3 => "gauss3",
            Self::Gauss4 => "gauss4",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

fn one_of<T: Copy>(
    s: &str,
    all: &[T],
    name: impl Fn(T) -> String,
    what: &str,
) -> Result<T, StudyError> {
    all.iter()
        .copied()
        .find(|&m| name(m).eq_ignore_ascii_case(s.trim()))
        .ok_or_else(|| {
            let names: Vec<String> = all.iter().map(|&m| format!("`{}`", name(m))).collect();
            StudyError::Settings(format!(
                "unknown {what} `{s}`; expected one of {}",
                names.join(", ")
            ))
        })
}

impl FromStr for Method {
    type Err = StudyError;

    fn from_str(s: &str) -> Result<Self, StudyError> {
        one_of(s, &Self::ALL, |m| m.name().to_string(), "method")
    }
}

/// The scheme of a run (`scheme=`): which forced Dirac step.
pub fn parse_scheme(s: &str) -> Result<Scheme, StudyError> {
    const ALL: [(Scheme, &str); 3] = [
        (Scheme::Plus, "plus"),
        (Scheme::Minus, "minus"),
        (Scheme::Symmetric, "symmetric"),
    ];
    one_of(s, &ALL, |(_, n)| n.to_string(), "scheme").map(|(s, _)| s)
}

/// The composition of a run's step (`--composition`, `composition=`): one of
/// [`Composition::NAMES`].
///
/// # Errors
/// An unknown name, listing the known ones.
pub fn parse_composition(s: &str) -> Result<Composition, StudyError> {
    Composition::named(s).ok_or_else(|| {
        let names: Vec<String> = Composition::NAMES
            .iter()
            .map(|n| format!("`{n}`"))
            .collect();
        StudyError::Settings(format!(
            "unknown composition `{s}`; expected one of {}",
            names.join(", ")
        ))
    })
}

/// How the interconnection is turned into equations (`--representation`, `representation=`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RepresentationChoice {
    /// One system, coupling potentials inside one Lagrangian.
    Monolithic,
    /// Subsystems plus interaction constraints with multipliers.
    Constraint,
    /// Couplings as equal-and-opposite interaction forces.
    Force,
    /// Co-simulation with the scene's splitting (Gauss–Seidel unless the scene says Jacobi).
    Staggered,
    /// Gauss–Seidel co-simulation.
    StaggeredGaussSeidel,
    /// Jacobi co-simulation.
    StaggeredJacobi,
}

impl RepresentationChoice {
    /// Every choice.
    pub const ALL: [Self; 6] = [
        Self::Monolithic,
        Self::Constraint,
        Self::Force,
        Self::Staggered,
        Self::StaggeredGaussSeidel,
        Self::StaggeredJacobi,
    ];

    /// The name used on the command line and in Python.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Monolithic => "monolithic",
            Self::Constraint => "constraint",
            Self::Force => "force",
            Self::Staggered => "staggered",
            Self::StaggeredGaussSeidel => "staggered-gs",
            Self::StaggeredJacobi => "staggered-jacobi",
        }
    }
}

impl FromStr for RepresentationChoice {
    type Err = StudyError;

    fn from_str(s: &str) -> Result<Self, StudyError> {
        one_of(s, &Self::ALL, |m| m.name().to_string(), "representation")
    }
}

impl RepresentationChoice {
    /// The execution this choice means; `scene` is the file's own execution (for its splitting).
    #[must_use]
    pub fn execution(self, scene: Option<Execution>) -> Execution {
        let splitting = match scene {
            Some(Execution::Staggered(s)) => s,
            _ => Splitting::GaussSeidel,
        };
        match self {
            Self::Monolithic => Execution::Assembled(Representation::Monolithic),
            Self::Constraint => Execution::Assembled(Representation::Constraint),
            Self::Force => Execution::Assembled(Representation::InteractionForce),
            Self::Staggered => Execution::Staggered(splitting),
            Self::StaggeredGaussSeidel => Execution::Staggered(Splitting::GaussSeidel),
            Self::StaggeredJacobi => Execution::Staggered(Splitting::Jacobi),
        }
    }
}

/// What to change about a file's own run: every field left `None` keeps the file's setting
/// (a scene's `[simulation]`, a netlist's `.tran`, `.options method=` and `.print`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSettings {
    /// Representation (default: the scene's, monolithic for netlists).
    pub representation: Option<RepresentationChoice>,
    /// Discretisation (default: the scene's, the netlist's `.options method=` or midpoint).
    pub method: Option<Method>,
    /// Scheme (default: the scene's, plus for netlists).
    pub scheme: Option<Scheme>,
    /// Step size (default: the scene's `h` or `.tran` TSTEP).
    pub h: Option<f64>,
    /// End time (default: the scene's `t_end` or `.tran` TSTOP).
    pub t_end: Option<f64>,
    /// Signals to record by name (default: the file's).
    pub signals: Option<Vec<String>>,
    /// The start ramp on or off (default: the scene's `start_ramp`; for a netlist, on when the
    /// modal check finds a damped mode the method would leave ringing, as SPICE damps its
    /// start, see [`crate::RunPlan::start_ramp_auto`]; see [`dirac_sim::StartRamp`]).
    /// `Some(false)` also turns off a netlist's automatic ramps after source breakpoints
    /// ([`crate::RunPlan::corner_ramp_auto`]).
    pub start_ramp: Option<bool>,
    /// Truncation-error control on or off (default: on for netlists with diodes, with the
    /// netlist's `.options` tolerances, off otherwise; see [`dirac_sim::TruncationControl`]).
    pub truncation: Option<bool>,
    /// The step as a composition of substeps (default: the scene's `composition`, a single
    /// step for netlists; see [`Composition`]). A symmetric composition of a second-order step
    /// (midpoint, trapezoid; Störmer–Verlet on a separable model) has the composition's order
    /// when the run has no constraints or uses the symmetric scheme.
    pub composition: Option<Composition>,
    /// Run even when the method would multiply a mode of the model by more than
    /// [`dirac_sim::UNSTABLE_GROWTH`] over the run ([`dirac_sim::NaturalModes::instability`]:
    /// the trapezoid rule on a decay much faster than `h`). Without it such a run is refused
    /// as a setting before it starts ([`crate::Model::prepare_plan`]).
    pub force: bool,
}

/// Splits `a,v(x,y),b` at the commas outside parentheses (signal lists keep `v(a,b)` whole).
#[must_use]
pub fn split_list(list: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut depth = 0usize;
    let mut current = String::new();
    for c in list.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            ',' if depth == 0 => {
                if !current.trim().is_empty() {
                    out.push(current.trim().to_string());
                }
                current.clear();
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    if !current.trim().is_empty() {
        out.push(current.trim().to_string());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names parse case-insensitively and unknown ones list what exists; commas inside
    /// parentheses belong to the signal (`v(a,b)`).
    #[test]
    fn names_and_lists() {
        assert_eq!("GAUSS2".parse::<Method>().unwrap(), Method::Gauss2);
        let err = "rk4".parse::<Method>().unwrap_err().to_string();
        assert!(
            err.contains("`midpoint`") && err.contains("`gauss4`"),
            "{err}"
        );
        assert_eq!(
            "staggered-jacobi".parse::<RepresentationChoice>().unwrap(),
            RepresentationChoice::StaggeredJacobi
        );
        assert_eq!(parse_scheme("minus").unwrap(), Scheme::Minus);
        assert_eq!(
            parse_composition("yoshida6").unwrap(),
            Composition::yoshida6()
        );
        let err = parse_composition("ruth3").unwrap_err().to_string();
        assert!(
            err.contains("`kahan-li8`") && err.contains("`none`"),
            "{err}"
        );
        assert_eq!(
            split_list("v(1), v(a,b),i(l1)"),
            ["v(1)", "v(a,b)", "i(l1)"]
        );
    }
}
