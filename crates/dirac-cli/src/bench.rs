//! `dirac bench`: work-precision sweeps of the benchmark scenes defined in `bench/SCENES.md`.
//!
//! Every run goes through the run layer, [`Simulation`], as `dirac run` and the library's users
//! do: the scene is an interconnection (scene A is the seed netlist read by `dirac-netlist`; the
//! reference problems of `dirac-problems` are one-part interconnections), and the timed region
//! covers the simulation's set-up (assembly, consistent start) and its steps (best of three
//! repetitions, one when a run takes more than two seconds). The states it produces are stored
//! and the error against the scene's reference is evaluated after the clock stops, as the peers in
//! `bench/peers/` and `bench/compiled/` do.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use nalgebra::DVector;

use dirac_core::{Discretisation, Model};
use dirac_graph::{GraphError, Interconnection, Representation, Subsystem};
use dirac_netlist::{Circuit, CircuitError, NetlistError, build_circuit, parse_netlist};
use dirac_output::CsvSink;
use dirac_problems::{
    DampedOscillator, DoublePendulum, HenonHeiles, LadderSection, RcLadder, RlcLoop, SpringChain,
    rlc_exact, rlc_ladder,
};
use dirac_sim::{
    Composition, Execution, IntegratorOptions, RunError, Scheme, Signal, Simulation, Sink,
    StartRamp,
};

/// How every benchmark run is executed: one assembled monolithic system (`dirac run`'s default).
const EXECUTION: Execution = Execution::Assembled(Representation::Monolithic);

/// The seed netlist of scene A (`examples/netlists/seed_rlc.cir`: C = 3 F charged to 1 V).
const SEED_NETLIST: &str = include_str!("../../../examples/netlists/seed_rlc.cir");

/// The seed netlist's initial charge `C·V = 3`; scene A's error is divided by it so that it is the
/// error of the unit-charge run of `bench/SCENES.md` (the loop is linear).
const SEED_Q0: f64 = 3.0;

/// The CSV header shared with `bench/peers/peers.py`.
pub const HEADER: &str =
    "scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error";

/// The benchmark scenes of `bench/SCENES.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchScene {
    /// Seed RLC loop on [0, 50]: max |q_C − exact|.
    A,
    /// Damped oscillator m = k = 1, c = 0.01: error at t = 5T.
    B,
    /// RLC ladders of N sections, h = 0.01, 1000 steps: µs per step per section.
    C,
    /// Stiff spring chain (10 masses, springs 1 and 1e6): slow-mode and energy error at t = 10.
    D1,
    /// Double pendulum on [0, 100]: max energy error.
    D2,
    /// Double pendulum on [0, 10⁴]: phase error of θ₁ at 10⁴ and max energy error.
    #[value(name = "D2-long")]
    D2Long,
    /// Hénon–Heiles on [0, 10⁴]: max energy error.
    E,
    /// SciMLBenchmarks RC ladder, n = 1000, t ∈ [0, 10]: max capacitor-voltage error at t = 10.
    F,
    /// `dirac run` against the library's run of the same netlist (the seed loop and an RLC
    /// ladder netlist), and the bare process start-up: µs per step (per section).
    #[value(name = "CLI")]
    Cli,
}

/// One benchmark run: one CSV row.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchRow {
    /// Scene label (`A`, `B`, `C-1000`, `D1`, `D2`).
    pub scene: String,
    /// Method label, e.g. `gauss3`.
    pub method: String,
    /// Step size, or the number of sections for scene C.
    pub setting: f64,
    /// Best wall time of the timed region in seconds.
    pub wall_s: f64,
    /// Steps taken.
    pub steps: usize,
    /// Newton iterations over the run.
    pub newton_iterations: usize,
    /// The scene's error measure.
    pub error: f64,
    /// Max energy error (NaN where the scene defines none).
    pub energy_error: f64,
    /// Long runs (D2-long, E): running maximum of the energy error at the end of each tenth of
    /// the interval; empty otherwise.
    pub tenths: Vec<f64>,
}

impl BenchRow {
    /// The row as CSV (no trailing newline).
    #[must_use]
    pub fn csv(&self) -> String {
        format!(
            "{},dirac,{},{:e},{:e},{},{},{:e},{:e}",
            self.scene,
            self.method,
            self.setting,
            self.wall_s,
            self.steps,
            self.newton_iterations,
            self.error,
            self.energy_error
        )
    }

    /// The running maxima per tenth as a row of the `.drift.csv` side file (`None` when the
    /// scene is not a long run).
    #[must_use]
    pub fn drift_csv(&self) -> Option<String> {
        if self.tenths.is_empty() {
            return None;
        }
        let cells: Vec<String> = self.tenths.iter().map(|x| format!("{x:e}")).collect();
        Some(format!(
            "{},dirac,{},{:e},{}",
            self.scene,
            self.method,
            self.setting,
            cells.join(",")
        ))
    }
}

/// Header of the `.drift.csv` side file of the long runs.
pub const DRIFT_HEADER: &str = "scene,tool,method,setting,tenth1,tenth2,tenth3,tenth4,tenth5,tenth6,tenth7,tenth8,tenth9,tenth10";

/// Sweep settings.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Fewer step sizes and repetitions (smoke test).
    pub quick: bool,
    /// Ladder sizes for scene C.
    pub sections: Vec<usize>,
    /// Only these methods of a fixed-step scene (all when empty).
    pub methods: Vec<String>,
}

