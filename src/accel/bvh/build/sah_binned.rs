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
    /// side by side so the sweeps below advance them together.
    fn fill(&self, refs: &[PrimRef], bins: &mut [Bin]) {
        let bins = &mut bins[..3 * self.buckets];
        let last = Vec3A::splat((self.buckets - 1) as f32);
        for r in refs {
            let (lo, hi) = (r.lo(), r.hi());
            let c = (lo + hi - self.origin) * self.scale;
            // NaN (a degenerate extent) and negatives go to the first bucket; past the
            // last (rounding at the top of the range) to the last.
            let k = Vec3A::select(c.cmpge(Vec3A::ZERO), c, Vec3A::ZERO).min(last);
            // SAFETY: every lane of k is finite and in 0..=buckets − 1 (clamped above), so
            // its truncation is representable.
            let k: [usize; 3] = unsafe {
                [
                    k.x.to_int_unchecked::<u32>() as usize,
                    k.y.to_int_unchecked::<u32>() as usize,
                    k.z.to_int_unchecked::<u32>() as usize,
                ]
            };
            for (axis, k) in k.into_iter().enumerate() {
                let bin = &mut bins[3 * k + axis];
                bin.count += 1;
                bin.bounds.grow(lo, hi);
            }
        }
    }

    fn fill_parallel(&self, refs: &[PrimRef], bins: &mut [Bin]) {
        if refs.len() < PARALLEL_PASS {
            return self.fill(refs, bins);
        }
        let partial = refs
            .par_chunks(PARALLEL_PASS / 4)
            .map(|chunk| {
                let mut bins = vec![EMPTY_BIN; 3 * self.buckets];
                self.fill(chunk, &mut bins);
                bins
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

/// Per-thread buffers, so the many small nodes near the leaves allocate nothing.
#[derive(Default)]
struct Scratch {
    bins: Vec<Bin>,
    right_area: Vec<f32>,
    right_count: Vec<u32>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::default();
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

    fn new(binning: Binning, axis: usize, bucket: usize) -> Self {
        let mut boundary = Vec3A::INFINITY;
        boundary[axis] = bucket as f32;
        ObjectSplit {
            cost: 0.0,
            axis,
            binning,
            boundary,
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

/// Bins `refs` and offers every boundary with primitives on both sides to `visit`, in the
/// builder's order (boundary by boundary, the three axes at each). Boundaries after an
/// empty bucket repeat the one before; they are offered only `with_repeats` (the bucket
/// plot draws them; choosing a split needs only the others, and near the leaves, where
/// most buckets are empty, skipping them halves the sweep).
fn candidates(
    refs: &[PrimRef],
    binning: &Binning,
    parent_area: f32,
    p: &BuildParams,
    with_repeats: bool,
    mut visit: impl FnMut(Candidate),
) {
    let b = binning.buckets;
    SCRATCH.with_borrow_mut(|s| {
        s.bins.clear();
        s.bins.resize(3 * b, EMPTY_BIN);
        s.right_area.resize(3 * b, 0.0);
        s.right_count.resize(3 * b, 0);
        binning.fill_parallel(refs, &mut s.bins);
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
                s.right_area[3 * k + axis] = area[axis];
                s.right_count[3 * k + axis] = count[axis];
            }
        }
        let (mut acc, mut count) = ([Box3A::EMPTY; 3], [0u32; 3]);
        for k in 1..b {
            for axis in 0..3 {
                let bin = &s.bins[3 * (k - 1) + axis];
                let right = s.right_count[3 * k + axis];
                if bin.count > 0 {
                    acc[axis] = acc[axis].union(bin.bounds);
                    count[axis] += bin.count;
                } else if !with_repeats {
                    continue;
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
                        s.right_area[3 * k + axis],
                        right as usize,
                        p,
                    ),
                    left: count[axis],
                    right,
                    repeats_previous: bin.count == 0,
                });
            }
        }
    });
}

/// The cheapest object split at a bucket boundary (of equal costs the first offered; a
/// boundary after an empty bucket repeats the one before), or `None` if every centroid
/// fell into one bucket.
pub fn best(refs: &[PrimRef], info: &NodeInfo, p: &BuildParams) -> Option<ObjectSplit> {
    let b = p.buckets as usize;
    let binning = Binning::new(&info.centroids, b);
    let mut best: Option<(f32, usize, usize)> = None;
    candidates(refs, &binning, info.bounds.surface_area(), p, false, |c| {
        if !c.repeats_previous && best.is_none_or(|(cost, _, _)| c.cost < cost) {
            best = Some((c.cost, c.axis, c.k));
        }
    });
    let (cost, axis, bucket) = best?;
    // The children's boxes from the bins `candidates` left in this thread's scratch.
    SCRATCH.with_borrow(|s| {
        let side = |range: std::ops::Range<usize>| {
            range.fold(Box3A::EMPTY, |a, k| a.union(s.bins[3 * k + axis].bounds))
        };
        Some(ObjectSplit {
            cost,
            left: side(0..bucket),
            right: side(bucket..b),
            ..ObjectSplit::new(binning, axis, bucket)
        })
    })
}

/// Splits a node at its cheapest bucket boundary; a node large enough for its passes to
/// run on all threads adds their times to `clock`.
pub fn split(
    refs: &mut [PrimRef],
    info: &NodeInfo,
    p: &BuildParams,
    clock: &TopSplitClock,
) -> Option<Split> {
    let n = refs.len();
    // Only the nodes near the root are timed: reading the clock at each of the ~10^5
    // small nodes took a few per cent of the build.
    let start = (n >= PARALLEL_PASS).then(Instant::now);
    let best = best(refs, info, p);
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
    let split = partition(refs, |r| best.is_left(r));
    if let Some(start) = start {
        clock.add_partition(start.elapsed());
    }
    Some(split)
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
    candidates(refs, &binning, info.bounds.surface_area(), p, true, |c| {
        out.push((c, binning.plane(c.axis, c.k)));
    });
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
            (Binning::new(&tiny.centroids, 16), &refs[500..]),
        ] {
            let b = binning.buckets;
            let mut bins = vec![EMPTY_BIN; 3 * b];
            binning.fill(refs, &mut bins);
            for axis in 0..3 {
                let mut counts = vec![0u32; b];
                for r in refs {
                    counts[binning.bucket(r, axis)] += 1;
                }
                let filled: Vec<u32> = (0..b).map(|k| bins[3 * k + axis].count).collect();
                assert_eq!(filled, counts, "axis {axis}, {b} buckets");
                for k in 1..b {
                    let split = ObjectSplit::new(binning, axis, k);
                    for r in refs {
                        assert_eq!(split.is_left(r), binning.bucket(r, axis) < k);
                    }
                }
            }
        }
    }
}
