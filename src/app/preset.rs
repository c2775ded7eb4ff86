//! Lecture presets: one view of the lecture — scene, camera, structure and its parameters,
//! view mode, overlays, tool — as a small TOML file a lecturer can write by hand, save from
//! the app and load by key. A file holds one preset (its keys at the top) or a sequence
//! (`[[preset]]` tables, in lecture order). The built-in lecture is such a file,
//! `assets/lecture.toml`, compiled into the program.
//!
//! Everything is checked before anything is applied: a bad file is an error that names the
//! file, the preset and the field (and the line, for what TOML itself rejects), and the
//! app's state stays as it was.

use super::Tool;
use super::settings::Settings;
use crate::accel::StructureParams;
use crate::geometry::simd::SimdLevel;
use crate::scene::{Camera, builtin};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The lecture, in order, as shipped.
pub const LECTURE_TOML: &str = include_str!("../../assets/lecture.toml");

/// What `--preset lecture` and the app's Lecture panel call the built-in sequence.
pub const LECTURE: &str = "lecture";

/// A camera of a preset: where the eye is, the point it looks at and the vertical field
/// of view in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct View {
    pub eye: [f32; 3],
    pub look: [f32; 3],
    #[serde(default = "default_fov")]
    pub fov: f32,
}

fn default_fov() -> f32 {
    60.0
}

impl View {
    pub fn from_camera(c: &Camera) -> Self {
        View {
            eye: c.eye.to_array(),
            look: c.look_at.to_array(),
            fov: c.fov_y_deg,
        }
    }

    pub fn camera(&self) -> Camera {
        Camera {
            fov_y_deg: self.fov,
            ..Camera::new(Vec3::from(self.eye), Vec3::from(self.look))
        }
    }

    fn check(&self) -> Result<(), String> {
        let finite = self.eye.iter().chain(&self.look).all(|x| x.is_finite());
        if !finite {
            return Err("camera: eye and look must be finite numbers".into());
        }
        let limit = crate::scene::MAX_COORDINATE;
        if self.eye.iter().chain(&self.look).any(|x| x.abs() > limit) {
            return Err(format!(
                "camera: eye and look must be within ±{limit:e}, where ray arithmetic stays in f32"
            ));
        }
        if Vec3::from(self.eye).distance(Vec3::from(self.look)) < 1e-6 {
            return Err("camera: eye and look are the same point".into());
        }
        if !(1.0..=170.0).contains(&self.fov) {
            return Err(format!(
                "camera: fov {} is not an angle from 1 to 170 degrees",
                self.fov
            ));
        }
        Ok(())
    }
}

/// A section of the stats panel a preset can open at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Focus {
    /// "SAH predicted against measured".
    SahCheck,
    /// The ray replay's list of visits.
    Replay,
    /// The SAH cost's growth since the build.
    Refit,
    /// A against B.
    Compare,
}

/// One view of the lecture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Preset {
    pub title: String,
    /// The question the view answers, shown under the title while the preset is active.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub caption: String,
    /// A built-in scene (`cornell`, `walls-rotated@30`, …) or a file; a relative path is
    /// first looked for beside the preset file.
    pub scene: String,
    /// None: the scene's own start view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<View>,
    #[serde(default)]
    pub tool: Tool,
    /// The tree walk opened at this node (0 = the root).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk: Option<u32>,
    /// The stats panel's section the step is about, scrolled into sight when it opens
    /// (without it the panels open at their top).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus: Option<Focus>,
    /// The structure, its parameters, the view mode and the overlays: the app's settings,
    /// every one optional (missing = its default).
    #[serde(default)]
    pub settings: Settings,
    /// Configuration A of a comparison, pinned when the preset opens (the settings are B);
    /// none: nothing pinned. Its fields are the structure's settings, missing = default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pinned: Option<StructureParams>,
}

