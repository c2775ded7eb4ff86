//! The sparse octree against brute force: the same closest hits, bit for bit, with
//! mailboxing on and off, for several leaf sizes and depth bounds, on random soups, on every
//! built-in scene and on lattice scenes whose hits lie exactly on cell faces, edges and
//! corners; parameter errors; counting changes no hit; degenerate and very large inputs.

use bvhlab_testkit as common;

use bvhlab::accel::octree::{Octree, OctreeError, OctreeParams, build};
use bvhlab::accel::{Accel, BruteForce, NoStats};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::lattice::{PINS, contact_rays, contact_targets, lattice_rays, lattice_scene};
use common::{Rng, rays, same_hit, soup};
use glam::{Vec3, vec3};

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn params(max_leaf_size: u32, max_depth: u32) -> OctreeParams {
    OctreeParams {
        max_leaf_size,
        max_depth,
        mailbox: true,
    }
}

fn built(tris: &[Triangle], p: &OctreeParams) -> Octree {
    let (octree, report) = build(tris, p).expect("builds");
    assert_eq!(report.structure, "octree");
    assert_eq!(report.triangles, tris.len());
    assert!(report.max_depth <= p.max_depth);
    let outline = octree.outline();
    outline.validate().expect("valid outline");
    // Every triangle is in some leaf (an empty scene has none).
    assert_eq!(outline.triangles_under(0).len(), tris.len());
    octree
}

/// Closest and any hits of the octree equal brute force on `rays`, mailbox on and off.
fn check(tris: &[Triangle], p: &OctreeParams, rays: &[Ray], what: &str) {
    let brute = BruteForce::new(tris, false);
    let mut octree = built(tris, p);
    let expected: Vec<_> = rays
        .iter()
        .map(|r| brute.closest_hit::<Watertight, _>(r, &mut NoStats))
        .collect();
    for mailbox in [true, false] {
        octree.mailbox = mailbox;
        common::assert_mailboxed_hits(&octree, rays, &expected, mailbox, &format!("{what} {p:?}"));
    }
}

const SHAPES: [(u32, u32); 5] = [(8, 10), (1, 16), (4, 3), (32, 10), (8, 0)];

#[test]
fn matches_brute_force_on_random_soups() {
    for (seed, n) in [(1, 1), (2, 7), (3, 100), (4, 2000)] {
        let tris = soup(n, seed);
        let rays = rays(&bounds(&tris), 500, seed + 100);
        for (leaf, depth) in SHAPES {
            check(&tris, &params(leaf, depth), &rays, &format!("soup {n}"));
        }
    }
}

#[test]
fn matches_brute_force_on_every_builtin_scene() {
    for name in common::SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let mut rays = rays(&scene.bounds(), 300, 7);
        rays.extend(common::view_rays(&scene, 16, 12));
        for (leaf, depth) in [(8, 10), (2, 16)] {
            check(&scene.triangles, &params(leaf, depth), &rays, name);
        }
    }
}

#[test]
fn hits_exactly_on_cell_faces_edges_and_corners_match_brute_force() {
    for seed in 0..4 {
        let tris = lattice_scene(seed);
        let rays = lattice_rays(&tris, seed + 10);
        for (leaf, depth) in [(1, 3), (8, 10), (2, 16)] {
            check(
                &tris,
                &params(leaf, depth),
                &rays,
                &format!("lattice {seed}"),
            );
        }
    }
}

#[test]
fn only_hit_on_a_cell_face_edge_or_corner() {
    let pins = PINS;
    let rays = contact_rays();
    for target in contact_targets() {
        // Many small triangles near the target force splits down to cells meeting at the
        // target point, at (4, 4, 4) the root's centre.
        let mut tris = pins.to_vec();
        for k in 0..40 {
            let p = vec3(
                3.75 + (k % 4) as f32 * 0.125,
                3.5,
                3.5 + (k / 4) as f32 * 0.1,
            );
            tris.push(Triangle::new(p, p + Vec3::X * 0.05, p + Vec3::Z * 0.05));
        }
        tris.push(target);
        for (leaf, depth) in [(1, 3), (1, 10), (8, 10)] {
            check(
                &tris,
                &params(leaf, depth),
                &rays,
                &format!("target {target:?}"),
            );
        }
    }
}

