//! A packet of rays as structures of arrays: row r, lane i holds field r of ray i, so one
//! vector load brings the same field of 4, 8 or 16 rays. Loading a packet transposes the
//! rays' 8 × 8 blocks of floats with SIMD shuffles (one kernel per instruction set), as
//! scattering them one float at a time cost more than a packet's whole box tests.

use super::slab::{Avx2, Avx512, Portable, Sse41};
use crate::geometry::Ray;

/// Rays per packet: an 8 × 8 tile of pixels.
pub const PACKET_RAYS: usize = 64;

/// Rows of `RayPacket::ray`: the fields of `Ray` in its order (origin x, y, z, direction x,
/// y, z, tmin, tmax).
pub const ORIGIN: usize = 0;
pub const DIR: usize = 3;
pub const TMIN: usize = 6;
pub const TMAX: usize = 7;

/// A ray is eight f32 in the order of the rows (`Ray` is `repr(C)`).
const _: () = assert!(std::mem::size_of::<Ray>() == 32);
const _: () = assert!(std::mem::offset_of!(Ray, direction) == 4 * DIR);
const _: () = assert!(std::mem::offset_of!(Ray, tmin) == 4 * TMIN);
const _: () = assert!(std::mem::offset_of!(Ray, tmax) == 4 * TMAX);

/// A packet's rays as structures of arrays. Lanes past the packet's rays are never active.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct RayPacket {
    /// Row r, lane i: field r of ray i (`ORIGIN`, `DIR`, `TMIN`, `TMAX`).
    pub ray: [[f32; PACKET_RAYS]; 8],
    pub inv_dir: [[f32; PACKET_RAYS]; 3],
    /// Each ray's box-test limit: its tmax, or its best hit so far, widened for the rounding
    /// of the box test.
    pub tmax: [f32; PACKET_RAYS],
    /// Per axis, bit i set where ray i's direction is negative (−0.0 included): its near
    /// plane is the box's max.
    pub negative: [u64; 3],
    /// Bit i set for each ray of the packet.
    pub rays: u64,
}

/// Transposes rays into rows, one kernel per instruction set.
pub trait RayLoad {
    /// Writes field r of `rays[i]` into `rows[r][i]` (`rays` holds at most `PACKET_RAYS`).
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]);

    /// The sign bits of a row: bit i set where lane i is negative (−0.0 included).
    ///
    /// # Safety
    /// The CPU supports the kernel's instruction set (`SimdLevel::supported`).
    unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64;
}

impl RayPacket {
    /// The packet of `rays` (at most `PACKET_RAYS`), with box-test limits tmax · `scale`.
    /// Inlined into the traversal, so that its loops use the traversal's instructions.
    ///
    /// # Safety
    /// The CPU supports K's instruction set.
    #[inline(always)]
    pub unsafe fn load<K: RayLoad>(rays: &[Ray], scale: f32) -> Self {
        let n = rays.len().min(PACKET_RAYS);
        let lanes = |v: f32| [v; PACKET_RAYS];
        let mut p = RayPacket {
            // Unused lanes: a ray along +x that enters no box, in (+∞, −∞).
            ray: [
                lanes(0.0),
                lanes(0.0),
                lanes(0.0),
                lanes(1.0),
                lanes(1.0),
                lanes(1.0),
                lanes(f32::INFINITY),
                lanes(f32::NEG_INFINITY),
            ],
            inv_dir: [lanes(1.0); 3],
            tmax: lanes(0.0),
            negative: [0; 3],
            rays: if n == PACKET_RAYS {
                u64::MAX
            } else {
                (1u64 << n) - 1
            },
        };
        // SAFETY: the caller guarantees K's instruction set.
        unsafe { K::transpose(&rays[..n], &mut p.ray) };
        // Whole rows at once, so that they vectorise.
        for axis in 0..3 {
            for (inv, &d) in p.inv_dir[axis].iter_mut().zip(&p.ray[DIR + axis]) {
                *inv = 1.0 / d;
            }
            // SAFETY: as above.
            p.negative[axis] = unsafe { K::signs(&p.ray[DIR + axis]) } & p.rays;
        }
        for (limit, &t) in p.tmax.iter_mut().zip(&p.ray[TMAX]) {
            *limit = t * scale;
        }
        p
    }

    /// Rays in the packet (they are its lowest lanes).
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.rays.count_ones() as usize
    }

    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.rays == 0
    }

    /// Row `row` of the rays in the packet.
    #[inline(always)]
    pub fn row(&self, row: usize) -> &[f32] {
        &self.ray[row][..self.len()]
    }

    /// The largest box-test limit of the packet's rays (unused lanes hold −∞).
    #[inline(always)]
    pub fn largest_tmax(&self) -> f32 {
        max(&self.tmax, PACKET_RAYS)
    }
}

