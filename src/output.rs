//! Files the tool writes (images, CSVs, plots, hit files, presets), written whole. A path is
//! checked before any work is done: its folder exists, it is not a folder itself, and its
//! extension names a format the writer makes. The bytes go to a temporary file beside the
//! target and are renamed onto it, so a failure (a full disk, a vanished folder) leaves
//! nothing behind and an earlier file of that name survives whole.

use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("cannot write {path}: it is a folder")]
    IsFolder { path: PathBuf },
    #[error("cannot write {path}: it is also {other}")]
    SameFile { path: PathBuf, other: String },
    #[error("cannot write {path}: the folder {folder} does not exist")]
    NoFolder { path: PathBuf, folder: PathBuf },
    #[error("cannot write {path}: {format} files are not written here; use {expected}")]
    Format {
        path: PathBuf,
        format: String,
        expected: String,
    },
    // Causes are said in the message, not chained after it (they would print twice).
    #[error("cannot write {path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("cannot encode the image for {path}: {error}")]
    Encode {
        path: PathBuf,
        error: image::ImageError,
    },
}

/// Refuses to write `path` when it names the same file as `other` (described as `what`:
/// "the ray file read", "the CSV"), which would be read and overwritten, or lost.
pub fn check_distinct(path: &Path, other: &Path, what: &str) -> Result<(), OutputError> {
    let absolute = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|_| {
            let folder = std::fs::canonicalize(folder_of(p)).unwrap_or_else(|_| folder_of(p));
            folder.join(p.file_name().unwrap_or_default())
        })
    };
    if absolute(path) == absolute(other) {
        return Err(OutputError::SameFile {
            path: path.to_path_buf(),
            other: what.to_string(),
        });
    }
    Ok(())
}

/// Checks that `path` can be written as one of `extensions` (lower case, without the dot;
/// empty: any name), before any work is done for it.
pub fn check(path: &Path, extensions: &[&str]) -> Result<(), OutputError> {
    if path.is_dir() {
        return Err(OutputError::IsFolder {
            path: path.to_path_buf(),
        });
    }
    let folder = folder_of(path);
    if !folder.is_dir() {
        return Err(OutputError::NoFolder {
            path: path.to_path_buf(),
            folder,
        });
    }
    // A folder that cannot be written in (read-only, a system folder) is found now too.
    let probe = folder.join(format!(".bvhlab-probe.{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
        }
        Err(error) => {
            return Err(OutputError::Io {
                path: path.to_path_buf(),
                error,
            });
        }
    }
    if !extensions.is_empty() {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        if !extensions.contains(&ext.as_str()) {
            return Err(OutputError::Format {
                path: path.to_path_buf(),
                format: if ext.is_empty() {
                    "extensionless".into()
                } else {
                    format!(".{ext}")
                },
                expected: extensions
                    .iter()
                    .map(|e| format!(".{e}"))
                    .collect::<Vec<_>>()
                    .join(" or "),
            });
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` whole: to a temporary file in the same folder, then renamed
/// onto `path`. On any failure the temporary file is removed and `path` is untouched.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    stage(path, bytes)?.commit()
}

/// A file written whole beside its target but not yet in its place: `commit` renames it
/// there; dropped uncommitted, it is removed. A command that writes several files stages
/// each and commits them once all are written, so a failure leaves none of them.
pub struct Staged {
    temp: PathBuf,
    path: PathBuf,
    committed: bool,
}

/// Writes `bytes` for `path` to a temporary file in its folder.
pub fn stage(path: &Path, bytes: &[u8]) -> Result<Staged, OutputError> {
    check(path, &[])?;
    let name = path.file_name().map_or_else(
        || "output".to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let staged = Staged {
        temp: folder_of(path).join(format!(".{name}.{}.partial", std::process::id())),
        path: path.to_path_buf(),
        committed: false,
    };
    let written = std::fs::File::create(&staged.temp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.sync_all()
    });
    written.map_err(|error| staged.io(error))?;
    Ok(staged)
}

impl Staged {
    /// Renames the file into its place.
    pub fn commit(mut self) -> Result<(), OutputError> {
        std::fs::rename(&self.temp, &self.path).map_err(|error| self.io(error))?;
        self.committed = true;
        Ok(())
    }

    fn io(&self, error: std::io::Error) -> OutputError {
        OutputError::Io {
            path: self.path.clone(),
            error,
        }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// An RGBA8 image as PNG bytes.
pub fn png_bytes(
    rgba: &[u8],
    width: u32,
    height: u32,
    path: &Path,
) -> Result<Vec<u8>, OutputError> {
    let mut bytes = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut bytes),
        rgba,
        width,
        height,
        image::ExtendedColorType::Rgba8,
        image::ImageFormat::Png,
    )
    .map_err(|source| OutputError::Encode {
        path: path.to_path_buf(),
        error: source,
    })?;
    Ok(bytes)
}

/// Writes an RGBA8 image to `path` (a `.png`) whole.
pub fn write_png(rgba: &[u8], width: u32, height: u32, path: &Path) -> Result<(), OutputError> {
    check(path, &["png"])?;
    write(path, &png_bytes(rgba, width, height, path)?)
}

/// The folder `path` is in (the working folder for a bare name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bvhlab-output-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn paths_are_checked_before_any_work() {
        let dir = temp_dir("check");
        assert!(check(&dir.join("a.png"), &["png"]).is_ok());
        assert!(check(&dir.join("A.PNG"), &["png"]).is_ok());
        let e = check(&dir.join("a.jpg"), &["png"]).unwrap_err().to_string();
        assert!(
            e.contains(".jpg files are not written here; use .png"),
            "{e}"
        );
        let e = check(&dir, &["png"]).unwrap_err().to_string();
        assert!(e.contains("it is a folder"), "{e}");
        let e = check(&dir.join("nowhere/a.png"), &["png"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        assert!(check(Path::new("bare-name.csv"), &["csv"]).is_ok());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_file_is_written_whole_or_not_at_all() {
        let dir = temp_dir("write");
        let path = dir.join("out.bin");
        write(&path, b"first").unwrap();
        write(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        // A failed write leaves the old file as it was and no temporary file behind.
        assert!(write(&dir.join("gone/out.bin"), b"x").is_err());
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.bin"]);
        // A PNG decodes back to its pixels.
        let png = dir.join("p.png");
        write_png(&[1, 2, 3, 255, 4, 5, 6, 255], 2, 1, &png).unwrap();
        let back = image::open(&png).unwrap().to_rgba8();
        assert_eq!(back.as_raw(), &[1, 2, 3, 255, 4, 5, 6, 255]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