#[test]
fn parameter_errors_are_clear() {
    let tris = soup(10, 1);
    let e = build(&tris, &params(0, 10)).expect_err("leaf size 0");
    assert_eq!(e, OctreeError::LeafSize(0));
    assert!(e.to_string().contains("1..=65536"), "{e}");
    let e = build(&tris, &params(8, 17)).expect_err("depth 17");
    assert_eq!(e, OctreeError::Depth(17));
    assert!(e.to_string().contains("16"), "{e}");
    let bad = [Triangle::new(
        Vec3::ZERO,
        Vec3::X,
        vec3(0., f32::INFINITY, 0.),
    )];
    assert_eq!(
        build(&bad, &OctreeParams::default()).expect_err("infinite vertex"),
        OctreeError::NonFinite(0)
    );
}

#[test]
fn mailboxing_removes_repeated_tests_and_changes_no_hit() {
    let tris = common::large_triangles(300, 5);
    let rays = rays(&bounds(&tris), 400, 6);
    let p = params(4, 6);
    let (mut octree, report) = build(&tris, &p).expect("builds");
    assert!(report.references_per_triangle() > 3.0, "{report:?}");
    common::mailbox_totals(&mut octree, |o, on| o.mailbox = on, &rays, "octree");
    check(&tris, &p, &rays, "large triangles");
}

#[test]
fn adapts_to_the_teapot_in_the_stadium_and_reports_caps() {
    let scene = Scene::load("teapot-in-stadium").expect("scene");
    let (_, report) = build(&scene.triangles, &OctreeParams::default()).expect("builds");
    assert!(report.max_depth >= 6, "{report:?}");
    assert!(report.empty_leaves > 0);
    // A depth bound of 2 leaves big leaves, and the report says so.
    let (_, report) = build(&scene.triangles, &params(8, 2)).expect("builds");
    assert!(
        report.caps_hit.iter().any(|c| c.contains("depth bound 2")),
        "{report:?}"
    );
    // Copies of one triangle cannot be separated: one leaf, reported.
    let copies = vec![scene.triangles[0]; 200];
    let (octree, report) = build(&copies, &OctreeParams::default()).expect("builds");
    assert_eq!(octree.outline().nodes.len(), 1, "{report:?}");
    assert!(
        report
            .caps_hit
            .iter()
            .any(|c| c.contains("every non-empty octant"))
    );
    // Triangles sharing one box, all crossing every cell: splitting stops once it only
    // copies them (or the reference budget runs out), and the report says so.
    let same = Scene::load("same-bbox:2000").expect("scene").triangles;
    let (_, report) = build(&same, &OctreeParams::default()).expect("builds");
    assert!(report.references <= 16 * 2000 + 4096, "{report:?}");
    assert!(!report.caps_hit.is_empty(), "{report:?}");
}

