//! Forced (+)/(−) discrete Dirac integrators (MATH §4, §6).

mod common;

use common::{max_diff, options, trajectory};
use dirac::core::{
    ConstraintKind, Constraints, Discretisation, Flavour, LagrangianHessian, LinearForms, Model,
    NoConstraints,
};
use dirac::sim::{Integrator, IntegratorOptions, Scheme, SimError};
use dirac_components::{RollingConstraint, RollingDisk};
use dirac_problems::{CircleConstraint, LcTank, QuarticPendulums, RlcLoop, rlc_exact};

/// A small dense Newton with a central-difference Jacobian, written independently of the library,
/// used to solve reference step equations.
fn reference_newton(mut x: Vec<f64>, f: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let n = x.len();
    for _ in 0..50 {
        let r = f(&x);
        if r.iter().all(|v| v.abs() < 1e-15) {
            break;
        }
        let mut a = vec![vec![0.0; n + 1]; n];
        for j in 0..n {
            let d = 1e-6 * (1.0 + x[j].abs());
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[j] += d;
            xm[j] -= d;
            let (fp, fm) = (f(&xp), f(&xm));
            for i in 0..n {
                a[i][j] = (fp[i] - fm[i]) / (2.0 * d);
            }
        }
        for i in 0..n {
            a[i][n] = -r[i];
        }
        // Gaussian elimination with partial pivoting.
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
                .unwrap();
            a.swap(k, p);
            let (top, bottom) = a.split_at_mut(k + 1);
            let pivot_row = &top[k];
            for row in bottom.iter_mut() {
                let factor = row[k] / pivot_row[k];
                for (x, p) in row[k..].iter_mut().zip(&pivot_row[k..]) {
                    *x -= factor * p;
                }
            }
        }
        let mut dx = vec![0.0; n];
        for k in (0..n).rev() {
            let s: f64 = (k + 1..n).map(|j| a[k][j] * dx[j]).sum();
            dx[k] = (a[k][n] - s) / a[k][k];
        }
        for (xi, d) in x.iter_mut().zip(&dx) {
            *xi += d;
        }
    }
    x
}

/// With no constraints, (+) and (−) are the forced discrete Hamiltonian map of MATH §3, and the
/// linear path with one Gauss node is the midpoint rule. The reference writes the midpoint map by
/// hand: p_k = Lv − ½h(Lq + f), p_{k+1} = Lv + ½h(Lq + f), evaluated at (q̄, v̄), and is compared
/// with `Discretisation::gauss(1)` (which `Discretisation::midpoint()` is, asserted).
#[test]
fn without_constraints_both_flavours_are_the_forced_hamiltonian_map() {
    let model = QuarticPendulums {
        g: 2.0,
        kappa: 0.7,
        eps: 0.3,
        c: 0.15,
    };
    let h = 0.05;
    let steps = 200;
    let halves = |q0: &[f64], q1: &[f64]| {
        let qb = [(q0[0] + q1[0]) / 2.0, (q0[1] + q1[1]) / 2.0];
        let vb = [(q1[0] - q0[0]) / h, (q1[1] - q0[1]) / h];
        let (mut lq, mut lv, mut f) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        model.lagrangian_gradient(&qb, &vb, &mut lq, &mut lv);
        model.force(&qb, &vb, 0.0, &mut f);
        let kick = [0.5 * h * (lq[0] + f[0]), 0.5 * h * (lq[1] + f[1])];
        (
            [lv[0] - kick[0], lv[1] - kick[1]],
            [lv[0] + kick[0], lv[1] + kick[1]],
        )
    };
    let (mut q, mut p) = (vec![0.4, -0.3], vec![0.2, 0.5]);
    let mut reference = vec![(q.clone(), p.clone())];
    for _ in 0..steps {
        let q1 = reference_newton(q.clone(), |x| {
            let (pk, _) = halves(&q, x);
            vec![pk[0] - p[0], pk[1] - p[1]]
        });
        p = halves(&q, &q1).1.to_vec();
        q = q1;
        reference.push((q.clone(), p.clone()));
    }
    assert_eq!(Discretisation::midpoint(), Discretisation::gauss(1));
    for flavour in [Flavour::Plus, Flavour::Minus] {
        let run = trajectory(
            model,
            NoConstraints,
            options(Discretisation::gauss(1), flavour, h),
            &[0.4, -0.3],
            &[0.2, 0.5],
            steps,
        );
        let dev = run
            .iter()
            .zip(&reference)
            .map(|(a, b)| max_diff(&a.0, &b.0).max(max_diff(&a.1, &b.1)))
            .fold(0.0, f64::max);
        println!("{flavour:?}: deviation from the hand-written map {dev:.2e}");
        assert!(dev <= 1e-13, "{flavour:?}: deviation {dev:e}");
    }
}

