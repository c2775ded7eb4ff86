//! The BVH against brute force: every builder and traversal order finds the same closest
//! hits on random soups and on every built-in scene; any hit agrees with closest hit; refit
//! equals rebuild; counting does not change hits; degenerate inputs build valid trees.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildError, BuildParams, Strategy, TraversalOrder, build};
use bvhlab::accel::{Accel, BruteForce, Bvh, Counters, NoStats};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, rays, same_hit, soup};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn all_params() -> Vec<BuildParams> {
    let mut out = Vec::new();
    for strategy in Strategy::ALL {
        for max_leaf_size in [1, 4, 16] {
            out.push(BuildParams {
                strategy,
                max_leaf_size,
                ..Default::default()
            });
        }
    }
    for buckets in [2, 3, 8, 32, 256] {
        out.push(BuildParams {
            buckets,
            ..Default::default()
        });
    }
    out.push(BuildParams {
        c_trav: 0.0,
        c_isect: 5.0,
        ..Default::default()
    });
    out.push(BuildParams {
        c_trav: 10.0,
        max_leaf_size: 64,
        ..Default::default()
    });
    out
}

fn built(tris: &[Triangle], p: &BuildParams, order: TraversalOrder) -> Bvh {
    let (mut bvh, report) = build(tris, p).expect("valid parameters");
    bvh.validate(p.max_leaf_size).expect("valid tree");
    assert_eq!(report.tree.nodes, bvh.nodes.len());
    bvh.order = order;
    bvh
}

/// Closest and any hits of `bvh` equal brute force on `rays`.
fn assert_matches_brute_force(bvh: &Bvh, brute: &BruteForce, rays: &[Ray], what: &str) {
    for (i, ray) in rays.iter().enumerate() {
        let expected = brute.closest_hit::<Watertight, _>(ray, &mut NoStats);
        let got = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert!(
            same_hit(got, expected),
            "{what}: ray {i} {ray:?}: bvh {got:?}, brute force {expected:?}"
        );
        let occluded = bvh.any_hit::<Watertight, _>(ray, &mut NoStats);
        assert_eq!(
            occluded,
            expected.is_some(),
            "{what}: any hit of ray {i} {ray:?}"
        );
    }
}

#[test]
fn every_builder_and_order_matches_brute_force_on_random_soups() {
    for (seed, n) in [(1, 1), (2, 7), (3, 100), (4, 2000)] {
        let tris = soup(n, seed);
        let brute = BruteForce::new(&tris, false);
        let rays = rays(&bounds(&tris), 600, seed + 100);
        for p in all_params() {
            for order in TraversalOrder::ALL {
                let bvh = built(&tris, &p, order);
                assert_matches_brute_force(
                    &bvh,
                    &brute,
                    &rays,
                    &format!("soup {n} {p:?} {order:?}"),
                );
            }
        }
    }
}

const SMALL_BUILTINS: &[&str] = &[
    "cornell",
    "teapot-in-stadium",
    "grass:3000",
    "walls",
    "walls-rotated",
    "same-centroid:1500",
    "same-bbox:1500",
    "soup:3000",
    "sphere:3000",
];

#[test]
fn every_builder_matches_brute_force_on_every_builtin_scene() {
    for name in SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 300, 7);
        // Rays through the scene's own view, as the renderer casts them.
        rays.extend(common::view_rays(&scene, 16, 12));
        for strategy in Strategy::ALL {
            for order in TraversalOrder::ALL {
                let p = BuildParams::with_strategy(strategy);
                let bvh = built(&scene.triangles, &p, order);
                assert_matches_brute_force(
                    &bvh,
                    &brute,
                    &rays,
                    &format!("{name} {strategy:?} {order:?}"),
                );
            }
        }
    }
}

#[test]
fn brute_force_early_out_changes_no_hit() {
    let tris = soup(300, 9);
    let rays = rays(&bounds(&tris), 500, 10);
    let plain = BruteForce::new(&tris, false);
    let early = BruteForce::new(&tris, true);
    let mut saved = 0;
    for ray in &rays {
        let (mut a, mut b) = (Counters::default(), Counters::default());
        assert_eq!(
            plain.closest_hit::<Watertight, _>(ray, &mut a),
            early.closest_hit::<Watertight, _>(ray, &mut b)
        );
        if b.triangle_tests == 0 {
            saved += 1;
        }
    }
    assert!(
        saved > 0,
        "some rays miss the scene box and skip every triangle"
    );
}

