//! Regenerates the small meshes and clouds shipped in `data/` (see `data/README.md`).
//!
//! Run: `cargo run --release --example make_data` (writes into `data/`).

use anyhow::Result;
use glam::Vec3;
use isokit::io::{NrrdEncoding, Volume, generate, write_mesh, write_nrrd_key_values, write_points};
use std::path::Path;

fn main() -> Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let out = |name: &str| dir.join(name);

    write_mesh(&out("sphere.obj"), &generate::icosphere(Vec3::ZERO, 1.0, 3))?;
    write_mesh(&out("torus.off"), &generate::torus(1.0, 0.35, 48, 24))?;
    let knot = generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 192, 16);
    write_mesh(&out("trefoil.ply"), &knot)?;
    write_mesh(&out("open_cube.obj"), &generate::open_cube(0.5))?;
    write_mesh(&out("degenerate.off"), &generate::degenerate_mesh())?;
    write_points(
        &out("torus_cloud.ply"),
        &generate::torus_cloud(1.0, 0.35, 4000, 2026),
    )?;
    let (dims, data, keys) = atmosphere();
    let volume = Volume {
        dims,
        origin: Vec3::ZERO,
        spacing: Vec3::ONE,
        data,
    };
    write_nrrd_key_values(
        &out("atmosphere.nrrd"),
        &volume,
        NrrdEncoding::GzipBest,
        &keys,
    )?;
    for name in [
        "atmosphere.nrrd",
        "sphere.obj",
        "torus.off",
        "trefoil.ply",
        "open_cube.obj",
        "degenerate.off",
        "torus_cloud.ply",
    ] {
        println!("wrote {}", out(name).display());
    }
    Ok(())
}

/// A cloud layer on a spherical lattice (radius 1 to 1.3, every 5° of polar angle, every 5°
/// of azimuth round the circle): a density that peaks at radius 1.12, in bands that wind
/// with the polar angle, densest away from the poles, and a thin haze above the ground.
#[allow(clippy::type_complexity)]
fn atmosphere() -> ([usize; 3], Vec<f32>, [(&'static str, &'static str); 4]) {
    let (nr, nt, np) = (13, 37, 72);
    let mut data = Vec::with_capacity(nr * nt * np);
    for k in 0..np {
        let phi = (5.0 * k as f32).to_radians();
        for j in 0..nt {
            let theta = (5.0 * j as f32).to_radians();
            for i in 0..nr {
                let r = 1.0 + 0.3 * i as f32 / (nr - 1) as f32;
                let layer = (-((r - 1.12) / 0.07).powi(2)).exp();
                let bands = (4.0 * phi + 3.0 * (2.0 * theta).sin()).sin().max(0.0);
                let haze = 0.25 * (-((r - 1.02) / 0.04).powi(2)).exp();
                data.push(layer * bands * theta.sin().powi(2) + haze);
            }
        }
    }
    let keys = [
        ("lattice", "spherical"),
        ("r-range", "1,1.3"),
        ("theta-range", "0,180"),
        ("phi-range", "0,355"),
    ];
    ([nr, nt, np], data, keys)
}
