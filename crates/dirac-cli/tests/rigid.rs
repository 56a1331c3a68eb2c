//! `dirac run` on a rigid-body scene: the bundled heavy symmetric top writes its `[record]`
//! columns, row 0 is the stated initial state (centre of mass `R₀ (0, 0, ℓ)` for a tilt of 0.6 rad
//! about `x`, spin 40 rad/s), and the spin about the symmetry axis `top.w3`, conserved by the
//! top's symmetry, stays 40 to round-off in every printed row (the CSV prints shortest round-trip
//! decimals, so nothing is lost in the text).

use std::path::PathBuf;
use std::process::Command;

/// Round-off on the spin over 4000 steps (measured 1.0e-14 relative).
const SPIN: f64 = 1e-12;

/// Round-off of the state read out at t_0 (the rates solve a linear system; measured 1.6e-15).
const ROW_ZERO: f64 = 1e-13;

/// Mutation seen to fail: `angular_velocity = [0.0, 0.0, 40.000001]` in the scene (row 0 reads
/// 40.000001).
#[test]
fn heavy_top_runs_from_the_command_line() {
    let scene =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/heavy_top.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_dirac"))
        .arg("run")
        .arg(&scene)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("UTF-8");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(
        header,
        [
            "t", "top.x", "top.y", "top.z", "top.w1", "top.w2", "top.w3", "top.wz", "pivot.fz",
            "energy"
        ]
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    assert_eq!(rows.len(), 4001);
    let (s, c) = 0.6_f64.sin_cos();
    let expected = [0.0, 0.0, -0.15 * s, 0.15 * c, 0.0, 0.0, 40.0];
    for (got, want) in rows[0].iter().zip(expected) {
        assert!((got - want).abs() < ROW_ZERO, "row 0: {:?}", rows[0]);
    }
    let worst = rows
        .iter()
        .map(|r| (r[6] / 40.0 - 1.0).abs())
        .fold(0.0, f64::max);
    println!("heavy top via dirac run: max |w3/40 − 1| = {worst:.2e}");
    assert!(worst < SPIN, "{worst:e}");
}
