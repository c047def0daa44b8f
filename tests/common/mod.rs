//! Helpers shared by the end-to-end tests (`tests/*.rs`): run the real binary, find the
//! shipped data, make scratch folders that clean up after themselves.
// Each test binary uses a different subset of these helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `isokit` with `args`.
pub fn isokit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args(args)
        .output()
        .expect("the isokit binary runs")
}

/// Runs `isokit` with `args` and checks that it succeeded (printing its stderr if not).
pub fn isokit_ok(args: &[&str]) -> Output {
    let out = isokit(args);
    assert!(
        out.status.success(),
        "isokit {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Path of a file in `data/`.
pub fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// A fresh scratch folder, removed when dropped.
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A fresh scratch folder per test, unique per process and name.
pub fn scratch(name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!(
        "isokit-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    Scratch(d)
}

/// Parses stdout as one JSON object after checking the run succeeded.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// A failure exits with 2 and prints exactly one line on stderr.
pub fn assert_clear_error(out: &Output, needle: &str) {
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    // Notes printed before the failure (e.g. that the CPU twin renders because the only
    // adapter is a software one) are not part of the error.
    let lines = err
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with("note: "));
    assert_eq!(lines.count(), 1, "one line expected, got: {err}");
    assert!(err.contains(needle), "'{needle}' not in: {err}");
}
