//! The wide BVHs (BVH4, BVH8) against the BVH2 they are collapsed from: every SIMD kernel
//! this machine has gives the BVH2's hits bit for bit (triangle, t, u, v), any hit agrees,
//! counting changes nothing; the slab kernels equal the scalar slab test and the triangle
//! kernels the scalar watertight test lane for lane; the collapse keeps every box around its
//! subtree and costs no more than a greedy collapse; the wide trees of the default build are
//! the ones recorded, on 1 and 2 threads.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::wide::{CollapseParams, LaneKind, Lanes, NodeWidth};
use bvhlab::accel::bvh::{self, BuildParams, Bvh, Strategy, TraversalOrder, WideBvh};
use bvhlab::accel::progress::BuildProgress;
use bvhlab::accel::{Accel, Counters, Hit, NoStats};
use bvhlab::geometry::aabb::{SlabRay, slab_entry};
use bvhlab::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab};
use bvhlab::geometry::simd::{BLOCK, SimdLevel, TriangleBlock, TriangleKernel, WideRay};
use bvhlab::geometry::{Aabb, Intersector, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, SMALL_BUILTINS, degenerate_cases, rays, soup, view_rays};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn bits(h: Option<Hit>) -> Option<(u64, u32, u32, u32)> {
    h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
}

fn bvh2(tris: &[Triangle], strategy: Strategy) -> Bvh {
    bvh::build(tris, &BuildParams::with_strategy(strategy))
        .expect("build")
        .0
}

/// Every kernel and order of a W-wide collapse of `b2` against `b2` itself.
fn assert_wide_equals_bvh2<const W: usize>(b2: &Bvh, rays: &[Ray], what: &str)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    let wide = WideBvh::<W>::collapse(b2, &CollapseParams::default());
    assert_tree_equals_bvh2(wide, b2, rays, what);
}

/// Every kernel and order of the W-wide tree `wide` against the BVH2 `b2` over the same
/// triangles.
fn assert_tree_equals_bvh2<const W: usize>(mut wide: WideBvh<W>, b2: &Bvh, rays: &[Ray], what: &str)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    wide.validate()
        .unwrap_or_else(|e| panic!("{what}: BVH{W}: {e}"));
    wide.outline()
        .validate()
        .unwrap_or_else(|e| panic!("{what}: BVH{W} outline: {e}"));
    for level in SimdLevel::available() {
        wide.set_simd(level).unwrap();
        for order in TraversalOrder::ALL {
            wide.order = order;
            for (i, ray) in rays.iter().enumerate() {
                let expected = b2.closest_hit::<Watertight, _>(ray, &mut NoStats);
                let got = wide.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(
                    bits(got),
                    bits(expected),
                    "{what}: BVH{W} {} {}: ray {i} {ray:?}",
                    level.label(),
                    order.label()
                );
                let mut c = Counters::default();
                let counted = wide.closest_hit::<Watertight, _>(ray, &mut c);
                assert_eq!(bits(counted), bits(got), "{what}: counting changed ray {i}");
                let occluded = wide.any_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(occluded, got.is_some(), "{what}: any hit of ray {i}");
                let occluded_counted = wide.any_hit::<Watertight, _>(ray, &mut Counters::default());
                assert_eq!(
                    occluded_counted, occluded,
                    "{what}: counted any hit of ray {i}"
                );
            }
        }
    }
}

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

