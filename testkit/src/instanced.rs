//! Comparing an instanced scene's hits with its flattened scene's: the same triangle, t
//! within the rounding of the transforms, or a ray grazing an edge within that rounding.

use bvhlab::accel::Hit;
use bvhlab::geometry::{Ray, Triangle};
use glam::Vec3;

/// The rounding both sides commit, relative to the distances involved: the flattened
/// scene rounds the vertices (M·v), the two-level structure rounds the ray (M⁻¹·o, M⁻¹·d),
/// each by a few ulps of the coordinates' magnitude times the transform's condition number
/// (at most about 6 in these tests: scales up to 4:1, and a shear). 64 ε is a wide margin: the
/// largest error these scenes show is about 1 ε.
const ROUNDING: f32 = 64.0 * f32::EPSILON;

/// The distance scale of a hit at `t` in ray units: the origin's and the scene's extent
/// over the direction's length, plus t.
fn distance_scale(ray: &Ray, extent: f32, t: f32) -> f32 {
    (ray.origin.length() + extent) / ray.direction.length() + t
}

/// The bound on |t − t_flat| for a hit on `tri`: `ROUNDING` of the distance scale, over
/// the cosine of the angle between ray and normal (t of a grazing ray moves far when the
/// plane moves a little).
fn t_bound(ray: &Ray, extent: f32, t: f32, tri: &Triangle) -> f32 {
    let cos = tri
        .normal()
        .normalize_or_zero()
        .dot(ray.direction.normalize())
        .abs();
    ROUNDING * distance_scale(ray, extent, t) / cos.max(f32::MIN_POSITIVE)
}

/// How far (in f64) the ray passes from the boundary of `tri`, where it crosses its plane:
/// 0 for a ray in the plane. Where this is within rounding, f32 tests in world and in
/// object space may fairly disagree on whether the ray hits.
fn edge_distance(tri: &Triangle, ray: &Ray) -> f64 {
    let d = |v: Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    let [a, b, c] = tri.v.map(d);
    let (o, dir) = (d(ray.origin), d(ray.direction));
    let n = (b - a).cross(c - a);
    let denom = n.dot(dir);
    if denom.abs() <= 1e-12 * n.length() * dir.length() {
        return 0.0;
    }
    let p = o + dir * (n.dot(a - o) / denom);
    let segment = |s: glam::DVec3, e: glam::DVec3| {
        let k =
            ((p - s).dot(e - s) / (e - s).length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        (s + (e - s) * k - p).length()
    };
    segment(a, b).min(segment(b, c)).min(segment(c, a))
}

/// Checks a two-level hit against the flattened scene's; returns whether they disagree
/// only by a ray grazing a triangle's edge within rounding (counted by the caller).
pub fn compare(
    label: &str,
    triangles: &[Triangle],
    extent: f32,
    ray: &Ray,
    got: Option<Hit>,
    want: Option<Hit>,
) -> bool {
    if let (Some(g), Some(w)) = (got, want)
        && g.triangle == w.triangle
    {
        let bound = t_bound(ray, extent, w.t, &triangles[w.triangle as usize]);
        assert!(
            (g.t - w.t).abs() <= bound,
            "{label}: {ray:?}: t {} vs {} (bound {bound})",
            g.t,
            w.t
        );
        return false;
    }
    if got.is_none() && want.is_none() {
        return false;
    }
    // Different answers: fair only where one of the triangles involved is grazed.
    let grazed = [got, want].into_iter().flatten().any(|h| {
        let near = ROUNDING * distance_scale(ray, extent, h.t) * ray.direction.length();
        edge_distance(&triangles[h.triangle as usize], ray) <= near as f64
    });
    assert!(
        grazed,
        "{label}: {ray:?}: two-level {got:?}, flattened {want:?}"
    );
    true
}
