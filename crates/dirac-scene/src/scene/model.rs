//! The scene data model: what a scene file says, as Rust values (serialisable back to TOML).

use std::collections::BTreeMap;
use std::fmt;

use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::ser::{SerializeMap, SerializeSeq, Serializer};
use serde::{Deserialize, Serialize};

use super::error::Origin;

/// A whole scene: settings, parts, connections and what to record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scene {
    /// How to integrate.
    pub simulation: Simulation,
    /// The parts, in the order of the file (which is the order of the global coordinates).
    #[serde(rename = "part", skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<Part>,
    /// The connections between ports.
    #[serde(rename = "connection", skip_serializing_if = "Vec::is_empty")]
    pub connections: Vec<Connection>,
    /// What to record.
    #[serde(skip_serializing_if = "Record::is_empty")]
    pub record: Record,
}

/// How couplings and connections become equations (`representation = ...`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RepresentationSpec {
    /// One system; coupling potentials in the one Lagrangian (`"monolithic"`, the default).
    #[default]
    Monolithic,
    /// Couplings on massless endpoint coordinates tied by joints (`"constraint"`).
    Constraint,
    /// Coupling potentials as equal-and-opposite forces (`"force"`).
    Force,
    /// Co-simulation: every part stepped on its own against frozen partners (`"staggered"`);
    /// needs couplings only (no nodes or joints).
    Staggered,
}

/// Order of the staggered co-simulation (`splitting = ...`, only with `"staggered"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SplittingSpec {
    /// Part `i` sees the new values of parts before it (`"gauss-seidel"`, the default).
    #[default]
    GaussSeidel,
    /// Every part sees its partners' values from the start of the step (`"jacobi"`).
    Jacobi,
}

/// The forced discrete Dirac scheme (`scheme = ...`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeSpec {
    /// The (+) step, constraint forms at `q_k` (`"plus"`, the default).
    #[default]
    Plus,
    /// The (−) step, constraint forms at `q_{k+1}` (`"minus"`).
    Minus,
    /// (−) over `h/2` then (+) over `h/2` (`"symmetric"`).
    Symmetric,
}

/// Path and quadrature (`discretisation = ...`, with `order = ...` for Gauss and Lobatto).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DiscretisationSpec {
    /// Linear path, midpoint rule (order 2, the default).
    #[default]
    Midpoint,
    /// Linear path, trapezoid rule (order 2).
    Trapezoid,
    /// Linear path, Simpson's rule (order 2).
    Simpson,
    /// Degree-`s` path with `s` Gauss nodes (order `2s`).
    Gauss,
    /// Degree-`s` path with `s + 1` Lobatto nodes (order `2s`).
    Lobatto,
}

/// Where a run starts (`initial = ...`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitialSpec {
    /// From the parts' `q0` and `v0` (`"given"`, the default), made consistent where the model's
    /// algebraic relations fix values that were not given.
    #[default]
    Given,
    /// From the steady state: static equilibrium of a mechanism, the DC operating point of a
    /// circuit (`"equilibrium"`).
    Equilibrium,
}

impl InitialSpec {
    fn is_given(&self) -> bool {
        *self == Self::Given
    }
}

/// A stock composition (`composition = ...`), named as in [`dirac_sim::Composition::NAMES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CompositionSpec {
    /// A single step (the default).
    #[serde(rename = "none")]
    None,
    /// Yoshida's triple jump, order 4.
    #[serde(rename = "yoshida4")]
    Yoshida4,
    /// Yoshida's solution A, order 6.
    #[serde(rename = "yoshida6")]
    Yoshida6,
    /// Yoshida's solution A, order 8.
    #[serde(rename = "yoshida8")]
    Yoshida8,
    /// Kahan and Li's `s9odr6a`, order 6.
    #[serde(rename = "kahan-li6")]
    KahanLi6,
    /// Kahan and Li's `s17odr8a`, order 8.
    #[serde(rename = "kahan-li8")]
    KahanLi8,
}

impl CompositionSpec {
    /// The composition this names.
    #[must_use]
    pub fn composition(self) -> dirac_sim::Composition {
        use dirac_sim::Composition;
        match self {
            Self::None => Composition::single(),
            Self::Yoshida4 => Composition::yoshida4(),
            Self::Yoshida6 => Composition::yoshida6(),
            Self::Yoshida8 => Composition::yoshida8(),
            Self::KahanLi6 => Composition::kahan_li6(),
            Self::KahanLi8 => Composition::kahan_li8(),
        }
    }
}

/// The `[simulation]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// Representation (default monolithic).
    #[serde(default)]
    pub representation: RepresentationSpec,
    /// Splitting of a staggered run (default Gauss–Seidel; only with `"staggered"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub splitting: Option<SplittingSpec>,
    /// Scheme (default plus).
    #[serde(default)]
    pub scheme: SchemeSpec,
    /// Discretisation (default midpoint).
    #[serde(default)]
    pub discretisation: DiscretisationSpec,
    /// Where the run starts: the given `q0`/`v0` (default) or the static equilibrium / steady
    /// state (MATH §7).
    #[serde(default, skip_serializing_if = "InitialSpec::is_given")]
    pub initial: InitialSpec,
    /// Order of the step map: even, 2 for midpoint, trapezoid and Simpson (the default), `2s`
    /// for Gauss and Lobatto of degree `s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<usize>,
    /// Take the first step as the start ramp's geometrically growing substeps
    /// ([`dirac_sim::StartRamp`], default off): stiff modes of a start off the slow manifold
    /// then decay instead of ringing.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub start_ramp: bool,
    /// The step as a symmetric composition of substeps (default: a single step): Yoshida's of
    /// order 4, 6, 8 or Kahan and Li's of order 6, 8 ([`dirac_sim::Composition`]). It raises a
    /// second-order discretisation (midpoint, trapezoid) to that order when the scene has no
    /// constraints or uses the symmetric scheme; on a separable scene with the trapezoid rule
    /// every substep is an explicit Störmer–Verlet step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub composition: Option<CompositionSpec>,
    /// Step size.
    pub h: f64,
    /// End time: the run takes `round(t_end / h)` steps.
    pub t_end: f64,
    /// Where it was written.
    #[serde(skip)]
    pub origin: Origin,
}

