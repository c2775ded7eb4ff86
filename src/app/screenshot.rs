//! `bvhlab screenshot`: the real app window, opened in a given state, saved through egui's
//! screenshot request once its frame is complete, then closed. This is how the README's
//! pictures are made.

use super::settings::Settings;
use crate::accel::StructureParams;
use crate::render::ViewMode;
use crate::render::compare::CompareView;
use eframe::egui;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The smallest view, in pixels each way, a screenshot is taken of.
const MIN_VIEW: u32 = 64;

/// Which view of the app to capture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shot {
    Shaded,
    Nodes,
    Boxes,
    Triangles,
    /// The boxes of one BVH level over the shaded scene.
    Levels,
    /// An object dragged away, refitted, with the SAH cost chart.
    Refit,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Settling,
    Refitting,
    Replaying,
    Comparing,
    Requested,
    Closing,
}

/// A replay to show in the shot: the ray through `at` (0..1 across and down the view), at
/// visit `visit` (counted from 1; past the last, the last).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayShot {
    pub at: [f32; 2],
    pub visit: usize,
}

/// A comparison to show in the shot: the plan's configuration is pinned as A, then `b`
/// becomes the current configuration, shown in `view`.
#[derive(Clone, Debug, PartialEq)]
pub struct CompareShot {
    pub b: StructureParams,
    pub view: CompareView,
}

/// What the app is to do for the plan.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    None,
    /// Drag an object away (the refit shot).
    Refit,
    /// Replay the ray through this point of the view.
    Replay(ReplayShot),
    /// Pin the configuration as A and switch to B.
    Compare(CompareShot),
}

/// What a screenshot run saved: the file, and the view's size in it (pixels).
#[derive(Clone, Debug, PartialEq)]
pub struct Saved {
    pub path: String,
    pub viewport: [u32; 2],
}

/// What the screenshot run saved, or why it could not.
pub type Outcome = Arc<Mutex<Option<Result<Saved, String>>>>;

#[derive(Clone, Debug)]
pub struct ScreenshotPlan {
    pub out: PathBuf,
    pub shot: Shot,
    pub width: u32,
    pub height: u32,
    /// The depth of a levels shot (default 3).
    pub level: Option<u32>,
    /// The node the tree walk opens at (the bucket-cost plot shows its splits).
    pub walk: Option<u32>,
    /// Under the two levels: the instance selected, whose BLAS levels follow the TLAS's.
    pub instance: Option<usize>,
    /// Replay the ray through this point of the view (0..1 across and down) and show it.
    pub replay: Option<ReplayShot>,
    /// Pin the configuration as A, change to B and compare.
    pub compare: Option<CompareShot>,
    /// The presentation layout (no side panels, one slim caption bar).
    pub presentation: bool,
    /// The hierarchy diagram open under the view.
    pub tree: bool,
    /// The UI scale (egui's zoom factor), 1 by default.
    pub ui_scale: f32,
    /// The size was asked for: a window that comes out another size is an error (the
    /// default size gives way to a smaller screen).
    pub exact_size: bool,
    pub result: Outcome,
    stage: Stage,
    started: Instant,
    /// Since when the app has been settled, waiting for a lecture step's section to be
    /// scrolled into sight.
    settled_since: Option<Instant>,
    /// The section was still to be scrolled to at the last step: its scroll shows a frame
    /// later.
    focus_was_pending: bool,
}

/// A run that has not settled by then gives up with an error.
const TIMEOUT: Duration = Duration::from_secs(180);

/// How long a settled app may wait for the section a lecture step is about to appear
/// (the SAH check's after the counted pass): a shot shows the panel as the step opens.
const FOCUS_WAIT: Duration = Duration::from_secs(3);

impl ScreenshotPlan {
    pub fn new(out: PathBuf, shot: Shot, width: u32, height: u32) -> Self {
        ScreenshotPlan {
            out,
            shot,
            width,
            height,
            level: None,
            walk: None,
            instance: None,
            replay: None,
            compare: None,
            presentation: false,
            tree: false,
            ui_scale: 1.0,
            exact_size: true,
            result: Arc::new(Mutex::new(None)),
            stage: Stage::Settling,
            started: Instant::now(),
            settled_since: None,
            focus_was_pending: false,
        }
    }

