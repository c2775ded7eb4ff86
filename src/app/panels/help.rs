//! The help window: every shortcut and what each tool does.

use crate::app::BvhLabApp;
use eframe::egui::{self};

pub fn help_window(app: &mut BvhLabApp, ctx: &egui::Context) {
    let mut open = app.show_help;
    egui::Window::new("Help")
        .open(&mut open)
        .resizable(false)
        .show(ctx, |ui| {
            egui::Grid::new("keys")
                .num_columns(2)
                .striped(true)
                .show(ui, |ui| {
                    for (k, what) in [
                        ("left drag", "orbit (or move a triangle with the move tool)"),
                        ("right / middle drag", "pan"),
                        ("wheel", "zoom"),
                        ("F", "frame the whole scene"),
                        ("R", "back to the scene's own view"),
                        ("O / M", "orbit tool / move-triangles tool"),
                        ("P", "replay tool: click a pixel to replay its ray"),
                        (
                            "Left / Right, Home / End",
                            "replay: previous / next visit, first / last visit",
                        ),
                        ("Esc", "close the replay"),
                        ("1 … 9", "lecture presets 1 to 9"),
                        ("two digits quickly", "presets 10 on (1, 7: preset 17)"),
                        ("Page Down / Page Up", "next / previous preset"),
                        (
                            "Shift+1 … 7",
                            "shaded, normals, depth, nodes, box tests, triangle tests, repeated tests",
                        ),
                        (
                            "Shift+8, 9, 0",
                            "two levels: top-level nodes, bottom-level nodes, instances entered",
                        ),
                        ("Ctrl+1 … 9", "the scene's camera bookmarks"),
                        ("S", "heatmaps of shadow rays on/off"),
                        ("A", "pin the current configuration as A / unpin"),
                        ("C", "comparison view: B only, A | B, B − A"),
                        ("L", "level boxes on/off"),
                        ("[ / ]", "previous / next level"),
                        ("W", "tree walk on/off"),
                        (
                            "wheel / drag on the tree",
                            "zoom / pan the hierarchy diagram (double-click: the whole tree)",
                        ),
                        (
                            "Up / Left / Right",
                            "walk to parent / first child / last child",
                        ),
                        ("B", "rebuild the structure"),
                        ("Ctrl+Z", "undo the last move"),
                        ("Ctrl+O", "open an OBJ file (or drop one on the window)"),
                        (
                            "Tab or F11",
                            "presentation layout: the view fills the window, the caption above",
                        ),
                        ("F1", "this help"),
                    ] {
                        ui.strong(k);
                        ui.label(what);
                        ui.end_row();
                    }
                });
        });
    app.show_help = open;
}
