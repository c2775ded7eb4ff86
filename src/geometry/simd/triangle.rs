//! The watertight triangle test on four triangles at once: a wide leaf's triangles are stored
//! as structures of arrays (`TriangleBlock`), one SIMD lane per triangle.
//!
//! Each lane computes what the scalar test (`intersect::Watertight`) computes in f32, the
//! same operations in the same order (no fused multiply-add), so a lane's t, u and v are the
//! scalar test's bit for bit. What the scalar test decides in f64 — an edge function that
//! rounds to exactly zero, a hit too close to the origin for f32 to place — a lane hands back
//! to the scalar test (`BlockHits::retest`); both are rare.

use super::slab::{Avx2, Avx512, Portable, Sse41};
use crate::geometry::intersect::Shear;
use crate::geometry::{Ray, Triangle, gamma};
use glam::Vec3;

/// Triangles per block: one 128-bit vector of f32.
pub const BLOCK: usize = 4;

/// Four triangles as structures of arrays, `v[vertex][axis][lane]`: one load brings the same
/// coordinate of all four. An unused lane holds NaN, which no ray hits (every comparison
/// with NaN fails, so its t is never inside the ray's interval and no edge is zero).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct TriangleBlock {
    pub v: [[[f32; BLOCK]; 3]; 3],
}

impl TriangleBlock {
    pub const EMPTY: TriangleBlock = TriangleBlock {
        v: [[[f32::NAN; BLOCK]; 3]; 3],
    };

    #[inline]
    pub fn triangle(&self, lane: usize) -> Triangle {
        let p = |k: usize| Vec3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]);
        Triangle::new(p(0), p(1), p(2))
    }

    #[inline]
    pub fn set(&mut self, lane: usize, tri: &Triangle) {
        for (row, p) in self.v.iter_mut().zip(&tri.v) {
            row[0][lane] = p.x;
            row[1][lane] = p.y;
            row[2][lane] = p.z;
        }
    }

    /// Whether `lane` is unused (all NaN): what padding must look like.
    pub fn is_padding(&self, lane: usize) -> bool {
        self.v.iter().flatten().all(|row| row[lane].is_nan())
    }
}

/// What the test found, lane by lane. `hit` lanes meet the triangle at `t` within the ray's
/// (tmin, tmax), with barycentrics `u`, `v` (meaningless in other lanes); `retest` lanes need
/// the scalar test, which decides them in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockHits {
    pub t: [f32; BLOCK],
    pub u: [f32; BLOCK],
    pub v: [f32; BLOCK],
    pub hit: u32,
    pub retest: u32,
}

impl BlockHits {
    /// Every lane to the scalar test: what an intersector without a block test returns.
    pub const RETEST_ALL: BlockHits = BlockHits {
        t: [0.0; BLOCK],
        u: [0.0; BLOCK],
        v: [0.0; BLOCK],
        hit: 0,
        retest: (1 << BLOCK) - 1,
    };

    /// No lane hits and none is handed back (t, u and v are then never read).
    pub const MISS: BlockHits = BlockHits {
        hit: 0,
        retest: 0,
        ..BlockHits::RETEST_ALL
    };
}

/// The watertight test of one ray against a block, one kernel per instruction set. The ray
/// enters through its `Shear`, which holds its origin in the permuted axes.
pub trait TriangleKernel: super::KernelLevel {
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn watertight(
        block: &TriangleBlock,
        shear: &Shear,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
    ) -> BlockHits;
}

impl TriangleKernel for Portable {
    #[inline(always)]
    unsafe fn watertight(
        block: &TriangleBlock,
        shear: &Shear,
        _ray: &Ray,
        tmin: f32,
        tmax: f32,
    ) -> BlockHits {
        let [kx, ky, kz] = shear.k();
        let s = shear.s;
        let o = shear.o;
        let mut out = BlockHits {
            hit: 0,
            retest: 0,
            ..BlockHits::RETEST_ALL
        };
        for i in 0..BLOCK {
            let rel = |k: usize| {
                let p = &block.v[k];
                Vec3::new(p[kx][i] - o[0], p[ky][i] - o[1], p[kz][i] - o[2])
            };
            let (a, b, c) = (rel(0), rel(1), rel(2));
            let (ax, ay) = (a.x + s.x * a.z, a.y + s.y * a.z);
            let (bx, by) = (b.x + s.x * b.z, b.y + s.y * b.z);
            let (cx, cy) = (c.x + s.x * c.z, c.y + s.y * c.z);
            let e0 = bx * cy - by * cx;
            let e1 = cx * ay - cy * ax;
            let e2 = ax * by - ay * bx;
            let zero = e0 == 0.0 || e1 == 0.0 || e2 == 0.0;
            let outside = (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0);
            let det = e0 + e1 + e2;
            let (az, bz, cz) = (s.z * a.z, s.z * b.z, s.z * c.z);
            let inv_det = 1.0 / det;
            let t = (e0 * az + e1 * bz + e2 * cz) * inv_det;
            let inside = !outside && det != 0.0 && t > tmin && t < tmax;
            let max_z = az.abs().max(bz.abs()).max(cz.abs());
            let max_qz = a.z.abs().max(b.z.abs()).max(c.z.abs());
            let max_x = ax.abs().max(bx.abs()).max(cx.abs());
            let max_y = ay.abs().max(by.abs()).max(cy.abs());
            let delta_z = gamma(3) * max_z;
            let delta_x = gamma(5) * (max_x + max_qz);
            let delta_y = gamma(5) * (max_y + max_qz);
            let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
            let max_e = e0.abs().max(e1.abs()).max(e2.abs());
            let delta_t = 3.0
                * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e)
                * inv_det.abs();
            let near = t <= delta_t;
            out.t[i] = t;
            out.u[i] = e1 * inv_det;
            out.v[i] = e2 * inv_det;
            out.hit |= u32::from(inside && !near && !zero) << i;
            out.retest |= u32::from(zero || (inside && near)) << i;
        }
        out
    }
}

