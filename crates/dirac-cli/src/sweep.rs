//! `dirac sweep`: a parameter sweep of a netlist or scene, whole or one shard of it (a batch
//! scheduler's array task), and `dirac sweep --merge DIR` joining the shards.
//!
//! The points are the Cartesian product of the `--param` axes, the first varying slowest; shard
//! `I/N` is the contiguous block `[I·len/N, (I+1)·len/N)` of them, so the shards in order are the
//! whole sweep and every point is run the same way whichever shard holds it
//! ([`dirac_study::Sweep`]). The table is `point,<parameters>,<outputs>` (or `t,<signals>` with
//! `--trajectories`), written as the Python package's `dirac.table_csv` writes it.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use dirac_study::{
    Axis, Method, Model, Output, Outputs, Plan, RepresentationChoice, RunSettings, StudyError,
    Sweep, TableWriter, merge_shards, parse_shard, shard_file_name, split_list,
};

use crate::{Failure, guard};

/// Arguments of `dirac sweep`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  dirac sweep examples/netlists/seed_rlc.cir --param R1.r=0.1,0.2,0.5 --param C1.c=1:5:3
  dirac sweep SCENE --param R1.r=1,2,5 --param C1.c=1e-6:1e-5:10 --shard 3/10 --out DIR
  dirac sweep --merge DIR --out table.csv

Values: a list 1,2,5, a range start:stop:count (both ends included) or start:stop:count:log;
SPICE suffixes (1u, 10k) allowed. Shard I/N (0 <= I < N) writes DIR/shard-I-of-N.csv; with a Slurm
array --array=0-(N-1), pass --shard $SLURM_ARRAY_TASK_ID/N.")]
pub struct SweepArgs {
    /// Netlist or scene to sweep (not with --merge).
    #[arg(required_unless_present = "merge")]
    file: Option<PathBuf>,
    /// A swept parameter and its values, `<part>.<parameter>=<values>` or a netlist's top-level
    /// `.param` name, `<name>=<values>` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUES")]
    params: Vec<String>,
    /// What each run returns, `<reduction>(<signal>)` with final, min, max, peak, mean or rms
    /// (repeatable; default: the final value of every recorded signal).
    #[arg(long = "reduce", value_name = "OUTPUT")]
    reduce: Vec<String>,
    /// Every row of every run instead of reductions.
    #[arg(long, conflicts_with = "reduce")]
    trajectories: bool,
    /// Record these signals, comma-separated (default: the file's).
    #[arg(long)]
    signals: Option<String>,
    /// Discretisation: midpoint, trapezoid, gauss2, gauss3, gauss4 (default: the file's).
    #[arg(long)]
    method: Option<String>,
    /// Representation: monolithic, constraint, force, staggered (default: the file's).
    #[arg(long)]
    representation: Option<String>,
    /// Step size (default: the file's); SPICE suffixes read, e.g. `10u`.
    #[arg(long, value_parser = crate::spice_number)]
    h: Option<f64>,
    /// End time (default: the file's); SPICE suffixes read, e.g. `0.3m`.
    #[arg(long = "t-end", value_parser = crate::spice_number)]
    t_end: Option<f64>,
    /// Run shard I of N only (0-based), e.g. 3/10.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// A point that fails numerically leaves NaN outputs instead of stopping the sweep.
    #[arg(long)]
    keep_going: bool,
    /// Run points whose method amplifies a mode of the model over the run (the trapezoid rule
    /// on a fast decay), which are otherwise refused before the sweep starts a step.
    #[arg(long)]
    force: bool,
    /// Most steps a point may take: a sweep with a point of more steps (its t_end / h; a
    /// parameter may set h, t_end or a netlist's TMAX) is refused before it starts (not with
    /// --force).
    #[arg(long = "max-steps", default_value_t = guard::DEFAULT_MAX_STEPS)]
    max_steps: u64,
    /// Running: the directory for shard-I-of-N.csv (default: the table on stdout). Merging: the
    /// merged table's file (default: stdout).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Join the shard files in this directory into one table.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["file", "params", "shard"])]
    merge: Option<PathBuf>,
}

fn input(e: StudyError) -> Failure {
    if e.is_numerical() {
        Failure::Numerical(e.to_string())
    } else {
        Failure::Input(e.to_string())
    }
}

