//! Degenerate and bad inputs: they build and trace, or are refused with an error.

use super::*;

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