/// A Galerkin–Gauss discretisation of `s` nodes (order 2s), optionally applied as an affine map.
#[derive(Debug, Clone)]
struct Method {
    name: String,
    discretisation: Discretisation,
    affine: bool,
    composition: Composition,
    /// The start ramp ([`StartRamp`]; scene F).
    ramp: Option<StartRamp>,
}

fn gauss(s: usize, affine: bool) -> Method {
    let base = if s == 1 {
        "midpoint".to_string()
    } else {
        format!("gauss{s}")
    };
    Method {
        name: if affine {
            format!("{base}-affine")
        } else {
            base
        },
        discretisation: if s == 1 {
            Discretisation::midpoint()
        } else {
            Discretisation::gauss(s)
        },
        affine,
        composition: Composition::single(),
        ramp: None,
    }
}

/// [`gauss`] with the default start ramp (`-ramp` appended to the name).
fn ramped(s: usize) -> Method {
    let plain = gauss(s, false);
    Method {
        name: format!("{}-ramp", plain.name),
        ramp: Some(StartRamp::default()),
        ..plain
    }
}

/// The stock compositions by name (`yoshida4`, …, `kahan-li8`; [`Composition::NAMES`] without
/// `none`).
fn compositions() -> impl Iterator<Item = (&'static str, Composition)> {
    Composition::NAMES
        .into_iter()
        .filter(|name| *name != "none")
        .filter_map(|name| Composition::named(name).map(|c| (name, c)))
}

/// A composition of the midpoint step (implicit), named `midpoint-<composition>`.
fn composed_midpoint(name: &str, composition: Composition) -> Method {
    Method {
        name: format!("midpoint-{name}"),
        discretisation: Discretisation::midpoint(),
        affine: false,
        composition,
        ramp: None,
    }
}

/// Störmer–Verlet (the trapezoid rule, stepped explicitly on a separable model), alone
/// (`verlet`) or composed (`verlet-<composition>`).
fn verlet(name: Option<&str>, composition: Composition) -> Method {
    Method {
        name: name.map_or_else(|| "verlet".to_string(), |n| format!("verlet-{n}")),
        discretisation: Discretisation::trapezoid(),
        affine: false,
        composition,
        ramp: None,
    }
}

/// The midpoint compositions of the long runs (every stock composition).
fn midpoint_compositions() -> impl Iterator<Item = Method> {
    compositions().map(|(name, c)| composed_midpoint(name, c))
}

/// What a timed run hands back for error evaluation.
struct Record {
    /// `(q_k, p_k)` at the recorded steps, flattened as `q ‖ p` per record.
    states: Vec<f64>,
    steps: usize,
    newton_iterations: usize,
}

/// A one-part interconnection of a reference model (no ports: nothing is connected to it).
fn single<M: Model + Send + Sync + 'static>(model: M) -> Result<Interconnection, GraphError> {
    let mut graph = Interconnection::new();
    graph.add_subsystem(Subsystem::new("P", model))?;
    Ok(graph)
}

/// Runs the one-part interconnection `graph` through [`Simulation`] for `steps` steps from the
/// given `(q0, v0)`, recording `(q, p)` after every step (or only the last with `every = false`).
/// The bench's trapezoid runs are the `verlet` methods, timed as explicit Störmer–Verlet: a model
/// that does not take the explicit path is refused rather than timed under that name.
fn integrate(
    graph: Interconnection,
    options: IntegratorOptions,
    q0: &[f64],
    v0: &[f64],
    steps: usize,
    every: bool,
) -> Result<Record, RunError> {
    let verlet = options.discretisation.is_trapezoid();
    let mut sim = Simulation::new(graph, EXECUTION, options);
    sim.set_initial(&[q0.to_vec()], &[v0.to_vec()], &[], &[])?;
    sim.prepare()?;
    if verlet && !sim.assembled().is_some_and(|(_, i)| i.uses_explicit()) {
        return Err(RunError::Settings(
            "a verlet method on a model that is not stepped explicitly (not separable?)".into(),
        ));
    }
    let n = q0.len();
    let mut states = Vec::with_capacity(if every { (steps + 1) * 2 * n } else { 2 * n });
    let (mut q, mut p) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut record = |sim: &Simulation, states: &mut Vec<f64>| {
        sim.state_into(&mut q, &mut p);
        states.extend_from_slice(&q);
        states.extend_from_slice(&p);
    };
    if every {
        record(&sim, &mut states);
    }
    for _ in 0..steps {
        sim.step()?;
        if every {
            record(&sim, &mut states);
        }
    }
    if !every {
        record(&sim, &mut states);
    }
    Ok(Record {
        states,
        steps,
        newton_iterations: sim.summary().newton_iterations,
    })
}

/// A sink keeping the first signal of every row.
#[derive(Default)]
struct FirstColumn(Vec<f64>);

impl Sink for FirstColumn {
    fn begin(&mut self, _names: &[String]) -> Result<(), String> {
        Ok(())
    }
    fn row(&mut self, _k: usize, _t: f64, values: &[f64]) -> Result<(), String> {
        self.0.push(values.first().copied().unwrap_or(f64::NAN));
        Ok(())
    }
}

/// Best wall time of up to `repeats` runs (one when a run exceeds two seconds).
fn timed<T, E>(repeats: usize, mut run: impl FnMut() -> Result<T, E>) -> Result<(T, f64), E> {
    let start = Instant::now();
    let mut out = run()?;
    let mut best = start.elapsed().as_secs_f64();
    for _ in 1..repeats {
        if best > 2.0 {
            break;
        }
        let start = Instant::now();
        out = run()?;
        best = best.min(start.elapsed().as_secs_f64());
    }
    Ok((out, best))
}

