//! Temporary directories for the tests' files, removed when the test ends.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh directory under the system's temporary directory, removed with everything in it
/// when dropped, so a test leaves nothing behind in `/tmp`, passed or failed (the guard is
/// dropped while a panic unwinds too). Keep it alive for as long as its files are used,
/// by a child process too: `let dir = TempDir::new("trace");` at the top of the test.
pub struct TempDir(PathBuf);

impl TempDir {
    /// `bvhlab-{label}-{pid}-{n}`: the process id keeps test binaries running at the same
    /// time apart, the counter the tests of one binary (threads of one process).
    pub fn new(label: &str) -> TempDir {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("bvhlab-{label}-{}-{n}", std::process::id()));
        // Left by an earlier process with the same id (killed before its guards dropped):
        // the test starts from an empty directory all the same.
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path)
            .unwrap_or_else(|e| panic!("cannot create {}: {e}", path.display()));
        TempDir(path)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }

    /// `path` inside the directory.
    pub fn join(&self, path: impl AsRef<Path>) -> PathBuf {
        self.0.join(path)
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    /// Errors are ignored: a directory that cannot be removed must not fail the test (or
    /// abort it, while unwinding from a failure).
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
