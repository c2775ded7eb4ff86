//! The two-level structure against the same scene flattened into world-space triangles:
//! instances rotated, scaled unevenly, mirrored and sheared give the flattened scene's
//! closest hit (same triangle, t within the transform's rounding) and any hit, in either
//! child order, with counting on or off; scenes without instances of their own (each
//! object one instance) answer bit for bit like brute force; degenerate inputs build.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::build::{DEFAULT_REBRAID, MAX_REBRAID};
use bvhlab::accel::bvh::{Strategy, Subtree};
use bvhlab::accel::structure::{self, AccelKind, Structure, StructureParams};
use bvhlab::accel::two_level::{LeafReference, Reference, TwoLevel};
use bvhlab::accel::{Accel, BruteForce, Counters, NoStats, TraversalOrder};
use bvhlab::geometry::{Ray, Triangle, Watertight};
use bvhlab::scene::{Instance, Instancing, Mesh, Scene, instance};
use common::Rng;
use common::instanced::compare;

/// The extent of the test scenes, the distance scale of their rounding.
const EXTENT: f32 = 20.0;
use glam::{Affine3A, Quat, Vec3};

fn two_level_params(order: TraversalOrder) -> StructureParams {
    StructureParams {
        order,
        ..StructureParams::of_kind(AccelKind::TwoLevel)
    }
}

/// Re-braiding off, at its default budget and at its largest.
const BUDGETS: [f32; 3] = [0.0, DEFAULT_REBRAID, MAX_REBRAID];

fn rebraided(order: TraversalOrder, rebraid: f32) -> StructureParams {
    let mut p = two_level_params(order);
    p.bvh.rebraid = rebraid;
    p
}

/// Both levels built as the LBVH's wide trees straight from the Morton order.
fn direct_wide(mut p: StructureParams) -> StructureParams {
    p.bvh.strategy = Strategy::Lbvh;
    p.bvh.direct_wide = true;
    p
}

/// A closed mesh: the built-in sphere, centred at the origin with radius 1.
fn sphere() -> Vec<Triangle> {
    let s = Scene::load("sphere:400").unwrap();
    let c = s.bounds().center();
    let r = s.bounds().extent().x / 2.0;
    s.triangles
        .iter()
        .map(|t| Triangle::new((t.v[0] - c) / r, (t.v[1] - c) / r, (t.v[2] - c) / r))
        .collect()
}

/// A random rotation, a scale of up to 4:1 between axes, and a translation in a 20-unit
/// cube; every fifth transform is a mirror, every seventh has a shear.
fn random_transform(rng: &mut Rng, k: usize) -> Affine3A {
    let axis = rng.unit_vector();
    let rotation = Quat::from_axis_angle(axis, rng.range(0.0, std::f32::consts::TAU));
    let mut scale = Vec3::new(
        rng.range(0.5, 2.0),
        rng.range(0.5, 2.0),
        rng.range(0.5, 2.0),
    );
    if k.is_multiple_of(5) {
        scale.x = -scale.x;
    }
    let translation = Vec3::new(
        rng.range(-10.0, 10.0),
        rng.range(-10.0, 10.0),
        rng.range(-10.0, 10.0),
    );
    let mut m = Affine3A::from_scale_rotation_translation(scale, rotation, translation);
    if k.is_multiple_of(7) {
        m.matrix3.y_axis += m.matrix3.x_axis * 0.5;
    }
    m
}

/// Three unique meshes (a random soup, a sphere, an empty mesh) placed by `count`
/// instances, one in ten of the empty mesh.
fn instanced_scene(count: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene::new("instanced");
    let soup: Vec<Triangle> = common::soup(200, seed)
        .iter()
        .map(|t| Triangle::new(t.v[0] * 2.0, t.v[1] * 2.0, t.v[2] * 2.0))
        .collect();
    scene.meshes = vec![
        Mesh {
            name: "soup".into(),
            triangles: soup,
        },
        Mesh {
            name: "sphere".into(),
            triangles: sphere(),
        },
        Mesh {
            name: "nothing".into(),
            triangles: Vec::new(),
        },
    ];
    for k in 0..count {
        let mesh = if k % 10 == 9 { 2 } else { k % 2 };
        let instance = Instance::new(mesh, random_transform(&mut rng, k)).unwrap();
        scene.push_instance(format!("instance {k}"), Vec3::ONE, instance);
    }
    scene
}