/// A fixed-step scene: how to run one method at `n` steps and score the trajectory.
trait FixedStepScene {
    fn label(&self) -> &'static str;
    fn t_end(&self) -> f64;
    fn methods(&self) -> Vec<Method>;
    /// Step counts to try, coarse to fine; the sweep of a method stops early once its error
    /// reaches round-off.
    fn steps(&self, quick: bool) -> Vec<usize>;
    /// Step counts for one method (default: [`FixedStepScene::steps`]).
    fn steps_for(&self, _method: &Method, quick: bool) -> Vec<usize> {
        self.steps(quick)
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError>;
    /// `(error, energy_error)`.
    fn score(&self, trajectory: &Record, h: f64) -> (f64, f64);
    /// Running maximum of the energy error per tenth of the interval (long runs only).
    fn tenths(&self, _trajectory: &Record) -> Vec<f64> {
        Vec::new()
    }
}

/// Running maximum of `errors` (one per recorded state, equally spaced over the interval) at
/// the end of each tenth.
fn running_max_tenths(errors: &[f64]) -> Vec<f64> {
    let steps = errors.len().saturating_sub(1).max(1);
    let mut out = Vec::with_capacity(10);
    let mut running: f64 = 0.0;
    let mut next = 0;
    for tenth in 1..=10 {
        let end = (steps * tenth).div_ceil(10);
        while next <= end && next < errors.len() {
            running = running.max(errors[next]);
            next += 1;
        }
        out.push(running);
    }
    out
}

fn doubling(first: usize, count: usize) -> Vec<usize> {
    (0..count).map(|j| first << j).collect()
}

fn options(method: &Method, h: f64) -> IntegratorOptions {
    IntegratorOptions::new(method.discretisation.clone(), h)
        .affine_map(method.affine)
        .composition(method.composition.clone())
        .start_ramp(method.ramp)
}

/// Scene A: the seed netlist, read once; each run is `Circuit::simulation` and `run_into` with
/// the capacitor charge recorded at every step, as `dirac run --signals 'q(c1)'` does.
struct SceneA {
    circuit: Circuit,
    q_c: Signal,
}

impl SceneA {
    fn new() -> Result<Self, BenchError> {
        let circuit = seed_circuit()?;
        let q_c = circuit.signal("q(c1)")?;
        Ok(Self { circuit, q_c })
    }
}

/// The seed netlist as a circuit.
fn seed_circuit() -> Result<Circuit, BenchError> {
    let netlist = parse_netlist(SEED_NETLIST, "seed_rlc.cir")?;
    Ok(build_circuit(&netlist, "seed_rlc.cir")?)
}

impl FixedStepScene for SceneA {
    fn label(&self) -> &'static str {
        "A"
    }
    fn t_end(&self) -> f64 {
        50.0
    }
    fn methods(&self) -> Vec<Method> {
        gauss_family()
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        short_steps(quick)
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        let h = self.t_end() / n as f64;
        let mut sim =
            self.circuit
                .simulation(EXECUTION, options(method, h), self.circuit.start())?;
        let mut charge = FirstColumn::default();
        let summary = sim.run_into(self.t_end(), std::slice::from_ref(&self.q_c), &mut charge)?;
        Ok(Record {
            states: charge.0,
            steps: summary.steps,
            newton_iterations: summary.newton_iterations,
        })
    }
    fn score(&self, trajectory: &Record, h: f64) -> (f64, f64) {
        let rlc = RlcLoop::seed();
        let error = trajectory
            .states
            .iter()
            .enumerate()
            .map(|(k, q)| (q - rlc_exact(&rlc, SEED_Q0, k as f64 * h)).abs() / SEED_Q0)
            .fold(0.0, f64::max);
        (error, f64::NAN)
    }
}

/// Midpoint and Gauss 2–4, each with and without the affine map (scenes A and B).
fn gauss_family() -> Vec<Method> {
    let mut m: Vec<Method> = (1..=4).map(|s| gauss(s, false)).collect();
    m.extend((1..=4).map(|s| gauss(s, true)));
    m
}

/// Step counts of scenes A and B: 25 … 25·2¹⁶ (quick: every third of the first twelve).
fn short_steps(quick: bool) -> Vec<usize> {
    if quick {
        doubling(25, 12).into_iter().step_by(3).collect()
    } else {
        doubling(25, 17)
    }
}

struct SceneB;

const OSCILLATOR: DampedOscillator = DampedOscillator {
    m: 1.0,
    k: 1.0,
    c: 0.01,
};

impl FixedStepScene for SceneB {
    fn label(&self) -> &'static str {
        "B"
    }
    fn t_end(&self) -> f64 {
        5.0 * OSCILLATOR.period()
    }
    fn methods(&self) -> Vec<Method> {
        gauss_family()
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        short_steps(quick)
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        let h = self.t_end() / n as f64;
        integrate(
            single(OSCILLATOR)?,
            options(method, h),
            &[1.0],
            &[0.0],
            n,
            false,
        )
    }
    fn score(&self, trajectory: &Record, _h: f64) -> (f64, f64) {
        let (q, p) = OSCILLATOR.exact(1.0, 0.0, self.t_end());
        let x = &trajectory.states;
        ((x[0] - q).abs().max((x[1] - p).abs()), f64::NAN)
    }
}

