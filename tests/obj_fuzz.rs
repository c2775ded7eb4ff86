//! The OBJ loader under a fuzzer: random bytes, and real and hand-written files mutated at
//! random (bytes flipped, lines dropped, duplicated, swapped, truncated, hostile lines
//! inserted). Every input must load or be rejected with a typed error naming the file;
//! none may panic or hang.

use bvhlab_testkit as common;

use bvhlab::scene::{ObjError, Scene, load_obj};
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

/// A file with every feature the loader handles.
const FEATURES: &str = "# comment\nmtllib missing.mtl\no first\nv 0 0 0\nv 1 0 0\nv 1 1 0\n\
v 0 1 0 1\nv 0.5 0.5 1 2\nv 1 2 3 0.1 0.2 0.3\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\ng group\n\
usemtl red\ns 1\nf 1 2 3\nf 1/1 2/2 3/3\nf 1//1 2//1 4//1\nf 1/1/1 2/2/1 3/3/1 4/1/1\n\
f -1 -2 -3\nl 1 2 3\no second\nf 4 5 6 1 2\n";

/// Lines a hostile or broken file may contain.
const HOSTILE: &[&str] = &[
    "f 1 2 99999999999999999999",
    "f 0 1 2",
    "f -1 -2 -9999",
    "f 1/1/1/1 2 3",
    "f 1//// 2 3",
    "f",
    "f a b c",
    "v 1e39 0 0",
    "v nan 0 0",
    "v inf -inf 0",
    "v 1 2",
    "v 1 2 3 0",
    "v 1 2 3 4 5",
    "v 1 2 3 4 5 6 7",
    "vt",
    "vn 1",
    "usemtl",
    "usemtl  ",
    "mtllib /dev/zero",
    "mtllib ../../../../../../../../etc",
    "mtllib .",
    "o",
    "g",
    "s off",
    "\u{feff}v 1 1 1",
    "\0\0\0",
    "l",
    "l 1",
    "p 1 2 3",
    "f 1 1 1",
    "f 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20",
];

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(base: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut lines: Vec<Vec<u8>> = base.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
    for _ in 0..1 + rng.below(4) {
        let n = lines.len().max(1);
        match rng.below(8) {
            0 => {
                let i = rng.below(n);
                if let Some(line) = lines.get_mut(i)
                    && !line.is_empty()
                {
                    let k = rng.below(line.len());
                    let choices = b"0123456789-+/ .eEfvlgnaio\t\r\xff\x00#";
                    line[k] = choices[rng.below(choices.len())];
                }
            }
            1 if !lines.is_empty() => {
                lines.remove(rng.below(n));
            }
            2 if !lines.is_empty() => {
                let line = lines[rng.below(n)].clone();
                lines.insert(rng.below(n), line);
            }
            3 if n >= 2 => {
                let (a, b) = (rng.below(n), rng.below(n));
                lines.swap(a, b);
            }
            4 => {
                let line = HOSTILE[rng.below(HOSTILE.len())].as_bytes().to_vec();
                lines.insert(rng.below(n + 1).min(lines.len()), line);
            }
            5 => {
                let keep = rng.below(n);
                lines.truncate(keep);
            }
            6 => {
                // A very long line of numbers.
                let mut line = b"f".to_vec();
                for _ in 0..2000 {
                    line.extend_from_slice(format!(" {}", 1 + rng.below(8)).as_bytes());
                }
                lines.insert(rng.below(n + 1).min(lines.len()), line);
            }
            _ => {
                let i = rng.below(n);
                if let Some(line) = lines.get_mut(i) {
                    let cut = rng.below(line.len() + 1);
                    line.truncate(cut);
                }
            }
        }
    }
    lines.join(&b'\n')
}

/// Loads `bytes` as `path` on a worker thread: the result, or a failure message if loading
/// panicked or did not finish within a minute (a hang, not a slow parse).
fn load_guarded(path: &Path, bytes: &[u8]) -> Result<Result<Scene, ObjError>, String> {
    std::fs::write(path, bytes).map_err(|e| e.to_string())?;
    let (tx, rx) = mpsc::channel();
    let owned = path.to_path_buf();
    let worker = std::thread::spawn(move || {
        let _ = tx.send(load_obj(&owned));
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

fn check(path: &Path, bytes: &[u8], what: &str) {
    match load_guarded(path, bytes) {
        Ok(Ok(scene)) => {
            assert!(
                !scene.triangles.is_empty(),
                "{what}: a scene without triangles"
            );
            assert!(
                scene.triangles.iter().all(|t| t.is_finite()),
                "{what}: non-finite vertex"
            );
            let covered: usize = scene.objects.iter().map(|o| o.count).sum();
            assert_eq!(covered, scene.triangles.len(), "{what}");
        }
        Ok(Err(e)) => {
            let message = e.to_string();
            assert!(
                message.contains(&path.display().to_string()),
                "{what}: '{message}' does not name the file"
            );
        }
        Err(failure) => {
            let keep = std::env::temp_dir().join("bvhlab-fuzz-failure.obj");
            let _ = std::fs::write(&keep, bytes);
            panic!("{what}: {failure} (input kept in {})", keep.display());
        }
    }
}

#[test]
fn random_bytes_never_panic() {
    let dir = common::TempDir::new("fuzz");
    let path = dir.join("random.obj");
    let mut rng = Rng(0x00b1_f022);
    for round in 0..6000 {
        let len = rng.below(400);
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                // Mostly OBJ-like characters, some raw bytes.
                let vocab = b"vf tngol0123456789-./\n \n";
                if rng.below(4) == 0 {
                    rng.next() as u8
                } else {
                    vocab[rng.below(vocab.len())]
                }
            })
            .collect();
        check(&path, &bytes, &format!("random round {round}"));
    }
}

#[test]
fn mutated_feature_file_never_panics() {
    let dir = common::TempDir::new("fuzz");
    let path = dir.join("features.obj");
    let scene = load_obj(&{
        std::fs::write(&path, FEATURES).unwrap();
        path.clone()
    })
    .expect("the unmutated file loads");
    assert!(scene.triangles.len() >= 8);
    let mut rng = Rng(0x0fea_70e5);
    for round in 0..20_000 {
        let bytes = mutate(FEATURES.as_bytes(), &mut rng);
        check(&path, &bytes, &format!("features round {round}"));
    }
}

#[test]
fn mutated_real_meshes_never_panic() {
    let mut bases = vec![
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/teapot.obj")).unwrap(),
    ];
    if let Some(dir) = common::shared_scenes() {
        bases.push(std::fs::read(dir.join("cornell-box.obj")).unwrap());
    }
    let dir = common::TempDir::new("fuzz");
    let path = dir.join("real.obj");
    let mut rng = Rng(0x07ea_9071);
    for (b, base) in bases.iter().enumerate() {
        for round in 0..400 {
            let bytes = mutate(base, &mut rng);
            check(&path, &bytes, &format!("real mesh {b} round {round}"));
        }
    }
}
