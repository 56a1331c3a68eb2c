//! The example netlists in `examples/netlists/` parse, with the expected contents.

use std::path::PathBuf;

use dirac_netlist::{Element, Netlist, SourceSpec, parse_netlist};

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/netlists")
}

fn load(name: &str) -> Netlist {
    let path = dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    parse_netlist(&text, name).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn all_example_netlists_parse() {
    let mut names: Vec<String> = std::fs::read_dir(dir())
        .expect("examples/netlists exists")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".cir"))
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    let [
        mut dc,
        mut sin,
        mut pulse,
        mut exp,
        mut pwl,
        mut sffm,
        mut am,
    ] = [false; 7];
    for name in &names {
        let net = load(name);
        // Every bundled netlist has a transient or an operating point; the ones written for the
        // operating-point start (issue 12) say so in their name, and the diode netlists (issue 13)
        // start from theirs as ngspice does.
        match net.tran {
            Some(tran) => assert_eq!(
                tran.uic,
                !name.ends_with("_op.cir")
                    && !name.starts_with("diode_")
                    && name != "rc_lowpass_sine.cir"
                    && name != "rlc_pulse_fast.cir"
                    && name != "rc_fast_coarse_tstep.cir"
                    && name != "opamp_filter.cir"
                    && name != "ccsources.cir"
                    && name != "behavioural.cir"
                    && name != "modulated.cir"
                    && name != "mosfet.cir"
                    && name != "cmos_ring.cir",
                "{name}: UIC"
            ),
            None => assert!(net.op, "{name}: neither .tran nor .op"),
        }
        assert!(!net.nodes().is_empty(), "{name}");
        let has_diode = net.elements.iter().any(|e| matches!(e, Element::D { .. }));
        assert_eq!(
            has_diode,
            name == "rectifier.cir"
                || name.starts_with("diode_")
                || name == "mosfet.cir"
                || name == "cmos_ring.cir",
            "{name}: only the rectifier, the diode_* netlists and the MOSFETs' bulk junctions \
             have diodes"
        );
        for e in &net.elements {
            if let Element::V { source, .. } | Element::I { source, .. } = e {
                match source {
                    SourceSpec::Dc(_) => dc = true,
                    SourceSpec::Sin { .. } => sin = true,
                    SourceSpec::Pulse { .. } => pulse = true,
                    SourceSpec::Exp { .. } => exp = true,
                    SourceSpec::Pwl { .. } => pwl = true,
                    SourceSpec::Sffm { .. } => sffm = true,
                    SourceSpec::Am { .. } => am = true,
                }
            }
        }
        for w in &net.warnings {
            assert!(
                w.message.contains(".options"),
                "{name}: unexpected warning {w}"
            );
        }
    }
    assert!(
        dc && sin && pulse && exp && pwl && sffm && am,
        "every source kind is exercised"
    );
}

#[test]
fn seed_rlc() {
    let net = load("seed_rlc.cir");
    let t = net.tran.expect("tran");
    assert_eq!((t.tstep, t.tstop, t.uic), (0.05, 50.0, true));
    let mut values: Vec<(char, f64, Option<f64>)> = net
        .elements
        .iter()
        .map(|e| match e {
            Element::R { value, .. } => ('R', *value, None),
            Element::L { value, ic, .. } => ('L', *value, *ic),
            Element::C { value, ic, .. } => ('C', *value, *ic),
            other => panic!("{other:?}"),
        })
        .collect();
    values.sort_by_key(|a| a.0);
    assert_eq!(
        values,
        [('C', 3.0, Some(1.0)), ('L', 0.75, None), ('R', 0.1, None)]
    );
}

#[test]
fn rectifier() {
    let net = load("rectifier.cir");
    let diode = net
        .elements
        .iter()
        .find_map(|e| match e {
            Element::D {
                anode,
                cathode,
                model,
                ..
            } => Some((anode, cathode, model)),
            _ => None,
        })
        .expect("a diode");
    assert_eq!((diode.0.as_str(), diode.1.as_str()), ("in", "out"));
    assert_eq!(
        (diode.2.card.is, diode.2.card.n, diode.2.card.rs),
        (1e-14, 1.0, 0.5)
    );
    assert!(
        net.elements
            .iter()
            .any(|e| matches!(e, Element::C { n1, .. } if n1 == "out"))
    );
    assert!(net.elements.iter().any(|e| matches!(
        e,
        Element::V {
            source: SourceSpec::Sin { .. },
            ..
        }
    )));
}

#[test]
fn ladder_subcircuit_expands() {
    let net = load("ladder_subckt.cir");
    assert_eq!(net.nodes(), ["in", "n1", "n2", "n3", "n4"]);
    assert!(matches!(net.element("x3.c1"), Some(Element::C { value, .. }) if *value == 0.5e-6));
}

/// Truncated and mangled netlists give errors, never panics.
#[test]
fn mangled_examples_never_panic() {
    let specials = [
        '(', ')', '{', '}', '=', '+', '*', ';', '\'', ',', '-', '\n', ' ', 'x', '9',
    ];
    for entry in std::fs::read_dir(dir())
        .expect("examples/netlists exists")
        .flatten()
    {
        let text = std::fs::read_to_string(entry.path()).expect("readable");
        let chars: Vec<char> = text.chars().collect();
        for cut in 0..=chars.len() {
            let prefix: String = chars[..cut].iter().collect();
            let _ = parse_netlist(&prefix, "cut.cir");
            let mut mangled = chars.clone();
            if cut < mangled.len() {
                mangled[cut] = specials[cut % specials.len()];
            }
            let _ = parse_netlist(&mangled.iter().collect::<String>(), "mangled.cir");
        }
    }
}
