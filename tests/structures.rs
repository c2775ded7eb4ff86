//! Every structure behind the selector against brute force, through the one runtime type
//! the app, the CLI and the bench use: the same closest hits (lowest triangle on equal t)
//! with mailboxing on and off, any hit agreeing with closest hit, counting changing no hit,
//! and exactly the BVH2's hit counts on the standard views of the shared scenes.

use bvhlab_testkit as common;

use bvhlab::accel::structure::{self, AccelKind, Structure, StructureParams};
use bvhlab::accel::{Accel, BruteForce, Counters, NoStats};
use bvhlab::bench::rays::RaySets;
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::{Scene, builtin};
use common::{rays, same_hit, shared_scenes, soup};

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn build(tris: &[Triangle], kind: AccelKind, mailbox: bool) -> Structure {
    let params = StructureParams {
        mailbox,
        ..StructureParams::of_kind(kind)
    };
    let built = structure::build(tris, &params, &Default::default())
        .unwrap_or_else(|e| panic!("{}: {e}", kind.label()));
    assert_eq!(built.structure.kind(), kind);
    assert_eq!(built.report.triangles, tris.len());
    built
        .structure
        .outline()
        .validate()
        .unwrap_or_else(|e| panic!("{}: outline: {e}", kind.label()));
    built.structure
}

/// Closest hits equal brute force exactly, any hit agrees, and counting changes nothing.
fn assert_matches_brute_force(s: &Structure, brute: &BruteForce, rays: &[Ray], what: &str) {
    for (i, ray) in rays.iter().enumerate() {
        let expected = brute.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let got = s.closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert!(
            same_hit(got, expected),
            "{what}: ray {i} {ray:?}: got {got:?}, brute force {expected:?}"
        );
        let counted = s.closest_hit::<Watertight, _>(ray, &mut Counters::default());
        assert!(
            same_hit(counted, got),
            "{what}: ray {i}: counting changed the hit"
        );
        let occluded = s.any_hit::<Watertight, _>(ray, &mut NoStats);
        assert_eq!(
            occluded,
            expected.is_some(),
            "{what}: any hit of ray {i} {ray:?}"
        );
    }
}

#[test]
fn every_structure_matches_brute_force_on_random_soups() {
    for seed in 0..3 {
        let tris = soup(1500, seed);
        let brute = BruteForce::new(&tris, false);
        let rays = rays(&bounds(&tris), 1500, seed + 10);
        for kind in AccelKind::ALL {
            for mailbox in [true, false] {
                let s = build(&tris, kind, mailbox);
                let what = format!("{} mailbox {mailbox} soup {seed}", kind.label());
                assert_matches_brute_force(&s, &brute, &rays, &what);
            }
        }
    }
}

#[test]
fn every_structure_matches_brute_force_on_every_builtin_scene() {
    for name in builtin::NAMES {
        let spec = match *name {
            "grass" | "soup" | "sphere" | "walls" | "walls-rotated" => format!("{name}:3000"),
            "same-centroid" | "same-bbox" => format!("{name}:300"),
            // Its flattened scene is compared with the two levels in tests/island.rs.
            "island" => continue,
            _ => name.to_string(),
        };
        let scene = Scene::load(&spec).unwrap();
        let tris = &scene.triangles;
        let brute = BruteForce::new(tris, false);
        let mut rays = rays(&scene.bounds(), 600, 7);
        rays.extend(common::view_rays(&scene, 24, 18));
        for kind in AccelKind::ALL {
            for mailbox in [true, false] {
                let s = build(tris, kind, mailbox);
                let what = format!("{} mailbox {mailbox} on {spec}", kind.label());
                assert_matches_brute_force(&s, &brute, &rays, &what);
            }
        }
    }
}

