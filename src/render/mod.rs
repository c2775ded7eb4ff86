//! The CPU ray tracer: one primary ray per pixel and one shadow ray per hit, traced in
//! parallel tiles, then coloured by the chosen mode: shaded, normals, depth, or a heatmap of
//! the work each pixel's rays took.

pub mod colormap;
pub mod compare;
pub mod cracks;
pub mod export;
pub mod frame;
pub mod heat;
pub mod node_visits;
pub mod overlay;
pub mod per_triangle;
pub mod replay;
mod sample_pool;
pub mod view_mode;

pub use frame::{CounterSummary, Frame, FrameSummary, RayKind, Sample};
pub use view_mode::ViewMode;

use crate::accel::bvh::packet::{PACKET_SIZE, tile_pixels};
use crate::accel::{Accel, Counter, Counters, Hit, NoStats, Stats, Structure};
use crate::geometry::spawn::SurfacePoint;
use crate::geometry::{Intersector, Ray, Triangle, Watertight};
use crate::scene::{Camera, Scene};
use colormap::{Srgb8, to_rgba8};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Lambert shading with a hard shadow from the point light.
    #[default]
    Shaded,
    Normals,
    Depth,
    /// One counter of one kind of ray, through the colour map.
    Heatmap(Counter, RayKind),
    /// Each pixel coloured by its triangle's share of the tree's SAH cost (log scale):
    /// `per_triangle`.
    TriangleCost,
    /// Each pixel coloured by the ray–triangle tests its triangle received from the
    /// frame's rays of one kind: `per_triangle`.
    TestsReceived(RayKind),
}

impl Mode {
    /// Whether this mode shows the work of shadow rays.
    pub fn counts_shadow_rays(self) -> bool {
        matches!(self, Mode::Heatmap(_, RayKind::Shadow))
    }

    /// Whether this mode colours each triangle by a value of its own (`per_triangle`).
    pub fn colours_triangles(self) -> bool {
        matches!(self, Mode::TriangleCost | Mode::TestsReceived(_))
    }

    pub fn label(self) -> String {
        match self {
            Mode::Shaded => "shaded".into(),
            Mode::Normals => "normals".into(),
            Mode::Depth => "depth".into(),
            Mode::Heatmap(c, r) => format!("{} ({})", c.label(), r.label()),
            Mode::TriangleCost => "SAH cost per triangle".into(),
            Mode::TestsReceived(r) => format!("tests per triangle ({})", r.label()),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub light: Vec3,
    pub mode: Mode,
    /// Heatmap scale: the count shown at the top of the map; `None` = the frame's maximum.
    pub heat_max: Option<u32>,
    /// Trace a shadow ray per hit. Without them (a quick preview) every hit counts as lit.
    pub shadows: bool,
    /// Count each ray's work. Without (a quick shaded preview) the counters stay zero and
    /// the counting code is compiled away.
    pub counters: bool,
}

impl RenderSettings {
    pub fn for_scene(scene: &Scene, width: u32, height: u32) -> Self {
        RenderSettings {
            width,
            height,
            camera: scene.camera(),
            light: scene.light(),
            mode: Mode::Shaded,
            heat_max: None,
            shadows: true,
            counters: true,
        }
    }
}

/// Rows per tile: the image is split into tiles of whole rows for the worker threads. A
/// tile is one packet high.
const TILE_ROWS: u32 = 8;

/// The tiles a frame of `height` rows is traced in (`trace_unless` asks its `stop` once
/// before each, so counting the asks counts the tiles begun).
pub fn tile_count(height: u32) -> usize {
    height.max(1).div_ceil(TILE_ROWS) as usize
}
/// Columns per primary-ray packet: a packet is an 8 × 8 block of a tile.
const PACKET_COLUMNS: u32 = 8;
const _: () = assert!((TILE_ROWS * PACKET_COLUMNS) as usize == PACKET_SIZE);
const AMBIENT: f32 = 0.12;

/// Traces and colours a frame with the default (watertight) intersector.
pub fn render<A: Accel>(accel: &A, scene: &Scene, settings: &RenderSettings) -> Frame {
    render_with::<A, Watertight>(accel, scene, settings)
}

pub fn render_with<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
) -> Frame {
    let mut frame = trace_with::<A, I>(accel, scene, settings);
    frame.recolor(settings.mode, settings.heat_max);
    frame
}

/// Traces a frame with the default intersector. Its `rgba` holds the shaded image when
/// `settings.mode` is `Mode::Shaded` (coloured as each tile is traced, while its samples are
/// in cache), and is empty otherwise: callers colour it themselves (`colorize`).
pub fn trace<A: Accel>(accel: &A, scene: &Scene, settings: &RenderSettings) -> Frame {
    trace_with::<A, Watertight>(accel, scene, settings)
}

/// Traces every pixel's rays into the frame's samples. The image is cut into tiles of
/// `TILE_ROWS` full rows, contiguous in memory, so each worker thread writes its own slice.
/// A counting frame traces ray by ray, as the lecture's counters are defined; without
/// counting, the primary rays go in 8 × 8 packets (`Accel::closest_hits`), then their shadow
/// rays, with the same hits and the same lit pixels.
pub fn trace_with<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
) -> Frame {
    // Never stopped, the trace always gives its frame.
    trace_unless::<A, I>(accel, scene, settings, &|| false).unwrap_or_default()
}

