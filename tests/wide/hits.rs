//! Hits of the wide trees against the BVH2: collapsed and direct builds, any hit of
//! segments, leaves larger than a lane, degenerate inputs, packets.

use super::*;
use bvhlab::accel::bvh::packet::tile_pixels;

#[test]
fn wide_trees_equal_the_bvh2_on_random_soups() {
    for seed in 0..3 {
        let tris = soup(2000, seed);
        let rays = rays(&bounds(&tris), 2000, seed + 20);
        for strategy in Strategy::ALL {
            let b2 = bvh2(&tris, strategy);
            let what = format!("soup {seed} {}", strategy.label());
            assert_wide_equals_bvh2::<4>(&b2, &rays, &what);
            assert_wide_equals_bvh2::<8>(&b2, &rays, &what);
        }
    }
}

#[test]
fn wide_trees_equal_the_bvh2_on_every_builtin_scene() {
    for name in SMALL_BUILTINS {
        let scene = Scene::load(name).unwrap();
        let mut rays = view_rays(&scene, 48, 36);
        rays.extend(common::rays(&scene.bounds(), 1000, 7));
        let b2 = bvh2(&scene.triangles, Strategy::SahBinned);
        assert_wide_equals_bvh2::<4>(&b2, &rays, name);
        assert_wide_equals_bvh2::<8>(&b2, &rays, name);
    }
}

/// The wide trees made straight from the Morton order and from binned SAH's splits
/// (`--direct-wide`) give the BVH2's hits on random soups, every small built-in scene and
/// the degenerate inputs, and are the same tree on 1 and 2 threads where their parts are
/// laid out in parallel.
#[test]
fn wide_trees_built_directly_equal_the_bvh2() {
    let mut cases: Vec<(String, Vec<Triangle>, Vec<Ray>)> = Vec::new();
    for seed in 0..2 {
        let tris = soup(3000, seed);
        let rays = rays(&bounds(&tris), 1500, seed + 30);
        cases.push((format!("soup {seed}"), tris, rays));
    }
    for name in SMALL_BUILTINS {
        let scene = Scene::load(name).unwrap();
        let mut rays = view_rays(&scene, 32, 24);
        rays.extend(common::rays(&scene.bounds(), 500, 7));
        cases.push((name.to_string(), scene.triangles, rays));
    }
    for (what, tris) in degenerate_cases() {
        let box_ = if tris.is_empty() {
            Aabb::new(Vec3::splat(-1.0), Vec3::ONE)
        } else {
            bounds(&tris)
        };
        cases.push((what.to_string(), tris, common::rays(&box_, 300, 3)));
    }
    let none = BuildProgress::default();
    for (what, tris, rays) in &cases {
        let b2 = bvh2(tris, Strategy::SahBinned);
        for leaf_size in [1, 4] {
            let what = format!("{what}, direct, leaves of {leaf_size}");
            let (w4, _) = WideBvh::<4>::morton(tris, leaf_size).expect("direct BVH4");
            assert_tree_equals_bvh2(w4, &b2, rays, &what);
            let (w8, _) = WideBvh::<8>::morton(tris, leaf_size).expect("direct BVH8");
            assert_tree_equals_bvh2(w8, &b2, rays, &what);
            let p = BuildParams {
                max_leaf_size: leaf_size,
                ..BuildParams::default()
            };
            let what = format!("{what}, from binned SAH");
            let (w4, _) = WideBvh::<4>::binned_sah(tris, &p, &none).expect("direct BVH4");
            assert_tree_equals_bvh2(w4, &b2, rays, &what);
            let (w8, _) = WideBvh::<8>::binned_sah(tris, &p, &none).expect("direct BVH8");
            assert_tree_equals_bvh2(w8, &b2, rays, &what);
        }
    }
    // Large enough for parts laid out in parallel.
    let tris = soup(70_000, 5);
    let p = BuildParams::default();
    let on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        pool.install(|| {
            let morton = WideBvh::<8>::morton(&tris, 4).unwrap().0;
            let sah = WideBvh::<8>::binned_sah(&tris, &p, &none).unwrap().0;
            (fingerprint(&morton), fingerprint(&sah))
        })
    };
    assert_eq!(on(1), on(2));
    let rays = rays(&bounds(&tris), 1000, 9);
    let b2 = bvh2(&tris, Strategy::Lbvh);
    let (w8, _) = WideBvh::<8>::morton(&tris, 4).unwrap();
    assert_tree_equals_bvh2(w8, &b2, &rays, "soup of 70 000");
    let (w8, _) = WideBvh::<8>::binned_sah(&tris, &p, &none).unwrap();
    assert_tree_equals_bvh2(w8, &b2, &rays, "soup of 70 000, from binned SAH");
}

