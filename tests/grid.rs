//! The uniform grid against brute force: the same closest hits, bit for bit, with mailboxing
//! on and off, for every λ, on random soups, on every built-in scene and on lattice scenes
//! whose hits lie exactly on cell faces, edges and corners; errors for bad parameters;
//! counting changes no hit; degenerate and very large inputs.

use bvhlab_testkit as common;

use bvhlab::accel::grid::{GridError, GridParams, MAX_CELLS, build};
use bvhlab::accel::{Accel, BruteForce, NoStats};
use bvhlab::geometry::overlap::triangle_box_overlap;
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::lattice::{PINS, contact_rays, contact_targets, lattice_rays, lattice_scene};
use common::{Rng, rays, same_hit, soup};
use glam::{Vec3, vec3};

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn params(lambda: f32, mailbox: bool) -> GridParams {
    GridParams { lambda, mailbox }
}

/// Closest and any hits of the grid over `tris` equal brute force on `rays`, with the
/// mailbox on and off.
fn check(tris: &[Triangle], lambda: f32, rays: &[Ray], what: &str) {
    let brute = BruteForce::new(tris, false);
    let (mut grid, report) = build(tris, &params(lambda, true)).expect("builds");
    assert_eq!(report.structure, "grid");
    assert_eq!(report.triangles, tris.len());
    grid.outline().validate().expect("valid outline");
    let expected: Vec<_> = rays
        .iter()
        .map(|r| brute.closest_hit::<Watertight, _>(r, &mut NoStats))
        .collect();
    for mailbox in [true, false] {
        grid.mailbox = mailbox;
        common::assert_mailboxed_hits(
            &grid,
            rays,
            &expected,
            mailbox,
            &format!("{what} λ={lambda}"),
        );
    }
}

#[test]
fn matches_brute_force_on_random_soups_for_every_lambda() {
    for (seed, n) in [(1, 1), (2, 7), (3, 100), (4, 2000)] {
        let tris = soup(n, seed);
        let rays = rays(&bounds(&tris), 500, seed + 100);
        for lambda in [1.0 / 16.0, 1.0, 8.0, 64.0] {
            check(&tris, lambda, &rays, &format!("soup {n}"));
        }
    }
}

#[test]
fn matches_brute_force_on_every_builtin_scene() {
    for name in common::SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let mut rays = rays(&scene.bounds(), 300, 7);
        rays.extend(common::view_rays(&scene, 16, 12));
        for lambda in [1.0, 4.0] {
            check(&scene.triangles, lambda, &rays, name);
        }
    }
}

#[test]
fn hits_exactly_on_cell_faces_edges_and_corners_match_brute_force() {
    for seed in 0..4 {
        let tris = lattice_scene(seed);
        let (grid, _) = build(&tris, &GridParams::default()).expect("builds");
        assert_eq!(grid.resolution(), [8, 8, 8]);
        let rays = lattice_rays(&tris, seed + 10);
        check(&tris, 1.0, &rays, &format!("lattice {seed}"));
    }
}

#[test]
fn only_hit_on_a_cell_face_edge_or_corner() {
    // Two pinning triangles far off the rays' paths, and one target whose only contact with
    // the ray is a point on a face (x = 4), an edge (x = y = 4) or a corner (4, 4, 4).
    let pins = PINS;
    let rays = contact_rays();
    for target in contact_targets() {
        let mut tris = pins.to_vec();
        // Fill up to 512 triangles with copies of the pins so the grid is 8 × 8 × 8.
        while tris.len() < 511 {
            tris.push(pins[tris.len() % 2]);
        }
        tris.push(target);
        let (grid, _) = build(&tris, &GridParams::default()).expect("builds");
        assert_eq!(grid.resolution(), [8, 8, 8]);
        let brute = BruteForce::new(&tris, false);
        let hits = rays
            .iter()
            .filter(|r| {
                brute
                    .closest_hit::<Watertight, _>(r, &mut NoStats)
                    .is_some()
            })
            .count();
        assert!(hits > rays.len() / 3, "{hits} of {} rays hit", rays.len());
        check(&tris, 1.0, &rays, &format!("target {target:?}"));
    }
}

