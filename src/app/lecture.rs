//! The lecture in the app: the sequence of presets (the built-in lecture or a loaded file),
//! the preset shown with its question in a caption bar, saving and loading preset files,
//! and the camera bookmarks of each scene.

use super::BvhLabApp;
use super::orbit::Orbit;
use super::preset::{Preset, PresetError, Sequence, View};
use super::settings::{Bookmark, Settings};
use crate::render::ViewMode;
use crate::scene::Camera;
use eframe::egui::{self, Key, RichText};
use std::path::Path;

struct Pending {
    camera: Option<Camera>,
    walk: Option<u32>,
    level: u32,
}

impl Pending {
    fn of(preset: &Preset) -> Self {
        Pending {
            camera: preset.camera.map(|v| v.camera()),
            walk: preset.walk,
            level: preset.settings.level,
        }
    }
}

/// What the app knows of the lecture.
pub struct Lecture {
    pub sequence: Sequence,
    /// The preset shown (its caption is on screen); none once closed.
    pub current: Option<usize>,
    /// Why the last preset file could not be loaded or saved (the state stayed).
    pub error: Option<String>,
    /// What of the preset shown could not be done (it opened without it).
    pub notice: Option<String>,
    /// The last file saved.
    pub saved: Option<String>,
    /// The camera and tree-walk node of the preset being opened, set once its scene has
    /// loaded (loading a scene sets the scene's own view).
    pending: Option<Pending>,
    /// Its tree-walk node and level, set once its structure is built: until then the
    /// panels know only the old structure's depth, and would clamp them to it.
    pending_structure: Option<(Option<u32>, u32)>,
    /// The settings from before the first preset opened: what is saved at exit while a
    /// preset is shown, so a lecture does not change what the next plain launch opens.
    pub before: Option<Settings>,
    /// The last digit typed and when: a second one soon after makes a two-digit step.
    typed: Option<(usize, std::time::Instant)>,
}

/// Two digits typed within this time name one step (1 then 7: step 17).
const TWO_DIGITS: std::time::Duration = std::time::Duration::from_millis(800);

impl Default for Lecture {
    fn default() -> Self {
        Lecture {
            sequence: Sequence::lecture(),
            current: None,
            error: None,
            notice: None,
            saved: None,
            pending: None,
            pending_structure: None,
            before: None,
            typed: None,
        }
    }
}

impl Lecture {
    /// A lecture starting at `index` of `sequence` (as `--preset` asks).
    pub fn at(sequence: Sequence, index: usize, before: Settings) -> Self {
        let mut lecture = Lecture {
            sequence,
            before: Some(before),
            ..Default::default()
        };
        lecture.current = Some(index);
        if let Some(p) = lecture.sequence.presets.get(index) {
            lecture.pending = Some(Pending::of(p));
        }
        lecture
    }
}

impl Lecture {
    /// The settings to keep at exit: with a preset on screen, those from before the
    /// lecture, with the personal ones (UI scale, layout, recent files, bookmarks) as they
    /// are now; else the current ones.
    pub fn settings_to_keep(&self, current: &Settings) -> Settings {
        match (&self.before, self.current) {
            (Some(before), Some(_)) => before.with_personal_of(current),
            _ => current.clone(),
        }
    }
}

impl BvhLabApp {
    /// Shows preset `index` of the sequence: its scene loaded afresh (undoing moves), its
    /// structure built, its view, overlays, tool and camera set. False if there is none.
    pub fn go_to_preset(&mut self, index: usize) -> bool {
        let Some(preset) = self.lecture.sequence.presets.get(index).cloned() else {
            return false;
        };
        self.lecture.current = Some(index);
        self.apply_preset(&preset);
        true
    }

    /// The next (or previous) preset of the sequence; the first if none is shown.
    pub fn step_preset(&mut self, forward: bool) {
        let last = self.lecture.sequence.presets.len().saturating_sub(1);
        let index = match (self.lecture.current, forward) {
            (None, _) => 0,
            (Some(i), true) => (i + 1).min(last),
            (Some(i), false) => i.saturating_sub(1),
        };
        if Some(index) != self.lecture.current {
            self.go_to_preset(index);
        }
    }

