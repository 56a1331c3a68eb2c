//! Sparse LU (left-looking, threshold partial pivoting, fill-reducing column orders from faer)
//! for large step systems.

use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};

use crate::error::LinearSolveError;
use crate::newton::{LinearSolver, max_norm};
use crate::ordering::{colamd_order, split_order, symmetric_order};
use crate::pivoting::{self, Workspace};
use crate::triplets::PatternMismatch;

/// Sparse LU factorisation, allocation-free in the Newton loop.
///
/// Large step systems (long chains, KKT matrices `[[J, Aᵀ], [A, 0]]` with a structurally zero
/// block) are far too big for [`DenseLu`](crate::DenseLu), whose `O(n³)` factorisation costs
/// seconds where this one costs about 100 ns per unknown on a banded KKT system. The work is
/// split as the [`LinearSolver`] trait asks:
///
/// * [`analyse`](LinearSolver::analyse) (once per pattern) builds the compressed-column pattern
///   from the triplets and a slot map from every triplet to its entry (duplicates share a slot),
///   checks the structural rank with a maximum matching, computes the COLAMD fill-reducing column
///   order and sizes the workspace of factorisation and solve. On a long thin pattern (a ladder,
///   a chain) of at least `SPLIT_MIN` unknowns it also prepares COLAMD's order cut into two
///   halves whose columns alternate (see the `ordering` module), which lets the processor run the
///   halves' dependency chains side by side.
/// * The first [`factor`](LinearSolver::factor) after `analyse` sizes the `L`/`U` storage and
///   chooses the column order by the fill of the values Newton actually factorises, with their
///   pivots (no factorisation of generic values is spent on the choice): COLAMD's first; where
///   that fills in more than `SYMMETRIC_TRY_FILL` (2) times the matrix, AMD's order for pivots on a
///   maximum matching that keeps the diagonal, kept if it fills in less by more than
///   `SPLIT_MAX_FILL` (KLU's strategy: 5–7× less fill on CMOS netlists, audit item 47); where
///   there is a split order, that, kept if its fill stays within `SPLIT_MAX_FILL` of the order
///   kept so far.
/// * [`factor`](LinearSolver::factor) refills the values through the slot map (summing
///   duplicates) and first refactorises with the pivot order and the `L`/`U` pattern of the last
///   pivoting factorisation (no pivot search, no graph traversal), kept while every pivot passes
///   threshold partial pivoting (`PIVOT_THRESHOLD`, 0.1). Otherwise it pivots again (Gilbert and
///   Peierls' left-looking LU, the `pivoting` module: partial pivoting, or the symmetric order's
///   preferred rows while they pass the threshold), reusing the column order and all storage.
///   Every pivot is then checked: one not above `1e-14` times
///   the largest matrix entry is reported as [`LinearSolveError::NumericallySingular`]. With rows
///   equilibrated to unit max-norm, as [`Newton`](crate::Newton) does, this is exactly
///   [`DenseLu`](crate::DenseLu)'s criterion.
/// * [`solve_in_place`](LinearSolver::solve_in_place) applies the stored factors to one
///   right-hand side, as often as wanted per factorisation, and reports a non-finite result as
///   [`LinearSolveError::NonFinite`].
///
/// faer provides the column orders (COLAMD, AMD); its numeric LUs are not used: the simplicial
/// one pivots on the largest candidate only (no preferred row), the supernodal one allocates
/// work arrays on every call (and on banded KKT systems it was 2.5–3× slower). The `L`/`U`
/// storage only grows; a factorisation after the first allocates only if its pivot sequence
/// creates more fill than any earlier one left room for.
pub struct SparseLu {
    /// Pivots not above this fraction of the largest matrix entry count as zero.
    pivot_tol: f64,
    n: usize,
    triplets: usize,
    analysed: bool,
    factored: bool,
    /// Whether the last factorisation kept the previous pivot order (see [`SparseLu::factor`]).
    reused_pivots: bool,
    /// The split column order's largest fill relative to COLAMD's ([`SPLIT_MAX_FILL`]; tests
    /// lower it to take the rejecting path).
    split_max_fill: f64,
    factors: Option<Factors>,
}

/// Everything sized by `analyse` (absent for a 0×0 system).
#[derive(Clone)]
struct Factors {
    /// The matrix in compressed-column form; its values are refilled by every `factor`.
    matrix: SparseColMat<u32, f64>,
    /// `slots[t]` is the position of triplet `t` in `matrix`'s value array.
    slots: Vec<u32>,
    /// The column order and the factors made with it.
    order: Ordered,
    /// The split column order, tried against COLAMD's (`order`) by the first factorisation.
    split: Option<Vec<u32>>,
    /// Whether the first factorisation is still to try the symmetric order (see
    /// [`Factors::try_symmetric`]).
    symmetric: bool,
    /// Work arrays of the factorisations; its dense column is zero between calls.
    lu: Workspace,
    /// The permuted right-hand side of a solve.
    work: Vec<f64>,
}

/// A column order and what a factorisation with it sets: the row pivots and the factors. One
/// value per order, so that [`SparseLu::analyse`] can keep one aside while it tries another.
#[derive(Clone)]
pub(crate) struct Ordered {
    /// `col_fwd[k]` is the column eliminated at step `k` (COLAMD's, its split into interleaved
    /// halves, or the symmetric order); `col_inv` is its inverse.
    pub(crate) col_fwd: Vec<u32>,
    col_inv: Vec<u32>,
    /// The row pivoted at step `k`, and its inverse.
    pub(crate) row_perm: Vec<u32>,
    pub(crate) row_perm_inv: Vec<u32>,
    /// The row each column's pivot is preferred on (the symmetric order's matching), or `None`
    /// for partial pivoting.
    pub(crate) preferred: Option<Vec<u32>>,
    /// The factors the solves use, in pivot order (see [`Triangular`]).
    pub(crate) own: Triangular,
}

/// A column order and the pivot rows it prefers, if any.
type ColumnOrder = (Vec<u32>, Option<Vec<u32>>);

impl Ordered {
    /// Storage for factors with column order `order` (`order[k]` eliminated at step `k`).
    fn new((order, preferred): ColumnOrder) -> Self {
        let n = order.len();
        let mut col_inv = vec![0; n];
        for (k, &c) in order.iter().enumerate() {
            col_inv[c as usize] = k as u32;
        }
        Self {
            col_fwd: order,
            col_inv,
            row_perm: vec![0; n],
            row_perm_inv: vec![0; n],
            preferred,
            own: Triangular {
                u_inv: Vec::with_capacity(n),
                ..Triangular::default()
            },
        }
    }
}

/// `P A Q = L U` in pivot order: `L` unit lower triangular with its diagonal stored first in each
/// column, `U` upper triangular with its diagonal stored last and the other rows of a column in
/// a topological order of `L`'s dependencies (each row after every row whose column of `L`
/// reaches it: the order a left-looking refactorisation eliminates them in).
#[derive(Clone, Default)]
pub(crate) struct Triangular {
    pub(crate) l_ptr: Vec<u32>,
    pub(crate) l_row: Vec<u32>,
    pub(crate) l_val: Vec<f64>,
    pub(crate) u_ptr: Vec<u32>,
    pub(crate) u_row: Vec<u32>,
    pub(crate) u_val: Vec<f64>,
    /// Reciprocals of `U`'s diagonal, set by [`SparseLu::factor`] once the pivots pass its test:
    /// the back substitution multiplies by them (a division's latency lies on its critical path).
    u_inv: Vec<f64>,
    /// Whether the pattern and pivot order belong to the analysed matrix pattern.
    pub(crate) valid: bool,
}

impl Triangular {
    /// `nnz(L) + nnz(U)`.
    fn fill(&self) -> usize {
        self.l_val.len() + self.u_val.len()
    }

