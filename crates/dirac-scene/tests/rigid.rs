//! Rigid bodies and joints in scene files, through the run layer: the recorded angular velocity,
//! joint angle, joint slide and joint reaction force against closed forms (an isotropic body
//! spins uniformly, a small-amplitude compound pendulum swings at `√(m g d / (J + m d²))`, a body
//! on a prismatic joint falls on the parabola, a body hanging at rest is held up by `m g`), and
//! errors that name the file, line and column or the body and joint.

use dirac_rigid::so3;
use dirac_scene::{BuiltScene, Scene, SceneError};

/// Round-off allowance for order-one recorded values over a few thousand steps.
const ROUND_OFF: f64 = 1e-12;

/// Builds `text` (named `rigid.toml`), panicking with the error.
fn build(text: &str) -> BuiltScene {
    Scene::parse(text, "rigid.toml")
        .and_then(|s| s.build())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Every recorded row `(t, signals)` of the scene's run.
fn run(built: &BuiltScene) -> Vec<(f64, Vec<f64>)> {
    let mut sim = built.simulation().unwrap_or_else(|e| panic!("{e}"));
    let (run, _) = sim
        .run(built.t_end, &built.signals)
        .unwrap_or_else(|e| panic!("{e}"));
    (0..run.len())
        .map(|k| (run.t()[k], run.row(k).to_vec()))
        .collect()
}

/// The error of parsing and building `text` (named `bad.toml`).
fn error(text: &str) -> SceneError {
    match Scene::parse(text, "bad.toml").and_then(|s| s.build()) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            println!("{e}");
            e
        }
    }
}

/// A torque-free body with isotropic inertia keeps its angular velocity, in space and in body
/// axes (its angular momentum `J ω` is conserved and `J` is a multiple of `I`; the body axes
/// turn about `ω`, which they contain, so `Ω = Rᵀ ω` is constant too). The recorded `w1..w3`
/// equal the stated body rate `Ω₀` and `wx..wz` equal `R₀ Ω₀` at every row to round-off; so the
/// index maps of `vee(Rᵀ Ṙ)` and `vee(Ṙ Rᵀ)` and the product probes are right.
///
/// Measured: 1.9e-14 over 2000 steps.
///
/// Mutation seen to fail: the body sum written `Σ R_kb Ṙ_ka` (the transpose of `Rᵀ Ṙ`, i.e.
/// `−Ω`) reads 6.0 off (twice `Ω₃`).
#[test]
fn angular_velocity_of_an_isotropic_spinner() {
    let built = build(
        r#"
[simulation]
discretisation = "trapezoid"
h = 1e-3
t_end = 2.0

[[part]]
name = "ball"
type = "rigid_body"
m = 2.0
inertia = [0.4, 0.4, 0.4]
gravity = [0, 0, 0]
rotation = { axis = [1, 2, 2], angle = 0.7 }
angular_velocity = [1.0, -2.0, 3.0]

[record]
signals = ["ball.w1", "ball.w2", "ball.w3", "ball.wx", "ball.wy", "ball.wz"]
"#,
    );
    let body = [1.0, -2.0, 3.0];
    let r0 = so3::from_axis_angle([1.0, 2.0, 2.0], 0.7);
    let space = so3::apply(&r0, &body);
    let rows = run(&built);
    let mut worst = 0.0_f64;
    for (_, row) in &rows {
        for (k, expected) in body.iter().chain(&space).enumerate() {
            worst = worst.max((row[k] - expected).abs());
        }
    }
    println!(
        "isotropic spinner: {} rows, max |ω − ω₀| = {worst:.2e}",
        rows.len()
    );
    assert!(worst < ROUND_OFF, "{worst:e}");
}

