//! The convex hull's vertices of a point set: the fewest points whose box, under any affine
//! map, is the box of the whole set mapped. A rotated instance's tightest world box is its
//! mesh's hull vertices placed one by one, where the box of its BLAS's boxes placed takes in
//! the corners those boxes swing out (`two_level::rebraid`).
//!
//! Built in f64 by quickhull (Barber, Dobkin and Huhdanpaa 1996): a tetrahedron of extreme
//! points, each point outside it kept in the outside set of one face that sees it; then,
//! face by face, the farthest point of an outside set joined to the surface (the faces it
//! sees replaced by faces from their border to it) and the replaced faces' points shared
//! out among the new faces. A hull that rounding might have made wrong (a face of no area,
//! a surface that does not close, a point left outside it) is refused (`None`), and the
//! caller keeps its coarser box.

use crate::geometry::Aabb;
use glam::{Affine3A, DVec3, Vec3};
use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// The hull's sets and maps of integer keys (point bits, vertex numbers, edges) hash a word
/// with a multiply, not SipHash: no one chooses these keys to collide, and a mesh's 360 000
/// corners are hashed at every build.
type Map<K, V> = HashMap<K, V, BuildHasherDefault<WordHasher>>;
type Set<K> = HashSet<K, BuildHasherDefault<WordHasher>>;

#[derive(Default)]
struct WordHasher(u64);

