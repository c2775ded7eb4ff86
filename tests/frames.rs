//! The app's frame pipeline: a full shaded frame is shown traced without counting (primary
//! rays in packets), and its counted pass follows. Both must show the same frame.

use bvhlab_testkit as common;

use bvhlab::accel::structure::{self, AccelKind, Structure, StructureParams};
use bvhlab::app::worker::{Command, Overlay, RenderJob, Reply, Worker};
use bvhlab::render::{Frame, Mode, RenderSettings, colorize, trace, trace_unless};
use bvhlab::scene::Scene;
use std::time::Duration;

const KINDS: [AccelKind; 5] = [
    AccelKind::Bvh,
    AccelKind::Bvh4,
    AccelKind::Bvh8,
    AccelKind::KdTree,
    AccelKind::TwoLevel,
];

/// Every pixel of `b` shows what the same pixel of `a` shows: the same hit, normal, colour,
/// light and shadow.
fn assert_same_pixels(a: &Frame, b: &Frame, what: &str) {
    assert_eq!(a.samples.len(), b.samples.len(), "{what}");
    for (i, (x, y)) in a.samples.iter().zip(&b.samples).enumerate() {
        assert_eq!(
            (x.t.to_bits(), x.triangle, x.lit, x.cos_light.to_bits()),
            (y.t.to_bits(), y.triangle, y.lit, y.cos_light.to_bits()),
            "{what}: pixel {i}"
        );
        assert_eq!(
            (x.normal, x.albedo),
            (y.normal, y.albedo),
            "{what}: pixel {i}"
        );
    }
}

/// The structure of `kind` over `scene`, with the default parameters.
fn built(scene: &Scene, kind: AccelKind) -> Structure {
    let params = StructureParams {
        kind,
        ..Default::default()
    };
    structure::build_scene(scene, &params, &Default::default())
        .unwrap()
        .structure
}

#[test]
fn an_uncounted_shaded_frame_is_the_counted_frame_pixel_for_pixel() {
    for name in ["cornell", "teapot-in-stadium", "walls-rotated", "island:12"] {
        let scene = Scene::load(name).unwrap();
        for kind in KINDS {
            let s = built(&scene, kind);
            let counted = RenderSettings::for_scene(&scene, 77, 45);
            let quick = RenderSettings {
                counters: false,
                ..counted
            };
            let (a, b) = (trace(&s, &scene, &counted), trace(&s, &scene, &quick));
            let what = format!("{name}, {}", kind.label());
            assert!(
                a.summary.primary_hits > 0,
                "{what}: the view sees the scene"
            );
            assert!(a.summary.counted() && !b.summary.counted(), "{what}");
            assert_same_pixels(&a, &b, &what);
            assert_eq!(
                (a.summary.primary_hits, a.summary.shadow_rays),
                (b.summary.primary_hits, b.summary.shadow_rays),
                "{what}"
            );
            assert_eq!(
                a.summary.shadow_occluded, b.summary.shadow_occluded,
                "{what}"
            );
            // Both come coloured from the trace, as colouring them afterwards would.
            let (image, _) = colorize(&a, Mode::Shaded, None);
            assert!(
                a.rgba == image && b.rgba == image,
                "{what}: the shaded image"
            );
        }
    }
}

/// On the shared meshes, from the views the frame times are measured from: every pixel's
/// shadow ray, traced in the packet of its tile, gives the single any-hit ray's lit flag.
#[test]
fn packet_shadow_rays_light_the_pixels_the_single_rays_light_on_real_scenes() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared scenes");
        return;
    };
    for (file, view) in [
        ("cornell-box.obj", None),
        ("sponza.obj", Some(([-14.0, 3.0, 0.0], [10.0, 5.0, 0.0]))),
        (
            "conference.obj",
            Some(([1500.0, 100.0, 80.0], [0.0, 400.0, 20.0])),
        ),
    ] {
        let scene = Scene::load(dir.join(file).to_str().unwrap()).unwrap();
        let mut counted = RenderSettings::for_scene(&scene, 160, 90);
        if let Some((eye, look)) = view {
            counted.camera.eye = eye.into();
            counted.camera.look_at = look.into();
        }
        let quick = RenderSettings {
            counters: false,
            ..counted
        };
        for kind in [AccelKind::Bvh, AccelKind::Bvh8] {
            let s = built(&scene, kind);
            let (a, b) = (trace(&s, &scene, &counted), trace(&s, &scene, &quick));
            let what = format!("{file}, {}", kind.label());
            assert!(a.summary.shadow_rays > 0, "{what}: the view sees the scene");
            assert_same_pixels(&a, &b, &what);
        }
    }
}

