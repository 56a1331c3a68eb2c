//! The forced discrete Hamiltonian map with Galerkin discretisations (MATH §2–§3, §6).

mod common;

use common::{fitted_slope, max_diff, options, trajectory};
use dirac::core::{
    AutoDiff, Discretisation, Flavour, ForceJacobian, LagrangianHessian, Model, NoConstraints,
    QuadratureRule,
};
use dirac_problems::{
    DampedOscillator, QuarticPendulums, QuarticPendulumsGeneric, SplitOscillator,
};

/// Round-off allowance for quantities of order one accumulated over a few thousand steps.
const ROUND_OFF: f64 = 1e-12;

/// Every stock discretisation once: `gauss(1)` is `midpoint()` and `lobatto(1)` is `trapezoid()`
/// (asserted), so they are not listed twice.
fn every_discretisation() -> Vec<Discretisation> {
    assert_eq!(Discretisation::gauss(1), Discretisation::midpoint());
    assert_eq!(Discretisation::lobatto(1), Discretisation::trapezoid());
    let mut all = vec![
        Discretisation::midpoint(),
        Discretisation::trapezoid(),
        Discretisation::simpson(),
    ];
    all.extend((2..=4).map(Discretisation::gauss));
    all.extend((2..=3).map(Discretisation::lobatto));
    // Degree s with s Lobatto nodes: order 2s − 2.
    all.push(Discretisation::galerkin(3, QuadratureRule::lobatto(3)));
    all.push(Discretisation::galerkin(4, QuadratureRule::lobatto(4)));
    for (i, a) in all.iter().enumerate() {
        assert!(!all[..i].contains(a), "{a} listed twice");
    }
    all
}

/// Error in (q, p) at t = 4 on the damped oscillator m = k = 1, c = 0.2, for `steps` steps.
fn oscillator_error(d: &Discretisation, steps: usize) -> f64 {
    let osc = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 0.2,
    };
    let t_end = 4.0;
    let h = t_end / steps as f64;
    let run = trajectory(
        osc,
        NoConstraints,
        options(d.clone(), Flavour::Plus, h),
        &[1.0],
        &[0.0],
        steps,
    );
    let (q, p) = &run[steps];
    let (qe, pe) = osc.exact(1.0, 0.0, t_end);
    (q[0] - qe).abs().max((p[0] - pe).abs())
}

/// Observed order on the damped oscillator: the fitted slope of log error against log h lies
/// within ±0.2 of `Discretisation::order()`. Step counts are chosen per order so the errors
/// stay well above round-off (a plateau would flatten the slope).
#[test]
fn observed_order_matches_theory() {
    for d in every_discretisation() {
        let r = d.order();
        let steps: Vec<usize> = match r {
            2 => vec![40, 80, 160, 320],
            4 => vec![10, 20, 40, 80],
            6 => vec![6, 12, 24, 48],
            _ => vec![4, 5, 6, 8, 10],
        };
        let errs: Vec<f64> = steps.iter().map(|&n| oscillator_error(&d, n)).collect();
        assert!(
            errs.iter().all(|e| *e > 1e-13),
            "{d}: errors reach round-off {errs:?}"
        );
        let hs: Vec<f64> = steps.iter().map(|&n| 4.0 / n as f64).collect();
        let slope = fitted_slope(&hs, &errs);
        println!("{d}: order {r}, slope {slope:.3}");
        assert!(
            (slope - r as f64).abs() <= 0.2,
            "{d}: slope {slope:.3}, expected {r}; errors {errs:?}"
        );
    }
}

/// Equivalence preservation (paper §3, Fig. 2): moving the spring from L into the force leaves
/// the discrete trajectory unchanged for every equivalence-preserving discretisation.
#[test]
fn alpha_sweep_is_invariant_for_equivalence_preserving_discretisations() {
    for d in every_discretisation() {
        let reference = trajectory(
            SplitOscillator { alpha: 0.0 },
            NoConstraints,
            options(d.clone(), Flavour::Plus, 0.05),
            &[1.0],
            &[0.0],
            2000,
        );
        let mut worst: f64 = 0.0;
        for i in 1..=10 {
            let alpha = f64::from(i) / 10.0;
            let run = trajectory(
                SplitOscillator { alpha },
                NoConstraints,
                options(d.clone(), Flavour::Plus, 0.05),
                &[1.0],
                &[0.0],
                2000,
            );
            let dev = run
                .iter()
                .zip(&reference)
                .map(|(a, b)| max_diff(&a.0, &b.0) + max_diff(&a.1, &b.1))
                .fold(0.0, f64::max);
            worst = worst.max(dev);
            assert!(dev <= ROUND_OFF, "{d}, alpha = {alpha}: deviation {dev:e}");
        }
        println!("{d}: max deviation over alpha {worst:.2e}");
    }
}

