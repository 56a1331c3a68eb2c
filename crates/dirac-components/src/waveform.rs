//! Time functions of independent sources, with ngspice semantics.

use std::f64::consts::PI;

use dirac_graph::{Check, PartError};

/// The value of an independent source as a function of time.
///
/// Semantics follow ngspice's `vsrcload.c`/`isrcload.c` (transient analysis), with every parameter
/// given explicitly: ngspice substitutes `TSTEP` or `TSTOP` for omitted or zero `TR`, `TF`, `PW`,
/// `PER`, `FREQ`, which a part cannot know.
///
/// - [`Waveform::Dc`]: a constant.
/// - [`Waveform::Sin`] `SIN(VO VA FREQ TD THETA PHASE)`: with `τ = t − TD`,
///   `VO + VA·sin(2π·PHASE/360)` for `τ ≤ 0`, else `VO + VA·sin(2π·FREQ·τ + 2π·PHASE/360)·e^{−THETA·τ}`
///   (continuous at `TD`, as ngspice computes it; the manual's `VO` before `TD` is the `PHASE = 0`
///   case).
/// - [`Waveform::Pulse`] `PULSE(V1 V2 TD TR TF PW PER NP)`: with `τ = t − TD` reduced modulo `PER`
///   when `τ > PER`: `V1` for `τ ≤ 0` or `τ ≥ TR + PW + TF`, a linear rise over `(0, TR)`, `V2` on
///   `[TR, TR + PW]`, a linear fall over `(TR + PW, TR + PW + TF)`. `TR = 0` or `TF = 0` are ideal
///   edges; `PER = ∞` is a single pulse. After `NP` periods (`t − TD > NP·PER`, ngspice's eighth
///   parameter, any positive number) the value is `V1`; `NP = ∞` repeats forever.
/// - [`Waveform::Exp`] `EXP(V1 V2 TD1 TAU1 TD2 TAU2)`: `V1` for `t ≤ TD1`, then
///   `V1 + (V2 − V1)(1 − e^{−(t−TD1)/TAU1})`, and for `t > TD2` plus `(V1 − V2)(1 − e^{−(t−TD2)/TAU2})`.
///   A zero time constant is an ideal edge.
/// - [`Waveform::Sffm`] `SFFM(VO VA FC MDI FS PHASEC PHASES)`:
///   `VO + VA·sin(2π·FC·t + PHASEC·π/180 + MDI·sin(2π·FS·t + PHASES·π/180))`.
/// - [`Waveform::Am`] `AM(VA VO MF FC TD PHASEC PHASES)`: 0 for `τ = t − TD ≤ 0`, else
///   `VA·(VO + sin(2π·MF·τ + φ))·sin(2π·FC·τ + φ)` with `φ = PHASES·π/180` in both sines, as
///   ngspice-39 computes it (it reads `PHASEC` and does not use it).
/// - [`Waveform::Pwl`] `PWL(T1 V1 T2 V2 …) [r=R] [td=TD]`: with `τ = t − TD`, `V1` for `τ ≤ T1`,
///   linear interpolation on `(Tᵢ₋₁, Tᵢ]`, and for `τ > Tₙ` the last value held or, with `r=R`
///   (`R` one of the times `Tᵢ` before `Tₙ`), the stretch `(R, Tₙ]` repeated forever with period
///   `Tₙ − R`. Equal consecutive times make a step; at a step, a repetition's restart included, the
///   value is the left one (ngspice takes the left one at a PWL step and at the first restart; at
///   the later restarts its rounding of `τ` decides).
///
/// ```
/// use dirac_components::Waveform;
/// let w = Waveform::pulse(0.0, 5.0, 1.0, 0.5, 0.5, 2.0, 10.0);
/// assert_eq!(w.value(1.25), 2.5); // half-way up the rise
/// assert_eq!(w.value(13.0), 5.0); // second period, on the plateau
/// ```
#[derive(Debug, Clone, PartialEq)]
pub enum Waveform {
    /// Constant value.
    Dc(f64),
    /// Damped sine `SIN(VO VA FREQ TD THETA PHASE)`.
    Sin {
        /// `VO`: offset.
        offset: f64,
        /// `VA`: amplitude.
        amplitude: f64,
        /// `FREQ` in Hz.
        frequency: f64,
        /// `TD`: delay.
        delay: f64,
        /// `THETA`: damping factor in 1/s.
        damping: f64,
        /// `PHASE` in degrees.
        phase_deg: f64,
    },
    /// Trapezoidal pulse train `PULSE(V1 V2 TD TR TF PW PER NP)`.
    Pulse {
        /// `V1`: initial value.
        v1: f64,
        /// `V2`: pulsed value.
        v2: f64,
        /// `TD`: delay.
        delay: f64,
        /// `TR`: rise time (0: ideal edge).
        rise: f64,
        /// `TF`: fall time (0: ideal edge).
        fall: f64,
        /// `PW`: pulse width.
        width: f64,
        /// `PER`: period (`f64::INFINITY`: one pulse).
        period: f64,
        /// `NP`: number of periods after which the value stays `V1` (`f64::INFINITY`: no end).
        pulses: f64,
    },
    /// Exponential rise and fall `EXP(V1 V2 TD1 TAU1 TD2 TAU2)`.
    Exp {
        /// `V1`: initial value.
        v1: f64,
        /// `V2`: the value the rise tends to.
        v2: f64,
        /// `TD1`: start of the rise.
        rise_delay: f64,
        /// `TAU1`: time constant of the rise (0: an ideal edge).
        rise_tau: f64,
        /// `TD2`: start of the fall back towards `V1`.
        fall_delay: f64,
        /// `TAU2`: time constant of the fall (0: an ideal edge).
        fall_tau: f64,
    },
    /// Single-frequency FM `SFFM(VO VA FC MDI FS PHASEC PHASES)`.
    Sffm {
        /// `VO`: offset.
        offset: f64,
        /// `VA`: amplitude.
        amplitude: f64,
        /// `FC`: carrier frequency in Hz.
        carrier: f64,
        /// `MDI`: modulation index.
        index: f64,
        /// `FS`: signal frequency in Hz.
        signal: f64,
        /// `PHASEC`: carrier phase in degrees.
        carrier_phase_deg: f64,
        /// `PHASES`: signal phase in degrees.
        signal_phase_deg: f64,
    },
    /// Amplitude modulation `AM(VA VO MF FC TD PHASEC PHASES)` (ngspice).
    Am {
        /// `VA`: amplitude.
        amplitude: f64,
        /// `VO`: offset of the modulating sine.
        offset: f64,
        /// `MF`: modulating frequency in Hz.
        modulation: f64,
        /// `FC`: carrier frequency in Hz.
        carrier: f64,
        /// `TD`: delay.
        delay: f64,
        /// `PHASES`: the phase, in degrees, of both sines (ngspice-39's use of it).
        phase_deg: f64,
    },
    /// Piecewise linear `PWL(T1 V1 T2 V2 …) [r=R] [td=TD]` (see [`Waveform::pwl`] and
    /// [`Waveform::pwl_repeating`]).
    Pwl {
        /// `(time, value)` points, times non-decreasing.
        points: Vec<(f64, f64)>,
        /// `TD`: the whole sequence starts this much later.
        delay: f64,
        /// `R`: after the last point the stretch from this time (one of the points' times, before
        /// the last) to the last point repeats; `None` holds the last value.
        repeat: Option<f64>,
    },
}

