//! The two layouts. Normal: controls on the left, statistics on the right, each
//! resizable and collapsible, sized so the view keeps at least `VIEW_SHARE` of the window
//! at any UI scale (a panel's contents wrap and scroll rather than squeeze the view). Presentation
//! (Tab or F11): no side panels, the view fills the window under one slim bar with the
//! step, its title and its caption in type scaled with the window, for the back of a room.

use crate::app::BvhLabApp;
use crate::app::preset::Focus;
use eframe::egui::{self, RichText};

/// The least share of the window's area the view keeps in the normal layout.
pub const VIEW_SHARE: f32 = 0.56;
/// A side panel is not made narrower than this (points) by the share, unless the share
/// leaves no room at all.
const MIN_PANEL: f32 = 140.0;
/// The room a panel's scroll bar takes beside its contents (points).
const SCROLL_BAR: f32 = 12.0;
/// Narrower than this (points), the two panels share one as tabs.
const COMFORTABLE: f32 = 200.0;

/// The controls and the statistics, each as wide as the view's share leaves room for.
/// When that room cannot hold both side by side (a large UI scale on a small window),
/// they share one panel as two tabs.
pub fn side_panels(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let window = ui.ctx().content_rect();
    let rest = ui.available_rect_before_wrap();
    // The view's height is what the bars left; its width must make up the share.
    let view_width = VIEW_SHARE * window.area() / rest.height().max(1.0);
    let room = (rest.width() - view_width).max(0.0);
    let (controls, stats) = (app.settings.show_controls, app.settings.show_stats);
    if controls && stats && room < 2.0 * COMFORTABLE {
        tabbed_panel(app, ui, room);
        app.panels_to_top = false;
        return;
    }
    let (left, right) = if controls && stats {
        (room * 0.52, room * 0.48)
    } else {
        (room, room)
    };
    // The panel may flip its flag (dragged shut); the contents need the app meanwhile.
    let mut open = controls;
    side_panel(egui::Panel::left("controls"), 300.0, left)
        .show_collapsible(ui, &mut open, |ui| controls_contents(app, ui));
    app.settings.show_controls = open;
    let mut open = stats;
    side_panel(egui::Panel::right("stats"), 290.0, right)
        .show_collapsible(ui, &mut open, |ui| stats_contents(app, ui));
    app.settings.show_stats = open;
    app.panels_to_top = false;
}

/// A resizable side panel of at most `max` points.
fn side_panel(panel: egui::Panel, default: f32, max: f32) -> egui::Panel {
    panel
        .resizable(true)
        .default_size(default.min(max))
        .size_range(MIN_PANEL.min(max)..=max.max(1.0))
}

fn controls_contents(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    // Sliders shrink with a narrow panel, so their labels stay in sight.
    let width = ui.available_width();
    ui.spacing_mut().slider_width = (width - 190.0).clamp(48.0, 150.0);
    scrolled(app, ui, "controls scroll", super::controls);
}

fn stats_contents(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    scrolled(app, ui, "stats scroll", super::stats);
}

/// A panel's contents in a scroll area: text wraps at the panel's width, a wider widget
/// scrolls sideways, and a lecture step just opened starts it at its top.
fn scrolled(
    app: &mut BvhLabApp,
    ui: &mut egui::Ui,
    salt: &str,
    contents: fn(&mut BvhLabApp, &mut egui::Ui),
) {
    let width = ui.available_width();
    // The panel keeps its width: text that wraps would let it shrink to its longest word.
    let mut area = egui::ScrollArea::both()
        .id_salt(salt)
        .auto_shrink([false, false]);
    if app.panels_to_top {
        area = area.vertical_scroll_offset(0.0);
    }
    area.show(ui, |ui| {
        ui.set_max_width(width - SCROLL_BAR);
        // Headings and labels wrap too: a sideways scroll area would let them run on.
        ui.style_mut().wrap_mode = Some(egui::TextWrapMode::Wrap);
        contents(app, ui)
    });
}

/// Where a section of the stats panel starts: scrolled into sight if the lecture step
/// that just opened is about it. Held there until the step has settled: the sections
/// above it (the report, the counters) grow as the build and the counted frame arrive.
pub(super) fn section_starts(app: &mut BvhLabApp, ui: &mut egui::Ui, section: Focus) {
    if app.panel_focus == Some(section) {
        // At once: a step opens on its point, not on a glide to it.
        ui.scroll_to_cursor_animation(Some(egui::Align::TOP), egui::style::ScrollAnimation::none());
        if app.settled() {
            app.panel_focus = None;
        }
    }
}

/// Which of the two panels the shared one shows.
#[derive(Clone, Copy, Default, PartialEq)]
enum Tab {
    #[default]
    Controls,
    Stats,
}

