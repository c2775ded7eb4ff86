//! The two questions a ray asks a structure: which triangle it meets first (the closest
//! hit, for camera and diffuse rays) and whether it meets any before its end (any hit, for
//! shadow rays). A structure's walk is written once over `Query`: the closest hit narrows
//! the walk as hits come in, any hit ends it at the first.

use super::{BestHit, Hit};
use crate::geometry::Ray;
use crate::geometry::intersect::TriangleHit;

pub trait Query {
    type Answer;

    fn new(ray: &Ray) -> Self;

    /// The exclusive far bound of the next triangle test.
    fn limit(&self) -> f32;

    /// Takes a hit on `triangle` found below `limit`; whether the walk is over.
    fn offer(&mut self, hit: TriangleHit, triangle: u32) -> bool;

    /// The distance of the best hit so far, if there is one: a cell or node entered beyond
    /// it cannot change the answer.
    fn found(&self) -> Option<f32>;

    /// How far the walk must look: the best distance so far (the ray's end before a hit)
    /// for the closest hit; unbounded for any hit, whose triangle tests stop at the ray's
    /// end and whose walk ends at its first hit.
    fn reach(&self) -> f32;

    fn answer(self) -> Self::Answer;
}

/// The closest hit, the lowest triangle index on equal t (`BestHit`).
pub struct Closest(BestHit);

impl Query for Closest {
    type Answer = Option<Hit>;

    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        Closest(BestHit::new(ray))
    }

    #[inline(always)]
    fn limit(&self) -> f32 {
        self.0.limit
    }

    #[inline(always)]
    fn offer(&mut self, hit: TriangleHit, triangle: u32) -> bool {
        self.0.offer(hit, triangle);
        false
    }

    #[inline(always)]
    fn found(&self) -> Option<f32> {
        self.0.hit().map(|_| self.0.t)
    }

    #[inline(always)]
    fn reach(&self) -> f32 {
        self.0.t
    }

    #[inline(always)]
    fn answer(self) -> Option<Hit> {
        self.0.hit()
    }
}

/// Whether anything is hit within the ray's interval.
pub struct AnyHit {
    tmax: f32,
    hit: bool,
}

impl Query for AnyHit {
    type Answer = bool;

    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        AnyHit {
            tmax: ray.tmax,
            hit: false,
        }
    }

    #[inline(always)]
    fn limit(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn offer(&mut self, _: TriangleHit, _: u32) -> bool {
        self.hit = true;
        true
    }

    #[inline(always)]
    fn found(&self) -> Option<f32> {
        None
    }

    #[inline(always)]
    fn reach(&self) -> f32 {
        f32::INFINITY
    }

    #[inline(always)]
    fn answer(self) -> bool {
        self.hit
    }
}
