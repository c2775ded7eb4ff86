//! LBVH and treelet restructuring: valid trees with the closest and any hits of brute force
//! for every parameter, the same tree on 1 and 2 threads, degenerate and large inputs, an SAH
//! cost that no treelet round raises, and the dynamic program's topology equal to the best of
//! all binary trees over the treelet's leaves.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::build::MAX_DEPTH;
use bvhlab::accel::bvh::build::linked_tree::SahCost;
use bvhlab::accel::bvh::build::treelet::{Optimal, TreeletLeaf};
use bvhlab::accel::bvh::{BuildError, BuildParams, BuildReport, Strategy, TraversalOrder, build};
use bvhlab::accel::{Accel, BruteForce, Bvh, Counters, NoStats};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, rays, same_hit, soup};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn lbvh(treelets: bool) -> BuildParams {
    BuildParams::with_strategy(if treelets {
        Strategy::LbvhTreelet
    } else {
        Strategy::Lbvh
    })
}

/// Plain LBVH and LBVH + treelets at several leaf sizes, treelet sizes and round counts.
fn lbvh_params() -> Vec<BuildParams> {
    let mut out = Vec::new();
    for max_leaf_size in [1, 4, 8, 32] {
        out.push(BuildParams {
            max_leaf_size,
            ..lbvh(false)
        });
    }
    for (treelet_size, treelet_rounds, max_leaf_size) in [
        (5, 1, 8),
        (7, 3, 8),
        (9, 2, 4),
        (7, 0, 8),
        (7, 6, 1),
        (6, 3, 16),
    ] {
        out.push(BuildParams {
            treelet_size,
            treelet_rounds,
            max_leaf_size,
            ..lbvh(true)
        });
    }
    out.push(BuildParams {
        c_trav: 0.0,
        c_isect: 3.0,
        ..lbvh(true)
    });
    out.push(BuildParams {
        c_trav: 8.0,
        max_leaf_size: 64,
        ..lbvh(true)
    });
    out
}

fn built(tris: &[Triangle], p: &BuildParams) -> (Bvh, BuildReport) {
    let (bvh, report) = build(tris, p).expect("valid parameters");
    bvh.validate(p.max_leaf_size).expect("valid tree");
    assert_eq!(report.tree.nodes, bvh.nodes.len());
    (bvh, report)
}

/// Closest and any hits of `bvh`, in both traversal orders, equal brute force on `rays`.
fn assert_matches_brute_force(bvh: &mut Bvh, brute: &BruteForce, rays: &[Ray], what: &str) {
    let expected: Vec<_> = rays
        .iter()
        .map(|r| brute.closest_hit::<Watertight, _>(r, &mut NoStats))
        .collect();
    for order in TraversalOrder::ALL {
        bvh.order = order;
        for (i, (ray, want)) in rays.iter().zip(&expected).enumerate() {
            let got = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert!(
                same_hit(got, *want),
                "{what} {order:?}: ray {i} {ray:?}: bvh {got:?}, brute force {want:?}"
            );
            assert_eq!(
                bvh.any_hit::<Watertight, _>(ray, &mut NoStats),
                want.is_some(),
                "{what} {order:?}: any hit of ray {i}"
            );
        }
    }
}

#[test]
fn every_parameter_set_matches_brute_force_on_random_soups() {
    for (seed, n) in [(1, 1), (2, 2), (3, 9), (4, 300), (5, 6000)] {
        let tris = soup(n, seed);
        let brute = BruteForce::new(&tris, false);
        let rays = rays(&bounds(&tris), 500, seed + 50);
        for p in lbvh_params() {
            let (mut bvh, _) = built(&tris, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("soup {n} {p:?}"));
        }
    }
}

#[test]
fn both_builders_match_brute_force_on_every_builtin_scene() {
    for name in common::SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 300, 7);
        rays.extend(common::view_rays(&scene, 16, 12));
        for treelets in [false, true] {
            let (mut bvh, _) = built(&scene.triangles, &lbvh(treelets));
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{name} {treelets}"));
        }
    }
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
        for p in lbvh_params() {
            let (mut bvh, _) = built(&tris, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{what} {p:?}"));
        }
    }
    // Thousands of triangles on one centroid or with one box: only the index orders them.
    for name in ["same-centroid:5000", "same-bbox:5000"] {
        let scene = Scene::load(name).unwrap();
        for treelets in [false, true] {
            let p = BuildParams {
                max_leaf_size: 4,
                ..lbvh(treelets)
            };
            let (bvh, _) = built(&scene.triangles, &p);
            assert!(
                bvh.nodes.len() >= 2 * 5000 / 4 - 1,
                "{name}: split by index"
            );
        }
    }
}

