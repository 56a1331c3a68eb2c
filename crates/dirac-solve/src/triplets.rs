//! A fixed-pattern stream of `(row, col, value)` entries.

use thiserror::Error;

/// A stream of matrix entries `(row, col, value)` whose pattern is fixed after the first pass.
///
/// The first pass records the pattern; [`Triplets::freeze`] fixes it; every later pass (started by
/// [`Triplets::begin`]) must emit the same `(row, col)` sequence and only refreshes the values.
/// Duplicate positions are allowed and are summed by consumers. This is how models stamp their
/// derivatives and how step residuals stamp Jacobians without allocating in the step loop.
#[derive(Debug, Clone, Default)]
pub struct Triplets {
    rows: Vec<usize>,
    cols: Vec<usize>,
    values: Vec<f64>,
    cursor: usize,
    frozen: bool,
    mismatch: Option<usize>,
    row_offset: usize,
    col_offset: usize,
}

/// The `(row, col)` sequence of a refill pass differed from the recorded pattern.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error(
    "entry {index} of the derivative pattern changed between evaluations (patterns must be fixed)"
)]
pub struct PatternMismatch {
    /// Index of the first entry that differed (or the recorded length if the count differed).
    pub index: usize,
}

impl Triplets {
    /// Entries reserved when the first entry is recorded.
    const FIRST_CAPACITY: usize = 32;

    /// An empty stream in recording mode.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a pass: in recording mode clears everything, once frozen rewinds the cursor.
    pub fn begin(&mut self) {
        self.cursor = 0;
        self.mismatch = None;
        self.row_offset = 0;
        self.col_offset = 0;
        if !self.frozen {
            self.rows.clear();
            self.cols.clear();
            self.values.clear();
        }
    }

    /// Fixes the recorded pattern; later passes only refill values.
    pub fn freeze(&mut self) {
        self.frozen = true;
    }

    /// Whether the pattern is fixed.
    #[must_use]
    pub fn is_frozen(&self) -> bool {
        self.frozen
    }

    /// Shifts every subsequent `add` by `(row_offset, col_offset)`, so a part can stamp its local
    /// derivatives straight into a global matrix. Reset to `(0, 0)` by [`Triplets::begin`].
    pub fn set_offset(&mut self, row_offset: usize, col_offset: usize) {
        self.row_offset = row_offset;
        self.col_offset = col_offset;
    }

    /// Adds one entry (recording) or refreshes the value of the next entry (frozen).
    #[inline]
    pub fn add(&mut self, row: usize, col: usize, value: f64) {
        let (row, col) = (row + self.row_offset, col + self.col_offset);
        if self.frozen {
            let c = self.cursor;
            if c < self.rows.len() && self.rows[c] == row && self.cols[c] == col {
                self.values[c] = value;
            } else if self.mismatch.is_none() {
                self.mismatch = Some(c);
            }
            self.cursor += 1;
        } else {
            // The first entry reserves room for a small model's pattern, instead of growing
            // from empty through several reallocations (streams never written stay unallocated).
            if self.rows.capacity() == 0 {
                self.rows.reserve(Self::FIRST_CAPACITY);
                self.cols.reserve(Self::FIRST_CAPACITY);
                self.values.reserve(Self::FIRST_CAPACITY);
            }
            self.rows.push(row);
            self.cols.push(col);
            self.values.push(value);
        }
    }

    /// Checks that a refill pass emitted exactly the recorded pattern.
    pub fn finish(&self) -> Result<(), PatternMismatch> {
        match self.mismatch {
            Some(index) => Err(PatternMismatch { index }),
            None if self.frozen && self.cursor != self.rows.len() => Err(PatternMismatch {
                index: self.cursor.min(self.rows.len()),
            }),
            None => Ok(()),
        }
    }

    /// Number of entries in the pattern.
    #[must_use]
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether the pattern is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Row indices, one per entry.
    #[must_use]
    pub fn rows(&self) -> &[usize] {
        &self.rows
    }

    /// Column indices, one per entry.
    #[must_use]
    pub fn cols(&self) -> &[usize] {
        &self.cols
    }

    /// Values, one per entry.
    #[must_use]
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Iterates over `(row, col, value)`.
    pub fn iter(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        self.rows
            .iter()
            .zip(&self.cols)
            .zip(&self.values)
            .map(|((&r, &c), &v)| (r, c, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refill_keeps_pattern_and_detects_changes() {
        let mut t = Triplets::new();
        t.begin();
        t.add(0, 1, 2.0);
        t.add(1, 0, 3.0);
        t.freeze();
        t.begin();
        t.add(0, 1, 5.0);
        t.add(1, 0, 7.0);
        assert!(t.finish().is_ok());
        assert_eq!(t.values(), &[5.0, 7.0]);
        t.begin();
        t.add(0, 1, 5.0);
        t.add(1, 1, 7.0);
        assert_eq!(t.finish(), Err(PatternMismatch { index: 1 }));
        t.begin();
        t.add(0, 1, 5.0);
        assert_eq!(t.finish(), Err(PatternMismatch { index: 1 }));
    }
}