/// Each kernel's lanes equal the scalar slab test on random boxes, flat boxes, boxes the
/// ray starts in, and axis-parallel rays with ±0 components lying in a box's face plane.
#[test]
fn every_slab_kernel_equals_the_scalar_slab_test() {
    fn check<const W: usize, K: WideSlab<W>>(level: SimdLevel, rng: &mut Rng)
    where
        Portable: WideSlab<W>,
    {
        if !level.supported() {
            return;
        }
        let unit = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        for case in 0..20_000 {
            let mut boxes = [Aabb::EMPTY; W];
            for (i, b) in boxes.iter_mut().enumerate() {
                let (p, q) = (rng.vec3_in(&unit), rng.vec3_in(&unit));
                *b = match (case + i) % 4 {
                    // Flat in x: the ray may lie in its plane.
                    0 => Aabb::new(p.min(q).with_x(0.25), p.max(q).with_x(0.25)),
                    1 if i == W - 1 => Aabb::EMPTY,
                    _ => Aabb::new(p.min(q), p.max(q)),
                };
            }
            let origin = match case % 3 {
                0 => rng.vec3_in(&unit),
                1 => Vec3::new(0.25, rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)),
                _ => rng.unit_vector() * 3.0,
            };
            let mut d = match case % 4 {
                0 => Vec3::new(0.0, 1.0, 0.0),
                1 => Vec3::new(-0.0, -0.0, -1.0),
                _ => rng.unit_vector(),
            };
            if case % 7 == 0 {
                d.x = -0.0;
            }
            let ray = Ray::new(origin, d);
            let (tmin, tmax) = (0.0, if case % 5 == 0 { 0.7 } else { f32::INFINITY });
            let mut rows = [[0.0f32; W]; 6];
            for (i, b) in boxes.iter().enumerate() {
                for a in 0..3 {
                    rows[a][i] = b.min[a];
                    rows[a + 3][i] = b.max[a];
                }
            }
            let wray = WideRay::new(&ray);
            let mut got = [0.0f32; W];
            // SAFETY: `level.supported()` was checked above.
            let mask = unsafe { K::entries(&rows, &wray, tmin, tmax, &mut got) };
            let slab = SlabRay::new(&ray);
            for (i, b) in boxes.iter().enumerate() {
                let expected = slab_entry(&[b.min, b.max], &slab, tmin, tmax);
                let hit = mask >> i & 1 == 1;
                assert_eq!(
                    hit,
                    expected != f32::INFINITY,
                    "{} W={W} case {case} lane {i}: {b:?} {ray:?}",
                    level.label()
                );
                if hit {
                    assert_eq!(
                        got[i].to_bits(),
                        expected.to_bits(),
                        "{} lane {i}",
                        level.label()
                    );
                }
            }
        }
    }
    let mut rng = Rng::new(11);
    check::<4, Portable>(SimdLevel::Portable, &mut rng);
    check::<8, Portable>(SimdLevel::Portable, &mut rng);
    check::<4, Sse41>(SimdLevel::Sse41, &mut rng);
    check::<8, Sse41>(SimdLevel::Sse41, &mut rng);
    check::<4, Avx2>(SimdLevel::Avx2, &mut rng);
    check::<8, Avx2>(SimdLevel::Avx2, &mut rng);
    check::<4, Avx512>(SimdLevel::Avx512, &mut rng);
    check::<8, Avx512>(SimdLevel::Avx512, &mut rng);
}