#[test]
fn a_million_triangles_build_without_deep_recursion() {
    // Tiny triangles on a few planes: many equal Morton codes and long shared prefixes.
    let n = 1_000_000;
    let mut rng = Rng::new(3);
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let c = Vec3::new(rng.f32(), (i % 4) as f32, rng.f32() * 1e-3);
            Triangle::new(c, c + Vec3::X * 1e-4, c + Vec3::Z * 1e-4)
        })
        .collect();
    for treelets in [false, true] {
        let (bvh, report) = built(&tris, &lbvh(treelets));
        assert_eq!(report.triangles, n);
        assert!(bvh.root().bounds().contains(&bounds(&tris)));
    }
}

#[test]
fn ten_million_triangles_build_with_treelets() {
    // The largest input: 10^7 random triangles through the LBVH and three treelet
    // rounds (about 2.5 GB at its peak), a valid tree with brute force's hits.
    let scene = Scene::load("soup:10000000").unwrap();
    let tris = &scene.triangles;
    assert_eq!(tris.len(), 10_000_000);
    let (mut bvh, report) = built(tris, &lbvh(true));
    assert_eq!(report.triangles, tris.len());
    assert_eq!(report.phases.sah_after_round.len(), 3);
    assert!(bvh.nodes.len() <= 2 * tris.len());
    let brute = BruteForce::new(tris, true);
    assert_matches_brute_force(&mut bvh, &brute, &rays(&bounds(tris), 8, 3), "soup 10^7");
}

fn on_threads(threads: usize, tris: &[Triangle], p: &BuildParams) -> Bvh {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| build(tris, p).expect("valid parameters").0)
}

#[test]
fn one_and_two_threads_build_the_same_tree() {
    // Large enough for parallel sorting passes and parallel subtrees.
    let inputs = [
        soup(150_000, 11),
        Scene::load("teapot-in-stadium").unwrap().triangles,
        Scene::load("same-centroid:20000").unwrap().triangles,
    ];
    for tris in &inputs {
        for treelets in [false, true] {
            let p = lbvh(treelets);
            let (a, b) = (on_threads(1, tris, &p), on_threads(2, tris, &p));
            assert_eq!(a.nodes, b.nodes, "{} triangles, {p:?}", tris.len());
            assert_eq!(a.prim_indices, b.prim_indices);
        }
    }
}

#[test]
fn treelet_rounds_never_raise_the_sah_cost() {
    let mut scenes: Vec<Vec<Triangle>> = ["teapot-in-stadium", "walls-rotated", "grass:4000"]
        .iter()
        .map(|name| Scene::load(name).unwrap().triangles)
        .collect();
    scenes.push(soup(20_000, 5));
    for tris in &scenes {
        for (treelet_size, max_leaf_size) in [(5, 8), (7, 1), (9, 4)] {
            let p = |treelet_rounds| BuildParams {
                treelet_size,
                treelet_rounds,
                max_leaf_size,
                ..lbvh(true)
            };
            let plain = BuildParams {
                max_leaf_size,
                ..lbvh(false)
            };
            let (_, lbvh_report) = built(tris, &plain);
            let (_, report) = built(tris, &p(4));
            let phases = &report.phases;
            let before = phases.sah_before_rounds.expect("reported");
            assert!((before - lbvh_report.tree.sah_cost).abs() <= 1e-9 * before);
            assert_eq!(phases.sah_after_round.len(), 4);
            let mut last = before;
            for &cost in &phases.sah_after_round {
                assert!(cost <= last, "{cost} after {last}");
                last = cost;
            }
            assert!(
                last < before,
                "treelets improve the LBVH ({last} vs {before})"
            );
            // The reported cost is the cost of the tree returned, up to summation order.
            assert!((report.tree.sah_cost - last).abs() <= 1e-9 * last);
            // Fewer rounds stop on the way: each round's tree is the next round's input.
            let (_, two) = built(tris, &p(2));
            assert!((two.tree.sah_cost - phases.sah_after_round[1]).abs() <= 1e-9 * last);
        }
    }
}

#[test]
fn zero_rounds_are_the_plain_lbvh() {
    let tris = soup(10_000, 2);
    let (a, _) = built(&tris, &lbvh(false));
    let (b, _) = built(
        &tris,
        &BuildParams {
            treelet_rounds: 0,
            ..lbvh(true)
        },
    );
    assert_eq!(a.nodes, b.nodes);
    assert_eq!(a.prim_indices, b.prim_indices);
}

