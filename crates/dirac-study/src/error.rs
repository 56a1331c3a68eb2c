//! Errors of studies: bad input (a file, a parameter, a setting, a sweep) or a failed run.

use dirac_netlist::{CircuitError, NetlistError};
use dirac_output::TableError;
use dirac_scene::SceneError;
use dirac_sim::RunError;
use thiserror::Error;

/// Why a model could not be loaded, changed or run, or a sweep not planned or merged.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StudyError {
    /// A file that cannot be read.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// What the operating system said.
        message: String,
    },
    /// A file that is neither a netlist nor a scene (by its extension).
    #[error("{file}: unknown file type (expected .cir, .sp, .net or .toml)")]
    FileType {
        /// The file.
        file: String,
    },
    /// A netlist that cannot be read (`file:line:column`).
    #[error(transparent)]
    Netlist(#[from] NetlistError),
    /// A netlist that cannot become a circuit, or a circuit signal that does not exist.
    #[error(transparent)]
    Circuit(#[from] CircuitError),
    /// A scene that cannot be read or built (`file:line:column`, or the part, port or
    /// connection at fault).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A parameter name that names nothing the model has.
    #[error("unknown parameter `{name}`: {reason}")]
    UnknownParameter {
        /// The name as given (`R1.r`).
        name: String,
        /// What is missing and what exists.
        reason: String,
    },
    /// A parameter value the model does not accept.
    #[error("parameter `{name}` = {value}: {reason}")]
    BadParameter {
        /// The name as given (`C1.c`).
        name: String,
        /// The value given.
        value: f64,
        /// Why not.
        reason: String,
    },
    /// A step size or end time that neither the file (a netlist without `.tran`) nor the
    /// settings give.
    #[error("{file}: no .tran card and no {setting}")]
    MissingSetting {
        /// The file.
        file: String,
        /// `h` or `t_end`.
        setting: &'static str,
    },
    /// Run settings that cannot be used (no step size, an unknown method, a staggered netlist).
    #[error("{0}")]
    Settings(String),
    /// The run failed: bad input found while setting it up, or a numerical failure.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A sweep that cannot be planned (no parameters, values that are not numbers, a bad shard).
    #[error("{0}")]
    Sweep(String),
    /// Shard files that cannot be merged.
    #[error("{dir}: {message}")]
    Merge {
        /// The directory of the shards.
        dir: String,
        /// What is wrong.
        message: String,
    },
    /// A CSV table that cannot be read (given points, a shard).
    #[error(transparent)]
    Table(#[from] TableError),
}

impl StudyError {
    /// True for a numerical failure of a run (the command line's exit code 1), false for bad input
    /// (exit code 2).
    #[must_use]
    pub fn is_numerical(&self) -> bool {
        matches!(self, Self::Run(e) if e.is_numerical())
    }
}
