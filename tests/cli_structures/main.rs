//! The structure selector on the command line: `--accel` on every subcommand that builds,
//! `bench --accel all` as one table or one JSON object over every structure, and clear
//! errors for what a subcommand cannot do.

use bvhlab::accel::AccelKind;
use bvhlab_testkit::TempDir;
use std::process::Command;

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("bvhlab runs")
}

const SMALL_BENCH: [&str; 10] = [
    "--width",
    "32",
    "--height",
    "24",
    "--builds",
    "1",
    "--runs",
    "1",
    "--threads",
    "2",
];

/// Each of `cases` (flags added to `render --scene cornell --out …`) fails with a message
/// containing its text, without a panic and without leaving the PNG behind.
fn assert_refused(dir: &std::path::Path, cases: &[(&[&str], &str)]) {
    let png = dir.join("refused.png");
    for &(args, says) in cases {
        let mut all = vec![
            "render",
            "--scene",
            "cornell",
            "--out",
            png.to_str().unwrap(),
        ];
        all.extend_from_slice(args);
        let out = bvhlab(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert!(!png.exists(), "{args:?} left a file");
    }
}

mod bench;
mod flags;
mod outputs;
mod renders;
