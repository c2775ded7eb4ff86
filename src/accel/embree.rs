//! Embree 3 as a peer structure, for side-by-side benchmarks on the same rays and threads
//! (`bvhlab bench --embree`). Built only with the `embree` feature, which links the system's
//! libembree3 (Debian: `apt-get install libembree-dev`).
//!
//! It answers the same `Accel` queries as bvhlab's own structures. Embree uses its own
//! ray–triangle test whatever intersector is asked for, counts nothing, and accepts hits
//! with t in the closed interval [tmin, tmax]; on the standard ray sets its hits agree with
//! bvhlab's apart from ties and edge hits (the benchmark reports how many differ).

use super::{Accel, Hit, Stats};
use crate::geometry::{Intersector, Ray, Triangle};
use crate::scene::instance::Instancing;
use std::ffi::{c_char, c_uint, c_void};
use std::time::{Duration, Instant};

/// The subset of Embree 3's C API (rtcore.h) the benchmark uses.
mod ffi {
    use super::*;

    pub type Device = *mut c_void;
    pub type Scene = *mut c_void;
    pub type Geometry = *mut c_void;

    pub const GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
    pub const GEOMETRY_TYPE_INSTANCE: c_uint = 121;
    pub const BUFFER_TYPE_INDEX: c_uint = 0;
    pub const BUFFER_TYPE_VERTEX: c_uint = 1;
    pub const FORMAT_UINT3: c_uint = 0x5003;
    pub const FORMAT_FLOAT3: c_uint = 0x9003;
    pub const FORMAT_FLOAT3X4_COLUMN_MAJOR: c_uint = 0x9234;
    pub const BUILD_QUALITY_MEDIUM: c_uint = 1;
    pub const SCENE_FLAG_ROBUST: c_uint = 1 << 2;
    pub const INVALID_GEOMETRY_ID: c_uint = u32::MAX;
    pub const CONTEXT_FLAG_INCOHERENT: c_uint = 0;
    pub const CONTEXT_FLAG_COHERENT: c_uint = 1;

    /// RTCIntersectContext with RTC_MAX_INSTANCE_LEVEL_COUNT = 1 and no minimum width, as
    /// Debian's libembree3 is configured (rtcore_config.h).
    #[repr(C)]
    pub struct IntersectContext {
        pub flags: c_uint,
        pub filter: *const c_void,
        pub inst_id: [c_uint; 1],
    }

    #[repr(C, align(16))]
    #[derive(Clone, Copy)]
    pub struct Ray1 {
        pub org: [f32; 3],
        pub tnear: f32,
        pub dir: [f32; 3],
        pub time: f32,
        pub tfar: f32,
        pub mask: c_uint,
        pub id: c_uint,
        pub flags: c_uint,
    }

    #[repr(C, align(16))]
    #[derive(Clone, Copy)]
    pub struct Hit1 {
        pub ng: [f32; 3],
        pub u: f32,
        pub v: f32,
        pub prim_id: c_uint,
        pub geom_id: c_uint,
        pub inst_id: [c_uint; 1],
    }

    #[repr(C)]
    #[derive(Clone, Copy)]
    pub struct RayHit1 {
        pub ray: Ray1,
        pub hit: Hit1,
    }

    #[repr(C, align(64))]
    pub struct Ray16 {
        pub org_x: [f32; 16],
        pub org_y: [f32; 16],
        pub org_z: [f32; 16],
        pub tnear: [f32; 16],
        pub dir_x: [f32; 16],
        pub dir_y: [f32; 16],
        pub dir_z: [f32; 16],
        pub time: [f32; 16],
        pub tfar: [f32; 16],
        pub mask: [c_uint; 16],
        pub id: [c_uint; 16],
        pub flags: [c_uint; 16],
    }

    #[repr(C, align(64))]
    pub struct Hit16 {
        pub ng_x: [f32; 16],
        pub ng_y: [f32; 16],
        pub ng_z: [f32; 16],
        pub u: [f32; 16],
        pub v: [f32; 16],
        pub prim_id: [c_uint; 16],
        pub geom_id: [c_uint; 16],
        pub inst_id: [[c_uint; 16]; 1],
    }

    #[repr(C)]
    pub struct RayHit16 {
        pub ray: Ray16,
        pub hit: Hit16,
    }

