//! A convex part of a triangle, clipped to boxes in f64: what EPO weighs by its area.

use crate::geometry::Triangle;
use glam::DVec3;

/// Three vertices, and at most one more per clipping plane.
const MAX_VERTS: usize = 9;

/// A convex part of a triangle: its vertices, bounds and area, in f64.
#[derive(Clone, Copy)]
pub struct Part {
    v: [DVec3; MAX_VERTS],
    n: usize,
    pub lo: DVec3,
    pub hi: DVec3,
    pub area: f64,
    /// Twice its vector area (Σ of the fan's cross products): its area in another space
    /// is half the length of this carried by the map's cofactor matrix.
    pub normal: DVec3,
}

/// Where a part lies against a box, from its bounds.
pub enum Against {
    Outside,
    Inside,
    /// Its bounds cross a face plane: it must be clipped to tell.
    Crossing,
}

impl Part {
    pub fn of(tri: &Triangle) -> Part {
        let mut v = [DVec3::ZERO; MAX_VERTS];
        for (p, q) in v.iter_mut().zip(tri.v) {
            *p = q.as_dvec3();
        }
        Part::new(v, 3)
    }

    fn new(v: [DVec3; MAX_VERTS], n: usize) -> Part {
        let (mut lo, mut hi) = (v[0], v[0]);
        for p in &v[1..n] {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        // Half the length of Σ (v_i − v_0) × (v_(i+1) − v_0).
        let mut normal = DVec3::ZERO;
        for i in 1..n - 1 {
            normal += (v[i] - v[0]).cross(v[i + 1] - v[0]);
        }
        Part {
            v,
            n,
            lo,
            hi,
            area: 0.5 * normal.length(),
            normal,
        }
    }

    /// The part carried by `map` (an instance's world → object map, say).
    pub fn mapped(&self, map: impl Fn(DVec3) -> DVec3) -> Part {
        let mut v = self.v;
        for p in &mut v[..self.n] {
            *p = map(*p);
        }
        Part::new(v, self.n)
    }

    #[inline(always)]
    pub fn against(&self, min: &[f64; 3], max: &[f64; 3]) -> Against {
        let (min, max) = (DVec3::from(*min), DVec3::from(*max));
        if self.lo.cmpgt(max).any() || self.hi.cmplt(min).any() {
            Against::Outside
        } else if self.lo.cmpge(min).all() && self.hi.cmple(max).all() {
            Against::Inside
        } else {
            Against::Crossing
        }
    }

    /// The part inside the closed box [min, max] (Sutherland–Hodgman, one face plane after
    /// another, only the planes the part crosses); `None` if nothing of it with an area is.
    #[inline(never)]
    pub fn clipped(&self, min: &[f64; 3], max: &[f64; 3]) -> Option<Part> {
        let mut buffers = [self.v, [DVec3::ZERO; MAX_VERTS]];
        let (mut from, mut n) = (0, self.n);
        for axis in 0..3 {
            for (c, above) in [(min[axis], true), (max[axis], false)] {
                if (above && self.lo[axis] >= c) || (!above && self.hi[axis] <= c) {
                    continue;
                }
                // Signed distance into the kept side: ≥ 0 is inside.
                let into = |p: &DVec3| if above { p[axis] - c } else { c - p[axis] };
                let [a_buf, b_buf] = &mut buffers;
                let (src, dst) = if from == 0 {
                    (a_buf, b_buf)
                } else {
                    (b_buf, a_buf)
                };
                let mut m = 0;
                let (mut a, mut a_in) = (src[n - 1], into(&src[n - 1]) >= 0.0);
                for &b in &src[..n] {
                    let b_in = into(&b) >= 0.0;
                    if a_in != b_in && m < MAX_VERTS {
                        let s = (c - a[axis]) / (b[axis] - a[axis]);
                        dst[m] = a + (b - a) * s;
                        dst[m][axis] = c;
                        m += 1;
                    }
                    if b_in && m < MAX_VERTS {
                        dst[m] = b;
                        m += 1;
                    }
                    (a, a_in) = (b, b_in);
                }
                from = 1 - from;
                n = m;
                if n < 3 {
                    return None;
                }
            }
        }
        let part = Part::new(buffers[from], n);
        (part.area > 0.0).then_some(part)
    }
}
