//! Regenerates the small meshes and clouds shipped in `data/` (see `data/README.md`).
//!
//! Run: `cargo run --release --example make_data` (writes into `data/`).

use anyhow::Result;
use glam::Vec3;
use isokit::io::{generate, write_mesh, write_points};
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
    for name in [
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
