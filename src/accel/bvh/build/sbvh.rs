//! SBVH (Stich, Friedrich and Dietrich 2009, "Spatial splits in bounding volume hierarchies"):
//! the binned SAH with a second kind of candidate. An object split sorts whole references to
//! two sides and its children may overlap; a spatial split cuts the node's box with a plane,
//! like a k-d tree, so the children never overlap, and a triangle straddling the plane gets a
//! reference on each side, each bounded by the triangle clipped to its side.
//!
//! Spatial splits are tried only where the best object split's children overlap by more than
//! α times the root's area (the paper's overlap threshold); a straddling reference goes whole
//! to one side when that is cheaper ("reference unsplitting"); and the references a subtree
//! may duplicate are capped by a budget, shared between the two children in proportion to
//! their sizes so that the tree never depends on the thread count. Triangles are never
//! copied or cut: only their references are.

use super::prim::{Box3A, NodeInfo, PrimRef, Split, partition, split_at};
use super::sah_binned::{self, ObjectSplit};
use super::{
    BuildParams, MEDIAN_FALLBACK_DEPTH, PARALLEL_PASS, PARALLEL_SUBTREE, median, sah_split_cost,
    sah_worth_splitting,
};
use crate::accel::bvh::node::Node;
use crate::accel::progress::BuildProgress;
use crate::geometry::clip::clipped_bounds;
#[cfg(target_arch = "x86_64")]
use crate::geometry::simd::SimdLevel;
use crate::geometry::{Aabb, Triangle};
use glam::Vec3A;
use rayon::prelude::*;

/// Bins per axis of the spatial split search (equal-width slabs of the node's box).
pub const SPATIAL_BINS: usize = 32;

/// The tree as built: nodes with each pair of children adjacent after its parent, the leaf
/// order as scene triangle indices, and what the spatial splits did.
#[derive(Default)]
pub struct Subtree {
    pub nodes: Vec<Node>,
    pub prims: Vec<u32>,
    /// Nodes split by a spatial split.
    pub spatial_splits: usize,
    /// Straddling references that reference unsplitting sent whole to one side.
    pub unsplit: usize,
}

impl Subtree {
    /// Appends `sub` (built on its own, indices from 0) and returns its root, moved to match.
    fn append(&mut self, root: Node, sub: Subtree) -> Node {
        let (node_base, prim_base) = (self.nodes.len() as u32, self.prims.len() as u32);
        let shift = |mut n: Node| {
            n.left_first += if n.is_leaf() { prim_base } else { node_base };
            n
        };
        self.nodes.extend(sub.nodes.into_iter().map(shift));
        self.prims.extend(sub.prims);
        self.spatial_splits += sub.spatial_splits;
        self.unsplit += sub.unsplit;
        shift(root)
    }
}

/// Builds the SBVH over `triangles` (not empty). Node 0 of the result is the root. An
/// abandoned build (`progress`) stops searching for splits and halves the rest.
pub fn build(triangles: &[Triangle], params: &BuildParams, progress: &BuildProgress) -> Subtree {
    let refs: Vec<PrimRef> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| PrimRef::new(t.bounds(), i as u32))
        .collect();
    let info = NodeInfo::of(&refs);
    let budget = (params.split_budget as f64 * triangles.len() as f64) as usize;
    let builder = Builder {
        triangles,
        params,
        progress,
        root_area: info.bounds.surface_area(),
    };
    let mut out = Subtree {
        nodes: vec![Node::default()],
        ..Default::default()
    };
    let root = builder.node(refs, info, budget, 0, &mut out);
    out.nodes[0] = root;
    out
}

struct Builder<'a> {
    triangles: &'a [Triangle],
    params: &'a BuildParams,
    progress: &'a BuildProgress<'a>,
    root_area: f32,
}

/// A spatial split: the plane `axis` = `position`, and the children's boxes and reference
/// counts as the bins estimated them.
#[derive(Clone, Copy, Debug)]
struct SpatialSplit {
    cost: f32,
    axis: usize,
    position: f32,
    left: Box3A,
    right: Box3A,
    n_left: usize,
    n_right: usize,
}

/// How a node is split, if at all.
enum Choice {
    Leaf,
    Object(ObjectSplit),
    Spatial(SpatialSplit),
    /// No SAH candidate (all centroids coincide, or beyond the depth limit) but the leaf
    /// would be too large: the object median, which halves the count.
    Median,
}