/// Rays from around the scene at random points of random triangles, so most rays hit.
fn rays_at_triangles(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed ^ 0x7a11);
    let b = scene.bounds();
    (0..n)
        .map(|_| {
            let t = &scene.triangles[rng.below(scene.triangles.len())];
            let (u, v) = (rng.f32(), rng.f32());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let target = t.point(u, v);
            let origin = b.center() + rng.unit_vector() * b.diagonal();
            Ray::new(origin, (target - origin) * rng.range(0.1, 3.0))
        })
        .collect()
}

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
fn transforms_without_an_inverse_are_refused() {
    use bvhlab::scene::TransformError;
    let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert_eq!(Instance::new(0, flat), Err(TransformError::Singular));
    let tiny = Affine3A::from_scale(Vec3::new(1.0, 1e-20, 1.0));
    assert_eq!(Instance::new(0, tiny), Err(TransformError::Singular));
    let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    assert_eq!(Instance::new(0, nan), Err(TransformError::NonFinite));
    let inf = Affine3A::from_scale(Vec3::splat(f32::INFINITY));
    assert_eq!(Instance::new(0, inf), Err(TransformError::NonFinite));
    let mirror = Affine3A::from_scale(Vec3::new(-1.0, 2.0, 0.5));
    let i = Instance::new(0, mirror).unwrap();
    let p = Vec3::new(1.0, 2.0, 3.0);
    assert!((i.inverse.transform_point3(i.transform.transform_point3(p)) - p).length() < 1e-6);
}

#[test]
fn degenerate_inputs_build_and_trace() {
    let params = two_level_params(TraversalOrder::FrontToBack);
    let ray = Ray::new(Vec3::new(0.2, 0.2, -5.0), Vec3::Z);
    let empty_mesh: &[Triangle] = &[];
    let one = [Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)];
    let cases: Vec<(&str, Instancing, bool)> = vec![
        (
            "no instances",
            Instancing {
                meshes: vec![&one],
                instances: Vec::new().into(),
            },
            false,
        ),
        ("no meshes", Instancing::single(empty_mesh), false),
        ("one instance", Instancing::single(&one), true),
        (
            "instances of an empty mesh",
            Instancing {
                meshes: vec![empty_mesh],
                instances: vec![Instance::identity(0); 3].into(),
            },
            false,
        ),
        (
            "an empty mesh before a full one",
            Instancing {
                meshes: vec![empty_mesh, &one],
                instances: vec![Instance::identity(0), Instance::identity(1)].into(),
            },
            true,
        ),
        (
            "the same place many times",
            Instancing {
                meshes: vec![&one],
                instances: vec![Instance::identity(0); 100].into(),
            },
            true,
        ),
    ];
    for (what, instancing, hit) in cases {
        let built = structure::build_two_level(&instancing, &params, &Default::default())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let s = &built.structure;
        let found = s.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        assert_eq!(found.is_some(), hit, "{what}");
        // Of instances in the same place, the first (lowest triangle number) wins.
        if let Some(h) = found {
            assert_eq!(h.triangle, 0, "{what}");
        }
        assert_eq!(
            s.any_hit::<Watertight, _>(&ray, &mut NoStats),
            hit,
            "{what}"
        );
        s.outline().validate().unwrap();
        assert_eq!(built.report.triangles, instancing.instanced_triangles());
    }
    // The degenerate triangle lists of every structure's tests, as one instance.
    for (what, triangles) in common::degenerate_cases() {
        let built = structure::build(&triangles, &params, &Default::default()).unwrap();
        let flat = BruteForce::new(&triangles, false);
        let b = triangles
            .iter()
            .fold(bvhlab::geometry::Aabb::EMPTY, |b, t| b.union(t.bounds()));
        let b = if b.is_empty() {
            bvhlab::geometry::Aabb::new(Vec3::ZERO, Vec3::ONE)
        } else {
            b
        };
        for ray in common::rays(&b, 300, 3) {
            assert!(
                common::same_hit(
                    built
                        .structure
                        .closest_hit::<Watertight, _>(&ray, &mut NoStats),
                    flat.closest_hit::<Watertight, _>(&ray, &mut NoStats)
                ),
                "{what}: {ray:?}"
            );
        }
    }
}

