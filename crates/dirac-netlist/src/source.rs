//! Independent source waveforms with ngspice's definitions.
//!
//! The formulas follow ngspice's `vsrcload.c`/`isrcload.c` (ngspice 39–44):
//!
//! - `SIN(VO VA FREQ TD THETA PHASE)`: with `τ = t − TD`, `VO + VA·sin(PHASE·π/180)` for `τ ≤ 0`,
//!   else `VO + VA·sin(2π·FREQ·τ + PHASE·π/180)·exp(−τ·THETA)`. `FREQ` absent or 0 means
//!   `1/TSTOP`.
//! - `PULSE(V1 V2 TD TR TF PW PER)`: with `τ = t − TD`, if `τ > PER` then `τ −= PER·⌊τ/PER⌋`;
//!   `V1` for `τ ≤ 0` or `τ ≥ TR+PW+TF`, `V2` for `TR ≤ τ ≤ TR+PW`, linear ramps in between.
//!   `TR`, `TF` absent or 0 mean `TSTEP`; `PW`, `PER` absent or 0 mean `TSTOP`.
//! - `EXP(V1 V2 TD1 TAU1 TD2 TAU2)`: `V1` up to `TD1`, then `V1 + (V2−V1)(1 − e^{−(t−TD1)/TAU1})`,
//!   after `TD2` plus `(V1−V2)(1 − e^{−(t−TD2)/TAU2})`. `TD1`, `TAU1`, `TAU2` absent or 0 mean
//!   `TSTEP`, `TD2` absent or 0 means `TD1 + TSTEP` (ngspice's code; its manual gives 0 for `TD1`).
//! - `SFFM(VO VA FC MDI FS PHASEC PHASES)`: `VO + VA·sin(2π·FC·t + PHASEC·π/180 +
//!   MDI·sin(2π·FS·t + PHASES·π/180))`; `FC`, `FS` absent or 0 mean `1/TSTOP`.
//! - `AM(VA VO MF FC TD PHASEC PHASES)`: 0 up to `TD`, then with `τ = t − TD`
//!   `VA·(VO + sin(2π·MF·τ + φ))·sin(2π·FC·τ + φ)`, `φ = PHASES·π/180` in both (ngspice-39 reads
//!   `PHASEC` and does not use it); `MF` absent or 0 means `1/TSTOP`.
//! - `PWL(t1 v1 t2 v2 ...) [r=R] [td=TD]`: with `τ = t − TD`, `v1` before `t1`, linear
//!   interpolation in between (at a time point, the segment ending there is used), and after the
//!   last time the last value, or with `r=R` the stretch from the time point `R` to the last one
//!   repeated.
//!
//! A [`SourceSpec`] in a [`Netlist`](super::Netlist) that has a `.tran` card has these defaults
//! already resolved (see [`SourceSpec::resolved`]), so [`SourceSpec::value`] is then exactly
//! ngspice's waveform. Without `.tran`, unresolved zeros are taken literally, except that a zero
//! `PER` means "no repetition".

/// The waveform of an independent voltage or current source.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    /// A constant value (`5`, `DC 5`).
    Dc(f64),
    /// `SIN(VO VA [FREQ [TD [THETA [PHASE]]]])`.
    Sin {
        /// Offset.
        vo: f64,
        /// Amplitude.
        va: f64,
        /// Frequency in Hz (0 = default `1/TSTOP`, until resolved).
        freq: f64,
        /// Delay in seconds.
        td: f64,
        /// Damping factor in 1/s.
        theta: f64,
        /// Phase in degrees.
        phase: f64,
    },
    /// `PULSE(V1 V2 [TD [TR [TF [PW [PER [NP]]]]]])`.
    Pulse {
        /// Initial value.
        v1: f64,
        /// Pulsed value.
        v2: f64,
        /// Delay.
        td: f64,
        /// Rise time (0 = default `TSTEP`, until resolved).
        tr: f64,
        /// Fall time (0 = default `TSTEP`, until resolved).
        tf: f64,
        /// Pulse width (0 = default `TSTOP`, until resolved).
        pw: f64,
        /// Period (0 = default `TSTOP`, until resolved; an unresolved 0 means no repetition).
        per: f64,
        /// Number of pulses, ngspice's eighth parameter (0 or less, or absent: no end).
        np: f64,
    },
    /// `EXP(V1 V2 [TD1 [TAU1 [TD2 [TAU2]]]])`.
    Exp {
        /// Initial value.
        v1: f64,
        /// The value the rise tends to.
        v2: f64,
        /// Rise delay (0 = default `TSTEP`, until resolved).
        td1: f64,
        /// Rise time constant (0 = default `TSTEP`, until resolved).
        tau1: f64,
        /// Fall delay (0 = default `TD1 + TSTEP`, until resolved).
        td2: f64,
        /// Fall time constant (0 = default `TSTEP`, until resolved).
        tau2: f64,
    },
    /// `SFFM(VO VA [FC [MDI [FS [PHASEC [PHASES]]]]])`.
    Sffm {
        /// Offset.
        vo: f64,
        /// Amplitude.
        va: f64,
        /// Carrier frequency in Hz (0 = default `1/TSTOP`, until resolved).
        fc: f64,
        /// Modulation index.
        mdi: f64,
        /// Signal frequency in Hz (0 = default `1/TSTOP`, until resolved).
        fs: f64,
        /// Carrier phase in degrees.
        phasec: f64,
        /// Signal phase in degrees.
        phases: f64,
    },
    /// `AM(VA VO [MF [FC [TD [PHASEC [PHASES]]]]])` (ngspice).
    Am {
        /// Amplitude.
        va: f64,
        /// Offset of the modulating sine.
        vo: f64,
        /// Modulating frequency in Hz (0 = default `1/TSTOP`, until resolved).
        mf: f64,
        /// Carrier frequency in Hz.
        fc: f64,
        /// Delay.
        td: f64,
        /// Carrier phase in degrees (read, and unused by ngspice-39).
        phasec: f64,
        /// Phase of both sines in degrees (ngspice-39's use of it).
        phases: f64,
    },
    /// `PWL(t1 v1 t2 v2 ...) [r=R] [td=TD]`.
    Pwl {
        /// Time–value points with non-decreasing times.
        points: Vec<(f64, f64)>,
        /// `td=`: delay of the whole sequence (0 when absent).
        td: f64,
        /// `r=`: the time point from which the sequence repeats after its last point (`None`: the
        /// last value is held).
        r: Option<f64>,
    },
}

