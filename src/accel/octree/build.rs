//! Octree construction, top down: a cell holding more than `max_leaf_size` triangles is cut
//! at its centre into eight octants, each triangle listed in the octants it really overlaps
//! (exact triangle–box test, only where its bounding box straddles a mid plane), and only
//! the non-empty octants are kept.

use super::{MAX_REFERENCES_PER_TRIANGLE, Node, Octree, OctreeError, OctreeParams};
use crate::accel::StructureReport;
use crate::accel::grid::{PAD, mark_shared};
use crate::accel::progress::BuildProgress;
use crate::accel::report::Detail;
use crate::geometry::overlap::TriangleSat;
use crate::geometry::simd::SimdLevel;
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// A split that would list each triangle in more than this many octants on average does
/// not help: the triangles are larger than the octants, and splitting further only copies
/// them.
const DUPLICATION: usize = 4;
/// Cells over at least this many triangles build their octants' subtrees on other threads,
/// and split their triangles in chunks on other threads.
const PARALLEL_CELL: usize = 4096;
/// The chunk of a parallel split.
const SPLIT_CHUNK: usize = 2048;

/// Builds the octree over `triangles`.
pub fn build(
    triangles: &[Triangle],
    params: &OctreeParams,
) -> Result<(Octree, StructureReport), OctreeError> {
    build_with_progress(triangles, params, &BuildProgress::default())
}

/// `build`; an abandoned build (`progress`) makes every cell it has not split yet a leaf.
pub fn build_with_progress(
    triangles: &[Triangle],
    params: &OctreeParams,
    progress: &BuildProgress,
) -> Result<(Octree, StructureReport), OctreeError> {
    build_from(triangles, params, progress, PARALLEL_CELL)
}

/// `build_with_progress`, cells of at least `parallel_cell` triangles built in parallel.
fn build_from(
    triangles: &[Triangle],
    params: &OctreeParams,
    progress: &BuildProgress,
    parallel_cell: usize,
) -> Result<(Octree, StructureReport), OctreeError> {
    params.validate()?;
    if triangles.len() >= (u32::MAX / 2) as usize {
        return Err(OctreeError::TooMany(triangles.len()));
    }
    if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
        return Err(OctreeError::NonFinite(i));
    }
    let start = Instant::now();
    let bounds = triangles
        .par_iter()
        .map(|t| t.bounds())
        .reduce(|| Aabb::EMPTY, Aabb::union);
    let (root_min, root_size) = if bounds.is_empty() {
        (DVec3::ZERO, 0.0)
    } else {
        (
            bounds.min.as_dvec3(),
            bounds.extent().as_dvec3().max_element(),
        )
    };
    let mut b = Builder::new(triangles, params, progress, root_size * PAD, parallel_cell);
    let budget = MAX_REFERENCES_PER_TRIANGLE * triangles.len() + 4096;
    b.node(
        0,
        root_min,
        root_size,
        (0..triangles.len() as u32).collect(),
        0,
        budget,
    );
    let (nodes, mut refs, caps) = (b.nodes, b.refs, b.caps);
    mark_shared(&mut refs, triangles.len());
    let max = root_min + root_size;
    // The f32 cube rounded outwards, so the entry test never rejects a ray the f64 cube
    // admits.
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x { f.next_up() } else { f }
    };
    let octree = Octree {
        root_min,
        root_size,
        bounds: if bounds.is_empty() {
            Aabb::EMPTY
        } else {
            Aabb::new(bounds.min, glam::Vec3::new(up(max.x), up(max.y), up(max.z)))
        },
        nodes,
        refs,
        triangles: triangles.to_vec(),
        mailbox: params.mailbox,
    };
    let build_time = start.elapsed();
    let report = report(&octree, params, &caps, build_time);
    Ok((octree, report))
}

