//! `dirac bench`: work-precision sweeps of the benchmark scenes defined in `bench/SCENES.md`.
//!
//! Each run builds the model, initialises and steps it inside the timed region (best of three
//! repetitions, one when a run takes more than two seconds); the states it produces are stored and
//! the error against the scene's reference is evaluated after the clock stops, as the peers in
//! `bench/peers/` do.

use std::time::Instant;

use nalgebra::DVector;

use dirac_core::{Constraints, Discretisation, Model, NoConstraints};
use dirac_graph::{Assembler, Representation, SubsystemId};
use dirac_problems::{
    DampedOscillator, DoublePendulum, HenonHeiles, LadderSection, RcLadder, RlcLoop, SpringChain,
    rlc_exact, rlc_ladder,
};
use dirac_sim::{Composition, Integrator, IntegratorOptions, SimError};

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
}

/// A Galerkin–Gauss discretisation of `s` nodes (order 2s), optionally applied as an affine map.
#[derive(Debug, Clone)]
struct Method {
    name: String,
    discretisation: Discretisation,
    affine: bool,
    composition: Composition,
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
    }
}

/// Yoshida's composition of `order` (4, 6, 8) of the midpoint step.
fn composed_midpoint(order: usize) -> Method {
    let composition = match order {
        4 => Composition::yoshida4(),
        6 => Composition::yoshida6(),
        _ => Composition::yoshida8(),
    };
    Method {
        name: format!("midpoint-yoshida{}", composition.order()),
        discretisation: Discretisation::midpoint(),
        affine: false,
        composition,
    }
}

/// What a timed run hands back for error evaluation.
struct Trajectory {
    /// `(q_k, p_k)` at the recorded steps, flattened as `q ‖ p` per record.
    states: Vec<f64>,
    steps: usize,
    newton_iterations: usize,
}

/// Runs `steps` steps from `(q0, v0)` and records every state (or only the last with
/// `every = false`).
fn integrate<M: Model, C: Constraints>(
    model: M,
    constraints: C,
    options: IntegratorOptions,
    q0: &[f64],
    v0: &[f64],
    steps: usize,
    every: bool,
) -> Result<Trajectory, SimError> {
    let mut sim = Integrator::new(model, constraints, options)?;
    sim.initialise(q0, v0, 0.0)?;
    let n = q0.len();
    let mut states = Vec::with_capacity(if every { (steps + 1) * 2 * n } else { 2 * n });
    if every {
        states.extend_from_slice(sim.q());
        states.extend_from_slice(sim.p());
    }
    for _ in 0..steps {
        sim.step()?;
        if every {
            states.extend_from_slice(sim.q());
            states.extend_from_slice(sim.p());
        }
    }
    if !every {
        states.extend_from_slice(sim.q());
        states.extend_from_slice(sim.p());
    }
    Ok(Trajectory {
        states,
        steps,
        newton_iterations: sim.stats().iterations,
    })
}

