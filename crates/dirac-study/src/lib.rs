//! Studies of a `dirac` model: a netlist or scene read once, run as the command line runs it,
//! its parameters changed by name, and parameter sweeps that run in shards.
//!
//! - [`Model`] reads a netlist (`.cir`, `.sp`, `.net`) or a scene (`.toml`), keeps its source
//!   text and the parameter changes made by name ([`Model::set_parameter`]: `R1.r`, `C1.c`,
//!   `V1.waveform.amplitude`), and runs it with [`RunSettings`] (method, representation, step,
//!   end time, signals by name) over the file's own settings: [`Model::prepare`] /
//!   [`Model::run`], [`Model::compare`], [`Model::check`], [`Model::operating_point`]. The `dirac`
//!   command line and the Python package both run files through it, so they give the same rows.
//! - [`Sweep`] runs a model over a [`Plan`] (a Cartesian grid of [`Axis`] values or given points)
//!   and returns, per point, reductions of signals ([`Output`]: `max(v(2))`) or whole
//!   trajectories; [`Plan::shard`] splits the points into contiguous blocks for batch schedulers,
//!   [`TableWriter`] writes the table as CSV and [`merge_shards`] joins shard files.
//!
//! ```
//! use dirac_study::{Model, Plan, RunSettings, Sweep};
//!
//! let netlist = "RC\nR1 1 0 1k\nC1 1 0 1u IC=1\n.tran 1e-4 1e-3 uic\n.end\n";
//! let model = Model::netlist(netlist, "rc.cir").unwrap();
//! assert_eq!(model.parameter("R1.r").unwrap(), 1e3);
//! let plan = Plan::grid(&["R1.r=1k,2k".parse().unwrap()]).unwrap();
//! let sweep = Sweep::new(model, plan, RunSettings::default(), None).unwrap();
//! assert_eq!(sweep.columns(), ["point", "R1.r", "final(v(1))", "final(q(c1))"]);
//! let row = &sweep.run_point(1).unwrap()[0];
//! assert_eq!(row[..2], [1.0, 2e3]);
//! ```

mod error;
mod model;
mod run;
mod settings;
mod sweep;

pub use error::StudyError;
pub use model::{Model, SourceKind, kind_of};
pub use run::{
    CheckReport, Comparison, Measurement, OperatingPoint, Prepared, RepresentationSize, RunPlan,
};
pub use settings::{
    Method, RepresentationChoice, RunSettings, parse_composition, parse_scheme, split_list,
};
pub use sweep::{
    Axis, Output, Outputs, Plan, Reduction, Sweep, TableWriter, merge_shards, parse_shard,
    parse_values, shard_file_name,
};