#[test]
fn any_hit_is_occlusion_within_tmax() {
    let scene = Scene::load("soup:2000").expect("soup");
    let bvh = built(
        &scene.triangles,
        &BuildParams::default(),
        TraversalOrder::FrontToBack,
    );
    let mut rng = Rng::new(5);
    for ray in rays(&scene.bounds(), 2000, 11) {
        let closest = bvh.closest_hit::<Watertight, _>(
            &Ray {
                tmax: f32::INFINITY,
                ..ray
            },
            &mut NoStats,
        );
        let tmax = rng.range(0.0, 2.0);
        let segment = Ray { tmax, ..ray };
        let occluded = bvh.any_hit::<Watertight, _>(&segment, &mut NoStats);
        if let Some(h) = closest {
            // Exactly at tmax is outside the open interval; avoid asserting on that tie.
            if (h.t - tmax).abs() > 1e-6 * tmax.max(1.0) {
                assert_eq!(occluded, h.t < tmax, "ray {segment:?}, closest t {}", h.t);
            }
        } else {
            assert!(!occluded);
        }
    }
}

#[test]
fn refit_then_trace_equals_rebuild_then_trace() {
    let mut rng = Rng::new(77);
    for strategy in Strategy::ALL {
        let mut tris = soup(1500, 21);
        let p = BuildParams::with_strategy(strategy);
        let mut bvh = built(&tris, &p, TraversalOrder::FrontToBack);
        for round in 0..3 {
            for _ in 0..200 {
                let i = rng.below(tris.len());
                let offset = rng.unit_vector() * rng.range(0.0, 0.5);
                for v in &mut tris[i].v {
                    *v += offset;
                }
            }
            let report = bvh
                .refit(&tris, p.c_trav, p.c_isect)
                .expect("same triangle count");
            assert!(report.sah_before.is_finite() && report.sah_after.is_finite());
            bvh.validate(p.max_leaf_size)
                .expect("refitted tree is valid");
            let fresh = built(&tris, &p, TraversalOrder::FrontToBack);
            let brute = BruteForce::new(&tris, false);
            for ray in rays(&bounds(&tris), 600, round) {
                let a = bvh.closest_hit::<Watertight, _>(&ray, &mut NoStats);
                let b = fresh.closest_hit::<Watertight, _>(&ray, &mut NoStats);
                assert!(
                    same_hit(a, b),
                    "{strategy:?} round {round}: refit {a:?} rebuild {b:?}"
                );
            }
            assert_matches_brute_force(&bvh, &brute, &rays(&bounds(&tris), 200, 99), "refit");
        }
    }
}

#[test]
fn refit_reports_growing_sah_cost_after_scattering_and_rejects_other_counts() {
    let mut tris = soup(1000, 3);
    let p = BuildParams::default();
    let (mut bvh, report) = build(&tris, &p).unwrap();
    let mut rng = Rng::new(1);
    for t in &mut tris {
        let offset = rng.unit_vector() * 3.0;
        for v in &mut t.v {
            *v += offset;
        }
    }
    let r = bvh.refit(&tris, p.c_trav, p.c_isect).unwrap();
    assert!((r.sah_before - report.tree.sah_cost).abs() < 1e-9);
    let rebuilt = build(&tris, &p).unwrap().1.tree.sah_cost;
    assert!(
        r.sah_after > 1.5 * rebuilt,
        "scattered refit {} vs rebuild {rebuilt}",
        r.sah_after
    );
    assert!(bvh.refit(&tris[..10], 1.0, 1.0).is_err());
}

#[test]
fn counting_and_zero_sized_sinks_give_identical_hits() {
    let scene = Scene::load("teapot-in-stadium").unwrap();
    for strategy in Strategy::ALL {
        for order in TraversalOrder::ALL {
            let bvh = built(
                &scene.triangles,
                &BuildParams::with_strategy(strategy),
                order,
            );
            for ray in rays(&scene.bounds(), 1000, 3) {
                let mut c = Counters::default();
                assert_eq!(
                    bvh.closest_hit::<Watertight, _>(&ray, &mut c),
                    bvh.closest_hit::<Watertight, _>(&ray, &mut NoStats)
                );
                assert_eq!(
                    bvh.any_hit::<Watertight, _>(&ray, &mut c),
                    bvh.any_hit::<Watertight, _>(&ray, &mut NoStats)
                );
                assert!(c.box_tests >= 1, "the root box is always tested");
            }
        }
    }
}

