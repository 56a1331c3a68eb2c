//! Equivalence preservation with rigid bodies.
//!
//! (1) A rigid body and the same body cut in two halves held together by a fixed joint have the
//! same discrete trajectory: the map `(x, R) ↦ (x + R c_A, R, x + R c_B, R)` is linear, so the
//! halves' discrete Lagrangians (with the parallel-axis second moments) sum exactly to the
//! whole's, and the fixed joint's constraint manifold is the image of the whole's configuration
//! space. The constrained discrete Euler–Lagrange equations on the two are therefore the same
//! equations (docs/math.md §10.3).
//!
//! (2) A spring between two bodies written as a potential in the Lagrangian (monolithic), on a
//! massless endpoint tied by a joint (constraint) or as equal and opposite forces (interaction
//! force) gives the same trajectory, because the discrete forces use the quadrature of `L_d`
//! (MATH §2, §5).

mod common;

use common::{Run, pivot_momentum, trapezoid, vec_diff};
use dirac_components::Spring;
use dirac_core::Discretisation;
use dirac_graph::{Interconnection, Representation};
use dirac_rigid::{Joint, JointFrame, JointKind, RigidBody, Side, so3};
use dirac_sim::IntegratorOptions;

/// Round-off allowance for positions and momenta of order one over the runs below (measured:
/// 1.1e-13 for the split body, 3e-14 for the spring).
const EQUIVALENT: f64 = 1e-12;

/// The whole body: a cuboid 0.4 × 0.2 × 0.1 of mass 2, pivoted at a corner, under gravity.
const SIDES: [f64; 3] = [0.4, 0.2, 0.1];
const PIVOT: [f64; 3] = [0.2, 0.1, 0.05];
const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];

fn pivot_joint(body: &str, at: [f64; 3]) -> Joint {
    Joint::new(
        JointKind::Spherical,
        Side::body(body, JointFrame::at(at)),
        Side::ground(JointFrame::at([0.0; 3])),
    )
}

/// Per step: the whole body's coordinates and its body angular momentum about the pivot.
type Trajectory = Vec<(Vec<f64>, [f64; 3])>;

/// Positions per step of the whole body, and its body angular momentum about the pivot.
fn whole(options: &IntegratorOptions, r0: &so3::Mat3, omega: [f64; 3], steps: usize) -> Trajectory {
    let body = RigidBody::cuboid(2.0, SIDES)
        .expect("body")
        .with_gravity(GRAVITY);
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("whole")).expect("unique");
    pivot_joint("whole", PIVOT)
        .connect(&mut g, "pivot")
        .expect("joint");
    let (q0, v0) = common::pivoted_state(r0, PIVOT, omega);
    let mut run = Run::new(
        &g,
        Representation::Monolithic,
        options.clone(),
        &[q0],
        &[v0],
    );
    let mut out = Vec::new();
    for _ in 0..steps {
        run.step();
        let q = run.body_q(0).to_vec();
        let pi = pivot_momentum(&q, run.body_p(0), PIVOT);
        out.push((q, pi));
    }
    out
}

