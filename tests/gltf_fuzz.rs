//! The glTF loader under a fuzzer, as the OBJ loader is: a .gltf with an embedded buffer, a
//! .gltf with an external buffer and a .glb, corrupted at random (bytes flipped, cut,
//! duplicated; JSON numbers replaced by hostile ones). Every input must load or be rejected
//! with a typed error naming the file; none may panic or hang.

use bvhlab_testkit as common;

use bvhlab::scene::{GltfError, Scene, load_gltf};
use common::gltf::{GltfBuilder, UNSIGNED_BYTE, UNSIGNED_SHORT};
use common::{Rng, TempDir};
use glam::Vec3;
use serde_json::json;
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

/// Numbers a corrupted file may hold where a count, index, offset or coordinate stands.
const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "1e39",
    "-1e39",
    "0.5",
    "65536",
    "99999999999",
    "5126",
    "5121",
    "7",
];

/// A file with nested nodes, a shared mesh, both index types and TRS and matrix nodes.
fn features() -> GltfBuilder {
    let mut b = GltfBuilder::default();
    let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let p = b.positions(&quad);
    let i16 = b.indices(&[0, 1, 2, 0, 2, 3], UNSIGNED_SHORT);
    let p2 = b.positions(&[Vec3::Z, Vec3::Z + Vec3::X, Vec3::Z + Vec3::Y]);
    let i8 = b.indices(&[0, 1, 2], UNSIGNED_BYTE);
    let shared = b.mesh(&[(p, Some(i16)), (p2, None)]);
    let other = b.mesh(&[(p2, Some(i8))]);
    let leaf = b.node(json!({"mesh": other, "scale": [1.0, -2.0, 0.5]}));
    let mid = b.node(json!({
        "mesh": shared, "children": [leaf],
        "matrix": [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 1.0]
    }));
    let root = b.node(json!({
        "mesh": shared, "children": [mid], "rotation": [0.0, 0.6, 0.0, 0.8],
        "translation": [0.0, 1.0, 0.0], "name": "root"
    }));
    b.roots.push(root);
    b
}

fn mutate(base: &[u8], rng: &mut Rng, json_text: bool) -> Vec<u8> {
    let mut bytes = base.to_vec();
    for _ in 0..1 + rng.below(4) {
        let n = bytes.len().max(1);
        match rng.below(if json_text { 6 } else { 5 }) {
            0 => {
                let i = rng.below(n);
                if let Some(b) = bytes.get_mut(i) {
                    *b = rng.next_u64() as u8;
                }
            }
            1 => bytes.truncate(rng.below(n)),
            2 => {
                let (a, len) = (rng.below(n), rng.below(64));
                let chunk: Vec<u8> = bytes.iter().skip(a).take(len).copied().collect();
                let at = rng.below(bytes.len() + 1);
                bytes.splice(at..at, chunk);
            }
            3 => {
                let (a, len) = (rng.below(n), rng.below(32));
                let end = (a + len).min(bytes.len());
                if a < end {
                    bytes.drain(a..end);
                }
            }
            4 => {
                // A 32-bit field (GLB header or chunk length, or buffer data) overwritten.
                let i = rng.below(n) & !3;
                let value = [0u32, 1, 0xFFFF_FFFF, 12, 0x8000_0000][rng.below(5)];
                for (k, b) in value.to_le_bytes().into_iter().enumerate() {
                    if let Some(slot) = bytes.get_mut(i + k) {
                        *slot = b;
                    }
                }
            }
            _ => {
                // Replace one JSON number by a hostile one.
                let digits: Vec<usize> = (0..bytes.len())
                    .filter(|&i| {
                        bytes[i].is_ascii_digit() && (i == 0 || !bytes[i - 1].is_ascii_digit())
                    })
                    .collect();
                if !digits.is_empty() {
                    let start = digits[rng.below(digits.len())];
                    let mut end = start;
                    while end < bytes.len() && (bytes[end].is_ascii_digit() || bytes[end] == b'.') {
                        end += 1;
                    }
                    let number = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())];
                    bytes.splice(start..end, number.bytes());
                }
            }
        }
    }
    bytes
}

