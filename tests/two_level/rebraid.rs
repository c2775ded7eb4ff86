//! Re-braiding: references cut each instance's BLAS; without it, one reference per
//! instance; entries counted per reference.

use super::*;

/// Re-braiding opens instances into references, each a subtree of the instance's BLAS: the
/// references of an instance cut its BLAS, so they reach each of its triangles exactly once;
/// the top-level leaf of each holds its placed triangles; the locator finds for every
/// triangle the reference that reaches it; the budget bounds their number.
#[test]
fn rebraiding_cuts_each_instances_blas_into_references() {
    use bvhlab::accel::two_level::rebraid::SMALL_SCENE;
    let scene = instanced_scene(40, 41);
    for rebraid in [0.01, DEFAULT_REBRAID, MAX_REBRAID] {
        let built = structure::build_scene(
            &scene,
            &rebraided(TraversalOrder::FrontToBack, rebraid),
            &Default::default(),
        )
        .unwrap();
        let Structure::TwoLevel(tl) = &built.structure else {
            panic!("two levels")
        };
        let placed = (0..scene.instances.len())
            .filter(|&i| !scene.meshes[scene.instances[i].mesh].triangles.is_empty())
            .count();
        let budget = (rebraid * placed.max(SMALL_SCENE) as f32) as usize;
        assert!(
            tl.references.len() > placed,
            "rebraid {rebraid}: something opened"
        );
        assert!(tl.references.len() <= placed + budget);
        let report = &built.report;
        let row = |k: &str| report.detail(k).unwrap().clone();
        assert_eq!(
            row("TLAS references").as_count(),
            Some(tl.references.len() as u64)
        );
        assert!(
            row("re-braiding").to_string().contains("instances opened"),
            "{:?}",
            report.details
        );
        // Sorted by instance, then subtree; `first_reference` bounds each instance's.
        assert!(
            tl.references
                .windows(2)
                .all(|w| (w[0].instance, w[0].subtree) < (w[1].instance, w[1].subtree))
        );
        let top = tl.outline();
        let leaf_references = tl.leaf_references();
        let leaf_of: std::collections::HashMap<u32, usize> = leaf_references
            .iter()
            .enumerate()
            .filter(|(_, r)| **r != u32::MAX)
            .map(|(k, &r)| (r, k))
            .collect();
        assert_eq!(leaf_of.len(), tl.references.len(), "one leaf per reference");
        let locator = tl.reference_locator();
        for (i, instance) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[instance.mesh].triangles;
            let refs = tl.references_of(i);
            assert_eq!(refs.is_empty(), mesh.is_empty());
            let mut reached = vec![0u32; mesh.len()];
            for r in refs.clone() {
                let reference = tl.references[r];
                assert_eq!(reference.instance as usize, i);
                let triangles = tl.reference_triangles(r);
                assert_eq!(triangles.len(), reference.triangles as usize);
                // The leaf's box holds the reference's triangles, placed.
                let leaf_box = top.nodes[leaf_of[&(r as u32)]].bounds;
                for &t in &triangles {
                    let local = (t - tl.first_triangle[i]) as usize;
                    reached[local] += 1;
                    let world = instance.place(&mesh[local]);
                    assert!(world.v.iter().all(|&v| leaf_box.contains_point(v)));
                    assert_eq!(tl.reference_of_triangle(&locator, t), Some(r as u32));
                }
                if reference.subtree != Subtree::ROOT {
                    assert!(refs.len() > 1 || reference.subtree.is_leaf());
                }
            }
            assert!(reached.iter().all(|&n| n == 1), "instance {i}: {reached:?}");
        }
    }
}

/// With re-braiding off the top level is the one over whole instances: one reference per
/// instance of a non-empty mesh, its BLAS's root, and the tree the BVH builder makes over
/// the instances' world boxes.
#[test]
fn without_rebraiding_the_top_level_is_built_over_whole_instances() {
    use bvhlab::accel::bvh::wide::CollapseParams;
    use bvhlab::accel::bvh::{self, Bvh8, Subtree};
    use bvhlab::accel::two_level::instance_world_box;
    let scene = instanced_scene(50, 43);
    let params = rebraided(TraversalOrder::FrontToBack, 0.0);
    let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    let mut boxes = Vec::new();
    let mut whole = Vec::new();
    for (i, instance) in scene.instances.iter().enumerate() {
        let hull = tl.hulls[instance.mesh].as_ref();
        let w = instance_world_box(instance, &tl.blases[instance.mesh], hull);
        if !w.is_empty() {
            boxes.push(Triangle::new(w.min, w.max, w.max));
            whole.push(i as u32);
        }
    }
    let instances: Vec<u32> = tl.references.iter().map(|r| r.instance).collect();
    assert_eq!(instances, whole);
    assert!(tl.references.iter().all(|r| r.subtree == Subtree::ROOT));
    let tlas_params = bvhlab::accel::BuildParams {
        max_leaf_size: 1,
        ..params.bvh.whole_references()
    };
    let (tlas2, _) = bvh::build(&boxes, &tlas_params).unwrap();
    let collapse = CollapseParams {
        c_trav: params.bvh.c_trav,
        c_isect: params.bvh.c_isect,
        max_leaf_size: 1,
    };
    let old = Bvh8::collapse(&tlas2, &collapse);
    assert_eq!(tl.tlas.nodes, old.nodes);
    assert_eq!(tl.tlas.prim_indices, old.prim_indices);
    let report = &built.report.details;
    assert!(report.contains(&(
        "re-braiding".into(),
        "off (one reference per instance)".into()
    )));
}

