//! Truncation-error control on the fixed output grid, as SPICE does it (`CKTterr`): after a
//! substep, the local error of every energy-storing state component is estimated from its
//! third divided difference over the last four accepted points; a substep whose estimate exceeds
//! the tolerance is taken again as `2^m` equal pieces, which end on the same grid point.
//!
//! The components judged are the ones SPICE judges: a capacitor's charge (a position with a
//! potential, `∂²L/∂q² ≠ 0` on its diagonal) and an inductor's flux or a junction's charge (a
//! momentum with a mass, `∂²L/∂v² ≠ 0`). Branch charges of resistors and sources, which store no
//! energy, are not judged: their offsets are arbitrary.

use dirac_core::{ConstraintKind, Constraints, Model};
use dirac_solve::Triplets;

use crate::derivatives::Derivatives;
use crate::sharing::Sharing;

/// Tolerances of the truncation-error test, with SPICE's names and defaults (ngspice 39 manual,
/// `.options`): a substep of size `s` passes when, for every judged component `x`,
/// `(0.9 s)² · |x[t₀, t₁, t₂, t₃]| / 12 ≤ TRTOL · tol`, where `x[…]` is the third divided
/// difference over the last four points, `1/12` the trapezoid rule's error constant and
/// `tol = max(ABSTOL + RELTOL·|ẋ|, RELTOL·max(|x|, CHGTOL)/s)` (`ẋ` the larger of the last two
/// chord rates). This is ngspice's test: it takes the step `del = √(TRTOL·tol·12/|x[…]|)` next and
/// rejects the step just taken when `del < 0.9 s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruncationControl {
    /// `RELTOL`: relative tolerance (default 1e-3).
    pub reltol: f64,
    /// `ABSTOL`: absolute tolerance on the rate of a judged component, a current for a charge
    /// (default 1e-12).
    pub abstol: f64,
    /// `CHGTOL`: smallest charge (or flux) the relative tolerance is taken of (default 1e-14).
    pub chgtol: f64,
    /// `TRTOL`: factor by which the divided-difference estimate overstates the error (default 7).
    pub trtol: f64,
    /// Most halvings of a grid step (default 10: substeps down to `h/1024`). A substep at this
    /// depth is accepted whatever its estimate.
    pub max_depth: u32,
}

impl Default for TruncationControl {
    fn default() -> Self {
        Self {
            reltol: 1e-3,
            abstol: 1e-12,
            chgtol: 1e-14,
            trtol: 7.0,
            max_depth: 10,
        }
    }
}

/// Rejections above this many halvings at once are capped (a step `2^12` times too long).
const MOST_HALVINGS: u32 = 12;

/// What the test says of a substep.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Keep it.
    Accept,
    /// Take it again as `2^m` equal pieces (`m ≥ 1`).
    Split(u32),
    /// The estimate passes, within the window after a source corner ([`History::judge`]), by
    /// less than [`DOUBT`] for these judged components (positions in [`History::judged`]'s
    /// order): judge them again by step doubling.
    Doubtful(Vec<usize>),
}

/// The judged components and their last accepted values.
#[derive(Debug, Clone, Default)]
pub(crate) struct History {
    /// Judged positions (capacitor charges).
    positions: Vec<usize>,
    /// Judged momenta (inductor fluxes, junction charges).
    momenta: Vec<usize>,
    /// Judged sums `Σ c·q_j + Σ c·p_i`, one per constraint row of a loop of charges the readout
    /// shares (docs/math.md §7): the charge a node stores in its capacitors and junctions.
    /// Their members are judged only here: the split of that charge between them is a mode the
    /// steps do not see and leave alternating (midpoint) at an amplitude no substep resolves.
    sums: Vec<Vec<(Member, f64)>>,
    /// Up to four accepted points `(t, x)`, oldest first; the last is the current state.
    points: Vec<(f64, Vec<f64>)>,
    /// When the history last restarted at a source corner (−∞ before the first).
    restarted: f64,
}

/// A member of a judged sum: a position or a momentum.
#[derive(Debug, Clone, Copy)]
enum Member {
    Position(usize),
    Momentum(usize),
}