impl Builder<'_> {
    /// Builds the subtree over `refs`, appending its descendants to `out`, and returns its
    /// root. `budget` is how many references it may still duplicate.
    fn node(
        &self,
        mut refs: Vec<PrimRef>,
        info: NodeInfo,
        budget: usize,
        depth: u32,
        out: &mut Subtree,
    ) -> Node {
        let n = refs.len();
        let bounds = info.bounds.to_aabb();
        let mut choice = if !self.progress.is_abandoned() {
            self.choose(&mut refs, &info, budget, depth)
        } else if n > self.params.max_leaf_size as usize {
            Choice::Median
        } else {
            Choice::Leaf
        };
        if let Choice::Spatial(s) = &choice {
            if let Some(sides) = self.spatial_partition(&refs, s) {
                out.spatial_splits += 1;
                out.unsplit += sides.unsplit;
                let Sides {
                    left,
                    right,
                    left_info,
                    right_info,
                    ..
                } = sides;
                return self.interior(
                    bounds,
                    n,
                    [(left, left_info), (right, right_info)],
                    budget,
                    depth,
                    out,
                );
            }
            // Unsplitting emptied one side: choose again among whole references.
            choice = self.choose(&mut refs, &info, 0, depth);
        }
        let (m, li, ri): Split = match choice {
            Choice::Leaf => {
                let first = out.prims.len() as u32;
                out.prims.extend(refs.iter().map(|r| r.index));
                return Node::leaf(bounds, first, n as u32);
            }
            Choice::Object(o) => partition(&mut refs, |r| o.is_left(r)),
            Choice::Median if info.centroid_axis().1 => split_at(&refs, n / 2),
            Choice::Median | Choice::Spatial(_) => median::object_median(&mut refs, &info),
        };
        let right = refs.split_off(m);
        self.interior(bounds, n, [(refs, li), (right, ri)], budget, depth, out)
    }

    /// The interior node over `children` (references and infos), built below `depth`.
    fn interior(
        &self,
        bounds: Aabb,
        n: usize,
        children: [(Vec<PrimRef>, NodeInfo); 2],
        budget: usize,
        depth: u32,
        out: &mut Subtree,
    ) -> Node {
        let [(left, left_info), (right, right_info)] = children;
        // What the split duplicated comes out of the budget; the rest is shared in
        // proportion to the children's sizes.
        let used = (left.len() + right.len()).saturating_sub(n);
        let rest = budget.saturating_sub(used);
        let left_budget =
            (rest as u64 * left.len() as u64 / (left.len() + right.len()) as u64) as usize;
        let right_budget = rest - left_budget;

        let pair = out.nodes.len();
        out.nodes.extend([Node::default(); 2]);
        let (l, r) = if left.len() + right.len() >= PARALLEL_SUBTREE {
            let ((lroot, lsub), (rroot, rsub)) = rayon::join(
                || self.detached(left, left_info, left_budget, depth + 1),
                || self.detached(right, right_info, right_budget, depth + 1),
            );
            (out.append(lroot, lsub), out.append(rroot, rsub))
        } else {
            let l = self.node(left, left_info, left_budget, depth + 1, out);
            let r = self.node(right, right_info, right_budget, depth + 1, out);
            (l, r)
        };
        out.nodes[pair] = l;
        out.nodes[pair + 1] = r;
        Node::interior(bounds, pair as u32)
    }

    /// `node` into a subtree of its own, for another thread.
    fn detached(
        &self,
        refs: Vec<PrimRef>,
        info: NodeInfo,
        budget: usize,
        depth: u32,
    ) -> (Node, Subtree) {
        let mut sub = Subtree::default();
        let root = self.node(refs, info, budget, depth, &mut sub);
        (root, sub)
    }

    /// The SAH's choice between a leaf, the best object split and (if the overlap and the
    /// budget allow) the best spatial split.
    ///
    /// The SAH prices rays that never stop. Rays stop at their first hit, and front to back
    /// the far one of two disjoint children is skipped once a hit lies before it; in the
    /// overlap of an object split's children it cannot be. So when the two splits are
    /// weighed, the object split costs C · (1 + κ · A(L ∩ R) / A(N)): the share of the
    /// node's rays that enter the overlap, times the overlap penalty κ (0: the plain SAH, as
    /// Stich et al.; Popov et al. 2009 found that enforcing space subdivision pays).
    /// Whether to split at all is still the plain SAH's decision.
    fn choose(&self, refs: &mut [PrimRef], info: &NodeInfo, budget: usize, depth: u32) -> Choice {
        let n = refs.len();
        let p = self.params;
        let must_split = n > p.max_leaf_size as usize;
        if n == 1 {
            return Choice::Leaf;
        }
        if depth >= MEDIAN_FALLBACK_DEPTH {
            return if must_split {
                Choice::Median
            } else {
                Choice::Leaf
            };
        }
        let object = if info.centroid_axis().1 {
            None
        } else {
            sah_binned::best(refs, info, p, true)
        };
        // The overlap of the object split's children; with no object split the references
        // all share one centroid and overlap completely.
        let overlap = match &object {
            Some(o) => intersection_area(&o.left, &o.right),
            None => info.bounds.surface_area(),
        };
        let spatial = if budget > 0 && overlap > p.split_alpha * self.root_area {
            self.best_spatial(refs, info, budget)
        } else {
            None
        };
        let parent_area = info.bounds.surface_area();
        let object_cost = object.as_ref().map_or(f32::INFINITY, |o| {
            o.cost * (1.0 + p.overlap_penalty * overlap / parent_area.max(f32::MIN_POSITIVE))
        });
        match (object, spatial) {
            (_, Some(s)) if s.cost < object_cost => {
                if sah_worth_splitting(n, s.cost, parent_area, p) {
                    Choice::Spatial(s)
                } else {
                    Choice::Leaf
                }
            }
            (Some(o), _) => {
                if sah_worth_splitting(n, o.cost, parent_area, p) {
                    Choice::Object(o)
                } else {
                    Choice::Leaf
                }
            }
            _ if must_split => Choice::Median,
            _ => Choice::Leaf,
        }
    }

    /// The cheapest spatial split at the boundaries of `SPATIAL_BINS` equal slabs of the
    /// node's box on each axis, duplicating at most `budget` references (Stich et al., §4.2).
    /// A reference spanning several slabs is clipped to each: its part in a slab is the
    /// triangle clipped to the slab and to the reference's own box.
    fn best_spatial(
        &self,
        refs: &[PrimRef],
        info: &NodeInfo,
        budget: usize,
    ) -> Option<SpatialSplit> {
        let bounds = info.bounds;
        let grid = SlabGrid::new(bounds);
        let bins = if refs.len() >= PARALLEL_PASS {
            refs.par_chunks(PARALLEL_PASS / 4)
                .map(|chunk| self.fill_bins(chunk, &grid))
                .reduce(SpatialBins::default, SpatialBins::merge)
        } else {
            self.fill_bins(refs, &grid)
        };
        let parent_area = bounds.surface_area();
        let n = refs.len();
        let mut best: Option<SpatialSplit> = None;
        for axis in 0..3 {
            if grid.scale[axis] == 0.0 {
                continue;
            }
            let bins = &bins.axis[axis];
            // Right side: boxes and exits from the back.
            let mut right_box = [Box3A::EMPTY; SPATIAL_BINS];
            let mut right_count = [0usize; SPATIAL_BINS];
            let (mut acc, mut count) = (Box3A::EMPTY, 0usize);
            for k in (1..SPATIAL_BINS).rev() {
                acc = acc.union(bins[k].bounds);
                count += bins[k].exit as usize;
                right_box[k] = acc;
                right_count[k] = count;
            }
            let (mut acc, mut count) = (Box3A::EMPTY, 0usize);
            for k in 1..SPATIAL_BINS {
                acc = acc.union(bins[k - 1].bounds);
                count += bins[k - 1].enter as usize;
                let (n_left, n_right) = (count, right_count[k]);
                if n_left == 0 || n_right == 0 || n_left + n_right > n + budget {
                    continue;
                }
                let cost = sah_split_cost(
                    parent_area,
                    acc.surface_area(),
                    n_left,
                    right_box[k].surface_area(),
                    n_right,
                    self.params,
                );
                if best.is_none_or(|b| cost < b.cost) {
                    best = Some(SpatialSplit {
                        cost,
                        axis,
                        position: grid.plane(axis, k),
                        left: acc,
                        right: right_box[k],
                        n_left,
                        n_right,
                    });
                }
            }
        }
        best
    }

    /// Bins the references on every axis. The parts of a reference spanning several slabs
    /// come from chopping it at each slab boundary in turn (`split_estimate`); the chosen
    /// split is then made with the exact, conservative clip.
    fn fill_bins(&self, refs: &[PrimRef], grid: &SlabGrid) -> SpatialBins {
        #[cfg(target_arch = "x86_64")]
        if SimdLevel::Avx2.supported() {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.fill_bins_avx2(refs, grid) };
        }
        self.fill_bins_with(refs, grid)
    }

    /// `fill_bins` compiled for AVX2: the same operations (none fused, so the same bits)
    /// in three-operand forms, which spare the register copies the chopping loop's
    /// minima and maxima need in SSE2's two-operand ones.
    ///
    /// # Safety
    /// The CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn fill_bins_avx2(&self, refs: &[PrimRef], grid: &SlabGrid) -> SpatialBins {
        self.fill_bins_with(refs, grid)
    }

    #[inline(always)]
    fn fill_bins_with(&self, refs: &[PrimRef], grid: &SlabGrid) -> SpatialBins {
        let mut bins = SpatialBins::default();
        let [x, y, z] = &mut bins.axis;
        for r in refs {
            let tri = &self.triangles[r.index as usize];
            let v = tri.v.map(Vec3A::from);
            bin_on::<0>(r, &v, grid, x);
            bin_on::<1>(r, &v, grid, y);
            bin_on::<2>(r, &v, grid, z);
        }
        bins
    }

    /// Sends every reference to the side(s) of the plane it touches. A straddling one goes
    /// whole to one side if that costs less than duplicating it (Stich et al., §4.3), else
    /// it is split: each side gets the bounds of the triangle clipped to that side of its
    /// box. `None` if no reference ends up on one of the sides.
    fn spatial_partition(&self, refs: &[PrimRef], s: &SpatialSplit) -> Option<Sides> {
        let (axis, c) = (s.axis, s.position);
        let (area_l, area_r) = (s.left.surface_area(), s.right.surface_area());
        let (n_l, n_r) = (s.n_left as f32, s.n_right as f32);
        let split_cost = area_l * n_l + area_r * n_r;
        let mut sides = Sides::default();
        for r in refs {
            if r.max[axis] <= c {
                sides.push_left(*r);
            } else if r.min[axis] >= c {
                sides.push_right(*r);
            } else {
                let whole = r.box3a();
                let to_left = s.left.union(whole).surface_area() * n_l + area_r * (n_r - 1.0);
                let to_right = area_l * (n_l - 1.0) + s.right.union(whole).surface_area() * n_r;
                if to_left < split_cost && to_left <= to_right {
                    sides.push_left(*r);
                    sides.unsplit += 1;
                    continue;
                }
                if to_right < split_cost {
                    sides.push_right(*r);
                    sides.unsplit += 1;
                    continue;
                }
                let tri = &self.triangles[r.index as usize];
                let mut below = Aabb::new(r.min, r.max);
                below.max[axis] = c;
                let mut above = Aabb::new(r.min, r.max);
                above.min[axis] = c;
                let parts = (clipped_bounds(tri, &below), clipped_bounds(tri, &above));
                if let Some(b) = parts.0 {
                    sides.push_left(PrimRef::new(b, r.index));
                }
                if let Some(b) = parts.1 {
                    sides.push_right(PrimRef::new(b, r.index));
                }
                if parts == (None, None) {
                    // The clip lost the triangle to rounding: keep the reference as it is.
                    sides.push_left(*r);
                }
            }
        }
        (!sides.left.is_empty() && !sides.right.is_empty()).then_some(sides)
    }
}