/// The same body as two halves (x < 0 and x > 0, centres at ∓0.1 along x) joined by a fixed joint
/// at their interface; half A carries the pivot. Returns the whole body's coordinates
/// reconstructed from the halves (centre of mass, rotation of A) and the summed momentum about the
/// pivot, per step, and the largest difference of the halves' rotations.
fn split(
    options: &IntegratorOptions,
    r0: &so3::Mat3,
    omega: [f64; 3],
    steps: usize,
) -> (Trajectory, f64) {
    let half = RigidBody::cuboid(1.0, [0.2, 0.1 * 2.0, 0.1])
        .expect("half")
        .with_gravity(GRAVITY);
    let (ca, cb) = ([0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]);
    let mut g = Interconnection::new();
    g.add_subsystem(half.subsystem("A")).expect("unique");
    g.add_subsystem(half.subsystem("B")).expect("unique");
    let pa = [PIVOT[0] - ca[0], PIVOT[1] - ca[1], PIVOT[2] - ca[2]];
    pivot_joint("A", pa)
        .connect(&mut g, "pivot")
        .expect("joint");
    Joint::new(
        JointKind::Fixed,
        Side::body("A", JointFrame::at([-0.1, 0.0, 0.0])),
        Side::body("B", JointFrame::at([0.1, 0.0, 0.0])),
    )
    .connect(&mut g, "glue")
    .expect("joint");
    // The halves' states: rigidly attached to the whole's motion about the pivot.
    let part = |c: [f64; 3]| {
        let d = [c[0] - PIVOT[0], c[1] - PIVOT[1], c[2] - PIVOT[2]];
        let x = so3::apply(r0, &d);
        let xdot = so3::apply(r0, &so3::cross(&omega, &d));
        (
            RigidBody::coordinates(x, r0),
            RigidBody::rates(r0, xdot, omega),
        )
    };
    let ((qa, va), (qb, vb)) = (part(ca), part(cb));
    let mut run = Run::new(
        &g,
        Representation::Monolithic,
        options.clone(),
        &[qa, qb],
        &[va, vb],
    );
    let (mut out, mut twist) = (Vec::new(), 0.0_f64);
    for _ in 0..steps {
        run.step();
        let (qa, qb) = (run.body_q(0).to_vec(), run.body_q(1).to_vec());
        let r = RigidBody::rotation(&qa);
        twist = twist.max(common::mat_diff(&r, &RigidBody::rotation(&qb)));
        let mut q = qa.clone();
        for i in 0..3 {
            q[i] = 0.5 * (qa[i] + qb[i]);
        }
        let mut pi = [0.0; 3];
        for (s, c) in [(0, ca), (1, cb)] {
            let (qs, ps) = (run.body_q(s), run.body_p(s));
            let d = [c[0] - PIVOT[0], c[1] - PIVOT[1], c[2] - PIVOT[2]];
            let px = so3::apply(
                &so3::transpose(&RigidBody::rotation(qs)),
                &[ps[0], ps[1], ps[2]],
            );
            let orbital = so3::cross(&d, &px);
            let spin = RigidBody::body_angular_momentum(qs, ps);
            for i in 0..3 {
                pi[i] += spin[i] + orbital[i];
            }
        }
        out.push((q, pi));
    }
    (out, twist)
}

/// A heavy cuboid on a pivot (h = 0.01, 500 steps) against the same cuboid cut in two and glued
/// by a fixed joint: centre of mass, rotation and the momentum about the pivot agree to
/// round-off, for the trapezoid rule (the LGVI) and for the midpoint rule.
///
/// Mutations seen to fail: half A's length given as the whole's 0.4 (wrong second moments:
/// positions differ by 2.0); the glue joint's point 1 mm off (the initial state is refused:
/// `glue (Δx = 0)` residual 7.8e-4).
#[test]
fn body_split_by_a_fixed_joint_moves_as_the_whole() {
    let r0 = so3::from_axis_angle([0.3, 1.0, 0.2], 0.7);
    let omega = [1.0, -2.0, 3.0];
    for options in [
        trapezoid(0.01),
        IntegratorOptions::new(Discretisation::midpoint(), 0.01),
    ] {
        let a = whole(&options, &r0, omega, 500);
        let (b, twist) = split(&options, &r0, omega, 500);
        let (mut dq, mut dp) = (0.0_f64, 0.0_f64);
        for ((qa, pa), (qb, pb)) in a.iter().zip(&b) {
            dq = dq.max(vec_diff(qa, qb));
            dp = dp.max(vec_diff(pa, pb));
        }
        println!(
            "{}: positions {dq:.2e}, momentum about the pivot {dp:.2e}, halves' rotations differ by {twist:.2e}",
            options.discretisation
        );
        assert!(dq <= EQUIVALENT && dp <= EQUIVALENT && twist <= EQUIVALENT);
    }
}