#[test]
fn a_frame_in_another_mode_comes_uncoloured_and_a_stopped_trace_gives_none() {
    let scene = Scene::load("cornell").unwrap();
    let s = built(&scene, StructureParams::default().kind);
    let settings = RenderSettings {
        mode: Mode::Normals,
        ..RenderSettings::for_scene(&scene, 40, 30)
    };
    assert!(trace(&s, &scene, &settings).rgba.is_empty());
    let watertight = |stop: &(dyn Fn() -> bool + Sync)| {
        trace_unless::<_, bvhlab::geometry::Watertight>(&s, &scene, &settings, stop)
    };
    assert!(watertight(&|| true).is_none());
    let whole = watertight(&|| false).expect("never stopped");
    assert_same_pixels(&whole, &trace(&s, &scene, &settings), "cornell");
}

fn job(scene: &Scene, mode: Mode, preview: bool) -> RenderJob {
    RenderJob {
        camera: scene.camera(),
        width: 64,
        height: 48,
        mode,
        heat_max: None,
        heat_style: Default::default(),
        overlay: Overlay::default(),
        preview,
        compare: None,
    }
}

/// The frames and counted passes among `replies`.
fn frames_and_counts(replies: Vec<Reply>) -> (Vec<Reply>, Vec<Reply>) {
    replies
        .into_iter()
        .filter(|r| matches!(r, Reply::Frame(_) | Reply::Counted { .. }))
        .partition(|r| matches!(r, Reply::Frame(_)))
}

/// Loads `spec` in the worker and waits for it: the loaded scene.
fn load(worker: &mut Worker, spec: &str) -> std::sync::Arc<bvhlab::scene::Scene> {
    worker.send(Command::Load(spec.into()));
    worker
        .wait_idle(Duration::from_secs(120))
        .into_iter()
        .find_map(|r| match r {
            Reply::Loaded { scene, .. } => Some(scene),
            _ => None,
        })
        .expect("the scene loads")
}

#[test]
fn the_worker_shows_a_full_shaded_frame_first_and_its_counts_after() {
    let mut worker = Worker::spawn(|| {});
    let wait = Duration::from_secs(120);
    let scene = load(&mut worker, "teapot-in-stadium");
    let shaded = job(&scene, Mode::Shaded, false);
    worker.send(Command::Render(shaded.clone()));
    let replies = worker.wait_idle(wait);
    let order: Vec<bool> = replies
        .iter()
        .filter_map(|r| match r {
            Reply::Frame(_) => Some(true),
            Reply::Counted { .. } => Some(false),
            _ => None,
        })
        .collect();
    assert_eq!(order, [true, false], "the frame, then its counts");
    let (frames, counts) = frames_and_counts(replies);
    let (
        Reply::Frame(shown),
        Reply::Counted {
            job: counted_job,
            frame,
        },
    ) = (&frames[0], &counts[0])
    else {
        unreachable!()
    };
    assert!(!shown.frame.summary.counted(), "shown before counting");
    assert!(frame.summary.counted(), "then counted");
    assert_eq!(*counted_job, shaded);
    assert_same_pixels(&shown.frame, frame, "teapot-in-stadium");
    // The counted pass keeps the shown frame's image, which its samples colour.
    assert_eq!(frame.rgba, shown.frame.rgba);
    let (recoloured, _) = colorize(frame, Mode::Shaded, None);
    assert_eq!(frame.rgba, recoloured);
    assert_eq!(shown.image_time, shown.frame.summary.trace_time);

    // The heatmap of the same view recolours the counted frame: no tracing, no second pass.
    worker.send(Command::Render(job_with(
        &shaded,
        Mode::Heatmap(bvhlab::accel::Counter::NodesVisited, Default::default()),
    )));
    let (frames, counts) = frames_and_counts(worker.wait_idle(wait));
    let Reply::Frame(heat) = &frames[0] else {
        unreachable!()
    };
    assert!(!heat.traced && heat.frame.summary.counted() && counts.is_empty());

    // A preview is never counted; a full heatmap of a new view is counted at once.
    for (mode, preview) in [(Mode::Shaded, true), (heat.job.mode, false)] {
        let mut j = job(&scene, mode, preview);
        j.camera.eye += glam::Vec3::splat(0.01);
        worker.send(Command::Render(j));
        let (frames, counts) = frames_and_counts(worker.wait_idle(wait));
        let Reply::Frame(f) = &frames[0] else {
            unreachable!()
        };
        assert!(
            counts.is_empty(),
            "{mode:?} preview {preview}: no counted pass"
        );
        assert_eq!(f.frame.summary.counted(), !preview);
    }
}