/// `trace_with`, given up (`None`) as soon as `stop` says so: `stop` is asked before each
/// tile, so a frame no longer wanted (the app's counted pass, when a newer command
/// arrives) costs at most a tile per thread more.
pub fn trace_unless<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
    stop: &(dyn Fn() -> bool + Sync),
) -> Option<Frame> {
    trace_streaming::<A, I>(accel, scene, settings, stop, &|_| {})
}

/// A tile just traced: its first pixel, its samples and (for a shaded frame) its pixels.
pub struct TileDone<'a> {
    pub first_pixel: usize,
    pub samples: &'a [Sample],
    pub rgba: &'a [u8],
}

/// `trace_unless`, handing each tile to `done` as soon as it is traced: what the app shows
/// of a slow frame while the rest is on its way.
pub fn trace_streaming<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
    stop: &(dyn Fn() -> bool + Sync),
    done: &(dyn Fn(TileDone) + Sync),
) -> Option<Frame> {
    trace_tiles::<A, I>(
        accel,
        scene,
        settings,
        settings.mode == Mode::Shaded,
        stop,
        done,
    )
}

/// `trace_unless` without colouring (`rgba` stays empty): for a frame whose image is known
/// already, as the app's counted pass of a frame it has shown (the same hits, the same
/// image).
pub fn trace_uncoloured_unless<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
    stop: &(dyn Fn() -> bool + Sync),
) -> Option<Frame> {
    trace_tiles::<A, I>(accel, scene, settings, false, stop, &|_| {})
}

/// The tiles of `trace_unless`, coloured as they are traced when `shaded`.
fn trace_tiles<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
    shaded: bool,
    stop: &(dyn Fn() -> bool + Sync),
    done: &(dyn Fn(TileDone) + Sync),
) -> Option<Frame> {
    let (w, h) = (settings.width.max(1), settings.height.max(1));
    let rays = settings.camera.rays(w, h);
    let start = Instant::now();
    let mut samples = sample_pool::take((w * h) as usize);
    let stopped = AtomicBool::new(false);
    let tile_pixels = (w * TILE_ROWS) as usize;
    // A shaded frame's pixels are coloured tile by tile, as the tile's samples are made.
    let mut rgba = vec![0u8; if shaded { samples.len() * 4 } else { 0 }];
    let mut rgba_tiles: Vec<&mut [u8]> = rgba.chunks_mut(tile_pixels * 4).collect();
    rgba_tiles.resize_with(samples.len().div_ceil(tile_pixels), Default::default);
    let tiles = samples
        .par_chunks_mut(tile_pixels)
        .zip(rgba_tiles)
        .enumerate();
    // Each tile sums (and colours) its own samples while they are still in cache: a
    // separate pass over a 1280 × 720 frame's 96 MB of samples costs as much as tracing
    // its primary rays in packets.
    let sums = tiles.map(|(tile, (out, pixels))| {
        if stopped.load(Ordering::Relaxed) || stop() {
            stopped.store(true, Ordering::Relaxed);
            return FrameSummary::default();
        }
        let sums = trace_tile::<A, I>(accel, scene, settings, &rays, tile as u32, out);
        let srgb = Srgb8::tables();
        for (px, s) in pixels.chunks_exact_mut(4).zip(out.iter()) {
            px.copy_from_slice(&shaded_color(s, srgb));
        }
        done(TileDone {
            first_pixel: tile * tile_pixels,
            samples: out,
            rgba: pixels,
        });
        sums
    });
    let sums = sums.reduce(FrameSummary::default, FrameSummary::merged);
    let trace_time = start.elapsed();
    let frame = Frame {
        width: w,
        height: h,
        rgba,
        summary: sums.with_means(trace_time),
        samples,
        heat_max: None,
        per_triangle: Default::default(),
    };
    // A stopped frame's samples go back to the pool as it drops.
    (!stopped.into_inner()).then_some(frame)
}

