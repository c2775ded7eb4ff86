//! The Embree peer's bindings against bvhlab (run with `cargo test --release --features
//! embree`, which needs libembree-dev): a wrong struct layout or constant in the FFI shows up
//! as hits that disagree. Embree breaks ties its own way and counts edge hits differently,
//! so agreement is asked for all but a small fraction of rays.
#![cfg(feature = "embree")]

use bvhlab_testkit as common;

use bvhlab::accel::embree::{Embree, EmbreeMode};
use bvhlab::accel::{Accel, BuildParams, NoStats};
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::Scene;

fn view_rays(scene: &Scene) -> Vec<Ray> {
    let cam = scene.camera().rays(64, 48);
    (0..48)
        .flat_map(|y| (0..64).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_center(x, y))
        .collect()
}

#[test]
fn embree_finds_the_hits_bvhlab_finds() {
    let names = [
        "cornell",
        "teapot-in-stadium",
        "sphere:5000",
        "walls-rotated",
    ];
    // Embree's defaults, its robust flag, and its low (Morton) and high (spatial splits)
    // quality builders (`RTCBuildQuality` 0 and 2).
    let peers = [
        (EmbreeMode::Default, 1),
        (EmbreeMode::Robust, 1),
        (EmbreeMode::Default, 0),
        (EmbreeMode::Default, 2),
    ];
    for (name, (mode, quality)) in names.into_iter().flat_map(|n| peers.map(|p| (n, p))) {
        let scene = Scene::load(name).unwrap();
        let (bvh, _) =
            bvhlab::accel::bvh::build(&scene.triangles, &BuildParams::default()).expect("builds");
        let embree = Embree::build_at(&scene.triangles, 2, mode, quality).expect("Embree builds");
        let mut rays = view_rays(&scene);
        rays.extend(common::rays(&scene.bounds(), 2000, 3));
        let mut disagree = 0;
        for ray in &rays {
            let ours = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
            let theirs = embree.closest_hit::<Watertight, _>(ray, &mut NoStats);
            let same = match (ours, theirs) {
                (None, None) => true,
                (Some(a), Some(b)) => (a.t - b.t).abs() <= 1e-4 * a.t.abs().max(1.0),
                _ => false,
            };
            disagree += usize::from(!same);
            let occluded = embree.any_hit::<Watertight, _>(ray, &mut NoStats);
            disagree += usize::from(occluded != theirs.is_some());
        }
        assert!(
            disagree * 200 <= rays.len(),
            "{name} ({mode:?}, quality {quality}): {disagree} of {} rays disagree",
            rays.len()
        );
        // Embree's packets answer as its single rays do (at the same distance: its two
        // kernels may break a tie at a shared edge differently).
        let packet_rays = view_rays(&scene);
        let mut hits = vec![None; packet_rays.len()];
        embree.closest_hits::<Watertight>(&packet_rays, &mut hits);
        for (ray, hit) in packet_rays.iter().zip(&hits) {
            let single = embree.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert_eq!(
                hit.map(|h| h.t),
                single.map(|h| h.t),
                "{name} ({mode:?}): {ray:?}"
            );
        }
    }
}

