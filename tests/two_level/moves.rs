//! Moving triangles and instances: the refitted or rebuilt levels equal a build from
//! scratch.

use super::*;

#[test]
fn moving_triangles_of_an_instanced_scene_keeps_it_consistent() {
    let mut scene = instanced_scene(6, 9);
    let object = scene.objects[2].clone();
    let moved: Vec<u32> = object.range().map(|t| t as u32).collect();
    scene.move_triangles(&moved, Vec3::new(0.5, 0.0, 0.0));
    // The instances no longer describe the moved scene: it is traced as its objects.
    let instancing = scene.instancing();
    assert_eq!(instancing.instanced_triangles(), scene.triangles.len());
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::FrontToBack),
        &Default::default(),
    )
    .unwrap();
    let flat = BruteForce::new(&scene.triangles, false);
    for ray in common::rays(&scene.bounds(), 1000, 10) {
        assert!(common::same_hit(
            built
                .structure
                .closest_hit::<Watertight, _>(&ray, &mut NoStats),
            flat.closest_hit::<Watertight, _>(&ray, &mut NoStats)
        ));
    }
}

#[test]
fn moving_instances_rebuilds_the_top_level_only_and_equals_a_full_rebuild() {
    let scene = instanced_scene(40, 31);
    for rebraid in [0.0, DEFAULT_REBRAID] {
        let params = rebraided(TraversalOrder::FrontToBack, rebraid);
        moves_equal_a_full_rebuild(&scene, &params);
        moves_equal_a_full_rebuild(&scene, &direct_wide(params));
    }
}

