//! LBVH (Karras 2012, "Maximizing parallelism in the construction of BVHs, octrees and k-d
//! trees"): sort the primitives along a Morton curve through their centroids, then find every
//! internal node of the radix tree over the sorted codes independently of the others. The
//! build is a few parallel passes and never looks at the SAH; the tree follows the curve.

use super::linked_tree::{LinkedNode, LinkedTree, SahCost};
use super::prim::PrimRef;
use super::radix_sort::{self, Keyed};
use super::{BuildParams, PARALLEL_SUBTREE, Strategy, treelet};
use crate::accel::bvh::report::BuildPhases;
use crate::geometry::{Aabb, Triangle};
use rayon::prelude::*;
use std::time::Instant;

/// Bits per axis of a Morton code: 3 × 21 = 63 bits.
const MORTON_BITS: u32 = 21;

/// Spreads the low 21 bits of `v` so that bit k moves to bit 3k.
#[inline(always)]
fn spread_bits(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// The Morton code of a point quantised to 21 bits per axis: x, y and z bits interleaved,
/// x the most significant of each triple.
#[inline(always)]
pub fn morton3(q: [u32; 3]) -> u64 {
    (spread_bits(q[0] as u64) << 2) | (spread_bits(q[1] as u64) << 1) | spread_bits(q[2] as u64)
}

/// Quantises centroids into a 2^21 grid over their bounds. Computed in f64 so that huge
/// coordinates neither overflow nor lose the grid; a flat axis maps to 0.
struct Quantizer {
    origin: [f64; 3],
    scale: [f64; 3],
}

impl Quantizer {
    fn new(centroids: &CentroidBounds) -> Self {
        let cells = (1u64 << MORTON_BITS) as f64;
        let mut scale = [0.0; 3];
        for (axis, s) in scale.iter_mut().enumerate() {
            let extent = centroids.max[axis] - centroids.min[axis];
            if extent > 0.0 {
                *s = cells / extent;
            }
        }
        Quantizer {
            origin: centroids.min,
            scale,
        }
    }

    #[inline(always)]
    fn code(&self, c: [f64; 3]) -> u64 {
        let top = ((1u32 << MORTON_BITS) - 1) as f64;
        let q =
            |axis: usize| ((c[axis] - self.origin[axis]) * self.scale[axis]).clamp(0.0, top) as u32;
        morton3([q(0), q(1), q(2)])
    }
}

/// The bounds of the centroids, in f64.
#[derive(Clone, Copy)]
struct CentroidBounds {
    min: [f64; 3],
    max: [f64; 3],
}

impl CentroidBounds {
    const EMPTY: CentroidBounds = CentroidBounds {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    /// The bounds grown by the finite point `c` (a compare and a select per bound: no NaN
    /// to handle, as `f64::min` does).
    #[inline(always)]
    fn grow(self, c: [f64; 3]) -> Self {
        CentroidBounds {
            min: std::array::from_fn(|k| {
                if c[k] < self.min[k] {
                    c[k]
                } else {
                    self.min[k]
                }
            }),
            max: std::array::from_fn(|k| {
                if c[k] > self.max[k] {
                    c[k]
                } else {
                    self.max[k]
                }
            }),
        }
    }

    #[inline(always)]
    fn union(self, o: CentroidBounds) -> Self {
        CentroidBounds {
            min: std::array::from_fn(|k| self.min[k].min(o.min[k])),
            max: std::array::from_fn(|k| self.max[k].max(o.max[k])),
        }
    }
}

#[inline(always)]
fn centroid(b: &Aabb) -> [f64; 3] {
    std::array::from_fn(|k| 0.5 * (b.min[k] as f64 + b.max[k] as f64))
}

/// A child in the radix tree: a leaf (a sorted position) or an internal node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Child {
    Leaf(u32),
    Internal(u32),
}

/// An internal node of the radix tree: its children and the number of keys it covers.
#[derive(Clone, Copy, Debug)]
struct RadixNode {
    left: Child,
    right: Child,
    count: u32,
}

/// The radix tree over sorted keys (Karras 2012, §4): internal node i covers a range of keys
/// that starts or ends at key i, and node 0 is the root.
struct RadixTree<'a> {
    codes: &'a [u64],
}