/// The area of the intersection of two boxes (0 if they are disjoint).
fn intersection_area(a: &Box3A, b: &Box3A) -> f32 {
    a.intersect(b).surface_area()
}

/// The children of a spatial split.
#[derive(Default)]
struct Sides {
    left: Vec<PrimRef>,
    right: Vec<PrimRef>,
    left_info: NodeInfo,
    right_info: NodeInfo,
    unsplit: usize,
}

impl Sides {
    fn push_left(&mut self, r: PrimRef) {
        self.left_info.add(&r);
        self.left.push(r);
    }

    fn push_right(&mut self, r: PrimRef) {
        self.right_info.add(&r);
        self.right.push(r);
    }
}

/// The slabs of a node's box: slab k on an axis spans plane(k)..plane(k + 1).
struct SlabGrid {
    origin: Vec3A,
    extent: Vec3A,
    /// Slabs per unit length on each axis, 0 on a flat axis.
    scale: Vec3A,
}

impl SlabGrid {
    fn new(bounds: Box3A) -> Self {
        let extent = bounds.max - bounds.min;
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            SPATIAL_BINS as f32 / extent,
            Vec3A::ZERO,
        );
        SlabGrid {
            origin: bounds.min,
            extent,
            scale,
        }
    }

    /// The slab holding coordinate `x` on `axis`.
    #[inline(always)]
    fn slab(&self, axis: usize, x: f32) -> usize {
        let k = (x - self.origin[axis]) * self.scale[axis];
        (k.max(0.0) as usize).min(SPATIAL_BINS - 1)
    }

    /// The boundary between slabs k − 1 and k.
    #[inline(always)]
    fn plane(&self, axis: usize, k: usize) -> f32 {
        self.origin[axis] + self.extent[axis] * (k as f32 / SPATIAL_BINS as f32)
    }
}