impl Waveform {
    /// `SIN(VO VA FREQ)` without delay, damping or phase.
    #[must_use]
    pub fn sin(offset: f64, amplitude: f64, frequency: f64) -> Self {
        Self::Sin {
            offset,
            amplitude,
            frequency,
            delay: 0.0,
            damping: 0.0,
            phase_deg: 0.0,
        }
    }

    /// `PULSE(V1 V2 TD TR TF PW PER)`, repeating without end.
    #[must_use]
    pub fn pulse(
        v1: f64,
        v2: f64,
        delay: f64,
        rise: f64,
        fall: f64,
        width: f64,
        period: f64,
    ) -> Self {
        Self::Pulse {
            v1,
            v2,
            delay,
            rise,
            fall,
            width,
            period,
            pulses: f64::INFINITY,
        }
    }

    /// `PWL(T1 V1 T2 V2 …)` from `(time, value)` points.
    ///
    /// # Panics
    /// If `points` is empty or its times decrease (a malformed source description).
    #[must_use]
    pub fn pwl(points: impl Into<Vec<(f64, f64)>>) -> Self {
        let points = points.into();
        assert!(!points.is_empty(), "PWL needs at least one point");
        assert!(
            points.windows(2).all(|w| w[0].0 <= w[1].0),
            "PWL times must be non-decreasing"
        );
        Self::Pwl {
            points,
            delay: 0.0,
            repeat: None,
        }
    }