impl RadixTree<'_> {
    /// δ(i, j): the length of the common prefix of keys i and j, −1 outside the array.
    /// Equal codes are told apart by their positions, as if each key were the code followed
    /// by its index (Karras 2012, §4).
    #[inline(always)]
    fn delta(&self, i: i64, j: i64) -> i32 {
        if j < 0 || j >= self.codes.len() as i64 {
            return -1;
        }
        let (a, b) = (self.codes[i as usize], self.codes[j as usize]);
        if a != b {
            (a ^ b).leading_zeros() as i32
        } else {
            64 + ((i ^ j) as u32).leading_zeros() as i32
        }
    }

    /// Internal node `i`, found from the keys alone (Karras 2012, Figure 4).
    fn node(&self, i: usize) -> RadixNode {
        let i = i as i64;
        // The direction of the range: towards the neighbour sharing the longer prefix.
        let d: i64 = if self.delta(i, i + 1) >= self.delta(i, i - 1) {
            1
        } else {
            -1
        };
        // The other end: beyond it the prefix gets shorter than the one shared with the
        // neighbour on the other side. Exponential search for an upper bound, then binary.
        let delta_min = self.delta(i, i - d);
        let mut l_max: i64 = 2;
        while self.delta(i, i + l_max * d) > delta_min {
            l_max *= 2;
        }
        let mut l = 0;
        let mut t = l_max / 2;
        while t >= 1 {
            if self.delta(i, i + (l + t) * d) > delta_min {
                l += t;
            }
            t /= 2;
        }
        let j = i + l * d;
        // The split: the last key in the range that still shares the node's prefix with i.
        let delta_node = self.delta(i, j);
        let mut s = 0;
        let mut div = 2;
        loop {
            let t = (l + div - 1) / div;
            if self.delta(i, i + (s + t) * d) > delta_node {
                s += t;
            }
            if t == 1 {
                break;
            }
            div *= 2;
        }
        let gamma = i + s * d + d.min(0);
        let (lo, hi) = (i.min(j), i.max(j));
        let child = |k: i64, is_leaf: bool| {
            if is_leaf {
                Child::Leaf(k as u32)
            } else {
                Child::Internal(k as u32)
            }
        };
        RadixNode {
            left: child(gamma, lo == gamma),
            right: child(gamma + 1, hi == gamma + 1),
            count: (hi - lo + 1) as u32,
        }
    }
}

/// The radix tree as a linked tree in preorder, boxes and costs computed bottom-up.
fn linked_tree(internal: &[RadixNode], leaf_bounds: &[Aabb], sah: &SahCost) -> LinkedTree {
    let n = leaf_bounds.len();
    let root = if n == 1 {
        Child::Leaf(0)
    } else {
        Child::Internal(0)
    };
    // Filled on every thread: the first touch of its pages is a large part of its cost.
    let mut nodes = Vec::with_capacity(2 * n - 1);
    nodes.par_extend(rayon::iter::repeat_n(
        LinkedNode::leaf(Aabb::EMPTY, 0, sah),
        2 * n - 1,
    ));
    let fill = Fill {
        internal,
        leaf_bounds,
        sah,
    };
    fill.subtree(root, &mut nodes, 0);
    LinkedTree { nodes }
}

struct Fill<'a> {
    internal: &'a [RadixNode],
    leaf_bounds: &'a [Aabb],
    sah: &'a SahCost,
}

