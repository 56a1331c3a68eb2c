//! Each joint kind allows exactly its motion.
//!
//! Revolute: a compound pendulum swings with the elliptic-integral period
//! `T = 4 K(sin²(θ₀/2)) √(I_p / (m g ℓ))`. Prismatic: a block sliding on a tilted rail under
//! gravity follows `s = ½ (g·e) t²` exactly (the trapezoid rule integrates constant acceleration
//! exactly) and does not turn. Cylindrical: the same slide while spinning at a constant rate.
//! Universal: two shafts at an angle β joined by a Hooke joint obey `tan φ_B = tan φ_A / cos β`,
//! and their mean rates over a step approach `ω_B/ω_A = cos β / (1 − sin²β cos²φ_A)`. Planar: a
//! puck on a plane moves uniformly (exactly) and spins uniformly. A planar four-bar (a closed
//! loop whose three out-of-plane rows are redundant and dropped at the start) keeps Freudenstein's
//! closure equation.

mod common;

use common::{Run, elliptic_k, norm, trapezoid, upward_crossings};
use dirac_graph::{Interconnection, Representation};
use dirac_rigid::{Joint, JointFrame, JointKind, RigidBody, Side, so3};

const G: f64 = 9.81;
const GRAVITY: [f64; 3] = [0.0, 0.0, -G];

/// A compound pendulum (a 0.1 × 0.6 × 0.05 plate hanging from an axis through one end, along
/// the world y axis) released from 1 rad: the period from upward zero crossings of the joint
/// angle, for h = 4e-3 and 2e-3.
fn pendulum_period(h: f64) -> (f64, f64) {
    let (m, sides) = (0.8, [0.1, 0.05, 0.6]);
    let body = RigidBody::cuboid(m, sides)
        .expect("body")
        .with_gravity(GRAVITY);
    let ell = 0.5 * sides[2];
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("plate")).expect("unique");
    let axis = [0.0, 1.0, 0.0];
    let joint = Joint::new(
        JointKind::Revolute,
        Side::ground(JointFrame::with_axis([0.0; 3], axis)),
        Side::body("plate", JointFrame::with_axis([0.0, 0.0, ell], axis)),
    );
    joint.connect(&mut g, "hinge").expect("joint");
    let theta0 = 1.0_f64;
    let r0 = so3::from_axis_angle(axis, theta0);
    let x0 = so3::apply(&r0, &[0.0, 0.0, -ell]);
    let q0 = RigidBody::coordinates(x0, &r0);
    let mut run = Run::new(
        &g,
        Representation::Monolithic,
        trapezoid(h),
        &[q0],
        &[vec![0.0; 12]],
    );
    let steps = (6.0 / h) as usize;
    let mut angle = Vec::with_capacity(steps);
    for _ in 0..steps {
        angle.push(
            joint
                .coordinate(&[], run.body_q(0))
                .expect("revolute angle"),
        );
        run.step();
    }
    let c = upward_crossings(&angle, h);
    let measured = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    let ip = m * (sides[0] * sides[0] + sides[2] * sides[2]) / 12.0 + m * ell * ell;
    let exact = 4.0 * elliptic_k((0.5 * theta0).sin().powi(2)) * (ip / (m * G * ell)).sqrt();
    (measured, exact)
}

/// Relative period error at h = 2e-3 (measured 9.0e-6) and the error ratio for halved h (order
/// 2; measured 4.00).
const PERIOD_ERROR: f64 = 1e-4;
const RATIO: std::ops::RangeInclusive<f64> = 3.6..=4.4;

/// Mutation seen to fail: `I_p` computed with the plate's thickness instead of its width (error
/// 2.6e-3 at both steps, ratio 0.99).
#[test]
fn revolute_pendulum_has_the_elliptic_period() {
    let (coarse, exact) = pendulum_period(4e-3);
    let (fine, _) = pendulum_period(2e-3);
    let (e1, e2) = (
        ((coarse - exact) / exact).abs(),
        ((fine - exact) / exact).abs(),
    );
    println!(
        "pendulum period {fine:.9} s (exact {exact:.9}): errors {e1:.2e}, {e2:.2e}, ratio {:.2}",
        e1 / e2
    );
    assert!(e2 <= PERIOD_ERROR, "period error {e2:e}");
    assert!(RATIO.contains(&(e1 / e2)), "not order 2: {e1:e} {e2:e}");
}

