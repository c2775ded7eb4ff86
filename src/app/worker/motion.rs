//! Moving triangles and objects: the move tool's selection, the refit (BVH) or rebuild after
//! each move, the two levels' instance moves, and the undo steps they make.

use super::messages::*;
use super::state::*;
use crate::accel::bvh;
use crate::accel::bvh::refit::RefitIndex;
use crate::accel::structure;
use crate::accel::two_level::InstanceOutline;
use crate::geometry::Aabb;
use crate::scene::Scene;
use glam::Vec3;
use std::sync::Arc;
use std::time::Instant;

/// The move tool's selection as a table by triangle index (a selection can be a whole
/// object of 10^5 triangles): made once per selection and scene, then read by the tint of
/// every frame and the box of every move of a drag.
pub(in crate::app) struct SelectionTable {
    pub(in crate::app) triangles: Arc<Vec<u32>>,
    pub(in crate::app) selected: Vec<bool>,
    /// Some triangle is listed twice (a move moves it twice).
    pub(in crate::app) repeated: bool,
}

impl SelectionTable {
    pub(in crate::app) fn new(triangles: &Arc<Vec<u32>>, triangle_count: usize) -> Self {
        let mut selected = vec![false; triangle_count];
        let mut repeated = false;
        for &t in triangles.iter() {
            if let Some(s) = selected.get_mut(t as usize) {
                repeated |= *s;
                *s = true;
            }
        }
        SelectionTable {
            triangles: triangles.clone(),
            selected,
            repeated,
        }
    }

    pub(in crate::app) fn is_for(&self, triangles: &Arc<Vec<u32>>, triangle_count: usize) -> bool {
        self.selected.len() == triangle_count && same_selection(&self.triangles, triangles)
    }

    pub(in crate::app) fn contains(&self, t: u64) -> bool {
        usize::try_from(t).is_ok_and(|t| self.selected.get(t) == Some(&true))
    }
}

/// The triangles moved since the last build, as a table by triangle index: a drag adds its
/// whole selection (an object of 10^5 triangles) at every move, and the levels' tint asks
/// about every pixel's triangle. A hash set took milliseconds of each drag step for both.
#[derive(Default)]
pub(in crate::app) struct MovedTriangles {
    moved: Vec<bool>,
    any: bool,
}

impl MovedTriangles {
    /// Marks `triangles` of a scene of `triangle_count` as moved (a table kept for a scene
    /// of another size is dropped first: its indices named other triangles).
    pub(in crate::app) fn add(&mut self, triangles: &[u32], triangle_count: usize) {
        if self.moved.len() != triangle_count {
            self.moved = vec![false; triangle_count];
            self.any = false;
        }
        for &t in triangles {
            if let Some(m) = self.moved.get_mut(t as usize) {
                *m = true;
                self.any = true;
            }
        }
    }

    pub(in crate::app) fn is_empty(&self) -> bool {
        !self.any
    }

    pub(in crate::app) fn clear(&mut self) {
        if self.any {
            self.moved.fill(false);
            self.any = false;
        }
    }

    pub(in crate::app) fn contains(&self, t: u64) -> bool {
        usize::try_from(t).is_ok_and(|t| self.moved.get(t) == Some(&true))
    }
}

pub(in crate::app) fn same_selection(a: &Arc<Vec<u32>>, b: &Arc<Vec<u32>>) -> bool {
    Arc::ptr_eq(a, b) || a == b
}

/// The scene's box in two parts while one selection is dragged: the box of every other
/// triangle, which the drag does not change, and the selection's, which each move
/// translates. A translation moves the box exactly (rounding is monotonic, so the smallest
/// coordinate stays the smallest), so the standard light, which follows the scene's box,
/// costs no pass over the scene's triangles per move.
pub(in crate::app) struct DragBounds {
    pub(in crate::app) selection: Arc<Vec<u32>>,
    /// The scene version the boxes are of.
    pub(in crate::app) scene_version: u64,
    pub(in crate::app) rest: Aabb,
    pub(in crate::app) selected: Aabb,
}

