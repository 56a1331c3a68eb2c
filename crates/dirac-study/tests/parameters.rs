//! Parameters set by name reach the model: the seed RLC netlist with `C1.c` changed from 3 F to
//! 1 F converges at order 2 to the exact charge of the changed loop,
//! q(t) = C·V₀ e^{−γt}(cos ω t + γ/ω sin ω t), γ = R/2L, ω = √(1/LC − γ²) (V₀ = 1 V, its `IC`):
//! halving h divides the error by 4 (measured 1.77e-3 → 4.43e-4, ratio 4.00). Had the change not
//! reached the circuit, the error against the changed loop's solution would not shrink at all.
//! A sweep's points are single runs of the changed model, and its shards tile the plan.

use dirac_study::{Model, Plan, RunSettings, Sweep};

const SEED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/netlists/seed_rlc.cir"
);

/// Order 2: the error ratio on halving h is 4 up to the O(h⁴) term (measured 4.00).
const RATIO_TOLERANCE: f64 = 0.1;

fn charge_error(model: &Model, h: f64, c: f64) -> f64 {
    let settings = RunSettings {
        h: Some(h),
        signals: Some(vec!["q(c1)".into()]),
        ..RunSettings::default()
    };
    let (trajectory, _) = model.run(&settings).expect("the seed loop runs");
    let (l, r) = (0.75, 0.1);
    let gamma = r / (2.0 * l);
    let omega = (1.0 / (l * c) - gamma * gamma).sqrt();
    (0..trajectory.len())
        .map(|k| {
            let t = trajectory.t()[k];
            let exact =
                c * (-gamma * t).exp() * ((omega * t).cos() + gamma / omega * (omega * t).sin());
            (trajectory.row(k)[0] - exact).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_changed_capacitance_converges_to_the_changed_loop() {
    let mut model = Model::from_file(SEED).expect("the seed netlist reads");
    assert_eq!(model.parameter("C1.c").expect("C1.c exists"), 3.0);
    model
        .set_parameter("C1.c", 1.0)
        .expect("1 F is a capacitance");
    assert_eq!(model.overrides(), [("C1.c".to_string(), 1.0)]);
    let coarse = charge_error(&model, 0.05, 1.0);
    let fine = charge_error(&model, 0.025, 1.0);
    assert!(
        (coarse / fine - 4.0).abs() < RATIO_TOLERANCE,
        "errors {coarse:e}, {fine:e}: ratio {}",
        coarse / fine
    );
    assert!(model.set_parameter("C1.c", -1.0).is_err());
    assert!(model.set_parameter("C9.c", 1.0).is_err());
}

#[test]
fn sweep_points_are_single_runs_and_shards_tile_the_plan() {
    let model = Model::from_file(SEED).expect("the seed netlist reads");
    let plan = Plan::grid(&[
        "R1.r=0.1,0.5".parse().expect("an axis"),
        "C1.c=1,3".parse().expect("an axis"),
    ])
    .expect("a plan");
    let settings = RunSettings {
        t_end: Some(5.0),
        ..RunSettings::default()
    };
    let sweep = Sweep::new(model.clone(), plan.clone(), settings.clone(), None).expect("a sweep");
    for (k, point) in plan.points().iter().enumerate() {
        let row = &sweep.run_point(k).expect("the point runs")[0];
        let single = model
            .with_parameters(plan.names(), point)
            .expect("the point's model")
            .run(&settings)
            .expect("the run")
            .0;
        let last = single.row(single.len() - 1);
        assert_eq!(row[0], k as f64);
        assert_eq!(&row[1..3], point.as_slice());
        assert_eq!(&row[3..], last, "point {k}");
    }
    let tiles: Vec<_> = (0..3).map(|i| plan.shard(i, 3).expect("a shard")).collect();
    assert_eq!(tiles.first().map(|r| r.start), Some(0));
    assert_eq!(tiles.last().map(|r| r.end), Some(plan.len()));
    assert!(tiles.windows(2).all(|w| w[0].end == w[1].start));
}

/// A top-level `.param` is set by its own name, and every expression that uses it follows: an
/// NMOS (`VTO = 0.7`, `KP = 110u`, `LAMBDA = 0.04`, `L = 1u`) with `W = {wn}` pulls its 10 kΩ load
/// from 3.3 V; at `wn` = 1, 2 and 4 µm its drain sits at ngspice-39's `.op` values 2.907068,
/// 2.524899 and 1.791124 V (the deck with `.param wn=` changed, 7 digits). An element value set
/// before the `.param` (the load) survives the text's second reading; an unknown name lists
/// the `.param` names. The card's own `W` set by name (`M1.w`) reads the same values.
#[test]
fn a_param_sets_every_expression_that_uses_it() {
    let deck = "* nmos with W from a param\n.param wn=2u\n.param wd={wn}\n\
                .model nch NMOS (LEVEL=1 VTO=0.7 KP=110u LAMBDA=0.04)\n\
                VDD vdd 0 3.3\nVG g 0 1.5\nRL vdd d 10k\nM1 d g 0 0 nch L=1u W={wd}\n.op\n.end\n";
    let model = Model::netlist(deck, "mosw.cir").expect("reads");
    let drain = |m: &Model| {
        m.operating_point()
            .expect("operating point")
            .values
            .into_iter()
            .find(|(n, _)| n == "v(d)")
            .map(|(_, v)| v)
            .expect("v(d)")
    };
    for (w, ngspice) in [(1e-6, 2.907068), (2e-6, 2.524899), (4e-6, 1.791124)] {
        let set = model
            .with_parameters(&["wn".into()], &[w])
            .expect("wn is a .param");
        let v = drain(&set);
        assert!(
            (v / ngspice - 1.0).abs() < 1e-6,
            "wn = {w}: {v} against {ngspice}"
        );
    }
    // The load doubled first, then the width: both hold (a 20 kΩ load at W = 1 µm reads less
    // than 2.907068 V).
    let both = model
        .with_parameters(&["RL.r".into(), "wn".into()], &[20e3, 1e-6])
        .expect("both set");
    assert_eq!(both.overrides().len(), 2);
    assert!(drain(&both) < 2.9, "{}", drain(&both));
    let unknown = model
        .with_parameters(&["wx".into()], &[1e-6])
        .expect_err("no such parameter")
        .to_string();
    assert!(unknown.contains(".param names wn, wd"), "{unknown}");
    // The card's own width, set by name (`M1.w`), reads the same values.
    let card = Model::netlist(&deck.replace("W={wd}", "W=2u"), "mosw2.cir").expect("reads");
    for (w, ngspice) in [(1e-6, 2.907068), (4e-6, 1.791124)] {
        let set = card
            .with_parameters(&["M1.w".into()], &[w])
            .expect("M1.w is an instance parameter");
        let v = drain(&set);
        assert!(
            (v / ngspice - 1.0).abs() < 1e-6,
            "M1.w = {w}: {v} against {ngspice}"
        );
    }
    let zero = card
        .with_parameters(&["M1.w".into()], &[0.0])
        .expect_err("W = 0")
        .to_string();
    assert!(zero.contains("must be positive"), "{zero}");
}