impl History {
    /// The energy-storing components of `model` at `(q, v)`: positions whose diagonal of
    /// `∂²L/∂q²` and momenta whose diagonal of `∂²L/∂v²` is nonzero there; where the readout
    /// shares charge along loops of them, the charge each constraint row of the loop stores.
    pub(crate) fn for_model<M: Model, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Self {
        let Derivatives {
            hessian,
            force: jacobian,
            forms,
        } = Derivatives::at(model, constraints, q, v, t);
        let n = q.len();
        let diagonal = |block: &Triplets| {
            let mut on = vec![false; n];
            for (i, j, value) in block.iter() {
                if i == j && value != 0.0 {
                    on[i] = true;
                }
            }
            (0..n).filter(|&i| on[i]).collect::<Vec<_>>()
        };
        let mut positions = diagonal(&hessian.qq);
        let mut momenta = diagonal(&hessian.vv);
        // A coordinate in a holonomic row is judged by its position: its momentum carries the
        // constraint's impulse, which depends on the substep's size (a body held at height z
        // under gravity has p_z = −(s/2)·m·g after a substep of size s), so a refinement would
        // itself move it and be refined again.
        let mut held = vec![false; n];
        for (a, j, value) in forms.iter() {
            if value != 0.0 && constraints.kind(a) == ConstraintKind::Holonomic {
                held[j] = true;
            }
        }
        for &i in momenta.iter().filter(|&&i| held[i]) {
            if !positions.contains(&i) {
                positions.push(i);
            }
        }
        positions.sort_unstable();
        momenta.retain(|&i| !held[i]);
        let sharing = Sharing::find(n, constraints.count(), &hessian.vv, &jacobian.v, &forms);
        let mut sums = Vec::new();
        if !sharing.coords.is_empty() {
            // The momenta each shift's rate pushes, with the coefficient: a momentum pushed by
            // that shift alone is the member of the sum that moves with it.
            let mut pushes: Vec<Vec<(usize, f64)>> = vec![Vec::new(); sharing.coords.len()];
            let mut pushed = vec![0usize; n];
            for (i, k, value) in sharing.impulses(&jacobian.v) {
                if value != 0.0 {
                    pushed[i] += 1;
                    pushes[k].push((i, value));
                }
            }
            sums = vec![Vec::new(); sharing.rows.len()];
            for (l, k, value) in sharing.flows(&forms) {
                sums[l].push(match pushes[k].as_slice() {
                    &[(i, c)] if pushed[i] == 1 => (Member::Momentum(i), value / c),
                    _ => (Member::Position(sharing.coords[k]), value),
                });
            }
            positions.retain(|&j| sharing.shift(j).is_none());
            momenta.retain(|&i| pushed[i] == 0);
        }
        Self {
            positions,
            momenta,
            sums,
            points: Vec::with_capacity(HISTORY),
            restarted: f64::NEG_INFINITY,
        }
    }

    /// Whether nothing is judged.
    pub(crate) fn is_empty(&self) -> bool {
        self.positions.is_empty() && self.momenta.is_empty() && self.sums.is_empty()
    }

    /// Forgets the past and starts from `(t, q, p)` (at the start and after a source corner,
    /// where the divided differences would span a jump in a derivative). The next two substeps
    /// are judged by step doubling ([`History::judge_halves`]).
    pub(crate) fn restart(&mut self, t: f64, q: &[f64], p: &[f64]) {
        self.points.clear();
        self.restarted = t;
        self.push(t, q, p);
    }

    /// Starts from `(t, q, p)` at the start of a run: as [`History::restart`], but without step
    /// doubling after it (neither the first two substeps nor narrow passes in the window of
    /// [`History::judge`]). The start is a consistent state or one the start ramp takes care
    /// of, and doubling there misjudged two things: the modes the midpoint rule leaves
    /// alternating (a bridge rectifier's floating source nodes then read the alternating
    /// common mode, −59 V for 5.8), and a momentum that carries half its last substep's
    /// constraint impulse, which differs between one substep and two halves at every size (a
    /// winding's flux from rest under a source rising as `c t`: `c s²/4` against `5 c s²/16`), so
    /// the first step of a transformer rectifier was bisected to the floor and its first row
    /// read `v(s)` 6 % off.
    pub(crate) fn start(&mut self, t: f64, q: &[f64], p: &[f64]) {
        self.points.clear();
        self.restarted = f64::NEG_INFINITY;
        self.push(t, q, p);
    }

