//! Wavefront OBJ loading: every object or group becomes an `Object`, polygons are
//! fan-triangulated, and material diffuse colours (Kd) colour the objects.
//!
//! tobj does the loading. It reports errors without line numbers, so a validation pass of
//! our own goes first and names the offending line; tobj then only sees files that pass.

use super::{Scene, Triangle};
use glam::Vec3;
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// Colour of objects without a material (or whose material library could not be read).
pub const DEFAULT_COLOR: Vec3 = Vec3::splat(0.7);

/// Why an OBJ file could not be loaded. Line numbers are 1-based.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    // The cause is said in the message, not chained after it (it would print twice).
    #[error("cannot read {}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}:{line}: {reason}: '{text}'", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        /// The offending line, shortened.
        text: String,
        reason: &'static str,
    },
    #[error(
        "{}:{line}: vertex coordinate is NaN, infinite or beyond the f32 range (±3.4e38)",
        path.display()
    )]
    NonFinite { path: PathBuf, line: usize },
    #[error(
        "{}:{line}: {kind} index {index} is out of range ({defined} defined before this line)",
        path.display()
    )]
    IndexOutOfRange {
        path: PathBuf,
        line: usize,
        /// The index as written in the file (1-based, or negative = relative).
        index: i64,
        /// "vertex", "texture coordinate" or "normal".
        kind: &'static str,
        defined: usize,
    },
    #[error("{} contains no triangles", path.display())]
    NoTriangles { path: PathBuf },
    /// A file our validation accepted but tobj did not; tobj gives no line number.
    #[error("{}: the OBJ reader rejected the file: {reason}", path.display())]
    Rejected { path: PathBuf, reason: String },
}

/// Loads an OBJ file; its .mtl libraries are looked up next to it. A missing or broken
/// material library is only a warning (on stderr): its objects get `DEFAULT_COLOR`.
pub fn load_obj(path: &Path) -> Result<Scene, ObjError> {
    // The text, tobj's arrays and the triangles made of them: about 4 × the file.
    let bytes = crate::input::read(path, 4).map_err(|source| ObjError::Io {
        path: path.to_path_buf(),
        error: source,
    })?;
    parse_obj(path, bytes, path.parent())
}

