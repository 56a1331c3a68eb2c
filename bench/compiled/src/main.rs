//! Compiled peers of the dirac benchmark (bench/SCENES.md), one CSV row per run:
//!
//! ```text
//! scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error
//! ```
//!
//! Usage: `compiled-peers --scene A|B|D1|D2|D2-long|E|F|C [--quick] [--sections 10,100]
//! [--methods kahan-li8,dopri5] [--out FILE]` (`--methods` keeps the peers of those method
//! names, for side-by-side runs of a few); `compiled-peers --reference D2-long|F|C-N` prints how converged the scene's
//! reference is. Long runs (D2-long, E) also write the running maximum of the energy error at
//! each tenth of the interval to `FILE` with `.csv` replaced by `.drift.csv`. Skipped settings
//! (failed, too slow) go to stderr and to `.notes.txt`.

mod ffi;
mod rust_peers;
mod scenes;

use std::fs::File;
use std::io::{BufWriter, Write};

use ffi::{ARKODE_DIRK, ARKODE_ERK, CMethod, CProblem, CVODE_ADAMS, CVODE_BDF, IDA, Run};
use scenes::{Kind, Scene};

/// Best of three repetitions, one when a run takes longer than this (SCENES.md).
const BEST_OF_ONE_S: f64 = 2.0;
/// A run longer than this ends the sweep of its method (the next setting would take longer).
const SLOW_RUN_S: f64 = 20.0;
const QUICK_SLOW_RUN_S: f64 = 1.0;
/// Sections of scene F.
const F_SECTIONS: usize = 1000;

#[derive(Clone, Copy, Debug)]
enum Peer {
    C(CKind),
    Diffsol(&'static str),
    GaussLegendre(usize),
}

#[derive(Clone, Copy, Debug)]
enum CKind {
    Dopri5,
    Symplectic(i32),
    Sundials(i32),
}

impl Peer {
    fn tool(self) -> &'static str {
        match self {
            Peer::C(CKind::Sundials(_)) => "sundials",
            Peer::C(_) => "c",
            Peer::Diffsol(_) => "diffsol",
            Peer::GaussLegendre(_) => "differential-equations",
        }
    }
    fn method(self) -> String {
        match self {
            Peer::C(CKind::Dopri5) => "DOPRI5".into(),
            Peer::C(CKind::Symplectic(2)) => "verlet".into(),
            Peer::C(CKind::Symplectic(8)) => "kahan-li8".into(),
            Peer::C(CKind::Symplectic(o)) => format!("yoshida{o}"),
            Peer::C(CKind::Sundials(m)) => [
                "CVODE-ADAMS",
                "CVODE-BDF",
                "ARKODE-ERK8",
                "ARKODE-DIRK",
                "IDA",
            ][m as usize]
                .into(),
            Peer::Diffsol(m) => m.into(),
            Peer::GaussLegendre(o) => format!("GL{o}"),
        }
    }
    fn fixed_step(self) -> bool {
        matches!(self, Peer::C(CKind::Symplectic(_)))
    }
}

/// The peers that run on a scene (`--quick`: on the long runs only the explicit ones, and no
/// Gauss–Legendre, whose controller needs ~10⁴ steps per unit time).
fn peers(scene: &Scene, quick: bool) -> Vec<Peer> {
    let all = all_peers(scene);
    if !quick {
        return all;
    }
    all.into_iter()
        .filter(|p| match p {
            Peer::GaussLegendre(_) => false,
            Peer::C(CKind::Sundials(m)) => !scene.long_run() || *m == CVODE_ADAMS,
            Peer::Diffsol(m) => !scene.long_run() || *m == "TSIT45",
            Peer::C(_) => true,
        })
        .collect()
}

fn all_peers(scene: &Scene) -> Vec<Peer> {
    use CKind::*;
    let mut v = Vec::new();
    let stiff = scene.kind == Kind::F;
    if !stiff {
        v.push(Peer::C(Dopri5));
    }
    if scene.separable() {
        v.extend([2, 4, 6, 8].map(|o| Peer::C(Symplectic(o))));
    }
    if !stiff {
        v.push(Peer::C(Sundials(CVODE_ADAMS)));
        v.push(Peer::C(Sundials(ARKODE_ERK)));
    }
    v.push(Peer::C(Sundials(CVODE_BDF)));
    v.push(Peer::C(Sundials(ARKODE_DIRK)));
    if matches!(scene.kind, Kind::A | Kind::F | Kind::C) {
        v.push(Peer::C(Sundials(IDA)));
    }
    v.extend(["BDF", "TR-BDF2", "ESDIRK34"].map(Peer::Diffsol));
    if !stiff {
        v.push(Peer::Diffsol("TSIT45"));
    }
    if scene.n == 0 {
        v.extend([4, 6].map(Peer::GaussLegendre));
    }
    v
}

