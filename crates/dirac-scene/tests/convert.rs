//! `dirac convert`: a netlist written as a scene runs to the same trajectory.

use dirac_graph::Representation;
use dirac_netlist::{Element, build_circuit, parse_netlist};
use dirac_scene::{Scene, netlist_to_scene};
use dirac_sim::{Discretisation, Execution, IntegratorOptions, Signal, Simulation};

/// Every bundled netlist converts to a scene that runs to the same charges and currents.
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
        let circuit = build_circuit(&net, &file).unwrap();
        let toml = netlist_to_scene(&net, &file).unwrap_or_else(|e| panic!("{file}: {e}"));
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
        let (h, _) = circuit.tran_settings().unwrap();
        let options = IntegratorOptions::new(Discretisation::midpoint(), h);
        let execution = Execution::Assembled(Representation::Monolithic);
        let collect = |mut sim: Simulation, signals: &[Signal]| {
            let (run, _) = sim
                .run(50.0 * h, signals)
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
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} netlists");
}
