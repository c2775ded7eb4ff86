//! Ray replay: the recorded steps of a pixel's ray re-create the frame's counters for that
//! pixel (nodes visited, box tests, triangle tests) and its closest hit, exactly, for the
//! primary and the shadow ray, on every built-in scene and every structure; and
//! `bvhlab replay` prints them, as text or as one JSON object of the documented shape.

use bvhlab_testkit as common;

use bvhlab::accel::Outline;
use bvhlab::accel::replay::{Level, Step, Visited};
use bvhlab::accel::structure::{self, AccelKind, Structure, StructureParams};
use bvhlab::accel::{Strategy, TraversalOrder};
use bvhlab::geometry::Watertight;
use bvhlab::geometry::slab::Slabs;
use bvhlab::render::node_visits::{TallySize, TriangleCounts, node_visits, tally};
use bvhlab::render::replay::{Replay, ReplayError, replay_pixel};
use bvhlab::render::{self, RayKind, RenderSettings};
use bvhlab::scene::island::{self, Detail};
use bvhlab::scene::{Scene, builtin};
use common::{Rng, SMALL_BUILTINS};
use std::process::Command;

const W: u32 = 40;
const H: u32 = 30;

/// Every structure, the BVH2 once per builder and in naive order, the spatial structures
/// with mailboxing off too.
fn configurations() -> Vec<(String, StructureParams)> {
    let mut out = Vec::new();
    for kind in AccelKind::ALL {
        out.push((kind.label().to_string(), StructureParams::of_kind(kind)));
        if kind.is_spatial() {
            let mut p = StructureParams::of_kind(kind);
            p.mailbox = false;
            out.push((format!("{} without mailbox", kind.label()), p));
        }
        if kind.is_bvh() || kind == AccelKind::TwoLevel {
            let mut p = StructureParams::of_kind(kind);
            p.order = TraversalOrder::Naive;
            out.push((format!("{} naive order", kind.label()), p));
        }
    }
    for strategy in Strategy::ALL {
        let mut p = StructureParams::of_kind(AccelKind::Bvh);
        p.bvh.strategy = strategy;
        out.push((format!("bvh {}", strategy.label()), p));
    }
    out
}

/// The pixel's replay against what the frame counted and found for it.
fn assert_replay_matches_frame(
    s: &Structure,
    outline: &Outline,
    scene: &Scene,
    settings: &RenderSettings,
    frame: &render::Frame,
    (x, y): (u32, u32),
    what: &str,
) {
    let sample = frame.sample(x, y).expect("pixel in the frame");
    let check = |replay: &Replay, counted: &bvhlab::accel::Counters, kind: &str| {
        let what = format!("{what}, pixel ({x}, {y}), {kind}");
        assert_eq!(&replay.counters, counted, "{what}: recorder counts");
        let from_steps = replay.counters_from_steps();
        assert_eq!(
            (
                from_steps.nodes_visited,
                from_steps.box_tests,
                from_steps.triangle_tests
            ),
            (
                counted.nodes_visited,
                counted.box_tests,
                counted.triangle_tests
            ),
            "{what}: the steps re-create the counters"
        );
        assert_eq!(replay.visit_count() as u32, counted.nodes_visited, "{what}");
        let visit_json = replay
            .to_json()
            .get("steps")
            .and_then(|s| s.as_array().cloned())
            .unwrap_or_default()
            .iter()
            .filter(|s| s["kind"] == "visit")
            .count();
        assert_eq!(
            visit_json as u32, counted.nodes_visited,
            "{what}: JSON visits"
        );
        assert_child_boxes_are_the_visited_boxes(replay, &what);
        assert_the_path_is_the_visits_in_the_outline(s, outline, replay, &what);
    };
    let primary =
        replay_pixel::<Watertight>(s, scene, settings, (x, y), RayKind::Primary).expect(what);
    check(&primary, &sample.primary, "primary ray");
    let want = sample
        .is_hit()
        .then_some((sample.triangle, sample.t.to_bits()));
    let got = primary.hit.map(|h| (h.triangle, h.t.to_bits()));
    assert_eq!(got, want, "{what}, pixel ({x}, {y}): closest hit");
    match replay_pixel::<Watertight>(s, scene, settings, (x, y), RayKind::Shadow) {
        Ok(shadow) => {
            assert!(sample.is_hit(), "{what}: a shadow ray for a missed pixel");
            check(&shadow, &sample.shadow, "shadow ray");
            assert_eq!(
                shadow.hit.is_some(),
                !sample.lit,
                "{what}, pixel ({x}, {y}): shadow ray occluded"
            );
            // Any hit stops at its first hit: nothing is tested after it, but the rest of
            // its block of four in a wide leaf, tested by the same instruction.
            let tests: Vec<&Step> = shadow
                .steps
                .iter()
                .filter(|s| s.is_triangle_test())
                .collect();
            if let Some(first_hit) = tests
                .iter()
                .position(|s| matches!(s, Step::Triangle { t: Some(_), .. }))
            {
                let after = tests.len() - 1 - first_hit;
                let wide = ["bvh4", "bvh8", "two-level"]
                    .iter()
                    .any(|w| what.contains(w));
                let block_rest = if wide { 3 } else { 0 };
                assert!(after <= block_rest, "{what}: tested {after} past a hit");
            }
        }
        Err(ReplayError::NoShadowRay { .. }) => assert!(!sample.is_hit(), "{what}"),
        Err(e) => panic!("{what}: {e}"),
    }
}

