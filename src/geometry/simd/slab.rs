//! The slab test of one ray against the W boxes of a wide node, stored as structures of
//! arrays (`[min x, min y, min z, max x, max y, max z]`, each `[f32; W]`), one kernel per
//! instruction set, in two forms.
//!
//! The plain form (`entries`): every lane computes the scalar `slab_entry` exactly: near and
//! far planes picked per axis by the sign of the direction (fixed once per ray), the far
//! distances scaled by 1 + 2γ(3), the same order of max and min. `max_ps(x, acc)` returns
//! `acc` when `x` is NaN or not greater, which is the scalar `max_keep(acc, x)`; likewise
//! `min_ps`. So the lanes agree with the scalar test bit for bit, ±0 and NaN included.
//!
//! The fused form (`entries_fused`, the AVX-512 kernel's): a plane's distance is one fused
//! multiply-add, `b·inv + offset`, where the plain form subtracts, multiplies and scales: 6
//! instructions a node where the plain form takes 15, and the node's whole test 25
//! instructions instead of 36 in the walk. It keeps 12 vectors of per-ray constants live
//! where the plain form keeps 7: AVX-512 has the 32 registers for them, AVX2's 16 spill
//! (measured under callgrind: from 3 % fewer to 4 % more instructions), so AVX2 stays
//! plain. Its offsets are rounded outwards (`FusedPlanes`), so it is as conservative as the
//! plain form. The two forms may disagree on a box the ray grazes, by a rounding; both
//! never miss a box the ray meets, which the stress suite checks against exact arithmetic,
//! so the hits are the same, and only the node counts near such edges may differ between
//! kernels. The walks take the fused form for every ray whose fused constants are finite,
//! and the plain form for the rest (a zero direction component), whose infinities keep
//! axis-parallel rays exact.

use crate::geometry::Ray;
use crate::geometry::aabb::FAR_SCALE;
use glam::Vec3A;

/// Per-ray values of the wide slab test, fixed outside the traversal loop.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    /// Per axis, the row of the node's bounds holding the near plane (axis, or axis + 3
    /// where the direction is negative, −0.0 included) and the far plane. Always below 6.
    near: [usize; 3],
    far: [usize; 3],
    /// The same rows as byte offsets into 4- and 8-wide bounds (near x, y, z, then far),
    /// so a node's row address is one addition with no scaling left in the walk.
    bytes4: [u32; 6],
    bytes8: [u32; 6],
    /// The fused form's constants (`fused_entry`), per axis: a plane b is entered at
    /// `b·inv_dir + near_offset` and left at `b·inv_far + far_offset`.
    fused: FusedPlanes,
}

/// The fused slab form's per-ray constants: one fused multiply-add per plane, where the
/// plain form subtracts the origin and then multiplies.
///
/// `near_offset` is −(origin·inv_dir) moved down past its rounding error and `far_offset`
/// −(origin·inv_far) moved up past its, so each plane's distance is one rounding of a value
/// at most (near) or at least (far) the exact `(b − origin)·inv`: rounding is monotonic, so
/// the fused entry is at most, and the fused exit at least, one rounding of the exact
/// product. `inv_far` is `inv_dir` scaled by 1 + 2γ(3), as the plain form scales its far
/// distances, so the fused test is as conservative as the plain one (the stress suite checks
/// both against exact arithmetic). A ray with a zero direction component (an infinite
/// reciprocal) or an offset out of range is not `usable` and takes the plain form, whose
/// infinities make it exact on axis-parallel rays.
#[derive(Clone, Copy, Debug)]
pub struct FusedPlanes {
    inv_near: [f32; 3],
    inv_far: [f32; 3],
    near_offset: [f32; 3],
    far_offset: [f32; 3],
    usable: bool,
}

