//! The `dirac` binary's contracts: CSV columns, exit codes, atomic output, --signals.

mod common;

use common::scratch;
use std::path::{Path, PathBuf};
use std::process::Command;

fn dirac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dirac"))
}

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}

#[test]
fn run_writes_the_contracted_csv() {
    let out = scratch("seed.csv");
    let status = dirac()
        .args([
            "run",
            repo("examples/netlists/seed_rlc.cir").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .status()
        .expect("runs");
    assert!(status.success());
    let text = std::fs::read_to_string(&out).expect("output");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,v(1),v(2),i(l1),q(c1)"));
    assert_eq!(lines.count(), 1001, "t = 0, 0.05, …, 50");
}

#[test]
fn signals_option_selects_columns() {
    let output = dirac()
        .args([
            "run",
            repo("examples/netlists/seed_rlc.cir").to_str().unwrap(),
            "--signals",
            "q(C1),v(1)",
            "--t-end",
            "0.1",
        ])
        .output()
        .expect("runs");
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "t,q(c1),v(1)");
    assert_eq!(lines.len(), 4);
    assert!(lines[1].starts_with("0,3,"), "{}", lines[1]);
}

/// Time flags read SPICE numbers as the `.tran` card does (`0.3m`, `300us`), and refuse other
/// trailing letters (exit 2, no output) where a netlist would silently ignore them.
#[test]
fn time_flags_take_spice_suffixes() {
    let last_row = |t_end: &str| {
        let output = dirac()
            .args([
                "run",
                repo("examples/netlists/rc_dc.cir").to_str().unwrap(),
                "--signals",
                "v(out)",
                "--h",
                "10u",
                "--t-end",
                t_end,
            ])
            .output()
            .expect("runs");
        assert!(output.status.success(), "{t_end}: {output:?}");
        let text = String::from_utf8(output.stdout).unwrap();
        text.lines().last().unwrap_or_default().to_owned()
    };
    let plain = last_row("3e-4");
    assert!(plain.starts_with("0.0003,"), "{plain}");
    assert_eq!(last_row("0.3m"), plain);
    assert_eq!(last_row("300us"), plain);
    let typo = dirac()
        .args([
            "run",
            repo("examples/netlists/rc_dc.cir").to_str().unwrap(),
            "--t-end",
            "0.3x",
        ])
        .output()
        .expect("runs");
    assert_eq!(typo.status.code(), Some(2));
    assert!(typo.stdout.is_empty());
    let err = String::from_utf8_lossy(&typo.stderr);
    assert!(err.contains("`0.3x` is not a number"), "{err}");
}

#[test]
fn unsupported_card_is_exit_2_with_position_and_no_output() {
    let netlist = scratch("bad.cir");
    std::fs::write(
        &netlist,
        "bad\nR1 1 0 1k\nJ1 d g s jmod\n.tran 1m 1\n.end\n",
    )
    .unwrap();
    let out = scratch("bad.csv");
    let output = dirac()
        .args([
            "run",
            netlist.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .expect("runs");
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert!(
        stderr.contains("bad.cir:3:1") && stderr.contains("not supported"),
        "{stderr}"
    );
    assert!(!out.exists());
    assert!(!scratch("bad.csv.partial").exists());
}

/// Two voltage sources in parallel with different values fix one node potential twice: a loop of
/// voltage sources, refused at the card that closes it before the first step (bad input, exit 2),
/// with no output file.
#[test]
fn contradictory_sources_are_exit_2_and_leave_no_output() {
    let netlist = scratch("parallel_sources.cir");
    std::fs::write(
        &netlist,
        "two sources\nV1 1 0 1\nV2 1 0 2\nR1 1 0 1k\n.tran 1m 10m uic\n.end\n",
    )
    .unwrap();
    let out = scratch("parallel.csv");
    let output = dirac()
        .args([
            "run",
            netlist.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .expect("runs");
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("parallel_sources.cir:3:1: `V2` closes a loop of voltage sources (V1, V2)"),
        "{stderr}"
    );
    assert!(!out.exists());
}

/// A numerical failure: a saturating inductor with no saturated inductance holds at most
/// L₀·I_sat = 1 Wb; a 1 V source drives its flux past that at t = 1 s, where no state exists.
/// Exit 1, the time and the equation in the message, and no output file.
#[test]
fn numerical_failure_is_exit_1_and_leaves_no_output() {
    let scene = scratch("saturation.toml");
    std::fs::write(
        &scene,
        "[simulation]\nh = 0.1\nt_end = 2.0\n\n[[part]]\nname = \"V\"\ntype = \"voltage_source\"\nwaveform = 1.0\n\n[[part]]\nname = \"L\"\ntype = \"saturating_inductor\"\nl0 = 1.0\nl_inf = 0.0\ni_sat = 1.0\n\n[[connection]]\ntype = \"node\"\nname = \"a\"\nports = [\"-V.i\", \"-L.i\"]\n",
    )
    .unwrap();
    let out = scratch("saturation.csv");
    let output = dirac()
        .args(["run", scene.to_str().unwrap(), "--quiet"])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .expect("runs");
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("t = 1") && stderr.contains("`L.q`"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn unknown_signal_and_unknown_file_type_are_exit_2() {
    let seed = repo("examples/netlists/seed_rlc.cir");
    let output = dirac()
        .args(["run", seed.to_str().unwrap(), "--signals", "v(9)"])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    assert!(
        String::from_utf8(output.stderr)
            .unwrap()
            .contains("unknown signal `v(9)`")
    );
    let output = dirac().args(["run", "model.xyz"]).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
}

#[test]
fn compare_json_reports_every_representation() {
    let output = dirac()
        .args([
            "compare",
            repo("examples/netlists/seed_rlc.cir").to_str().unwrap(),
            "--json",
            "--t-end",
            "5",
        ])
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    for key in [
        "\"monolithic\"",
        "\"constraint\"",
        "\"force\"",
        "\"staggered-gs\"",
        "\"staggered-jacobi\"",
        "max_abs_deviation",
    ] {
        assert!(text.contains(key), "{text}");
    }
}

/// On a scene with a coupling spring, the constraint and force forms equal monolithic to round-off
/// and the staggered ones do not.
#[test]
fn compare_scene_separates_equivalent_from_staggered() {
    let output = dirac()
        .args([
            "compare",
            repo("examples/scenes/two_mass_split.toml")
                .to_str()
                .unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let value = |name: &str| -> f64 {
        let at = text
            .find(&format!("\"{name}\""))
            .unwrap_or_else(|| panic!("{name} in {text}"));
        let rest = &text[at..];
        let start = rest.find("max_abs_deviation\":").unwrap() + "max_abs_deviation\":".len();
        let end = rest[start..].find([',', '}']).unwrap() + start;
        rest[start..end].parse().unwrap()
    };
    assert!(
        value("constraint") <= 1e-12 && value("force") <= 1e-12,
        "{text}"
    );
    assert!(
        value("staggered-gs") > 1e-6 && value("staggered-jacobi") > 1e-6,
        "{text}"
    );
}

#[test]
fn plot_writes_svg() {
    let csv = scratch("plot.csv");
    let status = dirac()
        .args([
            "run",
            repo("examples/netlists/seed_rlc.cir").to_str().unwrap(),
            "--out",
            csv.to_str().unwrap(),
            "--t-end",
            "5",
            "--quiet",
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let svg = scratch("plot.svg");
    let status = dirac()
        .args(["plot", csv.to_str().unwrap(), "-o", svg.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

/// A scene's `[record]` energy, power, residuals and forces become columns after the signals; a
/// node force in a staggered run is bad input (exit 2, no output file).
#[test]
fn scene_record_requests_become_columns() {
    let text = std::fs::read_to_string(repo("examples/scenes/seed_rlc.toml")).expect("scene");
    let text = text.replace(
        "signals = [\"C1.q\", \"L1.i\"]",
        "signals = [\"C1.q\", \"L1.i\"]\nenergy = true\npower = [\"R1\"]\nresiduals = true\nforces = [\"n2\"]",
    );
    let scene = scratch("recorded.toml");
    std::fs::write(&scene, text).expect("write scene");
    let out = scratch("recorded.csv");
    let status = dirac()
        .args(["run", scene.to_str().unwrap(), "--t-end", "1", "--quiet"])
        .args(["--out", out.to_str().unwrap()])
        .status()
        .expect("runs");
    assert!(status.success());
    let csv = std::fs::read_to_string(&out).expect("output");
    assert_eq!(
        csv.lines().next(),
        Some("t,C1.q,L1.i,energy,power(R1),constraint_residual,force(n2)")
    );
    assert_eq!(csv.lines().count(), 22);
    let refused = scratch("refused.csv");
    let output = dirac()
        .args(["run", scene.to_str().unwrap(), "--t-end", "1", "--quiet"])
        .args([
            "--representation",
            "staggered",
            "--out",
            refused.to_str().unwrap(),
        ])
        .output()
        .expect("runs");
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("force(n2)"));
    assert!(!refused.exists());
}

/// `--start-ramp` on a stiff two-section RC ladder started off its slow manifold (`v(n1) = 1`,
/// `v(n2) = 3`, fast time constant about 1e-6 s, h = 0.01): the grid and the row count are
/// those of the plain run, the JSON summary counts the ramp's substeps, and at the end
/// `v(n2) − v(n1)` is the quasi-static gap `R₂C₂ |v̇(n2)| ≤ 1e-3 · 1e-3 · 1.1 ≈ 1.1e-6` (the slow
/// mode decays at rate about 1/(R₁(C₁ + C₂)) from about 1 V), where the plain run still rings
/// with an O(1) gap (`|R(λh)| ≈ 1 − 4/(|λ|h)`, |λ|h ≈ 1e4, per step). The plain run is
/// `--no-start-ramp`: a netlist takes a ramp by itself when the modal check finds such a mode.
/// Both ramps, asked for or not, are sized to reach it (`h/τ` = 1e4: ⌈log₂ 1e4⌉ + 2 = 16 levels
/// of 3 substeps, 51 in all, down to `h·2⁻¹⁶/3` = 5e-8 s against τ = 1e-6 s), not the default
/// 32 levels (99 substeps), whose rows equalled these to 1e-9 (measured before the flag was
/// sized) and which stop Gauss 3 and 4 on MOSFET decks (audit 43).
#[test]
fn start_ramp_damps_a_stiff_start_and_is_reported() {
    let netlist = scratch("stiff_rc.cir");
    std::fs::write(
        &netlist,
        "stiff RC ladder\nR1 0 n1 1\nC1 n1 0 1 IC=1\nR2 n1 n2 1e-3\nC2 n2 0 1e-3 IC=3\n.tran 0.01 0.5 uic\n.end\n",
    )
    .expect("netlist");
    let run = |flag: Option<&str>| {
        let mut args = vec![
            "run",
            netlist.to_str().unwrap(),
            "--signals",
            "v(n1),v(n2)",
            "--json-summary",
            "--quiet",
        ];
        args.extend(flag);
        let output = dirac().args(&args).output().expect("runs");
        assert!(output.status.success(), "{output:?}");
        let rows: Vec<Vec<f64>> = String::from_utf8(output.stdout)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        let stderr = String::from_utf8(output.stderr).unwrap();
        let summary: serde_json::Value = stderr
            .lines()
            .find_map(|l| serde_json::from_str(l).ok())
            .expect("a JSON summary");
        (rows, summary)
    };
    let (plain, plain_summary) = run(Some("--no-start-ramp"));
    let (ramped, summary) = run(Some("--start-ramp"));
    let (default, default_summary) = run(None);
    assert_eq!(
        default, ramped,
        "a netlist with a stiff start takes the ramp asked for by itself"
    );
    assert_eq!(default_summary["ramp_substeps"], 51);
    assert_eq!(plain.len(), 51, "t = 0, 0.01, …, 0.5");
    assert_eq!(ramped.len(), plain.len());
    for (a, b) in plain.iter().zip(&ramped) {
        assert_eq!(a[0], b[0], "the grid must not move");
    }
    assert_eq!(plain_summary["ramp_substeps"], 0);
    assert_eq!(summary["ramp_substeps"], 51);
    assert_eq!(summary["steps"], plain_summary["steps"]);
    let gap = |rows: &[Vec<f64>]| {
        let last = &rows[rows.len() - 1];
        (last[2] - last[1]).abs()
    };
    println!(
        "v(n2) − v(n1) at t = 0.5: plain {:.3e}, ramped {:.3e}",
        gap(&plain),
        gap(&ramped)
    );
    assert!(gap(&plain) > 0.1, "the control must ring");
    assert!(gap(&ramped) <= 1.1e-6, "{}", gap(&ramped));
}

/// `A.x`, `B.x` of `two_mass_split.toml` (walls and coupling springs k = 1, unit masses, released
/// from x = (1, 0) at rest): the normal modes 1 and √3 give `x_A = ½(cos t + cos √3 t)`,
/// `x_B = ½(cos t − cos √3 t)`.
fn two_mass_exact(t: f64) -> [f64; 2] {
    let (slow, fast) = (t.cos(), (3f64.sqrt() * t).cos());
    [0.5 * (slow + fast), 0.5 * (slow - fast)]
}

/// Largest error of `A.x`, `B.x` against [`two_mass_exact`] over a `dirac run` of the bundled
/// two-mass scene with the trapezoid rule (explicit Störmer–Verlet: masses and springs are
/// separable) at step `h`, with the extra arguments `extra`.
fn two_mass_error(h: &str, extra: &[&str]) -> f64 {
    let scene = repo("examples/scenes/two_mass_split.toml");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--method",
        "trapezoid",
        "--h",
        h,
        "--t-end",
        "20",
        "--signals",
        "A.x,B.x",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let output = dirac().args(&args).output().expect("runs");
    assert!(output.status.success(), "{output:?}");
    let text = String::from_utf8(output.stdout).unwrap();
    let mut worst: f64 = 0.0;
    for line in text.lines().skip(1) {
        let row: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let exact = two_mass_exact(row[0]);
        worst = worst.max((row[1] - exact[0]).abs().max((row[2] - exact[1]).abs()));
    }
    worst
}

/// `--composition` composes the step: on the two-mass scene each composition shows its order
/// against the closed-form normal-mode solution when h halves (within 0.3), and the scene key
/// `composition = ...` gives the same rows as the flag. An unknown name is an input error that
/// lists the known ones.
#[test]
fn compositions_from_the_command_line_have_their_order() {
    let plain = two_mass_error("0.1", &[]);
    let plain_fine = two_mass_error("0.05", &[]);
    println!(
        "single step: {plain:.2e}, {plain_fine:.2e}: order {:.2}",
        (plain / plain_fine).log2()
    );
    assert!(((plain / plain_fine).log2() - 2.0).abs() < 0.3);
    for (name, order, h) in [("yoshida6", 6.0, "0.4"), ("kahan-li8", 8.0, "0.8")] {
        let coarse = two_mass_error(h, &["--composition", name]);
        let half = format!("{}", h.parse::<f64>().unwrap() / 2.0);
        let fine = two_mass_error(&half, &["--composition", name]);
        let observed = (coarse / fine).log2();
        println!("{name}: {coarse:.2e} at h = {h}, {fine:.2e} at {half}: order {observed:.2}");
        assert!(
            fine > 1e-12,
            "{name}: {fine:e} is round-off, not truncation"
        );
        assert!((observed - order).abs() < 0.3, "{name}: order {observed}");
    }

    // The scene key gives the flag's rows.
    let text = std::fs::read_to_string(repo("examples/scenes/two_mass_split.toml")).unwrap();
    let keyed = scratch("two_mass_yoshida6.toml");
    std::fs::write(
        &keyed,
        text.replace(
            "discretisation = \"midpoint\"",
            "discretisation = \"trapezoid\"\ncomposition = \"yoshida6\"",
        ),
    )
    .unwrap();
    let rows = |file: &Path, extra: &[&str]| {
        let mut args = vec!["run", file.to_str().unwrap(), "--t-end", "5", "--quiet"];
        args.extend_from_slice(extra);
        let output = dirac().args(&args).output().expect("runs");
        assert!(output.status.success(), "{output:?}");
        output.stdout
    };
    let flag = rows(
        &repo("examples/scenes/two_mass_split.toml"),
        &["--method", "trapezoid", "--composition", "yoshida6"],
    );
    assert_eq!(rows(&keyed, &[]), flag);
    assert_ne!(rows(&keyed, &["--composition", "none"]), flag);

    let bad = dirac()
        .args([
            "run",
            keyed.to_str().unwrap(),
            "--composition",
            "ruth3",
            "--quiet",
        ])
        .output()
        .expect("runs");
    let stderr = String::from_utf8(bad.stderr).unwrap();
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("unknown composition `ruth3`") && stderr.contains("`kahan-li8`"),
        "{stderr}"
    );
    assert!(bad.stdout.is_empty());

    // In a scene file the bad name is placed at its line and column.
    let bad_scene = scratch("two_mass_ruth3.toml");
    std::fs::write(
        &bad_scene,
        std::fs::read_to_string(&keyed)
            .unwrap()
            .replace("\"yoshida6\"", "\"ruth3\""),
    )
    .unwrap();
    let bad = dirac()
        .args(["run", bad_scene.to_str().unwrap(), "--quiet"])
        .output()
        .expect("runs");
    let stderr = String::from_utf8(bad.stderr).unwrap();
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("two_mass_ruth3.toml:12:15: unknown variant `ruth3`")
            && stderr.contains("`kahan-li8`"),
        "{stderr}"
    );
}

/// `dirac bench --methods` refuses, before any output, a method the scene does not sweep (naming
/// the scene's methods) and any method list on the scenes whose runs are fixed.
#[test]
fn bench_methods_are_checked_before_output() {
    for (scene, methods, message) in [
        ("E", "verlet,nope", "scene E has no method `nope`"),
        (
            "C",
            "midpoint",
            "--methods selects methods of the fixed-step scenes",
        ),
    ] {
        let output = dirac()
            .args(["bench", "--scene", scene, "--methods", methods])
            .output()
            .expect("runs");
        let stderr = String::from_utf8(output.stderr).unwrap();
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(message), "{stderr}");
        assert!(output.stdout.is_empty(), "no partial CSV");
    }
}
