//! SAH predicted against measured: the random lines the SAH assumes, and the check's place
//! in `bvhlab bench`.

use bvhlab::accel::sah_check::random_lines;
use bvhlab::geometry::Aabb;
use bvhlab::geometry::aabb::SlabRay;
use glam::Vec3;
use std::process::Command;

/// The share of `rays` that pass through `b`.
fn share_through(rays: &[bvhlab::geometry::Ray], b: &Aabb) -> f64 {
    let hits = rays
        .iter()
        .filter(|r| {
            b.slab_test(&SlabRay::new(r), 0.0, f32::INFINITY)
                .is_finite()
        })
        .count();
    hits as f64 / rays.len() as f64
}

#[test]
fn random_lines_hit_a_box_inside_with_the_chance_of_its_area_ratio() {
    // Cauchy: for uniformly random lines through a convex body, the chance of also crossing
    // a convex body inside it is the ratio of their surface areas.
    let outer = Aabb::new(Vec3::new(-1.0, -2.0, 0.0), Vec3::new(3.0, 2.0, 1.0));
    let rays = random_lines(&outer, 1 << 16, 7);
    for r in &rays {
        assert!(
            outer.contains_point(r.origin),
            "{r:?} starts outside the box"
        );
        assert!((r.direction.length() - 1.0).abs() < 1e-4);
    }
    for inner in [
        Aabb::new(Vec3::new(0.0, -1.0, 0.2), Vec3::new(1.0, 0.0, 0.8)),
        Aabb::new(Vec3::new(-1.0, -2.0, 0.0), Vec3::new(0.0, 2.0, 1.0)),
        Aabb::new(Vec3::new(2.0, 1.0, 0.0), Vec3::new(2.5, 1.5, 0.1)),
    ] {
        let expected = (inner.surface_area() / outer.surface_area()) as f64;
        let got = share_through(&rays, &inner);
        assert!(
            (got - expected).abs() < 0.01,
            "{inner:?}: {got} against {expected}"
        );
    }
    // A flat box gets lines too (its two large faces), and the same seed the same lines.
    let flat = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
    assert!(
        random_lines(&flat, 100, 3)
            .iter()
            .all(|r| r.direction.z != 0.0)
    );
    assert_eq!(random_lines(&outer, 10, 7), random_lines(&outer, 10, 7));
}

fn bench_json(accel: &str, scene: &str) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(["bench", "--scene", scene, "--accel", accel, "--json"])
        .args([
            "--width", "64", "--height", "48", "--builds", "1", "--runs", "1",
        ])
        .output()
        .expect("run bvhlab");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON")
}

#[test]
fn bench_reports_the_sah_check_for_trees_only() {
    for accel in ["bvh", "bvh8", "kdtree"] {
        let v = bench_json(accel, "teapot-in-stadium");
        let c = &v["sah_check"];
        let predicted = c["predicted"].as_f64().expect("predicted");
        for key in ["random", "primary", "diffuse", "shadow"] {
            let measured = c[key].as_f64().expect(key);
            assert!(measured > 0.0, "{accel} {key}");
        }
        // On the teapot in a stadium few lines stop early: random lines come close.
        let random = c["random"].as_f64().unwrap();
        assert!(
            (random / predicted - 1.0).abs() < 0.5,
            "{accel}: {random} against {predicted}"
        );
        if accel == "bvh" {
            assert_eq!(
                v["sah_cost"].as_f64(),
                Some((predicted * 1000.0).round() / 1000.0)
            );
        }
    }
    for accel in ["grid", "octree", "brute-force"] {
        assert!(
            bench_json(accel, "cornell")["sah_check"].is_null(),
            "{accel}"
        );
    }
}