/// Total counters over the primary rays of a scene's default view.
fn view_counters(bvh: &Bvh, scene: &Scene) -> Counters {
    let cam = scene.camera().rays(96, 72);
    let mut total = Counters::default();
    for y in 0..72 {
        for x in 0..96 {
            let mut c = Counters::default();
            bvh.closest_hit::<Watertight, _>(&cam.pixel_center(x, y), &mut c);
            total += c;
        }
    }
    total
}

#[test]
fn sah_visits_fewer_nodes_than_median_on_teapot_in_stadium() {
    let scene = Scene::load("teapot-in-stadium").unwrap();
    let visits = |s| {
        let bvh = built(
            &scene.triangles,
            &BuildParams::with_strategy(s),
            TraversalOrder::FrontToBack,
        );
        view_counters(&bvh, &scene).nodes_visited
    };
    let (sah, sweep) = (visits(Strategy::SahBinned), visits(Strategy::SahSweep));
    for median in [Strategy::ObjectMedian, Strategy::SpatialMedian] {
        let m = visits(median);
        assert!(
            sah < m && sweep < m,
            "binned {sah}, sweep {sweep}, {median:?} {m}"
        );
    }
}

#[test]
fn front_to_back_tests_fewer_triangles_than_naive_order() {
    let scene = Scene::load("sphere:4000").unwrap();
    let mut bvh = built(
        &scene.triangles,
        &BuildParams::default(),
        TraversalOrder::FrontToBack,
    );
    let ordered = view_counters(&bvh, &scene);
    bvh.order = TraversalOrder::Naive;
    let naive = view_counters(&bvh, &scene);
    assert!(
        ordered.triangle_tests < naive.triangle_tests,
        "{ordered:?} vs {naive:?}"
    );
}

#[test]
fn sah_sweep_is_never_worse_than_binned_at_the_root_and_more_buckets_help() {
    let scene = Scene::load("soup:5000").unwrap();
    let cost = |p: BuildParams| build(&scene.triangles, &p).unwrap().1.tree.sah_cost;
    let sweep = cost(BuildParams::with_strategy(Strategy::SahSweep));
    let b2 = cost(BuildParams {
        buckets: 2,
        ..Default::default()
    });
    let b32 = cost(BuildParams {
        buckets: 32,
        ..Default::default()
    });
    let median = cost(BuildParams::with_strategy(Strategy::ObjectMedian));
    assert!(b32 < b2, "B=32 {b32} vs B=2 {b2}");
    assert!(sweep < median && b32 < median);
    assert!(sweep <= b32 * 1.05, "sweep {sweep} vs B=32 {b32}");
}

#[test]
fn degenerate_inputs_build_valid_trees_and_trace() {
    for (what, tris) in common::degenerate_cases() {
        let brute = BruteForce::new(&tris, false);
        let b = if tris.is_empty() {
            Aabb::new(Vec3::splat(-1.0), Vec3::ONE)
        } else {
            bounds(&tris)
        };
        let rays = rays(&b, 300, 1);
        for p in all_params() {
            for order in TraversalOrder::ALL {
                let bvh = built(&tris, &p, order);
                assert_matches_brute_force(&bvh, &brute, &rays, &format!("{what} {p:?}"));
            }
        }
    }
}

#[test]
fn same_centroid_and_same_bbox_scenes_respect_the_leaf_size() {
    for name in ["same-centroid:5000", "same-bbox:5000"] {
        let scene = Scene::load(name).unwrap();
        for strategy in Strategy::ALL {
            let p = BuildParams {
                strategy,
                max_leaf_size: 4,
                ..Default::default()
            };
            let bvh = built(&scene.triangles, &p, TraversalOrder::FrontToBack);
            assert!(
                bvh.nodes.len() > 1,
                "{name} {strategy:?}: split despite equal centroids"
            );
        }
    }
}

