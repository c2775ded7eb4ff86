//! What the app remembers between runs (eframe persistence): the structure and its
//! parameters (the library's `StructureParams`, one definition for the app, the CLI and the
//! presets), the view, the UI scale and the recently opened files.

use super::preset::View;
use crate::accel::{AccelKind, StructureParams};
use crate::geometry::IntersectorKind;
use crate::render::ViewMode;
use crate::render::compare::CompareView;
use crate::render::heat::HeatStyle;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub const STORAGE_KEY: &str = "bvhlab-settings";
const MAX_RECENT: usize = 8;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    pub scene: String,
    /// The structure the app builds, its parameters and traversal settings: configuration
    /// B of a comparison. Its keys stand beside the others (`accel`, `strategy`, …).
    #[serde(flatten)]
    pub structure: StructureParams,
    pub mode: ViewMode,
    /// Heatmaps count shadow rays instead of primary rays.
    pub shadow_rays: bool,
    /// Fixed top of the heatmap scale; `None` = each frame's maximum.
    pub heat_max: Option<u32>,
    /// A heatmap's curve (linear or log), clipping at a percentile and shaded underlay.
    #[serde(flatten)]
    pub heat_style: HeatStyle,
    pub show_levels: bool,
    pub level: u32,
    pub see_through: bool,
    pub color_by_node: bool,
    pub move_whole_object: bool,
    /// With a pinned configuration A: B alone, A | B, or B − A.
    pub compare_view: CompareView,
    /// Rebuild automatically when the SAH cost has grown by more than this many percent.
    pub auto_rebuild_percent: Option<f32>,
    pub ui_scale: f32,
    /// The presentation layout: the view fills the window under one slim caption bar.
    pub presentation: bool,
    /// The side panels of the normal layout, each collapsed or not.
    pub show_controls: bool,
    pub show_stats: bool,
    /// The hierarchy diagram under the view.
    pub show_tree: bool,
    /// The cracks: exact rays at every shared edge and vertex in view, those that slip
    /// through `crack_intersector` marked in red, with the scene (and camera) moved by
    /// `crack_offset` on every axis.
    pub show_cracks: bool,
    pub crack_intersector: IntersectorKind,
    pub crack_offset: f64,
    pub recent: Vec<String>,
    /// Camera bookmarks per scene (keyed by its spec), kept between runs.
    pub bookmarks: BTreeMap<String, Vec<Bookmark>>,
}

/// A camera kept under a name for one scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bookmark {
    pub name: String,
    pub view: View,
}

impl Settings {
    /// These settings with the personal ones of `current`: the UI scale, the layout, the
    /// recent files and the bookmarks (`preset::PERSONAL` lists their keys).
    pub fn with_personal_of(&self, current: &Settings) -> Settings {
        Settings {
            ui_scale: current.ui_scale,
            presentation: current.presentation,
            show_controls: current.show_controls,
            show_stats: current.show_stats,
            show_tree: current.show_tree,
            recent: current.recent.clone(),
            bookmarks: current.bookmarks.clone(),
            ..self.clone()
        }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            scene: "cornell".into(),
            // Trace with the fastest layout until the user picks another.
            structure: StructureParams::of_kind(AccelKind::fastest()),
            mode: ViewMode::Shaded,
            shadow_rays: false,
            heat_max: None,
            heat_style: HeatStyle::default(),
            show_levels: false,
            level: 0,
            see_through: false,
            color_by_node: false,
            move_whole_object: false,
            compare_view: CompareView::Split,
            auto_rebuild_percent: None,
            ui_scale: 1.0,
            presentation: false,
            show_controls: true,
            show_stats: true,
            show_tree: false,
            show_cracks: false,
            crack_intersector: IntersectorKind::MollerTrumbore,
            crack_offset: 0.0,
            recent: Vec::new(),
            bookmarks: BTreeMap::new(),
        }
    }
}

impl Settings {
    /// Remembers a file that loaded, most recent first.
    pub fn add_recent(&mut self, path: &str) {
        self.recent.retain(|p| p != path);
        self.recent.insert(0, path.to_string());
        self.recent.truncate(MAX_RECENT);
    }

    /// The settings as eframe stores them (RON).
    pub fn to_ron(&self) -> Option<String> {
        ron::ser::to_string(self).ok()
    }

    /// Settings stored by this version of the app or by an earlier one, which wrote them
    /// as a RON struct `(scene: …, accel: …)` where this one writes a map `{"scene": …}`
    /// (the structure's keys are flattened in). `None` for text that is neither.
    pub fn from_ron(text: &str) -> Option<Settings> {
        ron::from_str(text)
            .ok()
            .or_else(|| ron::from_str(&struct_as_map(text)?).ok())
    }
}

/// A RON struct written without its name, `(a: 1, b: (c: 2))`, as the map `{"a": 1, "b":
/// (c: 2)}`: only the outermost fields become keys. `None` if `text` is not such a struct.
fn struct_as_map(text: &str) -> Option<String> {
    let body = text.trim().strip_prefix('(')?.strip_suffix(')')?;
    let mut out = String::from("{");
    let mut depth = 0usize;
    let mut in_string = false;
    let mut escaped = false;
    let mut at_key = true;
    let mut key = String::new();
    for c in body.chars() {
        if at_key {
            match c {
                ':' => {
                    out.push_str(&format!("\"{}\":", key.trim()));
                    key.clear();
                    at_key = false;
                }
                c if c.is_alphanumeric() || c == '_' || c.is_whitespace() => key.push(c),
                _ => return None,
            }
            continue;
        }
        out.push(c);
        if in_string {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match c {
            '"' => in_string = true,
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => depth = depth.checked_sub(1)?,
            ',' if depth == 0 => at_key = true,
            _ => {}
        }
    }
    if depth != 0 || in_string || !key.trim().is_empty() {
        return None;
    }
    out.push('}');
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_round_trip_through_eframes_storage() {
        let mut s = Settings {
            scene: "walls".into(),
            mode: ViewMode::Nodes,
            heat_max: Some(40),
            ..Default::default()
        };
        s.structure.kind = AccelKind::KdTree;
        s.structure.mailbox = false;
        s.add_recent("a \"quoted\" (path).obj");
        let text = s.to_ron().unwrap();
        assert_eq!(Settings::from_ron(&text), Some(s));
        assert_eq!(Settings::from_ron("not settings"), None);
        assert_eq!(Settings::from_ron("(scene: \"x\""), None);
    }

    #[test]
    fn a_ron_struct_becomes_a_map_of_its_outer_fields() {
        assert_eq!(
            struct_as_map("(a:1,b:(c:\"x,)\"),d:[1,2],e:{\"k\":(f:2)})").as_deref(),
            Some("{\"a\":1,\"b\":(c:\"x,)\"),\"d\":[1,2],\"e\":{\"k\":(f:2)}}")
        );
        assert_eq!(struct_as_map("{\"a\":1}"), None);
    }
}