impl Fill<'_> {
    fn count(&self, c: Child) -> usize {
        match c {
            Child::Leaf(_) => 1,
            Child::Internal(i) => self.internal[i as usize].count as usize,
        }
    }

    /// Writes the subtree of `c` into `out` in preorder, `out[0]` being node `base`. The
    /// recursion is as deep as the radix tree, which is at most 97 levels: each level
    /// lengthens the common prefix of 63 code bits and 32 index bits.
    fn subtree(&self, c: Child, out: &mut [LinkedNode], base: u32) {
        let node = match c {
            Child::Leaf(k) => {
                out[0] = LinkedNode::leaf(self.leaf_bounds[k as usize], k, self.sah);
                return;
            }
            Child::Internal(i) => self.internal[i as usize],
        };
        let left_size = 2 * self.count(node.left) - 1;
        let (head, rest) = out.split_at_mut(1);
        let (lo, ro) = rest.split_at_mut(left_size);
        let (left, right) = (base + 1, base + 1 + left_size as u32);
        let mut l = || self.subtree(node.left, lo, left);
        let mut r = || self.subtree(node.right, ro, right);
        if node.count as usize >= PARALLEL_SUBTREE {
            rayon::join(l, r);
        } else {
            l();
            r();
        }
        head[0] = LinkedNode::interior(left, &lo[0], right, &ro[0], self.sah);
    }
}

/// The Morton code of each reference's centroid (63 bits: 21 per axis, over the centroids'
/// bounds), with its index into `refs`, in `refs`' order; and the references' boxes.
fn morton_keys(refs: &[PrimRef], phases: &mut BuildPhases) -> (Vec<Keyed>, Vec<Aabb>) {
    let start = Instant::now();
    let bounds: Vec<Aabb> = refs.par_iter().map(|r| Aabb::new(r.min, r.max)).collect();
    let centroids = bounds
        .par_iter()
        .fold(|| CentroidBounds::EMPTY, |b, t| b.grow(centroid(t)))
        .reduce(|| CentroidBounds::EMPTY, CentroidBounds::union);
    let quantizer = Quantizer::new(&centroids);
    let keyed: Vec<Keyed> = bounds
        .par_iter()
        .enumerate()
        .map(|(i, b)| Keyed {
            key: quantizer.code(centroid(b)),
            value: i as u32,
        })
        .collect();
    phases.add("Morton codes", start.elapsed());
    (keyed, bounds)
}

/// Triangles a task of `triangle_codes_into`'s first pass takes.
const CODE_CHUNK: usize = 1 << 14;

/// The Morton code of each triangle's box centroid, as `morton_keys` codes a whole
/// reference, packed with the triangle's index by `pack(code, index)` into `keys`, which is
/// emptied first and keeps its memory: a scene rebuilt every frame writes its codes over
/// last frame's. Each box is made twice, for the centroids' bounds and for the code, rather
/// than kept between the passes: a build from nothing pays more for a fresh array's pages
/// (240 MB for 10^7 triangles) than for reading the triangles again.
pub(crate) fn triangle_codes_into(
    triangles: &[Triangle],
    keys: &mut Vec<u64>,
    pack: impl Fn(u64, u32) -> u64 + Sync,
) {
    let bounds = triangles
        .par_chunks(CODE_CHUNK)
        .map(|tris| {
            tris.iter()
                .fold(CentroidBounds::EMPTY, |c, t| c.grow(centroid(&t.bounds())))
        })
        .reduce(|| CentroidBounds::EMPTY, CentroidBounds::union);
    let quantizer = Quantizer::new(&bounds);
    keys.clear();
    keys.par_extend(
        triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| pack(quantizer.code(centroid(&t.bounds())), i as u32)),
    );
}