#[derive(Default, Clone, Copy)]
struct Caps {
    /// Leaves at the depth bound still above the leaf size.
    depth: usize,
    /// Leaves kept whole because splitting would not help: every non-empty octant (two or
    /// more) would have held all the cell's triangles, or each triangle would have been
    /// copied into more than `DUPLICATION` octants on average.
    unsplittable: usize,
    /// Leaves kept whole because the reference budget ran out.
    budget: usize,
    /// Empty octants of split cells (not stored).
    empty_octants: usize,
    max_depth: u32,
}

impl Caps {
    /// Adds a subtree's caps built apart.
    fn add(&mut self, part: &Caps) {
        self.depth += part.depth;
        self.unsplittable += part.unsplittable;
        self.budget += part.budget;
        self.empty_octants += part.empty_octants;
        self.max_depth = self.max_depth.max(part.max_depth);
    }
}

struct Builder<'a> {
    triangles: &'a [Triangle],
    params: &'a OctreeParams,
    progress: &'a BuildProgress<'a>,
    pad: f64,
    /// `PARALLEL_CELL`, or `usize::MAX` for the tests' build on one thread.
    parallel_cell: usize,
    nodes: Vec<Node>,
    refs: Vec<u32>,
    caps: Caps,
}

impl<'a> Builder<'a> {
    /// A builder with only its root (node 0, to be built) and no references yet.
    fn new(
        triangles: &'a [Triangle],
        params: &'a OctreeParams,
        progress: &'a BuildProgress<'a>,
        pad: f64,
        parallel_cell: usize,
    ) -> Self {
        Builder {
            triangles,
            params,
            progress,
            pad,
            parallel_cell,
            nodes: vec![Node {
                first: 0,
                count: 0,
                mask: 0,
            }],
            refs: Vec::new(),
            caps: Caps::default(),
        }
    }

    /// Builds node `index`, the cube at `min` with side `size`, over `tris`, with at most
    /// `budget` references in its leaves. The recursion is at most `MAX_DEPTH` + 1 deep.
    fn node(
        &mut self,
        index: usize,
        min: DVec3,
        size: f64,
        tris: Vec<u32>,
        depth: u32,
        budget: usize,
    ) {
        let n = tris.len();
        if n <= self.params.max_leaf_size as usize || self.progress.is_abandoned() {
            return self.leaf(index, tris, depth);
        }
        if depth >= self.params.max_depth {
            self.caps.depth += 1;
            return self.leaf(index, tris, depth);
        }
        let half = size * 0.5;
        let octants = self.split(&tris, min, half);
        let sizes = octants.each_ref().map(Vec::len);
        let non_empty = sizes.iter().filter(|&&s| s > 0).count();
        let total: usize = sizes.iter().sum();
        if (non_empty >= 2 && sizes.iter().all(|&s| s == 0 || s == n)) || total > DUPLICATION * n {
            self.caps.unsplittable += 1;
            return self.leaf(index, tris, depth);
        }
        if total > budget {
            self.caps.budget += 1;
            return self.leaf(index, tris, depth);
        }
        drop(tris);
        self.caps.empty_octants += 8 - non_empty;
        let first = self.nodes.len();
        let mut mask = 0u8;
        for (o, s) in sizes.iter().enumerate() {
            if *s > 0 {
                mask |= 1 << o;
            }
        }
        self.nodes[index] = Node {
            first: first as u32,
            count: 0,
            mask,
        };
        self.nodes.resize(first + non_empty, self.nodes[index]);
        let child_of = |o: usize, list: &Vec<u32>| {
            let corner = DVec3::new((o & 1) as f64, (o >> 1 & 1) as f64, (o >> 2 & 1) as f64);
            // Each child may grow in proportion to its share of the references, so the
            // budget is not spent on whichever dense region the build reaches first.
            let share = (budget as u128 * list.len() as u128 / total as u128) as usize;
            (min + corner * half, share)
        };
        if n < self.parallel_cell {
            let mut child = first;
            for (o, list) in octants.into_iter().enumerate() {
                if list.is_empty() {
                    continue;
                }
                let (child_min, share) = child_of(o, &list);
                self.node(child, child_min, half, list, depth + 1, share);
                child += 1;
            }
            return;
        }
        // Each octant's subtree built apart, on other threads, then laid out as the loop
        // above lays it out: after its siblings' subtrees, its leaves' references after
        // theirs. The octree is the same on any number of threads.
        let parts: Vec<Builder> = octants
            .into_par_iter()
            .enumerate()
            .filter(|(_, list)| !list.is_empty())
            .map(|(o, list)| {
                let (child_min, share) = child_of(o, &list);
                let mut part = self.part();
                part.node(0, child_min, half, list, depth + 1, share);
                part
            })
            .collect();
        for (k, part) in parts.into_iter().enumerate() {
            // The part's node 0 is the child itself; its others follow the nodes so far.
            let (nodes, refs) = (self.nodes.len() as u32 - 1, self.refs.len() as u32);
            let placed = |n: &Node| Node {
                first: n.first + if n.is_leaf() { refs } else { nodes },
                ..*n
            };
            let mut placed_nodes = part.nodes.iter().map(placed);
            if let Some(root) = placed_nodes.next() {
                self.nodes[first + k] = root;
            }
            self.nodes.extend(placed_nodes);
            self.refs.extend_from_slice(&part.refs);
            self.caps.add(&part.caps);
        }
    }