/// Traces the tile of `TILE_ROWS` rows from row `tile * TILE_ROWS` into its samples `out`
/// and sums them.
fn trace_tile<A: Accel, I: Intersector>(
    accel: &A,
    scene: &Scene,
    settings: &RenderSettings,
    rays: &crate::scene::camera::CameraRays,
    tile: u32,
    out: &mut [Sample],
) -> FrameSummary {
    let w = settings.width.max(1);
    let y0 = tile * TILE_ROWS;
    let mut albedos = Albedos::new(scene);
    {
        if settings.counters {
            for (k, sample) in out.iter_mut().enumerate() {
                let ray = rays.pixel_center(k as u32 % w, y0 + k as u32 / w);
                let mut primary = Counters::default();
                let hit = accel.closest_hit::<I, _>(&ray, &mut primary);
                let occluded = |r: &Ray, s: &mut Counters| accel.any_hit::<I, _>(r, s);
                *sample = shade(&mut albedos, &ray, hit, primary, settings, occluded);
            }
            return FrameSummary::sum_of(out, settings.shadows);
        }
        // Without counting, primary rays go through the tree in 8 × 8 packets, and the
        // shadow rays of their hits after them.
        let rows = out.len() as u32 / w;
        let mut packet = Vec::with_capacity(PACKET_SIZE);
        let mut pixels = Vec::with_capacity(PACKET_SIZE);
        let mut hits = [None; PACKET_SIZE];
        let mut shadows = Vec::with_capacity(PACKET_SIZE);
        let mut lit_pixels = Vec::with_capacity(PACKET_SIZE);
        for x0 in (0..w).step_by(PACKET_COLUMNS as usize) {
            packet.clear();
            pixels.clear();
            for (x, y) in tile_pixels(x0, 0, w, rows) {
                packet.push(rays.pixel_center(x, y0 + y));
                pixels.push((y * w + x) as usize);
            }
            let hits = &mut hits[..packet.len()];
            accel.closest_hits::<I>(&packet, hits);
            // The packet's shadow rays are gathered as it is shaded (each hit taken as lit
            // for now), then traced together: a shadow ray is blocked exactly when it has
            // a closest hit within its segment.
            shadows.clear();
            lit_pixels.clear();
            for hit in hits.iter().flatten() {
                albedos.prefetch(hit.triangle);
            }
            for ((ray, &hit), &pixel) in packet.iter().zip(hits.iter()).zip(&pixels) {
                let gather = |r: &Ray, _: &mut NoStats| {
                    shadows.push(*r);
                    lit_pixels.push(pixel);
                    false
                };
                out[pixel] = shade(&mut albedos, ray, hit, NoStats, settings, gather);
            }
            let blockers = &mut hits[..shadows.len()];
            accel.closest_hits::<I>(&shadows, blockers);
            for (blocker, &pixel) in blockers.iter().zip(&lit_pixels) {
                out[pixel].lit = blocker.is_none();
            }
        }
        // Nothing was counted: only the rays and hits to sum.
        FrameSummary::sum_of_uncounted(out, settings.shadows)
    }
}

/// A pixel's sample from its primary ray's hit (found with `primary` counting) and, if it
/// hit, the shadow ray towards the light, which `occluded` traces (or gathers for later).
fn shade<S: Stats + Into<Counters>>(
    albedos: &mut Albedos,
    ray: &Ray,
    hit: Option<Hit>,
    primary: S,
    settings: &RenderSettings,
    mut occluded: impl FnMut(&Ray, &mut S) -> bool,
) -> Sample {
    let light = settings.light;
    let Some(hit) = hit else {
        return Sample {
            t: f32::INFINITY,
            triangle: u64::MAX,
            primary: primary.into(),
            ..Default::default()
        };
    };
    let Some((tri, albedo)) = &albedos.of(hit.triangle) else {
        // A structure built over another scene: nothing to shade.
        return Sample {
            t: f32::INFINITY,
            triangle: u64::MAX,
            primary: primary.into(),
            ..Default::default()
        };
    };
    let (normal, albedo) = (tri.facing_normal(ray.direction), *albedo);
    let mut shadow = S::default();
    let (lit, cos_light) = if settings.shadows {
        let shadow_ray = shadow_ray(tri, normal, &hit, light);
        let blocked = occluded(&shadow_ray, &mut shadow);
        (!blocked, normal.dot(shadow_ray.direction).max(0.0))
    } else {
        let to_light = (light - ray.at(hit.t)).normalize_or_zero();
        (true, normal.dot(to_light).max(0.0))
    };
    Sample {
        t: hit.t,
        triangle: hit.triangle,
        normal,
        albedo,
        cos_light,
        lit,
        primary: primary.into(),
        shadow: shadow.into(),
    }
}