/// Each triangle kernel's lanes equal the scalar watertight test: hit or miss, and t, u, v
/// bit for bit, on random triangles, triangles sharing edges, degenerate and tiny ones, rays
/// through vertices and edges, axis-parallel rays with ±0 components and rays starting on a
/// triangle; lanes it hands back to the scalar test are those the scalar test decides in f64,
/// and padding never hits.
#[test]
fn every_triangle_kernel_equals_the_scalar_watertight_test() {
    fn check<K: TriangleKernel>(level: SimdLevel, rng: &mut Rng) -> (usize, usize) {
        if !level.supported() {
            return (0, 0);
        }
        let unit = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        let (mut hits, mut retests) = (0, 0);
        for case in 0..40_000 {
            // Four triangles around a shared vertex p (edges shared pairwise), or random
            // ones; some degenerate, one lane left as padding now and then.
            let p = rng.vec3_in(&unit);
            let ring: [Vec3; 5] = std::array::from_fn(|_| rng.vec3_in(&unit));
            let mut tris: Vec<Option<Triangle>> = (0..BLOCK)
                .map(|i| {
                    Some(match (case + i) % 5 {
                        0 => Triangle::new(p, ring[i], ring[i + 1]),
                        1 => Triangle::new(p, p, ring[i]),
                        2 => Triangle::new(p, ring[i], ring[i] * 2.0 - p),
                        3 => {
                            let c = rng.vec3_in(&unit);
                            let s = 1e-4;
                            Triangle::new(c, c + Vec3::X * s, c + Vec3::Y * s)
                        }
                        _ => Triangle::new(ring[i], ring[i + 1], rng.vec3_in(&unit)),
                    })
                })
                .collect();
            if case % 9 == 0 {
                tris[case % BLOCK] = None;
            }
            let mut block = TriangleBlock::EMPTY;
            for (lane, t) in tris.iter().enumerate() {
                if let Some(t) = t {
                    block.set(lane, t);
                }
            }
            let aim = match case % 4 {
                0 => p,
                1 => ring[0] * 0.5 + ring[1] * 0.5,
                _ => rng.vec3_in(&unit),
            };
            let origin = match case % 6 {
                // On the first triangle's plane: t at or next to 0.
                0 => match tris[0] {
                    Some(t) => t.point(rng.f32() * 0.5, rng.f32() * 0.5),
                    None => rng.vec3_in(&unit),
                },
                1 => aim - Vec3::new(0.0, 0.0, 2.0),
                _ => rng.unit_vector() * 3.0,
            };
            let mut d = match case % 6 {
                1 => Vec3::new(-0.0, 0.0, 1.0),
                0 => rng.unit_vector(),
                _ => aim - origin,
            };
            if case % 7 == 0 {
                d.y = -0.0;
            }
            if d == Vec3::ZERO {
                continue;
            }
            let ray = Ray::new(origin, d);
            let (tmin, tmax) = (0.0, if case % 5 == 0 { 1.5 } else { f32::INFINITY });
            let shear = Watertight::prepare(&ray);
            // SAFETY: `level.supported()` was checked above.
            let got = unsafe { K::watertight(&block, &shear, &ray, tmin, tmax) };
            // SAFETY: the portable kernel has no requirement.
            let portable = unsafe { Portable::watertight(&block, &shear, &ray, tmin, tmax) };
            assert_eq!(
                (got.hit, got.retest),
                (portable.hit, portable.retest),
                "{} case {case}: lanes differ from the portable kernel",
                level.label()
            );
            for (lane, t) in tris.iter().enumerate() {
                let (hit, retest) = (got.hit >> lane & 1 == 1, got.retest >> lane & 1 == 1);
                let Some(t) = t else {
                    assert!(!hit && !retest, "{} case {case}: padding", level.label());
                    continue;
                };
                let expected = Watertight::intersect(&shear, &ray, t, tmin, tmax);
                if retest {
                    retests += 1;
                    continue;
                }
                assert_eq!(
                    hit,
                    expected.is_some(),
                    "{} case {case} lane {lane}: {t:?} {ray:?}",
                    level.label()
                );
                if let Some(e) = expected {
                    hits += 1;
                    let lanes = (got.t[lane], got.u[lane], got.v[lane]);
                    assert_eq!(
                        [lanes.0, lanes.1, lanes.2].map(f32::to_bits),
                        [e.t, e.u, e.v].map(f32::to_bits),
                        "{} case {case} lane {lane}",
                        level.label()
                    );
                }
            }
        }
        (hits, retests)
    }
    let mut rng = Rng::new(5);
    let (hits, retests) = check::<Portable>(SimdLevel::Portable, &mut rng);
    // The cases reach both paths: hits decided by the lanes, and lanes handed back.
    assert!(
        hits > 1000 && retests > 100,
        "{hits} hits, {retests} retests"
    );
    check::<Sse41>(SimdLevel::Sse41, &mut rng);
    check::<Avx2>(SimdLevel::Avx2, &mut rng);
    check::<Avx512>(SimdLevel::Avx512, &mut rng);
}

