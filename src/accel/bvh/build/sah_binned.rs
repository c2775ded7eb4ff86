//! Binned SAH (Wald 2007): drop the centroids into B equal-width buckets per axis, and
//! evaluate the SAH only at the B − 1 bucket boundaries. One linear pass instead of a sort,
//! at the price of split planes restricted to a grid; B trades build time for tree quality.

use super::prim::{Box3A, NodeInfo, PrimRef, Split, partition};
use super::{BuildParams, PARALLEL_PASS, TopSplitClock, sah_split_cost, sah_worth_splitting};
use glam::Vec3A;
use rayon::prelude::*;
use std::cell::RefCell;
use std::time::Instant;

#[derive(Clone, Copy)]
struct Bin {
    bounds: Box3A,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Box3A::EMPTY,
    count: 0,
};

/// Maps a (doubled) centroid to its bucket on each axis.
#[derive(Clone, Copy)]
struct Binning {
    origin: Vec3A,
    scale: Vec3A,
    buckets: usize,
}

impl Binning {
    fn new(centroids: &Box3A, buckets: usize) -> Self {
        let extent = centroids.max - centroids.min;
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            buckets as f32 / extent,
            Vec3A::ZERO,
        );
        Binning {
            origin: centroids.min,
            scale,
            buckets,
        }
    }

    /// The world position of the boundary before bucket `k` on `axis` (the centroids are
    /// doubled, hence the half).
    fn plane(&self, axis: usize, k: usize) -> f32 {
        0.5 * (self.origin[axis] + k as f32 / self.scale[axis])
    }

    /// The bucket of `r` on `axis`, one reference at a time: what `fill` computes for three
    /// axes at once and `ObjectSplit::is_left` decides with one compare (tested equal).
    #[cfg(test)]
    fn bucket(&self, r: &PrimRef, axis: usize) -> usize {
        let c = (r.min[axis] + r.max[axis] - self.origin[axis]) * self.scale[axis];
        // NaN (a degenerate extent) and negatives go to the first bucket, as in `fill`.
        let c = if c >= 0.0 { c } else { 0.0 };
        (c as usize).min(self.buckets - 1)
    }

    /// Adds `refs` to `bins`: `bins[3k + axis]` is bucket k on that axis, the three axes
    /// side by side so the sweeps below advance them together. A large node's references
    /// go alternately to `bins` and to `spare` (as long, every bin empty; left so), merged
    /// at the end: a mesh's neighbouring triangles, next to each other in the references
    /// after a few partitions, fall into the same buckets, and with one set of bins each
    /// update would wait for the one before to be stored. The unions and counts are exact,
    /// so the bins are the same.
    ///
    /// The buckets of `KEYS_AHEAD` references are found before their bins are updated: an
    /// update's load from a bin may not pass an earlier store to a bin whose address is
    /// still being computed, and consecutive references so often share a bin that the
    /// processor stops guessing. With the addresses a load away, the updates no longer
    /// wait for the whole arithmetic of the reference before.
    ///
    /// Each reference's buckets are recorded in it (`PrimRef::mark_bucket_bytes`) for the
    /// partition that follows.
    fn fill(&self, refs: &mut [PrimRef], bins: &mut [Bin], spare: &mut [Bin]) {
        let n = 3 * self.buckets;
        let bins = &mut bins[..n];
        let two_sets = refs.len() >= TWO_SETS && spare.len() >= n;
        let spare = &mut spare[..if two_sets { n } else { 0 }];
        // With two sets an odd count's last reference goes first, to `bins`; then the
        // even ones to `bins` and the odd ones to `spare`.
        let refs = if two_sets && refs.len() % 2 == 1 {
            let (last, rest) = refs.split_last_mut().expect("at least TWO_SETS references");
            let key = self.keys(last);
            Self::update(bins, last, key);
            rest
        } else {
            refs
        };
        let mut keys = [[0u32; 4]; KEYS_AHEAD];
        for run in refs.chunks_mut(KEYS_AHEAD) {
            for (key, r) in keys.iter_mut().zip(run.iter_mut()) {
                *key = self.keys(r);
            }
            let run = &*run;
            if two_sets {
                // Runs are of an even length, so a reference's place in its run has the
                // parity of its place in `refs`.
                for (pair, key) in run.chunks_exact(2).zip(keys.chunks_exact(2)) {
                    Self::update(bins, &pair[0], key[0]);
                    Self::update(spare, &pair[1], key[1]);
                }
            } else {
                for (r, &key) in run.iter().zip(&keys) {
                    Self::update(bins, r, key);
                }
            }
        }
        if two_sets {
            for (x, y) in bins.iter_mut().zip(spare.iter_mut()) {
                x.count += y.count;
                x.bounds = x.bounds.union(y.bounds);
                *y = EMPTY_BIN;
            }
        }
    }

    /// The bins of one reference, `3k + axis` for its bucket k on each axis; its buckets
    /// are recorded in it.
    #[inline(always)]
    fn keys(&self, r: &mut PrimRef) -> [u32; 4] {
        let last = Vec3A::splat((self.buckets - 1) as f32);
        let c = (r.lo() + r.hi() - self.origin) * self.scale;
        // NaN (a degenerate extent) and negatives go to the first bucket; past the
        // last (rounding at the top of the range) to the last. (The fourth lane, which
        // holds no coordinate, ends in the same range and is ignored.)
        let k = Vec3A::select(c.cmpge(Vec3A::ZERO), c, Vec3A::ZERO).min(last);
        let (keys, bytes) = bins_and_bytes(k);
        r.mark_bucket_bytes(bytes);
        keys
    }

    /// Adds one reference to its bins `keys` (from `keys`, so below `bins.len()`).
    #[inline(always)]
    fn update(bins: &mut [Bin], r: &PrimRef, keys: [u32; 4]) {
        let (lo, hi) = (r.lo(), r.hi());
        for &key in &keys[..3] {
            debug_assert!((key as usize) < bins.len());
            // SAFETY: k ≤ buckets − 1 (clamped in `keys`), so 3k + axis < 3 · buckets,
            // the length of `bins`. Unchecked: this is the build's innermost loop.
            let bin = unsafe { bins.get_unchecked_mut(key as usize) };
            bin.count += 1;
            bin.bounds.grow(lo, hi);
        }
    }

    /// `fill` over `refs`, on every thread for a node large enough for its passes to pay.
    fn fill_parallel(&self, refs: &mut [PrimRef], bins: &mut [Bin], spare: &mut [Bin]) {
        if refs.len() < PARALLEL_PASS {
            return self.fill(refs, bins, spare);
        }
        let partial = refs
            .par_chunks_mut(PARALLEL_PASS / 4)
            .map(|chunk| {
                let mut bins = vec![EMPTY_BIN; 6 * self.buckets];
                let (bins, spare) = bins.split_at_mut(3 * self.buckets);
                self.fill(chunk, bins, spare);
                bins.to_vec()
            })
            .collect::<Vec<_>>();
        for p in partial {
            for (x, y) in bins.iter_mut().zip(&p) {
                x.count += y.count;
                x.bounds = x.bounds.union(y.bounds);
            }
        }
    }
}

