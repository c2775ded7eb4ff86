//! The cracks, shown: an exact ray through every shared edge and closed vertex fan of the
//! scene in view, traced with one ray–triangle test, and those that slip through marked on
//! the picture: Möller–Trumbore's holes, and none for the watertight test. `offset` moves the
//! scene and its camera far from the origin, where f32 coordinates are coarse; measured, the
//! fast test's holes get fewer there, not more (docs/accuracy.md says why). Rays and
//! verdicts are the stress suite's (`bench::stress::crossing`).

use super::{Frame, Mode, RenderSettings};
use crate::accel::structure::{self, Structure, StructureError, StructureParams};
use crate::accel::{Accel, NoStats};
use crate::bench::stress::crossing::{self, Crossing, CrossingReport, EDGE_WEIGHTS, Outcome};
use crate::geometry::{Aabb, IntersectorKind, Ray, ReferenceF64, Triangle};
use crate::random::Rng;
use crate::scene::{Camera, FlattenError, MAX_COORDINATE, Scene};
use crate::with_intersector;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The seed of the crossings' origins (their distance from the surface).
pub const SEED: u64 = 1;

/// A scene must span at least this many f32 steps of its moved coordinates: coarser, its
/// triangles collapse and the picture shows the rounding, not the test.
pub const MIN_STEPS_ACROSS: f64 = 256.0;

/// An eye ray whose first hit (in f64) is within this relative distance of the aimed point
/// sees that point.
const VISIBLE_T: f64 = 1e-4;

#[derive(Debug, thiserror::Error)]
pub enum CrackError {
    #[error("the offset {0} is not a finite number")]
    NotFinite(f64),
    #[error(
        "at offset {offset:e} f32 coordinates step by {step:.3e}, too coarse for a scene \
         {extent:.4} across (a step may be at most 1/{MIN_STEPS_ACROSS} of it); offsets up to \
         about ±{farthest:.1e} resolve it"
    )]
    Unresolved {
        offset: f64,
        step: f64,
        extent: f64,
        farthest: f64,
    },
    #[error("the scene has no triangles to cross")]
    Empty,
    #[error("at offset {0:e} the eye and the point looked at round to the same point")]
    Camera(f64),
    #[error(transparent)]
    Flatten(#[from] FlattenError),
    #[error(transparent)]
    Structure(#[from] StructureError),
}

/// Refuses an offset that is not finite or at which f32 can no longer resolve a scene of
/// box `bounds` (`MIN_STEPS_ACROSS`). Cheap: call it before any work.
pub fn check_offset(bounds: &Aabb, offset: f64) -> Result<(), CrackError> {
    if !offset.is_finite() {
        return Err(CrackError::NotFinite(offset));
    }
    if bounds.is_empty() {
        return Err(CrackError::Empty);
    }
    let extent = f64::from(bounds.diagonal());
    let farthest_coordinate = [bounds.min, bounds.max]
        .iter()
        .flat_map(|p| p.to_array())
        .map(|x| (f64::from(x) + offset).abs())
        .fold(0.0, f64::max);
    let step = f32_step(farthest_coordinate);
    if step * MIN_STEPS_ACROSS > extent || farthest_coordinate > f64::from(MAX_COORDINATE) {
        // The step at x is at most x·2^-23: offsets below this keep the scene resolved.
        let farthest = extent / MIN_STEPS_ACROSS * 2f64.powi(23);
        return Err(CrackError::Unresolved {
            offset,
            step,
            extent,
            farthest,
        });
    }
    Ok(())
}

/// The spacing of f32 values around |x| (its ulp).
fn f32_step(x: f64) -> f64 {
    if x == 0.0 {
        return f64::from(f32::MIN_POSITIVE);
    }
    2f64.powi(x.abs().log2().floor() as i32 - 23)
}

/// `p` moved by (d, d, d) in f64, then rounded to f32: where the scene's numbers land.
pub fn moved(p: Vec3, offset: f64) -> Vec3 {
    (p.as_dvec3() + DVec3::splat(offset)).as_vec3()
}

/// Whether a crossing aims at a point of a shared edge or at a vertex of a closed fan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    Edge,
    Vertex,
}

