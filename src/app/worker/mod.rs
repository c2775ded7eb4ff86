//! The worker thread: it owns the scene and its acceleration structure (whichever the user
//! chose), takes commands from the UI (load, build, render a view, move triangles, undo)
//! and answers with results. The UI thread never
//! builds or traces. Commands that pile up while the worker is busy are taken together, and
//! only the newest render request among them is rendered.
//!
//! Nothing is redone that did not change: a frame is traced again only when the camera,
//! the size, the scene or the tree changed; a new colour mode or overlay recolours the
//! traced frame.

mod cracks;
mod epo;
mod frames;
pub mod messages;
mod motion;
mod prefetch;
pub(in crate::app) mod state;
mod streaming;

pub use messages::*;

use crate::accel::Outline;
use crate::accel::structure::StructureParams;
use state::State;
use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The UI's handle on the worker thread.
pub struct Worker {
    tx: Option<Sender<(u64, Command)>>,
    rx: Receiver<Reply>,
    sent: u64,
    /// `sent`, for the worker: a counted pass stops when a newer command is waiting.
    latest: Arc<AtomicU64>,
    /// The newest command that replaces a build: the build in flight is abandoned.
    newest_build: Arc<AtomicU64>,
    /// The newest command the worker has reported done.
    done: u64,
    /// Triangles placed by the build in progress, and how many there are in all.
    pub progress: Arc<(AtomicUsize, AtomicUsize)>,
    /// Tiles begun of the frame being traced, and how many it has.
    pub trace_progress: Arc<(AtomicUsize, AtomicUsize)>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the thread; `wake` is called after each reply (the UI's repaint request).
    pub fn spawn(wake: impl Fn() + Send + Sync + 'static) -> Self {
        let (tx, commands) = channel();
        let (replies, rx) = channel();
        let progress = Arc::new((AtomicUsize::new(0), AtomicUsize::new(0)));
        let trace_progress = Arc::new((AtomicUsize::new(0), AtomicUsize::new(0)));
        let latest = Arc::new(AtomicU64::new(0));
        let newest_build = Arc::new(AtomicU64::new(0));
        let state = State {
            latest: latest.clone(),
            newest_build: newest_build.clone(),
            applying: 0,
            light: None,
            replies,
            wake: Box::new(wake),
            progress: progress.clone(),
            trace_progress: trace_progress.clone(),
            pending: None,
            slow_trace: true,
            scene: None,
            structure: None,
            params: StructureParams::default(),
            outline: Arc::new(Outline::default()),
            instance: None,
            outline_stale: false,
            built_outline: Arc::default(),
            moved: Default::default(),
            leaf_instances: Arc::default(),
            leaf_references: Vec::new(),
            reference_locator: Default::default(),
            reference_bvh: None,
            version: 0,
            scene_version: 0,
            pinned: None,
            pinned_builds: 0,
            traced: None,
            pinned_traced: None,
            last_job: None,
            refit_index: None,
            gesture: Vec::new(),
            undo: Vec::new(),
            undoing: false,
            split_costs: RefCell::default(),
            selection: RefCell::default(),
            drag_bounds: None,
            prefetch: None,
            epo_version: None,
            blas_epo_for: None,
            crack_view: None,
        };
        let thread = std::thread::Builder::new()
            .name("bvhlab-worker".into())
            .spawn(move || state.run(commands))
            .ok();
        Worker {
            tx: Some(tx),
            rx,
            sent: 0,
            latest,
            newest_build,
            done: 0,
            progress,
            trace_progress,
            thread,
        }
    }

    pub fn send(&mut self, command: Command) {
        self.sent += 1;
        self.latest.store(self.sent, Ordering::Relaxed);
        if command.replaces_the_build() {
            self.newest_build.store(self.sent, Ordering::Relaxed);
        }
        if let Some(tx) = &self.tx {
            // A failed send means the worker is gone; the UI keeps its last state.
            let _ = tx.send((self.sent, command));
        }
    }

    /// Replies that have arrived, without waiting.
    pub fn poll(&mut self) -> Vec<Reply> {
        let replies: Vec<Reply> = self.rx.try_iter().collect();
        self.note_done(&replies);
        replies
    }

    fn note_done(&mut self, replies: &[Reply]) {
        for r in replies {
            if let Reply::Idle(seq) = r {
                self.done = self.done.max(*seq);
            }
        }
    }

    /// Whether every command sent so far has been handled.
    pub fn is_idle(&self) -> bool {
        self.done >= self.sent
    }

    /// Waits until every command sent so far is handled (or `timeout` passes) and returns
    /// the replies on the way. For tests and screenshots, never the interactive UI.
    pub fn wait_idle(&mut self, timeout: Duration) -> Vec<Reply> {
        let deadline = Instant::now() + timeout;
        let mut out = Vec::new();
        while !self.is_idle() {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(r) => {
                    self.note_done(std::slice::from_ref(&r));
                    out.push(r);
                }
                Err(_) => break,
            }
        }
        out
    }

    /// The next reply, waiting at most `timeout` (`None` if none came). For measuring when
    /// each reply arrives, never the interactive UI.
    pub fn next_reply(&mut self, timeout: Duration) -> Option<Reply> {
        let r = self.rx.recv_timeout(timeout).ok()?;
        self.note_done(std::slice::from_ref(&r));
        Some(r)
    }

    pub fn sent(&self) -> u64 {
        self.sent
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Work in flight (a build, a trace, a prefetch) is abandoned, not finished.
        self.latest.store(u64::MAX, Ordering::Relaxed);
        self.newest_build.store(u64::MAX, Ordering::Relaxed);
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