/// The smallest of the first `n` lanes of a row (NaN ignored; +∞ if none). Sixteen running
/// minima over the whole row, then halves, with plain comparisons and fixed trip counts, so
/// that the loops vectorise and stay in registers.
#[inline(always)]
pub fn min(row: &[f32; PACKET_RAYS], n: usize) -> f32 {
    reduce(row, n, f32::INFINITY, |a, b| if b < a { b } else { a })
}

/// The largest of the first `n` lanes of a row (NaN ignored; −∞ if none), as `min`.
#[inline(always)]
pub fn max(row: &[f32; PACKET_RAYS], n: usize) -> f32 {
    reduce(row, n, f32::NEG_INFINITY, |a, b| if b > a { b } else { a })
}

#[inline(always)]
fn reduce(row: &[f32; PACKET_RAYS], n: usize, empty: f32, keep: impl Fn(f32, f32) -> f32) -> f32 {
    let mut m = [empty; 16];
    let (chunks, _) = row.as_chunks::<16>();
    for (c, chunk) in chunks.iter().enumerate() {
        for (j, (m, &x)) in m.iter_mut().zip(chunk).enumerate() {
            let x = if 16 * c + j < n { x } else { empty };
            *m = keep(*m, x);
        }
    }
    let m: [f32; 8] = std::array::from_fn(|i| keep(m[i], m[i + 8]));
    let m: [f32; 4] = std::array::from_fn(|i| keep(m[i], m[i + 4]));
    keep(keep(m[0], m[2]), keep(m[1], m[3]))
}

impl RayLoad for Portable {
    #[inline(always)]
    unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]) {
        transpose_from(rays, 0, rows);
    }

    #[inline(always)]
    unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
        signs(row)
    }
}

#[inline(always)]
fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
    row.iter()
        .enumerate()
        .fold(0, |m, (i, &x)| m | u64::from(x.is_sign_negative()) << i)
}