/// Negative control: trapezoid on L_d with midpoint on f_d^± depends on α.
#[test]
fn non_preserving_mix_depends_on_alpha() {
    let mix = Discretisation::non_equivalence_preserving(
        1,
        QuadratureRule::trapezoid(),
        QuadratureRule::midpoint(),
    );
    let run = |alpha| {
        trajectory(
            SplitOscillator { alpha },
            NoConstraints,
            options(mix.clone(), Flavour::Plus, 0.05),
            &[1.0],
            &[0.0],
            2000,
        )
    };
    let (a0, a1) = (run(0.0), run(1.0));
    let dev = a0
        .iter()
        .zip(&a1)
        .map(|(a, b)| max_diff(&a.0, &b.0) + max_diff(&a.1, &b.1))
        .fold(0.0, f64::max);
    assert!(dev > 1e-6, "deviation {dev:e} should be visible");
}

/// Exact discrete power balance of the midpoint rule (MATH §6):
/// E_{k+1} − E_k = −h c v̄_k² with v̄_k = (q_{k+1} − q_k)/h.
#[test]
fn midpoint_power_balance_is_exact() {
    let osc = DampedOscillator {
        m: 1.3,
        k: 0.7,
        c: 0.05,
    };
    let h = 0.1;
    let run = trajectory(
        osc,
        NoConstraints,
        options(Discretisation::midpoint(), Flavour::Plus, h),
        &[1.0],
        &[0.2],
        5000,
    );
    for w in run.windows(2) {
        let (e0, e1) = (
            osc.energy(w[0].0[0], w[0].1[0]),
            osc.energy(w[1].0[0], w[1].1[0]),
        );
        let vbar = (w[1].0[0] - w[0].0[0]) / h;
        let defect = (e1 - e0 + h * osc.c * vbar * vbar).abs();
        assert!(
            defect <= 1e-13 * e0.max(1e-300),
            "defect {defect:e} at E = {e0:e}"
        );
    }
}

/// Negative control for the power balance: the trapezoid rule does not satisfy it exactly.
#[test]
fn trapezoid_power_balance_is_not_exact() {
    let osc = DampedOscillator {
        m: 1.3,
        k: 0.7,
        c: 0.05,
    };
    let h = 0.1;
    let run = trajectory(
        osc,
        NoConstraints,
        options(Discretisation::trapezoid(), Flavour::Plus, h),
        &[1.0],
        &[0.2],
        200,
    );
    let worst = run
        .windows(2)
        .map(|w| {
            let (e0, e1) = (
                osc.energy(w[0].0[0], w[0].1[0]),
                osc.energy(w[1].0[0], w[1].1[0]),
            );
            let vbar = (w[1].0[0] - w[0].0[0]) / h;
            (e1 - e0 + h * osc.c * vbar * vbar).abs() / e0
        })
        .fold(0.0, f64::max);
    assert!(
        worst > 1e-8,
        "trapezoid defect {worst:e} unexpectedly exact"
    );
}

/// Midpoint on an undamped linear system conserves ½p²/m + ½kq² to round-off, and the phase
/// advances by θ with tan(θ/2) = ωh/2 per step.
#[test]
fn midpoint_conserves_quadratic_energy_and_has_exact_phase() {
    let osc = DampedOscillator {
        m: 1.0,
        k: 4.0,
        c: 0.0,
    };
    let h = 0.1;
    let steps = 100_000;
    let run = trajectory(
        osc,
        NoConstraints,
        options(Discretisation::midpoint(), Flavour::Plus, h),
        &[1.0],
        &[0.0],
        steps,
    );
    let e0 = osc.energy(1.0, 0.0);
    let drift = run
        .iter()
        .map(|(q, p)| (osc.energy(q[0], p[0]) - e0).abs() / e0)
        .fold(0.0, f64::max);
    assert!(drift <= 1e-12, "energy drift {drift:e}");
    let theta = 2.0 * (2.0 * h / 2.0_f64).atan();
    let k = 1000;
    let expected = (theta * k as f64).cos();
    assert!(
        (run[k].0[0] - expected).abs() <= 1e-12,
        "{} vs {expected}",
        run[k].0[0]
    );
}

