//! Shared helpers for bvhlab's integration tests: a seeded generator, random scenes and rays,
//! the hit comparison used against brute force, and temporary directories that go with the
//! test.

pub mod app;
pub mod gltf;
pub mod instanced;
pub mod lattice;
mod temp;

pub use temp::TempDir;

use bvhlab::accel::{Accel, Counters, Hit, NoStats};
use bvhlab::geometry::{Aabb, Ray, Triangle, Watertight};
use glam::Vec3;

/// A SplitMix64 stream (`bvhlab::random`): small, seeded, good enough for test inputs.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        let out = bvhlab::random::splitmix64(self.0);
        self.0 = self.0.wrapping_add(bvhlab::random::GOLDEN);
        out
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub fn vec3_in(&mut self, b: &Aabb) -> Vec3 {
        Vec3::new(
            self.range(b.min.x, b.max.x),
            self.range(b.min.y, b.max.y),
            self.range(b.min.z, b.max.z),
        )
    }

    pub fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// `n` random triangles of random size inside the unit cube.
pub fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let s = rng.range(0.005, 0.15);
            Triangle::new(
                c + rng.unit_vector() * s,
                c + rng.unit_vector() * s,
                c + rng.unit_vector() * s,
            )
        })
        .collect()
}

/// A mix of rays for a scene with bounds `b`: from outside aimed at points inside, from
/// inside in random directions, axis-parallel rays (with ±0 components), and rays that
/// miss everything.
pub fn rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let size = b.diagonal().max(1e-3);
    let center = b.center();
    (0..n)
        .map(|i| match i % 5 {
            0 => {
                let target = rng.vec3_in(b);
                let origin = center + rng.unit_vector() * size * 1.5;
                Ray::new(origin, target - origin)
            }
            1 => Ray::new(rng.vec3_in(b), rng.unit_vector()),
            2 => {
                let mut d = Vec3::ZERO;
                let axis = rng.below(3);
                d[axis] = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                // Signed zeros in the other components.
                for k in 0..3 {
                    if k != axis && rng.f32() < 0.5 {
                        d[k] = -0.0;
                    }
                }
                Ray::new(rng.vec3_in(b), d)
            }
            3 => {
                let origin = center + rng.unit_vector() * size * 2.0;
                Ray::new(
                    origin,
                    (origin - center).normalize() + rng.unit_vector() * 0.1,
                )
            }
            _ => {
                let origin = rng.vec3_in(b);
                let d = rng.unit_vector();
                Ray::segment(origin, d, 0.0, rng.range(0.0, size * 0.5))
            }
        })
        .collect()
}

/// One ray through the centre of every pixel of the scene's own view at `w` × `h`, row by
/// row, as the renderer casts them.
pub fn view_rays(scene: &bvhlab::scene::Scene, w: u32, h: u32) -> Vec<Ray> {
    let cam = scene.camera().rays(w, h);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_center(x, y))
        .collect()
}

/// The built-in scenes at sizes a test traces quickly against brute force.
pub const SMALL_BUILTINS: &[&str] = &[
    "cornell",
    "teapot-in-stadium",
    "grass:2000",
    "walls",
    "walls-rotated",
    "same-centroid:1500",
    "same-bbox:1500",
    "soup:3000",
    "sphere:3000",
];

/// Hits agree exactly: the same triangle at the same distance. Every structure keeps the
/// lowest triangle index among hits at equal distance, so even ties must agree.
pub fn same_hit(a: Option<Hit>, b: Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(x), Some(y)) => x.triangle == y.triangle && x.t.to_bits() == y.t.to_bits(),
        _ => false,
    }
}

/// A mailboxed structure's closest and any hits equal `expected` (brute force's) on
/// `rays`, counting changes no hit, and with the mailbox on no test is counted as repeated.
pub fn assert_mailboxed_hits<A: Accel>(
    accel: &A,
    rays: &[Ray],
    expected: &[Option<Hit>],
    mailbox: bool,
    what: &str,
) {
    for (i, (ray, want)) in rays.iter().zip(expected).enumerate() {
        let got = accel.closest_hit::<Watertight, _>(ray, &mut NoStats);
        assert!(
            same_hit(got, *want),
            "{what} mailbox={mailbox}: ray {i} {ray:?}: {got:?}, brute force {want:?}"
        );
        let mut c = Counters::default();
        let counted = accel.closest_hit::<Watertight, _>(ray, &mut c);
        assert!(same_hit(got, counted), "{what}: counting changed ray {i}");
        if mailbox {
            assert_eq!(c.repeated_tests, 0, "{what}: ray {i}");
        }
        assert_eq!(
            accel.any_hit::<Watertight, _>(ray, &mut NoStats),
            want.is_some(),
            "{what} mailbox={mailbox}: any hit of ray {i} {ray:?}"
        );
    }
}