/// Best wall time of up to `repeats` runs (one when a run exceeds two seconds).
fn timed<T>(
    repeats: usize,
    mut run: impl FnMut() -> Result<T, SimError>,
) -> Result<(T, f64), SimError> {
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
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError>;
    /// `(error, energy_error)`.
    fn score(&self, trajectory: &Trajectory, h: f64) -> (f64, f64);
    /// Running maximum of the energy error per tenth of the interval (long runs only).
    fn tenths(&self, _trajectory: &Trajectory) -> Vec<f64> {
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
}

struct SceneA;

impl FixedStepScene for SceneA {
    fn label(&self) -> &'static str {
        "A"
    }
    fn t_end(&self) -> f64 {
        50.0
    }
    fn methods(&self) -> Vec<Method> {
        let mut m: Vec<Method> = (1..=4).map(|s| gauss(s, false)).collect();
        m.extend((1..=4).map(|s| gauss(s, true)));
        m
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        if quick {
            doubling(25, 12).into_iter().step_by(3).collect()
        } else {
            doubling(25, 17)
        }
    }
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        let h = self.t_end() / n as f64;
        integrate(
            RlcLoop::seed(),
            RlcLoop::kcl(),
            options(method, h),
            &[1.0, 0.0, 0.0],
            &[0.0; 3],
            n,
            true,
        )
    }
    fn score(&self, trajectory: &Trajectory, h: f64) -> (f64, f64) {
        let rlc = RlcLoop::seed();
        let error = trajectory
            .states
            .chunks_exact(6)
            .enumerate()
            .map(|(k, x)| (x[0] - rlc_exact(&rlc, 1.0, k as f64 * h)).abs())
            .fold(0.0, f64::max);
        (error, f64::NAN)
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
        SceneA.methods()
    }
    fn steps(&self, quick: bool) -> Vec<usize> {
        SceneA.steps(quick)
    }
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        let h = self.t_end() / n as f64;
        integrate(
            OSCILLATOR,
            NoConstraints,
            options(method, h),
            &[1.0],
            &[0.0],
            n,
            false,
        )
    }
    fn score(&self, trajectory: &Trajectory, _h: f64) -> (f64, f64) {
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
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        let h = self.t_end() / n as f64;
        integrate(
            self.chain.clone(),
            NoConstraints,
            options(method, h),
            &self.x0,
            &[0.0; 10],
            n,
            true,
        )
    }
    fn score(&self, trajectory: &Trajectory, _h: f64) -> (f64, f64) {
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
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        self.run_to(method, n, self.t_end())
    }
    fn score(&self, trajectory: &Trajectory, _h: f64) -> (f64, f64) {
        let energy = SceneD2Long::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        (energy, energy)
    }
}