/// A compound pendulum on a revolute joint about `y`: mass `m`, moment `J` about its centre of
/// mass, hinge `d` above it. At small amplitude `θ₀ = 10⁻³` the recorded `hinge.angle` is
/// `θ₀ cos Ω t` with `Ω² = m g d / (J + m d²)` and the body rate `w2` is its derivative
/// `−θ₀ Ω sin Ω t`; the differences are the step's phase error `(Ωh)²/12 · Ω t` and the
/// amplitude's `θ₀²/16` (both about 1e-5 of θ₀ here). The reaction force at the hinge is recorded
/// as well: its vertical component is `m g` to first order in `θ₀` (the pendulum's weight plus a
/// centripetal term of order `θ₀²`).
///
/// Mutations seen to fail: `m → 1.001 m` in the closed form (angle error 2.9e-7, rate 1.0e-6);
/// the body rate sign flip above (rate error 8.5e-3).
#[test]
fn compound_pendulum_angle_and_rate() {
    // Measured: max angle error 5.5e-9 rad, rate error 2.4e-8 rad/s (θ₀ = 1e-3, Ω = 4.26).
    const ANGLE: f64 = 5e-8;
    const RATE: f64 = 2e-7;
    // Vertical force: m g up to the θ₀² terms (9.3e-7 of m g measured; θ₀² = 1e-6).
    const FORCE: f64 = 1e-5;
    let (m, d, j, g, theta0) = (1.0, 0.5, 0.02, 9.81, 1e-3_f64);
    let (s, c) = theta0.sin_cos();
    let text = format!(
        r#"
[simulation]
discretisation = "trapezoid"
h = 1e-3
t_end = 2.0

[[part]]
name = "bob"
type = "rigid_body"
m = {m}
inertia = [{j}, {j}, {j}]
position = [{x}, 0, {z}]
rotation = {{ axis = [0, 1, 0], angle = {theta0} }}

[[connection]]
type = "revolute"
name = "hinge"
b = "bob"
origin_b = [0, 0, {d}]
axis_a = [0, 1, 0]
axis_b = [0, 1, 0]

[record]
signals = ["hinge.angle", "bob.w2", "hinge.fx", "hinge.fz"]
"#,
        x = -d * s,
        z = -d * c,
    );
    let rows = run(&build(&text));
    let omega = (m * g * d / (j + m * d * d)).sqrt();
    let (mut angle, mut rate, mut force) = (0.0_f64, 0.0_f64, 0.0_f64);
    for (t, row) in &rows {
        angle = angle.max((row[0] - theta0 * (omega * t).cos()).abs());
        rate = rate.max((row[1] + theta0 * omega * (omega * t).sin()).abs());
        force = force.max((row[3] / (m * g) - 1.0).abs());
    }
    println!("pendulum: angle {angle:.2e}, rate {rate:.2e}, vertical force {force:.2e}");
    assert!(angle < ANGLE && rate < RATE && force < FORCE);
}

/// A body on a prismatic joint along the vertical, with initial speed 1 upwards, falls on the
/// parabola `s = t − g t²/2`: the variational step with a constant force is exact on quadratics,
/// so the recorded `slide.slide` matches to round-off. The joint holds the body's orientation, so
/// its recorded angular velocity stays zero.
///
/// Mutation seen to fail: `g = 9.8` in the closed form (error 5.0e-3).
#[test]
fn prismatic_slide_falls_on_the_parabola() {
    // Measured 1.5e-14 over 1000 steps (order-one values, round-off).
    const PARABOLA: f64 = 1e-12;
    let built = build(
        r#"
[simulation]
h = 1e-3
t_end = 1.0

[[part]]
name = "slider"
type = "rigid_body"
m = 3.0
inertia = [0.1, 0.2, 0.25]
velocity = [0, 0, 1]

[[connection]]
type = "prismatic"
name = "slide"
b = "slider"

[record]
signals = ["slide.slide", "slider.wx", "slider.w3"]
"#,
    );
    let rows = run(&built);
    let mut worst = 0.0_f64;
    for (t, row) in &rows {
        worst = worst.max((row[0] - (t - 0.5 * 9.81 * t * t)).abs());
        worst = worst.max(row[1].abs()).max(row[2].abs());
    }
    println!("prismatic: max |s − (t − g t²/2)| = {worst:.2e}");
    assert!(worst < PARABOLA, "{worst:e}");
}

