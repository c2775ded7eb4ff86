//! Hits against the flattened scene and brute force: transformed instances, counting,
//! numbering, glTF nodes, closed meshes, ties and every slab kernel.

use super::*;

#[test]
fn instanced_scenes_hit_what_their_flattened_scenes_hit() {
    for (count, seed) in [(1, 1), (12, 2), (60, 3)] {
        let scene = instanced_scene(count, seed);
        let flat = BruteForce::new(&scene.triangles, false);
        let mut rays = common::rays(&scene.bounds(), 2000, seed);
        rays.extend(rays_at_triangles(&scene, 2000, seed));
        let (mut hits, mut grazing) = (0, 0);
        // Each order at each budget, and the direct wide build of both levels.
        let configurations: Vec<(StructureParams, String)> = TraversalOrder::ALL
            .into_iter()
            .flat_map(|order| BUDGETS.map(|rebraid| (order, rebraid)))
            .map(|(order, rebraid)| {
                let label = format!("{count} instances, {}, rebraid {rebraid}", order.label());
                (rebraided(order, rebraid), label)
            })
            .chain(BUDGETS.map(|rebraid| {
                let p = direct_wide(rebraided(TraversalOrder::FrontToBack, rebraid));
                (
                    p,
                    format!("{count} instances, direct wide, rebraid {rebraid}"),
                )
            }))
            .collect();
        for (params, label) in &configurations {
            let built = structure::build_scene(&scene, params, &Default::default()).unwrap();
            let tl = &built.structure;
            assert_eq!(tl.kind(), AccelKind::TwoLevel);
            for ray in &rays {
                let want = flat.closest_hit::<Watertight, _>(ray, &mut NoStats);
                let got = tl.closest_hit::<Watertight, _>(ray, &mut NoStats);
                if compare(label, &scene.triangles, EXTENT, ray, got, want) {
                    grazing += 1;
                    continue;
                }
                hits += usize::from(want.is_some());
                // A shadow ray towards just before the flattened hit, and one past it.
                if let Some(w) = want {
                    for (tmax, blocked) in [(w.t * 0.999, false), (w.t * 1.001, true)] {
                        let shadow = Ray::segment(ray.origin, ray.direction, ray.tmin, tmax);
                        let flat_any = flat.any_hit::<Watertight, _>(&shadow, &mut NoStats);
                        assert!(flat_any || !blocked, "the hit itself blocks {shadow:?}");
                        assert_eq!(
                            tl.any_hit::<Watertight, _>(&shadow, &mut NoStats),
                            flat_any,
                            "{label}: any hit of {shadow:?}"
                        );
                    }
                }
                assert_eq!(
                    tl.any_hit::<Watertight, _>(ray, &mut NoStats),
                    want.is_some(),
                    "{label}: any hit of {ray:?}"
                );
            }
        }
        let traced = configurations.len() * rays.len();
        assert!(hits > traced / 2, "the rays find the instances: {hits}");
        // Rays within rounding of an edge are rare: at most 1 in 500.
        assert!(grazing * 500 <= traced, "{grazing} rays grazing an edge");
    }
}

#[test]
fn counting_changes_no_hit_and_counts_both_levels() {
    let scene = instanced_scene(30, 7);
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::FrontToBack),
        &Default::default(),
    )
    .unwrap();
    let tl = &built.structure;
    let Structure::TwoLevel(two_level) = tl else {
        panic!("a two-level structure")
    };
    let mut total = Counters::default();
    for ray in common::rays(&scene.bounds(), 2000, 8) {
        let mut c = Counters::default();
        let counted = tl.closest_hit::<Watertight, _>(&ray, &mut c);
        let plain = tl.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        assert!(common::same_hit(counted, plain), "{ray:?}");
        if counted.is_some() {
            // The TLAS root, at least one TLAS leaf... and the BLAS's root at least.
            assert!(c.nodes_visited >= 2 && c.triangle_tests >= 1, "{c:?}");
        }
        let mut a = Counters::default();
        assert_eq!(
            tl.any_hit::<Watertight, _>(&ray, &mut a),
            tl.any_hit::<Watertight, _>(&ray, &mut NoStats)
        );
        total += c;
    }
    // Both levels are counted: more nodes than the TLAS alone could give.
    assert!(total.nodes_visited as usize > 2000 && two_level.tlas.nodes.len() > 1);
    assert_eq!(total.repeated_tests, 0);
}