/// Step map `(q0, p0) ↦ (q1, p1)` of the quartic pendulums with damping `c`, h = 0.1.
fn step_map(d: &Discretisation, c: f64, z: &[f64; 4]) -> [f64; 4] {
    let model = QuarticPendulums {
        g: 2.0,
        kappa: 0.5,
        eps: 0.3,
        c,
    };
    let run = trajectory(
        model,
        NoConstraints,
        options(d.clone(), Flavour::Plus, 0.1),
        &z[..2],
        &z[2..],
        1,
    );
    let (q, p) = &run[1];
    [q[0], q[1], p[0], p[1]]
}

/// `max |JᵀΩJ − Ω|` for the Jacobian J of the step map at a fixed state, by fourth-order central
/// differences (truncation ≈ δ⁴, round-off ≈ ε/δ: about 1e-13 at δ = 1e-3).
fn symplecticity_defect(d: &Discretisation, c: f64) -> f64 {
    let z0 = [0.4, -0.3, 0.2, 0.5];
    let delta = 1e-3;
    let mut jac = [[0.0; 4]; 4];
    for col in 0..4 {
        let shifted = |s: f64| {
            let mut z = z0;
            z[col] += s;
            step_map(d, c, &z)
        };
        let (p1, m1, p2, m2) = (
            shifted(delta),
            shifted(-delta),
            shifted(2.0 * delta),
            shifted(-2.0 * delta),
        );
        for row in 0..4 {
            jac[row][col] = (8.0 * (p1[row] - m1[row]) - (p2[row] - m2[row])) / (12.0 * delta);
        }
    }
    let omega = |i: usize, j: usize| -> f64 {
        match (i, j) {
            (0, 2) | (1, 3) => 1.0,
            (2, 0) | (3, 1) => -1.0,
            _ => 0.0,
        }
    };
    let mut defect: f64 = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            let mut s = 0.0;
            for a in 0..4 {
                for b in 0..4 {
                    s += jac[a][i] * omega(a, b) * jac[b][j];
                }
            }
            defect = defect.max((s - omega(i, j)).abs());
        }
    }
    defect
}

/// Largest symplecticity defect accepted: the difference Jacobian's error, measured 0.7e-13 …
/// 2.0e-13 for the four schemes below.
const SYMPLECTIC: f64 = 1e-12;

/// Unforced step maps are symplectic: JᵀΩJ = Ω for the Jacobian J of (q0, p0) ↦ (q1, p1).
#[test]
fn unforced_step_maps_are_symplectic() {
    for d in [
        Discretisation::midpoint(),
        Discretisation::trapezoid(),
        Discretisation::gauss(2),
        Discretisation::lobatto(2),
    ] {
        let defect = symplecticity_defect(&d, 0.0);
        println!("{d}: symplecticity defect {defect:.2e}");
        assert!(defect <= SYMPLECTIC, "{d}: symplecticity defect {defect:e}");
    }
}

/// Negative control for the check above, with the same defect function and tolerance: damping
/// contracts phase-space volume, so the forced map is not symplectic. The defect grows like
/// 0.12·c (measured 5.7e-2 at c = 0.5), so even c = 1e-9 must stay above [`SYMPLECTIC`]: the
/// check resolves departures a hundred times smaller than one in 1e9.
#[test]
fn forced_step_map_is_not_symplectic() {
    for d in [Discretisation::midpoint(), Discretisation::gauss(2)] {
        for c in [0.5, 1e-9] {
            let defect = symplecticity_defect(&d, c);
            println!("{d}, c = {c:e}: symplecticity defect {defect:.2e}");
            assert!(defect > SYMPLECTIC, "{d}, c = {c}: defect {defect:e}");
        }
    }
}

/// A particle in the plane, `L = ½|v|² − V(q)` with `V = ¼r⁴ − ½r² + ½ε x²`: a central
/// potential for ε = 0 (rotation symmetry), an anisotropic one otherwise.
#[derive(Debug, Clone, Copy)]
struct Orbit {
    eps: f64,
}