/// The triangle a hit names and the colour of its object. Neighbouring pixels mostly hit
/// the same object, so the object of the last hit is tried before the search over the
/// objects (200 002 of them on the island, whose triangles are placed on demand).
struct Albedos<'a> {
    scene: &'a Scene,
    /// The last hit's object: its triangles, its index and its colour.
    last: Option<(std::ops::Range<usize>, usize, Vec3)>,
}

impl<'a> Albedos<'a> {
    fn new(scene: &'a Scene) -> Self {
        Albedos { scene, last: None }
    }

    /// Asks for the memory `of(triangle)` will read. A packet's hits are asked for before
    /// they are shaded, so that their cache misses (a mesh's triangle, somewhere in the
    /// island's meshes) overlap instead of coming one after another.
    fn prefetch(&mut self, triangle: u64) {
        if let Ok(i) = usize::try_from(triangle)
            && let Some((o, _)) = self.object(i)
        {
            self.scene.prefetch_triangle(o, i);
        }
    }

    fn of(&mut self, triangle: u64) -> Option<(Triangle, Vec3)> {
        let i = usize::try_from(triangle).ok()?;
        let Some((o, color)) = self.object(i) else {
            // A triangle of no object (a flattened scene's only): the grey default.
            return Some((self.scene.triangle(triangle)?, Vec3::splat(0.7)));
        };
        Some((self.scene.triangle_of(o, i)?, color))
    }

    /// The object of triangle `i` and its colour.
    fn object(&mut self, i: usize) -> Option<(usize, Vec3)> {
        match &self.last {
            Some((range, o, color)) if range.contains(&i) => Some((*o, *color)),
            _ => {
                let o = self.scene.object_of(i)?;
                let object = &self.scene.objects[o];
                self.last = Some((object.range(), o, object.color));
                Some((o, object.color))
            }
        }
    }
}

/// The shadow ray from `hit` on triangle `tri` towards the light: spawned off the surface
/// on the side of `normal`, the triangle's normal facing the ray that hit it.
pub fn shadow_ray(tri: &crate::geometry::Triangle, normal: Vec3, hit: &Hit, light: Vec3) -> Ray {
    SurfacePoint::on_triangle(tri, hit.u, hit.v).ray_towards(normal, light)
}

/// The ray of kind `rays` that a pixel's `primary` ray stands for: the primary ray itself,
/// or the shadow ray from its closest hit towards `light` (`None`: the primary ray hits
/// nothing, so there is no shadow ray). The frame's own shadow rays are made the same way.
pub fn ray_of_kind<I: Intersector>(
    structure: &Structure,
    scene: &Scene,
    primary: &Ray,
    rays: RayKind,
    light: Vec3,
) -> Option<Ray> {
    match rays {
        RayKind::Primary => Some(*primary),
        RayKind::Shadow => {
            let hit = structure.closest_hit::<I, _>(primary, &mut NoStats)?;
            let tri = scene.triangle(hit.triangle)?;
            Some(shadow_ray(
                &tri,
                tri.facing_normal(primary.direction),
                &hit,
                light,
            ))
        }
    }
}

const BACKGROUND: Vec3 = Vec3::new(0.06, 0.07, 0.09);

/// A sample's pixel in the shaded mode: Lambert shading with the hard shadow, or the
/// background for a miss.
#[inline]
fn shaded_color(s: &Sample, srgb: &Srgb8) -> [u8; 4] {
    if !s.is_hit() {
        return to_rgba8(BACKGROUND);
    }
    let light = if s.lit { s.cos_light } else { 0.0 };
    let c = s.albedo * (AMBIENT + (1.0 - AMBIENT) * light);
    [srgb.code(c.x), srgb.code(c.y), srgb.code(c.z), 255]
}