impl FusedPlanes {
    /// Three axes at once in glam's 4-lane vectors: made once per ray, and again each time
    /// a ray enters an instance, so it must be cheap.
    #[inline(always)]
    fn new(origin: Vec3A, inv_dir: Vec3A) -> Self {
        let inv_far = inv_dir * FAR_SCALE;
        // Rounding to nearest is off by at most half an ulp, and |x|·2⁻²² is at least two
        // ulps of a normal x; the smallest normal number covers x near zero. (Not the
        // smallest subnormal: from an origin on a plane through zero, the offset would be
        // subnormal, and Intel cores take a microcode assist of about a hundred cycles for
        // every multiply-add with a subnormal operand: sponza's primary rays, whose eye has
        // z = 0, ran 8× slower.)
        let up = |x: Vec3A| x + x.abs() * POW2_M22 + Vec3A::splat(f32::MIN_POSITIVE);
        let near_offset = -up(origin * inv_dir);
        let far_offset = up(-(origin * inv_far));
        FusedPlanes {
            inv_near: inv_dir.to_array(),
            inv_far: inv_far.to_array(),
            near_offset: near_offset.to_array(),
            far_offset: far_offset.to_array(),
            usable: (inv_far.is_finite_mask()
                & near_offset.is_finite_mask()
                & far_offset.is_finite_mask())
            .all(),
        }
    }
}

/// 2⁻²², exactly.
const POW2_M22: f32 = 1.0 / 4_194_304.0;

impl WideRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        let o = ray.origin;
        let neg = |c: f32| usize::from(c.is_sign_negative());
        let n = [neg(d.x), neg(d.y), neg(d.z)];
        let inv_dir = Vec3A::ONE / Vec3A::from(d);
        let near = [3 * n[0], 1 + 3 * n[1], 2 + 3 * n[2]];
        let far = [3 * (1 - n[0]), 1 + 3 * (1 - n[1]), 2 + 3 * (1 - n[2])];
        let rows = [near[0], near[1], near[2], far[0], far[1], far[2]];
        WideRay {
            origin: [o.x, o.y, o.z],
            inv_dir: inv_dir.to_array(),
            near,
            far,
            bytes4: rows.map(|r| (r * 16) as u32),
            bytes8: rows.map(|r| (r * 32) as u32),
            fused: FusedPlanes::new(Vec3A::from(o), inv_dir),
        }
    }

    /// Row `k` of `rows` (near x, y, z, far x, y, z) in `b`.
    #[inline(always)]
    fn row<'b, const W: usize>(&self, b: &'b [[f32; W]; 6], k: usize) -> &'b [f32; W] {
        let bytes = match W {
            8 => self.bytes8[k] as usize,
            4 => self.bytes4[k] as usize,
            _ => [self.near, self.far][k / 3][k % 3] * size_of::<[f32; W]>(),
        };
        // SAFETY: `new` makes every row below 6, and the offsets are those rows' in bytes.
        unsafe { &*b.as_ptr().cast::<u8>().add(bytes).cast::<[f32; W]>() }
    }

    /// The row of the near plane on `axis`.
    #[inline(always)]
    fn near_row<'b, const W: usize>(&self, b: &'b [[f32; W]; 6], axis: usize) -> &'b [f32; W] {
        self.row(b, axis)
    }

    #[inline(always)]
    fn far_row<'b, const W: usize>(&self, b: &'b [[f32; W]; 6], axis: usize) -> &'b [f32; W] {
        self.row(b, 3 + axis)
    }

    /// Whether a kernel's fused form may test this ray.
    #[inline(always)]
    pub fn fused_usable(&self) -> bool {
        self.fused.usable
    }
}

