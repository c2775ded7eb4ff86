//! The invariants every BVH keeps, checked explicitly: each triangle in some leaf (in exactly
//! one unless its reference was split, and then the union of its references' boxes covers
//! it), each box enclosing its children and triangles, children after parents, depth
//! bounded. Tests run it after every build and refit.

use super::Bvh;
use super::build::MAX_DEPTH;
use crate::geometry::{Aabb, Triangle};

impl Bvh {
    pub fn validate(&self, max_leaf_size: u32) -> Result<(), String> {
        let n = self.triangles.len();
        if self.prim_indices.len() != n {
            return Err(format!(
                "{} indices for {n} triangle copies",
                self.prim_indices.len()
            ));
        }
        let boxes_of = references_per_triangle(&self.prim_indices, self.triangle_count)?;
        let mut covered = vec![false; n];
        // Boxes of every leaf-order slot, to check the coverage of split references.
        let mut slot_box = vec![Aabb::EMPTY; n];
        let depths = self.node_depths_checked()?;
        for (i, node) in self.nodes.iter().enumerate() {
            if depths[i] as usize > MAX_DEPTH {
                return Err(format!("node {i} at depth {} > {MAX_DEPTH}", depths[i]));
            }
            let b = node.bounds();
            if node.is_leaf() {
                if node.count > max_leaf_size.max(1) && n > 0 {
                    return Err(format!("leaf {i} holds {} > {max_leaf_size}", node.count));
                }
                let range = node.prim_range();
                if range.end > n {
                    return Err(format!("leaf {i} range {range:?} beyond {n} triangles"));
                }
                let ids = &self.prim_indices[range.clone()];
                if (1..ids.len()).any(|a| ids[..a].contains(&ids[a])) {
                    return Err(format!("leaf {i} holds a triangle twice"));
                }
                for k in range {
                    if std::mem::replace(&mut covered[k], true) {
                        return Err(format!("triangle slot {k} in two leaves"));
                    }
                    let t = self.prim_indices[k] as usize;
                    if boxes_of[t] == 1 && !b.contains(&self.triangles[k].bounds()) {
                        return Err(format!("leaf {i} box does not enclose triangle slot {k}"));
                    }
                    slot_box[k] = b;
                }
            } else {
                let l = node.left_first as usize;
                for c in [l, l + 1] {
                    if !b.contains(&self.nodes[c].bounds()) {
                        return Err(format!("node {i} box does not enclose child {c}"));
                    }
                }
            }
        }
        if let Some(k) = covered.iter().position(|&c| !c) {
            return Err(format!("triangle slot {k} in no leaf"));
        }
        check_split_coverage(&self.prim_indices, &self.triangles, &slot_box, &boxes_of)
    }

    /// Depths, checking on the way that every child index lies after its parent.
    fn node_depths_checked(&self) -> Result<Vec<u32>, String> {
        let mut depth = vec![u32::MAX; self.nodes.len()];
        depth[0] = 0;
        for (i, n) in self.nodes.iter().enumerate() {
            if depth[i] == u32::MAX {
                return Err(format!("node {i} is not reachable from the root"));
            }
            if !n.is_leaf() {
                let l = n.left_first as usize;
                if l <= i || l.is_multiple_of(2) || l + 1 >= self.nodes.len() {
                    return Err(format!(
                        "node {i} has children at {l} (must be an odd index after it)"
                    ));
                }
                for c in [l, l + 1] {
                    if depth[c] != u32::MAX {
                        return Err(format!("node {c} has two parents"));
                    }
                    depth[c] = depth[i] + 1;
                }
            }
        }
        Ok(depth)
    }
}

/// How many references each scene triangle has; an error if an index is out of range or a
/// triangle has none.
pub(crate) fn references_per_triangle(
    prim_indices: &[u32],
    triangles: usize,
) -> Result<Vec<u32>, String> {
    let mut count = vec![0u32; triangles];
    // u32::MAX marks a wide leaf block's padding lane: no triangle.
    for &i in prim_indices.iter().filter(|&&i| i != u32::MAX) {
        *count
            .get_mut(i as usize)
            .ok_or_else(|| format!("triangle index {i} out of range"))? += 1;
    }
    if let Some(t) = count.iter().position(|&c| c == 0) {
        return Err(format!("triangle {t} is in no leaf"));
    }
    Ok(count)
}

/// Samples per triangle edge for the coverage check.
const COVERAGE_SAMPLES: u32 = 8;

/// Checks that every triangle with several references is covered by its references' leaf
/// boxes: each sampled point of it (vertices, edges, interior) lies in one of them, up to
/// the rounding of the sample itself. `slot_box[k]` is the box of the leaf holding slot k.
pub(crate) fn check_split_coverage(
    prim_indices: &[u32],
    triangles: &[Triangle],
    slot_box: &[Aabb],
    references: &[u32],
) -> Result<(), String> {
    let (first, slots) = super::refit::slots_of(prim_indices, references.len());
    for t in 0..references.len() {
        if references[t] < 2 {
            continue;
        }
        let mine = &slots[first[t] as usize..first[t + 1] as usize];
        let tri = &triangles[mine[0] as usize];
        let scale = tri
            .bounds()
            .min
            .abs()
            .max(tri.bounds().max.abs())
            .max_element();
        let pad = 1e-5 * scale.max(f32::MIN_POSITIVE);
        let steps = COVERAGE_SAMPLES;
        for i in 0..=steps {
            for j in 0..=(steps - i) {
                let p = tri.point(i as f32 / steps as f32, j as f32 / steps as f32);
                let inside = mine.iter().any(|&k| {
                    let b = slot_box[k as usize];
                    Aabb::new(b.min - pad, b.max + pad).contains_point(p)
                });
                if !inside {
                    return Err(format!(
                        "triangle {t}: point {p:?} lies in none of its {} references' boxes",
                        mine.len()
                    ));
                }
            }
        }
    }
    Ok(())
}