#[test]
fn bad_parameters_and_non_finite_meshes_are_errors() {
    let mut params = two_level_params(TraversalOrder::FrontToBack);
    params.bvh.buckets = 1;
    assert!(params.validate().is_err());
    let one = [Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)];
    assert!(structure::build(&one, &params, &Default::default()).is_err());
    for budget in [-1.0, MAX_REBRAID + 1.0, f32::NAN, f32::INFINITY] {
        let params = rebraided(TraversalOrder::FrontToBack, budget);
        let error = structure::build(&one, &params, &Default::default())
            .err()
            .expect("a budget out of range is an error");
        assert!(error.to_string().contains("re-braiding budget"), "{error}");
    }
    let params = two_level_params(TraversalOrder::FrontToBack);
    let bad = [one[0], Triangle::new(Vec3::NAN, Vec3::X, Vec3::Y)];
    let instancing = Instancing {
        meshes: vec![&one, &bad],
        instances: vec![Instance::identity(0), Instance::identity(1)].into(),
    };
    let error = structure::build_two_level(&instancing, &params, &Default::default())
        .err()
        .expect("a NaN vertex is an error");
    // Named as the flattened scene numbers it: the second instance's second triangle.
    assert!(error.to_string().contains("triangle 2 "), "{error}");
}

#[test]
fn nested_gltf_nodes_hit_what_their_flattened_scene_hits() {
    use common::gltf::{GltfBuilder, UNSIGNED_INT, temp_dir};
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
    let path = b.write_glb(&temp_dir("nested"), "nested");
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
    use common::gltf::{GltfBuilder, UNSIGNED_INT, temp_dir};
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
    let scene = Scene::load(&b.write_glb(&temp_dir("ties"), "ties").display().to_string()).unwrap();
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
fn every_slab_kernel_gives_the_same_hits_and_counts() {
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
    for level in SimdLevel::available() {
        built.set_simd(level).unwrap();
        assert_eq!(built.simd(), Some(level));
        assert!(trace(&built) == portable, "{}", level.label());
    }
}

/// The explorer's view of the two levels: the selected instance's BLAS hangs below the
/// top-level leaf that holds it, its boxes drawn where the instance's transform places them
/// contain the instance's world-space triangles (every triangle inside the placed root box,
/// each leaf's triangles inside the leaf's placed box), and the walk's children and parents
/// are the structure's.
#[test]
fn the_selected_instances_blas_is_drawn_around_its_world_triangles_and_walked_below_its_leaf() {
    use bvhlab::app::levels::{Levels, WalkNode};
    let scene = instanced_scene(40, 91);
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::default()),
        &Default::default(),
    )
    .unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    let top = tl.outline();
    let leaf_instances = tl.leaf_instances();
    assert_eq!(leaf_instances.len(), top.nodes.len());
    let mut mirrored = 0;
    for (i, placed) in scene.instances.iter().enumerate() {
        let o = tl.instance_outline(i).unwrap();
        assert_eq!((o.instance, o.mesh), (i, placed.mesh));
        assert_eq!(o.transform, placed.transform);
        let mesh = &scene.meshes[placed.mesh].triangles;
        assert_eq!(o.triangle_count, mesh.len());
        mirrored += usize::from(placed.transform.matrix3.determinant() < 0.0);
        // The BLAS outline is the mesh's own BVH8, in the mesh's space.
        let blas = &tl.blases[placed.mesh];
        assert_eq!(o.blas.nodes[0].bounds, blas.nodes[0].bounds());
        // (The outline has a node per lane: its leaves are one below the deepest wide node.)
        if !mesh.is_empty() {
            assert_eq!(o.blas.max_depth(), blas.depth);
        }
        o.blas.validate().unwrap();
        if o.entries.is_empty() {
            // Only an empty mesh's instance is in no leaf.
            assert!(mesh.is_empty(), "instance {i} is in no leaf");
            continue;
        }
        // Every world triangle of the instance lies in the placed root box, and in the
        // world box around it; each leaf's triangles in that leaf's placed box.
        let world: Vec<Triangle> = mesh.iter().map(|t| placed.place(t)).collect();
        let root_box = o.world_bounds(0);
        for t in &world {
            for v in t.v {
                assert!(o.placed_box_contains(0, v, 1e-4), "instance {i}: {v}");
                let pad = 1e-4 * (root_box.max - root_box.min).max_element();
                assert!(
                    (v.cmpge(root_box.min - pad) & v.cmple(root_box.max + pad)).all(),
                    "instance {i}: {v} outside {root_box:?}"
                );
            }
        }
        // Each of the instance's top-level leaves holds one of its references, whose BLAS
        // node's triangles its world box holds; the entries' triangles are the mesh's, each
        // once (the references cut the BLAS).
        let mut reached = vec![0u32; mesh.len()];
        for e in &o.entries {
            assert_eq!(leaf_instances[e.tlas_leaf as usize], i as u32);
            assert!(top.nodes[e.tlas_leaf as usize].is_leaf());
            let leaf_box = top.nodes[e.tlas_leaf as usize].bounds;
            for t in o.triangles_under(e.blas_node as usize) {
                let local = (t - o.first_triangle) as usize;
                reached[local] += 1;
                assert!(world[local].v.iter().all(|&v| leaf_box.contains_point(v)));
            }
        }
        assert!(reached.iter().all(|&n| n == 1), "instance {i}: {reached:?}");
        let mut covered = vec![false; mesh.len()];
        for k in 0..o.blas.nodes.len() {
            if !o.blas.nodes[k].is_leaf() {
                continue;
            }
            for t in o.triangles_under(k) {
                let local = (t - o.first_triangle) as usize;
                covered[local] = true;
                for v in world[local].v {
                    assert!(o.placed_box_contains(k, v, 1e-4), "instance {i} node {k}");
                }
            }
        }
        assert!(covered.iter().all(|&c| c), "every triangle in a leaf");
        assert_eq!(o.first_triangle, tl.first_triangle[i]);
        // Hits name flattened triangles: each is found in its instance again.
        let last = o.first_triangle + mesh.len() as u64 - 1;
        assert_eq!(tl.instance_of_triangle(o.first_triangle), Some(i));
        assert_eq!(tl.instance_of_triangle(last), Some(i));

        // The walk: the levels run on below the top level by the BLAS's levels; a leaf of
        // the instance has its reference's BLAS node as its only child, whose parent is the
        // leaf; below, the BLAS's own.
        let levels = Levels::new(&top, Some(&o));
        assert_eq!(Levels::new(&top, None).max_depth(), top.max_depth());
        assert_eq!(levels.max_depth(), top.max_depth() + 1 + o.blas.max_depth());
        let root = WalkNode::Bottom(0);
        assert_eq!(levels.node(levels.id(root)), Some(root));
        assert_eq!(levels.depth(root), top.max_depth() + 1);
        assert_eq!(levels.level(top.max_depth() + 1), vec![root]);
        for e in &o.entries {
            let (leaf, node) = (
                WalkNode::Top(e.tlas_leaf as usize),
                WalkNode::Bottom(e.blas_node as usize),
            );
            assert_eq!(levels.children(leaf), vec![node]);
            assert_eq!(levels.parent(node), Some(leaf));
            assert_eq!(levels.top_above(node), Some(e.tlas_leaf as usize));
        }
        for k in 0..o.blas.nodes.len() {
            let n = WalkNode::Bottom(k);
            let children: Vec<WalkNode> =
                o.blas.nodes[k].children().map(WalkNode::Bottom).collect();
            assert_eq!(levels.children(n), children);
            for c in children {
                let WalkNode::Bottom(b) = c else {
                    unreachable!()
                };
                let above = match o.leaf_above(b as u32) {
                    Some(l) => WalkNode::Top(l as usize),
                    None => n,
                };
                assert_eq!(levels.parent(c), Some(above));
                assert_eq!(levels.depth(c), levels.depth(n) + 1);
            }
        }
        // The rest of the top level is unchanged.
        for k in 0..top.nodes.len() {
            if o.entry_below(k as u32).is_none() {
                let children: Vec<WalkNode> = top.nodes[k].children().map(WalkNode::Top).collect();
                assert_eq!(levels.children(WalkNode::Top(k)), children);
            }
        }
    }
    assert!(mirrored > 0, "the scene mirrors some instances");
    assert!(tl.instance_outline(scene.instances.len()).is_none());
    assert_eq!(tl.instance_of_triangle(scene.triangles.len() as u64), None);
}