/// A part: a name, a stock part type with its parameters, and initial conditions.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Part {
    /// Unique name (no `.`): the prefix of its ports and signals.
    pub name: String,
    /// The stock part and its parameters (`type = ...` plus the parameter keys).
    #[serde(flatten)]
    pub kind: PartKind,
    /// Initial positions (default 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q0: Option<Initial>,
    /// Initial velocities / rates (default 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v0: Option<Initial>,
    /// Where it was written.
    #[serde(skip)]
    pub origin: Origin,
}

/// Initial values of a part's coordinates: one number (a one-coordinate part), a list in
/// coordinate order, or a table by coordinate name (unnamed coordinates start at 0).
#[derive(Debug, Clone, PartialEq)]
pub enum Initial {
    /// `q0 = 1.0`
    Value(f64),
    /// `q0 = [1.0, 0.0]`
    List(Vec<f64>),
    /// `q0 = { x = 1.0, y = -2.0 }`
    Named(Vec<(String, f64)>),
}

impl Serialize for Initial {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Value(v) => s.serialize_f64(*v),
            Self::List(values) => values.serialize(s),
            Self::Named(values) => {
                let mut map = s.serialize_map(Some(values.len()))?;
                for (k, v) in values {
                    map.serialize_entry(k, v)?;
                }
                map.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for Initial {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Initial;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number, a list of numbers or a table of numbers by coordinate name")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Initial, E> {
                Ok(Initial::Value(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Initial, E> {
                Ok(Initial::Value(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Initial, E> {
                Ok(Initial::Value(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Initial, A::Error> {
                let mut out = Vec::new();
                while let Some(v) = seq.next_element::<f64>()? {
                    out.push(v);
                }
                Ok(Initial::List(out))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Initial, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = map.next_entry::<String, f64>()? {
                    out.push((k, v));
                }
                Ok(Initial::Named(out))
            }
        }
        d.deserialize_any(V)
    }
}

/// A source's time function (`waveform = ...`): a number for DC, or a table with a `shape`
/// (`"dc"`, `"sin"`, `"pulse"`, `"pwl"`), with ngspice's semantics (see
/// [`dirac_components::Waveform`]).
#[derive(Debug, Clone, PartialEq)]
pub enum WaveformSpec {
    /// `waveform = 12.0` or `{ shape = "dc", value = 12.0 }`.
    Dc(f64),
    /// `{ shape = "sin", offset = 0, amplitude = 10, frequency = 50, delay = 0, damping = 0,
    /// phase = 0 }`: `offset`, `delay`, `damping` and `phase` (degrees) default to 0.
    Sin {
        /// Offset.
        offset: f64,
        /// Amplitude.
        amplitude: f64,
        /// Frequency in Hz.
        frequency: f64,
        /// Delay.
        delay: f64,
        /// Damping factor (1/s).
        damping: f64,
        /// Phase in degrees.
        phase: f64,
    },
    /// `{ shape = "pulse", v1 = 0, v2 = 5, delay = 0, rise = 0, fall = 0, width = 1, period = 2,
    /// pulses = 3 }`: `delay`, `rise` and `fall` default to 0; without `period`, a single pulse;
    /// without `pulses` (SPICE's `NP`), the train has no end.
    Pulse {
        /// Initial value.
        v1: f64,
        /// Pulsed value.
        v2: f64,
        /// Delay.
        delay: f64,
        /// Rise time.
        rise: f64,
        /// Fall time.
        fall: f64,
        /// Pulse width.
        width: f64,
        /// Period (`None`: a single pulse).
        period: Option<f64>,
        /// Number of periods after which the value stays `v1` (`None`: no end).
        pulses: Option<f64>,
    },
    /// `{ shape = "sffm", offset = 0, amplitude = 1, carrier = 10e3, index = 3, signal = 1e3,
    /// carrier_phase = 0, signal_phase = 0 }` (SPICE's `SFFM(VO VA FC MDI FS PHASEC PHASES)`):
    /// `offset`, `index` and the phases (degrees) default to 0.
    Sffm {
        /// Offset.
        offset: f64,
        /// Amplitude.
        amplitude: f64,
        /// Carrier frequency in Hz.
        carrier: f64,
        /// Modulation index.
        index: f64,
        /// Signal frequency in Hz.
        signal: f64,
        /// Carrier phase in degrees.
        carrier_phase: f64,
        /// Signal phase in degrees.
        signal_phase: f64,
    },
    /// `{ shape = "am", amplitude = 1, offset = 0.5, modulation = 1e3, carrier = 10e3, delay = 0,
    /// phase = 0 }` (ngspice's `AM(VA VO MF FC TD PHASEC PHASES)`, `phase` its `PHASES`, applied to
    /// both sines as ngspice-39 does): `offset`, `delay` and `phase` default to 0.
    Am {
        /// Amplitude.
        amplitude: f64,
        /// Offset of the modulating sine.
        offset: f64,
        /// Modulating frequency in Hz.
        modulation: f64,
        /// Carrier frequency in Hz.
        carrier: f64,
        /// Delay.
        delay: f64,
        /// Phase of both sines in degrees.
        phase: f64,
    },
    /// `{ shape = "exp", v1 = 0, v2 = 5, rise_delay = 1e-3, rise_tau = 1e-4, fall_delay = 2e-3,
    /// fall_tau = 1e-4 }` (SPICE's `EXP(V1 V2 TD1 TAU1 TD2 TAU2)`): every key needed.
    Exp {
        /// Initial value.
        v1: f64,
        /// The value the rise tends to.
        v2: f64,
        /// Start of the rise.
        rise_delay: f64,
        /// Time constant of the rise.
        rise_tau: f64,
        /// Start of the fall.
        fall_delay: f64,
        /// Time constant of the fall.
        fall_tau: f64,
    },
    /// `{ shape = "pwl", points = [[0, 0], [1e-3, 5]], delay = 0, repeat = 0 }`: `(time, value)`
    /// points, times non-decreasing; the optional `delay` (SPICE's `td=`) shifts the whole
    /// sequence and `repeat` (SPICE's `r=`, one of the points' times before the last) repeats the
    /// stretch from that time to the last point forever.
    Pwl {
        /// `(time, value)` points.
        points: Vec<[f64; 2]>,
        /// Delay of the whole sequence.
        delay: f64,
        /// Time from which the sequence repeats after its last point (`None`: held).
        repeat: Option<f64>,
    },
}

/// The raw table of a waveform, all keys optional (checked against the shape afterwards).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WaveformTable {
    shape: String,
    value: Option<f64>,
    offset: Option<f64>,
    amplitude: Option<f64>,
    frequency: Option<f64>,
    delay: Option<f64>,
    damping: Option<f64>,
    phase: Option<f64>,
    v1: Option<f64>,
    v2: Option<f64>,
    rise: Option<f64>,
    fall: Option<f64>,
    width: Option<f64>,
    period: Option<f64>,
    pulses: Option<f64>,
    points: Option<Vec<[f64; 2]>>,
    repeat: Option<f64>,
    rise_delay: Option<f64>,
    rise_tau: Option<f64>,
    fall_delay: Option<f64>,
    fall_tau: Option<f64>,
    carrier: Option<f64>,
    index: Option<f64>,
    signal: Option<f64>,
    carrier_phase: Option<f64>,
    signal_phase: Option<f64>,
    modulation: Option<f64>,
}

impl WaveformTable {
    fn into_spec<E: de::Error>(self) -> Result<WaveformSpec, E> {
        let given: [(&str, bool); 26] = [
            ("value", self.value.is_some()),
            ("offset", self.offset.is_some()),
            ("amplitude", self.amplitude.is_some()),
            ("frequency", self.frequency.is_some()),
            ("delay", self.delay.is_some()),
            ("damping", self.damping.is_some()),
            ("phase", self.phase.is_some()),
            ("v1", self.v1.is_some()),
            ("v2", self.v2.is_some()),
            ("rise", self.rise.is_some()),
            ("fall", self.fall.is_some()),
            ("width", self.width.is_some()),
            ("period", self.period.is_some()),
            ("pulses", self.pulses.is_some()),
            ("points", self.points.is_some()),
            ("repeat", self.repeat.is_some()),
            ("rise_delay", self.rise_delay.is_some()),
            ("rise_tau", self.rise_tau.is_some()),
            ("fall_delay", self.fall_delay.is_some()),
            ("fall_tau", self.fall_tau.is_some()),
            ("carrier", self.carrier.is_some()),
            ("index", self.index.is_some()),
            ("signal", self.signal.is_some()),
            ("carrier_phase", self.carrier_phase.is_some()),
            ("signal_phase", self.signal_phase.is_some()),
            ("modulation", self.modulation.is_some()),
        ];
        let allowed: &[&str] = match self.shape.as_str() {
            "dc" => &["value"],
            "sin" => &[
                "offset",
                "amplitude",
                "frequency",
                "delay",
                "damping",
                "phase",
            ],
            "pulse" => &[
                "v1", "v2", "delay", "rise", "fall", "width", "period", "pulses",
            ],
            "exp" => &[
                "v1",
                "v2",
                "rise_delay",
                "rise_tau",
                "fall_delay",
                "fall_tau",
            ],
            "sffm" => &[
                "offset",
                "amplitude",
                "carrier",
                "index",
                "signal",
                "carrier_phase",
                "signal_phase",
            ],
            "am" => &[
                "amplitude",
                "offset",
                "modulation",
                "carrier",
                "delay",
                "phase",
            ],
            "pwl" => &["points", "delay", "repeat"],
            other => {
                return Err(E::custom(format!(
                    "unknown waveform shape `{other}`, expected one of `dc`, `sin`, `pulse`, `exp`, \
                     `sffm`, `am`, `pwl`"
                )));
            }
        };
        if let Some((key, _)) = given
            .iter()
            .find(|(key, set)| *set && !allowed.contains(key))
        {
            return Err(E::custom(format!(
                "key `{key}` does not belong to a `{}` waveform (its keys are {})",
                self.shape,
                super::error::listed(allowed.iter())
            )));
        }
        let need = |v: Option<f64>, key: &str| {
            v.ok_or_else(|| E::custom(format!("a `{}` waveform needs the key `{key}`", self.shape)))
        };
        Ok(match self.shape.as_str() {
            "dc" => WaveformSpec::Dc(need(self.value, "value")?),
            "sin" => WaveformSpec::Sin {
                offset: self.offset.unwrap_or(0.0),
                amplitude: need(self.amplitude, "amplitude")?,
                frequency: need(self.frequency, "frequency")?,
                delay: self.delay.unwrap_or(0.0),
                damping: self.damping.unwrap_or(0.0),
                phase: self.phase.unwrap_or(0.0),
            },
            "pulse" => WaveformSpec::Pulse {
                v1: need(self.v1, "v1")?,
                v2: need(self.v2, "v2")?,
                delay: self.delay.unwrap_or(0.0),
                rise: self.rise.unwrap_or(0.0),
                fall: self.fall.unwrap_or(0.0),
                width: need(self.width, "width")?,
                period: self.period,
                pulses: self.pulses,
            },
            "exp" => WaveformSpec::Exp {
                v1: need(self.v1, "v1")?,
                v2: need(self.v2, "v2")?,
                rise_delay: need(self.rise_delay, "rise_delay")?,
                rise_tau: need(self.rise_tau, "rise_tau")?,
                fall_delay: need(self.fall_delay, "fall_delay")?,
                fall_tau: need(self.fall_tau, "fall_tau")?,
            },
            "sffm" => WaveformSpec::Sffm {
                offset: self.offset.unwrap_or(0.0),
                amplitude: need(self.amplitude, "amplitude")?,
                carrier: need(self.carrier, "carrier")?,
                index: self.index.unwrap_or(0.0),
                signal: need(self.signal, "signal")?,
                carrier_phase: self.carrier_phase.unwrap_or(0.0),
                signal_phase: self.signal_phase.unwrap_or(0.0),
            },
            "am" => WaveformSpec::Am {
                amplitude: need(self.amplitude, "amplitude")?,
                offset: self.offset.unwrap_or(0.0),
                modulation: need(self.modulation, "modulation")?,
                carrier: need(self.carrier, "carrier")?,
                delay: self.delay.unwrap_or(0.0),
                phase: self.phase.unwrap_or(0.0),
            },
            _ => WaveformSpec::Pwl {
                points: self.points.ok_or_else(|| {
                    E::custom("a `pwl` waveform needs the key `points`".to_string())
                })?,
                delay: self.delay.unwrap_or(0.0),
                repeat: self.repeat,
            },
        })
    }
}

impl Serialize for WaveformSpec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Dc(v) => s.serialize_f64(*v),
            Self::Sin {
                offset,
                amplitude,
                frequency,
                delay,
                damping,
                phase,
            } => {
                let mut m = s.serialize_map(Some(7))?;
                m.serialize_entry("shape", "sin")?;
                m.serialize_entry("offset", offset)?;
                m.serialize_entry("amplitude", amplitude)?;
                m.serialize_entry("frequency", frequency)?;
                m.serialize_entry("delay", delay)?;
                m.serialize_entry("damping", damping)?;
                m.serialize_entry("phase", phase)?;
                m.end()
            }
            Self::Pulse {
                v1,
                v2,
                delay,
                rise,
                fall,
                width,
                period,
                pulses,
            } => {
                let mut m = s.serialize_map(None)?;
                m.serialize_entry("shape", "pulse")?;
                m.serialize_entry("v1", v1)?;
                m.serialize_entry("v2", v2)?;
                m.serialize_entry("delay", delay)?;
                m.serialize_entry("rise", rise)?;
                m.serialize_entry("fall", fall)?;
                m.serialize_entry("width", width)?;
                if let Some(p) = period {
                    m.serialize_entry("period", p)?;
                }
                if let Some(n) = pulses {
                    m.serialize_entry("pulses", n)?;
                }
                m.end()
            }
            Self::Exp {
                v1,
                v2,
                rise_delay,
                rise_tau,
                fall_delay,
                fall_tau,
            } => {
                let mut m = s.serialize_map(Some(7))?;
                m.serialize_entry("shape", "exp")?;
                m.serialize_entry("v1", v1)?;
                m.serialize_entry("v2", v2)?;
                m.serialize_entry("rise_delay", rise_delay)?;
                m.serialize_entry("rise_tau", rise_tau)?;
                m.serialize_entry("fall_delay", fall_delay)?;
                m.serialize_entry("fall_tau", fall_tau)?;
                m.end()
            }
            Self::Sffm {
                offset,
                amplitude,
                carrier,
                index,
                signal,
                carrier_phase,
                signal_phase,
            } => {
                let mut m = s.serialize_map(Some(8))?;
                m.serialize_entry("shape", "sffm")?;
                m.serialize_entry("offset", offset)?;
                m.serialize_entry("amplitude", amplitude)?;
                m.serialize_entry("carrier", carrier)?;
                m.serialize_entry("index", index)?;
                m.serialize_entry("signal", signal)?;
                m.serialize_entry("carrier_phase", carrier_phase)?;
                m.serialize_entry("signal_phase", signal_phase)?;
                m.end()
            }
            Self::Am {
                amplitude,
                offset,
                modulation,
                carrier,
                delay,
                phase,
            } => {
                let mut m = s.serialize_map(Some(7))?;
                m.serialize_entry("shape", "am")?;
                m.serialize_entry("amplitude", amplitude)?;
                m.serialize_entry("offset", offset)?;
                m.serialize_entry("modulation", modulation)?;
                m.serialize_entry("carrier", carrier)?;
                m.serialize_entry("delay", delay)?;
                m.serialize_entry("phase", phase)?;
                m.end()
            }
            Self::Pwl {
                points,
                delay,
                repeat,
            } => {
                let mut m = s.serialize_map(None)?;
                m.serialize_entry("shape", "pwl")?;
                m.serialize_entry("points", points)?;
                if *delay != 0.0 {
                    m.serialize_entry("delay", delay)?;
                }
                if let Some(r) = repeat {
                    m.serialize_entry("repeat", r)?;
                }
                m.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for WaveformSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = WaveformSpec;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number (DC) or a waveform table with a `shape`")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<WaveformSpec, E> {
                Ok(WaveformSpec::Dc(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<WaveformSpec, E> {
                Ok(WaveformSpec::Dc(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<WaveformSpec, E> {
                Ok(WaveformSpec::Dc(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<WaveformSpec, A::Error> {
                let table = WaveformTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                table.into_spec()
            }
        }
        d.deserialize_any(V)
    }
}

/// Every stock part and its parameters (`type = "..."`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum PartKind {
    /// `type = "resistor"`: coordinate `q`, port `i`.
    Resistor(dirac_components::Resistor),
    /// `type = "inductor"`: coordinate `q`, port `i`.
    Inductor(dirac_components::Inductor),
    /// `type = "capacitor"`: coordinate `q`, port `i`.
    Capacitor(dirac_components::Capacitor),
    /// `type = "voltage_source"`: coordinate `q`, port `i`.
    VoltageSource(SourceParams),
    /// `type = "current_source"`: coordinates `q`, `phi`, port `i`.
    CurrentSource(SourceParams),
    /// `type = "coupled_inductors"`: coordinates `q1`, `q2`, ports `i1`, `i2`.
    CoupledInductors(dirac_components::CoupledInductors),
    /// `type = "diode"`: coordinates `q`, `phi` (junction flux), port `i` (anode to cathode).
    Diode(DiodeParams),
    /// `type = "saturating_inductor"`: coordinate `q`, port `i`.
    SaturatingInductor(dirac_components::SaturatingInductor),
    /// `type = "mass"`: coordinate `x`, port `x`.
    Mass(dirac_components::Mass),
    /// `type = "inertia"`: coordinate `theta`, port `theta`.
    Inertia(dirac_components::Inertia),
    /// `type = "spring"` (to ground): coordinate and port `x` (`theta` if rotational).
    Spring(SpringParams),
    /// `type = "damper"` (to ground): coordinate and port `x` (`theta` if rotational).
    Damper(DamperParams),
    /// `type = "force_source"` (to ground): coordinate and port `x` (`theta` if rotational).
    ForceSource(ForceSourceParams),
    /// `type = "ground"`: the fixed frame, coordinate and port `x` (`theta` if rotational).
    Ground(GroundParams),
    /// `type = "pendulum"`: coordinates and ports `x`, `y`.
    Pendulum(dirac_components::Pendulum),
    /// `type = "planar_linkage"`: per body `{body}.x`, `{body}.y`, `{body}.theta`.
    PlanarLinkage(PlanarLinkageParams),
    /// `type = "dc_motor"`: coordinates `q`, `theta`, ports `i`, `theta`.
    DcMotor(dirac_components::DcMotor),
    /// `type = "ideal_transformer"`: coordinates `q1`, `q2`, ports `i1`, `i2`.
    IdealTransformer(dirac_components::IdealTransformer),
    /// `type = "ideal_gear"`: coordinates and ports `theta1`, `theta2`.
    IdealGear(dirac_components::IdealGear),
    /// `type = "rolling_disk"`: coordinates and ports `x`, `y`, `theta`, `phi`; rolls without
    /// slipping (q-dependent one-forms: use `scheme = "symmetric"` for bounded energy).
    RollingDisk(dirac_components::RollingDisk),
    /// `type = "vcvs"` (SPICE `E`): coordinates `q`, `q_c`, `phi_c`, ports `i` (output), `ic`
    /// (sensing branch across the controlling nodes).
    Vcvs(dirac_components::Vcvs),
    /// `type = "vccs"` (SPICE `G`): coordinates `q`, `phi`, `q_c`, `phi_c`, ports `i`, `ic`.
    Vccs(dirac_components::Vccs),
    /// `type = "cccs"` (SPICE `F`): coordinates `q`, `phi`, `q_c`, ports `i`, `ic` (a short in
    /// series with the controlling branch).
    Cccs(dirac_components::Cccs),
    /// `type = "ccvs"` (SPICE `H`): coordinates `q`, `q_c`, ports `i`, `ic`.
    Ccvs(dirac_components::Ccvs),
    /// `type = "rigid_body"`: a body in space, coordinates and ports `x`, `y`, `z` (centre of
    /// mass) and `r11` … `r33` (rotation), plus `{point}.x|y|z` per named point.
    RigidBody(Box<RigidBodyParams>),
}

/// The `type` names of [`PartKind`], in declaration order.
pub const PART_TYPES: [&str; 25] = [
    "resistor",
    "inductor",
    "capacitor",
    "voltage_source",
    "current_source",
    "coupled_inductors",
    "diode",
    "saturating_inductor",
    "mass",
    "inertia",
    "spring",
    "damper",
    "force_source",
    "ground",
    "pendulum",
    "planar_linkage",
    "dc_motor",
    "ideal_transformer",
    "ideal_gear",
    "rolling_disk",
    "rigid_body",
    "vcvs",
    "vccs",
    "cccs",
    "ccvs",
];

impl PartKind {
    /// The `type` name.
    #[must_use]
    pub fn type_name(&self) -> &'static str {
        let i = match self {
            Self::Resistor(_) => 0,
            Self::Inductor(_) => 1,
            Self::Capacitor(_) => 2,
            Self::VoltageSource(_) => 3,
            Self::CurrentSource(_) => 4,
            Self::CoupledInductors(_) => 5,
            Self::Diode(_) => 6,
            Self::SaturatingInductor(_) => 7,
            Self::Mass(_) => 8,
            Self::Inertia(_) => 9,
            Self::Spring(_) => 10,
            Self::Damper(_) => 11,
            Self::ForceSource(_) => 12,
            Self::Ground(_) => 13,
            Self::Pendulum(_) => 14,
            Self::PlanarLinkage(_) => 15,
            Self::DcMotor(_) => 16,
            Self::IdealTransformer(_) => 17,
            Self::IdealGear(_) => 18,
            Self::RollingDisk(_) => 19,
            Self::RigidBody(_) => 20,
            Self::Vcvs(_) => 21,
            Self::Vccs(_) => 22,
            Self::Cccs(_) => 23,
            Self::Ccvs(_) => 24,
        };
        PART_TYPES[i]
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn is_false(v: &bool) -> bool {
    !*v
}

/// `voltage_source` / `current_source`: `waveform`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceParams {
    /// The source's time function.
    pub waveform: WaveformSpec,
}

/// `diode`: the SPICE level-1 card of [`dirac_components::DiodeParameters`] under its lower-case
/// SPICE names, every key optional with ngspice's default (`is` 1e-14 A, `n` 1, `rs` 0, `cjo` 0,
/// `vj` 1, `m` 0.5, `fc` 0.5, `tt` 0, `bv` none, `ibv` 1e-3, `nbv` = `n`, `eg` 1.11, `xti` 3,
/// `tcv`, `trs1`, `trs2`, `ttt1`, `ttt2`, `tm1`, `tm2` 0, `area` 1), plus the junction
/// temperature `temp` (°C, 27), the nominal temperature `tnom` (°C, default `temp`: the
/// parameters are then taken as measured at the junction temperature) and `gmin` (S, 1e-12).
/// The part is built by [`dirac_components::Diode::at_temperature`], as a netlist's `D` element.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DiodeParams {
    /// `IS`: saturation current (A).
    pub is: f64,
    /// `N`: emission coefficient.
    pub n: f64,
    /// `RS`: series resistance (Ω).
    pub rs: f64,
    /// `CJO`: zero-bias depletion capacitance (F).
    pub cjo: f64,
    /// `VJ`: junction potential (V).
    pub vj: f64,
    /// `M`: grading coefficient.
    pub m: f64,
    /// `FC`: forward-bias depletion capacitance coefficient.
    pub fc: f64,
    /// `TT`: transit time (s).
    pub tt: f64,
    /// `BV`: reverse breakdown voltage (V, positive); none: no breakdown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bv: Option<f64>,
    /// `IBV`: current at the breakdown voltage (A).
    pub ibv: f64,
    /// `NBV`: breakdown emission coefficient; none: `n`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nbv: Option<f64>,
    /// `EG`: activation energy (eV).
    pub eg: f64,
    /// `XTI`: saturation-current temperature exponent.
    pub xti: f64,
    /// `TNOM`: temperature at which the parameters were measured (°C); none: `temp`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tnom: Option<f64>,
    /// `TCV`: linear temperature coefficient of `BV` (V/K).
    pub tcv: f64,
    /// `TRS1`: linear temperature coefficient of `RS` (1/K).
    pub trs1: f64,
    /// `TRS2`: quadratic temperature coefficient of `RS` (1/K²).
    pub trs2: f64,
    /// `TTT1`: linear temperature coefficient of `TT` (1/K).
    pub ttt1: f64,
    /// `TTT2`: quadratic temperature coefficient of `TT` (1/K²).
    pub ttt2: f64,
    /// `TM1`: linear temperature coefficient of `M` (1/K).
    pub tm1: f64,
    /// `TM2`: quadratic temperature coefficient of `M` (1/K²).
    pub tm2: f64,
    /// `AREA`: area factor scaling `IS` and `CJO` and dividing `RS`.
    pub area: f64,
    /// Junction temperature (°C).
    pub temp: f64,
    /// Conductance across the junction (S).
    pub gmin: f64,
}

impl Default for DiodeParams {
    fn default() -> Self {
        let d = dirac_components::DiodeParameters::default();
        Self {
            is: d.is,
            n: d.n,
            rs: d.rs,
            cjo: d.cjo,
            vj: d.vj,
            m: d.m,
            fc: d.fc,
            tt: d.tt,
            bv: d.bv,
            ibv: d.ibv,
            nbv: d.nbv,
            eg: d.eg,
            xti: d.xti,
            tnom: None,
            tcv: d.tcv,
            trs1: d.trs[0],
            trs2: d.trs[1],
            ttt1: d.ttt[0],
            ttt2: d.ttt[1],
            tm1: d.tm[0],
            tm2: d.tm[1],
            area: d.area,
            temp: d.tnom,
            gmin: dirac_components::Diode::GMIN,
        }
    }
}

impl DiodeParams {
    /// The SPICE card these keys describe (`TNOM` = `temp` when `tnom` is not given).
    #[must_use]
    pub fn card(&self) -> dirac_components::DiodeParameters {
        dirac_components::DiodeParameters {
            is: self.is,
            n: self.n,
            rs: self.rs,
            cjo: self.cjo,
            vj: self.vj,
            m: self.m,
            fc: self.fc,
            tt: self.tt,
            bv: self.bv,
            ibv: self.ibv,
            nbv: self.nbv,
            eg: self.eg,
            xti: self.xti,
            tnom: self.tnom.unwrap_or(self.temp),
            tcv: self.tcv,
            trs: [self.trs1, self.trs2],
            ttt: [self.ttt1, self.ttt2],
            tm: [self.tm1, self.tm2],
            area: self.area,
            ..dirac_components::DiodeParameters::default()
        }
    }
}

/// `spring` to ground (free end at its coordinate): `k` (≥ 0), cubic `k3` (default 0), `rest`
/// (default 0), `rotational` (default false: port `x`; true: port `theta`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringParams {
    /// Linear stiffness.
    pub k: f64,
    /// Cubic stiffness.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub k3: f64,
    /// Rest offset.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rest: f64,
    /// Rotational (port `theta`) rather than translational (port `x`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub rotational: bool,
}

/// `damper` to ground: `c` (≥ 0), `rotational`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DamperParams {
    /// Damping coefficient.
    pub c: f64,
    /// Rotational (port `theta`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub rotational: bool,
}

/// `force_source` to ground: `waveform`, `rotational` (a torque).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceSourceParams {
    /// The force (or torque) as a function of time.
    pub waveform: WaveformSpec,
    /// Rotational (port `theta`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub rotational: bool,
}

/// `ground`: the fixed frame at `position` (default 0), `rotational`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundParams {
    /// Where the frame is (its coordinate's initial value must equal it; it is the default).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub position: f64,
    /// Rotational (port `theta`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub rotational: bool,
}

fn default_gravity() -> f64 {
    9.81
}

/// A rigid body of a planar linkage: `{ name = "rod", m = 1, j = 0.1 }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Body name (prefix of its ports).
    pub name: String,
    /// Mass.
    pub m: f64,
    /// Moment of inertia about the centre of mass.
    pub j: f64,
}

/// A pin joint of a planar linkage: body point `point` (body frame) held either at the fixed
/// point `ground` or at point `at` of body `to`:
/// `{ body = "a", point = [-0.5, 0], ground = [0, 0] }`,
/// `{ body = "b", point = [-0.5, 0], to = "a", at = [0.5, 0] }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinSpec {
    /// The pinned body.
    pub body: String,
    /// The pinned point in its frame.
    pub point: [f64; 2],
    /// Fixed point of the plane it is pinned to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground: Option<[f64; 2]>,
    /// Other body it is pinned to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<String>,
    /// Point of the other body (its frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<[f64; 2]>,
}

/// `planar_linkage`: `g` (default 9.81), `bodies`, `pins`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarLinkageParams {
    /// Gravitational acceleration (towards −y).
    #[serde(default = "default_gravity")]
    pub g: f64,
    /// The bodies.
    pub bodies: Vec<BodySpec>,
    /// The pins.
    #[serde(default)]
    pub pins: Vec<PinSpec>,
}

fn default_gravity_vector() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// A body's inertia tensor about its centre of mass, in body axes: principal moments
/// `[J₁, J₂, J₃]` or a symmetric 3×3 table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum InertiaSpec {
    /// `inertia = [0.02, 0.02, 0.03]`
    Principal([f64; 3]),
    /// `inertia = [[0.02, 0, 0], [0, 0.02, 0], [0, 0, 0.03]]`
    Tensor([[f64; 3]; 3]),
}

/// A rotation: `{ axis = [0, 1, 0], angle = 0.4 }` (radians, right-handed), a unit quaternion
/// `[w, x, y, z]`, or a 3×3 matrix (rows).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RotationSpec {
    /// `{ axis = [0, 1, 0], angle = 0.4 }`
    AxisAngle {
        /// The axis (normalised when used).
        axis: [f64; 3],
        /// The angle in radians.
        angle: f64,
    },
    /// `[w, x, y, z]` (normalised when used).
    Quaternion([f64; 4]),
    /// `[[r11, r12, r13], [r21, r22, r23], [r31, r32, r33]]`
    Matrix([[f64; 3]; 3]),
}

/// `rigid_body`: mass `m` (> 0), `inertia` ([`InertiaSpec`]), `gravity` (default
/// `[0, 0, −9.81]`), named body-fixed `points = { tip = [0, 0, 0.3] }` (body axes, from the
/// centre of mass), and the initial state: `position` of the centre of mass, `rotation`
/// ([`RotationSpec`], body to space), `velocity` of the centre of mass and `angular_velocity`
/// (body axes). These set the defaults of `q0` and `v0` (which may still override coordinates by
/// name).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidBodyParams {
    /// Mass.
    pub m: f64,
    /// Inertia about the centre of mass, body axes.
    pub inertia: InertiaSpec,
    /// Gravitational acceleration.
    #[serde(default = "default_gravity_vector")]
    pub gravity: [f64; 3],
    /// Named body-fixed points (ports `{name}.x`, `.y`, `.z`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub points: BTreeMap<String, [f64; 3]>,
    /// Initial position of the centre of mass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    /// Initial rotation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<RotationSpec>,
    /// Initial velocity of the centre of mass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<[f64; 3]>,
    /// Initial angular velocity, body axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<[f64; 3]>,
}

/// A connection between ports, with a unique name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Connection {
    /// Unique name among connections.
    pub name: String,
    /// Node, joint or coupling.
    #[serde(flatten)]
    pub kind: ConnectionKind,
    /// Where it was written.
    #[serde(skip)]
    pub origin: Origin,
}

