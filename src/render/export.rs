//! Saving what the app shows: the viewport as a PNG, and the frame's per-pixel counters as
//! CSV (one row per pixel) for a spreadsheet or a plot of one's own.

use super::Frame;
use crate::output::{self, OutputError};
use std::io::Write;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("there is no frame to save yet")]
    NoFrame,
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error("the image is {got} bytes, not the 4 × {width} × {height} of its size")]
    Size { got: usize, width: u32, height: u32 },
}

/// Writes `rgba` (row-major, top row first, 4 bytes per pixel) as a PNG.
pub fn save_png(rgba: &[u8], width: u32, height: u32, path: &Path) -> Result<(), ExportError> {
    if rgba.len() != 4 * width as usize * height as usize || rgba.is_empty() {
        return Err(ExportError::Size {
            got: rgba.len(),
            width,
            height,
        });
    }
    Ok(output::write_png(rgba, width, height, path)?)
}

/// The header of the counters CSV.
pub const CSV_HEADER: &str = "x,y,triangle,t,lit,primary_nodes_visited,primary_box_tests,\
primary_triangle_tests,primary_repeated_tests,shadow_nodes_visited,shadow_box_tests,\
shadow_triangle_tests,shadow_repeated_tests";

/// Writes one row per pixel (top row first): the hit (empty on a miss), whether the shadow
/// ray reached the light, and the counters of the primary and the shadow ray.
pub fn write_counters_csv(frame: &Frame, out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for y in 0..frame.height {
        for x in 0..frame.width {
            let Some(s) = frame.sample(x, y) else {
                continue;
            };
            let (tri, t) = if s.is_hit() {
                (s.triangle.to_string(), s.t.to_string())
            } else {
                (String::new(), String::new())
            };
            let (p, sh) = (&s.primary, &s.shadow);
            writeln!(
                out,
                "{x},{y},{tri},{t},{},{},{},{},{},{},{},{},{}",
                u8::from(s.is_hit() && s.lit),
                p.nodes_visited,
                p.box_tests,
                p.triangle_tests,
                p.repeated_tests,
                sh.nodes_visited,
                sh.box_tests,
                sh.triangle_tests,
                sh.repeated_tests
            )?;
        }
    }
    Ok(())
}

/// Writes the frame's counters as CSV to `path`.
pub fn save_counters_csv(frame: &Frame, path: &Path) -> Result<(), ExportError> {
    output::check(path, &["csv"])?;
    let mut bytes = Vec::new();
    write_counters_csv(frame, &mut bytes).map_err(|source| OutputError::Io {
        path: path.to_path_buf(),
        error: source,
    })?;
    Ok(output::write(path, &bytes)?)
}
