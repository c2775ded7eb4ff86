//! Run time against error: the intersectors behind one run-time choice, and the accuracy
//! matrix behind `bvhlab bench accuracy` (every builder with every intersector), checked
//! on a small scene. Timings are produced but never asserted.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildParams, Strategy, build};
use bvhlab::accel::{Accel, BruteForce, NoStats};
use bvhlab::bench::accuracy::{self, AccuracyConfig, CSV_HEADER};
use bvhlab::bench::plot::{self, pareto_front};
use bvhlab::bench::{self, BenchConfig};
use bvhlab::geometry::{Intersector, IntersectorKind, MollerTrumbore, ReferenceF64, Watertight};
use bvhlab::scene::Scene;
use bvhlab::with_intersector;

#[test]
fn intersector_kinds_dispatch_to_their_intersector() {
    for kind in IntersectorKind::ALL {
        assert_eq!(IntersectorKind::from_label(kind.label()), Some(kind));
        let name = with_intersector!(kind, I => <I as Intersector>::NAME);
        assert_eq!(name, kind.label());
    }
    assert_eq!(IntersectorKind::default(), IntersectorKind::Watertight);
    assert_eq!(IntersectorKind::from_label("nope"), None);
}

#[test]
fn every_intersector_agrees_with_brute_force_through_the_bvh() {
    let tris = common::soup(3000, 21);
    let b = common::rays(
        &bvhlab::geometry::Aabb::from_points(tris.iter().flat_map(|t| t.v)),
        20_000,
        22,
    );
    let (bvh, _) = build(&tris, &BuildParams::default()).unwrap();
    let brute = BruteForce::new(&tris, false);
    for kind in IntersectorKind::ALL {
        with_intersector!(kind, I => {
            for r in &b {
                let x = bvh.closest_hit::<I, _>(r, &mut NoStats);
                let y = brute.closest_hit::<I, _>(r, &mut NoStats);
                assert!(common::same_hit(x, y), "{}: {r:?}: {x:?} vs {y:?}", kind.label());
                assert_eq!(bvh.any_hit::<I, _>(r, &mut NoStats), y.is_some(), "{}", kind.label());
            }
        });
    }
}

#[test]
fn the_f64_reference_matches_exact_hits_of_simple_cases() {
    use bvhlab::geometry::{Ray, Triangle};
    use glam::Vec3;
    let tri = Triangle::new(
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::new(4.0, 0.0, 5.0),
        Vec3::new(0.0, 4.0, 5.0),
    );
    let ray = Ray::new(Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 2.0));
    let hit = ReferenceF64::intersect(&ReferenceF64::prepare(&ray), &ray, &tri, 0.0, f32::INFINITY)
        .unwrap();
    assert_eq!((hit.t, hit.u, hit.v), (2.5, 0.25, 0.25));
    for (name, h) in [
        (
            "watertight",
            Watertight::intersect(&Watertight::prepare(&ray), &ray, &tri, 0.0, f32::INFINITY),
        ),
        (
            "moller-trumbore",
            MollerTrumbore::intersect(&(), &ray, &tri, 0.0, f32::INFINITY),
        ),
    ] {
        let h = h.unwrap();
        assert_eq!((h.t, h.u, h.v), (2.5, 0.25, 0.25), "{name}");
    }
    // A hit behind the origin or beyond tmax is no hit.
    assert!(ReferenceF64::intersect(&ReferenceF64::prepare(&ray), &ray, &tri, 0.0, 2.5).is_none());
    let back = Ray::new(Vec3::new(1.0, 1.0, 10.0), Vec3::new(0.0, 0.0, 1.0));
    assert!(
        ReferenceF64::intersect(
            &ReferenceF64::prepare(&back),
            &back,
            &tri,
            0.0,
            f32::INFINITY
        )
        .is_none()
    );
}