/// Nodes of at least this many references are binned into two sets of bins (`fill`).
const TWO_SETS: usize = 64;

/// References whose buckets `fill` finds before it updates their bins: even, so that the
/// two sets' alternation keeps its parity from one run to the next.
const KEYS_AHEAD: usize = 32;
const _: () = assert!(KEYS_AHEAD.is_multiple_of(2));

/// The bins of the buckets `k` (finite, every lane in 0..=buckets − 1, truncated):
/// `3k + axis` in the first three lanes; and the buckets as bytes, x lowest
/// (`PrimRef::mark_bucket_bytes`). In vector registers where there are SSE2's integer
/// operations: the bins' lanes stored whole, the bytes packed, no lane moved out one by
/// one.
#[inline(always)]
fn bins_and_bytes(k: Vec3A) -> ([u32; 4], u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86_64; the lanes are in range, so no lane saturates,
        // and every bucket (below 256) fits a byte.
        unsafe {
            let i = _mm_cvttps_epi32(k.into());
            let bins = _mm_add_epi32(_mm_add_epi32(i, i), i);
            let bins = _mm_add_epi32(bins, _mm_setr_epi32(0, 1, 2, 3));
            let words = _mm_packs_epi32(i, i);
            let bytes = _mm_cvtsi128_si32(_mm_packus_epi16(words, words)) as u32;
            (std::mem::transmute::<__m128i, [u32; 4]>(bins), bytes)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // SAFETY: every lane is finite and in 0..=buckets − 1, so its truncation is
        // representable.
        let [x, y, z] = unsafe {
            [
                k.x.to_int_unchecked::<u32>(),
                k.y.to_int_unchecked::<u32>(),
                k.z.to_int_unchecked::<u32>(),
            ]
        };
        ([3 * x, 3 * y + 1, 3 * z + 2, 0], x | y << 8 | z << 16)
    }
}