    fn apply_preset(&mut self, preset: &Preset) {
        if self.lecture.before.is_none() {
            self.lecture.before = Some(self.settings.clone());
        }
        self.settings = preset.settings_over(&self.settings);
        self.tool = preset.tool;
        self.pinned = preset.pinned;
        self.panels_to_top = true;
        self.panel_focus = preset.focus;
        self.compared = None;
        self.replay = None;
        self.replay_error = None;
        self.selection = None;
        self.drag = None;
        self.lecture.pending = Some(Pending::of(preset));
        self.lecture.error = None;
        self.lecture.notice = None;
        // The scene loads straight into the preset's structure: one build.
        let params = self.settings.structure;
        self.sent_build = Some(params);
        self.worker.send(super::worker::Command::SetParams(params));
        self.load(preset.scene.clone());
        if let Some(index) = self.lecture.current {
            prefetch_next(
                &mut self.worker,
                &self.lecture.sequence,
                index,
                &self.settings,
            );
        }
    }

    /// Once the preset's scene has loaded: its camera and tree-walk node.
    pub(super) fn apply_pending_view(&mut self) {
        if let Some(p) = self.lecture.pending.take() {
            if let Some(c) = p.camera {
                self.orbit = Orbit::from_camera(&c);
            }
            self.lecture.pending_structure = Some((p.walk, p.level));
        }
    }

    /// Once the preset's structure is built: its tree-walk node and level.
    pub(super) fn apply_pending_structure(&mut self) {
        if let Some((walk, level)) = self.lecture.pending_structure.take() {
            let nodes = self.outline.nodes.len();
            self.walk = walk.filter(|&w| (w as usize) < nodes);
            if let Some(w) = walk.filter(|&w| (w as usize) >= nodes) {
                // Said, not skipped: the preset names a node this tree does not have.
                self.lecture.notice = Some(format!(
                    "this preset's tree walk starts at node {w}, but the tree has {nodes} \
                     nodes (0 to {}): the walk stays closed",
                    nodes.saturating_sub(1)
                ));
            }
            self.settings.level = level.min(self.outline.max_depth());
        }
    }

    /// The app's state as a preset: the settings, the camera, the tool and the tree walk.
    pub fn preset_here(&self, title: &str) -> Preset {
        let shown = (self.lecture.current).and_then(|i| self.lecture.sequence.presets.get(i));
        let caption = shown.map(|p| p.caption.clone()).unwrap_or_default();
        Preset {
            focus: shown.and_then(|p| p.focus),
            title: title.to_string(),
            caption,
            scene: self.settings.scene.clone(),
            camera: Some(View::from_camera(&self.orbit.camera())),
            tool: self.tool,
            walk: self.walk,
            settings: self.settings.clone(),
            pinned: self.pinned,
        }
    }

    /// Saves the current state as a preset file.
    pub fn save_preset(&mut self, path: &Path) -> Result<(), String> {
        let title = path
            .file_stem()
            .map_or("preset".into(), |s| s.to_string_lossy().into_owned());
        let text = self.preset_here(&title).to_toml();
        let result = crate::output::write(path, text.as_bytes()).map_err(|e| e.to_string());
        match &result {
            Ok(()) => {
                self.lecture.saved = Some(path.display().to_string());
                self.lecture.error = None;
            }
            Err(e) => self.lecture.error = Some(e.clone()),
        }
        result
    }

    /// Loads a preset file as the sequence and shows its first preset; a bad file leaves
    /// the sequence and the state as they were and says why.
    pub fn load_presets(&mut self, path: &Path) -> Result<(), PresetError> {
        match Sequence::load(path) {
            Ok(sequence) => {
                self.lecture.sequence = sequence;
                self.go_to_preset(0);
                Ok(())
            }
            Err(e) => {
                self.lecture.error = Some(e.to_string());
                Err(e)
            }
        }
    }

    /// Back to the built-in lecture, at its first preset.
    pub fn open_lecture(&mut self) {
        self.lecture.sequence = Sequence::lecture();
        self.go_to_preset(0);
    }

    fn preset_dialog(&mut self, ctx: &egui::Context, save: bool) {
        use super::file_browser::{Purpose, Start};
        let (purpose, file_name) = if save {
            (Purpose::SavePreset, Some("preset.toml".to_string()))
        } else {
            (Purpose::LoadPresets, None)
        };
        let start = Start {
            folder: None,
            file_name,
        };
        self.files.start(ctx, purpose, start);
    }

