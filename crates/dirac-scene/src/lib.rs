//! Scene files: a model of stock parts joined at their ports, with its integrator settings and
//! what to record, written by hand in TOML.
//!
//! [`Scene::parse`] reads a scene (every error — bad syntax, an unknown key, a value of the wrong
//! type, an unknown part type, port or coordinate, a duplicate name, a parameter out of range —
//! names `file:line:column`), [`Scene::to_toml`] writes it back (parsing the output gives an equal
//! scene), [`Scene::build`] turns it into a [`BuiltScene`] (the interconnection, initial data,
//! [`dirac_sim::IntegratorOptions`], representation, start and signals), and
//! [`BuiltScene::simulation`] gives the [`dirac_sim::Simulation`] that runs it in any
//! representation, staggered included. [`netlist_to_scene`] writes a netlist as a scene.
//!
//! # The format
//!
//! ```toml
//! # ── How to integrate ────────────────────────────────────────────────────────────────────────
//! [simulation]
//! representation = "monolithic" # monolithic | constraint | force | staggered (default monolithic)
//! # splitting = "gauss-seidel"  # only with staggered: gauss-seidel (default) | jacobi
//! scheme = "plus"               # plus | minus | symmetric (default plus)
//! discretisation = "gauss"      # midpoint | trapezoid | simpson | gauss | lobatto (default midpoint)
//! order = 4                     # even; 2 for midpoint/trapezoid/simpson; 2s for gauss/lobatto
//! h = 0.05                      # step size (required)
//! t_end = 50.0                  # end time (required): round(t_end / h) steps
//! initial = "given"             # given (q0/v0, made consistent) | equilibrium (steady state)
//! start_ramp = false            # first step as 99 growing substeps: damps a stiff start (default off)
//! composition = "none"          # none | yoshida4 | yoshida6 | yoshida8 | kahan-li6 | kahan-li8:
//!                               # each step as symmetric substeps (order 4, 6, 8, 6, 8 from order 2)
//!
//! # ── Parts: `name` (unique, no dots), `type` (a stock part), its parameters, q0/v0 ─────────────
//! [[part]]
//! name = "C1"
//! type = "capacitor"
//! c = 3.0
//! q0 = 1.0                      # initial positions: a number (one coordinate), a list in
//!                               # coordinate order, or a table by name, e.g. { q = 1.0 };
//!                               # omitted coordinates start at 0
//!
//! [[part]]
//! name = "L1"
//! type = "inductor"
//! l = 0.75
//! v0 = { q = 0.0 }              # initial rates (a current here), same forms as q0
//!
//! [[part]]
//! name = "R1"
//! type = "resistor"
//! r = 0.1
//!
//! # ── Connections: `type` node | joint | coupling, and a unique `name` ────────────────────────
//! [[connection]]
//! type = "node"                 # KCL: Σ sign·flow = 0 over `part.port` with signs (+1: the flow
//! name = "n1"                   # enters the node, i.e. the node is the part's − terminal);
//! ports = [["L1.i", 1.0], ["R1.i", -1.0]]   # "+L1.i" / "-R1.i" is the same
//!
//! [[connection]]
//! type = "node"
//! name = "n2"
//! ports = ["+R1.i", "-C1.i"]
//!
//! [[connection]]
//! type = "node"
//! name = "n3"                   # a redundant node (KCL at every node) is dropped with a warning
//! ports = ["+C1.i", "-L1.i"]
//!
//! # A rigid joint (equal flows) and a coupling element between two ports look like:
//! #   [[connection]]
//! #   type = "joint"
//! #   name = "shaft"
//! #   a = "M.theta"
//! #   b = "G.theta1"
//! #
//! #   [[connection]]
//! #   type = "coupling"
//! #   name = "k12"
//! #   a = "A.x"
//! #   b = "B.x"
//! #   element = { type = "spring", k = 1.0, k3 = 0.0, rest = 0.0 }   # k3 ≠ 0: Duffing spring
//! #   # or { type = "damper", c = 0.1 }, or { type = "force_source", waveform = 2.0 }
//!
//! # ── What to record ──────────────────────────────────────────────────────────────────────────
//! [record]
//! signals = ["C1.q", "L1.i", "L1.q'"] # `part.coordinate` (its value), `part.coordinate'` (its
//!                                     # rate), `part.port` (the flow of a port that is not a
//!                                     # coordinate, e.g. a current `i`); default: every coordinate
//!                                     # and every such flow
//! energy = true                       # total energy (column `energy`)
//! power = ["R1"]                      # power of each part's forces (`power(R1)`)
//! residuals = true                    # the steps' constraint residual (`constraint_residual`)
//! forces = ["n1"]                     # a node's potential, a joint's or coupling's force
//!                                     # (`force(n1)`); every value is at the row's time t_k
//! ```
//!
//! # Stock parts
//!
//! | `type` | parameters (defaults) | coordinates | ports |
//! |---|---|---|---|
//! | `resistor` | `r` ≥ 0 | `q` | `i` |
//! | `inductor` | `l` > 0 | `q` | `i` |
//! | `capacitor` | `c` > 0 | `q` | `i` |
//! | `voltage_source` | `waveform` | `q` | `i` |
//! | `current_source` | `waveform` | `q`, `phi` | `i` |
//! | `coupled_inductors` | `l1`, `l2` > 0, `k` ∈ [−1, 1] | `q1`, `q2` | `i1`, `i2` |
//! | `diode` | SPICE level-1 card, every key optional with ngspice's default: `is` (1e-14), `n` (1), `rs` (0), `cjo` (0), `vj` (1), `m` (0.5), `fc` (0.5), `tt` (0), `bv` (none), `ibv` (1e-3), `nbv` (`n`), `eg` (1.11), `xti` (3), `tnom` (°C, `temp`), `tcv`, `trs1`, `trs2`, `ttt1`, `ttt2`, `tm1`, `tm2` (0), `area` (1); `temp` (°C, 27), `gmin` (1e-12) | `q`, `phi` | `i` |
//! | `saturating_inductor` | `l0` > 0, `l_inf` ∈ [0, l0], `i_sat` > 0 | `q` | `i` |
//! | `mass` | `m` > 0 (a wall spring or damper is a coupling to a `ground`) | `x` | `x` |
//! | `inertia` | `j` > 0 (torsion or friction to the frame: a coupling to a `ground`) | `theta` | `theta` |
//! | `spring` (to ground) | `k` ≥ 0, `k3` (0), `rest` (0), `rotational` (false) | `x` / `theta` | same |
//! | `damper` (to ground) | `c` ≥ 0, `rotational` | `x` / `theta` | same |
//! | `force_source` (to ground) | `waveform`, `rotational` | `x` / `theta` | same |
//! | `ground` | `position` (0), `rotational` | `x` / `theta` | same |
//! | `pendulum` | `m`, `length` > 0, `g` (9.81), `pivot` ([0, 0]); q0 default: hanging | `x`, `y` | `x`, `y` |
//! | `planar_linkage` | `g` (9.81), `bodies = [{ name, m, j }]`, `pins = [{ body, point, ground = [x, y] }` or `{ body, point, to, at }]` | `{body}.x`, `{body}.y`, `{body}.theta` | same |
//! | `dc_motor` | `k`, `r`, `l`, `j` ≥ 0, `b` (0) | `q`, `theta` | `i`, `theta` |
//! | `ideal_transformer` | `n` ≠ 0 | `q1`, `q2` | `i1`, `i2` |
//! | `ideal_gear` | `ratio` ≠ 0 | `theta1`, `theta2` | `theta1`, `theta2` |
//! | `vcvs` (SPICE `E`) | `gain` | `q`, `q_c`, `phi_c` | `i` (output), `ic` (across the controlling nodes; draws no current) |
//! | `vccs` (SPICE `G`) | `gm` | `q`, `phi`, `q_c`, `phi_c` | `i`, `ic` (as `vcvs`) |
//! | `cccs` (SPICE `F`) | `gain` | `q`, `phi`, `q_c` | `i`, `ic` (a short, in series with the controlling branch) |
//! | `ccvs` (SPICE `H`) | `r` | `q`, `q_c` | `i`, `ic` (as `cccs`) |
//! | `rolling_disk` | `m`, `i`, `j`, `radius` > 0 (rolls without slipping; use `scheme = "symmetric"`) | `x`, `y`, `theta`, `phi` | same |
//!
//! A `waveform` is a number (DC) or a table with a `shape`, with ngspice's semantics
//! ([`dirac_components::Waveform`]): `{ shape = "dc", value }`,
//! `{ shape = "sin", amplitude, frequency, offset = 0, delay = 0, damping = 0, phase = 0 }`
//! (phase in degrees), `{ shape = "pulse", v1, v2, width, delay = 0, rise = 0, fall = 0, period,
//! pulses }` (no `period`: one pulse; no `pulses`, SPICE's `NP`: no end),
//! `{ shape = "pwl", points = [[t, v], …] }`.
//!
//! ```
//! use dirac_scene::Scene;
//!
//! let scene = Scene::parse(
//!     r#"
//! [simulation]
//! h = 0.1
//! t_end = 1.0
//!
//! [[part]]
//! name = "A"
//! type = "mass"
//! m = 1.0
//! q0 = 1.0
//!
//! [[part]]
//! name = "wall"
//! type = "ground"
//!
//! [[connection]]
//! type = "coupling"
//! name = "wall-A"
//! a = "A.x"
//! b = "wall.x"
//! element = { type = "spring", k = 1.0 }
//!
//! [record]
//! signals = ["A.x", "A.x'"]
//! "#,
//!     "oscillator.toml",
//! )
//! .unwrap();
//! let built = scene.build().unwrap();
//! assert_eq!(built.steps(), 10);
//! assert_eq!(Scene::parse(&scene.to_toml().unwrap(), "again.toml").unwrap(), scene);
//!
//! let err = Scene::parse("[simulation]\nh = 0.1\nt_end = 1\nstep = 2\n", "bad.toml").unwrap_err();
//! assert_eq!(err.to_string(), "bad.toml:4:1: unknown field `step`, expected one of `representation`, `splitting`, `scheme`, `discretisation`, `initial`, `order`, `start_ramp`, `composition`, `h`, `t_end`");
//! ```

