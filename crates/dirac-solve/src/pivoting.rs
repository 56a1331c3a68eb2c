//! The pivoting numeric LU of [`SparseLu`](crate::SparseLu): Gilbert and Peierls' left-looking
//! factorisation with threshold partial pivoting and, where the column order was made for pivots
//! on a given row of each column, a preference for that row (as KLU and CSparse's `cs_lu` do).
//!
//! Plain partial pivoting takes the largest candidate of each column, which can be any row: a
//! column order chosen for pivots on the diagonal of a symmetric pattern (AMD on `A + Aᵀ`)
//! then fills in as if it had been chosen for none. On the step matrices of CMOS netlists, where
//! one supply node couples every transistor, COLAMD's order with partial pivoting filled in
//! 8–16× the matrix; AMD's order with the preferred row kept while it is within
//! [`PIVOT_THRESHOLD`](crate::sparse) of the largest candidate fills in 1.5–2× (audit item 47).

use crate::error::LinearSolveError;
use crate::sparse::{Ordered, PIVOT_THRESHOLD, Triangular};

/// Marks a row that is not yet a pivot row.
const UNPIVOTED: u32 = u32::MAX;

/// A matrix in compressed-column form (sorted, unique row indices per column).
pub(crate) struct Csc<'a> {
    pub col_ptr: &'a [u32],
    pub row_idx: &'a [u32],
    pub val: &'a [f64],
}

/// Work arrays of a factorisation, sized once per pattern (the factorisation allocates only where
/// its fill exceeds what earlier ones left room for).
#[derive(Clone, Default)]
pub(crate) struct Workspace {
    /// The dense work column (of refactorisations too), zero between calls.
    pub(crate) column: Vec<f64>,
    /// The reach of a column in topological order, filled from the end.
    reach: Vec<u32>,
    /// Depth-first search: the rows on the path and where each resumes in its column of `L`.
    path: Vec<u32>,
    resume: Vec<u32>,
    /// `mark[i] == stamp` once row `i` is in the current column's reach.
    mark: Vec<u32>,
}

impl Workspace {
    /// Work arrays for `n` unknowns.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            column: vec![0.0; n],
            reach: vec![0; n],
            path: Vec::with_capacity(n),
            resume: Vec::with_capacity(n),
            mark: vec![0; n],
        }
    }
}

/// Factorises `P A Q = L U` with the column order of `o` (`o.col_fwd[k]` eliminated at step
/// `k`) into `o.own`, setting its row order. A column's pivot is the largest candidate (partial
/// pivoting) or, where `o` prefers a row for the column, that row while it is at least
/// [`PIVOT_THRESHOLD`] times the largest (the test a refactorisation keeps pivots by). Errors
/// name the unknown (column) whose elimination failed.
///
/// Column `k` is the sparse triangular solve `L⁻¹ A(:, col_fwd[k])`: its pattern is the set of
/// rows reachable from the column's entries in the graph of the `L` built so far (depth-first
/// search, which also gives a topological order), so the work is proportional to the arithmetic.
pub(crate) fn factorise(
    a: &Csc<'_>,
    o: &mut Ordered,
    ws: &mut Workspace,
) -> Result<(), LinearSolveError> {
    let mut x = std::mem::take(&mut ws.column);
    let done = eliminate(a, o, &mut x, ws);
    ws.column = x;
    done
}

