//! Where to split a k-d tree node: the surface area heuristic over candidate planes, with
//! the empty-space bonus. The sweep evaluates every perfect split (each reference's clipped
//! bounds, sorted as end, planar and start events per axis; Wald & Havran 2006); the binned
//! variant evaluates only the boundaries of equal-width bins, counting in O(N) per node.

use super::{KdParams, KdSplit};
use crate::geometry::Aabb;
use rayon::prelude::*;

/// A triangle as a node sees it: its scene index and its bounds clipped to the node's cell.
#[derive(Clone, Copy, Debug)]
pub struct KdRef {
    pub bounds: Aabb,
    pub tri: u32,
}

/// A candidate split plane and its SAH cost (relative to a leaf's C_isect·N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub axis: usize,
    pub pos: f32,
    /// Triangles lying in the plane go to the below side (else above).
    pub planar_below: bool,
    pub cost: f64,
    /// References on each side (those lying in the plane counted on theirs).
    pub below: usize,
    pub above: usize,
}

/// Nodes with at least this many events sort them by radix (`sort_events`), smaller ones by
/// comparisons.
const RADIX_SORT: usize = 1 << 9;
/// Nodes with at least this many references search their three axes in parallel.
const PARALLEL_AXES: usize = 1 << 14;

/// The SAH cost model of one node's cell.
struct Sah<'a> {
    params: &'a KdParams,
    cell: &'a Aabb,
    inv_area: f64,
    /// The cell's extents.
    extent: [f64; 3],
}

impl<'a> Sah<'a> {
    fn new(params: &'a KdParams, cell: &'a Aabb) -> Option<Self> {
        let extent = [0, 1, 2].map(|k| (cell.max[k] as f64 - cell.min[k] as f64).max(0.0));
        let [x, y, z] = extent;
        let area = 2.0 * (x * y + y * z + z * x);
        (area > 0.0).then(|| Sah {
            params,
            cell,
            inv_area: 1.0 / area,
            extent,
        })
    }

    /// C_trav + C_isect·(1 − bonus)·(P_below·N_below + P_above·N_above), with P the ratio of
    /// a child's surface area to the cell's: the chance a ray through the cell enters it.
    #[inline(always)]
    fn cost(&self, axis: usize, pos: f32, below: usize, above: usize) -> f64 {
        // A child of length l along `axis` has area 2·(e_b·e_c + (e_b + e_c)·l).
        let (eb, ec) = (self.extent[(axis + 1) % 3], self.extent[(axis + 2) % 3]);
        let (cap, side) = (eb * ec, eb + ec);
        let below_len = pos as f64 - self.cell.min[axis] as f64;
        let above_len = self.cell.max[axis] as f64 - pos as f64;
        let p_below = 2.0 * (cap + side * below_len) * self.inv_area;
        let p_above = 2.0 * (cap + side * above_len) * self.inv_area;
        let bonus = if below == 0 || above == 0 {
            self.params.empty_bonus as f64
        } else {
            0.0
        };
        self.params.c_trav as f64
            + self.params.c_isect as f64
                * (1.0 - bonus)
                * (p_below * below as f64 + p_above * above as f64)
    }

    /// Offers the plane at `pos` with `below` and `above` references besides `planar` ones
    /// lying in it, which may go to either side: `sink` sees each choice.
    fn offer(&self, sink: &mut impl FnMut(Split), axis: usize, pos: f32, c: Counts) {
        if !(pos > self.cell.min[axis] && pos < self.cell.max[axis]) {
            return;
        }
        let mut consider = |below: usize, above: usize, planar_below: bool| {
            sink(Split {
                axis,
                pos,
                planar_below,
                cost: self.cost(axis, pos, below, above),
                below,
                above,
            })
        };
        consider(c.below + c.planar, c.above, true);
        if c.planar > 0 {
            consider(c.below, c.above + c.planar, false);
        }
    }
}

/// Keeps the first of the cheapest splits offered.
fn keep_cheapest(best: &mut Option<Split>) -> impl FnMut(Split) + '_ {
    move |s: Split| {
        if best.is_none_or(|b| s.cost < b.cost) {
            *best = Some(s);
        }
    }
}

#[derive(Clone, Copy)]
struct Counts {
    below: usize,
    planar: usize,
    above: usize,
}

