//! `dirac`: run, compare, check and plot circuits and mechanisms with forced discrete Dirac
//! integrators.
//!
//! Exit codes: 0 success, 1 numerical failure (with the step index and residual), 2 bad input
//! (with the file, line and column, or the part, port or signal at fault). A failed run never
//! leaves a partial output file.

mod animate;
mod bench;
mod guard;
mod guidance;
mod sweep;

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand, ValueEnum};
use dirac_graph::{Assembler, Representation};
use dirac_netlist::parse_netlist;
use dirac_output::{CsvSink, Table};
use dirac_sim::{Composition, Execution, RunError, RunSummary, Start};
use dirac_study::{
    Method, Model, RepresentationChoice, RunSettings, StudyError, parse_composition, split_list,
};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

const LONG_ABOUT: &str = "\
dirac simulates circuits and mechanisms built from parts with forced discrete Dirac variational
integrators (Parks & Leok). One quadrature serves the Lagrangian and the forces, so a model gives the
same discrete trajectory whether its couplings are written as potentials, constraints or interaction
forces; `dirac compare` shows it.

Input files:
  *.cir, *.sp, *.net   SPICE-subset netlists (R L C V I K D M Q E F G H B X, .tran, .op, .param,
                       .subckt, .ic, .options, .model D/NMOS/PMOS/NPN/PNP; docs/guide.md lists the
                       subset)
  *.toml               scene files (parts, connections, integrator, what to record)

Every row of a run is the state at t_k = t_0 + k*h (row 0 is the initial or operating-point state).
A netlist without UIC starts from its DC operating point, as SPICE does.

Examples:
  dirac run examples/netlists/seed_rlc.cir --out run.csv
  dirac run circuit.cir --signals 'v(out),i(l1)' --method gauss2
  dirac op circuit.cir --json
  dirac plot run.csv -o run.svg
  dirac check circuit.cir
  dirac compare examples/netlists/seed_rlc.cir --json
  dirac convert examples/netlists/seed_rlc.cir -o seed_rlc.toml

Exit codes: 0 success, 1 numerical failure, 2 bad input.";

#[derive(Debug, Parser)]
#[command(name = "dirac", version, about = "Structure-preserving simulation of circuits and mechanisms", long_about = LONG_ABOUT)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a netlist or scene and write `t,<signal>,...` CSV (stdout unless --out).
    Run(RunArgs),
    /// Print the operating point (steady state) of a netlist or scene: `signal,value`.
    Op(OpArgs),
    /// Run every representation and report the max deviation of each from monolithic.
    Compare(CompareArgs),
    /// Validate a file and print a model summary (parts, coordinates, constraints, unknowns).
    Check(CheckArgs),
    /// Plot a CSV written by `dirac run` to SVG or PNG (by the output's extension).
    Plot(PlotArgs),
    /// Draw a scene's rigid bodies moving, as a sequence of projected SVG frames.
    Animate(animate::AnimateArgs),
    /// Convert a netlist into an equivalent scene file.
    Convert(ConvertArgs),
    /// Work-precision sweep of a benchmark scene (bench/SCENES.md): one CSV row per run.
    Bench(BenchArgs),
    /// Sweep parameters of a netlist or scene (whole, or one shard of a batch job) or merge shards.
    Sweep(sweep::SweepArgs),
}

/// How the coupled system is assembled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum RepresentationArg {
    /// One system: coupling potentials inside one Lagrangian.
    Monolithic,
    /// Subsystems plus interaction constraints with multipliers.
    Constraint,
    /// Couplings as equal-and-opposite interaction forces.
    Force,
    /// Gauss–Seidel co-simulation (not equivalent; measures the split error).
    Staggered,
}

/// The discretisation of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MethodArg {
    /// Linear path, midpoint rule (order 2; on linear circuits the charges of SPICE's trapezoidal rule).
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

impl MethodArg {
    fn method(self) -> Method {
        match self {
            Self::Midpoint => Method::Midpoint,
            Self::Trapezoid => Method::Trapezoid,
            Self::Gauss2 => Method::Gauss2,
            Self::Gauss3 => Method::Gauss3,
            Self::Gauss4 => Method::Gauss4,
        }
    }
}

