//! Observed orders of the stock compositions against an exact solution.
//!
//! The Kepler problem `L = ½|v|² + 1/|q|` (unit gravitational parameter) on an orbit of
//! eccentricity ½ is separable, so the trapezoid rule runs explicitly (Störmer–Verlet) and each
//! [`Composition`] of it must show its order against the closed-form orbit: the position at time
//! `t` from Kepler's equation `E − e sin E = t` (semi-major axis 1, period 2π), solved by Newton
//! iteration to round-off. The errors are measured after one period at two step sizes in the
//! asymptotic range (error between 1e-3 and 1e-11).

use dirac_core::{LagrangianHessian, Model, NoConstraints, Triplets};
use dirac_sim::{Composition, Discretisation, Integrator, IntegratorOptions};
use std::f64::consts::PI;

const ECCENTRICITY: f64 = 0.5;

/// The Kepler problem in the plane, `q = (x, y)`.
#[derive(Debug, Clone, Copy)]
struct Kepler;

impl Model for Kepler {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * (v[0] * v[0] + v[1] * v[1]) + 1.0 / q[0].hypot(q[1])
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let r = q[0].hypot(q[1]);
        let r3 = r * r * r;
        lq[0] = -q[0] / r3;
        lq[1] = -q[1] / r3;
        lv[0] = v[0];
        lv[1] = v[1];
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        let r = q[0].hypot(q[1]);
        let r3 = r * r * r;
        let r5 = r3 * r * r;
        for i in 0..2 {
            for j in 0..2 {
                let delta = if i == j { 1.0 } else { 0.0 };
                h.qq.add(i, j, 3.0 * q[i] * q[j] / r5 - delta / r3);
            }
            h.vv.add(i, i, 1.0);
        }
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn separable(&self) -> Option<Triplets> {
        let mut m = Triplets::new();
        m.add(0, 0, 1.0);
        m.add(1, 1, 1.0);
        Some(m)
    }
}

/// The exact position at time `t`, starting at periapsis `(1 − e, 0)` moving in `+y`.
fn exact(t: f64) -> [f64; 2] {
    let e = ECCENTRICITY;
    let mut big_e = t;
    for _ in 0..50 {
        big_e -= (big_e - e * big_e.sin() - t) / (1.0 - e * big_e.cos());
    }
    [big_e.cos() - e, (1.0 - e * e).sqrt() * big_e.sin()]
}

/// Position error after one period with `steps` composed steps.
fn error(composition: &Composition, steps: usize) -> f64 {
    let period = 2.0 * PI;
    let h = period / steps as f64;
    let options = IntegratorOptions::new(Discretisation::trapezoid(), h)
        .composition(composition.clone())
        .breakpoints(false);
    let mut sim = Integrator::new(Kepler, NoConstraints, options).expect("options");
    let e = ECCENTRICITY;
    let speed = ((1.0 + e) / (1.0 - e)).sqrt();
    sim.initialise(&[1.0 - e, 0.0], &[0.0, speed], 0.0)
        .expect("initial state");
    assert!(sim.uses_explicit(), "Kepler is separable: Störmer–Verlet");
    for _ in 0..steps {
        sim.step().expect("step");
    }
    let want = exact(period);
    let q = sim.q();
    (q[0] - want[0]).hypot(q[1] - want[1])
}

/// Each stock composition of Störmer–Verlet has its order on the Kepler orbit (observed
/// `log₂` of the error ratio when the step halves, within 0.3 of the order), and Kahan–Li's
/// sixth- and eighth-order methods need fewer force evaluations than Yoshida's of the same order
/// to reach the same error (each Kahan–Li error moved to the Yoshida run's error along its own
/// order, a step change of at most 1.5 from a measured run).
#[test]
fn compositions_have_their_order_on_the_kepler_orbit() {
    let cases = [
        (Composition::single(), 2000),
        (Composition::yoshida4(), 400),
        (Composition::yoshida6(), 400),
        (Composition::kahan_li6(), 200),
        (Composition::yoshida8(), 400),
        (Composition::kahan_li8(), 50),
    ];
    // (order, force evaluations of the finer run, its error)
    let mut finer = Vec::new();
    for (composition, steps) in cases {
        let coarse = error(&composition, steps);
        let fine = error(&composition, 2 * steps);
        let observed = (coarse / fine).log2();
        println!(
            "{} stages, order {}: error {coarse:.2e} at {steps} steps, {fine:.2e} at {}: observed order {observed:.2}",
            composition.gammas().len(),
            composition.order(),
            2 * steps
        );
        assert!(
            fine > 1e-11 && coarse < 1e-3,
            "outside the asymptotic range: {coarse:e}, {fine:e}"
        );
        assert!(
            (observed - composition.order() as f64).abs() < 0.3,
            "{} stages: observed order {observed}, expected {}",
            composition.gammas().len(),
            composition.order()
        );
        finer.push((
            composition.order(),
            (2 * steps * composition.gammas().len()) as f64,
            fine,
        ));
    }
    // Evaluations Kahan–Li needs for the Yoshida run's error, against Yoshida's own.
    let needed = |(order, evaluations, err): (usize, f64, f64), target: f64| {
        evaluations * (err / target).powf(1.0 / order as f64)
    };
    for (yoshida, kahan_li) in [(finer[2], finer[3]), (finer[4], finer[5])] {
        let kl = needed(kahan_li, yoshida.2);
        let stretch = kl / kahan_li.1;
        println!(
            "order {}: Yoshida {:.0} evaluations for {:.2e}, Kahan–Li {kl:.0}",
            yoshida.0, yoshida.1, yoshida.2
        );
        assert!(
            (1.0 / 1.5..=1.5).contains(&stretch),
            "extrapolated by {stretch}"
        );
        assert!(kl < yoshida.1, "order {}: {kl} ≥ {}", yoshida.0, yoshida.1);
    }
}