/// What a connection does (`type = "node" | "joint" | "coupling"`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ConnectionKind {
    /// KCL: `Σ sᵢ flowᵢ = 0` over `ports = [["L1.i", 1], ["R1.i", -1]]` (`+1`: the flow enters
    /// the node, i.e. the node is the part's `−` terminal). A port may also be written `"+L1.i"` or
    /// `"-R1.i"`.
    Node {
        /// `(part.port, sign)` pairs.
        ports: Vec<NodePort>,
    },
    /// A rigid joint `flow_a = flow_b` between `a = "A.x"` and `b = "G.x"`.
    Joint {
        /// First port.
        a: String,
        /// Second port.
        b: String,
    },
    /// A coupling element between `a` and `b`: `element = { type = "spring", k = 1 }`.
    Coupling {
        /// First port.
        a: String,
        /// Second port.
        b: String,
        /// The element.
        element: ElementSpec,
    },
    /// `type = "spherical"`: a ball joint between rigid bodies (see [`RigidJointSpec`]).
    Spherical(RigidJointSpec),
    /// `type = "revolute"`: a hinge about the joint frames' `z` axis.
    Revolute(RigidJointSpec),
    /// `type = "universal"`: a Hooke joint (`x` of frame `a` stays perpendicular to `y` of `b`).
    Universal(RigidJointSpec),
    /// `type = "cylindrical"`: rotation about and sliding along `z`.
    Cylindrical(RigidJointSpec),
    /// `type = "prismatic"`: sliding along `z`.
    Prismatic(RigidJointSpec),
    /// `type = "planar"`: motion in the `xy` plane of frame `a`.
    Planar(RigidJointSpec),
    /// `type = "fixed"`: the frames coincide.
    Fixed(RigidJointSpec),
    /// `type = "joint_coordinate"`: ties the one-dimensional `port` (a motor shaft, a gear, a
    /// rotational spring, damper or torque source) to the angle (revolute, cylindrical, planar)
    /// or the slide (prismatic) of the rigid joint named `joint`.
    JointCoordinate {
        /// The rigid joint.
        joint: String,
        /// `part.port`.
        port: String,
    },
}