fn c_scene_id(kind: Kind) -> i32 {
    kind as i32
}

/// One run of `peer` on `scene` at `setting` (relative tolerance, or the step count).
fn run_once(peer: Peer, scene: &Scene, setting: f64, problem: &CProblem) -> Result<Run, String> {
    let every = scene.needs_every_point();
    match peer {
        Peer::C(kind) => {
            let method = match kind {
                CKind::Dopri5 => CMethod::Dopri5 {
                    rtol: setting,
                    atol: setting * 1e-3,
                },
                CKind::Symplectic(order) => CMethod::Symplectic {
                    steps: setting as usize,
                    order,
                },
                CKind::Sundials(method) => CMethod::Sundials {
                    method,
                    rtol: setting,
                    atol: setting * 1e-3,
                },
            };
            problem.run(method, scene.t_end, &scene.y0, every)
        }
        Peer::Diffsol(m) => rust_peers::diffsol(scene, m, setting),
        Peer::GaussLegendre(o) => rust_peers::gauss_legendre(scene, o, setting),
    }
}

/// Best of up to three runs (one above BEST_OF_ONE_S); the first run's trajectory is scored.
fn timed(
    peer: Peer,
    scene: &Scene,
    setting: f64,
    problem: &CProblem,
    repeats: usize,
) -> Result<Run, String> {
    let mut first = run_once(peer, scene, setting, problem)?;
    let mut best = first.wall_s;
    for _ in 1..repeats {
        if best > BEST_OF_ONE_S {
            break;
        }
        best = best.min(run_once(peer, scene, setting, problem)?.wall_s);
    }
    first.wall_s = best;
    Ok(first)
}

struct Out {
    csv: Box<dyn Write>,
    drift: Option<BufWriter<File>>,
    notes: Vec<String>,
}

impl Out {
    fn note(&mut self, msg: String) {
        eprintln!("# {msg}");
        self.notes.push(msg);
    }
}

fn settings(scene: &Scene, peer: Peer, quick: bool) -> Vec<f64> {
    if peer.fixed_step() {
        let hs: Vec<f64> = match scene.kind {
            // Explicit Verlet is stable for h < 2/ω_max = 1.41e-3 on D1.
            Kind::D1 => (0..6).map(|k| 1e-3 / f64::powi(2.0, k)).collect(),
            _ => (0..8).map(|k| 0.2 / f64::powi(2.0, k)).collect(),
        };
        let hs: Vec<f64> = if quick {
            hs.into_iter().step_by(3).collect()
        } else {
            hs
        };
        return hs.iter().map(|h| (scene.t_end / h).round()).collect();
    }
    let tight = match scene.kind {
        Kind::F | Kind::C => 8,
        Kind::D2 | Kind::E => 13,
        _ => 12,
    };
    // Long runs start at 1e-6: looser tolerances let the energy error grow until the Hénon–Heiles
    // orbit escapes (and the solver crawls), far from the 1e-10 the scene asks about.
    let loose = if scene.long_run() { 6 } else { 3 };
    let all: Vec<f64> = (loose..=tight).map(|k| 10f64.powi(-k)).collect();
    if quick {
        all.into_iter().step_by(3).take(2).collect()
    } else {
        all
    }
}

