//! What a closest-hit query returns, and the one rule every structure uses to keep the
//! closest hit while it searches.

use crate::geometry::Ray;
use crate::geometry::intersect::TriangleHit;

/// The closest hit of a ray: distance, barycentrics and the scene's triangle index. The
/// index is 64-bit: an instanced scene places more triangles than 32 bits can number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub triangle: u64,
}

/// The closest hit so far. Of hits at the same distance the lowest triangle index wins, so
/// the answer does not depend on the order the triangles are tested in: brute force, a
/// tree front to back or in naive order, and a packet of rays all return the same hit.
#[derive(Clone, Copy, Debug)]
pub struct BestHit {
    /// The best distance so far (the ray's own end before the first hit).
    pub t: f32,
    /// Exclusive bound for the next triangle test: the ray's end before the first hit,
    /// just past the best distance after one, so that a tie can still be offered.
    pub limit: f32,
    hit: Option<Hit>,
}

impl BestHit {
    pub fn new(ray: &Ray) -> Self {
        BestHit {
            t: ray.tmax,
            limit: ray.tmax,
            hit: None,
        }
    }

    /// Keeps `h`, a hit on `triangle` found below `limit`, if it is closer than the best so
    /// far, or as close and on a lower-numbered triangle.
    #[inline(always)]
    pub fn offer(&mut self, h: TriangleHit, triangle: impl Into<u64>) {
        let triangle = triangle.into();
        if let Some(b) = self.hit {
            // An intersector that decides in higher precision may round a hit just below
            // the limit up to it: such a hit is farther, not a tie.
            if h.t > b.t || (h.t == b.t && triangle > b.triangle) {
                return;
            }
        }
        self.t = h.t;
        self.limit = h.t.next_up();
        self.hit = Some(Hit {
            t: h.t,
            u: h.u,
            v: h.v,
            triangle,
        });
    }

    pub fn hit(&self) -> Option<Hit> {
        self.hit
    }
}
