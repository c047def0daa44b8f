//! End-to-end tests of `isokit render VOLUME --lattice spherical --r-range R0,R1
//! --theta-range T0,T1 --phi-range P0,P1` and of the NRRD header keys of the same names: a
//! shell field's isosurface lands on the analytic sphere (read back from the G-buffer), the
//! bundled atmosphere renders in both modes from its header alone, and what does not go with
//! a spherical lattice is refused in one line.

mod common;

use common::{assert_clear_error, data, isokit, isokit_ok, json, scratch};
use glam::Vec3;
use std::path::Path;

/// `r − 0.65` on a lattice over r 0.3..1, theta 0..180 (10°), phi 0..350 (10°, round), as an
/// NPY file (r fastest: shape (nphi, ntheta, nr)).
fn shell_npy(dir: &Path) -> String {
    let (nr, nt, np) = (15usize, 19usize, 36usize);
    let data: Vec<f32> = (0..nr * nt * np)
        .map(|n| 0.3 + 0.7 * (n % nr) as f32 / (nr - 1) as f32 - 0.65)
        .collect();
    let p = dir.join("shell.npy");
    isokit::io::write_npy_f32(&p, &[np, nt, nr], &data).unwrap();
    p.to_str().unwrap().to_string()
}

const SPHERICAL: [&str; 8] = [
    "--lattice",
    "spherical",
    "--r-range",
    "0.3,1",
    "--theta-range",
    "0,180",
    "--phi-range",
    "0,350",
];

#[test]
fn a_shell_on_a_spherical_lattice_renders_the_analytic_sphere() {
    let dir = scratch("spherical-cli");
    let vol = shell_npy(&dir);
    let (png, exr) = (dir.join("s.png"), dir.join("s.exr"));
    let mut args = vec![
        "render",
        &vol,
        "-o",
        png.to_str().unwrap(),
        "--gbuffer",
        exr.to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "48",
        "--eye",
        "2.5,0,0.5",
        "--stats",
    ];
    args.extend(SPHERICAL);
    let stats = json(&isokit_ok(&args));
    assert_eq!(stats["lattice"]["kind"], "spherical");
    assert_eq!(stats["lattice"]["periodic"], true);
    assert_eq!(stats["mode"], "isosurface");
    let hits = stats["surface_pixels"].as_u64().unwrap();
    assert!(hits > 300, "{stats}");
    let g = isokit::io::read_exr(&exr).unwrap();
    let (x, y, z, a) = (
        g.channel("P.X").unwrap(),
        g.channel("P.Y").unwrap(),
        g.channel("P.Z").unwrap(),
        g.channel("A").unwrap(),
    );
    let mut n = 0;
    for i in 0..a.len() {
        if a[i] > 0.5 {
            let r = Vec3::new(x[i], y[i], z[i]).length();
            assert!((r - 0.65).abs() < 1e-4, "pixel {i}: radius {r}");
            n += 1;
        }
    }
    assert_eq!(n as u64, hits);
    // Direct volume rendering of the same file, pre-integrated.
    let tf = dir.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points": [[-0.1, 1, 0.5, 0.2, 8], [0, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    let mut args = vec![
        "render",
        &vol,
        "-o",
        png.to_str().unwrap(),
        "--mode",
        "dvr",
        "--tf",
        tf.to_str().unwrap(),
        "--classification",
        "preintegrated",
        "--width",
        "24",
        "--height",
        "24",
        "--stats",
    ];
    args.extend(SPHERICAL);
    let stats = json(&isokit_ok(&args));
    assert_eq!(stats["mode"], "dvr");
    assert_eq!(stats["classification"], "preintegrated");
    assert!(stats["samples"].as_u64().unwrap() > 0);
}

