//! Moving triangles and objects: the move tool's selection, the refit (BVH) or rebuild after
//! each move, the two levels' instance moves, and the undo steps they make.

use super::messages::*;
use super::state::*;
use crate::accel::bvh;
use crate::accel::bvh::refit::RefitIndex;
use crate::accel::structure;
use crate::accel::two_level::InstanceOutline;
use crate::geometry::{Aabb, Triangle};
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

/// The triangles away from where the last build put them, as a table by triangle index: a
/// drag moves its whole selection (an object of 10^5 triangles) at every move, and the
/// levels' tint asks about every pixel's triangle (a hash set took milliseconds of each drag
/// step for both). Each triangle's position as built is kept from its first move after the
/// build, so a triangle an undo puts back is no longer tinted, and one an undo moves away
/// from a tree built after the drag is.
#[derive(Default)]
pub(in crate::app) struct MovedTriangles {
    /// Per triangle of the scene, its place in `as_built` once it has moved (else `NONE`).
    slot: Vec<u32>,
    /// The positions as built of the triangles moved since.
    as_built: Vec<Triangle>,
    /// Per triangle: away from its position as built.
    away: Vec<bool>,
    /// How many are away.
    count: usize,
}

const NONE: u32 = u32::MAX;

impl MovedTriangles {
    /// Keeps the positions of `triangles` in `scene` (about to move) of those not moved
    /// since the build. A table kept for a scene of another size is dropped first: its
    /// indices named other triangles.
    pub(in crate::app) fn remember(&mut self, triangles: &[u32], scene: &[Triangle]) {
        if self.slot.len() != scene.len() {
            *self = MovedTriangles {
                slot: vec![NONE; scene.len()],
                away: vec![false; scene.len()],
                ..Default::default()
            };
        }
        for &t in triangles {
            if let (Some(slot), Some(position)) =
                (self.slot.get_mut(t as usize), scene.get(t as usize))
                && *slot == NONE
            {
                *slot = self.as_built.len() as u32;
                self.as_built.push(*position);
            }
        }
    }

    /// Marks each of `triangles` (remembered before their move) as away from its position
    /// as built or not, by where it is in `scene` now.
    pub(in crate::app) fn update(&mut self, triangles: &[u32], scene: &[Triangle]) {
        for &t in triangles {
            let t = t as usize;
            let (Some(&slot), Some(now)) = (self.slot.get(t), scene.get(t)) else {
                continue;
            };
            let Some(built) = self.as_built.get(slot as usize) else {
                continue;
            };
            let away = now.v != built.v;
            if away != self.away[t] {
                self.away[t] = away;
                if away {
                    self.count += 1;
                } else {
                    self.count -= 1;
                }
            }
        }
    }

    pub(in crate::app) fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// A build: every triangle is where the tree has it.
    pub(in crate::app) fn clear(&mut self) {
        if !self.as_built.is_empty() {
            self.slot.fill(NONE);
            self.away.fill(false);
            self.as_built.clear();
            self.count = 0;
        }
    }

    pub(in crate::app) fn contains(&self, t: u64) -> bool {
        usize::try_from(t).is_ok_and(|t| self.away.get(t) == Some(&true))
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
        self.moved.remember(triangles, &scene.triangles);
        match origin {
            Some(o) => scene.restore_triangles(triangles, &o.triangles),
            None => scene.move_triangles(triangles, delta),
        }
        self.scene_version += 1;
        self.moved.update(triangles, &scene.triangles);
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
        // Built where the triangles are now: none is away from its build.
        self.moved.clear();
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
    use crate::geometry::Triangle;
    use glam::Vec3;

    /// A triangle is marked while it is away from its position as built: moves mark it, a
    /// move back to where it was built unmarks it, a build (`clear`) unmarks all; an index
    /// outside the scene is ignored; a table made for a scene of another size starts afresh
    /// (its indices named other triangles).
    #[test]
    fn moved_triangles_are_those_away_from_the_build() {
        let at = |x: f32| Triangle::new(Vec3::new(x, 0.0, 0.0), Vec3::Y, Vec3::Z);
        let mut scene: Vec<Triangle> = (0..10).map(|i| at(i as f32)).collect();
        let built = scene.clone();
        let mut m = MovedTriangles::default();
        let step = |m: &mut MovedTriangles, scene: &mut Vec<Triangle>, ts: &[u32], x: f32| {
            m.remember(ts, scene);
            for &t in ts {
                if let Some(tri) = scene.get_mut(t as usize) {
                    tri.v[0].x += x;
                }
            }
            m.update(ts, scene);
        };
        let marked =
            |m: &MovedTriangles| -> Vec<u64> { (0..12).filter(|&t| m.contains(t)).collect() };
        assert!(m.is_empty() && !m.contains(0));
        step(&mut m, &mut scene, &[3, 5, 5], 1.0);
        step(&mut m, &mut scene, &[7, 99], 1.0);
        assert_eq!(marked(&m), [3, 5, 7]);
        assert!(!m.contains(u64::MAX));
        // Triangle 5 moved twice (listed twice): one step back leaves it away.
        step(&mut m, &mut scene, &[5, 7], -1.0);
        assert_eq!(marked(&m), [3, 5]);
        step(&mut m, &mut scene, &[3, 5], -1.0);
        assert_eq!(scene, built);
        assert!(
            m.is_empty(),
            "every triangle back where it was built: {:?}",
            marked(&m)
        );
        // A build where they are; moving back to the old places is now a move away.
        step(&mut m, &mut scene, &[2], 1.0);
        m.clear();
        assert!(m.is_empty() && !m.contains(2));
        step(&mut m, &mut scene, &[2], -1.0);
        assert_eq!(marked(&m), [2]);
        step(&mut m, &mut scene, &[99], 1.0);
        assert_eq!(marked(&m), [2], "no triangle of the scene moved");
        // Another scene's size: the table starts afresh.
        let mut other: Vec<Triangle> = (0..20).map(|i| at(i as f32)).collect();
        step(&mut m, &mut other, &[6], 1.0);
        assert_eq!(marked(&m), [6]);
    }
}