/// `dirac sweep`.
pub(crate) fn sweep(args: &SweepArgs) -> Result<(), Failure> {
    if let Some(dir) = &args.merge {
        let table = merge_shards(dir).map_err(input)?;
        return write_atomically(args.out.as_deref(), table.as_bytes());
    }
    let Some(file) = &args.file else {
        return Err(Failure::Input("give a file to sweep or --merge DIR".into()));
    };
    guard::install_interrupt_handler();
    let model = Model::from_file(file).map_err(input)?;
    for w in model.warnings() {
        eprintln!("warning: {w}");
    }
    let axes: Vec<Axis> = args
        .params
        .iter()
        .map(|p| p.parse())
        .collect::<Result<_, _>>()
        .map_err(input)?;
    let plan = Plan::grid(&axes).map_err(input)?;
    let settings = RunSettings {
        representation: args
            .representation
            .as_deref()
            .map(str::parse::<RepresentationChoice>)
            .transpose()
            .map_err(input)?,
        method: args
            .method
            .as_deref()
            .map(str::parse::<Method>)
            .transpose()
            .map_err(input)?,
        scheme: None,
        h: args.h,
        t_end: args.t_end,
        signals: args.signals.as_deref().map(split_list),
        start_ramp: None,
        truncation: None,
        composition: None,
        force: args.force,
    };
    let outputs = if args.trajectories {
        Some(Outputs::Trajectories)
    } else if args.reduce.is_empty() {
        None
    } else {
        Some(Outputs::Reduced(
            args.reduce
                .iter()
                .map(|o| o.parse::<Output>())
                .collect::<Result<_, _>>()
                .map_err(input)?,
        ))
    };
    let (index, count) = match &args.shard {
        Some(spec) => parse_shard(spec).map_err(input)?,
        None => (0, 1),
    };
    let range = plan.shard(index, count).map_err(input)?;
    let sweep = Sweep::new(model, plan, settings, outputs).map_err(input)?;
    if !args.force {
        for point in range.clone() {
            let steps = sweep.point_steps(point).map_err(input)?;
            guard::check_steps(steps, args.max_steps)
                .map_err(|why| Failure::Input(format!("point {point}: {why}")))?;
        }
    }
    let mut text = Vec::new();
    let io = |e: std::io::Error| Failure::Input(format!("writing output: {e}"));
    let mut writer = TableWriter::new(&mut text, &sweep.columns()).map_err(io)?;
    for point in range {
        if guard::interrupted() {
            return Err(Failure::Interrupted(format!(
                "interrupted at point {point}: nothing written"
            )));
        }
        let rows = match sweep.run_point_watched(point, &mut |_| {
            if guard::interrupted() {
                Err("interrupted".to_string())
            } else {
                Ok(())
            }
        }) {
            Ok(rows) => rows,
            Err(_) if guard::interrupted() => {
                return Err(Failure::Interrupted(format!(
                    "interrupted at point {point}: nothing written"
                )));
            }
            Err(e) if args.keep_going && e.is_numerical() => {
                eprintln!("warning: point {point}: {e}");
                sweep.failed_rows(point)
            }
            Err(e) => return Err(input(e)),
        };
        for row in &rows {
            writer.row(row).map_err(io)?;
        }
    }
    writer.finish().map_err(io)?;
    match &args.out {
        None => write_atomically(None, &text),
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .map_err(|e| Failure::Input(format!("{}: {e}", dir.display())))?;
            write_atomically(Some(&dir.join(shard_file_name(index, count))), &text)
        }
    }
}

/// Writes `bytes` to stdout, or to `path` through `<path>.partial` renamed when complete (so a
/// merge never reads a half-written shard).
fn write_atomically(path: Option<&Path>, bytes: &[u8]) -> Result<(), Failure> {
    let Some(path) = path else {
        let mut out = std::io::stdout().lock();
        return match out.write_all(bytes).and_then(|()| out.flush()) {
            Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                Err(Failure::Input(format!("writing output: {e}")))
            }
            _ => Ok(()),
        };
    };
    let fail = |e: std::io::Error| Failure::Input(format!("{}: {e}", path.display()));
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    let mut file = BufWriter::new(File::create(&tmp).map_err(fail)?);
    let written = file
        .write_all(bytes)
        .and_then(|()| file.flush())
        .and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(fail(e));
    }
    Ok(())
}
