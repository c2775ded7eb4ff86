//! The `island` scene: its two levels hit what its flattened scene hits, at a size small
//! enough to flatten; at its default size it places over 1.5 × 10^10 triangles without
//! storing them, and a structure over its flattened triangles is refused with a clear error.

mod common;

use bvhlab::accel::structure::{self, AccelKind, StructureError, StructureParams};
use bvhlab::accel::{Accel, Counters, NoStats};
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::island::{self, Detail};
use bvhlab::scene::{FlattenError, Scene, SceneError, instance};
use common::instanced::compare;

fn two_level() -> StructureParams {
    StructureParams::of_kind(AccelKind::TwoLevel)
}

/// Rays from above the island down at random points of its ground, and from the view.
fn island_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let b = scene.bounds();
    let mut rays = common::rays(&b, n, seed);
    rays.extend(common::view_rays(scene, 48, 27));
    rays
}

#[test]
fn a_small_island_hits_what_its_flattened_scene_hits() {
    let scene = island::island(300, &Detail::SMALL);
    assert_eq!(scene.instances.len(), 302);
    assert!(!scene.is_flattened());
    let flat_triangles = instance::flatten(&scene.meshes, &scene.instances);
    assert_eq!(flat_triangles.len(), scene.placed_triangles());
    // The scene places each triangle where flattening puts it.
    for i in (0..flat_triangles.len()).step_by(97) {
        assert_eq!(scene.triangle(i as u64), Some(flat_triangles[i]));
    }
    let flat = structure::build(
        &flat_triangles,
        &StructureParams::of_kind(AccelKind::Bvh),
        &Default::default(),
    )
    .unwrap();
    // A flat structure over the scene flattens it on demand: the same answers.
    let on_demand = structure::build_scene(
        &scene,
        &StructureParams::of_kind(AccelKind::Bvh),
        &Default::default(),
    )
    .unwrap();
    let built = structure::build_scene(&scene, &two_level(), &Default::default()).unwrap();
    let tl = &built.structure;
    let extent = scene.bounds().diagonal();
    let rays = island_rays(&scene, 3000, 11);
    let (mut hits, mut grazing) = (0, 0);
    for ray in &rays {
        let want = flat
            .structure
            .closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert_eq!(
            on_demand
                .structure
                .closest_hit::<Watertight, _>(ray, &mut NoStats),
            want
        );
        let got = tl.closest_hit::<Watertight, _>(ray, &mut Counters::default());
        // Counting changes nothing.
        assert_eq!(tl.closest_hit::<Watertight, _>(ray, &mut NoStats), got);
        if compare("island", &flat_triangles, extent, ray, got, want) {
            grazing += 1;
            continue;
        }
        hits += usize::from(want.is_some());
        assert_eq!(
            tl.any_hit::<Watertight, _>(ray, &mut NoStats),
            want.is_some(),
            "any hit of {ray:?}"
        );
        assert_eq!(
            tl.any_hit::<Watertight, _>(ray, &mut Counters::default()),
            want.is_some()
        );
    }
    assert!(hits > rays.len() / 3, "the rays find the island: {hits}");
    assert!(grazing * 500 <= 2 * rays.len(), "{grazing} rays grazing");
}

#[test]
fn the_default_island_places_over_fifteen_billion_triangles_unflattened() {
    let scene = Scene::load("island").unwrap();
    assert_eq!(scene.instances.len(), island::DEFAULT_INSTANCES + 2);
    assert!(scene.triangles.is_empty());
    let instancing = scene.instancing();
    assert!(instancing.instanced_triangles() as f64 >= 1.5e10);
    assert_eq!(instancing.instanced_triangles(), scene.placed_triangles());
    assert!(instancing.unique_triangles() < 2_000_000);
    // A flat structure would need the flattened copy: refused, saying how large it is.
    for kind in [AccelKind::Bvh, AccelKind::KdTree, AccelKind::Grid] {
        let err =
            structure::build_scene(&scene, &StructureParams::of_kind(kind), &Default::default())
                .err()
                .expect("a flat structure over the default island");
        let StructureError::Flatten(FlattenError { triangles, bytes }) = err else {
            panic!("{err:?}");
        };
        assert_eq!(triangles, scene.placed_triangles());
        assert_eq!(bytes, 40 * triangles as u64);
        assert!(err.to_string().contains("two-level"), "{err}");
    }
    assert!(matches!(scene.flattened(), Err(FlattenError { .. })));
}

#[test]
fn island_sizes_are_checked() {
    let small = Scene::load("island:5").unwrap();
    assert_eq!(small.instances.len(), 7);
    for bad in ["island:0", "island:x", "island:99999999"] {
        assert!(
            matches!(Scene::load(bad), Err(SceneError::BadParameter { .. })),
            "{bad}"
        );
    }
    // Deterministic.
    let again = Scene::load("island:5").unwrap();
    assert_eq!(small.instances, again.instances);
}
