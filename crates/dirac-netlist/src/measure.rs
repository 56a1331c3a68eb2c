//! `.meas`/`.measure` transient measurements, as ngspice-39 defines them (`com_measure2.c`):
//! a delay between two events (`TRIG … TARG …`), the time of an event (`WHEN`), a value at an
//! event or a time (`FIND … WHEN`, `FIND … AT=`), and a statistic over a window (`AVG MIN MAX
//! PP RMS INTEG MIN_AT MAX_AT`, `FROM=`/`TO=`). [`Measure::evaluate`] computes one from a run's
//! samples: times and the signals the measure reads, linear between samples as ngspice
//! interpolates its time points.

use crate::Pos;

/// The edge of a crossing an event counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Edge {
    /// `RISE=`: the signal goes from below the level to at or above it.
    Rise,
    /// `FALL=`: from at or above the level to at or below it.
    Fall,
    /// `CROSS=`: either.
    Cross,
}

/// Which crossing of its edge an event is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Occurrence {
    /// The `n`-th (from 1).
    Nth(usize),
    /// `=LAST`.
    Last,
}

/// What a signal crosses: a value or another signal (`WHEN v(a)=v(b)`).
#[derive(Debug, Clone, PartialEq)]
pub enum Level<V> {
    /// A constant (`VAL=`, `WHEN v(out)=0.5`).
    Value(V),
    /// Another signal's value at the same time.
    Signal(String),
}

/// A crossing of `signal` through `level` after `td`.
#[derive(Debug, Clone, PartialEq)]
pub struct Crossing<V> {
    /// The signal, as a netlist names it (`v(out)`, `i(v1)`).
    pub signal: String,
    /// What it crosses.
    pub level: Level<V>,
    /// `TD=`: samples before this time are not looked at.
    pub td: Option<V>,
    /// `RISE=`, `FALL=` or `CROSS=`; `None`: the first crossing of either edge.
    pub edge: Option<(Edge, Occurrence)>,
}

/// An instant a measure refers to.
#[derive(Debug, Clone, PartialEq)]
pub enum Event<V> {
    /// `AT=time`.
    At(V),
    /// The time of a crossing.
    Crossing(Crossing<V>),
}

/// A statistic of a signal over a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Statistic {
    /// The time average (the integral over the window's length).
    Avg,
    /// The smallest sample.
    Min,
    /// The largest sample.
    Max,
    /// Largest minus smallest.
    Pp,
    /// The root of the time average of the square.
    Rms,
    /// The integral over the window.
    Integ,
    /// The time of the smallest sample.
    MinAt,
    /// The time of the largest sample.
    MaxAt,
}

/// What a measure computes.
#[derive(Debug, Clone, PartialEq)]
pub enum MeasureKind<V> {
    /// `TRIG … TARG …`: the target's time minus the trigger's.
    Delay {
        /// The trigger.
        trig: Event<V>,
        /// The target.
        targ: Event<V>,
    },
    /// `WHEN …`: the time of a crossing.
    When(Crossing<V>),
    /// `FIND signal WHEN …` or `FIND signal AT=…`: the signal's value then.
    Find {
        /// The signal read.
        signal: String,
        /// When.
        at: Event<V>,
    },
    /// `AVG|MIN|… signal [FROM=] [TO=]`.
    Statistic {
        /// Which statistic.
        statistic: Statistic,
        /// The signal.
        signal: String,
        /// Window start (`FROM=`); default the first sample.
        from: Option<V>,
        /// Window end (`TO=`); default the last sample.
        to: Option<V>,
    },
}

/// One `.meas` card: its result's name, where it was written, and what it computes (values of
/// type `V`: expressions as read, numbers once the netlist's parameters are evaluated).
#[derive(Debug, Clone, PartialEq)]
pub struct Measure<V = f64> {
    /// The result's name (lowercase).
    pub name: String,
    /// Where the card starts.
    pub pos: Pos,
    /// The card as written.
    pub text: String,
    /// What it computes.
    pub kind: MeasureKind<V>,
}