/// The box a children step gives each child (drawn by the replay's slab picture of a
/// missed child) is the box that child's visit shows, bit for bit, and an entered child's
/// slab test meets. One-level steps only: a BLAS's node numbers repeat across instances;
/// a wide BVH names a leaf by its first triangle slot, so a leaf and a node may share one.
fn assert_child_boxes_are_the_visited_boxes(replay: &Replay, what: &str) {
    let mut tested = std::collections::HashMap::new();
    for step in &replay.steps {
        match step {
            Step::Children { children, .. } | Step::Octants { children } => {
                for c in children {
                    tested.insert((c.node, c.leaf), c.bounds);
                    if c.entry.is_some() {
                        let s = Slabs::of(&replay.ray, &c.bounds);
                        let slack = 1e-4 * (s.exit.abs() + 1.0);
                        assert!(
                            s.enter <= s.exit + slack,
                            "{what}: entered child {}",
                            c.node
                        );
                    }
                }
            }
            Step::Visit {
                node,
                what: visited,
                bounds,
                level: Level::Single,
                ..
            } => {
                if let Some(b) = tested.get(&(*node, *visited == Visited::Leaf)) {
                    assert_eq!(b, bounds, "{what}: child {node}'s box");
                }
            }
            _ => {}
        }
    }
}

/// The hierarchy diagram's path of a replay: each visit of the outline's level is the
/// outline node with the visit's box, bit for bit, entered below a node visited before it
/// (the root first); other visits (a BLAS's) and structures without a hierarchy have none.
fn assert_the_path_is_the_visits_in_the_outline(
    s: &Structure,
    outline: &Outline,
    replay: &Replay,
    what: &str,
) {
    assert_eq!(replay.outline_nodes.len(), replay.visits.len(), "{what}");
    let hierarchy = !matches!(s, Structure::Grid(_) | Structure::BruteForce(_));
    let shown = if matches!(s, Structure::TwoLevel(_)) {
        Level::Top
    } else {
        Level::Single
    };
    let mut seen = std::collections::HashSet::new();
    for (&i, &node) in replay.visits.iter().zip(&replay.outline_nodes) {
        let Step::Visit { bounds, level, .. } = replay.steps[i] else {
            panic!("{what}: visit {i} is not a visit step");
        };
        if !hierarchy || level != shown {
            assert_eq!(node, None, "{what}: visit {i} is not in the outline");
            continue;
        }
        let node = node.unwrap_or_else(|| panic!("{what}: visit {i} has no outline node"));
        let n = &outline.nodes[node as usize];
        assert_eq!(
            n.bounds, bounds,
            "{what}: visit {i}, outline node {node}'s box"
        );
        assert!(
            node == 0 && seen.is_empty() || seen.contains(&n.parent),
            "{what}: outline node {node} visited before its parent {}",
            n.parent
        );
        // The words name the diagram's number where the structure's own differs.
        let Step::Visit { node: own, .. } = replay.steps[i] else {
            unreachable!()
        };
        let named = format!("(node {node} in the diagram and the walk)");
        assert_eq!(
            replay.describe(i).contains(&named),
            own != node,
            "{what}: {}",
            replay.describe(i)
        );
        seen.insert(node);
    }
    if hierarchy && replay.visit_count() > 0 {
        assert!(!seen.is_empty(), "{what}: a path with no node");
    }
}

/// Random pixels (and the centre, which hits on every built-in view) of a small frame.
fn check_scene(scene: &Scene, configs: &[(String, StructureParams)], seed: u64) {
    check_view(
        scene,
        &RenderSettings::for_scene(scene, W, H),
        configs,
        seed,
    );
}

