//! Refit of the top level after one instance moved: the same TLAS, the instance's leaf box
//! replaced by its new world box and each box above it recomputed from its node's children,
//! up to the root. A few dozen boxes, where a rebuild sorts every instance again; the tree
//! keeps its shape, so a long drag loosens it until the next rebuild.

use super::instance_world_box;
use crate::accel::bvh::Bvh8;
use crate::geometry::Aabb;
use crate::scene::Instance;

/// Where each instance and each TLAS node sits in its parent: made with the TLAS.
#[derive(Clone, Debug, Default)]
pub struct TopLevelIndex {
    /// Per instance: the (node, lane) whose leaf holds it; `None` for an instance the TLAS
    /// left out (an empty mesh).
    slot: Vec<Option<(u32, u8)>>,
    /// Per TLAS node: the (node, lane) that points to it (the root's is unused).
    parent: Vec<(u32, u8)>,
}

impl TopLevelIndex {
    pub fn new(tlas: &Bvh8, instances: usize) -> Self {
        let mut slot = vec![None; instances];
        let mut parent = vec![(u32::MAX, 0u8); tlas.nodes.len()];
        for (n, node) in tlas.nodes.iter().enumerate() {
            for lane in 0..node.child_count() {
                let c = node.child[lane] as usize;
                if node.is_interior(lane) {
                    parent[c] = (n as u32, lane as u8);
                } else {
                    for &i in &tlas.prim_indices[c..c + node.count[lane] as usize] {
                        slot[i as usize] = Some((n as u32, lane as u8));
                    }
                }
            }
        }
        TopLevelIndex { slot, parent }
    }

    /// Whether the TLAS holds instance `i` (false for an empty mesh's).
    pub fn holds(&self, i: usize) -> bool {
        self.slot.get(i).is_some_and(Option::is_some)
    }
}

/// Puts instance `i`'s new world box into `tlas` and widens or shrinks every box above it.
/// `index` must have been made for `tlas`, and `i` be held by it.
pub fn refit_instance(
    tlas: &mut Bvh8,
    index: &TopLevelIndex,
    blases: &[Bvh8],
    instances: &[Instance],
    i: usize,
) {
    let Some(Some((mut node, lane))) = index.slot.get(i).copied() else {
        return;
    };
    // The leaf lane's box: the union of its instances' boxes (one, as the TLAS is built).
    let n = &tlas.nodes[node as usize];
    let first = n.child[lane as usize] as usize;
    let count = n.count[lane as usize] as usize;
    let leaf = tlas.prim_indices[first..first + count]
        .iter()
        .map(|&k| &instances[k as usize])
        .fold(Aabb::EMPTY, |b, inst| {
            b.union(instance_world_box(inst, &blases[inst.mesh]))
        });
    tlas.nodes[node as usize].set_child_bounds(lane as usize, leaf);
    while node != 0 {
        let (p, l) = index.parent[node as usize];
        let bounds = tlas.nodes[node as usize].bounds();
        tlas.nodes[p as usize].set_child_bounds(l as usize, bounds);
        node = p;
    }
}
