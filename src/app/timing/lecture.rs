//! The built-in lecture (or any preset file) stepped through as the app shows it, timed:
//! for each step, from opening it to the first image on screen (a coarse one comes first
//! when the frame is slow), and to its full frame. Through the app's own worker, without a
//! window. As in the app, each step prefetches the next while it is shown, and the next
//! step opens once that is done (a lecturer talks over each step for longer); the first
//! step, and a step timed alone, load and build afresh.

use crate::app::preset::Sequence;
use crate::app::settings::Settings;
use crate::app::worker::{Command, CompareJob, Overlay, RenderJob, Reply, Worker};
use std::time::{Duration, Instant};

/// One step's times, in milliseconds from the step opening.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StepTime {
    pub step: usize,
    pub title: String,
    pub scene: String,
    pub first_image_ms: f64,
    pub full_frame_ms: f64,
    /// Whether the step opened from the scene and structure the step before it prefetched
    /// (as when a lecturer steps forward); false for the first step and a step timed alone.
    pub prefetched: bool,
}

/// A step that shows nothing within this is reported as an error.
const TIMEOUT: Duration = Duration::from_secs(600);

/// Steps through `sequence`, each traced at `width` × `height` as the app's view would be.
pub fn run(sequence: &Sequence, width: u32, height: u32) -> Result<Vec<StepTime>, String> {
    let mut worker = Worker::spawn(|| {});
    let mut steps = Vec::new();
    // Whether the step about to open was prefetched by the one before.
    let mut opened_prefetched = false;
    for (i, preset) in sequence.presets.iter().enumerate() {
        let settings = preset.settings_over(&Settings::default());
        let start = Instant::now();
        // As the app opens a step: the structure's parameters, then the scene (afresh, or
        // as the previous step prefetched it), then the next step to prefetch.
        worker.send(Command::SetParams(settings.structure));
        worker.send(Command::Load(preset.scene.clone()));
        let next = sequence.presets.get(i + 1);
        if let Some(next) = next {
            worker.send(Command::Prefetch {
                spec: next.scene.clone(),
                params: next.settings_over(&settings).structure,
            });
        }
        let scene = loop {
            match worker.next_reply(TIMEOUT) {
                Some(Reply::Loaded { scene, .. }) => break scene,
                Some(Reply::LoadFailed { error, .. }) => {
                    return Err(format!("step {} ({}): {error}", i + 1, preset.title));
                }
                Some(_) => {}
                None => return Err(format!("step {}: the scene did not load", i + 1)),
            }
        };
        let camera = preset
            .camera
            .as_ref()
            .map_or_else(|| scene.camera(), |v| v.camera());
        let job = RenderJob {
            camera,
            width,
            height,
            mode: settings.mode.render_mode(settings.shadow_rays),
            heat_max: settings.heat_max,
            heat_style: settings.heat_style,
            overlay: Overlay {
                level: settings.show_levels.then_some(settings.level),
                walk: preset.walk,
                see_through: settings.see_through,
                color_by_node: settings.color_by_node,
                ..Overlay::default()
            },
            preview: false,
            compare: preset.pinned.map(|a| CompareJob {
                a,
                view: settings.compare_view,
            }),
        };
        worker.send(Command::Render(job.clone()));
        let (mut first, mut full) = (None, None);
        while full.is_none() {
            match worker.next_reply(TIMEOUT) {
                Some(Reply::Frame(shown)) => {
                    first.get_or_insert_with(|| start.elapsed());
                    if shown.job == job {
                        full = Some(start.elapsed());
                    }
                }
                Some(Reply::BuildFailed(e)) => {
                    return Err(format!("step {} ({}): {e}", i + 1, preset.title));
                }
                Some(_) => {}
                None => return Err(format!("step {}: no frame within {TIMEOUT:?}", i + 1)),
            }
        }
        // The counted pass after a shaded frame is not waited for by a viewer; let it
        // finish before the next step so it does not slow that one's load. Then, as a
        // lecturer talks over each step, the next step is prefetched before it opens.
        worker.wait_idle(TIMEOUT);
        let prefetched = next.is_some_and(|_| {
            let deadline = Instant::now() + TIMEOUT;
            loop {
                let left = deadline.saturating_duration_since(Instant::now());
                match worker.next_reply(left) {
                    Some(Reply::Prefetched(_)) => break true,
                    Some(_) => {}
                    None => break false,
                }
            }
        });
        let ms = |d: Option<Duration>| d.unwrap_or_default().as_secs_f64() * 1e3;
        steps.push(StepTime {
            step: i + 1,
            title: preset.title.clone(),
            scene: preset.scene.clone(),
            first_image_ms: ms(first),
            full_frame_ms: ms(full),
            prefetched: opened_prefetched,
        });
        opened_prefetched = prefetched;
    }
    Ok(steps)
}