struct SceneD1 {
    chain: SpringChain,
    x0: [f64; 10],
}

impl SceneD1 {
    fn new() -> Self {
        let mut x0 = [0.0; 10];
        x0[0] = 1.0;
        x0[1] = 1.001;
        Self {
            chain: SpringChain::alternating(10, 1e6),
            x0,
        }
    }
}

impl FixedStepScene for SceneD1 {
    fn label(&self) -> &'static str {
        "D1"
    }
    fn t_end(&self) -> f64 {
        10.0
    }
    fn methods(&self) -> Vec<Method> {
        (1..=3).map(|s| gauss(s, false)).collect()
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        // h = 0.2 … down to 1.2e-5: the first four (h ≥ 0.025) are ≥ 5× the fast period 4.44e-3.
        if quick {
            vec![50, 200, 800]
        } else {
            doubling(50, 15)
        }
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        let h = self.t_end() / n as f64;
        integrate(
            single(self.chain.clone())?,
            options(method, h),
            &self.x0,
            &[0.0; 10],
            n,
            true,
        )
    }
    fn score(&self, trajectory: &Record, _h: f64) -> (f64, f64) {
        let e0 = self.chain.energy(&self.x0, &[0.0; 10]);
        let energy = trajectory
            .states
            .chunks_exact(20)
            .map(|x| ((self.chain.energy(&x[..10], &x[10..]) - e0) / e0).abs())
            .fold(0.0, f64::max);
        // Slow-mode error: the state error projected on the five slowest normal modes, in
        // position and in momentum.
        let (xe, pe) = self.chain.exact(&self.x0, &[0.0; 10], self.t_end());
        let last = &trajectory.states[trajectory.states.len() - 20..];
        let dx: Vec<f64> = last[..10].iter().zip(&xe).map(|(a, b)| a - b).collect();
        let dp: Vec<f64> = last[10..].iter().zip(&pe).map(|(a, b)| a - b).collect();
        let modes = self.chain.slow_modes(5).transpose();
        let slow = (&modes * DVector::from_column_slice(&dx))
            .amax()
            .max((&modes * DVector::from_column_slice(&dp)).amax());
        (slow, energy)
    }
}

struct SceneD2;

impl FixedStepScene for SceneD2 {
    fn label(&self) -> &'static str {
        "D2"
    }
    fn t_end(&self) -> f64 {
        100.0
    }
    fn methods(&self) -> Vec<Method> {
        (1..=4).map(|s| gauss(s, false)).collect()
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        if quick {
            vec![2000, 8000]
        } else {
            doubling(1000, 10)
        }
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        self.run_to(method, n, self.t_end())
    }
    fn score(&self, trajectory: &Record, _h: f64) -> (f64, f64) {
        let energy = SceneD2Long::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        (energy, energy)
    }
}

impl SceneD2 {
    /// `n` steps over `[0, t_end]` from θ = (1, 0.5), θ̇ = 0, every state recorded.
    fn run_to(&self, method: &Method, n: usize, t_end: f64) -> Result<Record, RunError> {
        let h = t_end / n as f64;
        integrate(
            single(DoublePendulum::unit())?,
            options(method, h),
            &[1.0, 0.5],
            &[0.0, 0.0],
            n,
            true,
        )
    }
}

/// θ₁(10⁴) of D2 from θ = (1, 0.5), θ̇ = 0: the converged reference of the D2-long phase error
/// (bench/SCENES.md says how it was obtained and how far it is converged).
pub const D2_LONG_THETA1: f64 = -0.147_651_889_63;

/// The double pendulum on [0, 10⁴]: phase error of θ₁ at 10⁴, max energy error, and its running
/// maximum per tenth.
struct SceneD2Long;

impl SceneD2Long {
    fn energy_errors(trajectory: &Record) -> Vec<f64> {
        let pendulum = DoublePendulum::unit();
        let e0 = pendulum.energy(&[1.0, 0.5], &[0.0, 0.0]);
        trajectory
            .states
            .chunks_exact(4)
            .map(|x| (pendulum.hamiltonian(&x[..2], &x[2..]) - e0).abs())
            .collect()
    }
}

impl FixedStepScene for SceneD2Long {
    fn label(&self) -> &'static str {
        "D2-long"
    }
    fn t_end(&self) -> f64 {
        1e4
    }
    fn methods(&self) -> Vec<Method> {
        let mut m: Vec<Method> = (1..=4).map(|s| gauss(s, false)).collect();
        m.extend(midpoint_compositions());
        m
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        if quick {
            vec![50_000]
        } else {
            doubling(100_000, 4)
        }
    }
    fn steps_for(&self, method: &Method, quick: bool) -> Vec<usize> {
        // Each method from the step size where its energy error nears 1e-8 down to 1e-10 and
        // below (D2 measurements on [0, 100]); 10⁵ … 8·10⁵ steps (quick: one coarse run each).
        // The Gauss steps, whose energy error no longer drifts, in quarter octaves: at order 6
        // and 8 a doubling moves the error by 64 and 256, which would step over the 1e-10 level.
        if quick {
            return self.steps(true);
        }
        let (first, per_octave) = match method.name.as_str() {
            "midpoint" => (800_000, 1),
            "gauss2" => (400_000, 1),
            "gauss3" | "gauss4" => (100_000, 4),
            _ => (100_000, 1),
        };
        (0..=3 * per_octave)
            .map(|j| {
                let octaves = f64::from(j) / f64::from(per_octave);
                (first as f64 * octaves.exp2()).round() as usize
            })
            .filter(|&n| n <= 800_000)
            .collect()
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        SceneD2.run_to(method, n, self.t_end())
    }
    fn score(&self, trajectory: &Record, _h: f64) -> (f64, f64) {
        let energy = Self::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        let last = &trajectory.states[trajectory.states.len() - 4..];
        ((last[0] - D2_LONG_THETA1).abs(), energy)
    }
    fn tenths(&self, trajectory: &Record) -> Vec<f64> {
        running_max_tenths(&Self::energy_errors(trajectory))
    }
}

