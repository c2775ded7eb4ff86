//! The Embree peer's bindings against bvhlab (run with `cargo test --release --features
//! embree`, which needs libembree-dev): a wrong struct layout or constant in the FFI shows up
//! as hits that disagree. Embree breaks ties its own way and counts edge hits differently,
//! so agreement is asked for all but a small fraction of rays.
#![cfg(feature = "embree")]

mod common;

use bvhlab::accel::embree::Embree;
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
    for name in [
        "cornell",
        "teapot-in-stadium",
        "sphere:5000",
        "walls-rotated",
    ] {
        let scene = Scene::load(name).unwrap();
        let (bvh, _) =
            bvhlab::accel::bvh::build(&scene.triangles, &BuildParams::default()).expect("builds");
        let embree = Embree::build(&scene.triangles, 2).expect("Embree builds");
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
            "{name}: {disagree} of {} rays disagree",
            rays.len()
        );
        // Embree's packets answer as its single rays do (at the same distance: its two
        // kernels may break a tie at a shared edge differently).
        let packet_rays = view_rays(&scene);
        let mut hits = vec![None; packet_rays.len()];
        embree.closest_hits::<Watertight>(&packet_rays, &mut hits);
        for (ray, hit) in packet_rays.iter().zip(&hits) {
            let single = embree.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert_eq!(hit.map(|h| h.t), single.map(|h| h.t), "{name}: {ray:?}");
        }
    }
}
