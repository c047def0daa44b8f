//! The GPU kernel against its CPU twin (on lavapipe in CI): the same keys up to f32
//! rounding, so the same values within 1e-5 of the band width and the same signs. Skips with
//! a printed reason where no adapter exists, fails instead when `ISOKIT_REQUIRE_GPU=1`.

use glam::Vec3;
use isokit_field::Grid;
use isokit_gpu::testing::gpu_or_skip;
use isokit_io::{TriMesh, generate, read_mesh};
use isokit_prism::{Engine, GridGeometry, PrismGpu, PrismOptions, PrismSdf};

fn data(name: &str) -> TriMesh {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name);
    read_mesh(&p).unwrap()
}

fn geometry(mesh: &TriMesh, res: usize) -> GridGeometry {
    let pad = 0.15 * mesh.bounds().diagonal();
    let (dims, origin, spacing) = Grid::covering_geometry(mesh.bounds(), res, pad).unwrap();
    GridGeometry {
        dims,
        origin,
        spacing,
    }
}

#[test]
fn gpu_equals_cpu_twin() {
    let Some(gpu) = gpu_or_skip("gpu_equals_cpu_twin") else {
        return;
    };
    let pg = PrismGpu::new(gpu).unwrap();
    let cases = [
        ("sphere", data("sphere.obj"), 40, 0.1),
        ("torus", data("torus.off"), 40, 0.2),
        ("trefoil", data("trefoil.ply"), 48, 0.1),
        (
            "degenerate (winding signs)",
            data("degenerate.off"),
            24,
            0.1,
        ),
        (
            "small icosphere, wide band",
            generate::icosphere(Vec3::new(0.3, -0.2, 0.1), 0.7, 2),
            32,
            0.5,
        ),
    ];
    for (name, mesh, res, band_rel) in cases {
        let g = geometry(&mesh, res);
        let band = (band_rel * mesh.bounds().size().max_element()) as f64;
        let sdf = PrismSdf::new(&mesh, PrismOptions::with_band(band)).unwrap();
        let (cpu, _) = sdf.grid(&g, &Engine::Cpu).unwrap();
        let (gpu, _) = sdf.grid(&g, &Engine::Gpu(&pg)).unwrap();
        let tol = 1e-5 * band;
        let mut worst = 0.0f64;
        let mut band_samples = 0;
        for (a, b) in cpu.data().iter().zip(gpu.data()) {
            let d = (*a as f64 - *b as f64).abs();
            worst = worst.max(d);
            band_samples += usize::from((a.abs() as f64) < band);
            assert!(
                d <= tol,
                "{name}: cpu {a} vs gpu {b} differ by {d:e} > {tol:e}"
            );
        }
        assert!(band_samples > 20, "{name}: no band");
        eprintln!(
            "{name}: {band_samples} band samples, largest CPU–GPU difference {:.2e} of the band",
            worst / band
        );
    }
}

#[test]
fn gpu_brick_grid_equals_cpu_dense() {
    let Some(gpu) = gpu_or_skip("gpu_brick_grid_equals_cpu_dense") else {
        return;
    };
    let pg = PrismGpu::new(gpu).unwrap();
    let mesh = data("trefoil.ply");
    let g = geometry(&mesh, 40);
    let band = 0.05 * mesh.bounds().size().max_element() as f64;
    let sdf = PrismSdf::new(&mesh, PrismOptions::with_band(band)).unwrap();
    let (dense, _) = sdf.grid(&g, &Engine::Cpu).unwrap();
    let (bricks, _) = sdf.brick_grid(&g, 8, 1, &Engine::Gpu(&pg)).unwrap();
    let back = bricks.to_grid().unwrap();
    for (a, b) in dense.data().iter().zip(back.data()) {
        assert!(((a - b) as f64).abs() <= 1e-5 * band, "{a} vs {b}");
    }
}
