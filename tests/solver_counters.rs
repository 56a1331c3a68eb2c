//! Solver counters of every bundled scene and netlist, as insta snapshots, so that a change in
//! solver behaviour (more Newton updates, factorisations kept or dropped, readouts, breakpoints
//! landed, steps cut) shows in review as a snapshot diff.
//!
//! Each file runs as `dirac run FILE` runs it: a scene with its own settings, a netlist with its
//! `.tran` step and end, its `.options method=` (else the midpoint rule), its truncation-error
//! control (on with diodes) and its start (the given values with `UIC`, else the operating
//! point), in the monolithic representation; a netlist
//! without `.tran` as `dirac op` runs it (the operating point alone). The counters
//! are integers of a deterministic computation, so the snapshots are exact; wall time is left out.
//!
//! Can fail: running `seed_rlc.cir` with h doubled changes `steps` from 1000 to 500 and the
//! snapshot no longer matches (tests/mutations.md).

use std::path::{Path, PathBuf};

use dirac::netlist::{build_circuit, parse_netlist};
use dirac::prelude::*;

fn bundled(dir: &str) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(dir);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&root)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.sort();
    assert!(!files.is_empty(), "no bundled files in {}", root.display());
    files
}

fn counters(summary: &RunSummary) -> String {
    format!(
        "steps: {}\nnewton_iterations: {}\nfactorisations: {}\nreadout_iterations: {}\nbreakpoint_substeps: {}\nstep_cuts: {}\nrefinements: {}\nsubsteps: {}\n",
        summary.steps,
        summary.newton_iterations,
        summary.factorisations,
        summary.readout_iterations,
        summary.breakpoint_substeps,
        summary.step_cuts,
        summary.refinements,
        summary.substeps
    )
}

fn name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().replace('.', "_"))
        .unwrap_or_default()
}

#[test]
fn scene_counters() {
    for path in bundled("scenes") {
        let built = Scene::from_file(&path)
            .and_then(|s| s.build())
            .expect("scene");
        let mut sim = built.simulation().expect("simulation");
        let (_, summary) = sim.run(built.t_end, &built.signals).expect("run");
        insta::assert_snapshot!(name(&path), counters(&summary));
    }
}

#[test]
fn netlist_counters() {
    for path in bundled("netlists") {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(&path).expect("readable");
        let netlist = parse_netlist(&text, &file).expect("netlist");
        let circuit = build_circuit(&netlist, &file).expect("circuit");
        // A deck without `.tran` (an `.op` deck) runs as `dirac op` runs it: the operating point
        // alone, at h = 1 and t_end = 0.
        let (h, t_end, start, signals) = match circuit.tran_settings() {
            Some((h, t_end)) => (h, t_end, circuit.start(), circuit.signals.clone()),
            None => (
                1.0,
                0.0,
                Start::SteadyState,
                circuit.operating_point_signals(),
            ),
        };
        let method = circuit
            .method
            .clone()
            .unwrap_or_else(Discretisation::midpoint);
        let mut sim = circuit
            .simulation(
                Execution::Assembled(Representation::Monolithic),
                IntegratorOptions::new(method, h).truncation(circuit.default_truncation()),
                start,
            )
            .expect("simulation");
        let (_, summary) = sim.run(t_end, &signals).expect("run");
        insta::assert_snapshot!(name(&path), counters(&summary));
    }
}