    /// A builder for a subtree built apart: the same scene and parameters, its own nodes
    /// (node 0 its root), references and caps.
    fn part(&self) -> Self {
        Builder::new(
            self.triangles,
            self.params,
            self.progress,
            self.pad,
            self.parallel_cell,
        )
    }

    fn leaf(&mut self, index: usize, tris: Vec<u32>, depth: u32) {
        self.caps.max_depth = self.caps.max_depth.max(depth);
        self.nodes[index] = Node {
            first: self.refs.len() as u32,
            count: tris.len() as u32,
            mask: 0,
        };
        self.refs.extend_from_slice(&tris);
    }

    /// The triangles of each octant of the cube at `min` with side 2·`half`: compiled for
    /// AVX2 where the CPU has it, so that the separating axes' loops (`TriangleSlabs`) run
    /// four f64 lanes at a time instead of SSE2's two (nothing fused, the same bits).
    fn split(&self, tris: &[u32], min: DVec3, half: f64) -> [Vec<u32>; 8] {
        if tris.len() >= self.parallel_cell {
            // In chunks on other threads, each chunk's lists appended in order: the same
            // lists as one pass.
            let chunks: Vec<[Vec<u32>; 8]> = tris
                .par_chunks(SPLIT_CHUNK)
                .map(|chunk| self.split_serial(chunk, min, half))
                .collect();
            let mut out: [Vec<u32>; 8] = Default::default();
            for (o, list) in out.iter_mut().enumerate() {
                list.reserve(chunks.iter().map(|c| c[o].len()).sum());
                for c in &chunks {
                    list.extend_from_slice(&c[o]);
                }
            }
            return out;
        }
        self.split_serial(tris, min, half)
    }

    /// `split` on this thread.
    fn split_serial(&self, tris: &[u32], min: DVec3, half: f64) -> [Vec<u32>; 8] {
        #[cfg(target_arch = "x86_64")]
        if SimdLevel::Avx2.supported() {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.split_avx2(tris, min, half) };
        }
        self.split_with(tris, min, half)
    }

    /// # Safety
    /// The CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn split_avx2(&self, tris: &[u32], min: DVec3, half: f64) -> [Vec<u32>; 8] {
        self.split_with(tris, min, half)
    }

    #[inline(always)]
    fn split_with(&self, tris: &[u32], min: DVec3, half: f64) -> [Vec<u32>; 8] {
        let mid = min + half;
        let mut out: [Vec<u32>; 8] = Default::default();
        let pad = self.pad;
        for &t in tris {
            let tri = &self.triangles[t as usize];
            let b = tri.bounds();
            let (lo, hi) = (b.min.as_dvec3() - pad, b.max.as_dvec3() + pad);
            // Per axis: may the triangle reach the lower half (bit 0), the upper (bit 1)?
            let side = |k: usize| u8::from(lo[k] <= mid[k]) | u8::from(hi[k] >= mid[k]) << 1;
            // Written out: `[0, 1, 2].map(side)` stayed a call of 67 instructions.
            let sides = [side(0), side(1), side(2)];
            let single = sides.iter().all(|&s| s != 3);
            if single {
                // On one side of every mid plane: the triangle overlaps this cell, so it
                // overlaps that octant.
                let o = (0..3).fold(0, |o, k| o | usize::from(sides[k] == 2) << k);
                out[o].push(t);
                continue;
            }
            let slabs = TriangleSat::new(tri).slabs(DVec3::splat(half * 0.5 + pad));
            for (o, list) in out.iter_mut().enumerate() {
                let bit = |k: usize| o >> k & 1;
                if (0..3).any(|k| sides[k] >> bit(k) & 1 == 0) {
                    continue;
                }
                let corner = DVec3::new(bit(0) as f64, bit(1) as f64, bit(2) as f64);
                if slabs.overlaps_centered(min + corner * half + half * 0.5) {
                    list.push(t);
                }
            }
        }
        out
    }
}

