//! The invariants every BVH keeps, checked explicitly: each triangle in exactly one leaf,
//! each box enclosing its children and triangles, children after parents, depth bounded.
//! Tests run it after every build and refit.

use super::Bvh;
use super::build::MAX_DEPTH;

impl Bvh {
    pub fn validate(&self, max_leaf_size: u32) -> Result<(), String> {
        let n = self.triangles.len();
        if self.prim_indices.len() != n {
            return Err(format!(
                "{} indices for {n} triangles",
                self.prim_indices.len()
            ));
        }
        let mut seen = vec![false; n];
        for &i in &self.prim_indices {
            let slot = seen
                .get_mut(i as usize)
                .ok_or_else(|| format!("triangle index {i} out of range"))?;
            if std::mem::replace(slot, true) {
                return Err(format!("triangle {i} appears twice"));
            }
        }
        let mut covered = vec![false; n];
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
                for k in range {
                    if std::mem::replace(&mut covered[k], true) {
                        return Err(format!("triangle slot {k} in two leaves"));
                    }
                    if !b.contains(&self.triangles[k].bounds()) {
                        return Err(format!("leaf {i} box does not enclose triangle slot {k}"));
                    }
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
        Ok(())
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
