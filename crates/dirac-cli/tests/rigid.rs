//! `dirac run` on a rigid-body scene: the bundled heavy symmetric top writes its `[record]`
//! columns, row 0 is the stated initial state (centre of mass `R₀ (0, 0, ℓ)` for a tilt of 0.6 rad
//! about `x`, spin 40 rad/s), and the spin about the symmetry axis `top.w3`, conserved by the
//! top's symmetry, stays 40 to round-off in every printed row (the CSV prints shortest round-trip
//! decimals, so nothing is lost in the text).

mod common;

use common::scratch;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Round-off on the spin over 4000 steps (measured 1.0e-14 relative).
const SPIN: f64 = 1e-12;

/// Round-off of the state read out at t_0 (the rates solve a linear system; measured 1.6e-15).
const ROW_ZERO: f64 = 1e-13;

/// The bundled scene `name`.
fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/scenes")
        .join(name)
}

/// `dirac command path args…`.
fn dirac(command: &str, path: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dirac"))
        .arg(command)
        .arg(path)
        .args(args)
        .output()
        .expect("runs")
}

/// The standard output of `out`, which must have succeeded (`context` names the run).
fn stdout_of(out: &Output, context: &str) -> String {
    assert!(
        out.status.success(),
        "{context}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).expect("UTF-8")
}

/// Mutation seen to fail: `angular_velocity = [0.0, 0.0, 40.000001]` in the scene (row 0 reads
/// 40.000001).
#[test]
fn heavy_top_runs_from_the_command_line() {
    let out = dirac("run", &scene("heavy_top.toml"), &[]);
    let text = stdout_of(&out, "heavy_top.toml");
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

/// The energies `dirac run four_bar.toml --h H --t-end T` records, one per row, and its stderr.
fn four_bar_energies(h: &str, t_end: &str) -> (Vec<f64>, String) {
    let out = dirac(
        "run",
        &scene("four_bar.toml"),
        &["--h", h, "--t-end", t_end, "--signals", "energy"],
    );
    let energies = second_column(&stdout_of(&out, &format!("four_bar.toml at h = {h}")));
    (energies, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The second column of a `t,signal` CSV, one value per row.
fn second_column(csv: &str) -> Vec<f64> {
    csv.lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(1)
                .expect("second column")
                .parse()
                .expect("number")
        })
        .collect()
}

/// The bundled spatial four-bar at a long step, h = 0.03 (its crank turns up to about 0.7 rad
/// per step on the motion's branch). The discrete rigid body's step equations have roots that
/// no motion takes. Newton once solved step 9 to one that turned the crank 2.5 rad (the energy
/// jumped from 0.59 to 2.97 J): a step that turns a body a quarter turn or more is rejected and
/// cut (`Model::check_step`). Then step 20 landed on one below a quarter turn: the crank turned
/// 1.27 rad where two half steps turn it 0.70 rad and end 0.58 rad from it, and the energy
/// jumped from 0.56 to 0.93 J (45 % of its start) and stayed there. A step that turns a body by
/// more than 0.25 rad is now checked against two half steps and cut when their ends lie more
/// than half their turn apart. On the motion's branch this coarse step's energy dips while the
/// crank swings through fast (0.51 J) and comes back; it is never above its start by more than
/// 1e-3 J here, so 5 % above it can only be a root off the branch. The run warns that steps
/// were cut as such roots.
#[test]
fn a_long_step_does_not_land_on_a_spurious_rotation() {
    let (energies, stderr) = four_bar_energies("0.03", "1.2");
    assert_eq!(energies.len(), 41);
    // The cut roots are reported: the step is long for the rotation.
    assert!(
        stderr.contains("landed on a root of a rigid body's step equations"),
        "{stderr}"
    );
    let start = energies[0];
    let highest = energies.iter().copied().fold(f64::MIN, f64::max);
    let lowest = energies.iter().copied().fold(f64::MAX, f64::min);
    println!("four-bar at h = 0.03: energy {lowest:.3} … {highest:.3} J, start {start:.4} J");
    assert!(highest < 1.05 * start, "{energies:?}");
    assert!(lowest > 0.5 * start, "{energies:?}");
}

/// The heavy top spins at 40 rad/s: at h = 0.01 every step turns it by 0.4 rad, on the motion's
/// branch (each is checked against two half steps and kept), but its discrete spin rate is
/// `sin θ/h` for a mean rate `θ/h`, 2.7 % apart: the run warns that h resolves the rotation
/// coarsely, as it warns where roots were cut. At its own h = 1e-3 (0.04 rad a step) it does
/// not. Can fail: without the warning for checked-and-kept steps the coarse run is silent.
#[test]
fn a_step_that_turns_a_body_far_warns_that_the_rotation_is_coarse() {
    let coarse = dirac("run", &scene("heavy_top.toml"), &["--h", "0.01"]);
    stdout_of(&coarse, "heavy_top.toml --h 0.01");
    let stderr = String::from_utf8_lossy(&coarse.stderr);
    assert!(
        stderr.contains("400 step(s) turned a body by more than 0.25 rad"),
        "{stderr}"
    );
    let fine = dirac("run", &scene("heavy_top.toml"), &[]);
    stdout_of(&fine, "heavy_top.toml");
    let stderr = String::from_utf8_lossy(&fine.stderr);
    assert!(!stderr.contains("warning"), "{stderr}");
}

/// Where Newton fails on a long step of the four-bar, the step is cut; its pieces started from
/// the iterate Newton gave up on, scaled down, which on a rigid body can be turned by radians,
/// and every piece down to h/1024 failed: at h = 0.03 at step 101, at h = 0.1 at step 10 (with
/// the half-step check above; without it at step 16 of h = 0.04 and step 3 of h = 0.1). A model
/// that checks its steps now starts the pieces from the guess the failed solve started from,
/// and the runs reach their end.
#[test]
fn a_failed_long_step_is_cut_from_its_guess() {
    for h in ["0.03", "0.1"] {
        let (energies, _) = four_bar_energies(h, "4");
        assert!(energies.iter().all(|e| e.is_finite()), "h = {h}");
        assert_eq!(
            energies.len(),
            (4.0 / h.parse::<f64>().expect("h")).round() as usize + 1
        );
    }
}

/// `--refine` (SPICE's truncation-error control) on the spatial four-bar: a body held by a
/// joint carries the joint's impulse in its momentum, which depends on the substep's size (a
/// body held at its height under gravity has `p_z = −(s/2)·m·g` after a substep of size `s`),
/// so judging that momentum made every refinement a reason for the next: 2375 refinements in
/// the first 1000 steps, 309 Newton updates per step, and a failure at t = 2.57 (Newton at
/// `h/1024`). A coordinate in a holonomic row is judged by its position now: the run at
/// h = 1e-3 refines nothing and writes the rows of the run without `--refine`.
#[test]
fn refinement_judges_a_held_body_by_its_position() {
    let run = |refine: bool| {
        let mut args = vec!["--t-end", "1", "--json-summary"];
        if refine {
            args.push("--refine");
        }
        let out = dirac("run", &scene("four_bar.toml"), &args);
        let rows = stdout_of(&out, "four_bar.toml");
        let summary: serde_json::Value = String::from_utf8_lossy(&out.stderr)
            .lines()
            .find_map(|l| serde_json::from_str(l).ok())
            .expect("a JSON summary");
        (rows, summary)
    };
    let (refined, summary) = run(true);
    let (plain, _) = run(false);
    assert_eq!(summary["refinements"], 0, "{summary}");
    assert_eq!(refined, plain);
}

/// The planar chain swings in the x–z plane, so its links' rates out of the plane are zero by
/// symmetry (1e-38 to 1e-30: round-off). The readout judges a rate's disagreement between the
/// state and the steps against the largest rate read; that scale was gathered entry by entry,
/// so at the first row compared a zero rate listed before the moving ones was judged against
/// round-off alone, and the run warned that `energy` carried "a mode faster than the step" at
/// 862 069 % of its size. No mode is there to find: the run must not warn.
#[test]
fn a_rate_zero_by_symmetry_is_not_a_fast_mode() {
    let out = dirac("run", &scene("pendulum_chain.toml"), &["--t-end", "0.05"]);
    stdout_of(&out, "pendulum_chain.toml");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("warning"), "{stderr}");
}

/// `dirac op` of a mechanism is its static equilibrium. Its positions are held only through the
/// curvature of its constraints, `λ·∂²g/∂q²`, which vanishes at `λ = 0`: the structural check
/// called the pendulum's coordinates "not fixed by any equation" and, past it, Newton's first
/// matrix was singular. The multipliers now start from the least-squares balance of the forces,
/// and the Cartesian pendulum (rod of length 1, released at 1 rad) hangs straight down, as it
/// must. Released level, gravity is normal to the rod, the balancing multiplier is zero and the
/// first matrix singular again: stiffness stepping (a spring to the start, relaxed to none)
/// finds the same point. The spatial four-bar finds a configuration where every body's force
/// and torque balance (the residual is checked by the solve; which of the linkage's equilibria
/// Newton reaches from the start is not asserted).
#[test]
fn the_static_equilibrium_of_a_mechanism() {
    let level = scratch("level.toml");
    let text = std::fs::read_to_string(scene("cartesian_pendulum.toml")).expect("scene");
    let released = "q0 = { x = 0.8414709848078965, y = -0.5403023058681398 }";
    assert!(text.contains(released));
    std::fs::write(&level, text.replace(released, "q0 = { x = 1.0, y = 0.0 }")).expect("written");
    let op = |path: &Path| op_values(path).0;
    for path in [scene("cartesian_pendulum.toml"), level] {
        let pendulum = op(&path);
        let value = |name: &str| signal(&pendulum, name);
        assert!(value("P.x").abs() < 1e-12, "{path:?}: {pendulum:?}");
        assert!((value("P.y") + 1.0).abs() < 1e-12, "{path:?}: {pendulum:?}");
        assert!(value("P.x'").abs() < 1e-12 && value("P.y'").abs() < 1e-12);
    }
    let four_bar = op(&scene("four_bar.toml"));
    assert!(
        four_bar
            .iter()
            .any(|(n, v)| n == "constraint_residual" && v.abs() < 1e-12),
        "{four_bar:?}"
    );
}

/// The value of signal `name` among `op`'s values.
fn signal(values: &[(String, f64)], name: &str) -> f64 {
    values
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .expect(name)
}

/// `op`'s values as `(signal, value)`, with its stderr.
fn op_values(path: &Path) -> (Vec<(String, f64)>, String) {
    let out = dirac("op", path, &[]);
    let values = stdout_of(&out, &path.display().to_string())
        .lines()
        .skip(1)
        .map(|l| {
            let (name, value) = l.split_once(',').expect("signal,value");
            (name.to_string(), value.parse::<f64>().expect("number"))
        })
        .collect();
    (values, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The heavy top's steady states form a continuum (it may be turned about the vertical), so
/// Newton's matrix is singular at every one of them: `dirac op` stopped there with "no isolated
/// steady state". Stiffness stepping's proximal iteration (a soft spring whose anchor follows
/// the solution) now settles on one, and `op` prints it with a warning that it is not isolated.
/// What must hold at any equilibrium of a top on a spherical pivot, whatever Newton reaches: the
/// centre of mass on the vertical through the pivot, at its distance 0.15 m (upright or hanging),
/// at rest, the pivot carrying the weight `m g` = 1.2 · 9.81 N.
#[test]
fn a_steady_state_that_is_not_isolated_is_found_and_named() {
    let (top, stderr) = op_values(&scene("heavy_top.toml"));
    let value = |name: &str| signal(&top, name);
    assert!(
        stderr.contains("not isolated") && stderr.contains("symmetry"),
        "{stderr}"
    );
    assert!(
        value("top.x").abs() < 1e-12 && value("top.y").abs() < 1e-12,
        "{top:?}"
    );
    assert!((value("top.z").abs() - 0.15).abs() < 1e-12, "{top:?}");
    for w in ["top.w1", "top.w2", "top.w3", "top.wz"] {
        assert!(value(w).abs() < 1e-12, "{top:?}");
    }
    assert!((value("pivot.fz") - 1.2 * 9.81).abs() < 1e-9, "{top:?}");
}

/// A scene written from a bundled one with `replacements` (each `from` must occur; its first
/// occurrence is replaced), to a temporary file named `name` (removed by the caller).
fn variant(bundled: &str, name: &str, replacements: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(scene(bundled)).expect("scene");
    for (from, to) in replacements {
        assert!(text.contains(from), "{bundled}: {from}");
        text = text.replacen(from, to, 1);
    }
    let path = scratch(name);
    std::fs::write(&path, text).expect("written");
    path
}

/// The heavy top hanging straight down at rest, its start exactly an equilibrium: stiffness
/// stepping sized its springs by the start's unbalanced force (1.2e-9 N here), so every spring
/// was too soft to hold the free turn about the vertical and the first solve met a singular
/// matrix, before the proximal iteration could start ("no isolated steady state"). The springs
/// are now sized by the applied force (the weight, 11.772 N), and a schedule that fails after a
/// stiffer spring converged goes on with the proximal iteration from there.
#[test]
fn a_top_at_rest_at_its_equilibrium_has_it() {
    let path = variant(
        "heavy_top.toml",
        "hanging_top.toml",
        &[
            (
                "position = [0.0, -0.0846963710092553, 0.12380034223645174]",
                "position = [0.0, 0.0, -0.15]",
            ),
            (
                "rotation = { axis = [1.0, 0.0, 0.0], angle = 0.6 }",
                "rotation = { axis = [1.0, 0.0, 0.0], angle = 3.141592653589793 }",
            ),
            ("angular_velocity = [0.0, 0.0, 40.0]", ""),
        ],
    );
    let (top, stderr) = op_values(&path);
    std::fs::remove_file(&path).expect("removed");
    let value = |name: &str| signal(&top, name);
    assert!(stderr.contains("not isolated"), "{stderr}");
    assert!(
        value("top.x").abs() < 1e-12 && value("top.y").abs() < 1e-12,
        "{top:?}"
    );
    assert!((value("top.z") + 0.15).abs() < 1e-12, "{top:?}");
    assert!((value("pivot.fz") - 1.2 * 9.81).abs() < 1e-9, "{top:?}");
}

/// The four-bar at h = 0.03 with a free sphere spinning at 32.8 rad/s beside it (1 rad per
/// step). The half-step check compared the largest disagreement of any body with the largest
/// turn of any body: the sphere's 1 rad let the rocker's root off the branch through (its full
/// step 0.12 rad from the half steps' end, which turn it 0.10 rad), and the energy rose by
/// 0.14 and 0.28 J in single steps. Judged body by body, the run's energy stays at its start
/// or below it (the four-bar's coarse-step dips).
#[test]
fn a_fast_body_does_not_hide_another_bodys_spurious_root() {
    let path = variant(
        "four_bar.toml",
        "four_bar_spinner.toml",
        &[(
            "[[connection]]",
            "[[part]]\nname = \"spinner\"\ntype = \"rigid_body\"\nm = 1.0\n\
             inertia = [0.01, 0.01, 0.01]\nposition = [5.0, 5.0, 0.0]\n\
             angular_velocity = [0.0, 0.0, 32.8]\n\n[[connection]]",
        )],
    );
    let out = dirac(
        "run",
        &path,
        &["--h", "0.03", "--t-end", "4", "--signals", "energy"],
    );
    std::fs::remove_file(&path).expect("removed");
    let energies = second_column(&stdout_of(&out, "four-bar with a spinner"));
    assert_eq!(energies.len(), 134);
    let start = energies[0];
    let highest = energies.iter().copied().fold(f64::MIN, f64::max);
    println!("four-bar and spinner at h = 0.03: highest energy {highest:.4} J, start {start:.4} J");
    assert!(highest - start < 0.02, "{energies:?}");
}

/// The motor arm's drive torque at t_k (`force(drive)`, the multiplier of the row that ties the
/// gear's output to the base joint's angle) against the motor's own torque balance: the gear
/// passes `(k i − b ω − J ω̇)/ratio` from the motor (k = 0.5, b = 0.02, J = 0.001, ratio 0.8; ω̇
/// by fourth-order central differences of `M.theta'`) to the column. The readout took the constraints'
/// contracted derivative through a row subset (a KCL row of the closed loop is dropped) whose
/// scratch storage held the forms' pattern, and read the torque 0.0196 N·m off at t = 0.1 and
/// 0.062 at t = 0.311 (of 0.343), at every step size; now it agrees to the differences' error.
#[test]
fn the_motor_arm_reads_its_drive_torque_from_the_motor() {
    let out = dirac(
        "run",
        &scene("motor_arm.toml"),
        &[
            "--h",
            "5e-4",
            "--t-end",
            "0.8",
            "--signals",
            "M.i,M.theta',force(drive)",
        ],
    );
    let rows: Vec<Vec<f64>> = stdout_of(&out, "motor_arm.toml")
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    let h = rows[1][0] - rows[0][0];
    let (k, b, j, ratio) = (0.5, 0.02, 0.001, 0.8);
    let mut worst = 0.0_f64;
    for i in (100..rows.len() - 2).step_by(50) {
        let (current, rate, torque) = (rows[i][1], rows[i][2], rows[i][3]);
        let acceleration = (8.0 * (rows[i + 1][2] - rows[i - 1][2]) - rows[i + 2][2]
            + rows[i - 2][2])
            / (12.0 * h);
        let from_motor = (k * current - b * rate - j * acceleration) / ratio;
        worst = worst.max((torque + from_motor).abs());
    }
    println!("motor arm: |force(drive) + (k i − b ω − J ω̇)/ratio| ≤ {worst:.2e} N·m");
    assert!(worst < 1e-4, "{worst:e}");
}

/// The DC motor stalled against its load's torsion spring: 6 V over 2 Ω drives the stall
/// current 3 A, whose torque `k i` = 0.3 N·m the 0.25 gear raises to 1.2 N·m, which turns the
/// spring (k = 2 N·m/rad) by 0.6 rad. The motor's and the load's shafts are joined by their
/// rates (one-form rows between coordinates at rest at the steady state); with the forms'
/// derivative returned correctly by the row subset (audit 49) those rows were empty and the gear's
/// angles "not fixed by any equation" (it had worked by that defect's accident); they now hold as
/// their integrals, the shafts at their start's offsets.
#[test]
fn the_dc_motor_stalls_against_its_spring() {
    let (motor, _) = op_values(&scene("dc_motor.toml"));
    let value = |name: &str| signal(&motor, name);
    assert!((value("M.i") - 3.0).abs() < 1e-12, "{motor:?}");
    assert!((value("J.theta") - 0.6).abs() < 1e-12, "{motor:?}");
    assert!(value("M.theta'").abs() < 1e-12 && value("J.theta'").abs() < 1e-12);
}

/// The motor arm's motor, fed a constant voltage, turns a column that nothing holds: at rest its
/// torque `k V/R` has nothing to balance it, so there is no static equilibrium (the motion tends
/// to a steady rotation). `dirac op` failed with "Newton did not converge" and advice for
/// circuits; stiffness stepping's proximal iteration moves the gear by the same 1.076 rad with
/// every solve (the spring's pull balancing the constant torque), which now reads as the
/// model's answer: no static equilibrium, the gear's angles named, exit 2 (a model without a
/// steady state, as a current source into capacitors). The DC motor held by its spring
/// (`the_dc_motor_stalls_against_its_spring`) and the hanging chain, whose proximal iteration
/// settles, are the controls.
#[test]
fn a_motor_turning_a_free_column_has_no_static_equilibrium() {
    let out = dirac("op", &scene("motor_arm.toml"), &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(out.stdout.is_empty(), "no partial output");
    assert!(stderr.contains("no static equilibrium"), "{stderr}");
    assert!(stderr.contains("`G.theta1`"), "{stderr}");
}

/// The bundled pendulum chain (ten links of 0.7 kg on hinges about y, each hinge 0.3 m from the
/// last link's centre of mass, the first at its own) stopped `dirac op` with a singular matrix
/// at the end of stiffness stepping, 4.5e-6 N from balance: the last link's centre of mass sits
/// on its hinge, so it may hang at any angle. Its equilibrium hangs straight down, every link's
/// centre of mass 0.3 m below the last (potential energy `−m g 0.3 (0 + 1 + … + 9)`), and the
/// proximal iteration leaves the free angle where it started (4.0 rad about y).
#[test]
fn the_hanging_chain_has_its_equilibrium() {
    let (chain, stderr) = op_values(&scene("pendulum_chain.toml"));
    let value = |name: &str| signal(&chain, name);
    assert!(stderr.contains("not isolated"), "{stderr}");
    assert!(value("link9.x").abs() < 1e-12, "{chain:?}");
    assert!((value("link9.z") + 2.7).abs() < 1e-12, "{chain:?}");
    assert!(
        (value("energy") + 0.7 * 9.81 * 0.3 * 45.0).abs() < 1e-9,
        "{chain:?}"
    );
    assert!(
        (value("link9.r11") - 4.0_f64.cos()).abs() < 1e-9,
        "{chain:?}"
    );
}