/// Two bodies hanging from spherical joints, joined by a zero-rest-length 3D spring between body
/// points (three scalar springs on the points' `x`, `y`, `z` ports), under gravity: the
/// monolithic, constraint and interaction-force representations agree to round-off (h = 0.01,
/// 250 trapezoid steps). The motion is chaotic: the round-off difference grows about tenfold per
/// second (2.8e-14 after 200 steps, 1e-11 after 500), so the run stops at 2.5 s.
///
/// Mutation seen to fail: forces by the midpoint rule while `L_d` keeps the trapezoid
/// (`Discretisation::non_equivalence_preserving`): the force representation's positions deviate
/// by 0.98 (the constraint representation, whose spring stays a potential, still agrees).
#[test]
fn spring_as_potential_or_interaction_force_gives_the_same_motion() {
    let body = RigidBody::cuboid(1.0, [0.3, 0.2, 0.1])
        .expect("body")
        .with_gravity(GRAVITY)
        .with_point("tip", [0.15, 0.0, 0.0]);
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("A")).expect("unique");
    g.add_subsystem(body.subsystem("B")).expect("unique");
    let hang = |name: &str, at: [f64; 3]| {
        Joint::new(
            JointKind::Spherical,
            Side::body(name, JointFrame::at([-0.15, 0.0, 0.0])),
            Side::ground(JointFrame::at(at)),
        )
    };
    hang("A", [0.0, 0.0, 0.0])
        .connect(&mut g, "hinge A")
        .expect("joint");
    hang("B", [0.5, 0.1, 0.0])
        .connect(&mut g, "hinge B")
        .expect("joint");
    for axis in ["x", "y", "z"] {
        let a = g.port("A", &format!("tip.{axis}")).expect("port");
        let b = g.port("B", &format!("tip.{axis}")).expect("port");
        g.coupling(
            format!("spring {axis}"),
            a,
            b,
            Spring::linear(40.0).expect("spring"),
        );
    }
    let state = |anchor: [f64; 3], r: so3::Mat3, omega: [f64; 3]| {
        let pivot = [-0.15, 0.0, 0.0];
        let (mut q, mut v) = common::pivoted_state(&r, pivot, omega);
        for i in 0..3 {
            q[i] += anchor[i];
        }
        v.truncate(12);
        (q, v)
    };
    // Hanging (body x axis down), slightly turned, slowly moving.
    let down = so3::from_axis_angle([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2);
    let (qa, va) = state(
        [0.0; 3],
        so3::mul(&so3::from_axis_angle([1.0, 0.0, 0.0], 0.1), &down),
        [0.0, 0.3, 0.2],
    );
    let (qb, vb) = state(
        [0.5, 0.1, 0.0],
        so3::mul(&so3::from_axis_angle([0.0, 1.0, 1.0], 0.1), &down),
        [0.1, 0.0, -0.3],
    );
    let run = |rep| {
        let mut run = Run::new(
            &g,
            rep,
            trapezoid(0.01),
            &[qa.clone(), qb.clone()],
            &[va.clone(), vb.clone()],
        );
        let mut out = Vec::new();
        for _ in 0..250 {
            run.step();
            let q = run
                .system()
                .subsystem_positions(run.integrator().q())
                .to_vec();
            let p = run.system().subsystem_momenta(run.integrator().p());
            // Momenta compared through their body-momentum pairing (constraint impulses of the
            // endpoint joints differ between representations).
            let mut pairing = Vec::new();
            for s in 0..2 {
                let (qs, ps) = (&q[12 * s..12 * s + 12], &p[12 * s..12 * s + 12]);
                pairing.extend(pivot_momentum(qs, ps, [-0.15, 0.0, 0.0]));
            }
            out.push((q, pairing));
        }
        out
    };
    let mono = run(Representation::Monolithic);
    for rep in [Representation::Constraint, Representation::InteractionForce] {
        let other = run(rep);
        let (mut dq, mut dp) = (0.0_f64, 0.0_f64);
        for ((qa, pa), (qb, pb)) in mono.iter().zip(&other) {
            dq = dq.max(vec_diff(qa, qb));
            dp = dp.max(vec_diff(pa, pb));
        }
        println!("{rep}: positions {dq:.2e}, momenta {dp:.2e}");
        assert!(dq <= EQUIVALENT && dp <= EQUIVALENT, "{rep}: {dq:e} {dp:e}");
    }
}