fn check_view(
    scene: &Scene,
    settings: &RenderSettings,
    configs: &[(String, StructureParams)],
    seed: u64,
) {
    let settings = *settings;
    let mut rng = Rng::new(seed);
    let mut pixels = vec![(W / 2, H / 2)];
    pixels.extend((0..8).map(|_| (rng.below(W as usize) as u32, rng.below(H as usize) as u32)));
    for (name, params) in configs {
        let built = structure::build_scene(scene, params, &Default::default())
            .unwrap_or_else(|e| panic!("{}: {name}: {e}", scene.name));
        let frame = render::trace(&built.structure, scene, &settings);
        let outline = built.structure.outline();
        for &pixel in &pixels {
            let what = format!("{} {name}", scene.name);
            let s = &built.structure;
            assert_replay_matches_frame(s, &outline, scene, &settings, &frame, pixel, &what);
        }
    }
}

#[test]
fn replays_recreate_the_counters_and_hits_of_every_structure_on_every_builtin_scene() {
    let configs = configurations();
    for (k, spec) in SMALL_BUILTINS.iter().enumerate() {
        let scene = builtin::by_name(spec).unwrap().unwrap();
        check_scene(&scene, &configs, 100 + k as u64);
    }
}

/// The diagram's measured visits: per outline node, over every pixel's primary or shadow
/// ray, summing to the frame's counted node visits (the top level's, for two levels).
#[test]
fn node_visits_of_a_frame_sum_to_the_frames_counted_visits() {
    let scene = builtin::by_name("teapot-in-stadium").unwrap().unwrap();
    let settings = RenderSettings::for_scene(&scene, W, H);
    for kind in AccelKind::ALL {
        let params = StructureParams::of_kind(kind);
        let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
        let s = &built.structure;
        let frame = render::trace(s, &scene, &settings);
        let nodes = s.outline().nodes.len();
        for rays in [RayKind::Primary, RayKind::Shadow] {
            let v =
                node_visits::<Watertight>(s, &scene, &settings, rays, 1, nodes, &|| false).unwrap();
            let mut counted = 0u64;
            let mut traced = 0u64;
            for y in 0..H {
                for x in 0..W {
                    let sample = frame.sample(x, y).unwrap();
                    let c = match rays {
                        RayKind::Primary => sample.primary,
                        RayKind::Shadow if sample.is_hit() => sample.shadow,
                        RayKind::Shadow => continue,
                    };
                    traced += 1;
                    counted += u64::from(match s {
                        Structure::TwoLevel(_) => c.top_nodes_visited,
                        Structure::Grid(_) | Structure::BruteForce(_) => 0,
                        _ => c.nodes_visited,
                    });
                }
            }
            let what = format!("{} {rays:?}", kind.label());
            assert_eq!(v.per_node.len(), nodes, "{what}");
            assert_eq!(v.rays, traced, "{what}: rays");
            assert_eq!(v.total(), counted, "{what}: visits");
            if !matches!(s, Structure::Grid(_) | Structure::BruteForce(_)) {
                assert!(v.per_node[0] > 0, "{what}: the root is visited");
            }
        }
        // Every other pixel each way: a quarter of the rays; and given up when asked.
        let quarter =
            node_visits::<Watertight>(s, &scene, &settings, RayKind::Primary, 2, nodes, &|| false);
        assert_eq!(
            quarter.unwrap().rays,
            u64::from(W.div_ceil(2) * H.div_ceil(2))
        );
        let given_up =
            node_visits::<Watertight>(s, &scene, &settings, RayKind::Primary, 1, nodes, &|| true);
        assert!(given_up.is_none(), "{}", kind.label());
    }
}