/// Settings that belong to the person at the computer, not to a view of the lecture: a
/// preset neither saves nor sets them.
/// The layout is among them: a lecture step does not open or close the panels.
const PERSONAL: [&str; 8] = [
    "scene",
    "ui_scale",
    "presentation",
    "show_controls",
    "show_stats",
    "show_tree",
    "recent",
    "bookmarks",
];

/// A list of presets and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    /// `lecture` or the file's path.
    pub source: String,
    pub presets: Vec<Preset>,
}

/// A preset file that cannot be used: the file, and what is wrong with it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct PresetError {
    pub origin: String,
    pub message: String,
}

impl Sequence {
    /// The built-in lecture.
    pub fn lecture() -> Sequence {
        parse(LECTURE_TOML, LECTURE, None).expect("the built-in lecture is a valid preset file")
    }

    /// Reads a preset file (one preset or a sequence).
    pub fn load(path: &Path) -> Result<Sequence, PresetError> {
        let origin = path.display().to_string();
        let text = crate::input::read_text(path, 1).map_err(|e| PresetError {
            origin: origin.clone(),
            message: format!("cannot read it: {e}"),
        })?;
        parse(&text, &origin, path.parent())
    }

    /// `lecture`, `lecture:N`, `FILE` or `FILE:N` (N counted from 1): the sequence and the
    /// index of the preset named.
    pub fn open(spec: &str) -> Result<(Sequence, usize), PresetError> {
        if spec.trim().is_empty() {
            return Err(PresetError {
                origin: "the preset".into(),
                message: format!(
                    "no preset named: give `{LECTURE}`, `{LECTURE}:N`, a preset file or FILE:N"
                ),
            });
        }
        let (name, step) = match spec.rsplit_once(':') {
            Some((name, n)) if n.parse::<usize>().is_ok() && !Path::new(spec).exists() => {
                (name, n.parse::<usize>().ok())
            }
            // `lecture:abc` or `file.toml:abc`: a sequence named, with no number after it.
            Some((name, n))
                if !Path::new(spec).exists() && (name == LECTURE || Path::new(name).is_file()) =>
            {
                return Err(PresetError {
                    origin: name.to_string(),
                    message: format!("'{n}' is not a preset number (they count from 1)"),
                });
            }
            _ => (spec, None),
        };
        let sequence = if name == LECTURE {
            Sequence::lecture()
        } else {
            Sequence::load(Path::new(name))?
        };
        let count = sequence.presets.len();
        let index = match step {
            None => 0,
            Some(n) if (1..=count).contains(&n) => n - 1,
            Some(n) => {
                return Err(PresetError {
                    origin: sequence.source,
                    message: format!("there is no preset {n}: it holds presets 1 to {count}"),
                });
            }
        };
        Ok((sequence, index))
    }
}