fn sweep(
    scene: &Scene,
    quick: bool,
    methods: Option<&[String]>,
    out: &mut Out,
) -> Result<(), String> {
    let problem = CProblem::new(c_scene_id(scene.kind), scene.n)?;
    let repeats = if quick { 1 } else { 3 };
    let slow = if quick { QUICK_SLOW_RUN_S } else { SLOW_RUN_S };
    let all = peers(scene, quick);
    if let Some(unknown) = methods
        .into_iter()
        .flatten()
        .find(|name| !all.iter().any(|p| p.method() == **name))
    {
        let names: Vec<String> = all.iter().map(|p| p.method()).collect();
        return Err(format!(
            "scene {} has no peer method `{unknown}`; it has {}",
            scene.label,
            names.join(", ")
        ));
    }
    let chosen = all
        .into_iter()
        .filter(|p| methods.is_none_or(|m| m.iter().any(|name| *name == p.method())));
    for peer in chosen {
        let list = settings(scene, peer, quick);
        let mut previous = f64::INFINITY;
        let mut failures = 0;
        for (i, &setting) in list.iter().enumerate() {
            let label = if peer.fixed_step() {
                format!("{:e}", scene.t_end / setting)
            } else {
                format!("{setting:.0e}")
            };
            let run = match timed(peer, scene, setting, &problem, repeats) {
                Ok(r) => r,
                Err(e) => {
                    // A loose tolerance may fail where a tighter one succeeds (a long run whose
                    // orbit escapes); two failures in a row end the sweep.
                    failures += 1;
                    let what = if failures >= 2 {
                        "tighter settings skipped"
                    } else {
                        "trying the next"
                    };
                    out.note(format!(
                        "{} {} {} at {label}: failed ({e}); {what}",
                        scene.label,
                        peer.tool(),
                        peer.method()
                    ));
                    if failures >= 2 {
                        break;
                    }
                    continue;
                }
            };
            failures = 0;
            let (error, energy) = scene.score(&run.t, &run.y);
            writeln!(
                out.csv,
                "{},{},{},{},{:e},{},{},{:e},{:e}",
                scene.label,
                peer.tool(),
                peer.method(),
                label,
                run.wall_s,
                run.steps,
                run.newton_iterations,
                error,
                energy
            )
            .map_err(|e| e.to_string())?;
            out.csv.flush().map_err(|e| e.to_string())?;
            if scene.long_run() {
                if let Some(d) = out.drift.as_mut() {
                    let tenths = scene.tenths(&run.t, &run.y);
                    let cells: Vec<String> = tenths.iter().map(|x| format!("{x:e}")).collect();
                    writeln!(
                        d,
                        "{},{},{},{},{}",
                        scene.label,
                        peer.tool(),
                        peer.method(),
                        label,
                        cells.join(",")
                    )
                    .map_err(|e| e.to_string())?;
                    d.flush().map_err(|e| e.to_string())?;
                }
            }
            eprintln!(
                "  {} {} {} {label}: {:.3e} s, {} steps, error {error:.3e}, energy {energy:.3e}",
                scene.label,
                peer.tool(),
                peer.method(),
                run.wall_s,
                run.steps
            );
            let rest = list.len() - i - 1;
            if rest > 0 && run.wall_s > slow {
                out.note(format!(
                    "{} {} {} at {label}: {:.1} s, over the {slow:.0} s limit; {rest} tighter settings skipped",
                    scene.label,
                    peer.tool(),
                    peer.method(),
                    run.wall_s
                ));
                break;
            }
            // Past round-off, tighter settings only cost time.
            if rest > 0 && error < 1e-13 || (error > 0.5 * previous && error < 1e-11) {
                break;
            }
            previous = error;
        }
    }
    Ok(())
}

/// The reference final state of the RLC ladder of N sections: CVODE-BDF at rtol 1e-11.
fn ladder_reference(n: usize) -> Result<Vec<f64>, String> {
    let problem = CProblem::new(c_scene_id(Kind::C), n)?;
    let y0 = vec![0.0; 2 * n];
    let run = problem.run(
        CMethod::Sundials {
            method: CVODE_BDF,
            rtol: 1e-11,
            atol: 1e-14,
        },
        10.0,
        &y0,
        false,
    )?;
    Ok(run.y[run.y.len() - 2 * n..]
        .iter()
        .skip(1)
        .step_by(2)
        .copied()
        .collect())
}