/// The block test stops early when no lane can hit or be handed back (a ray beside all four
/// triangles, triangles behind the origin or beyond tmax, a padding block) and only then:
/// a lane on a shared edge is still handed back, a lane inside still hits. Every kernel
/// agrees with the portable one and with the scalar test in each case.
#[test]
fn the_block_test_stops_early_only_when_no_lane_can_hit() {
    // Four right triangles apart from each other in the plane z = 5, legs of length 1.
    let tri = |x: f32| {
        Triangle::new(
            Vec3::new(x, 0.0, 5.0),
            Vec3::new(x + 1.0, 0.0, 5.0),
            Vec3::new(x, 1.0, 5.0),
        )
    };
    let tris = [tri(0.0), tri(2.0), tri(4.0), tri(6.0)];
    let mut block = TriangleBlock::EMPTY;
    for (lane, t) in tris.iter().enumerate() {
        block.set(lane, t);
    }
    // The first of them and its mirror image across its hypotenuse, which they share, in a
    // block of their own: a ray through the hypotenuse has an edge function of exactly zero.
    let a = tris[0];
    let mut edge_block = TriangleBlock::EMPTY;
    edge_block.set(0, &a);
    edge_block.set(1, &Triangle::new(a.v[1], Vec3::new(1.0, 1.0, 5.0), a.v[2]));
    let up = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 0.0), Vec3::Z);
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 0.0), -Vec3::Z);
    // (block, ray, tmax, expected hit lanes, whether some lane is handed back)
    let cases: [(&TriangleBlock, Ray, f32, u32, bool); 8] = [
        (&block, up(1.5, 0.5), f32::INFINITY, 0, false), // beside all four
        (&block, up(0.25, 0.25), f32::INFINITY, 0b0001, false), // inside lane 0
        (&block, up(4.25, 0.25), f32::INFINITY, 0b0100, false), // inside lane 2
        (&block, down(0.25, 0.25), f32::INFINITY, 0, false), // lane 0 behind the origin
        (&block, up(0.25, 0.25), 4.0, 0, false),         // lane 0 beyond tmax
        (
            &TriangleBlock::EMPTY,
            up(0.25, 0.25),
            f32::INFINITY,
            0,
            false,
        ), // padding
        (&edge_block, up(0.5, 0.5), f32::INFINITY, 0, true), // on the shared hypotenuse
        (&edge_block, up(0.75, 0.75), f32::INFINITY, 0b0010, false), // inside lane 1
    ];
    fn check<K: TriangleKernel>(level: SimdLevel, cases: &[(&TriangleBlock, Ray, f32, u32, bool)]) {
        if !level.supported() {
            return;
        }
        for (i, &(block, ray, tmax, hit, handed_back)) in cases.iter().enumerate() {
            let shear = Watertight::prepare(&ray);
            // SAFETY: `level.supported()` was checked above.
            let got = unsafe { K::watertight(block, &shear, &ray, 0.0, tmax) };
            // SAFETY: the portable kernel has no requirement.
            let portable = unsafe { Portable::watertight(block, &shear, &ray, 0.0, tmax) };
            let what = format!("{} case {i}", level.label());
            assert_eq!(
                (got.hit, got.retest),
                (portable.hit, portable.retest),
                "{what}"
            );
            assert_eq!(got.hit, hit, "{what}: hit lanes");
            assert_eq!(got.retest != 0, handed_back, "{what}: handed-back lanes");
            for lane in 0..BLOCK {
                let scalar = Watertight::intersect(&shear, &ray, &block.triangle(lane), 0.0, tmax);
                if got.retest >> lane & 1 == 0 {
                    assert_eq!(
                        got.hit >> lane & 1 == 1,
                        scalar.is_some(),
                        "{what} lane {lane}"
                    );
                }
                if let Some(s) = scalar.filter(|_| got.hit >> lane & 1 == 1) {
                    assert_eq!(got.t[lane].to_bits(), s.t.to_bits(), "{what} lane {lane}");
                }
            }
        }
    }
    check::<Portable>(SimdLevel::Portable, &cases);
    check::<Sse41>(SimdLevel::Sse41, &cases);
    check::<Avx2>(SimdLevel::Avx2, &cases);
    check::<Avx512>(SimdLevel::Avx512, &cases);
}

