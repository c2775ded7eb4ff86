//! The slab test as the lecture states it, step by step: a box is three slabs (the space
//! between two parallel planes per axis); the ray's interval inside each is [t_near, t_far],
//! and the ray meets the box over the intersection of the three and its own [tmin, tmax]:
//! a hit if that is not empty. The traversal kernels compute the same with fewer steps; this
//! keeps every interval for the replay's picture.

use super::{Aabb, Ray};

/// The ray's interval in each slab of a box, and their intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slabs {
    /// [t_near, t_far] per axis (±∞ for a ray parallel to a slab it starts in; an empty
    /// interval, near > far, for one parallel to a slab it starts outside).
    pub axes: [(f32, f32); 3],
    /// The largest near and the smallest far, clipped to the ray's [tmin, tmax].
    pub enter: f32,
    pub exit: f32,
}

impl Slabs {
    pub fn of(ray: &Ray, bounds: &Aabb) -> Self {
        let mut axes = [(0.0, 0.0); 3];
        for (a, interval) in axes.iter_mut().enumerate() {
            let (o, d) = (ray.origin[a], ray.direction[a]);
            let (lo, hi) = (bounds.min[a], bounds.max[a]);
            *interval = if d == 0.0 {
                if (lo..=hi).contains(&o) {
                    (f32::NEG_INFINITY, f32::INFINITY)
                } else {
                    (f32::INFINITY, f32::NEG_INFINITY)
                }
            } else {
                let (t1, t2) = ((lo - o) / d, (hi - o) / d);
                (t1.min(t2), t1.max(t2))
            };
        }
        let enter = axes.iter().fold(ray.tmin, |t, a| t.max(a.0));
        let exit = axes.iter().fold(ray.tmax, |t, a| t.min(a.1));
        Slabs { axes, enter, exit }
    }

    /// Whether the three intervals and the ray's overlap: the box is hit.
    pub fn hit(&self) -> bool {
        self.enter <= self.exit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_intervals_meet_for_a_hit_and_not_for_a_miss() {
        let unit = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let through = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let s = Slabs::of(&through, &unit);
        assert_eq!(s.axes[0], (1.0, 2.0));
        assert_eq!(
            s.axes[1],
            (f32::NEG_INFINITY, f32::INFINITY),
            "parallel, inside"
        );
        assert!(s.hit() && s.enter == 1.0 && s.exit == 2.0);
        // Past the corner: x's interval ends before y's begins.
        let past = Ray::new(Vec3::new(-1.0, -2.5, 0.5), Vec3::new(1.0, 1.0, 0.0));
        let s = Slabs::of(&past, &unit);
        assert!(s.axes[0].1 < s.axes[1].0 && !s.hit());
        // Parallel to a slab it starts outside of: that interval is empty.
        let beside = Ray::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::X);
        assert!(!Slabs::of(&beside, &unit).hit());
    }
}