#[test]
fn degenerate_scenes_build_and_match_brute_force() {
    let empty: Vec<Triangle> = Vec::new();
    let (octree, report) = build(&empty, &OctreeParams::default()).expect("empty scene");
    assert_eq!(report.references, 0);
    let r = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(
        octree
            .closest_hit::<Watertight, _>(&r, &mut NoStats)
            .is_none()
    );
    assert!(!octree.any_hit::<Watertight, _>(&r, &mut NoStats));
    octree.outline().validate().expect("valid outline");

    let mut cases: Vec<(&str, Vec<Triangle>)> = vec![(
        "one triangle",
        vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)],
    )];
    let mut rng = Rng::new(9);
    let flat: Vec<Triangle> = (0..500)
        .map(|_| {
            let c = vec3(rng.f32(), rng.f32(), 0.5);
            Triangle::new(c, c + vec3(0.05, 0., 0.), c + vec3(0., 0.05, 0.))
        })
        .collect();
    cases.push(("flat", flat));
    let line: Vec<Triangle> = (0..200)
        .map(|i| {
            let x = i as f32 * 0.01;
            Triangle::new(
                vec3(x, 1., 2.),
                vec3(x + 0.02, 1., 2.),
                vec3(x + 0.01, 1., 2.),
            )
        })
        .collect();
    cases.push(("line", line));
    cases.push((
        "point",
        vec![Triangle::new(Vec3::ONE, Vec3::ONE, Vec3::ONE); 50],
    ));
    // All in one cell: 50 copies of one tiny triangle.
    let tiny = Triangle::new(Vec3::ZERO, vec3(1e-3, 0., 0.), vec3(0., 1e-3, 1e-3));
    cases.push(("one cell", vec![tiny; 50]));
    for spec in ["same-centroid:500", "same-bbox:500"] {
        cases.push((spec, Scene::load(spec).expect("scene").triangles));
    }
    for (what, tris) in &cases {
        let b = bounds(tris);
        let mut rays = rays(&b, 400, 11);
        let c = b.center();
        for d in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            vec3(1., 1., 0.),
            vec3(-1., 0., -0.),
        ] {
            rays.push(Ray::new(c - d * 3.0, d));
            rays.push(Ray::new(b.min - d * 3.0, d));
        }
        for (leaf, depth) in SHAPES {
            check(tris, &params(leaf, depth), &rays, what);
        }
    }
}

#[test]
fn ten_million_triangles_build_within_memory() {
    // 10^7 copies of one tiny triangle, each moved to its own point of a 216³ lattice: about
    // eight levels of cells with a few copies each; then the same copy 10^7 times in one
    // place, which no split separates: one leaf.
    let n = 10_000_000;
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let p = vec3(
                (i % 216) as f32,
                ((i / 216) % 216) as f32,
                (i / 46656) as f32,
            );
            Triangle::new(p, p + vec3(0.3, 0., 0.1), p + vec3(0., 0.3, 0.2))
        })
        .collect();
    let (octree, report) = build(&tris, &OctreeParams::default()).expect("builds");
    assert_eq!(report.triangles, n);
    assert!(report.references <= 2 * n, "{report:?}");
    assert!(octree.bytes() <= n * 80, "{} bytes", octree.bytes());
    let brute = BruteForce::new(&tris, true);
    for ray in rays(&bounds(&tris), 6, 12) {
        let a = octree.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        let b = brute.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        assert!(same_hit(a, b), "{ray:?}: {a:?} vs {b:?}");
    }
    drop((octree, brute));
    let same = vec![tris[0]; n];
    let (octree, report) = build(&same, &OctreeParams::default()).expect("builds");
    assert_eq!(report.references, n);
    assert!(octree.outline().nodes.len() <= 9);
}

#[test]
fn shared_meshes_agree_with_the_bvh() {
    let Some(dir) = common::shared_scenes() else {
        return;
    };
    for file in ["cornell-box.obj", "teapot.obj", "bunny.obj"] {
        let path = dir.join(file);
        if !path.exists() {
            continue;
        }
        let scene = Scene::load(path.to_str().expect("utf-8 path")).expect("loads");
        let tris = &scene.triangles;
        let (bvh, _) = bvhlab::accel::bvh::build(tris, &Default::default()).expect("bvh");
        let mut octree = built(tris, &OctreeParams::default());
        let mut rays = rays(&scene.bounds(), 3000, 21);
        rays.extend(common::view_rays(&scene, 32, 24));
        for mailbox in [true, false] {
            octree.mailbox = mailbox;
            for ray in &rays {
                let a = octree.closest_hit::<Watertight, _>(ray, &mut NoStats);
                let b = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert!(same_hit(a, b), "{file}: {ray:?}: octree {a:?}, bvh {b:?}");
                assert_eq!(
                    octree.any_hit::<Watertight, _>(ray, &mut NoStats),
                    b.is_some()
                );
            }
        }
    }
}