#[test]
fn bad_parameters_are_errors() {
    let tris = soup(10, 1);
    let bad = [
        (
            BuildParams {
                buckets: 1,
                ..Default::default()
            },
            BuildError::Buckets(1),
        ),
        (
            BuildParams {
                buckets: 257,
                ..Default::default()
            },
            BuildError::Buckets(257),
        ),
        (
            BuildParams {
                max_leaf_size: 0,
                ..Default::default()
            },
            BuildError::LeafSize(0),
        ),
        (
            BuildParams {
                c_trav: f32::NAN,
                ..Default::default()
            },
            BuildError::Cost {
                name: "C_trav",
                value: f32::NAN,
            },
        ),
    ];
    for (p, want) in bad {
        let err = build(&tris, &p).unwrap_err();
        assert_eq!(
            std::mem::discriminant(&err),
            std::mem::discriminant(&want),
            "{p:?}: {err}"
        );
    }
    let mut nan = tris.clone();
    nan[3].v[1].y = f32::NAN;
    assert_eq!(
        build(&nan, &BuildParams::default()).unwrap_err(),
        BuildError::NonFinite(3)
    );
}

#[test]
fn build_report_describes_the_tree() {
    let scene = Scene::load("soup:4000").unwrap();
    let p = BuildParams {
        max_leaf_size: 6,
        ..Default::default()
    };
    let (bvh, r) = build(&scene.triangles, &p).unwrap();
    let t = &r.tree;
    assert_eq!(t.nodes, 2 * t.leaves - 1);
    let in_leaves: usize = t
        .leaf_size_histogram
        .iter()
        .enumerate()
        .map(|(s, c)| s * c)
        .sum();
    assert_eq!(in_leaves, 4000);
    assert!(t.leaf_size_histogram.len() <= 7);
    assert!(
        t.max_leaf_depth as f64 >= t.mean_leaf_depth
            && t.mean_leaf_depth >= (t.leaves as f64).log2() - 1.0
    );
    assert!(t.sah_cost >= 1.0 && (t.sah_cost - bvh.sah_cost(1.0, 1.0)).abs() < 1e-9);
    assert!(t.bytes >= t.nodes * 32);
    assert!(r.rows().iter().any(|(k, _)| k == "SAH cost"));
}

#[test]
fn every_builder_matches_brute_force_on_the_shared_meshes() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared meshes");
        return;
    };
    for file in [
        "cornell-box.obj",
        "teapot.obj",
        "bunny.obj",
        "sponza.obj",
        "sibenik.obj",
        "conference.obj",
    ] {
        let scene = bvhlab::scene::load_obj(&dir.join(file)).expect("shared mesh loads");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 150, 42);
        rays.extend(common::view_rays(&scene, 8, 6));
        let expected: Vec<_> = rays
            .iter()
            .map(|r| brute.closest_hit::<Watertight, _>(r, &mut NoStats))
            .collect();
        for strategy in Strategy::ALL {
            let bvh = built(
                &scene.triangles,
                &BuildParams::with_strategy(strategy),
                TraversalOrder::FrontToBack,
            );
            for (ray, want) in rays.iter().zip(&expected) {
                let got = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert!(
                    same_hit(got, *want),
                    "{file} {strategy:?}: {ray:?}: {got:?} vs {want:?}"
                );
                assert_eq!(
                    bvh.any_hit::<Watertight, _>(ray, &mut NoStats),
                    want.is_some()
                );
            }
        }
    }
}

#[test]
fn build_progress_counts_every_triangle_once() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    for n in [0, 10, 5000, 60_000] {
        let tris = soup(n, 8);
        for strategy in Strategy::ALL {
            let progress = AtomicUsize::new(0);
            bvhlab::accel::bvh::build_with_progress(
                &tris,
                &BuildParams::with_strategy(strategy),
                &bvhlab::accel::progress::BuildProgress::counting(&progress),
            )
            .unwrap();
            assert_eq!(progress.load(Ordering::Relaxed), n, "{strategy:?}");
        }
    }
}

