//! Waiting for files to change (polling their size and modification time), for
//! `isokit render --watch`; a live viewer uses file events instead.

use crate::file::{SceneFormat, parse};
use crate::node::Node;
use isokit_field::{Cancelled, Job};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// The files an input depends on, without compiling it: the input itself and, for a scene
/// file that parses, every file its tree names (meshes, clouds, volumes, included scenes and
/// what they name). For a scene that compiles, [`crate::Scene::dependencies`] says the same.
pub fn files_of(input: &Path) -> Vec<PathBuf> {
    let mut out = vec![input.to_path_buf()];
    collect(input, &mut out, 0);
    out
}

fn collect(path: &Path, out: &mut Vec<PathBuf>, depth: usize) {
    let Some(format) = SceneFormat::from_path(path) else {
        return;
    };
    let Ok(text) = std::fs::read_to_string(path) else {
        return;
    };
    let Ok(file) = parse(&text, format, &path.display().to_string()) else {
        return;
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut stack = vec![&file.shape];
    while let Some(node) = stack.pop() {
        let named = match node {
            Node::Mesh(m) => m.path.as_deref(),
            Node::Points(p) => p.path.as_deref(),
            Node::Volume(v) => v.path.as_deref(),
            Node::Include { path } => Some(path.as_str()),
            _ => None,
        };
        if let Some(p) = named {
            let p = dir.join(p);
            let seen = out.contains(&p);
            out.push(p.clone());
            // Cycles are the scene loader's error to report; stop at a depth anyway.
            if matches!(node, Node::Include { .. }) && !seen && depth < 16 {
                collect(&p, out, depth + 1);
            }
        }
        stack.extend(node.children());
    }
}

/// Size and modification time of each file (`None` for a missing file).
fn stamp(files: &[PathBuf]) -> Vec<Option<(SystemTime, u64)>> {
    files
        .iter()
        .map(|f| {
            std::fs::metadata(f)
                .ok()
                .and_then(|m| Some((m.modified().ok()?, m.len())))
        })
        .collect()
}

/// Returns once one of `files` changed (appeared, disappeared, or changed size or
/// modification time), polling every 200 ms and then waiting 100 ms for the writer to
/// finish; `Err(Cancelled)` when `job` is cancelled first.
pub fn wait_for_change(files: &[PathBuf], job: &Job) -> Result<(), Cancelled> {
    let before = stamp(files);
    loop {
        std::thread::sleep(Duration::from_millis(200));
        job.check()?;
        if stamp(files) != before {
            std::thread::sleep(Duration::from_millis(100));
            return Ok(());
        }
    }
}
