//! The interval test of a packet (`RayInterval`) against the W boxes of a wide node at once:
//! one SIMD test tells which children no ray of the packet can enter, before any ray is
//! tested on its own. It only culls, never decides a hit, so it need not match a scalar test
//! bit for bit, only never cull a box that one of the rays' own slab tests enters (see
//! `frustum`: the rounded products are monotonic in the reciprocal direction).

use super::ray_packet::{ORIGIN, PACKET_RAYS, RayPacket, TMIN, max, min};
use super::slab::{Avx2, Avx512, Portable, Sse41};
use crate::geometry::aabb::FAR_SCALE;

/// A packet as one interval ray, laid out for the wide kernels: one origin, per axis the
/// range of reciprocal directions, the rows of the near and far planes (one sign per axis
/// for the whole packet) and the smallest tmin.
#[derive(Clone, Copy, Debug)]
pub struct WideInterval {
    pub origin: [f32; 3],
    pub inv_lo: [f32; 3],
    pub inv_hi: [f32; 3],
    pub near: [usize; 3],
    pub far: [usize; 3],
    pub tmin: f32,
}

impl WideInterval {
    /// The interval ray of a packet (as `RayInterval::new` makes it), or `None` when the
    /// test does not apply: the rays do not share one origin (bit for bit), a direction
    /// component changes sign within the packet, or a reciprocal is zero or not finite.
    #[inline(always)]
    pub fn of_packet(p: &RayPacket) -> Option<WideInterval> {
        if p.is_empty() {
            return None;
        }
        let mut iv = WideInterval {
            origin: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            near: [0; 3],
            far: [0; 3],
            tmin: min(&p.ray[TMIN], p.len()),
        };
        let n = p.len();
        for axis in 0..3 {
            let origin = &p.ray[ORIGIN + axis];
            let o = origin[0];
            let inv = &p.inv_dir[axis];
            // Fixed trip counts and `&` rather than `all`: the loops vectorise.
            // Bit for bit, so that a plane's offset from the origin is each ray's own
            // (`PacketSlab::packet_entries_shared`).
            let same = (0..PACKET_RAYS).fold(true, |a, i| {
                a & ((origin[i].to_bits() == o.to_bits()) | (i >= n))
            });
            let usable = (0..PACKET_RAYS).fold(true, |a, i| {
                let x = inv[i];
                a & ((x.is_finite() & (x != 0.0)) | (i >= n))
            });
            let negative = p.negative[axis];
            if !same || !usable || (negative != 0 && negative != p.rays) {
                return None;
            }
            iv.origin[axis] = o;
            iv.inv_lo[axis] = min(inv, n);
            iv.inv_hi[axis] = max(inv, n);
            let max = usize::from(negative != 0);
            iv.near[axis] = axis + 3 * max;
            iv.far[axis] = axis + 3 * (1 - max);
        }
        Some(iv)
    }
}

/// An interval kernel for nodes of W children.
pub trait IntervalSlab<const W: usize> {
    /// The mask of the lanes whose box some ray of the interval may enter before `tmax`
    /// (the largest box-test limit of the packet's rays).
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn maybe_entered(bounds: &[[f32; W]; 6], iv: &WideInterval, tmax: f32) -> u32;
}

impl<const W: usize> IntervalSlab<W> for Portable {
    #[inline(always)]
    unsafe fn maybe_entered(b: &[[f32; W]; 6], iv: &WideInterval, tmax: f32) -> u32 {
        let mut mask = 0;
        #[allow(clippy::needless_range_loop)] // lane i of six rows
        for i in 0..W {
            let mut enter = iv.tmin;
            let mut exit = tmax;
            for axis in 0..3 {
                let (lo, hi) = (iv.inv_lo[axis], iv.inv_hi[axis]);
                let near = b[iv.near[axis]][i] - iv.origin[axis];
                let far = b[iv.far[axis]][i] - iv.origin[axis];
                // The lowest near distance and the highest far distance over the packet.
                enter = enter.max((near * lo).min(near * hi));
                exit = exit.min((far * lo).max(far * hi) * FAR_SCALE);
            }
            // Not `enter <= exit`: a NaN bound keeps the child (the interval cannot rule
            // it out).
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let kept = !(enter > exit);
            mask |= u32::from(kept) << i;
        }
        mask
    }
}

/// The lanes of one vector of boxes starting at lane `$at` that the interval may enter, as
/// a vector mask `!(enter > exit)`.
#[cfg(target_arch = "x86_64")]
macro_rules! interval_vector {
    ($b:expr, $iv:expr, $tmax:expr, $at:expr,
     $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident) => {{
        // Macros rather than closures: a closure does not inherit the caller's target
        // features, so the intrinsics in it would not be inlined.
        let (b, iv) = ($b, $iv);
        macro_rules! offset {
            ($row:expr, $axis:expr) => {
                $sub($load(b[$row][$at..].as_ptr()), $set1(iv.origin[$axis]))
            };
        }
        macro_rules! near {
            ($axis:expr) => {{
                let x = offset!(iv.near[$axis], $axis);
                $min(
                    $mul(x, $set1(iv.inv_lo[$axis])),
                    $mul(x, $set1(iv.inv_hi[$axis])),
                )
            }};
        }
        macro_rules! far {
            ($axis:expr) => {{
                let x = offset!(iv.far[$axis], $axis);
                $mul(
                    $max(
                        $mul(x, $set1(iv.inv_lo[$axis])),
                        $mul(x, $set1(iv.inv_hi[$axis])),
                    ),
                    $set1(FAR_SCALE),
                )
            }};
        }
        let enter = $max(near!(2), $max(near!(1), $max(near!(0), $set1(iv.tmin))));
        let exit = $min(far!(2), $min(far!(1), $min(far!(0), $set1($tmax))));
        (enter, exit)
    }};
}

