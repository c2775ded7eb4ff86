//! What the explorer draws over a traced frame, from the worker's structure: the boxes or
//! cells of a level, the tree walk's node and children with the SAH cost of its split, the
//! bucket costs at that node, the two levels' BLAS below a selected instance, the cells a
//! probe ray walks, and the move tool's selection.

use super::levels::{Levels, WalkNode};
use super::worker::messages::*;
use super::worker::state::*;
use crate::accel::Outline;
use crate::accel::bvh::split_costs;
use crate::accel::split_costs::SplitCosts;
use crate::accel::structure::Structure;
use crate::accel::two_level::InstanceOutline;
use crate::render::Frame;
use crate::render::overlay::{
    OutlinedBox, outline_boxes, outline_corners, palette, tint_triangles,
};
use std::sync::Arc;

/// `tint_triangles` unless `tints` is false (the walk over counts only outlines).
fn tint_walk(
    tints: bool,
    frame: &Frame,
    rgba: &mut [u8],
    tint_of: impl Fn(u64) -> Option<[u8; 4]> + Sync,
) {
    if tints {
        tint_triangles(frame, rgba, tint_of);
    }
}

/// A box's extent at the build, under its refitted self.
const GHOST: [u8; 4] = [210, 210, 210, 90];
/// The triangles moved since the build.
const MOVED_TINT: [u8; 4] = [90, 220, 255, 120];