impl Model for Orbit {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let r2 = q[0] * q[0] + q[1] * q[1];
        0.5 * (v[0] * v[0] + v[1] * v[1])
            - (0.25 * r2 * r2 - 0.5 * r2 + 0.5 * self.eps * q[0] * q[0])
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let s = q[0] * q[0] + q[1] * q[1] - 1.0;
        lq[0] = -s * q[0] - self.eps * q[0];
        lq[1] = -s * q[1];
        lv.copy_from_slice(v);
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        let s = q[0] * q[0] + q[1] * q[1] - 1.0;
        h.qq.add(0, 0, -(s + 2.0 * q[0] * q[0] + self.eps));
        h.qq.add(0, 1, -2.0 * q[0] * q[1]);
        h.qq.add(1, 0, -2.0 * q[0] * q[1]);
        h.qq.add(1, 1, -(s + 2.0 * q[1] * q[1]));
        h.vv.add(0, 0, 1.0);
        h.vv.add(1, 1, 1.0);
    }
}

/// Largest change of the angular momentum `J = x p_y − y p_x` over 2000 steps (h = 0.05) of
/// `orbit` with `options`.
fn angular_momentum_drift(orbit: Orbit, options: dirac::sim::IntegratorOptions) -> f64 {
    let run = trajectory(
        orbit,
        NoConstraints,
        options,
        &[1.2, 0.0],
        &[0.0, 0.8],
        2000,
    );
    let j = |(q, p): &(Vec<f64>, Vec<f64>)| q[0] * p[1] - q[1] * p[0];
    let j0 = j(&run[0]);
    run.iter().map(|s| (j(s) - j0).abs()).fold(0.0, f64::max)
}

/// Round-off allowance for the angular momentum (order one) over 2000 steps: measured up to
/// 2.8e-14 (see the test's output).
const NOETHER: f64 = 1e-12;

/// Discrete Noether theorem: a discrete Lagrangian invariant under rotations (any Galerkin path and
/// quadrature of a central potential, since the path commutes with linear maps) conserves the
/// discrete angular momentum `q_k × p_k` exactly, for every rule and for compositions of them;
/// nothing in the step treats J specially, so this can fail. Negative control: ε = 1e-6 breaks
/// the symmetry and J drifts far beyond [`NOETHER`] (by physics, not by the scheme).
#[test]
fn discrete_noether_conserves_angular_momentum() {
    use dirac::sim::Composition;
    let central = Orbit { eps: 0.0 };
    for d in [
        Discretisation::midpoint(),
        Discretisation::trapezoid(),
        Discretisation::gauss(2),
        Discretisation::lobatto(2),
    ] {
        let drift = angular_momentum_drift(central, options(d.clone(), Flavour::Plus, 0.05));
        let composed = angular_momentum_drift(
            central,
            options(d.clone(), Flavour::Plus, 0.05).composition(Composition::yoshida4()),
        );
        println!("{d}: J drift {drift:.2e}, composed (Yoshida 4) {composed:.2e}");
        assert!(
            drift <= NOETHER && composed <= NOETHER,
            "{d}: {drift:e}, {composed:e}"
        );
    }
    let drift = angular_momentum_drift(
        Orbit { eps: 1e-6 },
        options(Discretisation::midpoint(), Flavour::Plus, 0.05),
    );
    println!("anisotropic ε = 1e-6: J drift {drift:.2e}");
    assert!(drift > 1e3 * NOETHER, "broken symmetry not seen: {drift:e}");
}