/// Rolling disk, midpoint discrete Lagrangian L_d = ½ (q1−q0)ᵀM(q1−q0)/h, no forces.
struct DiskReference {
    mass: [f64; 4],
    forms: RollingConstraint,
    h: f64,
}

impl DiskReference {
    fn omega(&self, q: &[f64]) -> [[f64; 4]; 2] {
        let r = self.forms.radius;
        [
            [1.0, 0.0, -r * q[3].cos(), 0.0],
            [0.0, 1.0, -r * q[3].sin(), 0.0],
        ]
    }
    /// D2 L_d(q0, q1) = M(q1 − q0)/h = −D1 L_d(q0, q1).
    fn d2(&self, q0: &[f64], q1: &[f64]) -> [f64; 4] {
        std::array::from_fn(|i| self.mass[i] * (q1[i] - q0[i]) / self.h)
    }
}

/// With f = 0 the (+) step is Leok–Ohsawa's (+) discrete Dirac integrator, written here from the
/// paper: ω(q_k)(q_{k+1} − q_k) = 0, p_k = −D1L_d + μ·ω(q_k), p_{k+1} = D2L_d.
/// The (−) step is checked against the literal two-step form
/// D2L_d(q_{k−1}, q_k) + μ·ω(q_k) + D1L_d(q_k, q_{k+1}) = 0, ω(q_{k+1})(q_{k+1} − q_k) = 0.
#[test]
fn without_forces_both_flavours_are_leok_ohsawa() {
    let disk = DiskReference {
        mass: [1.0, 1.0, 1.0, 1.0],
        forms: RollingConstraint::new(1.0).unwrap(),
        h: 0.05,
    };
    let q0 = vec![0.0, 0.0, 0.0, 0.0];
    let v0 = [1.0, 0.0, 1.0, 0.5];
    let p0: Vec<f64> = (0..4).map(|i| disk.mass[i] * v0[i]).collect();
    let steps = 100;

    let mut q = q0.clone();
    let mut p = p0.clone();
    let mut plus = vec![q.clone()];
    for _ in 0..steps {
        let w = disk.omega(&q);
        let x = reference_newton([q.clone(), vec![0.0, 0.0]].concat(), |x| {
            let d2 = disk.d2(&q, &x[..4]);
            let mut r: Vec<f64> = (0..4)
                .map(|i| d2[i] + w[0][i] * x[4] + w[1][i] * x[5] - p[i])
                .collect();
            for row in &w {
                r.push((0..4).map(|i| row[i] * (x[i] - q[i])).sum());
            }
            r
        });
        p = disk.d2(&q, &x[..4]).to_vec();
        q = x[..4].to_vec();
        plus.push(q.clone());
    }

    let mut minus = vec![q0.clone()];
    let mut prev_momentum = p0.clone(); // plays D2L_d(q_{−1}, q_0)
    let mut q = q0.clone();
    for _ in 0..steps {
        let w = disk.omega(&q);
        let x = reference_newton([q.clone(), vec![0.0, 0.0]].concat(), |x| {
            let d2 = disk.d2(&q, &x[..4]);
            let mut r: Vec<f64> = (0..4)
                .map(|i| prev_momentum[i] + w[0][i] * x[4] + w[1][i] * x[5] - d2[i])
                .collect();
            let w1 = disk.omega(&x[..4]);
            for row in &w1 {
                r.push((0..4).map(|i| row[i] * (x[i] - q[i])).sum());
            }
            r
        });
        prev_momentum = disk.d2(&q, &x[..4]).to_vec();
        q = x[..4].to_vec();
        minus.push(q.clone());
    }

    for (flavour, reference) in [(Flavour::Plus, &plus), (Flavour::Minus, &minus)] {
        let run = trajectory(
            RollingDisk::new(1.0, 1.0, 1.0, 1.0).unwrap(),
            RollingConstraint::new(1.0).unwrap(),
            options(Discretisation::midpoint(), flavour, 0.05),
            &q0,
            &p0,
            steps,
        );
        let dev = run
            .iter()
            .zip(reference)
            .map(|(a, b)| max_diff(&a.0, b))
            .fold(0.0, f64::max);
        println!("{flavour:?}: deviation from the Leok–Ohsawa reference {dev:.2e}");
        assert!(dev <= 1e-12, "{flavour:?}: deviation {dev:e}");
    }
    // The two flavours differ on this q-dependent constraint (negative control).
    let dev = plus
        .iter()
        .zip(&minus)
        .map(|(a, b)| max_diff(a, b))
        .fold(0.0, f64::max);
    assert!(dev > 1e-6);
}