impl RepresentationArg {
    fn choice(self) -> RepresentationChoice {
        match self {
            Self::Monolithic => RepresentationChoice::Monolithic,
            Self::Constraint => RepresentationChoice::Constraint,
            Self::Force => RepresentationChoice::Force,
            Self::Staggered => RepresentationChoice::Staggered,
        }
    }
}

/// Options shared by the commands that run a model.
#[derive(Debug, Clone, clap::Args)]
struct ModelArgs {
    /// Netlist (.cir, .sp, .net) or scene (.toml).
    file: PathBuf,
    /// Representation to assemble (default: the scene's, or monolithic for netlists).
    #[arg(long, value_enum)]
    representation: Option<RepresentationArg>,
    /// Discretisation (default: the scene's, or the midpoint rule for netlists).
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
    /// Step size (overrides .tran TSTEP or the scene's h); SPICE suffixes read, e.g. `10u`.
    #[arg(long, value_parser = spice_number)]
    h: Option<f64>,
    /// End time (overrides .tran TSTOP or the scene's t_end); SPICE suffixes read, e.g. `0.3m`.
    #[arg(long = "t-end", value_parser = spice_number)]
    t_end: Option<f64>,
    /// Most steps to take: a run of more steps (t_end / h) is refused before it starts.
    #[arg(long = "max-steps", default_value_t = guard::DEFAULT_MAX_STEPS)]
    max_steps: u64,
    /// Run even past --max-steps, with an output that may not fit on the disk, or with a method
    /// that amplifies a mode of the model over the run (the trapezoid rule on a fast decay).
    #[arg(long)]
    force: bool,
    /// Take the first step as geometrically growing substeps (3 per level, from h·2^-L/3 to
    /// h/6), so that the stiff modes of a start off the slow manifold decay instead of ringing
    /// (midpoint and Gauss are not L-stable). L = ⌈log₂(h/τ)⌉ + 2 reaches the fastest damped
    /// mode τ of the modal check (at most 32; 32 where the modes are not analysed, 99
    /// substeps). The grid t_k = k·h is unchanged.
    /// On by default for a netlist whose modal check finds a damped mode the method would
    /// leave ringing (SPICE damps every start); such a netlist also ramps the stretch after
    /// every source breakpoint, from a substep that resolves that mode (SPICE restarts with a
    /// tiny step there).
    #[arg(long = "start-ramp", conflicts_with = "no_start_ramp")]
    start_ramp: bool,
    /// No start ramp and no ramps after breakpoints, also where a netlist would take them by
    /// default.
    #[arg(long = "no-start-ramp")]
    no_start_ramp: bool,
    /// Control the truncation error as SPICE does: a step whose estimated local error (charges
    /// and fluxes, third divided differences; step doubling right after source corners inside
    /// steps) exceeds .options reltol/abstol/chgtol/trtol is taken again as 2^m equal
    /// substeps on the same grid. On by default for netlists with diodes.
    #[arg(long, conflicts_with = "fixed_step")]
    refine: bool,
    /// Take every step at h: no truncation-error control (see --refine).
    #[arg(long = "fixed-step")]
    fixed_step: bool,
    /// Take each step as a symmetric composition of substeps: yoshida4, yoshida6, yoshida8,
    /// kahan-li6, kahan-li8 (order 4, 6, 8, 6, 8 from a second-order method when the run has
    /// no constraints), or none (default: the scene's `composition`, none for netlists). On a
    /// separable scene with --method trapezoid every substep is an explicit Störmer–Verlet step.
    #[arg(long, value_parser = parse_composition_arg)]
    composition: Option<Composition>,
}

/// `--composition`: a name of [`Composition::NAMES`].
fn parse_composition_arg(s: &str) -> Result<Composition, String> {
    parse_composition(s).map_err(|e| e.to_string())
}