/// The two sides of a rigid joint: bodies `a` (omitted: the fixed frame) and `b`, and on each a
/// joint frame: `origin_a` (body axes from the centre of mass, or a point in space for the fixed
/// frame; default `[0, 0, 0]`), `axis_a` (the frame's `z` axis, default `[0, 0, 1]`) and
/// `ref_a` (its `x` axis, made perpendicular to `z`; default: the coordinate axis least aligned
/// with `z`), and the same for `b`. The frames should coincide in the initial configuration.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidJointSpec {
    /// Body `a` (`None`: the fixed frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<String>,
    /// Body `b`.
    pub b: String,
    /// Joint origin on `a`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin_a: Option<[f64; 3]>,
    /// Joint origin on `b`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin_b: Option<[f64; 3]>,
    /// Joint axis (frame `z`) on `a`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis_a: Option<[f64; 3]>,
    /// Joint axis (frame `z`) on `b`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis_b: Option<[f64; 3]>,
    /// Reference direction (frame `x`) on `a`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ref_a: Option<[f64; 3]>,
    /// Reference direction (frame `x`) on `b`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ref_b: Option<[f64; 3]>,
}

/// The `type` names of the rigid joints.
pub const RIGID_JOINT_TYPES: [&str; 7] = [
    "spherical",
    "revolute",
    "universal",
    "cylindrical",
    "prismatic",
    "planar",
    "fixed",
];