/// Parses and checks a preset file's text; `dir` is where relative scene paths are also
/// looked for.
pub fn parse(text: &str, origin: &str, dir: Option<&Path>) -> Result<Sequence, PresetError> {
    let fail = |message: String| PresetError {
        origin: origin.to_string(),
        message,
    };
    // First the syntax and the keys, then the values (serde's errors carry the line).
    let table: toml::Table = toml::from_str(text).map_err(|e| fail(one_line(text, &e)))?;
    let (tables, mut presets) = match table.get("preset") {
        Some(list) => {
            #[derive(Deserialize)]
            #[serde(deny_unknown_fields)]
            struct File {
                preset: Vec<Preset>,
            }
            let tables: Vec<toml::Table> = match list {
                toml::Value::Array(a) => a.iter().filter_map(|v| v.as_table().cloned()).collect(),
                _ => Vec::new(),
            };
            let file: File = toml::from_str(text).map_err(|e| fail(locate(text, e)))?;
            (tables, file.preset)
        }
        None => {
            let one: Preset = toml::from_str(text).map_err(|e| fail(locate(text, e)))?;
            (vec![table.clone()], vec![one])
        }
    };
    if presets.is_empty() {
        return Err(fail("it holds no preset".into()));
    }
    let known = key_names(Settings::default());
    let known_pinned = key_names(StructureParams::default());
    for (i, (preset, table)) in presets.iter_mut().zip(&tables).enumerate() {
        let name = format!("preset {} ('{}')", i + 1, preset.title);
        if let Some(toml::Value::Table(pinned)) = table.get("pinned")
            && let Some(key) = pinned.keys().find(|k| !known_pinned.contains(k))
        {
            return Err(fail(format!(
                "{name}: unknown setting '{key}' in [pinned] (its settings are: {})",
                known_pinned.join(", ")
            )));
        }
        if let Some(toml::Value::Table(settings)) = table.get("settings") {
            for key in settings.keys() {
                if PERSONAL.contains(&key.as_str()) {
                    return Err(fail(format!(
                        "{name}: '{key}' is not set by a preset{}",
                        if key == "scene" {
                            " (the preset's own `scene` is)"
                        } else {
                            ""
                        }
                    )));
                }
                if !known.contains(key) {
                    return Err(fail(format!(
                        "{name}: unknown setting '{key}' (the settings are: {})",
                        known
                            .iter()
                            .filter(|k| !PERSONAL.contains(&k.as_str()))
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(", ")
                    )));
                }
            }
        }
        preset.scene =
            resolve_scene(&preset.scene, dir).map_err(|e| fail(format!("{name}: {e}")))?;
        preset.settings.scene = preset.scene.clone();
        if let Err(e) = preset.check() {
            let at = culprit(text, i, table, preset).unwrap_or_default();
            return Err(fail(format!("{name}: {at}{e}")));
        }
    }
    Ok(Sequence {
        source: origin.to_string(),
        presets,
    })
}

/// A TOML error on one line, with its line and column, as every other error is said
/// (the parser's own text draws the line over several).
fn one_line(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim();
    let Some(span) = error.span() else {
        return message.to_string();
    };
    let before = &text[..span.start.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {column}: {message}")
}

/// Where in preset `index`'s `[settings]` a value the checks refuse is written ("line 5:
/// setting 'buckets': "): each setting is checked alone, over the defaults, and the first
/// refused one is found in the file.
fn culprit(text: &str, index: usize, table: &toml::Table, preset: &Preset) -> Option<String> {
    let settings = table.get("settings")?.as_table()?;
    let key = settings.iter().find_map(|(key, value)| {
        let one = toml::Table::from_iter([(key.clone(), value.clone())]);
        let alone: Settings = toml::Value::Table(one).try_into().ok()?;
        let p = Preset {
            settings: alone,
            camera: None,
            ..preset.clone()
        };
        p.check().is_err().then_some(key)
    })?;
    // The line of `key =` within the preset's own tables.
    let starts = |l: &str| l.trim_start().starts_with("[[preset]]");
    let mut seen = 0;
    for (n, line) in text.lines().enumerate() {
        if starts(line) {
            seen += 1;
        }
        let written = line.trim_start().strip_prefix(key.as_str());
        let is_key = written.is_some_and(|r| r.trim_start().starts_with('='));
        if is_key && (seen == index + 1 || (seen == 0 && index == 0)) {
            return Some(format!("line {}: setting '{key}': ", n + 1));
        }
    }
    Some(format!("setting '{key}': "))
}

/// A value serde rejects, said with its line. The settings' keys are read as one flattened
/// table, so serde's error points at the table's header: here the table's lines are read
/// one by one to find the setting whose value is wrong.
fn locate(text: &str, error: toml::de::Error) -> String {
    let Some(span) = error.span() else {
        return one_line(text, &error);
    };
    // The table starts on the line of the span: its header, then its keys.
    let first = text[..span.start.min(text.len())].lines().count();
    let is_header = |l: &str| l.trim_start().starts_with('[');
    let mut lines = text.lines().enumerate().skip(first).peekable();
    lines.next_if(|(_, l)| is_header(l));
    let in_table = lines.take_while(|(_, l)| !is_header(l));
    for (i, line) in in_table {
        if let Some((key, _)) = line.split_once('=')
            && let Err(e) = toml::from_str::<Settings>(line)
        {
            return format!("line {}: setting '{}': {}", i + 1, key.trim(), e.message());
        }
    }
    one_line(text, &error)
}

/// The keys of `value`'s fields, as a preset file spells them.
fn key_names(value: impl Serialize) -> Vec<String> {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::Object(map)) => map.keys().cloned().collect(),
        _ => Vec::new(),
    }
}