fn seed_run(flavour: Flavour) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut sim = Integrator::new(
        RlcLoop::seed(),
        RlcLoop::kcl(),
        IntegratorOptions::new(Discretisation::midpoint(), 0.05).flavour(flavour),
    )
    .unwrap();
    sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0).unwrap();
    let mut out = vec![(sim.q().to_vec(), sim.p().to_vec())];
    for _ in 0..1000 {
        sim.step().unwrap();
        out.push((sim.q().to_vec(), sim.p().to_vec()));
    }
    out
}

/// Seed paper §4: midpoint on the RLC loop has max |q_C − exact| ≈ 3.4e-4 over 1000 steps,
/// in both flavours (the exact charge is the closed-form solution of the loop's ODE).
#[test]
fn seed_rlc_error_matches_the_paper() {
    let rlc = RlcLoop::seed();
    for flavour in [Flavour::Plus, Flavour::Minus] {
        let run = seed_run(flavour);
        let err = run
            .iter()
            .enumerate()
            .map(|(k, (q, _))| (q[0] - rlc_exact(&rlc, 1.0, 0.05 * k as f64)).abs())
            .fold(0.0, f64::max);
        println!("{flavour:?}: max |q_C − exact| = {err:.4e}");
        assert!(
            (err - 3.4e-4).abs() <= 0.05 * 3.4e-4,
            "{flavour:?}: max error {err:e}"
        );
    }
}

/// Largest relative defect of the seed loop's discrete power balance: round-off of energies of
/// order one summed from three momenta, measured 1.9e-15 (allowance 50×).
const POWER_BALANCE: f64 = 1e-13;

/// Exact discrete power balance with the loop momentum P = p_C + p_L + p_R (MATH §6):
/// E_{k+1} − E_k = −hR((q_R,{k+1} − q_R,k)/h)², to round-off relative at every step.
#[test]
fn seed_rlc_discrete_power_balance() {
    let rlc = RlcLoop::seed();
    let h = 0.05;
    for flavour in [Flavour::Plus, Flavour::Minus] {
        let run = seed_run(flavour);
        let worst = run
            .windows(2)
            .map(|w| {
                let (e0, e1) = (rlc.energy(&w[0].0, &w[0].1), rlc.energy(&w[1].0, &w[1].1));
                let vr = (w[1].0[2] - w[0].0[2]) / h;
                (e1 - e0 + h * rlc.r * vr * vr).abs() / e0
            })
            .fold(0.0, f64::max);
        println!("{flavour:?}: largest relative power-balance defect {worst:.2e}");
        assert!(worst <= POWER_BALANCE, "{flavour:?}: defect {worst:e}");
    }
    // Negative control: with p_L alone in the energy the balance fails by far more.
    let run = seed_run(Flavour::Plus);
    let raw = |q: &[f64], p: &[f64]| p[1] * p[1] / (2.0 * rlc.l) + q[0] * q[0] / (2.0 * rlc.c);
    let worst = run
        .windows(2)
        .map(|w| {
            let vr = (w[1].0[2] - w[0].0[2]) / h;
            (raw(&w[1].0, &w[1].1) - raw(&w[0].0, &w[0].1) + h * rlc.r * vr * vr).abs()
        })
        .fold(0.0, f64::max);
    assert!(
        worst > 1e-6,
        "raw p_L balance unexpectedly exact: {worst:e}"
    );
}