/// A crossing of the view: the exact ray and where its crossing point lands in the image.
#[derive(Clone, Copy, Debug)]
pub struct ViewCrossing {
    pub crossing: Crossing,
    /// The crossing point in the image, in pixels (y down, (0.5, 0.5) the first pixel's
    /// centre).
    pub x: f32,
    pub y: f32,
    pub at: Feature,
}

/// A point drawn on the picture (or by the app over its view): a crossing, leaked or held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marker {
    pub x: f32,
    pub y: f32,
    pub leaked: bool,
}

/// The verdicts of one intersector on a view's crossings.
#[derive(Clone, Debug)]
pub struct Cracks {
    pub kind: IntersectorKind,
    /// The counts, as `bvhlab stress` reports them.
    pub report: CrossingReport,
    /// Per crossing, in the view's order.
    pub outcomes: Vec<Outcome>,
}

/// The scene and its camera moved by (d, d, d), a structure over the moved triangles and
/// the crossings in view: all that any intersector's verdicts need.
pub struct CrackView {
    pub offset: f64,
    pub width: u32,
    pub height: u32,
    /// The moved scene, flattened, with its moved view and light.
    pub scene: Scene,
    pub camera: Camera,
    pub light: Vec3,
    pub structure: Structure,
    pub crossings: Vec<ViewCrossing>,
    /// Shared edges and closed fans of the moved triangles, in view or not.
    pub shared_edges: usize,
    pub closed_fans: usize,
}

/// What a crack study looks at: the view, its size in pixels and how far the scene (with
/// its camera and light) is moved from where it stands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrackSetup {
    pub camera: Camera,
    pub light: Vec3,
    pub width: u32,
    pub height: u32,
    /// The scene moves by (offset, offset, offset).
    pub offset: f64,
}

impl CrackSetup {
    /// The view of a frame's settings, moved by `offset`.
    pub fn new(settings: &RenderSettings, offset: f64) -> Self {
        CrackSetup {
            camera: settings.camera,
            light: settings.light,
            width: settings.width,
            height: settings.height,
            offset,
        }
    }
}

impl CrackView {
    /// Moves `scene`, its camera and light by `setup.offset` on every axis, builds the
    /// structure `params` names over the moved triangles and makes the crossings in view.
    pub fn new(
        scene: &Scene,
        setup: &CrackSetup,
        params: &StructureParams,
        seed: u64,
    ) -> Result<Self, CrackError> {
        let CrackSetup {
            camera,
            light,
            width,
            height,
            offset,
        } = *setup;
        check_offset(&scene.bounds(), offset)?;
        let triangles: Vec<Triangle> = scene
            .flattened()?
            .par_iter()
            .map(|t| Triangle {
                v: t.v.map(|p| moved(p, offset)),
            })
            .collect();
        let camera = Camera {
            eye: moved(camera.eye, offset),
            look_at: moved(camera.look_at, offset),
            ..camera
        };
        if camera.eye == camera.look_at {
            return Err(CrackError::Camera(offset));
        }
        let light = moved(light, offset);
        let mut moved_scene = Scene::new(scene.name.clone());
        moved_scene.triangles = triangles;
        moved_scene.objects = scene.objects.clone();
        moved_scene.view = Some(camera);
        moved_scene.light = Some(light);
        let structure =
            structure::build(&moved_scene.triangles, params, &Default::default())?.structure;
        let (crossings, shared_edges, closed_fans) = in_view(
            &structure,
            &moved_scene.triangles,
            &camera,
            width,
            height,
            seed,
        );
        Ok(CrackView {
            offset,
            width,
            height,
            scene: moved_scene,
            camera,
            light,
            structure,
            crossings,
            shared_edges,
            closed_fans,
        })
    }

