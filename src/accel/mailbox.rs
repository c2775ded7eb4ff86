//! Mailboxing: a spatial structure (k-d tree, grid, octree) references a triangle from
//! every cell it overlaps, so a ray crossing several of those cells would test it several
//! times. The mailbox is a small per-ray record of the triangles already tested; a triangle
//! found in it is skipped. With mailboxing off the record still runs when counting, so the
//! repeated tests it would have saved are counted.
//!
//! The record is exact: a small open-addressed table on the stack, moving to a larger one on
//! the heap (doubling as it fills) only for rays that test very many triangles. Skipping a repeat never changes a hit: a
//! triangle's test does not depend on the cell it was found in, and a hit beyond the
//! current cell is kept as the best so far rather than thrown away.

use super::Stats;
use super::query::Query;
use super::replay::Step;
use super::stats::record;
use crate::geometry::{Intersector, Ray, Triangle};

/// Slots of the inline table (a power of two); it spills when three quarters are used.
const SLOTS: usize = 32;
const SPILL_AT: usize = SLOTS * 3 / 4;
const EMPTY: u32 = u32::MAX;

/// Set on a cell's stored triangle id when the triangle is listed in more than one cell:
/// only those can be met twice by a ray, so only those go through the mailbox (a triangle in
/// one cell needs no record, which keeps the per-ray record small and off the heap).
pub const SHARED: u32 = 1 << 31;

/// Marks the ids of triangles listed more than once with `SHARED`.
pub fn mark_shared(ids: &mut [u32], triangles: usize) {
    let mut seen = vec![0u8; triangles];
    for &id in ids.iter() {
        let s = &mut seen[id as usize];
        *s = s.saturating_add(1);
    }
    for id in ids.iter_mut() {
        if seen[*id as usize] > 1 {
            *id |= SHARED;
        }
    }
}

#[derive(Clone, Debug)]
pub struct Mailbox {
    /// Skip triangles already tested (the toggle); otherwise only count repeats.
    enabled: bool,
    slots: [u32; SLOTS],
    used: usize,
    /// The table once the inline one is three quarters full: a power-of-two size.
    spill: Vec<u32>,
}

impl Mailbox {
    #[inline(always)]
    pub fn new(enabled: bool) -> Self {
        Mailbox {
            enabled,
            slots: [EMPTY; SLOTS],
            used: 0,
            spill: Vec::new(),
        }
    }

    /// Whether triangle `tri` is to be tested now: false when mailboxing is on and this ray
    /// tested it already. A test that repeats an earlier one (mailboxing off) is counted.
    #[inline(always)]
    pub fn admit<S: Stats>(&mut self, tri: u32, stats: &mut S) -> bool {
        if !self.enabled && !S::COUNTING {
            return true;
        }
        if self.insert(tri) {
            return true;
        }
        if self.enabled {
            return false;
        }
        stats.repeated_test();
        true
    }

    /// Tests the triangles a cell lists (ids as cells store them, `SHARED` flagged) for the
    /// query, a hit beyond the cell included; whether the walk is over.
    #[inline(always)]
    pub fn test_cell<I: Intersector, S: Stats, Q: Query>(
        &mut self,
        ids: &[u32],
        triangles: &[Triangle],
        (data, ray): (&I::RayData, &Ray),
        query: &mut Q,
        stats: &mut S,
    ) -> bool {
        for &id in ids {
            let tri = id & !SHARED;
            if id & SHARED != 0 && !self.admit(tri, stats) {
                record(stats, || Step::Mailboxed {
                    triangle: tri.into(),
                });
                continue;
            }
            stats.triangle_test();
            let hit = I::intersect(data, ray, &triangles[tri as usize], ray.tmin, query.limit());
            record(stats, || Step::Triangle {
                triangle: tri.into(),
                t: hit.map(|h| h.t),
            });
            if let Some(h) = hit
                && query.offer(h, tri)
            {
                return true;
            }
        }
        false
    }

    /// Records `tri`; true if it was not recorded before.
    #[inline(always)]
    fn insert(&mut self, tri: u32) -> bool {
        if self.spill.is_empty() {
            if !insert_into(&mut self.slots, tri) {
                return false;
            }
            self.used += 1;
            if self.used == SPILL_AT {
                self.spill = grown(&self.slots, 4 * SLOTS);
            }
            return true;
        }
        if !insert_into(&mut self.spill, tri) {
            return false;
        }
        self.used += 1;
        if self.used * 4 >= self.spill.len() * 3 {
            self.spill = grown(&self.spill, 2 * self.spill.len());
        }
        true
    }
}

/// Fibonacci hashing spreads the consecutive ids of neighbouring triangles over a table of
/// `len` (a power of two) slots.
#[inline(always)]
fn slot(tri: u32, len: usize) -> usize {
    (tri.wrapping_mul(0x9E37_79B9) >> (32 - len.trailing_zeros())) as usize
}

/// Inserts `tri` into an open-addressed table with a free slot; false if it was there.
#[inline(always)]
fn insert_into(table: &mut [u32], tri: u32) -> bool {
    let mask = table.len() - 1;
    let mut i = slot(tri, table.len());
    loop {
        let s = table[i];
        if s == tri {
            return false;
        }
        if s == EMPTY {
            table[i] = tri;
            return true;
        }
        i = (i + 1) & mask;
    }
}

/// A table of `len` slots holding the entries of `table`.
#[cold]
fn grown(table: &[u32], len: usize) -> Vec<u32> {
    let mut out = vec![EMPTY; len];
    for &t in table.iter().filter(|&&t| t != EMPTY) {
        insert_into(&mut out, t);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Counters, NoStats};

    #[test]
    fn admits_each_triangle_once_when_enabled_even_past_the_inline_table() {
        let mut m = Mailbox::new(true);
        let mut c = Counters::default();
        let ids: Vec<u32> = (0..500).map(|k| k * 7 + 3).collect();
        for &t in &ids {
            assert!(m.admit(t, &mut c));
        }
        for &t in ids.iter().rev() {
            assert!(!m.admit(t, &mut c), "{t} admitted twice");
        }
        assert!(m.admit(1, &mut c));
        assert_eq!(c.repeated_tests, 0);
    }

    #[test]
    fn counts_repeats_when_disabled_and_costs_nothing_without_counting() {
        let mut m = Mailbox::new(false);
        let mut c = Counters::default();
        for t in [5, 9, 5, 5, 9, 2] {
            assert!(m.admit(t, &mut c));
        }
        assert_eq!(c.repeated_tests, 3);
        let mut m = Mailbox::new(false);
        for t in [5, 5, 5] {
            assert!(m.admit(t, &mut NoStats));
        }
        assert_eq!(
            m.used, 0,
            "nothing recorded when neither skipping nor counting"
        );
    }
}