/// (+) and (−) solve the same equations on the RLC loop, whose constraint forms are constant:
/// the (+) step takes the one-pass path for forms at q_k, the (−) step the general path with
/// forms at the control points. Charges and the loop momentum must agree to a few ulps (measured
/// exactly 0); both flavours are also checked against the exact solution above.
#[test]
fn seed_rlc_flavours_agree_on_charges() {
    let (a, b) = (seed_run(Flavour::Plus), seed_run(Flavour::Minus));
    let dev = a
        .iter()
        .zip(&b)
        .map(|(x, y)| max_diff(&x.0, &y.0))
        .fold(0.0, f64::max);
    let loop_p = |p: &[f64]| p[0] + p[1] + p[2];
    let dev_p = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (loop_p(&x.1) - loop_p(&y.1)).abs())
        .fold(0.0, f64::max);
    println!("(+) vs (−): charges {dev:.2e}, loop momentum {dev_p:.2e}");
    // Four ulps of the order-one charges and momenta.
    let ulps = 4.0 * f64::EPSILON;
    assert!(dev <= ulps, "charge deviation {dev:e}");
    assert!(dev_p <= ulps, "loop momentum deviation {dev_p:e}");
}

/// Constraint residuals vanish to round-off at every step: KCL and rolling (Dirac form),
/// g(q) for the position-level pendulum.
#[test]
fn constraint_residuals_are_round_off() {
    let kcl = RlcLoop::kcl();
    let run = seed_run(Flavour::Plus);
    let mut forms = dirac::core::Triplets::new();
    let mut worst = [0.0_f64; 3];
    for w in run.windows(2) {
        forms.begin();
        kcl.forms(&w[0].0, &mut forms);
        let mut r = [0.0; 2];
        for (a, j, c) in forms.iter() {
            r[a] += c * (w[1].0[j] - w[0].0[j]);
        }
        worst[0] = worst[0].max(r[0].abs()).max(r[1].abs());
    }

    let disk = RollingConstraint::new(1.0).unwrap();
    let mut sim = Integrator::new(
        RollingDisk::new(1.0, 1.0, 1.0, 1.0).unwrap(),
        disk,
        IntegratorOptions::new(Discretisation::midpoint(), 0.05),
    )
    .unwrap();
    sim.initialise(&[0.0; 4], &[1.0, 0.0, 1.0, 0.5], 0.0)
        .unwrap();
    for _ in 0..2000 {
        let q0 = sim.q().to_vec();
        sim.step().unwrap();
        let (c, s) = (q0[3].cos(), q0[3].sin());
        let d: Vec<f64> = (0..4).map(|i| sim.q()[i] - q0[i]).collect();
        let r = [d[0] - c * d[2], d[1] - s * d[2]];
        worst[1] = worst[1].max(r[0].abs()).max(r[1].abs());
    }

    let circle = CircleConstraint {
        length: 1.0,
        kind: ConstraintKind::Holonomic,
    };
    let mut sim = Integrator::new(
        CircleConstraint::model(1.0, 9.81),
        circle,
        IntegratorOptions::new(Discretisation::midpoint(), 0.01),
    )
    .unwrap();
    let a = 60f64.to_radians();
    sim.initialise(&[a.sin(), -a.cos()], &[0.0, 0.0], 0.0)
        .unwrap();
    for _ in 0..5000 {
        sim.step().unwrap();
        worst[2] = worst[2].max(circle.drift(sim.q()).abs());
    }
    println!(
        "largest residuals: KCL {:.1e}, rolling {:.1e}, circle {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(worst.iter().all(|r| *r <= 1e-13), "{worst:?}");
}

/// Runs the rolling disk (m = I = J = R = 1, θ̇₀ = 1, φ̇₀ = 0.5, h = 0.05) and returns the max
/// energy change since step 1 over the first and the last tenth of the run, and the final energy
/// relative to the energy after step 1.
fn rolling_disk(scheme: Scheme, steps: usize) -> (f64, f64, f64) {
    let model = RollingDisk::new(1.0, 1.0, 1.0, 1.0).unwrap();
    let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).scheme(scheme);
    let mut sim = Integrator::new(model, RollingConstraint::new(1.0).unwrap(), options).unwrap();
    sim.initialise(&[0.0; 4], &[1.0, 0.0, 1.0, 0.5], 0.0)
        .unwrap();
    // Energy after the first step: the first constraint impulse projects the initial momentum
    // once; what matters is what happens after.
    sim.step().unwrap();
    let e0 = model.energy(sim.p());
    let (mut first, mut last) = (0.0_f64, 0.0_f64);
    for k in 1..steps {
        sim.step().unwrap();
        let de = (model.energy(sim.p()) - e0).abs();
        if k < steps / 10 {
            first = first.max(de);
        } else if k >= steps - steps / 10 {
            last = last.max(de);
        }
    }
    (first, last, model.energy(sim.p()) / e0)
}