/// On the island, placing billions of triangles, a selected instance's outline is its
/// mesh's BLAS alone: nothing is flattened.
#[test]
fn an_island_instances_outline_is_its_meshs_blas_alone() {
    use bvhlab::scene::island::{self, Detail};
    let scene = island::island(300, &Detail::SMALL);
    assert!(!scene.is_flattened());
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::default()),
        &Default::default(),
    )
    .unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    for i in [0, 1, scene.instances.len() / 2, scene.instances.len() - 1] {
        let o = tl.instance_outline(i).unwrap();
        let mesh = &scene.meshes[o.mesh].triangles;
        assert_eq!(o.blas.refs.len(), tl.blases[o.mesh].prim_indices.len());
        assert!(o.blas.nodes.len() <= 2 * mesh.len() + 1);
        let placed = &scene.instances[i];
        for t in mesh.iter().step_by(7) {
            for v in placed.place(t).v {
                assert!(o.placed_box_contains(0, v, 1e-4), "instance {i}");
            }
        }
    }
}

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
        let w = instance_world_box(instance, &tl.blases[instance.mesh]);
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

/// Sponza loaded as instances (each OBJ object one instance) and re-braided hits what the
/// flattened BVH8 hits, bit for bit: its instances leave their meshes in place.
#[test]
fn sponza_as_instances_hits_what_the_flattened_bvh8_hits() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared scenes");
        return;
    };
    let scene = Scene::load(&dir.join("sponza.obj").display().to_string()).unwrap();
    let flat = structure::build_scene(
        &scene,
        &StructureParams::of_kind(AccelKind::Bvh8),
        &Default::default(),
    )
    .unwrap();
    for rebraid in BUDGETS {
        let built = structure::build_scene(
            &scene,
            &rebraided(TraversalOrder::FrontToBack, rebraid),
            &Default::default(),
        )
        .unwrap();
        let Structure::TwoLevel(tl) = &built.structure else {
            panic!("two levels")
        };
        assert_eq!(tl.instances.len(), scene.objects.len());
        let mut rays = common::rays(&scene.bounds(), 3000, 51);
        rays.extend(rays_at_triangles(&scene, 3000, 52));
        let mut hits = 0;
        for ray in &rays {
            let want = flat
                .structure
                .closest_hit::<Watertight, _>(ray, &mut NoStats);
            let got = built
                .structure
                .closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert_eq!(got, want, "rebraid {rebraid}: {ray:?}");
            hits += usize::from(got.is_some());
            assert_eq!(
                built.structure.any_hit::<Watertight, _>(ray, &mut NoStats),
                flat.structure.any_hit::<Watertight, _>(ray, &mut NoStats),
                "rebraid {rebraid}: {ray:?}"
            );
        }
        assert!(hits > rays.len() / 2, "{hits} hits");
    }
}

