//! Column orders for [`SparseLu`](crate::SparseLu): COLAMD's fill-reducing order, and a split of
//! it into two independent halves whose columns are interleaved.
//!
//! On a long thin structure (a ladder network, a chain of bodies) COLAMD eliminates from one end
//! to the other, so every column of the triangular solves and of a refactorisation waits for the
//! one before it: the work is one chain of dependent loads, multiplies and stores, bound by their
//! latency rather than by the processor's throughput. Cut at a small separator in the middle, the
//! two halves do not touch each other until the separator, so each can be eliminated from its far
//! end towards it with almost no fill, and listing their columns alternately puts two independent chains
//! into the instruction stream, which an out-of-order core runs side by side (a synthetic
//! bidiagonal solve of 3000 unknowns: 14 ns per unknown as one chain, 6.8 ns as two). The order
//! stays a valid elimination order for any matrix; whether it pays is decided by its fill
//! against COLAMD's (see `SparseLu::analyse`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::{amd, colamd};

use crate::error::LinearSolveError;

/// Components smaller than this are not split: their chains are too short to matter.
const MIN_SPLIT: usize = 64;

/// A separator is accepted only if it holds at most this fraction of its component (`1/16`): the
/// columns eliminated last should be few, or the halves' fill into them costs more than the
/// overlap gains.
const MAX_SEPARATOR_SHARE: usize = 16;

/// Only structures whose every level has at most this many vertices are cut. The halves are
/// ordered level by level, which on a wide structure (a mesh) fills in like a band matrix of
/// the level width, far beyond COLAMD's order: an RC mesh of 30 × 30 nodes (3540 unknowns, levels
/// up to 88 wide) had 2.6× COLAMD's fill, and the factorisation that finds this out cost
/// its 200-step run 30 % more time. An RLC ladder's levels hold 2 vertices, a rigid chain's 12.
const MAX_WIDTH: usize = 16;

/// Breadth-first sweeps from the last level's vertex in search of a pseudo-peripheral vertex
/// (George and Liu); two or three usually suffice.
const SWEEPS: usize = 4;

/// COLAMD's column order of the pattern: `fwd[k]` is the column eliminated at step `k`.
pub(crate) fn colamd_order(
    pattern: SymbolicSparseColMatRef<'_, u32>,
) -> Result<Vec<u32>, LinearSolveError> {
    let (m, n) = (pattern.nrows(), pattern.ncols());
    let nnz = pattern.row_idx().len();
    let mut mem = MemBuffer::try_new(colamd::order_scratch::<u32>(m, n, nnz))
        .map_err(|_| LinearSolveError::Backend("out of memory for the column order".into()))?;
    let (mut fwd, mut inv) = (vec![0_u32; n], vec![0_u32; n]);
    colamd::order(
        &mut fwd,
        &mut inv,
        pattern,
        colamd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| LinearSolveError::Backend(format!("column order: {e}")))?;
    Ok(fwd)
}

/// A column order for pivots on a matching: `matched[c]` is the row paired with column `c` (a
/// perfect matching of the pattern). Relabelling every row by its column puts the pairs on the
/// diagonal; the order is AMD's for the pattern of that matrix plus its transpose, the order a
/// symmetric elimination with those diagonal pivots fills in least (KLU's order after its
/// maximum transversal). It pays only where the factorisation keeps the paired rows as pivots
/// (`pivoting::factorise` with preferred rows). Also returns AMD's count of the fill
/// `nnz(L) + nnz(U)` (each with its diagonal) of that order: a Cholesky factor's of the
/// symmetrised pattern, an upper bound where every pivot stays on its pair.
pub(crate) fn symmetric_order(
    pattern: SymbolicSparseColMatRef<'_, u32>,
    matched: &[u32],
) -> Result<(Vec<u32>, usize), LinearSolveError> {
    let n = pattern.ncols();
    let mut column_of_row = vec![0_u32; n];
    for (c, &r) in matched.iter().enumerate() {
        column_of_row[r as usize] = c as u32;
    }
    let relabelled: Vec<u32> = pattern
        .row_idx()
        .iter()
        .map(|&r| column_of_row[r as usize])
        .collect();
    let paired =
        SymbolicSparseColMatRef::new_unsorted_checked(n, n, pattern.col_ptr(), None, &relabelled);
    let mut mem = MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<u32>(
        n,
        relabelled.len(),
    ))
    .map_err(|_| LinearSolveError::Backend("out of memory for the column order".into()))?;
    let (mut fwd, mut inv) = (vec![0_u32; n], vec![0_u32; n]);
    let count = amd::order_maybe_unsorted(
        &mut fwd,
        &mut inv,
        paired,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| LinearSolveError::Backend(format!("column order: {e}")))?;
    // AMD's divisions of an LDLᵀ factorisation: one per entry below L's diagonal.
    let below = count.n_div as usize;
    Ok((fwd, 2 * (below + n)))
}

