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
    bench_json_with(accel, scene, &[])
}

fn bench_json_with(accel: &str, scene: &str, extra: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(["bench", "--scene", scene, "--accel", accel, "--json"])
        .args(extra)
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
    for accel in ["bvh", "bvh8", "kdtree", "octree"] {
        let v = bench_json(accel, "teapot-in-stadium");
        let c = &v["sah_check"];
        let predicted = c["predicted"].as_f64().expect("predicted");
        for key in ["random", "primary", "diffuse", "shadow"] {
            let measured = c[key].as_f64().expect(key);
            assert!(measured > 0.0, "{accel} {key}");
        }
        // EPO beside it. (The k-d cells do not overlap, but the stadium's walls lie in
        // split planes, held by the closed cells on both sides: their EPO is not 0. The
        // octree's midpoint planes hold none of them, and its cells list every triangle
        // they touch: 0.)
        let epo = c["epo"].as_f64().expect("epo");
        assert_eq!(epo > 0.0, accel != "octree", "{accel}: EPO {epo}");
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
    // Both levels placed: the SAH over the top level and each reference's placed BLAS
    // boxes, and their EPO; measured on the island's random lines within the SAH's usual
    // margin.
    let v = bench_json("two-level", "island:1");
    let c = &v["sah_check"];
    let predicted = c["predicted"].as_f64().expect("predicted");
    let random = c["random"].as_f64().expect("random");
    assert!(
        (random / predicted - 1.0).abs() < 0.5,
        "{random} against {predicted}"
    );
    assert!(c["epo"].as_f64().expect("epo") > 0.0);
    // The EPO estimated from end points instead: near the clipped one.
    let exact = bench_json("bvh", "teapot-in-stadium")["sah_check"]["epo"]
        .as_f64()
        .unwrap();
    let args = ["--epo", "estimate", "--end-points", "20000"];
    let estimated = bench_json_with("bvh", "teapot-in-stadium", &args)["sah_check"]["epo"]
        .as_f64()
        .unwrap();
    assert!(
        (estimated / exact - 1.0).abs() < 0.05,
        "{estimated} against {exact}"
    );
    for accel in ["grid", "brute-force"] {
        assert!(
            bench_json(accel, "cornell")["sah_check"].is_null(),
            "{accel}"
        );
    }
}

// EPO, the end-point overlap (Aila, Karras & Laine 2013): the second predictor.

use bvhlab::accel::epo::{area, clipped_area, epo};
use bvhlab::accel::structure::{self as structures, AccelKind, StructureParams};
use bvhlab::accel::{Outline, OutlineNode, Strategy};
use bvhlab::geometry::Triangle;

fn node(bounds: Aabb, parent: u32, children: (u32, u32), refs: (u32, u32)) -> OutlineNode {
    OutlineNode {
        bounds,
        depth: u32::from(parent != u32::MAX),
        parent,
        first_child: children.0,
        child_count: children.1,
        refs,
        plane: None,
    }
}

#[test]
fn epo_charges_a_leaf_for_the_area_of_other_triangles_in_its_box() {
    // Two right triangles of area 2 in z = 0: A at the origin, B shifted by 1 along x.
    // Leaf 1 holds A and has A's box [0,2]²; leaf 2 holds B. Half of B's area... precisely
    // B ∩ [0,2]² is B minus its part beyond x = 2 (a right triangle of area 0.5): 1.5.
    let a = Triangle::new(
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    );
    let b = Triangle::new(
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
    );
    let outline = Outline {
        nodes: vec![
            node(a.bounds().union(b.bounds()), u32::MAX, (1, 2), (0, 0)),
            node(a.bounds(), 0, (0, 0), (0, 1)),
            node(b.bounds(), 0, (0, 0), (1, 1)),
        ],
        refs: vec![0, 1],
    };
    // Leaf 2 ([1,3]×[0,2]) holds A's part beyond x = 1: a triangle of area 0.5.
    let (c_trav, c_isect) = (1.0, 3.0);
    let expected = c_isect as f64 * (1.5 + 0.5) / 4.0;
    let got = epo(&outline, &[a, b], c_trav, c_isect);
    assert!((got - expected).abs() < 1e-9, "{got} against {expected}");
    assert!((clipped_area(&b, &a.bounds()) - 1.5).abs() < 1e-12);
    // Moved apart, the boxes hold nothing of each other: no overlap, no EPO.
    let far = Triangle::new(
        b.v[0] + 5.0 * Vec3::X,
        b.v[1] + 5.0 * Vec3::X,
        b.v[2] + 5.0 * Vec3::X,
    );
    let mut apart = outline.clone();
    apart.nodes[2].bounds = far.bounds();
    apart.nodes[0].bounds = a.bounds().union(far.bounds());
    assert_eq!(epo(&apart, &[a, far], c_trav, c_isect), 0.0);
}

/// EPO by its definition: every node against every triangle not under it.
fn epo_by_definition(outline: &Outline, scene: &[Triangle], c_trav: f32, c_isect: f32) -> f64 {
    let total: f64 = scene.iter().map(area).sum();
    let mut sum = 0.0;
    for (n, node) in outline.nodes.iter().enumerate() {
        let under = outline.triangles_under(n);
        let cost = if node.is_leaf() {
            f64::from(c_isect) * f64::from(node.refs.1)
        } else {
            f64::from(c_trav)
        };
        for (t, tri) in scene.iter().enumerate() {
            if under.binary_search(&(t as u32)).is_err() {
                sum += cost * clipped_area(tri, &node.bounds);
            }
        }
    }
    sum / total
}

#[test]
fn epo_of_every_tree_equals_its_definition_node_by_node() {
    let scene = bvhlab_testkit::soup(300, 11);
    let mut whole = bvhlab::scene::Scene::new("soup");
    whole.push_object("soup", glam::Vec3::ONE, &scene);
    let mut params = StructureParams::of_kind(AccelKind::Bvh);
    let progress = Default::default();
    for strategy in Strategy::ALL {
        params.bvh.strategy = strategy;
        for kind in [
            AccelKind::Bvh,
            AccelKind::Bvh4,
            AccelKind::Bvh8,
            AccelKind::KdTree,
        ] {
            if kind == AccelKind::KdTree && strategy != Strategy::ALL[0] {
                continue;
            }
            params.kind = kind;
            let built = structures::build(&scene, &params, &progress).unwrap();
            let got = built.structure.epo(&params, &whole).unwrap();
            assert!(got.estimate.is_none());
            let got = got.value;
            let (c_trav, c_isect) = if kind == AccelKind::KdTree {
                (params.kdtree.c_trav, params.kdtree.c_isect)
            } else {
                (params.bvh.c_trav, params.bvh.c_isect)
            };
            let expected = epo_by_definition(&built.structure.outline(), &scene, c_trav, c_isect);
            let what = format!("{} {}", kind.label(), strategy.label());
            assert!(
                (got - expected).abs() <= 1e-9 * expected.max(1.0),
                "{what}: {got} against {expected}"
            );
            // A BVH over a soup overlaps; a k-d tree's cells do not, so only a triangle
            // in a split plane could count.
            if kind == AccelKind::KdTree {
                assert!(got < 1e-6, "{what}: {got}");
            } else {
                assert!(got > 0.0, "{what}");
            }
        }
    }
}