/// Every binary tree over the leaves `ids`: (cost, shape as a string).
fn all_trees(leaves: &[TreeletLeaf], sah: &SahCost) -> Vec<(f64, String)> {
    // A tree as nested pairs; leaf k inserted on every edge (and above the root) of every
    // tree over leaves 0..k gives each tree over 0..=k exactly once.
    #[derive(Clone)]
    enum T {
        Leaf(usize),
        Node(Box<T>, Box<T>),
    }
    fn insert(t: &T, k: usize) -> Vec<T> {
        let mut out = vec![T::Node(Box::new(t.clone()), Box::new(T::Leaf(k)))];
        if let T::Node(l, r) = t {
            for l2 in insert(l, k) {
                out.push(T::Node(Box::new(l2), r.clone()));
            }
            for r2 in insert(r, k) {
                out.push(T::Node(l.clone(), Box::new(r2)));
            }
        }
        out
    }
    // (box, count, cost, shape)
    fn eval(t: &T, leaves: &[TreeletLeaf], sah: &SahCost) -> (Aabb, u32, f64, String) {
        match t {
            T::Leaf(k) => (
                leaves[*k].bounds,
                leaves[*k].count,
                leaves[*k].cost,
                k.to_string(),
            ),
            T::Node(l, r) => {
                let (lb, lc, lcost, ls) = eval(l, leaves, sah);
                let (rb, rc, rcost, rs) = eval(r, leaves, sah);
                let b = lb.union(rb);
                let area = b.surface_area() as f64;
                let split = sah.c_trav * area + lcost + rcost;
                let count = lc + rc;
                let cost = if count <= sah.max_leaf_size {
                    split.min(sah.c_isect * area * count as f64)
                } else {
                    split
                };
                (b, count, cost, format!("({ls} {rs})"))
            }
        }
    }
    let mut trees = vec![T::Leaf(0)];
    for k in 1..leaves.len() {
        trees = trees.iter().flat_map(|t| insert(t, k)).collect();
    }
    trees
        .iter()
        .map(|t| {
            let (_, _, cost, shape) = eval(t, leaves, sah);
            (cost, shape)
        })
        .collect()
}

#[test]
fn the_dynamic_program_finds_the_best_of_all_binary_trees() {
    let mut rng = Rng::new(99);
    let mut leaf_chosen = 0;
    for trial in 0..400 {
        let m = 2 + trial % 4; // 2..=5 leaves
        let sah = SahCost {
            c_trav: [1.0, 0.3, 2.0][trial % 3],
            c_isect: 1.0,
            max_leaf_size: [1, 4, 16][trial % 3],
        };
        let space = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let leaves: Vec<TreeletLeaf> = (0..m)
            .map(|_| {
                let c = rng.vec3_in(&space);
                let h = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * rng.range(0.0, 4.0);
                let bounds = Aabb::new(c - h, c + h);
                let count = 1 + rng.below(4) as u32;
                // A subtree costs at most its cost as one leaf.
                let leaf = sah.c_isect * bounds.surface_area() as f64 * count as f64;
                TreeletLeaf {
                    bounds,
                    count,
                    cost: leaf * rng.range(0.3, 1.0) as f64,
                    height: rng.below(3) as u32,
                }
            })
            .collect();
        let trees = all_trees(&leaves, &sah);
        let expected_count: usize = (1..m).map(|k| 2 * k - 1).product();
        assert_eq!(
            trees.len(),
            expected_count,
            "(2m − 3)!! trees over {m} leaves"
        );
        let best = trees.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
        let opt = Optimal::new(&leaves, &sah);
        let full = (1u32 << m) - 1;
        let dp = opt.cost[full as usize];
        assert!(
            (dp - best).abs() <= 1e-12 * best.max(1.0),
            "{m} leaves: DP {dp}, enumeration {best}"
        );
        // The DP's topology is one of the trees, with the optimal cost.
        fn shape(opt: &Optimal, s: u32) -> String {
            if s.is_power_of_two() {
                return s.trailing_zeros().to_string();
            }
            let p = opt.split[s as usize] as u32;
            format!("({} {})", shape(opt, p), shape(opt, s ^ p))
        }
        // Child order is not part of a topology: compare with children sorted.
        let dp_shape = canonical(&shape(&opt, full));
        let matching = trees.iter().find(|(_, t)| canonical(t) == dp_shape);
        let (cost, _) = matching.expect("the DP's topology is a binary tree over the leaves");
        assert!((cost - best).abs() <= 1e-12 * best.max(1.0));
        if leaves.iter().map(|l| l.count).sum::<u32>() <= sah.max_leaf_size
            && (best - sah.c_isect * bounds_of(&leaves).surface_area() as f64 * count_of(&leaves))
                .abs()
                < 1e-12
        {
            leaf_chosen += 1;
        }
    }
    assert!(leaf_chosen > 0, "some treelets are cheapest as one leaf");
}

