//! Sample buffers recycled between frames. A 1280 × 720 frame keeps about 100 bytes per
//! pixel (`Sample`), 96 MB; allocated afresh, that memory comes from the system as untouched
//! pages, and touching them one thread after another cost about 35 ms a frame here, a
//! third of the frame. A dropped frame gives its buffer back to this pool and the next
//! frame takes it; a fresh buffer is filled by every thread at once.

use super::Sample;
use rayon::prelude::*;
use std::sync::Mutex;

/// Buffers kept for reuse: the frame on screen, the one being traced, and one spare
/// (a comparison traces two frames).
const KEPT: usize = 3;
/// Smaller buffers are not worth keeping (a small frame allocates in microseconds).
const SMALLEST_KEPT: usize = 1 << 16;

static POOL: Mutex<Vec<Vec<Sample>>> = Mutex::new(Vec::new());

/// A buffer of `len` samples for a frame to overwrite. A recycled buffer keeps the old
/// frame's samples (every one is overwritten by the trace); a fresh one is filled in
/// parallel, so its pages are first touched by every thread.
pub(crate) fn take(len: usize) -> Vec<Sample> {
    let recycled = POOL.lock().ok().and_then(|mut pool| {
        // The smallest buffer that fits, so a big one stays for a big frame.
        let best = (0..pool.len())
            .filter(|&i| pool[i].capacity() >= len)
            .min_by_key(|&i| pool[i].capacity())?;
        Some(pool.swap_remove(best))
    });
    match recycled {
        Some(mut buffer) => {
            buffer.truncate(len);
            let missing = len - buffer.len();
            buffer.par_extend(rayon::iter::repeat_n(Sample::default(), missing));
            buffer
        }
        None => {
            let mut buffer = Vec::with_capacity(len);
            buffer.par_extend(rayon::iter::repeat_n(Sample::default(), len));
            buffer
        }
    }
}

/// Takes back a dropped frame's buffer, if it is worth keeping and the pool has room
/// (else the smallest kept one makes way for a larger one).
pub(crate) fn give_back(buffer: Vec<Sample>) {
    if buffer.capacity() < SMALLEST_KEPT {
        return;
    }
    let Ok(mut pool) = POOL.lock() else { return };
    if pool.len() < KEPT {
        pool.push(buffer);
    } else if let Some(smallest) = (0..pool.len()).min_by_key(|&i| pool[i].capacity())
        && pool[smallest].capacity() < buffer.capacity()
    {
        pool[smallest] = buffer;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A buffer given back is taken again, at the length asked for, and a fresh buffer is
    /// all default samples.
    #[test]
    fn buffers_come_back_at_the_length_asked_for() {
        let fresh = take(SMALLEST_KEPT + 5);
        assert_eq!(fresh.len(), SMALLEST_KEPT + 5);
        assert!(fresh.iter().all(|s| *s == Sample::default()));
        let address = fresh.as_ptr();
        give_back(fresh);
        // Other tests may take it first; when this one does, it is the same memory.
        let again = take(SMALLEST_KEPT);
        assert_eq!(again.len(), SMALLEST_KEPT);
        if again.as_ptr() == address {
            assert!(again.capacity() >= SMALLEST_KEPT + 5);
        }
        let longer = take(SMALLEST_KEPT * 2);
        assert_eq!(longer.len(), SMALLEST_KEPT * 2);
        give_back(again);
        give_back(longer);
    }
}