/// Hénon–Heiles on [0, 10⁴] from the SciMLBenchmarks state: max energy error.
struct SceneE;

impl SceneE {
    fn energy_errors(trajectory: &Record) -> Vec<f64> {
        let e0 = HenonHeiles::hamiltonian(&HenonHeiles::Q0, &HenonHeiles::P0);
        trajectory
            .states
            .chunks_exact(4)
            .map(|x| (HenonHeiles::hamiltonian(&x[..2], &x[2..]) - e0).abs())
            .collect()
    }
}

impl FixedStepScene for SceneE {
    fn label(&self) -> &'static str {
        "E"
    }
    fn t_end(&self) -> f64 {
        1e4
    }
    fn methods(&self) -> Vec<Method> {
        let mut m: Vec<Method> = (1..=4).map(|s| gauss(s, false)).collect();
        m.extend(midpoint_compositions());
        // Separable: the trapezoid rule runs explicitly (no Newton iteration).
        m.push(verlet(None, Composition::single()));
        m.extend(compositions().map(|(name, c)| verlet(Some(name), c)));
        m
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        // h = 0.4 … 0.003
        if quick {
            vec![25_000]
        } else {
            doubling(25_000, 8)
        }
    }
    fn run(&self, method: &Method, n: usize) -> Result<Record, RunError> {
        let h = self.t_end() / n as f64;
        integrate(
            single(HenonHeiles)?,
            options(method, h),
            &HenonHeiles::Q0,
            &HenonHeiles::P0,
            n,
            true,
        )
    }
    fn score(&self, trajectory: &Record, _h: f64) -> (f64, f64) {
        let energy = Self::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        (energy, energy)
    }
    fn tenths(&self, trajectory: &Record) -> Vec<f64> {
        running_max_tenths(&Self::energy_errors(trajectory))
    }
}

/// A run longer than this ends its method's sweep (the next step size would take twice as long).
const SLOW_RUN_S: f64 = 15.0;

/// Sweeps one fixed-step scene, calling `emit` with each row as soon as it is measured.
fn sweep(
    scene: &dyn FixedStepScene,
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    let repeats = if options.quick { 1 } else { 3 };
    let chosen = scene
        .methods()
        .into_iter()
        .filter(|m| options.methods.is_empty() || options.methods.contains(&m.name));
    for method in chosen {
        let mut previous = f64::INFINITY;
        for n in scene.steps_for(&method, options.quick) {
            let h = scene.t_end() / n as f64;
            let (trajectory, wall) = match timed(repeats, || scene.run(&method, n)) {
                Ok(out) => out,
                Err(e) => {
                    // A step size too coarse for Newton is a data point, not a failed sweep.
                    eprintln!(
                        "{} {} h = {h:e}: no result ({e}); trying smaller steps",
                        scene.label(),
                        method.name
                    );
                    continue;
                }
            };
            let (error, energy_error) = scene.score(&trajectory, h);
            emit(BenchRow {
                scene: scene.label().to_string(),
                method: method.name.clone(),
                setting: h,
                wall_s: wall,
                steps: trajectory.steps,
                newton_iterations: trajectory.newton_iterations,
                error,
                energy_error,
                tenths: scene.tenths(&trajectory),
            })?;
            // Past round-off, smaller steps only cost time.
            if error < 1e-13 || error > 0.5 * previous && error < 1e-10 {
                break;
            }
            // The next (halved) step would take twice as long: keep the sweep within minutes.
            if wall > SLOW_RUN_S {
                eprintln!(
                    "{} {} h = {h:e}: {wall:.1} s, smaller steps skipped",
                    scene.label(),
                    method.name
                );
                break;
            }
            previous = error;
        }
    }
    Ok(())
}

/// A sink that drops every row (runs whose score needs only the final state).
struct Discard;

impl Sink for Discard {
    fn begin(&mut self, _names: &[String]) -> Result<(), String> {
        Ok(())
    }
    fn row(&mut self, _k: usize, _t: f64, _values: &[f64]) -> Result<(), String> {
        Ok(())
    }
}

/// Scene C: the ladder's stepping time per step and section, through [`Simulation::step`]
/// (assembly and the consistent start are not timed; ngspice's `trantime` likewise excludes
/// parsing and the operating point).
fn ladder(
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    const STEPS: usize = 1000;
    for &n in &options.sections {
        let graph = rlc_ladder(n, LADDER_SECTION)?;
        let repeats = if options.quick || n >= 10_000 { 1 } else { 3 };
        let mut best = f64::INFINITY;
        let mut iterations = 0;
        for _ in 0..repeats {
            let mut sim = Simulation::new(
                graph.clone(),
                EXECUTION,
                IntegratorOptions::new(Discretisation::midpoint(), 0.01),
            );
            sim.prepare()?;
            let start = Instant::now();
            for _ in 0..STEPS {
                sim.step()?;
            }
            best = best.min(start.elapsed().as_secs_f64());
            iterations = sim.summary().newton_iterations;
        }
        emit(BenchRow {
            scene: format!("C-{n}"),
            method: "midpoint".to_string(),
            setting: n as f64,
            wall_s: best,
            steps: STEPS,
            newton_iterations: iterations,
            error: best / STEPS as f64 / n as f64 * 1e6,
            energy_error: f64::NAN,
            tenths: Vec::new(),
        })?;
        if n <= LADDER_ACCURACY_MAX {
            ladder_accuracy(&graph, n, repeats, emit)?;
        }
    }
    Ok(())
}

