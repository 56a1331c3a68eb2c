//! `dirac`: run, compare, check and plot circuits and mechanisms with forced discrete Dirac
//! integrators.
//!
//! Exit codes: 0 success, 1 numerical failure (with the step index and residual), 2 bad input
//! (with the file, line and column, or the part, port or signal at fault). A failed run never
//! leaves a partial output file.

mod bench;

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand, ValueEnum};
use dirac_core::{Discretisation, Model};
use dirac_graph::{Assembler, Representation};
use dirac_io::{
    BuiltScene, Circuit, Execution, Recording, RunError, RunSettings, RunSummary, Scene,
    SceneSignal, Signal, build_circuit, parse_netlist, recorded_columns, run_circuit,
    run_scene_recorded,
};
use dirac_sim::{Scheme, SimError, Splitting};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

const LONG_ABOUT: &str = "\
dirac simulates circuits and mechanisms built from parts with forced discrete Dirac variational
integrators (Parks & Leok). One quadrature serves the Lagrangian and the forces, so a model gives the
same discrete trajectory whether its couplings are written as potentials, constraints or interaction
forces; `dirac compare` shows it.

Input files:
  *.cir, *.sp, *.net   SPICE-subset netlists (R L C V I K D, .tran, .param, .subckt, .ic, .model D)
  *.toml               scene files (parts, connections, integrator, what to record)

Examples:
  dirac run examples/netlists/seed_rlc.cir --out run.csv
  dirac run circuit.cir --signals 'v(out),i(l1)' --h 1e-3 --t-end 2
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
    /// Run every representation and report the max deviation of each from monolithic.
    Compare(CompareArgs),
    /// Validate a file and print a model summary (parts, coordinates, constraints, unknowns).
    Check(CheckArgs),
    /// Plot a CSV written by `dirac run` to SVG or PNG (by the output's extension).
    Plot(PlotArgs),
    /// Convert a netlist into an equivalent scene file.
    Convert(ConvertArgs),
    /// Work-precision sweep of a benchmark scene (bench/SCENES.md): one CSV row per run.
    Bench(BenchArgs),
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

impl RepresentationArg {
    fn assembled(self) -> Option<Representation> {
        match self {
            Self::Monolithic => Some(Representation::Monolithic),
            Self::Constraint => Some(Representation::Constraint),
            Self::Force => Some(Representation::InteractionForce),
            Self::Staggered => None,
        }
    }
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// Netlist (.cir, .sp, .net) or scene (.toml).
    file: PathBuf,
    /// Write the CSV here instead of streaming it to stdout. The file appears only when the run
    /// succeeds (it is written to `<out>.partial` and renamed).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Record only these signals, comma-separated, e.g. 'v(out),i(l1)'.
    #[arg(long)]
    signals: Option<String>,
    /// Representation to assemble (default: the scene's, or monolithic for netlists).
    #[arg(long, value_enum)]
    representation: Option<RepresentationArg>,
    /// Step size (overrides .tran TSTEP or the scene's h).
    #[arg(long)]
    h: Option<f64>,
    /// End time (overrides .tran TSTOP or the scene's t_end).
    #[arg(long = "t-end")]
    t_end: Option<f64>,
    /// Print a JSON summary (steps, Newton iterations per step, constraint residual, wall time) on stderr.
    #[arg(long)]
    json_summary: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, clap::Args)]
#[command(after_help = "\
Scenes (bench/SCENES.md): A seed RLC loop, B damped oscillator, C RLC ladders (--sections),
D1 stiff spring chain, D2 double pendulum, D2-long the pendulum to t = 1e4, E Henon-Heiles to
t = 1e4, F the SciMLBenchmarks RC ladder (n = 1000). Methods: midpoint and Gauss-Galerkin of 2, 3,
4 nodes (orders 2, 4, 6, 8), the opt-in affine step map on the linear scenes A and B, Yoshida
compositions of the midpoint step on E. Long runs (D2-long, E) also write the running maximum of
the energy error per tenth of the interval to the --out file with .csv replaced by .drift.csv.
CSV: scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error
The peers (scipy, SUNDIALS, ngspice) write the same columns: bench/peers/run.sh runs everything.")]
struct BenchArgs {
    /// Scene to sweep (A, B, C, D1, D2, D2-long, E, F; case does not matter).
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
    /// Netlist or scene.
    file: PathBuf,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// Step size override.
    #[arg(long)]
    h: Option<f64>,
    /// End time override.
    #[arg(long = "t-end")]
    t_end: Option<f64>,
}