fn bounds_of(leaves: &[TreeletLeaf]) -> Aabb {
    leaves.iter().fold(Aabb::EMPTY, |b, l| b.union(l.bounds))
}

fn count_of(leaves: &[TreeletLeaf]) -> f64 {
    leaves.iter().map(|l| l.count as f64).sum()
}

/// A shape string with the two children of every node in sorted order.
fn canonical(s: &str) -> String {
    fn parse(b: &[u8], i: &mut usize) -> String {
        if b[*i] == b'(' {
            *i += 1;
            let l = parse(b, i);
            *i += 1; // space
            let r = parse(b, i);
            *i += 1; // ')'
            let (a, c) = if l <= r { (l, r) } else { (r, l) };
            format!("({a} {c})")
        } else {
            let start = *i;
            while *i < b.len() && b[*i].is_ascii_digit() {
                *i += 1;
            }
            String::from_utf8_lossy(&b[start..*i]).into_owned()
        }
    }
    parse(s.as_bytes(), &mut 0)
}

#[test]
fn counting_and_zero_sized_sinks_give_identical_hits() {
    let scene = Scene::load("teapot-in-stadium").unwrap();
    for treelets in [false, true] {
        let (bvh, _) = built(&scene.triangles, &lbvh(treelets));
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
        }
    }
}

#[test]
fn the_report_gives_each_phase_and_each_round() {
    let tris = soup(5000, 1);
    let (_, report) = built(
        &tris,
        &BuildParams {
            treelet_rounds: 2,
            ..lbvh(true)
        },
    );
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
            "Morton codes",
            "radix sort",
            "radix tree",
            "treelet round 1",
            "treelet round 2",
            "collapse"
        ]
    );
    let rows = report.rows();
    for key in [
        "treelet size n",
        "time: radix sort",
        "SAH cost before treelets",
        "SAH cost after round 2",
    ] {
        assert!(rows.iter().any(|(k, _)| k == key), "{key} in {rows:?}");
    }
    let (_, plain) = built(&tris, &lbvh(false));
    assert!(plain.phases.sah_after_round.is_empty());
    assert!(!plain.rows().iter().any(|(k, _)| k.starts_with("treelet")));
}

#[test]
fn bad_treelet_parameters_are_errors() {
    let tris = soup(10, 1);
    for (p, want) in [
        (
            BuildParams {
                treelet_size: 4,
                ..lbvh(true)
            },
            BuildError::TreeletSize(4),
        ),
        (
            BuildParams {
                treelet_size: 10,
                ..lbvh(true)
            },
            BuildError::TreeletSize(10),
        ),
        (
            BuildParams {
                treelet_rounds: 17,
                ..lbvh(true)
            },
            BuildError::TreeletRounds(17),
        ),
    ] {
        let err = build(&tris, &p).unwrap_err();
        assert_eq!(err, want);
        assert!(err.to_string().contains("treelet"), "{err}");
    }
}

#[test]
fn both_builders_match_brute_force_on_the_shared_meshes() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared meshes");
        return;
    };
    for file in ["sponza.obj", "sibenik.obj", "conference.obj"] {
        let scene = bvhlab::scene::load_obj(&dir.join(file)).expect("shared mesh loads");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 150, 42);
        rays.extend(common::view_rays(&scene, 8, 6));
        for treelets in [false, true] {
            let (mut bvh, _) = built(&scene.triangles, &lbvh(treelets));
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{file} {treelets}"));
        }
    }
}

#[test]
fn nested_triangles_keep_the_depth_bound() {
    // Each triangle 1.15 times the size of the previous, all at one corner: the SAH's best
    // tree peels them off one by one, a chain far deeper than a traversal stack. Treelet
    // restructuring must stop short of the depth bound (validate checks it).
    let tris: Vec<Triangle> = (0..300)
        .map(|i| {
            let s = 1.15f32.powi(i);
            Triangle::new(Vec3::ZERO, Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, s, s))
        })
        .collect();
    let brute = BruteForce::new(&tris, false);
    let rays = rays(&bounds(&tris), 300, 8);
    for max_leaf_size in [1, 2] {
        let p = BuildParams {
            max_leaf_size,
            treelet_rounds: 16,
            ..lbvh(true)
        };
        let (mut bvh, report) = built(&tris, &p);
        let before = report.phases.sah_before_rounds.expect("reported");
        assert!(report.tree.sah_cost < before);
        let depth = report.tree.max_leaf_depth as usize;
        assert!(
            (MAX_DEPTH - 5..=MAX_DEPTH).contains(&depth),
            "the chain grows to the bound and stops there: depth {depth}"
        );
        assert_matches_brute_force(&mut bvh, &brute, &rays, "nested");
    }
}
