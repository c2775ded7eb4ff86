//! Reading an input file whole, safely: only a regular file (a device such as /dev/zero or a
//! pipe never ends, a folder is not data), and only when what it becomes in memory fits the
//! budget (`crate::budget`), checked from its size before a byte is read.

use std::io;
use std::path::Path;

/// The bytes of `path`, whose contents take about `expansion` times its size once read and
/// decoded (the text and what is made of it).
pub fn read(path: &Path, expansion: u64) -> io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            if meta.is_dir() {
                "it is a folder, not a file"
            } else {
                "not a regular file (a device or a pipe)"
            },
        ));
    }
    crate::budget::check(
        format!("reading {}", path.display()),
        crate::budget::times(meta.len(), expansion),
    )
    .map_err(io::Error::other)?;
    std::fs::read(path)
}

/// `read` as UTF-8 text.
pub fn read_text(path: &Path, expansion: u64) -> io::Result<String> {
    String::from_utf8(read(path, expansion)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "not UTF-8 text"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_within_the_budget_are_read() {
        assert!(read(Path::new("/dev/zero"), 1).is_err());
        assert!(read(Path::new("/"), 1).is_err());
        assert_eq!(
            read(Path::new("/nonexistent-bvhlab"), 1)
                .unwrap_err()
                .kind(),
            io::ErrorKind::NotFound
        );
        let path = std::env::temp_dir().join(format!("bvhlab-input-{}", std::process::id()));
        std::fs::write(&path, b"v 0 0 0\n").unwrap();
        assert_eq!(read(&path, 1).unwrap(), b"v 0 0 0\n");
        assert_eq!(read_text(&path, 1).unwrap(), "v 0 0 0\n");
        assert!(read(&path, u64::MAX).is_err());
        std::fs::remove_file(&path).ok();
    }
}