/// [`factorise`] with its dense work column `x` (zero on entry and on return) taken out of `ws`.
fn eliminate(
    a: &Csc<'_>,
    o: &mut Ordered,
    x: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), LinearSolveError> {
    let Ordered {
        col_fwd: order,
        row_perm,
        row_perm_inv: pinv,
        preferred,
        own: out,
        ..
    } = o;
    let n = order.len();
    out.valid = false;
    pinv.fill(UNPIVOTED);
    ws.mark.fill(0);
    for v in [&mut out.l_ptr, &mut out.u_ptr] {
        v.clear();
        v.push(0);
    }
    out.l_row.clear();
    out.l_val.clear();
    out.u_row.clear();
    out.u_val.clear();
    for (k, &col) in order.iter().enumerate() {
        let col = col as usize;
        let stamp = k as u32 + 1;
        let (start, end) = (a.col_ptr[col] as usize, a.col_ptr[col + 1] as usize);
        // The reach of the column's rows through L, in topological order at reach[top..].
        let mut top = n;
        for &r in &a.row_idx[start..end] {
            if ws.mark[r as usize] != stamp {
                top = reach_from(r, stamp, top, out, pinv, ws);
            }
        }
        for p in start..end {
            x[a.row_idx[p] as usize] = a.val[p];
        }
        for &j in &ws.reach[top..] {
            let step = pinv[j as usize];
            if step == UNPIVOTED {
                continue;
            }
            let xj = x[j as usize];
            if xj != 0.0 {
                let step = step as usize;
                for q in out.l_ptr[step] as usize + 1..out.l_ptr[step + 1] as usize {
                    x[out.l_row[q] as usize] -= out.l_val[q] * xj;
                }
            }
        }
        // Rows already pivoted go to U, in the reach's topological order (the order a
        // refactorisation eliminates them in); the others are candidates for the pivot.
        let mut pivot_row = UNPIVOTED;
        let mut candidates = false;
        let mut largest = 0.0_f64;
        for &i in &ws.reach[top..] {
            let xi = x[i as usize];
            match pinv[i as usize] {
                UNPIVOTED => {
                    candidates = true;
                    if xi.abs() > largest {
                        largest = xi.abs();
                        pivot_row = i;
                    }
                }
                step => {
                    out.u_row.push(step);
                    out.u_val.push(xi);
                }
            }
        }
        if pivot_row == UNPIVOTED {
            // No candidate left, or every one zero (or NaN, after an earlier zero pivot).
            clear(x, &ws.reach[top..]);
            return Err(if candidates {
                LinearSolveError::NumericallySingular { index: col }
            } else {
                LinearSolveError::StructurallySingular { index: col }
            });
        }
        if let Some(preferred) = preferred {
            let d = preferred[col];
            if pinv[d as usize] == UNPIVOTED && x[d as usize].abs() >= PIVOT_THRESHOLD * largest {
                pivot_row = d;
            }
        }
        let pivot = x[pivot_row as usize];
        pinv[pivot_row as usize] = k as u32;
        row_perm[k] = pivot_row;
        out.u_row.push(k as u32);
        out.u_val.push(pivot);
        out.u_ptr.push(out.u_row.len() as u32);
        // L's column: the pivot row first (unit diagonal), then the multipliers, still in the
        // matrix's row numbering until every row has its pivot step.
        out.l_row.push(pivot_row);
        out.l_val.push(1.0);
        for &i in &ws.reach[top..] {
            if pinv[i as usize] == UNPIVOTED {
                out.l_row.push(i);
                out.l_val.push(x[i as usize] / pivot);
            }
        }
        out.l_ptr.push(out.l_row.len() as u32);
        clear(x, &ws.reach[top..]);
    }
    for r in &mut out.l_row {
        *r = pinv[*r as usize];
    }
    out.valid = true;
    Ok(())
}

/// Sets `x` back to zero on `rows`.
fn clear(x: &mut [f64], rows: &[u32]) {
    for &i in rows {
        x[i as usize] = 0.0;
    }
}

/// Depth-first search from row `root` through the columns of `L` of the rows already pivoted,
/// marking what it visits with `stamp` and listing the rows in reverse finishing order before
/// `ws.reach[top]`; returns the new top.
fn reach_from(
    root: u32,
    stamp: u32,
    mut top: usize,
    l: &Triangular,
    pinv: &[u32],
    ws: &mut Workspace,
) -> usize {
    ws.path.clear();
    ws.resume.clear();
    ws.path.push(root);
    ws.mark[root as usize] = stamp;
    ws.resume.push(first_child(root, l, pinv));
    while let Some(&j) = ws.path.last() {
        let depth = ws.path.len() - 1;
        let step = pinv[j as usize];
        let end = if step == UNPIVOTED {
            0
        } else {
            l.l_ptr[step as usize + 1]
        };
        let mut p = ws.resume[depth];
        let mut child = None;
        while p < end {
            let i = l.l_row[p as usize];
            p += 1;
            if ws.mark[i as usize] != stamp {
                child = Some(i);
                break;
            }
        }
        ws.resume[depth] = p;
        match child {
            Some(i) => {
                ws.mark[i as usize] = stamp;
                ws.path.push(i);
                ws.resume.push(first_child(i, l, pinv));
            }
            None => {
                ws.path.pop();
                ws.resume.pop();
                top -= 1;
                ws.reach[top] = j;
            }
        }
    }
    top
}

/// Where the children of row `j` start in `L`: after the diagonal entry of its pivot step's
/// column, or nowhere (0, with an end of 0) if it has none yet.
fn first_child(j: u32, l: &Triangular, pinv: &[u32]) -> u32 {
    match pinv[j as usize] {
        UNPIVOTED => 0,
        step => l.l_ptr[step as usize] + 1,
    }
}
