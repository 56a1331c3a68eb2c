//! Input formats for dirac.
//!
//! [`netlist`] is a SPICE-subset netlist front end: [`parse_netlist`] reads netlist text (`R L C V
//! I K D X` cards, `.param` arithmetic, `.subckt`, `.model D`, `.tran`, `.ic`) into a flat
//! [`Netlist`] with evaluated values, or a [`NetlistError`] that names the file, line and column.
//! [`circuit`] turns a parsed netlist into an interconnection of stock parts ([`build_circuit`]).
//!
//! ```
//! use dirac_io::{Element, parse_netlist};
//!
//! let net = parse_netlist(
//!     "RC low-pass\n.param r0=1k\nV1 in 0 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out {r0}\nC1 out 0 10uF\n.tran 10u 5m uic\n",
//!     "rc.cir",
//! )
//! .unwrap();
//! assert_eq!(net.nodes(), ["in", "out"]);
//! assert!(matches!(net.element("R1"), Some(Element::R { value, .. }) if *value == 1000.0));
//! ```

#![warn(missing_docs)]

pub mod circuit;
pub mod convert;
pub mod netlist;
pub mod run;
pub mod scene;

pub use circuit::{Circuit, CircuitError, Signal, SignalKind, build_circuit, waveform};
pub use convert::{ConvertError, netlist_to_scene};
pub use netlist::{
    DiodeModel, Element, ErrorKind, Netlist, NetlistError, Origin, Pos, SourceSpec, Tran, Warning,
    parse_netlist, parse_spice_number,
};
pub use run::{RunError, RunSettings, RunSummary, run_circuit};
pub use scene::{
    BuiltScene, Execution, Location, Quantity, Recording, Scene, SceneError, SceneSignal,
    SceneSimulation, recorded_columns, run_scene, run_scene_recorded,
};