/// Any hit of segments that end before, at and past each ray's closest hit, in a tree that
/// has both leaves in one block of four (tested by the straight one-block path, inlined in
/// the any-hit walk) and leaves over more blocks (the loop over blocks).
fn assert_segments_agree<const W: usize>(b2: &Bvh, rays: &[Ray], what: &str)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    // Steps that cost more than triangle tests make larger leaves.
    let params = CollapseParams {
        c_trav: 8.0,
        ..CollapseParams::default()
    };
    let mut wide = WideBvh::<W>::collapse(b2, &params);
    let leaves = wide.nodes.iter().flat_map(|n| {
        (0..n.child_count())
            .filter(|&l| !n.is_interior(l))
            .map(|l| (n.child[l].index() as usize, n.leaf_count(l) as usize))
    });
    let (one, more): (Vec<_>, Vec<_>) =
        leaves.partition(|&(first, count)| first % BLOCK + count <= BLOCK);
    assert!(
        !one.is_empty() && !more.is_empty(),
        "{what}: BVH{W} needs both kinds of leaves"
    );
    let mut segments = 0;
    for level in SimdLevel::available() {
        wide.set_simd(level).unwrap();
        for ray in rays {
            let Some(hit) = b2.closest_hit::<Watertight, _>(ray, &mut NoStats) else {
                continue;
            };
            for end in [
                hit.t * 0.5,
                hit.t.next_down(),
                hit.t,
                hit.t.next_up(),
                hit.t * 2.0,
            ] {
                let segment = Ray::segment(ray.origin, ray.direction, ray.tmin, end);
                let expected = b2.any_hit::<Watertight, _>(&segment, &mut NoStats);
                let got = wide.any_hit::<Watertight, _>(&segment, &mut NoStats);
                assert_eq!(
                    got,
                    expected,
                    "{what}: BVH{W} {}: {segment:?}",
                    level.label()
                );
                let counted = wide.any_hit::<Watertight, _>(&segment, &mut Counters::default());
                assert_eq!(counted, got, "{what}: counting changed {segment:?}");
                segments += usize::from(expected);
            }
        }
    }
    assert!(segments > 0, "{what}: no segment was occluded");
}

#[test]
fn any_hit_of_segments_equals_the_bvh2s_in_every_kind_of_leaf() {
    for seed in 0..2 {
        let tris = soup(3000, seed + 40);
        let rays = rays(&bounds(&tris), 1500, seed + 50);
        let params = BuildParams {
            c_trav: 8.0,
            ..BuildParams::with_strategy(Strategy::SahBinned)
        };
        let b2 = bvh::build(&tris, &params).expect("build").0;
        let what = format!("soup {seed}");
        assert_segments_agree::<4>(&b2, &rays, &what);
        assert_segments_agree::<8>(&b2, &rays, &what);
    }
}