/// Rolling disk over 10⁵ steps. The symmetric scheme keeps the energy bounded: after the first
/// step (whose impulse projects the initial momentum once) it is conserved to round-off, as its
/// two half-step constraints share the midpoint. The one-sided (+) scheme projects the momentum
/// onto ker ω(q_{k+1}) each step and dissipates (−(1 − cos Δφ)/2 per step), and (−) gains by the
/// mirror argument: both drift secularly, which is why the symmetric scheme exists. (p_φ is not
/// checked: neither the Lagrangian nor the rolling forms involve φ, so its momentum equation is
/// `p_φ,k+1 = p_φ,k` in every scheme by construction; conserved momenta that can fail are checked
/// in `tests/foundation.rs`, `discrete_noether_conserves_angular_momentum`.)
#[test]
fn rolling_disk_invariants() {
    let steps = 100_000;
    let (first, last, _) = rolling_disk(Scheme::Symmetric, steps);
    println!("symmetric: energy error {first:.2e} (first tenth), {last:.2e} (last tenth)");
    assert!(
        first <= 1e-12 && last <= 1e-12,
        "symmetric: energy error {first:e} then {last:e}"
    );
    // Measured (docs/results.md): (+) ends with ~1/9 of its energy (only the φ spin survives),
    // (−) with many times its initial energy.
    let (_, _, plus_ratio) = rolling_disk(Scheme::Plus, steps);
    assert!(
        plus_ratio < 0.5,
        "(+) should dissipate: E_end/E_1 = {plus_ratio}"
    );
    let (_, _, minus_ratio) = rolling_disk(Scheme::Minus, steps);
    assert!(
        minus_ratio > 2.0,
        "(−) should gain: E_end/E_1 = {minus_ratio}"
    );
}

/// LC tank (degenerate Lagrangian): energy with the loop momentum conserved to round-off.
#[test]
fn lc_tank_conserves_energy() {
    let tank = LcTank { l: 1.0, c: 1.0 };
    let mut sim = Integrator::new(
        tank,
        LcTank::kcl(),
        IntegratorOptions::new(Discretisation::midpoint(), 0.1),
    )
    .unwrap();
    sim.initialise(&[1.0, 0.0], &[0.0, 0.0], 0.0).unwrap();
    let e0 = tank.energy(sim.q(), sim.p());
    for _ in 0..100_000 {
        sim.step().unwrap();
    }
    let drift = (tank.energy(sim.q(), sim.p()) - e0).abs() / e0;
    println!("LC tank: relative energy drift after 1e5 steps {drift:.2e}");
    assert!(drift <= 1e-12, "relative drift {drift:e}");
}