#[test]
fn scenes_without_instances_answer_exactly_like_brute_force() {
    let mut names: Vec<String> = common::SMALL_BUILTINS
        .iter()
        .map(|s| s.to_string())
        .collect();
    if let Some(dir) = common::shared_scenes() {
        names.push(dir.join("cornell-box.obj").display().to_string());
    }
    for name in names {
        let scene = Scene::load(&name).unwrap();
        assert!(scene.instances.is_empty());
        let instancing = scene.instancing();
        assert_eq!(instancing.instances.len(), scene.objects.len(), "{name}");
        let flat = BruteForce::new(&scene.triangles, false);
        let built = structure::build_scene(
            &scene,
            &two_level_params(TraversalOrder::FrontToBack),
            &Default::default(),
        )
        .unwrap();
        let tl = &built.structure;
        let mut rays = common::rays(&scene.bounds(), 1500, 11);
        rays.extend(common::view_rays(&scene, 24, 18));
        for ray in &rays {
            let want = flat.closest_hit::<Watertight, _>(ray, &mut NoStats);
            let got = tl.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert!(
                common::same_hit(got, want),
                "{name}: {ray:?}: {got:?} vs {want:?}"
            );
            assert_eq!(
                tl.any_hit::<Watertight, _>(ray, &mut NoStats),
                flat.any_hit::<Watertight, _>(ray, &mut NoStats),
                "{name}: {ray:?}"
            );
        }
        let outline = tl.outline();
        outline.validate().unwrap();
        assert_eq!(outline.triangles_under(0).len(), scene.triangles.len());
    }
}

#[test]
fn the_flattened_scene_numbers_triangles_instance_by_instance() {
    let scene = instanced_scene(12, 5);
    let flat = instance::flatten(&scene.meshes, &scene.instances);
    assert_eq!(flat, scene.triangles);
    let mut next = 0;
    for inst in &scene.instances {
        let mesh = &scene.meshes[inst.mesh].triangles;
        for (k, t) in mesh.iter().enumerate() {
            assert_eq!(scene.triangles[next + k], inst.place(t));
        }
        next += mesh.len();
    }
    assert_eq!(next, scene.triangles.len());
    let instancing = scene.instancing();
    assert_eq!(instancing.instanced_triangles(), scene.triangles.len());
    assert_eq!(instancing.unique_triangles(), 200 + sphere().len());
}

#[test]
fn nested_gltf_nodes_hit_what_their_flattened_scene_hits() {
    use common::gltf::{GltfBuilder, UNSIGNED_INT};
    use serde_json::json;
    let mut b = GltfBuilder::default();
    let mesh_of = |b: &mut GltfBuilder, triangles: &[Triangle]| {
        let points: Vec<Vec3> = triangles.iter().flat_map(|t| t.v).collect();
        let p = b.positions(&points);
        let indices: Vec<u32> = (0..points.len() as u32).collect();
        let i = b.indices(&indices, UNSIGNED_INT);
        b.mesh(&[(p, Some(i))])
    };
    let sphere_mesh = mesh_of(&mut b, &sphere());
    let soup_mesh = mesh_of(&mut b, &common::soup(150, 21));
    // Three levels: a rotated, unevenly scaled root; mirrored and sheared children placed
    // by matrices; grandchildren placed by TRS; both meshes used at every level.
    let mut rng = Rng::new(22);
    let mut roots = Vec::new();
    for r in 0..3 {
        let mut children = Vec::new();
        for c in 0..3 {
            let mut grandchildren = Vec::new();
            for g in 0..2 {
                let rotation = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, 6.0));
                let node = b.node(json!({
                    "mesh": if g == 0 { sphere_mesh } else { soup_mesh },
                    "translation": [rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 1.5],
                    "rotation": rotation.to_array(),
                    "scale": [rng.range(0.3, 1.0), rng.range(0.3, 1.0), rng.range(0.3, 1.0)],
                }));
                grandchildren.push(node);
            }
            let m = random_transform(&mut rng, 5 * c + 7 * (c % 2));
            let node = b.node(json!({
                "mesh": if c == 1 { sphere_mesh } else { soup_mesh },
                "matrix": glam::Mat4::from(m).to_cols_array(),
                "children": grandchildren,
            }));
            children.push(node);
        }
        let rotation = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, 6.0));
        let node = b.node(json!({
            "rotation": rotation.to_array(),
            "scale": [1.0, 0.5 + r as f32, 0.75],
            "translation": [r as f32 * 15.0, 0.0, 0.0],
            "children": children,
        }));
        roots.push(node);
    }
    b.roots = roots;
    let dir = common::TempDir::new("gltf-nested");
    let path = b.write_glb(dir.path(), "nested");
    let scene = Scene::load(&path.display().to_string()).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.instances.len(), 3 * 3 * 3);
    let flat = BruteForce::new(&scene.triangles, false);
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::FrontToBack),
        &Default::default(),
    )
    .unwrap();
    let mut rays = common::rays(&scene.bounds(), 1500, 23);
    rays.extend(rays_at_triangles(&scene, 1500, 24));
    let (mut hits, mut grazing) = (0, 0);
    for ray in &rays {
        let want = flat.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let got = built
            .structure
            .closest_hit::<Watertight, _>(ray, &mut NoStats);
        if compare("nested glTF", &scene.triangles, EXTENT, ray, got, want) {
            grazing += 1;
            continue;
        }
        hits += usize::from(want.is_some());
        assert_eq!(
            built.structure.any_hit::<Watertight, _>(ray, &mut NoStats),
            want.is_some()
        );
    }
    assert!(hits > rays.len() / 2, "{hits} hits");
    assert!(
        grazing * 500 <= rays.len(),
        "{grazing} rays grazing an edge"
    );
}