impl DragBounds {
    /// The two boxes of a flattened scene (whose box is that of its triangles), or `None`
    /// if a move would not translate the selection (a triangle listed twice moves twice).
    pub(in crate::app) fn new(
        scene: &Scene,
        table: &SelectionTable,
        scene_version: u64,
    ) -> Option<Self> {
        if table.repeated || !scene.is_flattened() {
            return None;
        }
        let (mut rest, mut selected) = (Aabb::EMPTY, Aabb::EMPTY);
        for (t, &s) in scene.triangles.iter().zip(&table.selected) {
            if s {
                selected = selected.union(t.bounds());
            } else {
                rest = rest.union(t.bounds());
            }
        }
        Some(DragBounds {
            selection: table.triangles.clone(),
            scene_version,
            rest,
            selected,
        })
    }
}

impl State {
    /// Where a move of `triangles` starts, kept if it starts a drag (or moves another
    /// selection than the drag's last move): undo puts them back there exactly.
    pub(in crate::app) fn origin_of_triangles(
        &self,
        triangles: &Arc<Vec<u32>>,
    ) -> Option<Arc<Origin>> {
        let continues = matches!(self.gesture.last(),
            Some(Motion::Triangles(last, ..)) if same_selection(last, triangles));
        let scene = self.scene.as_ref().filter(|_| !continues)?;
        let positions = triangles
            .iter()
            .filter_map(|&t| scene.triangles.get(t as usize));
        Some(Arc::new(Origin {
            triangles: positions.copied().collect(),
            transform: None,
        }))
    }