/// COLAMD's order `fwd` split so that independent dependency chains alternate, or `None` if no
/// component of the graph of `A + Aᵀ` is long and thin enough to cut.
///
/// A component of at least [`MIN_SPLIT`] vertices whose breadth-first levels from a
/// pseudo-peripheral vertex all hold at most [`MAX_WIDTH`] vertices is cut at the smallest level
/// of the middle third, if that level is at most `1/`[`MAX_SEPARATOR_SHARE`] of the component.
/// Each half is ordered from its far end towards the separator ([`towards_separator`]), a
/// component not cut in COLAMD's order (which also breaks ties); the columns of all these
/// sequences are listed alternately, then the separators. Components do not interact, nor do the
/// halves of a cut before its separator, so the alternation creates no fill.
pub(crate) fn split_order(
    pattern: SymbolicSparseColMatRef<'_, u32>,
    fwd: &[u32],
) -> Option<Vec<u32>> {
    let n = pattern.ncols();
    let graph = Graph::symmetric(pattern);
    let mut rank = vec![0_usize; n];
    for (k, &c) in fwd.iter().enumerate() {
        rank[c as usize] = k;
    }
    let mut visited = vec![false; n];
    let mut level = vec![usize::MAX; n];
    let mut sequences: Vec<Vec<u32>> = Vec::new();
    let mut separators: Vec<u32> = Vec::new();
    let mut cut_any = false;
    for &start in fwd {
        let start = start as usize;
        if visited[start] {
            continue;
        }
        let members = graph.reach(start, &mut visited);
        let cut = (members.len() >= MIN_SPLIT)
            .then(|| graph.bisect(&members, &mut level))
            .flatten();
        match cut {
            Some((near, far, separator)) => {
                cut_any = true;
                // `level` holds this component's levels until the next component is cut.
                sequences.push(towards_separator(near, &graph, &level, &rank, false));
                sequences.push(towards_separator(far, &graph, &level, &rank, true));
                separators.extend(by_rank(separator, &rank));
            }
            None => sequences.push(by_rank(members, &rank)),
        }
    }
    if !cut_any {
        return None;
    }
    // Longest first, so that the sequences still running at position `k` are a prefix.
    sequences.sort_by_key(|s| std::cmp::Reverse(s.len()));
    let mut order = Vec::with_capacity(n);
    let mut running = sequences.len();
    for k in 0..sequences.first().map_or(0, Vec::len) {
        while sequences[running - 1].len() <= k {
            running -= 1;
        }
        order.extend(sequences[..running].iter().map(|s| s[k]));
    }
    order.extend(separators);
    Some(order)
}