/// Rays `from..` into the rows, one float at a time: the portable kernel, and the SIMD
/// kernels' last rays short of a whole block.
#[inline(always)]
fn transpose_from(rays: &[Ray], from: usize, rows: &mut [[f32; PACKET_RAYS]; 8]) {
    for (i, r) in rays.iter().enumerate().take(PACKET_RAYS).skip(from) {
        let (o, d) = (r.origin, r.direction);
        let fields = [o.x, o.y, o.z, d.x, d.y, d.z, r.tmin, r.tmax];
        for (row, f) in rows.iter_mut().zip(fields) {
            row[i] = f;
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    impl RayLoad for Sse41 {
        #[inline(always)]
        unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]) {
            let whole = rays.len().min(PACKET_RAYS) / 4 * 4;
            // SAFETY: the caller guarantees SSE4.1. `Ray` is eight f32 (`repr(C)`, asserted
            // above), so ray i's fields are the floats 8i..8i + 8 from the slice's start;
            // blocks of four rays below `whole` stay inside the slice, and each store writes
            // lanes at..at + 4 ≤ `PACKET_RAYS` of a row.
            unsafe {
                let base = rays.as_ptr().cast::<f32>();
                for at in (0..whole).step_by(4) {
                    for half in 0..2 {
                        // Fields 4·half.. of rays at..at + 4, transposed 4 × 4.
                        macro_rules! quarter {
                            ($k:expr) => {
                                _mm_loadu_ps(base.add(8 * (at + $k) + 4 * half))
                            };
                        }
                        let (r0, r1, r2, r3) = (quarter!(0), quarter!(1), quarter!(2), quarter!(3));
                        let t0 = _mm_unpacklo_ps(r0, r1);
                        let t1 = _mm_unpacklo_ps(r2, r3);
                        let t2 = _mm_unpackhi_ps(r0, r1);
                        let t3 = _mm_unpackhi_ps(r2, r3);
                        let row = &mut rows[4 * half..4 * half + 4];
                        _mm_storeu_ps(row[0][at..].as_mut_ptr(), _mm_movelh_ps(t0, t1));
                        _mm_storeu_ps(row[1][at..].as_mut_ptr(), _mm_movehl_ps(t1, t0));
                        _mm_storeu_ps(row[2][at..].as_mut_ptr(), _mm_movelh_ps(t2, t3));
                        _mm_storeu_ps(row[3][at..].as_mut_ptr(), _mm_movehl_ps(t3, t2));
                    }
                }
            }
            transpose_from(rays, whole, rows);
        }

        #[inline(always)]
        unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
            let mut m = 0;
            for at in (0..PACKET_RAYS).step_by(4) {
                // SAFETY: the caller guarantees SSE4.1; lanes at..at + 4 of the row.
                m |= (unsafe { _mm_movemask_ps(_mm_loadu_ps(row[at..].as_ptr())) } as u64) << at;
            }
            m
        }
    }

    /// The 8 × 8 transpose of AVX, for AVX2 and AVX-512.
    macro_rules! transpose_m256 {
        ($rays:expr, $rows:expr) => {{
            let (rays, rows) = ($rays, $rows);
            let whole = rays.len().min(PACKET_RAYS) / 8 * 8;
            let base = rays.as_ptr().cast::<f32>();
            for at in (0..whole).step_by(8) {
                macro_rules! ray {
                    ($k:expr) => {
                        _mm256_loadu_ps(base.add(8 * (at + $k)))
                    };
                }
                // Pairs of rays interleaved, then quadruples: fields f and f + 4 of four
                // rays in each vector's two halves, whose halves are then regrouped.
                let t0 = _mm256_unpacklo_ps(ray!(0), ray!(1));
                let t1 = _mm256_unpackhi_ps(ray!(0), ray!(1));
                let t2 = _mm256_unpacklo_ps(ray!(2), ray!(3));
                let t3 = _mm256_unpackhi_ps(ray!(2), ray!(3));
                let t4 = _mm256_unpacklo_ps(ray!(4), ray!(5));
                let t5 = _mm256_unpackhi_ps(ray!(4), ray!(5));
                let t6 = _mm256_unpacklo_ps(ray!(6), ray!(7));
                let t7 = _mm256_unpackhi_ps(ray!(6), ray!(7));
                let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
                let s1 = _mm256_shuffle_ps::<0xee>(t0, t2);
                let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
                let s3 = _mm256_shuffle_ps::<0xee>(t1, t3);
                let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
                let s5 = _mm256_shuffle_ps::<0xee>(t4, t6);
                let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
                let s7 = _mm256_shuffle_ps::<0xee>(t5, t7);
                let fields = [
                    _mm256_permute2f128_ps::<0x20>(s0, s4),
                    _mm256_permute2f128_ps::<0x20>(s1, s5),
                    _mm256_permute2f128_ps::<0x20>(s2, s6),
                    _mm256_permute2f128_ps::<0x20>(s3, s7),
                    _mm256_permute2f128_ps::<0x31>(s0, s4),
                    _mm256_permute2f128_ps::<0x31>(s1, s5),
                    _mm256_permute2f128_ps::<0x31>(s2, s6),
                    _mm256_permute2f128_ps::<0x31>(s3, s7),
                ];
                for (row, f) in rows.iter_mut().zip(fields) {
                    _mm256_storeu_ps(row[at..].as_mut_ptr(), f);
                }
            }
            transpose_from(rays, whole, rows);
        }};
    }

    impl RayLoad for Avx2 {
        #[inline(always)]
        unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]) {
            // SAFETY: the caller guarantees AVX2. `Ray` is eight f32 (`repr(C)`, asserted
            // above): blocks of eight rays below a multiple of 8 ≤ the slice's length stay
            // inside it, and each store writes lanes at..at + 8 ≤ `PACKET_RAYS` of a row.
            unsafe { transpose_m256!(rays, rows) }
        }

        #[inline(always)]
        unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
            let mut m = 0;
            for at in (0..PACKET_RAYS).step_by(8) {
                // SAFETY: the caller guarantees AVX2; lanes at..at + 8 of the row.
                let bits = unsafe { _mm256_movemask_ps(_mm256_loadu_ps(row[at..].as_ptr())) };
                m |= (bits as u64) << at;
            }
            m
        }
    }

    impl RayLoad for Avx512 {
        #[inline(always)]
        unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]) {
            // SAFETY: AVX-512 F implies AVX2; otherwise as for AVX2.
            unsafe { transpose_m256!(rays, rows) }
        }

        #[inline(always)]
        unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
            let mut m = 0;
            for at in (0..PACKET_RAYS).step_by(16) {
                // SAFETY: the caller guarantees AVX-512 F; lanes at..at + 16 of the row.
                let bits = unsafe {
                    let x = _mm512_castps_si512(_mm512_loadu_ps(row[at..].as_ptr()));
                    _mm512_cmplt_epi32_mask(x, _mm512_setzero_si512())
                };
                m |= u64::from(bits) << at;
            }
            m
        }
    }
}

/// Elsewhere the x86 kernels are never selected (`SimdLevel::supported`); they run the
/// portable code so that code generic over them compiles.
#[cfg(not(target_arch = "x86_64"))]
mod elsewhere {
    use super::*;

    macro_rules! portable_as {
        ($kernel:ty) => {
            impl RayLoad for $kernel {
                #[inline(always)]
                unsafe fn transpose(rays: &[Ray], rows: &mut [[f32; PACKET_RAYS]; 8]) {
                    transpose_from(rays, 0, rows);
                }

                #[inline(always)]
                unsafe fn signs(row: &[f32; PACKET_RAYS]) -> u64 {
                    signs(row)
                }
            }
        };
    }
    portable_as!(Sse41);
    portable_as!(Avx2);
    portable_as!(Avx512);
}

/// Asks for the cache lines of the packet of rays at `rays` (which may lie past the slice:
/// a prefetch never faults). Traced while the packet before it is, so that the packet's
/// first loads do not wait on its 32 lines at once.
#[inline(always)]
pub fn prefetch_packet(rays: *const Ray) {
    let bytes = rays.cast::<u8>();
    for line in (0..PACKET_RAYS * size_of::<Ray>()).step_by(64) {
        super::prefetch(bytes.wrapping_add(line));
    }
}