/// The cheapest split of the node over `refs` with cell `cell`, or `None` if its cell has no
/// area or no candidate lies strictly inside it.
pub fn best_split(refs: &[KdRef], cell: &Aabb, params: &KdParams) -> Option<Split> {
    let sah = Sah::new(params, cell)?;
    cheapest_of_axes(refs.len(), |axis, events, best| {
        let sink = &mut keep_cheapest(best);
        match params.split {
            KdSplit::Sweep => sweep(refs, axis, &sah, events, sink),
            KdSplit::Binned(bins) => binned(refs, axis, bins as usize, &sah, sink),
        }
    })
}

/// `best_split` by the sweep over a node's events already sorted on each axis (`axes`, each
/// event's position and type above `shift` bits; `refs` references).
pub(super) fn best_split_in(
    axes: &[Vec<u64>; 3],
    shift: u32,
    refs: usize,
    cell: &Aabb,
    params: &KdParams,
) -> Option<Split> {
    let sah = Sah::new(params, cell)?;
    cheapest_of_axes(refs, |axis, _, best| {
        sweep_sorted(
            &axes[axis],
            shift,
            refs,
            axis,
            &sah,
            &mut keep_cheapest(best),
        )
    })
}

/// The cheapest of the splits `search` offers on each axis (with a scratch list of events),
/// the first axis winning a tie; a node of many references searches its axes in parallel,
/// with the same choice.
fn cheapest_of_axes(
    refs: usize,
    search: impl Fn(usize, &mut Vec<u64>, &mut Option<Split>) + Sync,
) -> Option<Split> {
    if refs >= PARALLEL_AXES {
        let per_axis: Vec<Option<Split>> = (0..3)
            .into_par_iter()
            .map(|axis| {
                let mut best = None;
                search(axis, &mut Vec::new(), &mut best);
                best
            })
            .collect();
        return per_axis
            .into_iter()
            .flatten()
            .fold(None, |acc: Option<Split>, s| match acc {
                Some(a) if a.cost <= s.cost => Some(a),
                _ => Some(s),
            });
    }
    let mut best = None;
    let mut events = Vec::new();
    for axis in 0..3 {
        search(axis, &mut events, &mut best);
    }
    best
}

/// Every split `best_split` weighs, in its order (axis by axis): what the bucket-cost plot
/// draws. Empty if the cell has no area.
pub fn all_splits(refs: &[KdRef], cell: &Aabb, params: &KdParams) -> Vec<Split> {
    let mut all = Vec::new();
    let Some(sah) = Sah::new(params, cell) else {
        return all;
    };
    let mut events = Vec::new();
    let sink = &mut |s: Split| all.push(s);
    for axis in 0..3 {
        match params.split {
            KdSplit::Sweep => sweep(refs, axis, &sah, &mut events, sink),
            KdSplit::Binned(bins) => binned(refs, axis, bins as usize, &sah, sink),
        }
    }
    all
}

// Events at one position sort as end, planar, start: the sweep then sees, at each position,
// the references ending there, lying in the plane, and starting there, in that order.
const END: u64 = 0;
const PLANAR: u64 = 1;
const START: u64 = 2;
/// An event's bits: the position's order key (32) above the event's type (2).
pub(super) const EVENT_BITS: u32 = 34;

/// The events of a reference whose clipped bounds span `lo..=hi` on an axis: one lying in
/// the plane at `lo`, or a start and an end.
#[inline(always)]
pub(super) fn event(lo: f32, hi: f32) -> impl Iterator<Item = u64> {
    let (first, second) = if lo == hi {
        (order_key(lo) << 2 | PLANAR, None)
    } else {
        (order_key(lo) << 2 | START, Some(order_key(hi) << 2 | END))
    };
    std::iter::once(first).chain(second)
}

/// An f32 as a u32 that sorts in the same order (for non-NaN values).
fn order_key(x: f32) -> u64 {
    let b = x.to_bits();
    (if b >> 31 == 1 { !b } else { b | 1 << 31 }) as u64
}