/// A body hanging at rest from a spherical joint is in equilibrium: the joint holds it up with
/// `m g`, so the recorded `fz` (the force on body `b`) is `m g` and `fx`, `fy` are zero at every
/// row; `fz` is the multiplier of row 2, `force(ball[2])`.
///
/// Mutations seen to fail: recording `fz` as minus the row multiplier (the force on side `a`)
/// reads `−m g`; the expected weight times 1.001.
#[test]
fn hanging_body_is_held_by_its_weight() {
    let built = build(
        r#"
[simulation]
h = 1e-2
t_end = 1.0

[[part]]
name = "weight"
type = "rigid_body"
m = 2.5
inertia = [0.1, 0.1, 0.05]
position = [0, 0, -0.4]

[[connection]]
type = "spherical"
name = "ball"
b = "weight"
origin_b = [0, 0, 0.4]

[record]
signals = ["ball.fx", "ball.fy", "ball.fz", "force(ball[2])"]
"#,
    );
    let weight = 2.5 * 9.81;
    for (t, row) in run(&built) {
        let expected = [0.0, 0.0, weight, weight];
        for (got, want) in row.iter().zip(expected) {
            assert!((got - want).abs() < ROUND_OFF * weight, "t = {t}: {row:?}");
        }
    }
}

const HEAD: &str = "[simulation]\nh = 0.01\nt_end = 1.0\n\n";
const BODY: &str =
    "[[part]]\nname = \"arm\"\ntype = \"rigid_body\"\nm = 1\ninertia = [0.1, 0.1, 0.1]\n";

/// Parse errors name the file, line and column of the key or value; build errors name the body
/// or joint (and where it is written).
#[test]
fn rigid_errors_name_the_place_and_the_item() {
    // An unknown key of a rigid body: line 10, column 1.
    let e = error(&format!("{HEAD}{BODY}inertial = 2\n"));
    assert!(
        e.to_string()
            .starts_with("bad.toml:10:1: unknown field `inertial`"),
        "{e}"
    );
    // A rotation that is not one: at the value, naming the part.
    let e = error(&format!(
        "{HEAD}{BODY}rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]\n"
    ));
    assert!(
        e.to_string().starts_with("bad.toml:10:12: part `arm`"),
        "{e}"
    );
    // Inertia with the mass on a line (J₃ = J₁ + J₂): at the inertia, naming the part.
    let e = error(&format!(
        "{HEAD}[[part]]\nname = \"rod\"\ntype = \"rigid_body\"\nm = 1\ninertia = [0.1, 0.1, 0.2]\n"
    ));
    assert!(
        e.to_string().starts_with("bad.toml:9:11: part `rod`") && e.to_string().contains("J_d"),
        "{e}"
    );
    // A joint whose body does not exist: at the body's name, naming it.
    let e = error(&format!(
        "{HEAD}{BODY}\n[[connection]]\ntype = \"revolute\"\nname = \"hinge\"\na = \"arm\"\nb = \"forearm\"\n"
    ));
    assert!(
        e.to_string().starts_with("bad.toml:15:5:") && e.to_string().contains("`forearm`"),
        "{e}"
    );
    // A joint to a part that is not a rigid body: naming the joint and the part.
    let e = error(&format!(
        "{HEAD}{BODY}\n[[part]]\nname = \"m\"\ntype = \"mass\"\nm = 1\n\n[[connection]]\ntype = \"spherical\"\nname = \"ball\"\na = \"arm\"\nb = \"m\"\n"
    ));
    assert!(
        e.to_string().starts_with("bad.toml:20:5:")
            && e.to_string().contains("`ball`")
            && e.to_string().contains("part `m` is not a rigid body"),
        "{e}"
    );
    // A joint coordinate of a spherical joint (it has none): naming the coupling.
    let e = error(&format!(
        "{HEAD}{BODY}\n[[part]]\nname = \"k\"\ntype = \"inertia\"\nj = 1\n\n[[connection]]\ntype = \"spherical\"\nname = \"ball\"\nb = \"arm\"\n\n[[connection]]\ntype = \"joint_coordinate\"\nname = \"drive\"\njoint = \"ball\"\nport = \"k.theta\"\n"
    ));
    assert!(
        e.to_string()
            .starts_with("bad.toml:21:1: connection `drive`"),
        "{e}"
    );
    // A joint signal the joint does not have: at the signal, listing what it offers.
    let e = error(&format!(
        "{HEAD}{BODY}\n[[connection]]\ntype = \"spherical\"\nname = \"ball\"\nb = \"arm\"\n\n[record]\nsignals = [\"ball.angle\"]\n"
    ));
    assert!(
        e.to_string().starts_with("bad.toml:17:12:") && e.to_string().contains("`fx`, `fy`, `fz`"),
        "{e}"
    );
    // `force(joint)` of a rigid joint points to its components.
    let e = error(&format!(
        "{HEAD}{BODY}\n[[connection]]\ntype = \"spherical\"\nname = \"ball\"\nb = \"arm\"\n\n[record]\nforces = [\"ball\"]\n"
    ));
    assert!(e.to_string().contains("`ball.fx`"), "{e}");
}

