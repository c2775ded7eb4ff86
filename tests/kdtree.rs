//! The SAH k-d tree against brute force: closest and any hits agree exactly with every
//! split search, with mailboxing on and off, on random soups, every built-in scene, a grid
//! whose triangles lie in and end on the split planes, and degenerate inputs; counting does
//! not change hits; mailboxing removes repeated tests; bad parameters are errors.

use bvhlab_testkit as common;

use bvhlab::accel::kdtree::{KdError, KdParams, KdSplit, KdTree, build};
use bvhlab::accel::{Accel, BruteForce, NoStats, StructureReport};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, rays, same_hit, soup};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

/// Split searches, leaf sizes, costs and caps worth testing; each with mailboxing on.
fn all_params() -> Vec<KdParams> {
    let mut out = Vec::new();
    for split in [
        KdSplit::Sweep,
        KdSplit::Binned(2),
        KdSplit::Binned(16),
        KdSplit::Binned(64),
    ] {
        for max_leaf_size in [1, 4] {
            out.push(KdParams {
                split,
                max_leaf_size,
                ..Default::default()
            });
        }
    }
    out.push(KdParams {
        c_isect: 80.0,
        max_leaf_size: 1,
        ..Default::default()
    });
    out.push(KdParams {
        empty_bonus: 0.0,
        c_trav: 0.0,
        ..Default::default()
    });
    out.push(KdParams {
        max_depth: 3,
        ..Default::default()
    });
    out.push(KdParams {
        max_references_factor: 1.0,
        c_isect: 80.0,
        ..Default::default()
    });
    out
}

fn built(tris: &[Triangle], p: &KdParams) -> (KdTree, StructureReport) {
    let (kd, report) = build(tris, p).expect("valid parameters");
    check_shape(&kd, &report, tris.len());
    (kd, report)
}

/// The report and the outline describe the tree: counts agree, every leaf's references
/// are valid triangles, children are contiguous, planes are flat boxes inside their cell.
fn check_shape(kd: &KdTree, report: &StructureReport, n: usize) {
    assert_eq!(report.structure, "kdtree");
    assert_eq!(report.triangles, n);
    assert_eq!(report.nodes, kd.nodes.len());
    assert_eq!(report.references, kd.references());
    assert_eq!(report.bytes, kd.bytes());
    let outline = kd.outline();
    outline.validate().expect("valid outline");
    assert_eq!(outline.nodes.len(), kd.nodes.len());
    assert_eq!(outline.refs.len(), report.references);
    assert_eq!(outline.max_depth(), report.max_depth);
    assert!(report.max_depth <= 64);
    let leaves: Vec<_> = outline.nodes.iter().filter(|o| o.is_leaf()).collect();
    assert_eq!(leaves.len(), report.leaves);
    assert_eq!(
        leaves.iter().filter(|o| o.refs.1 == 0).count(),
        report.empty_leaves
    );
    assert!(outline.refs.iter().all(|&t| (t as usize) < n));
    if n > 0 {
        // Every triangle is in some leaf.
        assert_eq!(outline.triangles_under(0).len(), n);
    }
    for o in &outline.nodes {
        assert!(kd.bounds.contains(&o.bounds) || n == 0);
        match (o.is_leaf(), o.plane) {
            (true, None) => {}
            (false, Some(p)) => {
                assert!(o.bounds.contains(&p));
                assert!((0..3).any(|k| p.min[k] == p.max[k]), "plane is flat");
                let children = o.children();
                let below = &outline.nodes[children.start].bounds;
                let above = &outline.nodes[children.start + 1].bounds;
                assert_eq!(below.union(*above), o.bounds);
            }
            _ => panic!("a node has a plane iff it is interior"),
        }
    }
}

/// Closest and any hits of `kd` (mailbox on and off) equal brute force on `rays`.
fn assert_matches_brute_force(kd: &mut KdTree, brute: &BruteForce, rays: &[Ray], what: &str) {
    let expected: Vec<_> = rays
        .iter()
        .map(|r| brute.closest_hit::<Watertight, _>(r, &mut NoStats))
        .collect();
    for mailbox in [true, false] {
        kd.mailbox = mailbox;
        common::assert_mailboxed_hits(kd, rays, &expected, mailbox, what);
    }
}

