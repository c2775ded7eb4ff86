//! The sweep's events kept sorted from a node to its children (Wald & Havran 2006): the
//! root sorts its events once per axis, and a split hands each child the events of the
//! references that go to it alone, already in order; only the references the plane cuts,
//! clipped to each child's cell, get new events, sorted apart and merged in. Each node then
//! costs time linear in its events instead of a sort, and finds the same split as sorting
//! them afresh (`split::best_split`): the sweep reads positions and types only, which sort
//! the same either way.

use super::KdParams;
use super::build::classify_into;
use super::split::{EVENT_BITS, KdRef, Split, best_split_in, event, sort_events_by};
use crate::geometry::{Aabb, Triangle};

/// Bits of an event below its position and type: the index of its reference in the node's
/// list. A node holds at most `MAX_TRIANGLES` (2^28) references: no child holds more than
/// its parent, nor the root more than the triangles.
const REF_BITS: u32 = 64 - EVENT_BITS;
const REF_MASK: u64 = (1 << REF_BITS) - 1;
const _: () = assert!(super::MAX_TRIANGLES as u64 <= 1 << REF_BITS);
/// `went`'s flag of a reference sent to the above child, and its mark of one cut.
const ABOVE: u32 = 1 << 31;
const CUT: u32 = u32::MAX;
const _: () = assert!(super::MAX_TRIANGLES < ABOVE as usize);

/// A node's events on each axis, each `event(position, type) << REF_BITS | reference`,
/// sorted by position and type.
pub(super) struct Events([Vec<u64>; 3]);

/// Nodes of fewer references sort their events afresh (`split::best_split`): for a few
/// dozen events a sort costs less than carrying the lists down.
pub(super) const KEPT_FROM: usize = 64;

impl Events {
    /// The events of `refs`, sorted: what the root starts from.
    pub(super) fn of(refs: &[KdRef]) -> Self {
        Events(std::array::from_fn(|axis| {
            sorted_events(refs.len(), (0..).zip(refs), axis)
        }))
    }

    /// The cheapest split of the node over `refs` in `cell` (`best_split`'s answer).
    pub(super) fn best_split(&self, refs: usize, cell: &Aabb, params: &KdParams) -> Option<Split> {
        best_split_in(&self.0, REF_BITS, refs, cell, params)
    }

    /// Splits the node over `refs` by `split`: each child's references (as `classify` sends
    /// them) and events. Consumes the node's events, which its children no longer need.
    pub(super) fn split(
        self,
        triangles: &[Triangle],
        refs: &[KdRef],
        split: &Split,
        cells: (&Aabb, &Aabb),
    ) -> ((Vec<KdRef>, Events), (Vec<KdRef>, Events)) {
        // Where each reference went: its place in one child's list with that child's
        // flag, or `CUT` (its events are made anew from its clipped bounds).
        let mut went = vec![0u32; refs.len()];
        let (mut cut_below, mut cut_above) = (Vec::new(), Vec::new());
        let (below, above) =
            classify_into(triangles, refs, split, cells, &mut |i, side| match side {
                Side::Cut => went[i] = CUT,
                Side::Below(at) if went[i] == CUT => cut_below.push(at),
                Side::Above(at) if went[i] == CUT => cut_above.push(at),
                Side::Below(at) => went[i] = at,
                Side::Above(at) => went[i] = at | ABOVE,
            });
        let Events(axes) = self;
        let mut below_events: [Vec<u64>; 3] = Default::default();
        let mut above_events: [Vec<u64>; 3] = Default::default();
        for (axis, events) in axes.into_iter().enumerate() {
            let new_below = cut_events(&cut_below, &below, axis);
            let new_above = cut_events(&cut_above, &above, axis);
            let mut b = Merge::new(2 * below.len(), &new_below);
            let mut a = Merge::new(2 * above.len(), &new_above);
            for e in events {
                let to = went[(e & REF_MASK) as usize];
                let head = e & !REF_MASK;
                if to == CUT {
                    continue;
                } else if to & ABOVE == 0 {
                    b.push(head | u64::from(to));
                } else {
                    a.push(head | u64::from(to & !ABOVE));
                }
            }
            below_events[axis] = b.finish();
            above_events[axis] = a.finish();
        }
        ((below, Events(below_events)), (above, Events(above_events)))
    }
}

/// Where `classify_into` sent a reference: to a place in a child's list, or first of all
/// that the plane cut it (it then also goes to one child or both, clipped).
pub(super) enum Side {
    Below(u32),
    Above(u32),
    Cut,
}

/// The events on `axis` of the cut references at places `at` of a child's list `child`,
/// sorted.
fn cut_events(at: &[u32], child: &[KdRef], axis: usize) -> Vec<u64> {
    sorted_events(at.len(), at.iter().map(|&k| (k, &child[k as usize])), axis)
}

/// The events on `axis` of `n` references, each with its place in the node's list, sorted.
fn sorted_events<'r>(
    n: usize,
    refs: impl Iterator<Item = (u32, &'r KdRef)>,
    axis: usize,
) -> Vec<u64> {
    let mut events = Vec::with_capacity(2 * n);
    for (k, r) in refs {
        let e = event(r.bounds.min[axis], r.bounds.max[axis]);
        events.extend(e.map(|e| e << REF_BITS | u64::from(k)));
    }
    sort_events_by(&mut events, REF_BITS);
    events
}

/// A child's events as they are filtered from its parent's, in order, with the cut
/// references' new events (sorted) merged in on the way.
struct Merge<'a> {
    out: Vec<u64>,
    new: &'a [u64],
}

impl<'a> Merge<'a> {
    fn new(capacity: usize, new: &'a [u64]) -> Self {
        Merge {
            out: Vec::with_capacity(capacity),
            new,
        }
    }

    #[inline(always)]
    fn push(&mut self, e: u64) {
        while let Some((&n, rest)) = self.new.split_first()
            && n >> REF_BITS < e >> REF_BITS
        {
            self.out.push(n);
            self.new = rest;
        }
        self.out.push(e);
    }

    fn finish(mut self) -> Vec<u64> {
        self.out.extend_from_slice(self.new);
        self.out
    }
}