#[derive(Clone, Copy)]
struct SpatialBin {
    /// The clipped parts of the references in this slab.
    bounds: Box3A,
    /// References whose first slab is this one.
    enter: u32,
    /// References whose last slab is this one.
    exit: u32,
}

impl Default for SpatialBin {
    fn default() -> Self {
        SpatialBin {
            bounds: Box3A::EMPTY,
            enter: 0,
            exit: 0,
        }
    }
}

#[derive(Clone, Copy)]
struct SpatialBins {
    axis: [[SpatialBin; SPATIAL_BINS]; 3],
}

impl Default for SpatialBins {
    fn default() -> Self {
        SpatialBins {
            axis: [[SpatialBin::default(); SPATIAL_BINS]; 3],
        }
    }
}

impl SpatialBins {
    fn merge(mut self, o: SpatialBins) -> SpatialBins {
        for (a, b) in self.axis.iter_mut().flatten().zip(o.axis.iter().flatten()) {
            a.bounds = a.bounds.union(b.bounds);
            a.enter += b.enter;
            a.exit += b.exit;
        }
        self
    }
}

/// Bins reference `r` (of the triangle `v`) on axis `AXIS`: a constant, so that every
/// coordinate of that axis is a lane picked at compile time (as a variable, each was a store
/// and a load, in the loop that chops a reference at each slab boundary).
#[inline(always)]
fn bin_on<const AXIS: usize>(
    r: &PrimRef,
    v: &[Vec3A; 3],
    grid: &SlabGrid,
    bins: &mut [SpatialBin; SPATIAL_BINS],
) {
    if grid.scale[AXIS] == 0.0 {
        return;
    }
    let first = grid.slab(AXIS, r.min[AXIS]);
    let last = grid.slab(AXIS, r.max[AXIS]);
    bins[first].enter += 1;
    bins[last].exit += 1;
    if first == last {
        bins[first].bounds.grow(r.lo(), r.hi());
        return;
    }
    let mut rest = r.box3a();
    // `first < last < SPATIAL_BINS` (`slab` clamps): the slice of slabs crossed, where
    // `enumerate().take().skip()` over all of them cost a division a step.
    for (k, bin) in (first + 1..).zip(&mut bins[first..last]) {
        let (below, above) = split_estimate::<AXIS>(v, &rest, grid.plane(AXIS, k));
        bin.bounds = bin.bounds.union(below);
        rest = above;
    }
    bins[last].bounds = bins[last].bounds.union(rest);
}