impl State {
    pub(in crate::app) fn draw_overlay(
        &self,
        frame: &Frame,
        rgba: &mut [u8],
        job: &RenderJob,
    ) -> Option<WalkInfo> {
        let outline = &self.outline;
        let o = &job.overlay;
        let triangle_count = self.scene.as_ref().map_or(0, |s| s.triangles.len());
        if o.level.is_some() && !self.moved.is_empty() {
            // What moved since the build, so the stretched boxes can be traced to it.
            let moved = &self.moved;
            tint_triangles(frame, rgba, |t| moved.contains(t).then_some(MOVED_TINT));
        }
        if let Some(sel) = &o.selected {
            let selection = self.selection_table(sel);
            tint_triangles(frame, rgba, |t| {
                selection.contains(t).then_some([255, 230, 80, 110])
            });
        }
        let instance = self.instance.as_deref();
        let levels = Levels::new(outline, instance);
        if let Some(level) = o.level {
            self.draw_ghost(frame, rgba, job, &levels, level);
            let color = |i: usize| {
                if o.color_by_node {
                    palette(i)
                } else {
                    palette(level as usize)
                }
            };
            let nodes = levels.level(level);
            let mut boxes = Vec::new();
            for node in nodes {
                match (node, instance) {
                    (WalkNode::Top(i), _) => {
                        let n = &outline.nodes[i];
                        boxes.push(OutlinedBox {
                            bounds: n.bounds,
                            color: color(i),
                        });
                        // A k-d tree's split planes at this depth, in white over their cells.
                        if let Some(bounds) = n.plane {
                            boxes.push(OutlinedBox {
                                bounds,
                                color: [255, 255, 255, 230],
                            });
                        }
                    }
                    // The BLAS's boxes where the instance places them.
                    (WalkNode::Bottom(i), Some(inst)) => {
                        let corners = inst.world_corners(i);
                        outline_corners(
                            frame,
                            rgba,
                            &job.camera,
                            &corners,
                            color(i),
                            o.see_through,
                        );
                    }
                    (WalkNode::Bottom(_), None) => {}
                }
            }
            outline_boxes(frame, rgba, &job.camera, &boxes, o.see_through);
        }
        if let (Some([u, v]), Some(s)) = (o.probe, &self.structure) {
            let (w, h) = (frame.width, frame.height);
            let (x, y) = ((u * w as f32) as u32, (v * h as f32) as u32);
            let ray = job
                .camera
                .rays(w, h)
                .pixel_center(x.min(w - 1), y.min(h - 1));
            if let Some(cells) = s.cells_along(&ray) {
                let boxes: Vec<OutlinedBox> = cells
                    .into_iter()
                    .map(|bounds| OutlinedBox {
                        bounds,
                        color: [255, 230, 80, 255],
                    })
                    .collect();
                outline_boxes(frame, rgba, &job.camera, &boxes, true);
            }
        }
        let id = o.walk?;
        // Over counts (a heatmap, B − A) the walk only outlines: a tint would change the
        // colours the legend reads.
        let tints = !matches!(job.mode, crate::render::Mode::Heatmap(..));
        let node = levels.node(id)?;
        if let (WalkNode::Bottom(k), Some(inst)) = (node, instance) {
            return Some(self.draw_blas_walk(frame, rgba, job, &levels, inst, k));
        }
        let WalkNode::Top(node) = node else {
            return None;
        };
        let n = &outline.nodes[node];
        let whole_instance = match (&self.structure, self.leaf_references.get(node)) {
            (Some(s), Some(&r)) => s.reference_is_whole_instance(r),
            _ => false,
        };
        let mut info = WalkInfo {
            node: id,
            depth: n.depth,
            instance: self.leaf_instance(node),
            in_blas: false,
            whole_instance,
            surface_area: n.bounds.surface_area(),
            triangles: 0,
            sah_cost: 0.0,
            children: levels
                .children(WalkNode::Top(node))
                .into_iter()
                .map(|c| levels.id(c) as usize)
                .collect(),
            split_costs: None,
        };
        let mut boxes = vec![OutlinedBox {
            bounds: n.bounds,
            color: [255, 255, 255, 255],
        }];
        let p = &self.params.bvh;
        let entry = instance.and_then(|i| Some((i, i.entry_below(node as u32)?)));
        if let (Some((inst, b)), true) = (entry, n.is_leaf()) {
            // A leaf of the selected instance: the subtree of its BLAS below it, placed.
            let under: std::collections::HashSet<u64> =
                inst.triangles_under(b as usize).into_iter().collect();
            info.triangles = under.len();
            info.sah_cost = p.c_isect * info.triangles as f32;
            let corners = inst.world_corners(b as usize);
            outline_corners(frame, rgba, &job.camera, &corners, FIRST_CHILD, true);
            tint_walk(tints, frame, rgba, |t| {
                under.contains(&t).then_some(FIRST_CHILD)
            });
        } else if let Some(tl) = self.structure.as_ref().filter(|s| s.places_instances()) {
            // The top level's nodes hold references: their triangles are counted and tinted
            // by reference, never listed (the island places 10^10).
            let children: Vec<usize> = if n.is_leaf() {
                vec![node]
            } else {
                n.children().collect()
            };
            let count = children.len();
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            info.sah_cost = if n.is_leaf() { 0.0 } else { p.c_trav };
            let mut side = std::collections::HashMap::new();
            for (k, &c) in children.iter().enumerate() {
                let mut under = 0u64;
                for r in self.references_under(c) {
                    under += tl.reference_triangles(r);
                    side.insert(r, k as u8);
                }
                info.triangles += under as usize;
                let weight = if n.is_leaf() {
                    1.0
                } else {
                    outline.nodes[c].bounds.surface_area() / area
                };
                info.sah_cost += weight * under as f32 * p.c_isect;
                if !n.is_leaf() {
                    let [r, g, b, _] = child_color(k, count);
                    boxes.push(OutlinedBox {
                        bounds: outline.nodes[c].bounds,
                        color: [r, g, b, 255],
                    });
                }
            }
            let locator = self
                .reference_locator
                .get_or_init(|| tl.reference_locator().unwrap_or_default());
            tint_walk(tints, frame, rgba, |t| {
                let r = tl.reference_of_triangle(locator, t)?;
                side.get(&r).map(|&k| child_color(k as usize, count))
            });
        } else if n.is_leaf() {
            let under = outline.triangles_under(node);
            info.triangles = under.len();
            info.sah_cost = p.c_isect * under.len() as f32;
            let mut mark = vec![false; triangle_count];
            for &t in &under {
                if let Some(m) = mark.get_mut(t as usize) {
                    *m = true;
                }
            }
            tint_walk(tints, frame, rgba, |t| {
                (mark.get(t as usize) == Some(&true)).then_some(FIRST_CHILD)
            });
        } else {
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            let count = info.children.len();
            // Which child a triangle lies under (the last one wins where cells share it).
            let mut side = vec![u8::MAX; triangle_count];
            let mut all = std::collections::HashSet::new();
            info.sah_cost = p.c_trav;
            for (k, c) in n.children().enumerate() {
                let under = outline.triangles_under(c);
                let child = &outline.nodes[c];
                info.sah_cost +=
                    child.bounds.surface_area() / area * under.len() as f32 * p.c_isect;
                for &t in &under {
                    if let Some(s) = side.get_mut(t as usize) {
                        *s = k as u8;
                    }
                }
                all.extend(under);
                let [r, g, b, _] = child_color(k, count);
                boxes.push(OutlinedBox {
                    bounds: child.bounds,
                    color: [r, g, b, 255],
                });
            }
            info.triangles = all.len();
            if count == 2 {
                info.split_costs = self.split_costs_of(outline, node, all);
            }
            tint_walk(tints, frame, rgba, |t| match side.get(t as usize) {
                Some(&k) if k != u8::MAX => Some(child_color(k as usize, count)),
                _ => None,
            });
            if let Some(plane) = n.plane {
                boxes.push(OutlinedBox {
                    bounds: plane,
                    color: [255, 255, 255, 255],
                });
            }
        }
        outline_boxes(frame, rgba, &job.camera, &boxes, true);
        Some(info)
    }

