//! The build report every structure gives, in the same measures so structures compare:
//! build time, memory, nodes or cells, depth, empty cells, references per triangle, the
//! largest leaf, and which safety caps (depth, references, cells) bit.

use std::fmt;
use std::time::Duration;

/// The value of a structure-specific report row, kept as what it is: a count, a time or a
/// number is read back as one (the bench's JSON, the app's instance picker), and shown with
/// its unit.
#[derive(Clone, Debug, PartialEq)]
pub enum Detail {
    Text(String),
    Count(u64),
    Time(Duration),
    /// A measure without a unit, shown with this many decimals.
    Number(f64, usize),
}

impl Detail {
    pub fn count(n: usize) -> Detail {
        Detail::Count(n as u64)
    }

    pub fn as_count(&self) -> Option<u64> {
        match self {
            Detail::Count(n) => Some(*n),
            _ => None,
        }
    }

    pub fn as_ms(&self) -> Option<f64> {
        match self {
            Detail::Time(t) => Some(t.as_secs_f64() * 1e3),
            _ => None,
        }
    }
}

impl fmt::Display for Detail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Detail::Text(t) => f.write_str(t),
            Detail::Count(n) => write!(f, "{n}"),
            Detail::Time(t) => write!(f, "{:.2} ms", t.as_secs_f64() * 1e3),
            Detail::Number(x, decimals) => write!(f, "{x:.decimals$}"),
        }
    }
}

impl From<String> for Detail {
    fn from(text: String) -> Detail {
        Detail::Text(text)
    }
}

impl From<&str> for Detail {
    fn from(text: &str) -> Detail {
        Detail::Text(text.to_string())
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct StructureReport {
    /// The structure's name as `--accel` spells it.
    pub structure: &'static str,
    pub triangles: usize,
    pub build_time: Duration,
    /// Memory of the structure, triangles included.
    pub bytes: usize,
    /// Nodes (trees) or cells (grid).
    pub nodes: usize,
    /// Leaves (trees) or cells (grid).
    pub leaves: usize,
    /// Leaves or cells that reference no triangle.
    pub empty_leaves: usize,
    /// Deepest leaf (0 for a grid or brute force).
    pub max_depth: u32,
    /// Triangle references in all leaves or cells.
    pub references: usize,
    /// Most references in one leaf or cell.
    pub largest_leaf: usize,
    /// Structure-specific rows (parameters, resolution, SAH cost…).
    pub details: Vec<(String, Detail)>,
    /// Caps that stopped the build short of its criterion, in words.
    pub caps_hit: Vec<String>,
}

impl StructureReport {
    pub fn build_ms(&self) -> f64 {
        self.build_time.as_secs_f64() * 1e3
    }

    pub fn references_per_triangle(&self) -> f64 {
        self.references as f64 / self.triangles.max(1) as f64
    }

    pub fn empty_percent(&self) -> f64 {
        100.0 * self.empty_leaves as f64 / self.leaves.max(1) as f64
    }

    pub fn mib(&self) -> f64 {
        self.bytes as f64 / (1024.0 * 1024.0)
    }

    /// The structure-specific row named `name`.
    pub fn detail(&self, name: &str) -> Option<&Detail> {
        self.details.iter().find(|(k, _)| k == name).map(|(_, v)| v)
    }

    /// The report as (label, value) rows, for the CLI and the app's stats panel.
    pub fn rows(&self) -> Vec<(String, String)> {
        let mut rows = vec![("structure".to_string(), self.structure.to_string())];
        rows.extend(self.details.iter().map(|(k, v)| (k.clone(), v.to_string())));
        rows.extend([
            ("triangles".into(), self.triangles.to_string()),
            ("build time".into(), format!("{:.2} ms", self.build_ms())),
            ("memory".into(), format!("{:.2} MiB", self.mib())),
            ("nodes / cells".into(), self.nodes.to_string()),
            ("leaves / cells".into(), self.leaves.to_string()),
            ("empty".into(), format!("{:.1} %", self.empty_percent())),
            ("max depth".into(), self.max_depth.to_string()),
            (
                "references per triangle".into(),
                format!("{:.2}", self.references_per_triangle()),
            ),
            ("largest leaf / cell".into(), self.largest_leaf.to_string()),
        ]);
        for cap in &self.caps_hit {
            rows.push(("cap hit".into(), cap.clone()));
        }
        rows
    }
}
