//! Replays the fuzz corpus (`fuzz/corpus/<target>/*`: seeds from `data/`, the inputs of
//! past bug reports and every crash a campaign found) through the targets, in
//! `cargo test --workspace`. A file that panics or yields a multi-line error fails the test,
//! naming the file.

use std::path::{Path, PathBuf};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus")
}

#[test]
fn every_target_has_a_corpus() {
    for (name, _) in isokit_fuzz::TARGETS {
        let n = std::fs::read_dir(corpus().join(name))
            .map(|d| d.count())
            .unwrap_or(0);
        assert!(n >= 2, "fuzz/corpus/{name} holds {n} files");
    }
    // And every corpus folder is a target.
    for e in std::fs::read_dir(corpus()).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            isokit_fuzz::target(&name).is_some(),
            "fuzz/corpus/{name}: no such target"
        );
    }
}

#[test]
fn the_corpus_replays_without_a_panic() {
    let mut failures = Vec::new();
    let mut count = 0;
    for (name, target) in isokit_fuzz::TARGETS {
        let Ok(dir) = std::fs::read_dir(corpus().join(name)) else {
            continue;
        };
        let mut files: Vec<PathBuf> = dir.map(|e| e.unwrap().path()).collect();
        files.sort();
        for f in files {
            let bytes = std::fs::read(&f).unwrap();
            count += 1;
            if std::panic::catch_unwind(|| target(&bytes)).is_err() {
                failures.push(f.display().to_string());
            }
        }
    }
    assert!(count > 30, "{count} corpus files");
    assert!(failures.is_empty(), "panicked: {failures:?}");
}
