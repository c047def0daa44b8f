//! One progress style for long stages: sparse lines with the share, rate and time left when
//! stderr is not a terminal (as here), nothing with `-q`, nothing for short stages.

mod common;

use common::scratch;
use std::process::Command;

fn run(args: &[&str], after_ms: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args(args)
        .env("ISOKIT_PROGRESS_AFTER_MS", after_ms)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn progress_lines(stderr: &str, stage: &str) -> Vec<String> {
    stderr
        .lines()
        .filter(|l| l.starts_with(&format!("{stage}: ")))
        .map(str::to_owned)
        .collect()
}

#[test]
fn long_stages_report_sparse_lines_and_quiet_silences_them() {
    let d = scratch("progress");
    let scene = common::data("../examples/scenes/part.json");
    let out = d.join("p.nrrd").to_string_lossy().into_owned();
    let args = ["scene", scene.as_str(), "--res", "96", "-o", out.as_str()];
    // Shown from the start (a delay of 0): every 10% at most, ending with the total time.
    let lines = progress_lines(&run(&args, "0"), "sampling bricks");
    assert!(!lines.is_empty(), "no progress lines");
    assert!(lines.len() <= 11, "{} lines: {lines:?}", lines.len());
    assert!(
        lines.iter().all(|l| l.contains('%') && l.contains("/s")),
        "{lines:?}"
    );
    assert!(lines.last().unwrap().contains("100.0%") && lines.last().unwrap().contains("done in"));
    assert!(
        !lines[0].contains('['),
        "no bar when stderr is not a terminal"
    );
    // -q: nothing; and a short stage says nothing with the default delay.
    let mut quiet = args.to_vec();
    quiet.push("-q");
    assert!(progress_lines(&run(&quiet, "0"), "sampling bricks").is_empty());
    assert!(progress_lines(&run(&args, "60000"), "sampling bricks").is_empty());
    // The scene sampling of `render` reports the same way.
    let png = d.join("p.png").to_string_lossy().into_owned();
    let r = run(
        &[
            "render",
            scene.as_str(),
            "-o",
            png.as_str(),
            "--backend",
            "cpu",
            "--res",
            "64",
        ],
        "0",
    );
    assert!(!progress_lines(&r, "sampling bricks").is_empty(), "{r}");
    // And `sample` of a primitive.
    let npy = d.join("s.nrrd").to_string_lossy().into_owned();
    let s = run(
        &["sample", "sphere", "--res", "64", "-o", npy.as_str()],
        "0",
    );
    let lines = progress_lines(&s, "sampling");
    assert!(!lines.is_empty() && lines.len() <= 11, "{s}");
}

#[test]
fn octree_and_mesh_report_their_stages() {
    let d = scratch("progress-octree-mesh");
    // The octree: a line per level reached, ending each level with its total time.
    let o = run(&["octree", "sphere", "--max-level", "6"], "0");
    let level5 = progress_lines(&o, "octree level 5 of 6");
    assert!(!level5.is_empty(), "{o}");
    assert!(level5.last().unwrap().contains("done in"), "{level5:?}");
    assert!(progress_lines(&o, "octree level 6 of 6").is_empty(), "{o}");
    let bottom_up = run(
        &["octree", "sphere", "--max-level", "5", "--bottom-up"],
        "0",
    );
    assert!(
        !progress_lines(&bottom_up, "sampling the finest octree level").is_empty(),
        "{bottom_up}"
    );
    // Meshing a volume: blocks of cells.
    let vol = d.join("s.nrrd").to_string_lossy().into_owned();
    run(
        &["sample", "sphere", "--res", "64", "-o", vol.as_str(), "-q"],
        "0",
    );
    let obj = d.join("s.obj").to_string_lossy().into_owned();
    let m = run(&["mesh", vol.as_str(), "-o", obj.as_str()], "0");
    let lines = progress_lines(&m, "meshing");
    assert!(!lines.is_empty() && lines.len() <= 11, "{m}");
    assert!(lines.last().unwrap().contains("100.0%"), "{lines:?}");
    // Dual contouring: the crossed edges, then the cells' vertices.
    let dual = run(
        &["mesh", vol.as_str(), "-o", obj.as_str(), "--mesher", "dual"],
        "0",
    );
    for stage in ["meshing (crossed edges)", "meshing (vertices)"] {
        let lines = progress_lines(&dual, stage);
        assert!(!lines.is_empty(), "{stage}: {dual}");
        assert!(lines.last().unwrap().contains("100.0%"), "{lines:?}");
    }
    assert!(
        progress_lines(
            &run(&["mesh", vol.as_str(), "-o", obj.as_str(), "-q"], "0"),
            "meshing"
        )
        .is_empty()
    );
}