/// A slider on a rail along `axis` through the origin, optionally spinning about it: returns the
/// run and the joint.
fn slider(kind: JointKind, axis: [f64; 3], spin: f64) -> (Run, Joint) {
    let body = RigidBody::principal(2.0, [0.02, 0.03, 0.04])
        .expect("body")
        .with_gravity(GRAVITY);
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("block")).expect("unique");
    let frame = JointFrame::with_axis([0.0; 3], axis);
    let joint = Joint::new(kind, Side::ground(frame), Side::body("block", frame));
    joint.connect(&mut g, "rail").expect("joint");
    let r0 = so3::IDENTITY;
    let omega = so3::apply(&so3::transpose(&r0), &axis.map(|c| c * spin / norm(&axis)));
    let q0 = RigidBody::coordinates([0.0; 3], &r0);
    let v0 = RigidBody::rates(&r0, [0.0; 3], omega);
    (
        Run::new(
            &g,
            Representation::Monolithic,
            trapezoid(0.01),
            &[q0],
            &[v0],
        ),
        joint,
    )
}

/// Round-off allowance for the exact motions, relative to the distance travelled (the slide
/// reaches 347 m; measured 1.3e-14 relative for the slide, 0 for the rotation).
const EXACT: f64 = 1e-13;

/// Prismatic rail tilted 45° below the horizontal, 1000 steps of 0.01: `s_k = ½ a t_k²` with
/// `a = g sin 45°`, the block never turns, and it stays on the rail.
///
/// Mutation seen to fail: the rail's second row written `Δ·z_A = 0` instead of `Δ·y_A = 0` (the
/// block can then only move along `y_A` and never slides): slide error 3.5e2.
#[test]
fn prismatic_slide_is_exact() {
    let axis = [1.0, 0.0, -1.0];
    let (mut run, joint) = slider(JointKind::Prismatic, axis, 0.0);
    let a = G / 2f64.sqrt();
    let (mut slide, mut turn, mut off) = (0.0_f64, 0.0_f64, 0.0_f64);
    for k in 1..=1000 {
        run.step();
        let q = run.body_q(0);
        let t = k as f64 * 0.01;
        let s = joint.coordinate(&[], q).expect("slide");
        slide = slide.max((s - 0.5 * a * t * t).abs() / (1.0 + s.abs()));
        turn = turn.max(common::mat_diff(&RigidBody::rotation(q), &so3::IDENTITY));
        let u = axis.map(|c| c / norm(&axis));
        let along = so3::dot(&[q[0], q[1], q[2]], &u);
        let gap = [
            q[0] - along * u[0],
            q[1] - along * u[1],
            q[2] - along * u[2],
        ];
        off = off.max(norm(&gap) / (1.0 + along.abs()));
    }
    println!("prismatic: slide error {slide:.2e}, rotation {turn:.2e}, off the rail {off:.2e}");
    assert!(slide <= EXACT && turn <= EXACT && off <= EXACT);
}

/// Cylindrical joint along the same tilted rail with a 5 rad/s spin about it: the slide is the
/// same exact parabola, and the spin is uniform (equal angle increments to round-off).
///
/// Mutation seen to fail: a prismatic joint instead (the initial velocity is projected onto the
/// joint's motions, the spin disappears: increment 3.5e-4 rad, unevenness 0.69).
#[test]
fn cylindrical_slides_and_spins() {
    let axis = [1.0, 0.0, -1.0];
    let (mut run, joint) = slider(JointKind::Cylindrical, axis, 5.0);
    let a = G / 2f64.sqrt();
    let (mut slide, mut uneven) = (0.0_f64, 0.0_f64);
    let mut last = 0.0;
    let mut first_increment = None;
    let u = axis.map(|c| c / norm(&axis));
    for k in 1..=1000 {
        run.step();
        let q = run.body_q(0);
        let t = k as f64 * 0.01;
        let s = so3::dot(&[q[0], q[1], q[2]], &u);
        slide = slide.max((s - 0.5 * a * t * t).abs() / (1.0 + s.abs()));
        let phi = joint.coordinate(&[], q).expect("angle");
        let mut d = phi - last;
        if d < -std::f64::consts::PI {
            d += 2.0 * std::f64::consts::PI;
        }
        last = phi;
        let first = *first_increment.get_or_insert(d);
        uneven = uneven.max((d - first).abs());
    }
    let step_angle = first_increment.unwrap_or(0.0);
    println!(
        "cylindrical: slide error {slide:.2e}, spin increment {step_angle:.6} rad, unevenness {uneven:.2e}"
    );
    assert!(slide <= EXACT && uneven <= EXACT);
    assert!((step_angle - 0.05).abs() < 1e-3, "spin {step_angle}");
}