#[test]
fn kdtree_matches_brute_force_on_random_soups() {
    for (seed, n) in [(1, 1), (2, 7), (3, 100), (4, 2000)] {
        let tris = soup(n, seed);
        let brute = BruteForce::new(&tris, false);
        let rays = rays(&bounds(&tris), 500, seed + 100);
        for p in all_params() {
            let (mut kd, _) = built(&tris, &p);
            assert_matches_brute_force(&mut kd, &brute, &rays, &format!("soup {n} {p:?}"));
        }
    }
}

#[test]
fn kdtree_matches_brute_force_on_every_builtin_scene() {
    for name in common::SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 300, 7);
        rays.extend(common::view_rays(&scene, 16, 12));
        for split in [KdSplit::Sweep, KdSplit::Binned(32)] {
            let p = KdParams {
                split,
                ..Default::default()
            };
            let (mut kd, _) = built(&scene.triangles, &p);
            assert_matches_brute_force(&mut kd, &brute, &rays, &format!("{name} {split:?}"));
        }
    }
}

/// Unit squares (two triangles each) on the integer grid in the planes x = i, y = j and
/// z = k: every triangle lies in or ends on a plane the SAH is likely to split at.
fn integer_grid(size: i32) -> Vec<Triangle> {
    let mut tris = Vec::new();
    let square = |o: Vec3, u: Vec3, v: Vec3, out: &mut Vec<Triangle>| {
        out.push(Triangle::new(o, o + u, o + u + v));
        out.push(Triangle::new(o, o + u + v, o + v));
    };
    for i in 0..size {
        for j in 0..size {
            let (a, b) = (i as f32, j as f32);
            // A floor, a wall and a slab of squares, each offset to make cells uneven.
            square(Vec3::new(a, b, 0.0), Vec3::X, Vec3::Y, &mut tris);
            if (i + j) % 3 == 0 {
                square(Vec3::new(a, 0.0, b), Vec3::Y, Vec3::Z, &mut tris);
                square(Vec3::new(0.0, a, b), Vec3::Z, Vec3::X, &mut tris);
            }
            if (i * j) % 5 == 1 {
                square(Vec3::new(a, b, 2.0), Vec3::X, Vec3::Y, &mut tris);
            }
        }
    }
    tris
}

/// Rays aimed at integer points (vertices and edges of the grid, where hits lie exactly on
/// split planes), rays lying in the planes x = i, y = j, z = k, and axis-parallel rays with
/// signed zero components through grid lines.
fn grid_rays(size: i32, rng: &mut Rng) -> Vec<Ray> {
    let mut out = Vec::new();
    let s = size as f32;
    for _ in 0..1500 {
        let target = Vec3::new(
            rng.below(size as usize + 1) as f32,
            rng.below(size as usize + 1) as f32,
            rng.below(3) as f32,
        );
        let target = match rng.below(3) {
            0 => target,
            1 => target + Vec3::X * 0.5,
            _ => target + Vec3::new(0.0, 0.25, 0.0),
        };
        let origin = Vec3::new(
            rng.range(-s, 2.0 * s),
            rng.range(-s, 2.0 * s),
            rng.range(-3.0, 6.0),
        );
        out.push(Ray::new(origin, target - origin));
        // The same point from within a plane x = i: the ray lies in it.
        let mut o2 = origin;
        o2.x = target.x;
        if o2 != target {
            out.push(Ray::new(o2, target - o2));
        }
        let mut o3 = origin;
        o3.z = target.z;
        if o3 != target {
            out.push(Ray::new(o3, target - o3));
        }
        // Axis-parallel along a grid line, with ±0 in the other components.
        let axis = rng.below(3);
        let mut d = Vec3::new(
            if rng.f32() < 0.5 { 0.0 } else { -0.0 },
            if rng.f32() < 0.5 { 0.0 } else { -0.0 },
            if rng.f32() < 0.5 { 0.0 } else { -0.0 },
        );
        d[axis] = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
        let mut o4 = target;
        o4[axis] = if d[axis] > 0.0 { -5.0 } else { s + 5.0 };
        out.push(Ray::new(o4, d));
        // Starting exactly on a grid plane, going either way.
        out.push(Ray::new(target, rng.unit_vector()));
    }
    out
}

