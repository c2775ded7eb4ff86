//! The watertight triangle test of one triangle against a packet of rays at once, SIMD
//! across the rays: the counterpart of the block test (`simd::triangle`, one ray against
//! four triangles) for a leaf that many rays of a packet reach.
//!
//! Each lane computes what the scalar test (`intersect::Watertight`) computes in f32, the same
//! operations in the same order, so a lane's t, u and v are that ray's scalar answer bit for
//! bit; what the scalar test decides in f64 the lane hands back (`PacketHits::retest`). The
//! rays of one call share the shear's axis permutation (the axis of their largest direction
//! component); a packet whose rays do not is tested once per permutation.
//!
//! The kernel also keeps each ray's closest hit (`PacketBest`, what `BestHit` keeps for one
//! ray) with masked stores: a hit closer than the ray's best replaces it. The rarer cases,
//! a hit at exactly the best distance (a tie, decided by the triangle index) and the lanes
//! handed back, go to the caller (`PacketHits::rest`), which decides them one ray at a time.

use super::ray_packet::{DIR, ORIGIN, PACKET_RAYS, RayLoad, RayPacket, TMAX, TMIN};
use super::slab::{Avx2, Avx512, Portable, Sse41};
use crate::geometry::gamma;
use crate::geometry::intersect::shear_axes_of;
use glam::Vec3;

/// The packet's rays in the watertight test's terms: each ray's shear as structures of
/// arrays, and per axis the rays whose largest direction component lies on it (which fixes
/// the whole permutation).
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct PacketShear {
    /// Rows s_x, s_y, s_z of each ray's `Shear`.
    pub s: [[f32; PACKET_RAYS]; 3],
    /// `by_axis[kz]`: the rays whose shear has that kz.
    pub by_axis: [u64; 3],
}

impl PacketShear {
    /// Each ray's shear, as `Watertight::prepare` computes it.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub unsafe fn new<K: RayLoad>(p: &RayPacket) -> Self {
        let mut shear = PacketShear {
            s: [[0.0; PACKET_RAYS]; 3],
            by_axis: [0; 3],
        };
        let [dx, dy, dz] = [&p.ray[DIR], &p.ray[DIR + 1], &p.ray[DIR + 2]];
        // Each ray's largest axis kz (`shear_axes`), with selects rather than branches, as
        // sign masks (−1 on it), and its components d_kx, d_ky, d_kz: whole rows at once, so
        // that they vectorise.
        let mut on = [[1.0f32; PACKET_RAYS]; 2];
        let mut dk = [[1.0f32; PACKET_RAYS]; 3];
        let [sx, sy, sz] = &mut shear.s;
        for i in 0..PACKET_RAYS {
            let (x, y, z) = (dx[i], dy[i], dz[i]);
            let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
            let on_x = ax >= ay && ax >= az;
            let on_y = !on_x && ay >= az;
            on[0][i] = if on_x { -1.0 } else { 1.0 };
            on[1][i] = if on_y { -1.0 } else { 1.0 };
            // (kx, ky, kz) = (1, 2, 0), (2, 0, 1) or (0, 1, 2).
            let (a, b, c) = if on_x {
                (y, z, x)
            } else if on_y {
                (z, x, y)
            } else {
                (x, y, z)
            };
            dk[0][i] = a;
            dk[1][i] = b;
            dk[2][i] = c;
            // 1 / d_kz is the reciprocal the box test already took.
            let (ix, iy, iz) = (p.inv_dir[0][i], p.inv_dir[1][i], p.inv_dir[2][i]);
            sz[i] = if on_x {
                ix
            } else if on_y {
                iy
            } else {
                iz
            };
        }
        for i in 0..PACKET_RAYS {
            sx[i] = -dk[0][i] / dk[2][i];
            sy[i] = -dk[1][i] / dk[2][i];
        }
        // SAFETY: the caller guarantees K's instruction set.
        let [x, y] = unsafe { [K::signs(&on[0]), K::signs(&on[1])] };
        shear.by_axis = [x & p.rays, y & p.rays, !(x | y) & p.rays];
        shear
    }
}