/// The section of scene C's ladders: R = 0.1, L = C = 1.
const LADDER_SECTION: LadderSection = LadderSection {
    r: 0.1,
    l: 1.0,
    c: 1.0,
};

/// Largest ladder whose accuracy rows (`Cacc-N`) are measured: the Gauss-4 reference run costs
/// several times the midpoint run.
const LADDER_ACCURACY_MAX: usize = 10_000;

/// The runs of scene C's accuracy rows: the scene's own configuration (midpoint, h = 0.01) first,
/// then Gauss 2–4 at steps up to the ladder's slowest time scale (its highest frequency is 2
/// rad/s), so that dirac's cheapest configuration at the midpoint run's accuracy is measured,
/// not assumed.
const LADDER_ACCURACY_RUNS: [(usize, f64); 10] = [
    (1, 0.01),
    (2, 0.05),
    (2, 0.1),
    (2, 0.2),
    (3, 0.2),
    (3, 0.5),
    (3, 1.0),
    (4, 0.5),
    (4, 1.0),
    (4, 2.0),
];

/// Runs the ladder `graph` through [`Simulation::run_into`] to t = 10 with `discretisation` at
/// step `h`; returns the capacitor voltages at t = 10, the wall time of the whole solve
/// (assembly, consistent start, stepping), the steps and the Newton iterations.
fn ladder_voltages(
    graph: &Interconnection,
    discretisation: Discretisation,
    h: f64,
) -> Result<(Vec<f64>, f64, usize, usize), RunError> {
    let graph = graph.clone();
    let offsets = graph.coordinate_offsets();
    let parts = graph.subsystems().len();
    let start = Instant::now();
    let mut sim = Simulation::new(graph, EXECUTION, IntegratorOptions::new(discretisation, h));
    let summary = sim.run_into(10.0, &[], &mut Discard)?;
    let wall = start.elapsed().as_secs_f64();
    // Section k (part k, after the source) holds (q_s, q_c); C = 1, so v = q_c.
    let q = sim.positions();
    let voltages = (1..parts).map(|k| q[offsets[k] + 1]).collect();
    Ok((voltages, wall, summary.steps, summary.newton_iterations))
}

/// Scene C's accuracy rows `Cacc-N`: each run of [`LADDER_ACCURACY_RUNS`], its max
/// capacitor-voltage error at t = 10 against Gauss 4 (order 8) at h = 0.01 (its error
/// ~(ωh)⁸ ≈ 1e-14 here), timed as a whole solve so the compiled peers' rows compare.
fn ladder_accuracy(
    graph: &Interconnection,
    n: usize,
    repeats: usize,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    let (reference, ..) = ladder_voltages(graph, Discretisation::gauss(4), 0.01)?;
    for (s, h) in LADDER_ACCURACY_RUNS {
        let method = gauss(s, false);
        let mut best = f64::INFINITY;
        let mut result = (Vec::new(), 0, 0);
        for _ in 0..repeats {
            let (v, wall, steps, iterations) =
                ladder_voltages(graph, method.discretisation.clone(), h)?;
            best = best.min(wall);
            result = (v, steps, iterations);
        }
        let error = result
            .0
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        emit(BenchRow {
            scene: format!("Cacc-{n}"),
            method: method.name,
            setting: h,
            wall_s: best,
            steps: result.1,
            newton_iterations: result.2,
            error,
            energy_error: f64::NAN,
            tenths: Vec::new(),
        })?;
    }
    Ok(())
}