/// The bundled scene `name`, built.
fn bundled(name: &str) -> BuiltScene {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/scenes")
        .join(name);
    Scene::from_file(path)
        .and_then(|s| s.build())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The column of `built`'s signal named `signal` in `rows`.
fn column(built: &BuiltScene, rows: &[(f64, Vec<f64>)], signal: &str) -> Vec<f64> {
    let c = built
        .signals
        .iter()
        .position(|s| s.name == signal)
        .unwrap_or_else(|| panic!("no signal {signal}"));
    rows.iter().map(|(_, r)| r[c]).collect()
}

/// `max |x − x₀| / scale` over a column.
fn spread(x: &[f64], scale: f64) -> f64 {
    x.iter().map(|v| (v - x[0]).abs()).fold(0.0, f64::max) / scale
}

/// The bundled heavy top (`examples/scenes/heavy_top.toml`): the spin about the symmetry axis
/// (`top.w3`, conserved by the rotational symmetry of a symmetric top: Euler's third equation
/// reads `C Ω̇₃ = 0`) stays at its stated 40 rad/s, and the energy of the conservative top stays
/// in a small band.
///
/// Mutation seen to fail: `inertia = [0.02, 0.0202, 0.03]` in the scene (no symmetry) moves the
/// spin by 6.3e-6 relative.
#[test]
fn bundled_heavy_top_keeps_its_spin() {
    // Measured 1.0e-14 relative (round-off over 4000 steps).
    const SPIN: f64 = 1e-12;
    // Measured 8.2e-7 of the spin energy at h = 1e-3 (the O(h²) band of the trapezoid LGVI).
    const ENERGY: f64 = 1e-5;
    let built = bundled("heavy_top.toml");
    let rows = run(&built);
    let spin = column(&built, &rows, "top.w3");
    let energy = column(&built, &rows, "energy");
    let kinetic = 0.5 * 0.03 * 40.0 * 40.0;
    let (ds, de) = (spread(&spin, 40.0), spread(&energy, kinetic));
    println!("heavy top: spin {ds:.2e}, energy {de:.2e} (of the spin energy)");
    assert!((spin[0] - 40.0).abs() < SPIN * 40.0 && ds < SPIN && de < ENERGY);
}

/// The bundled spatial four-bar (`examples/scenes/four_bar.toml`), a closed loop: every step's
/// constraint residual (the loop closure among them) is round-off and the energy of the
/// conservative linkage stays in a small band; the linkage does move (the rocker swings).
///
/// Mutation seen to fail: the coupler 1 % longer in the scene (`origin_b` of `crank_pin` × 1.01)
/// is rejected at the start ("inconsistent initial condition: crank_pin[0] (Δx = 0) is violated
/// by -2.500e-4").
#[test]
fn bundled_four_bar_closes_its_loop() {
    // Newton's tolerance on the rows, lengths of order 0.1 (measured 1.8e-15).
    const CLOSURE: f64 = 1e-12;
    // Measured 3.3e-4 of the rocker's potential energy swing at h = 1e-3 (the O(h²) band).
    const ENERGY: f64 = 2e-3;
    let built = bundled("four_bar.toml");
    let rows = run(&built);
    let residual = column(&built, &rows, "constraint_residual");
    let energy = column(&built, &rows, "energy");
    let crank = column(&built, &rows, "rocker_pivot.angle");
    let z = column(&built, &rows, "rocker.z");
    let swing = 9.81 * 0.3 * spread(&z, 1.0);
    let worst = residual.iter().copied().fold(0.0, f64::max);
    let de = spread(&energy, swing);
    let turned = spread(&crank, 1.0);
    println!(
        "four-bar: residual {worst:.2e}, energy {de:.2e} of the rocker's swing {swing:.3e} J, rocker turned {turned:.3} rad"
    );
    assert!(worst < CLOSURE && de < ENERGY && turned > 0.1);
}

/// The bundled motor-driven arm (`examples/scenes/motor_arm.toml`) after 20 s: the motor turns at
/// its closed-form steady speed `ω_m = V k / (k² + R b)` (its torque balances its own friction;
/// the arm's relative equilibrium takes no power) and the column at `ratio · ω_m`, measured as the
/// angle advanced by the last step over `h` (the steady state is a fixed point of the discrete
/// equations). The rate recorded at `t_k`, `M.theta'`, is the `M`-orthogonal projection of the
/// discrete flow's central chord onto the constraints' tangent space (see
/// `recorded_rates_are_the_projected_central_chord`): every body point and every rotation entry
/// turns on a circle about the column's axis by `θ = ω h` per step, so its central chord is
/// `sin θ / θ` times its velocity, while the motor's own angle is flat and its chord exact. The
/// recorded rate is then below `ω_m` by `(1 − sin θ/θ)` times the bodies' share of the inertia
/// about the axis (column `J_zz`, the arm's `J` about the vertical and its orbital `m (d sin α*)²`,
/// against those plus the motor's `J_m/ratio²`): 1.9705e-4 at `θ = 0.0356`, α* = 62.2°.
///
/// Mutations seen to fail: the gear ratio written `1/0.8` in the column's closed form (error 0.36);
/// the arm's orbital term left out of the bodies' share (tests/mutations.md RB16: offset off by
/// 2.5e-5).
#[test]
fn bundled_motor_arm_reaches_the_motor_speed() {
    // Measured 1.6e-13 (motor) and 1.9e-14 (column) relative: round-off of angle differences
    // of size 0.04 on angles up to 220; the transient has decayed (e^{-t/τ}, τ < 1 s).
    const SPEED: f64 = 1e-10;
    // The recorded rate's offset against its prediction (measured 6.9e-10 of ω_m, 3.5e-6 of the
    // offset: α* is the continuous relative equilibrium, the discrete one differs by O(h²)).
    const READOUT: f64 = 1e-8;
    let built = bundled("motor_arm.toml");
    let h = built.h();
    let rows = run(&built);
    let omega_m = 6.0 * 0.5 / (0.5 * 0.5 + 1.0 * 0.02);
    let last = |signal: &str| {
        let x = column(&built, &rows, signal);
        let d = x[x.len() - 1] - x[x.len() - 2];
        // Angles in (−π, π]: unwrap the last step.
        (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
    };
    let em = (last("M.theta") / h / omega_m - 1.0).abs();
    let ec = (last("base.angle") / h / (0.8 * omega_m) - 1.0).abs();
    // Inertias about the column's axis: column 1 kg, 0.1 × 0.1 m; arm 0.5 kg, 0.4 × 0.03 × 0.03 m,
    // hinged at its end (d = 0.2) at the relative equilibrium α*; motor 1e-3 through the 0.8 gear.
    let omega = 0.8 * omega_m;
    let (m, len, t, d) = (0.5, 0.4, 0.03, 0.2);
    let (across, along) = (m * (len * len + t * t) / 12.0, m * (2.0 * t * t) / 12.0);
    let alpha = (m * 9.81 * d / (omega * omega * (across + m * d * d - along))).acos();
    let (s, c) = alpha.sin_cos();
    let bodies = 1.0 * (0.1 * 0.1 + 0.1 * 0.1) / 12.0
        + across * s * s
        + along * c * c
        + m * (d * s) * (d * s);
    let share = bodies / (bodies + 1e-3 / (0.8 * 0.8));
    let theta = omega * h;
    let predicted = (1.0 - theta.sin() / theta) * share;
    let rate = column(&built, &rows, "M.theta'");
    let er = 1.0 - rate[rate.len() - 1] / omega_m;
    println!(
        "motor arm: motor speed error {em:.2e}, column {ec:.2e}, recorded rate {er:.9e} below ω_m (predicted {predicted:.9e}, α* = {:.2}°)",
        alpha.to_degrees()
    );
    assert!(em < SPEED && ec < SPEED && (er - predicted).abs() < READOUT);
}

/// The bundled spatial chain (`examples/scenes/spatial_chain.toml`, five rods on spherical joints
/// released from a helical pose while turning about the vertical) is the mechanism
/// `SphericalChain::bundled(5)`: the same initial positions and rates. Through the run layer the
/// vertical angular momentum about the suspension point, `L_z = Σ m (x ẏ − y ẋ) + (R J Ω)_z`
/// from the recorded positions, rates and body angular velocities, is constant to round-off
/// (rotations about `z` are a symmetry of the discrete flow, and the rates read at `t_k` pair
/// with the momenta exactly as the discrete momentum map does); every joint row holds to
/// round-off and the energy stays in the O(h²) band.
///
/// Mutations seen to fail (tests/mutations.md RB9–RB12): the scene's gravity tilted by 1e-3 rad
/// (`gravity = [0.00981, 0, -9.81]` in every link: `L_z` changes by 5.6e-3); `J₂` in the
/// recorded `L_z` × 1.001 (1.4e-4); the mechanism's twist 1.0001 rad (start differs by 6.1e-4);
/// the scene at h = 4e-3 (energy band 5.9e-4).
#[test]
fn bundled_spatial_chain_keeps_its_vertical_momentum() {
    // Measured 6.0e-15 of L_z over 10⁴ steps (order-one products summed).
    const MOMENTUM: f64 = 1e-12;
    // Initial state against the mechanism: decimal round trips of the scene file (measured 0).
    const SAME_START: f64 = 1e-15;
    // Newton's tolerance on the rows, lengths of order 0.1 (measured 1.0e-14).
    const CLOSURE: f64 = 1e-12;
    // Measured 4.1e-5 of |E₀| = 14.84 J at h = 1e-3 (the O(h²) band, docs/rigid.md).
    const ENERGY: f64 = 5e-4;
    let mut built = bundled("spatial_chain.toml");
    let chain = dirac_rigid::mechanisms::SphericalChain::bundled(5);
    let mechanism = chain.build().expect("chain");
    let start = built
        .q0
        .iter()
        .chain(&built.v0)
        .flatten()
        .zip(mechanism.q0.iter().chain(&mechanism.v0).flatten())
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    let link = chain.link().expect("link");
    let j = link.inertia();
    let fields = ["x", "y", "x'", "y'", "r31", "r32", "r33", "w1", "w2", "w3"];
    let mut names = Vec::new();
    for i in 0..chain.links {
        for f in fields {
            let name = format!("link{i}.{f}");
            let signal = built.signal(&name).unwrap_or_else(|e| panic!("{e}"));
            built.signals.push(signal);
            names.push(name);
        }
    }
    let rows = run(&built);
    let columns: Vec<Vec<f64>> = names.iter().map(|n| column(&built, &rows, n)).collect();
    let lz: Vec<f64> = (0..rows.len())
        .map(|k| {
            (0..chain.links)
                .map(|i| {
                    let c = |f: usize| columns[i * fields.len() + f][k];
                    let orbital = chain.mass * (c(0) * c(3) - c(1) * c(2));
                    let spin: f64 = (0..3).map(|a| c(4 + a) * j[a][a] * c(7 + a)).sum();
                    orbital + spin
                })
                .sum()
        })
        .collect();
    let residual = column(&built, &rows, "constraint_residual");
    let energy = column(&built, &rows, "energy");
    let dl = spread(&lz, lz[0].abs());
    let worst = residual.iter().copied().fold(0.0, f64::max);
    let de = spread(&energy, energy[0].abs());
    println!(
        "spatial chain: start {start:.1e}, L_z0 = {:.6}, ΔL_z {dl:.2e}, residual {worst:.2e}, energy {de:.2e} of |E0| = {:.4} J",
        lz[0],
        energy[0].abs()
    );
    assert!(
        start <= SAME_START,
        "scene and mechanism differ by {start:e}"
    );
    assert!(dl < MOMENTUM && worst < CLOSURE && de < ENERGY);
}

/// The rotation matrix of row `k` from the recorded entries `r11 … r33` (columns `first..first+9`
/// in the order `r11, r12, r13, r21, …`).
fn recorded_rotation(row: &[f64], first: usize) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| row[first + 3 * i + j]))
}

