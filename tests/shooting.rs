//! Shooting discretisation (paper §3): observed orders, equivalence preservation under the
//! α-split of a spring, and the step Jacobian against finite differences.

use dirac::core::{OneStepMap, QuadratureRule, ShootingDiscretisation, ShootingStep};
use dirac::sim::ShootingIntegrator;
use dirac_problems::{ArtificialPotential, DampedOscillator, SplitOscillator};

const OSCILLATOR: DampedOscillator = DampedOscillator {
    m: 1.0,
    k: 1.0,
    c: 0.01,
};

/// Error norm of (q, p) at t = 5T on the damped oscillator (q0 = 1, p0 = 0), h = T/n.
fn error_at_five_periods(discretisation: &ShootingDiscretisation, n: usize) -> f64 {
    let h = OSCILLATOR.period() / n as f64;
    let mut sim = ShootingIntegrator::new(OSCILLATOR, discretisation.clone(), h).unwrap();
    sim.set_state([1.0], [0.0], 0.0);
    for _ in 0..5 * n {
        sim.step().unwrap();
    }
    let (qe, pe) = OSCILLATOR.exact(1.0, 0.0, sim.t());
    (sim.q()[0] - qe).hypot(sim.p()[0] - pe)
}

/// Least-squares slope of log(error) against log(h).
fn fitted_order(discretisation: &ShootingDiscretisation, steps: &[usize]) -> f64 {
    let pts: Vec<(f64, f64)> = steps
        .iter()
        .map(|&n| {
            (
                (1.0 / n as f64).ln(),
                error_at_five_periods(discretisation, n).ln(),
            )
        })
        .collect();
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let num: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let den: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    num / den
}

fn assert_order(name: &str, discretisation: ShootingDiscretisation, expected: f64) {
    let slope = fitted_order(&discretisation, &[20, 40, 80, 160]);
    eprintln!("{name}: fitted order {slope:.4}");
    assert!(
        (slope - expected).abs() <= 0.2,
        "{name}: fitted order {slope} vs {expected}"
    );
}

#[test]
fn trapezoid_taylor2_is_second_order() {
    assert_order(
        "trap-taylor2",
        ShootingDiscretisation::trapezoid_taylor2(),
        2.0,
    );
}

#[test]
fn simpson_taylor4_is_fourth_order() {
    assert_order(
        "simpson-taylor4",
        ShootingDiscretisation::simpson_taylor4(),
        4.0,
    );
}

#[test]
fn simpson_rk4_is_fourth_order() {
    // min(p, q) = min(4, 4).
    assert_order(
        "simpson-rk4",
        ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::simpson()),
        4.0,
    );
}

#[test]
fn trapezoid_rk4_is_second_order() {
    // min(p, q) = min(4, 2): the quadrature limits the order.
    assert_order(
        "trap-rk4",
        ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::trapezoid()),
        2.0,
    );
}

#[test]
fn system_taylor_maps_have_the_same_orders() {
    assert_order(
        "trap-taylor2-system",
        ShootingDiscretisation::new(OneStepMap::Taylor2System, QuadratureRule::trapezoid()),
        2.0,
    );
    assert_order(
        "simpson-taylor4-system",
        ShootingDiscretisation::new(OneStepMap::Taylor4System, QuadratureRule::simpson()),
        4.0,
    );
}

/// Trajectory `(q, p)` of the α-split oscillator, q0 = 1, p0 = 0, h = 0.05.
fn split_run(alpha: f64, discretisation: &ShootingDiscretisation, steps: usize) -> Vec<(f64, f64)> {
    let mut sim =
        ShootingIntegrator::new(SplitOscillator { alpha }, discretisation.clone(), 0.05).unwrap();
    sim.set_state([1.0], [0.0], 0.0);
    let mut out = Vec::new();
    sim.run(steps, |_, _, q, p| out.push((q[0], p[0]))).unwrap();
    out
}

fn max_deviation(a: &[(f64, f64)], b: &[(f64, f64)]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x.0 - y.0).abs() + (x.1 - y.1).abs())
        .fold(0.0, f64::max)
}

/// Paper Figure 2: the equivalence-preserving construction gives the same (q, p) whatever part of
/// the spring is written as a force; trapezoid L_d with midpoint f_d^± does not.
#[test]
fn alpha_sweep_equivalence() {
    let steps = 2000;
    let ep = ShootingDiscretisation::new(OneStepMap::Taylor2, QuadratureRule::trapezoid());
    assert!(ep.is_equivalence_preserving());
    let non_ep = ShootingDiscretisation::non_equivalence_preserving(
        OneStepMap::Taylor2,
        QuadratureRule::trapezoid(),
        QuadratureRule::midpoint(),
    );
    assert!(!non_ep.is_equivalence_preserving());
    let reference = split_run(0.0, &ep, steps);
    for alpha in [0.3, 0.7, 1.0] {
        let dev = max_deviation(&split_run(alpha, &ep, steps), &reference);
        eprintln!("ep α = {alpha}: deviation {dev:.2e}");
        assert!(dev <= 1e-12, "ep α = {alpha}: {dev:e}");
    }
    let reference = split_run(0.0, &non_ep, steps);
    let dev = max_deviation(&split_run(1.0, &non_ep, steps), &reference);
    assert!(dev > 1e-6, "non-ep α = 1 should disagree: {dev:e}");
}

