//! A slow frame shown while it is traced: the coarse first image, enlarged to the full
//! size, with each tile of the full frame put over it as soon as it is done, sent to the
//! UI every `EVERY`. The lecture's "a coarse image first, then tiles": even a structure
//! that is slow on the view (a grid in the stadium, brute force on sponza) shows its
//! picture filling in rather than a still image.

use super::messages::{RenderJob, Reply, Shown};
use crate::render::{TileDone, colorize_tile};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often the picture so far is sent: often enough to be seen filling in, rarely
/// enough that copying it costs nothing beside the trace.
const EVERY: Duration = Duration::from_millis(100);

pub(super) struct Stream<'a> {
    /// The picture so far, and when it was last sent.
    image: Mutex<(Vec<u8>, Instant)>,
    /// The coarse first image it starts from (its frame answers the pixel reports).
    coarse: Arc<Shown>,
    /// The full frame's job, marked as a preview: the UI waits for the full frame.
    job: RenderJob,
    replies: &'a Sender<Reply>,
    wake: &'a (dyn Fn() + Send + Sync),
}

impl<'a> Stream<'a> {
    /// A stream for `job`'s full frame over its coarse first image; `None` where a tile
    /// cannot be coloured by itself (the depth mode's range, a comparison's B − A).
    pub(super) fn new(
        coarse: Arc<Shown>,
        job: &RenderJob,
        replies: &'a Sender<Reply>,
        wake: &'a (dyn Fn() + Send + Sync),
    ) -> Option<Self> {
        let streams = job.compare.is_none() && job.mode != crate::render::Mode::Depth;
        if !streams || coarse.rgba.is_empty() {
            return None;
        }
        let image = enlarged(&coarse, job.width, job.height);
        Some(Stream {
            image: Mutex::new((image, Instant::now())),
            coarse,
            job: RenderJob {
                preview: true,
                ..job.clone()
            },
            replies,
            wake,
        })
    }

    /// Puts a tile just traced over the picture, and sends the picture if it is time.
    pub(super) fn tile(&self, tile: TileDone) {
        let mut coloured;
        let pixels = if tile.rgba.is_empty() {
            coloured = vec![0u8; tile.samples.len() * 4];
            let top = self.coarse.heat_max.unwrap_or(1);
            let style = &self.job.heat_style;
            colorize_tile(tile.samples, self.job.mode, top, style, &mut coloured);
            &coloured[..]
        } else {
            tile.rgba
        };
        let Ok(mut image) = self.image.lock() else {
            return;
        };
        let at = tile.first_pixel * 4;
        if let Some(dst) = image.0.get_mut(at..at + pixels.len()) {
            dst.copy_from_slice(pixels);
        }
        if image.1.elapsed() < EVERY {
            return;
        }
        image.1 = Instant::now();
        let rgba = image.0.clone();
        drop(image);
        let c = &self.coarse;
        let _ = self.replies.send(Reply::Frame(Arc::new(Shown {
            job: self.job.clone(),
            rgba,
            heat_max: c.heat_max,
            frame: c.frame.clone(),
            walk: c.walk.clone(),
            traced: false,
            image_time: c.image_time,
            compared: None,
            pinned_frame: None,
            pinned_tree: None,
        })));
        (self.wake)();
    }
}

/// The coarse image enlarged to `width` × `height`, each of its pixels a block.
fn enlarged(coarse: &Shown, width: u32, height: u32) -> Vec<u8> {
    let (cw, ch) = (coarse.job.width.max(1), coarse.job.height.max(1));
    let mut out = vec![0u8; (width * height * 4) as usize];
    for y in 0..height {
        let cy = (y * ch / height.max(1)).min(ch - 1);
        for x in 0..width {
            let cx = (x * cw / width.max(1)).min(cw - 1);
            let from = ((cy * cw + cx) * 4) as usize;
            let to = ((y * width + x) * 4) as usize;
            if let Some(px) = coarse.rgba.get(from..from + 4) {
                out[to..to + 4].copy_from_slice(px);
            }
        }
    }
    out
}
