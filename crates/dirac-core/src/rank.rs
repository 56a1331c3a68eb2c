//! Detection of linearly dependent constraint rows, and a view that drops them.

use std::cell::RefCell;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use dirac_solve::Triplets;

use crate::constraints::{ConstraintKind, Constraints};

/// Result of [`analyse_rows`]: which rows of a constraint matrix are empty or dependent.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RowAnalysis {
    /// Rows with no nonzero entry (a modelling error, not a redundancy).
    pub empty: Vec<usize>,
    /// Rows that are linear combinations of earlier rows (redundant if consistent).
    pub dependent: Vec<usize>,
}

/// Finds empty and linearly dependent rows of the `m × n` matrix stamped in `entries`.
///
/// Sparse incremental Gaussian elimination: each row is reduced against the rows kept before it,
/// in the order they were kept (a kept row has zeros in the pivot columns of earlier kept rows, so
/// a min-heap on insertion order eliminates each pivot once). A row whose reduced max-norm falls
/// below `tol` times its original max-norm is dependent. Incidence-like matrices (KCL, joints)
/// cause little fill, so this stays near-linear for circuits of 10⁵ nodes.
#[must_use]
pub fn analyse_rows(m: usize, n: usize, entries: &Triplets, tol: f64) -> RowAnalysis {
    let mut rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); m];
    for (a, j, v) in entries.iter() {
        if v != 0.0 {
            rows[a].push((j, v));
        }
    }
    let mut work = vec![0.0; n];
    let mut touched: Vec<usize> = Vec::new();
    let mut is_touched = vec![false; n];
    let mut pivot_of: Vec<Option<usize>> = vec![None; n];
    let mut basis: Vec<(usize, Vec<(usize, f64)>)> = Vec::new();
    let mut result = RowAnalysis::default();
    for (a, row) in rows.iter().enumerate() {
        if row.is_empty() {
            result.empty.push(a);
            continue;
        }
        let scale = row.iter().fold(0.0_f64, |s, (_, v)| s.max(v.abs()));
        let mut heap = BinaryHeap::new();
        for &(j, v) in row {
            if !is_touched[j] {
                is_touched[j] = true;
                touched.push(j);
            }
            work[j] += v;
            if let Some(b) = pivot_of[j] {
                heap.push(Reverse(b));
            }
        }
        while let Some(Reverse(b)) = heap.pop() {
            let (p, ref brow) = basis[b];
            let w = work[p];
            if w == 0.0 {
                continue;
            }
            let pv = brow.iter().find(|(j, _)| *j == p).map_or(1.0, |(_, v)| *v);
            let factor = w / pv;
            for &(j, v) in brow {
                if !is_touched[j] {
                    is_touched[j] = true;
                    touched.push(j);
                }
                work[j] -= factor * v;
                if let Some(c) = pivot_of[j]
                    && c > b
                {
                    heap.push(Reverse(c));
                }
            }
            work[p] = 0.0;
        }
        let (mut best, mut at) = (0.0_f64, usize::MAX);
        for &j in &touched {
            if work[j].abs() > best {
                best = work[j].abs();
                at = j;
            }
        }
        if best <= tol * scale || at == usize::MAX {
            result.dependent.push(a);
        } else {
            let kept: Vec<(usize, f64)> = touched
                .iter()
                .filter(|&&j| work[j].abs() > f64::EPSILON * scale)
                .map(|&j| (j, work[j]))
                .collect();
            pivot_of[at] = Some(basis.len());
            basis.push((at, kept));
        }
        for &j in &touched {
            work[j] = 0.0;
            is_touched[j] = false;
        }
        touched.clear();
    }
    result
}

/// A constraint set with some rows dropped (redundant rows found by [`analyse_rows`]).
#[derive(Debug)]
pub struct RowSubset<C> {
    inner: C,
    kept: Vec<usize>,
    new_index: Vec<Option<usize>>,
    /// The full set's forms and contracted derivatives, stamped before the dropped rows are
    /// taken out: one storage each, since a [`Triplets`] keeps the pattern of its first stamp.
    scratch_forms: RefCell<Triplets>,
    scratch_contracted: RefCell<Triplets>,
    scratch_values: RefCell<Vec<f64>>,
    scratch_lambda: RefCell<Vec<f64>>,
}