fn job_with(j: &RenderJob, mode: Mode) -> RenderJob {
    RenderJob { mode, ..j.clone() }
}

/// A drag keeps the selection's table and the scene's box in two parts from move to move
/// (the standard light follows the box): every frame is the frame of the scene as moved,
/// traced afresh with the scene's own light, for a selection pushed out of the box (it
/// moves the light), back, undone, for another selection, and one listing a triangle twice.
#[test]
fn a_dragged_selection_is_lit_and_tinted_as_the_scene_it_moved() {
    let mut worker = Worker::spawn(|| {});
    let params = StructureParams {
        kind: AccelKind::Bvh8,
        ..Default::default()
    };
    worker.send(Command::Build(params));
    // An OBJ has no light of its own: the standard one, from the box. A floor of 30 × 30
    // quads under a roof of 10 × 10.
    let mut obj = String::new();
    for (name, n, y, size) in [("floor", 30, 0.0f32, 2.0f32), ("roof", 10, 0.8, 1.0)] {
        obj += &format!("o {name}\n");
        for i in 0..=n {
            for j in 0..=n {
                let (x, z) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
                obj += &format!("v {} {} {}\n", x * size, y + 0.1 * x * z, z * size);
            }
        }
    }
    let mut first_vertex = 1;
    for n in [30, 10] {
        for i in 0..n {
            for j in 0..n {
                let v = |a: usize, b: usize| first_vertex + a * (n + 1) + b;
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                obj += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
            }
        }
        first_vertex += (n + 1) * (n + 1);
    }
    let dir = common::TempDir::new("drag");
    let path = dir.join("drag.obj");
    std::fs::write(&path, obj).unwrap();
    let wait = Duration::from_secs(120);
    let scene = load(&mut worker, &path.display().to_string());
    assert!(scene.light.is_none(), "the standard light, from the box");
    let range = |r: std::ops::Range<u32>| std::sync::Arc::new(r.collect::<Vec<u32>>());
    let (first, second) = (|| range(0..600), || range(1_700..1_900));
    let mut twice = (*second()).clone();
    twice.push(twice[0]);
    let up = glam::Vec3::Y * scene.bounds().diagonal();
    let steps: Vec<(std::sync::Arc<Vec<u32>>, Option<glam::Vec3>)> = vec![
        (first(), Some(up)),
        (first(), Some(up * 0.5)),
        (first(), Some(-up * 0.25)),
        (first(), None),
        (second(), Some(up * 0.1)),
        (std::sync::Arc::new(twice), Some(-up * 0.3)),
    ];
    let (mut tinted, mut lights) = (0, vec![scene.light()]);
    for (k, (selection, delta)) in steps.into_iter().enumerate() {
        let mut dragged = job(&scene, Mode::Shaded, false);
        dragged.overlay.selected = Some(selection.clone());
        worker.send(Command::Render(dragged.clone()));
        worker.send(match delta {
            Some(delta) => Command::Move {
                triangles: selection.clone(),
                delta,
            },
            None => Command::Undo,
        });
        worker.send(Command::Snapshot);
        let replies = worker.wait_idle(wait);
        let moved = replies
            .iter()
            .find_map(|r| match r {
                Reply::Snapshot(s) => Some(s.clone()),
                _ => None,
            })
            .expect("a snapshot");
        let shown = replies
            .iter()
            .rev()
            .find_map(|r| match r {
                Reply::Frame(f) => Some(f.clone()),
                _ => None,
            })
            .expect("a frame after the move");
        lights.push(moved.light());
        let built = structure::build_scene(&moved, &params, &Default::default()).unwrap();
        let settings = RenderSettings {
            camera: dragged.camera,
            mode: Mode::Shaded,
            ..RenderSettings::for_scene(&moved, dragged.width, dragged.height)
        };
        let fresh = trace(&built.structure, &moved, &settings);
        assert_same_pixels(&shown.frame, &fresh, &format!("step {k}"));
        // The selection is tinted, nothing else.
        for (i, s) in shown.frame.samples.iter().enumerate() {
            let px = &shown.rgba[4 * i..4 * i + 4];
            if s.is_hit() && selection.contains(&(s.triangle as u32)) {
                tinted += usize::from(px != &fresh.rgba[4 * i..4 * i + 4]);
            } else {
                assert_eq!(px, &fresh.rgba[4 * i..4 * i + 4], "step {k}: pixel {i}");
            }
        }
    }
    assert!(tinted > 0, "the selection is tinted");
    // The moves moved the light, and the undo put it back exactly.
    assert!(lights[1] != lights[0] && lights[2] != lights[1] && lights[3] != lights[2]);
    assert_eq!(lights[4], lights[0]);
}