impl<V> Measure<V> {
    /// The same measure with every value mapped by `f` (evaluating the card's expressions).
    ///
    /// # Errors
    /// The first error of `f`.
    pub fn try_map<W, E>(self, f: &mut impl FnMut(V) -> Result<W, E>) -> Result<Measure<W>, E> {
        let crossing = |c: Crossing<V>, f: &mut dyn FnMut(V) -> Result<W, E>| {
            Ok(Crossing {
                signal: c.signal,
                level: match c.level {
                    Level::Value(v) => Level::Value(f(v)?),
                    Level::Signal(s) => Level::Signal(s),
                },
                td: c.td.map(&mut *f).transpose()?,
                edge: c.edge,
            })
        };
        let event = |e: Event<V>, f: &mut dyn FnMut(V) -> Result<W, E>| {
            Ok(match e {
                Event::At(v) => Event::At(f(v)?),
                Event::Crossing(c) => Event::Crossing(crossing(c, f)?),
            })
        };
        let kind = match self.kind {
            MeasureKind::Delay { trig, targ } => MeasureKind::Delay {
                trig: event(trig, f)?,
                targ: event(targ, f)?,
            },
            MeasureKind::When(c) => MeasureKind::When(crossing(c, f)?),
            MeasureKind::Find { signal, at } => MeasureKind::Find {
                signal,
                at: event(at, f)?,
            },
            MeasureKind::Statistic {
                statistic,
                signal,
                from,
                to,
            } => MeasureKind::Statistic {
                statistic,
                signal,
                from: from.map(&mut *f).transpose()?,
                to: to.map(&mut *f).transpose()?,
            },
        };
        Ok(Measure {
            name: self.name,
            pos: self.pos,
            text: self.text,
            kind,
        })
    }

    /// The signals the measure reads, in order of first mention.
    #[must_use]
    pub fn signals(&self) -> Vec<String> {
        let mut names: Vec<&str> = Vec::new();
        fn crossing<'c, V>(c: &'c Crossing<V>, names: &mut Vec<&'c str>) {
            names.push(&c.signal);
            if let Level::Signal(s) = &c.level {
                names.push(s);
            }
        }
        match &self.kind {
            MeasureKind::Delay { trig, targ } => {
                for event in [trig, targ] {
                    if let Event::Crossing(c) = event {
                        crossing(c, &mut names);
                    }
                }
            }
            MeasureKind::When(c) => crossing(c, &mut names),
            MeasureKind::Find { signal, at } => {
                names.push(signal);
                if let Event::Crossing(c) = at {
                    crossing(c, &mut names);
                }
            }
            MeasureKind::Statistic { signal, .. } => names.push(signal),
        }
        let mut out: Vec<String> = Vec::new();
        for name in names {
            if !out.iter().any(|o| o == name) {
                out.push(name.to_string());
            }
        }
        out
    }
}

