//! End-to-end tests of `isokit molecule`: PDB and mmCIF to PNG and G-buffer, both styles,
//! shadows and outlines, the GPU backend against the CPU's, and clear errors on bad input.

mod common;

use common::{assert_clear_error, isokit, json, scratch};
use std::path::Path;

fn molecule(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/molecules")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

fn run(input: &str, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "molecule",
        input,
        "-o",
        out.to_str().unwrap(),
        "--width",
        "96",
        "--height",
        "72",
        "--stats",
    ];
    args.extend_from_slice(extra);
    json(&isokit(&args))
}

#[test]
fn pdb_and_mmcif_give_the_same_picture() {
    let dir = scratch("molecule-formats");
    let (a, b) = (dir.join("pdb.png"), dir.join("cif.png"));
    let exr = dir.join("g.exr");
    let ja = run(
        &molecule("1a8o.pdb.gz"),
        &a,
        &["--backend", "cpu", "--gbuffer", exr.to_str().unwrap()],
    );
    let jb = run(&molecule("1a8o.cif.gz"), &b, &["--backend", "cpu"]);
    assert_eq!(ja["atoms"], 644, "{ja}");
    assert_eq!(ja["atoms"], jb["atoms"]);
    assert_eq!(ja["bonds"], jb["bonds"]);
    assert!(ja["covered_pixels"].as_u64().unwrap() > 300, "{ja}");
    let (pa, pb) = (
        isokit::io::read_png(&a).unwrap().2,
        isokit::io::read_png(&b).unwrap().2,
    );
    assert_eq!(pa, pb);
    let info = isokit::io::read_exr_info(&exr).unwrap();
    assert!(info.channels.iter().any(|c| c == "K1"));
    // The file's pixels are the G-buffer the library splats for the same molecule and
    // settings (the command's defaults: ball-and-stick, Phong, no shadows), channel by channel.
    let mol = isokit::molecule::read_molecule(Path::new(&molecule("1a8o.pdb.gz"))).unwrap();
    let settings = isokit::scene::MoleculeSettings {
        width: 96,
        height: 72,
        ..Default::default()
    };
    let frame = isokit::scene::Renderer::cpu()
        .render_molecule(&mol, &settings)
        .unwrap();
    let back = isokit::io::read_exr(&exr).unwrap();
    frame.frame.gbuffer.matches_exr(&back).unwrap();
    assert_eq!(
        frame.frame.gbuffer.hit_count() as u64,
        ja["covered_pixels"].as_u64().unwrap()
    );
}

#[test]
fn spacefill_with_shadows_and_outlines() {
    let dir = scratch("molecule-effects");
    let out = dir.join("m.png");
    let j = run(
        &molecule("7ddo.pdb.gz"),
        &out,
        &[
            "--backend",
            "cpu",
            "--style",
            "spacefill",
            "--shadows",
            "--outlines",
            "--shadow-map",
            "256",
        ],
    );
    assert_eq!(j["style"], "spacefill");
    assert_eq!(j["quadrics"], j["atoms"]);
    assert!(j["shadow_samples"].as_u64().unwrap() > 0, "{j}");
    assert!(out.exists());
}

/// `--backend gpu` splats and shades on the GPU (lavapipe in CI) the picture the CPU makes.
#[test]
fn gpu_backend_splats_like_the_cpu() {
    if isokit::render::gpu::testing::run_or_skip(
        "gpu_backend_splats_like_the_cpu",
        isokit::render::gpu::GpuRenderer::open(),
        |g| g.describe(),
    )
    .is_none()
    {
        return;
    }
    let dir = scratch("molecule-gpu");
    let (c, g) = (dir.join("cpu.png"), dir.join("gpu.png"));
    let extra = ["--shadows", "--outlines", "--shadow-map", "256"];
    let jc = run(
        &molecule("1a8o.pdb.gz"),
        &c,
        &[&["--backend", "cpu"][..], &extra].concat(),
    );
    let jg = run(
        &molecule("1a8o.pdb.gz"),
        &g,
        &[&["--backend", "gpu"][..], &extra].concat(),
    );
    assert_eq!(jg["backend"], "gpu", "{jg}");
    let diff =
        (jc["covered_pixels"].as_i64().unwrap() - jg["covered_pixels"].as_i64().unwrap()).abs();
    assert!(diff <= 3, "{jc} {jg}");
    let (pc, pg) = (
        isokit::io::read_png(&c).unwrap().2,
        isokit::io::read_png(&g).unwrap().2,
    );
    let mean = pc
        .iter()
        .zip(&pg)
        .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
        .sum::<f64>()
        / pc.len() as f64
        / 255.0;
    assert!(mean < 2e-3, "mean difference {mean}");
}

#[test]
fn bad_input_gives_one_clear_line() {
    let dir = scratch("molecule-bad");
    let bad = dir.join("bad.pdb");
    std::fs::write(
        &bad,
        "HEADER    TEST\nATOM      1  CA  ALA A   1      12.3a   1.000   2.000  1.00  0.00           C\n",
    )
    .unwrap();
    let out = dir.join("x.png");
    let o = isokit(&[
        "molecule",
        bad.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_clear_error(&o, "line 2");
    assert!(!out.exists());
    let empty = dir.join("empty.cif");
    std::fs::write(&empty, "data_x\n_cell.length_a 1.0\n").unwrap();
    let o = isokit(&[
        "molecule",
        empty.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_clear_error(&o, "empty.cif");
    let o = isokit(&["molecule", "no/such.pdb", "-o", out.to_str().unwrap()]);
    assert_clear_error(&o, "no/such.pdb");
    let o = isokit(&[
        "molecule",
        &molecule("1a8o.pdb.gz"),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "0",
    ]);
    assert_clear_error(&o, "image size");
    let o = isokit(&[
        "molecule",
        &molecule("1a8o.pdb.gz"),
        "-o",
        out.to_str().unwrap(),
        "--shadows",
        "--shadow-map",
        "100000",
    ]);
    assert_clear_error(&o, "--shadow-map");
    let o = isokit(&["molecule", &molecule("1a8o.pdb.gz"), "-o", "x.jpg"]);
    assert_clear_error(&o, "unknown output format");
}