/// A slow frame (the uniform grid's triangle tests over the teapot in a stadium, at
/// 1280×720) asked for just before a quick one: the quick one's frame is the last shown,
/// and the slow one's full frame never comes (its trace is given up for the newer request;
/// at most its coarse first image is shown before).
#[test]
fn a_newer_request_cancels_a_slow_frame_in_flight() {
    let mut worker = Worker::spawn(|| {});
    worker.send(Command::Build(StructureParams {
        kind: AccelKind::Grid,
        ..Default::default()
    }));
    let scene = load(&mut worker, "teapot-in-stadium");
    let heat = Mode::Heatmap(bvhlab::accel::Counter::TriangleTests, Default::default());
    let slow = RenderJob {
        width: 1280,
        height: 720,
        ..job(&scene, heat, false)
    };
    let mut quick = job(&scene, Mode::Shaded, false);
    quick.camera.eye += glam::Vec3::splat(0.01);
    worker.send(Command::Render(slow.clone()));
    std::thread::sleep(Duration::from_millis(50));
    worker.send(Command::Render(quick.clone()));
    let (frames, _) = frames_and_counts(worker.wait_idle(Duration::from_secs(120)));
    let jobs: Vec<&RenderJob> = frames
        .iter()
        .filter_map(|r| match r {
            Reply::Frame(f) => Some(&f.job),
            _ => None,
        })
        .collect();
    assert_eq!(
        jobs.last(),
        Some(&&quick),
        "the newest request's frame is shown last"
    );
    assert!(
        !jobs.contains(&&slow),
        "the slow full frame was given up, not shown after or before it"
    );
}

/// A slow build followed by a fast one: the slow one is abandoned in flight, and only the
/// newest structure is reported built (nothing queues behind the slow structure).
#[test]
fn a_newer_structure_abandons_the_build_in_flight() {
    let mut worker = Worker::spawn(|| {});
    let scene = load(&mut worker, "soup:300000");
    let shaded = job(&scene, Mode::Shaded, false);
    let of = |kind| {
        Command::Build(StructureParams {
            kind,
            ..Default::default()
        })
    };
    worker.send(of(AccelKind::KdTree));
    worker.send(Command::Render(shaded.clone()));
    // Time for the worker to start the k-d tree (hundreds of ms over 300,000 triangles).
    std::thread::sleep(Duration::from_millis(50));
    worker.send(of(AccelKind::Bvh));
    worker.send(Command::Render(shaded));
    let replies = worker.wait_idle(Duration::from_secs(120));
    let built: Vec<&str> = replies
        .iter()
        .filter_map(|r| match r {
            Reply::Built { report, .. } => Some(report.structure),
            Reply::BuildFailed(e) => panic!("a build failed: {e}"),
            _ => None,
        })
        .collect();
    assert_eq!(built, [AccelKind::Bvh.label()]);
    assert!(replies.iter().any(|r| matches!(r, Reply::Frame(_))));
}