/// BVH2 leaves larger than a lane holds (`--max-leaf` above `MAX_LEAF_COUNT`, up to the
/// largest a build allows) become subtrees of leaves of at most `MAX_LEAF_COUNT`: the tree
/// validates, no lane holds more, and every kernel and order gives the BVH2's hits bit for
/// bit, the walks through a leaf's subtree included; a refit keeps them.
#[test]
fn leaves_larger_than_a_lane_holds_become_subtrees_of_leaves() {
    use bvhlab::accel::bvh::wide::node::MAX_LEAF_COUNT;
    for (spec, max_leaf) in [
        ("soup:3000", 64),
        ("sphere:6000", 500),
        ("same-centroid:3000", 4096),
    ] {
        let scene = Scene::load(spec).unwrap();
        let tris = &scene.triangles;
        let params = BuildParams {
            max_leaf_size: max_leaf,
            // Steps far dearer than triangle tests: the build keeps leaves as large as it may.
            c_trav: 1000.0,
            ..BuildParams::with_strategy(Strategy::SahBinned)
        };
        let b2 = bvh::build(tris, &params).expect("build").0;
        let largest = b2
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.count)
            .max();
        assert!(
            largest > Some(MAX_LEAF_COUNT),
            "{spec}: leaves of {largest:?}"
        );
        let mut rays = rays(&bounds(tris), 1500, 11);
        rays.extend(view_rays(&scene, 24, 18));
        assert_wide_equals_bvh2::<4>(&b2, &rays, spec);
        assert_wide_equals_bvh2::<8>(&b2, &rays, spec);
        fn lanes_fit<const W: usize>(b2: &Bvh, max_leaf: u32, spec: &str)
        where
            Lanes<W>: NodeWidth,
        {
            let p = CollapseParams {
                max_leaf_size: max_leaf,
                ..CollapseParams::default()
            };
            let mut wide = WideBvh::<W>::collapse(b2, &p);
            wide.validate()
                .unwrap_or_else(|e| panic!("{spec} BVH{W}: {e}"));
            let counts = wide
                .nodes
                .iter()
                .flat_map(|n| n.child.iter().map(|c| c.count()));
            assert!(counts.clone().all(|c| c <= MAX_LEAF_COUNT), "{spec} BVH{W}");
            assert!(
                counts.clone().any(|c| c > 8),
                "{spec} BVH{W}: no leaf past 8"
            );
            let before = wide.sah_cost(1.0, 1.0);
            wide.refit(&b2_scene(b2), 1.0, 1.0).unwrap();
            wide.validate()
                .unwrap_or_else(|e| panic!("{spec} BVH{W} refit: {e}"));
            assert_eq!(
                wide.sah_cost(1.0, 1.0),
                before,
                "{spec} BVH{W}: refit moved a box"
            );
        }
        lanes_fit::<4>(&b2, max_leaf, spec);
        lanes_fit::<8>(&b2, max_leaf, spec);
    }
}

/// The scene triangles a BVH2 was built over, in scene order (from its leaf-order copies).
fn b2_scene(b2: &Bvh) -> Vec<Triangle> {
    let mut scene = vec![Triangle::new(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO); b2.triangle_count];
    for (t, &i) in b2.triangles.iter().zip(&b2.prim_indices) {
        scene[i as usize] = *t;
    }
    scene
}

#[test]
fn wide_trees_survive_degenerate_inputs() {
    for (what, tris) in degenerate_cases() {
        let b = bounds(&tris);
        let rays = if tris.is_empty() {
            common::rays(&Aabb::new(Vec3::splat(-1.0), Vec3::ONE), 200, 3)
        } else {
            common::rays(&b, 500, 3)
        };
        let b2 = bvh2(&tris, Strategy::SahBinned);
        assert_wide_equals_bvh2::<4>(&b2, &rays, what);
        assert_wide_equals_bvh2::<8>(&b2, &rays, what);
    }
}