    /// Reserves the storage `other`'s factors take (a factorisation that fills in about as much
    /// then grows none of it).
    fn reserve_like(&mut self, other: &Self) {
        self.l_row.reserve(other.l_row.len());
        self.l_val.reserve(other.l_val.len());
        self.u_row.reserve(other.u_row.len());
        self.u_val.reserve(other.u_val.len());
        self.l_ptr.reserve(other.l_ptr.len());
        self.u_ptr.reserve(other.u_ptr.len());
    }
}

/// A refactorisation keeps the old pivot order while every pivot is at least this fraction of the
/// largest candidate in its column (UMFPACK's default pivot tolerance; partial pivoting is 1). The
/// Newton matrices of a step change little between factorisations, but where two candidates are
/// nearly equal (the ±1 entries of joint rows) strict partial pivoting would swap them back and
/// forth and search again every time.
pub(crate) const PIVOT_THRESHOLD: f64 = 0.1;

impl Default for SparseLu {
    fn default() -> Self {
        Self {
            pivot_tol: Self::PIVOT_TOL,
            n: 0,
            triplets: 0,
            analysed: false,
            factored: false,
            reused_pivots: false,
            split_max_fill: SPLIT_MAX_FILL,
            factors: None,
        }
    }
}

impl Clone for SparseLu {
    fn clone(&self) -> Self {
        Self {
            pivot_tol: self.pivot_tol,
            n: self.n,
            triplets: self.triplets,
            analysed: self.analysed,
            factored: self.factored,
            reused_pivots: self.reused_pivots,
            split_max_fill: self.split_max_fill,
            factors: self.factors.clone(),
        }
    }
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu")
            .field("n", &self.n)
            .field("triplets", &self.triplets)
            .field("nnz", &self.nnz())
            .field("analysed", &self.analysed)
            .field("factored", &self.factored)
            .finish()
    }
}

impl SparseLu {
    /// Pivots not above this fraction of the largest matrix entry count as zero, unless
    /// [`SparseLu::with_pivot_tolerance`] says otherwise.
    pub const PIVOT_TOL: f64 = 1e-14;

    /// faer treats 32-bit indices as signed, and its pattern construction tags duplicates in the
    /// top bit of a triplet index: dimension and triplet count must stay below 2³¹.
    const MAX_INDEX: usize = i32::MAX as usize;

    /// A solver with no pattern yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The same solver with pivots up to `tol` of the largest entry counted as zero (see
    /// [`DenseLu::with_pivot_tolerance`](crate::DenseLu::with_pivot_tolerance)).
    #[must_use]
    pub fn with_pivot_tolerance(mut self, tol: f64) -> Self {
        self.pivot_tol = tol;
        self
    }

    /// Whether the last factorisation reused the pivot order of the one before it (a
    /// refactorisation without pivot search, kept only where that order passes threshold partial
    /// pivoting).
    #[must_use]
    pub fn reused_pivot_order(&self) -> bool {
        self.reused_pivots
    }

    /// Number of distinct structural entries of the analysed pattern (0 before `analyse`).
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.factors.as_ref().map_or(0, |f| f.matrix.val().len())
    }
}

impl LinearSolver for SparseLu {
    fn analyse(
        &mut self,
        n: usize,
        rows: &[usize],
        cols: &[usize],
    ) -> Result<(), LinearSolveError> {
        self.analysed = false;
        self.factored = false;
        self.reused_pivots = false;
        self.factors = None;
        if rows.len() != cols.len() {
            return Err(PatternMismatch {
                index: rows.len().min(cols.len()),
            }
            .into());
        }
        if n > Self::MAX_INDEX || rows.len() > Self::MAX_INDEX {
            return Err(LinearSolveError::Backend(format!(
                "{n} unknowns and {} entries exceed the 32-bit index range of the sparse LU",
                rows.len()
            )));
        }
        let mut row_seen = vec![false; n];
        let mut col_seen = vec![false; n];
        for (t, (&r, &c)) in rows.iter().zip(cols).enumerate() {
            if r >= n || c >= n {
                return Err(LinearSolveError::Backend(format!(
                    "entry {t} at ({r}, {c}) lies outside the {n}×{n} matrix"
                )));
            }
            row_seen[r] = true;
            col_seen[c] = true;
        }
        if let Some(row) = row_seen.iter().position(|s| !s) {
            return Err(LinearSolveError::EmptyRow { row });
        }
        if let Some(col) = col_seen.iter().position(|s| !s) {
            return Err(LinearSolveError::EmptyColumn { col });
        }
        self.n = n;
        self.triplets = rows.len();
        if n == 0 {
            self.analysed = true;
            return Ok(());
        }

        // Indices fit in u32: checked against MAX_INDEX above.
        let pairs: Vec<Pair<u32, u32>> = rows
            .iter()
            .zip(cols)
            .map(|(&r, &c)| Pair::new(r as u32, c as u32))
            .collect();
        let (pattern, _) = SymbolicSparseColMat::<u32>::try_new_from_indices(n, n, &pairs)
            .map_err(|e| LinearSolveError::Backend(format!("sparse pattern: {e}")))?;
        drop(pairs);
        let slots = slot_map(pattern.col_ptr(), pattern.row_idx(), rows, cols)?;
        if let Err(index) = maximum_matching(n, pattern.col_ptr(), pattern.row_idx(), false) {
            return Err(LinearSolveError::StructurallySingular { index });
        }
        let colamd = colamd_order(pattern.as_ref())?;
        let split = (n >= SPLIT_MIN)
            .then(|| split_order(pattern.as_ref(), &colamd))
            .flatten();
        let nnz = pattern.row_idx().len();
        self.factors = Some(Factors {
            matrix: SparseColMat::new(pattern, vec![0.0; nnz]),
            slots,
            order: Ordered::new((colamd, None)),
            split,
            symmetric: true,
            lu: Workspace::new(n),
            work: vec![0.0; n],
        });
        self.analysed = true;
        Ok(())
    }

    fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        if !self.analysed {
            return Err(LinearSolveError::Backend(
                "sparse LU: factor called before a successful analyse".into(),
            ));
        }
        if values.len() != self.triplets {
            return Err(PatternMismatch {
                index: self.triplets,
            }
            .into());
        }
        self.factored = false;
        let Some(f) = self.factors.as_mut() else {
            self.factored = true; // 0×0
            return Ok(());
        };
        let (pattern, vals) = f.matrix.parts_mut();
        vals.fill(0.0);
        for (&s, &v) in f.slots.iter().zip(values) {
            vals[s as usize] += v;
        }
        let mut largest = 0.0_f64;
        for (p, v) in vals.iter().enumerate() {
            if !v.is_finite() {
                // Report the unknown (column) of the offending entry.
                let col = pattern.col_ptr().partition_point(|&q| q as usize <= p) - 1;
                return Err(LinearSolveError::NonFinite { index: col });
            }
            largest = largest.max(v.abs());
        }
        self.reused_pivots = f.order.own.valid && refactor(f);
        if !self.reused_pivots {
            f.factorise()?;
            if std::mem::take(&mut f.symmetric) {
                f.try_symmetric()?;
            }
            if let Some(split) = f.split.take() {
                f.try_split(split, self.split_max_fill);
            }
        }
        let tol = self.pivot_tol * largest;
        let col_perm = &f.order.col_fwd;
        let t = &mut f.order.own;
        t.u_inv.clear();
        for (j, w) in t.u_ptr.windows(2).enumerate() {
            // The pivot is U's diagonal entry, stored last in its column.
            let pivot = t.u_val[w[1] as usize - 1];
            if pivot.is_nan() || pivot.abs() <= tol {
                let index = col_perm.get(j).map_or(j, |&c| c as usize);
                return Err(LinearSolveError::NumericallySingular { index });
            }
            t.u_inv.push(1.0 / pivot);
        }
        self.factored = true;
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinearSolveError> {
        if !self.factored {
            return Err(LinearSolveError::Backend(
                "sparse LU: solve called without a successful factorisation".into(),
            ));
        }
        if rhs.len() != self.n {
            return Err(LinearSolveError::Backend(format!(
                "sparse LU: right-hand side has {} entries, the matrix {} rows",
                rhs.len(),
                self.n
            )));
        }
        let Some(f) = self.factors.as_mut() else {
            return Ok(()); // 0×0
        };
        // P A Q = L U: gather by the row permutation, solve with the unit lower factor (its
        // diagonal stored first in each column) and the upper factor (diagonal stored last),
        // scatter by the column permutation.
        let w: &mut [f64] = &mut f.work;
        for (wi, &p) in w.iter_mut().zip(&f.order.row_perm) {
            *wi = rhs[p as usize];
        }
        let t = &f.order.own;
        let (l_ptr, l_row, l_val) = (&t.l_ptr, &t.l_row, &t.l_val);
        for j in 0..w.len() {
            let xj = w[j];
            if xj != 0.0 {
                for p in l_ptr[j] as usize + 1..l_ptr[j + 1] as usize {
                    w[l_row[p] as usize] -= l_val[p] * xj;
                }
            }
        }
        let (u_ptr, u_row, u_val) = (&t.u_ptr, &t.u_row, &t.u_val);
        for (j, inv) in t.u_inv.iter().enumerate().rev() {
            let last = u_ptr[j + 1] as usize - 1;
            w[j] *= inv;
            let xj = w[j];
            if xj != 0.0 {
                for p in u_ptr[j] as usize..last {
                    w[u_row[p] as usize] -= u_val[p] * xj;
                }
            }
        }
        for (out, &c) in rhs.iter_mut().zip(&f.order.col_inv) {
            *out = w[c as usize];
        }
        // The max-norm's vectorised pass finds the first non-finite entry.
        match max_norm(rhs) {
            (norm, index) if !norm.is_finite() => Err(LinearSolveError::NonFinite { index }),
            _ => Ok(()),
        }
    }
}

/// Refactorises `f.matrix` into `f.own` with the pivot order and pattern of the last pivoting
/// factorisation (left-looking, as KLU's refactorisation: no depth-first search, no pivot search),
/// and keeps it only while every multiplier satisfies `|L_ij| ≤ 1/PIVOT_THRESHOLD`: each kept
/// pivot is at least [`PIVOT_THRESHOLD`] times the largest candidate of its column, the test of
/// threshold partial pivoting. Returns whether it kept them; otherwise `f.own` is invalid until
/// the next pivoting factorisation.
fn refactor(f: &mut Factors) -> bool {
    let o = &mut f.order;
    let t = &mut o.own;
    let x = &mut f.lu.column;
    let (a_pattern, a_val) = f.matrix.parts();
    let (a_ptr, a_row) = (a_pattern.col_ptr(), a_pattern.row_idx());
    let mut same_pivots = true;
    for (j, &c) in o.col_fwd.iter().enumerate() {
        let c = c as usize;
        for p in a_ptr[c] as usize..a_ptr[c + 1] as usize {
            x[o.row_perm_inv[a_row[p] as usize] as usize] = a_val[p];
        }
        let last = t.u_ptr[j + 1] as usize - 1;
        for p in t.u_ptr[j] as usize..last {
            let k = t.u_row[p] as usize;
            let xk = std::mem::take(&mut x[k]);
            t.u_val[p] = xk;
            if xk != 0.0 {
                for q in t.l_ptr[k] as usize + 1..t.l_ptr[k + 1] as usize {
                    x[t.l_row[q] as usize] -= t.l_val[q] * xk;
                }
            }
        }
        let pivot = std::mem::take(&mut x[j]);
        t.u_val[last] = pivot;
        for q in t.l_ptr[j] as usize + 1..t.l_ptr[j + 1] as usize {
            let multiplier = std::mem::take(&mut x[t.l_row[q] as usize]) / pivot;
            t.l_val[q] = multiplier;
            same_pivots &= multiplier.abs() * PIVOT_THRESHOLD <= 1.0;
        }
        if !same_pivots {
            break;
        }
    }
    // Every entry the elimination touched lies in the stored pattern and was taken back out.
    let kept = same_pivots && x.iter().all(|v| *v == 0.0);
    if !kept {
        x.fill(0.0);
        t.valid = false;
    }
    kept
}

impl Factors {
    /// Factorises `matrix` with the current order, pivoting (see [`pivoting::factorise`]).
    fn factorise(&mut self) -> Result<(), LinearSolveError> {
        let (pattern, val) = self.matrix.parts();
        let a = pivoting::Csc {
            col_ptr: pattern.col_ptr(),
            row_idx: pattern.row_idx(),
            val,
        };
        pivoting::factorise(&a, &mut self.order, &mut self.lu)
    }

    /// Factorises the same values with `order` and keeps it if `keep` accepts its fill
    /// `nnz(L) + nnz(U)` against the current order's; otherwise (or if it fails, which the
    /// current order did not) the current order and its factors stay. Both fills are those of
    /// the values Newton actually factorises, with their pivots.
    fn try_order(&mut self, order: ColumnOrder, keep: impl Fn(usize, usize) -> bool) {
        let mut candidate = Ordered::new(order);
        candidate.own.reserve_like(&self.order.own);
        let previous = std::mem::replace(&mut self.order, candidate);
        let kept = self.factorise().is_ok() && keep(self.order.own.fill(), previous.own.fill());
        if !kept {
            self.order = previous;
        }
    }

    /// After the first factorisations, tries the `split` order and keeps it if its fill is at
    /// most `max_fill` times the current one's (COLAMD's, or the symmetric order's where that
    /// was kept).
    fn try_split(&mut self, split: Vec<u32>, max_fill: f64) {
        self.try_order((split, None), |fill, current| {
            fill as f64 <= max_fill * current as f64
        });
    }

    /// After a first factorisation with COLAMD's order that filled in more than
    /// [`SYMMETRIC_TRY_FILL`] times the matrix, tries AMD's order on a maximum matching that
    /// keeps the diagonal where it can, pivoting on the matched rows while they pass the
    /// threshold test (KLU's strategy, `ordering::symmetric_order`), and keeps it if it fills
    /// in less by more than [`SPLIT_MAX_FILL`] (the margin the split is kept within). COLAMD
    /// orders the columns for whatever row partial pivoting then takes; on step matrices whose
    /// pattern is nearly symmetric (circuits: a node's equation and its potential) a diagonal
    /// pivot is usually acceptable and AMD's order for it fills in far less: 8–16× the matrix
    /// against 1.5–2× on CMOS netlists (audit item 47). AMD's order is computed only where
    /// COLAMD's pivots fall on the matching's pairs in at least [`SYMMETRIC_ON_PAIR_MIN`] of the
    /// columns, and factorised only where AMD's own count of its fill is at most
    /// [`SYMMETRIC_COUNT_MAX`] times the current fill.
    fn try_symmetric(&mut self) -> Result<(), LinearSolveError> {
        let (pattern, _) = self.matrix.parts();
        let current = self.order.own.fill() as f64;
        if current <= SYMMETRIC_TRY_FILL * pattern.row_idx().len() as f64 {
            return Ok(());
        }
        let n = pattern.ncols();
        let Ok(matched) = maximum_matching(n, pattern.col_ptr(), pattern.row_idx(), true) else {
            return Ok(()); // the analysis found a matching; none here means nothing to try
        };
        let o = &self.order;
        let on_pair = o.col_fwd.iter().zip(&o.row_perm);
        let on_pair = on_pair.filter(|&(&c, &r)| matched[c as usize] == r).count();
        if (on_pair as f64) < SYMMETRIC_ON_PAIR_MIN * n as f64 {
            return Ok(());
        }
        let (order, counted) = symmetric_order(pattern, &matched)?;
        if counted as f64 > SYMMETRIC_COUNT_MAX * current {
            return Ok(());
        }
        self.try_order((order, Some(matched)), |fill, current| {
            fill as f64 * SPLIT_MAX_FILL < current as f64
        });
        Ok(())
    }
}

