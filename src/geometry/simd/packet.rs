//! The slab test of one box against a whole packet of rays, SIMD across the rays: the
//! packet's rays are stored as structures of arrays (`RayPacket`), and one instruction tests
//! the box against 4 (SSE4.1), 8 (AVX2) or 16 (AVX-512) of them. A packet of 64 rays is
//! tested in groups of that many; a group without an active ray is skipped.
//!
//! Every lane computes the scalar `slab_entry` exactly, as the wide slab kernels do: the near
//! plane of each axis picked by the sign of that ray's direction (−0.0 counts as negative),
//! the far distances scaled by 1 + 2γ(3), the same order of max and min, so `max_ps(x, acc)`
//! is the scalar `max_keep(acc, x)` with its ±0 and NaN rules. Rays of one packet may point
//! different ways, so the planes are chosen lane by lane (a blend), not once per packet;
//! where they leave one origin into one octant (a camera's tile), the planes are chosen once
//! and their offsets from the origin found once per box (`packet_entries_shared`), which
//! leaves a multiply per plane for each group of rays.

use super::interval::WideInterval;
use super::ray_packet::{ORIGIN, PACKET_RAYS, RayPacket, TMIN};
use super::slab::{Avx2, Avx512, Portable, Sse41};
use crate::geometry::aabb::FAR_SCALE;

/// A box as its six planes: min x, min y, min z, max x, max y, max z.
pub type BoxPlanes = [f32; 6];

/// A slab kernel across the rays of a packet.
pub trait PacketSlab {
    /// The rays of `active` whose scalar slab test enters the box within their
    /// [tmin, tmax], and the smallest entry distance among them (+∞ if none).
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn packet_entries(b: &BoxPlanes, p: &RayPacket, active: u64) -> (u64, f32);

    /// `packet_entries` for a packet whose rays leave one origin into one octant, as its
    /// interval `iv` holds them (`WideInterval::of_packet`: the origins equal bit for bit):
    /// each plane's offset from the origin is found once for all rays, and no plane is
    /// chosen lane by lane. The same answers bit for bit, as each lane computes the same
    /// `(plane − origin) · 1/d` from the same values.
    ///
    /// A kernel without such a form answers with `packet_entries`.
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    #[inline(always)]
    unsafe fn packet_entries_shared(
        b: &BoxPlanes,
        iv: &WideInterval,
        p: &RayPacket,
        active: u64,
    ) -> (u64, f32) {
        let _ = iv;
        // SAFETY: the caller's guarantee is `packet_entries`' too.
        unsafe { Self::packet_entries(b, p, active) }
    }
}

/// The planes of `b` nearer (`rows` = `iv.near`) or farther (`iv.far`) on each axis, less
/// the packet's one origin: the first step of every ray's slab test, done once.
#[inline(always)]
fn offsets(b: &BoxPlanes, rows: &[usize; 3], iv: &WideInterval) -> [f32; 3] {
    [
        b[rows[0]] - iv.origin[0],
        b[rows[1]] - iv.origin[1],
        b[rows[2]] - iv.origin[2],
    ]
}

#[inline(always)]
fn max_keep(acc: f32, x: f32) -> f32 {
    if x > acc { x } else { acc }
}

#[inline(always)]
fn min_keep(acc: f32, x: f32) -> f32 {
    if x < acc { x } else { acc }
}

impl PacketSlab for Portable {
    /// The scalar test ray by ray.
    #[inline(always)]
    unsafe fn packet_entries(b: &BoxPlanes, p: &RayPacket, active: u64) -> (u64, f32) {
        let mut hits = 0;
        let mut nearest = f32::INFINITY;
        let mut rest = active & p.rays;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let d = |axis: usize, far: bool| {
                let max = (p.negative[axis] >> i & 1 == 1) != far;
                let plane = b[axis + 3 * usize::from(max)];
                (plane - p.ray[ORIGIN + axis][i]) * p.inv_dir[axis][i]
            };
            let enter = max_keep(
                max_keep(max_keep(p.ray[TMIN][i], d(0, false)), d(1, false)),
                d(2, false),
            );
            let exit = min_keep(
                min_keep(
                    min_keep(p.tmax[i], d(0, true) * FAR_SCALE),
                    d(1, true) * FAR_SCALE,
                ),
                d(2, true) * FAR_SCALE,
            );
            if enter <= exit {
                hits |= 1 << i;
                nearest = nearest.min(enter);
            }
        }
        (hits, nearest)
    }
}