    /// Keeps the current camera as a bookmark of the scene.
    pub fn bookmark_view(&mut self) {
        let list = self
            .settings
            .bookmarks
            .entry(self.settings.scene.clone())
            .or_default();
        list.push(Bookmark {
            name: format!("view {}", list.len() + 1),
            view: View::from_camera(&self.orbit.camera()),
        });
    }

    /// The scene's bookmarks.
    pub fn bookmarks(&self) -> &[Bookmark] {
        self.settings
            .bookmarks
            .get(&self.settings.scene)
            .map_or(&[], |b| b.as_slice())
    }

    /// Moves the camera to bookmark `index` of the scene; false if there is none.
    pub fn recall_bookmark(&mut self, index: usize) -> bool {
        let Some(view) = self.bookmarks().get(index).map(|b| b.view) else {
            return false;
        };
        self.orbit = Orbit::from_camera(&view.camera());
        true
    }

    pub fn delete_bookmark(&mut self, index: usize) {
        let scene = self.settings.scene.clone();
        if let Some(list) = self.settings.bookmarks.get_mut(&scene) {
            if index < list.len() {
                list.remove(index);
            }
            if list.is_empty() {
                self.settings.bookmarks.remove(&scene);
            }
        }
    }

    /// The digit keys: 1–9 open presets 1–9 and two digits typed quickly the presets from
    /// 10 on, Shift+1…0 the view modes, Ctrl+1–9 the scene's bookmarks; Page Down / Page Up
    /// the next and previous preset.
    /// A digit typed: step `digit` at once, or with the digit typed just before it the
    /// two-digit step they make, if the sequence has it.
    pub fn digit_typed(&mut self, digit: usize) {
        let now = std::time::Instant::now();
        let count = self.lecture.sequence.presets.len();
        let earlier = self.lecture.typed.take();
        if let Some((first, _)) = earlier.filter(|(_, at)| now - *at < TWO_DIGITS) {
            let step = first * 10 + digit;
            if (10..=count).contains(&step) {
                self.go_to_preset(step - 1);
                return;
            }
        }
        if digit > 0 {
            self.go_to_preset(digit - 1);
            self.lecture.typed = Some((digit, now));
        }
    }

    pub(super) fn lecture_keys(&mut self, ctx: &egui::Context) {
        for (digit, m) in digits_pressed(ctx) {
            if m.shift && !m.command {
                // Key 1 is the first mode, key 0 the tenth.
                self.settings.mode = ViewMode::ALL[(digit + 9) % 10];
            } else if m.command && digit > 0 {
                self.recall_bookmark(digit - 1);
            } else if !m.command && !m.alt {
                self.digit_typed(digit);
            }
        }
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k));
        if pressed(Key::PageDown) {
            self.step_preset(true);
        }
        if pressed(Key::PageUp) {
            self.step_preset(false);
        }
    }
}

/// Digit keys pressed this frame, with their modifiers. A digit is found by its place on
/// the keyboard when the layout reports one, so Shift+1 is digit 1 even where it types "!".
fn digits_pressed(ctx: &egui::Context) -> Vec<(usize, egui::Modifiers)> {
    const DIGITS: [Key; 10] = [
        Key::Num0,
        Key::Num1,
        Key::Num2,
        Key::Num3,
        Key::Num4,
        Key::Num5,
        Key::Num6,
        Key::Num7,
        Key::Num8,
        Key::Num9,
    ];
    ctx.input(|i| {
        i.events
            .iter()
            .filter_map(|e| match e {
                egui::Event::Key {
                    key,
                    physical_key,
                    pressed: true,
                    repeat: false,
                    modifiers,
                } => {
                    let k = physical_key.unwrap_or(*key);
                    DIGITS.iter().position(|d| *d == k).map(|d| (d, *modifiers))
                }
                _ => None,
            })
            .collect()
    })
}

/// Above the viewport while a preset is shown: its number, title and question, and the
/// way to the neighbours.
pub fn caption_bar(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let Some(index) = app.lecture.current else {
        return;
    };
    let Some(preset) = app.lecture.sequence.presets.get(index).cloned() else {
        return;
    };
    let count = app.lecture.sequence.presets.len();
    egui::Panel::top("caption").show(ui, |ui| {
        ui.horizontal(|ui| {
            if ui
                .add_enabled(index > 0, egui::Button::new("< previous preset"))
                .on_hover_text("previous preset (Page Up)")
                .clicked()
            {
                app.step_preset(false);
            }
            if ui
                .add_enabled(index + 1 < count, egui::Button::new("next preset >"))
                .on_hover_text("next preset (Page Down)")
                .clicked()
            {
                app.step_preset(true);
            }
            ui.menu_button(format!("{}/{count}", index + 1), |ui| {
                sequence_list(app, ui);
            });
            ui.heading(&preset.title);
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                if ui
                    .small_button("×")
                    .on_hover_text("hide the caption")
                    .clicked()
                {
                    app.lecture.current = None;
                }
            });
        });
        if !preset.caption.is_empty() {
            ui.label(RichText::new(&preset.caption).size(15.0));
        }
        ui.add_space(2.0);
    });
}

