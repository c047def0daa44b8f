//! What `isokit points CLOUD --res N [--sign nearest|winding]` does, without the CLI's
//! other dependencies: the cloud's field sampled densely on the lattice over its bounds
//! padded by 10% of their diagonal, with the build and sampling times.
//!
//! `cargo run --release -p isokit-points --example points_grid -- CLOUD.ply 64 winding
//! [OUT.npy]` (the samples as an (nz, ny, nx) float32 array; origin and spacing printed).

use isokit_field::{Aabb, Grid, Job};
use isokit_points::{CloudGridOptions, PointSdfOptions, SignRule, cloud_to_grid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 2 {
        return Err("usage: points_grid CLOUD [RES] [nearest|winding|winding-everywhere]".into());
    }
    let res: usize = args.get(2).map_or(Ok(64), |s| s.parse())?;
    let sign = match args.get(3).map_or("winding", String::as_str) {
        "nearest" => SignRule::Nearest,
        "winding" => SignRule::Winding,
        "winding-everywhere" => SignRule::WindingEverywhere,
        s => return Err(format!("unknown sign rule {s}").into()),
    };
    let cloud = isokit_io::read_points(std::path::Path::new(&args[1]))?;
    let b = Aabb::from_points(&cloud.points);
    let mut grid = Grid::covering(b, res, 0.1 * b.diagonal())?;
    let opts = CloudGridOptions {
        field: PointSdfOptions {
            sign,
            ..PointSdfOptions::default()
        },
        ..CloudGridOptions::default()
    };
    let st = cloud_to_grid(&cloud, &mut grid, &opts, &Job::default())?;
    println!(
        "{} samples, {:?} grid, sign {}: build {:.2} s (winding number {:.2} s), sampling {:.2} s",
        st.build.samples,
        grid.dims(),
        sign.name(),
        st.build_seconds,
        st.build.winding_seconds,
        st.sample_seconds
    );
    if let Some(out) = args.get(4) {
        let [nx, ny, nz] = grid.dims();
        isokit_io::write_npy_f32(std::path::Path::new(out), &[nz, ny, nx], grid.data())?;
        let o = grid.origin();
        println!(
            "wrote {out}: origin {} {} {}, spacing {}",
            o.x,
            o.y,
            o.z,
            grid.spacing()
        );
    }
    Ok(())
}