    /// The settings the shot starts from.
    pub fn apply(&self, s: &mut Settings) {
        s.presentation = self.presentation;
        s.ui_scale = self.ui_scale;
        s.show_controls = true;
        s.show_stats = true;
        s.show_tree = self.tree;
        s.mode = match self.shot {
            Shot::Nodes => ViewMode::Nodes,
            Shot::Boxes => ViewMode::Boxes,
            Shot::Triangles => ViewMode::Triangles,
            Shot::Shaded | Shot::Levels | Shot::Refit => ViewMode::Shaded,
        };
        match self.shot {
            Shot::Levels => {
                s.show_levels = true;
                s.level = self.level.unwrap_or(3);
            }
            Shot::Refit => {
                s.show_levels = true;
                s.level = 4;
                s.see_through = true;
                // The object under the centre moves as a whole: its boxes stretch visibly.
                s.move_whole_object = true;
            }
            _ => {}
        }
    }

    /// Ends the run without a shot: what it was asked to show does not exist.
    pub fn fail(&mut self, why: String) {
        self.finish(Err(why));
    }

    fn finish(&mut self, outcome: Result<Saved, String>) {
        if let Ok(mut r) = self.result.lock() {
            r.get_or_insert(outcome);
        }
        self.stage = Stage::Closing;
    }

    /// Advances the plan; `settled` says the worker is idle and the full frame is shown.
    /// Returns, once, what the app is to do before the shot (the scripted drag of a refit
    /// shot, the replay of a replay shot).
    /// `focus_pending`: a lecture step's section has yet to be scrolled into sight.
    pub fn step(
        &mut self,
        settled: bool,
        focus_pending: bool,
        viewport: [u32; 2],
        ctx: &egui::Context,
    ) -> Action {
        if self.started.elapsed() > TIMEOUT && self.stage != Stage::Closing {
            self.finish(Err(format!("the frame did not settle within {TIMEOUT:?}")));
        }
        self.settled_since = settled.then(|| self.settled_since.unwrap_or_else(Instant::now));
        let scrolled = !focus_pending && !self.focus_was_pending;
        self.focus_was_pending = focus_pending;
        let settled =
            settled && (scrolled || self.settled_since.is_some_and(|t| t.elapsed() > FOCUS_WAIT));
        let mut action = Action::None;
        match self.stage {
            Stage::Settling if settled => {
                if self.shot == Shot::Refit {
                    self.stage = Stage::Refitting;
                    action = Action::Refit;
                } else if let Some(r) = self.replay {
                    self.stage = Stage::Replaying;
                    action = Action::Replay(r);
                } else if let Some(c) = &self.compare {
                    self.stage = Stage::Comparing;
                    action = Action::Compare(c.clone());
                } else {
                    self.request(viewport, ctx);
                }
            }
            Stage::Refitting | Stage::Replaying | Stage::Comparing if settled => {
                self.request(viewport, ctx)
            }
            Stage::Requested if self.result.lock().is_ok_and(|r| r.is_some()) => {
                self.stage = Stage::Closing;
            }
            Stage::Closing => ctx.send_viewport_cmd(egui::ViewportCommand::Close),
            _ => {}
        }
        // Keep frames coming until the window closes.
        ctx.request_repaint_after(Duration::from_millis(50));
        action
    }

    fn request(&mut self, viewport: [u32; 2], ctx: &egui::Context) {
        // A window too small for its panels leaves the view a sliver: no picture of it.
        if viewport.iter().any(|&n| n < MIN_VIEW) {
            return self.finish(Err(format!(
                "the window leaves the view only {}×{} pixels (at least {MIN_VIEW}×{MIN_VIEW} \
                 needed): ask for a larger --width and --height, or --presentation",
                viewport[0], viewport[1]
            )));
        }
        self.stage = Stage::Requested;
        let out = self.out.clone();
        let result = self.result.clone();
        let repaint = ctx.clone();
        let asked = [self.width as usize, self.height as usize];
        let exact = self.exact_size;
        let native = ctx.native_pixels_per_point().unwrap_or(1.0);
        ctx.request_screenshot(move |image| {
            let [w, h] = image.size;
            // A window larger than the screen (or the driver's largest surface) comes out
            // smaller: say so rather than save a shot of another size.
            let expected = asked.map(|n| (n as f32 * native).round() as usize);
            if exact && image.size != expected {
                if let Ok(mut r) = result.lock() {
                    *r = Some(Err(format!(
                        "the window came out {w}×{h} pixels, not the {}×{} asked for: the \
                         screen (or the graphics driver) has no room for it; ask for a smaller \
                         --width and --height",
                        expected[0], expected[1]
                    )));
                }
                repaint.request_repaint();
                return;
            }
            let bytes: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
            let saved = crate::output::write_png(&bytes, w as u32, h as u32, &out)
                .map(|()| Saved {
                    path: out.display().to_string(),
                    viewport,
                })
                .map_err(|e| e.to_string());
            if let Ok(mut r) = result.lock() {
                *r = Some(saved);
            }
            repaint.request_repaint();
        });
    }
}