/// The first factorisation must fill in more than this multiple of the matrix's entries for the
/// symmetric order to be tried (its AMD order, and one more factorisation in the first `factor`
/// unless [`SYMMETRIC_COUNT_MAX`] rules it out; once per pattern). Measured `nnz(L + U) / nnz(A)`
/// with COLAMD's order: 5.7–12.4 on the step and operating-point matrices of CMOS inverter chains
/// (the symmetric order filled in 3.8–7.3× less) and 2.1–3.7 on `cmos_ring.cir`'s (1.3–2.4×
/// less); 2.0–2.5 on RLC ladders under Gauss 2 to 4 and 2.6 on the rigid chain, where it did not
/// gain 1.25×.
const SYMMETRIC_TRY_FILL: f64 = 2.0;

/// AMD's count of the symmetric order's fill (that of a Cholesky factor of the symmetrised
/// pattern, so an overestimate for an unsymmetric one) above which the order is not factorised:
/// the count exceeded the factorisation's fill by 1.24–1.72× on the matrices of
/// [`SYMMETRIC_TRY_FILL`], so above 1.4 times the current fill a gain of 1.25× is unlikely. The
/// ladders' counts were 1.51× COLAMD's fill (the try's factorisation had cost a 5-step Gauss 4
/// run of the 1000-section ladder 12 %); `cmos_ring.cir`'s, which gain, 0.60–1.19×.
const SYMMETRIC_COUNT_MAX: f64 = 1.4;

/// Share of the columns whose pivot under COLAMD's order lies on the matching's pair below which
/// the symmetric order is not computed. AMD models an elimination with every pivot on its pair;
/// where partial pivoting put few pivots there (RLC ladders under Gauss 2 and 4: 0.30; the rigid
/// chains and the motor arm, whose multiplier columns have no diagonal: 0.13–0.22), it has not
/// filled in 1.25× less on any matrix measured, and its order cost as much as half the first
/// factorisation (1.6 ms of AMD against 2.7 ms on the 1000-section ladder's Gauss 2 step, 5.4
/// against 10.5 under Gauss 4). The CMOS matrices that gain had 0.49–0.82.
const SYMMETRIC_ON_PAIR_MIN: f64 = 0.4;

/// Patterns with fewer unknowns keep COLAMD's order without trying the split: their dependency
/// chains are short, and the second factorisation of the first `factor` would be set-up cost
/// for little.
const SPLIT_MIN: usize = 128;

/// The split order is kept if its first fill is at most this multiple of COLAMD's. Measured
/// side by side with COLAMD's order: on an RLC ladder with every section active the split has
/// 0.2 % more fill and the steps cost 26 % less, all of it from the overlap (the same halves
/// listed one after the other cost what COLAMD's order does); on the rigid chain (`chain_profile`,
/// 8 to 128 links) it has 12 % more fill and the steps cost 16–30 % less, none of it from the
/// overlap but from fewer Newton updates and factorisations per step (docs/rigid.md).
const SPLIT_MAX_FILL: f64 = 1.25;

/// Position in the compressed-column value array of every triplet. Row indices are sorted and
/// unique within a column, so a binary search finds it; duplicates get the same position.
fn slot_map(
    col_ptr: &[u32],
    row_idx: &[u32],
    rows: &[usize],
    cols: &[usize],
) -> Result<Vec<u32>, LinearSolveError> {
    rows.iter()
        .zip(cols)
        .enumerate()
        .map(|(t, (&r, &c))| {
            let start = col_ptr[c] as usize;
            let end = col_ptr[c + 1] as usize;
            match row_idx[start..end].binary_search(&(r as u32)) {
                Ok(k) => Ok((start + k) as u32),
                Err(_) => Err(LinearSolveError::Backend(format!(
                    "sparse pattern lost entry {t} at ({r}, {c})"
                ))),
            }
        })
        .collect()
}

