//! The SIMD kernels lane for lane against the scalar tests: slabs, triangles, the block
//! test's early exit.

use super::*;

/// Each kernel's lanes equal the scalar slab test on random boxes, flat boxes, boxes the
/// ray starts in, and axis-parallel rays with ±0 components lying in a box's face plane; the
/// fused form of the AVX-512 kernel equals its scalar form (`fused_entry`, with
/// `f32::mul_add`) on every ray it may test.
#[test]
fn every_slab_kernel_equals_the_scalar_slab_test() {
    fn check<const W: usize, K: WideSlab<W>>(level: SimdLevel, rng: &mut Rng)
    where
        Portable: WideSlab<W>,
    {
        if !level.supported() {
            return;
        }
        let unit = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        let mut fused = 0;
        for case in 0..20_000 {
            let mut boxes = [Aabb::EMPTY; W];
            for (i, b) in boxes.iter_mut().enumerate() {
                let (p, q) = (rng.vec3_in(&unit), rng.vec3_in(&unit));
                *b = match (case + i) % 4 {
                    // Flat in x: the ray may lie in its plane.
                    0 => Aabb::new(p.min(q).with_x(0.25), p.max(q).with_x(0.25)),
                    1 if i == W - 1 => Aabb::EMPTY,
                    _ => Aabb::new(p.min(q), p.max(q)),
                };
            }
            let origin = match case % 3 {
                0 => rng.vec3_in(&unit),
                1 => Vec3::new(0.25, rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)),
                _ => rng.unit_vector() * 3.0,
            };
            let mut d = match case % 4 {
                0 => Vec3::new(0.0, 1.0, 0.0),
                1 => Vec3::new(-0.0, -0.0, -1.0),
                _ => rng.unit_vector(),
            };
            if case % 7 == 0 {
                d.x = -0.0;
            }
            let ray = Ray::new(origin, d);
            let (tmin, tmax) = (0.0, if case % 5 == 0 { 0.7 } else { f32::INFINITY });
            let mut rows = [[0.0f32; W]; 6];
            for (i, b) in boxes.iter().enumerate() {
                for a in 0..3 {
                    rows[a][i] = b.min[a];
                    rows[a + 3][i] = b.max[a];
                }
            }
            let wray = WideRay::new(&ray);
            if K::FUSED && wray.fused_usable() {
                // The fused form lane for lane against its scalar form.
                let mut got = [0.0f32; W];
                // SAFETY: `level.supported()` was checked above; the ray is usable.
                let mask = unsafe { K::entries_fused(&rows, &wray, tmin, tmax, &mut got) };
                for (i, got) in got.iter().enumerate() {
                    let expected = fused_entry(&rows, i, &wray, tmin, tmax);
                    assert_eq!(mask >> i & 1 == 1, expected != f32::INFINITY, "case {case}");
                    if mask >> i & 1 == 1 {
                        assert_eq!(got.to_bits(), expected.to_bits(), "case {case} {i}");
                    }
                }
                fused += 1;
            }
            let mut got = [0.0f32; W];
            // SAFETY: `level.supported()` was checked above.
            let mask = unsafe { K::entries(&rows, &wray, tmin, tmax, &mut got) };
            let slab = SlabRay::new(&ray);
            for (i, b) in boxes.iter().enumerate() {
                let expected = slab_entry(&[b.min, b.max], &slab, tmin, tmax);
                let hit = mask >> i & 1 == 1;
                assert_eq!(
                    hit,
                    expected != f32::INFINITY,
                    "{} W={W} case {case} lane {i}: {b:?} {ray:?}",
                    level.label()
                );
                if hit {
                    assert_eq!(
                        got[i].to_bits(),
                        expected.to_bits(),
                        "{} lane {i}",
                        level.label()
                    );
                }
            }
        }
        // Half the rays have a zero component (plain form only); the rest test the fused.
        assert!(
            !K::FUSED || fused > 5_000,
            "{} W={W}: {fused} fused",
            level.label()
        );
    }
    let mut rng = Rng::new(11);
    check::<4, Portable>(SimdLevel::Portable, &mut rng);
    check::<8, Portable>(SimdLevel::Portable, &mut rng);
    check::<4, Sse41>(SimdLevel::Sse41, &mut rng);
    check::<8, Sse41>(SimdLevel::Sse41, &mut rng);
    check::<4, Avx2>(SimdLevel::Avx2, &mut rng);
    check::<8, Avx2>(SimdLevel::Avx2, &mut rng);
    check::<4, Avx512>(SimdLevel::Avx512, &mut rng);
    check::<8, Avx512>(SimdLevel::Avx512, &mut rng);
}