/// One signed port of a node.
#[derive(Debug, Clone, PartialEq)]
pub struct NodePort {
    /// `part.port`.
    pub port: String,
    /// Sign (`+1`: the port's flow enters the node).
    pub sign: f64,
}

impl Serialize for NodePort {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(2))?;
        seq.serialize_element(&self.port)?;
        seq.serialize_element(&self.sign)?;
        seq.end()
    }
}

impl<'de> Deserialize<'de> for NodePort {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = NodePort;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(
                    "a pair [\"part.port\", sign] or a string \"+part.port\" / \"-part.port\"",
                )
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<NodePort, E> {
                let (sign, rest) = match v.as_bytes().first() {
                    Some(b'+') => (1.0, &v[1..]),
                    Some(b'-') => (-1.0, &v[1..]),
                    _ => {
                        return Err(E::custom(format!(
                            "node port `{v}` needs a sign: write \"+{v}\" or \"-{v}\", or [\"{v}\", 1]"
                        )));
                    }
                };
                Ok(NodePort {
                    port: rest.trim().to_string(),
                    sign,
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<NodePort, A::Error> {
                let port: String = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(0, &self))?;
                let sign: f64 = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(1, &self))?;
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(3, &self));
                }
                Ok(NodePort { port, sign })
            }
        }
        d.deserialize_any(V)
    }
}