/// One group of rays starting at ray `$at`: evaluates to `(enter, exit)` vectors.
/// `$blend!(near_if_positive, near_if_negative, axis)` picks each lane's plane. Macros rather
/// than closures: a closure does not inherit the caller's target features, so the
/// intrinsics in it would not be inlined.
#[cfg(target_arch = "x86_64")]
macro_rules! packet_group {
    ($b:expr, $p:expr, $at:expr, $blend:ident,
     $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident) => {{
        let (b, p, at) = ($b, $p, $at);
        let s = $set1(FAR_SCALE);
        let lo = [$set1(b[0]), $set1(b[1]), $set1(b[2])];
        let hi = [$set1(b[3]), $set1(b[4]), $set1(b[5])];
        macro_rules! dist {
            ($plane:expr, $axis:expr) => {
                $mul(
                    $sub($plane, $load(p.ray[ORIGIN + $axis][at..].as_ptr())),
                    $load(p.inv_dir[$axis][at..].as_ptr()),
                )
            };
        }
        macro_rules! near {
            ($axis:expr) => {
                dist!($blend!(lo[$axis], hi[$axis], $axis), $axis)
            };
        }
        macro_rules! far {
            ($axis:expr) => {
                $mul(dist!($blend!(hi[$axis], lo[$axis], $axis), $axis), s)
            };
        }
        let enter = $max(
            near!(2),
            $max(near!(1), $max(near!(0), $load(p.ray[TMIN][at..].as_ptr()))),
        );
        let exit = $min(
            far!(2),
            $min(far!(1), $min(far!(0), $load(p.tmax[at..].as_ptr()))),
        );
        (enter, exit)
    }};
}

