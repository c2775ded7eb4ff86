//! The memory budget. Every large allocation the tool makes on a user's word (an image of a
//! given size, a number of rays, a scene of N triangles and the structure over it) is sized
//! first, in bytes per pixel, per ray or per triangle, and refused with one line naming the
//! parameter, the estimate and the limit when it would not fit. The limit is half of the
//! machine's memory unless the front end sets another (`--memory-limit`), so a request
//! inside the documented ranges either runs or says at once why it cannot, rather than
//! growing until the system kills it.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes per pixel of a rendered frame: colour (4), the sample behind it (about 48) and
/// the per-pixel counters, with the renderer's tiles and the PNG's copy. Measured: 112 at
/// 2048² (`render`, peak resident size over pixels).
pub const FRAME_BYTES_PER_PIXEL: u64 = 128;
/// Bytes per pixel of `bench`'s ray sets: primary, diffuse and shadow rays, their packets
/// and hits (measured: 140 at 1024²).
pub const RAY_SETS_BYTES_PER_PIXEL: u64 = 192;
/// Bytes per ray of a study's ray list with its hits and the f64 reference's answer.
pub const BYTES_PER_RAY: u64 = 128;

/// The limit and where it comes from.
#[derive(Clone, Debug, PartialEq)]
struct Limit {
    bytes: u64,
    origin: String,
    /// What the front end tells a user who wants more (empty: nothing).
    hint: String,
}

static LIMIT: Mutex<Option<Limit>> = Mutex::new(None);

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what} would need about {}, more than the memory limit of {} ({origin}){hint}", gib(*.bytes), gib(*.limit))]
pub struct BudgetError {
    pub what: String,
    pub bytes: u64,
    pub limit: u64,
    origin: String,
    hint: String,
}

/// `bytes` as GiB with two decimals (MiB below one GiB).
pub fn gib(bytes: u64) -> String {
    let b = bytes as f64;
    if b < (1u64 << 30) as f64 {
        format!("{:.0} MiB", (b / (1u64 << 20) as f64).ceil())
    } else {
        format!("{:.2} GiB", b / (1u64 << 30) as f64)
    }
}

/// The machine's memory in bytes, from `/proc/meminfo` (8 GiB where it cannot be read).
pub fn machine_memory() -> u64 {
    let text = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(8 << 30, |kib| kib * 1024)
}

fn current() -> Limit {
    let set = LIMIT.lock().map(|l| l.clone()).unwrap_or(None);
    set.unwrap_or_else(|| Limit {
        bytes: machine_memory() / 2,
        origin: "half of this machine's memory".into(),
        hint: String::new(),
    })
}

/// Sets the limit (`None`: half of the machine's memory) and the hint added to every
/// refusal (e.g. "; --memory-limit raises it").
pub fn set_limit(bytes: Option<u64>, hint: &str) {
    let mut limit = current();
    if let Some(bytes) = bytes {
        limit.bytes = bytes;
        limit.origin = "as set".into();
    }
    limit.hint = hint.to_string();
    if let Ok(mut l) = LIMIT.lock() {
        *l = Some(limit);
    }
}

/// The limit in bytes.
pub fn limit() -> u64 {
    current().bytes
}

/// Bytes held by what is loaded and built so far (`hold`): a later check counts them, so
/// a scene, its structure and the image traced over them fit the limit together, not
/// each alone.
static HELD: AtomicU64 = AtomicU64::new(0);

/// Memory a front end keeps while it works (a loaded scene and its structure), counted
/// by every check until it is dropped.
#[must_use = "the bytes are held only while this lives"]
pub struct Held(u64);

impl Drop for Held {
    fn drop(&mut self) {
        HELD.fetch_sub(self.0, Ordering::Relaxed);
    }
}

/// Counts `bytes` as held until the answer is dropped.
pub fn hold(bytes: u64) -> Held {
    HELD.fetch_add(bytes, Ordering::Relaxed);
    Held(bytes)
}

/// Whether `bytes` for `what` (said as "an image of 16384×16384 pixels") fit the limit
/// beside what is held already.
pub fn check(what: impl Into<String>, bytes: u64) -> Result<(), BudgetError> {
    let limit = current();
    let held = HELD.load(Ordering::Relaxed);
    if bytes.saturating_add(held) <= limit.bytes {
        return Ok(());
    }
    // Said when it is what is held that tips it over.
    let mut what = what.into();
    let mut bytes = bytes;
    if bytes <= limit.bytes {
        what += &format!(" with what is loaded already ({} of it)", gib(held));
        bytes += held;
    }
    Err(BudgetError {
        what,
        bytes,
        limit: limit.bytes,
        origin: limit.origin,
        hint: limit.hint,
    })
}

/// `count` things of `each` bytes, saturating (a count near `u64::MAX` is over any limit).
pub fn times(count: u64, each: u64) -> u64 {
    count.saturating_mul(each)
}

/// A size as the CLI takes it: bytes with an optional K, M, G or T suffix (powers of 1024,
/// an optional trailing "B" or "iB"), e.g. `16G`, `512MiB`, `1.5T`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (number, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], Some(c)),
        _ => (t, None),
    };
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size (e.g. 16G or 512M)"))?;
    let shift = match unit.map(|c| c.to_ascii_uppercase()) {
        None => 0,
        Some('K') => 10,
        Some('M') => 20,
        Some('G') => 30,
        Some('T') => 40,
        Some(_) => return Err(format!("'{text}': the unit must be K, M, G or T")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes < (1u64 << 20) as f64 || bytes > (1u64 << 50) as f64 {
        return Err(format!("'{text}' must be between 1M and 1024T"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_units() {
        assert_eq!(parse_size("16G"), Ok(16 << 30));
        assert_eq!(parse_size("512MiB"), Ok(512 << 20));
        assert_eq!(parse_size("1.5T"), Ok(3 << 39));
        assert_eq!(parse_size("2097152"), Ok(2 << 20));
        assert!(parse_size("12Q").unwrap_err().contains("unit"));
        assert!(parse_size("lots").unwrap_err().contains("not a size"));
        assert!(parse_size("0").is_err());
        assert!(parse_size("-4G").is_err());
    }

    #[test]
    fn a_refusal_names_what_the_estimate_and_the_limit() {
        let limit = limit();
        assert!(check("a small thing", limit).is_ok());
        let e = check("an image of 16384×16384 pixels", limit + 1).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("an image of 16384×16384 pixels would need about"),
            "{text}"
        );
        assert!(text.contains("memory limit"), "{text}");
        assert_eq!(times(u64::MAX, 2), u64::MAX);
        assert_eq!(gib(3 << 30), "3.00 GiB");
    }
}