/// Per-thread buffers, so the many small nodes near the leaves allocate nothing. A subtree
/// built on one thread holds one for all its nodes (`Builder::sequential`); elsewhere each
/// search takes its thread's out of a slot and puts it back (`with_scratch`).
#[derive(Default)]
pub(crate) struct Scratch {
    bins: Vec<Bin>,
    /// `fill`'s second set of bins, every one empty between calls.
    spare: Vec<Bin>,
    sweep: Sweep,
}

/// The sweeps' buffers.
#[derive(Default)]
struct Sweep {
    right_area: Vec<f32>,
    right_count: Vec<u32>,
    /// The filled buckets of the three axes, B entries each (`filled_buckets`).
    filled: Vec<u16>,
}

/// Lists the filled buckets of each axis, lowest first, in `filled[axis · B..]`, and returns
/// their numbers: one pass over the bins for the three axes, writing every bucket and
/// advancing past the filled ones, so no branch depends on the counts.
fn filled_buckets(bins: &[Bin], b: usize, filled: &mut [u16]) -> [usize; 3] {
    let (bins, filled) = (&bins[..3 * b], &mut filled[..3 * b]);
    let mut m = [0usize; 3];
    for (k, bucket) in bins.chunks_exact(3).enumerate() {
        for axis in 0..3 {
            // SAFETY: m[axis] ≤ k < b (an axis's count grows at most once per bucket), so
            // the index is below 3b, the length of `filled`. Unchecked: the loop runs B
            // times at each of the build's ~10^5 nodes.
            unsafe { *filled.get_unchecked_mut(axis * b + m[axis]) = k as u16 };
            m[axis] += usize::from(bucket[axis].count > 0);
        }
    }
    m
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::default();
}

/// Runs `f` with this thread's scratch, taken out of its slot for the call and put back
/// after: `f` bins in parallel, and a thread waiting inside that loop may be handed
/// another node's search (work stealing), which then finds the slot empty and starts a
/// scratch of its own. (Borrowed across the loop, the slot made that second search panic
/// with "already borrowed".)
pub(crate) fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    let mut scratch = SCRATCH.take();
    let result = f(&mut scratch);
    SCRATCH.set(scratch);
    result
}

/// The best binned object split of a node: its SAH cost (unnormalised, see
/// `sah_split_cost`), where it cuts, and both children's boxes.
#[derive(Clone, Copy)]
pub struct ObjectSplit {
    pub cost: f32,
    axis: usize,
    binning: Binning,
    /// The first bucket of the right side, in the split axis's lane; +∞ in the others
    /// (`is_left`).
    boundary: Vec3A,
    /// The first bucket of the right side (`is_left_marked`).
    bucket: u32,
    pub left: Box3A,
    pub right: Box3A,
}