/// Builds the LBVH (and, for `Strategy::LbvhTreelet`, restructures it) over the triangle
/// references `refs`, which is not empty. Returns the nodes, the leaf order as triangle
/// indices, and the time of each phase.
pub fn build(
    refs: &[PrimRef],
    params: &BuildParams,
) -> (crate::accel::bvh::Nodes, Vec<u32>, BuildPhases) {
    let sah = SahCost {
        c_trav: params.c_trav as f64,
        c_isect: params.c_isect as f64,
        max_leaf_size: params.max_leaf_size,
    };
    let mut phases = BuildPhases::default();
    let (mut keyed, bounds) = morton_keys(refs, &mut phases);
    let start = Instant::now();
    radix_sort::sort(&mut keyed);
    phases.add("radix sort", start.elapsed());

    let start = Instant::now();
    let codes: Vec<u64> = keyed.par_iter().map(|k| k.key).collect();
    let order: Vec<u32> = keyed.par_iter().map(|k| k.value).collect();
    drop(keyed);
    let radix = RadixTree { codes: &codes };
    let internal: Vec<RadixNode> = (0..codes.len().saturating_sub(1))
        .into_par_iter()
        .map(|i| radix.node(i))
        .collect();
    let sorted_bounds: Vec<Aabb> = order.par_iter().map(|&i| bounds[i as usize]).collect();
    drop(bounds);
    let mut tree = linked_tree(&internal, &sorted_bounds, &sah);
    drop((internal, sorted_bounds, codes));
    phases.add("radix tree", start.elapsed());

    if params.strategy == Strategy::LbvhTreelet {
        phases.sah_before_rounds = Some(tree.sah_cost(&sah));
        for round in 0..params.treelet_rounds {
            let start = Instant::now();
            if round > 0 {
                tree = tree.preorder();
            }
            // Only subtrees of at least γ primitives root a treelet: γ = n in the first
            // round, doubled in each later one, as the paper does. The many small subtrees
            // near the leaves gain little and would cost most of the time.
            let gamma = params.treelet_size.saturating_mul(1 << round.min(31));
            treelet::restructure(&mut tree, params.treelet_size as usize, gamma, &sah);
            phases.add_round(start.elapsed(), tree.sah_cost(&sah));
        }
    }

    let start = Instant::now();
    let (nodes, leaf_order) = tree.to_bvh_nodes(&sah);
    let prim_indices = leaf_order
        .par_iter()
        .map(|&k| refs[order[k as usize] as usize].index)
        .collect();
    phases.add("collapse", start.elapsed());
    (nodes, prim_indices, phases)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_the_bits() {
        let naive = |q: [u32; 3]| {
            let mut code = 0u64;
            for bit in 0..MORTON_BITS {
                for (axis, &v) in q.iter().enumerate() {
                    code |= (((v >> bit) & 1) as u64) << (3 * bit + 2 - axis as u32);
                }
            }
            code
        };
        let mut x = 12345u32;
        for _ in 0..10_000 {
            let q = std::array::from_fn(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                x >> 11
            });
            assert_eq!(morton3(q), naive(q), "{q:?}");
        }
        let top = (1 << MORTON_BITS) - 1;
        assert_eq!(morton3([top; 3]), (1 << 63) - 1);
    }

    #[test]
    fn centroid_bounds_union_keeps_the_empty_box_neutral() {
        let a = CentroidBounds::EMPTY
            .grow([1.0, -2.0, 3.0])
            .grow([4.0, 0.0, 3.0]);
        for (x, y) in [
            (a, CentroidBounds::EMPTY),
            (CentroidBounds::EMPTY, a),
            (a, a),
        ] {
            let u = x.union(y);
            assert_eq!((u.min, u.max), ([1.0, -2.0, 3.0], [4.0, 0.0, 3.0]));
        }
    }

    #[test]
    fn radix_tree_covers_every_key_once() {
        // Sorted codes with duplicates: every internal node's children partition its range.
        let codes: Vec<u64> = vec![1, 2, 4, 5, 5, 5, 19, 24, 25, 30, 30];
        let radix = RadixTree { codes: &codes };
        let mut seen = vec![0; codes.len()];
        let mut stack = vec![(Child::Internal(0), 0usize, codes.len() - 1)];
        while let Some((c, lo, hi)) = stack.pop() {
            match c {
                Child::Leaf(k) => {
                    assert_eq!((lo, hi), (k as usize, k as usize));
                    seen[k as usize] += 1;
                }
                Child::Internal(i) => {
                    let node = radix.node(i as usize);
                    assert_eq!(node.count as usize, hi - lo + 1);
                    let split = match node.left {
                        Child::Leaf(k) | Child::Internal(k) => k as usize,
                    };
                    assert!(lo <= split && split < hi);
                    stack.push((node.left, lo, split));
                    stack.push((node.right, split + 1, hi));
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
    }
}
