//! Ray replay: one pixel's primary ray (closest hit) or shadow ray (any hit) traced again
//! through the structure with a recording sink, so every step of its traversal can be
//! shown in order: the same traversal code, so the same counts and the same hit as the
//! frame's pixel.

use super::overlay::{BOX_EDGES, box_corners};
use super::{RayKind, RenderSettings, ray_of_kind};
use crate::accel::replay::{Level, Step, Visited, counters_of};
use crate::accel::visit_index::VisitIndex;
use crate::accel::{Accel, Counters, Recorder, Structure};
use crate::geometry::{Aabb, Intersector, Ray};
use crate::scene::Scene;
use glam::{Affine3A, Vec3};

/// A triangle hit as the replay reports it: the flattened scene's triangle number and t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayHit {
    pub triangle: u64,
    pub t: f32,
}

/// The recorded traversal of one ray.
#[derive(Clone, Debug)]
pub struct Replay {
    pub pixel: (u32, u32),
    pub rays: RayKind,
    pub ray: Ray,
    pub steps: Vec<Step>,
    /// What the recording sink counted (the same as a `Counters` sink would).
    pub counters: Counters,
    /// The closest hit (primary ray), or the first hit found (shadow ray).
    pub hit: Option<ReplayHit>,
    /// For each visit step, its box's eight corners in the world (a BLAS box carried out
    /// of its instance's object space); `None` for the other steps.
    pub corners: Vec<Option<[Vec3; 8]>>,
    /// The index of each visit step in `steps`.
    pub visits: Vec<usize>,
    /// For each visit step, the node of the structure's outline it is (what the hierarchy
    /// diagram draws), or `None` when the outline does not hold it (a BLAS's node).
    pub outline_nodes: Vec<Option<u32>>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ReplayError {
    #[error("pixel ({x}, {y}) is outside the {width}×{height} image")]
    OutsideImage {
        x: u32,
        y: u32,
        width: u32,
        height: u32,
    },
    #[error("pixel ({x}, {y}) hits nothing, so it has no shadow ray")]
    NoShadowRay { x: u32, y: u32 },
}

/// Replays pixel (x, y) of the frame `settings` describes: its primary ray, or with
/// `RayKind::Shadow` the shadow ray from its hit towards the light.
pub fn replay_pixel<I: Intersector>(
    structure: &Structure,
    scene: &Scene,
    settings: &RenderSettings,
    (x, y): (u32, u32),
    rays: RayKind,
) -> Result<Replay, ReplayError> {
    let (width, height) = (settings.width.max(1), settings.height.max(1));
    if x >= width || y >= height {
        return Err(ReplayError::OutsideImage {
            x,
            y,
            width,
            height,
        });
    }
    let primary = settings.camera.rays(width, height).pixel_center(x, y);
    let ray = ray_of_kind::<I>(structure, scene, &primary, rays, settings.light)
        .ok_or(ReplayError::NoShadowRay { x, y })?;
    Ok(replay_ray::<I>(structure, &ray, rays, (x, y)))
}

/// Replays `ray`: a closest-hit query for a primary ray, an any-hit query for a shadow ray.
pub fn replay_ray<I: Intersector>(
    structure: &Structure,
    ray: &Ray,
    rays: RayKind,
    pixel: (u32, u32),
) -> Replay {
    let mut recorder = Recorder::default();
    let occluded = match rays {
        RayKind::Primary => {
            structure.closest_hit::<I, _>(ray, &mut recorder);
            None
        }
        RayKind::Shadow => Some(structure.any_hit::<I, _>(ray, &mut recorder)),
    };
    let Recorder {
        counters,
        mut steps,
    } = recorder;
    let corners = place_visits(structure, ray, &mut steps);
    let visits: Vec<usize> = (0..steps.len()).filter(|&i| steps[i].is_visit()).collect();
    let index = VisitIndex::of(structure);
    let mut replay = Replay {
        pixel,
        rays,
        ray: *ray,
        outline_nodes: visits.iter().map(|&i| index.node(&steps[i])).collect(),
        visits,
        steps,
        counters,
        hit: None,
        corners,
    };
    replay.hit = match occluded {
        None => replay.best_after(replay.steps.len()),
        // The any-hit query stops at its first hit.
        Some(_) => replay.steps.iter().find_map(|s| match *s {
            Step::Triangle {
                triangle,
                t: Some(t),
            } => Some(ReplayHit { triangle, t }),
            _ => None,
        }),
    };
    replay
}

/// Fills in each visit's entry and exit distances, in the space its box is in, numbers a
/// BLAS's triangles as the scene does, and returns each visit's corners in the world.
fn place_visits(structure: &Structure, ray: &Ray, steps: &mut [Step]) -> Vec<Option<[Vec3; 8]>> {
    let mut instance: Option<Affine3A> = None;
    // A BLAS numbers its triangles from 0: the scene's number adds its instance's first.
    let mut first_triangle = 0u64;
    let mut out = Vec::with_capacity(steps.len());
    for step in steps.iter_mut() {
        if let Step::Instance { instance: i } = &*step {
            instance = structure.instance_transform(*i as usize);
            first_triangle = structure.instance_first_triangle(*i as usize).unwrap_or(0);
        }
        if let Step::Triangle { triangle, .. } = &mut *step
            && structure.places_instances()
        {
            *triangle += first_triangle;
        }
        let Step::Visit {
            bounds,
            level,
            entry,
            exit,
            ..
        } = step
        else {
            out.push(None);
            continue;
        };
        // A BLAS walks as a wide BVH of its own: its visits are the bottom level's.
        if *level == Level::Single && structure.places_instances() {
            *level = Level::Bottom;
        }
        let place = match level {
            Level::Bottom => instance.unwrap_or(Affine3A::IDENTITY),
            _ => Affine3A::IDENTITY,
        };
        let local = Ray {
            origin: place.inverse().transform_point3(ray.origin),
            direction: place.inverse().transform_vector3(ray.direction),
            ..*ray
        };
        (*entry, *exit) = interval(bounds, &local).unzip();
        out.push(Some(box_corners(bounds).map(|c| place.transform_point3(c))));
    }
    out
}

/// The ray's interval inside `b` within (tmin, tmax), if it passes through it.
fn interval(b: &Aabb, ray: &Ray) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (ray.tmin, ray.tmax);
    for k in 0..3 {
        let inv = 1.0 / ray.direction[k];
        let (a, c) = (
            (b.min[k] - ray.origin[k]) * inv,
            (b.max[k] - ray.origin[k]) * inv,
        );
        // A NaN (the ray lies in a face plane) leaves the interval as it is.
        let (near, far) = if a < c { (a, c) } else { (c, a) };
        if near > t0 {
            t0 = near;
        }
        if far < t1 {
            t1 = far;
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// How a line of the replay's picture is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ink {
    /// The box of the visit shown.
    Current,
    /// An interior node (or cell) visited before it.
    Visited,
    /// A leaf visited before it.
    VisitedLeaf,
    /// The ray.
    Ray,
}

impl Ink {
    /// RGBA, alpha = opacity.
    pub fn color(self) -> [u8; 4] {
        match self {
            Ink::Current => [255, 210, 60, 255],
            Ink::Visited => [150, 170, 255, 90],
            Ink::VisitedLeaf => [120, 220, 140, 110],
            Ink::Ray => [255, 90, 90, 255],
        }
    }
}

/// What the replay draws over the view at one stop, in world space: box edges and the ray
/// as segments, and the best hit so far.
#[derive(Clone, Debug, Default)]
pub struct Picture {
    pub segments: Vec<(Vec3, Vec3, Ink)>,
    pub best: Option<Vec3>,
}

/// Draws `picture` into `rgba` (`width` × `height`, 4 bytes a pixel) as `camera` sees it,
/// on top of everything (as the app draws it over the view).
pub fn draw_picture(
    picture: &Picture,
    rgba: &mut [u8],
    (width, height): (u32, u32),
    camera: &crate::scene::Camera,
) {
    let mut plot = |x: f32, y: f32, c: [u8; 4]| {
        if !(x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32) {
            return;
        }
        let i = 4 * (y as usize * width as usize + x as usize);
        if let Some(px) = rgba.get_mut(i..i + 4) {
            let a = u32::from(c[3]);
            for k in 0..3 {
                px[k] = ((u32::from(px[k]) * (255 - a) + u32::from(c[k]) * a) / 255) as u8;
            }
        }
    };
    for &(a, b, ink) in &picture.segments {
        // In pieces, so a part behind the eye drops out without the rest.
        const PIECES: usize = 8;
        for k in 0..PIECES {
            let p = a.lerp(b, k as f32 / PIECES as f32);
            let q = a.lerp(b, (k + 1) as f32 / PIECES as f32);
            let (Some(p), Some(q)) = (
                camera.project(p, width, height),
                camera.project(q, width, height),
            ) else {
                continue;
            };
            let n = (p.0 - q.0).abs().max((p.1 - q.1).abs());
            if !n.is_finite() {
                continue;
            }
            let n = (2.0 * n).ceil().clamp(1.0, 16384.0) as u32;
            for s in 0..=n {
                let f = s as f32 / n as f32;
                plot(p.0 + (q.0 - p.0) * f, p.1 + (q.1 - p.1) * f, ink.color());
            }
        }
    }
    if let Some(hit) = picture.best
        && let Some((x, y, _)) = camera.project(hit, width, height)
    {
        for dy in -3..=3 {
            for dx in -3..=3 {
                if dx * dx + dy * dy <= 9 {
                    plot(x + dx as f32, y + dy as f32, Ink::Ray.color());
                }
            }
        }
    }
}

impl Replay {
    /// The visit steps: one per node visited.
    pub fn visit_count(&self) -> usize {
        self.visits.len()
    }

    /// How many stops the replay has when stepped visit by visit (at least one: a ray
    /// that misses the outer box stops once, at that test).
    pub fn stops(&self) -> usize {
        self.visits.len().max(1)
    }

    /// The steps shown at stop `k`: visit k and what follows it up to the next visit (the
    /// tests, pushes and pops it led to); stop 0 also shows what came before the first visit.
    pub fn stop_range(&self, k: usize) -> std::ops::Range<usize> {
        let start = if k == 0 {
            0
        } else {
            self.visits.get(k).copied().unwrap_or(self.steps.len())
        };
        let end = self.visits.get(k + 1).copied().unwrap_or(self.steps.len());
        start..end.max(start)
    }

    /// The visit step of stop `k`, if there is one.
    pub fn visit_at(&self, k: usize) -> Option<(&Step, &[Vec3; 8])> {
        let i = *self.visits.get(k)?;
        Some((&self.steps[i], self.corners[i].as_ref()?))
    }

    /// The best hit among the triangle tests in `steps[..end]` (the rule every structure
    /// keeps: nearer wins, and of equal t the lower triangle number).
    pub fn best_after(&self, end: usize) -> Option<ReplayHit> {
        let mut best: Option<ReplayHit> = None;
        for s in &self.steps[..end.min(self.steps.len())] {
            if let Step::Triangle {
                triangle,
                t: Some(t),
            } = *s
                && best.is_none_or(|b| t < b.t || (t == b.t && triangle < b.triangle))
            {
                best = Some(ReplayHit { triangle, t });
            }
            if self.rays == RayKind::Shadow && best.is_some() {
                break;
            }
        }
        best
    }

    /// The picture at stop `stop`: the boxes visited up to it (its own highlighted), and
    /// the ray from its start to the best hit so far, or `length` along it without one.
    pub fn picture(&self, stop: usize, length: f32) -> Picture {
        let mut segments = Vec::new();
        let stop = stop.min(self.stops() - 1);
        for k in 0..=stop {
            let Some((step, corners)) = self.visit_at(k) else {
                continue;
            };
            let ink = match step {
                _ if k == stop => Ink::Current,
                Step::Visit {
                    what: Visited::Leaf,
                    ..
                } => Ink::VisitedLeaf,
                _ => Ink::Visited,
            };
            segments.extend(
                BOX_EDGES
                    .iter()
                    .map(|&(i, j)| (corners[i], corners[j], ink)),
            );
        }
        let r = &self.ray;
        let best = self.best_after(self.stop_range(stop).end);
        let end = best.map_or(r.tmax.min(r.tmin + length), |h| h.t);
        segments.push((r.at(r.tmin), r.at(end), Ink::Ray));
        Picture {
            segments,
            best: best.map(|h| r.at(h.t)),
        }
    }

    /// What the steps re-create of the counters (see `counters_of`).
    pub fn counters_from_steps(&self) -> Counters {
        counters_of(&self.steps)
    }

    /// One line per step, as the CLI prints it and the app lists it.
    /// A visit whose node the diagram and the tree walk number otherwise (a wide BVH's, a
    /// k-d tree's) names that number too.
    pub fn describe(&self, i: usize) -> String {
        let visit = self.visits.binary_search(&i).ok();
        let text = describe(&self.steps[i], visit);
        let outline = visit.and_then(|v| self.outline_nodes.get(v).copied().flatten());
        match (&self.steps[i], outline) {
            (Step::Visit { node, .. }, Some(o)) if *node != o => {
                format!("{text} (node {o} in the diagram and the walk)")
            }
            _ => text,
        }
    }

    /// The whole replay as text.
    pub fn text(&self) -> String {
        let r = &self.ray;
        let mut out = format!(
            "{} of pixel ({}, {}): origin {} direction {} t in ({}, {})\n",
            match self.rays {
                RayKind::Primary => "primary ray (closest hit)",
                RayKind::Shadow => "shadow ray (any hit: stops at the first)",
            },
            self.pixel.0,
            self.pixel.1,
            vec3(r.origin),
            vec3(r.direction),
            r.tmin,
            r.tmax
        );
        for i in 0..self.steps.len() {
            let indent = if self.steps[i].is_visit() { "" } else { "    " };
            out += &format!("{indent}{}\n", self.describe(i));
        }
        let c = &self.counters;
        out += &format!(
            "{} nodes visited, {} box tests, {} triangle tests\n",
            c.nodes_visited, c.box_tests, c.triangle_tests
        );
        out += &match self.hit {
            Some(h) => format!("hit: triangle {} at t = {}\n", h.triangle, h.t),
            None => "hit: none\n".into(),
        };
        out
    }

    /// The replay as one JSON object: the ray, the steps, the counters and the hit.
    pub fn to_json(&self) -> serde_json::Value {
        let r = &self.ray;
        let c = &self.counters;
        serde_json::json!({
            "pixel": [self.pixel.0, self.pixel.1],
            "rays": match self.rays {
                RayKind::Primary => "primary",
                RayKind::Shadow => "shadow",
            },
            "ray": {
                "origin": r.origin.to_array(),
                "direction": r.direction.to_array(),
                "tmin": r.tmin,
                "tmax": r.tmax,
            },
            "steps": self.steps,
            "counters": {
                "nodes_visited": c.nodes_visited,
                "box_tests": c.box_tests,
                "triangle_tests": c.triangle_tests,
                "repeated_tests": c.repeated_tests,
            },
            "hit": self.hit.map(|h| serde_json::json!({"triangle": h.triangle, "t": h.t})),
        })
    }
}

fn vec3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

fn t_or(t: Option<f32>, missed: &str) -> String {
    t.map_or_else(|| missed.to_string(), |t| format!("t = {t:.4}"))
}

fn named(node: u32, leaf: bool) -> String {
    format!("{} {node}", if leaf { "leaf" } else { "node" })
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// One step in words; `visit` is its number among the visits.
pub fn describe(step: &Step, visit: Option<usize>) -> String {
    match step {
        Step::Bounds { entry } => format!(
            "outer box: {}",
            entry.map_or("missed, nothing to search".into(), |t| format!(
                "entered at t = {t:.4}"
            ))
        ),
        Step::Visit {
            node,
            what,
            level,
            entry,
            exit,
            ..
        } => {
            let level = match level {
                Level::Single => "",
                Level::Top => "TLAS ",
                Level::Bottom => "BLAS ",
            };
            let what = match what {
                Visited::Node => format!("{level}node {node}"),
                Visited::Leaf => format!("{level}leaf {node}"),
                Visited::Cell => format!("cell {node}"),
                Visited::Scene => "the scene (every triangle)".into(),
            };
            let span = match (entry, exit) {
                (Some(a), Some(b)) => format!("enters at t = {a:.4}, leaves at t = {b:.4}"),
                _ => "the ray's interval misses its box (rounding)".into(),
            };
            format!("visit {}: {what}: {span}", visit.map_or(0, |v| v + 1))
        }
        Step::Children {
            children,
            first,
            order,
        } => {
            let list: Vec<String> = children
                .iter()
                .map(|c| {
                    format!(
                        "{} {}",
                        named(c.node, c.leaf),
                        t_or(c.entry, "missed or beyond the best hit")
                    )
                })
                .collect();
            let taken = first.map_or("none: back to the stack".into(), |f| {
                format!("{f} first ({})", order.reason())
            });
            format!("children: {}; take {taken}", list.join(", "))
        }
        Step::Plane { axis, t, near, far } => format!(
            "split plane on {} at t = {t:.4}: take node {near} first (the side the ray \
             meets first){}",
            AXES[(*axis as usize).min(2)],
            far.map_or(
                "; the other side lies outside the ray's interval or beyond the best hit".into(),
                |f| format!("; node {f} later")
            )
        ),
        Step::Octants { children } => {
            let list: Vec<String> = children
                .iter()
                .map(|c| format!("{} {}", named(c.node, c.leaf), t_or(c.entry, "")))
                .collect();
            format!(
                "mid planes: the ray passes through {} (in this order)",
                list.join(", ")
            )
        }
        Step::Cross { axis, t } => format!(
            "cross the {} face at t = {t:.4} into the next cell",
            AXES[(*axis as usize).min(2)]
        ),
        Step::Stop { t } => {
            format!("stop: the next cell starts at t = {t:.4}, beyond the best hit or the grid")
        }
        Step::Push { node, leaf, entry } => {
            format!("push {} (enters at t = {entry:.4})", named(*node, *leaf))
        }
        Step::Pop { node, leaf, entry } => format!(
            "pop {}{}",
            named(*node, *leaf),
            entry.map_or(String::new(), |t| format!(" (enters at t = {t:.4})"))
        ),
        Step::Skip {
            node,
            leaf,
            entry,
            best,
        } => format!(
            "pop {} and skip it: it starts at t = {entry:.4}, beyond the best hit at \
             t = {best:.4}",
            named(*node, *leaf)
        ),
        Step::TriangleBox { triangle, pierced } => format!(
            "box of triangle {triangle}: {}",
            if *pierced {
                "pierced, test the triangle"
            } else {
                "missed, skip it"
            }
        ),
        Step::Triangle { triangle, t } => format!(
            "test triangle {triangle}: {}",
            t.map_or("miss".into(), |t| format!("hit at t = {t:.4}"))
        ),
        Step::Mailboxed { triangle } => {
            format!("triangle {triangle}: tested already in another cell (mailbox), skip")
        }
        Step::Instance { instance } => {
            format!("enter instance {instance}: the ray in its object space, walk its BLAS")
        }
    }
}