#[test]
fn degenerate_scenes_build_and_trace_with_every_structure() {
    let one = Triangle::new(glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y);
    // Every triangle in the plane z = 0: a scene with zero extent on an axis.
    let flat: Vec<Triangle> = soup(400, 3)
        .into_iter()
        .map(|t| Triangle::new(t.v[0].with_z(0.0), t.v[1].with_z(0.0), t.v[2].with_z(0.0)))
        .collect();
    let cases: Vec<(&str, Vec<Triangle>)> = vec![
        ("empty", Vec::new()),
        ("one triangle", vec![one]),
        ("flat", flat),
        (
            "same centroid",
            Scene::load("same-centroid:200").unwrap().triangles,
        ),
        ("same box", Scene::load("same-bbox:200").unwrap().triangles),
    ];
    for (what, tris) in cases {
        let brute = BruteForce::new(&tris, false);
        let b = if tris.is_empty() {
            Aabb::new(glam::Vec3::splat(-1.0), glam::Vec3::ONE)
        } else {
            bounds(&tris)
        };
        let rays = rays(&b, 500, 3);
        for kind in AccelKind::ALL {
            let s = build(&tris, kind, true);
            assert_matches_brute_force(&s, &brute, &rays, &format!("{} on {what}", kind.label()));
        }
    }
}

#[test]
fn plain_brute_force_tests_every_triangle_and_the_early_out_tests_pierced_boxes() {
    let scene = Scene::load("soup:500").unwrap();
    let plain = build(&scene.triangles, AccelKind::BruteForce, true);
    let early = build(&scene.triangles, AccelKind::BruteForceBbox, true);
    let rays = rays(&scene.bounds(), 200, 4);
    let mut fewer = 0;
    for ray in &rays {
        let mut a = Counters::default();
        plain.closest_hit::<Watertight, _>(ray, &mut a);
        assert_eq!(
            a.triangle_tests, 500,
            "plain brute force tests every triangle"
        );
        assert_eq!(a.box_tests, 0);
        let mut b = Counters::default();
        early.closest_hit::<Watertight, _>(ray, &mut b);
        // One test of the scene's box, then one per triangle unless the scene box is missed.
        assert!(b.box_tests == 1 || b.box_tests == 501, "{b:?}");
        assert!(b.triangle_tests <= b.box_tests.saturating_sub(1));
        fewer += usize::from(b.triangle_tests < 500);
    }
    assert!(
        fewer > rays.len() / 2,
        "the early out spared tests on only {fewer} rays"
    );
}

#[test]
fn traversal_settings_change_no_hit_and_need_no_rebuild() {
    let a = StructureParams::default();
    let b = StructureParams {
        mailbox: false,
        order: bvhlab::accel::TraversalOrder::Naive,
        ..a
    };
    assert!(!a.needs_rebuild_for(&b));
    for kind in AccelKind::ALL {
        assert!(a.needs_rebuild_for(&StructureParams { kind, ..a }) == (kind != a.kind));
    }
}

/// The octree's report weighs its cells with the k-d tree's C_trav and C_isect, so a change
/// of those rebuilds it (and its report); the k-d tree's other settings do not.
#[test]
fn the_kd_constants_rebuild_the_octree_and_nothing_else_of_the_kd_tree_does() {
    let octree = StructureParams::of_kind(AccelKind::Octree);
    let with = |f: fn(&mut StructureParams)| {
        let mut p = octree;
        f(&mut p);
        p
    };
    assert!(octree.needs_rebuild_for(&with(|p| p.kdtree.c_trav = 3.0)));
    assert!(octree.needs_rebuild_for(&with(|p| p.kdtree.c_isect = 0.5)));
    assert!(!octree.needs_rebuild_for(&with(|p| p.kdtree.empty_bonus = 0.5)));
    let bvh = StructureParams::of_kind(AccelKind::Bvh);
    let mut other = bvh;
    other.kdtree.c_trav = 3.0;
    assert!(!bvh.needs_rebuild_for(&other), "a BVH does not use them");
}