/// Packets of coherent rays (a view's tiles, in the renderer's order) and of incoherent
/// ones give every ray its single-ray hit, with every kernel.
#[test]
fn wide_packets_equal_single_rays() {
    fn check<const W: usize>(b2: &Bvh, rays: &[Ray], what: &str)
    where
        Lanes<W>: NodeWidth,
        WideBvh<W>: Accel,
    {
        let mut wide = WideBvh::<W>::collapse(b2, &CollapseParams::default());
        for level in SimdLevel::available() {
            wide.set_simd(level).unwrap();
            let mut hits = vec![None; rays.len()];
            wide.closest_hits::<Watertight>(rays, &mut hits);
            for (i, (ray, got)) in rays.iter().zip(&hits).enumerate() {
                let single = wide.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(
                    bits(*got),
                    bits(single),
                    "{what} BVH{W} {}: ray {i}",
                    level.label()
                );
            }
        }
    }
    for name in SMALL_BUILTINS {
        let scene = Scene::load(name).unwrap();
        let b2 = bvh2(&scene.triangles, Strategy::SahBinned);
        // Tiles of 8 × 8 pixels, as the renderer sends them.
        let cam = scene.camera().rays(64, 48);
        let tiled: Vec<Ray> = (0..6)
            .flat_map(|ty| (0..8).map(move |tx| (tx, ty)))
            .flat_map(|(tx, ty)| tile_pixels(tx * 8, ty * 8, 64, 48))
            .map(|(x, y)| cam.pixel_center(x, y))
            .collect();
        check::<4>(&b2, &tiled, name);
        check::<8>(&b2, &tiled, name);
        let random = rays(&scene.bounds(), 640, 5);
        check::<4>(&b2, &random, name);
        check::<8>(&b2, &random, name);
    }
}

/// Packets from one origin (the case whose planes are offset from the origin once, and whose
/// triangle groups stop after the edge functions when no ray is inside or on an edge) aimed
/// exactly at the shared vertices and edges of grids in three orientations: rays through a
/// vertex or along an edge are decided by the single-ray retest, and every ray gets its
/// single-ray hit, bit for bit, with every kernel.
#[test]
fn one_origin_packets_through_vertices_and_edges_equal_single_rays() {
    // A 9 × 9 grid of unit squares, two triangles each, in the plane `axis` = 0.
    let grid = |axis: usize| -> Vec<Triangle> {
        let at = |i: usize, j: usize| {
            let mut p = [0.0f32; 3];
            p[(axis + 1) % 3] = i as f32 - 4.5;
            p[(axis + 2) % 3] = j as f32 - 4.5;
            Vec3::from(p)
        };
        (0..81)
            .flat_map(|k| {
                let (i, j) = (k % 9, k / 9);
                [
                    Triangle::new(at(i, j), at(i + 1, j), at(i + 1, j + 1)),
                    Triangle::new(at(i, j), at(i + 1, j + 1), at(i, j + 1)),
                ]
            })
            .collect()
    };
    for axis in 0..3 {
        let tris = grid(axis);
        let mut origin = [0.25f32, 0.5, 0.75];
        origin[axis] = 7.0;
        let origin = Vec3::from(origin);
        // Every vertex, every edge's midpoint and every triangle's centroid, 64 at a time
        // from the same origin.
        let mut targets: Vec<Vec3> = tris.iter().flat_map(|t| t.v).collect();
        targets.extend(tris.iter().flat_map(|t| {
            let [a, b, c] = t.v;
            [(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]
        }));
        targets.extend(tris.iter().map(|t| (t.v[0] + t.v[1] + t.v[2]) / 3.0));
        let rays: Vec<Ray> = targets
            .iter()
            .map(|&p| Ray::new(origin, p - origin))
            .collect();
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut wide = WideBvh::<8>::collapse(&b2, &CollapseParams::default());
        for level in SimdLevel::available() {
            wide.set_simd(level).unwrap();
            let mut hits = vec![None; rays.len()];
            wide.closest_hits::<Watertight>(&rays, &mut hits);
            let mut hit = 0;
            for (i, (ray, got)) in rays.iter().zip(&hits).enumerate() {
                let single = wide.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(
                    bits(*got),
                    bits(single),
                    "grid {axis} {}: ray {i}",
                    level.label()
                );
                hit += usize::from(got.is_some());
            }
            // Watertight: no ray aimed inside the grid slips through it.
            assert_eq!(hit, rays.len(), "grid {axis} {}", level.label());
        }
    }
}
