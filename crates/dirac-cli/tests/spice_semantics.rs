//! What a SPICE user reads (issue 12): the operating point, a consistent start, values at t_k, the
//! method choice and the signals a netlist names. Each check is against a closed form or the
//! netlist's own stated initial state.

use std::path::PathBuf;
use std::process::{Command, Output};

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dirac-semantics-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir.join(name)
}

fn dirac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dirac"))
        .args(args)
        .output()
        .expect("dirac runs")
}

fn rows(csv: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = csv.lines();
    let header = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("number")).collect())
        .collect();
    (header, rows)
}

/// `.op` of a current divider (1 mA into 1k ∥ (2k + 1k)): v(a) = 0.75 V, v(b) = 0.25 V, as
/// `signal,value` from `dirac run` on an `.op`-only netlist and as JSON from `dirac op --json`.
#[test]
fn operating_point_of_a_current_divider() {
    let file = repo("examples/netlists/divider_op.cir");
    let out = dirac(&["run", file.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("signal,value"));
    let values: Vec<(String, f64)> = lines
        .map(|l| {
            let (name, value) = l.split_once(',').expect("two columns");
            (name.to_string(), value.parse().expect("number"))
        })
        .collect();
    assert_eq!(values.len(), 2);
    assert_eq!(values[0].0, "v(a)");
    assert!((values[0].1 - 0.75).abs() <= 1e-15, "{values:?}");
    assert!((values[1].1 - 0.25).abs() <= 1e-15, "{values:?}");
    let json = dirac(&["op", file.to_str().unwrap(), "--json"]);
    let parsed: serde_json::Value = serde_json::from_slice(&json.stdout).expect("json");
    assert!(
        (parsed["v(b)"].as_f64().unwrap() - 0.25).abs() <= 1e-15,
        "{parsed}"
    );
}

/// A `.tran` without UIC starts from the operating point: the ladder with a 1 mA load sits at its
/// DC solution from row 0 (5, 4, 3, 2, 1 V down the four 1k sections) and stays there.
#[test]
fn transient_without_uic_starts_at_the_operating_point() {
    let file = repo("examples/netlists/ladder_op.cir");
    let out = dirac(&[
        "run",
        file.to_str().unwrap(),
        "--signals",
        "v(in),v(x1.mid),v(a),v(x2.mid),v(b)",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (_, rows) = rows(&String::from_utf8(out.stdout).unwrap());
    for row in &rows {
        for (value, expected) in row[1..].iter().zip([5.0, 4.0, 3.0, 2.0, 1.0]) {
            // Round-off of a ladder of five unknowns around 1–5 V.
            assert!((value - expected).abs() <= 1e-13, "{row:?}");
        }
    }
}

/// Row 0 of every bundled netlist with UIC is the netlist's stated initial state: capacitor
/// charges C·IC, inductor currents IC (zero where none is given), and every node voltage that a
/// source or a charged capacitor fixes.
#[test]
fn row_zero_is_the_stated_initial_state() {
    for (file, column, expected) in [
        ("seed_rlc.cir", "q(c1)", 3.0),
        ("seed_rlc.cir", "i(l1)", 0.0),
        ("seed_rlc.cir", "v(1)", 1.0),
        ("rc_dc.cir", "v(in)", 5.0),
        ("coupled_lc.cir", "v(p)", 1.0),
        ("v_across_c.cir", "q(c1)", 1e-6),
    ] {
        let path = repo(&format!("examples/netlists/{file}"));
        let out = dirac(&["run", path.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (header, rows) = rows(&String::from_utf8(out.stdout).unwrap());
        let c = header.iter().position(|h| h == column).expect("column");
        assert_eq!(rows[0][0], 0.0);
        assert!(
            (rows[0][c] - expected).abs() <= 1e-15 * (1.0 + expected.abs()),
            "{file} {column}: {} vs {expected}",
            rows[0][c]
        );
    }
}

/// A 1 V source across an uncharged 1 µF capacitor (UIC): the start is moved onto q = C·V with a
/// warning naming the charge, and the charge does not ring (the midpoint rule would alternate
/// 0, 2 µC, 0, … from the inconsistent start).
#[test]
fn inconsistent_start_is_repaired_with_a_warning_and_does_not_ring() {
    let path = repo("examples/netlists/v_across_c.cir");
    let out = dirac(&["run", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("c1.q = 0") && stderr.contains("set to"),
        "{stderr}"
    );
    let (header, rows) = rows(&String::from_utf8(out.stdout).unwrap());
    let q = header.iter().position(|h| h == "q(c1)").unwrap();
    for row in &rows {
        assert!((row[q] - 1e-6).abs() <= 1e-21, "{row:?}");
    }
}

/// A node joined only through capacitors has no DC path: the operating point is refused (exit 2)
/// naming the node and suggesting UIC or a resistor to ground, with no output file.
#[test]
fn no_dc_path_is_bad_input_naming_the_node() {
    let netlist = scratch("floating.cir");
    std::fs::write(
        &netlist,
        "floating\nV1 in 0 DC 1\nC1 in mid 1u\nC2 mid 0 1u\n.tran 1u 10u\n.end\n",
    )
    .unwrap();
    let out_file = scratch("floating.csv");
    let out = dirac(&[
        "run",
        netlist.to_str().unwrap(),
        "--out",
        out_file.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("node `mid`") && stderr.contains("UIC"),
        "{stderr}"
    );
    assert!(!out_file.exists());
}

/// A current source into a capacitor-only cut set has no DC solution: exit 2 naming the node.
#[test]
fn current_source_into_capacitors_has_no_operating_point() {
    let netlist = scratch("cutset.cir");
    std::fs::write(
        &netlist,
        "cutset\nI1 0 a DC 1m\nC1 a 0 1u\nC2 a 0 2u\n.tran 1u 10u\n.end\n",
    )
    .unwrap();
    let out = dirac(&["run", netlist.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("node `a`"), "{stderr}");
}

/// `.print` chooses the recorded signals (a difference `v(a,b)` included, quoted in the header);
/// `--method gauss2` is accepted for netlists and changes the result (a fourth-order method).
#[test]
fn print_cards_and_method_choice() {
    let netlist = scratch("printed.cir");
    std::fs::write(
        &netlist,
        "printed\nV1 in 0 SIN(0 1 1k)\nR1 in out 1k\nC1 out 0 100n\n.tran 10u 1m\n.print tran v(out) v(in,out) i(r1)\n.end\n",
    )
    .unwrap();
    let out = dirac(&["run", netlist.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.starts_with("t,v(out),\"v(in,out)\",i(r1)\n"), "{text}");
    let gauss = dirac(&["run", netlist.to_str().unwrap(), "--method", "gauss2"]);
    assert!(gauss.status.success());
    assert_ne!(gauss.stdout, text.as_bytes());
    // v(in, out) = R·i(r1): an algebraic relation, exact at every row.
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.trim_matches('"').parse().unwrap())
            .collect();
        assert!((v[2] - 1e3 * v[3]).abs() <= 1e-15, "{line}");
    }
}

/// At a PULSE corner the source node reads the source's value at t_k (steps land on corners): the
/// 1 ms corner of rc_pulse.cir reads 0 (the old step-midpoint readout read 0.125).
#[test]
fn source_nodes_read_the_source_at_corners() {
    let path = repo("examples/netlists/rc_pulse.cir");
    let out = dirac(&["run", path.to_str().unwrap(), "--signals", "v(in)"]);
    assert!(out.status.success());
    let (_, rows) = rows(&String::from_utf8(out.stdout).unwrap());
    let at = |t: f64| {
        rows.iter()
            .find(|r| (r[0] - t).abs() < 1e-12)
            .map(|r| r[1])
            .expect("row")
    };
    assert_eq!(at(1e-3), 0.0);
    assert!((at(1.05e-3) - 2.5).abs() <= 1e-12, "{}", at(1.05e-3));
    assert_eq!(at(1.1e-3), 5.0);
}
