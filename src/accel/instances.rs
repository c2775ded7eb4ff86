//! Instances through the structure interface: what the explorer, the replay and the bench
//! ask of a structure that places instances (the two levels: a TLAS over references into
//! per-mesh BLASes). Every other structure answers "none", so callers never name the
//! two-level structure, and its instances, references and BLASes stay in `two_level/`.

use super::structure::Structure;
use super::two_level::{InstanceOutline, MoveError, ReferenceLocator, TwoLevel};
use crate::accel::bvh::Subtree;
use crate::scene::Scene;
use glam::Affine3A;

impl Structure {
    fn two_level(&self) -> Option<&TwoLevel> {
        match self {
            Structure::TwoLevel(t) => Some(t),
            _ => None,
        }
    }

    /// Whether the structure places instances (a top level over bottom-level trees).
    pub fn places_instances(&self) -> bool {
        self.two_level().is_some()
    }

    /// The instances the structure places (0 for a structure without instances).
    pub fn instance_count(&self) -> usize {
        self.two_level().map_or(0, |t| t.instances.len())
    }

    /// Instance `i`'s placement: object space to world space.
    pub fn instance_transform(&self, i: usize) -> Option<Affine3A> {
        Some(self.two_level()?.instances.get(i)?.transform)
    }

    /// The scene number of instance `i`'s first triangle: a BLAS numbers its own from 0.
    pub fn instance_first_triangle(&self, i: usize) -> Option<u64> {
        self.two_level()?.first_triangle.get(i).copied()
    }

    /// Instance `i`'s BLAS outlined for the levels view and the tree walk.
    pub fn instance_outline(&self, i: usize) -> Option<InstanceOutline> {
        self.two_level()?.instance_outline(i)
    }

    /// By top-level outline node: the instance its leaf holds (`u32::MAX` for an interior
    /// node), and the reference it holds. Empty without instances.
    pub fn leaf_instances_and_references(&self) -> (Vec<u32>, Vec<u32>) {
        self.two_level().map_or_else(Default::default, |t| {
            (t.leaf_instances(), t.leaf_references())
        })
    }

    /// Whether top-level reference `r` is its instance's whole BLAS (not a subtree that
    /// re-braiding opened).
    pub fn reference_is_whole_instance(&self, r: u32) -> bool {
        self.two_level()
            .and_then(|t| t.references.get(r as usize))
            .is_some_and(|r| r.subtree == Subtree::ROOT)
    }

    /// The triangles placed under top-level reference `r`.
    pub fn reference_triangles(&self, r: u32) -> u64 {
        self.two_level()
            .and_then(|t| t.references.get(r as usize))
            .map_or(0, |r| r.triangles as u64)
    }

    /// What finds a scene triangle's top-level reference (made once, it walks the BLASes).
    pub fn reference_locator(&self) -> Option<ReferenceLocator> {
        Some(self.two_level()?.reference_locator())
    }

    /// The top-level reference under which scene triangle `t` is placed.
    pub fn reference_of_triangle(&self, locator: &ReferenceLocator, t: u64) -> Option<u32> {
        self.two_level()?.reference_of_triangle(locator, t)
    }

    /// The instance that places scene object `object`: the scene's own instance, or the
    /// object itself where the structure's instances are the scene's objects (a scene
    /// whose objects do not cover its triangles in order is one instance of them all).
    pub fn instance_of_object(&self, scene: &Scene, object: usize) -> Option<usize> {
        let t = self.two_level()?;
        if !scene.instances.is_empty() {
            return scene.instance_of_object(object);
        }
        Some(if self.objects_are_instances(scene, object) {
            object
        } else {
            0
        })
        .filter(|&i| i < t.instances.len())
    }

    /// Whether the structure's instances are the scene's objects, object `object` among
    /// them (a scene without instances of its own, each object placed once).
    pub fn objects_are_instances(&self, scene: &Scene, object: usize) -> bool {
        let (Some(t), Some(o)) = (self.two_level(), scene.objects.get(object)) else {
            return false;
        };
        t.instances.len() == scene.objects.len()
            && t.first_triangle.get(object) == Some(&(o.range().start as u64))
    }

    /// Places instance `i` by `transform` and refits the top level; `None` for a structure
    /// without instances.
    pub fn move_instance(
        &mut self,
        i: usize,
        transform: Affine3A,
    ) -> Option<Result<(), MoveError>> {
        match self {
            Structure::TwoLevel(t) => Some(t.move_instance(i, transform)),
            _ => None,
        }
    }
}