impl Measure<f64> {
    /// The measure's value from samples at times `t` (increasing) of the signals it reads
    /// (`column(name)`: one value per time, for every name of [`Measure::signals`]).
    ///
    /// # Errors
    /// Why it could not be taken, as a sentence (no such crossing, a time outside the run, an
    /// empty window); ngspice then reports the measure as failed and goes on.
    pub fn evaluate<'a>(
        &self,
        t: &[f64],
        column: &dyn Fn(&str) -> &'a [f64],
    ) -> Result<f64, String> {
        match &self.kind {
            MeasureKind::Delay { trig, targ } => {
                let start = event_time(trig, t, column)?;
                let end = event_time(targ, t, column)?;
                Ok(end - start)
            }
            MeasureKind::When(c) => crossing_time(c, t, column),
            MeasureKind::Find { signal, at } => {
                let time = event_time(at, t, column)?;
                value_at(t, column(signal), time)
                    .ok_or_else(|| format!("{signal} has no sample around t = {time:e}"))
            }
            MeasureKind::Statistic {
                statistic,
                signal,
                from,
                to,
            } => statistic_over(*statistic, t, column(signal), *from, *to)
                .ok_or_else(|| format!("the window holds no stretch of {signal}")),
        }
    }

    /// The stretches of time its value reads between two samples, for a warning where a source
    /// corner lies inside one (the samples do not resolve it; docs/audit.md item 51): the
    /// sample interval around each event time (a crossing, an `AT=`) and a statistic's window.
    #[must_use]
    pub fn stretches<'a>(&self, t: &[f64], column: &dyn Fn(&str) -> &'a [f64]) -> Vec<(f64, f64)> {
        let around = |time: f64| -> Option<(f64, f64)> {
            let i = t.iter().position(|&ti| ti >= time)?;
            if t[i] == time {
                return None;
            }
            Some((t[i.checked_sub(1)?], t[i]))
        };
        let events: Vec<&Event<f64>> = match &self.kind {
            MeasureKind::Delay { trig, targ } => vec![trig, targ],
            MeasureKind::Find { at, .. } => vec![at],
            MeasureKind::When(c) => {
                return crossing_time(c, t, column)
                    .ok()
                    .and_then(around)
                    .into_iter()
                    .collect();
            }
            MeasureKind::Statistic { from, to, .. } => {
                let (Some(&first), Some(&last)) = (t.first(), t.last()) else {
                    return Vec::new();
                };
                return vec![(from.unwrap_or(first), to.unwrap_or(last))];
            }
        };
        events
            .into_iter()
            .filter_map(|e| event_time(e, t, column).ok())
            .filter_map(around)
            .collect()
    }
}

fn event_time<'a>(
    event: &Event<f64>,
    t: &[f64],
    column: &dyn Fn(&str) -> &'a [f64],
) -> Result<f64, String> {
    match event {
        Event::At(time) => Ok(*time),
        Event::Crossing(c) => crossing_time(c, t, column),
    }
}

/// The time of the crossing `c`: a rise is the signal passing from below the level to above
/// it, a fall the reverse, at the time linear between the two samples around it, or at the
/// first sample on the level where it rests there on its way; samples on the level do not
/// change its side, so a signal resting on the level (a rail at `VAL`, a current that is 0
/// before a source starts) crosses nothing, and a start on the level is no crossing
/// (ngspice-39 counts a rise there when the signal leaves the level upwards at once: a `SIN`
/// from 0 has one crossing of 0 more in ngspice).
fn crossing_time<'a>(
    c: &Crossing<f64>,
    t: &[f64],
    column: &dyn Fn(&str) -> &'a [f64],
) -> Result<f64, String> {
    let y = column(&c.signal);
    let level: Box<dyn Fn(usize) -> f64> = match &c.level {
        Level::Value(v) => {
            let v = *v;
            Box::new(move |_| v)
        }
        Level::Signal(s) => {
            let other = column(s);
            Box::new(move |i| other[i])
        }
    };
    let td = c.td.unwrap_or(f64::NEG_INFINITY);
    let (want, occurrence) = c.edge.unwrap_or((Edge::Cross, Occurrence::Nth(1)));
    let mut counts = [0usize; 2];
    let mut found = None;
    // The last sample off the level and its side (above: true), and the first sample of the
    // stretch on the level since.
    let mut last: Option<(usize, bool)> = None;
    let mut resting: Option<usize> = None;
    for i in (0..t.len()).filter(|&i| t[i] >= td) {
        let d = y[i] - level(i);
        if d == 0.0 {
            resting.get_or_insert(i);
            continue;
        }
        let above = d > 0.0;
        let crossing = match last {
            None => None,
            Some((j, side)) if side != above => {
                let edge = if above { Edge::Rise } else { Edge::Fall };
                let time = match resting {
                    Some(r) => t[r],
                    None => {
                        let dj = y[j] - level(j);
                        t[j] + (0.0 - dj) * (t[i] - t[j]) / (d - dj)
                    }
                };
                Some((edge, time))
            }
            Some(_) => None,
        };
        last = Some((i, above));
        resting = None;
        let Some((edge, time)) = crossing else {
            continue;
        };
        counts[usize::from(edge == Edge::Fall)] += 1;
        if want != Edge::Cross && want != edge {
            continue;
        }
        let count = match want {
            Edge::Cross => counts[0] + counts[1],
            Edge::Rise => counts[0],
            Edge::Fall => counts[1],
        };
        match occurrence {
            Occurrence::Nth(n) if count == n => return Ok(time),
            Occurrence::Nth(_) => {}
            Occurrence::Last => found = Some(time),
        }
    }
    found.ok_or_else(|| {
        let level = match &c.level {
            Level::Value(v) => format!("{v:e}"),
            Level::Signal(s) => s.clone(),
        };
        let which = match (c.edge, occurrence) {
            (None, _) => "no crossing".to_string(),
            (Some((e, _)), Occurrence::Last) => format!("no {}crossing", edge_name(e)),
            (Some((e, _)), Occurrence::Nth(n)) => {
                format!("no {}crossing number {n}", edge_name(e))
            }
        };
        let after =
            c.td.map_or(String::new(), |td| format!(" after TD = {td:e}"));
        format!("{which} of {} through {level}{after}", c.signal)
    })
}