impl WordHasher {
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

impl Hasher for WordHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(word));
        }
    }

    fn write_u32(&mut self, n: u32) {
        self.add(u64::from(n));
    }

    fn write_u64(&mut self, n: u64) {
        self.add(n);
    }

    fn write_usize(&mut self, n: usize) {
        self.add(n as u64);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// A face: its corners counter-clockwise seen from outside, and its outward unit normal
/// with the plane's offset.
#[derive(Clone)]
struct Face {
    v: [u32; 3],
    normal: DVec3,
    offset: f64,
    alive: bool,
    /// Points this face sees, not yet joined.
    outside: Vec<u32>,
}

struct Builder {
    points: Vec<DVec3>,
    faces: Vec<Face>,
    /// Each directed edge of the surface, and the face that has it counter-clockwise: the
    /// face across an edge (a, b) is the one with (b, a).
    edges: Map<(u32, u32), usize>,
    /// The point whose visible faces were last sought, for each face tested for it, and
    /// whether the face sees it.
    tested: Vec<(u32, bool)>,
    /// A point is outside a face when its distance beyond the plane exceeds this.
    tolerance: f64,
}

/// The vertices of the convex hull of `points`, or `None` where the points do not span a
/// solid (fewer than four, or all on one plane) or rounding made the hull doubtful. Every
/// point lies inside the returned points' hull, up to `tolerance(points)` beyond a face.
pub fn hull_vertices(points: &[Vec3]) -> Option<Vec<Vec3>> {
    let mut b = Builder::new(points)?;
    b.tetrahedron()?;
    let all: Vec<u32> = (0..b.points.len() as u32).collect();
    let first = b.faces.len();
    b.share_out(&all, 0..first);
    let mut pending: Vec<usize> = (0..first).collect();
    while let Some(f) = pending.pop() {
        let face = &b.faces[f];
        if !face.alive || face.outside.is_empty() {
            continue;
        }
        let far = |&p: &u32| b.beyond(face, p);
        let p = *face
            .outside
            .iter()
            .max_by(|x, y| far(x).total_cmp(&far(y)))?;
        let new = b.insert(p, f)?;
        pending.extend(new);
    }
    b.faces.retain(|f| f.alive);
    b.is_closed().then_some(())?;
    b.all_inside().then_some(())?;
    let used: Set<u32> = b.faces.iter().flat_map(|f| f.v).collect();
    let mut vertices: Vec<u32> = used.into_iter().collect();
    vertices.sort_unstable();
    Some(
        vertices
            .iter()
            .map(|&v| b.points[v as usize].as_vec3())
            .collect(),
    )
}

/// How far beyond its hull's faces `hull_vertices` may leave a point of `points`: a
/// ten-billionth of the points' extent, far below f32's rounding of them.
pub fn tolerance(points: &[Vec3]) -> f32 {
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    (1e-10
        * f64::from(
            (hi - lo)
                .max_element()
                .max(lo.abs().max(hi.abs()).max_element()),
        )) as f32
}

impl Builder {
    fn new(points: &[Vec3]) -> Option<Builder> {
        if points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        // Over the points as given: dropping repeats changes no extent.
        let tolerance = f64::from(tolerance(points));
        let mut seen = Set::default();
        let points: Vec<DVec3> = points
            .iter()
            .filter(|p| seen.insert(p.to_array().map(f32::to_bits)))
            .map(|p| p.as_dvec3())
            .collect();
        (points.len() >= 4).then(|| Builder {
            tolerance,
            points,
            faces: Vec::new(),
            edges: Map::default(),
            tested: Vec::new(),
        })
    }

    fn beyond(&self, f: &Face, p: u32) -> f64 {
        f.normal.dot(self.points[p as usize]) - f.offset
    }

    /// The point of greatest `key`.
    fn farthest(&self, key: impl Fn(DVec3) -> f64) -> u32 {
        (0..self.points.len())
            .max_by(|&a, &b| key(self.points[a]).total_cmp(&key(self.points[b])))
            .unwrap_or(0) as u32
    }

    /// The first four faces, from the lowest point in x, the point farthest from it, the
    /// farthest from their line and the farthest from their plane.
    fn tetrahedron(&mut self) -> Option<()> {
        let a = self.farthest(|p| -p.x);
        let pa = self.points[a as usize];
        let b = self.farthest(|p| (p - pa).length_squared());
        let pb = self.points[b as usize];
        let line = (pb - pa).normalize_or_zero();
        let c = self.farthest(|p| (p - pa).cross(line).length_squared());
        let pc = self.points[c as usize];
        let normal = (pb - pa).cross(pc - pa).normalize_or_zero();
        let d = self.farthest(|p| (p - pa).dot(normal).abs());
        if (self.points[d as usize] - pa).dot(normal).abs() <= 16.0 * self.tolerance {
            return None;
        }
        // Oriented so that d lies below the face (a, b, c).
        let (b, c) = match (self.points[d as usize] - pa).dot(normal) > 0.0 {
            true => (c, b),
            false => (b, c),
        };
        for v in [[a, b, c], [a, d, b], [b, d, c], [c, d, a]] {
            self.add_face(v)?;
        }
        Some(())
    }

    fn add_face(&mut self, v: [u32; 3]) -> Option<()> {
        let [a_, b_, c_] = v;
        let [a, b, c] = v.map(|i| self.points[i as usize]);
        let n = (b - a).cross(c - a);
        let length = n.length();
        // A face of no area has no direction to be outside of.
        if length <= self.tolerance * (b - a).length().max((c - a).length()) {
            return None;
        }
        let normal = n / length;
        let f = self.faces.len();
        for e in [(a_, b_), (b_, c_), (c_, a_)] {
            // An edge already on the surface: rounding made the horizon no simple loop.
            if self.edges.insert(e, f).is_some() {
                return None;
            }
        }
        self.tested.push((u32::MAX, false));
        self.faces.push(Face {
            v,
            normal,
            offset: normal.dot(a),
            alive: true,
            outside: Vec::new(),
        });
        Some(())
    }

    /// Each of `points` into the outside set of the first of `faces` that sees it; a point
    /// none sees is inside them for good.
    fn share_out(&mut self, points: &[u32], faces: std::ops::Range<usize>) {
        for &p in points {
            if let Some(f) = faces
                .clone()
                .find(|&f| self.beyond(&self.faces[f], p) > self.tolerance)
            {
                self.faces[f].outside.push(p);
            }
        }
    }

    /// Joins point `p`, which face `from` sees, to the surface: the faces it sees go (found
    /// from `from` across edges, as the faces a point sees on a convex surface meet), the
    /// edges around them (each seen face's edge whose face across is not seen) are joined
    /// to `p`, and the seen faces' points are shared out among the new faces. Returns the
    /// new faces.
    fn insert(&mut self, p: u32, from: usize) -> Option<std::ops::Range<usize>> {
        let mut seen = vec![from];
        self.tested[from] = (p, true);
        let mut horizon = Vec::new();
        let mut next = 0;
        while let Some(&f) = seen.get(next) {
            next += 1;
            let [a, b, c] = self.faces[f].v;
            for (a, b) in [(a, b), (b, c), (c, a)] {
                let g = *self.edges.get(&(b, a))?;
                if self.tested[g].0 != p {
                    let sees = self.beyond(&self.faces[g], p) > self.tolerance;
                    self.tested[g] = (p, sees);
                    if sees {
                        seen.push(g);
                    }
                }
                if !self.tested[g].1 {
                    horizon.push((a, b));
                }
            }
        }
        let mut orphans = Vec::new();
        for &f in &seen {
            self.faces[f].alive = false;
            let [a, b, c] = self.faces[f].v;
            for e in [(a, b), (b, c), (c, a)] {
                self.edges.remove(&e);
            }
            orphans.extend(std::mem::take(&mut self.faces[f].outside));
        }
        orphans.retain(|&q| q != p);
        horizon.sort_unstable();
        let first = self.faces.len();
        for (a, b) in horizon {
            self.add_face([a, b, p])?;
        }
        let new = first..self.faces.len();
        self.share_out(&orphans, new.clone());
        Some(new)
    }

    /// Whether every point lies within the tolerance inside every face: the check that
    /// rounding did not leave one out. Points nearer the hull's centre than its nearest face
    /// are inside them all; the others are screened in f32 over whole vectors of planes
    /// (`screen`), and only those the screen cannot place inside by a clear margin are
    /// checked again in f64: the hull's own vertices and points on its faces.
    fn all_inside(&self) -> bool {
        let used: Set<u32> = self.faces.iter().flat_map(|f| f.v).collect();
        let centre =
            used.iter().map(|&v| self.points[v as usize]).sum::<DVec3>() / used.len() as f64;
        let inner = (self.faces.iter())
            .map(|f| f.offset - f.normal.dot(centre))
            .fold(f64::INFINITY, f64::min)
            - self.tolerance;
        let inner = inner.max(0.0).powi(2);
        // The points came from f32, so `as_vec3` gives them back exactly.
        let outer: Vec<Vec3> = (self.points.iter())
            .filter(|p| p.distance_squared(centre) >= inner)
            .map(|p| p.as_vec3())
            .collect();
        let planes: Vec<[f64; 4]> = (self.faces.iter())
            .map(|f| {
                [
                    f.normal.x,
                    f.normal.y,
                    f.normal.z,
                    f.offset + self.tolerance,
                ]
            })
            .collect();
        // Each plane's offset is at most a point's |x| + |y| + |z| (its normal is a unit
        // vector through a corner), so the f32 test's error is below 12 units of f32
        // rounding of `reach` (normal and offset rounded, four operations): 2^-18 is 5×
        // that.
        let reach = (self.points.iter())
            .map(|p| p.abs().element_sum())
            .fold(self.tolerance, f64::max);
        let margin = (reach * f64::powi(2.0, -18)) as f32;
        screen(&planes, &outer, margin)
    }

    /// Whether every edge of the surface has the face across it: each directed edge once,
    /// and its reverse once.
    fn is_closed(&self) -> bool {
        let mut edges = Set::default();
        for f in &self.faces {
            let [a, b, c] = f.v;
            for e in [(a, b), (b, c), (c, a)] {
                if !edges.insert(e) {
                    return false;
                }
            }
        }
        edges.iter().all(|&(a, b)| edges.contains(&(b, a)))
    }
}

/// Whether every point of `points` lies on the inner side of every plane (normal,
/// offset), as the f64 test `d = n · p − offset ≤ 0` finds, with the widest vectors the CPU
/// has: each point against all planes in f32, and in f64 only against the planes that the
/// f32 test cannot place it inside of by more than `margin` (its rounding is below that).
/// Most points are far inside every plane; those on a face, as the island's grass has
/// half its points on the ground, are near one or two.
fn screen(planes: &[[f64; 4]], points: &[Vec3], margin: f32) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512 F (checked just before).
            return unsafe { screen_avx512(planes, points, margin) };
        }
        if is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just before).
            return unsafe { screen_avx2(planes, points, margin) };
        }
    }
    screen_portable(planes, points, margin)
}