impl ObjectSplit {
    /// Whether `r` goes to the left child: its bucket on the split axis is before
    /// `bucket`. For a bucket boundary k ≥ 1, "the bucket (truncated, NaN and negatives to
    /// 0, clamped to the last) is below k" is "the position is not ≥ k", so one vector
    /// compare in the split axis's lane decides it, with `fill`'s arithmetic.
    #[inline(always)]
    pub fn is_left(&self, r: &PrimRef) -> bool {
        let c = (r.lo() + r.hi() - self.binning.origin) * self.binning.scale;
        c.cmpge(self.boundary).bitmask() & (1 << self.axis) == 0
    }

    /// `is_left` for a reference binned by this split's `best`, from the bucket binning
    /// recorded in it: one byte compared, where `is_left` repeats binning's arithmetic.
    /// The side is the same (`fill_and_partition_agree_on_every_bucket`); the partition's
    /// branch on it waits for a load and a compare instead of the arithmetic's chain, which
    /// is what a mispredicted side costs.
    #[inline(always)]
    pub fn is_left_marked(&self, r: &PrimRef) -> bool {
        r.bucket(self.axis) < self.bucket
    }

    fn new(binning: Binning, axis: usize, bucket: usize) -> Self {
        let mut boundary = Vec3A::INFINITY;
        boundary[axis] = bucket as f32;
        ObjectSplit {
            cost: 0.0,
            axis,
            binning,
            boundary,
            bucket: bucket as u32,
            left: Box3A::EMPTY,
            right: Box3A::EMPTY,
        }
    }
}

/// One bucket boundary of a node: the split that puts buckets `..k` of `axis` on the left.
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    pub axis: usize,
    pub k: usize,
    /// The unnormalised SAH cost (see `sah_split_cost`).
    pub cost: f32,
    pub left: u32,
    pub right: u32,
    /// The bucket before the boundary is empty, so this split equals the one before it.
    pub repeats_previous: bool,
}

/// Bins `refs` and offers every boundary with primitives on both sides to `visit`, boundary
/// by boundary, the three axes at each, those after an empty bucket (which repeat the one
/// before) included: what the bucket plot draws. `best` finds the same cheapest split
/// without visiting the repeats.
fn candidates(
    refs: &mut [PrimRef],
    binning: &Binning,
    parent_area: f32,
    p: &BuildParams,
    mut visit: impl FnMut(Candidate),
) {
    let b = binning.buckets;
    with_scratch(|s| {
        s.bins.clear();
        s.bins.resize(3 * b, EMPTY_BIN);
        if s.spare.len() < 3 * b {
            s.spare.resize(3 * b, EMPTY_BIN);
        }
        s.sweep.right_area.resize(3 * b, 0.0);
        s.sweep.right_count.resize(3 * b, 0);
        binning.fill_parallel(refs, &mut s.bins, &mut s.spare);
        // Empty buckets change neither side: the sweeps skip their unions and areas.
        let (mut acc, mut count, mut area) = ([Box3A::EMPTY; 3], [0u32; 3], [0.0f32; 3]);
        for k in (1..b).rev() {
            for axis in 0..3 {
                let bin = &s.bins[3 * k + axis];
                if bin.count > 0 {
                    acc[axis] = acc[axis].union(bin.bounds);
                    count[axis] += bin.count;
                    area[axis] = acc[axis].surface_area();
                }
                s.sweep.right_area[3 * k + axis] = area[axis];
                s.sweep.right_count[3 * k + axis] = count[axis];
            }
        }
        let (mut acc, mut count) = ([Box3A::EMPTY; 3], [0u32; 3]);
        for k in 1..b {
            for axis in 0..3 {
                let bin = &s.bins[3 * (k - 1) + axis];
                let right = s.sweep.right_count[3 * k + axis];
                if bin.count > 0 {
                    acc[axis] = acc[axis].union(bin.bounds);
                    count[axis] += bin.count;
                }
                if count[axis] == 0 || right == 0 {
                    continue;
                }
                visit(Candidate {
                    axis,
                    k,
                    cost: sah_split_cost(
                        parent_area,
                        acc[axis].surface_area(),
                        count[axis] as usize,
                        s.sweep.right_area[3 * k + axis],
                        right as usize,
                        p,
                    ),
                    left: count[axis],
                    right,
                    repeats_previous: bin.count == 0,
                });
            }
        }
        // `best` expects every bin empty.
        s.bins.fill(EMPTY_BIN);
    });
}