/// Scene F: the SciMLBenchmarks RC ladder (n = 1000) to t = 10 with midpoint and Gauss 2–4 at
/// h = 1e-2 … 1e-4, and with the start ramp (`-ramp`) at h = 5e-2 … 1e-3. Two rows per run: `F`
/// timed from the simulation's creation to the last step (the "solve": assembly, consistent
/// start, stepping), `F-whole` from building the graph.
fn rc_ladder_scene(
    settings: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    const N: usize = 1000;
    const T_END: f64 = 10.0;
    let ladder = RcLadder { n: N };
    let exact = ladder.exact().voltages(T_END);
    // Per part: the source's coordinate, then (q_s, q_c) of each section. The charges are given;
    // the currents are left to the consistent start (the Lagrangian is degenerate).
    let flat = ladder.initial_coordinates();
    let mut q0 = vec![vec![flat[0]]];
    q0.extend(flat[1..].chunks_exact(2).map(<[f64]>::to_vec));
    let v0: Vec<Vec<f64>> = q0.iter().map(|q| vec![0.0; q.len()]).collect();
    let given_q: Vec<Vec<bool>> = q0.iter().map(|q| vec![true; q.len()]).collect();
    let given_v: Vec<Vec<bool>> = q0.iter().map(|q| vec![false; q.len()]).collect();
    // Without the ramp the fast modes ring (audit item 13): h down to 1e-4. With it the error
    // is the slow response's truncation error, and steps from 5e-2 (two per period of the
    // 10 Hz drive) to 1e-3 bracket the target accuracies.
    let plain_hs: &[f64] = if settings.quick {
        &[1e-2]
    } else {
        &[1e-2, 1e-3, 1e-4]
    };
    let ramp_hs: &[f64] = if settings.quick {
        &[1e-2]
    } else {
        &[5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3]
    };
    let runs = (1..=4)
        .map(|s| (gauss(s, false), plain_hs))
        .chain((1..=4).map(|s| (ramped(s), ramp_hs)));
    let repeats = if settings.quick { 1 } else { 3 };
    for (method, hs) in runs {
        for &h in hs {
            let steps = (T_END / h).round() as usize;
            let mut best = (f64::INFINITY, f64::INFINITY);
            let mut last = (Vec::new(), 0);
            for _ in 0..repeats {
                let start = Instant::now();
                let graph = ladder.graph()?;
                let built = start.elapsed().as_secs_f64();
                let offsets = graph.coordinate_offsets();
                let solve_start = Instant::now();
                let mut sim = Simulation::new(graph, EXECUTION, options(&method, h));
                sim.set_initial(&q0, &v0, &given_q, &given_v)?;
                let summary = sim.run_into(T_END, &[], &mut Discard)?;
                let solve = solve_start.elapsed().as_secs_f64();
                if solve < best.0 {
                    best = (solve, built + solve);
                }
                let q = sim.positions();
                last = (
                    (1..=N)
                        .map(|k| q[offsets[k] + 1] / RcLadder::capacitance(k))
                        .collect(),
                    summary.newton_iterations,
                );
                if built + solve > 2.0 {
                    break;
                }
            }
            let error = last
                .0
                .iter()
                .zip(&exact)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            for (scene, wall) in [("F", best.0), ("F-whole", best.1)] {
                emit(BenchRow {
                    scene: scene.to_string(),
                    method: method.name.clone(),
                    setting: h,
                    wall_s: wall,
                    steps,
                    newton_iterations: last.1,
                    error,
                    energy_error: f64::NAN,
                    tenths: Vec::new(),
                })?;
            }
        }
    }
    Ok(())
}

/// An RLC ladder netlist equal to scene C's: a 1 V DC source, `n` sections of a series 0.1 Ω
/// resistor and 1 H inductor and a shunt 1 F capacitor, h = 0.01 to t = 10 from rest.
fn ladder_netlist(n: usize) -> String {
    let mut text = format!("RLC ladder, {n} sections\nV1 n0 0 DC 1\n");
    for k in 1..=n {
        text.push_str(&format!(
            "R{k} n{} m{k} 0.1\nL{k} m{k} n{k} 1\nC{k} n{k} 0 1\n",
            k - 1
        ));
    }
    text.push_str(".tran 0.01 10 uic\n.end\n");
    text
}

/// What `dirac run` does inside its process, through the library: read the netlist, build the
/// circuit, run it with its `.tran` settings and write `signals` (all defaults when `None`) as CSV
/// to `out`. Returns the steps.
fn library_run(text: &str, signals: Option<&str>, out: &Path) -> Result<usize, BenchError> {
    let netlist = parse_netlist(text, "bench.cir")?;
    let circuit = build_circuit(&netlist, "bench.cir")?;
    let (h, t_end) = circuit
        .tran_settings()
        .ok_or_else(|| BenchError::Cli("the netlist has no .tran card".into()))?;
    let method = circuit
        .method
        .clone()
        .unwrap_or_else(Discretisation::midpoint);
    let signals = match signals {
        Some(name) => vec![circuit.signal(name)?],
        None => circuit.default_signals().to_vec(),
    };
    let mut sim = circuit.simulation(
        EXECUTION,
        IntegratorOptions::new(method, h).scheme(Scheme::Plus),
        circuit.start(),
    )?;
    let file = std::io::BufWriter::new(std::fs::File::create(out)?);
    let mut csv = CsvSink::new(file);
    let summary = sim.run_into(t_end, &signals, &mut csv)?;
    csv.finish()?;
    Ok(summary.steps)
}

/// Runs this executable with `args`; an unsuccessful exit is an error.
fn process(args: &[&str]) -> Result<(), BenchError> {
    let exe = std::env::current_exe()?;
    let output = Command::new(exe).args(args).output()?;
    if output.status.success() {
        Ok(())
    } else {
        Err(BenchError::Cli(format!(
            "dirac {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&output.stderr).trim()
        )))
    }
}

/// Removes `path` if it exists.
fn remove_if_present(path: &Path) -> std::io::Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

