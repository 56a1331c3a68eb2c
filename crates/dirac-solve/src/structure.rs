//! Structural analysis of a sparse system: a maximum matching of equations to unknowns and the
//! coarse Dulmage–Mendelsohn partition into under-, well- and over-determined parts.
//!
//! The analysis looks only at which unknowns each equation contains (its pattern), not at values,
//! so it finds what no choice of values can repair: an unknown no equation can determine (a node
//! with no DC path, a velocity fixed only by a differentiated constraint) or equations that
//! over-determine their unknowns (a capacitor across a voltage source fixes a charge twice). Callers
//! use it to decide which equations of an algebraic system to solve, which unknowns are free, and
//! which equations are consistency conditions to check instead of solve.

/// Pattern of a sparse system with `rows` equations and `cols` unknowns, analysed once.
#[derive(Debug, Clone)]
pub struct Structure {
    rows: usize,
    cols: usize,
    col_of_row: Vec<usize>,
    row_of_col: Vec<usize>,
    under_row: Vec<bool>,
    under_col: Vec<bool>,
    over_row: Vec<bool>,
    over_col: Vec<bool>,
}

/// Marks an unmatched row or column.
const NONE: usize = usize::MAX;

impl Structure {
    /// Analyses the pattern `entries` (`(row, col)`, duplicates allowed) of a `rows × cols` system.
    ///
    /// Rows are matched in the order given, each to the first free column of `col_priority`
    /// order (lower first; ties by index), before augmenting paths complete the matching. An
    /// augmentation never unmatches a matched row or column, so when the matching is not perfect
    /// the earlier rows and the preferred columns are the ones kept.
    ///
    /// # Panics
    /// If an entry lies outside `rows × cols` or `col_priority` has the wrong length (programming
    /// errors of the caller).
    #[must_use]
    pub fn analyse(
        rows: usize,
        cols: usize,
        entries: &[(usize, usize)],
        col_priority: &[u8],
    ) -> Self {
        assert_eq!(col_priority.len(), cols, "one priority per column");
        let adjacency = Csr::new(rows, cols, entries, col_priority);
        let (col_of_row, row_of_col) = maximum_matching(&adjacency, rows, cols);
        let transpose = adjacency.transpose(cols);
        let mut s = Self {
            rows,
            cols,
            col_of_row,
            row_of_col,
            under_row: vec![false; rows],
            under_col: vec![false; cols],
            over_row: vec![false; rows],
            over_col: vec![false; cols],
        };
        s.mark_underdetermined(&transpose);
        s.mark_overdetermined(&adjacency);
        s
    }

    /// Columns reachable from an unmatched column by alternating paths (column → any row that
    /// contains it → that row's matched column): the unknowns the equations cannot all fix.
    fn mark_underdetermined(&mut self, transpose: &Csr) {
        let mut stack: Vec<usize> = (0..self.cols)
            .filter(|&c| self.row_of_col[c] == NONE)
            .collect();
        for &c in &stack {
            self.under_col[c] = true;
        }
        while let Some(c) = stack.pop() {
            for &r in transpose.row(c) {
                if self.under_row[r] {
                    continue;
                }
                self.under_row[r] = true;
                let next = self.col_of_row[r];
                if next != NONE && !self.under_col[next] {
                    self.under_col[next] = true;
                    stack.push(next);
                }
            }
        }
    }

    /// Rows reachable from an unmatched row by alternating paths (row → any column it contains →
    /// that column's matched row): equations that over-determine their unknowns.
    fn mark_overdetermined(&mut self, adjacency: &Csr) {
        let mut stack: Vec<usize> = (0..self.rows)
            .filter(|&r| self.col_of_row[r] == NONE)
            .collect();
        for &r in &stack {
            self.over_row[r] = true;
        }
        while let Some(r) = stack.pop() {
            for &c in adjacency.row(r) {
                if self.over_col[c] {
                    continue;
                }
                self.over_col[c] = true;
                let next = self.row_of_col[c];
                if next != NONE && !self.over_row[next] {
                    self.over_row[next] = true;
                    stack.push(next);
                }
            }
        }
    }