impl ModelArgs {
    /// The run settings these options ask for, recording `signals` (a comma-separated list)
    /// or the file's own.
    fn settings(&self, signals: Option<&str>) -> RunSettings {
        RunSettings {
            representation: self.representation.map(RepresentationArg::choice),
            method: self.method.map(MethodArg::method),
            scheme: None,
            h: self.h,
            t_end: self.t_end,
            signals: signals.map(split_list),
            start_ramp: if self.start_ramp {
                Some(true)
            } else {
                self.no_start_ramp.then_some(false)
            },
            truncation: if self.refine {
                Some(true)
            } else {
                self.fixed_step.then_some(false)
            },
            composition: self.composition.clone(),
            force: self.force,
        }
    }
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Write the CSV here instead of streaming it to stdout. The file appears only when the run
    /// succeeds (it is written to `<out>.partial` and renamed).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Record only these signals, comma-separated, e.g. 'v(out),i(l1),v(a,b)' (netlists) or
    /// 'C1.q,L1.i,energy' (scenes).
    #[arg(long)]
    signals: Option<String>,
    /// Print a JSON summary (steps, Newton iterations per step, step cuts, start-ramp substeps,
    /// constraint residual, wall time) on stderr.
    #[arg(long)]
    json_summary: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, clap::Args)]
struct OpArgs {
    /// Netlist or scene.
    file: PathBuf,
    /// Print one JSON object `{signal: value}` instead of the `signal,value` table.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Args)]
#[command(after_help = "\
Scenes (bench/SCENES.md): A seed RLC loop, B damped oscillator, C RLC ladders (--sections),
D1 stiff spring chain, D2 double pendulum, D2-long the pendulum to t = 1e4, E Henon-Heiles to
t = 1e4, F the SciMLBenchmarks RC ladder (n = 1000), CLI `dirac run` against the library on the
seed and ladder netlists. Every run goes through the run layer (dirac_sim::Simulation). Methods: midpoint and Gauss-Galerkin of 2, 3,
4 nodes (orders 2, 4, 6, 8), the opt-in affine step map on the linear scenes A and B, Yoshida
compositions (yoshida4/6/8, kahan-li6/8) of the midpoint step on D2-long and E and of explicit Stormer-Verlet
on E (verlet, verlet-yoshida6, ...), the start ramp (-ramp) on F. Long runs (D2-long, E) also write the running maximum of
the energy error per tenth of the interval to the --out file with .csv replaced by .drift.csv.
CSV: scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error
The peers (scipy, SUNDIALS, ngspice) write the same columns: bench/peers/run.sh runs everything.")]
struct BenchArgs {
    /// Scene to sweep (A, B, C, D1, D2, D2-long, E, F, CLI; case does not matter).
    #[arg(long, value_enum, ignore_case = true)]
    scene: bench::BenchScene,
    /// Write the CSV here (atomically) instead of stdout.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also draw the work-precision diagram (wall time against error, log-log) to this .svg/.png.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// A short sweep with one repetition per run (smoke test).
    #[arg(long)]
    quick: bool,
    /// Ladder sizes for scene C, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "10,100,1000,10000,100000"
    )]
    sections: Vec<usize>,
    /// Only these methods of a fixed-step scene (A, B, D1, D2, D2-long, E), comma-separated
    /// (e.g. `gauss4,verlet-yoshida6`); all by default.
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
}

#[derive(Debug, clap::Args)]
struct CompareArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Args)]
struct CheckArgs {
    /// Netlist or scene.
    file: PathBuf,
    /// Step size to judge (default: .tran TSTEP or the scene's h); SPICE suffixes read.
    #[arg(long, value_parser = spice_number)]
    h: Option<f64>,
    /// Discretisation to judge (default: the scene's, or the midpoint rule for netlists).
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
}

#[derive(Debug, clap::Args)]
struct ConvertArgs {
    /// SPICE-subset netlist.
    netlist: PathBuf,
    /// Scene file to write (.toml).
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Debug, clap::Args)]
struct PlotArgs {
    /// CSV file written by `dirac run`.
    csv: PathBuf,
    /// Output figure: .svg or .png.
    #[arg(short, long)]
    output: PathBuf,
    /// Plot only these columns, comma-separated.
    #[arg(long)]
    signals: Option<String>,
}

/// Why the command failed, and which exit code that means.
#[derive(Debug)]
enum Failure {
    /// Bad input: exit code 2.
    Input(String),
    /// Numerical failure: exit code 1.
    Numerical(String),
    /// Stopped by SIGINT or SIGTERM: exit code 130.
    Interrupted(String),
}

impl Failure {
    fn code(&self) -> u8 {
        match self {
            Self::Input(_) => 2,
            Self::Numerical(_) => 1,
            Self::Interrupted(_) => guard::INTERRUPTED_EXIT,
        }
    }
}