#[test]
fn lambda_out_of_range_and_too_many_cells_are_clear_errors() {
    let tris = soup(100, 3);
    for lambda in [0.0, 1.0 / 32.0, 64.5, -1.0, f32::NAN, f32::INFINITY] {
        let err = build(&tris, &params(lambda, true)).expect_err("λ out of range");
        assert!(matches!(err, GridError::Lambda(_)), "{err}");
        assert!(err.to_string().contains("1/16..=64"), "{err}");
    }
    // 64 cells per triangle over 2^21 tiny triangles: 2^27 cells.
    let n = 1 << 21;
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let p = vec3(
                (i % 128) as f32,
                ((i / 128) % 128) as f32,
                (i / 16384) as f32,
            );
            Triangle::new(p, p + Vec3::X * 0.01, p + Vec3::Y * 0.01)
        })
        .collect();
    let err = build(&tris, &params(64.0, true)).expect_err("too many cells");
    match &err {
        GridError::TooManyCells { cells, .. } => assert!(*cells > MAX_CELLS as u64),
        e => panic!("{e}"),
    }
    assert!(err.to_string().contains(&MAX_CELLS.to_string()), "{err}");
    let bad = [Triangle::new(Vec3::ZERO, Vec3::X, vec3(f32::NAN, 0., 0.))];
    assert_eq!(
        build(&bad, &GridParams::default()).expect_err("NaN"),
        GridError::NonFinite(0)
    );
}

#[test]
fn mailboxing_removes_repeated_tests_and_changes_no_hit() {
    let tris = common::large_triangles(300, 5);
    let rays = rays(&bounds(&tris), 400, 6);
    let (mut grid, report) = build(&tris, &params(8.0, true)).expect("builds");
    assert!(report.references_per_triangle() > 10.0, "{report:?}");
    common::mailbox_totals(&mut grid, |g, on| g.mailbox = on, &rays, "grid");
    check(&tris, 8.0, &rays, "large triangles");
}

#[test]
fn degenerate_scenes_build_and_match_brute_force() {
    let empty: Vec<Triangle> = Vec::new();
    let (grid, report) = build(&empty, &GridParams::default()).expect("empty scene builds");
    assert_eq!(report.references, 0);
    let r = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(
        grid.closest_hit::<Watertight, _>(&r, &mut NoStats)
            .is_none()
    );
    assert!(!grid.any_hit::<Watertight, _>(&r, &mut NoStats));
    assert!(grid.cells_along(&r).is_empty());
    grid.outline().validate().expect("valid outline");

    let one = vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)];
    let mut cases: Vec<(&str, Vec<Triangle>)> = vec![("one triangle", one)];
    // Every triangle in one cell (λ = 1/16 over 8 triangles: one cell).
    cases.push(("one cell", soup(8, 3)));
    // Flat scenes: zero extent on z, and on y and z (all on a line).
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
    let point = vec![Triangle::new(Vec3::ONE, Vec3::ONE, Vec3::ONE); 10];
    cases.push(("point", point));
    for spec in ["same-centroid:500", "same-bbox:500"] {
        cases.push((spec, Scene::load(spec).expect("scene").triangles));
    }
    for (what, tris) in &cases {
        let b = bounds(tris);
        let mut rays = rays(&b, 400, 11);
        // Rays in the flat scenes' planes and along their axes.
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
        for lambda in [1.0 / 16.0, 1.0, 64.0] {
            check(tris, lambda, &rays, what);
        }
    }
    let (grid, _) = build(&cases[1].1, &params(1.0 / 16.0, true)).expect("builds");
    assert_eq!(grid.resolution(), [1, 1, 1]);
    let (grid, _) = build(&cases[2].1, &params(1.0, true)).expect("builds");
    assert_eq!(grid.resolution()[2], 1, "flat axis gets one cell");
}

#[test]
fn resolution_follows_lambda_with_cubical_cells() {
    // A 4 × 2 × 1 box: cells ≈ λN, per-axis counts in ratio 4 : 2 : 1.
    let mut tris = vec![
        Triangle::new(Vec3::ZERO, vec3(0.1, 0., 0.), vec3(0., 0.1, 0.)),
        Triangle::new(vec3(4., 2., 1.), vec3(3.9, 2., 1.), vec3(4., 1.9, 1.)),
    ];
    tris.resize(1000, tris[1]);
    let (grid, report) = build(&tris, &params(8.0, true)).expect("builds");
    // 8000 cells over a volume of 8: side³ = 8 / 8000, side = 0.1, so 40 × 20 × 10.
    assert_eq!(grid.resolution(), [40, 20, 10]);
    assert_eq!(report.nodes, 8000);
    assert_eq!(
        report
            .detail("resolution")
            .map(|v| v.to_string())
            .as_deref(),
        Some("40 × 20 × 10")
    );
}