/// Each ray's closest hit so far, as `BestHit` keeps it for one ray, as structures of
/// arrays: the best distance (the ray's tmax before a hit), the bound for the next triangle
/// test (`BestHit::limit`), the hit's barycentrics and triangle.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct PacketBest {
    pub t: [f32; PACKET_RAYS],
    pub limit: [f32; PACKET_RAYS],
    pub u: [f32; PACKET_RAYS],
    pub v: [f32; PACKET_RAYS],
    pub triangle: [u32; PACKET_RAYS],
    /// The rays that have a hit.
    pub found: u64,
}

impl PacketBest {
    /// No hit yet: each ray's best distance and limit are its tmax.
    #[inline(always)]
    pub fn new(p: &RayPacket) -> Self {
        PacketBest {
            t: p.ray[TMAX],
            limit: p.ray[TMAX],
            u: [0.0; PACKET_RAYS],
            v: [0.0; PACKET_RAYS],
            triangle: [u32::MAX; PACKET_RAYS],
            found: 0,
        }
    }

    /// `BestHit::offer` for ray `i`: keeps the hit if it is closer than the best so far, or
    /// as close and on a lower-numbered triangle; whether it did.
    #[inline(always)]
    pub fn offer(&mut self, i: usize, t: f32, u: f32, v: f32, triangle: u32) -> bool {
        if self.found >> i & 1 == 1
            && (t > self.t[i] || (t == self.t[i] && triangle > self.triangle[i]))
        {
            return false;
        }
        self.t[i] = t;
        self.limit[i] = t.next_up();
        self.u[i] = u;
        self.v[i] = v;
        self.triangle[i] = triangle;
        self.found |= 1 << i;
        true
    }
}

/// What one triangle's test left to the caller: `rest` rays, whose `retest` ones need the
/// scalar test and whose others hit at `t` (barycentrics `u`, `v`) exactly at or beyond
/// their best distance, for `PacketBest::offer` to decide.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct PacketHits {
    pub t: [f32; PACKET_RAYS],
    pub u: [f32; PACKET_RAYS],
    pub v: [f32; PACKET_RAYS],
    pub rest: u64,
    pub retest: u64,
}

impl Default for PacketHits {
    fn default() -> Self {
        PacketHits {
            t: [0.0; PACKET_RAYS],
            u: [0.0; PACKET_RAYS],
            v: [0.0; PACKET_RAYS],
            rest: 0,
            retest: 0,
        }
    }
}

/// A triangle as `v[vertex][axis]`.
pub type TriangleVertices = [[f32; 3]; 3];

/// The watertight test of one triangle against the rays of a packet, one kernel per
/// instruction set.
pub trait PacketTriangleKernel {
    /// Tests triangle number `index` against the rays of `active`, all of whose shears have
    /// the largest axis `kz`, each within its (tmin, `best.limit`); a hit closer than a ray's
    /// best replaces it. Returns the rays whose best hit it replaced; leaves the rest in
    /// `out`.
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    #[allow(clippy::too_many_arguments)]
    unsafe fn closest_packet(
        tri: &TriangleVertices,
        index: u32,
        kz: usize,
        shear: &PacketShear,
        packet: &RayPacket,
        best: &mut PacketBest,
        active: u64,
        out: &mut PacketHits,
    ) -> u64;
}