/// A built-in scene as it is; a file that exists as it is or beside the preset file.
fn resolve_scene(spec: &str, dir: Option<&Path>) -> Result<String, String> {
    let base = spec.split([':', '@']).next().unwrap_or(spec);
    if builtin::NAMES.contains(&base) {
        // Its size is checked here, so the message names the preset file.
        if builtin::check(spec).map_err(|e| e.to_string())? {
            return Ok(spec.to_string());
        }
    }
    if Path::new(spec).is_file() {
        return Ok(spec.to_string());
    }
    if let Some(beside) = dir.map(|d| d.join(spec)).filter(|p| p.is_file()) {
        return Ok(beside.display().to_string());
    }
    Err(format!(
        "unknown scene '{spec}': not a built-in scene ({}) nor a file that exists",
        builtin::NAMES.join(", ")
    ))
}

impl Preset {
    /// The values serde cannot check: the camera and the structure's parameters.
    fn check(&self) -> Result<(), String> {
        if let Some(view) = &self.camera {
            view.check()?;
        }
        self.settings
            .structure
            .validate()
            .map_err(|e| e.to_string())?;
        if let Some(reason) = self.settings.mode.missing_counts(&self.settings.structure) {
            return Err(format!(
                "mode {:?} shows nothing here: {reason}",
                self.settings.mode
            ));
        }
        if self.settings.heat_max == Some(0) {
            return Err("heat_max must be at least 1".into());
        }
        match &self.pinned {
            Some(a) => a.validate().map_err(|e| format!("pinned: {e}")),
            None => Ok(()),
        }
    }

    /// The settings the preset sets, with the personal ones kept from `current`.
    pub fn settings_over(&self, current: &Settings) -> Settings {
        Settings {
            scene: self.scene.clone(),
            ..self.settings.with_personal_of(current)
        }
    }

    /// The preset as a file of its own (one preset, its keys at the top).
    pub fn to_toml(&self) -> String {
        let Ok(toml::Value::Table(mut table)) = toml::Value::try_from(self) else {
            return String::new();
        };
        if let Some(toml::Value::Table(settings)) = table.get_mut("settings") {
            for key in PERSONAL {
                settings.remove(key);
            }
            // The machine's own SIMD kernel is the default; only another choice is saved,
            // so the file loads on machines with other vector units.
            if self.settings.structure.simd == SimdLevel::detect() {
                settings.remove("simd");
            }
        }
        if let Some(toml::Value::Table(pinned)) = table.get_mut("pinned")
            && self.pinned.as_ref().map(|a| a.simd) == Some(SimdLevel::detect())
        {
            pinned.remove("simd");
        }
        shortest_floats(&mut table);
        toml::to_string(&table).unwrap_or_default()
    }
}

/// Every number of a preset is an `f32`: written as the shortest decimal that reads back
/// as the same `f32` (0.1, not 0.10000000149011612), for the eye of whoever edits the file.
fn shortest_floats(table: &mut toml::Table) {
    fn visit(v: &mut toml::Value) {
        match v {
            toml::Value::Float(f) => {
                if let Ok(short) = (*f as f32).to_string().parse::<f64>() {
                    *f = short;
                }
            }
            toml::Value::Array(a) => a.iter_mut().for_each(visit),
            toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| visit(v)),
            _ => {}
        }
    }
    table.iter_mut().for_each(|(_, v)| visit(v));
}
