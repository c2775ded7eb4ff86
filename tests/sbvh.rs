//! Spatial splits (SBVH) and pre-splitting: triangle references are duplicated, triangles
//! never. Every tree is valid (each triangle reachable, each box around its subtree, the
//! references of a split triangle covering it), gives brute force's closest and any hits on
//! random soups, every built-in scene and the degenerate inputs, and so do its wide collapses
//! and its refits; the split budget caps the duplicates, a zero budget gives binned SAH's
//! tree exactly, and the build is the same on 1 and 2 threads.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::refit::RefitIndex;
use bvhlab::accel::bvh::wide::CollapseParams;
use bvhlab::accel::bvh::{BuildError, BuildParams, Strategy, TraversalOrder, WideBvh, build};
use bvhlab::accel::{Accel, BruteForce, Bvh, Counters, Hit, NoStats};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, rays, same_hit, soup};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn sbvh() -> BuildParams {
    BuildParams::with_strategy(Strategy::Sbvh)
}

fn presplit(strategy: Strategy, budget: f32) -> BuildParams {
    BuildParams {
        presplit: budget,
        ..BuildParams::with_strategy(strategy)
    }
}

/// SBVH at several thresholds, budgets and leaf sizes, and every builder that takes
/// pre-splits with a small and a large budget.
fn split_params() -> Vec<BuildParams> {
    let mut out = vec![sbvh()];
    for (split_alpha, split_budget, max_leaf_size) in [
        (0.0, 4.0, 1),
        (0.0, 0.05, 4),
        (1e-3, 1.0, 8),
        (1e-5, 0.3, 16),
    ] {
        out.push(BuildParams {
            split_alpha,
            split_budget,
            max_leaf_size,
            ..sbvh()
        });
    }
    out.push(BuildParams {
        buckets: 4,
        c_trav: 0.0,
        ..sbvh()
    });
    for overlap_penalty in [1.0, 16.0] {
        out.push(BuildParams {
            overlap_penalty,
            split_budget: 4.0,
            ..sbvh()
        });
    }
    for strategy in [Strategy::Lbvh, Strategy::LbvhTreelet, Strategy::SahBinned] {
        for budget in [0.3, 2.0] {
            out.push(presplit(strategy, budget));
        }
    }
    out
}

fn built(tris: &[Triangle], p: &BuildParams) -> Bvh {
    let (bvh, report) = build(tris, p).expect("valid parameters");
    bvh.validate(p.max_leaf_size)
        .unwrap_or_else(|e| panic!("{p:?}: {e}"));
    assert_eq!(report.triangles, tris.len());
    assert_eq!(report.references, bvh.prim_indices.len());
    assert_eq!(bvh.triangle_count, tris.len());
    if p.strategy == Strategy::Sbvh {
        let budget = (p.split_budget as f64 * tris.len() as f64) as usize;
        assert!(
            bvh.duplicated_references() <= budget,
            "{} duplicates over a budget of {budget}",
            bvh.duplicated_references()
        );
    }
    bvh
}

fn bits(h: Option<Hit>) -> Option<(u64, u32, u32, u32)> {
    h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
}