/// The cheapest object split at a bucket boundary, or `None` if every centroid fell into
/// one bucket. Of equal costs the first in `candidates`' order wins (the lowest boundary,
/// then the lowest axis); a boundary after an empty bucket repeats the one before at the
/// same cost, so only the boundaries after filled buckets are evaluated. Near the leaves,
/// where a node's few primitives fill a few of the B buckets, each axis's sweeps then take
/// as many steps as there are filled buckets instead of B.
///
/// The children's boxes (`left`, `right`) are only gathered when `sides` asks for them
/// (the SBVH weighs their overlap); the binned SAH leaves them empty, since its partition
/// computes the children's bounds anyway.
pub fn best(
    refs: &mut [PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
    sides: bool,
) -> Option<ObjectSplit> {
    with_scratch(|s| best_in(s, refs, info, p, sides))
}

/// `best` with the scratch `s`.
fn best_in(
    s: &mut Scratch,
    refs: &mut [PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
    sides: bool,
) -> Option<ObjectSplit> {
    let b = p.buckets as usize;
    let binning = Binning::new(&info.centroids, b);
    let parent_area = info.bounds.surface_area();
    // Every bin is empty between calls (only the filled ones are emptied after use, a
    // few of the 3B near the leaves): only new ones need setting.
    if s.bins.len() < 3 * b {
        s.bins.resize(3 * b, EMPTY_BIN);
        s.spare.resize(3 * b, EMPTY_BIN);
    }
    s.sweep.right_area.resize(b, 0.0);
    s.sweep.right_count.resize(b, 0);
    s.sweep.filled.resize(3 * b, 0);
    let bins = &mut s.bins[..3 * b];
    binning.fill_parallel(refs, bins, &mut s.spare);
    let Sweep {
        right_area,
        right_count,
        filled,
    } = &mut s.sweep;
    let m = filled_buckets(bins, b, filled);
    let mut per_axis = [AxisBest::default(); 3];
    for (axis, result) in per_axis.iter_mut().enumerate() {
        let filled = &filled[axis * b..axis * b + m[axis]];
        // SAFETY: `filled_buckets` lists buckets below b, and `bins` holds 3b.
        *result =
            unsafe { best_on_axis(bins, axis, filled, parent_area, p, right_area, right_count) };
    }
    let split = pick(&per_axis).map(|(cost, axis, bucket)| {
        let side = |range: std::ops::Range<usize>| {
            range.fold(Box3A::EMPTY, |a, k| a.union(bins[3 * k + axis].bounds))
        };
        let (left, right) = if sides {
            (side(0..bucket), side(bucket..b))
        } else {
            (Box3A::EMPTY, Box3A::EMPTY)
        };
        ObjectSplit {
            cost,
            left,
            right,
            ..ObjectSplit::new(binning, axis, bucket)
        }
    });
    for axis in 0..3 {
        for &k in &filled[axis * b..axis * b + m[axis]] {
            // SAFETY: `filled_buckets` lists buckets below b, and `bins` holds 3b.
            unsafe { *bins.get_unchecked_mut(3 * k as usize + axis) = EMPTY_BIN };
        }
    }
    split
}

/// One axis's share of `best`: its first boundary with primitives on both sides, and its
/// cheapest boundary (of equal costs the lowest), NaN costs aside.
#[derive(Clone, Copy, Default)]
struct AxisBest {
    first: Option<(usize, f32)>,
    cheapest: Option<(usize, f32)>,
}

/// The sweeps of one axis over its filled buckets only: right to left for the right
/// sides' areas and counts, then left to right for the costs, with the same unions in the
/// same order as `candidates`, so every cost is the same to the last bit.
///
/// # Safety
/// Every bucket in `filled` is below `bins.len() / 3` (`filled_buckets` lists only such).
unsafe fn best_on_axis(
    bins: &[Bin],
    axis: usize,
    filled: &[u16],
    parent_area: f32,
    p: &BuildParams,
    right_area: &mut [f32],
    right_count: &mut [u32],
) -> AxisBest {
    let m = filled.len();
    let (right_area, right_count) = (&mut right_area[..m], &mut right_count[..m]);
    // Unchecked: these sweeps are the bulk of the search at every node.
    let bin = |k: u16| {
        debug_assert!(3 * k as usize + axis < bins.len());
        // SAFETY: k < bins.len() / 3 (the caller's promise) and axis < 3.
        unsafe { bins.get_unchecked(3 * k as usize + axis) }
    };
    // right_area[i], right_count[i]: the union of the filled buckets from filled[i] on.
    let (mut acc, mut count) = (Box3A::EMPTY, 0u32);
    let rights = right_area.iter_mut().zip(right_count.iter_mut());
    for ((area, n), &k) in rights.zip(filled).rev() {
        let bin = bin(k);
        acc = acc.union(bin.bounds);
        count += bin.count;
        *area = acc.surface_area();
        *n = count;
    }
    let mut result = AxisBest::default();
    let (mut acc, mut count) = (Box3A::EMPTY, 0u32);
    // Each boundary after a filled bucket but the last, with the rights from the next on.
    let rights = right_area.iter().zip(right_count.iter()).skip(1);
    for (&k, (&right_area, &right_count)) in filled.iter().zip(rights) {
        let bin = bin(k);
        acc = acc.union(bin.bounds);
        count += bin.count;
        let cost = sah_split_cost(
            parent_area,
            acc.surface_area(),
            count as usize,
            right_area,
            right_count as usize,
            p,
        );
        let boundary = k as usize + 1;
        result.first.get_or_insert((boundary, cost));
        if !cost.is_nan() && result.cheapest.is_none_or(|(_, c)| cost < c) {
            result.cheapest = Some((boundary, cost));
        }
    }
    result
}

/// The winner of the three axes, as a scan of every boundary in `candidates`' order keeping
/// the strictly cheaper one finds it: the first boundary offered if its cost is NaN (nothing
/// is cheaper than NaN), else the cheapest, of equal costs the lowest boundary, then axis.
fn pick(per_axis: &[AxisBest; 3]) -> Option<(f32, usize, usize)> {
    let (first_axis, (_, first_cost)) = per_axis
        .iter()
        .enumerate()
        .filter_map(|(axis, a)| Some((axis, a.first?)))
        .min_by_key(|&(axis, (k, _))| (k, axis))?;
    if first_cost.is_nan() {
        let (k, _) = per_axis[first_axis].first?;
        return Some((first_cost, first_axis, k));
    }
    let mut best: Option<(f32, usize, usize)> = None;
    for (axis, a) in per_axis.iter().enumerate() {
        let Some((k, cost)) = a.cheapest else {
            continue;
        };
        let better =
            best.is_none_or(|(c, baxis, bk)| cost < c || (cost == c && (k, axis) < (bk, baxis)));
        if better {
            best = Some((cost, axis, k));
        }
    }
    best
}

/// Splits a node at its cheapest bucket boundary; a node large enough for its passes to
/// run on all threads adds their times to `clock`. The search uses `scratch` if given (a
/// subtree built on one thread holds one), else its thread's.
pub fn split(
    refs: &mut [PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
    clock: &TopSplitClock,
    scratch: Option<&mut Scratch>,
) -> Option<Split> {
    let n = refs.len();
    if n <= p.max_leaf_size as usize && no_split_pays(refs, info, p) {
        return None;
    }
    // Only the nodes near the root are timed: reading the clock at each of the ~10^5
    // small nodes took a few per cent of the build.
    let start = (n >= PARALLEL_PASS).then(Instant::now);
    let best = match scratch {
        Some(s) => best_in(s, refs, info, p, false),
        None => best(refs, info, p, false),
    };
    if let Some(start) = start {
        clock.add_binning(start.elapsed());
    }
    let Some(best) = best else {
        // Every centroid fell into one bucket (extents near the float resolution).
        return (n > p.max_leaf_size as usize).then(|| super::median::object_median(refs, info));
    };
    if !sah_worth_splitting(n, best.cost, info.bounds.surface_area(), p) {
        return None;
    }
    let start = (n >= PARALLEL_PASS).then(Instant::now);
    let split = partition(refs, |r| best.is_left_marked(r));
    if let Some(start) = start {
        clock.add_partition(start.elapsed());
    }
    Some(split)
}

/// Whether no split of a node can beat its leaf, without binning: a child's box holds
/// each of its primitives' boxes, so A_L·N_L + A_R·N_R ≥ Σ A_i, and every split costs at
/// least C_trav·A + C_isect·Σ A_i. Most nodes of two primitives (two halves of a quad,
/// whose boxes are the quad's) end there. The margin covers the rounding of both sums, so
/// the answer is the one binning would give: a node that passes here is never split.
fn no_split_pays(refs: &[PrimRef], info: &NodeInfo, p: &BuildParams) -> bool {
    let area = info.bounds.surface_area();
    let sum: f32 = refs.iter().map(|r| r.box3a().surface_area()).sum();
    let least_split = p.c_trav * area + p.c_isect * sum;
    least_split >= p.c_isect * area * refs.len() as f32 * (1.0 + 1e-4)
}

/// Every bucket boundary of the node over `refs`, with the plane's position along its
/// axis (world units): what the bucket-cost plot draws.
pub(super) fn all_candidates(
    refs: &[PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
) -> Vec<(Candidate, f32)> {
    let binning = Binning::new(&info.centroids, p.buckets as usize);
    let mut out = Vec::new();
    // Binning records each reference's buckets: in a copy, the caller's stay as they are.
    candidates(
        &mut refs.to_vec(),
        &binning,
        info.bounds.surface_area(),
        p,
        |c| {
            out.push((c, binning.plane(c.axis, c.k)));
        },
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;
    use glam::Vec3;

    /// Binning and partitioning put every reference in the same bucket, and on the same side
    /// of every boundary, at the ends of the
    /// range, inside it, and where a degenerate extent makes the position NaN or infinite.
    #[test]
    fn fill_and_partition_agree_on_every_bucket() {
        let mut refs: Vec<PrimRef> = (0..500u32)
            .map(|i| {
                let f = |k: u32| ((i * k) % 97) as f32 / 7.0;
                let lo = Vec3::new(f(3), f(5), f(11));
                PrimRef::new(Aabb::new(lo, lo + Vec3::new(f(2), 0.0, f(13) * 0.1)), i)
            })
            .collect();
        // Tiny extents: 16 / 1e-45 is infinite, so a centroid at the origin gives 0 · ∞.
        refs.push(PrimRef::new(Aabb::new(Vec3::ZERO, Vec3::ZERO), 500));
        refs.push(PrimRef::new(Aabb::new(Vec3::ZERO, Vec3::splat(1e-45)), 501));
        let info = NodeInfo::of(&refs);
        let tiny = NodeInfo::of(&refs[500..]);
        for (binning, refs) in [
            (Binning::new(&info.centroids, 16), &refs[..]),
            (Binning::new(&info.centroids, 3), &refs[..]),
            // An odd count: the last reference is binned first, then the pairs.
            (Binning::new(&info.centroids, 16), &refs[..501]),
            (Binning::new(&tiny.centroids, 16), &refs[500..]),
        ] {
            let b = binning.buckets;
            let mut bins = vec![EMPTY_BIN; 3 * b];
            let mut spare = vec![EMPTY_BIN; 3 * b];
            let mut marked = refs.to_vec();
            binning.fill(&mut marked, &mut bins, &mut spare);
            // One set of bins gives the same bins as two (the first three cases, of 502 and
            // 501 references, are binned into two), and the spare set is left empty.
            let mut one_set = vec![EMPTY_BIN; 3 * b];
            binning.fill(&mut refs.to_vec(), &mut one_set, &mut []);
            let bits = |bins: &[Bin]| -> Vec<[u32; 7]> {
                let b = |v: Vec3A| v.to_array().map(f32::to_bits);
                bins.iter()
                    .map(|x| {
                        let (lo, hi) = (b(x.bounds.min), b(x.bounds.max));
                        [x.count, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
                    })
                    .collect()
            };
            assert_eq!(bits(&bins), bits(&one_set));
            assert_eq!(bits(&spare), bits(&vec![EMPTY_BIN; 3 * b]));
            for axis in 0..3 {
                let mut counts = vec![0u32; b];
                for r in refs {
                    counts[binning.bucket(r, axis)] += 1;
                }
                let filled: Vec<u32> = (0..b).map(|k| bins[3 * k + axis].count).collect();
                assert_eq!(filled, counts, "axis {axis}, {b} buckets");
                for k in 1..b {
                    let split = ObjectSplit::new(binning, axis, k);
                    for (r, m) in refs.iter().zip(&marked) {
                        assert_eq!(split.is_left(r), binning.bucket(r, axis) < k);
                        assert_eq!(split.is_left_marked(m), split.is_left(r));
                    }
                }
            }
        }
    }
    /// `best` chooses what a scan of every boundary `candidates` offers finds, keeping the
    /// strictly cheaper one: the same split, cost and child boxes, for few and many
    /// primitives, clustered and spread, and every bucket count.
    #[test]
    fn best_equals_the_scan_of_every_candidate() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let p0 = BuildParams::default();
        for case in 0..3000 {
            let n = [2, 3, 5, 9, 17, 40, 300][case % 7];
            let spread = [1.0, 0.01, 100.0][case % 3];
            let mut refs: Vec<PrimRef> = (0..n)
                .map(|i| {
                    let lo = Vec3::new(next(), next() * spread, (next() * 8.0).floor());
                    let size = Vec3::new(next(), next(), next()) * 0.3;
                    PrimRef::new(Aabb::new(lo, lo + size), i as u32)
                })
                .collect();
            let info = NodeInfo::of(&refs);
            for buckets in [2, 3, 16, 64, 256] {
                let p = BuildParams { buckets, ..p0 };
                let binning = Binning::new(&info.centroids, buckets as usize);
                let mut scan: Option<Candidate> = None;
                candidates(&mut refs, &binning, info.bounds.surface_area(), &p, |c| {
                    if !c.repeats_previous && scan.is_none_or(|s| c.cost < s.cost) {
                        scan = Some(c);
                    }
                });
                let found = best(&mut refs, &info, &p, true);
                assert_eq!(
                    found.map(|f| (f.axis, f.boundary[f.axis], f.cost.to_bits())),
                    scan.map(|c| (c.axis, c.k as f32, c.cost.to_bits())),
                    "case {case}, {n} refs, {buckets} buckets"
                );
            }
        }
    }
    /// A node `no_split_pays` turns into a leaf is one that binning would not split either,
    /// and the bound does decide most nodes of two primitives of a mesh.
    #[test]
    fn no_split_pays_only_where_binning_agrees() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut decided = 0;
        for case in 0..20000 {
            let n = 2 + case % 7;
            let c_trav = [1.0, 0.3, 2.0, 0.0][case % 4];
            let p = BuildParams {
                c_trav,
                ..BuildParams::default()
            };
            // Pieces of a grid of quads, some flat, some touching, some far apart.
            let mut refs: Vec<PrimRef> = (0..n)
                .map(|i| {
                    let lo = Vec3::new(
                        (next() * 4.0).floor(),
                        (next() * 4.0).floor() * next(),
                        next() * 0.1,
                    );
                    let size = Vec3::new(1.0, next() + 0.5, [0.0, next()][case % 2]);
                    PrimRef::new(Aabb::new(lo, lo + size), i as u32)
                })
                .collect();
            let info = NodeInfo::of(&refs);
            if no_split_pays(&refs, &info, &p) {
                decided += 1;
                let area = info.bounds.surface_area();
                if let Some(b) = best(&mut refs, &info, &p, false) {
                    assert!(!sah_worth_splitting(n, b.cost, area, &p), "case {case}");
                }
            }
        }
        assert!(decided > 500, "only {decided} nodes decided");
    }
}