    /// `PWL(T1 V1 T2 V2 …) r=repeat td=delay`: [`Waveform::pwl`] delayed by `delay`, repeating the
    /// stretch from the point at time `repeat` to the last point after it ends (`None`: held).
    ///
    /// ```
    /// use dirac_components::Waveform;
    /// // A 1 ms triangle from 0 to 1 V, repeated from t = 0, starting 0.5 ms late.
    /// let w = Waveform::pwl_repeating(vec![(0.0, 0.0), (0.5e-3, 1.0), (1e-3, 0.0)], 0.5e-3, Some(0.0));
    /// assert_eq!(w.value(0.25e-3), 0.0);
    /// assert!((w.value(2.75e-3) - 0.5).abs() < 1e-12); // τ = 2.25 ms: 0.25 ms into the third cycle
    /// ```
    ///
    /// # Panics
    /// As [`Waveform::pwl`]; and if `repeat` is not one of the times before the last.
    #[must_use]
    pub fn pwl_repeating(
        points: impl Into<Vec<(f64, f64)>>,
        delay: f64,
        repeat: Option<f64>,
    ) -> Self {
        let Self::Pwl { points, .. } = Self::pwl(points) else {
            unreachable!("Waveform::pwl makes a PWL")
        };
        if let Some(r) = repeat
            && let Some(why) = Self::pwl_repeat_fault(&points, r)
        {
            panic!("the PWL repeat time {r} {why}");
        }
        Self::Pwl {
            points,
            delay,
            repeat,
        }
    }

