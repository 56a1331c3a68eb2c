//! The benchmark CSV contract of `bench/SCENES.md`: every tool's CSV in `bench/results/` (dirac,
//! the compiled peers, the Python peers, ngspice), written by one run of `bench/peers/run.sh`,
//! parses with the shared header; the long runs' `.drift.csv` side files parse too; and a fresh
//! `dirac bench --quick` writes the same format. No timing is checked, only the format and the
//! invariants every row must satisfy (finite positive wall times, non-negative errors or nan).
//!
//! Mutations (run): appending `,1` to the first data row of `bench/results/compiled_A.csv` fails
//! `committed_results_parse` ("compiled_A.csv:2: 9 fields expected"); moving `compiled_E.csv` away
//! fails it ("no compiled peer rows for scene E"); moving `dirac_CLI.csv` away fails it ("no dirac
//! rows for scene CLI"). Not run: renaming a column of `bench::HEADER`
//! would fail `fresh_dirac_bench_output_parses` at its header comparison.

mod common;

use common::scratch;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

const HEADER: &str = "scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error";
const TOOLS: &[&str] = &[
    "dirac",
    "sundials",
    "diffsol",
    "differential-equations",
    "c",
    "scipy-py",
    "sksundae-py",
    "ngspice",
];
const COMPILED: &[&str] = &["sundials", "diffsol", "differential-equations", "c"];
/// Every scene of SCENES.md (C appears as `C-N` and `Cacc-N`, CLI as `CLI-seed` and
/// `CLI-ladder-N`).
const SCENES: &[&str] = &["A", "B", "D1", "D2", "D2-long", "E", "F", "C", "CLI"];
/// The scenes of the issue-15 targets, which must have compiled-peer rows.
const COMPILED_SCENES: &[&str] = &["A", "B", "D2-long", "E", "F", "C"];

fn results() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../bench/results")
}

fn scene_family(scene: &str) -> &str {
    if scene.starts_with("C-") || scene.starts_with("Cacc-") {
        "C"
    } else if scene == "F-whole" {
        "F"
    } else if scene.starts_with("CLI-") {
        "CLI"
    } else {
        scene
    }
}

/// Parses one CSV; returns (scene family, tool) per row. Panics with the file and line on any
/// violation of the contract.
fn parse(path: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER), "{}: header", path.display());
    let mut rows = Vec::new();
    for (k, line) in lines.enumerate() {
        let at = format!("{}:{}", path.display(), k + 2);
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 9, "{at}: 9 fields expected in {line:?}");
        let family = scene_family(f[0]);
        assert!(SCENES.contains(&family), "{at}: unknown scene {}", f[0]);
        assert!(TOOLS.contains(&f[1]), "{at}: unknown tool {}", f[1]);
        assert!(!f[2].is_empty(), "{at}: empty method");
        let setting: f64 = f[3]
            .parse()
            .unwrap_or_else(|_| panic!("{at}: setting {}", f[3]));
        assert!(
            setting > 0.0 && setting.is_finite(),
            "{at}: setting {setting}"
        );
        let wall: f64 = f[4]
            .parse()
            .unwrap_or_else(|_| panic!("{at}: wall_s {}", f[4]));
        assert!(wall > 0.0 && wall.is_finite(), "{at}: wall_s {wall}");
        let steps: u64 = f[5]
            .parse()
            .unwrap_or_else(|_| panic!("{at}: steps {}", f[5]));
        assert!(steps > 0, "{at}: no steps");
        if !f[6].is_empty() {
            f[6].parse::<u64>()
                .unwrap_or_else(|_| panic!("{at}: newton_iterations {}", f[6]));
        }
        for (name, v) in [("error", f[7]), ("energy_error", f[8])] {
            let x: f64 = v.parse().unwrap_or_else(|_| panic!("{at}: {name} {v}"));
            assert!(x.is_nan() || x >= 0.0, "{at}: {name} {x}");
        }
        let error: f64 = f[7].parse().unwrap_or(f64::NAN);
        assert!(!error.is_nan(), "{at}: every scene defines `error`");
        rows.push((family.to_string(), f[1].to_string()));
    }
    rows
}

/// A `.drift.csv` side file: the header and 10 non-decreasing running maxima per row.
fn parse_drift(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let head = lines.next().unwrap_or_default();
    assert!(
        head.starts_with("scene,tool,method,setting,tenth1,"),
        "{}: header",
        path.display()
    );
    let mut n = 0;
    for (k, line) in lines.enumerate() {
        let at = format!("{}:{}", path.display(), k + 2);
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 14, "{at}: 14 fields");
        let v: Vec<f64> = f[4..]
            .iter()
            .map(|x| x.parse().unwrap_or_else(|_| panic!("{at}: {x}")))
            .collect();
        assert!(
            v.windows(2).all(|w| w[1] >= w[0]),
            "{at}: running maximum decreases"
        );
        n += 1;
    }
    n
}

#[test]
fn committed_results_parse() {
    let mut seen: BTreeSet<(String, String)> = BTreeSet::new();
    let mut files = 0;
    let mut drift_rows = 0;
    for entry in std::fs::read_dir(results()).expect("bench/results") {
        let path = entry.expect("entry").path();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        if name.ends_with(".drift.csv") {
            drift_rows += parse_drift(&path);
        } else if name.ends_with(".csv") {
            seen.extend(parse(&path));
            files += 1;
        }
    }
    assert!(files > 0, "no CSV in bench/results");
    for scene in SCENES {
        assert!(
            seen.contains(&(scene.to_string(), "dirac".to_string())),
            "no dirac rows for scene {scene}"
        );
    }
    for scene in COMPILED_SCENES {
        assert!(
            COMPILED
                .iter()
                .any(|t| seen.contains(&(scene.to_string(), t.to_string()))),
            "no compiled peer rows for scene {scene}"
        );
    }
    assert!(drift_rows > 0, "no drift rows for the long runs");
}

#[test]
fn fresh_dirac_bench_output_parses() {
    let out = scratch("B.csv");
    let status = Command::new(env!("CARGO_BIN_EXE_dirac"))
        .args(["bench", "--scene", "B", "--quick", "--out"])
        .arg(&out)
        .status()
        .expect("runs");
    assert!(status.success());
    let rows = parse(&out);
    assert!(rows.len() >= 8, "every method of B appears");
}