#[derive(Debug, clap::Args)]
struct CheckArgs {
    /// Netlist or scene.
    file: PathBuf,
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
}

impl Failure {
    fn code(&self) -> u8 {
        match self {
            Self::Input(_) => 2,
            Self::Numerical(_) => 1,
        }
    }
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Sim(SimError::Newton { .. }) => Self::Numerical(e.to_string()),
            other => Self::Input(other.to_string()),
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(&args),
        Command::Compare(args) => compare(&args),
        Command::Check(args) => check(&args),
        Command::Plot(args) => plot(&args),
        Command::Convert(args) => convert(&args),
        Command::Bench(args) => bench_command(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            let (Failure::Input(message) | Failure::Numerical(message)) = &failure;
            eprintln!("error: {message}");
            ExitCode::from(failure.code())
        }
    }
}

/// A model ready to run: the circuit (graph, initial data, default signals, step, end time) and,
/// for scenes, the scene's own settings.
struct Loaded {
    circuit: Circuit,
    name: String,
    scene: Option<BuiltScene>,
}

impl Loaded {
    /// The representation asked for on the command line, else the scene's, else monolithic.
    fn execution(&self, arg: Option<RepresentationArg>) -> Execution {
        match (arg, &self.scene) {
            (Some(RepresentationArg::Staggered), Some(scene)) => match scene.execution {
                Execution::Staggered(s) => Execution::Staggered(s),
                Execution::Assembled(_) => Execution::Staggered(Splitting::GaussSeidel),
            },
            (Some(RepresentationArg::Staggered), None) => {
                Execution::Staggered(Splitting::GaussSeidel)
            }
            (Some(a), _) => {
                Execution::Assembled(a.assembled().unwrap_or(Representation::Monolithic))
            }
            (None, Some(scene)) => scene.execution,
            (None, None) => Execution::Assembled(Representation::Monolithic),
        }
    }
}