#[test]
fn refitting_only_the_moved_triangles_equals_a_full_refit() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    let mut rng = Rng::new(12);
    for strategy in Strategy::ALL {
        let mut tris = soup(3000, 31);
        let p = BuildParams::with_strategy(strategy);
        let (mut partial, _) = build(&tris, &p).unwrap();
        // An SBVH's clipped leaf boxes become its triangles' whole boxes at the first full
        // refit (a partial one changes only the moved leaves): both start from there. For
        // every other tree this refit changes nothing.
        partial.refit(&tris, 1.0, 1.0).unwrap();
        let mut full = partial.clone();
        let mut index = RefitIndex::new(&partial);
        for round in 0..5 {
            let moved: Vec<u32> = (0..1 + round * 40)
                .map(|_| rng.below(tris.len()) as u32)
                .collect();
            let offset = rng.unit_vector() * rng.range(0.0, 0.4);
            for &t in &moved {
                for v in &mut tris[t as usize].v {
                    *v += offset;
                }
            }
            let a = partial
                .refit_moved(&mut index, &tris, &moved, 1.0, 1.0)
                .unwrap();
            let b = full.refit(&tris, 1.0, 1.0).unwrap();
            assert_eq!(partial.nodes, full.nodes, "{strategy:?} round {round}");
            assert_eq!(partial.triangles, full.triangles);
            assert!((a.sah_after - b.sah_after).abs() < 1e-9);
            partial.validate(p.max_leaf_size).unwrap();
        }
    }
}

fn camera(eye: Vec3, look_at: Vec3, fov_y_deg: f32) -> bvhlab::scene::Camera {
    bvhlab::scene::Camera {
        fov_y_deg,
        ..bvhlab::scene::Camera::new(eye, look_at)
    }
}

/// Rays in 8 × 8 pixel packets of a `w` × `h` view from `eye` towards `look`, row by row
/// within each packet, as the renderer casts them.
fn view_packets(eye: Vec3, look: Vec3, w: u32, h: u32) -> Vec<Vec<Ray>> {
    let cam = camera(eye, look, 50.0).rays(w, h);
    let mut packets = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let packet = (y0..(y0 + 8).min(h))
                .flat_map(|y| (x0..(x0 + 8).min(w)).map(move |x| (x, y)))
                .map(|(x, y)| cam.pixel_center(x, y))
                .collect();
            packets.push(packet);
        }
    }
    packets
}

/// Packet traversal returns, bit for bit, each ray's own closest hit.
fn assert_packets_match_single_rays(bvh: &Bvh, packets: &[Vec<Ray>], what: &str) {
    for packet in packets {
        let mut hits = vec![None; packet.len()];
        bvh.closest_hits::<Watertight>(packet, &mut hits);
        for (ray, got) in packet.iter().zip(&hits) {
            let want = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert_eq!(*got, want, "{what}: {ray:?}");
        }
    }
}

#[test]
fn packets_find_exactly_the_hits_of_single_rays() {
    let mut rng = Rng::new(77);
    for name in SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let b = scene.bounds();
        let cam = scene.camera();
        // The scene's own view (not a multiple of 8 wide), views from inside the scene,
        // a view straight down an axis (zero direction components in the middle packets),
        // and incoherent packets of random rays.
        let mut packets = view_packets(cam.eye, cam.look_at, 37, 21);
        for _ in 0..3 {
            packets.extend(view_packets(rng.vec3_in(&b), rng.vec3_in(&b), 24, 16));
        }
        let c = b.center();
        packets.extend(view_packets(c - Vec3::Z * b.diagonal(), c, 17, 17));
        packets.extend(rays(&b, 640, 5).chunks(64).map(<[Ray]>::to_vec));
        for strategy in Strategy::ALL {
            for order in TraversalOrder::ALL {
                let p = BuildParams::with_strategy(strategy);
                let bvh = built(&scene.triangles, &p, order);
                assert_packets_match_single_rays(&bvh, &packets, &format!("{name} {strategy:?}"));
            }
        }
    }
}