/// The fused form of the slab test on lane `i` (what the AVX-512 kernel computes, with
/// `f32::mul_add`): the entry distance, or +∞ if the ray misses the box within
/// [tmin, tmax].
pub fn fused_entry<const W: usize>(
    b: &[[f32; W]; 6],
    i: usize,
    r: &WideRay,
    tmin: f32,
    tmax: f32,
) -> f32 {
    let f = &r.fused;
    let (enter, exit) = if f.usable {
        let near = |a: usize| r.near_row(b, a)[i].mul_add(f.inv_near[a], f.near_offset[a]);
        let far = |a: usize| r.far_row(b, a)[i].mul_add(f.inv_far[a], f.far_offset[a]);
        // The kernels' tree of maxima and minima, operand for operand (`max_ps(x, acc)` is
        // `max_keep(acc, x)`).
        let enter = max_keep(max_keep(near(0), near(1)), max_keep(tmin, near(2)));
        let exit = min_keep(min_keep(far(0), far(1)), min_keep(tmax, far(2)));
        (enter, exit)
    } else {
        plain_lane(b, i, r, tmin, tmax)
    };
    if enter <= exit { enter } else { f32::INFINITY }
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

    /// Whether the kernel has a fused form (`FusedPlanes`), which the walks take for rays
    /// whose fused constants are usable.
    const FUSED: bool = false;

    /// `entries` in the fused form (`fused_entry`), for a ray whose `FusedPlanes` are
    /// usable; kernels without one test in the plain form.
    ///
    /// # Safety
    /// As `entries`.
    #[inline(always)]
    unsafe fn entries_fused(
        bounds: &[[f32; W]; 6],
        ray: &WideRay,
        tmin: f32,
        tmax: f32,
        entry: &mut [f32; W],
    ) -> u32 {
        // SAFETY: the caller's guarantee.
        unsafe { Self::entries(bounds, ray, tmin, tmax, entry) }
    }
}

/// A walk's slab test: K's fused form where the walk was chosen for it (`FUSED`, for a ray
/// whose fused constants are usable), its plain form otherwise.
///
/// # Safety
/// As `WideSlab::entries`; with `FUSED`, the ray is `fused_usable`.
#[inline(always)]
pub unsafe fn slab_test<const W: usize, K: WideSlab<W>, const FUSED: bool>(
    b: &[[f32; W]; 6],
    r: &WideRay,
    tmin: f32,
    tmax: f32,
    entry: &mut [f32; W],
) -> u32 {
    // SAFETY: the caller's guarantee.
    unsafe {
        match FUSED {
            true => K::entries_fused(b, r, tmin, tmax, entry),
            false => K::entries(b, r, tmin, tmax, entry),
        }
    }
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

/// The plain form on lane `i`: its entry and exit distances, the scalar `slab_entry`'s.
#[inline(always)]
fn plain_lane<const W: usize>(
    b: &[[f32; W]; 6],
    i: usize,
    r: &WideRay,
    tmin: f32,
    tmax: f32,
) -> (f32, f32) {
    let (o, inv) = (r.origin, r.inv_dir);
    let near = |a: usize| (r.near_row(b, a)[i] - o[a]) * inv[a];
    let far = |a: usize| (r.far_row(b, a)[i] - o[a]) * inv[a] * FAR_SCALE;
    let enter = max_keep(max_keep(max_keep(tmin, near(0)), near(1)), near(2));
    (
        enter,
        min_keep(min_keep(min_keep(tmax, far(0)), far(1)), far(2)),
    )
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
        let mut mask = 0;
        for (i, e) in entry.iter_mut().enumerate() {
            let (enter, exit) = plain_lane(b, i, r, tmin, tmax);
            *e = enter;
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
        let plane = |row: &[f32], axis: usize| {
            $mul(
                $sub($load(row[$at..].as_ptr()), $set1(r.origin[axis])),
                $set1(r.inv_dir[axis]),
            )
        };
        let near = |axis: usize| plane(r.near_row(b, axis), axis);
        let s = $set1(FAR_SCALE);
        let far = |axis: usize| $mul(plane(r.far_row(b, axis), axis), s);
        let enter = $max(near(2), $max(near(1), $max(near(0), $set1($tmin))));
        let exit = $min(far(2), $min(far(1), $min(far(0), $set1($tmax))));
        (enter, exit)
    }};
}