/// Moves five of `scene`'s instances built with `params`: the refitted two levels, their
/// top level rebuilt and the scene built again from scratch with the instances moved
/// agree; bad moves change nothing.
fn moves_equal_a_full_rebuild(scene: &Scene, params: &StructureParams) {
    use bvhlab::accel::two_level::MoveError;
    let built = structure::build_scene(scene, params, &Default::default()).unwrap();
    let Structure::TwoLevel(mut moved) = built.structure else {
        panic!("a two-level structure")
    };
    let blases_before: Vec<_> = moved.blases.iter().map(|b| b.nodes.clone()).collect();
    let mut rng = Rng::new(32);
    let mut transforms: Vec<Affine3A> = scene.instances.iter().map(|i| i.transform).collect();
    for k in [0, 7, 13, 20, 39] {
        // Instance 20 is only shifted, as a drag in the app shifts one: its references'
        // boxes are shifted, not placed corner by corner.
        transforms[k] = match k {
            20 => Affine3A::from_translation(Vec3::new(0.37, -1.25, 2.5)),
            _ => random_transform(&mut rng, k),
        };
        moved.move_instance(k, transforms[k]).unwrap();
    }
    assert_leaves_match(&moved);
    let blases_after: Vec<_> = moved.blases.iter().map(|b| b.nodes.clone()).collect();
    assert_eq!(blases_before, blases_after, "the BLASes stay as they were");
    // Every reference of a moved instance moved with it: its leaf box holds its triangles
    // where they are now.
    for k in [0, 7, 13, 20, 39] {
        let placed = Instance::new(scene.instances[k].mesh, transforms[k]).unwrap();
        let mesh = &scene.meshes[placed.mesh].triangles;
        for r in moved.references_of(k) {
            let (node, lane) = moved.top_index.slot_of(r).unwrap();
            let leaf = moved.tlas.nodes[node as usize].child_bounds(lane as usize);
            for t in moved.reference_triangles(r) {
                let world = placed.place(&mesh[(t - moved.first_triangle[k]) as usize]);
                assert!(
                    world.v.iter().all(|&v| leaf.contains_point(v)),
                    "instance {k}"
                );
            }
        }
    }

    // The same scene built from scratch with the instances where they were moved to.
    let mut again = Scene::new("moved");
    again.meshes = scene.meshes.clone();
    for (k, (inst, m)) in scene.instances.iter().zip(&transforms).enumerate() {
        let placed = Instance::new(inst.mesh, *m).unwrap();
        again.push_instance(format!("instance {k}"), Vec3::ONE, placed);
    }
    let rebuilt = structure::build_scene(&again, params, &Default::default()).unwrap();
    let flat = BruteForce::new(&again.triangles, false);
    let mut rays = common::rays(&again.bounds(), 1500, 33);
    rays.extend(rays_at_triangles(&again, 1500, 34));
    let mut hits = 0;
    for ray in &rays {
        let got = moved.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let want = rebuilt
            .structure
            .closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert!(common::same_hit(got, want), "{ray:?}: {got:?} vs {want:?}");
        assert_eq!(
            moved.any_hit::<Watertight, _>(ray, &mut NoStats),
            rebuilt
                .structure
                .any_hit::<Watertight, _>(ray, &mut NoStats)
        );
        hits += usize::from(got.is_some());
        let flat_hit = flat.closest_hit::<Watertight, _>(ray, &mut NoStats);
        compare("moved", &again.triangles, EXTENT, ray, got, flat_hit);
    }
    assert!(hits > rays.len() / 2, "{hits} hits");

    // The refitted top level and one built again over the moved instances agree.
    let mut rebuilt_top = moved.clone();
    rebuilt_top.rebuild_top_level().unwrap();
    for ray in &rays {
        let refitted = moved.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let again = rebuilt_top.closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert_eq!(refitted, again, "{ray:?}");
    }
    // The rebuild keeps the references, each in a leaf of its refitted box.
    assert_eq!(rebuilt_top.references, moved.references);
    for r in 0..moved.references.len() {
        let leaf_box = |tl: &TwoLevel| {
            let (node, lane) = tl.top_index.slot_of(r).unwrap();
            tl.tlas.nodes[node as usize].child_bounds(lane as usize)
        };
        assert_eq!(leaf_box(&rebuilt_top), leaf_box(&moved), "reference {r}");
    }
    // Without re-braiding the references are the instances themselves, as a build from
    // scratch makes them: over the same boxes, the rebuilt top level is its top level.
    if params.bvh.rebraid == 0.0 {
        let Structure::TwoLevel(fresh) = &rebuilt.structure else {
            panic!("a two-level structure")
        };
        assert_eq!(rebuilt_top.references, fresh.references);
        assert_eq!(rebuilt_top.tlas.nodes, fresh.tlas.nodes);
        assert_eq!(rebuilt_top.tlas.prim_indices, fresh.tlas.prim_indices);
    }

    // Bad moves change nothing.
    let before = moved.instances.clone();
    let singular = Affine3A::from_scale(Vec3::new(0.0, 1.0, 1.0));
    assert!(matches!(
        moved.move_instance(3, singular),
        Err(MoveError::Transform(_))
    ));
    assert_eq!(
        moved.move_instance(99, Affine3A::IDENTITY),
        Err(MoveError::NoInstance(99))
    );
    let far = Affine3A::from_translation(Vec3::splat(f32::MAX));
    assert!(moved.move_instance(3, far).is_err());
    assert_eq!(moved.instances, before);
    assert_leaves_match(&moved);
    assert_leaves_match(&rebuilt_top);
}

/// Each TLAS leaf slot carries its reference's instance as it is now.
fn assert_leaves_match(tl: &TwoLevel) {
    assert_eq!(tl.leaves.len(), tl.tlas.prim_indices.len());
    for (k, &r) in tl.tlas.prim_indices.iter().enumerate() {
        let Some(reference) = tl.references.get(r as usize) else {
            assert_eq!(tl.leaves[k], LeafReference::UNUSED, "padding slot {k}");
            continue;
        };
        let want = LeafReference::new(reference, &tl.instances[reference.instance as usize]);
        assert_eq!(tl.leaves[k], want, "leaf slot {k}");
    }
}
