//! `isokit view` in a real window (an X server: Xvfb in CI), driven headless through
//! `--events`, `--screenshot` and the exit flags, with the scene edited on disk while it
//! runs. Skipped with a printed reason where no display exists, unless
//! `ISOKIT_REQUIRE_DISPLAY=1` (CI), where that is a failure.

mod common;

use common::{isokit_ok, json, scratch};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn have_display() -> bool {
    let ok = std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty());
    if !ok {
        assert!(
            std::env::var("ISOKIT_REQUIRE_DISPLAY").as_deref() != Ok("1"),
            "ISOKIT_REQUIRE_DISPLAY=1 but DISPLAY is not set (run under xvfb-run)"
        );
        eprintln!("skipped: no DISPLAY for a window (run under xvfb-run to test the viewer)");
    }
    ok
}

const SIZE: &str = "128";

/// A union of three primitives on a fixed lattice (so an edit keeps every sample's place),
/// the middle sphere's radius `r`.
fn scene_text(r: f32) -> String {
    format!(
        r#"{{"sampling": {{"resolution": 48, "bounds": [[-2.2, -1.2, -1.2], [2.2, 1.2, 1.2]]}},
  "camera": {{"eye": [0.8, 2.0, 5.0], "target": [0, 0, 0]}},
  "shape": {{"union": [
    {{"box": {{"half": [0.45, 0.45, 0.45], "center": [-1.4, 0, 0]}}}},
    {{"sphere": {{"radius": {r}, "center": [0, 0, 0]}}}},
    {{"sphere": {{"radius": 0.5, "center": [1.4, 0, 0]}}}}]}}}}"#
    )
}