/// The greedy collapse the dynamic program must beat or tie: open the child with the
/// largest box until W children, leaves where the BVH2 has them.
fn greedy_cost<const W: usize>(b2: &Bvh, p: &CollapseParams) -> f64 {
    let area = |i: usize| b2.nodes[i].bounds().surface_area() as f64;
    let root = area(0);
    let mut cost = p.c_trav as f64 * root;
    let mut open = vec![0usize];
    while let Some(n) = open.pop() {
        let l = b2.nodes[n].left_first as usize;
        let mut children = vec![l, l + 1];
        while children.len() < W {
            let Some((k, _)) = children
                .iter()
                .enumerate()
                .filter(|(_, c)| !b2.nodes[**c].is_leaf())
                .max_by(|a, b| area(*a.1).total_cmp(&area(*b.1)))
            else {
                break;
            };
            let c = children.swap_remove(k);
            let l = b2.nodes[c].left_first as usize;
            children.extend([l, l + 1]);
        }
        for c in children {
            let node = &b2.nodes[c];
            if node.is_leaf() {
                cost += p.c_isect as f64 * node.count as f64 * area(c);
            } else {
                cost += p.c_trav as f64 * area(c);
                open.push(c);
            }
        }
    }
    cost / root
}

#[test]
fn the_sah_optimal_collapse_costs_no_more_than_a_greedy_one() {
    let p = CollapseParams::default();
    for name in [
        "cornell",
        "teapot-in-stadium",
        "sphere:3000",
        "walls-rotated",
    ] {
        let scene = Scene::load(name).unwrap();
        let b2 = bvh2(&scene.triangles, Strategy::SahBinned);
        let w4 = WideBvh::<4>::collapse(&b2, &p);
        let w8 = WideBvh::<8>::collapse(&b2, &p);
        let (c4, g4) = (w4.sah_cost(p.c_trav, p.c_isect), greedy_cost::<4>(&b2, &p));
        let (c8, g8) = (w8.sah_cost(p.c_trav, p.c_isect), greedy_cost::<8>(&b2, &p));
        assert!(c4 <= g4 * (1.0 + 1e-5), "{name}: BVH4 {c4} > greedy {g4}");
        assert!(c8 <= g8 * (1.0 + 1e-5), "{name}: BVH8 {c8} > greedy {g8}");
        // A wider node folds more levels: fewer nodes, and no deeper a tree.
        assert!(w8.nodes.len() < w4.nodes.len(), "{name}");
        assert!(w8.depth <= w4.depth, "{name}");
    }
}

#[test]
fn an_unsupported_kernel_is_refused_and_changes_nothing() {
    let b2 = bvh2(&soup(100, 1), Strategy::SahBinned);
    let mut wide = WideBvh::<8>::collapse(&b2, &CollapseParams::default());
    let before = wide.simd();
    for level in SimdLevel::ALL.into_iter().filter(|l| !l.supported()) {
        let err = wide.set_simd(level).unwrap_err();
        assert!(err.to_string().contains(level.label()), "{err}");
        assert_eq!(wide.simd(), before);
    }
    assert!(wide.set_simd(SimdLevel::Portable).is_ok());
}

/// Moves some triangles (scene order), returning the moved indices.
fn shake(tris: &mut [Triangle], rng: &mut Rng, every: usize) -> Vec<u32> {
    let mut moved = Vec::new();
    for (i, t) in tris.iter_mut().enumerate() {
        if rng.below(every) == 0 {
            let d = Vec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
            );
            for v in &mut t.v {
                *v += d;
            }
            moved.push(i as u32);
        }
    }
    moved
}