    #[link(name = "embree3")]
    unsafe extern "C" {
        pub fn rtcNewDevice(config: *const c_char) -> Device;
        pub fn rtcReleaseDevice(device: Device);
        pub fn rtcGetDeviceError(device: Device) -> c_uint;
        pub fn rtcNewScene(device: Device) -> Scene;
        pub fn rtcSetSceneBuildQuality(scene: Scene, quality: c_uint);
        pub fn rtcSetGeometryBuildQuality(geometry: Geometry, quality: c_uint);
        pub fn rtcSetSceneFlags(scene: Scene, flags: c_uint);
        pub fn rtcReleaseScene(scene: Scene);
        pub fn rtcNewGeometry(device: Device, kind: c_uint) -> Geometry;
        pub fn rtcSetNewGeometryBuffer(
            geometry: Geometry,
            kind: c_uint,
            slot: c_uint,
            format: c_uint,
            byte_stride: usize,
            item_count: usize,
        ) -> *mut c_void;
        pub fn rtcSetGeometryInstancedScene(geometry: Geometry, scene: Scene);
        pub fn rtcSetGeometryTransform(
            geometry: Geometry,
            time_step: c_uint,
            format: c_uint,
            transform: *const c_void,
        );
        pub fn rtcCommitGeometry(geometry: Geometry);
        pub fn rtcGetGeometry(scene: Scene, geom_id: c_uint) -> Geometry;
        pub fn rtcUpdateGeometryBuffer(geometry: Geometry, kind: c_uint, slot: c_uint);
        pub fn rtcAttachGeometry(scene: Scene, geometry: Geometry) -> c_uint;
        pub fn rtcReleaseGeometry(geometry: Geometry);
        pub fn rtcCommitScene(scene: Scene);
        pub fn rtcIntersect1(scene: Scene, context: *mut IntersectContext, rayhit: *mut RayHit1);
        pub fn rtcIntersect16(
            valid: *const i32,
            scene: Scene,
            context: *mut IntersectContext,
            rayhit: *mut RayHit16,
        );
        pub fn rtcOccluded1(scene: Scene, context: *mut IntersectContext, ray: *mut Ray1);
    }
}

/// How Embree builds and traces: its defaults, or with `RTC_SCENE_FLAG_ROBUST`, which
/// "avoids optimizations that reduce arithmetic accuracy" (rtcSetSceneFlags(3)): the
/// structures and tests Embree offers against rays slipping through shared edges, the
/// guarantee bvhlab's watertight test gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmbreeMode {
    Default,
    Robust,
}

impl EmbreeMode {
    /// The peer's name in the benchmark's tables.
    pub fn name(self, instanced: bool) -> &'static str {
        match (self, instanced) {
            (EmbreeMode::Default, false) => "Embree 3",
            (EmbreeMode::Default, true) => "Embree 3, instanced",
            (EmbreeMode::Robust, false) => "Embree 3 robust",
            (EmbreeMode::Robust, true) => "Embree 3 robust, instanced",
        }
    }
}

/// An Embree device and scene over a copy of the triangles, built with Embree's default
/// (medium quality) BVH; for an instanced scene, Embree's own two levels: a scene per unique
/// mesh and a top-level scene of instance geometries.
pub struct Embree {
    device: ffi::Device,
    scene: ffi::Scene,
    mode: EmbreeMode,
    /// Its builder, as `RTCBuildQuality`: low (0, a Morton builder per mesh under a top
    /// level), medium (1, the default binned SAH) or high (2, with spatial splits).
    quality: c_uint,
    /// The unique meshes' scenes of an instanced build (empty for one flattened mesh).
    meshes: Vec<ffi::Scene>,
    /// The flattened number of each instance's first triangle, so that a hit names the
    /// same triangle as bvhlab's two levels do (empty for one flattened mesh).
    first_triangle: Vec<u64>,
    /// How long the build took: filling Embree's buffers and committing the scene.
    pub build_time: Duration,
    /// Of an instanced build, the top level's commit alone (its instances' scenes already
    /// committed): what rebuilding the top level after instances moved costs.
    pub top_level_time: Option<Duration>,
}

// Embree's scene is immutable after commit, and its queries are thread-safe.
unsafe impl Send for Embree {}
unsafe impl Sync for Embree {}