/// Planes in chunks of `L` as f32 columns (normal x, y, z, offset), padded with a plane
/// every point is far inside.
#[repr(C, align(64))]
struct PlaneChunk<const L: usize>([[f32; L]; 4]);

fn plane_chunks<const L: usize>(planes: &[[f64; 4]]) -> Vec<PlaneChunk<L>> {
    let mut chunks = Vec::new();
    for c in planes.chunks(L) {
        let mut rows = [[0.0; L], [0.0; L], [0.0; L], [f32::MAX; L]];
        for (k, plane) in c.iter().enumerate() {
            for (row, &v) in rows.iter_mut().zip(plane) {
                row[k] = v as f32;
            }
        }
        chunks.push(PlaneChunk(rows));
    }
    chunks
}

/// The f64 test of `q` against the planes `first + k` for each bit k of `near`.
#[inline(always)]
fn inside_near(planes: &[[f64; 4]], first: usize, mut near: u32, q: DVec3) -> bool {
    while near != 0 {
        let [x, y, z, o] = planes[first + near.trailing_zeros() as usize];
        if x * q.x + y * q.y + z * q.z - o > 0.0 {
            return false;
        }
        near &= near - 1;
    }
    true
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn screen_avx512(planes: &[[f64; 4]], points: &[Vec3], margin: f32) -> bool {
    use std::arch::x86_64::*;
    let chunks = plane_chunks::<16>(planes);
    let limit = _mm512_set1_ps(-margin);
    for p in points {
        let (x, y, z) = (
            _mm512_set1_ps(p.x),
            _mm512_set1_ps(p.y),
            _mm512_set1_ps(p.z),
        );
        for (c, PlaneChunk([nx, ny, nz, o])) in chunks.iter().enumerate() {
            // SAFETY: each row is 16 f32, 64-byte aligned (`PlaneChunk`).
            let d = unsafe {
                let d = _mm512_mul_ps(_mm512_load_ps(nx.as_ptr()), x);
                let d = _mm512_add_ps(d, _mm512_mul_ps(_mm512_load_ps(ny.as_ptr()), y));
                let d = _mm512_add_ps(d, _mm512_mul_ps(_mm512_load_ps(nz.as_ptr()), z));
                _mm512_sub_ps(d, _mm512_load_ps(o.as_ptr()))
            };
            let near = u32::from(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(d, limit));
            if near != 0 && !inside_near(planes, c * 16, near, p.as_dvec3()) {
                return false;
            }
        }
    }
    true
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn screen_avx2(planes: &[[f64; 4]], points: &[Vec3], margin: f32) -> bool {
    use std::arch::x86_64::*;
    let chunks = plane_chunks::<8>(planes);
    let limit = _mm256_set1_ps(-margin);
    for p in points {
        let (x, y, z) = (
            _mm256_set1_ps(p.x),
            _mm256_set1_ps(p.y),
            _mm256_set1_ps(p.z),
        );
        for (c, PlaneChunk([nx, ny, nz, o])) in chunks.iter().enumerate() {
            // SAFETY: each row is 8 f32, 64-byte aligned (`PlaneChunk`).
            let d = unsafe {
                let d = _mm256_mul_ps(_mm256_load_ps(nx.as_ptr()), x);
                let d = _mm256_add_ps(d, _mm256_mul_ps(_mm256_load_ps(ny.as_ptr()), y));
                let d = _mm256_add_ps(d, _mm256_mul_ps(_mm256_load_ps(nz.as_ptr()), z));
                _mm256_sub_ps(d, _mm256_load_ps(o.as_ptr()))
            };
            let near = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(d, limit)) as u32;
            if near != 0 && !inside_near(planes, c * 8, near, p.as_dvec3()) {
                return false;
            }
        }
    }
    true
}

/// `screen` plane by plane, in the same f32 arithmetic as the vector versions.
fn screen_portable(planes: &[[f64; 4]], points: &[Vec3], margin: f32) -> bool {
    let chunks = plane_chunks::<1>(planes);
    points.iter().all(|p| {
        (chunks.iter().enumerate()).all(|(c, PlaneChunk([[x], [y], [z], [o]]))| {
            let d = x * p.x + y * p.y + z * p.z - o;
            d <= -margin || inside_near(planes, c, 1, p.as_dvec3())
        })
    })
}

/// A hull's vertices as three columns, padded with copies of the first to whole vectors:
/// placed once for each of an instanced mesh's rotated instances (the island's trees have
/// 266–655 hull vertices and 50 000 instances each), so placed over whole vectors.
#[derive(Clone, Debug)]
pub struct HullColumns {
    columns: [Vec<f32>; 3],
}

/// The widest vector `HullColumns::placed_box` uses, in f32 lanes.
const PLACE_LANES: usize = 16;

impl HullColumns {
    pub fn new(vertices: &[Vec3]) -> HullColumns {
        let n = vertices.len().div_ceil(PLACE_LANES) * PLACE_LANES;
        let column = |k: usize| -> Vec<f32> {
            (0..n)
                .map(|i| vertices.get(i).or(vertices.first()).map_or(0.0, |v| v[k]))
                .collect()
        };
        HullColumns {
            columns: [column(0), column(1), column(2)],
        }
    }

    /// The box of the vertices mapped by `m`, each mapped as `Affine3A::transform_point3`
    /// maps it, bit for bit (empty without vertices).
    pub fn placed_box(&self, m: &Affine3A) -> Aabb {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512 F (checked just before).
                return unsafe { self.placed_avx512(m) };
            }
            if is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just before).
                return unsafe { self.placed_avx2(m) };
            }
        }
        self.placed_lanes::<4>(m)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn placed_avx512(&self, m: &Affine3A) -> Aabb {
        use std::arch::x86_64::*;
        let [xs, ys, zs] = &self.columns;
        if xs.is_empty() {
            return Aabb::EMPTY;
        }
        let a = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let row = |j: usize| a.map(|axis| _mm512_set1_ps(axis[j]));
        let rows = [row(0), row(1), row(2)];
        // The accumulators in registers: written as arrays, they lived on the stack.
        let mut lo = [_mm512_set1_ps(f32::INFINITY); 3];
        let mut hi = [_mm512_set1_ps(f32::NEG_INFINITY); 3];
        for i in (0..xs.len()).step_by(16) {
            // SAFETY: the columns' lengths are equal multiples of 16 (`new`), so the 16
            // floats from i are in bounds.
            let (x, y, z) = unsafe {
                (
                    _mm512_loadu_ps(xs.as_ptr().add(i)),
                    _mm512_loadu_ps(ys.as_ptr().add(i)),
                    _mm512_loadu_ps(zs.as_ptr().add(i)),
                )
            };
            for j in 0..3 {
                let [r0, r1, r2] = rows[j];
                let v = _mm512_add_ps(_mm512_mul_ps(r0, x), _mm512_mul_ps(r1, y));
                let v = _mm512_add_ps(v, _mm512_mul_ps(r2, z));
                lo[j] = _mm512_min_ps(lo[j], v);
                hi[j] = _mm512_max_ps(hi[j], v);
            }
        }
        let low = Vec3::from(lo.map(|l| _mm512_reduce_min_ps(l)));
        let high = Vec3::from(hi.map(|h| _mm512_reduce_max_ps(h)));
        let t = Vec3::from(m.translation);
        Aabb::new(low + t, high + t)
    }

    /// `placed_avx512` eight vertices at a time.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn placed_avx2(&self, m: &Affine3A) -> Aabb {
        use std::arch::x86_64::*;
        let [xs, ys, zs] = &self.columns;
        if xs.is_empty() {
            return Aabb::EMPTY;
        }
        let a = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let row = |j: usize| a.map(|axis| _mm256_set1_ps(axis[j]));
        let rows = [row(0), row(1), row(2)];
        let mut lo = [_mm256_set1_ps(f32::INFINITY); 3];
        let mut hi = [_mm256_set1_ps(f32::NEG_INFINITY); 3];
        for i in (0..xs.len()).step_by(8) {
            // SAFETY: the columns' lengths are equal multiples of 16 (`new`), so the 8
            // floats from i are in bounds.
            let (x, y, z) = unsafe {
                (
                    _mm256_loadu_ps(xs.as_ptr().add(i)),
                    _mm256_loadu_ps(ys.as_ptr().add(i)),
                    _mm256_loadu_ps(zs.as_ptr().add(i)),
                )
            };
            for j in 0..3 {
                let [r0, r1, r2] = rows[j];
                let v = _mm256_add_ps(_mm256_mul_ps(r0, x), _mm256_mul_ps(r1, y));
                let v = _mm256_add_ps(v, _mm256_mul_ps(r2, z));
                lo[j] = _mm256_min_ps(lo[j], v);
                hi[j] = _mm256_max_ps(hi[j], v);
            }
        }
        let (mut low, mut high) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for j in 0..3 {
            let (mut l, mut h) = ([0f32; 8], [0f32; 8]);
            // SAFETY: each array takes the 8 floats stored.
            unsafe {
                _mm256_storeu_ps(l.as_mut_ptr(), lo[j]);
                _mm256_storeu_ps(h.as_mut_ptr(), hi[j]);
            }
            for k in 0..8 {
                low[j] = low[j].min(l[k]);
                high[j] = high[j].max(h[k]);
            }
        }
        let t = Vec3::from(m.translation);
        Aabb::new(low + t, high + t)
    }

    /// `placed_box` over `L` vertices at a time. Each coordinate sums the three axes'
    /// terms in `transform_point3`'s order; the shift is added to the lowest and highest
    /// sums only, which is the same, as rounding keeps order.
    #[inline(always)]
    pub(crate) fn placed_lanes<const L: usize>(&self, m: &Affine3A) -> Aabb {
        const { assert!(PLACE_LANES.is_multiple_of(L)) };
        let [xs, ys, zs] = &self.columns;
        let a = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let mut lo = [[f32::INFINITY; L]; 3];
        let mut hi = [[f32::NEG_INFINITY; L]; 3];
        let points = xs
            .chunks_exact(L)
            .zip(ys.chunks_exact(L))
            .zip(zs.chunks_exact(L));
        for ((x, y), z) in points {
            for j in 0..3 {
                for k in 0..L {
                    let v = a[0][j] * x[k] + a[1][j] * y[k] + a[2][j] * z[k];
                    lo[j][k] = if v < lo[j][k] { v } else { lo[j][k] };
                    hi[j][k] = if v > hi[j][k] { v } else { hi[j][k] };
                }
            }
        }
        if xs.is_empty() {
            return Aabb::EMPTY;
        }
        let (mut low, mut high) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for j in 0..3 {
            for k in 0..L {
                low[j] = low[j].min(lo[j][k]);
                high[j] = high[j].max(hi[j][k]);
            }
        }
        let t = Vec3::from(m.translation);
        Aabb::new(low + t, high + t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Rng;
    use glam::{Mat3, Quat};

    fn cloud(rng: &mut Rng, n: usize) -> Vec<Vec3> {
        (0..n).map(|_| random_vec(rng) * 2.0 - 1.0).collect()
    }

    fn random_vec(rng: &mut Rng) -> Vec3 {
        Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32)
    }

    /// The largest of each coordinate over `points` mapped by `m`, in f64.
    fn top(points: &[Vec3], m: Mat3) -> [f64; 3] {
        let m = m.as_dmat3();
        [0, 1, 2].map(|i| {
            points
                .iter()
                .map(|p| (m * p.as_dvec3())[i])
                .fold(f64::NEG_INFINITY, f64::max)
        })
    }

    #[test]
    fn a_cube_with_points_inside_has_its_eight_corners() {
        let mut rng = Rng(7);
        let mut points: Vec<Vec3> = cloud(&mut rng, 500).iter().map(|p| *p * 0.9).collect();
        for c in 0..8 {
            let corner = |bit: usize| if c >> bit & 1 == 1 { 1.0 } else { -1.0 };
            points.push(Vec3::new(corner(0), corner(1), corner(2)));
        }
        let hull = hull_vertices(&points).unwrap();
        assert_eq!(hull.len(), 8);
        assert!(hull.iter().all(|p| p.abs() == Vec3::ONE));
    }

    /// Under any rotation, the hull's vertices reach exactly as far as all the points, in
    /// every axis both ways: the property the world boxes rest on.
    #[test]
    fn the_hull_reaches_as_far_as_the_points_under_any_rotation() {
        let mut rng = Rng(11);
        for case in 0..20 {
            let mut points = cloud(&mut rng, 2000);
            if case % 2 == 1 {
                // A stretched cloud with points on a sphere's surface: many hull vertices.
                points.extend(cloud(&mut rng, 300).iter().map(|p| p.normalize() * 3.0));
                points.iter_mut().for_each(|p| p.y *= 5.0);
            }
            let hull = hull_vertices(&points).unwrap();
            assert!(hull.len() < points.len());
            for _ in 0..20 {
                let axis = (random_vec(&mut rng) - 0.5).normalize();
                let m = Mat3::from_quat(Quat::from_axis_angle(axis, rng.unit() as f32 * 6.3));
                for m in [m, -m] {
                    assert_eq!(top(&hull, m), top(&points, m), "case {case}");
                }
            }
        }
    }

    #[test]
    fn flat_or_too_few_points_have_no_hull() {
        let mut rng = Rng(3);
        let flat: Vec<Vec3> = cloud(&mut rng, 100)
            .iter()
            .map(|p| Vec3::new(p.x, p.y, 0.5))
            .collect();
        assert!(hull_vertices(&flat).is_none());
        assert!(hull_vertices(&flat[..3]).is_none());
        let line: Vec<Vec3> = (0..10).map(|i| Vec3::splat(i as f32)).collect();
        assert!(hull_vertices(&line).is_none());
        let mut bad = cloud(&mut rng, 10);
        bad[4].x = f32::NAN;
        assert!(hull_vertices(&bad).is_none());
    }

    /// The screen finds inside what the f64 test over all planes finds inside, whatever the
    /// lane width: points deep inside, on the faces, and a hair beyond them.
    #[test]
    fn the_f32_screen_finds_inside_what_the_f64_test_finds() {
        let mut rng = Rng(5);
        let points = cloud(&mut rng, 3000);
        let mut b = Builder::new(&points).unwrap();
        b.tetrahedron().unwrap();
        let planes: Vec<[f64; 4]> = (b.faces.iter())
            .map(|f| [f.normal.x, f.normal.y, f.normal.z, f.offset])
            .collect();
        let mut probes = cloud(&mut rng, 2000);
        // Points on the faces' planes, and nudged by a unit of rounding either way.
        for f in &b.faces {
            let [p, q, r] = f.v.map(|v| b.points[v as usize]);
            for _ in 0..50 {
                let (u, v) = (rng.unit(), rng.unit());
                let on = p + (q - p) * u * (1.0 - v) + (r - p) * v;
                for nudge in [-1e-7, 0.0, 1e-7] {
                    probes.push((on + f.normal * nudge).as_vec3());
                }
            }
        }
        let margin = (3.0 * f64::powi(2.0, -18)) as f32;
        let inside = |p: Vec3| {
            let q = p.as_dvec3();
            (planes.iter()).all(|[x, y, z, o]| x * q.x + y * q.y + z * q.z - o <= 0.0)
        };
        let outside = probes.iter().filter(|&&p| !inside(p)).count();
        assert!(outside > 100, "{outside} probes outside");
        for &p in &probes {
            assert_eq!(screen(&planes, &[p], margin), inside(p), "{p}");
            assert_eq!(screen_portable(&planes, &[p], margin), inside(p), "{p}");
            #[cfg(target_arch = "x86_64")]
            if is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just before).
                assert_eq!(
                    unsafe { screen_avx2(&planes, &[p], margin) },
                    inside(p),
                    "{p}"
                );
            }
        }
        assert!(!screen(&planes, &probes, margin));
    }

    /// A hull's columns place to the box of its vertices placed one by one, bit for bit, at
    /// every lane width.
    #[test]
    fn the_columns_place_as_the_vertices_do() {
        let mut rng = Rng(13);
        for n in [1, 5, 16, 17, 100] {
            let vertices: Vec<Vec3> = cloud(&mut rng, n).iter().map(|p| *p * 40.0).collect();
            let columns = HullColumns::new(&vertices);
            for _ in 0..20 {
                let axis = (random_vec(&mut rng) - 0.5).normalize();
                let m = Affine3A::from_scale_rotation_translation(
                    random_vec(&mut rng) * 3.0 + 0.1,
                    Quat::from_axis_angle(axis, rng.unit() as f32 * 6.3),
                    (random_vec(&mut rng) - 0.5) * 1000.0,
                );
                let each = Aabb::from_points(vertices.iter().map(|&p| m.transform_point3(p)));
                let mut placed = vec![
                    columns.placed_box(&m),
                    columns.placed_lanes::<4>(&m),
                    columns.placed_lanes::<8>(&m),
                    columns.placed_lanes::<16>(&m),
                ];
                #[cfg(target_arch = "x86_64")]
                if is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2 (checked just before).
                    placed.push(unsafe { columns.placed_avx2(&m) });
                }
                for placed in placed {
                    assert_eq!(
                        (placed.min, placed.max),
                        (each.min, each.max),
                        "{n} vertices"
                    );
                }
            }
        }
        assert!(
            HullColumns::new(&[])
                .placed_box(&Affine3A::IDENTITY)
                .is_empty()
        );
    }
}
