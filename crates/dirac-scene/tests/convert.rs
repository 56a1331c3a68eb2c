//! `dirac convert`: a netlist written as a scene runs to the same trajectory.

use dirac_graph::Representation;
use dirac_netlist::{ControlledSource, Element, Netlist, build_circuit, parse_netlist};
use dirac_scene::{Scene, netlist_to_scene};
use dirac_sim::{Discretisation, Execution, IntegratorOptions, Signal, Simulation};

/// Every bundled netlist converts to a scene that runs to the same charges and currents (the
/// diode netlists with their whole card: `diode_pulse_charge.cir`'s junction charge acts from its
/// first edge at step 100, so each run goes to `t_end` or 1000 steps).
#[test]
fn converted_scenes_reproduce_their_netlists() {
    let dir = format!("{}/../../examples/netlists", env!("CARGO_MANIFEST_DIR"));
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("netlists") {
        let path = entry.expect("entry").path();
        let file = path.display().to_string();
        let net = parse_netlist(&std::fs::read_to_string(&path).unwrap(), &file).unwrap();
        if net.tran.is_none() {
            // An `.op`-only netlist has no step: convert refuses it, naming the missing card.
            let e = netlist_to_scene(&net, &file).unwrap_err();
            assert!(e.to_string().contains("no .tran"), "{e}");
            continue;
        }
        let behavioural = net.elements.iter().zip(&net.origins).find(|(e, _)| {
            matches!(
                e,
                Element::Controlled {
                    source: ControlledSource::Behavioural { .. } | ControlledSource::Mosfet { .. },
                    ..
                }
            )
        });
        if let Some((_, origin)) = behavioural {
            // A behavioural source or a MOSFET has no scene part: convert refuses it at its card.
            let e = netlist_to_scene(&net, &file).unwrap_err().to_string();
            let place = format!(
                "{file}:{}:{}: `{}`",
                origin.line, origin.column, origin.name
            );
            assert!(e.starts_with(&place), "{e}");
            continue;
        }
        reproduces(&net, &file);
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} netlists");
}

/// Runs a netlist and its converted scene side by side and compares every charge and current.
fn reproduces(net: &Netlist, file: &str) {
    let circuit = build_circuit(net, file).unwrap();
    let toml = netlist_to_scene(net, file).unwrap_or_else(|e| panic!("{file}: {e}"));
    let built = Scene::parse(&toml, "converted.toml")
        .unwrap()
        .build()
        .unwrap();
    // Columns q(x) and i(x) of the netlist are x.q and x.i (or K.i1/K.i2) of the scene.
    let mut pairs = Vec::new();
    for s in &circuit.signals {
        let Some(inner) = s
            .name
            .strip_prefix("q(")
            .or_else(|| s.name.strip_prefix("i("))
        else {
            continue;
        };
        let element = inner.trim_end_matches(')');
        let coupled = net.elements.iter().find_map(|e| match e {
            Element::K { name, l1, l2, .. } if l1 == element => {
                Some(format!("{}.i1", name.replace('.', "_")))
            }
            Element::K {
                name, l1: _, l2, ..
            } if l2 == element => Some(format!("{}.i2", name.replace('.', "_"))),
            _ => None,
        });
        let scene_name = coupled.unwrap_or_else(|| {
            format!(
                "{}.{}",
                element.replace('.', "_"),
                if s.name.starts_with('q') { "q" } else { "i" }
            )
        });
        pairs.push((
            s.clone(),
            built
                .signal(&scene_name)
                .unwrap_or_else(|e| panic!("{file}: {e}")),
        ));
    }
    let (ours, theirs): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
    let (h, t_end) = circuit.tran_settings().unwrap();
    let duration = t_end.min(1000.0 * h);
    let options = IntegratorOptions::new(Discretisation::midpoint(), h);
    let execution = Execution::Assembled(Representation::Monolithic);
    let collect = |mut sim: Simulation, signals: &[Signal]| {
        let (run, _) = sim
            .run(duration, signals)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        (0..run.len())
            .map(|k| run.row(k).to_vec())
            .collect::<Vec<_>>()
    };
    let a = collect(
        circuit
            .simulation(execution, options.clone(), circuit.start())
            .unwrap(),
        &ours,
    );
    let b = collect(
        built
            .simulation_with(execution, options, built.start)
            .unwrap(),
        &theirs,
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        for (u, v) in x.iter().zip(y) {
            assert!(
                (u - v).abs() <= 1e-12 * (1.0 + u.abs()),
                "{file}: {u} vs {v}"
            );
        }
    }
}

/// A diode with breakdown, temperature coefficients, its own `TNOM`, a circuit
/// temperature and `GMIN` converts to a scene that runs through breakdown to the same trajectory.
#[test]
fn converted_breakdown_diode_reproduces_its_netlist() {
    let text = "Zener under a 10 V sine at 60 °C, GMIN raised
V1 in 0 SIN(0 10 1k)
R1 in a 100
D1 0 a dz
C1 a 0 10n
.model dz D(IS=2e-14 N=1.2 RS=2 CJO=5p VJ=0.8 M=0.35 FC=0.4 TT=20n BV=5.1 IBV=2m NBV=1.5 EG=1.2 XTI=2.5 TNOM=30 TCV=1m TRS1=2m TRS2=1e-5 TTT1=1m TTT2=1e-6 TM1=1e-3 TM2=1e-6)
.temp 60
.options gmin=1e-10
.tran 10u 1m
.end
";
    let net = parse_netlist(text, "zener.cir").unwrap();
    let toml = netlist_to_scene(&net, "zener.cir").unwrap();
    for key in [
        "is = 2e-14",
        "n = 1.2",
        "rs = 2.0",
        "cjo = 5e-12",
        "vj = 0.8",
        "m = 0.35",
        "fc = 0.4",
        "tt = 2e-8",
        "bv = 5.1",
        "ibv = 0.002",
        "nbv = 1.5",
        "eg = 1.2",
        "xti = 2.5",
        "tcv = 0.001",
        "trs1 = 0.002",
        "trs2 = 1e-5",
        "ttt1 = 0.001",
        "ttt2 = 1e-6",
        "tm1 = 0.001",
        "tm2 = 1e-6",
        "temp = 60.0",
        "tnom = 30.0",
        "gmin = 1e-10",
    ] {
        assert!(
            toml.contains(&format!("\n{key}\n")),
            "{key} missing:\n{toml}"
        );
    }
    reproduces(&net, "zener.cir");
}
