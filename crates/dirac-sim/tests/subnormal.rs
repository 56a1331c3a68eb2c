//! A damped oscillator decays towards rest exponentially: after about 700/γ time units its state
//! falls below the smallest normal double (2.2e-308). The midpoint step then does not reach exact
//! rest but cycles among subnormal numbers, where every operation costs several times more (the
//! damped seed loop in the soak: 3.44 µs per step against 0.80). The integrator sets a subnormal
//! state component to zero, so the state reaches exact rest and stays there; nothing above the
//! subnormal range changes.
//!
//! Mutation: without the flush in `Integrator::step` the state holds subnormal values from about
//! step 14 063 on (−1.17e-308) and is never exactly zero (the assertion on the first subnormal fails).

use dirac_core::NoConstraints;
use dirac_problems::DampedOscillator;
use dirac_sim::{Discretisation, Integrator, IntegratorOptions};

#[test]
fn a_decayed_state_reaches_exact_rest_without_subnormals() {
    // γ = c/2m = 0.5: the amplitude passes 1e-308 near t = 1420, step 14 200 at h = 0.1.
    let model = DampedOscillator {
        m: 1.0,
        k: 1.0,
        c: 1.0,
    };
    let options = IntegratorOptions::new(Discretisation::midpoint(), 0.1);
    let mut sim = Integrator::new(model, NoConstraints, options).unwrap();
    sim.initialise(&[1.0], &[0.0], 0.0).unwrap();
    let mut at_rest = None;
    for k in 1..=20_000 {
        sim.step().unwrap();
        let state = sim.q().iter().chain(sim.p());
        if let Some(v) = state.clone().find(|v| v.is_subnormal()) {
            panic!("step {k}: subnormal state component {v:e}");
        }
        if at_rest.is_none() && state.clone().all(|v| *v == 0.0) {
            at_rest = Some(k);
        }
        if at_rest.is_some() {
            assert!(state.clone().all(|v| *v == 0.0), "step {k}: left rest");
        }
    }
    let at_rest = at_rest.expect("the state reaches exact rest within 20 000 steps");
    println!("at rest from step {at_rest}");
    // Not before the amplitude e^{−t/2} reaches the normal range's floor (t ≈ 1417).
    assert!(at_rest > 14_000, "at rest from step {at_rest}");
}