#[test]
fn refit_then_trace_equals_rebuild_then_trace() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
        WideBvh<W>: Accel,
    {
        let mut rng = Rng::new(seed);
        let mut tris = soup(3000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut full = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut partial = full.clone();
        let mut index = RefitIndex::for_wide(&partial);
        for round in 0..3 {
            let moved = shake(&mut tris, &mut rng, 10);
            full.refit(&tris, 1.0, 1.0).unwrap();
            partial
                .refit_moved(&mut index, &tris, &moved, 1.0, 1.0)
                .unwrap();
            full.validate()
                .unwrap_or_else(|e| panic!("BVH{W} refit round {round}: {e}"));
            partial
                .validate()
                .unwrap_or_else(|e| panic!("BVH{W} partial round {round}: {e}"));
            let rebuilt = WideBvh::<W>::collapse(
                &bvh2(&tris, Strategy::SahBinned),
                &CollapseParams::default(),
            );
            for ray in rays(&bounds(&tris), 1500, seed + round) {
                let expected = bits(rebuilt.closest_hit::<Watertight, _>(&ray, &mut NoStats));
                assert_eq!(
                    bits(full.closest_hit::<Watertight, _>(&ray, &mut NoStats)),
                    expected
                );
                assert_eq!(
                    bits(partial.closest_hit::<Watertight, _>(&ray, &mut NoStats)),
                    expected
                );
                assert_eq!(
                    partial.any_hit::<Watertight, _>(&ray, &mut NoStats),
                    expected.is_some()
                );
            }
        }
        // Partial and full refits give the same boxes.
        assert_eq!(full.nodes, partial.nodes);
        let err = full.refit(&tris[1..], 1.0, 1.0).unwrap_err();
        assert!(err.to_string().contains("rebuild"), "{err}");
    }
    check::<4>(1);
    check::<8>(2);
}

/// The full refit of a tree large enough to run as parallel tasks: every triangle moved,
/// the boxes are exactly their subtrees' (validate), the blocks hold the moved triangles,
/// the SAH costs it reports are the tree's before and after, and it equals the partial refit.
#[test]
fn parallel_refit_is_exact() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
    {
        let mut tris = soup(50_000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut full = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut partial = full.clone();
        let mut index = RefitIndex::for_wide(&partial);
        let before = full.sah_cost(1.0, 2.0);
        let everything: Vec<u32> = (0..tris.len() as u32).collect();
        for t in &mut tris {
            for v in &mut t.v {
                *v = *v * 1.5 + Vec3::new(0.25, -0.5, 1.0);
            }
        }
        let report = full.refit(&tris, 1.0, 2.0).unwrap();
        full.validate().unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        assert!(
            close(report.sah_before, before),
            "{} {before}",
            report.sah_before
        );
        let after = full.sah_cost(1.0, 2.0);
        assert!(
            close(report.sah_after, after),
            "{} {after}",
            report.sah_after
        );
        partial
            .refit_moved(&mut index, &tris, &everything, 1.0, 2.0)
            .unwrap();
        assert_eq!(full.nodes, partial.nodes);
        for (slot, &t) in full.prim_indices.iter().enumerate() {
            if t != u32::MAX {
                let lane = full.blocks[slot / BLOCK].triangle(slot % BLOCK);
                assert_eq!(lane.v, tris[t as usize].v, "slot {slot}");
            }
        }
    }
    check::<4>(7);
    check::<8>(8);
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
            .flat_map(|(tx, ty)| (0..64).map(move |k| (tx * 8 + k % 8, ty * 8 + k / 8)))
            .map(|(x, y)| cam.pixel_center(x, y))
            .collect();
        check::<4>(&b2, &tiled, name);
        check::<8>(&b2, &tiled, name);
        let random = rays(&scene.bounds(), 640, 5);
        check::<4>(&b2, &random, name);
        check::<8>(&b2, &random, name);
    }
}

