//! The binary ray and hit files of `bvhlab trace`: rays as 8 little-endian f32 (origin,
//! direction, tmin, tmax); hits in input order as f32 t (+∞ on a miss) and the triangle's
//! number, in 32 bits (`HitFormat::U32`, all ones on a miss) or, for a scene that places
//! more triangles than 32 bits count (instancing), in 64 (`HitFormat::U64`); occlusion as
//! one byte per ray.

use super::Hit;
use crate::geometry::Ray;
use glam::Vec3;

pub const RAY_BYTES: usize = 32;
/// The triangle index of a miss in a 32-bit hit file.
pub const MISS: u32 = u32::MAX;
/// The triangle index of a miss in a 64-bit hit file.
pub const MISS_U64: u64 = u64::MAX;
/// At most this many invalid rays are listed in an error.
const LISTED: usize = 10;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RayFileError {
    #[error(
        "the ray file has {len} bytes, not a multiple of {RAY_BYTES} (8 little-endian f32 per ray): \
         it ends inside ray {complete}"
    )]
    Truncated { len: usize, complete: usize },
    #[error("{count} invalid ray(s): {}", list_invalid(.first))]
    InvalidRays {
        count: usize,
        /// The first few, as (ray index, reason).
        first: Vec<(usize, &'static str)>,
    },
}

fn list_invalid(first: &[(usize, &'static str)]) -> String {
    first
        .iter()
        .map(|(i, why)| format!("ray {i}: {why}"))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The shortest direction traced: a shorter one's components square to 0 in f32 (a
/// subnormal direction would silently miss everything).
const MIN_DIRECTION: f32 = 1e-18;

/// Why a ray cannot be traced, or `None` if it can.
pub fn invalid_reason(ray: &Ray) -> Option<&'static str> {
    if !ray.origin.is_finite() {
        Some("origin is NaN or infinite")
    } else if !ray.direction.is_finite() {
        Some("direction is NaN or infinite")
    } else if ray.origin.abs().max_element() > crate::scene::MAX_COORDINATE {
        Some("origin is beyond ±1e18, where ray arithmetic overflows f32")
    } else if ray.direction == Vec3::ZERO {
        Some("direction is zero")
    } else if ray.direction.length() < MIN_DIRECTION {
        Some("direction is too short to trace (its length is below 1e-18)")
    } else if ray.tmin.is_nan() || ray.tmax.is_nan() {
        Some("tmin or tmax is NaN")
    } else if !(ray.tmin.is_finite() && ray.tmin >= 0.0) {
        Some("tmin is negative or infinite (it must be a finite t ≥ 0)")
    } else if ray.tmax <= ray.tmin {
        Some("tmax is not greater than tmin (it may be +∞)")
    } else {
        None
    }
}

/// Decodes a ray file; every ray must be valid (see `invalid_reason`).
pub fn decode_rays(bytes: &[u8]) -> Result<Vec<Ray>, RayFileError> {
    if !bytes.len().is_multiple_of(RAY_BYTES) {
        return Err(RayFileError::Truncated {
            len: bytes.len(),
            complete: bytes.len() / RAY_BYTES,
        });
    }
    let rays: Vec<Ray> = bytes
        .chunks_exact(RAY_BYTES)
        .map(|chunk| {
            let f = |i: usize| {
                let mut word = [0u8; 4];
                word.copy_from_slice(&chunk[4 * i..4 * i + 4]);
                f32::from_le_bytes(word)
            };
            Ray::segment(
                Vec3::new(f(0), f(1), f(2)),
                Vec3::new(f(3), f(4), f(5)),
                f(6),
                f(7),
            )
        })
        .collect();
    let mut count = 0;
    let mut first = Vec::new();
    for (i, ray) in rays.iter().enumerate() {
        if let Some(why) = invalid_reason(ray) {
            count += 1;
            if first.len() < LISTED {
                first.push((i, why));
            }
        }
    }
    if count > 0 {
        return Err(RayFileError::InvalidRays { count, first });
    }
    Ok(rays)
}

pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    for r in rays {
        for x in [
            r.origin.x,
            r.origin.y,
            r.origin.z,
            r.direction.x,
            r.direction.y,
            r.direction.z,
            r.tmin,
            r.tmax,
        ] {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// How a hit file numbers triangles: 32 bits (8 bytes a ray) or 64 bits (12 bytes a ray).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HitFormat {
    U32,
    U64,
}

impl HitFormat {
    /// The smaller format that numbers every triangle of a scene placing `triangles`
    /// (the 32-bit miss marker is not a triangle's number).
    pub fn for_triangles(triangles: u64) -> HitFormat {
        if triangles <= u64::from(MISS) {
            HitFormat::U32
        } else {
            HitFormat::U64
        }
    }

    /// Bytes of one ray's hit: the f32 t and the triangle's number.
    pub fn record_bytes(self) -> usize {
        match self {
            HitFormat::U32 => 8,
            HitFormat::U64 => 12,
        }
    }

    pub fn bits(self) -> u32 {
        match self {
            HitFormat::U32 => 32,
            HitFormat::U64 => 64,
        }
    }
}

/// A hit the hit file cannot hold: it numbers triangles in 32 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a hit on triangle {0}, beyond the 32-bit numbers of the hit file")]
pub struct HitIndexTooLarge(pub u64);

pub fn encode_hits(hits: &[Option<Hit>], format: HitFormat) -> Result<Vec<u8>, HitIndexTooLarge> {
    let mut out = Vec::with_capacity(hits.len() * format.record_bytes());
    for h in hits {
        let t = h.map_or(f32::INFINITY, |h| h.t);
        out.extend_from_slice(&t.to_le_bytes());
        match format {
            HitFormat::U32 => {
                let tri = match h {
                    None => MISS,
                    Some(h) => match u32::try_from(h.triangle) {
                        Ok(tri) if tri != MISS => tri,
                        _ => return Err(HitIndexTooLarge(h.triangle)),
                    },
                };
                out.extend_from_slice(&tri.to_le_bytes());
            }
            HitFormat::U64 => {
                let tri = h.map_or(MISS_U64, |h| h.triangle);
                out.extend_from_slice(&tri.to_le_bytes());
            }
        }
    }
    Ok(out)
}

/// Decodes a hit file into (t, triangle number) pairs; a miss keeps its format's marker
/// (`MISS` or `MISS_U64`). A trailing partial record is ignored.
pub fn decode_hits(bytes: &[u8], format: HitFormat) -> Vec<(f32, u64)> {
    bytes
        .chunks_exact(format.record_bytes())
        .map(|c| {
            let t = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            let tri = match format {
                HitFormat::U32 => u32::from_le_bytes([c[4], c[5], c[6], c[7]]).into(),
                HitFormat::U64 => {
                    u64::from_le_bytes([c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11]])
                }
            };
            (t, tri)
        })
        .collect()
}

pub fn encode_occlusion(occluded: &[bool]) -> Vec<u8> {
    occluded.iter().map(|&o| u8::from(o)).collect()
}
