//! The structure's parameters as controls. Each parameter struct of the library
//! (`BuildParams`, `KdParams`, `GridParams`, `OctreeParams`) derives `Controls`, and one
//! egui visitor draws them all; the structure selector, the traversal order and the SIMD
//! kernel (settings of `StructureParams` itself) are drawn here. The same structs are the
//! CLI's flags and the presets' keys, so a parameter has one definition and its slider
//! follows from it.

use crate::accel::bvh::TraversalOrder;
use crate::accel::controls::{Control, ControlVisitor, Controls};
use crate::accel::{AccelKind, StructureParams};
use crate::geometry::simd::SimdLevel;
use eframe::egui;

/// The structure selector and the parameters of the chosen structure.
pub fn structure_params(ui: &mut egui::Ui, p: &mut StructureParams) {
    // The layout this machine traces fastest says so (the default of a fresh start).
    let selected = if p.kind == AccelKind::fastest() {
        format!("{} (fastest here)", p.kind.title())
    } else {
        p.kind.title().to_string()
    };
    let width = combo_width(ui, "structure");
    // A long name ("two-level (TLAS + BLAS)") would push its label into a column of single
    // letters in a narrow panel: the short one stands in for it.
    let selected = if text_width(ui, &selected) + 24.0 > width {
        p.kind.label().to_string()
    } else {
        selected
    };
    egui::ComboBox::from_label("structure")
        .width(width)
        .selected_text(selected)
        .show_ui(ui, |ui| {
            for kind in AccelKind::ALL {
                ui.selectable_value(&mut p.kind, kind, kind.title());
            }
        });
    if p.kind.is_spatial() {
        ui.checkbox(
            &mut p.mailbox,
            "mailboxing (test each triangle once per ray)",
        );
    }
    match p.kind {
        AccelKind::Bvh | AccelKind::TwoLevel => {
            let (scopes, off): (&[&str], _) = if p.kind.places_instances() {
                (&["two-level", "wide"], p.bvh.off_when_wide())
            } else {
                (&[], &[][..])
            };
            edit(ui, &mut p.bvh, scopes, off);
            traversal_order(ui, &mut p.order);
        }
        AccelKind::Bvh4 | AccelKind::Bvh8 => {
            let off = p.bvh.off_when_wide();
            edit(ui, &mut p.bvh, &["wide"], off);
            traversal_order(ui, &mut p.order);
            simd_level(ui, &mut p.simd);
        }
        AccelKind::KdTree => edit(ui, &mut p.kdtree, &[], &[]),
        AccelKind::Grid => edit(ui, &mut p.grid, &[], &[]),
        AccelKind::Octree => {
            edit(ui, &mut p.octree, &[], &[]);
            // The octree's SAH cost is weighed with the k-d tree's constants (its cells are
            // costed as the k-d tree's are): their two sliders, here too.
            edit_only(ui, &mut p.kdtree, &["kd_c_trav", "kd_c_isect"]);
        }
        AccelKind::BruteForce | AccelKind::BruteForceBbox => {}
    }
}

/// Draws each control of a parameter struct: numbers as sliders, enums as radio buttons,
/// toggles as checkboxes; a control that does not apply to the current choices is greyed
/// out, and one scoped to a context (`scope`) is shown only in it. The labels, ranges and
/// hover texts come from the struct's `#[param]` attributes and doc comments.
struct Editor<'a> {
    ui: &'a mut egui::Ui,
    scopes: &'a [&'a str],
    /// Controls switched off in these contexts by another setting (`off_when_wide`).
    off: &'a [&'a str],
    /// The only controls drawn, by key (empty: all).
    only: &'a [&'a str],
}

impl Editor<'_> {
    fn shown(&self, c: &Control) -> bool {
        c.scope.is_none_or(|scope| self.scopes.contains(&scope))
            && (self.only.is_empty() || self.only.contains(&c.key))
    }

    fn enabled(&self, c: &Control) -> bool {
        c.enabled && !self.off.contains(&c.key)
    }

    fn hover(response: egui::Response, c: &Control) {
        if !c.help.is_empty() {
            response.on_hover_text(c.help);
        }
    }
}