/// The lanes of the test with the intrinsics of one vector width; evaluates to
/// `(t, u, v, hit, retest)`, the last two as lane masks in vectors. A block in which no
/// lane can hit or be handed back — the commonest case, a ray passing beside all four
/// triangles — returns `BlockHits::MISS` from the enclosing kernel as soon as the edge
/// functions show it, before the division and the error bound: what those would decide
/// is only ever read in hit or handed-back lanes.
#[cfg(target_arch = "x86_64")]
macro_rules! watertight_m128 {
    ($block:expr, $shear:expr, $tmin:expr, $tmax:expr) => {{
        let (block, shear) = ($block, $shear);
        let [kx, ky, kz] = shear.k();
        // The origin in the permuted axes, picked once per ray (`Shear::o`).
        let [ox, oy, oz] = shear.o.map(|c| _mm_set1_ps(c));
        let (sx, sy, sz) = (
            _mm_set1_ps(shear.s.x),
            _mm_set1_ps(shear.s.y),
            _mm_set1_ps(shear.s.z),
        );
        // Unchecked: a shear's axes are below 3 (`Shear::k`).
        let row = |k: usize, axis: usize| _mm_load_ps(block.v[k].get_unchecked(axis).as_ptr());
        // Vertex k relative to the origin, permuted and sheared: (x, y, unscaled z).
        let vertex = |k: usize| {
            let z = _mm_sub_ps(row(k, kz), oz);
            (
                _mm_add_ps(_mm_sub_ps(row(k, kx), ox), _mm_mul_ps(sx, z)),
                _mm_add_ps(_mm_sub_ps(row(k, ky), oy), _mm_mul_ps(sy, z)),
                z,
            )
        };
        let (ax, ay, aqz) = vertex(0);
        let (bx, by, bqz) = vertex(1);
        let (cx, cy, cqz) = vertex(2);
        let edge = |px, py, qx, qy| _mm_sub_ps(_mm_mul_ps(px, qy), _mm_mul_ps(py, qx));
        let e0 = edge(bx, by, cx, cy);
        let e1 = edge(cx, cy, ax, ay);
        let e2 = edge(ax, ay, bx, by);
        let zero = _mm_setzero_ps();
        let on_edge = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(e0, zero), _mm_cmpeq_ps(e1, zero)),
            _mm_cmpeq_ps(e2, zero),
        );
        // Edges of one sign, read from the sign bits: the lanes whose edges' or has the sign
        // bit and whose edges' and has not are those with edges of both signs, the scalar
        // test's `outside` wherever no edge is ±0 (such a lane is on an edge and handed back
        // whatever this says). Only sign bits are meaningful in this mask and in those made
        // from it; each ends in a movemask.
        let mixed = _mm_andnot_ps(
            _mm_and_ps(_mm_and_ps(e0, e1), e2),
            _mm_or_ps(_mm_or_ps(e0, e1), e2),
        );
        let det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
        // A lane can hit only with its edges of one sign and a determinant that is not NaN
        // (padding's is): nonzero edges of one sign have a nonzero sum. It is handed back
        // only with an edge at zero.
        let one_sign = _mm_andnot_ps(mixed, _mm_cmpord_ps(det, det));
        if _mm_movemask_ps(_mm_or_ps(one_sign, on_edge)) == 0 {
            return BlockHits::MISS;
        }
        let (az, bz, cz) = (
            _mm_mul_ps(sz, aqz),
            _mm_mul_ps(sz, bqz),
            _mm_mul_ps(sz, cqz),
        );
        let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(e0, az), _mm_mul_ps(e1, bz)),
                _mm_mul_ps(e2, cz),
            ),
            inv_det,
        );
        // A NaN t (a NaN determinant) is within no interval.
        let inside = _mm_and_ps(
            one_sign,
            _mm_and_ps(
                _mm_cmpgt_ps(t, _mm_set1_ps($tmin)),
                _mm_cmplt_ps(t, _mm_set1_ps($tmax)),
            ),
        );
        // No lane within the interval nor on an edge: the error bound decides nothing.
        if _mm_movemask_ps(_mm_or_ps(inside, on_edge)) == 0 {
            return BlockHits::MISS;
        }
        // The rounding error of t, as the scalar test bounds it.
        let sign = _mm_set1_ps(-0.0);
        let abs = |x| _mm_andnot_ps(sign, x);
        let max3 = |a, b, c| _mm_max_ps(_mm_max_ps(abs(a), abs(b)), abs(c));
        let max_qz = max3(aqz, bqz, cqz);
        // max |s_z q_z| is |s_z| max |q_z| bit for bit: rounding is monotonic and symmetric.
        let max_z = _mm_mul_ps(abs(sz), max_qz);
        let max_x = max3(ax, bx, cx);
        let max_y = max3(ay, by, cy);
        let g = |n: i32| _mm_set1_ps(gamma(n));
        let delta_z = _mm_mul_ps(g(3), max_z);
        let delta_x = _mm_mul_ps(g(5), _mm_add_ps(max_x, max_qz));
        let delta_y = _mm_mul_ps(g(5), _mm_add_ps(max_y, max_qz));
        let delta_e = _mm_mul_ps(
            _mm_set1_ps(2.0),
            _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(2), max_x), max_y),
                    _mm_mul_ps(delta_y, max_x),
                ),
                _mm_mul_ps(delta_x, max_y),
            ),
        );
        let max_e = max3(e0, e1, e2);
        let delta_t = _mm_mul_ps(
            _mm_mul_ps(
                _mm_set1_ps(3.0),
                _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(_mm_mul_ps(g(3), max_e), max_z),
                        _mm_mul_ps(delta_e, max_z),
                    ),
                    _mm_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        let near = _mm_cmple_ps(t, delta_t);
        let hit = _mm_andnot_ps(_mm_or_ps(near, on_edge), inside);
        let retest = _mm_or_ps(on_edge, _mm_and_ps(inside, near));
        (
            t,
            _mm_mul_ps(e1, inv_det),
            _mm_mul_ps(e2, inv_det),
            hit,
            retest,
        )
    }};
}