/// The two levels over `scene` at every re-braiding budget, with every slab kernel.
fn each_configuration(
    scene: &Scene,
    mut f: impl FnMut(f32, bvhlab::geometry::simd::SimdLevel, &Structure),
) {
    use bvhlab::geometry::simd::SimdLevel;
    for rebraid in BUDGETS {
        let mut built = structure::build_scene(
            scene,
            &rebraided(TraversalOrder::FrontToBack, rebraid),
            &Default::default(),
        )
        .unwrap()
        .structure;
        let mut levels = vec![SimdLevel::Portable];
        levels.extend(SimdLevel::available());
        for level in levels {
            built.set_simd(level).unwrap();
            f(rebraid, level, &built);
        }
    }
}

/// 8 × 8 tiles of a camera's rays, as the renderer sends them: one origin per packet.
fn tiles_of(scene: &Scene, eye: Vec3, w: u32, h: u32) -> Vec<Ray> {
    let rays = bvhlab::scene::Camera::new(eye, scene.bounds().center()).rays(w, h);
    let mut out = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            for y in y0..(y0 + 8).min(h) {
                for x in x0..(x0 + 8).min(w) {
                    out.push(rays.pixel_center(x, y));
                }
            }
        }
    }
    out
}

/// Packets through the top level give exactly the single rays' hits: for coherent tiles of
/// a camera (the interval test culls) and for random rays of different origins (it cannot),
/// at every re-braiding budget and with every slab kernel, packets cut short included.
#[test]
fn packets_of_the_two_levels_hit_what_single_rays_hit() {
    let scene = instanced_scene(60, 61);
    let b = scene.bounds();
    let mut sets = vec![
        tiles_of(
            &scene,
            b.center() + Vec3::new(0.1, 0.15, 0.4) * b.diagonal(),
            40,
            27,
        ),
        tiles_of(
            &scene,
            b.center() - Vec3::new(0.4, 0.1, 0.05) * b.diagonal(),
            24,
            24,
        ),
        common::rays(&b, 1000, 62),
    ];
    sets.push(rays_at_triangles(&scene, 500, 63));
    each_configuration(&scene, |rebraid, level, built| {
        for rays in &sets {
            let single: Vec<_> = rays
                .iter()
                .map(|r| built.closest_hit::<Watertight, _>(r, &mut NoStats))
                .collect();
            let hits = single.iter().filter(|h| h.is_some()).count();
            assert!(hits > rays.len() / 10, "{hits} of {}", rays.len());
            // Whole packets, and packets of 13 rays (a packet shorter than 64).
            for chunk in [64, 13] {
                let mut packets = vec![None; rays.len()];
                for (r, h) in rays.chunks(chunk).zip(packets.chunks_mut(chunk)) {
                    built.closest_hits::<Watertight>(r, h);
                }
                for (k, (p, s)) in packets.iter().zip(&single).enumerate() {
                    assert_eq!(
                        p,
                        s,
                        "ray {k} {:?}, budget {rebraid}, {}",
                        rays[k],
                        level.label()
                    );
                }
            }
        }
    });
}