/// The tests per triangle (the "tests per triangle" view) counted in the same pass as the
/// visits: summed over the triangles, the frame's counted triangle tests, on every
/// structure, for both kinds of ray; the visits as `node_visits` counts them.
#[test]
fn tests_per_triangle_of_a_frame_sum_to_the_frames_counted_triangle_tests() {
    let scene = builtin::by_name("teapot-in-stadium").unwrap().unwrap();
    let settings = RenderSettings::for_scene(&scene, W, H);
    let triangles = scene.placed_triangles();
    for kind in AccelKind::ALL {
        let mut params = StructureParams::of_kind(kind);
        // Repeated tests are tests too: without the mailbox a spatial structure makes them.
        params.mailbox = kind != AccelKind::Grid;
        let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
        let s = &built.structure;
        let frame = render::trace(s, &scene, &settings);
        let nodes = s.outline().nodes.len();
        for rays in [RayKind::Primary, RayKind::Shadow] {
            let size = TallySize { nodes, triangles };
            let t = tally::<Watertight>(s, &scene, &settings, rays, 1, size, &|| false).unwrap();
            let counted: u64 = frame
                .samples
                .iter()
                .filter(|x| rays == RayKind::Primary || x.is_hit())
                .map(|x| u64::from(x.counters(rays).triangle_tests))
                .sum();
            let what = format!("{} {rays:?}", kind.label());
            assert!(
                matches!(&t.per_triangle, TriangleCounts::Every(v) if v.len() == triangles),
                "{what}"
            );
            assert_eq!(t.per_triangle.total(), counted, "{what}: tests");
            assert!(counted > 0, "{what}");
            // Each triangle a primary ray hits was tested, under the scene's number (a
            // BLAS's own number would credit another).
            if rays == RayKind::Primary {
                for x in frame.samples.iter().filter(|x| x.is_hit()) {
                    assert!(t.per_triangle.get(x.triangle) > 0, "{what}: {}", x.triangle);
                }
            }
            let v = node_visits::<Watertight>(s, &scene, &settings, rays, 1, nodes, &|| false);
            assert_eq!(Some(t.per_node), v.map(|v| v.per_node), "{what}: visits");
        }
    }
}

/// A scene placing more triangles than are counted one by one (`EVERY_TRIANGLE_MAX`)
/// counts only the tested ones: the same sum, each hit triangle among them.
#[test]
fn tests_per_triangle_on_a_huge_placed_scene_count_only_the_tested() {
    let scene = builtin::by_name("island:2000").unwrap().unwrap();
    let triangles = scene.placed_triangles();
    assert!(triangles > bvhlab::render::node_visits::EVERY_TRIANGLE_MAX);
    let settings = RenderSettings::for_scene(&scene, W, H);
    let params = StructureParams::of_kind(AccelKind::TwoLevel);
    let built = structure::build_scene(&scene, &params, &Default::default()).unwrap();
    let s = &built.structure;
    let frame = render::trace(s, &scene, &settings);
    let size = TallySize {
        nodes: 0,
        triangles,
    };
    let t =
        tally::<Watertight>(s, &scene, &settings, RayKind::Primary, 1, size, &|| false).unwrap();
    let TriangleCounts::Tested(tested) = &t.per_triangle else {
        panic!("every triangle counted");
    };
    let counted: u64 = frame
        .samples
        .iter()
        .map(|x| u64::from(x.counters(RayKind::Primary).triangle_tests))
        .sum();
    assert_eq!(t.per_triangle.total(), counted);
    assert!(tested.len() as u64 == t.per_triangle.tested() && !tested.is_empty());
    for x in frame.samples.iter().filter(|x| x.is_hit()) {
        assert!(t.per_triangle.get(x.triangle) > 0, "{}", x.triangle);
    }
}

#[test]
fn replays_recreate_the_counters_inside_sponza() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared scenes");
        return;
    };
    let scene = Scene::load(dir.join("sponza.obj").to_str().unwrap()).unwrap();
    let mut settings = RenderSettings::for_scene(&scene, W, H);
    settings.camera.eye = glam::Vec3::new(-14.0, 3.0, 0.0);
    settings.camera.look_at = glam::Vec3::new(10.0, 5.0, 0.0);
    settings.light = glam::Vec3::new(0.0, 14.0, 0.0);
    let configs: Vec<_> = configurations()
        .into_iter()
        .filter(|(name, p)| !p.kind.is_brute_force() && !name.starts_with("bvh "))
        .collect();
    check_view(&scene, &settings, &configs, 3);
}

#[test]
fn replays_of_the_island_walk_the_tlas_then_each_instance_blas() {
    let scene = island::island(40, &Detail::SMALL);
    let two_level: Vec<_> = configurations()
        .into_iter()
        .filter(|(_, p)| p.kind == AccelKind::TwoLevel)
        .collect();
    check_scene(&scene, &two_level, 7);
    // The centre ray enters instances, and each BLAS visit follows an instance step.
    let built = structure::build_scene(&scene, &two_level[0].1, &Default::default()).unwrap();
    let settings = RenderSettings::for_scene(&scene, W, H);
    let replay = replay_pixel::<Watertight>(
        &built.structure,
        &scene,
        &settings,
        (W / 2, H / 2),
        RayKind::Primary,
    )
    .unwrap();
    let first_instance = replay
        .steps
        .iter()
        .position(|s| matches!(s, Step::Instance { .. }))
        .expect("the centre ray enters an instance");
    let first_blas = replay.steps.iter().position(|s| {
        matches!(
            s,
            Step::Visit {
                level: bvhlab::accel::replay::Level::Bottom,
                ..
            }
        )
    });
    assert!(first_blas.is_some_and(|b| b > first_instance));
}