impl From<StudyError> for Failure {
    fn from(e: StudyError) -> Self {
        match e {
            // The command line names its own options.
            StudyError::MissingSetting { file, setting } => Self::Input(format!(
                "{file}: no .tran card and no --{}",
                setting.replace('_', "-")
            )),
            e if e.is_numerical() => Self::Numerical(e.to_string()),
            e => Self::Input(e.to_string()),
        }
    }
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        if e.is_numerical() {
            Self::Numerical(e.to_string())
        } else {
            Self::Input(e.to_string())
        }
    }
}

/// Reads a number flag as a plain float or with a SPICE scale suffix and an optional `s`
/// (`0.3m`, `10us`, `1meg`), so that a time copied from a netlist's `.tran` card means what it
/// meant there. Unlike a netlist, a flag refuses other trailing letters: `0.3x` is a typo here,
/// not 0.3.
pub(crate) fn spice_number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .or_else(|| dirac_netlist::parse_spice_quantity(text, "s"))
        .ok_or_else(|| {
            format!(
                "`{text}` is not a number (a float such as 3e-4, or with a SPICE suffix such as 0.3m or 10us)"
            )
        })
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(&args),
        Command::Op(args) => op(&args),
        Command::Compare(args) => compare(&args),
        Command::Check(args) => check(&args),
        Command::Plot(args) => plot(&args),
        Command::Animate(args) => animate::animate(&args),
        Command::Convert(args) => convert(&args),
        Command::Bench(args) => bench_command(&args),
        Command::Sweep(args) => sweep::sweep(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            match &failure {
                Failure::Input(message) | Failure::Numerical(message) => {
                    eprintln!("error: {message}");
                }
                Failure::Interrupted(message) => eprintln!("{message}"),
            }
            ExitCode::from(failure.code())
        }
    }
}

/// Reads a netlist or scene, printing the reader's warnings as it finds them.
fn load(path: &Path) -> Result<Model, Failure> {
    Ok(Model::from_file_reporting(path, &mut |w| {
        eprintln!("warning: {w}");
    })?)
}

/// Prints the warnings of building a netlist into a circuit (options dirac does differently).
fn print_circuit_warnings(model: &Model) {
    for w in model.circuit().map_or(&[][..], |c| &c.warnings) {
        eprintln!("warning: {w}");
    }
}

/// A CSV destination that becomes visible only when the run succeeds.
struct Output {
    writer: BufWriter<Box<dyn Write>>,
    temporary: Option<(PathBuf, PathBuf)>,
}

impl Output {
    fn open(path: Option<&Path>) -> Result<Self, Failure> {
        match path {
            None => Ok(Self {
                writer: BufWriter::new(Box::new(std::io::stdout().lock())),
                temporary: None,
            }),
            Some(path) => {
                let mut tmp = path.as_os_str().to_owned();
                tmp.push(".partial");
                let tmp = PathBuf::from(tmp);
                let file = File::create(&tmp)
                    .map_err(|e| Failure::Input(format!("{}: {e}", path.display())))?;
                guard::set_partial(Some(tmp.clone()));
                Ok(Self {
                    writer: BufWriter::new(Box::new(file)),
                    temporary: Some((tmp, path.to_path_buf())),
                })
            }
        }
    }

    fn commit(mut self) -> Result<(), Failure> {
        match self.writer.flush() {
            // Standard output whose reader went away (`dirac op … | head`): nothing to keep.
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe && self.temporary.is_none() => {
                return Ok(());
            }
            Err(e) => return Err(Failure::Input(format!("writing output: {e}"))),
            Ok(()) => {}
        }
        if let Some((tmp, path)) = self.temporary.take() {
            let renamed = std::fs::rename(&tmp, &path)
                .map_err(|e| Failure::Input(format!("{}: {e}", path.display())));
            guard::set_partial(None);
            renamed?;
        }
        Ok(())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Some((tmp, _)) = self.temporary.take() {
            let _ = std::fs::remove_file(tmp);
            guard::set_partial(None);
        }
    }
}

/// What the sink reports when a signal stopped the run.
const INTERRUPTED: &str = "interrupted";

/// The progress bar on a terminal and the interrupt check, shown every row of a run.
struct Progress {
    total: u64,
    started: Instant,
    show: bool,
    bar: Option<ProgressBar>,
}