/// Scene CLI: `dirac run` (a child process, whole wall time) against the library doing the same
/// in-process ([`library_run`]), and `dirac --version` (process start-up and exit alone), on the
/// seed netlist and on RLC ladder netlists. Repetitions are interleaved (start-up, library, CLI,
/// start-up, …) and the best of each is kept, so load changes hit all three alike. The error
/// column holds µs per step (seed) or per step and section (ladders) of the row's wall time.
fn cli(
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    let dir = std::env::temp_dir().join(format!("dirac-bench-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let result = cli_in(&dir, options, emit);
    // Best effort: a leftover temporary directory is not worth failing the benchmark for.
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn cli_in(
    dir: &Path,
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    let sizes: &[usize] = if options.quick {
        &[1000]
    } else {
        &[1000, 100_000]
    };
    let mut cases: Vec<(String, String, Option<String>, f64)> =
        vec![("CLI-seed".to_string(), SEED_NETLIST.to_string(), None, 1.0)];
    for &n in sizes {
        cases.push((
            format!("CLI-ladder-{n}"),
            ladder_netlist(n),
            Some(format!("v(n{n})")),
            n as f64,
        ));
    }
    let out = dir.join("out.csv");
    let out_arg = out.to_string_lossy().to_string();
    for (scene, text, signal, sections) in cases {
        let file = dir.join(format!("{scene}.cir"));
        std::fs::write(&file, &text)?;
        let file_arg = file.to_string_lossy().to_string();
        let mut cli_args = vec![
            "run",
            file_arg.as_str(),
            "--quiet",
            "--out",
            out_arg.as_str(),
        ];
        if let Some(signal) = &signal {
            cli_args.extend(["--signals", signal.as_str()]);
        }
        let repeats = match (sections > 1.0, options.quick) {
            (false, true) => 5,
            (false, false) => 20,
            (true, _) if sections >= 10_000.0 => 1,
            (true, true) => 1,
            (true, false) => 3,
        };
        let mut best = [f64::INFINITY; 3];
        let mut steps = 0;
        for _ in 0..repeats {
            let start = Instant::now();
            process(&["--version"])?;
            best[0] = best[0].min(start.elapsed().as_secs_f64());
            // Both write a new file: `dirac run` replaces an existing one by renaming over it,
            // which on ext4 waits for the data to reach the disk (auto_da_alloc).
            remove_if_present(&out)?;
            let start = Instant::now();
            steps = library_run(&text, signal.as_deref(), &out)?;
            best[1] = best[1].min(start.elapsed().as_secs_f64());
            remove_if_present(&out)?;
            let start = Instant::now();
            process(&cli_args)?;
            best[2] = best[2].min(start.elapsed().as_secs_f64());
        }
        for (method, wall) in ["process-start", "library", "dirac-run"].iter().zip(best) {
            emit(BenchRow {
                scene: scene.clone(),
                method: (*method).to_string(),
                setting: sections,
                wall_s: wall,
                steps,
                newton_iterations: 0,
                error: wall / steps.max(1) as f64 / sections * 1e6,
                energy_error: f64::NAN,
                tenths: Vec::new(),
            })?;
        }
    }
    Ok(())
}

/// Why a benchmark stopped.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A graph could not be built.
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// A run failed (fixed-step sweeps skip failed step sizes instead).
    #[error(transparent)]
    Run(#[from] RunError),
    /// A benchmark netlist could not be read.
    #[error(transparent)]
    Netlist(#[from] NetlistError),
    /// A benchmark netlist could not be turned into a circuit.
    #[error(transparent)]
    Circuit(#[from] CircuitError),
    /// `dirac run` (as a child process) failed.
    #[error("{0}")]
    Cli(String),
    /// Writing the CSV or a temporary file failed.
    #[error("writing the CSV: {0}")]
    Io(#[from] std::io::Error),
    /// `--methods` on a scene whose runs are fixed (C, F, CLI).
    #[error("--methods selects methods of the fixed-step scenes A, B, D1, D2, D2-long and E only")]
    MethodsNotSwept,
    /// `--methods` names a method the scene does not run.
    #[error("--methods: scene {scene} has no method `{name}` (its methods: {known})")]
    UnknownMethod {
        scene: &'static str,
        name: String,
        known: String,
    },
}

/// Checks `--methods` against the methods `scene` sweeps (any list passes when it is empty).
///
/// # Errors
/// [`BenchError::MethodsNotSwept`] on C, F and CLI; [`BenchError::UnknownMethod`] naming the
/// first method the scene does not run.
pub fn check_methods(scene: BenchScene, methods: &[String]) -> Result<(), BenchError> {
    if methods.is_empty() {
        return Ok(());
    }
    let fixed: Box<dyn FixedStepScene> = match scene {
        BenchScene::A => Box::new(SceneA::new()?),
        BenchScene::B => Box::new(SceneB),
        BenchScene::D1 => Box::new(SceneD1::new()),
        BenchScene::D2 => Box::new(SceneD2),
        BenchScene::D2Long => Box::new(SceneD2Long),
        BenchScene::E => Box::new(SceneE),
        BenchScene::C | BenchScene::F | BenchScene::Cli => {
            return Err(BenchError::MethodsNotSwept);
        }
    };
    let known: Vec<String> = fixed.methods().into_iter().map(|m| m.name).collect();
    match methods.iter().find(|name| !known.contains(name)) {
        Some(name) => Err(BenchError::UnknownMethod {
            scene: fixed.label(),
            name: name.clone(),
            known: known.join(", "),
        }),
        None => Ok(()),
    }
}

/// Runs the sweep of `scene`, handing each row to `emit` as it is measured. `options.methods`
/// is taken as checked by [`check_methods`] (the command checks it before writing any output).
///
/// # Errors
/// A failed ladder run, or `emit` failing.
pub fn run(
    scene: BenchScene,
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    match scene {
        BenchScene::A => sweep(&SceneA::new()?, options, emit),
        BenchScene::B => sweep(&SceneB, options, emit),
        BenchScene::C => ladder(options, emit),
        BenchScene::D1 => sweep(&SceneD1::new(), options, emit),
        BenchScene::D2 => sweep(&SceneD2, options, emit),
        BenchScene::D2Long => sweep(&SceneD2Long, options, emit),
        BenchScene::E => sweep(&SceneE, options, emit),
        BenchScene::F => rc_ladder_scene(options, emit),
        BenchScene::Cli => cli(options, emit),
    }
}