#[test]
fn front_to_back_skips_nodes_that_start_beyond_the_best_hit() {
    // Walls one behind the other: the nearest hides the rest, whose nodes are popped and
    // skipped.
    let scene = builtin::by_name("walls").unwrap().unwrap();
    let built = structure::build_scene(
        &scene,
        &StructureParams::of_kind(AccelKind::Bvh),
        &Default::default(),
    )
    .unwrap();
    let settings = RenderSettings::for_scene(&scene, W, H);
    let skipped: usize = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|p| {
            let r = replay_pixel::<Watertight>(
                &built.structure,
                &scene,
                &settings,
                p,
                RayKind::Primary,
            )
            .unwrap();
            r.steps
                .iter()
                .filter(|s| match s {
                    Step::Skip { entry, best, .. } => entry > best,
                    _ => false,
                })
                .count()
        })
        .sum();
    assert!(skipped > 0, "no node was skipped on the walls");
}

#[test]
fn a_pixel_outside_the_image_is_an_error() {
    let scene = builtin::by_name("cornell").unwrap().unwrap();
    let built =
        structure::build_scene(&scene, &StructureParams::default(), &Default::default()).unwrap();
    let settings = RenderSettings::for_scene(&scene, W, H);
    let e = replay_pixel::<Watertight>(
        &built.structure,
        &scene,
        &settings,
        (W, 0),
        RayKind::Primary,
    )
    .unwrap_err();
    assert!(e.to_string().contains("outside"), "{e}");
}

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("bvhlab runs")
}

#[test]
fn the_replay_command_prints_the_documented_json() {
    for accel in ["bvh", "kdtree", "grid", "two-level"] {
        for shadow in [false, true] {
            let mut args = vec![
                "replay", "--scene", "cornell", "--pixel", "20,15", "--width", "40", "--height",
                "30", "--accel", accel, "--json",
            ];
            if shadow {
                args.push("--shadow");
            }
            let out = bvhlab(&args);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let json: serde_json::Value =
                serde_json::from_slice(&out.stdout).expect("one JSON object");
            let ray = &json["ray"];
            for key in ["origin", "direction"] {
                assert_eq!(ray[key].as_array().map(Vec::len), Some(3), "{accel} {key}");
            }
            // A primary ray has no end: +∞, which JSON writes as null.
            assert!(ray["tmin"].is_number() && (ray["tmax"].is_number() || ray["tmax"].is_null()));
            let steps = json["steps"].as_array().expect("steps");
            assert!(steps.iter().all(|s| s["kind"].is_string()));
            let visits = steps.iter().filter(|s| s["kind"] == "visit").count() as u64;
            let counters = &json["counters"];
            assert_eq!(counters["nodes_visited"].as_u64(), Some(visits), "{accel}");
            assert!(counters["box_tests"].is_u64() && counters["triangle_tests"].is_u64());
            let hit = &json["hit"];
            if !shadow {
                // The centre of the Cornell box hits its back wall.
                assert!(
                    hit["triangle"].is_u64() && hit["t"].is_number(),
                    "{accel}: {hit}"
                );
            } else {
                assert!(hit.is_null() || hit["triangle"].is_u64(), "{accel}: {hit}");
            }
        }
    }
}

#[test]
fn the_replay_command_prints_readable_steps_and_clear_errors() {
    let out = bvhlab(&[
        "replay", "--scene", "cornell", "--pixel", "20,15", "--width", "40", "--height", "30",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("visit 1: node 0"), "{text}");
    assert!(text.contains("test triangle"), "{text}");
    assert!(text.contains("nodes visited"), "{text}");
    for (args, says) in [
        (vec!["--pixel", "40,0"], "outside"),
        (vec!["--pixel", "1"], "x,y"),
        (vec!["--pixel", "a,b"], "x,y"),
    ] {
        let mut all = vec![
            "replay", "--scene", "cornell", "--width", "40", "--height", "30",
        ];
        all.extend(args);
        let out = bvhlab(&all);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