/// Closest and any hits of `bvh` in both orders, one ray at a time and in packets, and of
/// its BVH4 and BVH8 collapses, equal brute force on `rays`.
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
            let counted = bvh.closest_hit::<Watertight, _>(ray, &mut Counters::default());
            assert_eq!(bits(counted), bits(got), "{what}: counting changed ray {i}");
            assert_eq!(
                bvh.any_hit::<Watertight, _>(ray, &mut NoStats),
                want.is_some(),
                "{what} {order:?}: any hit of ray {i}"
            );
        }
    }
    bvh.order = TraversalOrder::FrontToBack;
    let mut packed = vec![None; rays.len()];
    bvh.closest_hits::<Watertight>(rays, &mut packed);
    for (i, (got, want)) in packed.iter().zip(&expected).enumerate() {
        assert!(same_hit(*got, *want), "{what}: packet ray {i}");
    }
    let wide4 = WideBvh::<4>::collapse(bvh, &CollapseParams::default());
    let wide8 = WideBvh::<8>::collapse(bvh, &CollapseParams::default());
    wide4
        .validate()
        .unwrap_or_else(|e| panic!("{what}: BVH4: {e}"));
    wide8
        .validate()
        .unwrap_or_else(|e| panic!("{what}: BVH8: {e}"));
    for (i, ray) in rays.iter().enumerate() {
        let want = bits(bvh.closest_hit::<Watertight, _>(ray, &mut NoStats));
        assert_eq!(
            bits(wide4.closest_hit::<Watertight, _>(ray, &mut NoStats)),
            want,
            "{what}: BVH4 ray {i}"
        );
        assert_eq!(
            bits(wide8.closest_hit::<Watertight, _>(ray, &mut NoStats)),
            want,
            "{what}: BVH8 ray {i}"
        );
        assert_eq!(
            wide8.any_hit::<Watertight, _>(ray, &mut NoStats),
            want.is_some(),
            "{what}: BVH8 any hit of ray {i}"
        );
    }
}

#[test]
fn every_parameter_set_matches_brute_force_on_random_soups() {
    for (seed, n) in [(1, 1), (2, 2), (3, 9), (4, 300), (5, 5000)] {
        let tris = soup(n, seed);
        let brute = BruteForce::new(&tris, false);
        let rays = rays(&bounds(&tris), 400, seed + 50);
        for p in split_params() {
            let mut bvh = built(&tris, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("soup {n} {p:?}"));
        }
    }
}

#[test]
fn every_builder_with_split_references_matches_brute_force_on_every_builtin_scene() {
    for name in common::SMALL_BUILTINS {
        let scene = Scene::load(name).expect("built-in scene");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 300, 7);
        rays.extend(common::view_rays(&scene, 16, 12));
        for p in [
            sbvh(),
            presplit(Strategy::LbvhTreelet, 0.3),
            presplit(Strategy::Lbvh, 0.3),
            presplit(Strategy::SahBinned, 0.3),
        ] {
            let mut bvh = built(&scene.triangles, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{name} {p:?}"));
        }
    }
}

#[test]
fn spatial_splits_duplicate_references_where_boxes_overlap() {
    // The rotated walls: every slab's box covers its neighbours, which only cutting the
    // references can undo. The axis-aligned walls need almost none.
    let rotated = Scene::load("walls-rotated").unwrap().triangles;
    let binned = built(&rotated, &BuildParams::default());
    let split = built(&rotated, &sbvh());
    assert!(split.duplicated_references() > rotated.len() / 10);
    assert!(
        split.sah_cost(1.0, 1.0) < 0.9 * binned.sah_cost(1.0, 1.0),
        "SBVH {} against binned SAH {}",
        split.sah_cost(1.0, 1.0),
        binned.sah_cost(1.0, 1.0)
    );
    // Pre-splitting finds the same walls' wasted area, given enough pieces per slab.
    let pre = built(&rotated, &presplit(Strategy::LbvhTreelet, 3.0));
    let plain = built(&rotated, &BuildParams::with_strategy(Strategy::LbvhTreelet));
    assert!(pre.duplicated_references() > 0);
    assert!(pre.sah_cost(1.0, 1.0) < plain.sah_cost(1.0, 1.0));
}