/// A coupling element (`element = { type = ... }`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ElementSpec {
    /// `{ type = "spring", k = 1, k3 = 0, rest = 0 }`: `V = ½k d² + ¼k₃ d⁴`, `d = x_a − x_b − rest`
    /// (`k3 ≠ 0`: a nonlinear, Duffing spring).
    Spring(dirac_components::Spring),
    /// `{ type = "damper", c = 0.1 }`: `f_a = −c (v_a − v_b) = −f_b`.
    Damper(dirac_components::Damper),
    /// `{ type = "force_source", waveform = ... }`: an actuator, `+F(t)` on `a`, `−F(t)` on `b`.
    ForceSource(ActuatorElement),
}

/// The `type` names of [`ElementSpec`].
pub const ELEMENT_TYPES: [&str; 3] = ["spring", "damper", "force_source"];

/// An actuator element: `waveform`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorElement {
    /// The force as a function of time.
    pub waveform: WaveformSpec,
}

/// The `[record]` table: what the runner records. Only `signals` is evaluated by this crate's
/// runner; the other requests are carried for runners that compute them.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Record {
    /// Signals by name: `C1.q` (a coordinate), `L1.q'` (its rate), `L1.i` (the flow of a port that
    /// is not itself a coordinate). Empty: every coordinate and every such flow.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub signals: Vec<String>,
    /// Record the total energy.
    #[serde(skip_serializing_if = "is_false")]
    pub energy: bool,
    /// Parts whose power to record.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub power: Vec<String>,
    /// Record the constraint residuals.
    #[serde(skip_serializing_if = "is_false")]
    pub residuals: bool,
    /// Connections whose interaction forces to record.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub forces: Vec<String>,
    /// Where it was written.
    #[serde(skip)]
    pub origin: Origin,
}

impl Record {
    /// True when nothing beyond the defaults is asked for.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.signals.is_empty()
            && !self.energy
            && self.power.is_empty()
            && !self.residuals
            && self.forces.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::CompositionSpec;
    use dirac_sim::Composition;

    /// Every name the command line and Python take is a scene key naming the same composition,
    /// and an unknown name is refused.
    #[test]
    fn composition_keys_are_the_stock_names() {
        #[derive(serde::Deserialize)]
        struct Key {
            composition: CompositionSpec,
        }
        for name in Composition::NAMES {
            let key: Key = toml::from_str(&format!("composition = \"{name}\"")).expect(name);
            assert_eq!(
                Some(key.composition.composition()),
                Composition::named(name)
            );
        }
        assert!(toml::from_str::<Key>("composition = \"ruth3\"").is_err());
    }
}