/// One group of rays starting at ray `$at` of a packet with one origin and octant:
/// `$near` and `$far` hold each axis's plane offset from the origin (`offsets`), broadcast.
/// The operations of `packet_group` after its subtraction, in the same order.
#[cfg(target_arch = "x86_64")]
macro_rules! packet_group_shared {
    ($p:expr, $at:expr, $near:expr, $far:expr, $load:ident, $set1:ident, $mul:ident,
     $max:ident, $min:ident) => {{
        let (p, at, near, far) = ($p, $at, $near, $far);
        let s = $set1(FAR_SCALE);
        macro_rules! dist {
            ($offset:expr, $axis:expr) => {
                $mul($offset[$axis], $load(p.inv_dir[$axis][at..].as_ptr()))
            };
        }
        let enter = $max(
            dist!(near, 2),
            $max(
                dist!(near, 1),
                $max(dist!(near, 0), $load(p.ray[TMIN][at..].as_ptr())),
            ),
        );
        let exit = $min(
            $mul(dist!(far, 2), s),
            $min(
                $mul(dist!(far, 1), s),
                $min($mul(dist!(far, 0), s), $load(p.tmax[at..].as_ptr())),
            ),
        );
        (enter, exit)
    }};
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// The loop over groups of rays of a kernel whose comparisons give vector masks (SSE4.1:
    /// four rays a group, AVX2: eight): `$group` evaluates to the group's `(enter, exit)`
    /// for the group starting at ray `$at`. `$lanes!(bits)` makes the vector mask of the
    /// group's active rays, `$reduce!(v)` the smallest lane of a vector; then the width's
    /// broadcast, min, blend, compare (≤) and movemask.
    macro_rules! groups_vector {
        ($lanes_per:expr, $lanes:ident, $reduce:ident, $set1:ident, $min:ident, $and:ident,
         $blendv:ident, $cmple:expr, $movemask:ident,
         $p:expr, $active:expr, $at:ident => $group:expr) => {{
            const LANES: usize = $lanes_per;
            let active = $active & $p.rays;
            let mut hits = 0u64;
            let mut nearest = $set1(f32::INFINITY);
            for g in 0..PACKET_RAYS / LANES {
                let $at = g * LANES;
                let bits = (active >> $at) as i32 & ((1 << LANES) - 1);
                if bits == 0 {
                    continue;
                }
                let (enter, exit) = $group;
                let hit = $and($cmple(enter, exit), $lanes!(bits));
                nearest = $blendv(nearest, $min(enter, nearest), hit);
                hits |= ($movemask(hit) as u64) << $at;
            }
            (hits, $reduce!(nearest))
        }};
    }

    // The vector mask of the lanes set in `bits` (4 or 8 of them).
    macro_rules! lanes128 {
        ($bits:expr) => {{
            let lane_bits = _mm_set_epi32(8, 4, 2, 1);
            _mm_castsi128_ps(_mm_cmpeq_epi32(
                _mm_and_si128(_mm_set1_epi32($bits), lane_bits),
                lane_bits,
            ))
        }};
    }
    macro_rules! lanes256 {
        ($bits:expr) => {{
            let lane_bits = _mm256_set_epi32(128, 64, 32, 16, 8, 4, 2, 1);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32($bits), lane_bits),
                lane_bits,
            ))
        }};
    }

    // The smallest lane of a vector (none NaN).
    macro_rules! least128 {
        ($v:expr) => {
            min_lane_128($v)
        };
    }
    macro_rules! least256 {
        ($v:expr) => {{
            let v = $v;
            min_lane_128(_mm_min_ps(
                _mm256_castps256_ps128(v),
                _mm256_extractf128_ps::<1>(v),
            ))
        }};
    }

    macro_rules! groups_128 {
        ($p:expr, $active:expr, $at:ident => $group:expr) => {
            groups_vector!(4, lanes128, least128, _mm_set1_ps, _mm_min_ps,
                _mm_and_ps, _mm_blendv_ps, _mm_cmple_ps, _mm_movemask_ps,
                $p, $active, $at => $group)
        };
    }

    macro_rules! groups_256 {
        ($p:expr, $active:expr, $at:ident => $group:expr) => {
            groups_vector!(8, lanes256, least256, _mm256_set1_ps,
                _mm256_min_ps, _mm256_and_ps, _mm256_blendv_ps,
                _mm256_cmp_ps::<_CMP_LE_OQ>, _mm256_movemask_ps,
                $p, $active, $at => $group)
        };
    }

    /// The AVX-512 kernel's loop over groups of sixteen rays (as `groups_128`).
    macro_rules! groups_512 {
        ($p:expr, $active:expr, $at:ident => $group:expr) => {{
            const LANES: usize = 16;
            let active = $active & $p.rays;
            let mut hits = 0u64;
            let mut nearest = _mm512_set1_ps(f32::INFINITY);
            for g in 0..PACKET_RAYS / LANES {
                let $at = g * LANES;
                let bits = (active >> $at) as u16;
                if bits == 0 {
                    continue;
                }
                let (enter, exit) = $group;
                let hit = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(bits, enter, exit);
                nearest = _mm512_mask_min_ps(nearest, hit, enter, nearest);
                hits |= u64::from(hit) << $at;
            }
            (hits, _mm512_reduce_min_ps(nearest))
        }};
    }

    /// Both kernels of one instruction set: `$groups` its loop, `$v` its vector type, then
    /// its load, broadcast, subtract, multiply, max and min, and `$blend` its lane-by-lane
    /// choice of planes. Loads read lanes at..at + LANES of arrays of `PACKET_RAYS`, at a
    /// multiple of LANES below it.
    macro_rules! packet_slab {
        ($kernel:ty, $groups:ident, $v:ty, $load:ident, $set1:ident, $sub:ident, $mul:ident,
         $max:ident, $min:ident, $blend:ident) => {
            impl PacketSlab for $kernel {
                #[inline(always)]
                unsafe fn packet_entries(b: &BoxPlanes, p: &RayPacket, active: u64) -> (u64, f32) {
                    // SAFETY: the caller guarantees the kernel's instruction set; the loads
                    // stay inside the packet's arrays.
                    unsafe {
                        $groups!(p, active, at => {
                            macro_rules! blend {
                                ($pos:expr, $neg:expr, $axis:expr) => {
                                    $blend!(p, at, $pos, $neg, $axis)
                                };
                            }
                            packet_group!(b, p, at, blend, $load, $set1, $sub, $mul, $max, $min)
                        })
                    }
                }

                #[inline(always)]
                unsafe fn packet_entries_shared(
                    b: &BoxPlanes,
                    iv: &WideInterval,
                    p: &RayPacket,
                    active: u64,
                ) -> (u64, f32) {
                    // SAFETY: as above.
                    unsafe {
                        // Broadcast once per box, not per group (no closure: it would not
                        // inherit the target features, and the intrinsics in it would not
                        // be inlined).
                        let [n0, n1, n2] = offsets(b, &iv.near, iv);
                        let [f0, f1, f2] = offsets(b, &iv.far, iv);
                        let near: [$v; 3] = [$set1(n0), $set1(n1), $set1(n2)];
                        let far: [$v; 3] = [$set1(f0), $set1(f1), $set1(f2)];
                        $groups!(p, active, at => packet_group_shared!(
                            p, at, near, far, $load, $set1, $mul, $max, $min
                        ))
                    }
                }
            }
        };
    }

    // The sign bit of 1/d is the sign bit of d: blendv picks by it.
    macro_rules! blend_128 {
        ($p:expr, $at:expr, $pos:expr, $neg:expr, $axis:expr) => {
            _mm_blendv_ps($pos, $neg, _mm_loadu_ps($p.inv_dir[$axis][$at..].as_ptr()))
        };
    }
    macro_rules! blend_256 {
        ($p:expr, $at:expr, $pos:expr, $neg:expr, $axis:expr) => {
            _mm256_blendv_ps(
                $pos,
                $neg,
                _mm256_loadu_ps($p.inv_dir[$axis][$at..].as_ptr()),
            )
        };
    }
    macro_rules! blend_512 {
        ($p:expr, $at:expr, $pos:expr, $neg:expr, $axis:expr) => {
            _mm512_mask_blend_ps(($p.negative[$axis] >> $at) as u16, $pos, $neg)
        };
    }

    packet_slab!(
        Sse41,
        groups_128,
        __m128,
        _mm_loadu_ps,
        _mm_set1_ps,
        _mm_sub_ps,
        _mm_mul_ps,
        _mm_max_ps,
        _mm_min_ps,
        blend_128
    );
    packet_slab!(
        Avx2,
        groups_256,
        __m256,
        _mm256_loadu_ps,
        _mm256_set1_ps,
        _mm256_sub_ps,
        _mm256_mul_ps,
        _mm256_max_ps,
        _mm256_min_ps,
        blend_256
    );
    packet_slab!(
        Avx512,
        groups_512,
        __m512,
        _mm512_loadu_ps,
        _mm512_set1_ps,
        _mm512_sub_ps,
        _mm512_mul_ps,
        _mm512_max_ps,
        _mm512_min_ps,
        blend_512
    );

    /// The smallest of four lanes (none NaN).
    #[inline(always)]
    unsafe fn min_lane_128(v: __m128) -> f32 {
        // SAFETY: the caller guarantees SSE4.1.
        unsafe {
            let v = _mm_min_ps(v, _mm_movehl_ps(v, v));
            let v = _mm_min_ss(v, _mm_shuffle_ps::<0b01>(v, v));
            _mm_cvtss_f32(v)
        }
    }
}

/// Elsewhere the x86 kernels are never selected (`SimdLevel::supported`); they run the
/// portable lanes so that code generic over them compiles.
#[cfg(not(target_arch = "x86_64"))]
mod elsewhere {
    use super::*;

    macro_rules! portable_as {
        ($kernel:ty) => {
            impl PacketSlab for $kernel {
                #[inline(always)]
                unsafe fn packet_entries(b: &BoxPlanes, p: &RayPacket, active: u64) -> (u64, f32) {
                    // SAFETY: the portable kernel has no requirement.
                    unsafe { Portable::packet_entries(b, p, active) }
                }
            }
        };
    }
    portable_as!(Sse41);
    portable_as!(Avx2);
    portable_as!(Avx512);
}