#[test]
fn cells_list_exactly_the_triangles_that_overlap_them() {
    // Every cell lists each triangle overlapping it (touching included), in increasing
    // order, and no triangle farther from it than the padding; large triangles, thin ones
    // and axis-aligned ones, over grids with several cells on every axis.
    let mut tris = soup(300, 9);
    tris.extend(lattice_scene(2));
    tris.push(Triangle::new(
        vec3(-1., -1., -1.),
        vec3(9., 0., 3.),
        vec3(2., 8., 7.),
    ));
    let b = bounds(&tris);
    let near = b.extent().max_element() * 1e-4;
    for lambda in [1.0, 8.0] {
        let (grid, _) = build(&tris, &params(lambda, true)).expect("builds");
        let [nx, ny, nz] = grid.resolution();
        assert!(nx > 2 && ny > 2 && nz > 2, "{:?}", grid.resolution());
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let c = (x + nx * (y + ny * z)) as usize;
                    let listed = grid.cell_triangles(c);
                    assert!(listed.windows(2).all(|w| w[0] < w[1]), "cell {c} order");
                    let cell = grid.cell_bounds([x, y, z]);
                    let wide = Aabb::new(cell.min - near, cell.max + near);
                    for (t, tri) in tris.iter().enumerate() {
                        let t = t as u32;
                        if triangle_box_overlap(tri, &cell) {
                            assert!(listed.contains(&t), "λ {lambda}: cell {c} lacks {t}");
                        } else if listed.contains(&t) {
                            assert!(triangle_box_overlap(tri, &wide), "λ {lambda}: {t} in {c}");
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn cells_along_a_ray_follow_the_dda() {
    let tris = lattice_scene(1);
    let (grid, _) = build(&tris, &GridParams::default()).expect("builds");
    // Along x through the middle of cells (y, z) = (2, 5): eight cells in order.
    let cells = grid.cells_along(&Ray::new(vec3(-1., 2.5, 5.5), Vec3::X));
    assert_eq!(cells.len(), 8);
    for (i, c) in cells.iter().enumerate() {
        assert_eq!(c.min, vec3(i as f32, 2., 5.));
        assert_eq!(c.max, vec3(i as f32 + 1., 3., 6.));
    }
    // A segment ending inside cell 3.
    let seg = Ray::segment(vec3(-1., 2.5, 5.5), Vec3::X, 0.0, 4.5);
    assert_eq!(grid.cells_along(&seg).len(), 4);
    // A diagonal through cell corners visits connected cells only.
    let cells = grid.cells_along(&Ray::new(vec3(-1., -1., -1.), Vec3::ONE));
    assert!(cells.len() >= 8);
    for w in cells.windows(2) {
        let shared = (w[0].min - w[1].min).abs().max_element();
        assert!(shared <= 1.0, "{w:?}");
    }
}

#[test]
fn ten_million_triangles_build_within_memory() {
    // 10^7 copies of one tiny triangle, each moved to its own point of a 216³ lattice: the
    // grid has about 10^7 cells and each copy lands in one, so the build does no overlap
    // tests and stores one id per triangle (about 40 bytes each with the offsets and ids,
    // next to the 36 of the triangle itself).
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
    let (grid, report) = build(&tris, &GridParams::default()).expect("builds");
    assert_eq!(report.triangles, n);
    assert!(report.references <= 2 * n, "{report:?}");
    assert!(
        grid.bytes() <= n * (36 + 4 * 2 + 4 * 2) + 4096,
        "{} bytes",
        grid.bytes()
    );
    let brute = BruteForce::new(&tris, true);
    for ray in rays(&bounds(&tris), 6, 12) {
        let a = grid.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        let b = brute.closest_hit::<Watertight, _>(&ray, &mut NoStats);
        assert!(same_hit(a, b), "{ray:?}: {a:?} vs {b:?}");
    }
    drop((grid, brute));
    // The same tiny triangle 10^7 times in one place: each copy would fill thousands of
    // cells; the build stops with an error instead of running out of memory.
    let same = vec![tris[0]; n];
    let err = build(&same, &GridParams::default()).expect_err("too many references");
    assert!(matches!(err, GridError::TooManyReferences { .. }), "{err}");
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
        let (bvh, _) = bvhlab::accel::bvh::build(tris, &Default::default()).expect("bvh builds");
        let (mut grid, _) = build(tris, &GridParams::default()).expect("grid builds");
        let mut rays = rays(&scene.bounds(), 3000, 21);
        rays.extend(common::view_rays(&scene, 32, 24));
        for mailbox in [true, false] {
            grid.mailbox = mailbox;
            for ray in &rays {
                let a = grid.closest_hit::<Watertight, _>(ray, &mut NoStats);
                let b = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert!(same_hit(a, b), "{file}: {ray:?}: grid {a:?}, bvh {b:?}");
                assert_eq!(
                    grid.any_hit::<Watertight, _>(ray, &mut NoStats),
                    b.is_some()
                );
            }
        }
    }
}