    /// The crossings' rays, in order.
    pub fn rays(&self) -> Vec<Crossing> {
        self.crossings.iter().map(|c| c.crossing).collect()
    }

    /// Traces every crossing with `kind` and judges it as `crossing::count` does.
    pub fn classify(&self, kind: IntersectorKind) -> Cracks {
        let tris = &self.scene.triangles;
        let outcomes: Vec<Outcome> = with_intersector!(kind, I => self
            .crossings
            .par_iter()
            .with_min_len(256)
            .map(|c| crossing::classify::<_, I>(&self.structure, tris, &c.crossing))
            .collect());
        let mut report = CrossingReport::default();
        for &o in &outcomes {
            report.record(o);
        }
        Cracks {
            kind,
            report,
            outcomes,
        }
    }

    /// Every crossing as a marker, leaked or held by `cracks`.
    pub fn markers(&self, cracks: &Cracks) -> Vec<Marker> {
        self.crossings
            .iter()
            .zip(&cracks.outcomes)
            .map(|(c, o)| Marker {
                x: c.x,
                y: c.y,
                leaked: o.leaked(),
            })
            .collect()
    }

    /// The moved scene shaded through the moved camera, traced with `kind`.
    pub fn render(&self, kind: IntersectorKind) -> Frame {
        let settings = RenderSettings {
            width: self.width,
            height: self.height,
            camera: self.camera,
            light: self.light,
            mode: Mode::Shaded,
            heat_max: None,
            shadows: true,
            counters: false,
        };
        with_intersector!(kind, I => super::render_with::<_, I>(&self.structure, &self.scene, &settings))
    }
}

/// A crack study at one offset with one intersector: the view, the verdicts and the markers.
pub struct CrackStudy {
    pub view: CrackView,
    pub cracks: Cracks,
    pub markers: Vec<Marker>,
}

/// `CrackView::new` then `classify(kind)` and its markers: the one call a worker makes.
pub fn study(
    scene: &Scene,
    setup: &CrackSetup,
    params: &StructureParams,
    kind: IntersectorKind,
) -> Result<CrackStudy, CrackError> {
    let view = CrackView::new(scene, setup, params, SEED)?;
    let cracks = view.classify(kind);
    let markers = view.markers(&cracks);
    Ok(CrackStudy {
        view,
        cracks,
        markers,
    })
}