/// The overlap penalty κ weighs an object split against a spatial one by the overlap of its
/// children: on the rotated walls, where the plain SAH keeps overlapping object splits near
/// the root, it takes spatial splits instead, and the whole tree's SAH cost drops with the
/// overlap (the greedy choice was not the cheapest tree). With no spatial split possible
/// (budget 0) it changes nothing.
#[test]
fn the_overlap_penalty_takes_spatial_splits_where_object_splits_overlap() {
    let tris = Scene::load("walls-rotated").unwrap().triangles;
    let with = |overlap_penalty: f32, split_budget: f32| {
        let p = BuildParams {
            overlap_penalty,
            split_budget,
            ..sbvh()
        };
        let (bvh, report) = build(&tris, &p).unwrap();
        bvh.validate(p.max_leaf_size).unwrap();
        let (splits, _) = report.phases.spatial_splits.expect("an SBVH report");
        (bvh, splits)
    };
    let (plain, plain_splits) = with(0.0, 16.0);
    let (penalised, penalised_splits) = with(1.0, 16.0);
    assert!(
        penalised_splits > 2 * plain_splits,
        "{penalised_splits} spatial splits against {plain_splits}"
    );
    let (sah_plain, sah_penalised) = (plain.sah_cost(1.0, 1.0), penalised.sah_cost(1.0, 1.0));
    assert!(
        sah_penalised < 0.9 * sah_plain,
        "SAH cost {sah_penalised} against {sah_plain}"
    );
    // The view's primary rays visit far fewer nodes and test far fewer triangles.
    let camera = Scene::load("walls-rotated").unwrap().camera();
    let cost = |bvh: &Bvh| {
        let mut c = Counters::default();
        let rays = camera.rays(64, 48);
        for y in 0..48 {
            for x in 0..64 {
                bvh.closest_hit::<Watertight, _>(&rays.pixel_center(x, y), &mut c);
            }
        }
        c.nodes_visited + c.triangle_tests
    };
    assert!(
        3 * cost(&penalised) < 2 * cost(&plain),
        "{} against {} steps",
        cost(&penalised),
        cost(&plain)
    );
    // Without a budget there is no spatial split to prefer: binned SAH's tree either way.
    assert_eq!(with(4.0, 0.0).0.nodes, with(0.0, 0.0).0.nodes);
    let brute = BruteForce::new(&tris, true);
    let mut penalised = penalised;
    let rays = rays(&bounds(&tris), 300, 5);
    assert_matches_brute_force(&mut penalised, &brute, &rays, "walls-rotated, κ = 1");
}

#[test]
fn a_zero_budget_is_binned_sah_exactly() {
    for tris in [
        soup(4000, 9),
        Scene::load("walls-rotated").unwrap().triangles,
        Scene::load("same-centroid:600").unwrap().triangles,
    ] {
        for max_leaf_size in [1, 8] {
            let binned = BuildParams {
                max_leaf_size,
                ..BuildParams::default()
            };
            let no_splits = BuildParams {
                split_budget: 0.0,
                strategy: Strategy::Sbvh,
                ..binned
            };
            let a = built(&tris, &binned);
            let b = built(&tris, &no_splits);
            assert_eq!(a.nodes, b.nodes, "{} triangles", tris.len());
            assert_eq!(a.prim_indices, b.prim_indices);
            // And a zero pre-split budget changes nothing either.
            let c = built(&tris, &presplit(Strategy::SahBinned, 0.0));
            assert_eq!(
                c.prim_indices,
                built(&tris, &BuildParams::default()).prim_indices
            );
        }
    }
}

