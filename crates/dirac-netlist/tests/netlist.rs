//! Netlist front end: every supported feature, and every error kind with its exact position.

use dirac_components::DiodeParameters;
use dirac_netlist::{
    ControlledSource, DiodeModel, Element, ErrorKind, Netlist, Output, Sensing, SourceSpec, Tran,
    parse_netlist,
};

fn parse(src: &str) -> Netlist {
    parse_netlist(src, "t.cir").unwrap_or_else(|e| panic!("{e}"))
}

fn err(src: &str) -> dirac_netlist::NetlistError {
    parse_netlist(src, "t.cir").expect_err("should fail")
}

/// Asserts kind and `line:column` of the error of `src`.
fn assert_err(
    src: &str,
    kind: ErrorKind,
    line: usize,
    column: usize,
) -> dirac_netlist::NetlistError {
    let e = err(src);
    assert_eq!(
        (e.kind, e.line, e.column),
        (kind, line, column),
        "wrong error for {src:?}: {e}"
    );
    assert_eq!(e.file, "t.cir");
    assert!(
        e.to_string()
            .starts_with(&format!("t.cir:{line}:{column}: ")),
        "{e}"
    );
    e
}

fn value_of(net: &Netlist, name: &str) -> f64 {
    match net.element(name) {
        Some(Element::R { value, .. } | Element::L { value, .. } | Element::C { value, .. }) => {
            *value
        }
        other => panic!("{name}: {other:?}"),
    }
}

fn source_of<'a>(net: &'a Netlist, name: &str) -> &'a SourceSpec {
    match net.element(name) {
        Some(Element::V { source, .. } | Element::I { source, .. }) => source,
        other => panic!("{name}: {other:?}"),
    }
}

#[test]
fn rlc_cards_with_initial_conditions() {
    let net = parse(
        "R1 a b 1k is the title, not a card\nR1 N1 gnd 100\nL1 n1 N2 2m IC=0.5\nC1 n2 GND 3u ic=-1\nC2 n2 0 1p\n",
    );
    assert_eq!(net.title, "R1 a b 1k is the title, not a card");
    assert_eq!(
        net.elements,
        vec![
            Element::R {
                name: "r1".into(),
                n1: "n1".into(),
                n2: "0".into(),
                value: 100.0
            },
            Element::L {
                name: "l1".into(),
                n1: "n1".into(),
                n2: "n2".into(),
                value: 2e-3,
                ic: Some(0.5)
            },
            Element::C {
                name: "c1".into(),
                n1: "n2".into(),
                n2: "0".into(),
                value: 3e-6,
                ic: Some(-1.0)
            },
            Element::C {
                name: "c2".into(),
                n1: "n2".into(),
                n2: "0".into(),
                value: 1e-12,
                ic: None
            },
        ]
    );
    assert_eq!(net.nodes(), ["n1", "n2"]);
    assert_eq!(net.origins[0].name, "R1");
    assert_eq!((net.origins[2].line, net.origins[2].column), (4, 1));
    assert!(net.tran.is_none());
    assert!(net.warnings.is_empty());
}

#[test]
fn engineering_suffixes_and_unit_letters() {
    let net = parse(
        "suffixes\nC1 a 0 10uF\nR1 a b 1meg\nR2 b c 1m\nR3 c d 2.2k\nR4 d e 1e-3\nR5 e f 1kOhm\nL1 f g 4.7nH\nC2 g 0 100pF\nR6 g h 1MEG\nR7 h i 3.3K\n",
    );
    assert_eq!(value_of(&net, "c1"), 1e-5);
    assert_eq!(value_of(&net, "r1"), 1e6);
    assert_eq!(value_of(&net, "r2"), 1e-3);
    assert_eq!(value_of(&net, "r3"), 2200.0);
    assert_eq!(value_of(&net, "r4"), 1e-3);
    assert_eq!(value_of(&net, "r5"), 1000.0);
    assert_eq!(value_of(&net, "l1"), 4.7e-9);
    assert_eq!(value_of(&net, "c2"), 1e-10);
    assert_eq!(value_of(&net, "r6"), 1e6);
    assert_eq!(value_of(&net, "r7"), 3300.0);
    let net = parse("t\nV1 a 0 5V\nR1 a 0 1\n");
    assert_eq!(source_of(&net, "v1"), &SourceSpec::Dc(5.0));
    assert_eq!(dirac_netlist::parse_spice_number("10uF"), Some(1e-5));
}

#[test]
fn source_forms() {
    let net = parse(
        "sources
V1 a 0 5
V2 b 0 DC 2.5
I1 0 c dc 1m
V3 d 0 SIN(0.5 2 1k 1m 10 45)
V4 e 0 sin 0 1 50
V5 f 0 PULSE(0, 5, 1u, 2u, 3u, 10u, 20u, 3)
V6 g 0 pulse (1 -1)
I2 h 0 PWL(0 0 1m 1 2m 1)
V7 i 0 DC 1 SIN(0 1 1k) AC 1 0
V8 j 0 AC 1
V9 k 0
R1 a b 1
",
    );
    assert_eq!(source_of(&net, "v1"), &SourceSpec::Dc(5.0));
    assert_eq!(source_of(&net, "v2"), &SourceSpec::Dc(2.5));
    assert_eq!(source_of(&net, "i1"), &SourceSpec::Dc(1e-3));
    assert_eq!(
        source_of(&net, "v3"),
        &SourceSpec::Sin {
            vo: 0.5,
            va: 2.0,
            freq: 1e3,
            td: 1e-3,
            theta: 10.0,
            phase: 45.0
        }
    );
    assert_eq!(
        source_of(&net, "v4"),
        &SourceSpec::Sin {
            vo: 0.0,
            va: 1.0,
            freq: 50.0,
            td: 0.0,
            theta: 0.0,
            phase: 0.0
        }
    );
    assert_eq!(
        source_of(&net, "v5"),
        &SourceSpec::Pulse {
            v1: 0.0,
            v2: 5.0,
            td: 1e-6,
            tr: 2e-6,
            tf: 3e-6,
            pw: 1e-5,
            per: 2e-5,
            np: 3.0
        }
    );
    // No .tran: unresolved defaults stay 0.
    assert_eq!(
        source_of(&net, "v6"),
        &SourceSpec::Pulse {
            v1: 1.0,
            v2: -1.0,
            td: 0.0,
            tr: 0.0,
            tf: 0.0,
            pw: 0.0,
            per: 0.0,
            np: 0.0
        }
    );
    assert_eq!(
        source_of(&net, "i2"),
        &SourceSpec::pwl(vec![(0.0, 0.0), (1e-3, 1.0), (2e-3, 1.0)])
    );
    assert!(matches!(
        source_of(&net, "v7"),
        SourceSpec::Sin { freq, .. } if *freq == 1e3
    ));
    assert_eq!(source_of(&net, "v8"), &SourceSpec::Dc(0.0));
    assert_eq!(source_of(&net, "v9"), &SourceSpec::Dc(0.0));
    let messages: Vec<&str> = net.warnings.iter().map(|w| w.message.as_str()).collect();
    assert!(
        messages.iter().any(|m| m.starts_with("DC value ignored")),
        "{messages:?}"
    );
    assert_eq!(
        messages
            .iter()
            .filter(|m| m.starts_with("AC specification ignored"))
            .count(),
        2
    );
    assert!(
        messages
            .iter()
            .any(|m| m.starts_with("source without a value"))
    );
    match net.element("I1") {
        Some(Element::I {
            n_plus, n_minus, ..
        }) => assert_eq!((n_plus.as_str(), n_minus.as_str()), ("0", "c")),
        other => panic!("{other:?}"),
    }
}

#[test]
fn tran_resolves_source_defaults() {
    let net = parse(
        "defaults\nV1 a 0 PULSE(0 1 1m)\nV2 b 0 SIN(1 2 0 1m 0 30)\nR1 a b 1\n.tran 0.1m 5m uic\n",
    );
    assert_eq!(
        net.tran,
        Some(Tran {
            tstep: 1e-4,
            tstop: 5e-3,
            tstart: 0.0,
            tmax: None,
            uic: true
        })
    );
    assert_eq!(
        source_of(&net, "v1"),
        &SourceSpec::Pulse {
            v1: 0.0,
            v2: 1.0,
            td: 1e-3,
            tr: 1e-4,
            tf: 1e-4,
            pw: 5e-3,
            per: 5e-3,
            np: 0.0
        }
    );
    assert!(matches!(
        source_of(&net, "v2"),
        SourceSpec::Sin { freq, .. } if *freq == 200.0
    ));
}

#[test]
fn tran_forms() {
    let t = parse("t\nR1 a 0 1\n.tran 1u 1m\n").tran.expect("tran");
    assert_eq!(
        (t.tstep, t.tstop, t.tstart, t.tmax, t.uic),
        (1e-6, 1e-3, 0.0, None, false)
    );
    let t = parse("t\n.param ts=2u\nR1 a 0 1\n.TRAN {ts} 10m 1m 5u UIC\n")
        .tran
        .expect("tran");
    assert_eq!(
        (t.tstep, t.tstop, t.tstart, t.tmax, t.uic),
        (2e-6, 1e-2, 1e-3, Some(5e-6), true)
    );
}