/// A perfect matching of unknowns to equations (`matched[c]` is the row of column `c`), which
/// exists exactly when the pattern admits a nonsingular matrix; otherwise the first unknown that
/// cannot be matched. With `keep_diagonal` every column with a diagonal entry starts matched to
/// its own row, and augmenting paths only move a pair where they must (the symmetric order's
/// pairing, `ordering::symmetric_order`).
///
/// A pivoting LU reports structural singularity only when no candidate pivot row is left, which
/// depends on the column order and misses some cases: on random 30×30 patterns with a planted
/// deficiency faer's let 11 % through, returning NaN or finite garbage (|x| ~ 1e18). This is
/// Duff's augmenting-path algorithm (MC21, as in CSparse's `cs_maxtrans`) with a
/// cheap-assignment lookahead, written without recursion.
pub(crate) fn maximum_matching(
    n: usize,
    col_ptr: &[u32],
    row_idx: &[u32],
    keep_diagonal: bool,
) -> Result<Vec<u32>, usize> {
    const NONE: usize = usize::MAX;
    let mut row_match = vec![NONE; n]; // column matched to each row
    let mut seeded = vec![false; n];
    if keep_diagonal {
        for (k, w) in col_ptr.windows(2).enumerate() {
            if row_idx[w[0] as usize..w[1] as usize]
                .binary_search(&(k as u32))
                .is_ok()
            {
                row_match[k] = k;
                seeded[k] = true;
            }
        }
    }
    let mut cheap: Vec<usize> = col_ptr[..n].iter().map(|&p| p as usize).collect();
    let mut cursor = vec![0_usize; n];
    let mut mark = vec![NONE; n]; // last search that visited each column
    let mut path: Vec<usize> = Vec::new(); // columns on the current search path
    let mut via: Vec<usize> = Vec::new(); // via[t]: row through which path[t + 1] was entered
    for k in (0..n).filter(|&k| !seeded[k]) {
        path.clear();
        via.clear();
        path.push(k);
        let mut free_row = NONE;
        'search: while let Some(&j) = path.last() {
            let end = col_ptr[j + 1] as usize;
            if mark[j] != k {
                mark[j] = k;
                while cheap[j] < end {
                    let i = row_idx[cheap[j]] as usize;
                    cheap[j] += 1;
                    if row_match[i] == NONE {
                        free_row = i;
                        break 'search;
                    }
                }
                cursor[j] = col_ptr[j] as usize;
            }
            while cursor[j] < end {
                let i = row_idx[cursor[j]] as usize;
                cursor[j] += 1;
                let owner = row_match[i];
                if owner == NONE {
                    free_row = i;
                    break 'search;
                }
                if mark[owner] != k {
                    via.push(i);
                    path.push(owner);
                    continue 'search;
                }
            }
            path.pop();
            via.pop();
        }
        if free_row == NONE {
            return Err(k);
        }
        // Augment: the last column takes the free row, every earlier one the row it passed on.
        if let Some(&last) = path.last() {
            row_match[free_row] = last;
        }
        for (&i, &j) in via.iter().zip(&path) {
            row_match[i] = j;
        }
    }
    let mut row_of = vec![0_u32; n];
    for (i, &c) in row_match.iter().enumerate() {
        row_of[c] = i as u32;
    }
    Ok(row_of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DenseLu;

    /// One step of Knuth's MMIX linear congruential generator.
    fn lcg(state: u64) -> u64 {
        state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407)
    }

    /// The top 53 bits of `state` as a number in `[0, 1)`.
    fn unit(state: u64) -> f64 {
        (state >> 11) as f64 / (1_u64 << 53) as f64
    }

    /// Counts the allocations of the calling thread (tests run in parallel on other threads).
    mod counting {
        use std::alloc::{GlobalAlloc, Layout, System};
        use std::cell::Cell;

        thread_local! {
            static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
        }

        pub struct Counting;

        fn bump() {
            let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        }

        // SAFETY: forwards to the system allocator; the counter is a const-initialised
        // thread-local without destructor, so touching it neither allocates nor recurses.
        unsafe impl GlobalAlloc for Counting {
            unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
                bump();
                // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract.
                unsafe { System.alloc(layout) }
            }
            unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
                bump();
                // SAFETY: the caller upholds `GlobalAlloc::alloc_zeroed`'s contract.
                unsafe { System.alloc_zeroed(layout) }
            }
            unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
                bump();
                // SAFETY: the caller upholds `GlobalAlloc::realloc`'s contract.
                unsafe { System.realloc(ptr, layout, new_size) }
            }
            unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
                // SAFETY: the caller upholds `GlobalAlloc::dealloc`'s contract.
                unsafe { System.dealloc(ptr, layout) }
            }
        }

        pub fn allocations() -> usize {
            ALLOCATIONS.with(Cell::get)
        }
    }

    #[global_allocator]
    static GLOBAL: counting::Counting = counting::Counting;

    /// Tiny deterministic random numbers.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = lcg(self.0);
            lo + (hi - lo) * unit(self.0)
        }
        fn below(&mut self, n: usize) -> usize {
            ((self.uniform(0.0, 1.0) * n as f64) as usize).min(n - 1)
        }
    }

    /// A square matrix as triplets.
    #[derive(Default, Clone)]
    struct Problem {
        n: usize,
        rows: Vec<usize>,
        cols: Vec<usize>,
        vals: Vec<f64>,
    }

    impl Problem {
        fn new(n: usize) -> Self {
            Self {
                n,
                ..Self::default()
            }
        }
        fn add(&mut self, r: usize, c: usize, v: f64) {
            self.rows.push(r);
            self.cols.push(c);
            self.vals.push(v);
        }
        fn apply(&self, x: &[f64]) -> Vec<f64> {
            let mut b = vec![0.0; self.n];
            for ((&r, &c), &v) in self.rows.iter().zip(&self.cols).zip(&self.vals) {
                b[r] += v * x[c];
            }
            b
        }
    }

    /// Nonsymmetric sparse, strictly diagonally dominant by rows; diagonals stamped in two parts.
    fn diagonally_dominant(n: usize, rng: &mut Rng) -> Problem {
        let mut p = Problem::new(n);
        for i in 0..n {
            let mut off = 0.0;
            for _ in 0..4 {
                let j = rng.below(n);
                if j != i {
                    let v = rng.uniform(-1.0, 1.0);
                    off += v.abs();
                    p.add(i, j, v);
                }
            }
            let sign = if rng.uniform(0.0, 1.0) < 0.5 {
                -1.0
            } else {
                1.0
            };
            let d = sign * (off + rng.uniform(0.5, 1.5));
            p.add(i, i, 0.25 * d);
            p.add(i, i, 0.75 * d);
        }
        p
    }

    /// `[[J, Aᵀ], [A, 0]]`: J an SPD chain with random extra couplings, A with `m` rows, each
    /// coupling its own coordinate and two random ones. The (2,2) block is structurally zero.
    fn kkt(nq: usize, m: usize, rng: &mut Rng) -> Problem {
        let mut p = Problem::new(nq + m);
        for i in 0..nq {
            p.add(i, i, 4.0 + rng.uniform(0.0, 1.0));
            if i + 1 < nq {
                let v = rng.uniform(-1.0, -0.5);
                p.add(i, i + 1, v);
                p.add(i + 1, i, v);
            }
            let j = rng.below(nq);
            if j != i {
                let v = rng.uniform(-0.5, 0.5);
                p.add(i, j, v);
                p.add(j, i, v);
                p.add(i, i, v.abs());
                p.add(j, j, v.abs());
            }
        }
        for r in 0..m {
            let own = r * nq / m;
            let mut entries = vec![(own, rng.uniform(0.8, 1.5))];
            for _ in 0..2 {
                entries.push((rng.below(nq), rng.uniform(-0.5, 0.5)));
            }
            for (q, v) in entries {
                p.add(nq + r, q, v);
                p.add(q, nq + r, v);
            }
        }
        p
    }

    fn solve_with<S: LinearSolver>(solver: &mut S, p: &Problem, b: &[f64]) -> Vec<f64> {
        solver.analyse(p.n, &p.rows, &p.cols).unwrap();
        solver.factor(&p.vals).unwrap();
        let mut x = b.to_vec();
        solver.solve_in_place(&mut x).unwrap();
        x
    }

    fn max_abs(v: &[f64]) -> f64 {
        v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
    }

    fn assert_close(got: &[f64], want: &[f64], tol: f64) {
        let diff = got
            .iter()
            .zip(want)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        let rel = diff / max_abs(want);
        assert!(rel <= tol, "relative difference {rel:e} > {tol:e}");
    }

    fn random_vector(n: usize, rng: &mut Rng) -> Vec<f64> {
        (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect()
    }

    /// Factorises `p` with a fresh `SparseLu` in three rounds, the values perturbed by up to 1 %
    /// between them (so the later rounds refactorise); `first` checks the first factorisation,
    /// and every round must solve a random system as dense LU does and to the known solution.
    fn three_rounds_as_dense_lu(
        p: &mut Problem,
        rng: &mut Rng,
        first: impl Fn(&Factors, &Problem),
    ) {
        let mut lu = SparseLu::new();
        lu.analyse(p.n, &p.rows, &p.cols).unwrap();
        for round in 0..3 {
            lu.factor(&p.vals).unwrap();
            if round == 0 {
                first(lu.factors.as_ref().unwrap(), p);
            }
            let x_true = random_vector(p.n, rng);
            let b = p.apply(&x_true);
            let mut xs = b.clone();
            lu.solve_in_place(&mut xs).unwrap();
            let xd = solve_with(&mut DenseLu::new(), p, &b);
            assert_close(&xs, &xd, 1e-12);
            assert_close(&xs, &x_true, 1e-10);
            for v in &mut p.vals {
                *v *= rng.uniform(0.99, 1.01);
            }
        }
    }

    #[test]
    fn matches_dense_lu_on_diagonally_dominant_systems() {
        let mut rng = Rng(1);
        for n in [1, 2, 7, 150, 300, 450] {
            let p = diagonally_dominant(n, &mut rng);
            let b = p.apply(&random_vector(n, &mut rng));
            let xs = solve_with(&mut SparseLu::new(), &p, &b);
            let xd = solve_with(&mut DenseLu::new(), &p, &b);
            assert_close(&xs, &xd, 1e-12);
        }
    }

    /// The step matrix of an RLC ladder of `sections` sections in the shape the assembler gives
    /// it: per section a series-branch charge `a`, a shunt charge `b` and the multiplier `λ` of
    /// the node between them, whose row is `a_k − a_{k+1} − b_k = 0` (structurally zero
    /// diagonal); the charges' diagonal entries are random and the coupling rows carry random
    /// scales, so the pattern is symmetric and the values are not.
    fn ladder(sections: usize, rng: &mut Rng) -> Problem {
        let mut p = Problem::new(3 * sections);
        let (a, b, l) = (|k: usize| 3 * k, |k: usize| 3 * k + 1, |k: usize| 3 * k + 2);
        for k in 0..sections {
            p.add(a(k), a(k), rng.uniform(1.0, 2.0));
            p.add(b(k), b(k), rng.uniform(0.5, 1.0));
            let mut couple = |q: usize, sign: f64| {
                p.add(l(k), q, sign * rng.uniform(0.9, 1.1));
                p.add(q, l(k), sign * rng.uniform(0.9, 1.1));
            };
            couple(a(k), 1.0);
            couple(b(k), -1.0);
            if k + 1 < sections {
                couple(a(k + 1), -1.0);
            }
        }
        p
    }

    /// A ladder takes the split order (its two halves' columns alternate, see the `ordering`
    /// module) and solves as dense LU does, on the first factorisation and on refactorisations
    /// with new values; a short ladder keeps COLAMD's order.
    #[test]
    fn a_ladder_takes_the_split_order_and_solves_as_dense_lu() {
        let mut rng = Rng(5);
        for sections in [20, 400] {
            let mut p = ladder(sections, &mut rng);
            three_rounds_as_dense_lu(&mut p, &mut rng, |f, p| {
                let colamd = colamd_order(f.matrix.symbolic()).unwrap();
                if p.n < SPLIT_MIN {
                    assert_eq!(f.order.col_fwd, colamd);
                } else {
                    assert_eq!(
                        Some(&f.order.col_fwd),
                        split_order(f.matrix.symbolic(), &colamd).as_ref()
                    );
                }
            });
        }
    }

    /// A chain of stages that one hub unknown couples (a supply node feeding every transistor of
    /// a CMOS netlist, audit item 47), its row's entries larger than the stages' diagonals.
    /// Eliminated stage by stage on the diagonal, hub last, it fills in nothing (`L + U` holds
    /// the matrix's 779 entries and `L`'s unit diagonal, 960). With COLAMD's order partial
    /// pivoting takes the hub row as the pivot of an early column: 4576. The symmetric order
    /// (AMD, pivots kept on the diagonal, which passes the threshold) must come within 1.5× of
    /// the elimination without fill (1196), and solve as dense LU does, on the first
    /// factorisation and on refactorisations with new values.
    #[test]
    fn a_hub_coupled_chain_takes_the_symmetric_order_and_fills_in_nothing() {
        let mut rng = Rng(11);
        let stages = 60;
        let hub = 3 * stages;
        let mut p = Problem::new(hub + 1);
        for k in 0..stages {
            for i in 0..3 {
                for j in 0..3 {
                    let v = if i == j {
                        rng.uniform(2.0, 3.0)
                    } else {
                        rng.uniform(0.1, 0.5)
                    };
                    p.add(3 * k + i, 3 * k + j, v);
                }
            }
            if k + 1 < stages {
                p.add(3 * k + 2, 3 * k + 3, rng.uniform(-0.3, -0.1));
                p.add(3 * k + 3, 3 * k + 2, rng.uniform(-0.3, -0.1));
            }
            p.add(hub, 3 * k + 1, rng.uniform(5.0, 10.0));
            p.add(3 * k + 1, hub, rng.uniform(0.01, 0.02));
        }
        p.add(hub, hub, 1.0);
        three_rounds_as_dense_lu(&mut p, &mut rng, |f, p| {
            assert!(f.order.preferred.is_some(), "the symmetric order is kept");
            let no_fill = p.vals.len() + p.n;
            let fill = f.order.own.fill();
            assert!(2 * fill <= 3 * no_fill, "{fill}");
        });
    }

    /// Patterns the split order meets in assembled models, each taking it and solved as dense LU
    /// solves it: two
    /// ladders side by side (two components, each cut) with unknowns of their own (a diagonal
    /// entry only), and a ladder with a few long-range couplings (an unsymmetric pair of entries
    /// between distant sections), whose level structure is shallow where the couplings jump.
    #[test]
    fn split_patterns_solve_as_dense_lu() {
        let mut rng = Rng(9);
        let (a, b) = (ladder(150, &mut rng), ladder(170, &mut rng));
        let mut two = Problem::new(a.n + b.n + 5);
        for (p, shift) in [(&a, 0), (&b, a.n)] {
            for ((&r, &c), &v) in p.rows.iter().zip(&p.cols).zip(&p.vals) {
                two.add(r + shift, c + shift, v);
            }
        }
        for k in a.n + b.n..two.n {
            two.add(k, k, rng.uniform(1.0, 2.0));
        }
        let mut coupled = ladder(300, &mut rng);
        for _ in 0..4 {
            let (r, c) = (rng.below(coupled.n), rng.below(coupled.n));
            coupled.add(r, c, rng.uniform(-0.1, 0.1));
            coupled.add(c, r, rng.uniform(-0.1, 0.1));
        }
        for p in [two, coupled] {
            let mut lu = SparseLu::new();
            let x_true = random_vector(p.n, &mut rng);
            let rhs = p.apply(&x_true);
            let xs = solve_with(&mut lu, &p, &rhs);
            let f = lu.factors.as_ref().unwrap();
            let split = split_order(
                f.matrix.symbolic(),
                &colamd_order(f.matrix.symbolic()).unwrap(),
            );
            assert_eq!(Some(&f.order.col_fwd), split.as_ref());
            let xd = solve_with(&mut DenseLu::new(), &p, &rhs);
            assert_close(&xs, &xd, 1e-12);
            assert_close(&xs, &x_true, 1e-10);
        }
    }

    #[test]
    fn matches_dense_lu_on_kkt_systems() {
        let mut rng = Rng(2);
        for (nq, m) in [(3, 1), (10, 4), (100, 40), (200, 90), (320, 130)] {
            let p = kkt(nq, m, &mut rng);
            let x_true = random_vector(p.n, &mut rng);
            let b = p.apply(&x_true);
            let xs = solve_with(&mut SparseLu::new(), &p, &b);
            let xd = solve_with(&mut DenseLu::new(), &p, &b);
            assert_close(&xs, &xd, 1e-12);
            assert_close(&xs, &x_true, 1e-10);
        }
    }

    /// The refactorisation without pivot search is taken after small changes of the values and
    /// refused after large ones (where the old pivots fail the threshold test); either way the
    /// solution is backward stable: `‖A x − b‖∞ ≤ 1e-14 (‖A‖∞ ‖x‖∞ + ‖b‖∞)` (measured ≤ 3.2e-16).
    /// Mutations in `refactor`: accepting any finite multiplier gives a backward error of 1.0e-7
    /// (round 0); skipping the elimination updates makes the small
    /// change of round 2 refuse the old pivots.
    #[test]
    fn refactorises_without_pivot_search_only_on_the_same_pivots() {
        let mut rng = Rng(11);
        let base = kkt(150, 60, &mut rng);
        let mut lu = SparseLu::new();
        lu.analyse(base.n, &base.rows, &base.cols).unwrap();
        let (mut reused, mut searched) = (0, 0);
        let mut p = base.clone();
        for round in 0..12 {
            // Odd rounds scale the base values by factors 0.01 … 100, even rounds change the
            // previous round's by up to 1e-6.
            if round % 2 == 1 {
                for (v, v0) in p.vals.iter_mut().zip(&base.vals) {
                    *v = v0 * rng.uniform(-4.6, 4.6).exp();
                }
            } else {
                for v in &mut p.vals {
                    *v *= 1.0 + rng.uniform(-1e-6, 1e-6);
                }
            }
            lu.factor(&p.vals).unwrap();
            if round > 0 && round % 2 == 0 {
                assert!(
                    lu.reused_pivot_order(),
                    "round {round}: small change, new pivots"
                );
            }
            if lu.reused_pivot_order() {
                reused += 1;
            } else {
                searched += 1;
            }
            let b = p.apply(&random_vector(p.n, &mut rng));
            let mut xs = b.clone();
            lu.solve_in_place(&mut xs).unwrap();
            let residual = p.apply(&xs);
            let r = residual
                .iter()
                .zip(&b)
                .fold(0.0_f64, |m, (a, c)| m.max((a - c).abs()));
            let mut row_sums = vec![0.0; p.n];
            for ((&i, _), v) in p.rows.iter().zip(&p.cols).zip(&p.vals) {
                row_sums[i] += v.abs();
            }
            let norm_a = row_sums.iter().fold(0.0_f64, |m, v| m.max(*v));
            let backward = r / (norm_a * max_abs(&xs) + max_abs(&b));
            println!(
                "round {round}: kept {}, backward error {backward:.1e}",
                lu.reused_pivot_order()
            );
            assert!(
                backward <= 1e-14,
                "round {round}: backward error {backward:e}"
            );
        }
        println!("refactorisations kept {reused}, pivot searches {searched}");
        assert!(
            reused >= 5 && searched >= 3,
            "kept {reused}, searched {searched}"
        );
    }

    #[test]
    fn refactorises_new_values_on_the_same_pattern() {
        let mut rng = Rng(3);
        let base = kkt(120, 50, &mut rng);
        let mut lu = SparseLu::new();
        let mut dense = DenseLu::new();
        lu.analyse(base.n, &base.rows, &base.cols).unwrap();
        dense.analyse(base.n, &base.rows, &base.cols).unwrap();
        for round in 0..4 {
            let mut p = base.clone();
            if round > 0 {
                for v in &mut p.vals {
                    *v *= rng.uniform(0.7, 1.3);
                }
            }
            lu.factor(&p.vals).unwrap();
            dense.factor(&p.vals).unwrap();
            // Several right-hand sides per factorisation.
            for _ in 0..3 {
                let b = p.apply(&random_vector(p.n, &mut rng));
                let mut xs = b.clone();
                let mut xd = b;
                lu.solve_in_place(&mut xs).unwrap();
                dense.solve_in_place(&mut xd).unwrap();
                assert_close(&xs, &xd, 1e-12);
            }
        }
    }

    #[test]
    fn duplicates_are_summed() {
        // A = [[4, 1, 0], [1, 3, -1], [0, 2, 5]], entries stamped in pieces and out of order.
        let mut p = Problem::new(3);
        for (r, c, v) in [
            (2, 2, 2.0),
            (0, 0, 1.0),
            (1, 2, -1.0),
            (0, 1, 0.25),
            (1, 1, 3.0),
            (0, 0, 3.0),
            (2, 1, 2.0),
            (1, 0, 1.0),
            (0, 1, 0.75),
            (2, 2, 3.0),
            (1, 1, 0.0),
        ] {
            p.add(r, c, v);
        }
        let x = [1.0, -2.0, 3.0];
        let b = p.apply(&x);
        assert_eq!(b, vec![2.0, -8.0, 11.0]);
        let mut lu = SparseLu::new();
        let got = solve_with(&mut lu, &p, &b);
        assert_eq!(lu.nnz(), 7);
        assert_close(&got, &x, 1e-15);
    }

    #[test]
    fn empty_constraint_row_is_an_error() {
        // KKT with nq = 3, m = 2, whose second constraint (row and column 4) is empty.
        let mut p = Problem::new(5);
        for i in 0..3 {
            p.add(i, i, 2.0);
        }
        p.add(3, 0, 1.0);
        p.add(0, 3, 1.0);
        // Structurally present as an explicit zero, numerically empty: caught at the pivot.
        p.add(4, 4, 0.0);
        let mut lu = SparseLu::new();
        lu.analyse(p.n, &p.rows, &p.cols).unwrap();
        assert!(matches!(
            lu.factor(&p.vals),
            Err(LinearSolveError::NumericallySingular { index: 4 })
        ));
        assert!(lu.solve_in_place(&mut [0.0; 5]).is_err());
        // Structurally absent: a typed error from `analyse`; `factor` and `solve` do not panic.
        p.rows.pop();
        p.cols.pop();
        p.vals.pop();
        assert_eq!(
            lu.analyse(p.n, &p.rows, &p.cols),
            Err(LinearSolveError::EmptyRow { row: 4 })
        );
        assert!(lu.factor(&p.vals).is_err());
        assert!(lu.solve_in_place(&mut [0.0; 5]).is_err());
    }

    /// The matching the symmetric order pairs columns with rows by: a perfect matching inside the
    /// pattern (checked entry by entry), the identity where the diagonal is zero-free, and where
    /// it is not (a KKT pattern: zero multiplier block) every column still has a distinct row.
    #[test]
    fn the_matching_keeps_the_diagonal_and_is_perfect() {
        let mut rng = Rng(12);
        let cases = [
            (diagonally_dominant(60, &mut rng), true),
            (kkt(40, 15, &mut rng), false),
        ];
        for (p, zero_free) in cases {
            let pattern = SymbolicSparseColMat::<u32>::try_new_from_indices(
                p.n,
                p.n,
                &p.rows
                    .iter()
                    .zip(&p.cols)
                    .map(|(&r, &c)| Pair::new(r as u32, c as u32))
                    .collect::<Vec<_>>(),
            )
            .unwrap()
            .0;
            let (ptr, idx) = (pattern.col_ptr(), pattern.row_idx());
            let matched = maximum_matching(p.n, ptr, idx, true).unwrap();
            let mut taken = vec![false; p.n];
            for (c, &r) in matched.iter().enumerate() {
                let column = &idx[ptr[c] as usize..ptr[c + 1] as usize];
                assert!(column.contains(&r), "({r}, {c}) is not an entry");
                assert!(
                    !std::mem::replace(&mut taken[r as usize], true),
                    "row {r} twice"
                );
                if zero_free {
                    assert_eq!(r as usize, c);
                }
            }
        }
    }

    #[test]
    fn structurally_singular_pattern_is_an_error() {
        // Two constraints that both pin q0 and nothing else: no row or column is empty, but the
        // pattern has no perfect matching.
        let mut p = Problem::new(5);
        for i in 0..3 {
            p.add(i, i, 2.0);
        }
        for r in [3, 4] {
            p.add(r, 0, 1.0);
            p.add(0, r, 1.0);
        }
        let mut lu = SparseLu::new();
        assert!(matches!(
            lu.analyse(p.n, &p.rows, &p.cols),
            Err(LinearSolveError::StructurallySingular { index: 3 | 4 })
        ));
        // [[a, b, c], [d, 0, 0], [e, 0, 0]]: no empty row or column either.
        let rows = [0, 1, 2, 0, 0];
        let cols = [0, 0, 0, 1, 2];
        assert!(matches!(
            lu.analyse(3, &rows, &cols),
            Err(LinearSolveError::StructurallySingular { .. })
        ));
        assert!(lu.factor(&[1.0; 5]).is_err());
    }

    #[test]
    fn redundant_constraints_are_an_error_not_nan() {
        // Identical or proportional constraint rows make the KKT matrix singular while its
        // pattern is fine. faer alone returns NaN or huge finite values.
        let mut rng = Rng(5);
        let nq = 12;
        for trial in 0..40 {
            let mut p = kkt(nq, 3, &mut rng);
            let ratio = if trial % 2 == 0 {
                1.0
            } else {
                rng.uniform(-3.0, 3.0)
            };
            let constraint: Vec<(usize, f64)> = (0..3)
                .map(|k| (3 * k + trial % 3, rng.uniform(0.5, 50.0)))
                .collect();
            for (r, scale) in [(nq + 3, 1.0), (nq + 4, ratio)] {
                for &(q, v) in &constraint {
                    p.add(r, q, scale * v);
                    p.add(q, r, scale * v);
                }
            }
            p.n = nq + 5;
            let mut lu = SparseLu::new();
            lu.analyse(p.n, &p.rows, &p.cols).unwrap();
            let mut x = vec![1.0; p.n];
            let outcome = lu.factor(&p.vals).and_then(|()| lu.solve_in_place(&mut x));
            assert!(
                matches!(
                    outcome,
                    Err(LinearSolveError::NumericallySingular { .. }
                        | LinearSolveError::NonFinite { .. })
                ),
                "trial {trial}: {outcome:?}, max |x| = {:e}",
                max_abs(&x)
            );
        }
    }

    /// After `analyse`, refactorisations with new values and solves do not allocate. The counter
    /// is first shown to count: one heap allocation moves it by one, and `analyse` moves it.
    #[test]
    fn factor_and_solve_do_not_allocate() {
        let mut rng = Rng(6);
        let kkt_system = kkt(400, 150, &mut rng);
        let ladder_system = ladder(300, &mut rng);
        // The ladder keeps the split column order (its fill is close to COLAMD's); with the
        // fill bound at 0.5 the split is rejected and COLAMD's order is factorised again. Both
        // paths are checked for the storage they leave.
        for (p, max_fill, split) in [
            (&kkt_system, SPLIT_MAX_FILL, None),
            (&ladder_system, SPLIT_MAX_FILL, Some(true)),
            (&ladder_system, 0.5, Some(false)),
        ] {
            assert_factor_and_solve_do_not_allocate(p, max_fill, split, &mut rng);
        }
    }

    /// Checks that after `analyse` and the first factorisation (with the split's fill bound
    /// `max_fill`) the factorisations and solves of `p` allocate nothing, and, with
    /// `split = Some(kept)`, that `p` has a split order and whether the first factorisation
    /// kept it.
    fn assert_factor_and_solve_do_not_allocate(
        p: &Problem,
        max_fill: f64,
        split: Option<bool>,
        rng: &mut Rng,
    ) {
        let mut lu = SparseLu {
            split_max_fill: max_fill,
            ..SparseLu::new()
        };
        let before = counting::allocations();
        let probe = std::hint::black_box(vec![1u8; 16]);
        assert_eq!(
            counting::allocations() - before,
            1,
            "the counter does not count"
        );
        drop(probe);
        let before = counting::allocations();
        lu.analyse(p.n, &p.rows, &p.cols).unwrap();
        lu.factor(&p.vals).unwrap();
        assert!(
            counting::allocations() > before,
            "analyse and the first factorisation were expected to allocate"
        );
        let f = lu.factors.as_ref().unwrap();
        let colamd = colamd_order(f.matrix.symbolic()).unwrap();
        assert_eq!(
            split_order(f.matrix.symbolic(), &colamd).is_some(),
            split.is_some()
        );
        if let Some(kept) = split {
            assert_eq!(f.order.col_fwd != colamd, kept);
        }
        let mut vals = p.vals.clone();
        let mut x = vec![0.0; p.n];
        let before = counting::allocations();
        for _ in 0..20 {
            for (v, v0) in vals.iter_mut().zip(&p.vals) {
                *v = v0 * rng.uniform(0.9, 1.1);
            }
            lu.factor(&vals).unwrap();
            for _ in 0..3 {
                x.fill(1.0);
                lu.solve_in_place(&mut x).unwrap();
            }
        }
        assert_eq!(counting::allocations() - before, 0);
        // And the factors kept are right ones: the last values solve to the true solution.
        let last = Problem { vals, ..p.clone() };
        let x_true = random_vector(p.n, rng);
        let mut x = last.apply(&x_true);
        lu.solve_in_place(&mut x).unwrap();
        assert_close(&x, &x_true, 1e-10);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let mut lu = SparseLu::new();
        assert!(lu.factor(&[]).is_err());
        assert!(lu.solve_in_place(&mut []).is_err());
        assert!(lu.analyse(2, &[0, 1], &[0]).is_err());
        assert!(lu.analyse(2, &[0, 2], &[0, 1]).is_err());
        assert_eq!(
            lu.analyse(2, &[0], &[0]),
            Err(LinearSolveError::EmptyRow { row: 1 })
        );
        assert_eq!(
            lu.analyse(2, &[0, 1], &[0, 0]),
            Err(LinearSolveError::EmptyColumn { col: 1 })
        );
        lu.analyse(2, &[0, 1], &[0, 1]).unwrap();
        assert_eq!(
            lu.factor(&[1.0]),
            Err(LinearSolveError::Pattern(PatternMismatch { index: 2 }))
        );
        assert_eq!(
            lu.factor(&[1.0, f64::NAN]),
            Err(LinearSolveError::NonFinite { index: 1 })
        );
        lu.factor(&[2.0, 4.0]).unwrap();
        assert!(lu.solve_in_place(&mut [1.0]).is_err());
        let mut x = [1.0, 1.0];
        lu.solve_in_place(&mut x).unwrap();
        assert_eq!(x, [0.5, 0.25]);
        // The empty system.
        lu.analyse(0, &[], &[]).unwrap();
        lu.factor(&[]).unwrap();
        lu.solve_in_place(&mut []).unwrap();
    }

    #[test]
    fn clone_keeps_the_factorisation() {
        let mut rng = Rng(7);
        let p = kkt(30, 10, &mut rng);
        let mut lu = SparseLu::new();
        lu.analyse(p.n, &p.rows, &p.cols).unwrap();
        lu.factor(&p.vals).unwrap();
        let mut copy = lu.clone();
        let b = random_vector(p.n, &mut rng);
        let (mut x1, mut x2) = (b.clone(), b);
        lu.solve_in_place(&mut x1).unwrap();
        copy.solve_in_place(&mut x2).unwrap();
        assert_eq!(x1, x2);
    }

    /// The chain `F_i = x_i³ + 3 x_i − x_{i−1} − x_{i+1} − 1`.
    struct Chain(usize);

    impl crate::NonlinearSystem for Chain {
        fn len(&self) -> usize {
            self.0
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) {
            for (i, (ri, &xi)) in r.iter_mut().zip(x).enumerate() {
                let left = if i > 0 { x[i - 1] } else { 0.0 };
                let right = x.get(i + 1).copied().unwrap_or(0.0);
                *ri = xi.powi(3) + 3.0 * xi - left - right - 1.0;
            }
        }
        fn jacobian(&mut self, x: &[f64], jac: &mut crate::Triplets) {
            for (i, &xi) in x.iter().enumerate() {
                if i > 0 {
                    jac.add(i, i - 1, -1.0);
                }
                jac.add(i, i, 3.0 * xi * xi + 3.0);
                if i + 1 < self.0 {
                    jac.add(i, i + 1, -1.0);
                }
            }
        }
    }

    #[test]
    fn newton_converges_with_the_sparse_lu() {
        let n = 500;
        // Exact Newton (a fresh factorisation every iteration): the iteration count is the
        // quadratic-convergence count.
        let options = crate::NewtonOptions {
            reuse_jacobian: false,
            ..crate::NewtonOptions::default()
        };
        let mut sparse = crate::Newton::new(SparseLu::new(), options);
        let mut dense = crate::Newton::new(DenseLu::new(), options);
        let mut xs = vec![0.0; n];
        let mut xd = vec![0.0; n];
        let stats = sparse.solve(&mut Chain(n), &mut xs).unwrap();
        dense.solve(&mut Chain(n), &mut xd).unwrap();
        assert!(stats.iterations <= 8, "{stats:?}");
        assert_close(&xs, &xd, 1e-12);
    }
}