/// Gauss (order 2s) with constant constraints on a degenerate system keeps its order: the RLC
/// loop with Gauss s = 2 converges at order 4 against the exact charge.
#[test]
fn constrained_galerkin_keeps_its_order() {
    let rlc = RlcLoop::seed();
    for (d, order) in [
        (Discretisation::midpoint(), 2.0),
        (Discretisation::gauss(2), 4.0),
        (Discretisation::gauss(3), 6.0),
        (Discretisation::lobatto(2), 4.0),
    ] {
        let mut hs = Vec::new();
        let mut errs = Vec::new();
        for steps in [20usize, 40, 80, 160] {
            let h = 10.0 / steps as f64;
            let mut sim =
                Integrator::new(rlc, RlcLoop::kcl(), IntegratorOptions::new(d.clone(), h)).unwrap();
            sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0).unwrap();
            for _ in 0..steps {
                sim.step().unwrap();
            }
            hs.push(h);
            errs.push((sim.q()[0] - rlc_exact(&rlc, 1.0, 10.0)).abs());
        }
        let slope = common::fitted_slope(&hs, &errs);
        assert!(
            (slope - order).abs() <= 0.2,
            "{d}: slope {slope}, errors {errs:?}"
        );
    }
}

/// A constraint row with no coefficients is an error naming it.
#[test]
fn empty_constraint_row_is_a_typed_error() {
    let mut forms = RlcLoop::kcl();
    forms.push("dangling", &[]);
    let mut sim = Integrator::new(
        RlcLoop::seed(),
        forms,
        IntegratorOptions::new(Discretisation::midpoint(), 0.05),
    )
    .unwrap();
    match sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0) {
        Err(SimError::EmptyConstraint { constraint }) => assert_eq!(constraint, "dangling"),
        other => panic!("expected EmptyConstraint, got {other:?}"),
    }
}

/// A degenerate coordinate with neither potential nor constraint: the Newton matrix has an empty
/// column; the error names the coordinate and the step.
#[test]
fn undetermined_coordinate_is_a_typed_error() {
    // RLC loop without the constraint tying q_R: q_R appears only through its damping force.
    let mut forms = LinearForms::new(3);
    forms.push("kcl(L,C)", &[(1, 1.0), (0, -1.0)]);
    struct NoResistor(RlcLoop);
    impl Model for NoResistor {
        fn dim(&self) -> usize {
            3
        }
        fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
            self.0.lagrangian(q, v)
        }
        fn lagrangian_gradient(&self, q: &[f64], v: &[f64], a: &mut [f64], b: &mut [f64]) {
            self.0.lagrangian_gradient(q, v, a, b)
        }
        fn lagrangian_hessian(&self, q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
            self.0.lagrangian_hessian(q, v, h)
        }
        fn coordinate_name(&self, i: usize) -> String {
            self.0.coordinate_name(i)
        }
    }
    let mut sim = Integrator::new(
        NoResistor(RlcLoop::seed()),
        forms,
        IntegratorOptions::new(Discretisation::midpoint(), 0.05),
    )
    .unwrap();
    sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0).unwrap();
    let err = sim.step().unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, SimError::Newton { step: 0, .. }), "{text}");
    assert!(text.contains("qR"), "{text}");
}

/// Two holonomic constraints that contradict each other (x = 1 and x = 2): the initial check
/// names the violated one.
#[test]
fn contradicting_constraints_are_a_typed_error() {
    struct Pins;
    impl Constraints for Pins {
        fn count(&self) -> usize {
            2
        }
        fn kind(&self, _a: usize) -> ConstraintKind {
            ConstraintKind::Holonomic
        }
        fn forms(&self, _q: &[f64], out: &mut dirac::core::Triplets) {
            out.add(0, 0, 1.0);
            out.add(1, 0, 1.0);
        }
        fn values(&self, q: &[f64], out: &mut [f64]) {
            out[0] = q[0] - 1.0;
            out[1] = q[0] - 2.0;
        }
        fn is_constant(&self) -> bool {
            true
        }
        fn name(&self, a: usize) -> String {
            ["x=1", "x=2"][a].to_string()
        }
    }
    let mut sim = Integrator::new(
        CircleConstraint::model(1.0, 0.0),
        Pins,
        IntegratorOptions::new(Discretisation::midpoint(), 0.05),
    )
    .unwrap();
    match sim.initialise(&[1.0, 0.0], &[0.0, 0.0], 0.0) {
        Err(SimError::InconsistentInitialCondition { constraint, .. }) => {
            assert_eq!(constraint, "x=2")
        }
        other => panic!("expected InconsistentInitialCondition, got {other:?}"),
    }
}