impl Frame {
    /// Recomputes `rgba` and `heat_max` for another mode or scale, without tracing again.
    pub fn recolor(&mut self, mode: Mode, heat_max: Option<u32>) {
        let (rgba, max) = colorize(self, mode, heat_max);
        self.rgba = rgba;
        self.heat_max = max;
    }
}

/// The pixels of `frame` in `mode`, and for heatmaps the count at the top of the scale
/// (`heat_max`, or the frame's maximum).
pub fn colorize(frame: &Frame, mode: Mode, heat_max: Option<u32>) -> (Vec<u8>, Option<u32>) {
    colorize_styled(frame, mode, heat_max, &heat::HeatStyle::default())
}

/// `colorize` with a heatmap's curve, clipping and underlay (`heat::HeatStyle`); the count
/// returned is the top of the scale as drawn.
pub fn colorize_styled(
    frame: &Frame,
    mode: Mode,
    heat_max: Option<u32>,
    style: &heat::HeatStyle,
) -> (Vec<u8>, Option<u32>) {
    if let Some(image) = per_triangle::colorize(frame, mode, heat_max, style) {
        return image;
    }
    let samples = &frame.samples;
    // Only the depth mode needs the range of distances.
    let (t_near, t_far) = if mode == Mode::Depth {
        samples
            .iter()
            .filter(|s| s.is_hit())
            .fold((f32::INFINITY, 0.0f32), |(a, b), s| {
                (a.min(s.t), b.max(s.t))
            })
    } else {
        (0.0, 1.0)
    };
    let scale = match mode {
        Mode::Heatmap(c, r) => Some(style.top(heat_max, frame.summary.counter(r, c).max, || {
            samples.iter().map(|s| s.counters(r).get(c)).collect()
        })),
        _ => None,
    };
    let srgb = Srgb8::tables();
    let top = scale.unwrap_or(1);
    let color = |s: &Sample| sample_color(s, mode, top, style, (t_near, t_far), srgb);
    (paint(samples, color), scale)
}

/// Each sample's pixel by `color`, in parallel: written in place, a chunk of pixels per
/// task (collecting a flat-mapped parallel iterator builds and joins a list of vectors
/// instead).
fn paint(samples: &[Sample], color: impl Fn(&Sample) -> [u8; 4] + Sync) -> Vec<u8> {
    const CHUNK: usize = 4096;
    let mut rgba = vec![0u8; samples.len() * 4];
    rgba.par_chunks_mut(4 * CHUNK)
        .zip(samples.par_chunks(CHUNK))
        .for_each(|(out, samples)| {
            for (px, s) in out.chunks_exact_mut(4).zip(samples) {
                px.copy_from_slice(&color(s));
            }
        });
    rgba
}

/// One sample's colour in `mode`: a heatmap's under the scale's top `top`, the depth's
/// within the frame's range of hit distances `(t_near, t_far)`.
fn sample_color(
    s: &Sample,
    mode: Mode,
    top: u32,
    style: &heat::HeatStyle,
    (t_near, t_far): (f32, f32),
    srgb: &Srgb8,
) -> [u8; 4] {
    match mode {
        Mode::Heatmap(c, r) => to_rgba8(style.color(s.counters(r).get(c), top, s)),
        Mode::Shaded => shaded_color(s, srgb),
        _ if !s.is_hit() => to_rgba8(BACKGROUND),
        // Coloured by `per_triangle`, which needs the whole frame: grey until then.
        Mode::TriangleCost | Mode::TestsReceived(_) => to_rgba8(Vec3::splat(0.5)),
        Mode::Normals => to_rgba8(s.normal * 0.5 + 0.5),
        Mode::Depth => {
            let range = (t_far - t_near).max(f32::MIN_POSITIVE);
            to_rgba8(Vec3::splat(1.0 - 0.85 * (s.t - t_near) / range))
        }
    }
}

/// Colours a tile of a frame still being traced into `out`, a heatmap under a scale top
/// `top` known beforehand (the coarse first image's); false for the depth mode, whose
/// colours need the whole frame's range.
pub fn colorize_tile(
    samples: &[Sample],
    mode: Mode,
    top: u32,
    style: &heat::HeatStyle,
    out: &mut [u8],
) -> bool {
    if matches!(
        mode,
        Mode::Depth | Mode::TriangleCost | Mode::TestsReceived(_)
    ) {
        return false;
    }
    let srgb = Srgb8::tables();
    for (px, s) in out.chunks_exact_mut(4).zip(samples) {
        px.copy_from_slice(&sample_color(s, mode, top, style, (0.0, 1.0), srgb));
    }
    true
}