/// Every structure gives exactly the BVH2's primary, diffuse and shadow hit counts (and the
/// same hits) on the standard view of each shared scene.
#[test]
fn every_structure_gives_the_bvh_hits_on_the_standard_views() {
    let Some(dir) = shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared scenes");
        return;
    };
    for (file, eye, look, light) in [
        ("cornell-box.obj", None, None, None),
        (
            "sponza.obj",
            Some([-14.0, 3.0, 0.0]),
            Some([10.0, 5.0, 0.0]),
            Some([0.0, 14.0, 0.0]),
        ),
    ] {
        let scene = Scene::load(dir.join(file).to_str().unwrap()).unwrap();
        let mut cam = scene.camera();
        if let (Some(e), Some(l)) = (eye, look) {
            cam.eye = e.into();
            cam.look_at = l.into();
        }
        let light = light.map_or(scene.light(), Into::into);
        let bvh = build(&scene.triangles, AccelKind::Bvh, true);
        let sets = RaySets::standard(&bvh, &scene, &cam, light, 256, 192);
        let expect_closest = |rays: &[Ray]| -> Vec<_> {
            rays.iter()
                .map(|r| bvh.closest_hit::<Watertight, _>(r, &mut NoStats))
                .collect()
        };
        let (primary, diffuse) = (expect_closest(&sets.primary), expect_closest(&sets.diffuse));
        let shadow: Vec<bool> = sets
            .shadow
            .iter()
            .map(|r| bvh.any_hit::<Watertight, _>(r, &mut NoStats))
            .collect();
        for kind in AccelKind::ALL.into_iter().filter(|k| !k.is_brute_force()) {
            let s = build(&scene.triangles, kind, true);
            for (name, rays, expected) in [
                ("primary", &sets.primary, &primary),
                ("diffuse", &sets.diffuse, &diffuse),
            ] {
                for (i, (r, e)) in rays.iter().zip(expected).enumerate() {
                    let got = s.closest_hit::<Watertight, _>(r, &mut NoStats);
                    assert!(
                        same_hit(got, *e),
                        "{} {file} {name} ray {i}: {got:?} vs {e:?}",
                        kind.label()
                    );
                }
            }
            for (i, (r, &e)) in sets.shadow.iter().zip(&shadow).enumerate() {
                assert_eq!(
                    s.any_hit::<Watertight, _>(r, &mut NoStats),
                    e,
                    "{} {file} shadow ray {i}",
                    kind.label()
                );
            }
        }
    }
}

/// Stacks of long, thin triangles lying on top of each other in axis-aligned planes (as a
/// model's overlapping decals and doubled faces do), and slanted rays through them: every triangle
/// of a stack is hit at the same true distance, and the f32 distances differ by 10–20 ulps
/// or are equal. Every structure, ray by ray and in packets, names brute force's triangle:
/// no box is skipped because its entry lies beyond a best t that rounding placed too near,
/// and no hit is lost to an interval its f32 t fell outside of.
#[test]
fn every_structure_matches_brute_force_on_stacked_coplanar_triangles() {
    let mut rng = common::Rng::new(0xfa5);
    let mut tris = Vec::new();
    let mut planes = Vec::new();
    for stack in 0..40 {
        let center = glam::Vec3::new(
            (stack % 5) as f32 * 17.3 - 31.0,
            (stack / 5 % 4) as f32 * 15.9 + 2.0,
            (stack / 20) as f32 * 18.1 - 3.0,
        );
        // Axis-aligned planes, as floors and walls are: a leaf's box then begins exactly at
        // the plane, where the rays' f32 distances scatter.
        let axes = [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z];
        let (normal, u, v) = (
            axes[stack % 3],
            axes[(stack + 1) % 3],
            axes[(stack + 2) % 3],
        );
        for _ in 0..12 {
            // Corners at angles less than half a turn apart hold the centre; stretched
            // along u they make slivers 16 times longer than wide.
            let mut angle = rng.range(0.0, std::f32::consts::TAU);
            let mut corner = || {
                angle += rng.range(1.8, 2.4);
                let r = rng.range(1.0, 8.0);
                center + u * (r * angle.cos() * 4.0) + v * (r * angle.sin() * 0.25)
            };
            tris.push(Triangle::new(corner(), corner(), corner()));
        }
        planes.push((center, normal, u, v));
    }
    let mut rays = Vec::new();
    for &(center, normal, u, v) in &planes {
        for _ in 0..150 {
            let target = center + (u * rng.range(-1.0, 1.0) + v * rng.range(-1.0, 1.0)) * 0.05;
            // From 10° to 45° above the plane, on either side: slanted rays, whose f32 t
            // errs most.
            let side = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
            let along = rng.range(0.0, std::f32::consts::TAU);
            let dir = (u * along.cos() + v * along.sin()) + normal * side * rng.range(0.17, 1.0);
            let origin = target + dir * rng.range(2.0, 30.0);
            rays.push(Ray::new(origin, target - origin));
        }
    }
    let brute = BruteForce::new(&tris, false);
    for kind in AccelKind::ALL {
        let s = build(&tris, kind, false);
        assert_matches_brute_force(&s, &brute, &rays, &format!("{} on stacks", kind.label()));
        let mut hits = vec![None; rays.len()];
        s.closest_hits::<Watertight>(&rays, &mut hits);
        for (i, (ray, got)) in rays.iter().zip(hits).enumerate() {
            let expected = brute.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert!(
                same_hit(got, expected),
                "{} packets on stacks: ray {i}: got {got:?}, brute force {expected:?}",
                kind.label()
            );
        }
    }
}