fn report(
    octree: &Octree,
    params: &OctreeParams,
    caps: &Caps,
    build_time: std::time::Duration,
) -> StructureReport {
    let leaves: Vec<&Node> = octree.nodes.iter().filter(|n| n.is_leaf()).collect();
    let stored_empty = leaves.iter().filter(|n| n.count == 0).count();
    let mut caps_hit = Vec::new();
    if caps.depth > 0 {
        caps_hit.push(format!(
            "{} leaves at the depth bound {} hold more than {} triangles",
            caps.depth, params.max_depth, params.max_leaf_size
        ));
    }
    if caps.unsplittable > 0 {
        caps_hit.push(format!(
            "{} leaves hold more than {} triangles: splitting them would put all of them \
             in every non-empty octant, or copy each into more than {DUPLICATION}",
            caps.unsplittable, params.max_leaf_size
        ));
    }
    if caps.budget > 0 {
        caps_hit.push(format!(
            "{} leaves left unsplit: their share of the reference budget ({} per triangle) ran out",
            caps.budget, MAX_REFERENCES_PER_TRIANGLE
        ));
    }
    StructureReport {
        structure: "octree",
        triangles: octree.triangles.len(),
        build_time,
        bytes: octree.bytes(),
        nodes: octree.nodes.len(),
        leaves: leaves.len() + caps.empty_octants,
        empty_leaves: stored_empty + caps.empty_octants,
        max_depth: caps.max_depth,
        references: octree.refs.len(),
        largest_leaf: leaves.iter().map(|n| n.count as usize).max().unwrap_or(0),
        details: vec![
            (
                "max leaf size".into(),
                Detail::Count(params.max_leaf_size.into()),
            ),
            ("depth bound".into(), Detail::Count(params.max_depth.into())),
            ("root cube side".into(), Detail::Number(octree.root_size, 4)),
            (
                "empty octants (not stored)".into(),
                Detail::count(caps.empty_octants),
            ),
        ],
        caps_hit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::by_name;

    /// Cells built in parallel, their subtrees laid out after each other, give the octree of
    /// the build on one thread: the same nodes in the same places, the same references.
    #[test]
    fn the_parallel_build_lays_out_the_octree_of_the_serial_one() {
        let progress = BuildProgress::default();
        for spec in [
            "teapot-in-stadium",
            "soup:20000",
            "grass:3000",
            "walls-rotated",
        ] {
            let scene = by_name(spec).unwrap().unwrap();
            let triangles = scene.flattened().unwrap();
            let params = OctreeParams::default();
            // Small cells in parallel too, so that many parts are laid out.
            let parallel = build_from(&triangles, &params, &progress, 64).unwrap().0;
            let serial = build_from(&triangles, &params, &progress, usize::MAX)
                .unwrap()
                .0;
            assert!(parallel.nodes.len() > 8, "{spec}: too few cells to tell");
            assert_eq!(parallel.nodes, serial.nodes, "{spec}: the cells differ");
            assert_eq!(parallel.refs, serial.refs, "{spec}: the references differ");
        }
    }
}
