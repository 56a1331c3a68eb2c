//! The `dirac` binary under abuse: pipes closed early, signals, runs too long for the machine,
//! Newton failures, and the step-size report (issue 16).

mod common;

use common::scratch;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn dirac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dirac"))
}

fn repo(path: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
        .to_string_lossy()
        .into_owned()
}

/// A saturating inductor with no saturated inductance holds at most `L₀·I_sat = 1 Wb`; a 1 V
/// source drives its flux there at t = 1 s, where no state exists.
const SATURATION: &str = "[simulation]\nh = 0.1\nt_end = 2.0\n\n[[part]]\nname = \"V\"\ntype = \"voltage_source\"\nwaveform = 1.0\n\n[[part]]\nname = \"L\"\ntype = \"saturating_inductor\"\nl0 = 1.0\nl_inf = 0.0\ni_sat = 1.0\n\n[[connection]]\ntype = \"node\"\nname = \"a\"\nports = [\"-V.i\", \"-L.i\"]\n";

/// `dirac run … | head -3`: the reader closes the pipe after three lines; the run ends at its
/// next write with exit 0 and nothing on stderr, as `cat` does. Mutation: deleting the
/// `reader_closed` branch of `run` gives exit 2 and "writing output: Broken pipe".
#[test]
fn a_closed_pipe_ends_the_run_quietly() {
    let mut child = dirac()
        .args([
            "run",
            &repo("examples/netlists/seed_rlc.cir"),
            "--t-end",
            "500",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let stdout = child.stdout.take().expect("stdout");
    let lines: Vec<String> = BufReader::new(stdout)
        .lines()
        .take(3)
        .map(|l| l.expect("line"))
        .collect();
    assert_eq!(lines[0], "t,v(1),v(2),i(l1),q(c1)");
    // Dropping the reader closes the pipe; 10 000 rows are far more than the pipe buffer holds.
    let output = child.wait_with_output().expect("exits");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
}

/// `dirac check`, `op` and `compare` whose reader is gone before they write (`… | true`, or
/// `dirac check big.cir | head -3` while the modal analysis runs): exit 0 and nothing on
/// stderr. `check` panicked there ("failed printing to stdout: Broken pipe"), `op` exited 2
/// with "writing output: Broken pipe".
#[test]
fn a_reader_gone_before_the_output_is_not_an_error() {
    for args in [
        vec!["check", "examples/netlists/seed_rlc.cir"],
        vec!["op", "examples/netlists/ladder_subckt.cir"],
        vec!["op", "examples/netlists/ladder_subckt.cir", "--json"],
        vec!["compare", "examples/netlists/seed_rlc.cir"],
    ] {
        let mut child = dirac()
            .arg(args[0])
            .arg(repo(args[1]))
            .args(&args[2..])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("runs");
        drop(child.stdout.take());
        let output = child.wait_with_output().expect("exits");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
}

/// Ctrl-C (SIGINT sent to the child) during a run to a file stops it at the next row: exit 130,
/// and neither the output nor its `.partial` file is left. Mutation: not installing the signal
/// handler leaves the partial file and the child dies by the signal (no exit code).
#[test]
fn sigint_removes_the_partial_output_and_exits_130() {
    let out = scratch("interrupted.csv");
    let partial = scratch("interrupted.csv.partial");
    // 2·10⁷ steps: far longer than the test waits.
    let mut child = dirac()
        .args(["run", &repo("examples/netlists/seed_rlc.cir"), "--quiet"])
        .args(["--t-end", "1e6", "--force", "--out"])
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let started = Instant::now();
    while std::fs::metadata(&partial).map_or(0, |m| m.len()) == 0 {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no partial output appeared"
        );
        assert!(child.try_wait().expect("status").is_none(), "exited early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(status.success());
    let output = child.wait_with_output().expect("exits");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(!partial.exists(), "partial output left behind");
    assert!(!out.exists(), "output written");
}

/// More steps than `--max-steps` (default 10⁹) is refused before the run starts, naming the
/// flags; exactly `--max-steps` runs. A CSV larger than any disk (5·10¹⁰ rows, some 6 TB) is
/// refused unless `--force`. Mutation: comparing `steps < max` refuses the boundary run.
#[test]
fn runs_beyond_the_bounds_ask_for_max_steps_or_force() {
    let seed = repo("examples/netlists/seed_rlc.cir");
    let out = scratch("bounded.csv");
    let output = dirac()
        .args(["run", &seed, "--h", "1e-9", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("50000000000 steps") && stderr.contains("--max-steps 50000000000"),
        "{stderr}"
    );
    assert!(!out.exists());

    let run = |max: &str| {
        dirac()
            .args(["run", &seed, "--t-end", "100", "--max-steps", max])
            .stdout(Stdio::null())
            .output()
            .expect("runs")
    };
    assert_eq!(run("2000").status.code(), Some(0), "2000 steps allowed");
    let refused = run("1999");
    assert_eq!(refused.status.code(), Some(2));

    let output = dirac()
        .args(["run", &seed, "--h", "1e-9", "--max-steps", "100000000000"])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("could take up to") && stderr.contains("--force"),
        "{stderr}"
    );
    assert!(!out.exists());
}

/// A Newton failure in a step: the saturating inductor stepped with h = 0.3 reaches the flux
/// limit in step 3 (t = 0.9), where its Newton matrix becomes singular. The message names the
/// step, the time, the residual, the equation (`L.q`'s momentum balance) and the cause (a
/// nonlinear part at a singular point after regular steps); exit 1, no output. With h = 0.125 the
/// steps reach t = 1 exactly (a binary fraction), where the flux sits at saturation: the step
/// from there fails, cut ten times, naming the step, the time, `L.q` and the inductor at its
/// saturation flux. (With h = 0.1, `t = 1` carries round-off, and whether the readout at t = 1
/// or the step from it meets the singular point first depends on the last bits of the state: a
/// change of the Newton start moved it from the step to the readout.) Mutation: `likely_cause` ignoring the
/// step index (always "singular model") fails the first case.
#[test]
fn newton_failures_name_step_time_equation_and_cause() {
    let scene = scratch("saturation.toml");
    std::fs::write(&scene, SATURATION).expect("write");
    let out = scratch("saturation.csv");
    let run = |h: &str| {
        dirac()
            .arg("run")
            .arg(&scene)
            .args(["--quiet", "--h", h, "--out"])
            .arg(&out)
            .output()
            .expect("runs")
    };
    let output = run("0.3");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    for expected in [
        "step 3 (t = 0.9)",
        "residual 2.497e-1",
        "momentum balance of coordinate `L.q`",
        "became singular",
        "nonlinear part reached a singular point",
    ] {
        assert!(stderr.contains(expected), "`{expected}` missing: {stderr}");
    }
    assert!(!out.exists());

    let output = run("0.125");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    for expected in [
        "step 8 (t = 1)",
        "near coordinate `L.q`",
        "an inductor at its saturation flux",
        "cut 10 times",
    ] {
        assert!(stderr.contains(expected), "`{expected}` missing: {stderr}");
    }
    assert!(!out.exists());
}

/// Two current sources in series (`I1` into `a`, `I2` from `a` on), started from given values:
/// nothing fixes the potential of `a` between them. Each source's flux balance holds only its own
/// rates and the node's multiplier, so the step's Newton matrix has no perfect matching whatever
/// the values. (Two voltage sources in parallel, the earlier case here, are now refused by the
/// netlist reader as a loop of voltage sources before the structural check runs.)
const SERIES_CURRENT_SOURCES: &str = "two current sources in series\nI1 0 a 1m\nI2 a b 1m\n\
                                      R1 b 0 1k\nC1 b 0 1u\n.tran 1m 10m uic\n.end\n";

/// A mass on a spring and a force source of zero force attached to nothing: the source's
/// coordinate `F.x` has no inertia, potential, dissipation or constraint, so it appears in no
/// equation of the step.
const LOOSE_FORCE: &str = "[simulation]\nh = 0.01\nt_end = 1.0\n\n[[part]]\nname = \"M\"\ntype = \"mass\"\nm = 1.0\nv0 = 1.0\n\n[[part]]\nname = \"K\"\ntype = \"spring\"\nk = 1.0\n\n[[part]]\nname = \"F\"\ntype = \"force_source\"\nwaveform = 0.0\n\n[[connection]]\ntype = \"joint\"\nname = \"j\"\na = \"M.x\"\nb = \"K.x\"\n";

/// Runs `dirac run FILE --out …` on `text` written to `name`; returns the exit code, stderr and
/// whether the output file exists afterwards.
fn run_text(name: &str, text: &str) -> (Option<i32>, String, bool) {
    let file = scratch(name);
    std::fs::write(&file, text).expect("write");
    let out = scratch(&format!("{name}.csv"));
    let output = dirac()
        .arg("run")
        .arg(&file)
        .args(["--quiet", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    (output.status.code(), stderr, out.exists())
}

/// Structural singularity (docs/audit.md item 18), netlist reader: the step matrix of two
/// current sources in series matches only 7 of its 8 equations to unknowns (Dulmage–Mendelsohn:
/// the sources' fluxes and the node's multiplier are under-determined, their flux balances and
/// the node's KCL over-determined). The model is refused at set-up with exit 2 (a bad model),
/// naming both sources' fluxes, and no output is written. Mutation (2026-11-29): filtering out
/// the `integrator.check_structure()` finding in `Simulation::build_assembled` lets the run
/// start; it fails in step 0 (t = 0), exit 1 ("matrix is structurally singular near unknown 6 …
/// singular model: the Newton matrix is singular near multiplier of constraint `node `a` (KCL)`").
#[test]
fn a_structurally_singular_netlist_is_refused_before_the_run() {
    let (code, stderr, written) = run_text("series_current_sources.cir", SERIES_CURRENT_SOURCES);
    assert_eq!(code, Some(2), "{stderr}");
    for expected in [
        "structurally singular model",
        "nothing determines coordinate `i1.phi`, coordinate `i2.phi`",
        "no unknown is left to momentum balance of coordinate `i1.phi`",
        "structural rank 7 of 8",
    ] {
        assert!(stderr.contains(expected), "`{expected}` missing: {stderr}");
    }
    assert!(!stderr.contains("step 0"), "{stderr}");
    assert!(!written);
}

/// Structural singularity, scene reader: a force source attached to nothing leaves its
/// coordinate `F.x` in no equation (an empty column of the step matrix, rank 3 of 4). Refused
/// at set-up with exit 2, naming `F.x`. Mutation: without the `check_structure` call the run
/// fails in step 0 (t = 0), exit 1: "unknown 2 appears in no equation … singular model:
/// coordinate `F.x` appears in no equation".
#[test]
fn a_structurally_singular_scene_is_refused_before_the_run() {
    let (code, stderr, written) = run_text("loose_force.toml", LOOSE_FORCE);
    assert_eq!(code, Some(2), "{stderr}");
    for expected in [
        "structurally singular model",
        "nothing determines coordinate `F.x`",
        "structural rank 3 of 4",
    ] {
        assert!(stderr.contains(expected), "`{expected}` missing: {stderr}");
    }
    assert!(!stderr.contains("step 0"), "{stderr}");
    assert!(!written);
}

/// `dirac check` on the seed loop reports its one oscillation with the closed-form damped period
/// `2π/√(1/LC − (R/2L)²) = 9.4723` (L = 0.75, C = 3, R = 0.1), damping ratio 0.1 and
/// 189.4 steps of h = 0.05; `dirac run --h 2` (4.7 steps per period) warns about the phase, not
/// about stability. Mutation: the mode's period printed from `|s|` instead of `Im s` reads
/// 9.4248 (fails).
#[test]
fn check_reports_the_modes_and_run_warns_on_coarse_steps() {
    let seed = repo("examples/netlists/seed_rlc.cir");
    let output = dirac().args(["check", &seed]).output().expect("runs");
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("period 9.4723e0")
            && stdout.contains("damping ratio 0.100")
            && stdout.contains("189.4 steps per period"),
        "{stdout}"
    );
    assert!(stdout.contains("no warning"), "{stdout}");

    let output = dirac()
        .args(["run", &seed, "--h", "2", "--quiet"])
        .stdout(Stdio::null())
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("4.74 steps") && stderr.contains("no blow-up"),
        "{stderr}"
    );
}

/// Memory stays flat on a streamed run: the peak resident set of 2·10⁵ steps exceeds that of
/// 2·10⁴ steps by less than 1 MiB (rows go to the pipe, nothing grows with the step count).
/// Mutation: collecting the rows in a `Trajectory` before writing them adds about 6.5 MiB
/// (fails).
#[test]
fn streamed_runs_keep_memory_flat() {
    /// Allowed growth: allocator noise (measured differences are tens of KiB).
    const GROWTH_KIB: u64 = 1024;
    let peak = |t_end: &str| -> u64 {
        let output = dirac()
            .args(["run", &repo("examples/netlists/seed_rlc.cir"), "--quiet"])
            .args(["--t-end", t_end, "--json-summary"])
            .stdout(Stdio::null())
            .output()
            .expect("runs");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        let json: serde_json::Value = serde_json::from_str(stderr.trim()).expect("json");
        json["peak_rss_kib"].as_u64().expect("peak_rss_kib")
    };
    let short = peak("1000");
    let long = peak("10000");
    assert!(
        long <= short + GROWTH_KIB,
        "peak RSS grew from {short} KiB to {long} KiB"
    );
}