/// A build a newer request replaced answers `Abandoned`, for every structure; a builder
/// abandoned from the start still makes a valid tree (it stops searching for splits, it
/// does not unwind), holding every triangle once within the leaf size.
#[test]
fn an_abandoned_build_stops_and_says_so() {
    use bvhlab::accel::bvh::{BuildParams, Strategy};
    use bvhlab::accel::progress::BuildProgress;
    use std::sync::atomic::{AtomicU64, AtomicUsize};
    let tris = soup(3000, 21);
    let newest = AtomicU64::new(2);
    let placed = AtomicUsize::new(0);
    let abandoned = BuildProgress::counting(&placed).abandoned_after(&newest, 1);
    let wanted = BuildProgress::counting(&placed).abandoned_after(&newest, 2);
    for kind in AccelKind::ALL {
        let params = StructureParams::of_kind(kind);
        assert!(
            matches!(
                structure::build(&tris, &params, &abandoned),
                Err(structure::StructureError::Abandoned)
            ),
            "{kind:?}"
        );
        assert!(
            structure::build(&tris, &params, &wanted).is_ok(),
            "{kind:?}"
        );
    }
    for strategy in Strategy::ALL {
        let params = BuildParams::with_strategy(strategy);
        let (bvh, _) = bvhlab::accel::bvh::build_with_progress(&tris, &params, &abandoned)
            .unwrap_or_else(|e| panic!("{strategy:?}: {e}"));
        let mut seen = vec![0; tris.len()];
        for node in bvh.nodes.iter().filter(|n| n.is_leaf()) {
            assert!(
                node.prim_range().len() <= params.max_leaf_size as usize,
                "{strategy:?}"
            );
            for k in node.prim_range() {
                seen[bvh.prim_indices[k] as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&s| s >= 1), "{strategy:?}");
    }
    // The wide trees straight from the builders' splits: abandoned like the others, still
    // valid, and every triangle counted once when wanted (parts laid out in parallel too).
    for strategy in [Strategy::SahBinned, Strategy::Lbvh] {
        let mut params = StructureParams::of_kind(AccelKind::Bvh8);
        params.bvh.strategy = strategy;
        params.bvh.direct_wide = true;
        assert!(
            matches!(
                structure::build(&tris, &params, &abandoned),
                Err(structure::StructureError::Abandoned)
            ),
            "{strategy:?}, direct"
        );
        let (tree, _) = bvhlab::accel::bvh::Bvh8::direct(&tris, &params.bvh, &abandoned).unwrap();
        tree.validate().unwrap();
        for n in [3000, 70_000] {
            let counted = AtomicUsize::new(0);
            let progress = BuildProgress::counting(&counted);
            bvhlab::accel::bvh::Bvh8::direct(&soup(n, 3), &params.bvh, &progress).unwrap();
            assert_eq!(counted.into_inner(), n, "{strategy:?}, direct");
        }
    }
}