/// Signals of a body's nine rotation entries, row by row (`r11, r12, r13, r21, …`).
fn rotation_signals(body: &str) -> String {
    (1..=3)
        .flat_map(|i| (1..=3).map(move |j| format!("\"{body}.r{i}{j}\"")))
        .collect::<Vec<_>>()
        .join(", ")
}

/// What a recorded angular velocity is, exactly. The trapezoid step's two discrete Legendre
/// transforms at `t_k` give `p_k = M v̄_k − (h/2) F_k + A(q_k)ᵀΛ_k` and `p_k = M v̄_{k−1} +
/// (h/2) F_k` (`v̄` the chords `(q_{k+1} − q_k)/h`; forces of `q_k` alone), so
/// `p_k = M (q_{k+1} − q_{k−1})/2h + A(q_k)ᵀΛ_k/2`: the readout at `t_k`, which solves
/// `M v = p_k + Aᵀγ` with `A v = 0`, is the `M`-orthogonal projection of the central chord of the
/// discrete flow onto the tangent space at `q_k`. For a free body's rotation that is
/// `Ω_k = J⁻¹ Π(R_k, C J_d)` with `C = (R_{k+1} − R_{k−1})/2h` and `Π(R, P)` the pairing of
/// `P` with the tangent vectors `R η̂` (docs/rigid.md, "Rates at t_k"). A tumbling asymmetric body
/// (no gravity, ωh ≈ 0.01) records `w1..w3` equal to this, computed from its recorded rotations,
/// to round-off at every row.
///
/// Measured 5.3e-14 rad/s (rates of order 10; differences of recorded rotations over 2h carry
/// 1e-16/2e-3 of round-off). Without torques the one-sided chords project to the same `Ω_k`
/// (their difference is normal to `SO(3)`), so the test does not tell them apart; it does tell
/// the exact relation from other second-order estimates.
///
/// Mutations seen to fail (tests/mutations.md RB13–RB14): the chord's metric `J_d` replaced by `J`
/// (error 30); the wider chord `(R_{k+2} − R_{k−2})/4h` (error 6.0e-4, an O(h²) estimate).
#[test]
fn recorded_rates_are_the_projected_central_chord() {
    const CHORD: f64 = 1e-12;
    let moments = [0.02, 0.035, 0.05];
    let h = 1e-3;
    let built = build(&format!(
        r#"
[simulation]
discretisation = "trapezoid"
h = {h}
t_end = 1.0

[[part]]
name = "body"
type = "rigid_body"
m = 1.0
inertia = [{}, {}, {}]
gravity = [0, 0, 0]
rotation = {{ axis = [1, 2, 2], angle = 0.7 }}
angular_velocity = [4.0, -9.0, 3.0]

[record]
signals = ["body.w1", "body.w2", "body.w3", {}]
"#,
        moments[0],
        moments[1],
        moments[2],
        rotation_signals("body")
    ));
    let rows = run(&built);
    let trace = moments.iter().sum::<f64>();
    let jd = moments.map(|j| 0.5 * trace - j);
    let mut worst = 0.0_f64;
    for k in 1..rows.len() - 1 {
        let (before, now, after) = (
            recorded_rotation(&rows[k - 1].1, 3),
            recorded_rotation(&rows[k].1, 3),
            recorded_rotation(&rows[k + 1].1, 3),
        );
        // A = R_kᵀ C J_d, Π = (A₃₂ − A₂₃, A₁₃ − A₃₁, A₂₁ − A₁₂), Ω = J⁻¹ Π.
        let a = |i: usize, j: usize| {
            (0..3)
                .map(|l| now[l][i] * (after[l][j] - before[l][j]) / (2.0 * h) * jd[j])
                .sum::<f64>()
        };
        let pi = [a(2, 1) - a(1, 2), a(0, 2) - a(2, 0), a(1, 0) - a(0, 1)];
        for c in 0..3 {
            worst = worst.max((rows[k].1[c] - pi[c] / moments[c]).abs());
        }
    }
    println!("tumbling body: recorded Ω against the projected central chord: {worst:.2e}");
    assert!(worst < CHORD, "{worst:e}");
}

