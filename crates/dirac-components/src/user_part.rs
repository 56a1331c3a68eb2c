//! A user-written part: `L(q, v)` and `f(q, v, t)` only, derivatives by `dirac_core::AutoDiff`,
//! used as a subsystem beside stock parts.

use std::f64::consts::PI;

use dirac_core::{AutoDiff, Discretisation, GenericModel};
use dirac_graph::{Interconnection, Representation, Subsystem};
use dirac_sim::IntegratorOptions;
use num_dual::DualNum;

use crate::mechanical::{Damper, ForceSource, Mass, Spring};
use crate::testing::Run;
use crate::waveform::Waveform;

/// Driven, damped Duffing oscillator written by a user in a few lines:
/// `L = ½ m v² − ½ k q² − ¼ k₃ q⁴`, `f = −c v + A sin(2π f t)`.
struct DrivenDuffing {
    m: f64,
    k: f64,
    k3: f64,
    c: f64,
    amplitude: f64,
    frequency: f64,
}

impl GenericModel<1> for DrivenDuffing {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 1], v: &[D; 1]) -> D {
        v[0] * v[0] * (0.5 * self.m)
            - q[0] * q[0] * (0.5 * self.k)
            - q[0].powi(4) * (0.25 * self.k3)
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force<D: DualNum<Primitive = f64> + Copy>(&self, _q: &[D; 1], v: &[D; 1], t: f64) -> [D; 1] {
        [v[0] * (-self.c) + D::from(self.amplitude * (2.0 * PI * self.frequency * t).sin())]
    }
}

const USER: DrivenDuffing = DrivenDuffing {
    m: 1.5,
    k: 2.0,
    k3: 0.8,
    c: 0.1,
    amplitude: 0.7,
    frequency: 0.3,
};

/// Adds a second (stock) mass coupled to port `x` of subsystem `to` by a stock spring.
fn with_partner(g: &mut Interconnection, to: &str) {
    g.add_subsystem(Mass::new(0.5).unwrap().subsystem("M2"))
        .unwrap();
    let (a, b) = (g.port(to, "x").unwrap(), g.port("M2", "x").unwrap());
    g.coupling("k12", a, b, Spring::new(3.0, 0.0, -0.5).unwrap());
}

/// The user's part (AutoDiff of a `GenericModel`) coupled by a stock spring to a stock mass
/// follows the same trajectory, to 1e-12 over 2000 midpoint steps, as the hand-written
/// equivalent built from stock parts (a mass, a Duffing spring, a damper and a SIN force source,
/// each to ground and joined at one port): positions, and the user part's momentum against the
/// joint momentum `p_M + p_S + p_D + p_F` of the stock assembly (MATH §6: constraint impulses cancel in the
/// sum). The AutoDiff part works in all three representations.
#[test]
fn autodiff_part_matches_stock_equivalent() {
    let (x1, x2, h, steps) = (0.3, 1.0, 0.01, 2000);
    let mut user = Interconnection::new();
    user.add_subsystem(Subsystem::new("U", AutoDiff::new(USER)).with_port("x", 0))
        .unwrap();
    with_partner(&mut user, "U");

    let mut stock = Interconnection::new();
    let u = USER;
    stock
        .add_subsystem(Mass::new(u.m).unwrap().subsystem("M"))
        .unwrap();
    stock
        .add_subsystem(Spring::cubic(u.k, u.k3).unwrap().subsystem("S"))
        .unwrap();
    stock
        .add_subsystem(Damper::new(u.c).unwrap().subsystem("D"))
        .unwrap();
    stock
        .add_subsystem(
            ForceSource::new(Waveform::sin(0.0, u.amplitude, u.frequency))
                .unwrap()
                .subsystem("F"),
        )
        .unwrap();
    for part in ["S", "D", "F"] {
        let (a, b) = (
            stock.port("M", "x").unwrap(),
            stock.port(part, "x").unwrap(),
        );
        stock.joint(format!("M-{part}"), a, b);
    }
    with_partner(&mut stock, "M");

    let options = IntegratorOptions::new(Discretisation::midpoint(), h);
    let mut reference = Run::new(
        &stock,
        Representation::Monolithic,
        options.clone(),
        &[vec![x1], vec![x1], vec![x1], vec![x1], vec![x2]],
    );
    let mut reference_states = Vec::with_capacity(steps);
    for _ in 0..steps {
        reference.step();
        let p = (0..4).map(|s| reference.p(s, 0)).sum::<f64>();
        reference_states.push([reference.q(0, 0), reference.q(4, 0), p]);
    }
    for rep in [
        Representation::Monolithic,
        Representation::Constraint,
        Representation::InteractionForce,
    ] {
        let mut run = Run::new(&user, rep, options.clone(), &[vec![x1], vec![x2]]);
        let (mut dq, mut dp): (f64, f64) = (0.0, 0.0);
        for r in &reference_states {
            run.step();
            let momenta = run.system().subsystem_momenta(run.integrator().p());
            dq = dq
                .max((run.q(0, 0) - r[0]).abs())
                .max((run.q(1, 0) - r[1]).abs());
            dp = dp.max((momenta[0] - r[2]).abs());
        }
        println!("AutoDiff part ({rep}) vs stock equivalent: max |Δx| {dq:.2e}, max |Δp| {dp:.2e}");
        assert!(dq < 1e-12 && dp < 1e-12, "{rep}: {dq:e} {dp:e}");
    }
}