    /// Number of equations.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of unknowns.
    #[must_use]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Whether the square `n × n` pattern of the triplets `(rows[t], cols[t])` (duplicates
    /// allowed) has a perfect matching, i.e. admits a nonsingular matrix. A cheaper test than
    /// [`Structure::analyse`] (one column-compressed copy and an augmenting-path search, no
    /// partition) for callers that need the partition only when the answer is no.
    ///
    /// # Panics
    /// If `rows` and `cols` differ in length or an entry lies outside `n × n` (programming
    /// errors of the caller).
    #[must_use]
    pub fn has_perfect_matching(n: usize, rows: &[usize], cols: &[usize]) -> bool {
        assert_eq!(rows.len(), cols.len(), "one column per row index");
        if u32::try_from(n.max(rows.len())).is_err() {
            let entries: Vec<(usize, usize)> =
                rows.iter().copied().zip(cols.iter().copied()).collect();
            return Self::analyse(n, n, &entries, &vec![0; n]).rank() == n;
        }
        // Column-compressed, 32-bit (both sizes checked above).
        let mut col_ptr = vec![0_u32; n + 1];
        for &c in cols {
            assert!(c < n, "entry in column {c} outside {n}x{n}");
            col_ptr[c + 1] += 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let mut fill = col_ptr.clone();
        let mut row_idx = vec![0_u32; rows.len()];
        for (&r, &c) in rows.iter().zip(cols) {
            assert!(r < n, "entry in row {r} outside {n}x{n}");
            row_idx[fill[c] as usize] = r as u32;
            fill[c] += 1;
        }
        crate::sparse::maximum_matching(n, &col_ptr, &row_idx, false).is_ok()
    }

    /// The structural rank: the size of a maximum matching.
    #[must_use]
    pub fn rank(&self) -> usize {
        self.col_of_row.iter().filter(|&&c| c != NONE).count()
    }

    /// The unknown equation `row` is matched to, if any.
    #[must_use]
    pub fn matched_col(&self, row: usize) -> Option<usize> {
        Some(self.col_of_row[row]).filter(|&c| c != NONE)
    }

    /// The equation unknown `col` is matched to, if any.
    #[must_use]
    pub fn matched_row(&self, col: usize) -> Option<usize> {
        Some(self.row_of_col[col]).filter(|&r| r != NONE)
    }

    /// Whether unknown `col` lies in the under-determined part (no matching can fix it together
    /// with all the others there).
    #[must_use]
    pub fn is_underdetermined_col(&self, col: usize) -> bool {
        self.under_col[col]
    }

    /// Whether equation `row` lies in the under-determined part.
    #[must_use]
    pub fn is_underdetermined_row(&self, row: usize) -> bool {
        self.under_row[row]
    }

    /// Whether equation `row` lies in the over-determined part (with the other rows there it fixes
    /// its unknowns more than once: a consistency condition).
    #[must_use]
    pub fn is_overdetermined_row(&self, row: usize) -> bool {
        self.over_row[row]
    }

    /// Whether unknown `col` lies in the over-determined part.
    #[must_use]
    pub fn is_overdetermined_col(&self, col: usize) -> bool {
        self.over_col[col]
    }

    /// Unmatched unknowns (free: a square subsystem remains when they are fixed).
    pub fn unmatched_cols(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.cols).filter(|&c| self.row_of_col[c] == NONE)
    }

    /// Unmatched equations (redundant or contradictory: a square subsystem remains without them).
    pub fn unmatched_rows(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.rows).filter(|&r| self.col_of_row[r] == NONE)
    }
}

/// Compressed rows: the columns of each row, in priority order.
struct Csr {
    start: Vec<usize>,
    index: Vec<usize>,
}

impl Csr {
    fn new(rows: usize, cols: usize, entries: &[(usize, usize)], priority: &[u8]) -> Self {
        let mut count = vec![0usize; rows + 1];
        for &(r, c) in entries {
            assert!(
                r < rows && c < cols,
                "entry ({r}, {c}) outside {rows}x{cols}"
            );
            count[r + 1] += 1;
        }
        for r in 0..rows {
            count[r + 1] += count[r];
        }
        let mut fill = count.clone();
        let mut index = vec![0usize; entries.len()];
        for &(r, c) in entries {
            index[fill[r]] = c;
            fill[r] += 1;
        }
        for r in 0..rows {
            let row = &mut index[count[r]..count[r + 1]];
            row.sort_unstable_by_key(|&c| (priority[c], c));
        }
        let mut csr = Self {
            start: count,
            index,
        };
        csr.dedup(rows);
        csr
    }