/// Counting with references: an instance is entered once per reference walked (the replay
/// records one `instance` step for each), and the top level's nodes are those the replay
/// visits at the top level.
#[test]
fn an_instance_is_entered_once_per_reference_walked() {
    use bvhlab::accel::Recorder;
    use bvhlab::accel::replay::{Level, Step};
    let scene = instanced_scene(30, 47);
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::FrontToBack),
        &Default::default(),
    )
    .unwrap();
    let (mut entered, mut twice) = (0, 0);
    for ray in common::rays(&scene.bounds(), 1000, 48) {
        for any in [false, true] {
            let mut rec = Recorder::default();
            let mut counted = Counters::default();
            if any {
                built.structure.any_hit::<Watertight, _>(&ray, &mut rec);
                built.structure.any_hit::<Watertight, _>(&ray, &mut counted);
            } else {
                built.structure.closest_hit::<Watertight, _>(&ray, &mut rec);
                built
                    .structure
                    .closest_hit::<Watertight, _>(&ray, &mut counted);
            }
            assert_eq!(rec.counters, counted);
            let steps =
                |f: &dyn Fn(&Step) -> bool| rec.steps.iter().filter(|s| f(s)).count() as u32;
            let instances: Vec<u32> = rec
                .steps
                .iter()
                .filter_map(|s| match s {
                    Step::Instance { instance } => Some(*instance),
                    _ => None,
                })
                .collect();
            assert_eq!(counted.instances_entered, instances.len() as u32);
            let top = steps(&|s| {
                matches!(
                    s,
                    Step::Visit {
                        level: Level::Top,
                        ..
                    }
                )
            });
            assert_eq!(counted.top_nodes_visited, top);
            entered += instances.len();
            let mut distinct = instances.clone();
            distinct.sort_unstable();
            distinct.dedup();
            twice += usize::from(distinct.len() < instances.len());
        }
    }
    assert!(entered > 0);
    assert!(
        twice > 0,
        "some ray enters one instance through two references"
    );
}

/// A rotated or scaled instance's world box from its mesh's convex hull holds every placed
/// triangle, and is no larger than the box of its BLAS's boxes placed (what an instance
/// without a hull takes) and smaller for most instances.
#[test]
fn a_hull_places_to_a_box_that_holds_the_mesh_and_is_no_larger() {
    use bvhlab::accel::two_level::instance_world_box;
    let scene = instanced_scene(60, 47);
    let params = rebraided(TraversalOrder::FrontToBack, 0.0);
    let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    let (mut turned, mut tighter) = (0, 0);
    for instance in scene.instances.iter() {
        let (mesh, blas) = (&scene.meshes[instance.mesh], &tl.blases[instance.mesh]);
        if mesh.triangles.is_empty() || instance.is_identity() || instance.is_translation() {
            continue;
        }
        turned += 1;
        let hull = tl.hulls[instance.mesh]
            .as_ref()
            .expect("a solid mesh has a hull");
        let tight = instance_world_box(instance, blas, Some(hull));
        let coarse = instance_world_box(instance, blas, None);
        for t in &mesh.triangles {
            let placed = instance.place(t).bounds();
            assert!(tight.min.cmple(placed.min).all() && tight.max.cmpge(placed.max).all());
        }
        // Both are padded for rounding; the hull's pad may reach past an exact corner.
        assert!(tight.surface_area() <= coarse.surface_area() * (1.0 + 1e-5));
        tighter += usize::from(tight.surface_area() < coarse.surface_area() * 0.999);
    }
    assert!(
        turned > 20 && tighter * 10 >= turned * 8,
        "{tighter} of {turned}"
    );
}
