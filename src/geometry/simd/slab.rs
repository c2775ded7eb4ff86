//! The slab test of one ray against the W boxes of a wide node, stored as structures of
//! arrays (`[min x, min y, min z, max x, max y, max z]`, each `[f32; W]`), one kernel per
//! instruction set.
//!
//! Every lane computes the scalar `slab_entry` exactly: near and far planes picked per axis
//! by the sign of the direction (fixed once per ray), the far distances scaled by
//! 1 + 2γ(3), the same order of max and min. `max_ps(x, acc)` returns `acc` when `x` is NaN
//! or not greater, which is the scalar `max_keep(acc, x)`; likewise `min_ps`. So the lanes
//! agree with the scalar test bit for bit, ±0 and NaN included.

use crate::geometry::Ray;
use crate::geometry::aabb::FAR_SCALE;

/// Per-ray values of the wide slab test, fixed outside the traversal loop.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    pub origin: [f32; 3],
    pub inv_dir: [f32; 3],
    /// Per axis, the row of the node's bounds holding the near plane (axis, or axis + 3
    /// where the direction is negative, −0.0 included) and the far plane.
    pub near: [usize; 3],
    pub far: [usize; 3],
}

impl WideRay {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        let o = ray.origin;
        let neg = |c: f32| usize::from(c.is_sign_negative());
        let n = [neg(d.x), neg(d.y), neg(d.z)];
        WideRay {
            origin: [o.x, o.y, o.z],
            inv_dir: [1.0 / d.x, 1.0 / d.y, 1.0 / d.z],
            near: [3 * n[0], 1 + 3 * n[1], 2 + 3 * n[2]],
            far: [3 * (1 - n[0]), 1 + 3 * (1 - n[1]), 2 + 3 * (1 - n[2])],
        }
    }
}

/// A slab kernel for nodes of W children.
pub trait WideSlab<const W: usize> {
    /// Writes each lane's entry distance into `entry` and returns the mask of the lanes whose
    /// box the ray meets within [tmin, tmax] (other lanes' entries are meaningless).
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn entries(
        bounds: &[[f32; W]; 6],
        ray: &WideRay,
        tmin: f32,
        tmax: f32,
        entry: &mut [f32; W],
    ) -> u32;
}

/// The portable kernel: the scalar test in a loop over the lanes.
pub struct Portable;
/// SSE4.1: 128-bit vectors.
pub struct Sse41;
/// AVX2: 256-bit vectors (128-bit with VEX encoding for four lanes).
pub struct Avx2;
/// AVX-512 F + VL: compares straight into mask registers.
pub struct Avx512;

#[inline(always)]
fn max_keep(acc: f32, x: f32) -> f32 {
    if x > acc { x } else { acc }
}

#[inline(always)]
fn min_keep(acc: f32, x: f32) -> f32 {
    if x < acc { x } else { acc }
}

impl<const W: usize> WideSlab<W> for Portable {
    #[inline(always)]
    unsafe fn entries(
        b: &[[f32; W]; 6],
        r: &WideRay,
        tmin: f32,
        tmax: f32,
        entry: &mut [f32; W],
    ) -> u32 {
        let (o, inv) = (r.origin, r.inv_dir);
        let mut mask = 0;
        for i in 0..W {
            let near_x = (b[r.near[0]][i] - o[0]) * inv[0];
            let near_y = (b[r.near[1]][i] - o[1]) * inv[1];
            let near_z = (b[r.near[2]][i] - o[2]) * inv[2];
            let far_x = (b[r.far[0]][i] - o[0]) * inv[0];
            let far_y = (b[r.far[1]][i] - o[1]) * inv[1];
            let far_z = (b[r.far[2]][i] - o[2]) * inv[2];
            let enter = max_keep(max_keep(max_keep(tmin, near_x), near_y), near_z);
            let exit = min_keep(
                min_keep(min_keep(tmax, far_x * FAR_SCALE), far_y * FAR_SCALE),
                far_z * FAR_SCALE,
            );
            entry[i] = enter;
            mask |= u32::from(enter <= exit) << i;
        }
        mask
    }
}

/// The lanes' entry and exit distances for one vector of boxes starting at lane `$at`,
/// written with the intrinsics of one vector width (`m128` or `m256`).
#[cfg(target_arch = "x86_64")]
macro_rules! slab_vector {
    ($b:expr, $r:expr, $tmin:expr, $tmax:expr, $at:expr, m128) => {
        slab_vector!(@ $b, $r, $tmin, $tmax, $at,
            _mm_loadu_ps, _mm_set1_ps, _mm_sub_ps, _mm_mul_ps, _mm_max_ps, _mm_min_ps)
    };
    ($b:expr, $r:expr, $tmin:expr, $tmax:expr, $at:expr, m256) => {
        slab_vector!(@ $b, $r, $tmin, $tmax, $at,
            _mm256_loadu_ps, _mm256_set1_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_max_ps,
            _mm256_min_ps)
    };
    (@ $b:expr, $r:expr, $tmin:expr, $tmax:expr, $at:expr,
     $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident) => {{
        let (b, r) = ($b, $r);
        let plane = |row: usize, axis: usize| {
            $mul(
                $sub($load(b[row][$at..].as_ptr()), $set1(r.origin[axis])),
                $set1(r.inv_dir[axis]),
            )
        };
        let s = $set1(FAR_SCALE);
        let enter = $max(
            plane(r.near[2], 2),
            $max(plane(r.near[1], 1), $max(plane(r.near[0], 0), $set1($tmin))),
        );
        let exit = $min(
            $mul(plane(r.far[2], 2), s),
            $min(
                $mul(plane(r.far[1], 1), s),
                $min($mul(plane(r.far[0], 0), s), $set1($tmax)),
            ),
        );
        (enter, exit)
    }};
}