    /// Why `repeat` cannot be the repeat time (SPICE's `r=`) of a PWL through `points`, or `None`
    /// when it can: it must be one of the points' times and come before the last, as ngspice's
    /// `vsrcpar.c` requires (a repeat from the last time would have a zero period).
    #[must_use]
    pub fn pwl_repeat_fault(points: &[(f64, f64)], repeat: f64) -> Option<&'static str> {
        if !points.iter().any(|p| p.0 == repeat) {
            Some("must be one of the points' times")
        } else if points.last().is_some_and(|&(last, _)| repeat >= last) {
            Some("must come before the last time")
        } else {
            None
        }
    }

    /// Checks the waveform of a source of type `part` whose key is `key`: every value finite,
    /// frequency, rise, fall and width non-negative, a pulse period positive (∞: one pulse), PWL
    /// points present with non-decreasing times. Errors name the nested key (`waveform.period`,
    /// `waveform.points[2]`).
    ///
    /// # Errors
    /// [`PartError::Parameter`] for the first value out of range.
    pub fn check(&self, part: &'static str, key: &str) -> Result<(), PartError> {
        let c = Check::new(part);
        let k = |name: &str| format!("{key}.{name}");
        match self {
            Self::Dc(v) => {
                c.finite(key, *v)?;
            }
            Self::Sin {
                offset,
                amplitude,
                frequency,
                delay,
                damping,
                phase_deg,
            } => {
                c.finite(&k("offset"), *offset)?;
                c.finite(&k("amplitude"), *amplitude)?;
                c.non_negative(&k("frequency"), *frequency)?;
                c.finite(&k("delay"), *delay)?;
                c.finite(&k("damping"), *damping)?;
                c.finite(&k("phase"), *phase_deg)?;
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
                if period.is_nan() || *period <= 0.0 {
                    return Err(c.fail(&k("period"), *period, "must be positive"));
                }
                if pulses.is_nan() || *pulses <= 0.0 {
                    return Err(c.fail(&k("pulses"), *pulses, "must be positive"));
                }
                c.finite(&k("v1"), *v1)?;
                c.finite(&k("v2"), *v2)?;
                c.finite(&k("delay"), *delay)?;
                c.non_negative(&k("rise"), *rise)?;
                c.non_negative(&k("fall"), *fall)?;
                c.non_negative(&k("width"), *width)?;
            }
            Self::Exp {
                v1,
                v2,
                rise_delay,
                rise_tau,
                fall_delay,
                fall_tau,
            } => {
                c.finite(&k("v1"), *v1)?;
                c.finite(&k("v2"), *v2)?;
                c.finite(&k("rise_delay"), *rise_delay)?;
                c.non_negative(&k("rise_tau"), *rise_tau)?;
                c.finite(&k("fall_delay"), *fall_delay)?;
                c.non_negative(&k("fall_tau"), *fall_tau)?;
            }
            Self::Sffm {
                offset,
                amplitude,
                carrier,
                index,
                signal,
                carrier_phase_deg,
                signal_phase_deg,
            } => {
                c.finite(&k("offset"), *offset)?;
                c.finite(&k("amplitude"), *amplitude)?;
                c.non_negative(&k("carrier"), *carrier)?;
                c.finite(&k("index"), *index)?;
                c.non_negative(&k("signal"), *signal)?;
                c.finite(&k("carrier_phase"), *carrier_phase_deg)?;
                c.finite(&k("signal_phase"), *signal_phase_deg)?;
            }
            Self::Am {
                amplitude,
                offset,
                modulation,
                carrier,
                delay,
                phase_deg,
            } => {
                c.finite(&k("amplitude"), *amplitude)?;
                c.finite(&k("offset"), *offset)?;
                c.non_negative(&k("modulation"), *modulation)?;
                c.non_negative(&k("carrier"), *carrier)?;
                c.finite(&k("delay"), *delay)?;
                c.finite(&k("phase"), *phase_deg)?;
            }
            Self::Pwl {
                points,
                delay,
                repeat,
            } => {
                if points.is_empty() {
                    return Err(c.fail(&k("points"), 0.0, "must hold at least one point"));
                }
                for (i, p) in points.iter().enumerate() {
                    let at = format!("{key}.points[{i}]");
                    c.finite(&at, p.0)?;
                    c.finite(&at, p.1)?;
                    if i > 0 && p.0 < points[i - 1].0 {
                        return Err(c.fail(&at, p.0, "must not come before the previous time"));
                    }
                }
                c.finite(&k("delay"), *delay)?;
                if let Some(r) = repeat
                    && let Some(why) = Self::pwl_repeat_fault(points, *r)
                {
                    return Err(c.fail(&k("repeat"), *r, why));
                }
            }
        }
        Ok(())
    }

    /// The value at time `t`.
    #[must_use]
    pub fn value(&self, t: f64) -> f64 {
        self.eval(t).0
    }

    /// The time derivative at `t`. At a corner of a piecewise-linear waveform it is the slope of
    /// the piece [`Waveform::value`] uses there (for `PULSE` and `PWL`, the piece ending at `t`);
    /// it is 0 where the waveform is constant and before a `SIN`'s delay.
    #[must_use]
    pub fn derivative(&self, t: f64) -> f64 {
        self.eval(t).1
    }

    /// The first corner strictly after `t`: where the value or its slope jumps (a `PULSE`'s four
    /// corners in every period, a `PWL` point, a `SIN`'s delayed start, an `EXP`'s two delays).
    /// `None` for `DC`, an undelayed `SIN`, and after the last corner.
    #[must_use]
    pub fn next_breakpoint(&self, t: f64) -> Option<f64> {
        match self {
            Self::Dc(_) => None,
            Self::Sin {
                delay,
                frequency,
                damping,
                amplitude,
                ..
            } => {
                let moves = *amplitude != 0.0 && (*frequency != 0.0 || *damping != 0.0);
                (moves && *delay > t).then_some(*delay)
            }
            Self::Pulse {
                delay,
                rise,
                fall,
                width,
                period,
                pulses,
                ..
            } => {
                let corners = [0.0, *rise, rise + width, rise + width + fall];
                let first = |start: f64| corners.iter().map(|c| start + c).find(|&c| c > t);
                if t < *delay {
                    return Some(*delay);
                }
                let next = if !period.is_finite() || *period <= 0.0 {
                    first(*delay)
                } else {
                    let k = ((t - delay) / period).floor();
                    first(delay + k * period).or_else(|| first(delay + (k + 1.0) * period))
                };
                // The train ends after `NP` periods: no corner after it, and a cut inside a
                // pulse (a fractional `NP`) is a corner of its own.
                let span = pulses * period;
                let end = delay + span;
                let cut = span - period * (span / period).floor();
                match next {
                    Some(c) if c < end => Some(c),
                    _ => (end > t && cut > 0.0 && cut < rise + width + fall).then_some(end),
                }
            }
            Self::Exp {
                v1,
                v2,
                rise_delay,
                fall_delay,
                ..
            } => {
                let moves = v1 != v2;
                [*rise_delay, *fall_delay]
                    .into_iter()
                    .find(|&c| moves && c > t)
            }
            Self::Sffm { .. } => None,
            Self::Am {
                amplitude, delay, ..
            } => (*amplitude != 0.0 && *delay > t).then_some(*delay),
            Self::Pwl {
                points,
                delay,
                repeat,
            } => {
                let after = |shift: f64, from: f64| {
                    points
                        .iter()
                        .map(|p| p.0)
                        .filter(|&c| c > from)
                        .map(|c| c + shift + delay)
                        .find(|&c| c > t)
                };
                if let Some(c) = after(0.0, f64::NEG_INFINITY) {
                    return Some(c);
                }
                // Past the last point: the corners of the repeated stretch, cycle by cycle.
                let (r, last) = (repeat.as_ref()?, points.last()?.0);
                let period = last - r;
                let k = ((t - delay - r) / period).floor().max(0.0);
                after(k * period, *r).or_else(|| after((k + 1.0) * period, *r))
            }
        }
    }

    /// Value and slope at `t` (ngspice's `vsrcload.c` definitions; checked against ngspice 39 to
    /// 3e-13 on every waveform kind).
    fn eval(&self, t: f64) -> (f64, f64) {
        match self {
            Self::Dc(v) => (*v, 0.0),
            Self::Sin {
                offset,
                amplitude,
                frequency,
                delay,
                damping,
                phase_deg,
            } => {
                let phase = phase_deg * PI / 180.0;
                let tau = t - delay;
                if tau <= 0.0 {
                    (offset + amplitude * phase.sin(), 0.0)
                } else {
                    let arg = 2.0 * PI * frequency * tau + phase;
                    let decay = (-tau * damping).exp();
                    let value = offset + amplitude * arg.sin() * decay;
                    let slope = amplitude
                        * decay
                        * (2.0 * PI * frequency * arg.cos() - damping * arg.sin());
                    (value, slope)
                }
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
                let (v1, v2, rise, fall, width, period) = (*v1, *v2, *rise, *fall, *width, *period);
                let mut tau = t - delay;
                if tau > pulses * period {
                    return (v1, 0.0);
                }
                if period > 0.0 && tau > period {
                    tau -= period * (tau / period).floor();
                }
                if tau <= 0.0 || tau >= rise + width + fall {
                    (v1, 0.0)
                } else if tau >= rise && tau <= rise + width {
                    (v2, 0.0)
                } else if tau < rise {
                    (v1 + (v2 - v1) * tau / rise, (v2 - v1) / rise)
                } else {
                    (
                        v2 + (v1 - v2) * (tau - (rise + width)) / fall,
                        (v1 - v2) / fall,
                    )
                }
            }
            Self::Sffm {
                offset,
                amplitude,
                carrier,
                index,
                signal,
                carrier_phase_deg,
                signal_phase_deg,
            } => {
                let (wc, ws) = (2.0 * PI * carrier, 2.0 * PI * signal);
                let inner = ws * t + signal_phase_deg * PI / 180.0;
                let arg = wc * t + carrier_phase_deg * PI / 180.0 + index * inner.sin();
                (
                    offset + amplitude * arg.sin(),
                    amplitude * arg.cos() * (wc + index * ws * inner.cos()),
                )
            }
            Self::Am {
                amplitude,
                offset,
                modulation,
                carrier,
                delay,
                phase_deg,
            } => {
                let tau = t - delay;
                if tau <= 0.0 {
                    return (0.0, 0.0);
                }
                let phase = phase_deg * PI / 180.0;
                let (wm, wc) = (2.0 * PI * modulation, 2.0 * PI * carrier);
                let envelope = offset + (wm * tau + phase).sin();
                let wave = (wc * tau + phase).sin();
                (
                    amplitude * envelope * wave,
                    amplitude
                        * (wm * (wm * tau + phase).cos() * wave
                            + envelope * wc * (wc * tau + phase).cos()),
                )
            }
            Self::Exp {
                v1,
                v2,
                rise_delay,
                rise_tau,
                fall_delay,
                fall_tau,
            } => {
                // `step` of height `a` starting at `t0` with time constant `tau`: value and slope.
                let relax = |a: f64, t0: f64, tau: f64| {
                    if tau == 0.0 {
                        (a, 0.0)
                    } else {
                        let e = (-(t - t0) / tau).exp();
                        (a * (1.0 - e), a * e / tau)
                    }
                };
                if t <= *rise_delay {
                    return (*v1, 0.0);
                }
                let (rise, rise_slope) = relax(v2 - v1, *rise_delay, *rise_tau);
                if t <= *fall_delay {
                    return (v1 + rise, rise_slope);
                }
                let (fall, fall_slope) = relax(v1 - v2, *fall_delay, *fall_tau);
                (v1 + rise + fall, rise_slope + fall_slope)
            }
            Self::Pwl {
                points,
                delay,
                repeat,
            } => {
                let (Some(&(t0, v0)), Some(&(t_end, v_end))) = (points.first(), points.last())
                else {
                    return (0.0, 0.0);
                };
                let mut t = t - delay;
                if t < t0 {
                    return (v0, 0.0);
                }
                if t > t_end {
                    match repeat {
                        // Back into (R, Tₙ] by whole periods: the left value at each restart.
                        Some(r) if *r < t_end => {
                            let period = t_end - r;
                            t -= ((t - t_end) / period).ceil() * period;
                            t = t.clamp(*r, t_end);
                        }
                        _ => return (v_end, 0.0),
                    }
                }
                // First point with time ≥ t; the segment ends there.
                let i = points.partition_point(|p| p.0 < t).max(1);
                let ((ta, va), (tb, vb)) = (points[i - 1], points[i.min(points.len() - 1)]);
                let dt = tb - ta;
                if dt <= 0.0 {
                    // A jump at the first time point: ngspice holds the first value there.
                    return (va, 0.0);
                }
                let slope = (vb - va) / dt;
                (va + (t - ta) * slope, slope)
            }
        }
    }
}