/// The vertices of one half in elimination order from its far end towards the separator: by
/// the deepest level in each one's closed neighbourhood (for the far half, the shallowest,
/// descending), then by COLAMD rank. A vertex's key is at least that of every neighbour on the
/// far side of it, so it comes after them or ties with them, and ties go by COLAMD's rank, which
/// puts a vertex hanging off a path (a capacitor's charge off its node's multiplier: equal keys)
/// before the vertex it hangs from. Ordered by their own levels instead, the hub would come first
/// and join the leaf to the hub's next neighbour: 11 % more fill on an RLC ladder than COLAMD's,
/// where this order has 0.2 % more.
fn towards_separator(
    vertices: Vec<usize>,
    graph: &Graph,
    level: &[usize],
    rank: &[usize],
    far: bool,
) -> Vec<u32> {
    let mut keyed: Vec<(usize, usize, usize)> = vertices
        .into_iter()
        .map(|v| {
            let hood = std::iter::once(v)
                .chain(graph.neighbours(v))
                .map(|w| level[w]);
            let key = if far {
                usize::MAX - hood.min().unwrap_or(0)
            } else {
                hood.max().unwrap_or(0)
            };
            (key, rank[v], v)
        })
        .collect();
    keyed.sort_unstable();
    // Indices fit in u32: the sparse LU checks its dimension against the 32-bit range.
    keyed.into_iter().map(|(_, _, v)| v as u32).collect()
}

/// `vertices` in COLAMD's order.
fn by_rank(mut vertices: Vec<usize>, rank: &[usize]) -> Vec<u32> {
    vertices.sort_unstable_by_key(|&v| rank[v]);
    vertices.into_iter().map(|v| v as u32).collect()
}

/// The adjacency of `A + Aᵀ` without the diagonal, in compressed rows.
struct Graph {
    ptr: Vec<usize>,
    adj: Vec<u32>,
}