#[test]
fn a_leaf_reference_is_one_cache_line() {
    assert_eq!(std::mem::size_of::<LeafReference>(), 64);
    assert_eq!(std::mem::align_of::<LeafReference>(), 64);
}

#[test]
fn rays_are_carried_into_object_space_exactly_as_the_instance_does() {
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    for k in 0..500 {
        let scale = Vec3::new(0.1 + next().abs() * 4.0, 0.3 + next().abs(), -1.5 + next());
        let turn = Quat::from_euler(glam::EulerRot::XYZ, next() * 3.0, next(), next() * 2.0);
        let shift = Vec3::new(next(), next(), next()) * 1000.0;
        let instance = Instance::new(
            k % 3,
            Affine3A::from_scale_rotation_translation(scale, turn, shift),
        )
        .unwrap();
        let reference = Reference {
            instance: k as u32,
            subtree: Subtree::leaf(7, 2),
            triangles: 2,
        };
        let leaf = LeafReference::new(&reference, &instance);
        assert_eq!((leaf.instance(), leaf.blas), (k as u32, (k % 3) as u32));
        assert!(!leaf.is_identity());
        let ray = Ray::new(
            Vec3::new(next(), next(), next()) * 500.0,
            Vec3::new(next(), next(), next()),
        );
        let got = leaf.to_object(&ray);
        let want_origin = instance.inverse.transform_point3(ray.origin);
        let want_direction = instance.inverse.transform_vector3(ray.direction);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        assert_eq!(bits(got.origin), bits(want_origin));
        assert_eq!(bits(got.direction), bits(want_direction));
        assert_eq!((got.tmin, got.tmax), (ray.tmin, ray.tmax));
    }
    let identity = Instance::identity(4);
    let reference = Reference {
        instance: 9,
        subtree: Subtree::ROOT,
        triangles: 1,
    };
    let leaf = LeafReference::new(&reference, &identity);
    assert!(leaf.is_identity());
    assert_eq!((leaf.instance(), leaf.blas), (9, 4));
}

