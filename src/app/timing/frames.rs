//! Frame times of the explorer app, measured through its worker without a window: a view
//! rendered at preview and full resolution in the shaded and heatmap modes, and the time
//! from a drag's move command to the refitted frame (the latency a user feels while
//! dragging).

use crate::accel::{Counter, StructureParams};
use crate::app::worker::{Command, Overlay, RenderJob, Reply, Worker};
use crate::render::{Mode, RayKind};
use crate::scene::Camera;
use glam::Vec3;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct FrameTime {
    pub mode: Mode,
    pub width: u32,
    pub height: u32,
    /// A preview, as the app shows while the view or a triangle moves.
    pub preview: bool,
    /// Median over the runs, command to frame.
    pub median: Duration,
    /// For a frame shown before its counts (a full frame in a mode without counts): the
    /// median from the command to the counted pass's counters.
    pub counted: Option<Duration>,
}

#[derive(Clone, Debug)]
pub struct FrameReport {
    pub scene: String,
    pub triangles: usize,
    pub frames: Vec<FrameTime>,
    /// Drag steps in the shaded and the heatmap mode.
    pub drags: Vec<DragTime>,
    pub moved: usize,
}

/// A drag step: from a move of the dragged triangles to the refitted (or, for a structure
/// that cannot refit, rebuilt) preview frame.
#[derive(Clone, Debug)]
pub struct DragTime {
    pub mode: Mode,
    pub median: Duration,
    pub fps: f64,
    /// Medians of the two parts of a step: the refit or rebuild, and tracing the new frame.
    pub refit: Duration,
    pub trace: Duration,
    /// Under the two levels, where an instance moves: the median refit of a BVH over the
    /// flattened scene for the same move (`None` if the scene is too large to flatten).
    pub flat_refit: Option<Duration>,
}

/// What the worker did for the command just sent.
#[derive(Default)]
struct Step {
    /// Time spent tracing the frame, if one came.
    trace: Option<Duration>,
    /// When the frame asked for came (a coarse one before a slow full frame stands in
    /// until it comes), and when its counts came if they came after it.
    shown: Option<Instant>,
    counted: Option<Instant>,
    refit: Duration,
    flat_refit: Option<Duration>,
}

/// Waits for the frame of the command just sent; `None` if the worker went quiet.
fn frame_after(worker: &mut Worker) -> Option<Step> {
    let mut step = Step::default();
    let deadline = Instant::now() + Duration::from_secs(300);
    while !worker.is_idle() {
        let left = deadline.saturating_duration_since(Instant::now());
        let Some(r) = worker.next_reply(left) else {
            break;
        };
        match r {
            // A coarse first image stands in for a full frame until it comes.
            Reply::Frame(f) if step.shown.is_none() || !f.job.preview => {
                step.trace = Some(f.frame.summary.trace_time);
                step.shown = Some(Instant::now());
            }
            Reply::Counted { .. } => step.counted = Some(Instant::now()),
            Reply::Refitted { refit_time, .. } => step.refit += refit_time,
            Reply::RebuiltAfterMove { rebuild_time, .. } => step.refit += rebuild_time,
            Reply::InstanceMoved {
                refit_time,
                flat_refit_time,
                ..
            } => {
                step.refit += refit_time;
                step.flat_refit = flat_refit_time;
            }
            _ => {}
        }
    }
    step.trace.is_some().then_some(step)
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v.get(v.len() / 2).copied().unwrap_or_default()
}