#[test]
fn steps_per_row_follow_ngspices_largest_step() {
    // ngspice-39's TRANinit: TMAX when given, else min(TSTEP, (TSTOP - TSTART)/50).
    let m = |card: &str| {
        parse(&format!("t\nR1 a 0 1\n{card}\n"))
            .tran
            .expect("tran")
            .steps_per_row()
    };
    assert_eq!(m(".tran 1u 1m"), 1, "1000 rows");
    assert_eq!(m(".tran 1m 10m"), 5, "a fiftieth of 10 ms is 0.2 ms");
    assert_eq!(m(".tran 1m 10m 5m"), 10, "a fiftieth of the printed 5 ms");
    assert_eq!(m(".tran 1m 10m 0 10u"), 100, "a whole ratio up to rounding");
    assert_eq!(
        m(".tran 1m 10m 0 0.3m"),
        4,
        "the fewest steps no longer than TMAX"
    );
    assert_eq!(m(".tran 1u 1m 0 5u"), 1, "TMAX above TSTEP: rows are steps");
    assert_eq!(
        m(".tran 1m 10m 0 5m"),
        1,
        "TMAX sets the bound, not the fiftieth"
    );
}

#[test]
fn coupled_inductors() {
    let net = parse("k\nL1 a 0 1m\nL2 b 0 4m\nK1 L1 l2 0.5\nR1 b 0 1\n");
    assert_eq!(
        net.element("k1"),
        Some(&Element::K {
            name: "k1".into(),
            l1: "l1".into(),
            l2: "l2".into(),
            k: 0.5
        })
    );
    assert_eq!(net.nodes(), ["a", "b"]);
}