fn from_order_key(k: u64) -> f32 {
    let k = k as u32;
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

/// The exact sweep along `axis`: every clipped bound is a candidate, and the counts below and
/// above each are read off the sorted events in one pass.
fn sweep(
    refs: &[KdRef],
    axis: usize,
    sah: &Sah,
    events: &mut Vec<u64>,
    sink: &mut impl FnMut(Split),
) {
    events.clear();
    for r in refs {
        events.extend(event(r.bounds.min[axis], r.bounds.max[axis]));
    }
    sort_events(events);
    sweep_sorted(events, 0, refs.len(), axis, sah, sink);
}

/// The sweep over a node's events on `axis`, sorted, each event's position and type above
/// `shift` bits, for a node of `refs` references.
fn sweep_sorted(
    events: &[u64],
    shift: u32,
    refs: usize,
    axis: usize,
    sah: &Sah,
    sink: &mut impl FnMut(Split),
) {
    // Below: references starting before the plane (or lying in an earlier one); above:
    // references ending after it.
    let (mut below, mut above) = (0, refs);
    let mut i = 0;
    while i < events.len() {
        let key = events[i] >> (shift + 2);
        let mut count = [0usize; 3];
        while i < events.len() && events[i] >> (shift + 2) == key {
            count[(events[i] >> shift & 3) as usize] += 1;
            i += 1;
        }
        let [ending, planar, starting] = count;
        above -= ending + planar;
        let c = Counts {
            below,
            planar,
            above,
        };
        sah.offer(sink, axis, from_order_key(key), c);
        below += starting + planar;
    }
}

/// Sorts a node's events: by their key's digits, least significant first, for a large node
/// (a few passes over the events instead of a comparison sort's log n), else by
/// comparisons. An event's key fills `EVENT_BITS` bits; a digit every event shares (the high
/// bits of a node's positions mostly) costs no pass. Not the LBVH's `radix_sort`: built for
/// millions of keys (parallel chunks, a histogram pass per digit, eight-bit digits over all
/// 64 bits), it made conference's k-d tree 18 % slower than this one (825 against 700 ms).
fn sort_events(events: &mut Vec<u64>) {
    sort_events_by(events, 0);
}

/// `sort_events` for events whose position and type lie above `shift` bits: ordered by
/// those, and of equal ones kept in their order (the radix sort is stable; the comparison
/// sort orders them by the bits below, which for the k-d tree's lists are in that order).
pub(super) fn sort_events_by(events: &mut Vec<u64>, shift: u32) {
    const DIGIT: u32 = 9;
    const PASSES: usize = EVENT_BITS.div_ceil(DIGIT) as usize;
    const BUCKETS: usize = 1 << DIGIT;
    if events.len() < RADIX_SORT {
        events.sort_unstable();
        return;
    }
    let digit = |e: u64, pass: usize| (e >> (shift + pass as u32 * DIGIT)) as usize & (BUCKETS - 1);
    let mut counts = [[0u32; BUCKETS]; PASSES];
    for &e in events.iter() {
        for (pass, c) in counts.iter_mut().enumerate() {
            c[digit(e, pass)] += 1;
        }
    }
    let n = events.len() as u32;
    let mut from = std::mem::take(events);
    let mut to = vec![0u64; from.len()];
    for (pass, c) in counts.iter().enumerate() {
        if c.contains(&n) {
            continue;
        }
        let mut start = [0u32; BUCKETS];
        let mut sum = 0;
        for (s, &k) in start.iter_mut().zip(c) {
            *s = sum;
            sum += k;
        }
        for &e in &from {
            let d = digit(e, pass);
            to[start[d] as usize] = e;
            start[d] += 1;
        }
        std::mem::swap(&mut from, &mut to);
    }
    *events = from;
}

/// The binned search along `axis`: references counted into the bins their clipped bounds
/// start and end in; candidates are the bin boundaries.
fn binned(refs: &[KdRef], axis: usize, bins: usize, sah: &Sah, sink: &mut impl FnMut(Split)) {
    let (min, max) = (sah.cell.min[axis], sah.cell.max[axis]);
    let extent = max - min;
    if extent <= 0.0 {
        return;
    }
    let scale = bins as f32 / extent;
    // A start on a boundary counts in the bin above it, an end on one in the bin below, as
    // the final classification has them (a reference touching a plane is on one side).
    let start_bin = |x: f32| (((x - min) * scale) as usize).min(bins - 1);
    let end_bin = |x: f32| ((((x - min) * scale).ceil() as usize).max(1) - 1).min(bins - 1);
    let mut starts = vec![0usize; bins];
    let mut ends = vec![0usize; bins];
    for r in refs {
        let (lo, hi) = (r.bounds.min[axis], r.bounds.max[axis]);
        // A reference lying in a boundary plane goes below it, as `planar_below` says.
        starts[if lo == hi { end_bin(lo) } else { start_bin(lo) }] += 1;
        ends[end_bin(hi)] += 1;
    }
    // Below boundary b: references starting in bins < b; above it: ending in bins ≥ b.
    let (mut below, mut above) = (0, refs.len());
    for b in 1..bins {
        below += starts[b - 1];
        above -= ends[b - 1];
        let pos = min + extent * (b as f32 / bins as f32);
        let c = Counts {
            below,
            planar: 0,
            above,
        };
        sah.offer(sink, axis, pos, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn r(lo: f32, hi: f32, tri: u32) -> KdRef {
        KdRef {
            bounds: Aabb::new(Vec3::new(lo, 0.0, 0.0), Vec3::new(hi, 1.0, 1.0)),
            tri,
        }
    }

    #[test]
    fn order_keys_sort_like_floats() {
        let xs = [-3.5f32, -1.0, -0.0, 0.0, 1e-30, 0.5, 7.0];
        for w in xs.windows(2) {
            assert!(order_key(w[0]) <= order_key(w[1]));
            assert_eq!(from_order_key(order_key(w[0])).to_bits(), w[0].to_bits());
        }
    }

    #[test]
    fn the_sweep_cuts_off_empty_space_next_to_a_cluster() {
        // Ten references in x ∈ [0, 1] of a cell [0, 10]: the best plane is x = 1.
        let refs: Vec<KdRef> = (0..10).map(|i| r(0.0, 1.0, i)).collect();
        let cell = Aabb::new(Vec3::ZERO, Vec3::new(10.0, 1.0, 1.0));
        let p = KdParams::default();
        let s = best_split(&refs, &cell, &p).expect("a split");
        assert_eq!((s.axis, s.pos), (0, 1.0));
        let binned = KdParams {
            split: KdSplit::Binned(10),
            ..p
        };
        let s = best_split(&refs, &cell, &binned).expect("a split");
        assert_eq!((s.axis, s.pos), (0, 1.0));
    }

    #[test]
    fn planar_references_go_to_the_cheaper_side() {
        // Five references in the plane x = 2 and one in [2, 3]... with cell [0, 3]: putting
        // the planar ones above (with the other) leaves the below side empty.
        let mut refs: Vec<KdRef> = (0..5).map(|i| r(2.0, 2.0, i)).collect();
        refs.push(r(2.0, 3.0, 5));
        let cell = Aabb::new(Vec3::ZERO, Vec3::new(3.0, 1.0, 1.0));
        let s = best_split(&refs, &cell, &KdParams::default()).expect("a split");
        assert_eq!((s.axis, s.pos, s.planar_below), (0, 2.0, false));
    }

    #[test]
    fn no_candidate_inside_a_cell_that_is_one_triangle_s_bounds() {
        let refs = vec![r(0.0, 1.0, 0), r(0.0, 1.0, 1)];
        let cell = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(best_split(&refs, &cell, &KdParams::default()), None);
    }

    /// The radix sort orders events as a comparison sort does, at sizes below, at and above
    /// its threshold, with positions of both signs, ±0, repeats and all three event types.
    #[test]
    fn events_sort_by_radix_as_by_comparison() {
        let mut rng = crate::random::Rng(0x2545_f491_4f6c_dd1d);
        let mut rnd = move || rng.next_u64();
        for n in [0, 1, 7, RADIX_SORT - 1, RADIX_SORT, 5000, 70_000] {
            let events: Vec<u64> = (0..n)
                .map(|_| {
                    let r = rnd();
                    let pos = match r % 4 {
                        0 => [0.0, -0.0, 1.0, -2.5][(r >> 8) as usize % 4],
                        1 => f32::from_bits((r >> 16) as u32 & 0x807f_ffff | 0x3f00_0000),
                        _ => ((r >> 32) as u32 as f32 / 1e6) - 2000.0,
                    };
                    order_key(pos) << 2 | [END, PLANAR, START][(r >> 40) as usize % 3]
                })
                .collect();
            let mut by_radix = events.clone();
            sort_events(&mut by_radix);
            let mut expected = events;
            expected.sort_unstable();
            assert_eq!(by_radix, expected, "{n} events");
        }
    }
}