    /// Records the accepted state `(t, q, p)`.
    pub(crate) fn push(&mut self, t: f64, q: &[f64], p: &[f64]) {
        let mut x = if self.points.len() == HISTORY {
            self.points.remove(0).1
        } else {
            Vec::with_capacity(self.positions.len() + self.momenta.len())
        };
        x.clear();
        x.extend(self.judged(q, p));
        self.points.push((t, x));
    }

    /// The judged components of `(q, p)`: positions, momenta, then sums.
    fn judged<'a>(&'a self, q: &'a [f64], p: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
        self.positions
            .iter()
            .map(|&i| q[i])
            .chain(self.momenta.iter().map(|&i| p[i]))
            .chain(self.sums.iter().map(|sum| {
                sum.iter()
                    .map(|&(member, c)| match member {
                        Member::Position(j) => c * q[j],
                        Member::Momentum(i) => c * p[i],
                    })
                    .sum()
            }))
    }

    /// Whether the history is too short for the third-difference test after a source corner:
    /// the first two substeps after it, which [`History::judge_halves`] judges instead. After
    /// the start they stay unjudged (see [`History::start`]).
    pub(crate) fn is_short(&self) -> bool {
        self.points.len() < 3 && self.restarted.is_finite()
    }

    /// Judges a substep of a short history ([`History::is_short`]) by step doubling: taken whole
    /// it ended at `whole`, taken again as two halves at `halves` (both `(q, p)` at `t`). The
    /// whole substep's local error is about `2^p/(2^p − 1)` times the difference of the two
    /// ends; with the midpoint rule's `p = 2` (`4/3`, which overstates higher orders' error by
    /// at most a third) it passes where the third-difference test would: `(0.9 s)²`-scaled error
    /// per unit time within `TRTOL · tol`, `tol` as in [`TruncationControl`] with the chord rate.
    /// Without it the first two substeps after a corner were not judged at all: a diode turning
    /// off inside one (its junction's time constant falling from 99 ns to 1 ns within a 50 ns
    /// step) left its charge overshooting and the row read `v(a)` = −1082 V for −5 V (audit 52).
    /// A failed test splits the substep in two, whose first half is judged the same way again:
    /// the event is bisected, not the whole substep cut to the smallest piece.
    pub(crate) fn judge_halves(
        &self,
        rule: &TruncationControl,
        t: f64,
        whole: (&[f64], &[f64]),
        halves: (&[f64], &[f64]),
        only: Option<&[usize]>,
    ) -> Verdict {
        let Some((t0, x0)) = self.points.last() else {
            return Verdict::Accept;
        };
        let s = t - t0;
        if s <= 0.0 {
            return Verdict::Accept;
        }
        let judged = self
            .judged(whole.0, whole.1)
            .zip(self.judged(halves.0, halves.1))
            .zip(x0)
            .enumerate()
            .filter(|(j, _)| only.is_none_or(|only| only.binary_search(j).is_ok()));
        for (_, ((x, y), &start)) in judged {
            let error = DOUBLING_ERROR * (x - y).abs();
            let rate = ((x - start) / s).abs().max(((y - start) / s).abs());
            let size = x.abs().max(start.abs()).max(rule.chgtol);
            let tol = (rule.abstol + rule.reltol * rate).max(rule.reltol * size / s);
            // A NaN estimate (never from converged substeps) is no reason to refine.
            if 0.81 * error > rule.trtol * tol * s {
                return Verdict::Split(1);
            }
        }
        Verdict::Accept
    }

    /// Judges the substep that ended at `(t, q, p)` after the last recorded point; within
    /// `window` after the last restart, a narrow pass is [`Verdict::Doubtful`].
    pub(crate) fn judge(
        &self,
        rule: &TruncationControl,
        t: f64,
        (q, p): (&[f64], &[f64]),
        window: f64,
    ) -> Verdict {
        let past = self.points.len();
        if past < 3 {
            return Verdict::Accept;
        }
        let (t2, x2) = &self.points[past - 1];
        let s = t - t2;
        if s <= 0.0 {
            return Verdict::Accept;
        }
        // The smallest step any component allows, as ngspice computes it. Shortly after a
        // source corner (within `window`) the components it passes narrowly are judged
        // again by doubling: there a source has just changed its slope, the divided differences
        // span few points, and an event it sets off inside a substep (a diode turning off
        // 50 ns after its source falls) can leave a charge that continues its trend smoothly
        // but overshoots the junction's knee. Everywhere, doubling would also see the modes the
        // method leaves alternating, flipped once by the whole substep and twice by the halves,
        // and split substeps for them: on a bridge rectifier's floating source nodes the refined
        // steps then read the alternating common mode (−18.8 V for 1.52).
        let young = t - self.restarted <= window;
        let mut allowed = f64::INFINITY;
        let mut doubtful = Vec::new();
        for (j, x) in self.judged(q, p).enumerate() {
            let (third, rate) = self.third_difference(j, t, x);
            let size = x.abs().max(x2[j].abs()).max(rule.chgtol);
            let tol = (rule.abstol + rule.reltol * rate).max(rule.reltol * size / s);
            let del = (rule.trtol * tol / (third.abs() / 12.0).max(rule.abstol)).sqrt();
            // A NaN estimate (never from a converged step) is no reason to refine.
            if del < allowed {
                allowed = del;
            }
            if young && del < DOUBT * 0.9 * s {
                doubtful.push(j);
            }
        }
        if allowed < 0.9 * s {
            let halvings = (s / allowed).log2().ceil().max(1.0);
            Verdict::Split((halvings as u32).min(MOST_HALVINGS))
        } else if !doubtful.is_empty() {
            Verdict::Doubtful(doubtful)
        } else {
            Verdict::Accept
        }
    }

    /// Component `j`'s third divided difference at the new point `(t, x)` and the larger of its
    /// last two chord rates. With four past points it is the mean of the last two third
    /// differences: a mode the method leaves alternating every substep (the midpoint rule on a
    /// junction's charge, τ a millionth of the step) adds `±8a/(6s³)` to each, which the mean
    /// cancels on equal substeps, while a smooth charge's `x‴/6` stays. Judged alone, that mode
    /// grew the estimate as the step was halved (`a/(9s)`: refinement cannot resolve a mode of
    /// picoseconds), so every step of a bridge rectifier with `CJO` was split to `h/1024`. Where
    /// the two have one sign and the last is the larger, no mode alternates and an event begins
    /// in the newest substep: the last is taken whole, where the mean halved it and let the step
    /// through (a CMOS node falling 2.2 V within one step, 23 % of its swing off ngspice's; a peak
    /// detector's charging surge, its source current 115 % off). The mean still halves the
    /// estimate on the first step across a kink whose third differences alternate; keeping the
    /// full one where the two alternate only roughly split the bridge's steps more, not less
    /// (6.1 M substeps for 10⁴ steps), and so did taking the mean only where the last three
    /// second differences alternate (6.9 M), both measured while charges were judged member by
    /// member (audit item 42).
    fn third_difference(&self, j: usize, t: f64, x: f64) -> (f64, f64) {
        // Point `i` of the past points followed by the new one.
        let n = self.points.len() + 1;
        let at = |i: usize| match self.points.get(i) {
            Some((tp, xp)) => (*tp, xp[j]),
            None => (t, x),
        };
        // The third divided difference over points `i … i + 3` and the larger of the last two
        // chord rates there.
        let third = |i: usize| {
            let w = [at(i), at(i + 1), at(i + 2), at(i + 3)];
            let d = |a: (f64, f64), b: (f64, f64)| (b.1 - a.1) / (b.0 - a.0);
            let (d01, d12, d23) = (d(w[0], w[1]), d(w[1], w[2]), d(w[2], w[3]));
            let d012 = (d12 - d01) / (w[2].0 - w[0].0);
            let d123 = (d23 - d12) / (w[3].0 - w[1].0);
            ((d123 - d012) / (w[3].0 - w[0].0), d23.abs().max(d12.abs()))
        };
        let (last, rate) = third(n - 4);
        if n == HISTORY + 1 {
            let before = third(0).0;
            // One sign, the last the larger: an event begins in the newest substep, which the
            // mean would halve.
            if last * before >= 0.0 && last.abs() > before.abs() {
                (last, rate)
            } else {
                (0.5 * (last + before), rate)
            }
        } else {
            (last, rate)
        }
    }
}