/// Writes a file the way editors save: a temporary beside it, renamed over it.
fn save(path: &Path, text: &str) {
    let tmp = path.with_extension("tmp~");
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

fn spawn_view(scene: &Path, events: &Path, shot: &Path, exit: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_isokit"))
        .arg("view")
        .arg(scene)
        .args(["--backend", "cpu", "--width", SIZE, "--height", SIZE])
        .arg("--events")
        .arg(events)
        .arg("--screenshot")
        .arg(shot)
        .args(exit)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("isokit view starts")
}

fn read_events(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter(|l| l.ends_with('}'))
        .map(|l| serde_json::from_str(l).expect("each line of the events file is JSON"))
        .collect()
}

/// Waits until the events file holds an event that `pred` accepts; returns all events.
fn wait_for(path: &Path, what: &str, pred: impl Fn(&[Value]) -> bool) -> Vec<Value> {
    let t0 = Instant::now();
    loop {
        let ev = read_events(path);
        if pred(&ev) {
            return ev;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "waited 60 s for {what}; events: {ev:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn finals(ev: &[Value]) -> Vec<&Value> {
    ev.iter()
        .filter(|e| e["event"] == "frame" && e["final"] == true)
        .collect()
}

fn finish(mut child: Child) {
    let status = child.wait().unwrap();
    let mut err = String::new();
    if let Some(mut s) = child.stderr.take() {
        use std::io::Read;
        let _ = s.read_to_string(&mut err);
    }
    assert!(status.success(), "isokit view failed: {err}");
}

/// The scene, the events file and the screenshot in a scratch folder.
fn files(d: &Path) -> (PathBuf, PathBuf, PathBuf) {
    (d.join("s.json"), d.join("ev.jsonl"), d.join("v.png"))
}

/// The screenshot shows what `reference` shows (1/255 mean per channel at most).
fn assert_shows(shot: &Path, reference: &Path, what: &str) {
    let diff = mean_diff(shot, reference);
    assert!(diff <= 1.0, "{what}: mean difference {diff}/255");
}

/// Mean absolute difference of two PNGs, in 1/255 units per channel.
fn mean_diff(a: &Path, b: &Path) -> f64 {
    let (wa, ha, pa) = isokit_io::read_png(a).unwrap();
    let (wb, hb, pb) = isokit_io::read_png(b).unwrap();
    assert_eq!((wa, ha), (wb, hb), "image sizes differ");
    let sum: u64 = pa
        .iter()
        .zip(&pb)
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    sum as f64 / pa.len() as f64
}

fn render(scene: &Path, out: &Path) {
    isokit_ok(&[
        "render",
        &scene.to_string_lossy(),
        "-o",
        &out.to_string_lossy(),
        "--backend",
        "cpu",
        "--width",
        SIZE,
        "--height",
        SIZE,
    ]);
}

#[test]
fn the_first_frame_equals_render_and_an_edit_evaluates_fewer_bricks() {
    if !have_display() {
        return;
    }
    let d = scratch("view-edit");
    let (scene, events, shot) = files(&d);
    save(&scene, &scene_text(0.4));
    let reference = d.join("r.png");
    render(&scene, &reference);
    let stats = json(&isokit_ok(&[
        "scene",
        &scene.to_string_lossy(),
        "-o",
        &d.join("s.nrrd").to_string_lossy(),
        "--stats",
    ]));
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-frames", "1"]);
    finish(child);
    assert_shows(&shot, &reference, "first frame against isokit render");
    let ev = read_events(&events);
    let first = finals(&ev)[0];
    assert_eq!(first["reason"], "start");
    assert_eq!(
        first["evaluated_bricks"], stats["bricks_kept"],
        "{first} vs {stats}"
    );

    // Edit one primitive's radius while the window is open.
    std::fs::remove_file(&events).unwrap();
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-frames", "2"]);
    wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    save(&scene, &scene_text(0.55));
    finish(child);
    let ev = read_events(&events);
    let f = finals(&ev);
    assert_eq!(f.len(), 2, "{ev:?}");
    let (a, b) = (f[0], f[1]);
    assert_eq!(b["reason"], "edit");
    assert!(b["latency_ms"].as_f64().unwrap() > 0.0);
    let (ea, eb) = (
        a["evaluated_bricks"].as_u64().unwrap(),
        b["evaluated_bricks"].as_u64().unwrap(),
    );
    assert!(
        eb < ea,
        "the edit evaluated {eb} bricks, a full evaluation {ea}"
    );
    assert!(b["reused_bricks"].as_u64().unwrap() > 0);
    // The finished frame traced only the rays that can reach the grown sphere: those of the
    // box and the other sphere were taken from the first frame.
    let rays = b["width"].as_u64().unwrap() * b["height"].as_u64().unwrap();
    let taken = b["reused_rays"].as_u64().unwrap();
    assert!(taken > 0 && taken < rays, "{taken} of {rays} rays taken");
    // Same lattice, so the edited frame equals a fresh rendering of the edited scene.
    render(&scene, &reference);
    assert_shows(&shot, &reference, "edited frame against isokit render");
}

#[test]
fn a_broken_save_keeps_the_last_good_frame_and_the_next_good_save_recovers() {
    if !have_display() {
        return;
    }
    let d = scratch("view-broken");
    let (scene, events, shot) = files(&d);
    let good = d.join("good.png");
    save(&scene, &scene_text(0.4));
    render(&scene, &good);
    // A broken save, then the window closes: the screenshot is still the good frame.
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-seconds", "12"]);
    wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    save(&scene, r#"{"shape": {"sphere": {"radius": }}"#);
    let ev = wait_for(&events, "an error event", |e| {
        e.iter().any(|x| x["event"] == "error")
    });
    finish(child);
    let err = ev.iter().find(|x| x["event"] == "error").unwrap();
    assert_eq!(err["ok"], false);
    assert!(err["file"].as_str().unwrap().ends_with("s.json"), "{err}");
    assert!(!err["message"].as_str().unwrap().is_empty());
    assert_eq!(
        finals(&read_events(&events)).len(),
        1,
        "no frame from the broken save"
    );
    assert_shows(&shot, &good, "the last good frame is kept");

    // Broken, then a missing node kind, then good again: the good save recovers.
    std::fs::remove_file(&events).unwrap();
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-frames", "1"]);
    wait_for(&events, "the start error", |e| {
        e.iter().any(|x| x["event"] == "error")
    });
    save(&scene, r#"{"shape": {"spere": {}}}"#);
    std::thread::sleep(Duration::from_millis(300));
    save(&scene, &scene_text(0.5));
    finish(child);
    let ev = read_events(&events);
    assert!(
        ev.iter().filter(|x| x["event"] == "error").count() >= 2,
        "{ev:?}"
    );
    render(&scene, &good);
    assert_shows(&shot, &good, "recovered");
}

#[test]
fn rapid_saves_end_on_the_last_and_a_recreated_file_is_followed() {
    if !have_display() {
        return;
    }
    let d = scratch("view-rapid");
    let (scene, events, shot) = files(&d);
    save(&scene, &scene_text(0.3));
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-seconds", "10"]);
    wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    // Ten saves in 200 ms.
    for i in 0..10 {
        save(&scene, &scene_text(0.3 + 0.02 * i as f32));
        std::thread::sleep(Duration::from_millis(20));
    }
    let last = d.join("last.png");
    render(&scene, &last);
    finish(child);
    let ev = read_events(&events);
    let f = finals(&ev);
    assert!(f.len() >= 2, "{ev:?}");
    assert_eq!(f.last().unwrap()["reason"], "edit");
    assert!(f.len() <= 11, "more frames than saves: {}", f.len());
    assert_shows(&shot, &last, "the last save is shown");

    // Deleted, then re-created (how vim and emacs save).
    std::fs::remove_file(&events).unwrap();
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-frames", "2"]);
    wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    std::fs::remove_file(&scene).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    std::fs::write(&scene, scene_text(0.6)).unwrap();
    finish(child);
    render(&scene, &last);
    assert_shows(&shot, &last, "the re-created file is shown");
}

#[test]
fn a_mesh_replaced_under_the_scene_is_rendered_again() {
    if !have_display() {
        return;
    }
    let d = scratch("view-mesh");
    let (scene, events, shot) = files(&d);
    std::fs::copy(common::data("sphere.obj"), d.join("m.obj")).unwrap();
    save(
        &scene,
        r#"{"sampling": {"resolution": 40, "bounds": [[-1.2, -1.2, -1.2], [1.6, 1.2, 1.2]]},
  "shape": {"union": [
    {"transform": {"scale": 0.8, "of": {"mesh": {"path": "m.obj"}}}},
    {"sphere": {"radius": 0.3, "center": [1.2, 0, 0]}}]}}"#,
    );
    let child = spawn_view(&scene, &events, &shot, &["--exit-after-frames", "2"]);
    wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    // Another mesh saved over the first (written beside it, renamed over it).
    let tmp = d.join("m.obj.part");
    std::fs::copy(common::data("open_cube.obj"), &tmp).unwrap();
    std::fs::rename(&tmp, d.join("m.obj")).unwrap();
    finish(child);
    let ev = read_events(&events);
    assert_eq!(finals(&ev)[1]["reason"], "edit", "{ev:?}");
    let reference = d.join("r.png");
    render(&scene, &reference);
    assert_shows(&shot, &reference, "the new mesh is shown");
}

#[test]
fn bad_options_are_refused_with_one_line() {
    let d = scratch("view-bad");
    let out = common::isokit(&["view", &d.join("missing.json").to_string_lossy()]);
    common::assert_clear_error(&out, "no such file");
    let scene = d.join("s.json");
    save(&scene, &scene_text(0.4));
    let out = common::isokit(&["view", &scene.to_string_lossy(), "--exit-after-frames", "0"]);
    common::assert_clear_error(&out, "--exit-after-frames");
}

#[test]
fn the_resolution_flag_sets_the_sampling() {
    if !have_display() {
        return;
    }
    let d = scratch("view-res");
    let (scene, events, shot) = files(&d);
    save(&scene, &scene_text(0.4));
    let stats = json(&isokit_ok(&[
        "scene",
        &scene.to_string_lossy(),
        "-o",
        &d.join("s.nrrd").to_string_lossy(),
        "--res",
        "32",
        "--stats",
    ]));
    let child = spawn_view(
        &scene,
        &events,
        &shot,
        &["--exit-after-frames", "1", "--res", "32"],
    );
    finish(child);
    let ev = read_events(&events);
    assert_eq!(finals(&ev)[0]["evaluated_bricks"], stats["bricks_kept"]);
}

#[test]
fn a_volume_and_a_molecule_open_too() {
    if !have_display() {
        return;
    }
    let d = scratch("view-volume");
    let (vol, events, shot) = (d.join("t.npy"), d.join("ev.jsonl"), d.join("v.png"));
    isokit_ok(&[
        "sdf",
        &common::data("torus.off"),
        "--res",
        "48",
        "-o",
        &vol.to_string_lossy(),
    ]);
    finish(spawn_view(
        &vol,
        &events,
        &shot,
        &["--exit-after-frames", "1"],
    ));
    let reference = d.join("r.png");
    render(&vol, &reference);
    assert_shows(
        &shot,
        &reference,
        "the volume's first frame against isokit render",
    );
    // The same field as a Zarr store, read on demand: the frame of the NPY volume.
    let store = d.join("t.zarr");
    isokit_ok(&["convert", &vol.to_string_lossy(), &store.to_string_lossy()]);
    std::fs::remove_file(&events).unwrap();
    let npy_shot = d.join("npy.png");
    std::fs::rename(&shot, &npy_shot).unwrap();
    finish(spawn_view(
        &store,
        &events,
        &shot,
        &["--exit-after-frames", "1"],
    ));
    assert!(
        mean_diff(&shot, &npy_shot) == 0.0,
        "the store's first frame differs from the NPY volume's"
    );
    // A molecule (PDB, gzipped): a frame with some atoms on it.
    let mol = Path::new(&common::data("molecules")).join("1a8o.pdb.gz");
    std::fs::remove_file(&events).unwrap();
    finish(spawn_view(
        &mol,
        &events,
        &shot,
        &["--exit-after-frames", "1"],
    ));
    let (_, _, px) = isokit_io::read_png(&shot).unwrap();
    let background = px.chunks(4).filter(|p| p[..3] == [255, 255, 255]).count();
    assert!(background < px.len() / 4, "only background");
    assert_eq!(finals(&read_events(&events))[0]["reason"], "start");
}

/// The window of the viewer whose title names `dir` (its scene's folder), found by xdotool;
/// `None` (skipped, with the reason printed) where xdotool is missing, unless
/// `ISOKIT_REQUIRE_DISPLAY=1`.
fn window_of(dir: &Path) -> Option<String> {
    if Command::new("xdotool").arg("version").output().is_err() {
        assert!(
            std::env::var("ISOKIT_REQUIRE_DISPLAY").as_deref() != Ok("1"),
            "ISOKIT_REQUIRE_DISPLAY=1 but xdotool is missing (.ci/run installs it)"
        );
        eprintln!("skipped: no xdotool to click the panel");
        return None;
    }
    let name = dir.file_name().unwrap().to_string_lossy().to_string();
    let t0 = Instant::now();
    loop {
        let out = Command::new("xdotool")
            .args(["search", "--name", &name])
            .output()
            .unwrap();
        if let Some(w) = String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .next()
        {
            return Some(w.to_string());
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no window named {name}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Runs xdotool on the window `w` (pointer positions relative to it).
fn xdo(w: &str, args: &[&str]) {
    let mut all = vec!["mousemove", "--window", w];
    all.extend_from_slice(args);
    let ok = Command::new("xdotool")
        .args(&all)
        .status()
        .unwrap()
        .success();
    assert!(ok, "xdotool {all:?}");
}

fn panel_frames(ev: &[Value]) -> Vec<&Value> {
    ev.iter()
        .filter(|e| e["event"] == "frame" && e["reason"] == "panel" && e["final"] == true)
        .collect()
}

/// The panel's widgets answer clicks and drags: the shading mode's next button, the
/// isovalue's slider (clicked, then dragged past its left end) and the quit button.
/// Positions follow the panel's layout at one pixel per font pixel (windows under 720
/// pixels high): 8×10-pixel character cells from (4, 3); a widget's column is where its
/// label starts in its line.
#[test]
fn the_panel_widgets_answer_clicks_and_drags() {
    if !have_display() {
        return;
    }
    let d = scratch("view-widgets");
    let (scene, events, shot) = files(&d);
    save(&scene, &scene_text(0.5));
    let mut child = Command::new(env!("CARGO_BIN_EXE_isokit"))
        .arg("view")
        .arg(&scene)
        .args(["--backend", "cpu", "--width", "640", "--height", "400"])
        .arg("--events")
        .arg(&events)
        .arg("--screenshot")
        .arg(&shot)
        .args(["--exit-after-seconds", "90"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("isokit view starts");
    let ev = wait_for(&events, "the first frame", |e| !finals(e).is_empty());
    let first_mode = finals(&ev)[0]["mode"].as_str().unwrap().to_string();
    let Some(w) = window_of(&d) else {
        let _ = child.kill();
        let _ = child.wait();
        return;
    };
    let cell = |col: f32, row: f32| {
        (
            format!("{}", (4.0 + (col + 0.5) * 8.0) as i32),
            format!("{}", (3.0 + (row + 0.5) * 10.0) as i32),
        )
    };
    // Row 1: "shading  " and the mode padded to 10, then " [<] [>]": [>] starts at col 24.
    let (x, y) = cell(25.0, 1.0);
    xdo(&w, &[&x, &y, "click", "1"]);
    let ev = wait_for(&events, "a frame in another mode", |e| {
        panel_frames(e)
            .iter()
            .any(|f| f["mode"] != first_mode.as_str())
    });
    let n = panel_frames(&ev).len();
    // Row 3: the isovalue's slider, 24 columns from col 20; three quarters along it.
    let (x, y) = cell(38.0, 3.0);
    xdo(&w, &[&x, &y, "click", "1"]);
    let ev = wait_for(&events, "a frame at a positive isovalue", |e| {
        panel_frames(e)
            .iter()
            .skip(n)
            .any(|f| f["iso"].as_f64().unwrap() > 0.0)
    });
    let n = panel_frames(&ev).len();
    // Dragged from its middle to the window's left edge: the lowest isovalue, −band.
    let (x, y) = cell(32.0, 3.0);
    xdo(&w, &[&x, &y, "mousedown", "1"]);
    xdo(&w, &["1", &y]);
    xdo(&w, &["1", &y, "mouseup", "1"]);
    let ev = wait_for(&events, "a frame at a negative isovalue", |e| {
        panel_frames(e)
            .iter()
            .skip(n)
            .any(|f| f["iso"].as_f64().unwrap() < 0.0)
    });
    let iso: Vec<f64> = panel_frames(&ev)
        .iter()
        .map(|f| f["iso"].as_f64().unwrap())
        .collect();
    // The slider spans ±band symmetrically: its ends are opposite isovalues.
    let lowest = iso.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(lowest < 0.0, "{iso:?}");
    // Orbiting is not what a press on a widget does: no camera frame came.
    assert!(
        !ev.iter().any(|e| e["reason"] == "camera"),
        "a click on the panel moved the camera"
    );
    // Row 9: "drag orbit, shift-drag pan, wheel zoom" then " [reset view R] [quit Q]".
    let (x, y) = cell(56.0, 9.0);
    let clicked = std::time::Instant::now();
    xdo(&w, &[&x, &y, "click", "1"]);
    // The run would end by itself after 90 s: the quit button ends it long before.
    loop {
        match child.try_wait().unwrap() {
            Some(_) => break,
            None if clicked.elapsed() > std::time::Duration::from_secs(30) => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("the quit button did not end the viewer");
            }
            None => std::thread::sleep(std::time::Duration::from_millis(50)),
        }
    }
    finish(child);
}