    fn dedup(&mut self, rows: usize) {
        let mut out = Vec::with_capacity(self.index.len());
        let mut start = vec![0usize; rows + 1];
        for r in 0..rows {
            let row = &self.index[self.start[r]..self.start[r + 1]];
            for (i, &c) in row.iter().enumerate() {
                if !row[..i].contains(&c) {
                    out.push(c);
                }
            }
            start[r + 1] = out.len();
        }
        self.start = start;
        self.index = out;
    }

    fn row(&self, r: usize) -> &[usize] {
        &self.index[self.start[r]..self.start[r + 1]]
    }

    fn transpose(&self, cols: usize) -> Self {
        let rows = self.start.len() - 1;
        let mut count = vec![0usize; cols + 1];
        for &c in &self.index {
            count[c + 1] += 1;
        }
        for c in 0..cols {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut index = vec![0usize; self.index.len()];
        for r in 0..rows {
            for &c in self.row(r) {
                index[fill[c]] = r;
                fill[c] += 1;
            }
        }
        Self {
            start: count,
            index,
        }
    }
}

/// Hopcroft–Karp after a greedy pass in priority order; iterative, so long alternating paths (a
/// ladder of 10⁵ sections) cannot overflow the stack.
fn maximum_matching(adjacency: &Csr, rows: usize, cols: usize) -> (Vec<usize>, Vec<usize>) {
    let mut col_of_row = vec![NONE; rows];
    let mut row_of_col = vec![NONE; cols];
    for (r, matched) in col_of_row.iter_mut().enumerate() {
        if let Some(&c) = adjacency.row(r).iter().find(|&&c| row_of_col[c] == NONE) {
            *matched = c;
            row_of_col[c] = r;
        }
    }
    let mut layer = vec![0usize; rows];
    let mut queue = Vec::with_capacity(rows);
    let mut cursor = vec![0usize; rows];
    let mut path: Vec<usize> = Vec::new();
    loop {
        // Breadth-first layering from the free rows.
        queue.clear();
        for r in 0..rows {
            if col_of_row[r] == NONE {
                layer[r] = 0;
                queue.push(r);
            } else {
                layer[r] = usize::MAX;
            }
        }
        let mut found = false;
        let mut head = 0;
        while head < queue.len() {
            let r = queue[head];
            head += 1;
            for &c in adjacency.row(r) {
                let next = row_of_col[c];
                if next == NONE {
                    found = true;
                } else if layer[next] == usize::MAX {
                    layer[next] = layer[r] + 1;
                    queue.push(next);
                }
            }
        }
        if !found {
            break;
        }
        // Depth-first augmentation along the layers, one free row at a time.
        cursor.iter_mut().enumerate().for_each(|(r, k)| {
            *k = adjacency.start[r];
        });
        for root in 0..rows {
            if col_of_row[root] != NONE {
                continue;
            }
            path.clear();
            path.push(root);
            while let Some(&r) = path.last() {
                let end = adjacency.start[r + 1];
                let mut advanced = false;
                while cursor[r] < end {
                    let c = adjacency.index[cursor[r]];
                    cursor[r] += 1;
                    let next = row_of_col[c];
                    if next == NONE {
                        // Augment: flip the path root → … → r → c.
                        let mut col = c;
                        for &row in path.iter().rev() {
                            let previous = col_of_row[row];
                            col_of_row[row] = col;
                            row_of_col[col] = row;
                            col = previous;
                        }
                        path.clear();
                        advanced = true;
                        break;
                    }
                    if layer[next] == layer[r] + 1 {
                        path.push(next);
                        advanced = true;
                        break;
                    }
                }
                if !advanced {
                    layer[r] = usize::MAX;
                    path.pop();
                }
            }
        }
    }
    (col_of_row, row_of_col)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `has_perfect_matching` (MC21's augmenting paths over columns) agrees with the rank of
    /// [`Structure::analyse`] (Hopcroft–Karp over rows) on random square patterns with
    /// duplicates, both answers occurring, and on the empty pattern.
    #[test]
    fn perfect_matching_test_agrees_with_the_full_analysis() {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = |m: usize| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) as usize % m
        };
        let (mut full, mut deficient) = (0, 0);
        for _ in 0..2000 {
            let n = 1 + next(12);
            let count = next(3 * n + 1);
            let (rows, cols): (Vec<usize>, Vec<usize>) =
                (0..count).map(|_| (next(n), next(n))).unzip();
            let entries: Vec<(usize, usize)> =
                rows.iter().copied().zip(cols.iter().copied()).collect();
            let expected = flat(n, n, &entries).rank() == n;
            assert_eq!(
                Structure::has_perfect_matching(n, &rows, &cols),
                expected,
                "{n}x{n}: {entries:?}"
            );
            if expected {
                full += 1;
            } else {
                deficient += 1;
            }
        }
        assert!(
            full > 100 && deficient > 100,
            "{full} full, {deficient} deficient"
        );
        assert!(Structure::has_perfect_matching(0, &[], &[]));
        assert!(!Structure::has_perfect_matching(1, &[], &[]));
    }