/// The whole substep's local error per unit difference of its end from two halves' end under
/// step doubling, for a method of order 2: `2²/(2² − 1)`.
const DOUBLING_ERROR: f64 = 4.0 / 3.0;

/// Factor on the allowed step below which a passing third-difference estimate is checked by
/// step doubling.
const DOUBT: f64 = 4.0;

/// Accepted points a history keeps: the test needs three before the new one, and a fourth for
/// the mean of two third differences.
const HISTORY: usize = 4;

#[cfg(test)]
mod tests {
    use super::*;

    /// A history of one component `x(t)` at `ts`, judged at the last time.
    fn judged(x: impl Fn(f64) -> f64, ts: &[f64], rule: &TruncationControl) -> Verdict {
        let mut h = History {
            positions: vec![0],
            ..History::default()
        };
        let (last, past) = ts.split_last().unwrap();
        for &t in past {
            h.push(t, &[x(t)], &[]);
        }
        h.judge(rule, *last, (&[x(*last)], &[]), f64::INFINITY)
    }

    #[test]
    fn a_quadratic_charge_is_never_refined() {
        // The third divided difference of a quadratic is zero: no error to control, whatever
        // the spacing.
        let rule = TruncationControl::default();
        let v = judged(
            |t| 3.0 * t * t - t + 1e-3,
            &[0.0, 1e-3, 1.5e-3, 5e-3],
            &rule,
        );
        assert_eq!(v, Verdict::Accept);
    }