/// KCL written at every node of the loop (three rows, one redundant): the redundant row is
/// dropped with a warning naming it and the run equals the one with independent rows.
#[test]
fn redundant_constraint_is_dropped_with_a_warning() {
    let mut forms = RlcLoop::kcl();
    forms.push("kcl(C,L)", &[(0, 1.0), (1, -1.0)]);
    let mut sim = Integrator::new(
        RlcLoop::seed(),
        forms,
        IntegratorOptions::new(Discretisation::midpoint(), 0.05),
    )
    .unwrap();
    sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0).unwrap();
    assert_eq!(sim.warnings().len(), 1);
    assert!(
        sim.warnings()[0].contains("kcl(C,L)"),
        "{:?}",
        sim.warnings()
    );
    let reference = seed_run(Flavour::Plus);
    for (k, state) in reference.iter().enumerate().skip(1) {
        sim.step().unwrap();
        assert!(max_diff(sim.q(), &state.0) <= 1e-14, "step {k}");
    }
}

/// The opt-in affine step map (linear autonomous models, constant forms) reproduces the Newton
/// path: on the seed RLC loop, and on free fall under gravity, whose constant force makes the map
/// affine rather than linear (the offset must be kept).
#[test]
fn affine_step_map_matches_newton_path() {
    let run = |affine: bool| {
        let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).affine_map(affine);
        let mut sim = Integrator::new(RlcLoop::seed(), RlcLoop::kcl(), options).unwrap();
        sim.initialise(&[1.0, 0.0, 0.0], &[0.0; 3], 0.0).unwrap();
        let mut out = Vec::new();
        for _ in 0..1000 {
            sim.step().unwrap();
            out.push((
                sim.q().to_vec(),
                sim.p().to_vec(),
                sim.last_multipliers().to_vec(),
            ));
        }
        assert_eq!(sim.uses_affine_map(), affine);
        out
    };
    let (newton, affine) = (run(false), run(true));
    for (a, b) in newton.iter().zip(&affine) {
        assert!(
            max_diff(&a.0, &b.0) <= 1e-12
                && max_diff(&a.1, &b.1) <= 1e-12
                && max_diff(&a.2, &b.2) <= 1e-12
        );
    }
    // Free fall with gravity: L = ½ m v² − m g y, no constraints.
    let fall = |affine: bool| {
        let model = dirac_problems::FreeMasses {
            masses: vec![2.0, 2.0],
            weights: vec![0.0, 2.0 * 9.81],
            names: vec!["x", "y"],
        };
        let options = IntegratorOptions::new(Discretisation::gauss(2), 0.01).affine_map(affine);
        let mut sim = Integrator::new(model, NoConstraints, options).unwrap();
        sim.initialise(&[0.0, 10.0], &[1.0, 3.0], 0.0).unwrap();
        for _ in 0..100 {
            sim.step().unwrap();
        }
        assert_eq!(sim.uses_affine_map(), affine);
        sim.q().to_vec()
    };
    let (a, b) = (fall(false), fall(true));
    // Exact: y(1) = 10 + 3 − 9.81/2 (Gauss 2 integrates the quadratic motion exactly).
    assert!(
        (a[1] - (13.0 - 4.905)).abs() <= 1e-12 && max_diff(&a, &b) <= 1e-12,
        "{a:?} vs {b:?}"
    );
}

/// Models that do not qualify (nonlinear, or time-dependent) keep the Newton path.
#[test]
fn affine_step_map_only_where_it_is_exact() {
    let options = IntegratorOptions::new(Discretisation::midpoint(), 0.05).affine_map(true);
    let mut sim = Integrator::new(
        QuarticPendulums {
            g: 2.0,
            kappa: 0.5,
            eps: 0.3,
            c: 0.1,
        },
        NoConstraints,
        options,
    )
    .unwrap();
    sim.set_state(&[0.1, 0.2], &[0.0, 0.0], 0.0).unwrap();
    sim.step().unwrap();
    assert!(!sim.uses_affine_map());
}