/// Measures `runs` frames per (mode, size) and `runs` drag steps at the first size, which
/// should be a preview, as while dragging. `sizes` are (width, height, preview).
pub fn run(
    spec: &str,
    params: &StructureParams,
    camera: Option<Camera>,
    sizes: &[(u32, u32, bool)],
    runs: usize,
) -> Result<FrameReport, String> {
    let mut worker = Worker::spawn(|| {});
    worker.send(Command::Build(*params));
    worker.send(Command::Load(spec.to_string()));
    let mut scene = None;
    for r in worker.wait_idle(Duration::from_secs(300)) {
        match r {
            Reply::Loaded { scene: s, .. } => scene = Some(s),
            Reply::LoadFailed { error, .. } => return Err(error),
            _ => {}
        }
    }
    let scene = scene.ok_or("the scene did not load")?;
    let camera = camera.unwrap_or_else(|| scene.camera());
    let modes = [
        Mode::Shaded,
        Mode::Heatmap(Counter::NodesVisited, RayKind::Primary),
    ];
    let job = |camera: Camera, mode, (width, height, preview): (u32, u32, bool)| RenderJob {
        camera,
        width,
        height,
        mode,
        heat_max: None,
        heat_style: Default::default(),
        overlay: Overlay::default(),
        preview,
        compare: None,
    };
    let mut frames = Vec::new();
    for &size in sizes {
        for mode in modes {
            let (mut times, mut counted) = (Vec::new(), Vec::new());
            for k in 0..runs {
                // A new camera each time, as an orbit would, so every frame is traced; the
                // nudges are tiny and do not add up, so every frame shows the same view.
                let mut nudged = camera;
                nudged.eye += Vec3::splat(1e-5 * (k as f32 + 1.0) * scene.bounds().diagonal());
                let start = Instant::now();
                worker.send(Command::Render(job(nudged, mode, size)));
                let step = frame_after(&mut worker).ok_or("no frame")?;
                let shown = step.shown.unwrap_or_else(Instant::now);
                times.push(shown - start);
                counted.extend(step.counted.map(|c| c - start));
            }
            frames.push(FrameTime {
                mode,
                width: size.0,
                height: size.1,
                preview: size.2,
                median: median(times),
                counted: (!counted.is_empty()).then(|| median(counted)),
            });
        }
    }
    // Drag: move the largest object back and forth, one refitted preview frame per move.
    // Under the two levels its instance moves (the scene need not store its triangles).
    let (o, object) = scene
        .objects
        .iter()
        .enumerate()
        .max_by_key(|(_, o)| o.count)
        .ok_or("the scene has no objects")?;
    let instanced = params.kind.places_instances();
    let moved: Arc<Vec<u32>> = if instanced {
        Arc::new(Vec::new())
    } else {
        Arc::new(object.range().map(|t| t as u32).collect())
    };
    let step = scene.bounds().diagonal() * 0.002;
    let preview = sizes.first().copied().unwrap_or((640, 360, true));
    let mut drags = Vec::new();
    // A flat structure over a scene that does not store its triangles cannot move them.
    let drag_modes: &[Mode] = if instanced || scene.is_flattened() {
        &modes
    } else {
        &[]
    };
    for &mode in drag_modes {
        // The app tints the selection while it is dragged.
        let mut dragged = job(camera, mode, preview);
        dragged.overlay.selected = (!instanced).then(|| moved.clone());
        worker.send(Command::Render(dragged));
        frame_after(&mut worker).ok_or("no frame")?;
        let (mut times, mut refits, mut traces, mut flat) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for k in 0..runs.max(10) {
            let delta = if k % 2 == 0 { Vec3::X } else { -Vec3::X } * step;
            let start = Instant::now();
            worker.send(if instanced {
                Command::MoveObject { object: o, delta }
            } else {
                Command::Move {
                    triangles: moved.clone(),
                    delta,
                }
            });
            let step = frame_after(&mut worker).ok_or("no frame after a move")?;
            times.push(step.shown.unwrap_or_else(Instant::now) - start);
            refits.push(step.refit);
            traces.push(step.trace.unwrap_or_default());
            flat.extend(step.flat_refit);
        }
        let step_time = median(times);
        drags.push(DragTime {
            mode,
            fps: 1.0 / step_time.as_secs_f64().max(1e-9),
            median: step_time,
            refit: median(refits),
            trace: median(traces),
            flat_refit: (!flat.is_empty()).then(|| median(flat)),
        });
    }
    Ok(FrameReport {
        scene: scene.name.clone(),
        triangles: scene.placed_triangles(),
        frames,
        drags,
        moved: object.count,
    })
}