impl Embree {
    /// An empty device and top-level scene with `threads` build threads.
    fn device(threads: usize, mode: EmbreeMode, quality: c_uint) -> Result<Self, String> {
        let config = format!("threads={threads}\0");
        // SAFETY: a plain call with a NUL-terminated configuration string.
        let device = unsafe { ffi::rtcNewDevice(config.as_ptr().cast()) };
        if device.is_null() {
            return Err("Embree: rtcNewDevice failed".into());
        }
        // SAFETY: the device was checked above; the scene is released in `Drop`.
        let scene = unsafe { ffi::rtcNewScene(device) };
        Ok(Embree {
            device,
            scene,
            mode,
            quality,
            meshes: Vec::new(),
            first_triangle: Vec::new(),
            build_time: Duration::ZERO,
            top_level_time: None,
        })
    }

    /// Builds the scene with `threads` build threads; an error if Embree refuses.
    pub fn build(triangles: &[Triangle], threads: usize, mode: EmbreeMode) -> Result<Self, String> {
        Self::build_at(triangles, threads, mode, ffi::BUILD_QUALITY_MEDIUM)
    }

    /// `build` with the builder `quality` names (`RTCBuildQuality`: 0 low, 1 medium, 2 high).
    pub fn build_at(
        triangles: &[Triangle],
        threads: usize,
        mode: EmbreeMode,
        quality: c_uint,
    ) -> Result<Self, String> {
        let mut this = Self::device(threads, mode, quality)?;
        let start = Instant::now();
        this.commit_mesh(this.scene, triangles)?;
        this.build_time = start.elapsed();
        this.check("the build")?;
        Ok(this)
    }

    /// Builds Embree's two levels over the same meshes and instances as bvhlab's
    /// (`Instancing`): one scene per unique mesh, committed once, and a top-level scene with
    /// an instance geometry per instance, whose id is the instance's index.
    pub fn build_instanced(
        scene: &Instancing,
        threads: usize,
        mode: EmbreeMode,
    ) -> Result<Self, String> {
        Self::build_instanced_at(scene, threads, mode, ffi::BUILD_QUALITY_MEDIUM)
    }

    /// `build_instanced` with the meshes built at `quality` (`RTCBuildQuality`).
    pub fn build_instanced_at(
        scene: &Instancing,
        threads: usize,
        mode: EmbreeMode,
        quality: c_uint,
    ) -> Result<Self, String> {
        let mut this = Self::device(threads, mode, quality)?;
        let start = Instant::now();
        for mesh in &scene.meshes {
            // SAFETY: the device is live; the scene is kept in `meshes` and released in `Drop`.
            let s = unsafe { ffi::rtcNewScene(this.device) };
            this.meshes.push(s);
            this.commit_mesh(s, mesh)?;
        }
        let mut first = 0u64;
        for (i, instance) in scene.instances.iter().enumerate() {
            let Some(&mesh) = this.meshes.get(instance.mesh) else {
                return Err(format!("Embree: instance {i} names no mesh"));
            };
            // Columns x, y, z and the translation: Embree's FLOAT3X4_COLUMN_MAJOR.
            let transform = instance.transform.to_cols_array();
            // SAFETY: the geometry is checked before use and released after attaching (the
            // scene holds its own reference); the transform is read during the call.
            let id = unsafe {
                let g = ffi::rtcNewGeometry(this.device, ffi::GEOMETRY_TYPE_INSTANCE);
                if g.is_null() {
                    return Err(format!("Embree: no instance geometry for instance {i}"));
                }
                ffi::rtcSetGeometryInstancedScene(g, mesh);
                ffi::rtcSetGeometryTransform(
                    g,
                    0,
                    ffi::FORMAT_FLOAT3X4_COLUMN_MAJOR,
                    transform.as_ptr().cast(),
                );
                ffi::rtcCommitGeometry(g);
                let id = ffi::rtcAttachGeometry(this.scene, g);
                ffi::rtcReleaseGeometry(g);
                id
            };
            if id as usize != i {
                return Err(format!("Embree: instance {i} was given the id {id}"));
            }
            this.first_triangle.push(first);
            first += scene.meshes[instance.mesh].len() as u64;
        }
        let top = Instant::now();
        // SAFETY: the top-level scene is live; its instances' scenes are committed.
        unsafe {
            // The top level at the meshes' quality: low is Embree's builder for scenes
            // rebuilt every frame.
            ffi::rtcSetSceneBuildQuality(this.scene, this.quality);
            this.set_flags(this.scene);
            ffi::rtcCommitScene(this.scene);
        }
        this.top_level_time = Some(top.elapsed());
        this.build_time = start.elapsed();
        this.check("the instanced build")?;
        Ok(this)
    }