/// A free body spun about a principal axis at the stated `ω₀` turns by the same angle `θ` every
/// step, with `h Π₃ = J₃ sin θ` (the discrete Legendre transform of the step, docs/math.md §10.2:
/// `h Π + (h²/2) M = vee(F J_d − J_d Fᵀ)` at `F = exp(θ ê₃)`, `M = 0`) and `Π₃ = J₃ ω₀` from the
/// initial state: so `θ = asin(h ω₀)`, not `h ω₀`. The recorded rate `w3` is `ω₀` at every row
/// (the projected central chord `sin θ / h`, see above), so it is below the flow's mean rate
/// `θ/h` by `asin(hω₀)/(hω₀) − 1 ≈ (ω₀h)²/6`: 2.67e-4 at `ω₀ h = 0.04`. Both hold to round-off.
///
/// Mutation seen to fail (tests/mutations.md RB15): the flow's angle expected to be `h ω₀` (the
/// step's mean rate equal to the recorded one): off by 1.07e-5 rad per step.
#[test]
fn principal_spin_turns_by_asin_of_the_recorded_rate() {
    // Measured 7.3e-16 rad per step and 2.1e-13 rad/s (round-off over 2000 steps).
    const ANGLE: f64 = 1e-13;
    const RATE: f64 = 1e-12;
    let (h, omega) = (1e-3, 40.0_f64);
    let built = build(&format!(
        r#"
[simulation]
discretisation = "trapezoid"
h = {h}
t_end = 2.0

[[part]]
name = "body"
type = "rigid_body"
m = 1.0
inertia = [0.02, 0.035, 0.05]
gravity = [0, 0, 0]
rotation = {{ axis = [1, 2, 2], angle = 0.7 }}
angular_velocity = [0.0, 0.0, {omega}]

[record]
signals = ["body.w3", {}]
"#,
        rotation_signals("body")
    ));
    let rows = run(&built);
    let theta = (h * omega).asin();
    let (mut angle, mut rate) = (0.0_f64, 0.0_f64);
    for k in 0..rows.len() - 1 {
        let (now, next) = (
            recorded_rotation(&rows[k].1, 1),
            recorded_rotation(&rows[k + 1].1, 1),
        );
        // F = R_kᵀ R_{k+1} = exp(φ ê₃): φ = atan2(F₂₁, F₁₁).
        let f = |i: usize, j: usize| (0..3).map(|l| now[l][i] * next[l][j]).sum::<f64>();
        angle = angle.max((f(1, 0).atan2(f(0, 0)) - theta).abs());
        rate = rate.max((rows[k].1[0] - omega).abs());
    }
    println!(
        "principal spin: step angle − asin(hω₀) {angle:.2e} rad (asin(hω₀) − hω₀ = {:.3e}), w3 − ω₀ {rate:.2e}; mean rate / recorded − 1 = {:.3e}",
        theta - h * omega,
        theta / (h * omega) - 1.0
    );
    assert!(angle < ANGLE && rate < RATE, "{angle:e} {rate:e}");
}