/// Each triangle kernel's lanes equal the scalar watertight test: hit or miss, and t, u, v
/// bit for bit, on random triangles, triangles sharing edges, degenerate and tiny ones, rays
/// through vertices and edges, axis-parallel rays with ±0 components and rays starting on a
/// triangle; lanes it hands back to the scalar test are those the scalar test decides in f64,
/// and padding never hits.
#[test]
fn every_triangle_kernel_equals_the_scalar_watertight_test() {
    fn check<K: TriangleKernel>(level: SimdLevel, rng: &mut Rng) -> (usize, usize) {
        if !level.supported() {
            return (0, 0);
        }
        let unit = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        let (mut hits, mut retests) = (0, 0);
        for case in 0..40_000 {
            // Four triangles around a shared vertex p (edges shared pairwise), or random
            // ones; some degenerate, one lane left as padding now and then.
            let p = rng.vec3_in(&unit);
            let ring: [Vec3; 5] = std::array::from_fn(|_| rng.vec3_in(&unit));
            let mut tris: Vec<Option<Triangle>> = (0..BLOCK)
                .map(|i| {
                    Some(match (case + i) % 5 {
                        0 => Triangle::new(p, ring[i], ring[i + 1]),
                        1 => Triangle::new(p, p, ring[i]),
                        2 => Triangle::new(p, ring[i], ring[i] * 2.0 - p),
                        3 => {
                            let c = rng.vec3_in(&unit);
                            let s = 1e-4;
                            Triangle::new(c, c + Vec3::X * s, c + Vec3::Y * s)
                        }
                        _ => Triangle::new(ring[i], ring[i + 1], rng.vec3_in(&unit)),
                    })
                })
                .collect();
            if case % 9 == 0 {
                tris[case % BLOCK] = None;
            }
            let mut block = TriangleBlock::EMPTY;
            for (lane, t) in tris.iter().enumerate() {
                if let Some(t) = t {
                    block.set(lane, t);
                }
            }
            let aim = match case % 4 {
                0 => p,
                1 => ring[0] * 0.5 + ring[1] * 0.5,
                _ => rng.vec3_in(&unit),
            };
            let origin = match case % 6 {
                // On the first triangle's plane: t at or next to 0.
                0 => match tris[0] {
                    Some(t) => t.point(rng.f32() * 0.5, rng.f32() * 0.5),
                    None => rng.vec3_in(&unit),
                },
                1 => aim - Vec3::new(0.0, 0.0, 2.0),
                _ => rng.unit_vector() * 3.0,
            };
            let mut d = match case % 6 {
                1 => Vec3::new(-0.0, 0.0, 1.0),
                0 => rng.unit_vector(),
                _ => aim - origin,
            };
            if case % 7 == 0 {
                d.y = -0.0;
            }
            if d == Vec3::ZERO {
                continue;
            }
            let ray = Ray::new(origin, d);
            let (tmin, tmax) = (0.0, if case % 5 == 0 { 1.5 } else { f32::INFINITY });
            let shear = Watertight::prepare(&ray);
            // SAFETY: `level.supported()` was checked above.
            let got = unsafe { K::watertight(&block, &shear, &ray, tmin, tmax) };
            // SAFETY: the portable kernel has no requirement.
            let portable = unsafe { Portable::watertight(&block, &shear, &ray, tmin, tmax) };
            assert_eq!(
                (got.hit, got.retest),
                (portable.hit, portable.retest),
                "{} case {case}: lanes differ from the portable kernel",
                level.label()
            );
            for (lane, t) in tris.iter().enumerate() {
                let (hit, retest) = (got.hit >> lane & 1 == 1, got.retest >> lane & 1 == 1);
                let Some(t) = t else {
                    assert!(!hit && !retest, "{} case {case}: padding", level.label());
                    continue;
                };
                let expected = Watertight::intersect(&shear, &ray, t, tmin, tmax);
                if retest {
                    retests += 1;
                    continue;
                }
                assert_eq!(
                    hit,
                    expected.is_some(),
                    "{} case {case} lane {lane}: {t:?} {ray:?}",
                    level.label()
                );
                if let Some(e) = expected {
                    hits += 1;
                    let lanes = (got.t[lane], got.u[lane], got.v[lane]);
                    assert_eq!(
                        [lanes.0, lanes.1, lanes.2].map(f32::to_bits),
                        [e.t, e.u, e.v].map(f32::to_bits),
                        "{} case {case} lane {lane}",
                        level.label()
                    );
                }
            }
        }
        (hits, retests)
    }
    let mut rng = Rng::new(5);
    let (hits, retests) = check::<Portable>(SimdLevel::Portable, &mut rng);
    // The cases reach both paths: hits decided by the lanes, and lanes handed back.
    assert!(
        hits > 1000 && retests > 100,
        "{hits} hits, {retests} retests"
    );
    check::<Sse41>(SimdLevel::Sse41, &mut rng);
    check::<Avx2>(SimdLevel::Avx2, &mut rng);
    check::<Avx512>(SimdLevel::Avx512, &mut rng);
}