/// Embree's two levels name the same triangles of the flattened scene as bvhlab does: a
/// wrong transform layout or instance numbering in the bindings shows up as hits on other
/// triangles. Rotations, non-uniform scales, mirrors and an empty mesh.
#[test]
fn embree_instances_hit_the_triangles_of_the_flattened_scene() {
    use bvhlab::scene::instance::{Instance, Mesh};
    use glam::{Affine3A, Quat, Vec3};
    let mut scene = Scene::new("instanced");
    let mesh = |name: &str, triangles| Mesh {
        name: name.into(),
        triangles,
    };
    scene.meshes = vec![
        mesh("sphere", Scene::load("sphere:2000").unwrap().triangles),
        mesh("cornell", Scene::load("cornell").unwrap().triangles),
        mesh("nothing", Vec::new()),
    ];
    for k in 0..60 {
        let f = k as f32;
        let mut scale = Vec3::new(1.0 + (k % 3) as f32, 1.0, 0.5 + (k % 4) as f32 * 0.5);
        if k % 5 == 0 {
            scale.x = -scale.x;
        }
        let rotation = Quat::from_axis_angle(Vec3::new(f.sin(), 1.0, f.cos()).normalize(), f);
        let at = Vec3::new((k % 8) as f32 * 4.0, (k / 8) as f32 * 4.0, (k % 3) as f32);
        let transform = Affine3A::from_scale_rotation_translation(scale * 0.1, rotation, at);
        let instance = Instance::new(k % 3, transform).unwrap();
        scene.push_instance(format!("instance {k}"), Vec3::ONE, instance);
    }
    assert!(scene.triangles.len() > 40_000);
    let (bvh, _) =
        bvhlab::accel::bvh::build(&scene.triangles, &BuildParams::default()).expect("builds");
    let embree = Embree::build_instanced(&scene.instancing(), 2, EmbreeMode::Default)
        .expect("Embree builds");
    // Rays at triangles' centroids from around the scene (so most hit), and the usual mix.
    let b = scene.bounds();
    let mut rays: Vec<Ray> = (0..3000)
        .map(|i| {
            let f = i as f32;
            let target = scene.triangles[i * 7919 % scene.triangles.len()].centroid();
            let around = Vec3::new(f.sin(), (1.3 * f).cos(), (0.7 * f).sin()).normalize();
            let origin = b.center() + around * b.diagonal();
            Ray::new(origin, target - origin)
        })
        .collect();
    rays.extend(common::rays(&b, 1000, 7));
    let (mut hits, mut other_triangle, mut disagree) = (0, 0, 0);
    for ray in &rays {
        let ours = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let theirs = embree.closest_hit::<Watertight, _>(ray, &mut NoStats);
        match (ours, theirs) {
            (None, None) => {}
            (Some(a), Some(b)) if (a.t - b.t).abs() <= 1e-4 * a.t.abs().max(1.0) => {
                hits += 1;
                other_triangle += usize::from(a.triangle != b.triangle);
            }
            _ => disagree += 1,
        }
        let occluded = embree.any_hit::<Watertight, _>(ray, &mut NoStats);
        disagree += usize::from(occluded != theirs.is_some());
    }
    assert!(
        hits * 4 >= rays.len(),
        "only {hits} of {} rays hit",
        rays.len()
    );
    assert!(
        disagree * 200 <= rays.len() && other_triangle * 200 <= hits,
        "{disagree} of {} rays disagree, {other_triangle} of {hits} hits name another triangle",
        rays.len()
    );
}

/// `stress --embree`: on the must-hit rays through shared edges and vertices bvhlab's
/// watertight traversal loses none, Embree with its defaults loses some (its test is not
/// watertight), and Embree's robust flag loses fewer than its defaults.
#[test]
fn embree_leak_counts_order_the_three_tracers() {
    use bvhlab::bench::stress::peer;
    use bvhlab::bench::stress::suite::StressConfig;
    let cfg = StressConfig {
        leak_rays: 20_000,
        ..StressConfig::tests()
    };
    let report = peer::run(&cfg, &mut |_| {}).expect("Embree builds");
    let t = &report.total;
    assert!(t.rays > 500_000, "{} rays", t.rays);
    assert_eq!((t.bvhlab.closest, t.bvhlab.any), (0, 0));
    assert!(t.embree.closest > 0 && t.embree.any > 0, "{t:?}");
    assert!(t.embree_robust.closest < t.embree.closest, "{t:?}");
    let by_family: u64 = report.families.iter().map(|f| f.embree.closest).sum();
    assert_eq!(by_family, t.embree.closest);
    let by_placement: u64 = report.placements.iter().map(|p| p.rays).sum();
    assert_eq!(by_placement, t.rays);
}

/// Embree's scene committed again after its vertices were marked changed (the bench's
/// "rebuilt per frame") still finds bvhlab's hits, and takes a time; two levels are not
/// rebuilt this way.
#[test]
fn embree_rebuilt_in_its_memory_finds_the_same_hits() {
    let scene = Scene::load("sphere:5000").unwrap();
    let mut embree = Embree::build_at(&scene.triangles, 2, EmbreeMode::Default, 0).unwrap();
    let (bvh, _) = bvhlab::accel::bvh::build(&scene.triangles, &BuildParams::default()).unwrap();
    let rays = view_rays(&scene);
    let before: Vec<_> = rays
        .iter()
        .map(|r| {
            embree
                .closest_hit::<Watertight, _>(r, &mut NoStats)
                .map(|h| h.triangle)
        })
        .collect();
    for _ in 0..3 {
        assert!(embree.rebuild().unwrap().is_some());
    }
    let mut agree = 0;
    for (r, b) in rays.iter().zip(&before) {
        let got = embree
            .closest_hit::<Watertight, _>(r, &mut NoStats)
            .map(|h| h.triangle);
        assert_eq!(&got, b, "the rebuild changed a hit");
        agree += usize::from(
            got == bvh
                .closest_hit::<Watertight, _>(r, &mut NoStats)
                .map(|h| h.triangle),
        );
    }
    assert!(agree * 100 >= rays.len() * 99, "{agree} of {}", rays.len());
    let island = Scene::load("island:1").unwrap();
    let mut levels = Embree::build_instanced(&island.instancing(), 2, EmbreeMode::Default).unwrap();
    assert_eq!(levels.rebuild().unwrap(), None);
}