    /// Puts `triangles` into `scene` as one triangle geometry and commits it (an empty mesh
    /// stays an empty scene).
    fn commit_mesh(&self, scene: ffi::Scene, triangles: &[Triangle]) -> Result<(), String> {
        let n = triangles.len();
        // SAFETY: plain calls into Embree's C API with valid pointers and the sizes given;
        // each returned handle is checked before use.
        unsafe {
            // Embree heeds a mesh's quality only under a scene of low quality, where each
            // mesh gets a BVH of its own (its Morton builder at low quality).
            ffi::rtcSetSceneBuildQuality(scene, self.quality);
            self.set_flags(scene);
            if n > 0 {
                let geometry = ffi::rtcNewGeometry(self.device, ffi::GEOMETRY_TYPE_TRIANGLE);
                ffi::rtcSetGeometryBuildQuality(geometry, self.quality);
                let vertices = ffi::rtcSetNewGeometryBuffer(
                    geometry,
                    ffi::BUFFER_TYPE_VERTEX,
                    0,
                    ffi::FORMAT_FLOAT3,
                    12,
                    3 * n,
                ) as *mut f32;
                let indices = ffi::rtcSetNewGeometryBuffer(
                    geometry,
                    ffi::BUFFER_TYPE_INDEX,
                    0,
                    ffi::FORMAT_UINT3,
                    12,
                    n,
                ) as *mut u32;
                if vertices.is_null() || indices.is_null() {
                    ffi::rtcReleaseGeometry(geometry);
                    return Err(format!(
                        "Embree: no buffers for {n} triangles (error {})",
                        ffi::rtcGetDeviceError(self.device)
                    ));
                }
                let vertices = std::slice::from_raw_parts_mut(vertices, 9 * n);
                let indices = std::slice::from_raw_parts_mut(indices, 3 * n);
                for (i, tri) in triangles.iter().enumerate() {
                    for (k, v) in tri.v.iter().enumerate() {
                        vertices[9 * i + 3 * k..9 * i + 3 * k + 3].copy_from_slice(&v.to_array());
                        indices[3 * i + k] = (3 * i + k) as u32;
                    }
                }
                ffi::rtcCommitGeometry(geometry);
                ffi::rtcAttachGeometry(scene, geometry);
                ffi::rtcReleaseGeometry(geometry);
            }
            ffi::rtcCommitScene(scene);
        }
        self.check("a mesh's build")
    }

    /// Rebuilds a flattened scene as a scene that moved is rebuilt every frame: its
    /// vertices marked changed (`rtcUpdateGeometryBuffer`) and the mesh and scene committed
    /// again, into the memory Embree kept from the build before. Returns how long that
    /// took; `None` for two levels or an empty scene.
    pub fn rebuild(&mut self) -> Result<Option<Duration>, String> {
        if !self.meshes.is_empty() {
            return Ok(None);
        }
        // SAFETY: the scene is live and committed; geometry 0, where there is one, is the
        // mesh `commit_mesh` attached, and its vertex buffer is slot 0.
        let took = unsafe {
            let geometry = ffi::rtcGetGeometry(self.scene, 0);
            if geometry.is_null() {
                return Ok(None);
            }
            let start = Instant::now();
            ffi::rtcUpdateGeometryBuffer(geometry, ffi::BUFFER_TYPE_VERTEX, 0);
            ffi::rtcCommitGeometry(geometry);
            ffi::rtcCommitScene(self.scene);
            start.elapsed()
        };
        self.check("the rebuild")?;
        Ok(Some(took))
    }

    /// Sets the scene flags of this mode on `scene`, before its commit.
    ///
    /// # Safety
    /// `scene` is a live scene of this device.
    unsafe fn set_flags(&self, scene: ffi::Scene) {
        if self.mode == EmbreeMode::Robust {
            // SAFETY: the caller guarantees a live scene.
            unsafe { ffi::rtcSetSceneFlags(scene, ffi::SCENE_FLAG_ROBUST) };
        }
    }

    /// An error naming `what` if Embree reports one.
    fn check(&self, what: &str) -> Result<(), String> {
        // SAFETY: the device is live.
        match unsafe { ffi::rtcGetDeviceError(self.device) } {
            0 => Ok(()),
            e => Err(format!("Embree: {what} failed (error {e})")),
        }
    }