/// Splits the reference box `b` of `tri` at the plane `AXIS` = `c` the way the paper bins
/// (Stich et al., §4.2): the triangle's edges give the points on each side and where they
/// cross the plane, and each side's bounds are cut back to `b`. Looser than clipping the
/// triangle to `b` first, but a handful of operations: the bins only estimate the cost.
///
/// The three edges' distances to the plane and crossing fractions are found at once, in
/// the lanes of one vector (one division where each crossing edge had its own); the
/// points are then taken edge by edge in the same order, so the boxes are the same bits as
/// an edge-by-edge pass (`split_estimate_edge_by_edge` in the tests).
#[inline(always)]
fn split_estimate<const AXIS: usize>(v: &[Vec3A; 3], b: &Box3A, c: f32) -> (Box3A, Box3A) {
    // Edge i runs from v[i] to v[i + 1]: its ends' signed distances to the plane.
    let dp = Vec3A::new(v[0][AXIS], v[1][AXIS], v[2][AXIS]) - Vec3A::splat(c);
    let dq = Vec3A::new(dp.y, dp.z, dp.x);
    let t = dp / (dp - dq);
    let zero = Vec3A::ZERO;
    let below_p = dp.cmple(zero).bitmask();
    let above_p = dp.cmpge(zero).bitmask();
    let crosses = ((dp.cmplt(zero) & dq.cmpgt(zero)) | (dp.cmpgt(zero) & dq.cmplt(zero))).bitmask();
    let (mut below, mut above) = (Box3A::EMPTY, Box3A::EMPTY);
    for i in 0..3 {
        let (p, q) = (v[i], v[(i + 1) % 3]);
        if below_p >> i & 1 == 1 {
            below.grow(p, p);
        }
        if above_p >> i & 1 == 1 {
            above.grow(p, p);
        }
        if crosses >> i & 1 == 1 {
            let mut x = p + (q - p) * t[i];
            x[AXIS] = c;
            below.grow(x, x);
            above.grow(x, x);
        }
    }
    let mut below_box = *b;
    below_box.max[AXIS] = c;
    let mut above_box = *b;
    above_box.min[AXIS] = c;
    (below.intersect(&below_box), above.intersect(&above_box))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's split, edge by edge, as the build ran it before the edges were taken at
    /// once: the reference `split_estimate` must equal.
    fn split_estimate_edge_by_edge(
        v: &[Vec3A; 3],
        b: &Box3A,
        axis: usize,
        c: f32,
    ) -> (Box3A, Box3A) {
        let (mut below, mut above) = (Box3A::EMPTY, Box3A::EMPTY);
        for i in 0..3 {
            let (p, q) = (v[i], v[(i + 1) % 3]);
            let (dp, dq) = (p[axis] - c, q[axis] - c);
            if dp <= 0.0 {
                below.grow(p, p);
            }
            if dp >= 0.0 {
                above.grow(p, p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                let mut x = p + (q - p) * (dp / (dp - dq));
                x[axis] = c;
                below.grow(x, x);
                above.grow(x, x);
            }
        }
        let mut below_box = *b;
        below_box.max[axis] = c;
        let mut above_box = *b;
        above_box.min[axis] = c;
        (below.intersect(&below_box), above.intersect(&above_box))
    }

    /// The same boxes to the bit (signed zeros included) on random triangles, on planes
    /// through their vertices, at ±0 and at random, on each axis.
    #[test]
    fn split_estimate_equals_the_edge_by_edge_split() {
        let mut rng = crate::random::Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = || {
            let x = rng.unit() as f32 * 4.0 - 2.0;
            // Coordinates on a coarse grid, so vertices share planes and zeros often.
            if x.abs() < 0.3 {
                if x < 0.0 { -0.0 } else { 0.0 }
            } else {
                (x * 4.0).round() / 4.0
            }
        };
        let bits = |b: (Box3A, Box3A)| {
            [b.0.min, b.0.max, b.1.min, b.1.max].map(|v| v.to_array().map(f32::to_bits))
        };
        let mut checked = 0;
        for _ in 0..20_000 {
            let v = [0; 3].map(|_| Vec3A::new(next(), next(), next()));
            let b = Box3A {
                min: v[0].min(v[1]).min(v[2]),
                max: v[0].max(v[1]).max(v[2]),
            };
            for (axis, c) in [(0, next()), (1, v[1].y), (2, -0.0), (0, v[2].x), (1, 0.0)] {
                let want = split_estimate_edge_by_edge(&v, &b, axis, c);
                let got = match axis {
                    0 => split_estimate::<0>(&v, &b, c),
                    1 => split_estimate::<1>(&v, &b, c),
                    _ => split_estimate::<2>(&v, &b, c),
                };
                assert_eq!(bits(got), bits(want), "{v:?} on axis {axis} at {c}");
                checked += 1;
            }
        }
        assert_eq!(checked, 100_000);
    }
}