/// The block test stops early when no lane can hit or be handed back (a ray beside all four
/// triangles, triangles behind the origin or beyond tmax, a padding block) and only then:
/// a lane on a shared edge is still handed back, a lane inside still hits. Every kernel
/// agrees with the portable one and with the scalar test in each case.
#[test]
fn the_block_test_stops_early_only_when_no_lane_can_hit() {
    // Four right triangles apart from each other in the plane z = 5, legs of length 1.
    let tri = |x: f32| {
        Triangle::new(
            Vec3::new(x, 0.0, 5.0),
            Vec3::new(x + 1.0, 0.0, 5.0),
            Vec3::new(x, 1.0, 5.0),
        )
    };
    let tris = [tri(0.0), tri(2.0), tri(4.0), tri(6.0)];
    let mut block = TriangleBlock::EMPTY;
    for (lane, t) in tris.iter().enumerate() {
        block.set(lane, t);
    }
    // The first of them and its mirror image across its hypotenuse, which they share, in a
    // block of their own: a ray through the hypotenuse has an edge function of exactly zero.
    let a = tris[0];
    let mut edge_block = TriangleBlock::EMPTY;
    edge_block.set(0, &a);
    edge_block.set(1, &Triangle::new(a.v[1], Vec3::new(1.0, 1.0, 5.0), a.v[2]));
    let up = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 0.0), Vec3::Z);
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 0.0), -Vec3::Z);
    // (block, ray, tmax, expected hit lanes, whether some lane is handed back)
    let cases: [(&TriangleBlock, Ray, f32, u32, bool); 8] = [
        (&block, up(1.5, 0.5), f32::INFINITY, 0, false), // beside all four
        (&block, up(0.25, 0.25), f32::INFINITY, 0b0001, false), // inside lane 0
        (&block, up(4.25, 0.25), f32::INFINITY, 0b0100, false), // inside lane 2
        (&block, down(0.25, 0.25), f32::INFINITY, 0, false), // lane 0 behind the origin
        (&block, up(0.25, 0.25), 4.0, 0, false),         // lane 0 beyond tmax
        (
            &TriangleBlock::EMPTY,
            up(0.25, 0.25),
            f32::INFINITY,
            0,
            false,
        ), // padding
        (&edge_block, up(0.5, 0.5), f32::INFINITY, 0, true), // on the shared hypotenuse
        (&edge_block, up(0.75, 0.75), f32::INFINITY, 0b0010, false), // inside lane 1
    ];
    fn check<K: TriangleKernel>(level: SimdLevel, cases: &[(&TriangleBlock, Ray, f32, u32, bool)]) {
        if !level.supported() {
            return;
        }
        for (i, &(block, ray, tmax, hit, handed_back)) in cases.iter().enumerate() {
            let shear = Watertight::prepare(&ray);
            // SAFETY: `level.supported()` was checked above.
            let got = unsafe { K::watertight(block, &shear, &ray, 0.0, tmax) };
            // SAFETY: the portable kernel has no requirement.
            let portable = unsafe { Portable::watertight(block, &shear, &ray, 0.0, tmax) };
            let what = format!("{} case {i}", level.label());
            assert_eq!(
                (got.hit, got.retest),
                (portable.hit, portable.retest),
                "{what}"
            );
            assert_eq!(got.hit, hit, "{what}: hit lanes");
            assert_eq!(got.retest != 0, handed_back, "{what}: handed-back lanes");
            for lane in 0..BLOCK {
                let scalar = Watertight::intersect(&shear, &ray, &block.triangle(lane), 0.0, tmax);
                if got.retest >> lane & 1 == 0 {
                    assert_eq!(
                        got.hit >> lane & 1 == 1,
                        scalar.is_some(),
                        "{what} lane {lane}"
                    );
                }
                if let Some(s) = scalar.filter(|_| got.hit >> lane & 1 == 1) {
                    assert_eq!(got.t[lane].to_bits(), s.t.to_bits(), "{what} lane {lane}");
                }
            }
        }
    }
    check::<Portable>(SimdLevel::Portable, &cases);
    check::<Sse41>(SimdLevel::Sse41, &cases);
    check::<Avx2>(SimdLevel::Avx2, &cases);
    check::<Avx512>(SimdLevel::Avx512, &cases);
}