/// Both panels' contents in one left panel, one at a time.
fn tabbed_panel(app: &mut BvhLabApp, ui: &mut egui::Ui, room: f32) {
    let id = ui.scope_id().with("side panel tab");
    let mut tab: Tab = ui.data(|d| d.get_temp(id)).unwrap_or_default();
    // A lecture step about a section of the statistics shows them.
    if app.panel_focus.is_some() {
        tab = Tab::Stats;
    }
    side_panel(egui::Panel::left("controls and stats"), room, room).show(ui, |ui| {
        ui.horizontal(|ui| {
            ui.selectable_value(&mut tab, Tab::Controls, "Controls");
            ui.selectable_value(&mut tab, Tab::Stats, "Statistics");
        });
        ui.separator();
        match tab {
            Tab::Controls => controls_contents(app, ui),
            Tab::Stats => stats_contents(app, ui),
        }
    });
    ui.data_mut(|d| d.insert_temp(id, tab));
}

/// The size of the presentation bar's text (points): a fixed share of the window's
/// height in pixels, so it grows with the window and reads the same at any UI scale.
pub fn presentation_text(ctx: &egui::Context) -> f32 {
    let height_px = ctx.content_rect().height() * ctx.pixels_per_point();
    (height_px / 34.0).clamp(14.0, 64.0) / ctx.pixels_per_point()
}

/// How much larger what is drawn over the view (legends, counts, the in-view controls) is
/// in the presentation layout, where it grows with the window as the caption does; 1 in
/// the normal layout.
pub fn in_view_scale(presentation: bool, ctx: &egui::Context) -> f32 {
    if presentation {
        (presentation_text(ctx) / 12.0).max(1.0)
    } else {
        1.0
    }
}

/// Scales `ui`'s text and widgets by `scale` (the in-view controls in the presentation
/// layout): its text styles, spacing and the sizes of its buttons, sliders and boxes.
pub fn scale_widgets(ui: &mut egui::Ui, scale: f32) {
    if scale == 1.0 {
        return;
    }
    let style = ui.style_mut();
    for font in style.text_styles.values_mut() {
        font.size *= scale;
    }
    let s = &mut style.spacing;
    s.item_spacing *= scale;
    s.button_padding *= scale;
    s.interact_size *= scale;
    s.slider_width *= scale;
    s.icon_width *= scale;
    s.icon_width_inner *= scale;
    s.icon_spacing *= scale;
}

/// The presentation layout's one bar: the step and its title, the caption, and the way
/// back to the normal layout.
pub fn presentation_bar(app: &mut BvhLabApp, ui: &mut egui::Ui) {
    let size = presentation_text(ui.ctx());
    let step = app.lecture.current.and_then(|i| {
        let preset = app.lecture.sequence.presets.get(i)?;
        Some((i, app.lecture.sequence.presets.len(), preset.clone()))
    });
    egui::Panel::top("presentation").show(ui, |ui| {
        ui.horizontal_wrapped(|ui| {
            match &step {
                Some((i, count, preset)) => {
                    ui.label(
                        RichText::new(format!("{}/{count}", i + 1))
                            .size(size)
                            .weak(),
                    );
                    ui.label(RichText::new(&preset.title).size(size * 1.15).strong());
                }
                None => {
                    let scene = app.scene.as_ref().map_or("", |s| s.name.as_str());
                    let title = format!("{scene}: {}", app.settings.structure.kind.title());
                    ui.label(RichText::new(title).size(size * 1.15).strong());
                }
            }
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                // Buttons the lecturer finds at a glance on the projected window: their
                // text as large as the caption's.
                scale_widgets(ui, (size * 0.8 / 12.5).max(1.0));
                if ui
                    .button("exit presentation")
                    .on_hover_text("back to the panels (Tab or F11)")
                    .clicked()
                {
                    app.settings.presentation = false;
                }
                if let Some((i, count, _)) = &step {
                    if ui
                        .add_enabled(i + 1 < *count, egui::Button::new("next >"))
                        .on_hover_text("next step (Page Down)")
                        .clicked()
                    {
                        app.step_preset(true);
                    }
                    if ui
                        .add_enabled(*i > 0, egui::Button::new("< previous"))
                        .on_hover_text("previous step (Page Up)")
                        .clicked()
                    {
                        app.step_preset(false);
                    }
                }
            });
        });
        if let Some((_, _, preset)) = &step
            && !preset.caption.is_empty()
        {
            let strong = ui.visuals().strong_text_color();
            ui.label(
                RichText::new(&preset.caption)
                    .size(size * 0.8)
                    .color(strong),
            );
        }
        ui.add_space(2.0);
    });
}