mod convert;
mod scene;

pub use convert::{ConvertError, netlist_to_scene};
pub use scene::build::{BuiltScene, MAX_ORDER};
pub use scene::error::{Location, Origin, SceneError};
pub use scene::model::{
    ActuatorElement, BodySpec, CompositionSpec, Connection, ConnectionKind, DamperParams,
    DiodeParams, DiscretisationSpec, ELEMENT_TYPES, ElementSpec, ForceSourceParams, GroundParams,
    InertiaSpec, Initial, InitialSpec, NodePort, PART_TYPES, Part, PartKind, PinSpec,
    PlanarLinkageParams, RIGID_JOINT_TYPES, Record, RepresentationSpec, RigidBodyParams,
    RigidJointSpec, RotationSpec, Scene, SchemeSpec, Simulation, SourceParams, SplittingSpec,
    SpringParams, WaveformSpec,
};

impl Scene {
    /// Parses and checks scene text read from `file` (the name used in error messages).
    pub fn parse(text: &str, file: &str) -> Result<Self, SceneError> {
        scene::parse::parse_scene(text, file)
    }

    /// Reads, parses and checks the scene file at `path`.
    pub fn from_file(path: impl AsRef<std::path::Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        Self::parse(&text, &file)
    }

    /// The scene as TOML text; [`Scene::parse`] of it gives an equal scene.
    pub fn to_toml(&self) -> Result<String, SceneError> {
        toml::to_string(self).map_err(|e| SceneError::Serialise(e.to_string()))
    }
}