#[test]
fn closed_meshes_placed_as_instances_do_not_leak() {
    // Only the closed sphere, placed with rotations, uneven scales, mirrors and shears:
    // every ray from a sphere's centre must hit that sphere (or something nearer).
    let mut rng = Rng::new(41);
    let mut scene = Scene::new("spheres");
    scene.meshes = vec![Mesh {
        name: "sphere".into(),
        triangles: sphere(),
    }];
    for k in 0..25 {
        let instance = Instance::new(0, random_transform(&mut rng, k)).unwrap();
        scene.push_instance(format!("sphere {k}"), Vec3::ONE, instance);
    }
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::FrontToBack),
        &Default::default(),
    )
    .unwrap();
    let mut leaks = 0;
    let mut rays = 0;
    for instance in &scene.instances {
        let centre = instance.transform.transform_point3(Vec3::ZERO);
        for _ in 0..400 {
            let ray = Ray::new(centre, rng.unit_vector() * rng.range(0.1, 10.0));
            rays += 1;
            let hit = built
                .structure
                .closest_hit::<Watertight, _>(&ray, &mut NoStats);
            let any = built.structure.any_hit::<Watertight, _>(&ray, &mut NoStats);
            if hit.is_none() || !any {
                leaks += 1;
            }
        }
    }
    assert_eq!(leaks, 0, "{leaks} of {rays} rays left a closed mesh");
}

#[test]
fn instances_in_the_same_place_tie_as_the_flattened_scene_does() {
    // A glTF whose nodes do not move their meshes, one mesh placed three times in the same
    // place: every hit is a tie between three instances, which the lowest number wins,
    // bit for bit as brute force over the flattened scene.
    use common::gltf::{GltfBuilder, UNSIGNED_INT};
    use serde_json::json;
    let mut b = GltfBuilder::default();
    let points: Vec<Vec3> = sphere().iter().flat_map(|t| t.v).collect();
    let p = b.positions(&points);
    let i = b.indices(&(0..points.len() as u32).collect::<Vec<_>>(), UNSIGNED_INT);
    let mesh = b.mesh(&[(p, Some(i))]);
    for _ in 0..3 {
        let n = b.node(json!({ "mesh": mesh }));
        b.roots.push(n);
    }
    let dir = common::TempDir::new("gltf-ties");
    let scene = Scene::load(&b.write_glb(dir.path(), "ties").display().to_string()).unwrap();
    assert_eq!(scene.instances.len(), 3);
    let flat = BruteForce::new(&scene.triangles, false);
    for order in TraversalOrder::ALL {
        let built =
            structure::build_scene(&scene, &two_level_params(order), &Default::default()).unwrap();
        let mut hits = 0;
        for ray in common::rays(&scene.bounds(), 2000, 51) {
            let want = flat.closest_hit::<Watertight, _>(&ray, &mut NoStats);
            let got = built
                .structure
                .closest_hit::<Watertight, _>(&ray, &mut NoStats);
            assert!(common::same_hit(got, want), "{ray:?}: {got:?} vs {want:?}");
            if let Some(h) = got {
                assert!((h.triangle as usize) < scene.meshes[0].triangles.len());
                hits += 1;
            }
        }
        assert!(hits > 500, "{hits} hits");
    }
}

#[test]
fn every_slab_kernel_gives_the_same_hits_and_each_form_the_same_counts() {
    use bvhlab::geometry::simd::SimdLevel;
    let scene = instanced_scene(40, 51);
    let params = two_level_params(TraversalOrder::FrontToBack);
    let mut built = structure::build_scene(&scene, &params, &Default::default())
        .unwrap()
        .structure;
    let mut rays = common::rays(&scene.bounds(), 2000, 52);
    rays.extend(rays_at_triangles(&scene, 2000, 53));
    let trace = |s: &Structure| -> Vec<_> {
        rays.iter()
            .map(|r| {
                let mut c = Counters::default();
                let hit = s.closest_hit::<Watertight, _>(r, &mut c);
                (hit, c, s.any_hit::<Watertight, _>(r, &mut NoStats))
            })
            .collect()
    };
    built.set_simd(SimdLevel::Portable).unwrap();
    let portable = trace(&built);
    assert!(portable.iter().any(|(h, ..)| h.is_some()));
    // The plain kernels count alike; AVX-512 tests most rays in the fused form, whose
    // boxes may differ from the plain form's by a rounding at the edge, so there only the
    // hits must agree.
    for level in SimdLevel::available() {
        built.set_simd(level).unwrap();
        assert_eq!(built.simd(), Some(level));
        let got = trace(&built);
        let same_hits = got
            .iter()
            .zip(&portable)
            .all(|(a, b)| a.0 == b.0 && a.2 == b.2);
        assert!(same_hits, "{}", level.label());
        if level != SimdLevel::Avx512 {
            assert!(got == portable, "{}", level.label());
        }
    }
}