impl<C: Constraints> RowSubset<C> {
    /// Keeps every row of `inner` except those in `dropped`.
    pub fn new(inner: C, dropped: &[usize]) -> Self {
        let m = inner.count();
        let mut subset = Self {
            inner,
            kept: Vec::new(),
            new_index: Vec::new(),
            scratch_forms: RefCell::new(Triplets::new()),
            scratch_contracted: RefCell::new(Triplets::new()),
            scratch_values: RefCell::new(vec![0.0; m]),
            scratch_lambda: RefCell::new(vec![0.0; m]),
        };
        subset.set_dropped(dropped);
        subset
    }

    /// Keeps every row of the full set except those in `dropped` (indices of the full set).
    pub fn set_dropped(&mut self, dropped: &[usize]) {
        let m = self.inner.count();
        self.new_index = vec![None; m];
        self.kept.clear();
        for (a, slot) in self.new_index.iter_mut().enumerate() {
            if !dropped.contains(&a) {
                *slot = Some(self.kept.len());
                self.kept.push(a);
            }
        }
        self.scratch_forms = RefCell::new(Triplets::new());
        self.scratch_contracted = RefCell::new(Triplets::new());
    }

    /// The full constraint set.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// Indices (in the full set) of the rows kept.
    pub fn kept(&self) -> &[usize] {
        &self.kept
    }

    /// Whether every row is kept (then calls pass straight through).
    fn keeps_all(&self) -> bool {
        self.kept.len() == self.new_index.len()
    }

    /// Stamps the full set's rows with `f` into `scratch`, then the kept ones into `out` under
    /// their new indices.
    fn stamp_rows(
        &self,
        scratch: &RefCell<Triplets>,
        out: &mut Triplets,
        f: impl FnOnce(&mut Triplets),
    ) {
        if self.keeps_all() {
            f(out);
            return;
        }
        let mut scratch = scratch.borrow_mut();
        scratch.begin();
        f(&mut scratch);
        if !scratch.is_frozen() {
            scratch.freeze();
        }
        for (a, j, v) in scratch.iter() {
            if let Some(b) = self.new_index[a] {
                out.add(b, j, v);
            }
        }
    }
}