impl From<f64> for Waveform {
    fn from(v: f64) -> Self {
        Self::Dc(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corners of each kind, listed by hand from the definitions above: the pulse's four corners in
    /// its first and second period, a PWL's points, a delayed sine's start; nothing for DC and an
    /// undelayed sine.
    #[test]
    fn breakpoints_are_the_corners() {
        let p = Waveform::pulse(0.0, 5.0, 1.0, 0.5, 0.25, 2.0, 10.0);
        let mut t = -1.0;
        let mut seen = Vec::new();
        while let Some(b) = p.next_breakpoint(t) {
            if b > 21.2 {
                break;
            }
            seen.push(b);
            t = b;
        }
        assert_eq!(seen, [1.0, 1.5, 3.5, 3.75, 11.0, 11.5, 13.5, 13.75, 21.0]);
        let single = Waveform::pulse(0.0, 5.0, 1.0, 0.5, 0.25, 2.0, f64::INFINITY);
        assert_eq!(single.next_breakpoint(3.6), Some(3.75));
        assert_eq!(single.next_breakpoint(3.75), None);
        let pwl = Waveform::pwl(vec![(0.0, 0.0), (1.0, 2.0), (1.0, 3.0), (4.0, 3.0)]);
        assert_eq!(pwl.next_breakpoint(0.0), Some(1.0));
        assert_eq!(pwl.next_breakpoint(1.0), Some(4.0));
        assert_eq!(pwl.next_breakpoint(4.0), None);
        let mut s = Waveform::sin(0.0, 1.0, 50.0);
        assert_eq!(s.next_breakpoint(0.0), None);
        if let Waveform::Sin { delay, .. } = &mut s {
            *delay = 0.02;
        }
        assert_eq!(s.next_breakpoint(0.0), Some(0.02));
        assert_eq!(s.next_breakpoint(0.02), None);
        assert_eq!(Waveform::Dc(1.0).next_breakpoint(0.0), None);
    }

    /// `PULSE(0 5 1 0.5 0.25 2 10 NP)`, values worked by hand from ngspice's `vsrcload.c`
    /// (`time − TD > NP·PER` gives `V1`, strictly, before the period is reduced): with `NP = 2`
    /// the second pulse is whole and the third never comes, and the corners stop with it; with
    /// `NP = 1.2` the second pulse is cut on its plateau at `TD + 12 = 13`, a corner of its own.
    /// ngspice-39 on a deck of two such sources (`NP` = 2 and 1.5) agrees with dirac's rows to
    /// 1e-7 under gauss2 away from the cut.
    #[test]
    fn a_pulse_train_ends_after_np_periods() {
        let train = |pulses| Waveform::Pulse {
            v1: 0.0,
            v2: 5.0,
            delay: 1.0,
            rise: 0.5,
            fall: 0.25,
            width: 2.0,
            period: 10.0,
            pulses,
        };
        let two = train(2.0);
        assert_eq!(two.value(12.0), 5.0); // second pulse, plateau
        assert_eq!(two.value(11.25), 2.5); // second pulse, half-way up
        assert_eq!(two.value(21.0), 0.0); // τ = 20 = NP·PER: not past the end, but V1 anyway
        assert_eq!(two.value(22.0), 0.0); // where a third pulse would be on its plateau
        assert_eq!(train(f64::INFINITY).value(22.0), 5.0);
        let mut t = -1.0;
        let mut seen = Vec::new();
        while let Some(b) = two.next_breakpoint(t) {
            seen.push(b);
            t = b;
        }
        assert_eq!(seen, [1.0, 1.5, 3.5, 3.75, 11.0, 11.5, 13.5, 13.75]);
        let cut = train(1.2);
        assert_eq!(cut.value(13.0), 5.0); // τ = 12 = NP·PER exactly: still on the plateau
        assert_eq!(cut.value(13.0 + 1e-9), 0.0);
        assert_eq!(cut.next_breakpoint(11.5), Some(13.0));
        assert_eq!(cut.next_breakpoint(13.0), None);
        assert!(train(0.0).check("source", "waveform").is_err());
        assert!(train(f64::NAN).check("source", "waveform").is_err());
    }

    /// Hand-evaluated values of each ngspice function at breakpoints and inside segments.
    #[test]
    fn ngspice_semantics() {
        assert_eq!(Waveform::Dc(3.0).value(-1.0), 3.0);

        // SIN(1 2 50 0.01 10 30): before TD the phase-shifted constant, after it the damped sine.
        let s = Waveform::Sin {
            offset: 1.0,
            amplitude: 2.0,
            frequency: 50.0,
            delay: 0.01,
            damping: 10.0,
            phase_deg: 30.0,
        };
        assert!((s.value(0.0) - 2.0).abs() < 1e-15); // 1 + 2 sin 30°
        assert!((s.value(0.01) - 2.0).abs() < 1e-15);
        let tau: f64 = 0.013;
        let expected = 1.0 + 2.0 * (2.0 * PI * 50.0 * tau + PI / 6.0).sin() * (-10.0 * tau).exp();
        assert!((s.value(0.023) - expected).abs() < 1e-14);
        assert!((Waveform::sin(0.0, 1.0, 1.0).value(0.25) - 1.0).abs() < 1e-15);

        // PULSE(0 5 1 0.5 0.25 2 10).
        let p = Waveform::pulse(0.0, 5.0, 1.0, 0.5, 0.25, 2.0, 10.0);
        let cases = [
            (0.0, 0.0),
            (1.0, 0.0),
            (1.25, 2.5),
            (1.5, 5.0),
            (3.5, 5.0),
            (3.625, 2.5),
            (3.75, 0.0),
            (9.0, 0.0),
            (11.25, 2.5),
            (13.0, 5.0),
            (21.5, 5.0),
        ];
        for (t, v) in cases {
            assert!(
                (p.value(t) - v).abs() < 1e-12,
                "PULSE at {t}: {}",
                p.value(t)
            );
        }
        // Ideal edges and a single pulse.
        let ideal = Waveform::pulse(-1.0, 1.0, 0.0, 0.0, 0.0, 1.0, f64::INFINITY);
        assert_eq!(ideal.value(0.0), -1.0);
        assert_eq!(ideal.value(0.5), 1.0);
        assert_eq!(ideal.value(1.0), -1.0);
        assert_eq!(ideal.value(1e9), -1.0);

        // PWL(1 0 2 4 2 -4 3 0): held first value, ramp, step (left value at the step), hold.
        let w = Waveform::pwl(vec![(1.0, 0.0), (2.0, 4.0), (2.0, -4.0), (3.0, 0.0)]);
        let cases = [
            (0.0, 0.0),
            (1.0, 0.0),
            (1.5, 2.0),
            (2.0, 4.0),
            (2.5, -2.0),
            (3.0, 0.0),
            (7.0, 0.0),
        ];
        for (t, v) in cases {
            assert!((w.value(t) - v).abs() < 1e-15, "PWL at {t}: {}", w.value(t));
        }
        assert_eq!(Waveform::pwl(vec![(0.0, 2.5)]).value(-3.0), 2.5);
    }

    /// `PWL(0 0 1 2 1 -1 3 0) r=1 td=0.5`, worked out by hand from ngspice's `vsrcload.c`
    /// (`τ = t − TD`; past `Tₙ = 3`, `τ ← R + (τ − R) mod (Tₙ − R)` with `R = 1`, period 2): the
    /// ramp (at its first point with the first piece's slope, as without a delay), the step at 1
    /// (left value 2), the stretch (1, 3] from −1 up to 0, then that stretch again and again,
    /// with the left value at each restart.
    #[test]
    fn pwl_repeats_and_delays_as_ngspice() {
        let w = Waveform::pwl_repeating(
            vec![(0.0, 0.0), (1.0, 2.0), (1.0, -1.0), (3.0, 0.0)],
            0.5,
            Some(1.0),
        );
        let cases = [
            (0.0, 0.0, 0.0),
            (0.5, 0.0, 2.0),
            (1.0, 1.0, 2.0),
            (1.5, 2.0, 2.0),
            (2.5, -0.5, 0.5),
            (3.5, 0.0, 0.5),
            (4.0, -0.75, 0.5),
            (5.5, 0.0, 0.5),
            (6.5, -0.5, 0.5),
            (101.0, -0.25, 0.5),
        ];
        for (t, v, d) in cases {
            assert!(
                (w.value(t) - v).abs() < 1e-13,
                "value at {t}: {}",
                w.value(t)
            );
            assert!(
                (w.derivative(t) - d).abs() < 1e-13,
                "slope at {t}: {}",
                w.derivative(t)
            );
        }
        let mut t = -1.0;
        let mut corners = Vec::new();
        while let Some(b) = w.next_breakpoint(t) {
            if b > 10.0 {
                break;
            }
            corners.push(b);
            t = b;
        }
        assert_eq!(corners, [0.5, 1.5, 3.5, 5.5, 7.5, 9.5]);
        // Without `r`, the last value is held and the corners end with the last point.
        let held = Waveform::pwl_repeating(vec![(0.0, 1.0), (1.0, 3.0)], 2.0, None);
        assert_eq!(held.value(2.5), 2.0);
        assert_eq!(held.value(50.0), 3.0);
        assert_eq!(held.next_breakpoint(2.5), Some(3.0));
        assert_eq!(held.next_breakpoint(3.0), None);
        assert!(w.check("voltage_source", "waveform").is_ok());
        let bad = Waveform::Pwl {
            points: vec![(0.0, 0.0), (1.0, 1.0)],
            delay: 0.0,
            repeat: Some(0.5),
        };
        let err = bad
            .check("voltage_source", "waveform")
            .unwrap_err()
            .to_string();
        assert!(err.contains("waveform.repeat"), "{err}");
    }

    /// `SFFM` and `AM` as `vsrcload.c` of ngspice-39 writes them (`AM` uses `PHASES` in both
    /// sines), and their slopes against central differences.
    #[test]
    fn sffm_and_am_as_ngspice() {
        let sffm = Waveform::Sffm {
            offset: 0.5,
            amplitude: 2.0,
            carrier: 10e3,
            index: 3.0,
            signal: 1e3,
            carrier_phase_deg: 30.0,
            signal_phase_deg: 60.0,
        };
        let am = Waveform::Am {
            amplitude: 1.5,
            offset: 0.4,
            modulation: 1e3,
            carrier: 10e3,
            delay: 0.2e-3,
            phase_deg: 45.0,
        };
        let rad = PI / 180.0;
        for t in [0.0, 0.1e-3, 0.35e-3, 0.77e-3] {
            let fm = 0.5
                + 2.0
                    * (2.0 * PI * 10e3 * t
                        + 30.0 * rad
                        + 3.0 * (2.0 * PI * 1e3 * t + 60.0 * rad).sin())
                    .sin();
            assert!((sffm.value(t) - fm).abs() < 1e-13, "{t}");
            let tau = t - 0.2e-3;
            let modulated = if tau <= 0.0 {
                0.0
            } else {
                1.5 * (0.4 + (2.0 * PI * 1e3 * tau + 45.0 * rad).sin())
                    * (2.0 * PI * 10e3 * tau + 45.0 * rad).sin()
            };
            assert!((am.value(t) - modulated).abs() < 1e-13, "{t}");
            for w in [&sffm, &am] {
                let dt = 1e-10;
                let difference = (w.value(t + dt) - w.value(t - dt)) / (2.0 * dt);
                if t > 0.0 {
                    assert!(
                        (w.derivative(t) - difference).abs() < 1e-5 * (1.0 + difference.abs()),
                        "{w:?} at {t}: {} against {difference}",
                        w.derivative(t)
                    );
                }
            }
        }
        assert_eq!(am.next_breakpoint(0.0), Some(0.2e-3));
        assert_eq!(am.next_breakpoint(0.3e-3), None);
        assert_eq!(sffm.next_breakpoint(0.0), None);
    }

    /// `EXP(1 3 1 0.5 2 0.25)` by hand from ngspice's `vsrcload.c`: 1 up to TD1 = 1, then
    /// `1 + 2(1 − e^{−(t−1)/0.5})`, and after TD2 = 2 minus `2(1 − e^{−(t−2)/0.25})`.
    #[test]
    fn exp_rises_and_falls_as_ngspice() {
        let w = Waveform::Exp {
            v1: 1.0,
            v2: 3.0,
            rise_delay: 1.0,
            rise_tau: 0.5,
            fall_delay: 2.0,
            fall_tau: 0.25,
        };
        let rise = |t: f64| 2.0 * (1.0 - (-(t - 1.0) / 0.5).exp());
        let fall = |t: f64| -2.0 * (1.0 - (-(t - 2.0) / 0.25).exp());
        let cases = [
            (0.0, 1.0, 0.0),
            (1.0, 1.0, 0.0),
            (1.5, 1.0 + rise(1.5), 4.0 * (-1.0f64).exp()),
            (2.0, 1.0 + rise(2.0), 4.0 * (-2.0f64).exp()),
            (
                2.5,
                1.0 + rise(2.5) + fall(2.5),
                4.0 * (-3.0f64).exp() - 8.0 * (-2.0f64).exp(),
            ),
        ];
        for (t, v, d) in cases {
            assert!(
                (w.value(t) - v).abs() < 1e-14,
                "value at {t}: {}",
                w.value(t)
            );
            assert!(
                (w.derivative(t) - d).abs() < 1e-13,
                "slope at {t}: {}",
                w.derivative(t)
            );
        }
        assert_eq!(w.next_breakpoint(0.0), Some(1.0));
        assert_eq!(w.next_breakpoint(1.0), Some(2.0));
        assert_eq!(w.next_breakpoint(2.0), None);
        // Zero time constants are ideal edges.
        let edges = Waveform::Exp {
            v1: 0.0,
            v2: 1.0,
            rise_delay: 1.0,
            rise_tau: 0.0,
            fall_delay: 2.0,
            fall_tau: 0.0,
        };
        assert_eq!(
            [
                edges.value(1.0),
                edges.value(1.5),
                edges.value(2.0),
                edges.value(2.5)
            ],
            [0.0, 1.0, 1.0, 0.0]
        );
    }

    #[test]
    #[should_panic(expected = "non-decreasing")]
    fn pwl_rejects_decreasing_times() {
        let _ = Waveform::pwl(vec![(1.0, 0.0), (0.5, 1.0)]);
    }
}