impl SceneD2 {
    /// `n` steps over `[0, t_end]` from θ = (1, 0.5), θ̇ = 0, every state recorded.
    fn run_to(&self, method: &Method, n: usize, t_end: f64) -> Result<Trajectory, SimError> {
        let h = t_end / n as f64;
        integrate(
            DoublePendulum::unit(),
            NoConstraints,
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
    fn energy_errors(trajectory: &Trajectory) -> Vec<f64> {
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
        m.extend([4, 6, 8].map(composed_midpoint));
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
        if quick {
            return self.steps(true);
        }
        let first = match method.name.as_str() {
            "midpoint" => 800_000,
            "gauss2" => 400_000,
            _ => 100_000,
        };
        doubling(first, 4)
            .into_iter()
            .filter(|&n| n <= 800_000)
            .collect()
    }
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        SceneD2.run_to(method, n, self.t_end())
    }
    fn score(&self, trajectory: &Trajectory, _h: f64) -> (f64, f64) {
        let energy = Self::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        let last = &trajectory.states[trajectory.states.len() - 4..];
        ((last[0] - D2_LONG_THETA1).abs(), energy)
    }
    fn tenths(&self, trajectory: &Trajectory) -> Vec<f64> {
        running_max_tenths(&Self::energy_errors(trajectory))
    }
}

/// Hénon–Heiles on [0, 10⁴] from the SciMLBenchmarks state: max energy error.
struct SceneE;

impl SceneE {
    fn energy_errors(trajectory: &Trajectory) -> Vec<f64> {
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
        m.extend([4, 6, 8].map(composed_midpoint));
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
    fn run(&self, method: &Method, n: usize) -> Result<Trajectory, SimError> {
        let h = self.t_end() / n as f64;
        integrate(
            HenonHeiles,
            NoConstraints,
            options(method, h),
            &HenonHeiles::Q0,
            &HenonHeiles::P0,
            n,
            true,
        )
    }
    fn score(&self, trajectory: &Trajectory, _h: f64) -> (f64, f64) {
        let energy = Self::energy_errors(trajectory)
            .into_iter()
            .fold(0.0, f64::max);
        (energy, energy)
    }
    fn tenths(&self, trajectory: &Trajectory) -> Vec<f64> {
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
    for method in scene.methods() {
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

/// Scene C: the ladder's stepping time per step and section (assembly and initialisation are
/// not timed; ngspice's `trantime` likewise excludes parsing).
fn ladder(
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    const STEPS: usize = 1000;
    let section = LadderSection {
        r: 0.1,
        l: 1.0,
        c: 1.0,
    };
    for &n in &options.sections {
        let graph = rlc_ladder(n, section)?;
        let system = Assembler::assemble(&graph, Representation::Monolithic)?;
        let dim = system.coordinates();
        let repeats = if options.quick || n >= 10_000 { 1 } else { 3 };
        let mut best = f64::INFINITY;
        let mut iterations = 0;
        for _ in 0..repeats {
            let mut sim = Integrator::new(
                system.model.clone(),
                system.constraints.clone(),
                IntegratorOptions::new(Discretisation::midpoint(), 0.01),
            )?;
            sim.initialise(&vec![0.0; dim], &vec![0.0; dim], 0.0)?;
            let start = Instant::now();
            for _ in 0..STEPS {
                sim.step()?;
            }
            best = best.min(start.elapsed().as_secs_f64());
            iterations = sim.stats().iterations;
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
            ladder_accuracy(&graph, &system, n, repeats, emit)?;
        }
    }
    Ok(())
}

/// Largest ladder whose accuracy row (`Cacc-N`) is measured: the Gauss-4 reference run costs
/// several times the midpoint run.
const LADDER_ACCURACY_MAX: usize = 10_000;

/// Runs the ladder `system` for 1000 steps of 0.01 with `discretisation`; returns the capacitor
/// voltages at t = 10 and the wall time of the whole solve (integrator set-up, initialisation,
/// stepping), and the Newton iterations.
fn ladder_voltages(
    graph: &dirac_graph::Interconnection,
    system: &dirac_graph::AssembledSystem,
    discretisation: Discretisation,
) -> Result<(Vec<f64>, f64, usize), SimError> {
    let dim = system.coordinates();
    let start = Instant::now();
    let mut sim = Integrator::new(
        system.model.clone(),
        system.constraints.clone(),
        IntegratorOptions::new(discretisation, 0.01),
    )?;
    sim.initialise(&vec![0.0; dim], &vec![0.0; dim], 0.0)?;
    for _ in 0..1000 {
        sim.step()?;
    }
    let wall = start.elapsed().as_secs_f64();
    // Section k (subsystem k, after the source) holds (q_s, q_c); C = 1, so v = q_c.
    let q = sim.q();
    let voltages = (1..graph.subsystems().len())
        .map(|k| q[system.global_index(SubsystemId(k), 1)])
        .collect();
    Ok((voltages, wall, sim.stats().iterations))
}

/// Scene C's accuracy row `Cacc-N`: the midpoint run's max capacitor-voltage error at t = 10
/// against Gauss 4 (order 8) at the same step (its error ~(ωh)⁸ ≈ 1e-14 here), timed as a whole
/// solve so the compiled peers' rows compare.
fn ladder_accuracy(
    graph: &dirac_graph::Interconnection,
    system: &dirac_graph::AssembledSystem,
    n: usize,
    repeats: usize,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    let (reference, _, _) = ladder_voltages(graph, system, Discretisation::gauss(4))?;
    let mut best = f64::INFINITY;
    let mut result = (Vec::new(), 0);
    for _ in 0..repeats {
        let (v, wall, iterations) = ladder_voltages(graph, system, Discretisation::midpoint())?;
        best = best.min(wall);
        result = (v, iterations);
    }
    let error = result
        .0
        .iter()
        .zip(&reference)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    emit(BenchRow {
        scene: format!("Cacc-{n}"),
        method: "midpoint".to_string(),
        setting: 0.01,
        wall_s: best,
        steps: 1000,
        newton_iterations: result.1,
        error,
        energy_error: f64::NAN,
        tenths: Vec::new(),
    })?;
    Ok(())
}

/// The RC ladder's initial state in the assembled coordinates: `q_c,i = C_i v_i(0)`.
fn rc_initial_state(
    ladder: &RcLadder,
    system: &dirac_graph::AssembledSystem,
) -> Result<Vec<f64>, dirac_graph::GraphError> {
    let flat = ladder.initial_coordinates();
    let mut per = vec![vec![flat[0]]];
    per.extend(flat[1..].chunks_exact(2).map(<[f64]>::to_vec));
    let names: Vec<String> = std::iter::once("V1".to_string())
        .chain((1..=ladder.n).map(|k| format!("S{k}")))
        .collect();
    system.global_vector(&per, &names)
}

/// Scene F: the SciMLBenchmarks RC ladder (n = 1000) to t = 10 with midpoint and Gauss 2–4 at
/// h = 1e-2 … 1e-4. Two rows per run: `F` timed from integrator set-up to the last step (the
/// "solve"), `F-whole` from building the graph (graph, assembly, solve).
fn rc_ladder_scene(
    settings: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    const N: usize = 1000;
    const T_END: f64 = 10.0;
    let ladder = RcLadder { n: N };
    let exact = ladder.exact().voltages(T_END);
    let hs: &[f64] = if settings.quick {
        &[1e-2]
    } else {
        &[1e-2, 1e-3, 1e-4]
    };
    let repeats = if settings.quick { 1 } else { 3 };
    for method in (1..=4).map(|s| gauss(s, false)) {
        for &h in hs {
            let steps = (T_END / h).round() as usize;
            let mut best = (f64::INFINITY, f64::INFINITY);
            let mut last = (Vec::new(), 0);
            for _ in 0..repeats {
                let start = Instant::now();
                let graph = ladder.graph()?;
                let system = Assembler::assemble(&graph, Representation::Monolithic)?;
                let built = start.elapsed().as_secs_f64();
                let q0 = rc_initial_state(&ladder, &system)?;
                let p0 = vec![0.0; q0.len()];
                let solve_start = Instant::now();
                let mut sim = Integrator::new(
                    system.model.clone(),
                    system.constraints.clone(),
                    options(&method, h),
                )?;
                sim.set_state(&q0, &p0, 0.0)?;
                for _ in 0..steps {
                    sim.step()?;
                }
                let solve = solve_start.elapsed().as_secs_f64();
                if solve < best.0 {
                    best = (solve, built + solve);
                }
                let q = sim.q();
                last = (
                    (1..=N)
                        .map(|k| {
                            q[system.global_index(SubsystemId(k), 1)] / RcLadder::capacitance(k)
                        })
                        .collect(),
                    sim.stats().iterations,
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

/// Why a benchmark stopped.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The ladder graph or its assembly failed.
    #[error(transparent)]
    Graph(#[from] dirac_graph::GraphError),
    /// A ladder run failed (fixed-step sweeps skip failed step sizes instead).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Writing the CSV failed.
    #[error("writing the CSV: {0}")]
    Io(#[from] std::io::Error),
}

/// Runs the sweep of `scene`, handing each row to `emit` as it is measured.
///
/// # Errors
/// A failed ladder run, or `emit` failing.
pub fn run(
    scene: BenchScene,
    options: &BenchOptions,
    emit: &mut dyn FnMut(BenchRow) -> std::io::Result<()>,
) -> Result<(), BenchError> {
    match scene {
        BenchScene::A => sweep(&SceneA, options, emit),
        BenchScene::B => sweep(&SceneB, options, emit),
        BenchScene::C => ladder(options, emit),
        BenchScene::D1 => sweep(&SceneD1::new(), options, emit),
        BenchScene::D2 => sweep(&SceneD2, options, emit),
        BenchScene::D2Long => sweep(&SceneD2Long, options, emit),
        BenchScene::E => sweep(&SceneE, options, emit),
        BenchScene::F => rc_ladder_scene(options, emit),
    }
}
