//! The run layer refuses a method that would blow up on a mode of the model, for every front end
//! (the command line, the Python package, sweeps). The variational trapezoid rule is explicit on
//! a degenerate Lagrangian and multiplies a decay of time constant τ by `1 − h/τ` per step: an
//! RC divider of τ = 0.5 µs at h = 50 µs grows by 99 per step. `Model::prepare_plan` refuses
//! that run as a setting before a step is taken; `RunSettings::force` takes it, and it blows up
//! as the refusal said; the midpoint rule, which damps every decay, is not refused.

use dirac_study::{Method, Model, RunSettings, StudyError};

const FAST_RC: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/netlists/rc_fast_coarse_tstep.cir"
);

fn settings(method: Method, force: bool) -> RunSettings {
    RunSettings {
        method: Some(method),
        signals: Some(vec!["v(out)".into()]),
        force,
        ..RunSettings::default()
    }
}

#[test]
fn a_method_that_amplifies_a_decay_is_refused_by_the_run_layer() {
    let model = Model::from_file(FAST_RC).expect("the netlist reads");
    let trapezoid: Method = "trapezoid".parse().expect("a method");
    let midpoint: Method = "midpoint".parse().expect("a method");
    match model.run(&settings(trapezoid, false)) {
        Err(StudyError::Settings(why)) => {
            assert!(
                why.contains("amplifies the damped mode (in c1.q)") && why.contains("9.900e1"),
                "{why}"
            );
        }
        Err(other) => panic!("refused as a setting, not as {other:?}"),
        Ok(_) => panic!("the trapezoid rule at h = 100 τ must be refused"),
    }
    let (forced, _) = model
        .run(&settings(trapezoid, true))
        .expect("a forced run takes the method");
    let last = forced.column(0)[forced.len() - 1].abs();
    assert!(last > 1e100, "the forced run blows up as refused: {last:e}");
    let (damped, _) = model
        .run(&settings(midpoint, false))
        .expect("the midpoint rule damps every decay");
    assert!(damped.column(0).iter().all(|v| v.abs() <= 0.5 + 1e-9));
}