    #[test]
    fn the_split_is_what_ngspice_would_step_next() {
        // x = a t³ at t = −3s, −2s, −s, 0: x[t₀..t₃] = a, the chord rates are 7a s² and a s², and
        // |x| ≤ a s³, so tol = ABSTOL + RELTOL·7a s² (the charge term RELTOL·a s² is smaller) and
        // ngspice's next step is del = √(TRTOL·12·tol/a) = s·√(84·7·RELTOL) once ABSTOL is
        // negligible (a = 1e6, s = 1e-3: 7e-3 against 1e-12).
        let (a, s) = (1e6, 1e-3);
        let ts = [-3.0 * s, -2.0 * s, -s, 0.0];
        let x = |t: f64| a * t * t * t;
        for (reltol, expected) in [
            // del = 0.767 s < 0.9 s: one halving.
            (1e-3, Verdict::Split(1)),
            // del = 0.242 s: s/del = 4.1, so 2^3 pieces.
            (1e-4, Verdict::Split(3)),
            // del = 2.42 s: kept by ngspice's rule, but within the factor DOUBT = 4 of 0.9 s, so
            // judged again by step doubling.
            (1e-2, Verdict::Doubtful(vec![0])),
        ] {
            let rule = TruncationControl {
                reltol,
                ..TruncationControl::default()
            };
            assert_eq!(judged(x, &ts, &rule), expected, "reltol {reltol}");
        }
    }

    /// A history of one component holding `(t, x)` points only.
    fn one_component(points: &[(f64, f64)]) -> History {
        let mut h = History {
            positions: vec![0],
            ..History::default()
        };
        for &(t, x) in points {
            h.push(t, &[x], &[]);
        }
        h
    }

    #[test]
    fn doubling_splits_where_two_halves_end_apart_beyond_the_tolerance() {
        // From x = 1e-9 C at t = 0, a substep of s = 1e-8 ending at 0.9e-9 (chord rate 0.01 A):
        // tol = max(ABSTOL + RELTOL·0.01, RELTOL·1e-9/s) = 1e-4 A, so the halves may end up to
        // TRTOL·tol·s/(0.81·4/3) = 6.48e-12 C from the whole substep.
        let rule = TruncationControl::default();
        let h = one_component(&[(0.0, 1e-9)]);
        assert!(h.is_short());
        let s = 1e-8;
        let judge =
            |halves: f64| h.judge_halves(&rule, s, (&[0.9e-9], &[]), (&[halves], &[]), None);
        assert_eq!(judge(0.9e-9 + 6.4e-12), Verdict::Accept);
        assert_eq!(judge(0.9e-9 - 6.6e-12), Verdict::Split(1));
        // A diode's charge overshooting its knee: the whole substep ends 0.6 nC past the halves.
        assert_eq!(judge(-0.6e-9), Verdict::Split(1));
        // A NaN (never from converged substeps) is no reason to refine.
        assert_eq!(judge(f64::NAN), Verdict::Accept);
    }