/// Every function of bvhlab that uses SIMD intrinsics is compiled with their instruction
/// set, so that the intrinsics are single instructions. A closure is compiled with the
/// instruction set of the function that defines it, not of the entry point it is inlined
/// into: a walk passed as a closure from code outside the entry points called each
/// intrinsic out of line (the two levels' packet walk did, 312 calls in one closure). Read
/// from the release binary's disassembly; skipped in debug builds, where nothing is inlined,
/// and where `objdump` is missing.
#[test]
fn no_function_of_bvhlab_calls_an_intrinsic_out_of_line() {
    let Some(text) = disassembly() else { return };
    let mut function = "";
    let mut offenders = std::collections::BTreeSet::new();
    for line in text.lines() {
        if line.ends_with(">:") {
            function = line;
        } else if line.contains("call") && line.contains("core_arch") && function.contains("bvhlab")
        {
            offenders.insert(function.to_string());
        }
    }
    assert!(
        offenders.is_empty(),
        "functions calling intrinsics out of line: {offenders:#?}"
    );
}

/// The AVX2 and AVX-512 entry points count set bits with `popcnt` (a packet counts its
/// active rays at every node): compiled without the feature, `count_ones` becomes a dozen
/// instructions of shifts and masks with 0x5555… constants, which 48 of them held before
/// the feature was named.
#[test]
fn the_simd_entry_points_count_bits_with_one_instruction() {
    let Some(text) = disassembly() else { return };
    let entry_point =
        |f: &str| f.contains("bvhlab") && ["_avx217h", "_avx51217h"].iter().any(|s| f.contains(s));
    let (mut function, mut entry_points) = ("", 0);
    let mut offenders = std::collections::BTreeSet::new();
    for line in text.lines() {
        if line.ends_with(">:") {
            function = line;
            entry_points += usize::from(entry_point(function));
        } else if line.contains("0x5555555555555555") && entry_point(function) {
            offenders.insert(function.to_string());
        }
    }
    assert!(entry_points > 50, "{entry_points} entry points found");
    assert!(
        offenders.is_empty(),
        "entry points counting bits in software: {offenders:#?}"
    );
}

/// The release binary's disassembly; `None` (the test skipped) in debug builds, where
/// nothing is inlined, and where `objdump` is missing.
fn disassembly() -> Option<String> {
    if cfg!(debug_assertions) {
        eprintln!("skipped: a debug build inlines nothing");
        return None;
    }
    let exe = env!("CARGO_BIN_EXE_bvhlab");
    let Ok(out) = std::process::Command::new("objdump")
        .args(["-d", "--no-show-raw-insn", exe])
        .output()
    else {
        eprintln!("skipped: objdump is not installed");
        return None;
    };
    assert!(out.status.success(), "objdump failed on {exe}");
    Some(String::from_utf8_lossy(&out.stdout).into_owned())
}