#[test]
fn one_and_two_threads_build_the_same_tree() {
    let pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool")
    };
    let inputs = [
        soup(60_000, 11),
        Scene::load("teapot-in-stadium").unwrap().triangles,
    ];
    for tris in &inputs {
        for p in [sbvh(), presplit(Strategy::LbvhTreelet, 0.3)] {
            let a = pool(1).install(|| build(tris, &p).unwrap().0);
            let b = pool(2).install(|| build(tris, &p).unwrap().0);
            assert_eq!(a.nodes, b.nodes, "{} triangles, {p:?}", tris.len());
            assert_eq!(a.prim_indices, b.prim_indices);
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
        for p in split_params() {
            let mut bvh = built(&tris, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{what} {p:?}"));
        }
    }
}

#[test]
fn validation_finds_a_split_triangle_its_boxes_do_not_cover() {
    // One reference per leaf, so a leaf box bounds exactly one piece of a triangle.
    let tris = Scene::load("walls-rotated").unwrap().triangles;
    let p = BuildParams {
        max_leaf_size: 1,
        ..sbvh()
    };
    let bvh = built(&tris, &p);
    let mut references = vec![0; tris.len()];
    for &t in &bvh.prim_indices {
        references[t as usize] += 1;
    }
    let leaf = (0..bvh.nodes.len())
        .find(|&i| {
            let n = bvh.nodes[i];
            n.is_leaf() && references[bvh.prim_indices[n.prim_range().start] as usize] > 1
        })
        .expect("a leaf holding a piece of a split triangle");
    // Shrink that piece's box to its lowest corner: the piece is left uncovered.
    let mut broken = bvh.clone();
    let b = broken.nodes[leaf].bounds();
    broken.nodes[leaf].set_bounds(Aabb::new(b.min, b.min));
    let err = broken.validate(1).expect_err("an uncovered piece");
    assert!(err.contains("lies in none of its"), "{err}");
}

#[test]
fn refits_of_split_trees_stay_valid_and_match_brute_force() {
    let mut rng = Rng::new(5);
    for p in [sbvh(), presplit(Strategy::LbvhTreelet, 1.0)] {
        let mut tris = Scene::load("walls-rotated").unwrap().triangles;
        let mut full = built(&tris, &p);
        assert!(full.duplicated_references() > 0);
        let mut partial = full.clone();
        let mut index = RefitIndex::new(&partial);
        let mut wide = WideBvh::<4>::collapse(&full, &CollapseParams::default());
        let mut wide_index = RefitIndex::for_wide(&wide);
        for round in 0..3 {
            let moved: Vec<u32> = (0..50).map(|_| rng.below(tris.len()) as u32).collect();
            let offset = rng.unit_vector() * rng.range(0.0, 2.0);
            for &t in &moved {
                for v in &mut tris[t as usize].v {
                    *v += offset;
                }
            }
            full.refit(&tris, 1.0, 1.0).unwrap();
            partial
                .refit_moved(&mut index, &tris, &moved, 1.0, 1.0)
                .unwrap();
            wide.refit_moved(&mut wide_index, &tris, &moved, 1.0, 1.0)
                .unwrap();
            full.validate(p.max_leaf_size).unwrap();
            partial.validate(p.max_leaf_size).unwrap();
            wide.validate()
                .unwrap_or_else(|e| panic!("BVH4 round {round}: {e}"));
            let brute = BruteForce::new(&tris, false);
            let rays = rays(&bounds(&tris), 500, round);
            assert_matches_brute_force(&mut partial, &brute, &rays, &format!("refit {round}"));
            for ray in &rays {
                assert!(same_hit(
                    wide.closest_hit::<Watertight, _>(ray, &mut NoStats),
                    brute.closest_hit::<Watertight, _>(ray, &mut NoStats)
                ));
            }
        }
        // The wrong triangle count is refused, the tree untouched.
        let before = full.nodes.clone();
        assert!(full.refit(&tris[1..], 1.0, 1.0).is_err());
        assert_eq!(full.nodes, before);
    }
}

#[test]
fn the_report_counts_duplicated_references() {
    let tris = Scene::load("walls-rotated").unwrap().triangles;
    let (bvh, report) = build(&tris, &sbvh()).unwrap();
    assert_eq!(report.duplicated_references(), bvh.duplicated_references());
    let rows = report.rows();
    let row = |key: &str| {
        rows.iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| panic!("{key} in {rows:?}"))
    };
    assert!(row("duplicated references").starts_with(&report.duplicated_references().to_string()));
    assert!(row("spatial splits").parse::<usize>().unwrap() > 0);
    row("overlap threshold α");
    assert_eq!(row("overlap penalty κ"), "0");
    row("split budget");
    assert_eq!(row("buckets B"), "16");
    // Where the build's time went: the recursion (with the clipping) and the leaf order.
    let phase = |name: &str| report.phases.times.iter().any(|(p, _)| p == name);
    assert!(phase("splits (whole recursion)") && phase("leaf order"));
    let (_, pre) = build(&tris, &presplit(Strategy::Lbvh, 0.5)).unwrap();
    assert!(pre.duplicated_references() > 0);
    assert!(pre.phases.times.iter().any(|(p, _)| p == "pre-splitting"));
}