    #[test]
    fn a_narrow_pass_is_doubtful_and_a_wide_one_is_kept() {
        // As in `the_split_is_what_ngspice_would_step_next`: x = a t³ on substeps s, for which
        // ngspice's next step is s·√(84·7·RELTOL). RELTOL = 2e-3: 1.08 s, a pass by less than
        // the factor DOUBT = 4 (on 0.9 s), judged again by doubling; RELTOL = 0.05: 5.4 s, kept.
        let (a, s) = (1e6, 1e-3);
        let ts = [-3.0 * s, -2.0 * s, -s, 0.0];
        let x = |t: f64| a * t * t * t;
        for (reltol, expected) in [(2e-3, Verdict::Doubtful(vec![0])), (0.05, Verdict::Accept)] {
            let rule = TruncationControl {
                reltol,
                ..TruncationControl::default()
            };
            assert_eq!(judged(x, &ts, &rule), expected, "reltol {reltol}");
        }
        // Outside the window after the last restart the same narrow pass is kept.
        let mut h = History {
            positions: vec![0],
            ..History::default()
        };
        h.restart(-4.0 * s, &[x(-4.0 * s)], &[]);
        for &t in &ts[..3] {
            h.push(t, &[x(t)], &[]);
        }
        let rule = TruncationControl {
            reltol: 2e-3,
            ..TruncationControl::default()
        };
        let judge = |window: f64| h.judge(&rule, 0.0, (&[0.0], &[]), window);
        assert_eq!(judge(4.0 * s), Verdict::Doubtful(vec![0]));
        assert_eq!(judge(3.9 * s), Verdict::Accept);
        // With two points or fewer the history is short: doubling judges the substep.
        assert!(one_component(&[(0.0, 0.0), (s, 1.0)]).is_short());
        assert!(!one_component(&[(0.0, 0.0), (s, 1.0), (2.0 * s, 2.0)]).is_short());
    }

    /// `V — R — a`, a reverse-biased diode with `CJO` and a capacitor from `a` to ground: the
    /// loop of the junction's charge (a momentum) and the capacitor's (a position) is judged as
    /// node `a`'s stored charge `q_C − p_φ`, not member by member. A split of that charge between
    /// them (`q_C + δ`, `q_D + δ`, `p_φ + δ`: charge moved from the junction to the capacitor) is
    /// accepted however it moves; the same motion of the capacitor alone, which is charge on the
    /// node, is refined. Judged member by member, as before the sums, the
    /// split was refined too (to `h/1024` on every step of a CMOS XOR gate: 1.9 M substeps for
    /// 3200 steps).
    #[test]
    fn the_split_of_a_loop_of_charges_is_not_judged() {
        use dirac_components::{
            Capacitor, Diode, DiodeParameters, Resistor, VoltageSource, Waveform,
        };
        use dirac_graph::{Assembler, Interconnection, Representation};
        let card = DiodeParameters {
            cjo: 20e-15,
            m: 0.45,
            vj: 0.8,
            ..DiodeParameters::new(1e-14, 1.0)
        };
        let diode = Diode::at_temperature(&card, 27.0).expect("card").diode;
        let mut g = Interconnection::new();
        let source = VoltageSource::new(Waveform::Dc(3.0)).expect("source");
        g.add_subsystem(source.subsystem("V1")).expect("V1");
        let resistor = Resistor::new(1e4).expect("resistance");
        g.add_subsystem(resistor.subsystem("R1")).expect("R1");
        g.add_subsystem(diode.subsystem("D1")).expect("D1");
        let capacitor = Capacitor::new(1e-15).expect("capacitance");
        g.add_subsystem(capacitor.subsystem("C1")).expect("C1");
        let port = |g: &Interconnection, part: &str| g.port(part, "i").expect("port");
        let input = vec![(port(&g, "V1"), -1.0), (port(&g, "R1"), -1.0)];
        let node = vec![
            (port(&g, "R1"), 1.0),
            (port(&g, "D1"), 1.0),
            (port(&g, "C1"), -1.0),
        ];
        g.node("in", input).expect("in");
        g.node("a", node).expect("a");
        let system = Assembler::assemble(&g, Representation::Monolithic).expect("assembles");
        let model = &system.model;
        let n = model.dim();
        let index = |name: &str| (0..n).find(|&i| model.coordinate_name(i) == name);
        let (qc, qd, phi) = (
            index("C1.q").expect("C1.q"),
            index("D1.q").expect("D1.q"),
            index("D1.phi").expect("D1.phi"),
        );
        let zero = vec![0.0; n];
        let fresh = || History::for_model(model, &system.constraints, &zero, &zero, 0.0);
        let history = fresh();
        assert!(!history.positions.contains(&qc) && !history.momenta.contains(&phi));
        assert_eq!(history.sums.len(), 1, "one node stores charge");
        let rule = TruncationControl::default();
        // A node charging slowly (3 V over 1 µs into 21 fF) on equal substeps `s`, plus a cubic
        // `a (t − 4s)³` either along the split or on the capacitor alone: on one component the
        // cubic is refined (ngspice's next step would be 0.77 s, as in
        // `the_split_is_what_ngspice_would_step_next`).
        let s = 1e-10;
        let ts = [0.0, s, 2.0 * s, 3.0 * s, 4.0 * s];
        let state = |t: f64, split: f64, alone: f64| {
            let v = 3.0 * t / 1e-6;
            let cubic = (t - 4.0 * s).powi(3);
            let mut q = zero.clone();
            let mut p = zero.clone();
            q[qc] = 1e-15 * v + (split + alone) * cubic;
            q[qd] = 20e-15 * v + split * cubic;
            p[phi] = -20e-15 * v + split * cubic;
            (q, p)
        };
        let verdict = |split: f64, alone: f64| {
            let mut h = fresh();
            let (last, past) = ts.split_last().expect("points");
            for &t in past {
                let (q, p) = state(t, split, alone);
                h.push(t, &q, &p);
            }
            let (q, p) = state(*last, split, alone);
            h.judge(&rule, *last, (&q, &p), 0.0)
        };
        assert_eq!(verdict(0.0, 0.0), Verdict::Accept, "the smooth charge");
        assert_eq!(verdict(1e17, 0.0), Verdict::Accept, "the split");
        assert_eq!(
            verdict(0.0, 1e17),
            Verdict::Split(1),
            "the same motion of the capacitor alone"
        );
    }

