//! The embedded step is the Lie group variational integrator.
//!
//! With a linear path and the trapezoid rule, the forced discrete Dirac step of a rigid body in
//! `ℝ¹²` (with `RᵀR = I` as holonomic constraints) has the discrete Lagrangian
//! `(1/h) tr((I − R_kᵀR_{k+1}) J_d) − (h/2)(U_k + U_{k+1})` on `SO(3)`, and its constraint forces
//! are normal to `SO(3)`, so its positions solve the LGVI equations of Lee, Leok & McClamroch
//! (docs/math.md §10). These tests run an independently coded LGVI on `SO(3)` (Newton on the Cayley
//! parameters, `tests/common`) beside the embedded integrator: each step of the embedded
//! integrator is compared with the LGVI step from the same `(R_k, Π_k)`, so the comparison is of
//! the two step maps (a trajectory comparison would add the chaotic growth of round-off).

mod common;

use common::{
    Lgvi, Run, heavy_top, mat_diff, norm, pivot_momentum, pivoted_state, trapezoid, vec_diff,
};
use dirac_graph::{Interconnection, Representation};
use dirac_rigid::RigidBody;
use dirac_rigid::so3::{self, Mat3};

/// Round-off allowance of one step for `R` (entries of order 1) and for `Π` relative to `|Π|`:
/// both Newton solves stop at round-off, and the two maps evaluate different formulas.
const SAME_R: f64 = 1e-14;
const SAME_PI: f64 = 1e-14;

/// Steps `run` `steps` times and compares each step with the LGVI step from the same state:
/// the largest `|ΔR|` and `|ΔΠ|/scale`.
fn compare_maps(
    run: &mut Run,
    lgvi: &Lgvi,
    steps: usize,
    state: impl Fn(&Run) -> (Mat3, [f64; 3]),
    scale: f64,
) -> (f64, f64) {
    let (mut worst_r, mut worst_pi) = (0.0_f64, 0.0_f64);
    for _ in 0..steps {
        let (r, pi) = state(run);
        let (r1, pi1) = lgvi.step(&r, &pi);
        run.step();
        let (s1, sigma1) = state(run);
        worst_r = worst_r.max(mat_diff(&s1, &r1));
        worst_pi = worst_pi.max(vec_diff(&sigma1, &pi1) / scale);
    }
    (worst_r, worst_pi)
}

/// A free asymmetric body (J = diag(1, 2, 2.5), tumbling about all three axes), h = 0.05,
/// 400 steps: the embedded trapezoid step and the LGVI agree to round-off in `R_k` and `Π_k`.
///
/// Mutations seen to fail: the body's `J_d` built as `tr(J) I − J` (missing ½): one-step `|ΔR|`
/// 0.43; the reference's Newton stopped after one iteration: `|ΔR|` 5e-7.
#[test]
fn free_body_matches_the_lgvi() {
    let body = RigidBody::principal(2.0, [1.0, 2.0, 2.5]).expect("body");
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("b")).expect("unique");
    let r0 = so3::from_axis_angle([1.0, 2.0, -0.5], 0.7);
    let omega = [1.2, -0.4, 2.1];
    let q0 = RigidBody::coordinates([0.1, 0.2, 0.3], &r0);
    let v0 = RigidBody::rates(&r0, [0.5, 0.0, -0.2], omega);
    let h = 0.05;
    let mut run = Run::new(&g, Representation::Monolithic, trapezoid(h), &[q0], &[v0]);
    let lgvi = Lgvi::new(&body, [0.0; 3], h);
    let pi0 = so3::apply(body.inertia(), &omega);
    let state = |run: &Run| {
        let q = run.body_q(0);
        let pi = RigidBody::body_angular_momentum(q, run.body_p(0));
        (RigidBody::rotation(q), pi)
    };
    let (worst_r, worst_pi) = compare_maps(&mut run, &lgvi, 400, state, norm(&pi0));
    println!("free body: one-step max |ΔR| = {worst_r:.2e}, max |ΔΠ|/|Π| = {worst_pi:.2e}");
    assert!(worst_r <= SAME_R, "R deviates by {worst_r:e}");
    assert!(worst_pi <= SAME_PI, "Π deviates by {worst_pi:e}");
}

/// A heavy asymmetric top (J = diag(0.3, 0.5, 0.6) about the centre of mass, m = 1.5, centre of
/// mass at ρ = (0.05, −0.02, 0.4) from a pivot held at the origin by a spherical joint), h = 0.01,
/// 500 steps: the embedded step with the pivot as a joint equals the LGVI of the body about the
/// pivot (inertia moved by the parallel-axis theorem, gravity as the moment `m ρ × Rᵀg`).
///
/// Mutations seen to fail: gravity's moment with the opposite sign in the reference (one-step
/// `|ΔR|` 9.7e-4).
#[test]
fn heavy_top_with_a_joint_matches_the_lgvi() {
    let rho = [0.05, -0.02, 0.4];
    let pivot = rho.map(|c| -c);
    let body = RigidBody::principal(1.5, [0.3, 0.5, 0.6])
        .expect("body")
        .with_gravity([0.0, 0.0, -9.81]);
    let g = heavy_top(&body, pivot);
    let r0 = so3::from_axis_angle([1.0, 0.3, 0.0], 0.4);
    let omega = [0.3, -0.2, 15.0];
    let (q0, v0) = pivoted_state(&r0, pivot, omega);
    let h = 0.01;
    let mut run = Run::new(&g, Representation::Monolithic, trapezoid(h), &[q0], &[v0]);
    let lgvi = Lgvi::new(&body, rho, h);
    let pi0 = so3::apply(&lgvi.j, &omega);
    let state = |run: &Run| {
        let q = run.body_q(0);
        (
            RigidBody::rotation(q),
            pivot_momentum(q, run.body_p(0), pivot),
        )
    };
    let (worst_r, worst_pi) = compare_maps(&mut run, &lgvi, 500, state, norm(&pi0));
    println!("heavy top: one-step max |ΔR| = {worst_r:.2e}, max |ΔΠ|/|Π| = {worst_pi:.2e}");
    assert!(worst_r <= SAME_R, "R deviates by {worst_r:e}");
    assert!(worst_pi <= SAME_PI, "Π deviates by {worst_pi:e}");
}