    /// The flattened triangle number of Embree's hit on `prim` of instance `instance`.
    fn triangle(&self, instance: c_uint, prim: c_uint) -> u64 {
        match self.first_triangle.get(instance as usize) {
            Some(&first) => first + u64::from(prim),
            None => u64::from(prim),
        }
    }

    fn context(flags: c_uint) -> ffi::IntersectContext {
        ffi::IntersectContext {
            flags,
            filter: std::ptr::null(),
            inst_id: [ffi::INVALID_GEOMETRY_ID],
        }
    }

    fn ray1(ray: &Ray) -> ffi::Ray1 {
        ffi::Ray1 {
            org: ray.origin.to_array(),
            tnear: ray.tmin,
            dir: ray.direction.to_array(),
            time: 0.0,
            tfar: ray.tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// Closest hits of up to 16 coherent rays through Embree's packet query.
    fn intersect16(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        let mut valid = [0i32; 16];
        // SAFETY: RayHit16 is plain old data; all zeros is a valid value.
        let mut rh: ffi::RayHit16 = unsafe { std::mem::zeroed() };
        for (i, r) in rays.iter().enumerate().take(16) {
            valid[i] = -1;
            let ray = &mut rh.ray;
            (ray.org_x[i], ray.org_y[i], ray.org_z[i]) = (r.origin.x, r.origin.y, r.origin.z);
            let d = r.direction;
            (ray.dir_x[i], ray.dir_y[i], ray.dir_z[i]) = (d.x, d.y, d.z);
            (ray.tnear[i], ray.tfar[i], ray.mask[i]) = (r.tmin, r.tmax, u32::MAX);
            rh.hit.geom_id[i] = ffi::INVALID_GEOMETRY_ID;
        }
        let mut ctx = Self::context(ffi::CONTEXT_FLAG_COHERENT);
        // SAFETY: valid, context and the 64-byte-aligned packet outlive the call.
        unsafe { ffi::rtcIntersect16(valid.as_ptr(), self.scene, &mut ctx, &mut rh) };
        for (i, h) in hits.iter_mut().enumerate().take(rays.len().min(16)) {
            *h = (rh.hit.geom_id[i] != ffi::INVALID_GEOMETRY_ID).then(|| Hit {
                t: rh.ray.tfar[i],
                u: rh.hit.u[i],
                v: rh.hit.v[i],
                triangle: self.triangle(rh.hit.inst_id[0][i], rh.hit.prim_id[i]),
            });
        }
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: the handles came from Embree and are released once.
        unsafe {
            ffi::rtcReleaseScene(self.scene);
            for &mesh in &self.meshes {
                ffi::rtcReleaseScene(mesh);
            }
            ffi::rtcReleaseDevice(self.device);
        }
    }
}

impl Accel for Embree {
    fn closest_hit<I: Intersector, S: Stats>(&self, ray: &Ray, _: &mut S) -> Option<Hit> {
        let mut rh = ffi::RayHit1 {
            ray: Self::ray1(ray),
            hit: ffi::Hit1 {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: ffi::INVALID_GEOMETRY_ID,
                geom_id: ffi::INVALID_GEOMETRY_ID,
                inst_id: [ffi::INVALID_GEOMETRY_ID],
            },
        };
        let mut ctx = Self::context(ffi::CONTEXT_FLAG_INCOHERENT);
        // SAFETY: the context and ray-hit structure outlive the call.
        unsafe { ffi::rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geom_id != ffi::INVALID_GEOMETRY_ID).then_some(Hit {
            t: rh.ray.tfar,
            u: rh.hit.u,
            v: rh.hit.v,
            triangle: self.triangle(rh.hit.inst_id[0], rh.hit.prim_id),
        })
    }

    fn any_hit<I: Intersector, S: Stats>(&self, ray: &Ray, _: &mut S) -> bool {
        let mut r = Self::ray1(ray);
        let mut ctx = Self::context(ffi::CONTEXT_FLAG_INCOHERENT);
        // SAFETY: the context and ray outlive the call.
        unsafe { ffi::rtcOccluded1(self.scene, &mut ctx, &mut r) };
        // Embree marks an occluded ray by setting tfar to −∞.
        r.tfar == f32::NEG_INFINITY
    }

    fn closest_hits<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (rays, hits) in rays.chunks(16).zip(hits.chunks_mut(16)) {
            self.intersect16(rays, hits);
        }
    }
}