impl Progress {
    fn watch(&mut self, k: usize) -> Result<(), String> {
        if guard::interrupted() {
            return Err(INTERRUPTED.into());
        }
        if self.show && self.bar.is_none() && self.started.elapsed() > Duration::from_secs(1) {
            let b = ProgressBar::with_draw_target(Some(self.total), ProgressDrawTarget::stderr());
            if let Ok(style) =
                ProgressStyle::with_template("{bar:40} {pos}/{len} steps, {eta} left")
            {
                b.set_style(style);
            }
            self.bar = Some(b);
        }
        if let Some(b) = &self.bar {
            b.set_position(k as u64);
        }
        Ok(())
    }
}

fn run(args: &RunArgs) -> Result<(), Failure> {
    guard::install_interrupt_handler();
    let model = load(&args.model.file)?;
    print_circuit_warnings(&model);
    if model.operating_point_only() {
        // A netlist that asks only for `.op`: its analysis is the operating point.
        let mut out = Output::open(args.out.as_deref())?;
        operating_point(&model, false, &mut out.writer)?;
        return out.commit();
    }
    let plan = model.plan(&args.model.settings(args.signals.as_deref()))?;
    if !args.model.force {
        guard::check_steps(plan.steps(), args.model.max_steps).map_err(Failure::Input)?;
        if let Some(out) = &args.out {
            guard::check_disk(out, plan.output_rows(), plan.signals.len())
                .map_err(Failure::Input)?;
        }
    }
    let mut prepared = model.prepare_plan(plan)?;
    for w in prepared.warnings() {
        eprintln!("warning: {w}");
    }
    let printed = prepared.warnings().len();
    let execution = prepared.execution();
    let options = prepared.options().clone();
    if matches!(execution, Execution::Assembled(_))
        && let Ok(modes) = prepared.natural_modes()
    {
        for w in modes.warnings(&options) {
            eprintln!("warning: {w}");
        }
    }
    let (h, t_end) = (prepared.h(), prepared.t_end());
    let mut out = Output::open(args.out.as_deref())?;
    let mut csv = CsvSink::new(&mut out.writer);
    let mut progress = Progress {
        total: (t_end / h).round() as u64 + 1,
        started: Instant::now(),
        show: !args.quiet && std::io::stderr().is_terminal(),
        bar: None,
    };
    let result = prepared.run_into_watched(&mut csv, &mut |k| progress.watch(k));
    if let Some(b) = progress.bar.take() {
        b.finish_and_clear();
    }
    if result.is_err() && csv.reader_closed() {
        // `dirac run … | head`: the reader has what it wanted; end quietly, as `cat` does.
        return Ok(());
    }
    if guard::interrupted() {
        drop(csv);
        drop(out);
        return Err(Failure::Interrupted(match &args.out {
            Some(path) => format!("interrupted: {} not written", path.display()),
            None => "interrupted".to_string(),
        }));
    }
    let summary = result?;
    match csv.finish() {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
        Err(e) => return Err(Failure::Input(format!("writing output: {e}"))),
        Ok(_) => {}
    }
    out.commit()?;
    // What the run itself found (values read from the steps), after the set-up's warnings.
    for w in summary.warnings.iter().skip(printed) {
        eprintln!("warning: {w}");
    }
    // `.meas` results as ngspice prints them (`name = value`); a measure that could not be
    // taken is reported and the run still succeeds, as in ngspice.
    for m in prepared.measurements() {
        match &m.value {
            Ok(v) => eprintln!("{:<20}=  {v:.6e}", m.name),
            Err(why) => eprintln!("warning: `.meas {}` failed: {why}", m.name),
        }
        if let Some(w) = m.corner_warning() {
            eprintln!("warning: {w}");
        }
    }
    if args.json_summary {
        let mut json = summary_json(&model, execution, h, t_end, &summary);
        if !prepared.measurements().is_empty() {
            let measures: serde_json::Map<String, serde_json::Value> = prepared
                .measurements()
                .iter()
                .map(|m| (m.name.clone(), m.value.as_ref().ok().copied().into()))
                .collect();
            json["measures"] = measures.into();
        }
        eprintln!("{json}");
    }
    Ok(())
}