#[test]
fn bad_split_parameters_are_errors() {
    let tris = soup(10, 1);
    for p in [
        BuildParams {
            split_budget: -0.5,
            ..sbvh()
        },
        BuildParams {
            split_budget: f32::NAN,
            ..sbvh()
        },
        BuildParams {
            split_alpha: 2.0,
            ..sbvh()
        },
        BuildParams {
            overlap_penalty: -1.0,
            ..sbvh()
        },
        BuildParams {
            overlap_penalty: 17.0,
            ..sbvh()
        },
        BuildParams {
            overlap_penalty: f32::NAN,
            ..sbvh()
        },
        presplit(Strategy::Lbvh, 17.0),
        presplit(Strategy::Lbvh, f32::INFINITY),
    ] {
        let err = build(&tris, &p).unwrap_err();
        assert!(matches!(err, BuildError::Fraction { .. }), "{p:?}: {err}");
    }
}

#[test]
fn split_builders_match_brute_force_on_the_shared_meshes() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared meshes");
        return;
    };
    for file in ["sponza.obj", "sibenik.obj", "conference.obj"] {
        let scene = bvhlab::scene::load_obj(&dir.join(file)).expect("shared mesh loads");
        let brute = BruteForce::new(&scene.triangles, true);
        let mut rays = rays(&scene.bounds(), 150, 42);
        rays.extend(common::view_rays(&scene, 8, 6));
        for p in [sbvh(), presplit(Strategy::LbvhTreelet, 0.3)] {
            let mut bvh = built(&scene.triangles, &p);
            assert_matches_brute_force(&mut bvh, &brute, &rays, &format!("{file} {p:?}"));
        }
    }
}

/// The stress suite's scene part through the BVH built by every builder that splits
/// references, and plain LBVH: no leaks at shared edges and vertices, no mismatch against the
/// f64 reference, no shadow ray hitting the surface it leaves.
#[test]
fn the_stress_suite_zeros_hold_through_every_split_builder() {
    use bvhlab::accel::{AccelKind, StructureParams};
    use bvhlab::bench::stress::suite::{self, StressConfig};
    let scenes: Vec<Scene> = ["cornell", "sphere:5000", "walls-rotated:300"]
        .iter()
        .map(|s| Scene::load(s).unwrap())
        .collect();
    for bvh in [
        sbvh(),
        presplit(Strategy::LbvhTreelet, 0.3),
        presplit(Strategy::SahBinned, 0.3),
        BuildParams::with_strategy(Strategy::Lbvh),
    ] {
        let cfg = StressConfig {
            scene_rays: 20_000,
            structure: StructureParams {
                bvh,
                ..StructureParams::of_kind(AccelKind::Bvh)
            },
            ..StressConfig::tests()
        };
        for scene in &scenes {
            let r = suite::run_scene(scene, &cfg).unwrap();
            // Watertight and f64 (index 1 is Möller–Trumbore, only measured).
            for k in [0, 2] {
                let what = format!("{bvh:?} on {}", r.name);
                assert_eq!(r.crossings[k].leaks(), 0, "{what}: {:?}", r.crossings[k]);
                assert_eq!(r.agreement[k].mismatches, 0, "{what}");
                assert_eq!(r.shadow[k].self_hits(), 0, "{what}");
            }
        }
    }
}

#[test]
fn wide_reports_count_split_references() {
    // A wide tree's leaves hold the BVH2's references, padding lanes aside: the report's
    // references per triangle must show the spatial splits' duplicates.
    use bvhlab::accel::structure::{self, AccelKind, StructureParams};
    let rotated = Scene::load("walls-rotated").unwrap().triangles;
    let of = |kind| {
        let params = StructureParams {
            bvh: sbvh(),
            ..StructureParams::of_kind(kind)
        };
        structure::build(&rotated, &params, &Default::default())
            .unwrap()
            .report
    };
    let bvh2 = of(AccelKind::Bvh);
    assert!(bvh2.references > rotated.len(), "{bvh2:?}");
    for kind in [AccelKind::Bvh4, AccelKind::Bvh8] {
        assert_eq!(of(kind).references, bvh2.references, "{kind:?}");
    }
}