#[test]
fn packets_through_identity_instances_hit_what_single_rays_hit() {
    // Each object of a built-in scene is an identity instance: a packet entering one walks
    // on into its BLAS as a packet (the BVH8's packet walk from the reference's subtree,
    // each ray limited by its best hit in the BLASes before), where a single ray walks it
    // alone with the world ray's slab and shear data. Both must give the same hits, signs
    // of zero components included, at every re-braiding budget (whole BLASes, and
    // subtrees down to leaves), with every slab kernel, and with an intersector that has
    // no packet form (the BLAS leaves then test ray by ray).
    use bvhlab::geometry::MollerTrumbore;
    for name in ["cornell", "teapot-in-stadium", "walls-rotated", "soup:3000"] {
        let scene = Scene::load(name).unwrap();
        let b = scene.bounds();
        let mut rays = tiles_of(
            &scene,
            b.center() + Vec3::new(0.1, 0.2, 0.9) * b.diagonal(),
            32,
            24,
        );
        rays.extend(tiles_of(
            &scene,
            b.center() - Vec3::new(0.3, 0.05, 0.1) * b.diagonal(),
            24,
            16,
        ));
        // Axis-parallel rays from inside, with +0.0 and −0.0 components.
        let c = b.center();
        for d in [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ] {
            let negative_zeros = Vec3::select(d.cmpeq(Vec3::ZERO), Vec3::splat(-0.0), d);
            rays.push(Ray::new(c, d));
            rays.push(Ray::new(c, negative_zeros));
        }
        each_configuration(&scene, |rebraid, level, built| {
            let label = format!("{name}, budget {rebraid}, {}", level.label());
            let single: Vec<_> = rays
                .iter()
                .map(|r| built.closest_hit::<Watertight, _>(r, &mut NoStats))
                .collect();
            let hits = single.iter().filter(|h| h.is_some()).count();
            assert!(hits > rays.len() / 10, "{label}: {hits} hits");
            let single_mt: Vec<_> = rays
                .iter()
                .map(|r| built.closest_hit::<MollerTrumbore, _>(r, &mut NoStats))
                .collect();
            for chunk in [64, 13] {
                let mut packets = vec![None; rays.len()];
                let mut packets_mt = vec![None; rays.len()];
                for ((r, h), h_mt) in rays
                    .chunks(chunk)
                    .zip(packets.chunks_mut(chunk))
                    .zip(packets_mt.chunks_mut(chunk))
                {
                    built.closest_hits::<Watertight>(r, h);
                    built.closest_hits::<MollerTrumbore>(r, h_mt);
                }
                for k in 0..rays.len() {
                    assert_eq!(packets[k], single[k], "{label}: ray {k} {:?}", rays[k]);
                    assert_eq!(packets_mt[k], single_mt[k], "{label}: ray {k}");
                }
            }
        });
    }
}

/// The cost-per-triangle view under the two levels: each pixel's triangle carries its
/// placed share of both levels' SAH cost, worked out for the triangles shown only, the
/// shares of all placed triangles summing to the SAH cost (`PlacedCosts`' unit test).
#[test]
fn the_cost_per_triangle_view_shows_each_placed_triangles_share() {
    use bvhlab::render::per_triangle::PerTriangle;
    use bvhlab::render::{self, Mode, RenderSettings};
    let scene = instanced_scene(40, 5);
    let params = StructureParams::of_kind(AccelKind::TwoLevel);
    let s = structure::build_scene(&scene, &params, &Default::default())
        .unwrap()
        .structure;
    let settings = RenderSettings::for_scene(&scene, 64, 48);
    let frame = render::trace(&s, &scene, &settings);
    let v = frame
        .triangle_values_for::<Watertight>(
            Mode::TriangleCost,
            &s,
            &params,
            &scene,
            &settings,
            1,
            &|| false,
        )
        .unwrap()
        .unwrap();
    let (sah, c_trav, c_isect) = s.sah_cost(&params).unwrap();
    assert_eq!(v.total, sah);
    let Structure::TwoLevel(tl) = &s else {
        unreachable!()
    };
    let costs = tl.placed_costs(c_trav, c_isect);
    let PerTriangle::Some(worked_out) = &v.values else {
        panic!("every placed triangle worked out");
    };
    let hits: Vec<_> = frame.samples.iter().filter(|x| x.is_hit()).collect();
    assert!(hits.len() > 100);
    for x in hits {
        let share = v.of(x).unwrap();
        assert!(
            share > 0.0 && share == costs.of(x.triangle),
            "{}",
            x.triangle
        );
        assert!(worked_out.contains_key(&x.triangle));
    }
    assert!(worked_out.len() < scene.placed_triangles());
}