impl SourceSpec {
    /// `PWL(t1 v1 t2 v2 ...)` without `r=` or `td=`.
    #[must_use]
    pub fn pwl(points: Vec<(f64, f64)>) -> Self {
        Self::Pwl {
            points,
            td: 0.0,
            r: None,
        }
    }

    /// The waveform's value at time `t` (seconds), by ngspice's definitions. See the module docs
    /// for how unresolved defaults are treated.
    pub fn value(&self, t: f64) -> f64 {
        crate::circuit::waveform(self).value(t)
    }

    /// The waveform's time derivative at `t`. At a corner of a piecewise-linear waveform it is the
    /// slope of the piece that [`value`](Self::value) uses there (for `PULSE` and `PWL` the piece
    /// ending at `t`); it is 0 where the waveform is constant and before a `SIN`'s delay.
    pub fn derivative(&self, t: f64) -> f64 {
        crate::circuit::waveform(self).derivative(t)
    }

    /// The waveform with ngspice's transient defaults filled in from `.tran TSTEP TSTOP`: a zero
    /// `SIN` frequency becomes `1/tstop`; zero `PULSE` rise and fall times become `tstep`; zero
    /// pulse width and period become `tstop`; zero `EXP` delays and time constants become `tstep`
    /// (the fall delay `TD1 + tstep`); zero `SFFM` frequencies and a zero `AM` modulating
    /// frequency become `1/tstop`. Other waveforms are returned unchanged.
    pub fn resolved(&self, tstep: f64, tstop: f64) -> SourceSpec {
        let or = |x: f64, default: f64| if x == 0.0 { default } else { x };
        match self {
            SourceSpec::Sin {
                vo,
                va,
                freq,
                td,
                theta,
                phase,
            } => SourceSpec::Sin {
                vo: *vo,
                va: *va,
                freq: or(*freq, 1.0 / tstop),
                td: *td,
                theta: *theta,
                phase: *phase,
            },
            SourceSpec::Pulse {
                v1,
                v2,
                td,
                tr,
                tf,
                pw,
                per,
                np,
            } => SourceSpec::Pulse {
                v1: *v1,
                v2: *v2,
                td: *td,
                tr: or(*tr, tstep),
                tf: or(*tf, tstep),
                pw: or(*pw, tstop),
                per: or(*per, tstop),
                np: *np,
            },
            SourceSpec::Exp {
                v1,
                v2,
                td1,
                tau1,
                td2,
                tau2,
            } => {
                let td1 = or(*td1, tstep);
                SourceSpec::Exp {
                    v1: *v1,
                    v2: *v2,
                    td1,
                    tau1: or(*tau1, tstep),
                    td2: or(*td2, td1 + tstep),
                    tau2: or(*tau2, tstep),
                }
            }
            SourceSpec::Sffm {
                vo,
                va,
                fc,
                mdi,
                fs,
                phasec,
                phases,
            } => SourceSpec::Sffm {
                vo: *vo,
                va: *va,
                fc: or(*fc, 1.0 / tstop),
                mdi: *mdi,
                fs: or(*fs, 1.0 / tstop),
                phasec: *phasec,
                phases: *phases,
            },
            SourceSpec::Am {
                va,
                vo,
                mf,
                fc,
                td,
                phasec,
                phases,
            } => SourceSpec::Am {
                va: *va,
                vo: *vo,
                mf: or(*mf, 1.0 / tstop),
                fc: *fc,
                td: *td,
                phasec: *phasec,
                phases: *phases,
            },
            other => other.clone(),
        }
    }

    /// [`value`](Self::value) of the waveform [`resolved`](Self::resolved) with `tstep`, `tstop`.
    pub fn value_with_defaults(&self, t: f64, tstep: f64, tstop: f64) -> f64 {
        match self {
            SourceSpec::Dc(v) => *v,
            SourceSpec::Pwl { .. } => self.value(t),
            _ => self.resolved(tstep, tstop).value(t),
        }
    }

    /// [`derivative`](Self::derivative) of the waveform [`resolved`](Self::resolved) with `tstep`,
    /// `tstop`.
    pub fn derivative_with_defaults(&self, t: f64, tstep: f64, tstop: f64) -> f64 {
        match self {
            SourceSpec::Dc(_) => 0.0,
            SourceSpec::Pwl { .. } => self.derivative(t),
            _ => self.resolved(tstep, tstop).derivative(t),
        }
    }
}