/// `impl IntervalSlab<W> for Kernel` with the body given: the signature written once.
#[cfg(target_arch = "x86_64")]
macro_rules! interval_slab {
    ($kernel:ty, $w:literal, |$b:ident, $iv:ident, $tmax:ident| $body:block) => {
        impl IntervalSlab<$w> for $kernel {
            #[inline(always)]
            unsafe fn maybe_entered($b: &[[f32; $w]; 6], $iv: &WideInterval, $tmax: f32) -> u32 $body
        }
    };
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    interval_slab!(Sse41, 4, |b, iv, tmax| {
        // SAFETY: the caller guarantees SSE4.1; loads stay inside the arrays.
        unsafe {
            let (enter, exit) = interval_vector!(
                b,
                iv,
                tmax,
                0,
                _mm_loadu_ps,
                _mm_set1_ps,
                _mm_sub_ps,
                _mm_mul_ps,
                _mm_max_ps,
                _mm_min_ps
            );
            _mm_movemask_ps(_mm_cmpngt_ps(enter, exit)) as u32
        }
    });

    interval_slab!(Sse41, 8, |b, iv, tmax| {
        // SAFETY: the caller guarantees SSE4.1; loads stay inside the arrays (two halves).
        unsafe {
            let (e0, x0) = interval_vector!(
                b,
                iv,
                tmax,
                0,
                _mm_loadu_ps,
                _mm_set1_ps,
                _mm_sub_ps,
                _mm_mul_ps,
                _mm_max_ps,
                _mm_min_ps
            );
            let (e1, x1) = interval_vector!(
                b,
                iv,
                tmax,
                4,
                _mm_loadu_ps,
                _mm_set1_ps,
                _mm_sub_ps,
                _mm_mul_ps,
                _mm_max_ps,
                _mm_min_ps
            );
            let lo = _mm_movemask_ps(_mm_cmpngt_ps(e0, x0)) as u32;
            let hi = _mm_movemask_ps(_mm_cmpngt_ps(e1, x1)) as u32;
            lo | hi << 4
        }
    });

    interval_slab!(Avx2, 4, |b, iv, tmax| {
        // SAFETY: AVX2 implies SSE4.1, whose kernel this is.
        unsafe { <Sse41 as IntervalSlab<4>>::maybe_entered(b, iv, tmax) }
    });

    interval_slab!(Avx2, 8, |b, iv, tmax| {
        // SAFETY: the caller guarantees AVX2; loads stay inside the arrays.
        unsafe {
            let (enter, exit) = interval_vector!(
                b,
                iv,
                tmax,
                0,
                _mm256_loadu_ps,
                _mm256_set1_ps,
                _mm256_sub_ps,
                _mm256_mul_ps,
                _mm256_max_ps,
                _mm256_min_ps
            );
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NGT_UQ>(enter, exit)) as u32
        }
    });

    interval_slab!(Avx512, 4, |b, iv, tmax| {
        // SAFETY: AVX-512 implies SSE4.1, whose kernel this is.
        unsafe { <Sse41 as IntervalSlab<4>>::maybe_entered(b, iv, tmax) }
    });

    interval_slab!(Avx512, 8, |b, iv, tmax| {
        // SAFETY: the caller guarantees AVX-512 F + VL; loads stay inside the arrays.
        unsafe {
            let (enter, exit) = interval_vector!(
                b,
                iv,
                tmax,
                0,
                _mm256_loadu_ps,
                _mm256_set1_ps,
                _mm256_sub_ps,
                _mm256_mul_ps,
                _mm256_max_ps,
                _mm256_min_ps
            );
            _mm256_cmp_ps_mask::<_CMP_NGT_UQ>(enter, exit) as u32
        }
    });
}

/// Elsewhere the x86 kernels are never selected (`SimdLevel::supported`); they run the
/// portable lanes so that code generic over them compiles.
#[cfg(not(target_arch = "x86_64"))]
mod elsewhere {
    use super::*;

    macro_rules! portable_as {
        ($kernel:ty) => {
            impl<const W: usize> IntervalSlab<W> for $kernel {
                #[inline(always)]
                unsafe fn maybe_entered(b: &[[f32; W]; 6], iv: &WideInterval, tmax: f32) -> u32 {
                    // SAFETY: the portable kernel has no requirement.
                    unsafe { <Portable as IntervalSlab<W>>::maybe_entered(b, iv, tmax) }
                }
            }
        };
    }
    portable_as!(Sse41);
    portable_as!(Avx2);
    portable_as!(Avx512);
}
