//! The library's contract beyond accuracy: brick grids equal the dense band, bad input is an
//! error (never a panic), non-watertight meshes warn and take winding-number signs.

use glam::Vec3;
use isokit_field::{Grid, rng::SplitMix64};
use isokit_io::{TriMesh, generate};
use isokit_prism::{Engine, GridGeometry, PrismError, PrismOptions, PrismSdf, SignMethod};

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
fn brick_grid_equals_the_dense_band() {
    let mesh = generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 96, 10);
    let g = geometry(&mesh, 45);
    let band = 0.08;
    let sdf = PrismSdf::new(&mesh, PrismOptions::with_band(band)).unwrap();
    let (dense, _) = sdf.grid(&g, &Engine::Cpu).unwrap();
    for (brick, apron) in [(8, 0), (8, 3), (4, 1)] {
        let (bricks, stats) = sdf.brick_grid(&g, brick, apron, &Engine::Cpu).unwrap();
        let back = bricks.to_grid().unwrap();
        assert_eq!(back.data(), dense.data(), "brick {brick} apron {apron}");
        assert!(stats.band_samples > 0);
        // Only bricks the band touches are stored: far fewer than all of them.
        let all: usize = bricks.brick_dims().iter().product();
        assert!(
            bricks.brick_count() < all / 2,
            "{} of {all}",
            bricks.brick_count()
        );
        // Every stored brick holds a band sample; absent bricks read ±band.
        for info in bricks.bricks() {
            assert!(info.min < band as f32 && info.max > -(band as f32));
        }
        // Aprons hold the neighbours' samples.
        let side = brick + 2 * apron;
        for (n, info) in bricks.bricks().iter().enumerate() {
            let data = bricks.brick_data(n);
            let lo = info
                .coord
                .map(|c| (c as usize * brick) as i64 - apron as i64);
            for (m, v) in data.iter().enumerate() {
                let l = [m % side, (m / side) % side, m / (side * side)];
                let q: [usize; 3] = std::array::from_fn(|a| {
                    (lo[a] + l[a] as i64).clamp(0, g.dims[a] as i64 - 1) as usize
                });
                assert_eq!(*v, dense.get(q[0], q[1], q[2]));
            }
        }
    }
}

#[test]
fn inside_bricks_are_marked() {
    let mesh = generate::icosphere(Vec3::ZERO, 1.0, 3);
    let g = geometry(&mesh, 48);
    let sdf = PrismSdf::new(&mesh, PrismOptions::with_band(0.1)).unwrap();
    let (bricks, _) = sdf.brick_grid(&g, 8, 1, &Engine::Cpu).unwrap();
    let c = g.dims.map(|d| d / 2 / 8);
    assert!(bricks.is_inside(c), "the centre brick is inside");
    assert_eq!(
        bricks.get(g.dims[0] / 2, g.dims[1] / 2, g.dims[2] / 2),
        -0.1
    );
    assert_eq!(bricks.get(0, 0, 0), 0.1);
}

#[test]
fn bad_input_is_an_error() {
    let mesh = generate::icosphere(Vec3::ZERO, 1.0, 1);
    for band in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            PrismSdf::new(&mesh, PrismOptions::with_band(band)),
            Err(PrismError::BadBand(_))
        ));
    }
    let empty = TriMesh::new(vec![], vec![]);
    assert!(matches!(
        PrismSdf::new(&empty, PrismOptions::with_band(0.1)),
        Err(PrismError::Mesh(_))
    ));
    let bad_index = TriMesh::new(vec![Vec3::ZERO; 3], vec![[0, 1, 7]]);
    assert!(PrismSdf::new(&bad_index, PrismOptions::with_band(0.1)).is_err());
    let nan = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::NAN], vec![[0, 1, 2]]);
    assert!(PrismSdf::new(&nan, PrismOptions::with_band(0.1)).is_err());
    let sdf = PrismSdf::new(&mesh, PrismOptions::with_band(0.1)).unwrap();
    let g = geometry(&mesh, 16);
    assert!(
        sdf.brick_grid(&g, 8, 4, &Engine::Cpu).is_err(),
        "apron >= brick/2"
    );
    assert!(
        sdf.brick_grid(&g, 6, 1, &Engine::Cpu).is_err(),
        "brick not a power of 2"
    );
    let huge = GridGeometry {
        dims: [1 << 20, 1 << 20, 1 << 20],
        ..g
    };
    assert!(
        sdf.grid(&huge, &Engine::Cpu).is_err(),
        "refused before allocating"
    );
}

#[test]
fn open_meshes_warn_and_use_winding_signs() {
    let cube = generate::open_cube(0.5);
    let sdf = PrismSdf::new(&cube, PrismOptions::with_band(0.2)).unwrap();
    assert_eq!(sdf.sign_method(), SignMethod::Winding);
    let w = sdf.warning().expect("a warning for an open mesh");
    assert!(w.contains("winding"), "{w}");
    let g = geometry(&cube, 24);
    let (grid, stats) = sdf.grid(&g, &Engine::Cpu).unwrap();
    assert!(stats.windings > 0);
    // The centre of the (open) cube is inside by the winding number (about 5/6).
    let c = g.dims.map(|d| d / 2);
    assert!(grid.get(c[0], c[1], c[2]) < 0.0);
    // A closed mesh has no warning.
    let s = PrismSdf::new(
        &generate::icosphere(Vec3::ZERO, 1.0, 1),
        PrismOptions::with_band(0.1),
    )
    .unwrap();
    assert!(s.warning().is_none());
}

#[test]
fn outside_can_stay_nan_and_extreme_scales_work() {
    let mut rng = SplitMix64::new(11);
    for scale in [1e-5f32, 1.0, 1e5] {
        let offset = rng.unit_vector() * 3.0 * scale;
        let mut mesh = generate::icosphere(Vec3::ZERO, scale, 2);
        for p in &mut mesh.positions {
            *p += offset;
        }
        let band = 0.1 * scale as f64;
        let opts = PrismOptions {
            fill_outside: false,
            ..PrismOptions::with_band(band)
        };
        let sdf = PrismSdf::new(&mesh, opts).unwrap();
        let g = geometry(&mesh, 24);
        let (grid, _) = sdf.grid(&g, &Engine::Cpu).unwrap();
        let written = grid.data().iter().filter(|v| !v.is_nan()).count();
        assert!(written > 100 && written < grid.len(), "scale {scale}");
        // Written samples agree with the kd-tree.
        let h = g.spacing as f64;
        let mut st = Default::default();
        for ([i, j, k], v) in grid.iter() {
            if v.is_nan() {
                continue;
            }
            let p = g.origin.as_dvec3() + h * glam::DVec3::new(i as f64, j as f64, k as f64);
            let want = sdf.reference().signed_distance_band(p, band, &mut st);
            assert!(
                (v as f64 - want).abs() <= 1e-5 * h + 1e-6 * want.abs(),
                "scale {scale}: {v} vs {want}"
            );
        }
    }
}

/// `--backend cpu` opens no device; the CPU engine says where it runs.
#[test]
fn cpu_choice_opens_no_device() {
    let (gpu, note) = isokit_prism::PrismGpu::choose(isokit_gpu::BackendChoice::Cpu).unwrap();
    assert!(gpu.is_none() && note.is_none());
    let engine = Engine::from(gpu.as_ref());
    assert!(matches!(engine, Engine::Cpu));
    assert!(
        engine.describe().starts_with("CPU, "),
        "{}",
        engine.describe()
    );
}
