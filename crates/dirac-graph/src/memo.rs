//! Analyses derived from an interconnection's structure, kept with the graph so that running the
//! same graph again (a benchmark's repeats, a parameter study re-running one circuit) does not
//! redo them.

use std::any::Any;
use std::sync::{Arc, Mutex, PoisonError};

/// Most analyses one memo keeps (a few representations × the constraint rows kept at different
/// starts); the oldest is dropped beyond this.
const CAPACITY: usize = 8;

type Entry = Arc<dyn Any + Send + Sync>;

/// A small store of analyses of one graph, shared by its clones: a clone of an unchanged
/// [`crate::Interconnection`] sees what the original stored, and adding a part or a connection
/// gives the graph a fresh, empty memo (the clones made before keep the old one, which still
/// describes them).
///
/// What is stored must be a function of the graph alone plus a key the caller checks in
/// [`StructureMemo::find`] (a representation, the constraint rows kept): the memo cannot tell
/// when a stored analysis has gone stale any other way.
#[derive(Clone, Default)]
pub struct StructureMemo(Arc<Mutex<Vec<Entry>>>);

impl StructureMemo {
    /// The most recently stored value of type `T` that `accept` takes.
    #[must_use]
    pub fn find<T: Any + Send + Sync>(&self, accept: impl Fn(&T) -> bool) -> Option<Arc<T>> {
        let entries = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        entries
            .iter()
            .rev()
            .filter_map(|e| Arc::clone(e).downcast::<T>().ok())
            .find(|t| accept(t))
    }

    /// Stores `value` (dropping the oldest entry beyond a handful).
    pub fn insert<T: Any + Send + Sync>(&self, value: Arc<T>) {
        let mut entries = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if entries.len() >= CAPACITY {
            entries.remove(0);
        }
        entries.push(value);
    }

    /// Number of stored analyses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).len()
    }

    /// Whether nothing is stored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl std::fmt::Debug for StructureMemo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "StructureMemo({} entries)", self.len())
    }
}