    /// After a refit: the shown level's boxes as the build left them, faintly, under the
    /// refitted ones (drawn only where a box has moved).
    fn draw_ghost(
        &self,
        frame: &Frame,
        rgba: &mut [u8],
        job: &RenderJob,
        levels: &Levels,
        level: u32,
    ) {
        let (now, built) = (&self.outline, &self.built_outline);
        if Arc::ptr_eq(now, built) || now.nodes.len() != built.nodes.len() {
            return;
        }
        let ghosts: Vec<OutlinedBox> = levels
            .level(level)
            .into_iter()
            .filter_map(|node| match node {
                WalkNode::Top(i) if built.nodes[i].bounds != now.nodes[i].bounds => {
                    Some(OutlinedBox {
                        bounds: built.nodes[i].bounds,
                        color: GHOST,
                    })
                }
                _ => None,
            })
            .collect();
        outline_boxes(frame, rgba, &job.camera, &ghosts, job.overlay.see_through);
    }

    /// Under the two levels: the references in the top-level leaves under outline node
    /// `node`.
    pub(in crate::app) fn references_under(&self, node: usize) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![node];
        while let Some(k) = stack.pop() {
            let Some(n) = self.outline.nodes.get(k) else {
                continue;
            };
            if n.is_leaf() {
                out.extend(self.leaf_references.get(k).filter(|&&r| r != u32::MAX));
            } else {
                stack.extend(n.children());
            }
        }
        out
    }

    /// Under the two levels: the instance top-level outline node `node` holds, if a leaf.
    pub(in crate::app) fn leaf_instance(&self, node: usize) -> Option<usize> {
        self.leaf_instances
            .get(node)
            .filter(|&&i| i != u32::MAX)
            .map(|&i| i as usize)
    }

    /// The walk at node `k` of the selected instance's BLAS: its placed box, its children's
    /// placed boxes and their triangles tinted. Areas and the SAH cost are the BLAS's own,
    /// in the mesh's space, where it was built.
    pub(in crate::app) fn draw_blas_walk(
        &self,
        frame: &Frame,
        rgba: &mut [u8],
        job: &RenderJob,
        levels: &Levels,
        inst: &InstanceOutline,
        k: usize,
    ) -> WalkInfo {
        let blas = &inst.blas;
        let n = &blas.nodes[k];
        let p = &self.params.bvh;
        let mut info = WalkInfo {
            node: levels.id(WalkNode::Bottom(k)),
            depth: levels.depth(WalkNode::Bottom(k)),
            instance: Some(inst.instance),
            in_blas: true,
            whole_instance: false,
            surface_area: n.bounds.surface_area(),
            triangles: 0,
            sah_cost: 0.0,
            children: n
                .children()
                .map(|c| levels.id(WalkNode::Bottom(c)) as usize)
                .collect(),
            split_costs: None,
        };
        // Which child each of the mesh's triangles lies under (the mesh, not the scene:
        // bounded whatever the instancing places).
        let mut side = vec![u8::MAX; inst.triangle_count];
        let count = n.child_count as usize;
        if n.is_leaf() {
            let under = blas.triangles_under(k);
            info.triangles = under.len();
            info.sah_cost = p.c_isect * under.len() as f32;
            for &t in &under {
                if let Some(s) = side.get_mut(t as usize) {
                    *s = 0;
                }
            }
        } else {
            let area = info.surface_area.max(f32::MIN_POSITIVE);
            info.sah_cost = p.c_trav;
            for (j, c) in n.children().enumerate() {
                let under = blas.triangles_under(c);
                info.sah_cost +=
                    blas.nodes[c].bounds.surface_area() / area * under.len() as f32 * p.c_isect;
                info.triangles += under.len();
                for &t in &under {
                    if let Some(s) = side.get_mut(t as usize) {
                        *s = j as u8;
                    }
                }
                let [r, g, b, _] = child_color(j, count);
                outline_corners(
                    frame,
                    rgba,
                    &job.camera,
                    &inst.world_corners(c),
                    [r, g, b, 255],
                    true,
                );
            }
        }
        let first = inst.first_triangle;
        tint_triangles(frame, rgba, |t| {
            let local = usize::try_from(t.checked_sub(first)?).ok()?;
            match side.get(local) {
                Some(&j) if j != u8::MAX => Some(child_color(j as usize, count.max(1))),
                _ => None,
            }
        });
        let own = inst.world_corners(k);
        outline_corners(frame, rgba, &job.camera, &own, [255, 255, 255, 255], true);
        info
    }

    /// The bucket-cost plot's data for node `node` of the outline (`under`: the scene
    /// triangles below it), for a BVH2 or a k-d tree; computed once per node and tree.
    pub(in crate::app) fn split_costs_of(
        &self,
        outline: &Outline,
        node: usize,
        under: std::collections::HashSet<u32>,
    ) -> Option<Arc<SplitCosts>> {
        let key = SplitCostsKey {
            version: self.version,
            node,
            params: self.params,
        };
        let mut cache = self.split_costs.borrow_mut();
        if let Some((k, costs)) = cache.as_ref()
            && *k == key
        {
            return Some(costs.clone());
        }
        let costs = match self.structure.as_ref()? {
            Structure::Bvh(_) => {
                let scene = self.scene.as_ref()?;
                let mut under: Vec<u32> = under.into_iter().collect();
                under.sort_unstable();
                split_costs(&scene.triangles, &under, &self.params.bvh)
            }
            Structure::KdTree(tree) => {
                // The way down from the root: below (first) or above (second) child.
                let mut path = Vec::new();
                let mut i = node;
                while let Some(&parent) = outline.nodes.get(i).map(|n| &n.parent)
                    && parent != u32::MAX
                {
                    path.push(i as u32 != outline.nodes[parent as usize].first_child);
                    i = parent as usize;
                }
                path.reverse();
                tree.split_costs(&self.params.kdtree, &path)?
            }
            _ => return None,
        };
        let costs = Arc::new(costs);
        *cache = Some((key, costs.clone()));
        Some(costs)
    }
}

/// The tree walk's colours: the first child, the second of two, the palette beyond.
const FIRST_CHILD: [u8; 4] = [255, 140, 40, 150];
const SECOND_CHILD: [u8; 4] = [60, 170, 255, 150];

fn child_color(k: usize, count: usize) -> [u8; 4] {
    match (k, count) {
        (0, _) => FIRST_CHILD,
        (1, 2) => SECOND_CHILD,
        _ => {
            let [r, g, b, _] = palette(k);
            [r, g, b, 150]
        }
    }
}