/// `impl TriangleKernel for Kernel` with the body given: the signature written once.
#[cfg(target_arch = "x86_64")]
macro_rules! triangle_kernel {
    ($kernel:ty, |$block:ident, $shear:ident, $ray:ident, $tmin:ident, $tmax:ident| $body:block) => {
        impl TriangleKernel for $kernel {
            #[inline(always)]
            unsafe fn watertight(
                $block: &TriangleBlock,
                $shear: &Shear,
                $ray: &Ray,
                $tmin: f32,
                $tmax: f32,
            ) -> BlockHits $body
        }
    };
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    triangle_kernel!(Sse41, |block, shear, _ray, tmin, tmax| {
        // SAFETY: the caller guarantees SSE4.1; the block's rows are 16-byte aligned arrays
        // of four lanes, indexed by the shear's axes, which are below 3 (`Shear::k`); the
        // stores write into arrays of four.
        unsafe {
            let (t, u, v, hit, retest) = watertight_m128!(block, shear, tmin, tmax);
            let mut out = BlockHits {
                hit: _mm_movemask_ps(hit) as u32,
                retest: _mm_movemask_ps(retest) as u32,
                ..BlockHits::RETEST_ALL
            };
            _mm_storeu_ps(out.t.as_mut_ptr(), t);
            _mm_storeu_ps(out.u.as_mut_ptr(), u);
            _mm_storeu_ps(out.v.as_mut_ptr(), v);
            out
        }
    });

    triangle_kernel!(Avx2, |block, shear, ray, tmin, tmax| {
        // SAFETY: AVX2 implies SSE4.1, whose kernel this is (VEX-encoded when inlined into
        // code compiled for AVX2).
        unsafe { Sse41::watertight(block, shear, ray, tmin, tmax) }
    });

    triangle_kernel!(Avx512, |block, shear, ray, tmin, tmax| {
        // SAFETY: AVX-512 F implies SSE4.1, whose kernel this is (EVEX/VEX-encoded when
        // inlined into code compiled for AVX-512).
        unsafe { Sse41::watertight(block, shear, ray, tmin, tmax) }
    });
}

/// Elsewhere the x86 kernels are never selected (`SimdLevel::supported`); they run the
/// portable lanes so that code generic over them compiles.
#[cfg(not(target_arch = "x86_64"))]
mod elsewhere {
    use super::*;

    macro_rules! portable_as {
        ($kernel:ty) => {
            impl TriangleKernel for $kernel {
                #[inline(always)]
                unsafe fn watertight(
                    block: &TriangleBlock,
                    shear: &Shear,
                    ray: &Ray,
                    tmin: f32,
                    tmax: f32,
                ) -> BlockHits {
                    // SAFETY: the portable kernel has no requirement.
                    unsafe { Portable::watertight(block, shear, ray, tmin, tmax) }
                }
            }
        };
    }
    portable_as!(Sse41);
    portable_as!(Avx2);
    portable_as!(Avx512);
}