#[test]
fn hits_on_split_planes_and_rays_in_them_are_found() {
    let size = 12;
    let tris = integer_grid(size);
    let brute = BruteForce::new(&tris, false);
    let mut rng = Rng::new(17);
    let rays = grid_rays(size, &mut rng);
    for p in all_params() {
        let (mut kd, _) = built(&tris, &p);
        if p.split == KdSplit::Sweep {
            // The test is only as good as its planes: the tree splits where triangles lie.
            let planes: Vec<_> = kd.outline().nodes.iter().filter_map(|o| o.plane).collect();
            let on_grid = planes
                .iter()
                .filter(|b| (0..3).any(|k| b.min[k] == b.max[k] && b.min[k].fract() == 0.0))
                .count();
            assert!(
                on_grid > 0 && 2 * on_grid >= planes.len(),
                "{p:?}: {on_grid} of {} planes on the grid",
                planes.len()
            );
        }
        assert_matches_brute_force(&mut kd, &brute, &rays, &format!("grid {p:?}"));
    }
}

#[test]
fn any_hit_agrees_with_closest_hit_on_segments() {
    let tris = soup(1500, 21);
    let b = bounds(&tris);
    let mut rng = Rng::new(22);
    for p in [
        KdParams::default(),
        KdParams {
            split: KdSplit::Binned(16),
            ..Default::default()
        },
    ] {
        let (kd, _) = built(&tris, &p);
        for _ in 0..3000 {
            let o = rng.vec3_in(&b);
            let d = rng.unit_vector();
            let tmin = rng.range(0.0, 0.3);
            let tmax = tmin + rng.range(0.0, 0.6);
            let ray = Ray::segment(o, d, tmin, tmax);
            let closest = kd.closest_hit::<Watertight, _>(&ray, &mut NoStats);
            assert_eq!(
                kd.any_hit::<Watertight, _>(&ray, &mut NoStats),
                closest.is_some(),
                "{ray:?}"
            );
            if let Some(h) = closest {
                assert!(h.t > tmin && h.t < tmax);
            }
        }
    }
}

/// Long thin triangles across the whole scene among small ones: many cells reference them.
fn straddling_scene() -> Vec<Triangle> {
    let mut tris = soup(2000, 31);
    let mut rng = Rng::new(32);
    for _ in 0..60 {
        let a = Vec3::new(0.0, rng.f32(), rng.f32());
        let b = Vec3::new(1.0, rng.f32(), rng.f32());
        tris.push(Triangle::new(a, b, b + Vec3::new(0.0, 0.01, 0.01)));
    }
    tris
}

#[test]
fn counting_changes_no_hit_and_mailboxing_removes_repeated_tests() {
    let tris = straddling_scene();
    let rays = rays(&bounds(&tris), 2000, 33);
    for split in [KdSplit::Sweep, KdSplit::Binned(32)] {
        let (mut kd, report) = built(
            &tris,
            &KdParams {
                split,
                ..Default::default()
            },
        );
        assert!(
            report.references > tris.len(),
            "triangles are referenced twice"
        );
        common::mailbox_totals(
            &mut kd,
            |k, on| k.mailbox = on,
            &rays,
            &format!("{split:?}"),
        );
    }
}

/// The shared degenerate inputs, and the scenes whose triangles share one centroid or one
/// bounding box.
fn degenerate_cases() -> Vec<(&'static str, Vec<Triangle>)> {
    let mut cases = common::degenerate_cases();
    cases.push((
        "same centroid",
        Scene::load("same-centroid:800").expect("scene").triangles,
    ));
    cases.push((
        "same bbox",
        Scene::load("same-bbox:800").expect("scene").triangles,
    ));
    cases
}

#[test]
fn degenerate_inputs_build_and_trace() {
    for (what, tris) in degenerate_cases() {
        let brute = BruteForce::new(&tris, false);
        let b = if tris.is_empty() {
            Aabb::new(Vec3::splat(-1.0), Vec3::ONE)
        } else {
            bounds(&tris)
        };
        let rays = rays(&b, 300, 1);
        for p in all_params() {
            let (mut kd, _) = built(&tris, &p);
            assert_matches_brute_force(&mut kd, &brute, &rays, &format!("{what} {p:?}"));
        }
    }
}

#[test]
fn caps_are_reported_when_they_stop_a_split() {
    let tris = straddling_scene();
    let (_, report) = built(
        &tris,
        &KdParams {
            max_depth: 2,
            ..Default::default()
        },
    );
    assert!(report.max_depth <= 2);
    assert!(
        report.caps_hit.iter().any(|c| c.contains("depth")),
        "{:?}",
        report.caps_hit
    );
    let (_, report) = built(
        &tris,
        &KdParams {
            max_references_factor: 1.0,
            c_isect: 80.0,
            ..Default::default()
        },
    );
    assert!(report.references <= tris.len());
    assert!(
        report.caps_hit.iter().any(|c| c.contains("reference")),
        "{:?}",
        report.caps_hit
    );
}