/// Loads OBJ text already in memory. `path` names it in errors and gives the scene its
/// name; material libraries are read from `mtl_dir`, or ignored when it is `None`.
pub(crate) fn parse_obj(
    path: &Path,
    mut bytes: Vec<u8>,
    mtl_dir: Option<&Path>,
) -> Result<Scene, ObjError> {
    let warnings = RefCell::new(validate(path, &mut bytes)?);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) =
        tobj::load_obj_buf(&mut bytes.as_slice(), &options, |library| match mtl_dir {
            Some(dir) => load_materials(dir, library, &warnings),
            None => Ok(Default::default()),
        })
        .map_err(|e| ObjError::Rejected {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
    // Kept with the scene: the command line prints them, the app shows them.
    let warnings: Vec<String> = (warnings.into_inner().into_iter())
        .map(|w| format!("{}: {w}", path.display()))
        .collect();
    // Failures were reported above; tobj only repeats the last one here.
    let materials = materials.unwrap_or_default();

    let name = path
        .file_stem()
        .map_or_else(|| "obj".into(), |s| s.to_string_lossy().into_owned());
    let mut scene = Scene::new(name);
    let mut triangles = Vec::new();
    // tobj keeps file order: it emits a model whenever `o`/`g` or a material change ends the
    // faces read so far, and lists each model's faces in the order they were read.
    for model in &models {
        let mesh = &model.mesh;
        let vertex = |i: &u32| {
            let i = *i as usize * 3;
            mesh.positions
                .get(i..i + 3)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
        };
        triangles.clear();
        for corners in mesh.indices.chunks_exact(3) {
            match (
                vertex(&corners[0]),
                vertex(&corners[1]),
                vertex(&corners[2]),
            ) {
                (Some(a), Some(b), Some(c)) => triangles.push(Triangle::new(a, b, c)),
                _ => {
                    return Err(ObjError::Rejected {
                        path: path.to_path_buf(),
                        reason: "tobj returned a vertex index out of range".into(),
                    });
                }
            }
        }
        let color = mesh
            .material_id
            .and_then(|id| materials.get(id))
            .and_then(|m| m.diffuse)
            .map_or(DEFAULT_COLOR, |kd| {
                let kd = Vec3::from(kd);
                if kd.is_finite() {
                    kd.clamp(Vec3::ZERO, Vec3::ONE)
                } else {
                    DEFAULT_COLOR
                }
            });
        scene.push_object(model.name.clone(), color, &triangles);
    }
    if scene.triangles.is_empty() {
        return Err(ObjError::NoTriangles {
            path: path.to_path_buf(),
        });
    }
    scene.warnings = warnings;
    Ok(scene)
}

/// Reads a material library for tobj, turning every problem into a warning (tobj's result
/// type needs an error too; it only keeps it when no library loaded at all).
fn load_materials(
    dir: &Path,
    library: &Path,
    warnings: &RefCell<Vec<String>>,
) -> tobj::MTLLoadResult {
    let path = dir.join(library);
    let reason = match read_material_text(dir, &path) {
        Ok(text) => match tobj::load_mtl_buf(&mut text.as_bytes()) {
            Ok(loaded) => return Ok(loaded),
            Err(e) => e.to_string(),
        },
        Err(reason) => reason,
    };
    warnings.borrow_mut().push(format!(
        "material library {}: {reason}; its objects are grey",
        path.display()
    ));
    Err(tobj::LoadError::OpenFileFailed)
}

/// The text of a material library that tobj can read without panicking.
fn read_material_text(folder: &Path, path: &Path) -> Result<String, String> {
    // `mtllib` can name anything: only a regular file in the OBJ's folder (or below) is
    // read, as a glTF's buffers are.
    let inside = match (folder_of(folder).canonicalize(), path.canonicalize()) {
        (Ok(folder), Ok(file)) => file.starts_with(folder),
        _ => return Err("not found".into()),
    };
    if !inside {
        return Err("it is outside the OBJ file's folder".into());
    }
    let bytes = crate::input::read(path, 2).map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&bytes).into_owned();
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if matches!(words.next(), Some("Ka" | "Kd" | "Ks" | "Ke")) {
            let values: Vec<&str> = words.collect();
            // tobj 4 panics on a colour with fewer than three components (`Kd 0.5`).
            if values.len() < 3 {
                return Err(format!("line {}: a colour needs three values", number + 1));
            }
            // Out-of-range and non-finite values are tamed where the colour is used.
        }
    }
    Ok(text)
}

/// `folder` as a path canonicalize can take (the empty parent of a bare file name is ".").
fn folder_of(folder: &Path) -> &Path {
    if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    }
}

/// Number of vertices, texture coordinates and normals defined so far.
#[derive(Default)]
struct Defined {
    positions: usize,
    texcoords: usize,
    normals: usize,
}