    /// Where a move of object `object` starts (its triangles, and its instance's transform
    /// under the two levels), kept if it starts a drag or moves another object.
    pub(in crate::app) fn origin_of_object(&self, object: usize) -> Option<Arc<Origin>> {
        let continues = matches!(self.gesture.last(),
            Some(Motion::Object(last, ..)) if *last == object);
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return None;
        };
        let range = scene.objects.get(object).filter(|_| !continues)?.range();
        let transform = if !structure.places_instances() {
            None
        } else if scene.instances.is_empty() {
            structure.instance_transform(object)
        } else {
            let i = scene.instance_of_object(object)?;
            Some(scene.instances.get(i)?.transform)
        };
        Some(Arc::new(Origin {
            triangles: scene.triangles.get(range)?.to_vec(),
            transform,
        }))
    }

    /// Moves `triangles` by `delta`, or (undo's last step back) puts them at `origin`.
    pub(in crate::app) fn move_triangles(
        &mut self,
        triangles: &Arc<Vec<u32>>,
        delta: Vec3,
        origin: Option<&Origin>,
    ) {
        let bounds = self.drag_bounds(triangles);
        let (Some(scene), Some(structure)) = (&mut self.scene, &mut self.structure) else {
            return;
        };
        match origin {
            Some(o) => scene.restore_triangles(triangles, &o.triangles),
            None => scene.move_triangles(triangles, delta),
        }
        self.scene_version += 1;
        self.moved.add(triangles, scene.triangles.len());
        // The standard light from the scene's box in its two parts, the selection's moved;
        // back at the drag's origin, from the scene again, so it is the light it was.
        if origin.is_some() {
            self.light = None;
        } else if let Some(mut b) = bounds {
            b.selected = Aabb::new(b.selected.min + delta, b.selected.max + delta);
            b.scene_version = self.scene_version;
            let light = Scene::standard_light(&b.rest.union(b.selected));
            self.light = Some((self.scene_version, light));
            self.drag_bounds = Some(b);
        }
        let start = Instant::now();
        let p = &self.params.bvh;
        // Only the moved triangles' leaves and their ancestors change.
        let refit = structure.refit_moved(
            &mut self.refit_index,
            &scene.triangles,
            triangles,
            p.c_trav,
            p.c_isect,
        );
        if let Some(refit) = refit {
            if let Ok(r) = refit {
                let refit_time = start.elapsed();
                // The level boxes and the walk are drawn from the outline: it follows the
                // refitted boxes (the tree's shape is unchanged, so the walk stays valid),
                // made again when a frame draws it (`fresh_outline`), not on every move.
                self.outline_stale = true;
                self.version += 1;
                self.reply(Reply::Refitted {
                    sah_before: r.sah_before,
                    sah_after: r.sah_after,
                    refit_time,
                    undo: self.undoing,
                });
            }
            return;
        }
        // Any other structure is built again (a spatial one has no boxes to stretch).
        let Ok(built) = structure::build_scene(scene, &self.params, &Default::default()) else {
            return;
        };
        let rebuild_time = start.elapsed();
        *structure = built.structure;
        self.outline = Arc::new(structure.outline());
        self.outline_stale = false;
        self.version += 1;
        if self.reference_bvh.is_none()
            && let Ok((bvh, _)) = bvh::build(&scene.triangles, &bvh::BuildParams::default())
        {
            let index = RefitIndex::new(&bvh);
            self.reference_bvh = Some((bvh, index));
        }
        let bvh_refit_time = self.reference_bvh.as_mut().map(|(bvh, index)| {
            let start = Instant::now();
            let _ = bvh.refit_moved(index, &scene.triangles, triangles, p.c_trav, p.c_isect);
            start.elapsed()
        });
        self.built_outline = self.outline.clone();
        self.reply(Reply::RebuiltAfterMove {
            rebuild_time,
            bvh_refit_time,
            outline: self.outline.clone(),
        });
    }

    /// The scene's box in two parts for a move of `triangles` now: kept from the last move
    /// if it moved the same selection and nothing else changed the scene since, else made
    /// (`None` for a scene with its own light, which needs no box).
    pub(in crate::app) fn drag_bounds(&mut self, triangles: &Arc<Vec<u32>>) -> Option<DragBounds> {
        let scene = self.scene.as_ref().filter(|s| s.light.is_none())?;
        match self.drag_bounds.take() {
            Some(b)
                if b.scene_version == self.scene_version
                    && same_selection(&b.selection, triangles) =>
            {
                Some(b)
            }
            _ => DragBounds::new(scene, &self.selection_table(triangles), self.scene_version),
        }
    }

    /// The table of selection `triangles`, made again only for another selection or scene.
    pub(in crate::app) fn selection_table(&self, triangles: &Arc<Vec<u32>>) -> Arc<SelectionTable> {
        let count = self.scene.as_ref().map_or(0, |s| s.triangles.len());
        let mut cache = self.selection.borrow_mut();
        if let Some(table) = cache.as_ref().filter(|t| t.is_for(triangles, count)) {
            return table.clone();
        }
        let table = Arc::new(SelectionTable::new(triangles, count));
        *cache = Some(table.clone());
        table
    }

    /// Moves object `object` by `delta`; true if it moved. Under the two levels: its
    /// instance (the scene's own, or the object itself as an instance of its triangles)
    /// moves, and the top level is refitted.
    /// `origin`: undo's last step back, to the object's place before the drag, exactly.
    pub(in crate::app) fn move_object(
        &mut self,
        object: usize,
        delta: Vec3,
        origin: Option<&Origin>,
    ) -> bool {
        let (Some(scene), Some(structure)) = (&mut self.scene, &mut self.structure) else {
            return false;
        };
        let Some(range) = scene.objects.get(object).map(|o| o.range()) else {
            return false;
        };
        if !structure.places_instances() {
            // Any other structure moves the object's triangles.
            let triangles: Arc<Vec<u32>> = Arc::new(range.map(|t| t as u32).collect());
            self.move_triangles(&triangles, delta, origin);
            return true;
        };
        let start = Instant::now();
        let mut transform = glam::Affine3A::IDENTITY;
        let moved = if scene.instances.is_empty() {
            // Each object is an instance of its own triangles: the triangles move in the
            // scene, the instance in the structure.
            // (Only where the structure's instances are the objects: a scene whose objects
            // do not cover its triangles in order is one instance of them all.)
            let current = structure
                .instance_transform(object)
                .filter(|_| structure.objects_are_instances(scene, object));
            let Some(current) = current else {
                return false;
            };
            transform = match origin.and_then(|o| o.transform) {
                Some(t) => t,
                None => glam::Affine3A::from_translation(delta) * current,
            };
            let ok = structure
                .move_instance(object, transform)
                .is_some_and(|r| r.is_ok());
            if ok {
                let triangles = &mut scene.triangles[range.clone()];
                match origin {
                    Some(o) if o.triangles.len() == triangles.len() => {
                        triangles.copy_from_slice(&o.triangles)
                    }
                    _ => {
                        for t in triangles {
                            for v in &mut t.v {
                                *v += delta;
                            }
                        }
                    }
                }
            }
            ok
        } else {
            let Some(i) = scene.instance_of_object(object) else {
                return false;
            };
            let placed = match origin.and_then(|o| o.transform) {
                Some(t) => scene.transform_instance(i, t),
                None => scene.translate_instance(i, delta),
            };
            match placed {
                Ok(placed) => {
                    transform = placed.transform;
                    let ok =
                        (structure.move_instance(i, placed.transform)).is_some_and(|r| r.is_ok());
                    if !ok {
                        let _ = scene.translate_instance(i, -delta);
                    }
                    ok
                }
                Err(_) => false,
            }
        };
        if !moved {
            return false;
        }
        let refit_time = start.elapsed();
        self.version += 1;
        self.scene_version += 1;
        // Beside it: a BVH over the flattened scene, refitted for the same triangles.
        let p = self.params.bvh;
        if self.reference_bvh.is_none()
            && scene.is_flattened()
            && let Ok((bvh, _)) = bvh::build(&scene.triangles, &bvh::BuildParams::default())
        {
            let index = RefitIndex::new(&bvh);
            self.reference_bvh = Some((bvh, index));
        }
        let flat_refit_time = self.reference_bvh.as_mut().map(|(bvh, index)| {
            let triangles: Vec<u32> = range.map(|t| t as u32).collect();
            let start = Instant::now();
            let _ = bvh.refit_moved(index, &scene.triangles, &triangles, p.c_trav, p.c_isect);
            start.elapsed()
        });
        self.reply(Reply::InstanceMoved {
            refit_time,
            flat_refit_time,
            object,
            transform,
        });
        // The selected instance's boxes move with it: the same BLAS under the same leaf (a
        // refit keeps the top level's shape), placed by the new transform.
        if let (Some(selected), Some(structure)) = (&self.instance, &self.structure)
            && let Some(now) = structure.instance_transform(selected.instance)
            && now != selected.transform
        {
            let moved = Arc::new(InstanceOutline {
                transform: now,
                ..InstanceOutline::clone(selected)
            });
            self.instance = Some(moved.clone());
            self.reply(Reply::InstanceSelected(Some(moved)));
        }
        true
    }

    /// The structure's instance that places scene object `object` (under the two levels):
    /// the scene's own instance, or the object itself as an instance of its own triangles
    /// where the structure's instances are the objects.
    pub(in crate::app) fn instance_of_object(&self, object: usize) -> Option<usize> {
        let (Some(scene), Some(structure)) = (&self.scene, &self.structure) else {
            return None;
        };
        structure.instance_of_object(scene, object)
    }

    /// Outlines instance `i`'s BLAS for the levels view and the walk (none under any other
    /// structure, or for no such instance) and tells the UI.
    pub(in crate::app) fn select_instance(&mut self, i: Option<usize>) {
        let outlined = match (&self.structure, i) {
            (Some(structure), Some(i)) => structure.instance_outline(i).map(Arc::new),
            _ => None,
        };
        if outlined.is_none() && self.instance.is_none() {
            return;
        }
        // Only the overlay changes: the UI asks for a frame with the new selection.
        self.instance = outlined.clone();
        self.reply(Reply::InstanceSelected(outlined));
    }
}

#[cfg(test)]
mod tests {
    use super::MovedTriangles;

    /// Moves accumulate until cleared; an index outside the scene is ignored; a table made
    /// for a scene of another size starts afresh (its indices named other triangles).
    #[test]
    fn moved_triangles_accumulate_until_cleared() {
        let mut m = MovedTriangles::default();
        assert!(m.is_empty() && !m.contains(0));
        m.add(&[3, 5, 5], 10);
        m.add(&[7, 99], 10);
        assert!(!m.is_empty());
        let moved: Vec<u64> = (0..12).filter(|&t| m.contains(t)).collect();
        assert_eq!(moved, [3, 5, 7]);
        assert!(!m.contains(u64::MAX));
        m.clear();
        assert!(m.is_empty() && !m.contains(3));
        m.add(&[99], 10);
        assert!(m.is_empty(), "no triangle of the scene moved");
        m.add(&[4], 10);
        m.add(&[6], 20);
        assert!(!m.contains(4) && m.contains(6));
    }
}