/// Loads `bytes` written to `path` on a worker thread: the result, or a failure message if
/// loading panicked or did not finish within a minute.
fn load_guarded(path: &Path, bytes: &[u8]) -> Result<Result<Scene, GltfError>, String> {
    std::fs::write(path, bytes).map_err(|e| e.to_string())?;
    let (tx, rx) = mpsc::channel();
    let owned = path.to_path_buf();
    let worker = std::thread::spawn(move || {
        let _ = tx.send(load_gltf(&owned));
    });
    match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(result) => {
            let _ = worker.join();
            Ok(result)
        }
        Err(mpsc::RecvTimeoutError::Timeout) => Err("hang: no result after 60 s".into()),
        Err(mpsc::RecvTimeoutError::Disconnected) => Err("panic while loading".into()),
    }
}

fn check(path: &Path, bytes: &[u8], what: &str) -> bool {
    match load_guarded(path, bytes) {
        Ok(Ok(scene)) => {
            assert!(!scene.triangles.is_empty(), "{what}: no triangles");
            assert!(
                scene.triangles.iter().all(|t| t.is_finite()),
                "{what}: non-finite vertex"
            );
            let covered: usize = scene.objects.iter().map(|o| o.count).sum();
            assert_eq!(covered, scene.triangles.len(), "{what}");
            assert_eq!(
                scene.instancing().instanced_triangles(),
                scene.triangles.len(),
                "{what}"
            );
            true
        }
        Ok(Err(e)) => {
            let message = e.to_string();
            assert!(
                message.contains(&path.display().to_string()),
                "{what}: '{message}' does not name the file"
            );
            false
        }
        Err(failure) => {
            let keep = std::env::temp_dir().join(format!(
                "bvhlab-fuzz-failure.{}",
                path.extension().unwrap().to_string_lossy()
            ));
            let _ = std::fs::write(&keep, bytes);
            panic!("{what}: {failure} (input kept in {})", keep.display());
        }
    }
}

#[test]
fn corrupted_files_never_panic() {
    let dir = TempDir::new("gltf-fuzz");
    let b = features();
    let embedded = std::fs::read(b.write_embedded(dir.path(), "base-embedded")).unwrap();
    b.write_external(dir.path(), "base-external");
    let external = std::fs::read(dir.join("base-external.gltf")).unwrap();
    let glb = std::fs::read(b.write_glb(dir.path(), "base")).unwrap();
    let mut rng = Rng::new(0x61_7f);
    for (name, base, json_text, rounds) in [
        ("embedded.gltf", &embedded, true, 3000),
        // Loaded next to the buffer file `base-external.bin`, which stays intact.
        ("external.gltf", &external, true, 2000),
        ("mutated.glb", &glb, false, 3000),
    ] {
        let path = dir.join(name);
        assert!(check(&path, base, name), "{name} loads before corruption");
        let mut loaded = 0;
        for round in 0..rounds {
            let bytes = mutate(base, &mut rng, json_text);
            loaded += usize::from(check(&path, &bytes, &format!("{name} round {round}")));
        }
        // Some corruptions leave a loadable file: the fuzzer reaches past the parser.
        assert!(loaded > 0, "{name}: no corrupted file loaded");
    }
}

#[test]
fn random_bytes_never_panic() {
    let dir = TempDir::new("gltf-fuzz-random");
    let mut rng = Rng::new(0x0b1f);
    for round in 0..3000 {
        let len = rng.below(300);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
        // Half start like a GLB, so the header parser is reached.
        if round % 2 == 0 && bytes.len() >= 12 {
            bytes[..4].copy_from_slice(b"glTF");
            bytes[4..8].copy_from_slice(&2u32.to_le_bytes());
        }
        check(
            &dir.join("random.glb"),
            &bytes,
            &format!("random round {round}"),
        );
    }
}