impl Graph {
    fn symmetric(pattern: SymbolicSparseColMatRef<'_, u32>) -> Self {
        let n = pattern.ncols();
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        let mut degree = vec![0_usize; n + 1];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c] as usize..col_ptr[c + 1] as usize] {
                let r = r as usize;
                if r != c {
                    degree[r] += 1;
                    degree[c] += 1;
                }
            }
        }
        let mut ptr = vec![0_usize; n + 1];
        for v in 0..n {
            ptr[v + 1] = ptr[v] + degree[v];
        }
        let mut next = ptr.clone();
        let mut adj = vec![0_u32; ptr[n]];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c] as usize..col_ptr[c + 1] as usize] {
                let r = r as usize;
                if r != c {
                    adj[next[r]] = c as u32;
                    next[r] += 1;
                    adj[next[c]] = r as u32;
                    next[c] += 1;
                }
            }
        }
        // An entry stored on both sides of the diagonal gave its edge twice: keep each once.
        let mut seen = vec![usize::MAX; n];
        let mut kept = Vec::with_capacity(adj.len());
        let mut start = vec![0_usize; n + 1];
        for v in 0..n {
            for &w in &adj[ptr[v]..ptr[v + 1]] {
                if seen[w as usize] != v {
                    seen[w as usize] = v;
                    kept.push(w);
                }
            }
            start[v + 1] = kept.len();
        }
        Self {
            ptr: start,
            adj: kept,
        }
    }

    fn neighbours(&self, v: usize) -> impl Iterator<Item = usize> + '_ {
        self.adj[self.ptr[v]..self.ptr[v + 1]]
            .iter()
            .map(|&w| w as usize)
    }

    /// The vertices connected to `start`, each marked in `visited`.
    fn reach(&self, start: usize, visited: &mut [bool]) -> Vec<usize> {
        visited[start] = true;
        let mut members = vec![start];
        let mut head = 0;
        while let Some(&v) = members.get(head) {
            head += 1;
            for w in self.neighbours(v) {
                if !visited[w] {
                    visited[w] = true;
                    members.push(w);
                }
            }
        }
        members
    }

    /// Breadth-first levels from `root` over `members` (a connected component), written into
    /// `level`; returns the vertices in visiting order (the last is on the deepest level).
    fn levels(&self, root: usize, members: &[usize], level: &mut [usize]) -> Vec<usize> {
        for &v in members {
            level[v] = usize::MAX;
        }
        level[root] = 0;
        let mut queue = Vec::with_capacity(members.len());
        queue.push(root);
        let mut head = 0;
        while let Some(&v) = queue.get(head) {
            head += 1;
            for w in self.neighbours(v) {
                if level[w] == usize::MAX {
                    level[w] = level[v] + 1;
                    queue.push(w);
                }
            }
        }
        queue
    }

    /// Cuts the component `members` at the smallest level of the middle third of a level
    /// structure rooted at a pseudo-peripheral vertex (among equally small levels, the one
    /// nearest the middle):
    /// `(near half, far half, separator)`, or `None` if that level is too large a share of the
    /// component or the structure too shallow to have halves.
    fn bisect(
        &self,
        members: &[usize],
        level: &mut [usize],
    ) -> Option<(Vec<usize>, Vec<usize>, Vec<usize>)> {
        let mut root = members[0];
        let mut queue = self.levels(root, members, level);
        for _ in 0..SWEEPS {
            let last = *queue.last()?;
            let depth = level[last];
            // The vertex of least degree on the deepest level is the next root.
            let candidate = queue
                .iter()
                .rev()
                .take_while(|&&v| level[v] == depth)
                .copied()
                .min_by_key(|&v| self.ptr[v + 1] - self.ptr[v])?;
            let trial_queue = self.levels(candidate, members, level);
            let trial_depth = trial_queue.last().map_or(0, |&v| level[v]);
            if trial_depth <= depth {
                queue = self.levels(root, members, level);
                break;
            }
            root = candidate;
            queue = trial_queue;
        }
        let depth = queue.last().map_or(0, |&v| level[v]);
        if depth < 4 {
            return None;
        }
        let mut sizes = vec![0_usize; depth + 1];
        for &v in &queue {
            sizes[level[v]] += 1;
        }
        if sizes.iter().any(|&size| size > MAX_WIDTH) {
            return None;
        }
        let total = members.len();
        let mut before = 0;
        let mut best: Option<(usize, usize, usize)> = None;
        for (l, &size) in sizes.iter().enumerate() {
            let (start, end) = (before, before + size);
            before = end;
            if l == 0 || l == depth || 3 * start < total || 3 * end > 2 * total {
                continue;
            }
            let off_centre = (start + end).abs_diff(total);
            if best.is_none_or(|(s, o, _)| (size, off_centre) < (s, o)) {
                best = Some((size, off_centre, l));
            }
        }
        let (_, _, middle) = best?;
        let (mut near, mut far, mut separator) = (Vec::new(), Vec::new(), Vec::new());
        for &v in &queue {
            match level[v].cmp(&middle) {
                std::cmp::Ordering::Less => near.push(v),
                std::cmp::Ordering::Equal => separator.push(v),
                std::cmp::Ordering::Greater => far.push(v),
            }
        }
        (separator.len() * MAX_SEPARATOR_SHARE <= members.len()).then_some((near, far, separator))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{Pair, SymbolicSparseColMat};

    fn pattern(n: usize, entries: &[(usize, usize)]) -> SymbolicSparseColMat<u32> {
        let pairs: Vec<Pair<u32, u32>> = entries
            .iter()
            .map(|&(r, c)| Pair::new(r as u32, c as u32))
            .collect();
        SymbolicSparseColMat::try_new_from_indices(n, n, &pairs)
            .unwrap()
            .0
    }

    fn tridiagonal(n: usize) -> Vec<(usize, usize)> {
        let mut e = Vec::new();
        for i in 0..n {
            e.push((i, i));
            if i + 1 < n {
                e.push((i, i + 1));
                e.push((i + 1, i));
            }
        }
        e
    }

    fn is_permutation(order: &[u32], n: usize) -> bool {
        let mut seen = vec![false; n];
        order.len() == n
            && order
                .iter()
                .all(|&c| !std::mem::replace(&mut seen[c as usize], true))
    }

    /// On a path the split puts one vertex (the middle) last, and before it the two halves
    /// alternate, each running from its end of the path towards the middle: every column of
    /// either half has, among the columns after it, only its successor in its half (or the
    /// separator) as a neighbour, so the elimination creates no fill.
    #[test]
    fn a_path_splits_at_its_middle_into_two_alternating_halves() {
        let n = 1001;
        let p = pattern(n, &tridiagonal(n));
        let fwd = colamd_order(p.as_ref()).unwrap();
        assert!(is_permutation(&fwd, n));
        let order = split_order(p.as_ref(), &fwd).unwrap();
        assert!(is_permutation(&order, n));
        let separator = order[n - 1] as usize;
        assert!((separator as i64 - 500).abs() <= 1, "separator {separator}");
        let (evens, odds): (Vec<usize>, Vec<usize>) = (
            order[..n - 1]
                .iter()
                .step_by(2)
                .map(|&c| c as usize)
                .collect(),
            order[1..n - 1]
                .iter()
                .step_by(2)
                .map(|&c| c as usize)
                .collect(),
        );
        for half in [&evens, &odds] {
            // Consecutive path vertices, moving monotonically towards the separator.
            assert!(half.windows(2).all(|w| w[0].abs_diff(w[1]) == 1));
            let last = *half.last().unwrap();
            assert_eq!(last.abs_diff(separator), 1);
        }
        assert!(evens.iter().all(|&v| v < separator) || evens.iter().all(|&v| v > separator));
        assert_ne!(evens[0] < separator, odds[0] < separator);
    }

    /// A dense block has no small middle level, a mesh's levels are too wide to order level by
    /// level (its middle level is a small share of it, but the halves would fill in like a band
    /// matrix), and a short path is not worth splitting.
    #[test]
    fn compact_or_small_patterns_keep_colamd() {
        let n: usize = 200;
        let mut dense = Vec::new();
        for r in 0..n {
            for c in 0..n {
                if r.abs_diff(c) <= 40 {
                    dense.push((r, c));
                }
            }
        }
        let p = pattern(n, &dense);
        let fwd = colamd_order(p.as_ref()).unwrap();
        assert!(split_order(p.as_ref(), &fwd).is_none());
        let side = 40;
        let mut mesh = Vec::new();
        for i in 0..side * side {
            mesh.push((i, i));
            for j in [i + 1, i + side] {
                if j < side * side && (j != i + 1 || j % side != 0) {
                    mesh.push((i, j));
                    mesh.push((j, i));
                }
            }
        }
        let p = pattern(side * side, &mesh);
        let fwd = colamd_order(p.as_ref()).unwrap();
        assert!(split_order(p.as_ref(), &fwd).is_none());
        let short = pattern(40, &tridiagonal(40));
        let fwd = colamd_order(short.as_ref()).unwrap();
        assert!(split_order(short.as_ref(), &fwd).is_none());
    }

    /// Two separate paths: each is split, and all four halves alternate before the separators.
    #[test]
    fn separate_components_are_each_split_and_interleaved() {
        let m = 300;
        let mut e = tridiagonal(m);
        e.extend(tridiagonal(m).into_iter().map(|(r, c)| (r + m, c + m)));
        let p = pattern(2 * m, &e);
        let fwd = colamd_order(p.as_ref()).unwrap();
        let order = split_order(p.as_ref(), &fwd).unwrap();
        assert!(is_permutation(&order, 2 * m));
        let head: Vec<usize> = order[..4].iter().map(|&c| c as usize).collect();
        // The first four columns are the far ends of the four halves: two per path.
        assert_eq!(head.iter().filter(|&&v| v < m).count(), 2);
        assert!(head.iter().all(|&v| v % m == 0 || v % m == m - 1));
        let tail: Vec<usize> = order[2 * m - 2..].iter().map(|&c| c as usize).collect();
        assert_eq!(tail.iter().filter(|&&v| v < m).count(), 1);
    }
}