fn summary_json(
    model: &Model,
    execution: Execution,
    h: f64,
    t_end: f64,
    summary: &RunSummary,
) -> serde_json::Value {
    serde_json::json!({
        "file": model.name(),
        "representation": execution.to_string(),
        "h": h,
        "t_end": t_end,
        "steps": summary.steps,
        "newton_iterations_per_step": summary.newton_iterations_per_step(),
        "factorisations": summary.factorisations,
        "readout_iterations": summary.readout_iterations,
        "breakpoint_substeps": summary.breakpoint_substeps,
        "step_cuts": summary.step_cuts,
        "ramp_substeps": summary.ramp_substeps,
        "refinements": summary.refinements,
        "substeps": summary.substeps,
        "turn_checks": summary.turn_checks,
        "spurious_roots": summary.spurious_roots,
        "max_constraint_residual": summary.max_constraint_residual,
        "wall_s": summary.wall_s,
        "peak_rss_kib": guard::peak_rss_kib(),
    })
}

fn op(args: &OpArgs) -> Result<(), Failure> {
    let model = load(&args.file)?;
    print_circuit_warnings(&model);
    let mut out = Output::open(None)?;
    operating_point(&model, args.json, &mut out.writer)?;
    out.commit()
}

/// Writes the operating point of `model` as a `signal,value` table or one JSON object
/// ([`write_text`]).
fn operating_point(model: &Model, json: bool, out: &mut impl Write) -> Result<(), Failure> {
    let point = model.operating_point()?;
    for w in &point.warnings {
        eprintln!("warning: {w}");
    }
    let values = point.values;
    let text = if json {
        let mut map = serde_json::Map::new();
        for (name, value) in values {
            map.insert(name, value.into());
        }
        format!("{}\n", serde_json::Value::Object(map))
    } else {
        let quote = |f: &str| {
            if f.contains(',') || f.contains('"') {
                format!("\"{}\"", f.replace('"', "\"\""))
            } else {
                f.to_string()
            }
        };
        let mut text = "signal,value\n".to_string();
        for (name, value) in &values {
            text += &format!("{},{}\n", quote(name), dirac_output::format_value(*value));
        }
        text
    };
    write_text(out, &text)
}

fn compare(args: &CompareArgs) -> Result<(), Failure> {
    let model = load(&args.model.file)?;
    let settings = args.model.settings(None);
    let (options, t_end) = model.options_for(&settings)?;
    if !args.model.force {
        let steps = (t_end / options.h).round() as u64;
        guard::check_steps(steps, args.model.max_steps).map_err(Failure::Input)?;
        // Two trajectories (the reference and one representation) are held in memory at once.
        let bytes = steps
            .saturating_add(1)
            .saturating_mul(model.default_signals().len() as u64 + 1)
            .saturating_mul(16);
        if let Some(free) = guard::available_memory()
            && bytes > free
        {
            return Err(Failure::Input(format!(
                "compare holds two trajectories of {steps} steps in memory, about {bytes} bytes, more than the {free} available; use a larger h or a shorter t_end, or pass --force"
            )));
        }
    }
    let results = model.compare(&settings)?;
    if args.json {
        let mut map = serde_json::Map::new();
        for c in &results {
            let mut entry = serde_json::Map::new();
            entry.insert(
                "max_abs_deviation".into(),
                c.max_abs_deviation
                    .map_or(serde_json::Value::Null, serde_json::Value::from),
            );
            if let Some(note) = &c.note {
                entry.insert("note".into(), note.clone().into());
            }
            map.insert(c.execution.clone(), entry.into());
        }
        let json = serde_json::json!({ "file": model.name(), "representations": map });
        print_out(&format!("{json}\n"))
    } else {
        let mut text = format!("{:<16} {:>22}\n", "representation", "max |x - monolithic|");
        for c in &results {
            let name = &c.execution;
            text += &match c.max_abs_deviation {
                Some(d) => format!("{name:<16} {d:>22.3e}\n"),
                None => format!(
                    "{name:<16} {:>22}  ({})\n",
                    "-",
                    c.note.as_deref().unwrap_or("")
                ),
            };
        }
        print_out(&text)
    }
}

/// Writes `text` to standard output (see [`write_text`]).
fn print_out(text: &str) -> Result<(), Failure> {
    write_text(&mut std::io::stdout().lock(), text)
}

/// Writes `text` to `out` and flushes it. A reader that went away (`dirac check … | head`)
/// ends the output quietly, as it ends `dirac run`'s.
fn write_text(out: &mut impl Write, text: &str) -> Result<(), Failure> {
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(Failure::Input(format!("writing output: {e}"))),
        Ok(()) => Ok(()),
    }
}