/// The fused form (`fused_entry`) for one vector of boxes: one fused multiply-add a plane.
#[cfg(target_arch = "x86_64")]
macro_rules! slab_fused {
    ($b:expr, $r:expr, $tmin:expr, $tmax:expr, m128) => {
        slab_fused!(@ $b, $r, $tmin, $tmax,
            _mm_loadu_ps, _mm_set1_ps, _mm_fmadd_ps, _mm_max_ps, _mm_min_ps)
    };
    ($b:expr, $r:expr, $tmin:expr, $tmax:expr, m256) => {
        slab_fused!(@ $b, $r, $tmin, $tmax,
            _mm256_loadu_ps, _mm256_set1_ps, _mm256_fmadd_ps, _mm256_max_ps, _mm256_min_ps)
    };
    (@ $b:expr, $r:expr, $tmin:expr, $tmax:expr,
     $load:ident, $set1:ident, $fmadd:ident, $max:ident, $min:ident) => {{
        let (b, r) = ($b, $r);
        let f = &r.fused;
        let near = |axis: usize| {
            $fmadd(
                $load(r.near_row(b, axis).as_ptr()),
                $set1(f.inv_near[axis]),
                $set1(f.near_offset[axis]),
            )
        };
        let far = |axis: usize| {
            $fmadd(
                $load(r.far_row(b, axis).as_ptr()),
                $set1(f.inv_far[axis]),
                $set1(f.far_offset[axis]),
            )
        };
        // Reduced as a tree, two levels deep rather than three in a chain: the planes'
        // distances arrive together, so a node's test waits one max (or min) less.
        let enter = $max($max(near(2), $set1($tmin)), $max(near(1), near(0)));
        let exit = $min($min(far(2), $set1($tmax)), $min(far(1), far(0)));
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

    /// The AVX-512 kernels: the plain form as `entries`, the fused form as `entries_fused`,
    /// each finished by the given store and compare (`$done`).
    macro_rules! plain_and_fused {
        ($kernel:ty, $w:literal, $vec:ident, |$enter:ident, $exit:ident, $entry:ident| $done:block) => {
            impl WideSlab<$w> for $kernel {
                #[inline(always)]
                unsafe fn entries(
                    b: &[[f32; $w]; 6],
                    r: &WideRay,
                    tmin: f32,
                    tmax: f32,
                    $entry: &mut [f32; $w],
                ) -> u32 {
                    // SAFETY: the caller guarantees the kernel's instruction set (with FMA);
                    // loads and stores stay inside the arrays.
                    unsafe {
                        let ($enter, $exit) = slab_vector!(b, r, tmin, tmax, 0, $vec);
                        $done
                    }
                }

                const FUSED: bool = true;

                #[inline(always)]
                unsafe fn entries_fused(
                    b: &[[f32; $w]; 6],
                    r: &WideRay,
                    tmin: f32,
                    tmax: f32,
                    $entry: &mut [f32; $w],
                ) -> u32 {
                    debug_assert!(r.fused.usable);
                    // SAFETY: as in `entries`.
                    unsafe {
                        let ($enter, $exit) = slab_fused!(b, r, tmin, tmax, $vec);
                        $done
                    }
                }
            }
        };
    }

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

    plain_and_fused!(Avx512, 4, m128, |enter, exit, entry| {
        _mm_storeu_ps(entry.as_mut_ptr(), enter);
        _mm_cmp_ps_mask::<_CMP_LE_OQ>(enter, exit) as u32
    });
    plain_and_fused!(Avx512, 8, m256, |enter, exit, entry| {
        _mm256_storeu_ps(entry.as_mut_ptr(), enter);
        _mm256_cmp_ps_mask::<_CMP_LE_OQ>(enter, exit) as u32
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The fused constants are never subnormal, whatever the origin: a subnormal operand
    /// costs every multiply-add of the walk a microcode assist on Intel cores. An origin
    /// on a plane through zero (sponza's and sibenik's standard eyes have z = 0) was the
    /// case that made them so.
    #[test]
    fn the_fused_constants_are_never_subnormal() {
        let origins = [
            Vec3::ZERO,
            Vec3::new(-14.0, 3.0, 0.0),
            Vec3::new(-0.0, 1e-30, -1e-38),
            Vec3::new(1e-20, -1e-10, 1e5),
        ];
        let directions = [
            Vec3::new(0.9, 0.1, 0.3),
            Vec3::new(-1e-3, 1.0, -1e-6),
            Vec3::new(1e-20, -1.0, 1e-20),
        ];
        for o in origins {
            for d in directions {
                let f = WideRay::new(&Ray::new(o, d.normalize())).fused;
                let all = [f.inv_near, f.inv_far, f.near_offset, f.far_offset];
                for x in all.iter().flatten() {
                    assert!(!x.is_subnormal(), "{x:e} from origin {o} direction {d}");
                }
            }
        }
    }
}