impl PacketTriangleKernel for Portable {
    /// The block test's portable lanes, ray by ray.
    #[inline(always)]
    unsafe fn closest_packet(
        tri: &TriangleVertices,
        index: u32,
        kz: usize,
        shear: &PacketShear,
        p: &RayPacket,
        best: &mut PacketBest,
        active: u64,
        out: &mut PacketHits,
    ) -> u64 {
        let [kx, ky, kz] = shear_axes_of(kz);
        let (mut improved, mut rest, mut retests) = (0u64, 0u64, 0u64);
        let mut lanes = active & p.rays;
        while lanes != 0 {
            let i = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let s = Vec3::new(shear.s[0][i], shear.s[1][i], shear.s[2][i]);
            let o = [p.ray[ORIGIN][i], p.ray[ORIGIN + 1][i], p.ray[ORIGIN + 2][i]];
            let rel = |k: usize| {
                let q = &tri[k];
                Vec3::new(q[kx] - o[kx], q[ky] - o[ky], q[kz] - o[kz])
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
            let inside = !outside && det != 0.0 && t > p.ray[TMIN][i] && t < best.limit[i];
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
            let (u, v) = (e1 * inv_det, e2 * inv_det);
            let hit = inside && !near && !zero;
            let retest = zero || (inside && near);
            if hit && t < best.t[i] {
                best.t[i] = t;
                best.limit[i] = t.next_up();
                best.u[i] = u;
                best.v[i] = v;
                best.triangle[i] = index;
                improved |= 1 << i;
            } else if hit || retest {
                out.t[i] = t;
                out.u[i] = u;
                out.v[i] = v;
                rest |= 1 << i;
                retests |= u64::from(retest) << i;
            }
        }
        best.found |= improved;
        out.rest = rest;
        out.retest = retests;
        improved
    }
}

/// One group of rays starting at ray `$at`, with the intrinsics of one vector width;
/// evaluates to `(t, u, v, hit, retest)`, the last two as masks of that width (vectors for
/// 128 and 256 bits, mask registers for 512). The same operations as the block test's lanes
/// (`watertight_m128`), with the triangle's coordinates broadcast and each ray's origin,
/// shear and interval loaded per lane. Operations on masks and comparisons are macros
/// (`$mand!`, `$eq!`, ...), so each width passes its own.
#[cfg(target_arch = "x86_64")]
macro_rules! watertight_rays {
    ($tri:expr, $k:expr, $shear:expr, $p:expr, $limit:expr, $at:expr, $bits:expr,
     $lane_bits:ident, $load:ident, $set1:ident, $setzero:ident, $add:ident, $sub:ident,
     $mul:ident, $div:ident, $max:ident, $abs:ident, $mand:ident, $mor:ident, $mandnot:ident,
     $eq:ident, $neq:ident, $lt:ident, $gt:ident, $le:ident) => {{
        let (tri, shear, p, limit, at) = ($tri, $shear, $p, $limit, $at);
        let [kx, ky, kz] = $k;
        let (sx, sy, sz) = (
            $load(shear.s[0][at..].as_ptr()),
            $load(shear.s[1][at..].as_ptr()),
            $load(shear.s[2][at..].as_ptr()),
        );
        let (ox, oy, oz) = (
            $load(p.ray[ORIGIN + kx][at..].as_ptr()),
            $load(p.ray[ORIGIN + ky][at..].as_ptr()),
            $load(p.ray[ORIGIN + kz][at..].as_ptr()),
        );
        // Vertex k relative to each origin, permuted and sheared: (x, y, unscaled z).
        macro_rules! vertex {
            ($v:expr) => {{
                let z = $sub($set1(tri[$v][kz]), oz);
                (
                    $add($sub($set1(tri[$v][kx]), ox), $mul(sx, z)),
                    $add($sub($set1(tri[$v][ky]), oy), $mul(sy, z)),
                    z,
                )
            }};
        }
        let (ax, ay, aqz) = vertex!(0);
        let (bx, by, bqz) = vertex!(1);
        let (cx, cy, cqz) = vertex!(2);
        macro_rules! edge {
            ($px:expr, $py:expr, $qx:expr, $qy:expr) => {
                $sub($mul($px, $qy), $mul($py, $qx))
            };
        }
        let e0 = edge!(bx, by, cx, cy);
        let e1 = edge!(cx, cy, ax, ay);
        let e2 = edge!(ax, ay, bx, by);
        let zero = $setzero();
        let on_edge = $mor!($mor!($eq!(e0, zero), $eq!(e1, zero)), $eq!(e2, zero));
        let negative = $mor!($mor!($lt!(e0, zero), $lt!(e1, zero)), $lt!(e2, zero));
        let positive = $mor!($mor!($gt!(e0, zero), $gt!(e1, zero)), $gt!(e2, zero));
        let outside = $mand!(negative, positive);
        // No ray of the group inside the edges or on one: none can hit or be retested, so
        // nothing below would change a best hit or a ray handed back (the group's lanes of
        // `PacketHits` are read only for those). Most groups of a packet end here.
        if $bits & !($lane_bits!(outside) & !$lane_bits!(on_edge)) == 0 {
            continue;
        }
        let det = $add($add(e0, e1), e2);
        let (az, bz, cz) = ($mul(sz, aqz), $mul(sz, bqz), $mul(sz, cqz));
        let inv_det = $div($set1(1.0), det);
        let t = $mul(
            $add($add($mul(e0, az), $mul(e1, bz)), $mul(e2, cz)),
            inv_det,
        );
        let inside = $mandnot!(
            outside,
            $mand!(
                $neq!(det, zero),
                $mand!(
                    $gt!(t, $load(p.ray[TMIN][at..].as_ptr())),
                    $lt!(t, $load(limit[at..].as_ptr()))
                )
            )
        );
        // The rounding error of t, as the scalar test bounds it.
        macro_rules! max3 {
            ($a:expr, $b:expr, $c:expr) => {
                $max($max($abs!($a), $abs!($b)), $abs!($c))
            };
        }
        let max_z = max3!(az, bz, cz);
        let max_qz = max3!(aqz, bqz, cqz);
        let max_x = max3!(ax, bx, cx);
        let max_y = max3!(ay, by, cy);
        let (g2, g3, g5) = ($set1(gamma(2)), $set1(gamma(3)), $set1(gamma(5)));
        let delta_z = $mul(g3, max_z);
        let delta_x = $mul(g5, $add(max_x, max_qz));
        let delta_y = $mul(g5, $add(max_y, max_qz));
        let delta_e = $mul(
            $set1(2.0),
            $add(
                $add($mul($mul(g2, max_x), max_y), $mul(delta_y, max_x)),
                $mul(delta_x, max_y),
            ),
        );
        let max_e = max3!(e0, e1, e2);
        let delta_t = $mul(
            $mul(
                $set1(3.0),
                $add(
                    $add($mul($mul(g3, max_e), max_z), $mul(delta_e, max_z)),
                    $mul(delta_z, max_e),
                ),
            ),
            $abs!(inv_det),
        );
        let near = $le!(t, delta_t);
        let hit = $mandnot!($mor!(near, on_edge), inside);
        let retest = $mor!(on_edge, $mand!(inside, near));
        (t, $mul(e1, inv_det), $mul(e2, inv_det), hit, retest)
    }};
}

/// Binary operations and comparisons as macros, so every width passes them the same way.
#[cfg(target_arch = "x86_64")]
macro_rules! op_macros {
    ($($name:ident = $f:ident $(::<$pred:ident>)?;)*) => {
        $(
            macro_rules! $name {
                ($a:expr, $b:expr) => {
                    $f$(::<$pred>)?($a, $b)
                };
            }
        )*
    };
}

/// The kernel for vectors whose comparisons give vector masks (128 and 256 bits): the test,
/// then the masked update of the best hits. `$blend(a, b, mask)` takes b where mask is set;
/// `$movemask` gives the lane bits; `$lanes(bits)` the vector mask of lane bits.
#[cfg(target_arch = "x86_64")]
macro_rules! closest_vector {
    ($lanes_per:expr, $tri:expr, $index:expr, $kz:expr, $shear:expr, $p:expr, $best:expr,
     $active:expr, $out:expr,
     $load:ident, $store:ident, $set1:ident, $setzero:ident, $add:ident, $sub:ident,
     $mul:ident, $div:ident, $max:ident, $and:ident, $or:ident, $andnot:ident, $blend:ident,
     $movemask:ident, $cast_i:ident, $cast_f:ident, $set1_i:ident, $add_i:ident,
     $sub_i:ident, $lanes:ident,
     $eq:ident, $neq:ident, $lt:ident, $gt:ident, $le:ident) => {{
        const LANES: usize = $lanes_per;
        let (tri, shear, p, best, out) = ($tri, $shear, $p, $best, $out);
        let k = shear_axes_of($kz);
        let active = $active & p.rays;
        let (mut improved, mut rest, mut retests) = (0u64, 0u64, 0u64);
        let sign = $set1(-0.0);
        macro_rules! abs {
            ($x:expr) => {
                $andnot(sign, $x)
            };
        }
        op_macros! {
            mand = $and;
            mor = $or;
            mandnot = $andnot;
        }
        // A vector mask's lanes as bits.
        macro_rules! vector_bits {
            ($m:expr) => {
                $movemask($m) as u64
            };
        }
        let index = $cast_f($set1_i($index as i32));
        for g in 0..PACKET_RAYS / LANES {
            let at = g * LANES;
            let bits = (active >> at) & ((1 << LANES) - 1);
            if bits == 0 {
                continue;
            }
            let (t, u, v, hit, retest) = watertight_rays!(
                tri,
                k,
                shear,
                p,
                &best.limit,
                at,
                bits,
                vector_bits,
                $load,
                $set1,
                $setzero,
                $add,
                $sub,
                $mul,
                $div,
                $max,
                abs,
                mand,
                mor,
                mandnot,
                $eq,
                $neq,
                $lt,
                $gt,
                $le
            );
            let on = $lanes!(bits);
            let (hit, retest) = ($and(hit, on), $and(retest, on));
            // A hit closer than the best replaces it, lane by lane.
            let closer = $and(hit, $lt!(t, $load(best.t[at..].as_ptr())));
            macro_rules! keep {
                ($row:expr, $new:expr) => {
                    $store(
                        $row[at..].as_mut_ptr(),
                        $blend($load($row[at..].as_ptr()), $new, closer),
                    )
                };
            }
            keep!(best.t, t);
            keep!(best.u, u);
            keep!(best.v, v);
            // The next representable distance up (`f32::next_up` for finite t): the bits
            // one up for t > 0, one down for t < 0, the smallest subnormal for ±0.
            let t_bits = $cast_i(t);
            let up = $blend(
                $cast_f($set1_i(1)),
                $cast_f($add_i(t_bits, $set1_i(1))),
                $gt!(t, $setzero()),
            );
            let up = $blend(up, $cast_f($sub_i(t_bits, $set1_i(1))), $lt!(t, $setzero()));
            keep!(best.limit, up);
            let tri_row = best.triangle[at..].as_mut_ptr().cast::<f32>();
            $store(tri_row, $blend($load(tri_row), index, closer));
            $store(out.t[at..].as_mut_ptr(), t);
            $store(out.u[at..].as_mut_ptr(), u);
            $store(out.v[at..].as_mut_ptr(), v);
            improved |= ($movemask(closer) as u64) << at;
            rest |= ($movemask($or($andnot(closer, hit), retest)) as u64) << at;
            retests |= ($movemask(retest) as u64) << at;
        }
        best.found |= improved;
        out.rest = rest;
        out.retest = retests;
        improved
    }};
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    // The vector mask of the lanes set in `bits` (4 or 8 of them).
    macro_rules! lanes128 {
        ($bits:expr) => {{
            let lane_bits = _mm_set_epi32(8, 4, 2, 1);
            _mm_castsi128_ps(_mm_cmpeq_epi32(
                _mm_and_si128(_mm_set1_epi32($bits as i32), lane_bits),
                lane_bits,
            ))
        }};
    }
    macro_rules! lanes256 {
        ($bits:expr) => {{
            let lane_bits = _mm256_set_epi32(128, 64, 32, 16, 8, 4, 2, 1);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32($bits as i32), lane_bits),
                lane_bits,
            ))
        }};
    }

    impl PacketTriangleKernel for Sse41 {
        #[inline(always)]
        unsafe fn closest_packet(
            tri: &TriangleVertices,
            index: u32,
            kz: usize,
            shear: &PacketShear,
            p: &RayPacket,
            best: &mut PacketBest,
            active: u64,
            out: &mut PacketHits,
        ) -> u64 {
            op_macros! {
                eq = _mm_cmpeq_ps;
                neq = _mm_cmpneq_ps;
                lt = _mm_cmplt_ps;
                gt = _mm_cmpgt_ps;
                le = _mm_cmple_ps;
            }
            // SAFETY: the caller guarantees SSE4.1; every load and store covers lanes
            // at..at + 4 of arrays of `PACKET_RAYS`, at a multiple of 4 below it.
            unsafe {
                closest_vector!(
                    4,
                    tri,
                    index,
                    kz,
                    shear,
                    p,
                    best,
                    active,
                    out,
                    _mm_loadu_ps,
                    _mm_storeu_ps,
                    _mm_set1_ps,
                    _mm_setzero_ps,
                    _mm_add_ps,
                    _mm_sub_ps,
                    _mm_mul_ps,
                    _mm_div_ps,
                    _mm_max_ps,
                    _mm_and_ps,
                    _mm_or_ps,
                    _mm_andnot_ps,
                    _mm_blendv_ps,
                    _mm_movemask_ps,
                    _mm_castps_si128,
                    _mm_castsi128_ps,
                    _mm_set1_epi32,
                    _mm_add_epi32,
                    _mm_sub_epi32,
                    lanes128,
                    eq,
                    neq,
                    lt,
                    gt,
                    le
                )
            }
        }
    }

    impl PacketTriangleKernel for Avx2 {
        #[inline(always)]
        unsafe fn closest_packet(
            tri: &TriangleVertices,
            index: u32,
            kz: usize,
            shear: &PacketShear,
            p: &RayPacket,
            best: &mut PacketBest,
            active: u64,
            out: &mut PacketHits,
        ) -> u64 {
            op_macros! {
                eq = _mm256_cmp_ps::<_CMP_EQ_OQ>;
                neq = _mm256_cmp_ps::<_CMP_NEQ_UQ>;
                lt = _mm256_cmp_ps::<_CMP_LT_OQ>;
                gt = _mm256_cmp_ps::<_CMP_GT_OQ>;
                le = _mm256_cmp_ps::<_CMP_LE_OQ>;
            }
            // SAFETY: the caller guarantees AVX2; every load and store covers lanes
            // at..at + 8 of arrays of `PACKET_RAYS`, at a multiple of 8 below it.
            unsafe {
                closest_vector!(
                    8,
                    tri,
                    index,
                    kz,
                    shear,
                    p,
                    best,
                    active,
                    out,
                    _mm256_loadu_ps,
                    _mm256_storeu_ps,
                    _mm256_set1_ps,
                    _mm256_setzero_ps,
                    _mm256_add_ps,
                    _mm256_sub_ps,
                    _mm256_mul_ps,
                    _mm256_div_ps,
                    _mm256_max_ps,
                    _mm256_and_ps,
                    _mm256_or_ps,
                    _mm256_andnot_ps,
                    _mm256_blendv_ps,
                    _mm256_movemask_ps,
                    _mm256_castps_si256,
                    _mm256_castsi256_ps,
                    _mm256_set1_epi32,
                    _mm256_add_epi32,
                    _mm256_sub_epi32,
                    lanes256,
                    eq,
                    neq,
                    lt,
                    gt,
                    le
                )
            }
        }
    }

    impl PacketTriangleKernel for Avx512 {
        #[inline(always)]
        unsafe fn closest_packet(
            tri: &TriangleVertices,
            index: u32,
            kz: usize,
            shear: &PacketShear,
            p: &RayPacket,
            best: &mut PacketBest,
            active: u64,
            out: &mut PacketHits,
        ) -> u64 {
            const LANES: usize = 16;
            let k = shear_axes_of(kz);
            let active = active & p.rays;
            let (mut improved, mut rest, mut retests) = (0u64, 0u64, 0u64);
            // Masks are integers: their operations are the integer ones.
            macro_rules! mand {
                ($a:expr, $b:expr) => {
                    $a & $b
                };
            }
            macro_rules! mor {
                ($a:expr, $b:expr) => {
                    $a | $b
                };
            }
            macro_rules! mandnot {
                ($a:expr, $b:expr) => {
                    !$a & $b
                };
            }
            macro_rules! abs {
                ($x:expr) => {
                    _mm512_abs_ps($x)
                };
            }
            macro_rules! mask_bits {
                ($m:expr) => {
                    $m
                };
            }
            op_macros! {
                eq = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>;
                neq = _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>;
                lt = _mm512_cmp_ps_mask::<_CMP_LT_OQ>;
                gt = _mm512_cmp_ps_mask::<_CMP_GT_OQ>;
                le = _mm512_cmp_ps_mask::<_CMP_LE_OQ>;
            }
            // SAFETY: the caller guarantees AVX-512 F; every load and store covers lanes
            // at..at + 16 of arrays of `PACKET_RAYS`, at a multiple of 16 below it.
            unsafe {
                let index = _mm512_set1_epi32(index as i32);
                for g in 0..PACKET_RAYS / LANES {
                    let at = g * LANES;
                    let bits = (active >> at) as u16;
                    if bits == 0 {
                        continue;
                    }
                    let (t, u, v, hit, retest) = watertight_rays!(
                        tri,
                        k,
                        shear,
                        p,
                        &best.limit,
                        at,
                        bits,
                        mask_bits,
                        _mm512_loadu_ps,
                        _mm512_set1_ps,
                        _mm512_setzero_ps,
                        _mm512_add_ps,
                        _mm512_sub_ps,
                        _mm512_mul_ps,
                        _mm512_div_ps,
                        _mm512_max_ps,
                        abs,
                        mand,
                        mor,
                        mandnot,
                        eq,
                        neq,
                        lt,
                        gt,
                        le
                    );
                    let (hit, retest) = (hit & bits, retest & bits);
                    // A hit closer than the best replaces it, lane by lane.
                    let closer = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(
                        hit,
                        t,
                        _mm512_loadu_ps(best.t[at..].as_ptr()),
                    );
                    _mm512_mask_storeu_ps(best.t[at..].as_mut_ptr(), closer, t);
                    _mm512_mask_storeu_ps(best.u[at..].as_mut_ptr(), closer, u);
                    _mm512_mask_storeu_ps(best.v[at..].as_mut_ptr(), closer, v);
                    // The next representable distance up (`f32::next_up` for finite t).
                    let t_bits = _mm512_castps_si512(t);
                    let one = _mm512_set1_epi32(1);
                    let zero = _mm512_setzero_ps();
                    let up = _mm512_mask_add_epi32(
                        one,
                        _mm512_cmp_ps_mask::<_CMP_GT_OQ>(t, zero),
                        t_bits,
                        one,
                    );
                    let up = _mm512_mask_sub_epi32(
                        up,
                        _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, zero),
                        t_bits,
                        one,
                    );
                    _mm512_mask_storeu_ps(
                        best.limit[at..].as_mut_ptr(),
                        closer,
                        _mm512_castsi512_ps(up),
                    );
                    _mm512_mask_storeu_epi32(
                        best.triangle[at..].as_mut_ptr().cast(),
                        closer,
                        index,
                    );
                    _mm512_storeu_ps(out.t[at..].as_mut_ptr(), t);
                    _mm512_storeu_ps(out.u[at..].as_mut_ptr(), u);
                    _mm512_storeu_ps(out.v[at..].as_mut_ptr(), v);
                    improved |= u64::from(closer) << at;
                    rest |= u64::from((hit & !closer) | retest) << at;
                    retests |= u64::from(retest) << at;
                }
            }
            best.found |= improved;
            out.rest = rest;
            out.retest = retests;
            improved
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
            impl PacketTriangleKernel for $kernel {
                #[inline(always)]
                unsafe fn closest_packet(
                    tri: &TriangleVertices,
                    index: u32,
                    kz: usize,
                    shear: &PacketShear,
                    p: &RayPacket,
                    best: &mut PacketBest,
                    active: u64,
                    out: &mut PacketHits,
                ) -> u64 {
                    // SAFETY: the portable kernel has no requirement.
                    unsafe { Portable::closest_packet(tri, index, kz, shear, p, best, active, out) }
                }
            }
        };
    }
    portable_as!(Sse41);
    portable_as!(Avx2);
    portable_as!(Avx512);
}