/// Automatic (dual-number) and hand-written derivatives agree to 1e-12 on a nonlinear model.
#[test]
fn automatic_and_hand_written_derivatives_agree() {
    let hand = QuarticPendulums {
        g: 9.81,
        kappa: 3.0,
        eps: 0.4,
        c: 0.2,
    };
    let auto = AutoDiff::new(QuarticPendulumsGeneric(hand));
    let points = [
        ([0.3, -1.2], [0.5, 2.0]),
        ([2.0, 0.1], [-1.5, 0.3]),
        ([-0.7, 0.9], [0.0, -2.2]),
    ];
    let dense = |t: &dirac::core::Triplets| {
        let mut m = [[0.0; 2]; 2];
        for (r, c, v) in t.iter() {
            m[r][c] += v;
        }
        m
    };
    for (q, v) in points {
        assert!((hand.lagrangian(&q, &v) - auto.lagrangian(&q, &v)).abs() <= 1e-12);
        let (mut a, mut b, mut c, mut d) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
        hand.lagrangian_gradient(&q, &v, &mut a, &mut b);
        auto.lagrangian_gradient(&q, &v, &mut c, &mut d);
        assert!(max_diff(&a, &c) <= 1e-12 && max_diff(&b, &d) <= 1e-12);
        let (mut hh, mut ha) = (LagrangianHessian::default(), LagrangianHessian::default());
        hand.lagrangian_hessian(&q, &v, &mut hh);
        auto.lagrangian_hessian(&q, &v, &mut ha);
        for (x, y) in [(&hh.qq, &ha.qq), (&hh.qv, &ha.qv), (&hh.vv, &ha.vv)] {
            let (x, y) = (dense(x), dense(y));
            for i in 0..2 {
                assert!(max_diff(&x[i], &y[i]) <= 1e-12, "{x:?} vs {y:?}");
            }
        }
        hand.force(&q, &v, 0.0, &mut a);
        auto.force(&q, &v, 0.0, &mut c);
        assert!(max_diff(&a, &c) <= 1e-12);
        let (mut jh, mut ja) = (ForceJacobian::default(), ForceJacobian::default());
        hand.force_jacobian(&q, &v, 0.0, &mut jh);
        auto.force_jacobian(&q, &v, 0.0, &mut ja);
        for (x, y) in [(&jh.q, &ja.q), (&jh.v, &ja.v)] {
            let (x, y) = (dense(x), dense(y));
            for i in 0..2 {
                assert!(max_diff(&x[i], &y[i]) <= 1e-12);
            }
        }
    }
    // And whole trajectories agree.
    let a = trajectory(
        hand,
        NoConstraints,
        options(Discretisation::gauss(2), Flavour::Plus, 0.05),
        &[0.3, -0.2],
        &[0.0, 0.4],
        400,
    );
    let b = trajectory(
        auto,
        NoConstraints,
        options(Discretisation::gauss(2), Flavour::Plus, 0.05),
        &[0.3, -0.2],
        &[0.0, 0.4],
        400,
    );
    let dev = a
        .iter()
        .zip(&b)
        .map(|(x, y)| max_diff(&x.0, &y.0).max(max_diff(&x.1, &y.1)))
        .fold(0.0, f64::max);
    assert!(dev <= 1e-12, "trajectory deviation {dev:e}");
}

/// Yoshida's compositions of the (symmetric) midpoint step raise its order to 4, 6 and 8 on the
/// damped oscillator (the forced midpoint rule is symmetric, so the composition theorem applies
/// with forces too). Fitted slopes within ±0.25 of the theory; the single step (first row) is the
/// control that stays at order 2.
#[test]
fn compositions_of_midpoint_reach_orders_four_six_eight() {
    use dirac::sim::Composition;
    let osc = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 0.2,
    };
    let t_end = 4.0;
    for (composition, steps) in [
        (Composition::single(), vec![40, 80, 160, 320]),
        (Composition::yoshida4(), vec![10, 20, 40, 80]),
        (Composition::yoshida6(), vec![12, 16, 24, 32]),
        (Composition::yoshida8(), vec![20, 24, 30, 40]),
    ] {
        let errs: Vec<f64> = steps
            .iter()
            .map(|&n| {
                let h = t_end / n as f64;
                let run = trajectory(
                    osc,
                    NoConstraints,
                    options(Discretisation::midpoint(), Flavour::Plus, h)
                        .composition(composition.clone()),
                    &[1.0],
                    &[0.0],
                    n,
                );
                let (q, p) = &run[n];
                let (qe, pe) = osc.exact(1.0, 0.0, t_end);
                (q[0] - qe).abs().max((p[0] - pe).abs())
            })
            .collect();
        let hs: Vec<f64> = steps.iter().map(|&n| t_end / n as f64).collect();
        let slope = fitted_slope(&hs, &errs);
        let r = composition.order() as f64;
        println!(
            "{} stages: slope {slope:.3} (order {r}), errors {errs:?}",
            composition.gammas().len()
        );
        assert!(
            errs.iter().all(|e| *e > 1e-13),
            "errors reach round-off {errs:?}"
        );
        assert!(
            (slope - r).abs() <= 0.25,
            "slope {slope:.3}, expected {r}: {errs:?}"
        );
    }
}