    #[test]
    fn fewer_than_three_past_points_are_not_judged() {
        let rule = TruncationControl::default();
        let v = judged(|t| 1e9 * t.powi(5), &[0.0, 1.0, 2.0], &rule);
        assert_eq!(v, Verdict::Accept);
    }

    #[test]
    fn a_kink_is_refined_down_to_its_scale() {
        // A charge whose current switches on at t = 2.5 ms (a diode starting to conduct into a
        // capacitor): the step across the kink is refined.
        let rule = TruncationControl::default();
        let x = |t: f64| 1e-4 * (t - 2.5e-3).max(0.0).powi(2) / 1e-6 + 1e-9;
        let v = judged(x, &[0.0, 1e-3, 2e-3, 3e-3], &rule);
        assert!(matches!(v, Verdict::Split(m) if m >= 1), "{v:?}");
    }

    #[test]
    fn an_event_in_the_newest_substep_is_judged_whole() {
        // A charge at rest whose current switches on to 1 mA within the last substep (a node
        // discharging through a transistor turned on): the two third differences have one
        // sign and the last is the larger. Their mean lets the substep through; the last alone
        // asks for a split.
        let rule = TruncationControl::default();
        let s = 1e-10;
        let x = |t: f64| 1e-14 - 1e-3 * (t - 3.5 * s).max(0.0);
        let five = [0.0, s, 2.0 * s, 3.0 * s, 4.0 * s];
        assert!(matches!(judged(x, &five, &rule), Verdict::Split(_)));
    }

    #[test]
    fn an_alternating_mode_on_a_smooth_charge_is_not_refined() {
        // A quadratic charge (no truncation error) carrying a mode that flips sign every step,
        // as the midpoint rule leaves a junction's charge: the mean of the last two third
        // differences cancels it; the last one alone (four points) asks for a split.
        let rule = TruncationControl::default();
        let x = |t: f64| {
            let k = (t / 1e-3).round() as i32;
            1e-6 * t * t + 1e-9 * if k % 2 == 0 { 1.0 } else { -1.0 }
        };
        let five = [0.0, 1e-3, 2e-3, 3e-3, 4e-3];
        assert_eq!(judged(x, &five, &rule), Verdict::Accept);
        assert!(matches!(judged(x, &five[1..], &rule), Verdict::Split(_)));
    }
}