#[test]
fn the_bundled_atmosphere_renders_from_its_nrrd_header() {
    let dir = scratch("spherical-cli-atmosphere");
    let vol = data("atmosphere.nrrd");
    let keys = isokit::io::read_nrrd_key_values(Path::new(&vol)).unwrap();
    assert!(
        keys.contains(&("lattice".into(), "spherical".into())),
        "{keys:?}"
    );
    let info = json(&isokit_ok(&["info", &vol, "--json"]));
    assert_eq!(info["lattice"]["kind"], "spherical");
    assert_eq!(info["lattice"]["phi_range"][1], 355.0);
    let png = dir.join("a.png");
    let o = png.to_str().unwrap();
    let common = [
        "--width",
        "32",
        "--height",
        "32",
        "--eye",
        "2,-2.4,1.3",
        "--stats",
    ];
    let mut args = vec!["render", &vol, "-o", o, "--iso", "0.5", "--inside", "above"];
    args.extend(common);
    let stats = json(&isokit_ok(&args));
    assert_eq!(stats["lattice"]["r_range"][0], 1.0);
    assert!(stats["surface_pixels"].as_u64().unwrap() > 20, "{stats}");
    let mut args = vec![
        "render",
        &vol,
        "-o",
        o,
        "--mode",
        "dvr",
        "--tf",
        "mri-brain",
    ];
    args.extend(common);
    let stats = json(&isokit_ok(&args));
    assert_eq!(stats["lattice"]["kind"], "spherical");
    // A flag overrides the header: --lattice cartesian renders the array as a box.
    let mut args = vec![
        "render",
        &vol,
        "-o",
        o,
        "--lattice",
        "cartesian",
        "--iso",
        "0.5",
    ];
    args.extend([
        "--inside", "above", "--width", "16", "--height", "16", "--stats",
    ]);
    let stats = json(&isokit_ok(&args));
    assert!(stats.get("lattice").is_none(), "{stats}");
}

#[test]
fn what_does_not_go_with_a_spherical_lattice_is_refused_in_one_line() {
    let dir = scratch("spherical-cli-refusals");
    let vol = shell_npy(&dir);
    let png = dir.join("x.png");
    let o = png.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "render",
            vol.as_str(),
            "-o",
            o,
            "--width",
            "8",
            "--height",
            "8",
        ];
        args.extend(extra);
        isokit(&args)
    };
    let cases: &[(&[&str], &str)] = &[
        (&["--lattice", "spherical"], "needs --r-range"),
        (
            &[
                "--lattice",
                "spherical",
                "--r-range",
                "1,0.5",
                "--theta-range",
                "0,180",
                "--phi-range",
                "0,350",
            ],
            "0 <= r0 < r1",
        ),
        (
            &[
                "--lattice",
                "spherical",
                "--r-range",
                "0.3",
                "--theta-range",
                "0,180",
                "--phi-range",
                "0,350",
            ],
            "two finite numbers",
        ),
        (&["--r-range", "0.3,1"], "add --lattice spherical"),
        (
            &[&SPHERICAL[..], &["--clip", "x.json"]].concat(),
            "--clip is not available",
        ),
        (
            &[&SPHERICAL[..], &["--shading", "curvature"]].concat(),
            "without curvatures",
        ),
        (
            &[&SPHERICAL[..], &["--tf", "mri-brain"]].concat(),
            "applies to --mode dvr",
        ),
        (&[&SPHERICAL[..], &["--mode", "dvr"]].concat(), "needs --tf"),
        (
            &[&SPHERICAL[..], &["--table-build", "incremental"]].concat(),
            "applies to --mode dvr",
        ),
        (
            &[
                &SPHERICAL[..],
                &[
                    "--mode",
                    "dvr",
                    "--tf",
                    "mri-brain",
                    "--gradient",
                    "central",
                ],
            ]
            .concat(),
            "with --shading phong",
        ),
        (
            &[
                &SPHERICAL[..],
                &[
                    "--mode",
                    "dvr",
                    "--tf",
                    "mri-brain",
                    "--table-build",
                    "incremental",
                ],
            ]
            .concat(),
            "--classification preintegrated",
        ),
    ];
    for (extra, want) in cases {
        assert_clear_error(&run(extra), want);
    }
    // A header naming an unknown lattice.
    let bad = dir.join("bad.nrrd");
    let v = isokit::io::Volume {
        dims: [2, 2, 2],
        origin: Vec3::ZERO,
        spacing: Vec3::ONE,
        data: vec![0.0; 8],
    };
    isokit::io::write_nrrd_key_values(
        &bad,
        &v,
        isokit::io::NrrdEncoding::Raw,
        &[("lattice", "polar")],
    )
    .unwrap();
    let out = isokit(&["render", bad.to_str().unwrap(), "-o", o]);
    assert_clear_error(&out, "lattice:=polar");
}