/// Partial refits through one index keep the SAH sums from refit to refit: each reports
/// the tree's SAH cost before and after as a pass over every lane gives it, also after the
/// tree was refitted otherwise in between (its root box changed: the sums are made again).
#[test]
fn partial_refits_report_the_sah_cost_of_the_tree() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
    {
        let mut tris = soup(5_000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut tree = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut index = RefitIndex::for_wide(&tree);
        let moved: Vec<u32> = (0..tris.len() as u32).filter(|t| t % 7 == 3).collect();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        for round in 0..40 {
            let before = tree.sah_cost(1.0, 2.0);
            let offset = Vec3::new(0.3, -0.1, 0.2) * if round % 2 == 0 { 1.0 } else { -0.5 };
            for &t in &moved {
                for v in &mut tris[t as usize].v {
                    *v += offset;
                }
            }
            if round == 20 {
                // Every triangle moves and a full refit runs: the index's sums are stale.
                for t in &mut tris {
                    for v in &mut t.v {
                        *v *= 1.25;
                    }
                }
                tree.refit(&tris, 1.0, 2.0).unwrap();
                continue;
            }
            let report = tree
                .refit_moved(&mut index, &tris, &moved, 1.0, 2.0)
                .unwrap();
            let after = tree.sah_cost(1.0, 2.0);
            assert!(close(report.sah_before, before), "round {round}");
            assert!(close(report.sah_after, after), "round {round}");
        }
        tree.validate().unwrap();
    }
    check::<4>(3);
    check::<8>(4);
}

/// FNV-1a over a wide tree's nodes (boxes, children, counts), leaf blocks, slots and depth:
/// any change to the tree changes it. Each node's lanes are read through their kind and
/// hashed as the rows of the unpacked layout held them (a row of children, node indices or
/// first slots, then a row of counts, `u32::MAX` for an interior child, 0 for an unused
/// lane), so the recorded values name the same trees whatever the lanes' packing.
fn fingerprint<const W: usize>(w: &WideBvh<W>) -> u64
where
    Lanes<W>: NodeWidth,
{
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: u32| {
        for b in x.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for n in &w.nodes {
        n.bounds.iter().flatten().for_each(|x| eat(x.to_bits()));
        let unpacked = |l: usize| match n.lane_kind(l) {
            LaneKind::Unused => (0, 0),
            LaneKind::Interior(c) => (c, u32::MAX),
            LaneKind::Leaf { first, count } => (first, count),
        };
        (0..W).for_each(|l| eat(unpacked(l).0));
        (0..W).for_each(|l| eat(unpacked(l).1));
    }
    for b in &w.blocks {
        b.v.iter()
            .flatten()
            .flatten()
            .for_each(|x| eat(x.to_bits()));
    }
    w.prim_indices.iter().for_each(|&x| eat(x));
    eat(w.depth);
    h
}

/// The binned SAH build and its collapse give the same BVH4 and BVH8 on 1 and 2 threads,
/// and the very trees recorded before the build was made faster: a change of speed must not
/// change a node, a leaf's order or a box.
#[test]
fn wide_builds_are_the_recorded_trees_on_any_thread_count() {
    use bvhlab::accel::structure::{AccelKind, Structure, StructureParams, build};
    let recorded = [
        ("soup:100000", AccelKind::Bvh8, 0xb5bd_cf89_5700_d27a_u64),
        ("soup:100000", AccelKind::Bvh4, 0x8aa9_5e38_135b_bacf),
        ("teapot-in-stadium", AccelKind::Bvh8, 0x7c91_1f64_cc7d_ed76),
        ("sphere:50000", AccelKind::Bvh4, 0xb34d_0db9_3044_6c8f),
    ];
    for (spec, kind, expected) in recorded {
        let scene = Scene::load(spec).unwrap();
        let tris = scene.flattened().unwrap();
        let params = StructureParams {
            kind,
            ..StructureParams::default()
        };
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            let built = pool.install(|| build(&tris, &params, &Default::default()).unwrap());
            let fp = match &built.structure {
                Structure::Bvh8(w) => fingerprint(w),
                Structure::Bvh4(w) => fingerprint(w),
                _ => unreachable!("a wide BVH was asked for"),
            };
            assert_eq!(fp, expected, "{spec}, {kind:?}, {threads} threads: {fp:#x}");
        }
    }
}