impl<C: Constraints> Constraints for RowSubset<C> {
    fn count(&self) -> usize {
        self.kept.len()
    }
    fn kind(&self, a: usize) -> ConstraintKind {
        self.inner.kind(self.kept[a])
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        self.stamp_rows(&self.scratch_forms, out, |t| self.inner.forms(q, t));
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        if self.keeps_all() {
            self.inner.values(q, out);
            return;
        }
        let mut all = self.scratch_values.borrow_mut();
        self.inner.values(q, &mut all);
        for (b, &a) in self.kept.iter().enumerate() {
            out[b] = all[a];
        }
    }
    fn is_constant(&self) -> bool {
        self.inner.is_constant()
    }
    fn multiplier_hessian(&self, q: &[f64], lambda: &[f64], out: &mut Triplets) {
        if self.keeps_all() {
            self.inner.multiplier_hessian(q, lambda, out);
            return;
        }
        let mut full = self.scratch_lambda.borrow_mut();
        full.fill(0.0);
        for (b, &a) in self.kept.iter().enumerate() {
            full[a] = lambda[b];
        }
        self.inner.multiplier_hessian(q, &full, out);
    }
    fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
        self.stamp_rows(&self.scratch_contracted, out, |t| {
            self.inner.contracted_derivative(q, w, t);
        });
    }
    fn name(&self, a: usize) -> String {
        self.inner.name(self.kept[a])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamp(rows: &[&[(usize, f64)]]) -> Triplets {
        let mut t = Triplets::new();
        t.begin();
        for (a, r) in rows.iter().enumerate() {
            for &(j, v) in *r {
                t.add(a, j, v);
            }
        }
        t
    }

    /// One-form rows on two coordinates: row 0 `A = (1, 1)` (a KCL row: constant), row 1 the
    /// same (redundant), row 2 `A = (0, q₀ q₁)`, whose derivative has another pattern.
    struct Curved;
    impl Constraints for Curved {
        fn count(&self) -> usize {
            3
        }
        fn kind(&self, _a: usize) -> ConstraintKind {
            ConstraintKind::OneForm
        }
        fn forms(&self, q: &[f64], out: &mut Triplets) {
            for a in 0..2 {
                out.add(a, 0, 1.0);
                out.add(a, 1, 1.0);
            }
            out.add(2, 1, q[0] * q[1]);
        }
        fn is_constant(&self) -> bool {
            false
        }
        fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
            out.add(2, 0, w[1] * q[1]);
            out.add(2, 1, w[1] * q[0]);
        }
    }

    fn entries(t: &Triplets) -> Vec<(usize, usize, f64)> {
        t.iter().collect()
    }

    /// A subset with a dropped row stamps the forms and the contracted derivative of the rows it
    /// keeps, whichever it is asked for first. Both went through one scratch storage, whose
    /// pattern the first stamp fixes: the contracted derivative after the forms came back as the
    /// forms' entries with their values (a KCL row's `±1` read as `∂(A v)/∂q` on a motor's
    /// charges), which put the motor arm's drive torque at t_k off by up to 0.06 N·m.
    #[test]
    fn a_subset_stamps_forms_and_their_derivative_apart() {
        let subset = RowSubset::new(Curved, &[1]);
        let (q, w) = ([2.0, 3.0], [5.0, 7.0]);
        for forms_first in [true, false] {
            let subset = RowSubset::new(Curved, &[1]);
            let (mut forms, mut contracted) = (Triplets::new(), Triplets::new());
            for round in 0..2 {
                forms.begin();
                contracted.begin();
                if forms_first {
                    subset.forms(&q, &mut forms);
                    subset.contracted_derivative(&q, &w, &mut contracted);
                } else {
                    subset.contracted_derivative(&q, &w, &mut contracted);
                    subset.forms(&q, &mut forms);
                }
                assert_eq!(
                    entries(&forms),
                    vec![(0, 0, 1.0), (0, 1, 1.0), (1, 1, 6.0)],
                    "round {round}"
                );
                assert_eq!(
                    entries(&contracted),
                    vec![(1, 0, 21.0), (1, 1, 14.0)],
                    "round {round}"
                );
            }
        }
        assert_eq!(subset.count(), 2);
    }

    /// KCL written at every node of a triangle of branches (including ground) has one
    /// redundant row: the sum of all node equations is zero.
    #[test]
    fn kcl_at_every_node_has_one_dependent_row() {
        // Branch currents i0: n0→n1, i1: n1→n2, i2: n2→n0.
        let t = stamp(&[
            &[(0, -1.0), (2, 1.0)],
            &[(0, 1.0), (1, -1.0)],
            &[(1, 1.0), (2, -1.0)],
        ]);
        let r = analyse_rows(3, 3, &t, 1e-10);
        assert_eq!(r.dependent, vec![2]);
        assert!(r.empty.is_empty());
    }

    #[test]
    fn independent_rows_are_kept_and_empty_rows_reported() {
        let t = stamp(&[
            &[(0, 1.0), (1, 2.0)],
            &[],
            &[(1, 3.0), (2, 1.0)],
            &[(0, 1.0), (2, 1.0)],
        ]);
        let r = analyse_rows(4, 3, &t, 1e-10);
        assert_eq!(r.empty, vec![1]);
        assert!(r.dependent.is_empty());
        // Row 3 = row 0 − (2/3)·row 2 + ... : make a genuinely dependent one.
        let t = stamp(&[
            &[(0, 1.0), (1, 2.0)],
            &[(1, 3.0), (2, 1.0)],
            &[(0, 2.0), (1, 7.0), (2, 1.0)],
        ]);
        let r = analyse_rows(3, 3, &t, 1e-10);
        assert_eq!(r.dependent, vec![2]);
    }

    /// A long chain where each row is needed: elimination must not report false dependencies.
    #[test]
    fn long_chain_is_full_rank() {
        let n = 2000;
        let mut t = Triplets::new();
        t.begin();
        for a in 0..n - 1 {
            t.add(a, a, 1.0);
            t.add(a, a + 1, -1.0);
        }
        let r = analyse_rows(n - 1, n, &t, 1e-10);
        assert!(r.dependent.is_empty() && r.empty.is_empty());
    }
}