#[test]
fn diode_with_model() {
    let net = parse(
        "diode\nD1 a K dmod\nD2 k 0 Plain\n.model DMOD D(IS=2e-14 N=1.5 RS=0.25 CJO=1p IKF=1)\n.model plain d\nR1 a 0 1\n",
    );
    assert_eq!(
        net.element("d1"),
        Some(&Element::D {
            name: "d1".into(),
            anode: "a".into(),
            cathode: "k".into(),
            model: DiodeModel {
                name: "dmod".into(),
                card: DiodeParameters {
                    rs: 0.25,
                    cjo: 1e-12,
                    ..DiodeParameters::new(2e-14, 1.5)
                },
                tnom_given: false,
                ignored: vec![("ikf".into(), 1.0)],
                temp: None,
            }
        })
    );
    match net.element("d2") {
        Some(Element::D { model, .. }) => {
            assert_eq!(model.card, DiodeParameters::default())
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(net.warnings.len(), 1);
    assert_eq!((net.warnings[0].line, net.warnings[0].column), (4, 45));
    assert!(
        net.warnings[0].message.contains("IKF") && net.warnings[0].message.contains("knee"),
        "{}",
        net.warnings[0].message
    );
    // Model parameters without parentheses, with commas and parameter references.
    let net = parse("d\n.param isat=1f\nD1 a 0 m1\n.model m1 D is={isat*10}, n=2\n");
    match net.element("d1") {
        Some(Element::D { model, .. }) => {
            assert_eq!((model.card.is, model.card.n), (1e-15 * 10.0, 2.0))
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn initial_conditions_card() {
    let net = parse(
        "ic\n.param v0=2\nC1 a 0 1u\nC2 B 0 1u\nR1 a b 1\n.ic V(a)=1 v(b) = {v0*2}\n.IC V(a)=3\n",
    );
    assert_eq!(net.ic, vec![("a".to_owned(), 3.0), ("b".to_owned(), 4.0)]);
    assert_eq!(net.warnings.len(), 1);
}

/// A capacitor's initial voltage from `.ic` node voltages: both nodes named, or one of them with
/// ground; with `UIC` a node `.ic` leaves out is 0 V, as ngspice computes the capacitor's initial
/// condition from its node vector (ngspice-39 on a Wien oscillator kicked by `.ic v(w)=1m` alone
/// starts `C1 s w` at −1 mV; dirac's run now agrees with it to 6e-8 of the peak under gauss2, and
/// was 43 % off with C1 uncharged). Without `UIC` the other node stays unknown (the operating point
/// decides it).
#[test]
fn capacitor_voltage_from_node_initial_conditions() {
    let deck = |tran: &str| {
        parse(&format!(
            "t\nC1 s w 10n\nC2 w 0 10n\nC3 a 0 1n\nR1 s 0 1k\nR2 a w 1k\n.ic v(w)=1m\n{tran}\n"
        ))
    };
    let uic = deck(".tran 1u 1m uic");
    assert_eq!(uic.capacitor_voltage("w", "0", None), Some(1e-3));
    assert_eq!(uic.capacitor_voltage("s", "w", None), Some(-1e-3));
    assert_eq!(uic.capacitor_voltage("w", "s", None), Some(1e-3));
    assert_eq!(uic.capacitor_voltage("a", "0", None), None);
    assert_eq!(uic.capacitor_voltage("s", "w", Some(0.5)), Some(0.5));
    let op = deck(".tran 1u 1m");
    assert_eq!(op.capacitor_voltage("w", "0", None), Some(1e-3));
    assert_eq!(op.capacitor_voltage("s", "w", None), None);
}

#[test]
fn param_expressions() {
    let net = parse(
        "params
.param a=2 b=3
.param c = a + b * 2 d={(a + b) * 2} e=-a^2 f=2^3^2 g=a**b
.param h=sqrt(16)+exp(0)+log(1)+abs(-2)+sin(0)+cos(0)
.param late=early*2 early=5
.param i=10/4/5 j=1k*a k='b*2'
R1 n 0 {c}
R2 n 0 {d}
R3 n 0 {e}
R4 n 0 {f}
R5 n 0 {g}
R6 n 0 {h}
R7 n 0 {late}
R8 n 0 {i}
R9 n 0 j
R10 n 0 '2*k'
R11 n 0 2*a+1
R12 n 0 {A*B}
",
    );
    let got: Vec<f64> = (1..=12).map(|i| value_of(&net, &format!("r{i}"))).collect();
    assert_eq!(
        got,
        [
            // `2^3^2` is 64: ngspice-39's `^` is left-associative.
            8.0, 10.0, -4.0, 64.0, 8.0, 8.0, 10.0, 0.5, 2000.0, 12.0, 5.0, 6.0
        ]
    );
}

#[test]
fn continuation_and_comments() {
    let net = parse(
        "title line
* a comment line
  * an indented comment
R1 a ; inline comment
* comment between a card and its continuation

+ b
+ 1k ; value on a continuation line
V1 a 0 PULSE(0 1
+ 1m 1m 1m
+ 5m 10m)   ; closing on the third line
.end
R2 a b this is after .end and ignored
",
    );
    assert_eq!(net.elements.len(), 2);
    assert_eq!(value_of(&net, "r1"), 1e3);
    assert!(matches!(
        source_of(&net, "v1"),
        SourceSpec::Pulse { per, .. } if *per == 1e-2
    ));
}

#[test]
fn output_control_is_accepted_with_warnings() {
    let net = parse(
        "controls
R1 a 0 1
.options method=trap reltol=1e-6
.option gmin=1e-12
.print tran v(a)
.plot tran v(a)
.probe v(a)
.save v(a)
.meas tran vmax MAX v(a)
.control
run
plot v(a)
.endc
",
    );
    assert_eq!(net.elements.len(), 1);
    // `.options` are kept as pairs (the circuit builder maps `method` and warns about the rest);
    // `.print`/`.plot`/`.probe`/`.save` name the recorded signals; `.meas` is kept as a
    // measure; `.control` is ignored with a warning.
    let options: Vec<(&str, Option<&str>, usize)> = net
        .options
        .iter()
        .map(|o| (o.key.as_str(), o.value.as_deref(), o.pos.line))
        .collect();
    assert_eq!(
        options,
        [
            ("method", Some("trap"), 3),
            ("reltol", Some("1e-6"), 3),
            ("gmin", Some("1e-12"), 4)
        ]
    );
    let outputs: Vec<(&str, usize)> = net
        .outputs
        .iter()
        .map(|o| (o.signal.as_str(), o.pos.line))
        .collect();
    assert_eq!(
        outputs,
        [("v(a)", 5), ("v(a)", 6), ("v(a)", 7), ("v(a)", 8)]
    );
    let lines: Vec<usize> = net.warnings.iter().map(|w| w.line).collect();
    assert_eq!(lines, [10]);
    let measures: Vec<(&str, usize)> = net
        .measures
        .iter()
        .map(|m| (m.name.as_str(), m.pos.line))
        .collect();
    assert_eq!(measures, [("vmax", 9)]);
}

/// `.op` anywhere asks for the operating point; `.print` lists with differences and currents
/// are kept as written (lowercased, blanks dropped).
#[test]
fn operating_point_and_print_lists() {
    let net = parse(
        "t
R1 a 0 1
.op
.print tran V(a) v(a, 0) I(R1)
.end
",
    );
    assert!(net.op);
    let outputs: Vec<&str> = net.outputs.iter().map(|o| o.signal.as_str()).collect();
    assert_eq!(outputs, ["v(a)", "v(a,0)", "i(r1)"]);
    assert!(
        !parse(
            "t
R1 a 0 1
"
        )
        .op
    );
}

#[test]
fn case_insensitive_names_and_keywords() {
    let net = parse(
        ".TITLE-like title\n.PARAM Rv=5\nr1 N1 Gnd {RV}\nR2 n1 GND rv\n.Tran 1 10 UiC\n.END\n",
    );
    assert_eq!(net.nodes(), ["n1"]);
    assert_eq!(value_of(&net, "R1"), 5.0);
    assert_eq!(value_of(&net, "r2"), 5.0);
    assert!(net.tran.is_some_and(|t| t.uic));
}

#[test]
fn nested_subcircuits_with_parameters() {
    let net = parse(
        "nested subcircuits
.param rbase=100
.subckt cell in out params: r=1k c=1n
R1 in mid {r}
C1 mid GND {c} IC=0.5
L1 mid out 1u
.ends cell
.subckt pair a b c0=2n
.param rr=rbase*3
X1 a m cell r={rr}
X2 m b cell c={c0}
.subckt inner p
R9 p 0 {c0*1e9}
.ends
X3 m inner
.ends pair
Xtop n1 n2 PAIR c0=5n
Xsolo n2 0 cell
",
    );
    let names: Vec<&str> = net.elements.iter().map(Element::name).collect();
    assert_eq!(
        names,
        [
            "xtop.x1.r1",
            "xtop.x1.c1",
            "xtop.x1.l1",
            "xtop.x2.r1",
            "xtop.x2.c1",
            "xtop.x2.l1",
            "xtop.x3.r9",
            "xsolo.r1",
            "xsolo.c1",
            "xsolo.l1",
        ]
    );
    assert_eq!(
        net.elements[0],
        Element::R {
            name: "xtop.x1.r1".into(),
            n1: "n1".into(),
            n2: "xtop.x1.mid".into(),
            value: 300.0
        }
    );
    assert_eq!(
        net.elements[1],
        Element::C {
            name: "xtop.x1.c1".into(),
            n1: "xtop.x1.mid".into(),
            n2: "0".into(),
            value: 1e-9,
            ic: Some(0.5)
        }
    );
    assert_eq!(
        net.elements[2],
        Element::L {
            name: "xtop.x1.l1".into(),
            n1: "xtop.x1.mid".into(),
            n2: "xtop.m".into(),
            value: 1e-6,
            ic: None
        }
    );
    assert_eq!(value_of(&net, "xtop.x2.r1"), 1e3);
    assert_eq!(value_of(&net, "xtop.x2.c1"), 5e-9);
    assert_eq!(value_of(&net, "xtop.x3.r9"), 5.0);
    match net.element("xsolo.l1") {
        Some(Element::L { n1, n2, .. }) => {
            assert_eq!((n1.as_str(), n2.as_str()), ("xsolo.mid", "0"))
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        net.nodes(),
        [
            "n1",
            "xtop.x1.mid",
            "xtop.m",
            "xtop.x2.mid",
            "n2",
            "xsolo.mid"
        ]
    );
    assert_eq!(net.origins[0].name, "Xtop.X1.R1");
    assert_eq!((net.origins[0].line, net.origins[0].column), (4, 1));
}

#[test]
fn subcircuit_with_coupling_model_and_ic() {
    let net = parse(
        "xfmr
.subckt xf p s k=0.9
L1 p 0 1m
L2 s 0 1m
K1 L1 L2 {k}
D1 s out dloc
R1 out 0 1k
.model dloc D(IS=1e-12)
.ic V(out)=0.25
.ends
X1 a b xf k=0.5
V1 a 0 SIN(0 1 1k)
",
    );
    assert_eq!(
        net.element("x1.k1"),
        Some(&Element::K {
            name: "x1.k1".into(),
            l1: "x1.l1".into(),
            l2: "x1.l2".into(),
            k: 0.5
        })
    );
    match net.element("x1.d1") {
        Some(Element::D {
            anode,
            cathode,
            model,
            ..
        }) => {
            assert_eq!(
                (anode.as_str(), cathode.as_str(), model.card.is),
                ("b", "x1.out", 1e-12)
            )
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(net.ic, vec![("x1.out".to_owned(), 0.25)]);
}

// ---------------------------------------------------------------- errors

#[test]
fn unsupported_cards() {
    let e = assert_err(
        "t\nR1 a 0 1\n    J1 d g s jmod\n",
        ErrorKind::Unsupported,
        3,
        5,
    );
    assert_eq!(
        e.to_string(),
        "t.cir:3:5: card `J1 d g s jmod` not supported"
    );
    assert_eq!(e.text, "J1 d g s jmod");
    for card in [
        "T1 a 0 b 0 Z0=50 TD=1n",
        "J1 d g s jmod",
        ".ac dec 10 1 1meg",
        ".dc V1 0 1 0.1",
    ] {
        let e = assert_err(
            &format!("t\nR1 a 0 1\n{card}\n"),
            ErrorKind::Unsupported,
            3,
            1,
        );
        assert_eq!(
            e.to_string(),
            format!("t.cir:3:1: card `{card}` not supported")
        );
    }
}

/// `EXP(V1 V2 TD1 TAU1 TD2 TAU2)` with ngspice's defaults from `vsrcload.c`: `TD1`, `TAU1`, `TAU2`
/// absent or 0 are TSTEP and `TD2` is `TD1 + TSTEP` (the manual's 0 for `TD1` is not what the code
/// does); a negative time constant is refused.
#[test]
fn exp_source_and_its_defaults() {
    let net = parse(
        "t\nV1 a 0 EXP(0 2 0.2m 0.3m 1.5m 0.5m)\nV2 b 0 EXP(1 -1)\nV3 c 0 EXP(0 1 0 0 2m)\n\
         R1 a 0 1\nR2 b 0 1\nR3 c 0 1\n.tran 10u 4m\n",
    );
    assert_eq!(
        source_of(&net, "v1"),
        &SourceSpec::Exp {
            v1: 0.0,
            v2: 2.0,
            td1: 0.2e-3,
            tau1: 0.3e-3,
            td2: 1.5e-3,
            tau2: 0.5e-3
        }
    );
    assert_eq!(
        source_of(&net, "v2"),
        &SourceSpec::Exp {
            v1: 1.0,
            v2: -1.0,
            td1: 1e-5,
            tau1: 1e-5,
            td2: 2e-5,
            tau2: 1e-5
        }
    );
    assert_eq!(
        source_of(&net, "v3"),
        &SourceSpec::Exp {
            v1: 0.0,
            v2: 1.0,
            td1: 1e-5,
            tau1: 1e-5,
            td2: 2e-3,
            tau2: 1e-5
        }
    );
    // 0.1 ms into the rise: 2(1 − e^{−1/3}).
    let v = source_of(&net, "v1").value(0.3e-3);
    assert!(
        (v - 2.0 * (1.0 - (-1.0f64 / 3.0).exp())).abs() < 1e-14,
        "{v}"
    );
    let e = assert_err("t\nV1 a 0 EXP(0 1 0 -1m)\n", ErrorKind::BadValue, 2, 18);
    assert!(e.message.contains("EXP rise time constant"), "{e}");
    assert_err("t\nV1 a 0 EXP(0 1 0 1 2 3 4)\n", ErrorKind::Syntax, 2, 8);
}

/// A `.tran` whose TSTOP or TSTART is off the TSTEP grid is run on the grid, with a warning at the
/// value that says where the rows end or begin (ngspice ends at TSTOP); on the grid, none.
#[test]
fn off_grid_tran_times_are_warned_about() {
    let net = parse("t\nR1 a 0 1\nV1 a 0 1\n.tran 3u 100u 10u\n");
    let w: Vec<String> = net.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(
        w[0].contains("4:10") && w[0].contains("ends at 9.900000e-5"),
        "{w:?}"
    );
    assert!(
        w[1].contains("4:15") && w[1].contains("first row is at 1.200000e-5"),
        "{w:?}"
    );
    let on_grid = parse("t\nR1 a 0 1\nV1 a 0 1\n.tran 1e-5 1e-3 3e-5\n");
    assert!(on_grid.warnings.is_empty(), "{:?}", on_grid.warnings);
}

/// The linear forms of the controlled sources, inside a subcircuit too: `E`/`G` read the output
/// pair, the controlling pair and the value; `F`/`H` the output pair, the controlling voltage
/// source (resolved in the subcircuit's scope) and the value, which may be an expression.
#[test]
fn controlled_sources_are_read() {
    let net = parse(
        "t\n.param a=4\n.subckt amp i o\nvs i m 0\nrm m 0 1k\nf1 0 o vs {a/2}\nro o 0 1k\n.ends\n\
         v1 in 0 1\ne1 x 0 in 0 -10\ng1 y 0 x 0 2m\nry y 0 1k\nrx x 0 1k\nh1 z 0 v1 50\nrz z 0 1\n\
         x1 in out amp\n",
    );
    let controlled = |name: &str| match net.element(name) {
        Some(Element::Controlled {
            n_plus,
            n_minus,
            source,
            ..
        }) => (n_plus.clone(), n_minus.clone(), source.clone()),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(
        controlled("e1"),
        (
            "x".into(),
            "0".into(),
            ControlledSource::Vcvs {
                c_plus: "in".into(),
                c_minus: "0".into(),
                gain: -10.0
            }
        )
    );
    assert_eq!(
        controlled("g1").2,
        ControlledSource::Vccs {
            c_plus: "x".into(),
            c_minus: "0".into(),
            gm: 2e-3
        }
    );
    assert_eq!(
        controlled("h1").2,
        ControlledSource::Ccvs {
            control: "v1".into(),
            r: 50.0
        }
    );
    assert_eq!(
        controlled("x1.f1"),
        (
            "0".into(),
            "out".into(),
            ControlledSource::Cccs {
                control: "x1.vs".into(),
                gain: 2.0
            }
        )
    );
    assert_eq!(
        net.element("e1").unwrap().nodes(),
        vec!["x", "0", "in", "0"]
    );
}

/// What the linear forms do not cover is refused where it is written: the nonlinear forms, a
/// controlling element that is not a voltage source, a missing value.
#[test]
fn controlled_source_errors_name_the_place() {
    let e = assert_err(
        "t\nF1 o 0 TABLE {v(a)} = (0,0) (1,1)\n",
        ErrorKind::Unsupported,
        2,
        8,
    );
    assert!(e.message.contains("the form `TABLE`"), "{e}");
    assert_err(
        "t\nE1 o 0 TABLE {v(a)} = (0,0) (1)\n",
        ErrorKind::Syntax,
        2,
        32,
    );
    assert_err(
        "t\nE1 o 0 TABLE = v(a) (0,0) (1,1)\n",
        ErrorKind::Syntax,
        2,
        16,
    );
    assert_err("t\nG1 o 0 laplace={v(a)}\n", ErrorKind::Unsupported, 2, 8);
    // VOL= is E's, CUR= is G's.
    assert_err("t\nE1 o 0 cur={v(a)}\n", ErrorKind::Unsupported, 2, 8);
    assert_err("t\nB1 o 0 q={v(a)}\n", ErrorKind::Syntax, 2, 8);
    assert_err("t\nB1 o 0 v=\n", ErrorKind::Syntax, 2, 10);
    assert_err("t\nE1 o 0 POLY(0) a 0 1\n", ErrorKind::BadValue, 2, 13);
    assert_err("t\nE1 o 0 POLY(1) a 0\n", ErrorKind::Syntax, 2, 19);
    assert_err("t\nB1 o 0 v=v(a,b,c)\n", ErrorKind::Syntax, 2, 11);
    let e = assert_err("t\nR1 a 0 {v(a)}\n", ErrorKind::BadValue, 2, 9);
    assert!(e.message.contains("only a B source"), "{e}");
    let e = assert_err(
        "t\nB1 o 0 v=2*i(vx)\nRo o 0 1\n",
        ErrorKind::UnknownElement,
        2,
        12,
    );
    assert!(e.message.contains("no element has that name"), "{e}");
    let e = assert_err(
        "t\nR1 a 0 1\nF1 o 0 POLY(1) R1 0 2\nRo o 0 1\n",
        ErrorKind::UnknownElement,
        3,
        16,
    );
    assert!(e.message.contains("not a voltage source"), "{e}");
    assert_err("t\nB1 o 0 v=2*frob(1)\n", ErrorKind::UnknownFunction, 2, 12);
    assert_err("t\nB1 o 0 v=2*k\n", ErrorKind::UnknownParam, 2, 12);
    let e = assert_err(
        "t\nR1 a 0 1\nF1 o 0 R1 2\nRo o 0 1\n",
        ErrorKind::UnknownElement,
        3,
        8,
    );
    assert!(e.message.contains("not a voltage source"), "{e}");
    let e = assert_err(
        "t\nH1 o 0 vx 2\nRo o 0 1\n",
        ErrorKind::UnknownElement,
        2,
        8,
    );
    assert!(e.message.contains("no element has that name"), "{e}");
    // Inside a subcircuit the name is the subcircuit's, as in ngspice.
    let e = assert_err(
        "t\nVtop a 0 1\nRa a 0 1\n.subckt s o\nF1 o 0 Vtop 2\nRo o 0 1\n.ends\nX1 n s\n",
        ErrorKind::UnknownElement,
        5,
        8,
    );
    assert!(e.message.contains("local to the subcircuit"), "{e}");
    // A form's keyword names a node or source when no `(`, `=` or `{` follows (ngspice: v(f4) = 2,
    // v(e) = 6 on this deck).
    parse(
        "t\nVol a 0 1\nRa a 0 500\nF4 f4 0 Vol 1\nRF4 f4 0 1k\nV1 freq 0 2\nE1 e 0 freq 0 3\nRe e 0 1k\n",
    );
    // An E or H output is a voltage source whose current may control (ngspice reads it too).
    parse("t\nV1 a 0 1\nE1 x 0 a 0 2\nRx x 0 1k\nF1 0 y E1 1\nRy y 0 1k\n");
    assert_err("t\nE1 o 0 a 0\n", ErrorKind::Syntax, 2, 11);
    assert_err("t\nV1 a 0 1\nF1 o 0 V1 2 3\n", ErrorKind::Syntax, 3, 13);
}

/// The behavioural forms: `B … V=`/`I=`, `E`/`G` with `VALUE=`, `VOL=`, `CUR=`, and `POLY(n)` on
/// all four, inside a subcircuit too, with their controls mapped into scope. Values of the
/// expressions at chosen rates against the polynomials written out.
#[test]
fn behavioural_sources_and_their_controls() {
    let net = parse(
        "t\n.param k=3\nV1 a 0 1\nB1 b 0 V = {k*v(a)^2 + time}\nB2 0 c I='v(a, b) * i(V1)'\n\
         E1 d 0 VALUE = {v(GND, a)}\nG1 0 e cur={max(v(a), 0)}\nE2 f 0 poly(2) a 0 b c 1 2 3 4 5 6\n\
         H1 g 0 POLY(1) v1 7\n.subckt s p\nB1 p 0 v=v(p)*i(vin)\nVin p q 0\nRq q 0 1\n.ends\n\
         X1 a s\n",
    );
    let source = |name: &str| match net.element(name) {
        Some(Element::Controlled { source, .. }) => source.clone(),
        other => panic!("{name}: {other:?}"),
    };
    let value = |name: &str, x: &[f64], t: f64| match source(name) {
        ControlledSource::Behavioural { expression, .. } => expression.value(x, t),
        other => panic!("{name}: {other:?}"),
    };
    let sensed = |name: &str| match source(name) {
        ControlledSource::Behavioural {
            output, controls, ..
        } => (output, controls),
        other => panic!("{name}: {other:?}"),
    };
    let v = |plus: &str, minus: &str| Sensing::Voltage {
        plus: plus.into(),
        minus: minus.into(),
    };
    let i = |source: &str| Sensing::Current {
        source: source.into(),
    };
    assert_eq!(sensed("b1"), (Output::Voltage, vec![v("a", "0")]));
    assert_eq!(value("b1", &[2.0], 0.5), 12.5);
    assert_eq!(sensed("b2"), (Output::Current, vec![v("a", "b"), i("v1")]));
    assert_eq!(value("b2", &[2.0, -3.0], 0.0), -6.0);
    assert_eq!(sensed("e1"), (Output::Voltage, vec![v("0", "a")]));
    assert_eq!(sensed("g1").0, Output::Current);
    assert_eq!(value("g1", &[-2.0], 0.0), 0.0);
    // POLY(2): 1 + 2x + 3y + 4x² + 5xy + 6y².
    assert_eq!(
        sensed("e2"),
        (Output::Voltage, vec![v("a", "0"), v("b", "c")])
    );
    let (x, y) = (0.7, -1.3);
    let poly = 1.0 + 2.0 * x + 3.0 * y + 4.0 * x * x + 5.0 * x * y + 6.0 * y * y;
    assert!((value("e2", &[x, y], 0.0) - poly).abs() < 1e-14);
    // A single coefficient is p₀, as ngspice-39 reads it (`h1` is 7 V whatever `i(v1)`).
    assert_eq!(sensed("h1"), (Output::Voltage, vec![i("v1")]));
    assert_eq!(value("h1", &[5.0], 0.0), 7.0);
    // Inside a subcircuit: the port maps to the caller's node, names are local.
    assert_eq!(
        sensed("x1.b1"),
        (Output::Voltage, vec![v("a", "0"), i("x1.vin")])
    );
}

/// `.func` definitions (top level and subcircuit-local, using the instance's parameters) in
/// values, parameters and B expressions, and `pwl` tables; ngspice-39 on the same top-level
/// definitions gives `.param p = {g(2)}` = 15 and `f(v(b), 4) + g(1)` = 8 at v(b) = −0.5.
#[test]
fn functions_and_tables_in_cards() {
    let net = parse(
        "t\n.func f(x,y) {x*y+1}\n.func g(x) = {f(x,2)*k}\n.param k=3\n.param p={g(2)}\n\
         R1 a 0 {p}\nV1 b 0 -0.5\nB1 c 0 V = f(v(b), 4) + g(1)\n\
         B2 d 0 V = pwl(v(b), -1,0, 0,1, 1,{k})\n.subckt s o gain=2\n.func h(x) 'gain*x'\n\
         B1 o 0 V = h(v(o))\nR1 o 0 {h(10)}\n.ends\nX1 e s gain=5\n",
    );
    assert_eq!(value_of(&net, "r1"), 15.0);
    assert_eq!(value_of(&net, "x1.r1"), 50.0);
    let value = |name: &str, x: f64| match net.element(name) {
        Some(Element::Controlled {
            source: ControlledSource::Behavioural { expression, .. },
            ..
        }) => expression.value(&[x], 0.0),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(value("b1", -0.5), 8.0);
    assert_eq!(value("b2", -0.5), 0.5);
    assert_eq!(value("b2", 2.0), 5.0);
    assert_eq!(value("x1.b1", 0.3), 1.5);
    let e = assert_err("t\nR1 a 0 {2*nope(1)}\n", ErrorKind::UnknownFunction, 2, 11);
    assert!(e.message.contains("nor defined by a .func"), "{e}");
    assert_err(
        "t\n.func r(x) {r(x)}\nR1 a 0 {r(1)}\n",
        ErrorKind::RecursiveParam,
        2,
        13,
    );
    // A subcircuit's function is local to it.
    assert_err(
        "t\n.subckt s o\n.func h(x) {x}\nR1 o 0 1\n.ends\nX1 a s\nR2 a 0 {h(1)}\n",
        ErrorKind::UnknownFunction,
        7,
        9,
    );
    assert_err("t\n.func f(x, x) {x}\n", ErrorKind::Syntax, 2, 12);
    // A B source's own names, as ngspice-39 reads them at `.temp 50` beside `.param e=5`:
    // `pi + temper + hertz + e` is 55.85987 and `e` 2.718282 (the constant comes first).
    let net = parse("t\n.temp 50\nB1 d 0 V = pi + temper + hertz + e\n.param e=5\nB2 f 0 V = e\n");
    let constant = |name: &str| match net.element(name) {
        Some(Element::Controlled {
            source: ControlledSource::Behavioural { expression, .. },
            ..
        }) => expression.value(&[], 0.0),
        other => panic!("{name}: {other:?}"),
    };
    let expected = std::f64::consts::PI + 50.0 + std::f64::consts::E;
    assert!((constant("b1") - expected).abs() < 1e-13);
    assert_eq!(constant("b2"), std::f64::consts::E);
    let net = parse("t\n.param k=3\nB1 d 0 V = k*e\n");
    let Some(Element::Controlled {
        source: ControlledSource::Behavioural { expression, .. },
        ..
    }) = net.element("b1")
    else {
        panic!("b1");
    };
    assert_eq!(expression.value(&[], 0.0), 3.0 * std::f64::consts::E);
    // A `pwl` whose corner is a `.func` argument (ngspice-39: `f(v(a), 4)` at v(a) = 1 is 0.25;
    // the points were read without the call's parameters: "unknown parameter `y`").
    let net = parse("t\n.func f(x,y) {pwl(x, 0,0, y,1)}\nV1 a 0 1\nB1 b 0 V=f(v(a),4)\n");
    let Some(Element::Controlled {
        source: ControlledSource::Behavioural { expression, .. },
        ..
    }) = net.element("b1")
    else {
        panic!("b1");
    };
    assert_eq!(expression.value(&[1.0], 0.0), 0.25);
    assert_err(
        "t\nV1 a 0 1\nB1 b 0 V=pwl(v(a), 0,0, v(a),1)\n",
        ErrorKind::BadValue,
        3,
        10,
    );
}

/// `.include FILE` and `.lib FILE SECTION` read their files in place, relative to the including
/// file's directory (quotes allowed), a `.lib NAME` … `.endl` section definition outside such a
/// read is skipped, and errors and origins name the file they are in.
#[test]
fn includes_and_library_sections() {
    let dir = std::env::temp_dir().join(format!("dirac-include-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("models")).unwrap();
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    write(
        "models/lib.lib",
        "* sections\n.lib fast\n.model dfast d(is=1e-12)\n.endl\n.lib slow\n\
         .model dslow d(is=1e-15)\n.subckt clamp a b\nD1 a b dslow\n.ends\n.endl\n",
    );
    write(
        "models/rc.inc",
        "* RC\n.param rval=2k\nR9 n9 0 {rval}\n.include ../more.inc\n",
    );
    write("more.inc", "Rmore n9 n8 1k\nR8 n8 0 1k bogus=3\n");
    let main = dir.join("main.cir");
    let main_name = main.display().to_string();
    let text = "t\nV1 in 0 1\nR1 in n9 1k\n.include models/rc.inc\n\
                .lib 'models/lib.lib' slow\nX1 n9 0 clamp\n.lib unused\nR99 x 0 1\n.endl\n.op\n";
    // The error in the twice-included file names that file and its own line and column.
    let e = parse_netlist(text, &main_name).expect_err("bogus parameter");
    assert!(e.file.ends_with("more.inc"), "{e}");
    assert_eq!((e.line, e.column), (2, 12), "{e}");
    write("more.inc", "Rmore n9 n8 1k\nR8 n8 0 1k\n");
    let net = parse_netlist(text, &main_name).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(value_of(&net, "r9"), 2e3);
    assert!(net.element("x1.d1").is_some());
    assert!(
        net.element("r99").is_none(),
        "a section definition is not read by itself"
    );
    let origin = |name: &str| {
        let k = net.elements.iter().position(|e| e.name() == name).unwrap();
        net.origins[k].clone()
    };
    assert_eq!(origin("r1").file, main_name);
    assert!(origin("r9").file.ends_with("rc.inc"));
    assert_eq!((origin("r8").line, origin("r8").column), (2, 1));
    assert!(origin("x1.d1").file.ends_with("lib.lib"));
    assert_eq!(net.files.len(), 4, "{:?}", net.files);
    let fails = |text: &str| parse_netlist(text, &main_name).expect_err("fails");
    let e = fails("t\n.include nowhere.inc\n");
    assert_eq!((e.kind, e.line, e.column), (ErrorKind::Include, 2, 1));
    let e = fails("t\n.lib models/lib.lib medium\n");
    assert!(e.message.contains("no `.lib medium` section"), "{e}");
    write("loop.inc", ".include loop.inc\n");
    let e = fails("t\n.include loop.inc\n");
    assert_eq!(e.kind, ErrorKind::Include);
    assert!(e.message.contains("includes itself"), "{e}");
    assert!(e.file.ends_with("loop.inc"), "{e}");
    let e = fails("t\n.include\n");
    assert_eq!((e.kind, e.line), (ErrorKind::Syntax, 2));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// ngspice's other spellings of R, L, C and D cards: the value as `r=`/`l=`/`c=`, a multiplicity
/// `m=` (that many in parallel: R and L divided, C multiplied), a diode's area factor (positional
/// or `area=`) times its `m=`, and `off` (ignored with a warning).
#[test]
fn instance_parameters_as_ngspice_reads_them() {
    let net = parse(
        "t\nR1 a 0 r=1k\nR2 a b 1k m=2\nC1 b 0 c=1u m=3\nL1 a c l=1m M=2\nD1 a d dm 2 m=3\nD2 a e dm area=1.5 off\n\
         .model dm d(is=1e-14)\n",
    );
    let value = |name: &str| match net.element(name) {
        Some(Element::R { value, .. } | Element::L { value, .. } | Element::C { value, .. }) => {
            *value
        }
        Some(Element::D { model, .. }) => model.card.area,
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(value("r1"), 1e3);
    assert_eq!(value("r2"), 500.0);
    assert_eq!(value("c1"), 3e-6);
    assert_eq!(value("l1"), 5e-4);
    assert_eq!(value("d1"), 6.0);
    assert_eq!(value("d2"), 1.5);
    assert_eq!(net.warnings.len(), 1, "{:?}", net.warnings);
    assert!(net.warnings[0].message.contains("`off` ignored"));
    assert_err("t\nR1 a 0 1k m=0\n", ErrorKind::BadValue, 2, 13);
    assert_err("t\nD1 a 0 dm -1\n.model dm d\n", ErrorKind::BadValue, 2, 11);
    assert_err("t\nR1 a 0 1k nt=2\n", ErrorKind::Unsupported, 2, 11);
    // A model's AREA is the default of its instances' area, which an instance area replaces
    // (ngspice-39: v(b) = 0.67507 for D2 and v(c) = 0.66464 for D1 fed from 5 V through 1k).
    let areas = parse("t\nD2 b 0 dm\nD1 c 0 dm 3 m=2\n.model dm D(IS=1e-14 AREA=2)\n");
    let area = |name: &str| match areas.element(name) {
        Some(Element::D { model, .. }) => model.card.area,
        other => panic!("{other:?}"),
    };
    assert_eq!((area("d2"), area("d1")), (2.0, 6.0));
    assert!(areas.warnings.is_empty(), "{:?}", areas.warnings);
    // ngspice divides a coupled winding's self-inductance by `m` but not its L in M = k√(L₁L₂);
    // refused rather than guessed.
    let e = assert_err(
        "t\nL1 b 0 1m m=2\nL2 c 0 1m\nK1 L1 L2 0.5\n",
        ErrorKind::Unsupported,
        4,
        4,
    );
    assert!(
        e.message.contains("coupled inductor written with `m=`"),
        "{e}"
    );
}

/// Analyses dirac does not run (`.ac`, `.dc`, `.noise`, …) in a deck that also asks for `.tran` or
/// `.op`: that one runs and the others are warned about at their place, as ngspice would run them
/// all; a deck with only those is refused at the first (test `unsupported_cards`). `.nodeset` (an
/// operating-point starting guess) is ignored with a warning.
#[test]
fn other_analyses_beside_a_transient_are_warned_about() {
    let net = parse(
        "t\nV1 a 0 1\nR1 a 0 1k\n.ac dec 10 1 1meg\n.tran 1u 10u\n.nodeset v(a)=1\n.dc V1 0 1 0.1\n",
    );
    assert!(net.tran.is_some());
    let w: Vec<String> = net.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(w.len(), 3, "{w:?}");
    assert!(
        w[0].contains("4:1") && w[0].contains("`.ac` analysis not run"),
        "{w:?}"
    );
    assert!(
        w[1].contains("6:1") && w[1].contains("`.nodeset` card ignored"),
        "{w:?}"
    );
    assert!(
        w[2].contains("7:1") && w[2].contains("`.dc` analysis not run"),
        "{w:?}"
    );
    let e = assert_err(
        "t\nR1 a 0 1\n.noise v(a) V1 dec 10 1 1k\n",
        ErrorKind::Unsupported,
        3,
        1,
    );
    assert!(e.message.contains("not supported"), "{e}");
}

/// A subcircuit port named `gnd` (or `0`) is the ground node, as ngspice reads it (its input
/// stage rewrites `gnd` to `0` before expanding subcircuits): the element inside goes to ground,
/// and the caller's node on that port is left unconnected, with a warning at that node. ngspice-39
/// on the first deck below prints `v(b) = 5` and `v(c) = 0`.
#[test]
fn a_subcircuit_port_named_gnd_is_ground() {
    let net = parse(
        "t\n.subckt div in out gnd\nr1 in out 1k\nr2 out gnd 1k\n.ends\nv1 a 0 10\nx1 a b c div\nrc c 0 1k\n",
    );
    let r2 = net
        .element("x1.r2")
        .unwrap_or_else(|| panic!("{:?}", net.elements));
    assert_eq!(r2.nodes(), vec!["b", "0"]);
    let w: Vec<String> = net.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("7:8") && w[0].contains("node `c`"), "{w:?}");
    let grounded = parse(
        "t\n.subckt div in out 0\nr1 in out 1k\nr2 out 0 1k\n.ends\nv1 a 0 10\nx1 a b gnd div\n",
    );
    assert!(grounded.warnings.is_empty(), "{:?}", grounded.warnings);
    assert_err("t\n.subckt s gnd 0\n.ends\n", ErrorKind::Syntax, 2, 15);
}

/// `K … 1` (perfect coupling) has a singular inductance matrix; the run failed at its first step
/// with a hint about saturating parts. It is refused where it is written.
#[test]
fn perfect_coupling_is_refused_at_its_card() {
    let e = assert_err(
        "t\nL1 a 0 1m\nL2 b 0 4m\nK1 L1 L2 1\nR1 a 0 1\nR2 b 0 1\n",
        ErrorKind::Unsupported,
        4,
        10,
    );
    assert!(e.message.contains("0.999999"), "{e}");
    assert_err(
        "t\nL1 a 0 1m\nL2 b 0 4m\nK1 L1 L2 -1\nR1 a 0 1\nR2 b 0 1\n",
        ErrorKind::Unsupported,
        4,
        10,
    );
    parse("t\nL1 a 0 1m\nL2 b 0 4m\nK1 L1 L2 0.999999\nR1 a 0 1\nR2 b 0 1\n");
}

/// ngspice's `r=` and `td=` after `PWL(…)`, in either order and any case; `r` must be one of the
/// time points before the last (ngspice's `vsrcpar.c` refuses the others).
#[test]
fn pwl_repeat_and_delay_options() {
    let net = parse(
        "t\nV1 a 0 PWL(0 0 1m 1 2m 0) r=0 td=0.5m\nI1 a 0 PWL(0 0 1 1 1 2 3 0) TD={2*1} R=1\n\
         V2 b 0 PWL(0 1 1 2)\nR1 a 0 1\nR2 b 0 1\n",
    );
    assert_eq!(
        source_of(&net, "v1"),
        &SourceSpec::Pwl {
            points: vec![(0.0, 0.0), (1e-3, 1.0), (2e-3, 0.0)],
            td: 0.5e-3,
            r: Some(0.0)
        }
    );
    assert_eq!(
        source_of(&net, "i1"),
        &SourceSpec::Pwl {
            points: vec![(0.0, 0.0), (1.0, 1.0), (1.0, 2.0), (3.0, 0.0)],
            td: 2.0,
            r: Some(1.0)
        }
    );
    assert_eq!(
        source_of(&net, "v2"),
        &SourceSpec::pwl(vec![(0.0, 1.0), (1.0, 2.0)])
    );
    // τ = t − 0.5 ms, period 2 ms: at t = 3 ms, τ = 2.5 ms → 0.5 ms into the second cycle.
    assert!((source_of(&net, "v1").value(3e-3) - 0.5).abs() < 1e-12);
    let e = assert_err("t\nV1 a 0 PWL(0 0 1 1) r=0.5\n", ErrorKind::BadValue, 2, 23);
    assert!(e.message.contains("one of the time points"), "{e}");
    assert_err("t\nV1 a 0 PWL(0 0 1 1) r=1\n", ErrorKind::BadValue, 2, 23);
    let e = assert_err(
        "t\nV1 a 0 PWL(0 0 1 1) td=1 td=2\n",
        ErrorKind::Syntax,
        2,
        26,
    );
    assert!(e.message.contains("given twice"), "{e}");
    assert_err("t\nV1 a 0 PWL(0 0 1 1) r 0\n", ErrorKind::Syntax, 2, 21);
}

/// `SFFM` and `AM` with ngspice-39's parameter order and defaults: a zero or absent `SFFM`
/// frequency and `AM` modulating frequency are `1/TSTOP` once `.tran` is read.
#[test]
fn sffm_and_am_sources() {
    let net = parse(
        "t\nV1 a 0 SFFM(0.5 2 10k 3 1k 30 60)\nI2 0 b SFFM(0 1m)\nV3 c 0 AM(1.5 0.4 1k 10k 0.2m 0 45)\n\
         V4 d 0 AM(1 0.5)\nR1 a b 1\nR2 c d 1\nR3 d 0 1\n.tran 1u 2m\n",
    );
    assert_eq!(
        source_of(&net, "v1"),
        &SourceSpec::Sffm {
            vo: 0.5,
            va: 2.0,
            fc: 10e3,
            mdi: 3.0,
            fs: 1e3,
            phasec: 30.0,
            phases: 60.0
        }
    );
    assert!(matches!(
        source_of(&net, "i2"),
        &SourceSpec::Sffm { fc, fs, mdi, .. } if fc == 500.0 && fs == 500.0 && mdi == 0.0
    ));
    assert_eq!(
        source_of(&net, "v3"),
        &SourceSpec::Am {
            va: 1.5,
            vo: 0.4,
            mf: 1e3,
            fc: 10e3,
            td: 0.2e-3,
            phasec: 0.0,
            phases: 45.0
        }
    );
    assert!(matches!(
        source_of(&net, "v4"),
        &SourceSpec::Am { mf, fc, td, .. } if mf == 500.0 && fc == 0.0 && td == 0.0
    ));
    assert_err("t\nV1 a 0 SFFM(0 1 -1k)\n", ErrorKind::BadValue, 2, 17);
    assert_err("t\nV1 a 0 AM(1 2 3 4 5 6 7 8)\n", ErrorKind::Syntax, 2, 8);
}

#[test]
fn unsupported_features_inside_cards() {
    let e = assert_err(
        "t\nV1 a 0 TRNOISE(0 1n 0 0)\n",
        ErrorKind::Unsupported,
        2,
        8,
    );
    assert!(e.message.contains("not supported"), "{e}");
    assert!(e.message.contains("TRNOISE"), "{e}");
    let e = assert_err("t\nR1 a 0 1k w=1u\n", ErrorKind::Unsupported, 2, 11);
    assert!(e.message.contains("parameter `w`") && e.message.contains("not supported"));
    let e = assert_err("t\nR1 a 0 1k tc1=-1\n.temp 30\n", ErrorKind::BadValue, 2, 1);
    assert!(e.message.contains("must be positive"), "{e}");
    // A model of a device dirac does not read is ignored with a warning (a model library holds
    // them); a diode that names one is refused, and so is the element that would use it.
    let net =
        parse("t\nR1 a 0 1\n.model j1 NJF(BETA=1e-4 VTO=-2)\n+ LAMBDA=0.1\n.model s1 sw ron=1\n");
    assert_eq!(net.warnings.len(), 2, "{:?}", net.warnings);
    assert!(
        net.warnings[0].message.contains("type `NJF` ignored"),
        "{:?}",
        net.warnings
    );
    let e = assert_err(
        "t\nD1 a 0 q1\n.model q1 NPN(BF=100)\n",
        ErrorKind::MissingModel,
        2,
        8,
    );
    assert!(e.message.contains("a `NPN` model, not a diode's"), "{e}");
    assert_err(
        "t\nJ1 d g 0 j1\n.model j1 NJF(BETA=1e-4)\n",
        ErrorKind::Unsupported,
        2,
        1,
    );
    // A BJT that names a diode's model is refused at the model's name.
    let e = assert_err(
        "t\nQ1 c b 0 dm\n.model dm D\n",
        ErrorKind::MissingModel,
        2,
        10,
    );
    assert!(e.message.contains("a `D` model, not a BJT's"), "{e}");
    assert_err(
        "t\nD1 a 0 dm pj=2\n.model dm D\n",
        ErrorKind::Unsupported,
        2,
        11,
    );
    let e = assert_err(
        "t\n.subckt s a\n.tran 1 2\n.ends\n",
        ErrorKind::Unsupported,
        3,
        1,
    );
    // A `.tran` inside a subcircuit is most often a missing `.ends`: the message says where the
    // open `.subckt` started.
    assert!(e.to_string().contains(".subckt s` opened at line 2"), "{e}");
    let e = assert_err(
        "t\nR1 a 0 1\n.tran 1 2\n.tran 1 3\n",
        ErrorKind::Unsupported,
        4,
        1,
    );
    assert!(e.message.contains("not supported"));
}

#[test]
fn syntax_errors() {
    // Missing value: points just past the end of the card.
    assert_err("t\nR1 a b\n", ErrorKind::Syntax, 2, 7);
    assert_err("t\nR1 a\n", ErrorKind::Syntax, 2, 5);
    // Expression errors point at the offending character, also inside braces.
    assert_err("t\nR1 a b {1+*2}\n", ErrorKind::Syntax, 2, 11);
    assert_err("t\n.param x=(1+2\n", ErrorKind::Syntax, 2, 14);
    assert_err("t\nR1 a b 1k2\n", ErrorKind::Syntax, 2, 10);
    assert_err("t\nR1 a b {1+2\n", ErrorKind::Syntax, 2, 8);
    assert_err("t\nV1 a 0 SIN(0 1 1k\n", ErrorKind::Syntax, 2, 11);
    assert_err("t\nV1 a 0 SIN(0)\n", ErrorKind::Syntax, 2, 8);
    assert_err(
        "t\nV1 a 0 PULSE(0 1 2 3 4 5 6 7 8)\n",
        ErrorKind::Syntax,
        2,
        8,
    );
    assert_err("t\nI1 a 0 PWL(0 0 1)\n", ErrorKind::Syntax, 2, 8);
    assert_err("t\nV1 a 0 1 2\n", ErrorKind::Syntax, 2, 10);
    assert_err("t\n+ 1k\n", ErrorKind::Syntax, 2, 1);
    assert_err("t\nR1 a 0 1\n.ends\n", ErrorKind::Syntax, 3, 1);
    assert_err("t\n.subckt s a\nR1 a 0 1\n", ErrorKind::Syntax, 2, 1);
    assert_err(
        "t\n.subckt s a\nR1 a 0 1\n.ends other\n",
        ErrorKind::Syntax,
        4,
        7,
    );
    assert_err("t\n.control\nrun\n", ErrorKind::Syntax, 2, 1);
    assert_err("t\n.param\n", ErrorKind::Syntax, 2, 7);
    assert_err("t\n.ic a=1\n", ErrorKind::Syntax, 2, 5);
    assert_err("t\n.tran 1\n", ErrorKind::Syntax, 2, 1);
    assert_err(
        "t\nXa n1 n2 sub r=1 3\n.subckt sub a b r=2\n.ends\n",
        ErrorKind::Syntax,
        2,
        18,
    );
    assert_err("t\nR1 a 0 {sqrt(1, 2)}\n", ErrorKind::Syntax, 2, 9);
    // On a continuation line the position is on that line.
    assert_err("t\nR1 a b\n+ {2**}\n", ErrorKind::Syntax, 3, 7);
}

#[test]
fn unknown_and_recursive_params() {
    assert_err("t\nR1 a b {2*rx}\n", ErrorKind::UnknownParam, 2, 11);
    assert_err("t\nR1 a b rx\n", ErrorKind::UnknownParam, 2, 8);
    let e = assert_err(
        "t\n.subckt s a r=1\nR1 a 0 {r}\n.ends\nX1 n s r=2 q=3\n",
        ErrorKind::UnknownParam,
        5,
        12,
    );
    assert!(e.message.contains("no parameter `q`"), "{e}");
    // Subcircuit parameters are not visible outside.
    assert_err(
        "t\n.subckt s a r=1\nR1 a 0 {r}\n.ends\nX1 n s\nR2 n 0 {r}\n",
        ErrorKind::UnknownParam,
        6,
        9,
    );
    // An unused top-level parameter is still checked.
    assert_err(
        "t\nR1 a 0 1\n.param p=1 q={p+zz}\n",
        ErrorKind::UnknownParam,
        3,
        17,
    );
    assert_err(
        "t\n.param a=b+1 b=2*a\nR1 x 0 {a}\n",
        ErrorKind::RecursiveParam,
        2,
        18,
    );
    assert_err(
        "t\n.param a={a}\nR1 x 0 1\n",
        ErrorKind::RecursiveParam,
        2,
        11,
    );
    let e = assert_err("t\nR1 a b {foo(2)}\n", ErrorKind::UnknownFunction, 2, 9);
    assert!(e.message.contains("`foo`"));
}

#[test]
fn bad_values() {
    assert_err("t\nR1 a b 0\n", ErrorKind::BadValue, 2, 8);
    assert_err("t\n.param z=0\nR1 a b {1/z}\n", ErrorKind::BadValue, 3, 9);
    assert_err(
        "t\nL1 a 0 1\nL2 b 0 1\nK1 L1 L2 1.5\n",
        ErrorKind::BadValue,
        4,
        10,
    );
    assert_err("t\nL1 a 0 1\nK1 L1 l1 0.5\n", ErrorKind::BadValue, 3, 7);
    assert_err("t\nV1 a 0 PWL(0 0 2 1 1 2)\n", ErrorKind::BadValue, 2, 20);
    assert_err("t\nV1 a 0 PULSE(0 1 0 -1n)\n", ErrorKind::BadValue, 2, 20);
    assert_err("t\nR1 a 0 1\n.tran 0 1\n", ErrorKind::BadValue, 3, 7);
    assert_err("t\nR1 a 0 1\n.tran 1m -1\n", ErrorKind::BadValue, 3, 10);
    assert_err("t\nR1 a 0 1\n.tran 1m 1 2\n", ErrorKind::BadValue, 3, 12);
    assert_err(
        "t\nD1 a 0 dm\n.model dm D(IS=-1)\n",
        ErrorKind::BadValue,
        3,
        16,
    );
    assert_err("t\nR1 a 0 {sqrt(-1)}\n", ErrorKind::BadValue, 2, 9);
}

#[test]
fn model_and_subcircuit_lookup_errors() {
    assert_err("t\nD1 a 0 nomodel\n", ErrorKind::MissingModel, 2, 8);
    // A model local to a subcircuit is not visible outside it.
    assert_err(
        "t\n.subckt s a\n.model dm D\nD1 a 0 dm\n.ends\nX1 n s\nD2 n 0 dm\n",
        ErrorKind::MissingModel,
        7,
        8,
    );
    assert_err("t\nX1 a b nosuch\n", ErrorKind::UnknownSubckt, 2, 8);
    assert_err(
        "t\n.subckt loop a\nX1 a loop\n.ends\nX1 n loop\n",
        ErrorKind::RecursiveSubckt,
        3,
        6,
    );
    assert_err(
        "t\n.subckt s1 a\nX1 a s2\n.ends\n.subckt s2 a\nXdeep a s1\n.ends\nX1 n s1\n",
        ErrorKind::RecursiveSubckt,
        6,
        9,
    );
    let e = assert_err(
        "t\n.subckt s a b\nR1 a b 1\n.ends\nX1 n s\n",
        ErrorKind::PortMismatch,
        5,
        6,
    );
    assert!(
        e.message.contains("1 node but subcircuit `s` has 2 ports"),
        "{e}"
    );
}

#[test]
fn duplicates_and_dangling_references() {
    assert_err("t\nR1 a 0 1\nr1 b 0 2\n", ErrorKind::DuplicateElement, 3, 1);
    assert_err(
        "t\n.subckt s a\nR1 a 0 1\nR1 a 0 2\n.ends\nX1 n s\n",
        ErrorKind::DuplicateElement,
        4,
        1,
    );
    assert_err(
        "t\n.subckt s a\n.ends\n.subckt S b\n.ends\n",
        ErrorKind::DuplicateDefinition,
        4,
        9,
    );
    assert_err(
        "t\n.model d1 D\n.model D1 D\n",
        ErrorKind::DuplicateDefinition,
        3,
        8,
    );
    assert_err(
        "t\nL1 a 0 1\nR2 b 0 1\nK1 L1 R2 0.5\n",
        ErrorKind::UnknownElement,
        4,
        7,
    );
    assert_err(
        "t\nL1 a 0 1\nK1 L1 L9 0.5\n",
        ErrorKind::UnknownElement,
        3,
        7,
    );
    assert_err("t\nR1 a 0 1\n.ic V(b)=1\n", ErrorKind::UnknownNode, 3, 7);
    assert_err(
        "t\nR1 a 0 1\n.ic V(a)=1 V(gnd)=2\n",
        ErrorKind::UnknownNode,
        3,
        14,
    );
}

#[test]
fn errors_display_file_line_column() {
    let e = parse_netlist("t\nR1 a b {1/0}\n", "circuits/demo.cir").expect_err("bad");
    assert_eq!(
        e.to_string(),
        "circuits/demo.cir:2:9: `1/0` evaluates to inf"
    );
}

#[test]
fn limits_and_names() {
    assert_err("t\n.param 2x=1\n", ErrorKind::Syntax, 2, 8);
    assert_err("t\n.subckt s a r.1=2\n.ends\n", ErrorKind::Syntax, 2, 13);
    // A long chain of parameters is fine; an absurd one is refused, not a stack overflow.
    let chain = |n: usize| {
        let mut src = String::from("chain\n");
        for i in 0..n {
            src.push_str(&format!(".param p{i}=p{}+1\n", i + 1));
        }
        src.push_str(&format!(".param p{n}=0\nR1 a 0 {{p0}}\n"));
        src
    };
    assert_eq!(value_of(&parse(&chain(90)), "r1"), 90.0);
    assert_eq!(err(&chain(2000)).kind, ErrorKind::Unsupported);
    // Deep expressions along a chain count towards the same bound.
    let deep_chain = |n: usize| {
        let mut src = String::from("deep\n");
        for i in 0..n {
            let negs = "-(".repeat(40);
            let close = ")".repeat(40);
            src.push_str(&format!(".param p{i}={negs}p{}{close}\n", i + 1));
        }
        src.push_str(&format!(".param p{n}=1\nR1 a 0 {{p0}}\n"));
        src
    };
    assert_eq!(value_of(&parse(&deep_chain(8)), "r1"), 1.0);
    assert_eq!(err(&deep_chain(30)).kind, ErrorKind::Unsupported);
    // Deep but finite subcircuit nesting.
    let nest = |n: usize| {
        let mut src = String::from("nest\n.subckt s0 a\nR1 a 0 1\n.ends\n");
        for i in 1..=n {
            src.push_str(&format!(".subckt s{i} a\nX1 a s{}\n.ends\n", i - 1));
        }
        src.push_str(&format!("X1 n s{n}\n"));
        src
    };
    let net = parse(&nest(20));
    assert_eq!(net.elements.len(), 1);
    assert_eq!(net.elements[0].name(), format!("{}r1", "x1.".repeat(21)));
    assert_eq!(err(&nest(150)).kind, ErrorKind::Unsupported);
}

#[test]
fn pwl_repeated_time_is_a_warned_jump() {
    let net = parse("t\nV1 a 0 PWL(0 0 1m 0 1m 5 2m 5)\nR1 a 0 1\n");
    assert_eq!(net.warnings.len(), 1);
    assert_eq!((net.warnings[0].line, net.warnings[0].column), (2, 21));
    assert_eq!(source_of(&net, "v1").value(1.5e-3), 5.0);
}

/// An `M` card places its parts: the channel between the inner drain and source (sensing gate
/// and bulk against the inner source), the two bulk junctions oriented by polarity, the overlap
/// capacitances that are not zero and the series resistances with their inner nodes.
#[test]
fn mosfet_places_its_parts() {
    let n = parse(
        "t\n.model p1 pmos (vto=-0.7 kp=50u rd=10 cbd=2f cgso=1n)\n\
         M1 d g s b p1 l=1u w=3u\n",
    );
    let names: Vec<&str> = n.elements.iter().map(Element::name).collect();
    assert_eq!(names, ["m1", "m1 rd", "m1 bd", "m1 bs", "m1 cgs"]);
    match &n.elements[0] {
        Element::Controlled {
            n_plus,
            n_minus,
            source: ControlledSource::Mosfet {
                gate, bulk, source, ..
            },
            ..
        } => {
            assert_eq!((n_plus.as_str(), n_minus.as_str()), ("m1 drain", "s"));
            assert_eq!(
                (gate.as_str(), bulk.as_str(), source.as_str()),
                ("g", "b", "s")
            );
        }
        other => panic!("{other:?}"),
    }
    // A p-channel junction conducts from the drain into the bulk.
    assert_eq!(n.elements[2].terminals(), Some(("m1 drain", "b")));
    // With the source tied to the bulk and the gate to the source, the bulk–source junction
    // and the gate–source overlap are shorted: not placed.
    let tied = parse("t\n.model p1 pmos (cbs=2f cgso=1n)\nM1 d s s s p1 l=1u w=3u\n");
    let names: Vec<&str> = tied.elements.iter().map(Element::name).collect();
    assert_eq!(names, ["m1", "m1 bd"]);
    match &n.elements[4] {
        Element::C { n1, n2, value, .. } => {
            assert_eq!((n1.as_str(), n2.as_str()), ("g", "s"));
            assert!((value - 3e-15).abs() < 1e-28);
        }
        other => panic!("{other:?}"),
    }
}

/// What an `M` card refuses, at its place: an undefined model, a model of another device, a
/// level other than 1 (at the value), Meyer capacitances (`TOX`, at the card), an instance
/// parameter it does not read (at the parameter).
#[test]
fn mosfet_refusals() {
    assert_err("t\nM1 d g 0 0 none\n", ErrorKind::MissingModel, 2, 12);
    assert_err(
        "t\n.model dm D\nM1 d g 0 0 dm\n",
        ErrorKind::MissingModel,
        3,
        12,
    );
    let e = assert_err(
        "t\n.model n3 nmos level=3 vto=1\nM1 d g 0 0 n3\n",
        ErrorKind::Unsupported,
        2,
        22,
    );
    assert!(e.message.contains("only level 1"), "{e}");
    let e = assert_err(
        "t\n.model nt nmos (tox=10n)\nM1 d g 0 0 nt\n",
        ErrorKind::BadValue,
        3,
        1,
    );
    assert!(e.message.contains("Meyer"), "{e}");
    assert_err(
        "t\n.model n1 nmos\nM1 d g 0 0 n1 w=1u tnom=50\n",
        ErrorKind::Unsupported,
        3,
        20,
    );
    // Three nodes or five: the message says an M card has four and then its model.
    let e = assert_err(
        "t\n.model n1 nmos\nM1 d g 0 n1 L=1u\n",
        ErrorKind::Syntax,
        3,
        13,
    );
    assert!(e.message.contains("needs four nodes"), "{e}");
    let e = assert_err(
        "t\n.model n1 nmos\nM1 d g 0 0 0 n1 L=1u\n",
        ErrorKind::Syntax,
        3,
        14,
    );
    assert!(e.message.contains("`n1` follows `0`"), "{e}");
    // A model library with a level-1 card beside a BSIM one that no element uses reads.
    parse("t\n.model nb nmos level=54 version=4.5\n.model n1 nmos\nM1 d g 0 0 n1\nV1 g 0 1\n");
    // `off` after the last assignment (where SPICE writes it) ends that value and is ignored with
    // a warning, on an M card as on a D card.
    let net =
        parse("t\n.model n1 nmos\n.model dm d\nM1 d g 0 0 n1 W=10u off\nD1 d 0 dm area=2 off\n");
    let offs = net
        .warnings
        .iter()
        .filter(|w| w.message.contains("`off` ignored"))
        .count();
    assert_eq!(offs, 2, "{:?}", net.warnings);
}