/// Checks every line tobj would act on, with the line number on failure. Also blanks, in
/// place, the parts tobj would misread: polylines (`l a b c` would become a triangle) and
/// vertex colours (tobj fails when only some vertices have one), and a UTF-8 byte order mark.
/// Returns the warnings for what is skipped: faces of fewer than three corners.
fn validate(path: &Path, bytes: &mut [u8]) -> Result<Vec<String>, ObjError> {
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        bytes[..3].fill(b' ');
    }
    let mut defined = Defined::default();
    let mut short_faces = Vec::new();
    // Byte ranges to overwrite with spaces once the (borrowing) pass is over.
    let mut blank = Vec::new();
    let mut start = 0;
    for (number, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_start = start;
        start += raw.len() + 1;
        let fail = |reason| ObjError::Parse {
            path: path.to_path_buf(),
            line: number + 1,
            text: excerpt(raw),
            reason,
        };
        let line = std::str::from_utf8(raw).map_err(|_| fail("not UTF-8 text"))?;
        let offset = |word: &str| line_start + (word.as_ptr() as usize - line.as_ptr() as usize);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let rest: Vec<&str> = words.collect();
                let number_at = |i: usize| rest.get(i).and_then(|w| w.parse::<f32>().ok());
                let (Some(x), Some(y), Some(z)) = (number_at(0), number_at(1), number_at(2)) else {
                    return Err(fail("expected three numbers"));
                };
                let mut p = Vec3::new(x, y, z);
                match rest.len() {
                    3 => {}
                    4 => {
                        let w = number_at(3).ok_or_else(|| fail("bad w coordinate"))?;
                        if w == 0.0 {
                            return Err(fail("w coordinate is zero"));
                        }
                        p /= w;
                    }
                    6 => {
                        if (3..6).any(|i| number_at(i).is_none()) {
                            return Err(fail("bad vertex colour"));
                        }
                        let (first, last) = (rest[3], rest[5]);
                        blank.push(offset(first)..offset(last) + last.len());
                    }
                    _ => return Err(fail("expected 3, 4 or 6 numbers")),
                }
                if !p.is_finite() {
                    return Err(ObjError::NonFinite {
                        path: path.to_path_buf(),
                        line: number + 1,
                    });
                }
                defined.positions += 1;
            }
            Some("vt") => {
                if !leading_numbers(words, 2) {
                    return Err(fail("expected two numbers"));
                }
                defined.texcoords += 1;
            }
            Some("vn") => {
                if !leading_numbers(words, 3) {
                    return Err(fail("expected three numbers"));
                }
                defined.normals += 1;
            }
            Some("f") => {
                let mut corners = 0;
                for word in words {
                    check_face_vertex(word, &defined).map_err(|problem| match problem {
                        FaceProblem::Syntax(reason) => fail(reason),
                        FaceProblem::Range {
                            index,
                            kind,
                            defined,
                        } => ObjError::IndexOutOfRange {
                            path: path.to_path_buf(),
                            line: number + 1,
                            index,
                            kind,
                            defined,
                        },
                    })?;
                    corners += 1;
                }
                match corners {
                    0 => return Err(fail("face without vertices")),
                    // tobj skips a face of one or two corners; it is said below.
                    1 | 2 => short_faces.push(number + 1),
                    _ => {}
                }
            }
            Some(word @ "l") => blank.push(offset(word)..offset(word) + 1),
            // tobj rejects a `usemtl` without a name (and reads the name after the first space).
            Some("usemtl")
                if line
                    .split_once(' ')
                    .is_none_or(|(_, n)| n.trim().is_empty()) =>
            {
                return Err(fail("usemtl without a material name"));
            }
            // Comments, `o`, `g`, `s`, `mtllib` and unknown statements cannot fail.
            _ => {}
        }
    }
    for range in blank {
        bytes[range].fill(b' ');
    }
    let mut warnings = Vec::new();
    if let Some(first) = short_faces.first() {
        warnings.push(format!(
            "{} face{} of fewer than three vertices skipped (a point or a line, not a \
             surface; the first on line {first})",
            short_faces.len(),
            if short_faces.len() == 1 { "" } else { "s" }
        ));
    }
    Ok(warnings)
}

/// Whether the first `n` words are numbers (tobj ignores any further ones).
fn leading_numbers<'a>(words: impl Iterator<Item = &'a str>, n: usize) -> bool {
    let mut count = 0;
    for word in words.take(n) {
        if word.parse::<f32>().is_err() {
            return false;
        }
        count += 1;
    }
    count == n
}

enum FaceProblem {
    Syntax(&'static str),
    Range {
        index: i64,
        kind: &'static str,
        defined: usize,
    },
}

/// Checks one face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`. Indices are 1-based; negative
/// ones count back from the last element defined so far.
fn check_face_vertex(word: &str, defined: &Defined) -> Result<(), FaceProblem> {
    let kinds = [
        ("vertex", defined.positions),
        ("texture coordinate", defined.texcoords),
        ("normal", defined.normals),
    ];
    if word.split('/').count() > 3 {
        return Err(FaceProblem::Syntax(
            "more than three indices in a face vertex",
        ));
    }
    let mut parts = word.split('/');
    for (slot, &(kind, defined)) in kinds.iter().enumerate() {
        let part = match parts.next() {
            Some(part) if !part.is_empty() => part,
            _ if slot == 0 => return Err(FaceProblem::Syntax("missing vertex index")),
            _ => continue,
        };
        let index: i64 = part.parse().map_err(|_| FaceProblem::Syntax("bad index"))?;
        let magnitude = index.unsigned_abs();
        if index == 0 || magnitude > defined as u64 {
            return Err(FaceProblem::Range {
                index,
                kind,
                defined,
            });
        }
    }
    Ok(())
}

/// The start of a line for an error message, readable even when it is binary garbage.
fn excerpt(line: &[u8]) -> String {
    const MAX: usize = 80;
    let text = String::from_utf8_lossy(&line[..line.len().min(MAX)]);
    // Control characters (a terminal's escape sequences in a crafted file) are shown
    // escaped, never passed to the terminal.
    let text: String = text
        .trim_end_matches('\r')
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect();
    if line.len() > MAX {
        format!("{text}…")
    } else {
        text.to_string()
    }
}