/// A puck (a flat cylinder-like box) on the horizontal plane z = 0, sliding at (0.3, −0.2) m/s
/// and spinning at 2 rad/s, 1000 steps: the translation is exact, the spin uniform, the puck
/// stays flat on the plane.
///
/// Mutation seen to fail: the plane's point row written `Δ·x_A = 0` instead of `Δ·z_A = 0` (the
/// puck then falls through the table along z): translation error 98.
#[test]
fn planar_motion_is_uniform() {
    let body = RigidBody::principal(0.5, [0.01, 0.01, 0.018])
        .expect("body")
        .with_gravity(GRAVITY);
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("puck")).expect("unique");
    let joint = Joint::new(
        JointKind::Planar,
        Side::ground(JointFrame::at([0.0; 3])),
        Side::body("puck", JointFrame::at([0.0, 0.0, -0.02])),
    );
    joint.connect(&mut g, "table").expect("joint");
    let q0 = RigidBody::coordinates([0.0, 0.0, 0.02], &so3::IDENTITY);
    let v0 = RigidBody::rates(&so3::IDENTITY, [0.3, -0.2, 0.0], [0.0, 0.0, 2.0]);
    let mut run = Run::new(
        &g,
        Representation::Monolithic,
        trapezoid(0.01),
        &[q0],
        &[v0],
    );
    let (mut drift, mut tilt, mut uneven) = (0.0_f64, 0.0_f64, 0.0_f64);
    let (mut last, mut first) = (0.0, None);
    for k in 1..=1000 {
        run.step();
        let q = run.body_q(0);
        let t = k as f64 * 0.01;
        drift = drift.max(norm(&[q[0] - 0.3 * t, q[1] + 0.2 * t, q[2] - 0.02]) / (1.0 + 0.4 * t));
        let r = RigidBody::rotation(q);
        tilt = tilt.max(r[2][0].abs().max(r[2][1].abs()));
        let phi = joint.coordinate(&[], q).expect("angle");
        let mut d = phi - last;
        if d < -std::f64::consts::PI {
            d += 2.0 * std::f64::consts::PI;
        }
        last = phi;
        uneven = uneven.max((d - *first.get_or_insert(d)).abs());
    }
    println!(
        "planar: translation error {drift:.2e}, tilt {tilt:.2e}, spin unevenness {uneven:.2e}"
    );
    assert!(drift <= EXACT && tilt <= EXACT && uneven <= EXACT);
}

/// Two shafts: A turns about the x axis, B about `u = (cos β, sin β, 0)`, both on revolute joints
/// at the origin, joined there by a universal joint whose cross arms are A's `y` and B's `z` axes
/// (at rest). The three point rows of the universal joint repeat the revolutes' and are dropped
/// at the start (a closed loop).
fn cardan(beta: f64, spin: f64, h: f64) -> (Run, Vec<String>) {
    let shaft = RigidBody::principal(1.0, [0.5, 0.3, 0.3]).expect("body");
    let mut g = Interconnection::new();
    g.add_subsystem(shaft.subsystem("A")).expect("unique");
    g.add_subsystem(shaft.subsystem("B")).expect("unique");
    let u = [beta.cos(), beta.sin(), 0.0];
    let a_com = [-0.5, 0.0, 0.0];
    let b_com = u.map(|c| 0.5 * c);
    let hinge = |body: &str, com: [f64; 3], axis: [f64; 3]| {
        let at = com.map(|c| -c);
        Joint::new(
            JointKind::Revolute,
            Side::ground(JointFrame::with_axis([0.0; 3], axis)),
            Side::body(body, JointFrame::with_axis(at, axis)),
        )
    };
    hinge("A", a_com, [1.0, 0.0, 0.0])
        .connect(&mut g, "bearing A")
        .expect("joint");
    hinge("B", b_com, u)
        .connect(&mut g, "bearing B")
        .expect("joint");
    // Cross frames: A's x axis along e_y; B's y axis along e_z (z along u).
    let frame_a = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let x_b = so3::cross(&[0.0, 0.0, 1.0], &u);
    let frame_b = [
        [x_b[0], 0.0, u[0]],
        [x_b[1], 0.0, u[1]],
        [x_b[2], 1.0, u[2]],
    ];
    Joint::new(
        JointKind::Universal,
        Side::body("A", JointFrame::new(a_com.map(|c| -c), frame_a)),
        Side::body("B", JointFrame::new(b_com.map(|c| -c), frame_b)),
    )
    .connect(&mut g, "cross")
    .expect("joint");
    // At φ_A = 0 the output turns at ω_B = ω_A / cos β.
    let qa = RigidBody::coordinates(a_com, &so3::IDENTITY);
    let qb = RigidBody::coordinates(b_com, &so3::IDENTITY);
    let va = RigidBody::rates(&so3::IDENTITY, [0.0; 3], [spin, 0.0, 0.0]);
    let vb = RigidBody::rates(&so3::IDENTITY, [0.0; 3], u.map(|c| c * spin / beta.cos()));
    let run = Run::new(
        &g,
        Representation::Monolithic,
        trapezoid(h),
        &[qa, qb],
        &[va, vb],
    );
    let warnings = run.integrator().warnings().to_vec();
    (run, warnings)
}