fn check(args: &CheckArgs) -> Result<(), Failure> {
    let model = load(&args.file)?;
    let graph = model.graph();
    let mut text = format!(
        "{}: {} parts, {} connections\n",
        model.name(),
        graph.subsystems().len(),
        graph.connections().len()
    );
    for representation in [
        Representation::Monolithic,
        Representation::Constraint,
        Representation::InteractionForce,
    ] {
        let system = Assembler::assemble(graph, representation)
            .map_err(|e| Failure::Input(e.to_string()))?;
        let n = system.coordinates();
        let m = system.constraint_rows();
        text += &format!(
            "  {representation:<11} {n} coordinates, {m} constraint rows, {} unknowns per midpoint step\n",
            n + m
        );
    }
    let degenerate = model.degenerate_directions()?;
    text += &format!(
        "  degenerate directions (no kinetic term): {}\n",
        if degenerate.is_empty() {
            "none".to_string()
        } else {
            degenerate.join(", ")
        }
    );
    let signals: Vec<String> = model
        .default_signals()
        .iter()
        .map(|s| s.name.clone())
        .collect();
    text += &format!("  signals: {}\n", signals.join(", "));
    let start = match model.start() {
        Start::Given => "given values (UIC)",
        Start::SteadyState => "the operating point (steady state)",
    };
    text += &format!("  start: {start}\n");
    if let Some(tran) = model.circuit().and_then(|c| c.tran) {
        let (h, t) = (tran.tstep, tran.tstop);
        let every = tran.steps_per_row();
        let rows = (t / h).round();
        if every == 1 {
            text += &format!("  .tran: h = {h}, t_end = {t} ({rows} steps)");
        } else {
            text += &format!(
                "  .tran: TSTEP = {h}, t_end = {t} ({rows} output steps, stepped at h = {:e}, \
                 {every} steps each: ngspice's largest step is {})",
                h / every as f64,
                if tran.tmax.is_some() {
                    "TMAX"
                } else {
                    "(TSTOP - TSTART)/50"
                }
            );
        }
        text.push('\n');
    }
    for line in step_size_report(&model, args) {
        text += &line;
        text.push('\n');
    }
    print_out(&text)
}

/// `dirac check`'s natural modes and step-size judgement (docs/math.md §8).
fn step_size_report(model: &Model, args: &CheckArgs) -> Vec<String> {
    let settings = RunSettings {
        method: args.method.map(MethodArg::method),
        h: args.h,
        t_end: Some(0.0),
        ..RunSettings::default()
    };
    let options = match model.options_for(&settings) {
        Ok((options, _)) => options,
        Err(e) => {
            let (Failure::Input(why) | Failure::Numerical(why) | Failure::Interrupted(why)) =
                Failure::from(e);
            return vec![format!(
                "  natural modes: not analysed ({why}; pass --h to judge a step size)"
            )];
        }
    };
    let start = model.start();
    let at = match start {
        Start::Given => "the initial state",
        Start::SteadyState => "the operating point",
    };
    let modes = model
        .simulation(
            Execution::Assembled(Representation::Monolithic),
            options.clone(),
            start,
        )
        .map_err(Failure::from)
        .and_then(|mut sim| sim.natural_modes().map_err(Failure::from));
    match modes {
        Ok(modes) => guidance::report(&modes, &options, at),
        Err(Failure::Input(why) | Failure::Numerical(why) | Failure::Interrupted(why)) => {
            vec![format!("  natural modes: not analysed ({why})")]
        }
    }
}