/// Prints how converged a scene's reference is.
fn reference(label: &str) -> Result<(), String> {
    match label {
        "D2-long" => {
            let scene = Scene::new("D2-long", 0).ok_or("scene")?;
            let problem = CProblem::new(c_scene_id(Kind::D2), 0)?;
            for rtol in [1e-11, 1e-12, 1e-13, 1e-14] {
                for (name, m) in [
                    (
                        "DOPRI5",
                        CMethod::Dopri5 {
                            rtol,
                            atol: rtol * 1e-3,
                        },
                    ),
                    (
                        "ARKODE-ERK8",
                        CMethod::Sundials {
                            method: ARKODE_ERK,
                            rtol,
                            atol: rtol * 1e-3,
                        },
                    ),
                ] {
                    match problem.run(m, scene.t_end, &scene.y0, false) {
                        Ok(r) => println!(
                            "{name} rtol {rtol:.0e}: theta1(1e4) = {:.15e}, omega1 = {:.15e} ({:.1} s, {} steps)",
                            r.y[0], r.y[2], r.wall_s, r.steps
                        ),
                        Err(e) => println!("{name} rtol {rtol:.0e}: {e}"),
                    }
                }
            }
        }
        "F" => {
            let scene = Scene::new("F", F_SECTIONS).ok_or("scene")?;
            let problem = CProblem::new(c_scene_id(Kind::F), F_SECTIONS)?;
            for rtol in [1e-9, 1e-10, 1e-11] {
                let r = problem.run(
                    CMethod::Sundials {
                        method: CVODE_BDF,
                        rtol,
                        atol: rtol * 1e-3,
                    },
                    scene.t_end,
                    &scene.y0,
                    false,
                )?;
                let (err, _) = scene.score(&r.t, &r.y);
                println!("CVODE-BDF rtol {rtol:.0e}: max |v(10) - modal| = {err:.3e}");
            }
        }
        _ => {
            let n: usize = label
                .strip_prefix("C-")
                .and_then(|s| s.parse().ok())
                .ok_or("reference: D2-long, F or C-<N>")?;
            let a = ladder_reference(n)?;
            let problem = CProblem::new(c_scene_id(Kind::C), n)?;
            let r = problem.run(
                CMethod::Sundials {
                    method: ARKODE_DIRK,
                    rtol: 1e-11,
                    atol: 1e-14,
                },
                10.0,
                &vec![0.0; 2 * n],
                false,
            )?;
            let d = a
                .iter()
                .zip(r.y.iter().skip(1).step_by(2))
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            println!("C-{n}: CVODE-BDF vs ARKODE-DIRK at rtol 1e-11: max |dv(10)| = {d:.3e}");
        }
    }
    Ok(())
}

fn main() {
    if let Err(e) = real_main() {
        eprintln!("compiled-peers: {e}");
        std::process::exit(1);
    }
}

fn real_main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scene = None;
    let mut quick = false;
    let mut out_path = None;
    let mut sections = vec![10usize, 100, 1000];
    let mut methods: Option<Vec<String>> = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scene" => scene = it.next().cloned(),
            "--quick" => quick = true,
            "--out" => out_path = it.next().cloned(),
            "--methods" => {
                let list = it.next().ok_or("--methods needs a list")?;
                methods = Some(list.split(',').map(|m| m.trim().to_string()).collect());
            }
            "--sections" => {
                sections = it
                    .next()
                    .ok_or("--sections needs a list")?
                    .split(',')
                    .map(|s| s.trim().parse::<f64>().map(|x| x as usize))
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("--sections: {e}"))?;
            }
            "--reference" => {
                return reference(it.next().ok_or("--reference needs a scene")?);
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    let scene = scene.ok_or("--scene is required")?;
    let (csv, drift): (Box<dyn Write>, Option<BufWriter<File>>) = match &out_path {
        Some(p) => {
            let f = File::create(p).map_err(|e| format!("{p}: {e}"))?;
            let base = p.strip_suffix(".csv").unwrap_or(p);
            let drift = if scene == "D2-long" || scene == "E" {
                let d = File::create(format!("{base}.drift.csv")).map_err(|e| e.to_string())?;
                Some(BufWriter::new(d))
            } else {
                None
            };
            (Box::new(BufWriter::new(f)), drift)
        }
        None => (Box::new(std::io::stdout()), None),
    };
    let mut out = Out {
        csv,
        drift,
        notes: Vec::new(),
    };
    writeln!(
        out.csv,
        "scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error"
    )
    .map_err(|e| e.to_string())?;
    if let Some(d) = out.drift.as_mut() {
        writeln!(
            d,
            "scene,tool,method,setting,{}",
            (1..=10)
                .map(|k| format!("tenth{k}"))
                .collect::<Vec<_>>()
                .join(",")
        )
        .map_err(|e| e.to_string())?;
    }
    let start = std::time::Instant::now();
    if scene == "C" {
        for &n in &sections {
            let mut s = Scene::new(&format!("Cacc-{n}"), 0).ok_or("scene")?;
            s.set_reference(ladder_reference(n)?);
            sweep(&s, quick, methods.as_deref(), &mut out)?;
        }
    } else {
        let s = Scene::new(&scene, F_SECTIONS).ok_or_else(|| format!("unknown scene {scene}"))?;
        sweep(&s, quick, methods.as_deref(), &mut out)?;
    }
    out.note(format!(
        "scene {scene}{}: compiled peers took {:.1} s",
        if quick { " (quick)" } else { "" },
        start.elapsed().as_secs_f64()
    ));
    if let Some(p) = &out_path {
        let base = p.strip_suffix(".csv").unwrap_or(p);
        std::fs::write(format!("{base}.notes.txt"), out.notes.join("\n") + "\n")
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}
