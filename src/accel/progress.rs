//! How far a build is, and whether it is still wanted. The app builds on a worker thread:
//! the UI shows the triangles placed so far, and a newer request (another structure, another
//! scene) abandons the build in flight, so nothing queues behind a slow structure.
//!
//! An abandoned builder does not unwind: it stops choosing splits (the costly part) and
//! finishes the tree by the cheapest rule that keeps it valid, and `structure::build`
//! then answers `StructureError::Abandoned` instead of a tree nobody asked for.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

/// Progress counting and abandonment for one build; the default counts nothing and is
/// never abandoned.
#[derive(Clone, Copy, Default)]
pub struct BuildProgress<'a> {
    /// Triangles placed in finished subtrees.
    placed: Option<&'a AtomicUsize>,
    /// Abandoned once the counter passes the mark: the counter is the number of the newest
    /// request that replaces this build, the mark the number of the request it serves.
    abandon: Option<(&'a AtomicU64, u64)>,
}

impl<'a> BuildProgress<'a> {
    /// Counts placed triangles into `placed`.
    pub fn counting(placed: &'a AtomicUsize) -> Self {
        BuildProgress {
            placed: Some(placed),
            abandon: None,
        }
    }

    /// The same, abandoned once `newest` is greater than `request`.
    pub fn abandoned_after(self, newest: &'a AtomicU64, request: u64) -> Self {
        BuildProgress {
            abandon: Some((newest, request)),
            ..self
        }
    }

    /// `n` more triangles placed.
    pub fn add(&self, n: usize) {
        if let Some(placed) = self.placed {
            placed.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// All `n` triangles placed (builders that do not count as they go).
    pub fn finish(&self, n: usize) {
        if let Some(placed) = self.placed {
            placed.store(n, Ordering::Relaxed);
        }
    }

    /// Whether a newer request replaced this build.
    pub fn is_abandoned(&self) -> bool {
        self.abandon
            .is_some_and(|(newest, request)| newest.load(Ordering::Relaxed) > request)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_is_abandoned_only_by_a_newer_request() {
        let placed = AtomicUsize::new(0);
        let newest = AtomicU64::new(7);
        let p = BuildProgress::counting(&placed).abandoned_after(&newest, 7);
        p.add(3);
        p.add(4);
        assert_eq!(placed.load(Ordering::Relaxed), 7);
        assert!(!p.is_abandoned());
        newest.store(8, Ordering::Relaxed);
        assert!(p.is_abandoned());
        p.finish(10);
        assert_eq!(placed.load(Ordering::Relaxed), 10);
        let quiet = BuildProgress::default();
        quiet.add(5);
        assert!(!quiet.is_abandoned());
    }
}