fn plot(args: &PlotArgs) -> Result<(), Failure> {
    let name = args.csv.display().to_string();
    let text =
        std::fs::read_to_string(&args.csv).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let table = Table::read(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
    if table.names.first().map(String::as_str) != Some("t") {
        return Err(Failure::Input(format!(
            "{name}:1:1: the first column must be `t`"
        )));
    }
    let wanted: Vec<usize> = match &args.signals {
        None => (1..table.names.len()).collect(),
        Some(list) => split_list(list)
            .iter()
            .map(|s| {
                table
                    .position(s)
                    .ok_or_else(|| Failure::Input(format!("{name}: no column `{s}`")))
            })
            .collect::<Result<_, _>>()?,
    };
    let t = table.column(0);
    let title = args.csv.file_stem().map_or_else(
        || "dirac run".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let mut chart = dirac_output::LineChart::new(title).x_label("t");
    for &c in &wanted {
        let points = t.iter().copied().zip(table.column(c)).collect();
        chart.push(dirac_output::Series::new(table.names[c].clone(), points));
    }
    save_chart(&chart, &args.output)
}

fn bench_command(args: &BenchArgs) -> Result<(), Failure> {
    if args.sections.contains(&0) {
        return Err(Failure::Input(
            "--sections: a ladder needs at least one section".into(),
        ));
    }
    let options = bench::BenchOptions {
        quick: args.quick,
        sections: args.sections.clone(),
        methods: args.methods.clone(),
    };
    bench::check_methods(args.scene, &options.methods)
        .map_err(|e| Failure::Input(e.to_string()))?;
    let mut out = Output::open(args.out.as_deref())?;
    writeln!(out.writer, "{}", bench::HEADER)
        .map_err(|e| Failure::Input(format!("writing output: {e}")))?;
    let mut rows = Vec::new();
    bench::run(args.scene, &options, &mut |row| {
        writeln!(out.writer, "{}", row.csv())?;
        out.writer.flush()?;
        rows.push(row);
        Ok(())
    })
    .map_err(|e| Failure::Numerical(e.to_string()))?;
    out.commit()?;
    let drift: Vec<String> = rows.iter().filter_map(bench::BenchRow::drift_csv).collect();
    if let (Some(path), false) = (&args.out, drift.is_empty()) {
        let side = path.with_extension("drift.csv");
        let text = format!("{}\n{}\n", bench::DRIFT_HEADER, drift.join("\n"));
        std::fs::write(&side, text)
            .map_err(|e| Failure::Input(format!("{}: {e}", side.display())))?;
    }
    match &args.plot {
        Some(path) => save_chart(&work_precision_chart(&rows), path),
        None => Ok(()),
    }
}

/// Wall time against error, one line per method (scene C: µs per step per section against N).
fn work_precision_chart(rows: &[bench::BenchRow]) -> dirac_output::LineChart {
    let ladder = rows.iter().any(|r| r.scene.starts_with("C-"));
    let mut methods: Vec<&str> = Vec::new();
    for row in rows {
        if !methods.contains(&row.method.as_str()) {
            methods.push(&row.method);
        }
    }
    let scene = rows.first().map_or("", |r| r.scene.as_str());
    let mut chart = if ladder {
        dirac_output::LineChart::new("RLC ladder: stepping cost")
            .x_label("sections N")
            .y_label("µs per step per section")
    } else {
        dirac_output::LineChart::new(format!("scene {scene}: work against precision"))
            .x_label("error")
            .y_label("wall time [s]")
    }
    .log_log();
    for method in methods {
        let points = rows
            .iter()
            .filter(|r| r.method == method && r.error > 0.0 && r.error.is_finite())
            .map(|r| {
                if ladder {
                    (r.setting, r.error)
                } else {
                    (r.error, r.wall_s)
                }
            })
            .collect();
        chart.push(dirac_output::Series::new(method, points).markers(true));
    }
    chart
}

/// Saves a chart as SVG or PNG by the path's extension.
fn save_chart(chart: &dirac_output::LineChart, out: &Path) -> Result<(), Failure> {
    let result = match out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("svg") => chart.save_svg(out),
        Some("png") => chart.save_png(out),
        _ => {
            return Err(Failure::Input(format!(
                "{}: output must end in .svg or .png",
                out.display()
            )));
        }
    };
    result.map_err(|e| Failure::Input(format!("{}: {e}", out.display())))
}

fn convert(args: &ConvertArgs) -> Result<(), Failure> {
    let name = args.netlist.display().to_string();
    let text = std::fs::read_to_string(&args.netlist)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let netlist = parse_netlist(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
    let scene = dirac_scene::netlist_to_scene(&netlist, &name)
        .map_err(|e| Failure::Input(e.to_string()))?;
    let mut out = Output::open(Some(&args.output))?;
    out.writer
        .write_all(scene.as_bytes())
        .map_err(|e| Failure::Input(format!("{}: {e}", args.output.display())))?;
    out.commit()
}
