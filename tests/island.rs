//! The `island` scene: its two levels hit what its flattened scene hits, at a size small
//! enough to flatten; at its default size it places over 1.5 × 10^10 triangles without
//! storing them, and a structure over its flattened triangles is refused with a clear error.

use bvhlab_testkit as common;

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

/// The renderer's packets of 8 × 8 view rays through the two levels hit what the same rays
/// hit one by one.
#[test]
fn a_small_islands_view_in_packets_hits_what_single_rays_hit() {
    let scene = island::island(300, &Detail::SMALL);
    let built = structure::build_scene(&scene, &two_level(), &Default::default()).unwrap();
    let tl = &built.structure;
    let (w, h) = (64, 40);
    let cam = scene.camera().rays(w, h);
    for (x0, y0) in (0..h / 8).flat_map(|ty| (0..w / 8).map(move |tx| (tx * 8, ty * 8))) {
        let rays: Vec<Ray> = (0..64)
            .map(|k| cam.pixel_center(x0 + k % 8, y0 + k / 8))
            .collect();
        let mut packet = [None; 64];
        tl.closest_hits::<Watertight>(&rays, &mut packet);
        for (ray, got) in rays.iter().zip(packet) {
            assert_eq!(got, tl.closest_hit::<Watertight, _>(ray, &mut NoStats));
        }
    }
}

/// A crown's leaf cards are the size of a leaf cluster: a ray that reaches a tree tests a
/// few cards before its hit, as in any well-sorted mesh. (Cards of 70 cm put each point of
/// the crown inside the boxes of some 70 of them, and cost about 60 tests a ray.)
#[test]
fn a_ray_into_a_crown_tests_few_leaf_cards() {
    let scene = island::island(1, &Detail::FULL);
    for mesh in scene
        .meshes
        .iter()
        .filter(|m| m.name.contains("tree") || m.name == "conifer")
    {
        let built = structure::build(
            &mesh.triangles,
            &StructureParams::of_kind(AccelKind::Bvh8),
            &Default::default(),
        )
        .unwrap();
        let b = mesh
            .triangles
            .iter()
            .fold(bvhlab::geometry::Aabb::EMPTY, |b, t| b.union(t.bounds()));
        let cam = bvhlab::scene::Camera::framing(&b).rays(64, 64);
        let (mut tests, mut hits) = (0, 0);
        for (x, y) in (0..64).flat_map(|y| (0..64).map(move |x| (x, y))) {
            let mut c = Counters::default();
            let ray = cam.pixel_center(x, y);
            if built
                .structure
                .closest_hit::<Watertight, _>(&ray, &mut c)
                .is_some()
            {
                tests += c.triangle_tests;
                hits += 1;
            }
        }
        assert!(hits > 400, "{}: the crown is opaque: {hits}", mesh.name);
        let mean = tests as f32 / hits as f32;
        assert!(mean < 12.0, "{}: {mean} triangle tests a hit", mesh.name);
    }
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
