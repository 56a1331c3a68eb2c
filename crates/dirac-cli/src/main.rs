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
use dirac_core::{Discretisation, Model};
use dirac_graph::{Assembler, Interconnection, Representation};
use dirac_netlist::{Circuit, build_circuit, parse_netlist};
use dirac_output::{CsvSink, Table};
use dirac_scene::{BuiltScene, Scene};
use dirac_sim::{
    Execution, IntegratorOptions, RunError, RunSummary, Scheme, Signal, Simulation, Sink,
    Splitting, Start, Trajectory,
};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

const LONG_ABOUT: &str = "\
dirac simulates circuits and mechanisms built from parts with forced discrete Dirac variational
integrators (Parks & Leok). One quadrature serves the Lagrangian and the forces, so a model gives the
same discrete trajectory whether its couplings are written as potentials, constraints or interaction
forces; `dirac compare` shows it.

Input files:
  *.cir, *.sp, *.net   SPICE-subset netlists (R L C V I K D, .tran, .op, .param, .subckt, .ic, .model D)
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
    fn discretisation(self) -> Discretisation {
        match self {
            Self::Midpoint => Discretisation::midpoint(),
            Self::Trapezoid => Discretisation::trapezoid(),
            Self::Gauss2 => Discretisation::gauss(2),
            Self::Gauss3 => Discretisation::gauss(3),
            Self::Gauss4 => Discretisation::gauss(4),
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
    /// Step size (overrides .tran TSTEP or the scene's h).
    #[arg(long)]
    h: Option<f64>,
    /// End time (overrides .tran TSTOP or the scene's t_end).
    #[arg(long = "t-end")]
    t_end: Option<f64>,
    /// Most steps to take: a run of more steps (t_end / h) is refused before it starts.
    #[arg(long = "max-steps", default_value_t = guard::DEFAULT_MAX_STEPS)]
    max_steps: u64,
    /// Run even past --max-steps or with an output that may not fit on the disk.
    #[arg(long)]
    force: bool,
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
    /// Print a JSON summary (steps, Newton iterations per step, step cuts, constraint residual,
    /// wall time) on stderr.
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
compositions of the midpoint step on E. Long runs (D2-long, E) also write the running maximum of
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
    /// Step size to judge (default: .tran TSTEP or the scene's h).
    #[arg(long)]
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

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        if e.is_numerical() {
            Self::Numerical(e.to_string())
        } else {
            Self::Input(e.to_string())
        }
    }
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

/// A file read and built: a netlist's circuit or a scene.
enum Loaded {
    Netlist { name: String, circuit: Circuit },
    Scene { name: String, scene: BuiltScene },
}

impl Loaded {
    fn name(&self) -> &str {
        match self {
            Self::Netlist { name, .. } | Self::Scene { name, .. } => name,
        }
    }

    fn graph(&self) -> &Interconnection {
        match self {
            Self::Netlist { circuit, .. } => &circuit.graph,
            Self::Scene { scene, .. } => &scene.graph,
        }
    }

    /// The execution asked for on the command line, else the scene's, else monolithic.
    fn execution(&self, arg: Option<RepresentationArg>) -> Result<Execution, Failure> {
        let scene_splitting = match self {
            Self::Scene { scene, .. } => match scene.execution {
                Execution::Staggered(s) => Some(s),
                Execution::Assembled(_) => None,
            },
            Self::Netlist { .. } => None,
        };
        let execution = match arg {
            Some(RepresentationArg::Monolithic) => Execution::Assembled(Representation::Monolithic),
            Some(RepresentationArg::Constraint) => Execution::Assembled(Representation::Constraint),
            Some(RepresentationArg::Force) => {
                Execution::Assembled(Representation::InteractionForce)
            }
            Some(RepresentationArg::Staggered) => {
                Execution::Staggered(scene_splitting.unwrap_or(Splitting::GaussSeidel))
            }
            None => match self {
                Self::Scene { scene, .. } => scene.execution,
                Self::Netlist { .. } => Execution::Assembled(Representation::Monolithic),
            },
        };
        if matches!(execution, Execution::Staggered(_)) && matches!(self, Self::Netlist { .. }) {
            return Err(Failure::Input(format!(
                "{}: staggered co-simulation needs coupling elements between subsystems; a circuit's nodes are constraints",
                self.name()
            )));
        }
        Ok(execution)
    }

    /// Integrator options and end time after the command line's overrides.
    fn settings(&self, args: &ModelArgs) -> Result<(IntegratorOptions, f64), Failure> {
        let name = self.name();
        let (h, t_end, discretisation, scheme) = match self {
            Self::Netlist { circuit, .. } => {
                let tran = circuit.tran_settings();
                (
                    args.h.or(tran.map(|t| t.0)),
                    args.t_end.or(tran.map(|t| t.1)),
                    circuit
                        .method
                        .clone()
                        .unwrap_or_else(Discretisation::midpoint),
                    Scheme::Plus,
                )
            }
            Self::Scene { scene, .. } => (
                Some(args.h.unwrap_or(scene.options.h)),
                Some(args.t_end.unwrap_or(scene.t_end)),
                scene.options.discretisation.clone(),
                scene.options.scheme,
            ),
        };
        let h = h.ok_or_else(|| Failure::Input(format!("{name}: no .tran card and no --h")))?;
        let t_end =
            t_end.ok_or_else(|| Failure::Input(format!("{name}: no .tran card and no --t-end")))?;
        if !(h > 0.0 && h.is_finite()) {
            return Err(Failure::Input(format!(
                "step size must be positive and finite, got {h}"
            )));
        }
        if !(t_end >= 0.0 && t_end.is_finite()) {
            return Err(Failure::Input(format!(
                "end time must be non-negative and finite, got {t_end}"
            )));
        }
        let discretisation = args
            .method
            .map_or(discretisation, MethodArg::discretisation);
        Ok((
            IntegratorOptions::new(discretisation, h).scheme(scheme),
            t_end,
        ))
    }

    fn start(&self) -> Start {
        match self {
            Self::Netlist { circuit, .. } => circuit.start(),
            Self::Scene { scene, .. } => scene.start,
        }
    }

    fn simulation(
        &self,
        execution: Execution,
        options: IntegratorOptions,
        start: Start,
    ) -> Result<Simulation, Failure> {
        Ok(match self {
            Self::Netlist { circuit, .. } => circuit.simulation(execution, options, start)?,
            Self::Scene { scene, .. } => scene.simulation_with(execution, options, start)?,
        })
    }

    /// The default signals of the file.
    fn signals(&self) -> Vec<Signal> {
        match self {
            Self::Netlist { circuit, .. } => circuit.signals.clone(),
            Self::Scene { scene, .. } => scene.signals.clone(),
        }
    }

    /// The signals named in `list` (comma-separated; `v(a,b)` keeps its comma).
    fn select(&self, list: &str) -> Result<Vec<Signal>, Failure> {
        split_signal_list(list)
            .iter()
            .map(|name| match self {
                Self::Netlist { circuit, .. } => circuit
                    .signal(name)
                    .map_err(|e| Failure::Input(e.to_string())),
                Self::Scene { scene, .. } => scene
                    .signal(name)
                    .map_err(|e| Failure::Input(e.to_string())),
            })
            .collect()
    }

    /// Output rows begin at `.tran`'s TSTART.
    fn first_output_time(&self) -> f64 {
        match self {
            Self::Netlist { circuit, .. } => circuit.tran.map_or(0.0, |t| t.tstart),
            Self::Scene { .. } => 0.0,
        }
    }

    fn warnings(&self) -> Vec<String> {
        match self {
            Self::Netlist { circuit, .. } => circuit.warnings.clone(),
            Self::Scene { .. } => Vec::new(),
        }
    }
}

/// Splits `a,v(x,y),b` at the commas outside parentheses.
fn split_signal_list(list: &str) -> Vec<String> {
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

fn load(path: &Path) -> Result<Loaded, Failure> {
    let name = path.display().to_string();
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = std::fs::read(path).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        Failure::Input(format!(
            "{name}: not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        ))
    })?;
    match extension.as_deref() {
        Some("cir" | "sp" | "net" | "spice") => {
            let netlist = parse_netlist(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
            for w in &netlist.warnings {
                eprintln!("warning: {name}:{}:{}: {}", w.line, w.column, w.message);
            }
            let circuit =
                build_circuit(&netlist, &name).map_err(|e| Failure::Input(e.to_string()))?;
            Ok(Loaded::Netlist { name, circuit })
        }
        Some("toml") => {
            let scene = Scene::parse(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
            let scene = scene.build().map_err(|e| Failure::Input(e.to_string()))?;
            Ok(Loaded::Scene { name, scene })
        }
        _ => Err(Failure::Input(format!(
            "{name}: unknown file type (expected .cir, .sp, .net or .toml)"
        ))),
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
        self.writer
            .flush()
            .map_err(|e| Failure::Input(format!("writing output: {e}")))?;
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

/// A sink that skips rows before `first` (`.tran`'s TSTART) and shows progress on a terminal.
struct Progress<'a, S: Sink> {
    inner: &'a mut S,
    first: f64,
    total: u64,
    started: Instant,
    show: bool,
    bar: Option<ProgressBar>,
}

impl<S: Sink> Sink for Progress<'_, S> {
    fn begin(&mut self, names: &[String]) -> Result<(), String> {
        if guard::interrupted() {
            return Err(INTERRUPTED.into());
        }
        self.inner.begin(names)
    }

    fn row(&mut self, k: usize, t: f64, values: &[f64]) -> Result<(), String> {
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
        if t < self.first * (1.0 - 1e-12) {
            return Ok(());
        }
        self.inner.row(k, t, values)
    }
}

fn run(args: &RunArgs) -> Result<(), Failure> {
    guard::install_interrupt_handler();
    let loaded = load(&args.model.file)?;
    for w in loaded.warnings() {
        eprintln!("warning: {w}");
    }
    if let Loaded::Netlist { circuit, .. } = &loaded
        && circuit.op
        && circuit.tran.is_none()
    {
        // A netlist that asks only for `.op`: its analysis is the operating point.
        let mut out = Output::open(args.out.as_deref())?;
        operating_point(&loaded, false, &mut out.writer)?;
        return out.commit();
    }
    let execution = loaded.execution(args.model.representation)?;
    let (options, t_end) = loaded.settings(&args.model)?;
    let signals = match &args.signals {
        Some(list) => loaded.select(list)?,
        None => loaded.signals(),
    };
    let h = options.h;
    let steps = (t_end / h).round();
    if !args.model.force {
        guard::check_steps(steps as u64, args.model.max_steps).map_err(Failure::Input)?;
        if let Some(out) = &args.out {
            let rows = ((t_end - loaded.first_output_time()) / h).round().max(0.0) as u64 + 1;
            guard::check_disk(out, rows, signals.len()).map_err(Failure::Input)?;
        }
    }
    let mut sim = loaded.simulation(execution, options.clone(), loaded.start())?;
    sim.check_signals(&signals)?;
    sim.prepare()?;
    for w in sim.warnings() {
        eprintln!("warning: {w}");
    }
    if matches!(execution, Execution::Assembled(_))
        && let Ok(modes) = sim.natural_modes()
    {
        for w in modes.warnings(&options) {
            eprintln!("warning: {w}");
        }
    }
    let mut out = Output::open(args.out.as_deref())?;
    let mut csv = CsvSink::new(&mut out.writer);
    let mut sink = Progress {
        inner: &mut csv,
        first: loaded.first_output_time(),
        total: (t_end / h).round() as u64 + 1,
        started: Instant::now(),
        show: !args.quiet && std::io::stderr().is_terminal(),
        bar: None,
    };
    let result = sim.run_into(t_end, &signals, &mut sink);
    if let Some(b) = sink.bar.take() {
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
    if args.json_summary {
        eprintln!("{}", summary_json(&loaded, execution, h, t_end, &summary));
    }
    Ok(())
}

fn summary_json(
    loaded: &Loaded,
    execution: Execution,
    h: f64,
    t_end: f64,
    summary: &RunSummary,
) -> serde_json::Value {
    serde_json::json!({
        "file": loaded.name(),
        "representation": execution.to_string(),
        "h": h,
        "t_end": t_end,
        "steps": summary.steps,
        "newton_iterations_per_step": summary.newton_iterations_per_step(),
        "factorisations": summary.factorisations,
        "readout_iterations": summary.readout_iterations,
        "breakpoint_substeps": summary.breakpoint_substeps,
        "step_cuts": summary.step_cuts,
        "max_constraint_residual": summary.max_constraint_residual,
        "wall_s": summary.wall_s,
        "peak_rss_kib": guard::peak_rss_kib(),
    })
}

fn op(args: &OpArgs) -> Result<(), Failure> {
    let loaded = load(&args.file)?;
    for w in loaded.warnings() {
        eprintln!("warning: {w}");
    }
    let mut out = Output::open(None)?;
    operating_point(&loaded, args.json, &mut out.writer)?;
    out.commit()
}

/// Writes the operating point of `loaded` as a `signal,value` table or one JSON object.
fn operating_point(loaded: &Loaded, json: bool, out: &mut impl Write) -> Result<(), Failure> {
    let model = ModelArgs {
        file: PathBuf::new(),
        representation: None,
        method: None,
        h: Some(1.0),
        t_end: Some(0.0),
        max_steps: guard::DEFAULT_MAX_STEPS,
        force: false,
    };
    let (options, _) = loaded.settings(&model)?;
    let execution = loaded.execution(None)?;
    let signals = match loaded {
        Loaded::Netlist { circuit, .. } => circuit.operating_point_signals(),
        Loaded::Scene { scene, .. } => scene.signals.clone(),
    };
    let mut sim = loaded.simulation(execution, options, Start::SteadyState)?;
    let mut trajectory = Trajectory::new();
    sim.run_into(0.0, &signals, &mut trajectory)?;
    let values = trajectory.row(0);
    let write = |e: std::io::Error| Failure::Input(format!("writing output: {e}"));
    if json {
        let mut map = serde_json::Map::new();
        for (signal, value) in signals.iter().zip(values) {
            map.insert(signal.name.clone(), (*value).into());
        }
        writeln!(out, "{}", serde_json::Value::Object(map)).map_err(write)?;
    } else {
        let quote = |f: &str| {
            if f.contains(',') || f.contains('"') {
                format!("\"{}\"", f.replace('"', "\"\""))
            } else {
                f.to_string()
            }
        };
        writeln!(out, "signal,value").map_err(write)?;
        for (signal, value) in signals.iter().zip(values) {
            writeln!(
                out,
                "{},{}",
                quote(&signal.name),
                dirac_output::format_value(*value)
            )
            .map_err(write)?;
        }
    }
    Ok(())
}

/// Runs one execution and returns all default signals, row by row.
fn collect(
    loaded: &Loaded,
    execution: Execution,
    options: &IntegratorOptions,
    t_end: f64,
) -> Result<Trajectory, Failure> {
    let mut sim = loaded.simulation(execution, options.clone(), loaded.start())?;
    let (trajectory, _) = sim.run(t_end, &loaded.signals())?;
    Ok(trajectory)
}

fn compare(args: &CompareArgs) -> Result<(), Failure> {
    let loaded = load(&args.model.file)?;
    let (options, t_end) = loaded.settings(&args.model)?;
    if !args.model.force {
        let steps = (t_end / options.h).round() as u64;
        guard::check_steps(steps, args.model.max_steps).map_err(Failure::Input)?;
        // Two trajectories (the reference and one representation) are held in memory at once.
        let bytes = steps
            .saturating_add(1)
            .saturating_mul(loaded.signals().len() as u64 + 1)
            .saturating_mul(16);
        if let Some(free) = guard::available_memory()
            && bytes > free
        {
            return Err(Failure::Input(format!(
                "compare holds two trajectories of {steps} steps in memory, about {bytes} bytes, more than the {free} available; use a larger h or a shorter t_end, or pass --force"
            )));
        }
    }
    let reference = collect(
        &loaded,
        Execution::Assembled(Representation::Monolithic),
        &options,
        t_end,
    )?;
    let mut results = Vec::new();
    for representation in [
        Representation::Monolithic,
        Representation::Constraint,
        Representation::InteractionForce,
    ] {
        let run = collect(
            &loaded,
            Execution::Assembled(representation),
            &options,
            t_end,
        )?;
        results.push((
            representation.to_string(),
            Some(run.max_deviation(&reference)),
            None::<String>,
        ));
    }
    for splitting in [Splitting::GaussSeidel, Splitting::Jacobi] {
        let execution = Execution::Staggered(splitting);
        let name = execution.to_string();
        if matches!(loaded, Loaded::Netlist { .. }) {
            results.push((
                name,
                None,
                Some("not applicable: a circuit's nodes are constraints between parts, not coupling elements".to_string()),
            ));
            continue;
        }
        match collect(&loaded, execution, &options, t_end) {
            Ok(run) => results.push((name, Some(run.max_deviation(&reference)), None)),
            Err(Failure::Input(why) | Failure::Numerical(why) | Failure::Interrupted(why)) => {
                results.push((name, None, Some(why)))
            }
        }
    }
    if args.json {
        let mut map = serde_json::Map::new();
        for (name, dev, note) in &results {
            let mut entry = serde_json::Map::new();
            entry.insert(
                "max_abs_deviation".into(),
                dev.map_or(serde_json::Value::Null, serde_json::Value::from),
            );
            if let Some(note) = note {
                entry.insert("note".into(), note.clone().into());
            }
            map.insert(name.clone(), entry.into());
        }
        let json = serde_json::json!({ "file": loaded.name(), "representations": map });
        println!("{json}");
    } else {
        println!("{:<16} {:>22}", "representation", "max |x - monolithic|");
        for (name, dev, note) in &results {
            match dev {
                Some(d) => println!("{name:<16} {d:>22.3e}"),
                None => println!(
                    "{name:<16} {:>22}  ({})",
                    "-",
                    note.as_deref().unwrap_or("")
                ),
            }
        }
    }
    Ok(())
}

fn check(args: &CheckArgs) -> Result<(), Failure> {
    let loaded = load(&args.file)?;
    let graph = loaded.graph();
    println!(
        "{}: {} parts, {} connections",
        loaded.name(),
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
        println!(
            "  {representation:<11} {n} coordinates, {m} constraint rows, {} unknowns per midpoint step",
            n + m
        );
    }
    let system = Assembler::assemble(graph, Representation::Monolithic)
        .map_err(|e| Failure::Input(e.to_string()))?;
    let n = system.coordinates();
    let mut hessian = dirac_core::LagrangianHessian::default();
    hessian.begin();
    system
        .model
        .lagrangian_hessian(&vec![0.0; n], &vec![0.0; n], &mut hessian);
    let mut regular = vec![false; n];
    for (r, c, v) in hessian.vv.iter() {
        if r == c && v != 0.0 {
            regular[r] = true;
        }
    }
    let degenerate: Vec<String> = (0..n)
        .filter(|&i| !regular[i])
        .map(|i| system.model.coordinate_name(i))
        .collect();
    println!(
        "  degenerate directions (no kinetic term): {}",
        if degenerate.is_empty() {
            "none".to_string()
        } else {
            degenerate.join(", ")
        }
    );
    let signals: Vec<String> = loaded.signals().iter().map(|s| s.name.clone()).collect();
    println!("  signals: {}", signals.join(", "));
    let start = match loaded.start() {
        Start::Given => "given values (UIC)",
        Start::SteadyState => "the operating point (steady state)",
    };
    println!("  start: {start}");
    if let Loaded::Netlist { circuit, .. } = &loaded
        && let Some((h, t)) = circuit.tran_settings()
    {
        println!("  .tran: h = {h}, t_end = {t} ({} steps)", (t / h).round());
    }
    for line in step_size_report(&loaded, args) {
        println!("{line}");
    }
    Ok(())
}

/// `dirac check`'s natural modes and step-size judgement (docs/math.md §8).
fn step_size_report(loaded: &Loaded, args: &CheckArgs) -> Vec<String> {
    let model = ModelArgs {
        file: args.file.clone(),
        representation: None,
        method: args.method,
        h: args.h,
        t_end: Some(0.0),
        max_steps: guard::DEFAULT_MAX_STEPS,
        force: false,
    };
    let options = match loaded.settings(&model) {
        Ok((options, _)) => options,
        Err(Failure::Input(why) | Failure::Numerical(why) | Failure::Interrupted(why)) => {
            return vec![format!(
                "  natural modes: not analysed ({why}; pass --h to judge a step size)"
            )];
        }
    };
    let start = loaded.start();
    let at = match start {
        Start::Given => "the initial state",
        Start::SteadyState => "the operating point",
    };
    let modes = loaded
        .simulation(
            Execution::Assembled(Representation::Monolithic),
            options.clone(),
            start,
        )
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
        Some(list) => split_signal_list(list)
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
    };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Commas inside parentheses belong to the signal (`v(a,b)`).
    #[test]
    fn signal_lists_split_outside_parentheses() {
        assert_eq!(
            split_signal_list("v(1), v(a,b),i(l1)"),
            ["v(1)", "v(a,b)", "i(l1)"]
        );
    }
}