/// `impl WideSlab<W> for Kernel` with the body given: the signature written once.
macro_rules! wide_slab {
    ($kernel:ty, $w:literal, |$b:ident, $r:ident, $tmin:ident, $tmax:ident, $entry:ident| $body:block) => {
        impl WideSlab<$w> for $kernel {
            #[inline(always)]
            unsafe fn entries(
                $b: &[[f32; $w]; 6],
                $r: &WideRay,
                $tmin: f32,
                $tmax: f32,
                $entry: &mut [f32; $w],
            ) -> u32 $body
        }
    };
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    wide_slab!(Sse41, 4, |b, r, tmin, tmax, entry| {
        // SAFETY: the caller guarantees SSE4.1; loads and stores stay inside the arrays.
        unsafe {
            let (enter, exit) = slab_vector!(b, r, tmin, tmax, 0, m128);
            _mm_storeu_ps(entry.as_mut_ptr(), enter);
            _mm_movemask_ps(_mm_cmple_ps(enter, exit)) as u32
        }
    });

    wide_slab!(Sse41, 8, |b, r, tmin, tmax, entry| {
        // SAFETY: the caller guarantees SSE4.1; loads and stores stay inside the arrays
        // (two halves of four lanes).
        unsafe {
            let (e0, x0) = slab_vector!(b, r, tmin, tmax, 0, m128);
            let (e1, x1) = slab_vector!(b, r, tmin, tmax, 4, m128);
            _mm_storeu_ps(entry.as_mut_ptr(), e0);
            _mm_storeu_ps(entry[4..].as_mut_ptr(), e1);
            let lo = _mm_movemask_ps(_mm_cmple_ps(e0, x0)) as u32;
            let hi = _mm_movemask_ps(_mm_cmple_ps(e1, x1)) as u32;
            lo | hi << 4
        }
    });

    wide_slab!(Avx2, 4, |b, r, tmin, tmax, entry| {
        // SAFETY: AVX2 implies SSE4.1, whose kernel this is (VEX-encoded when inlined into
        // code compiled for AVX2).
        unsafe { <Sse41 as WideSlab<4>>::entries(b, r, tmin, tmax, entry) }
    });

    wide_slab!(Avx2, 8, |b, r, tmin, tmax, entry| {
        // SAFETY: the caller guarantees AVX2; loads and stores stay inside the arrays.
        unsafe {
            let (enter, exit) = slab_vector!(b, r, tmin, tmax, 0, m256);
            _mm256_storeu_ps(entry.as_mut_ptr(), enter);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(enter, exit)) as u32
        }
    });

    wide_slab!(Avx512, 4, |b, r, tmin, tmax, entry| {
        // SAFETY: the caller guarantees AVX-512 F + VL; loads and stores stay inside the
        // arrays.
        unsafe {
            let (enter, exit) = slab_vector!(b, r, tmin, tmax, 0, m128);
            _mm_storeu_ps(entry.as_mut_ptr(), enter);
            _mm_cmp_ps_mask::<_CMP_LE_OQ>(enter, exit) as u32
        }
    });

    wide_slab!(Avx512, 8, |b, r, tmin, tmax, entry| {
        // SAFETY: the caller guarantees AVX-512 F + VL; loads and stores stay inside the
        // arrays.
        unsafe {
            let (enter, exit) = slab_vector!(b, r, tmin, tmax, 0, m256);
            _mm256_storeu_ps(entry.as_mut_ptr(), enter);
            _mm256_cmp_ps_mask::<_CMP_LE_OQ>(enter, exit) as u32
        }
    });
}

/// Elsewhere the x86 kernels are never selected (`SimdLevel::supported`); they exist so the
/// code generic over them compiles, and run the portable lanes.
#[cfg(not(target_arch = "x86_64"))]
mod elsewhere {
    use super::*;

    macro_rules! portable_as {
        ($kernel:ty, $w:literal) => {
            wide_slab!($kernel, $w, |b, r, tmin, tmax, entry| {
                // SAFETY: the portable kernel has no requirement.
                unsafe { <Portable as WideSlab<$w>>::entries(b, r, tmin, tmax, entry) }
            });
        };
    }
    portable_as!(Sse41, 4);
    portable_as!(Sse41, 8);
    portable_as!(Avx2, 4);
    portable_as!(Avx2, 8);
    portable_as!(Avx512, 4);
    portable_as!(Avx512, 8);
}