/// The presets of the sequence, numbered, the shown one selected: click to open.
fn sequence_list(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let titles: Vec<String> = app
        .lecture
        .sequence
        .presets
        .iter()
        .map(|p| p.title.clone())
        .collect();
    for (i, title) in titles.iter().enumerate() {
        // Every step by the key (or two) that opens it.
        let key = format!("{:>2}  ", i + 1);
        if ui
            .selectable_label(app.lecture.current == Some(i), format!("{key}{title}"))
            .clicked()
        {
            app.go_to_preset(i);
        }
    }
}

/// The Lecture menu of the top bar: the sequence, saving and loading presets, and the
/// scene's bookmarks.
pub fn menu(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.menu_button("Lecture", |ui| {
        let source = app.lecture.sequence.source.clone();
        ui.label(
            RichText::new(if source == super::preset::LECTURE {
                "the built-in lecture (keys 1–9, two digits for 10 on, Page Down / Page Up)"
                    .to_string()
            } else {
                format!("presets of {source}")
            })
            .weak(),
        );
        sequence_list(app, ui);
        ui.separator();
        if ui.button("Save preset…").clicked() {
            app.preset_dialog(ui.ctx(), true);
        }
        if ui.button("Load presets…").clicked() {
            app.preset_dialog(ui.ctx(), false);
        }
        if source != super::preset::LECTURE && ui.button("Back to the built-in lecture").clicked() {
            app.open_lecture();
        }
        if let Some(path) = &app.lecture.saved {
            ui.label(RichText::new(format!("saved {path}")).weak());
        }
        ui.separator();
        bookmarks(app, ui);
    });
}

/// The scene's camera bookmarks: click to go there, × to forget.
fn bookmarks(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    ui.label(RichText::new("bookmarks of this scene (Ctrl+1–9)").weak());
    let names: Vec<String> = app.bookmarks().iter().map(|b| b.name.clone()).collect();
    let mut delete = None;
    for (i, name) in names.iter().enumerate() {
        ui.horizontal(|ui| {
            let key = if i < 9 {
                format!("  (Ctrl+{})", i + 1)
            } else {
                String::new()
            };
            if ui.button(format!("{name}{key}")).clicked() {
                app.recall_bookmark(i);
            }
            if ui.small_button("×").on_hover_text("delete").clicked() {
                delete = Some(i);
            }
        });
    }
    if let Some(i) = delete {
        app.delete_bookmark(i);
    }
    if ui
        .button("Bookmark view")
        .on_hover_text("keep this camera for this scene, between runs")
        .clicked()
    {
        app.bookmark_view();
    }
}

/// Why the last preset file failed, at the top of the controls (like a scene that failed).
pub fn error(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    if let Some(n) = &app.lecture.notice {
        ui.colored_label(ui.visuals().warn_fg_color, n);
        if ui.button("Dismiss").clicked() {
            app.lecture.notice = None;
        }
        ui.separator();
    }
    if let Some(e) = &app.lecture.error {
        ui.colored_label(ui.visuals().error_fg_color, e);
        ui.label(RichText::new("Nothing was changed.").weak());
        if ui.button("Dismiss").clicked() {
            app.lecture.error = None;
        }
        ui.separator();
    }
}

/// Asks the worker to make step `index` + 1 of `sequence` ready while step `index` is shown
/// with `settings` (`worker::prefetch`): stepping forward then opens it at once.
pub(super) fn prefetch_next(
    worker: &mut super::worker::Worker,
    sequence: &Sequence,
    index: usize,
    settings: &Settings,
) {
    if let Some(next) = sequence.presets.get(index + 1) {
        worker.send(super::worker::Command::Prefetch {
            spec: next.scene.clone(),
            params: next.settings_over(settings).structure,
        });
    }
}
