//! The view a scene opened from a file starts from. The standard framing view looks at the
//! scene's box from outside; for an interior (a courtyard, a cathedral, a conference room)
//! that shows only the outer hull — walls and roof — and none of what the lecture is about.
//! Such a scene starts from inside instead: an eye with free space around it, enclosed by
//! the scene, looking down the long axis of the box.

use crate::accel::bvh::{self, BuildParams};
use crate::accel::{Accel, NoStats};
use crate::geometry::{Aabb, Ray, Watertight};
use crate::scene::{Camera, Scene};
use glam::Vec3;

/// Above this many triangles the probe's BVH build is not worth the wait.
const MAX_TRIANGLES: usize = 5_000_000;
/// The framing view shows only the hull when at least this share of its hits lie on the
/// box's surface.
const HULL_SHARE: f32 = 0.3;
/// An eye is inside the scene when at least this share of the rays around it hit.
const ENCLOSED_SHARE: f32 = 0.9;

/// What the probes saw: for tests and for the choice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// Of the framing view's hits, the share within a hair of the box's surface.
    pub hull_share: f32,
    /// The best inside eye found, the share of the rays around it that hit, and the free
    /// distance ahead of it.
    pub inside: Option<(Camera, f32, f32)>,
}

/// An inside view for an interior whose outside view shows only its hull; `None` for any
/// other scene (it keeps the framing view).
pub fn interior_view(scene: &Scene) -> Option<Camera> {
    let probe = probe(scene)?;
    let (camera, enclosed, _) = probe.inside?;
    (probe.hull_share >= HULL_SHARE && enclosed >= ENCLOSED_SHARE).then_some(camera)
}

/// Traces the probes: the framing view's rays, and rays around candidate eyes inside.
pub fn probe(scene: &Scene) -> Option<Probe> {
    if scene.view.is_some() || !scene.is_flattened() || scene.triangles.len() > MAX_TRIANGLES {
        return None;
    }
    let bounds = scene.bounds();
    if bounds.is_empty() || scene.triangles.is_empty() {
        return None;
    }
    let (tree, _) = bvh::build(&scene.triangles, &BuildParams::default()).ok()?;
    let trace = |origin: Vec3, dir: Vec3| -> Option<(f32, u64)> {
        let h = tree.closest_hit::<Watertight, _>(&Ray::new(origin, dir), &mut NoStats)?;
        Some((h.t, h.triangle))
    };
    Some(Probe {
        hull_share: hull_share(&bounds, &trace),
        inside: best_inside_eye(scene, &bounds, &trace),
    })
}

/// Of the framing view's hits (a 32 × 18 grid of its rays), the share that lies within 1 %
/// of the box's diagonal of one of its faces.
fn hull_share(bounds: &Aabb, trace: &impl Fn(Vec3, Vec3) -> Option<(f32, u64)>) -> f32 {
    let rays = Camera::framing(bounds).rays(32, 18);
    let near = 0.01 * bounds.diagonal();
    let (mut hits, mut on_hull) = (0, 0);
    for y in 0..18 {
        for x in 0..32 {
            let r = rays.pixel_center(x, y);
            if let Some((t, _)) = trace(r.origin, r.direction) {
                hits += 1;
                let p = r.origin + r.direction * t;
                let to_face = (p - bounds.min).min(bounds.max - p).min_element();
                if to_face <= near {
                    on_hull += 1;
                }
            }
        }
    }
    if hits == 0 {
        0.0
    } else {
        on_hull as f32 / hits as f32
    }
}

/// Directions spread evenly over the sphere (a Fibonacci lattice).
fn sphere_directions(n: usize) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n).map(move |i| {
        let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let a = golden * i as f32;
        Vec3::new(r * a.cos(), y, r * a.sin())
    })
}

/// Candidate eyes along the box's long horizontal axis, low in the box (where people
/// stand), each looking down that axis the way with more free space. The best is the one
/// most enclosed, with the longest free view ahead; eyes close to a surface or facing the
/// backs of triangles (inside a solid column) are passed over.
fn best_inside_eye(
    scene: &Scene,
    bounds: &Aabb,
    trace: &impl Fn(Vec3, Vec3) -> Option<(f32, u64)>,
) -> Option<(Camera, f32, f32)> {
    let size = bounds.max - bounds.min;
    let diag = bounds.diagonal();
    // Y is up; the long axis is the longer of X and Z.
    let (long, across) = if size.x >= size.z {
        (Vec3::X, Vec3::Z)
    } else {
        (Vec3::Z, Vec3::X)
    };
    let mut best: Option<(Camera, f32, f32)> = None;
    for fa in [0.15, 0.25, 0.35, 0.5, 0.65, 0.75, 0.85] {
        for fc in [0.5, 0.35, 0.65] {
            for fy in [0.15, 0.25, 0.35] {
                let f = long * fa + across * fc + Vec3::Y * fy;
                let eye = bounds.min + size * f;
                let (mut hits, mut facing, mut clearance) = (0, 0, f32::INFINITY);
                let directions: Vec<Vec3> = sphere_directions(64).collect();
                for &d in &directions {
                    if let Some((t, tri)) = trace(eye, d) {
                        hits += 1;
                        clearance = clearance.min(t);
                        let n = scene.triangles[tri as usize].normal();
                        if n.dot(d) < 0.0 {
                            facing += 1;
                        }
                    }
                }
                let enclosed = hits as f32 / directions.len() as f32;
                if clearance < 0.01 * diag || facing * 2 < hits {
                    continue;
                }
                // Down the long axis, the way with more room.
                let free = |d: Vec3| trace(eye, d).map_or(diag, |(t, _)| t);
                let (dir, ahead) = [long, -long]
                    .into_iter()
                    .map(|d| (d, free(d)))
                    .fold((long, -1.0), |a, b| if b.1 > a.1 { b } else { a });
                let better = best.as_ref().is_none_or(|&(_, e, a)| {
                    (enclosed >= ENCLOSED_SHARE, ahead) > (e >= ENCLOSED_SHARE, a)
                });
                if better {
                    let camera = Camera::new(eye, eye + dir * (0.5 * ahead).max(0.01 * diag));
                    best = Some((camera, enclosed, ahead));
                }
            }
        }
    }
    best
}
