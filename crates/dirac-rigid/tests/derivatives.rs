//! Hand-written derivatives against central differences.
//!
//! The body's Lagrangian gradient and Hessian, the orthonormality rows, every joint kind's rows
//! and the joint-coordinate couplings (angle and slide) are checked at generic points off the
//! constraint manifold (where every term of the derivatives is active): covectors against
//! differences of `g`, multiplier Hessians against differences of `Σ λ A`, contracted derivatives
//! against differences of `A·w`.
//!
//! Mutations seen to fail: the `x`–`R` cross term of a `Dot` Hessian emitted one-sided (only
//! `(i, j)`, not `(j, i)`): `Σλ ∂A_…` mismatch; the angle row's `θθ` Hessian with the opposite sign.

mod common;

use common::{FD_AGREE, check_constraints, pseudo_random};
use dirac_components::Inertia;
use dirac_core::{Constraints, LagrangianHessian, Model};
use dirac_graph::{Assembler, Interconnection, Representation};
use dirac_rigid::{Joint, JointFrame, JointKind, Orthonormality, RigidBody, Side, so3};

#[test]
fn body_lagrangian_derivatives_match_differences() {
    let body = RigidBody::new(
        1.3,
        [[0.4, 0.05, -0.02], [0.05, 0.6, 0.01], [-0.02, 0.01, 0.7]],
    )
    .expect("body")
    .with_gravity([0.1, -0.2, -9.8]);
    let q = pseudo_random(12, 1);
    let v = pseudo_random(12, 2);
    let (mut lq, mut lv) = (vec![0.0; 12], vec![0.0; 12]);
    body.lagrangian_gradient(&q, &v, &mut lq, &mut lv);
    let mut h = LagrangianHessian::default();
    h.begin();
    body.lagrangian_hessian(&q, &v, &mut h);
    let vv = common::dense(&h.vv, 12, 12);
    assert!(h.qq.is_empty() && h.qv.is_empty());
    let e = common::FD_STEP;
    for j in 0..12 {
        let (mut qp, mut qm, mut vp, mut vm) = (q.clone(), q.clone(), v.clone(), v.clone());
        qp[j] += e;
        qm[j] -= e;
        vp[j] += e;
        vm[j] -= e;
        let dq = (body.lagrangian(&qp, &v) - body.lagrangian(&qm, &v)) / (2.0 * e);
        let dv = (body.lagrangian(&q, &vp) - body.lagrangian(&q, &vm)) / (2.0 * e);
        assert!(
            (lq[j] - dq).abs() <= FD_AGREE * (1.0 + dq.abs()),
            "∂L/∂q{j}"
        );
        assert!(
            (lv[j] - dv).abs() <= FD_AGREE * (1.0 + dv.abs()),
            "∂L/∂v{j}"
        );
        let (mut gp, mut gm, mut scratch) = (vec![0.0; 12], vec![0.0; 12], vec![0.0; 12]);
        body.lagrangian_gradient(&q, &vp, &mut scratch, &mut gp);
        body.lagrangian_gradient(&q, &vm, &mut scratch, &mut gm);
        for i in 0..12 {
            let d = (gp[i] - gm[i]) / (2.0 * e);
            assert!(
                (vv[i][j] - d).abs() <= FD_AGREE * (1.0 + d.abs()),
                "∂²L/∂v{i}∂v{j}"
            );
        }
    }
    // ½ tr(Ṙ J_d Ṙᵀ) is ½ Ωᵀ J Ω on SO(3).
    let r = so3::from_axis_angle([0.2, 1.0, -0.4], 1.1);
    let omega = [0.7, -1.2, 0.4];
    let (q0, v0) = (
        RigidBody::coordinates([0.0; 3], &r),
        RigidBody::rates(&r, [0.0; 3], omega),
    );
    let expected = body.kinetic_energy(&q0, &v0) - body.potential_energy(&q0);
    assert!((body.lagrangian(&q0, &v0) - expected).abs() < 1e-14);
}

#[test]
fn orthonormality_rows_match_differences() {
    let q = pseudo_random(12, 3);
    check_constraints(
        &Orthonormality,
        &q,
        &pseudo_random(6, 4),
        &pseudo_random(12, 5),
    );
}

/// Two bodies with every joint kind between them (and to the ground), plus the angle coupling of
/// a revolute joint and the slide coupling of a prismatic one, each to a rotor's angle.
#[test]
fn joint_rows_match_differences() {
    let body = RigidBody::principal(1.0, [0.3, 0.4, 0.5]).expect("body");
    let frame_a = JointFrame::new([0.1, -0.2, 0.3], so3::from_axis_angle([1.0, 0.5, 0.2], 0.8));
    let frame_b = JointFrame::new(
        [-0.3, 0.1, 0.2],
        so3::from_axis_angle([0.3, -1.0, 0.4], 1.3),
    );
    let kinds = [
        JointKind::Spherical,
        JointKind::Revolute,
        JointKind::Universal,
        JointKind::Cylindrical,
        JointKind::Prismatic,
        JointKind::Planar,
        JointKind::Fixed,
    ];
    for (k, kind) in kinds.into_iter().enumerate() {
        for ground in [false, true] {
            let mut g = Interconnection::new();
            g.add_subsystem(body.subsystem("A")).expect("unique");
            g.add_subsystem(body.subsystem("B")).expect("unique");
            g.add_subsystem(Inertia::new(0.1).expect("rotor").subsystem("rotor"))
                .expect("unique");
            let a = if ground {
                Side::ground(frame_a)
            } else {
                Side::body("A", frame_a)
            };
            let joint = Joint::new(kind, a, Side::body("B", frame_b));
            joint.connect(&mut g, "j").expect("joint");
            let rotor = g.port("rotor", "theta").expect("port");
            let coupled = joint.couple_coordinate(&mut g, "drive", rotor).is_ok();
            assert_eq!(
                coupled,
                matches!(
                    kind,
                    JointKind::Revolute
                        | JointKind::Cylindrical
                        | JointKind::Planar
                        | JointKind::Prismatic
                )
            );
            let system = Assembler::assemble(&g, Representation::Monolithic).expect("assembles");
            let c = &system.constraints;
            assert_eq!(c.count(), 12 + joint.rows() + usize::from(coupled));
            let n = system.coordinates();
            let seed = 10 * k as u64 + u64::from(ground);
            let q = pseudo_random(n, seed);
            check_constraints(
                c,
                &q,
                &pseudo_random(c.count(), seed + 100),
                &pseudo_random(n, seed + 200),
            );
        }
    }
}
