//! Partial re-braiding (Benthin, Woop, Wald and Áfra, "Improved two-level BVHs using
//! partial re-braiding", HPG 2017): the top level is built not over whole instances but over
//! references, each an instance and one subtree of its BLAS. A large instance overlaps many
//! others, and a ray entering its box walks its BLAS from the root; "opened", its reference
//! is replaced by references to its subtree's children, whose boxes, each placed in the
//! world, are tighter: the top level then sorts them by space among the other instances'
//! references, as a flattened BVH sorts the triangles under them.
//!
//! Opening is greedy, before the top level is built: the reference with the largest world
//! box (by surface area) is opened first and its children join the candidates, until one
//! more opening would pass the budget of `rebraid` × max(instances, `SMALL_SCENE`) extra
//! references. (The paper opens during the top-down build, where a reference is large
//! against the node being split; measured on sponza that visited more nodes than opening
//! the largest first, for the same number of references.) An instance's references always
//! name a cut through its BLAS (the subtrees partition it), so every triangle is reached
//! through exactly one reference, and a ray entering a top-level leaf walks the BLAS from
//! that reference's subtree instead of from the root. With `rebraid` 0 each instance is one
//! reference, its BLAS's root: the top level over whole instances.

use super::{MeshHull, WORLD_BOX_DEPTH};
use crate::accel::bvh::wide::WideNode;
use crate::accel::bvh::{Bvh8, Subtree};
use crate::geometry::Aabb;
use crate::scene::Instance;
use rayon::prelude::*;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// What a top-level leaf holds: a subtree of one instance's BLAS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reference {
    pub instance: u32,
    /// Where the BLAS walk starts (its root for an instance left whole).
    pub subtree: Subtree,
    /// The triangles the subtree reaches (below the root, a triangle that spatial splits
    /// cut counts once for each leaf holding a part of it).
    pub triangles: u32,
}

/// No more references than this, whatever the budget: the top level numbers them in 32
/// bits, with room to spare as for instances.
pub const MAX_REFERENCES: usize = (u32::MAX / 2) as usize - 1;

impl Reference {
    /// Reference `instance`'s whole BLAS; `None` for an empty mesh, which no ray can hit.
    pub fn root(instance: usize, blas: &Bvh8) -> Option<Reference> {
        (blas.nodes[0].child_count() > 0).then_some(Reference {
            instance: instance as u32,
            subtree: Subtree::ROOT,
            triangles: blas.triangle_count as u32,
        })
    }

    /// Its box in the world (`placed_box`), `hulls` holding each mesh's hull vertices.
    pub fn world_box(
        &self,
        instances: &[Instance],
        blases: &[Bvh8],
        hulls: &[Option<MeshHull>],
    ) -> Aabb {
        let instance = &instances[self.instance as usize];
        let hull = hulls.get(instance.mesh).and_then(Option::as_ref);
        placed_box(instance, &blases[instance.mesh], hull, self.subtree)
    }
}

/// The world box of `subtree` of `blas` placed by `instance`: the union of the placed boxes
/// of the subtree's nodes down to `WORLD_BOX_DEPTH` (a leaf's box placed as it is). A
/// rotated box's corners swing far beyond what it holds; its children's boxes, placed one
/// by one, hug it closer, and the top-level boxes overlap less. The identity's boxes are
/// the BLAS's own, exactly: its rays are not transformed, so there is no rounding to pad
/// for (a padded box would take in rays that start just off a surface, as bounced rays do).
///
/// A whole instance of a mesh with a hull (`MeshHull`) takes the placed hull's box instead:
/// the tightest, and no dearer than the 64 boxes.
pub fn placed_box(
    instance: &Instance,
    blas: &Bvh8,
    hull: Option<&MeshHull>,
    subtree: Subtree,
) -> Aabb {
    let whole_and_turned =
        subtree == Subtree::ROOT && !instance.is_identity() && !instance.is_translation();
    if let Some(hull) = hull.filter(|_| whole_and_turned) {
        return instance.world_bounds_of_hull(&hull.columns, hull.tolerance);
    }
    let object = match subtree.is_leaf() {
        true => leaf_box(blas, subtree),
        false => blas.nodes[subtree.node_index()].bounds(),
    };
    if instance.is_identity() {
        return object;
    }
    // A shifted box is as tight as its shifted children's union (the boxes below add
    // nothing): one box instead of dozens, when a dragged instance's references are
    // placed again.
    if subtree.is_leaf() || WORLD_BOX_DEPTH == 0 || instance.is_translation() {
        return instance.world_bounds(&object);
    }
    // On the stack, not the heap: a drag places each of an opened instance's references
    // again, 150 254 of them for the island's terrain.
    let mut stack = [(0usize, 0u32); PLACED_BOX_STACK];
    stack[0] = (subtree.node_index(), 1);
    let mut len = 1;
    let mut world = Aabb::EMPTY;
    while len > 0 {
        len -= 1;
        let (n, depth) = stack[len];
        let node = &blas.nodes[n];
        let mut placed = 0u32;
        for lane in 0..node.child_count() {
            if let Some(c) = node.interior(lane).filter(|_| depth < WORLD_BOX_DEPTH) {
                stack[len] = (c, depth + 1);
                len += 1;
            } else {
                placed |= 1 << lane;
            }
        }
        // The node's boxes not opened further, placed together.
        world = world.union(instance.world_bounds_of_lanes(&node.bounds, placed));
    }
    world
}