/// Large triangles across the unit cube: each lies in many cells of a spatial structure.
pub fn large_triangles(n: usize, seed: u64) -> Vec<Triangle> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.f32(), rng.f32(), rng.f32());
            Triangle::new(
                c + rng.unit_vector() * 0.5,
                c + rng.unit_vector() * 0.5,
                c + rng.unit_vector() * 0.5,
            )
        })
        .collect()
}

/// The counters of a mailboxed structure's closest and any hits over `rays`, with the
/// mailbox on and then off (`set_mailbox`). Counting changes no hit; the mailbox changes no
/// node visited, and removes exactly the tests counted as repeated without it.
pub fn mailbox_totals<A: Accel>(
    accel: &mut A,
    set_mailbox: impl Fn(&mut A, bool),
    rays: &[Ray],
    what: &str,
) -> [Counters; 2] {
    let mut totals = [Counters::default(); 2];
    for (m, mailbox) in [true, false].into_iter().enumerate() {
        set_mailbox(accel, mailbox);
        for ray in rays {
            let mut c = Counters::default();
            let counted = accel.closest_hit::<Watertight, _>(ray, &mut c);
            let plain = accel.closest_hit::<Watertight, _>(ray, &mut NoStats);
            assert!(same_hit(counted, plain), "{what}: {ray:?}");
            let mut c2 = Counters::default();
            assert_eq!(
                accel.any_hit::<Watertight, _>(ray, &mut c2),
                accel.any_hit::<Watertight, _>(ray, &mut NoStats),
                "{what}: {ray:?}"
            );
            assert!(c.box_tests >= 1, "{what}: {ray:?}");
            totals[m] += c;
            totals[m] += c2;
        }
    }
    let [on, off] = totals;
    assert_eq!(on.repeated_tests, 0, "{what}");
    assert!(off.repeated_tests > 0, "{what}: {off:?}");
    assert_eq!(
        on.triangle_tests + off.repeated_tests,
        off.triangle_tests,
        "{what}"
    );
    assert_eq!(on.nodes_visited, off.nodes_visited, "{what}");
    totals
}

/// The directory of the shared reference scenes, if the environment provides it.
pub fn shared_scenes() -> Option<std::path::PathBuf> {
    let dir = std::path::PathBuf::from(std::env::var_os("BVHLAB_SCENES")?);
    dir.is_dir().then_some(dir)
}

/// Inputs that break naive builders: empty, single, identical, zero-area, collinear, flat,
/// exponentially spaced and huge-and-tiny triangles.
pub fn degenerate_cases() -> Vec<(&'static str, Vec<Triangle>)> {
    let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let mut rng = Rng::new(4);
    vec![
        ("empty", vec![]),
        ("one triangle", vec![t]),
        ("identical triangles", vec![t; 500]),
        (
            "zero-area points",
            (0..300)
                .map(|i| {
                    let p = Vec3::splat(i as f32 * 0.01);
                    Triangle::new(p, p, p)
                })
                .collect(),
        ),
        (
            "one point",
            vec![Triangle::new(Vec3::ONE, Vec3::ONE, Vec3::ONE); 100],
        ),
        (
            "collinear",
            (0..300)
                .map(|i| {
                    let x = i as f32;
                    Triangle::new(
                        Vec3::new(x, 0.0, 0.0),
                        Vec3::new(x + 0.5, 0.0, 0.0),
                        Vec3::new(x + 1.0, 0.0, 0.0),
                    )
                })
                .collect(),
        ),
        (
            "flat in z",
            (0..300)
                .map(|_| {
                    let c = Vec3::new(rng.f32(), rng.f32(), 0.0);
                    Triangle::new(c, c + Vec3::X * 0.1, c + Vec3::Y * 0.1)
                })
                .collect(),
        ),
        (
            "exponential spacing",
            (0..200)
                .map(|i| {
                    let x = 1.1f32.powi(i);
                    Triangle::new(
                        Vec3::new(x, 0.0, 0.0),
                        Vec3::new(x, 1.0, 0.0),
                        Vec3::new(x, 0.0, 1.0),
                    )
                })
                .collect(),
        ),
        (
            "huge and tiny",
            vec![
                Triangle::new(
                    Vec3::splat(-1e30),
                    Vec3::new(1e30, -1e30, 0.0),
                    Vec3::splat(1e30),
                ),
                Triangle::new(Vec3::ZERO, Vec3::splat(1e-30), Vec3::new(1e-30, 0.0, 0.0)),
                t,
            ],
        ),
    ]
}
