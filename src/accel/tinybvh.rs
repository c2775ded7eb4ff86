//! tinybvh's BVH8_CPU as a peer structure, for side-by-side benchmarks on the same rays and
//! threads (`bvhlab bench --tinybvh`). Built only with the `tinybvh` feature, which
//! compiles the header in peers/tinybvh through a small C interface (`shim.cpp`).
//!
//! It answers the same `Accel` queries as bvhlab's own structures, one ray at a time (its
//! CPU layout has no packet query). It uses its own ray–triangle test (not watertight)
//! whatever intersector is asked for and counts nothing; the benchmark reports how many
//! primary hits differ from bvhlab's.

use super::{Accel, Hit, Stats};
use crate::geometry::{Intersector, Ray, Triangle};
use std::ffi::c_void;
use std::time::{Duration, Instant};

unsafe extern "C" {
    fn bvhlab_tinybvh_build(triangles: *const f32, count: u32, hq: i32) -> *mut c_void;
    fn bvhlab_tinybvh_intersect(
        peer: *const c_void,
        ray: *const f32,
        t: *mut f32,
        u: *mut f32,
        v: *mut f32,
        prim: *mut u32,
    ) -> i32;
    fn bvhlab_tinybvh_occluded(peer: *const c_void, ray: *const f32) -> i32;
    fn bvhlab_tinybvh_free(peer: *mut c_void);
}

/// Which of tinybvh's builds makes the BVH8_CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TinyBuild {
    /// Its default build (binned SAH, AVX), then the conversion to BVH8_CPU.
    Default,
    /// Its high-quality build (SBVH, spatial splits), then the conversion.
    Hq,
}

impl TinyBuild {
    pub fn name(self) -> &'static str {
        match self {
            TinyBuild::Default => "tinybvh BVH8_CPU (default build)",
            TinyBuild::Hq => "tinybvh BVH8_CPU (BuildHQ: SBVH)",
        }
    }
}

/// A BVH8_CPU over a triangle soup.
pub struct TinyBvh {
    peer: *mut c_void,
    pub build_time: Duration,
}

// SAFETY: after the build the structure is only read; tinybvh's queries take it const.
unsafe impl Send for TinyBvh {}
unsafe impl Sync for TinyBvh {}

impl TinyBvh {
    pub fn build(triangles: &[Triangle], build: TinyBuild) -> Result<Self, String> {
        let count = u32::try_from(triangles.len())
            .map_err(|_| format!("tinybvh: {} triangles are too many", triangles.len()))?;
        if count == 0 {
            return Err("tinybvh: the scene has no triangles".into());
        }
        let flat: Vec<f32> = triangles
            .iter()
            .flat_map(|t| t.v.iter().flat_map(|p| p.to_array()))
            .collect();
        let start = Instant::now();
        // SAFETY: `flat` holds 9 floats per triangle; the shim copies them.
        let peer = unsafe {
            bvhlab_tinybvh_build(flat.as_ptr(), count, i32::from(build == TinyBuild::Hq))
        };
        let build_time = start.elapsed();
        if peer.is_null() {
            return Err("tinybvh: its header was compiled without AVX2".into());
        }
        Ok(TinyBvh { peer, build_time })
    }

    fn ray(ray: &Ray) -> [f32; 8] {
        let (o, d) = (ray.origin, ray.direction);
        [o.x, o.y, o.z, d.x, d.y, d.z, ray.tmin, ray.tmax]
    }
}

impl Drop for TinyBvh {
    fn drop(&mut self) {
        // SAFETY: the handle came from the shim's build and is freed once.
        unsafe { bvhlab_tinybvh_free(self.peer) };
    }
}

impl Accel for TinyBvh {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, _: &mut S) -> Option<Hit> {
        let r = Self::ray(ray);
        let (mut t, mut u, mut v, mut prim) = (0.0, 0.0, 0.0, 0u32);
        // SAFETY: the peer lives as long as self; the outputs are written before returning.
        let hit = unsafe {
            bvhlab_tinybvh_intersect(self.peer, r.as_ptr(), &mut t, &mut u, &mut v, &mut prim)
        };
        (hit != 0).then_some(Hit {
            t,
            u,
            v,
            triangle: u64::from(prim),
        })
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, _: &mut S) -> bool {
        let r = Self::ray(ray);
        // SAFETY: as above.
        unsafe { bvhlab_tinybvh_occluded(self.peer, r.as_ptr()) != 0 }
    }
}