/// A slow frame fills in tile by tile: after its coarse first image come pictures of the
/// full size, each pixel either the coarse image's (enlarged) or the full frame's own, with
/// more of the full frame in each; then the full frame itself.
#[test]
fn a_slow_frame_fills_in_tile_by_tile_over_its_coarse_image() {
    let mut worker = Worker::spawn(|| {});
    // Brute force over a thousand triangles: about a second for 640 × 360.
    worker.send(Command::Build(StructureParams {
        kind: AccelKind::BruteForce,
        ..Default::default()
    }));
    let scene = load(&mut worker, "soup:1000");
    let slow = RenderJob {
        width: 640,
        height: 360,
        ..job(&scene, Mode::Shaded, false)
    };
    // The first full frame finds the trace slow; the next view is then streamed.
    worker.send(Command::Render(slow.clone()));
    worker.wait_idle(Duration::from_secs(120));
    let mut moved = slow.clone();
    moved.camera.eye += glam::Vec3::splat(0.01);
    worker.send(Command::Render(moved.clone()));
    let (frames, _) = frames_and_counts(worker.wait_idle(Duration::from_secs(120)));
    let shown: Vec<_> = frames
        .into_iter()
        .filter_map(|r| match r {
            Reply::Frame(f) => Some(f),
            _ => None,
        })
        .collect();
    let (coarse, rest) = shown.split_first().expect("frames");
    assert!(
        coarse.job.preview && coarse.job.width < moved.width,
        "a coarse image first"
    );
    let (full, partial) = rest.split_last().expect("the full frame");
    assert_eq!(full.job, moved, "the full frame last");
    assert!(!partial.is_empty(), "pictures in between");
    let pixel = |rgba: &[u8], i: usize| -> [u8; 4] { rgba[4 * i..4 * i + 4].try_into().unwrap() };
    let (w, cw) = (moved.width as usize, coarse.job.width as usize);
    let mut done = 0;
    for p in partial {
        assert!(p.job.preview && p.job.width == moved.width && p.job.height == moved.height);
        let mut from_full = 0;
        for i in 0..w * moved.height as usize {
            let (x, y) = (i % w, i / w);
            let c = (y * coarse.job.height as usize / moved.height as usize) * cw + x * cw / w;
            let px = pixel(&p.rgba, i);
            if px == pixel(&full.rgba, i) {
                from_full += 1;
            } else {
                assert_eq!(px, pixel(&coarse.rgba, c), "pixel {i}: coarse or full");
            }
        }
        assert!(from_full >= done, "the full frame only grows");
        done = from_full;
    }
}

/// Waits for the prefetch asked for to be ready; the replies on the way.
fn until_prefetched(worker: &mut Worker) -> Vec<Reply> {
    let mut seen = Vec::new();
    while let Some(r) = worker.next_reply(Duration::from_secs(120)) {
        if matches!(r, Reply::Prefetched(_)) {
            return seen;
        }
        seen.push(r);
    }
    panic!("the prefetch never came");
}