fn load(path: &Path) -> Result<Loaded, Failure> {
    let name = path.display().to_string();
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let text = std::fs::read_to_string(path).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    match extension.as_deref() {
        Some("cir" | "sp" | "net" | "spice") => {
            let netlist = parse_netlist(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
            for w in &netlist.warnings {
                eprintln!("warning: {name}:{}:{}: {}", w.line, w.column, w.message);
            }
            let circuit =
                build_circuit(&netlist, &name).map_err(|e| Failure::Input(e.to_string()))?;
            Ok(Loaded {
                circuit,
                name,
                scene: None,
            })
        }
        Some("toml") => {
            let scene = Scene::parse(&text, &name).map_err(|e| Failure::Input(e.to_string()))?;
            let built = scene.build().map_err(|e| Failure::Input(e.to_string()))?;
            Ok(Loaded {
                circuit: built.circuit(),
                name,
                scene: Some(built),
            })
        }
        _ => Err(Failure::Input(format!(
            "{name}: unknown file type (expected .cir, .sp, .net or .toml)"
        ))),
    }
}

fn settings(
    loaded: &Loaded,
    h: Option<f64>,
    t_end: Option<f64>,
    representation: Representation,
) -> Result<RunSettings, Failure> {
    let name = &loaded.name;
    let h = h
        .or(loaded.circuit.h)
        .ok_or_else(|| Failure::Input(format!("{name}: no .tran card and no --h")))?;
    let t_end = t_end
        .or(loaded.circuit.t_end)
        .ok_or_else(|| Failure::Input(format!("{name}: no .tran card and no --t-end")))?;
    if !(h > 0.0 && h.is_finite()) {
        return Err(Failure::Input(format!(
            "step size must be positive, got {h}"
        )));
    }
    if !(t_end >= 0.0 && t_end.is_finite()) {
        return Err(Failure::Input(format!(
            "end time must be non-negative, got {t_end}"
        )));
    }
    let (discretisation, scheme) = match &loaded.scene {
        Some(scene) => (scene.options.discretisation.clone(), scene.options.scheme),
        None => (Discretisation::midpoint(), Scheme::Plus),
    };
    Ok(RunSettings {
        h,
        t_end,
        representation,
        discretisation,
        scheme,
    })
}

/// The scene with step size and end time overridden, to run staggered with `splitting`.
fn scene_with(scene: &BuiltScene, settings: &RunSettings, execution: Execution) -> BuiltScene {
    let mut scene = scene.clone();
    scene.options.h = settings.h;
    scene.t_end = settings.t_end;
    scene.execution = execution;
    scene
}

fn select_signals(loaded: &Loaded, wanted: Option<&str>) -> Result<Vec<Signal>, Failure> {
    let circuit = &loaded.circuit;
    let Some(list) = wanted else {
        return Ok(circuit.signals.clone());
    };
    let mut out = Vec::new();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        if let Some(scene) = &loaded.scene {
            let signal = scene
                .signal(name)
                .map_err(|e| Failure::Input(e.to_string()))?;
            out.push(signal.to_signal());
            continue;
        }
        let lower = name.to_ascii_lowercase();
        match circuit.signals.iter().find(|s| s.name == lower) {
            Some(s) => out.push(s.clone()),
            None => {
                let available: Vec<&str> =
                    circuit.signals.iter().map(|s| s.name.as_str()).collect();
                return Err(Failure::Input(format!(
                    "unknown signal `{name}`; available: {}",
                    available.join(", ")
                )));
            }
        }
    }
    Ok(out)
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
            std::fs::rename(&tmp, &path)
                .map_err(|e| Failure::Input(format!("{}: {e}", path.display())))?;
        }
        Ok(())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Some((tmp, _)) = self.temporary.take() {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

fn run(args: &RunArgs) -> Result<(), Failure> {
    let loaded = load(&args.file)?;
    let execution = loaded.execution(args.representation);
    let representation = match execution {
        Execution::Assembled(r) => r,
        Execution::Staggered(_) if loaded.scene.is_none() => {
            return Err(Failure::Input(format!(
                "{}: staggered co-simulation needs coupling elements between subsystems; a circuit's nodes are constraints",
                loaded.name
            )));
        }
        Execution::Staggered(_) => Representation::Monolithic,
    };
    let settings = settings(&loaded, args.h, args.t_end, representation)?;
    let signals = select_signals(&loaded, args.signals.as_deref())?;
    // A scene's `[record]` energy, power, residuals and forces become extra columns.
    let recording = loaded
        .scene
        .as_ref()
        .map(|s| s.recording.clone())
        .filter(|r| *r != Recording::default());
    let extra_columns = match (&loaded.scene, &recording) {
        (Some(scene), Some(r)) => recorded_columns(&scene_with(scene, &settings, execution), r)
            .map_err(|e| Failure::Input(format!("{}: {e}", loaded.name)))?,
        _ => Vec::new(),
    };
    let mut out = Output::open(args.out.as_deref())?;
    let header: Vec<&str> = std::iter::once("t")
        .chain(signals.iter().map(|s| s.name.as_str()))
        .chain(extra_columns.iter().map(String::as_str))
        .collect();
    writeln!(out.writer, "{}", header.join(","))
        .map_err(|e| Failure::Input(format!("writing output: {e}")))?;
    let total = (settings.t_end / settings.h).round() as u64 + 1;
    let show_progress = !args.quiet && std::io::stderr().is_terminal();
    let started = Instant::now();
    let mut bar: Option<ProgressBar> = None;
    let mut rows = 0u64;
    let writer = &mut out.writer;
    let summary = execute(
        &loaded,
        &settings,
        execution,
        &signals,
        recording.as_ref(),
        |t, values| {
            let mut line = format!("{t}");
            for v in values {
                line.push(',');
                line.push_str(&v.to_string());
            }
            writeln!(writer, "{line}").map_err(|e| e.to_string())?;
            rows += 1;
            if show_progress && bar.is_none() && started.elapsed() > Duration::from_secs(1) {
                let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
                if let Ok(style) =
                    ProgressStyle::with_template("{bar:40} {pos}/{len} steps, {eta} left")
                {
                    b.set_style(style);
                }
                bar = Some(b);
            }
            if let Some(b) = &bar {
                b.set_position(rows);
            }
            Ok(())
        },
    )?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    out.commit()?;
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
    if args.json_summary {
        let representation = match execution {
            Execution::Assembled(r) => r.to_string(),
            Execution::Staggered(Splitting::GaussSeidel) => "staggered-gs".to_string(),
            Execution::Staggered(Splitting::Jacobi) => "staggered-jacobi".to_string(),
        };
        let json = serde_json::json!({
            "file": loaded.name,
            "representation": representation,
            "h": settings.h,
            "t_end": settings.t_end,
            "steps": summary.steps,
            "newton_iterations_per_step": summary.newton_iterations_per_step,
            "factorisations": summary.factorisations,
            "max_constraint_residual": summary.max_constraint_residual,
            "energy_drift": serde_json::Value::Null,
            "wall_s": summary.wall_s,
        });
        eprintln!("{json}");
    }
    Ok(())
}

/// Runs `loaded` in `execution` and streams rows of `signals` (then the `recording` columns of a
/// scene) to `row`.
fn execute(
    loaded: &Loaded,
    settings: &RunSettings,
    execution: Execution,
    signals: &[Signal],
    recording: Option<&Recording>,
    row: impl FnMut(f64, &[f64]) -> Result<(), String>,
) -> Result<RunSummary, Failure> {
    match (execution, &loaded.scene) {
        (_, Some(scene)) if recording.is_some() || matches!(execution, Execution::Staggered(_)) => {
            let scene = scene_with(scene, settings, execution);
            let scene_signals: Vec<SceneSignal> = signals
                .iter()
                .map(|s| scene.signal(&s.name))
                .collect::<Result<_, _>>()
                .map_err(|e| Failure::Input(e.to_string()))?;
            let recording = recording.cloned().unwrap_or_default();
            run_scene_recorded(&scene, &scene_signals, &recording, row).map_err(|e| {
                if e.is_numerical() {
                    Failure::Numerical(e.to_string())
                } else {
                    Failure::Input(e.to_string())
                }
            })
        }
        _ => Ok(run_circuit(&loaded.circuit, settings, signals, row)?),
    }
}

/// Runs one representation and returns all signals, row by row.
fn collect(
    loaded: &Loaded,
    settings: &RunSettings,
    execution: Execution,
) -> Result<Vec<Vec<f64>>, Failure> {
    let mut rows = Vec::new();
    execute(
        loaded,
        settings,
        execution,
        &loaded.circuit.signals,
        None,
        |_, v| {
            rows.push(v.to_vec());
            Ok(())
        },
    )?;
    Ok(rows)
}

fn compare(args: &CompareArgs) -> Result<(), Failure> {
    let loaded = load(&args.file)?;
    let base = settings(&loaded, args.h, args.t_end, Representation::Monolithic)?;
    let reference = collect(
        &loaded,
        &base,
        Execution::Assembled(Representation::Monolithic),
    )?;
    let deviation = |rows: &[Vec<f64>]| {
        rows.iter()
            .zip(&reference)
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0_f64, f64::max)
    };
    let mut results = Vec::new();
    for representation in [
        Representation::Monolithic,
        Representation::Constraint,
        Representation::InteractionForce,
    ] {
        let settings = RunSettings {
            representation,
            ..base.clone()
        };
        let rows = collect(&loaded, &settings, Execution::Assembled(representation))?;
        results.push((
            representation.to_string(),
            Some(deviation(&rows)),
            None::<String>,
        ));
    }
    for (name, splitting) in [
        ("staggered-gs", Splitting::GaussSeidel),
        ("staggered-jacobi", Splitting::Jacobi),
    ] {
        if loaded.scene.is_none() {
            results.push((
                name.to_string(),
                None,
                Some("not applicable: a circuit's nodes are constraints between parts, not coupling elements".to_string()),
            ));
            continue;
        }
        match collect(&loaded, &base, Execution::Staggered(splitting)) {
            Ok(rows) => results.push((name.to_string(), Some(deviation(&rows)), None)),
            Err(Failure::Input(why) | Failure::Numerical(why)) => {
                results.push((name.to_string(), None, Some(why)))
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
        let json = serde_json::json!({ "file": loaded.name, "representations": map });
        println!("{json}");
    } else {
        println!("{:<12} {:>22}", "representation", "max |x - monolithic|");
        for (name, dev, note) in &results {
            match dev {
                Some(d) => println!("{name:<12} {d:>22.3e}"),
                None => println!(
                    "{name:<12} {:>22}  ({})",
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
    let graph = &loaded.circuit.graph;
    println!(
        "{}: {} parts, {} connections",
        loaded.name,
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
    let signals: Vec<&str> = loaded
        .circuit
        .signals
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    println!("  signals: {}", signals.join(", "));
    if let (Some(h), Some(t)) = (loaded.circuit.h, loaded.circuit.t_end) {
        println!("  .tran: h = {h}, t_end = {t} ({} steps)", (t / h).round());
    }
    Ok(())
}

fn plot(args: &PlotArgs) -> Result<(), Failure> {
    let name = args.csv.display().to_string();
    let text =
        std::fs::read_to_string(&args.csv).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| Failure::Input(format!("{name}: empty file")))?
        .split(',')
        .collect();
    if header.first() != Some(&"t") {
        return Err(Failure::Input(format!(
            "{name}:1:1: the first column must be `t`"
        )));
    }
    let wanted: Vec<usize> = match &args.signals {
        None => (1..header.len()).collect(),
        Some(list) => list
            .split(',')
            .map(str::trim)
            .map(|s| {
                header
                    .iter()
                    .position(|h| h.eq_ignore_ascii_case(s))
                    .ok_or_else(|| Failure::Input(format!("{name}: no column `{s}`")))
            })
            .collect::<Result<_, _>>()?,
    };
    let mut series: Vec<Vec<(f64, f64)>> = vec![Vec::new(); header.len()];
    for (l, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != header.len() {
            return Err(Failure::Input(format!(
                "{name}:{}:1: expected {} fields, found {}",
                l + 2,
                header.len(),
                fields.len()
            )));
        }
        let mut values = Vec::with_capacity(fields.len());
        for (c, f) in fields.iter().enumerate() {
            let v: f64 = f.trim().parse().map_err(|_| {
                Failure::Input(format!("{name}:{}:{}: `{f}` is not a number", l + 2, c + 1))
            })?;
            values.push(v);
        }
        for &c in &wanted {
            series[c].push((values[0], values[c]));
        }
    }
    let title = args.csv.file_stem().map_or_else(
        || "dirac run".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let mut chart = dirac_plot::LineChart::new(title).x_label("t");
    for &c in &wanted {
        chart.push(dirac_plot::Series::new(
            header[c],
            std::mem::take(&mut series[c]),
        ));
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
fn work_precision_chart(rows: &[bench::BenchRow]) -> dirac_plot::LineChart {
    let ladder = rows.iter().any(|r| r.scene.starts_with("C-"));
    let mut methods: Vec<&str> = Vec::new();
    for row in rows {
        if !methods.contains(&row.method.as_str()) {
            methods.push(&row.method);
        }
    }
    let scene = rows.first().map_or("", |r| r.scene.as_str());
    let mut chart = if ladder {
        dirac_plot::LineChart::new("RLC ladder: stepping cost")
            .x_label("sections N")
            .y_label("µs per step per section")
    } else {
        dirac_plot::LineChart::new(format!("scene {scene}: work against precision"))
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
        chart.push(dirac_plot::Series::new(method, points).markers(true));
    }
    chart
}

/// Saves a chart as SVG or PNG by the path's extension.
fn save_chart(chart: &dirac_plot::LineChart, out: &Path) -> Result<(), Failure> {
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
    let scene =
        dirac_io::netlist_to_scene(&netlist, &name).map_err(|e| Failure::Input(e.to_string()))?;
    let mut out = Output::open(Some(&args.output))?;
    out.writer
        .write_all(scene.as_bytes())
        .map_err(|e| Failure::Input(format!("{}: {e}", args.output.display())))?;
    out.commit()
}