#[test]
fn bench_traces_with_the_chosen_intersector() {
    let scene = Scene::load("sphere:2000").unwrap();
    let mut hits = Vec::new();
    for kind in IntersectorKind::ALL {
        let cfg = BenchConfig {
            camera: scene.camera(),
            light: scene.light(),
            width: 64,
            height: 48,
            params: Default::default(),
            builds: 1,
            runs: 1,
            intersector: kind,
            embree: false,
            embree_robust: false,
            embree_quality: Default::default(),
            tinybvh: false,
            epo: Default::default(),
        };
        let r = bench::run(&scene, &cfg).unwrap();
        assert_eq!(r.intersector, kind);
        assert_eq!(r.json().intersector, kind.label());
        hits.push((r.primary.hits, r.shadow.hits));
    }
    // The exact tests agree on every hit and occlusion of the standard sets here.
    assert_eq!(hits[0], hits[2]);
}

#[test]
fn accuracy_matrix_covers_every_builder_and_intersector() {
    let scene = Scene::load("sphere:3000").unwrap();
    let cfg = AccuracyConfig {
        camera: scene.camera(),
        light: scene.light(),
        width: 96,
        height: 72,
        builds: 1,
        runs: 1,
        random_rays: 20_000,
        crossing_rays: 20_000,
        seed: 3,
    };
    let rows = accuracy::run(&scene, &cfg, &mut |_| {}).unwrap();
    assert_eq!(rows.len(), 14 * 3);
    let builders = accuracy::builders();
    assert_eq!(builders.len(), 14);
    let buckets: Vec<u32> = builders
        .iter()
        .filter(|b| b.params.strategy == Strategy::SahBinned)
        .map(|b| b.params.buckets)
        .collect();
    assert_eq!(buckets, [2, 4, 8, 16, 32, 64]);
    for r in &rows {
        assert!(r.build_ms >= 0.0 && r.sah_cost > 0.0);
        assert!(r.sets.iter().all(|s| s.rays > 0));
        assert!(r.crossings.rays >= 20_000, "{:?}", r.crossings);
        if r.intersector != IntersectorKind::MollerTrumbore {
            assert_eq!(
                r.crossings.leaks(),
                0,
                "{} {}",
                r.builder.label,
                r.intersector.label()
            );
            assert_eq!(
                r.agreement.mismatches,
                0,
                "{} {}",
                r.builder.label,
                r.intersector.label()
            );
        }
        if r.builder.params.strategy == Strategy::SahSweep {
            assert_eq!(r.sah_vs_sweep, 1.0);
        }
        if r.builder.params.strategy == Strategy::LbvhTreelet {
            assert!(r.sah_vs_sweep < 1.1, "LBVH + treelets: {}", r.sah_vs_sweep);
        }
        // The SAH builders are within a few percent of the full sweep; B = 2 is coarser.
        if r.builder.params.strategy == Strategy::SahBinned && r.builder.params.buckets >= 16 {
            assert!(
                r.sah_vs_sweep < 1.1,
                "{}: {}",
                r.builder.label,
                r.sah_vs_sweep
            );
        }
    }
    // Möller–Trumbore loses some of the rays through shared edges and vertices.
    let mt_leaks: u64 = rows
        .iter()
        .filter(|r| r.intersector == IntersectorKind::MollerTrumbore)
        .map(|r| r.crossings.leaks())
        .sum();
    assert!(mt_leaks > 0);
    let csv = accuracy::csv(&rows);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), 1 + 14 * 3);
    let columns = CSV_HEADER.split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == columns));
    let png = plot::render_png(&accuracy::pareto_plot(&rows)).unwrap();
    assert_eq!((png.width(), png.height()), (1100, 620));
}

#[test]
fn pareto_front_keeps_the_points_nothing_beats() {
    let points = [(1.0, 10.0), (2.0, 0.0), (3.0, 5.0), (0.5, 20.0), (2.5, 0.0)];
    assert_eq!(pareto_front(&points), vec![3, 0, 1]);
}