fn edge_name(edge: Edge) -> &'static str {
    match edge {
        Edge::Rise => "rising ",
        Edge::Fall => "falling ",
        Edge::Cross => "",
    }
}

/// `y` at `time`, linear between the samples around it (`None` outside the samples).
fn value_at(t: &[f64], y: &[f64], time: f64) -> Option<f64> {
    let i = t.iter().position(|&ti| ti >= time)?;
    if t[i] == time {
        return Some(y[i]);
    }
    let j = i.checked_sub(1)?;
    Some(y[j] + (time - t[j]) * (y[i] - y[j]) / (t[i] - t[j]))
}

/// `statistic` of `y` over `[from, to]`: of the samples inside and the values interpolated at the
/// ends (ngspice takes `MIN`/`MAX`/`AVG` of the samples inside only, and integrates `RMS` and
/// `INTEG` by Simpson's rules over equal intervals, which across a corner between samples are
/// off by a sixth of the interval times the change of slope).
fn statistic_over(
    statistic: Statistic,
    t: &[f64],
    y: &[f64],
    from: Option<f64>,
    to: Option<f64>,
) -> Option<f64> {
    let (first, last) = (*t.first()?, *t.last()?);
    let from = from.unwrap_or(first).max(first);
    let to = to.unwrap_or(last).min(last);
    if to < from {
        return None;
    }
    let mut xs = vec![from];
    let mut ys = vec![value_at(t, y, from)?];
    for (&ti, &yi) in t.iter().zip(y) {
        if ti > from && ti < to {
            xs.push(ti);
            ys.push(yi);
        }
    }
    if to > from {
        xs.push(to);
        ys.push(value_at(t, y, to)?);
    }
    let extreme = |better: fn(f64, f64) -> bool| {
        let mut k = 0;
        for i in 1..ys.len() {
            if better(ys[i], ys[k]) {
                k = i;
            }
        }
        k
    };
    let (min, max) = (extreme(|a, b| a <= b), extreme(|a, b| a >= b));
    let span = to - from;
    Some(match statistic {
        Statistic::Min => ys[min],
        Statistic::Max => ys[max],
        Statistic::MinAt => xs[min],
        Statistic::MaxAt => xs[max],
        Statistic::Pp => ys[max] - ys[min],
        Statistic::Integ => integral(&xs, &ys),
        Statistic::Avg if span > 0.0 => integral(&xs, &ys) / span,
        Statistic::Rms if span > 0.0 => (integral_of_square(&xs, &ys) / span).sqrt(),
        Statistic::Avg | Statistic::Rms => return None,
    })
}