/// Paper Figure 3: with the same rule on L_d and f_d^±, the artificial potential cancels exactly:
/// the run equals the plain oscillator's (`L = ½v² − ½q²`, no force) to round-off. (For this
/// undamped unit oscillator trapezoid + RK4 shooting happens to converge like h⁴: 5.1e-6 at
/// h = 0.05, 3.2e-7 at h = 0.025.)
#[test]
fn artificial_potential_cancels_with_equivalence_preserving_rk4() {
    let ep = ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::trapezoid());
    let run = |artificial: bool| {
        let mut out = Vec::new();
        let mut record = |_: usize, t: f64, q: &[f64; 1], p: &[f64; 1]| out.push((t, q[0], p[0]));
        if artificial {
            let mut sim =
                ShootingIntegrator::new(ArtificialPotential { a: 100.0 }, ep.clone(), 0.05)
                    .unwrap();
            sim.set_state([1.0], [0.0], 0.0);
            sim.run(2000, &mut record).unwrap();
        } else {
            let mut sim =
                ShootingIntegrator::new(SplitOscillator { alpha: 0.0 }, ep.clone(), 0.05).unwrap();
            sim.set_state([1.0], [0.0], 0.0);
            sim.run(2000, &mut record).unwrap();
        }
        out
    };
    let (with, without) = (run(true), run(false));
    let max_err = with
        .iter()
        .map(|x| (x.1 - x.0.cos()).abs())
        .fold(0.0, f64::max);
    assert!(max_err < 1e-5, "{max_err}");
    let dev = with
        .iter()
        .zip(&without)
        .map(|(a, b)| (a.1 - b.1).abs() + (a.2 - b.2).abs())
        .fold(0.0, f64::max);
    eprintln!("artificial vs plain oscillator: {dev:e}");
    assert!(dev < 1e-11, "artificial potential did not cancel: {dev:e}");
}

/// Largest relative difference between the step Jacobian and a central difference of the
/// residual with δ = 1e-6: the difference quotient's round-off (about ε·|r|/δ ≈ 1e-10) dominates;
/// measured 6.5e-11 (see the test's output).
const JACOBIAN: f64 = 5e-9;

/// The step Jacobian used by Newton against central differences of the residual, on a nonlinear
/// model with a force (every map, equivalence-preserving and not).
#[test]
fn step_jacobian_matches_finite_differences() {
    let model = ArtificialPotential { a: 3.0 };
    let damped = OSCILLATOR;
    let mut worst = 0.0_f64;
    for map in [OneStepMap::Taylor2, OneStepMap::Taylor4, OneStepMap::Rk4] {
        for d in [
            ShootingDiscretisation::new(map, QuadratureRule::trapezoid()),
            ShootingDiscretisation::new(map, QuadratureRule::simpson()),
            ShootingDiscretisation::non_equivalence_preserving(
                map,
                QuadratureRule::simpson(),
                QuadratureRule::midpoint(),
            ),
        ] {
            let mut step = ShootingStep::<1>::new(d.clone(), 0.1).unwrap();
            step.set_start(&[0.6], &[0.3], 0.0);
            let q1 = [0.62];
            let e = 1e-6;
            let (_, jac) = step.residual_and_jacobian(&model, &q1).unwrap();
            let fd = (step.residual(&model, &[q1[0] + e]).unwrap()[0]
                - step.residual(&model, &[q1[0] - e]).unwrap()[0])
                / (2.0 * e);
            let rel = (jac[0][0] - fd).abs() / (1.0 + fd.abs());
            worst = worst.max(rel);
            assert!(rel < JACOBIAN, "{d}: {} vs {fd}", jac[0][0]);
            let (_, jac) = step.residual_and_jacobian(&damped, &q1).unwrap();
            let fd = (step.residual(&damped, &[q1[0] + e]).unwrap()[0]
                - step.residual(&damped, &[q1[0] - e]).unwrap()[0])
                / (2.0 * e);
            let rel = (jac[0][0] - fd).abs() / (1.0 + fd.abs());
            worst = worst.max(rel);
            assert!(rel < JACOBIAN, "{d}: {} vs {fd}", jac[0][0]);
        }
    }
    eprintln!("step Jacobian vs central differences: largest relative difference {worst:.2e}");
}

mod allocations {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static COUNT: Cell<usize> = const { Cell::new(0) };
    }

    /// Counts allocations made by the current thread (tests run on several threads).
    struct Counting;

    // SAFETY: forwards to the system allocator; the counter is a const-initialised thread-local.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
            // SAFETY: same contract as the caller's.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: same contract as the caller's.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    pub fn count() -> usize {
        COUNT.with(Cell::get)
    }
}

/// After the first step (Newton sizes its buffers), stepping does not allocate.
#[test]
fn step_loop_does_not_allocate() {
    let c0 = allocations::count();
    let probe = std::hint::black_box(vec![1u8; 16]);
    assert!(
        allocations::count() > c0,
        "the allocation counter does not count"
    );
    drop(probe);
    let model = ArtificialPotential { a: 3.0 };
    for d in [
        ShootingDiscretisation::trapezoid_taylor2(),
        ShootingDiscretisation::simpson_taylor4(),
        ShootingDiscretisation::new(OneStepMap::Rk4, QuadratureRule::simpson()),
    ] {
        let mut sim = ShootingIntegrator::new(model, d.clone(), 0.05).unwrap();
        sim.set_state([0.5], [0.0], 0.0);
        sim.step().unwrap();
        let before = allocations::count();
        for _ in 0..50 {
            sim.step().unwrap();
        }
        assert_eq!(
            allocations::count() - before,
            0,
            "{d} allocated in the step loop"
        );
    }
}