/// The lecture's next step, prefetched while the current one is shown, opens without a
/// build of its own (the build's progress counters are never touched); a prefetch made
/// with other parameters than the step opens with gives its scene only, and the step
/// builds. A command that arrives while the prefetch builds is answered first, and the
/// prefetch is finished after it.
#[test]
fn a_prefetched_step_opens_without_building_and_gives_way_to_commands() {
    let mut worker = Worker::spawn(|| {});
    let scene = load(&mut worker, "cornell");
    let bvh8 = StructureParams {
        kind: AccelKind::Bvh8,
        ..Default::default()
    };
    let untouched = usize::MAX;
    for (prefetched_with, opens_built) in [(bvh8, true), (StructureParams::default(), false)] {
        worker.send(Command::Prefetch {
            spec: "soup:20000".into(),
            params: prefetched_with,
        });
        until_prefetched(&mut worker);
        worker
            .progress
            .1
            .store(untouched, std::sync::atomic::Ordering::Relaxed);
        worker.send(Command::SetParams(bvh8));
        worker.send(Command::Load("soup:20000".into()));
        let replies = worker.wait_idle(Duration::from_secs(120));
        let built: Vec<&str> = replies
            .iter()
            .filter_map(|r| match r {
                Reply::Built { report, .. } => Some(report.structure),
                _ => None,
            })
            .collect();
        assert_eq!(built, [AccelKind::Bvh8.label()]);
        let counted = worker.progress.1.load(std::sync::atomic::Ordering::Relaxed);
        assert_eq!(counted == untouched, opens_built, "counted {counted}");
        load(&mut worker, "cornell");
    }
    // A frame asked for while a slow prefetch builds comes before the prefetch is ready.
    worker.send(Command::Prefetch {
        spec: "soup:300000".into(),
        params: StructureParams {
            kind: AccelKind::KdTree,
            ..Default::default()
        },
    });
    std::thread::sleep(Duration::from_millis(600));
    worker.send(Command::Render(job(&scene, Mode::Shaded, false)));
    let before = until_prefetched(&mut worker);
    assert!(before.iter().any(|r| matches!(r, Reply::Frame(_))));
}

/// Waits for the worker's next EPO; the replies on the way.
fn until_epo(worker: &mut Worker) -> (bvhlab::accel::epo::Epo, Vec<Reply>) {
    let mut seen = Vec::new();
    while let Some(r) = worker.next_reply(Duration::from_secs(120)) {
        if let Reply::Epo(epo) = r {
            return (epo, seen);
        }
        seen.push(r);
    }
    panic!("no EPO came");
}

/// The shown tree's EPO comes after its build, at a quiet moment: the tree's own EPO, and
/// after a move the refitted tree's; under the two levels, both levels'. A structure
/// without an SAH cost gets none.
#[test]
fn the_worker_sends_the_epo_of_the_tree_built_and_of_the_tree_refitted() {
    let mut worker = Worker::spawn(|| {});
    let params = StructureParams {
        kind: AccelKind::Bvh,
        ..Default::default()
    };
    worker.send(Command::SetParams(params));
    let scene = load(&mut worker, "soup:3000");
    let (epo, _) = until_epo(&mut worker);
    let expected = built(&scene, AccelKind::Bvh).epo(&params, &scene).unwrap();
    assert_eq!(epo, expected);
    // Both levels' EPO, clipped exactly on a scene this small; then the BVH's again.
    let two = StructureParams {
        kind: AccelKind::TwoLevel,
        ..Default::default()
    };
    worker.send(Command::Build(two));
    let (both, _) = until_epo(&mut worker);
    assert!(both.estimate.is_none() && both.value > 0.0, "{both:?}");
    assert_eq!(
        both,
        built(&scene, AccelKind::TwoLevel)
            .epo(&two, &scene)
            .unwrap()
    );
    worker.send(Command::Build(params));
    assert_eq!(until_epo(&mut worker).0, epo);
    worker.send(Command::Move {
        triangles: std::sync::Arc::new((0..300).collect()),
        delta: glam::Vec3::new(0.3, 0.0, 0.0),
    });
    let (after, replies) = until_epo(&mut worker);
    assert!(replies.iter().any(|r| matches!(r, Reply::Refitted { .. })));
    assert_ne!(after, epo);
    // The grid has no SAH cost: no EPO follows its build.
    worker.send(Command::Build(StructureParams {
        kind: AccelKind::Grid,
        ..Default::default()
    }));
    let replies = worker.wait_idle(Duration::from_secs(120));
    assert!(replies.iter().any(|r| matches!(r, Reply::Built { .. })));
    std::thread::sleep(Duration::from_millis(500));
    assert!(worker.next_reply(Duration::from_millis(300)).is_none());
}
