//! Zarr stores on the command line: `-o field.zarr` on the sampling commands (the scene
//! sampled chunk by chunk equals its NRRD output bit for bit), `isokit info` on complete and
//! incomplete stores, `--resume`, rendering a store, and refusals.

mod common;

use common::{assert_clear_error, data, isokit, isokit_ok, json, scratch};
use isokit_io::read_volume;
use std::path::Path;

fn demo() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes/demo.json")
        .to_string_lossy()
        .into_owned()
}

fn same_samples(a: &Path, b: &Path) {
    let (x, y) = (read_volume(a).unwrap(), read_volume(b).unwrap());
    assert_eq!(x.dims, y.dims);
    assert_eq!(x.origin, y.origin);
    assert_eq!(x.spacing, y.spacing);
    let differ = x
        .data
        .iter()
        .zip(&y.data)
        .filter(|(p, q)| p.to_bits() != q.to_bits())
        .count();
    assert_eq!(
        differ,
        0,
        "{} and {} differ in {differ} samples",
        a.display(),
        b.display()
    );
}

#[test]
fn a_scene_sampled_chunk_by_chunk_equals_its_nrrd_output() {
    let d = scratch("scene");
    let (nrrd, zarr) = (d.join("f.nrrd"), d.join("f.zarr"));
    let s = demo();
    isokit_ok(&["scene", &s, "--res", "96", "-o", nrrd.to_str().unwrap()]);
    let out = isokit_ok(&[
        "scene",
        &s,
        "--res",
        "96",
        "--chunk",
        "24",
        "--stats",
        "-o",
        zarr.to_str().unwrap(),
    ]);
    same_samples(&nrrd, &zarr);
    let st = json(&out);
    assert!(st["dense_fraction"].as_f64().unwrap() < 1.0);
    let info = json(&isokit_ok(&["info", "--json", zarr.to_str().unwrap()]));
    assert_eq!(info["kind"], "zarr");
    assert_eq!(info["complete"], true);
    assert_eq!(info["chunk_shape"], serde_json::json!([24, 24, 24]));
    assert_eq!(info["band"], st["band"]);
    assert_eq!(info["dims"], st["dims"]);
    let present = info["chunks_present"].as_u64().unwrap();
    assert!(present < info["chunks"].as_u64().unwrap(), "{info}");
    // Rendering the store gives the image of the NRRD file.
    let (a, b) = (d.join("a.png"), d.join("b.png"));
    isokit_ok(&["render", zarr.to_str().unwrap(), "-o", a.to_str().unwrap()]);
    isokit_ok(&["render", nrrd.to_str().unwrap(), "-o", b.to_str().unwrap()]);
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn the_other_sampling_commands_write_stores() {
    let d = scratch("others");
    let sphere = data("sphere.obj");
    for (cmd, input) in [
        ("sdf", sphere.as_str()),
        ("points", &data("torus_cloud.ply")),
    ] {
        let (nrrd, zarr) = (d.join(format!("{cmd}.nrrd")), d.join(format!("{cmd}.zarr")));
        for o in [&nrrd, &zarr] {
            isokit_ok(&[cmd, input, "--res", "40", "-o", o.to_str().unwrap()]);
        }
        same_samples(&nrrd, &zarr);
    }
    // convert: into a store and back, the lattice and band kept.
    let (npy, back) = (d.join("c.npy"), d.join("back.npy"));
    isokit_ok(&["sdf", &sphere, "--res", "30", "-o", npy.to_str().unwrap()]);
    let store = d.join("c.zarr");
    isokit_ok(&["convert", npy.to_str().unwrap(), store.to_str().unwrap()]);
    isokit_ok(&["convert", store.to_str().unwrap(), back.to_str().unwrap()]);
    same_samples(&npy, &back);
    let (a, b) = (
        std::fs::read_to_string(d.join("c.npy.json")).unwrap(),
        std::fs::read_to_string(d.join("back.npy.json")).unwrap(),
    );
    assert_eq!(a, b, "the sidecars differ");
    // A sharded store from the scene sampled shard by shard: the same samples.
    let (plain, sharded) = (d.join("plain.nrrd"), d.join("sharded.zarr"));
    let demo = demo();
    isokit_ok(&["scene", &demo, "--res", "70", "-o", plain.to_str().unwrap()]);
    isokit_ok(&[
        "scene",
        &demo,
        "--res",
        "70",
        "--chunk",
        "8",
        "--shard",
        "3",
        "-o",
        sharded.to_str().unwrap(),
    ]);
    same_samples(&plain, &sharded);
    let info = json(&isokit_ok(&["info", "--json", sharded.to_str().unwrap()]));
    assert_eq!(info["chunk_shape"], serde_json::json!([24, 24, 24]));
    assert_eq!(info["subchunk_shape"], serde_json::json!([8, 8, 8]));
    let zarr = d.join("sample.zarr");
    isokit_ok(&[
        "sample",
        "torus",
        "--res",
        "30",
        "--chunk",
        "7",
        "-o",
        zarr.to_str().unwrap(),
    ]);
    let info = json(&isokit_ok(&["info", "--json", zarr.to_str().unwrap()]));
    assert_eq!(info["chunk_shape"], serde_json::json!([7, 7, 7]));
}

#[test]
fn a_killed_run_leaves_an_incomplete_store_that_resume_finishes() {
    let d = scratch("resume");
    let s = demo();
    let (fresh, z) = (d.join("fresh.zarr"), d.join("k.zarr"));
    isokit_ok(&[
        "scene",
        &s,
        "--res",
        "80",
        "--chunk",
        "16",
        "-o",
        fresh.to_str().unwrap(),
    ]);
    // What a killed run leaves: the partial store with two chunks done (two that hold only
    // the fill value) and no chunk file, and no rename.
    let partial = d.join("k.zarr.partial");
    copy_dir(&fresh, &partial);
    std::fs::remove_dir_all(partial.join("field/c")).unwrap();
    let absent: Vec<String> = (0..4)
        .flat_map(|y| (0..4).map(move |x| format!("0 {y} {x}")))
        .filter(|k| !fresh.join("field/c").join(k.replace(' ', "/")).exists())
        .take(2)
        .collect();
    assert_eq!(
        absent.len(),
        2,
        "two chunks of fill value in the first slab"
    );
    let group = partial.join("zarr.json");
    let mut g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&group).unwrap()).unwrap();
    let print = g["attributes"]["isokit"]["fingerprint"].clone();
    assert!(print.is_string(), "{g}");
    g["attributes"]["isokit"] = serde_json::json!({ "complete": false, "fingerprint": print });
    std::fs::write(&group, g.to_string()).unwrap();
    let progress = format!("{} 0\n{} 0\n", absent[0], absent[1]);
    std::fs::write(partial.join(".isokit-progress"), progress).unwrap();
    let info = json(&isokit_ok(&["info", "--json", z.to_str().unwrap()]));
    assert_eq!(info["complete"], false);
    let chunks = info["chunks"].as_u64().unwrap();
    assert_eq!(info["missing_chunks"].as_u64().unwrap(), chunks - 2);
    let text = String::from_utf8(isokit_ok(&["info", z.to_str().unwrap()]).stdout).unwrap();
    assert!(text.contains("INCOMPLETE"), "{text}");
    // Resume samples only the missing chunks and ends with the fresh store's samples.
    let out = isokit_ok(&[
        "scene",
        &s,
        "--res",
        "80",
        "--chunk",
        "16",
        "--resume",
        "-o",
        z.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("{} of {chunks} chunks left", chunks - 2)),
        "{err}"
    );
    same_samples(&fresh, &z);
    assert!(!partial.exists());
    // Another lattice cannot resume it.
    copy_dir(&fresh, &partial);
    std::fs::write(&group, g.to_string()).unwrap();
    let out = isokit(&[
        "scene",
        &s,
        "--res",
        "90",
        "--chunk",
        "16",
        "--resume",
        "-o",
        z.to_str().unwrap(),
    ]);
    assert_clear_error(&out, "another lattice");
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn outputs_that_are_not_stores_are_refused_before_any_work() {
    let d = scratch("refuse");
    let mine = d.join("mine.zarr");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("keep.txt"), "x").unwrap();
    let out = isokit(&[
        "scene",
        &demo(),
        "--res",
        "40",
        "-o",
        mine.to_str().unwrap(),
    ]);
    assert_clear_error(&out, "not a Zarr store");
    assert!(mine.join("keep.txt").exists());
    let z = d.join("c.zarr");
    let out = isokit(&[
        "sample",
        "sphere",
        "--chunk",
        "0",
        "-o",
        z.to_str().unwrap(),
    ]);
    assert_clear_error(&out, "--chunk 0");
    let out = isokit(&[
        "scene",
        &demo(),
        "--resume",
        "-o",
        d.join("m.nrrd").to_str().unwrap(),
    ]);
    assert_clear_error(&out, "--resume");
    let out = isokit(&["info", d.join("none.zarr").to_str().unwrap()]);
    assert_clear_error(&out, "no such Zarr store");
}