    fn flat(rows: usize, cols: usize, entries: &[(usize, usize)]) -> Structure {
        Structure::analyse(rows, cols, entries, &vec![0; cols])
    }

    /// A structurally nonsingular square pattern has full rank and no under- or over-determined
    /// part; the greedy pass alone would match only 2 of 3 (row 0 takes column 0, which row 1
    /// needs), so the augmenting path is exercised.
    #[test]
    fn square_pattern_is_matched_completely() {
        let s = flat(3, 3, &[(0, 0), (0, 1), (1, 0), (2, 1), (2, 2)]);
        assert_eq!(s.rank(), 3);
        assert_eq!(s.matched_col(1), Some(0));
        assert_eq!(s.matched_col(0), Some(1));
        assert_eq!(s.matched_col(2), Some(2));
        assert!((0..3).all(|c| !s.is_underdetermined_col(c) && !s.is_overdetermined_col(c)));
    }

    /// A capacitor across a voltage source: two equations (q/C = e and e = V) fix the one node
    /// potential e; a third unknown (the loop current) appears only in KCL with a second unknown.
    /// Dulmage–Mendelsohn: {q/C, V} × {e} over-determined, {KCL} × {i_C, i_V} under-determined.
    #[test]
    fn capacitor_across_source_is_over_and_under_determined() {
        // rows: 0 = capacitor (e), 1 = source (e), 2 = KCL (i_C, i_V); cols: 0 = e, 1 = i_C, 2 = i_V
        let s = flat(3, 3, &[(0, 0), (1, 0), (2, 1), (2, 2)]);
        assert_eq!(s.rank(), 2);
        assert!(s.is_overdetermined_row(0) && s.is_overdetermined_row(1));
        assert!(s.is_overdetermined_col(0));
        assert!(s.is_underdetermined_col(1) && s.is_underdetermined_col(2));
        assert!(s.is_underdetermined_row(2));
        assert_eq!(s.unmatched_rows().count(), 1);
        assert_eq!(s.unmatched_cols().count(), 1);
    }

    /// Rows listed first keep their match; among columns the lower priority is matched first.
    #[test]
    fn priorities_choose_what_stays_matched() {
        // Two rows on one column: the first row wins.
        let s = flat(2, 1, &[(1, 0), (0, 0)]);
        assert_eq!(s.matched_col(0), Some(0));
        assert_eq!(s.unmatched_rows().collect::<Vec<_>>(), vec![1]);
        // One row on two columns: the preferred column wins.
        let s = Structure::analyse(1, 2, &[(0, 0), (0, 1)], &[1, 0]);
        assert_eq!(s.matched_col(0), Some(1));
        assert_eq!(s.unmatched_cols().collect::<Vec<_>>(), vec![0]);
    }

    /// A pattern whose greedy matching leaves the last row unmatched: rows `r < n − 1` contain
    /// columns `r, r + 1` (greedy takes `r`), the last row only column 0. One augmenting path
    /// through all `n` rows completes it, iteratively.
    #[test]
    fn long_alternating_paths_do_not_recurse() {
        let n = 200_000;
        let mut entries = Vec::with_capacity(2 * n);
        for r in 0..n - 1 {
            entries.push((r, r));
            entries.push((r, r + 1));
        }
        entries.push((n - 1, 0));
        let s = flat(n, n, &entries);
        assert_eq!(s.rank(), n);
        assert_eq!(s.matched_col(n - 1), Some(0));
    }

    /// Duplicated entries count once.
    #[test]
    fn duplicates_are_harmless() {
        let s = flat(2, 2, &[(0, 0), (0, 0), (1, 1), (1, 1), (1, 0)]);
        assert_eq!(s.rank(), 2);
    }
}