/// The integral of the square of the samples' linear interpolant (the curve every other measure
/// reads): `Δt·(a² + ab + b²)/3` per interval. The trapezoid rule on the squares, which this
/// replaced, put a 1 V → 0 ramp between two samples at an RMS of `√½` for its `√⅓` (22 % off; a
/// pulse's edge between two corner samples).
fn integral_of_square(x: &[f64], y: &[f64]) -> f64 {
    x.windows(2)
        .zip(y.windows(2))
        .map(|(x, y)| (x[1] - x[0]) * (y[0] * y[0] + y[0] * y[1] + y[1] * y[1]) / 3.0)
        .sum()
}

/// The trapezoid rule: the integral of the samples' linear interpolant, the curve every other
/// measure reads.
fn integral(x: &[f64], y: &[f64]) -> f64 {
    x.windows(2)
        .zip(y.windows(2))
        .map(|(x, y)| 0.5 * (x[1] - x[0]) * (y[0] + y[1]))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measure(kind: MeasureKind<f64>) -> Measure {
        Measure {
            name: "m".into(),
            pos: Pos::new(1, 1),
            text: String::new(),
            kind,
        }
    }

    fn crossing(signal: &str, value: f64, edge: Option<(Edge, Occurrence)>) -> Crossing<f64> {
        Crossing {
            signal: signal.into(),
            level: Level::Value(value),
            td: None,
            edge,
        }
    }

    /// `sin(2πt)` sampled at `n + 1` points over one second, and `cos`.
    fn sine(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=n).map(|k| k as f64 / n as f64).collect();
        let tau = std::f64::consts::TAU;
        let s = t.iter().map(|&x| (tau * x).sin()).collect();
        let c = t.iter().map(|&x| (tau * x).cos()).collect();
        (t, s, c)
    }

    #[test]
    fn crossings_of_a_sine_are_its_closed_form_times() {
        let (t, s, c) = sine(4000);
        let column = |name: &str| -> &[f64] { if name == "s" { &s } else { &c } };
        let when = |edge, value| measure(MeasureKind::When(crossing("s", value, edge)));
        let at = |m: Measure| m.evaluate(&t, &column).expect("a crossing");
        // sin(2πt) = 0.5 rising at t = 1/12, falling at 5/12; linear interpolation is O(h²).
        let close = |a: f64, b: f64| (a - b).abs() < 1e-7;
        assert!(close(at(when(None, 0.5)), 1.0 / 12.0));
        assert!(close(
            at(when(Some((Edge::Fall, Occurrence::Nth(1))), 0.5)),
            5.0 / 12.0
        ));
        assert!(close(
            at(when(Some((Edge::Cross, Occurrence::Nth(2))), 0.5)),
            5.0 / 12.0
        ));
        assert!(close(
            at(when(Some((Edge::Cross, Occurrence::Last)), -0.5)),
            11.0 / 12.0
        ));
        assert!(
            when(Some((Edge::Rise, Occurrence::Nth(2))), 0.5)
                .evaluate(&t, &column)
                .is_err()
        );
        // TD skips the samples before it: the first fall through 0 after 0.1 s is at 0.5 s.
        let mut late = crossing("s", 0.0, Some((Edge::Fall, Occurrence::Nth(1))));
        late.td = Some(0.1);
        assert!(close(at(measure(MeasureKind::When(late))), 0.5));
        // Two signals crossing: sin = cos at 1/8 and 5/8.
        let both = Crossing {
            level: Level::Signal("c".into()),
            ..crossing("s", 0.0, Some((Edge::Cross, Occurrence::Nth(2))))
        };
        assert!(close(at(measure(MeasureKind::When(both))), 5.0 / 8.0));
        // A delay between two events, and a value found at an event.
        let delay = measure(MeasureKind::Delay {
            trig: Event::Crossing(crossing("s", 0.5, None)),
            targ: Event::Crossing(crossing("s", -0.5, None)),
        });
        assert!(close(at(delay), 7.0 / 12.0 - 1.0 / 12.0));
        let find = measure(MeasureKind::Find {
            signal: "c".into(),
            at: Event::At(0.125),
        });
        assert!(close(at(find), (std::f64::consts::TAU / 8.0).cos()));
    }

    #[test]
    fn a_signal_resting_on_the_level_crosses_nothing() {
        // 0 until 1, a ramp to 2 at 3, back to 0 at 5, then 0: a PULSE on a rail at VAL = 0.
        let t: Vec<f64> = (0..=8).map(f64::from).collect();
        let y = [0.0, 0.0, 1.0, 2.0, 2.0, 0.0, 0.0, 0.0, 0.0];
        let column = |_: &str| -> &[f64] { &y };
        let when = |edge| measure(MeasureKind::When(crossing("y", 0.0, Some(edge))));
        let first = |e| (e, Occurrence::Nth(1));
        // Leaving the rail it started on is no rise; landing on it at t = 5 and staying is no
        // fall (ngspice-39 fails both measures too).
        assert!(when(first(Edge::Rise)).evaluate(&t, &column).is_err());
        assert_eq!(
            when(first(Edge::Fall)).evaluate(&t, &column),
            Err("no falling crossing number 1 of y through 0e0".to_string())
        );
        // Resting on a level the signal then leaves on the same side is no crossing; passing it
        // is, at the first sample on it.
        let z = [-1.0, 0.0, 0.0, -1.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let column = |_: &str| -> &[f64] { &z };
        assert_eq!(when(first(Edge::Cross)).evaluate(&t, &column), Ok(4.0));
    }

    #[test]
    fn the_rms_of_a_ramp_between_two_samples_is_its_own() {
        // 1 → 0 over [0, 1], sampled at its ends only: the ramp's RMS is 1/√3; over a window
        // [0.25, 1] inside it, √(∫ (1 − t)² / 0.75) = √(0.75²/3/0.75) = √0.1875.
        let (t, y) = ([0.0, 1.0], [1.0, 0.0]);
        let rms = |from, to| {
            measure(MeasureKind::Statistic {
                statistic: Statistic::Rms,
                signal: "s".into(),
                from,
                to,
            })
            .evaluate(&t, &|_: &str| -> &[f64] { &y })
            .expect("a window")
        };
        assert!((rms(None, None) - (1.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((rms(Some(0.25), None) - 0.1875f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn statistics_of_a_sine_are_their_closed_forms() {
        let (t, s, _) = sine(3000);
        let stat = |statistic, from, to| {
            measure(MeasureKind::Statistic {
                statistic,
                signal: "s".into(),
                from,
                to,
            })
            .evaluate(&t, &|_: &str| -> &[f64] { &s })
            .expect("a window")
        };
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() < tol;
        // Over one period: mean 0, RMS 1/√2, peak to peak 2 (samples hit ±1 at n = 3000). The
        // RMS is that of the samples' linear interpolant: its mean square over a period is
        // (2 + cos δ)/6 for samples δ = 2π/3000 apart, 1/2 − δ²/12 (1.8e-7 of 1/√2 below).
        assert!(close(stat(Statistic::Avg, None, None), 0.0, 1e-12));
        let delta = std::f64::consts::TAU / 3000.0;
        assert!(close(
            stat(Statistic::Rms, None, None),
            ((2.0 + delta.cos()) / 6.0).sqrt(),
            1e-12
        ));
        assert!(close(stat(Statistic::Pp, None, None), 2.0, 1e-12));
        assert!(close(stat(Statistic::MaxAt, None, None), 0.25, 1e-12));
        // ∫ sin(2πt) over [0, 1/2 + 1e-4] = (1 − cos(π + 2π·1e-4))/(2π), a window end between
        // samples; the trapezoid rule is off by h²/12·(y'(b) − y'(a)) ≈ 4π/(12·3000²) = 1.16e-7.
        let end: f64 = 0.5 + 1e-4;
        let exact = (1.0 - (std::f64::consts::TAU * end).cos()) / std::f64::consts::TAU;
        let half = stat(Statistic::Integ, Some(0.0), Some(end));
        assert!(close(half, exact, 1.3e-7), "{half} against {exact}");
        assert!(close(
            stat(Statistic::Min, Some(0.6), Some(0.7)),
            (std::f64::consts::TAU * 0.7).sin(),
            1e-12
        ));
    }
}
