//! Overlays drawn into a traced frame: BVH boxes as wireframes (hidden where the traced
//! surface is nearer, unless seen through) and triangles tinted by the subtree they belong
//! to. Drawn on the CPU so the traced depth can occlude them exactly.

use super::Frame;
use crate::geometry::Aabb;
use crate::scene::Camera;
use glam::Vec3;
use rayon::prelude::*;

/// A box to outline, with its colour (RGBA, alpha = opacity).
#[derive(Clone, Copy, Debug)]
pub struct OutlinedBox {
    pub bounds: Aabb,
    pub color: [u8; 4],
}

/// The twelve edges of a box as pairs of corner indices (see `box_corners`).
pub const BOX_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// The eight corners of a box: bit k of the index picks max on axis k.
pub fn box_corners(b: &Aabb) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// Draws the outlines of `boxes` into `rgba` (the frame's size), seen through `camera`.
/// Where the traced surface in front of a line point is nearer than the point, the line is
/// hidden, unless `see_through`.
pub fn outline_boxes(
    frame: &Frame,
    rgba: &mut [u8],
    camera: &Camera,
    boxes: &[OutlinedBox],
    see_through: bool,
) {
    for b in boxes.iter().filter(|b| !b.bounds.is_empty()) {
        outline_corners(
            frame,
            rgba,
            camera,
            &box_corners(&b.bounds),
            b.color,
            see_through,
        );
    }
}

/// Draws the twelve edges between `corners` (numbered as `box_corners` numbers them): a
/// box placed by a transform, which may rotate, scale or mirror it (an oriented box).
pub fn outline_corners(
    frame: &Frame,
    rgba: &mut [u8],
    camera: &Camera,
    corners: &[Vec3; 8],
    color: [u8; 4],
    see_through: bool,
) {
    let (w, h) = (frame.width, frame.height);
    let basis = camera.basis();
    let forward = -basis.2;
    let rays = camera.rays(w, h);
    for &(i, j) in &BOX_EDGES {
        let (mut a, mut c) = (corners[i], corners[j]);
        // Clip the edge to the part in front of the eye.
        let near = 1e-4 * (a - camera.eye).length().max((c - camera.eye).length());
        let (za, zc) = ((a - camera.eye).dot(forward), (c - camera.eye).dot(forward));
        if za < near && zc < near {
            continue;
        }
        if za < near {
            a = a + (c - a) * ((near - za) / (zc - za));
        } else if zc < near {
            c = c + (a - c) * ((near - zc) / (za - zc));
        }
        let (Some(pa), Some(pc)) = (rays.project(a), rays.project(c)) else {
            continue;
        };
        let pixels = (pa.0 - pc.0).abs().max((pa.1 - pc.1).abs());
        if !pixels.is_finite() {
            continue;
        }
        // Sample along the 3D edge densely enough that no pixel is skipped.
        let steps = (2.0 * pixels).ceil().clamp(1.0, 16384.0) as u32;
        for s in 0..=steps {
            let p = a + (c - a) * (s as f32 / steps as f32);
            let Some((x, y, depth)) = rays.project(p) else {
                continue;
            };
            if !(x >= 0.0 && y >= 0.0 && x < w as f32 && y < h as f32) {
                continue;
            }
            let (px, py) = (x as u32, y as u32);
            let idx = (py * w + px) as usize;
            let surface = frame.samples[idx].t;
            if !see_through && depth > surface * 1.001 {
                continue;
            }
            blend(&mut rgba[4 * idx..4 * idx + 4], color);
        }
    }
}

/// Tints every pixel whose primary hit is a triangle `tint_of` gives a colour for. On every
/// thread: a pass over the frame's samples is bound by memory (a drag's selection is tinted
/// in every frame).
pub fn tint_triangles(
    frame: &Frame,
    rgba: &mut [u8],
    tint_of: impl Fn(u64) -> Option<[u8; 4]> + Sync,
) {
    const PIXELS: usize = 4096;
    let samples = frame.samples.par_chunks(PIXELS);
    samples
        .zip(rgba.par_chunks_mut(4 * PIXELS))
        .for_each(|(samples, rgba)| {
            for (s, px) in samples.iter().zip(rgba.chunks_exact_mut(4)) {
                if s.is_hit()
                    && let Some(c) = tint_of(s.triangle)
                {
                    blend(px, c);
                }
            }
        });
}

fn blend(dst: &mut [u8], c: [u8; 4]) {
    let a = c[3] as u32;
    for k in 0..3 {
        dst[k] = ((dst[k] as u32 * (255 - a) + c[k] as u32 * a) / 255) as u8;
    }
}

/// A distinct colour per tree depth or node index (golden-ratio hue steps).
pub fn palette(k: usize) -> [u8; 4] {
    let hue = (k as f32 * 0.618_034).fract();
    let (r, g, b) = hsv_to_rgb(hue, 0.75, 1.0);
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8, 255]
}

fn hsv_to_rgb(h: f32, s: f32, v: f32) -> (f32, f32, f32) {
    let i = (h * 6.0).floor();
    let f = h * 6.0 - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - f * s), v * (1.0 - (1.0 - f) * s));
    match i as i32 % 6 {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::{BuildParams, build};
    use crate::render::{RenderSettings, render};
    use crate::scene::Scene;

    #[test]
    fn boxes_behind_the_surface_are_hidden_unless_seen_through() {
        let scene = Scene::load("cornell").unwrap();
        let (bvh, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
        let settings = RenderSettings::for_scene(&scene, 64, 48);
        let frame = render(&bvh, &scene, &settings);
        // A box well behind the back wall, and the scene's own box.
        let hidden = OutlinedBox {
            bounds: Aabb::new(Vec3::new(-0.5, 0.5, -3.0), Vec3::new(0.5, 1.5, -2.5)),
            color: [255, 0, 0, 255],
        };
        let changed = |boxes: &[OutlinedBox], see: bool| {
            let mut rgba = frame.rgba.clone();
            outline_boxes(&frame, &mut rgba, &settings.camera, boxes, see);
            rgba.chunks(4)
                .zip(frame.rgba.chunks(4))
                .filter(|(a, b)| a != b)
                .count()
        };
        assert_eq!(changed(&[hidden], false), 0);
        assert!(changed(&[hidden], true) > 20);
        let visible = OutlinedBox {
            bounds: scene.bounds(),
            ..hidden
        };
        assert!(changed(&[visible], false) > 20);
    }
}