/// The crossings of the shared edges (at each of `EDGE_WEIGHTS`' points) and closed fans of
/// `triangles` that land in the image and that the eye sees (in f64, through `accel`): each
/// an exact ray from near the point, on its line to the eye, that crosses the surface
/// there transversally. Also the numbers of shared edges and closed fans.
pub fn in_view<A: Accel>(
    accel: &A,
    triangles: &[Triangle],
    camera: &Camera,
    width: u32,
    height: u32,
    seed: u64,
) -> (Vec<ViewCrossing>, usize, usize) {
    let topology = crossing::Topology::new(triangles);
    let (edges, fans) = (topology.shared_edges(), topology.closed_fans());
    let eye = camera.eye.as_dvec3();
    let seen = |p: DVec3| -> Option<(f32, f32)> {
        let (x, y, _) = camera.project(p.as_vec3(), width, height)?;
        if !(0.0..width as f32).contains(&x) || !(0.0..height as f32).contains(&y) {
            return None;
        }
        let ray = Ray::new(camera.eye, (p - eye).as_vec3());
        let hit = accel.closest_hit::<ReferenceF64, _>(&ray, &mut NoStats)?;
        ((f64::from(hit.t) - 1.0).abs() <= VISIBLE_T).then_some((x, y))
    };
    // From the point towards the eye, as far as the suite's crossings start from their
    // point (0.5 to 4.5 sizes), but never past half the way to the eye.
    let near = |p: DVec3, size: f64, rng: &mut Rng| -> (DVec3, f64) {
        let to_eye = eye - p;
        let dist = (size * (0.5 + 4.0 * rng.unit())).min(0.5 * to_eye.length());
        (p + to_eye.normalize_or_zero() * dist, dist)
    };
    let points = edges.len() * EDGE_WEIGHTS.len();
    let crossings = (0..points + fans.len())
        .into_par_iter()
        .with_min_len(1024)
        .filter_map(|i| {
            let mut rng = Rng::for_case(seed, i as u64);
            if i < points {
                let (a, b, pair) = &edges[i / EDGE_WEIGHTS.len()];
                let w = EDGE_WEIGHTS[i % EDGE_WEIGHTS.len()];
                let (a, b) = (a.as_dvec3(), b.as_dvec3());
                let p = crossing::edge_point(a, b, w);
                let (x, y) = seen(p)?;
                let normals = pair.map(|t| crossing::unit_normal(&triangles[t as usize]));
                let (o, dist) = near(p, (b - a).length(), &mut rng);
                let crossing = crossing::edge_crossing(a, b, w, o, dist, &normals)?;
                Some(ViewCrossing {
                    crossing,
                    x,
                    y,
                    at: Feature::Edge,
                })
            } else {
                let (v, fan) = &fans[i - points];
                let v = v.as_dvec3();
                let (x, y) = seen(v)?;
                let normals = crossing::fan_normals(triangles, fan);
                let (o, dist) = near(v, crossing::fan_size(triangles, v, fan), &mut rng);
                let crossing = crossing::vertex_crossing(v, o, dist, &normals)?;
                Some(ViewCrossing {
                    crossing,
                    x,
                    y,
                    at: Feature::Vertex,
                })
            }
        })
        .collect();
    (crossings, edges.len(), fans.len())
}

/// How the picture draws its markers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PictureStyle {
    /// Draw held crossings too, as faint one-pixel dots.
    pub held: bool,
    /// The radius of a leak's red dot, in pixels.
    pub leak_radius: f32,
}

impl Default for PictureStyle {
    fn default() -> Self {
        PictureStyle {
            held: false,
            leak_radius: 2.5,
        }
    }
}

const LEAK: [u8; 3] = [255, 0, 0];
const HELD: [u8; 3] = [90, 200, 255];

/// The frame greyed and dimmed, so only the markers carry colour: held crossings (with
/// `style.held`) as faint dots, then every leak as a saturated red dot on top.
pub fn picture(frame: &Frame, markers: &[Marker], style: PictureStyle) -> Vec<u8> {
    let mut rgba: Vec<u8> = frame
        .rgba
        .chunks_exact(4)
        .flat_map(|p| {
            let lum =
                0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]);
            let g = (24.0 + 0.5 * lum) as u8;
            [g, g, g, 255]
        })
        .collect();
    let (w, h) = (frame.width as i64, frame.height as i64);
    let mut blend = |x: i64, y: i64, colour: [u8; 3], alpha: f32| {
        if (0..w).contains(&x) && (0..h).contains(&y) {
            let i = ((y * w + x) * 4) as usize;
            for c in 0..3 {
                let old = f32::from(rgba[i + c]);
                rgba[i + c] = (old + (f32::from(colour[c]) - old) * alpha).round() as u8;
            }
        }
    };
    if style.held {
        for m in markers.iter().filter(|m| !m.leaked) {
            blend(m.x.floor() as i64, m.y.floor() as i64, HELD, 0.35);
        }
    }
    let r = style.leak_radius.max(0.5);
    let reach = r.ceil() as i64;
    for m in markers.iter().filter(|m| m.leaked) {
        let (cx, cy) = (m.x.floor() as i64, m.y.floor() as i64);
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if ((dx * dx + dy * dy) as f32) <= r * r {
                    blend(cx + dx, cy + dy, LEAK, 1.0);
                }
            }
        }
    }
    rgba
}

/// 1234567 as `1,234,567`.
pub fn group(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}