impl Editor<'_> {
    /// A number's slider over `range`, greyed out where the control does not apply.
    fn slider<N: egui::emath::Numeric>(
        &mut self,
        c: &Control,
        value: &mut N,
        range: std::ops::RangeInclusive<N>,
    ) {
        if self.shown(c) {
            let enabled = self.enabled(c);
            // The name beside the slider ends in "…" at the panel's edge, whole on hover (a
            // slider's own text would run past the edge and widen the panel's rows below).
            self.ui.horizontal(|ui| {
                let slider = egui::Slider::new(value, range).logarithmic(c.log);
                let slider = ui.add_enabled(enabled, slider);
                let name = ui.add_enabled(enabled, egui::Label::new(c.label).truncate());
                // The slider is still named by its label (screen readers, UI tests).
                Self::hover(slider.labelled_by(name.id), c);
                Self::hover(name, c);
            });
        }
    }
}

impl ControlVisitor for Editor<'_> {
    fn whole(&mut self, c: &Control, value: &mut u32) {
        let (lo, hi) = c.range();
        self.slider(c, value, lo as u32..=hi as u32);
    }

    fn real(&mut self, c: &Control, value: &mut f32) {
        let (lo, hi) = c.range();
        self.slider(c, value, lo as f32..=hi as f32);
    }

    fn flag(&mut self, c: &Control, value: &mut bool) {
        if self.shown(c) {
            let checkbox = egui::Checkbox::new(value, c.label);
            let enabled = self.enabled(c);
            Self::hover(self.ui.add_enabled(enabled, checkbox), c);
        }
    }

    fn choice(&mut self, c: &Control, selected: &mut usize, options: &[&'static str]) {
        if self.shown(c) {
            self.ui.label(c.label);
            let enabled = self.enabled(c);
            for (i, option) in options.iter().enumerate() {
                let radio = egui::RadioButton::new(*selected == i, *option);
                if self.ui.add_enabled(enabled, radio).clicked() {
                    *selected = i;
                }
            }
        }
    }
}

/// The controls of one parameter struct, in the contexts `scopes`, those keyed in `off`
/// greyed out.
pub fn edit(ui: &mut egui::Ui, params: &mut impl Controls, scopes: &[&str], off: &[&str]) {
    params.visit_controls(&mut Editor {
        ui,
        scopes,
        off,
        only: &[],
    });
}

/// The controls keyed in `only` of one parameter struct.
pub fn edit_only(ui: &mut egui::Ui, params: &mut impl Controls, only: &[&str]) {
    params.visit_controls(&mut Editor {
        ui,
        scopes: &[],
        off: &[],
        only,
    });
}

/// Front-to-back or the naive order (a traversal setting: no rebuild).
pub fn traversal_order(ui: &mut egui::Ui, order: &mut TraversalOrder) {
    let mut naive = *order == TraversalOrder::Naive;
    if ui
        .checkbox(&mut naive, "naive traversal order (no front-to-back)")
        .changed()
    {
        *order = if naive {
            TraversalOrder::Naive
        } else {
            TraversalOrder::FrontToBack
        };
    }
}

/// A combo box's width that leaves its label room on the same line in a narrow panel
/// (squeezed, the label would wrap a letter per line).
fn combo_width(ui: &egui::Ui, label: &str) -> f32 {
    // The icon, the spacing and the scroll bar's room besides the label.
    let room =
        ui.available_width() - text_width(ui, label) - 4.0 * ui.spacing().item_spacing.x - 24.0;
    room.clamp(60.0, 220.0)
}

/// The width of `text` on one line, in a button's font.
fn text_width(ui: &egui::Ui, text: &str) -> f32 {
    egui::WidgetText::from(text)
        .into_galley(
            ui,
            Some(egui::TextWrapMode::Extend),
            f32::INFINITY,
            egui::TextStyle::Button,
        )
        .size()
        .x
}

/// The wide BVHs' slab kernel, among those this CPU has.
pub fn simd_level(ui: &mut egui::Ui, simd: &mut SimdLevel) {
    egui::ComboBox::from_label("SIMD kernel")
        .width(combo_width(ui, "SIMD kernel"))
        .selected_text(simd.label())
        .show_ui(ui, |ui| {
            for level in SimdLevel::available() {
                ui.selectable_value(simd, level, level.label());
            }
        });
}