/// The most nodes `placed_box` holds at once: seven siblings waiting at each level above
/// the deepest, and the eight of a node being opened.
const PLACED_BOX_STACK: usize = 7 * WORLD_BOX_DEPTH as usize + 8;

/// A leaf subtree's box in its mesh's space: its triangles' (for a split triangle, the
/// whole triangle's, which holds its part).
fn leaf_box(blas: &Bvh8, leaf: Subtree) -> Aabb {
    leaf.slots().fold(Aabb::EMPTY, |b, slot| {
        b.union(blas.slot_triangle(slot).bounds())
    })
}

/// The budget counts at least this many instances: a scene of a few large objects (sponza's
/// 38) gets enough references to open them deeply (4096 at the default budget), one of
/// 10^5 instances `rebraid` more per instance. Per instance, a tenth of a reference is
/// what pays on the island: its 200 002 instances stand on one terrain, and a larger
/// budget only cuts the terrain into slivers of a few triangles (150 254 references at one
/// per instance, 2 triangles each) that no ray's walk gains from, each a box to place again
/// when the terrain is dragged.
pub const SMALL_SCENE: usize = 40_960;

/// A reference with its world box.
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    pub reference: Reference,
    pub bounds: Aabb,
}

/// The top level's references with their world boxes: each instance of a non-empty mesh
/// whole, then, with a `rebraid` budget above 0, the largest opened greedily. Sorted by
/// instance, then by subtree, so that each instance's references lie together.
pub fn references(
    blases: &[Bvh8],
    hulls: &[Option<MeshHull>],
    instances: &[Instance],
    rebraid: f32,
) -> Vec<Placed> {
    let mut placed: Vec<Placed> = instances
        .iter()
        .enumerate()
        .filter_map(|(i, inst)| Reference::root(i, blases.get(inst.mesh)?))
        .collect::<Vec<_>>()
        // Each box transforms up to 64 of its BLAS's boxes: in parallel for many instances.
        .into_par_iter()
        .with_min_len(1024)
        .map(|reference| Placed {
            bounds: reference.world_box(instances, blases, hulls),
            reference,
        })
        .collect();
    let extra = (rebraid.max(0.0) as f64 * placed.len().max(SMALL_SCENE) as f64)
        .min(MAX_REFERENCES.saturating_sub(placed.len()) as f64) as usize;
    if extra > 0 {
        open_largest(blases, instances, &mut placed, extra);
        // The opened references' boxes, made from their nodes' boxes further down.
        placed
            .par_iter_mut()
            .with_min_len(1024)
            .filter(|p| p.reference.subtree != Subtree::ROOT)
            .for_each(|p| p.bounds = p.reference.world_box(instances, blases, hulls));
    }
    placed.sort_unstable_by_key(|p| (p.reference.instance, p.reference.subtree));
    placed
}

/// `subtree`'s box placed by `instance` from its own box alone (its eight corners placed):
/// what opening ranks it by, one transform where `placed_box` may make 64.
fn rough_box(instance: &Instance, parent: &WideNode<8>, lane: usize) -> Aabb {
    let object = parent.child_bounds(lane);
    match instance.is_identity() {
        true => object,
        false => instance.world_bounds(&object),
    }
}

/// Opens the references with the largest world boxes first until one more opening would
/// add more than `extra` references in all. A box that is not finite (an instance placed
/// beyond f32) is never opened: the build reports it.
fn open_largest(blases: &[Bvh8], instances: &[Instance], placed: &mut Vec<Placed>, extra: usize) {
    let budget = placed.len() + extra;
    // The triangles under each BLAS node, for the references' counts.
    let under: Vec<Vec<u32>> = blases.par_iter().map(Bvh8::triangles_per_node).collect();
    // Surface areas are non-negative, so their bits order as they do; of equal ones the
    // reference made first opens first.
    let key = |p: &Placed, k: usize| (p.bounds.surface_area().max(0.0).to_bits(), Reverse(k));
    let openable = |p: &Placed| {
        !p.reference.subtree.is_leaf() && p.bounds.min.is_finite() && p.bounds.max.is_finite()
    };
    let mut heap: BinaryHeap<_> = placed
        .iter()
        .enumerate()
        .filter(|(_, p)| openable(p))
        .map(|(k, p)| key(p, k))
        .collect();
    while let Some((_, Reverse(k))) = heap.pop() {
        let r = placed[k].reference;
        let instance = &instances[r.instance as usize];
        let blas = &blases[instance.mesh];
        let lanes = blas.nodes[r.subtree.node_index()].child_count();
        if placed.len() + lanes - 1 > budget {
            break;
        }
        let node = &blas.nodes[r.subtree.node_index()];
        for (n, subtree) in blas.subtree_children(r.subtree).enumerate() {
            let child = Placed {
                reference: Reference {
                    instance: r.instance,
                    subtree,
                    triangles: match subtree.is_leaf() {
                        true => subtree.count(),
                        false => under[instance.mesh][subtree.node_index()],
                    },
                },
                bounds: rough_box(instance, node, n),
            };
            // The first child takes the opened reference's place, the others come after.
            let at = if n == 0 {
                placed[k] = child;
                k
            } else {
                placed.push(child);
                placed.len() - 1
            };
            if openable(&child) {
                heap.push(key(&child, at));
            }
        }
    }
}
