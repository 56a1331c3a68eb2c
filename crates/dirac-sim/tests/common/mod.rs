//! Circuits shared by the integration tests.

use dirac_components::{Capacitor, Resistor, VoltageSource, Waveform};
use dirac_graph::Interconnection;
use dirac_sim::{Probe, Signal};

/// A voltage source driving a capacitor through a resistor (nodes `in` and `out`), with the
/// capacitor's charge `q` as the one signal.
pub fn source_rc(wave: Waveform, r: f64, c: f64) -> (Interconnection, Vec<Signal>) {
    let mut g = Interconnection::new();
    g.add_subsystem(VoltageSource::new(wave).unwrap().subsystem("V"))
        .unwrap();
    g.add_subsystem(Resistor::new(r).unwrap().subsystem("R"))
        .unwrap();
    g.add_subsystem(Capacitor::new(c).unwrap().subsystem("C"))
        .unwrap();
    let port = |g: &Interconnection, p: &str| g.port(p, "i").unwrap();
    let (pv, pr, pc) = (port(&g, "V"), port(&g, "R"), port(&g, "C"));
    g.node("in", vec![(pv, -1.0), (pr, -1.0)]).unwrap();
    g.node("out", vec![(pr, 1.0), (pc, -1.0)]).unwrap();
    let signals = vec![Signal::new("q", Probe::position(&g, "C", "q").unwrap())];
    (g, signals)
}
