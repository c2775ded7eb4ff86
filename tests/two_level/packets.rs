//! Packets and the rays carried into object space: the same hits as single rays, bit for
//! bit.

use super::*;

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