/// Shaft angles `(φ_A, φ_B)` (unwrapped by the caller) from the rotations.
fn shaft_angles(run: &Run, beta: f64) -> (f64, f64) {
    let (ra, rb) = (
        RigidBody::rotation(run.body_q(0)),
        RigidBody::rotation(run.body_q(1)),
    );
    let phi_a = ra[2][1].atan2(ra[1][1]);
    let side = [beta.sin(), -beta.cos(), 0.0];
    let b = [rb[0][2], rb[1][2], rb[2][2]];
    (phi_a, so3::dot(&b, &side).atan2(b[2]))
}

/// Hooke joint at β = 0.5 rad, input at 3 rad/s, 2000 steps of 1e-3: the angles satisfy
/// `sin φ_A cos φ_B = cos β cos φ_A sin φ_B` to round-off, and the mean rates over each step
/// approach `ω_B/ω_A = cos β/(1 − sin²β cos²φ_A)` (at the step's mean input angle) at order 2.
///
/// Mutation seen to fail: the cross row written `x_A·x_B = 0`: the initial state is refused
/// (`cross (x_a·y_b = 0)` residual 0.88 = cos β).
#[test]
fn universal_joint_is_a_hooke_joint() {
    let beta = 0.5_f64;
    let mut ratio_errors = Vec::new();
    for h in [2e-3, 1e-3] {
        let (mut run, warnings) = cardan(beta, 3.0, h);
        assert_eq!(
            warnings.len(),
            3,
            "the cross's point rows repeat the bearings': {warnings:?}"
        );
        let (mut closure, mut ratio) = (0.0_f64, 0.0_f64);
        let (mut last_a, mut last_b) = shaft_angles(&run, beta);
        for _ in 0..(2.0 / h) as usize {
            run.step();
            let (pa, pb) = shaft_angles(&run, beta);
            closure = closure.max((pa.sin() * pb.cos() - beta.cos() * pa.cos() * pb.sin()).abs());
            let wrap = |d: f64| {
                (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI
            };
            let (da, db) = (wrap(pa - last_a), wrap(pb - last_b));
            let mid = last_a + 0.5 * da;
            let expected = beta.cos() / (1.0 - beta.sin().powi(2) * mid.cos().powi(2));
            ratio = ratio.max((db / da - expected).abs());
            (last_a, last_b) = (pa, pb);
        }
        println!("Hooke joint, h = {h:e}: closure {closure:.2e}, rate-ratio error {ratio:.2e}");
        assert!(closure <= CLOSURE, "closure {closure:e}");
        ratio_errors.push(ratio);
    }
    let r = ratio_errors[0] / ratio_errors[1];
    assert!(
        ratio_errors[1] <= RATE_RATIO && RATIO.contains(&r),
        "{ratio_errors:?}"
    );
}

/// Largest error of the step's rate ratio at h = 1e-3 (the mean rates over a step differ from the
/// instantaneous ratio at the mean angle by O(h²); measured 2.6e-7).
const RATE_RATIO: f64 = 1e-5;

/// Loop-closure equations in angles, to round-off (measured 5e-16 and 4e-15).
const CLOSURE: f64 = 1e-13;

/// The planar angle of a body's `x` axis in the x–z plane, turning about +y.
fn plane_angle(q: &[f64]) -> f64 {
    let r = RigidBody::rotation(q);
    (-r[2][0]).atan2(r[0][0])
}

/// A crank–rocker four-bar in the x–z plane (ground 0.4, crank 0.1, coupler 0.35, rocker 0.25;
/// revolute axes along y), released from rest under gravity at crank angle 1 rad, 5000 steps of
/// 1e-3: the three out-of-plane rows of the loop are dropped as redundant at the start (the
/// motion stays planar, so they stay redundant), and Freudenstein's equation
/// `K₁ cos θ₄ − K₂ cos θ₂ + K₃ = cos(θ₂ − θ₄)` holds to round-off throughout.
///
/// Mutation seen to fail: the rocker's ground pivot 1 mm off in the joint (the start is refused:
/// `rocker pivot (Δx = 0)` residual 1.0e-3).
#[test]
fn four_bar_keeps_freudenstein_closure() {
    let (d, a, b, c) = (0.4_f64, 0.1_f64, 0.35_f64, 0.25_f64);
    let theta2 = 1.0_f64;
    // Rocker angle from the circle intersection (the open branch).
    let pa = [a * theta2.cos(), a * theta2.sin()];
    let (dx, dz) = (d - pa[0], -pa[1]);
    let l = (dx * dx + dz * dz).sqrt();
    let gamma = ((c * c + l * l - b * b) / (2.0 * c * l)).acos();
    let theta4 = dz.atan2(dx) + std::f64::consts::PI - gamma;
    let pb = [d + c * theta4.cos(), c * theta4.sin()];
    let theta3 = (pb[1] - pa[1]).atan2(pb[0] - pa[0]);
    let y = [0.0, 1.0, 0.0];
    let link = |len: f64| {
        RigidBody::cuboid(0.2 * len, [len, 0.02, 0.02])
            .expect("link")
            .with_gravity(GRAVITY)
    };
    let mut g = Interconnection::new();
    for (name, len) in [("crank", a), ("coupler", b), ("rocker", c)] {
        g.add_subsystem(link(len).subsystem(name)).expect("unique");
    }
    let pin = |sa: Side, sb: Side| Joint::new(JointKind::Revolute, sa, sb);
    let at = |p: [f64; 3]| JointFrame::with_axis(p, y);
    let joints = [
        (
            "crank pivot",
            pin(
                Side::ground(at([0.0; 3])),
                Side::body("crank", at([-a / 2.0, 0.0, 0.0])),
            ),
        ),
        (
            "crank pin",
            pin(
                Side::body("crank", at([a / 2.0, 0.0, 0.0])),
                Side::body("coupler", at([-b / 2.0, 0.0, 0.0])),
            ),
        ),
        (
            "rocker pin",
            pin(
                Side::body("coupler", at([b / 2.0, 0.0, 0.0])),
                Side::body("rocker", at([c / 2.0, 0.0, 0.0])),
            ),
        ),
        (
            "rocker pivot",
            pin(
                Side::ground(at([d, 0.0, 0.0])),
                Side::body("rocker", at([-c / 2.0, 0.0, 0.0])),
            ),
        ),
    ];
    for (name, joint) in &joints {
        joint.connect(&mut g, name).expect("joint");
    }
    let place = |from: [f64; 2], theta: f64, len: f64| {
        let r = so3::from_axis_angle(y, theta);
        let mid = [
            from[0] + 0.5 * len * theta.cos(),
            0.0,
            -(from[1] + 0.5 * len * theta.sin()),
        ];
        RigidBody::coordinates(mid, &r)
    };
    let q0 = vec![
        place([0.0, 0.0], theta2, a),
        place(pa, theta3, b),
        place([d, 0.0], theta4, c),
    ];
    let mut run = Run::new(
        &g,
        Representation::Monolithic,
        trapezoid(1e-3),
        &q0,
        &vec![vec![0.0; 12]; 3],
    );
    let warnings = run.integrator().warnings().to_vec();
    println!("{warnings:?}");
    assert_eq!(warnings.len(), 3, "{warnings:?}");
    let (k1, k2, k3) = (
        d / a,
        d / c,
        (a * a - b * b + c * c + d * d) / (2.0 * a * c),
    );
    let (mut closure, mut travel) = (0.0_f64, 0.0_f64);
    for _ in 0..5000 {
        run.step();
        let (t2, t4) = (plane_angle(run.body_q(0)), plane_angle(run.body_q(2)));
        closure = closure.max((k1 * t4.cos() - k2 * t2.cos() + k3 - (t2 - t4).cos()).abs());
        travel = travel.max((t2 - theta2).abs());
    }
    println!("four-bar: Freudenstein closure {closure:.2e}, crank swing {travel:.2} rad");
    assert!(closure <= CLOSURE, "closure {closure:e}");
    assert!(
        travel > 0.5,
        "the linkage should swing under gravity: {travel}"
    );
}