#[test]
fn ten_million_identical_triangles_build_and_trace() {
    // Cheap in time but not in count: the recursion and the memory must cope.
    let t = Triangle::new(
        Vec3::ZERO,
        Vec3::new(1e-3, 0.0, 0.0),
        Vec3::new(0.0, 1e-3, 0.0),
    );
    let tris = vec![t; 10_000_000];
    let (mut kd, report) = build(&tris, &KdParams::default()).expect("builds");
    assert_eq!(report.references, tris.len());
    kd.mailbox = false;
    let hit = kd.closest_hit::<Watertight, _>(
        &Ray::new(Vec3::new(1e-4, 1e-4, 1.0), -Vec3::Z),
        &mut NoStats,
    );
    assert_eq!(hit.map(|h| (h.triangle, h.t)), Some((0, 1.0)));
    let miss = Ray::new(Vec3::new(1.0, 1.0, 1.0), -Vec3::Z);
    assert!(!kd.any_hit::<Watertight, _>(&miss, &mut NoStats));
}

#[test]
fn bad_parameters_are_errors() {
    let tris = soup(10, 1);
    let d = KdParams::default();
    let bad = [
        (
            KdParams {
                c_trav: f32::NAN,
                ..d
            },
            KdError::Cost {
                name: "C_trav",
                value: f32::NAN,
            },
        ),
        (
            KdParams { c_isect: 0.0, ..d },
            KdError::Cost {
                name: "C_isect",
                value: 0.0,
            },
        ),
        (
            KdParams {
                empty_bonus: 1.0,
                ..d
            },
            KdError::EmptyBonus(1.0),
        ),
        (
            KdParams {
                empty_bonus: -0.1,
                ..d
            },
            KdError::EmptyBonus(-0.1),
        ),
        (KdParams { max_depth: 65, ..d }, KdError::Depth(65)),
        (
            KdParams {
                max_leaf_size: 0,
                ..d
            },
            KdError::LeafSize(0),
        ),
        (
            KdParams {
                split: KdSplit::Binned(1),
                ..d
            },
            KdError::Bins(1),
        ),
        (
            KdParams {
                split: KdSplit::Binned(100_000),
                ..d
            },
            KdError::Bins(100_000),
        ),
        (
            KdParams {
                max_references_factor: 0.5,
                ..d
            },
            KdError::ReferencesFactor(0.5),
        ),
        (
            KdParams {
                max_references_factor: f32::INFINITY,
                ..d
            },
            KdError::ReferencesFactor(f32::INFINITY),
        ),
    ];
    for (p, expected) in bad {
        let err = build(&tris, &p).expect_err("rejected");
        // NaN != NaN: compare the message for the NaN case.
        assert_eq!(err.to_string(), expected.to_string());
        assert!(!err.to_string().is_empty());
    }
    let mut nan = tris.clone();
    nan[3].v[1].y = f32::NAN;
    assert_eq!(build(&nan, &d).err(), Some(KdError::NonFinite(3)));
}

#[test]
fn real_meshes_match_the_bvh_when_the_shared_scenes_are_present() {
    use bvhlab::accel::bvh::{BuildParams, build as build_bvh};
    let Some(dir) = common::shared_scenes() else {
        return;
    };
    for (file, n_rays) in [
        ("cornell-box.obj", 3000),
        ("teapot.obj", 3000),
        ("sponza.obj", 3000),
    ] {
        let scene = Scene::load(&dir.join(file).to_string_lossy()).expect("scene loads");
        let (bvh, _) = build_bvh(&scene.triangles, &BuildParams::default()).expect("bvh");
        let mut rays = rays(&scene.bounds(), n_rays, 41);
        rays.extend(common::view_rays(&scene, 40, 30));
        for split in [KdSplit::Sweep, KdSplit::Binned(32)] {
            let (mut kd, _) = built(
                &scene.triangles,
                &KdParams {
                    split,
                    ..Default::default()
                },
            );
            for mailbox in [true, false] {
                kd.mailbox = mailbox;
                for ray in &rays {
                    let expected = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
                    let got = kd.closest_hit::<Watertight, _>(ray, &mut NoStats);
                    assert!(
                        same_hit(got, expected),
                        "{file} {split:?}: {ray:?}: {got:?} vs {expected:?}"
                    );
                    assert_eq!(
                        kd.any_hit::<Watertight, _>(ray, &mut NoStats),
                        expected.is_some()
                    );
                }
            }
        }
    }
}