#[test]
fn the_interval_test_culls_only_boxes_every_ray_misses() {
    use bvhlab::geometry::aabb::{SlabRay, slab_entry};
    use bvhlab::geometry::frustum::RayInterval;
    let mut rng = Rng::new(5);
    let (mut culled, mut kept) = (0, 0);
    let space = Aabb::new(Vec3::splat(-10.0), Vec3::splat(10.0));
    for _ in 0..2000 {
        let eye = rng.vec3_in(&space);
        let look = eye + rng.unit_vector();
        // Narrow and wide packets, with limits as traversal leaves them.
        let fov = rng.range(1.0, 60.0);
        let cam = camera(eye, look, fov).rays(8, 8);
        let mut packet: Vec<Ray> = (0..64).map(|k| cam.pixel_center(k % 8, k / 8)).collect();
        for r in &mut packet {
            r.tmax = if rng.f32() < 0.5 {
                f32::INFINITY
            } else {
                rng.range(0.0, 30.0)
            };
        }
        let Some(interval) = RayInterval::new(&packet) else {
            continue;
        };
        let tmax = packet.iter().map(|r| r.tmax).fold(0.0, f32::max);
        // Random boxes, and boxes near the packet's view where they are often entered.
        let (mut a, mut b) = (rng.vec3_in(&space), rng.vec3_in(&space));
        if rng.f32() < 0.5 {
            let centre = eye + (look - eye) * rng.range(0.0, 20.0);
            let half = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * rng.range(0.0, 3.0);
            (a, b) = (centre - half, centre + half);
        }
        let mut corners = [a.min(b), a.max(b)];
        if rng.f32() < 0.2 {
            corners[1] = corners[0]; // a point-sized box
        }
        let any_enters = packet
            .iter()
            .any(|r| slab_entry(&corners, &SlabRay::new(r), r.tmin, r.tmax) != f32::INFINITY);
        if interval.misses(&corners, tmax) {
            assert!(
                !any_enters,
                "culled a box a ray enters: {corners:?} {eye:?} {look:?}"
            );
            culled += 1;
        } else {
            kept += 1;
        }
    }
    assert!(culled > 100 && kept > 100, "culled {culled}, kept {kept}");
}

#[test]
fn a_frame_traced_without_counting_has_the_hits_of_a_counted_frame() {
    use bvhlab::render::{RenderSettings, trace};
    for name in [
        "cornell",
        "teapot-in-stadium",
        "walls-rotated",
        "sphere:3000",
    ] {
        let scene = Scene::load(name).unwrap();
        let (bvh, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
        let counted = RenderSettings::for_scene(&scene, 83, 45);
        let quick = RenderSettings {
            counters: false,
            ..counted
        };
        let (a, b) = (trace(&bvh, &scene, &counted), trace(&bvh, &scene, &quick));
        assert!(
            a.summary.primary_hits > 0,
            "{name}: the view sees the scene"
        );
        for (x, y) in a.samples.iter().zip(&b.samples) {
            assert_eq!(
                (x.t.to_bits(), x.triangle),
                (y.t.to_bits(), y.triangle),
                "{name}"
            );
            assert_eq!(
                (x.lit, x.normal, x.albedo),
                (y.lit, y.normal, y.albedo),
                "{name}"
            );
        }
        assert!(b.samples.iter().all(|s| s.primary.nodes_visited == 0));
    }
}

/// The build report names its phases: binned SAH's splits near the root (binning and
/// partition) on a tree large enough to have them (and not on one without), and the wide
/// trees' collapse phases.
#[test]
fn the_report_gives_the_build_phases_and_threads() {
    use bvhlab::accel::structure::{self, AccelKind, StructureParams};
    let tris = soup(80_000, 5);
    let (_, report) = build(&tris, &BuildParams::default()).unwrap();
    let phases: Vec<&str> = report
        .phases
        .times
        .iter()
        .map(|(p, _)| p.as_str())
        .collect();
    assert_eq!(
        phases,
        [
            "references",
            "binning near the root",
            "partition near the root",
            "splits (whole recursion)",
            "leaf order"
        ]
    );
    // The root alone has 80,000 primitives: its binning took some time.
    assert!(report.phases.times[1].1 > std::time::Duration::ZERO);
    let rows = report.rows();
    let threads = rows.iter().find(|(k, _)| k == "threads").unwrap();
    assert_eq!(threads.1, rayon::current_num_threads().to_string());
    let params = StructureParams {
        kind: AccelKind::Bvh8,
        ..StructureParams::default()
    };
    let built = structure::build(&tris, &params, &Default::default()).unwrap();
    for key in [
        "threads",
        "time: binning near the root",
        "time: collapse table",
        "time: collapse layout",
    ] {
        assert!(
            built.report.details.iter().any(|(k, _)| k == key),
            "{key} in {:?}",
            built.report.details
        );
    }
    // A tree with no node of 32 768 primitives has no splits near the root to time, and
    // its report shows no such phase (rather than 0.00 ms).
    let (_, small) = build(&soup(20_000, 5), &BuildParams::default()).unwrap();
    let names: Vec<&str> = small.phases.times.iter().map(|(p, _)| p.as_str()).collect();
    assert_eq!(
        names,
        ["references", "splits (whole recursion)", "leaf order"]
    );
}
