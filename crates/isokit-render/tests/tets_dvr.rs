//! Direct volume rendering through tetrahedra against exact references. A linear field is
//! linear along a whole ray through a convex grid, so the exact colour and opacity of a ray
//! is one segment from its entry value to its exit value ([`TransferFunction::segment`]
//! with many sub-steps); the regular grid's renderer sees the same field; a constant
//! extinction passes opacity 0.5 at ln 2 / σ.

mod common;

use glam::{DVec3, Vec3, Vec4};
use isokit_field::primitives::Sphere;
use isokit_field::{Camera, Grid, Job, Projection, TetGrid, TetSplit, sample_into};
use isokit_render::dvr::{Classification, DvrOptions, TransferFunction, render_dvr};
use isokit_render::tets::dvr::{TetDvrOptions, TetVolume};

const A: Vec3 = Vec3::new(0.6, -0.35, 0.25);

fn linear_grid(n: usize) -> Grid {
    let mut g = Grid::new([n, n, n], Vec3::splat(-1.0), 2.0 / (n - 1) as f32).unwrap();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = g.position(i, j, k);
                g.set(i, j, k, A.dot(p) + 0.1);
            }
        }
    }
    g
}

/// Emission and extinction with three linear pieces over the field's range (−1.1 .. 1.3).
fn tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"points": [[-1.2, 0.1, 0.2, 0.9, 0.2], [-0.2, 0.2, 0.9, 0.3, 2.5],
                       [0.3, 1.0, 0.6, 0.1, 0.6], [1.3, 0.9, 0.1, 0.1, 1.8]]}"#,
    )
    .unwrap()
}

fn camera(size: u32) -> Camera {
    Camera::look_at(
        Vec3::new(2.6, 1.9, 1.4),
        Vec3::ZERO,
        Vec3::Z,
        Projection::Perspective {
            fov_y_degrees: 45.0,
        },
        size,
        size,
    )
    .unwrap()
}

/// The exact colour and opacity of each pixel's ray through the box [−1, 1]³ of the
/// linear field, or `None` where the ray passes within 1e-4 of the box's edges (where the
/// f32 camera rays and the cells' f64 walk may disagree about meeting the box).
fn exact(cam: &Camera, tf: &TransferFunction) -> Vec<Option<Vec4>> {
    let (w, h) = (cam.width(), cam.height());
    (0..w * h)
        .map(|p| {
            let ray = cam.ray((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3().normalize());
            let inv = DVec3::ONE / d;
            let (a, b) = ((DVec3::splat(-1.0) - o) * inv, (DVec3::ONE - o) * inv);
            let (t0, t1) = (a.min(b).max_element(), a.max(b).min_element());
            if t1 <= t0 {
                return Some(Vec4::ZERO);
            }
            // Near an edge of the box: two slabs' parameters nearly tie.
            let ends = [a.min(b), a.max(b)];
            let near = |v: DVec3, t: f64| {
                let mut s = [v.x, v.y, v.z];
                s.sort_by(f64::total_cmp);
                s.iter().filter(|&&x| (x - t).abs() < 1e-4).count() > 1
            };
            if near(ends[0], t0) || near(ends[1], t1) || t1 - t0 < 1e-3 {
                return None;
            }
            let v = |t: f64| A.as_dvec3().dot(o + t * d) + 0.1;
            Some(tf.segment(v(t0) as f32, v(t1) as f32, (t1 - t0) as f32, 2048))
        })
        .collect()
}

fn worst(img: &[Vec4], reference: &[Option<Vec4>]) -> (f32, usize) {
    let mut compared = 0;
    let w = img
        .iter()
        .zip(reference)
        .filter_map(|(p, r)| r.map(|r| (*p - r).abs().max_element()))
        .inspect(|_| compared += 1)
        .fold(0.0f32, f32::max);
    (w, compared)
}

#[test]
fn a_linear_field_through_tetrahedra_is_its_exact_integral() {
    let grid = linear_grid(9);
    let tf = tf();
    let cam = camera(48);
    let reference = exact(&cam, &tf);
    for split in [TetSplit::Five, TetSplit::Six] {
        let tets = TetGrid::from_grid(&grid, split).unwrap();
        let vol = TetVolume::new(&tets);
        let job = Job::new();
        // Measured: 2.0e-4 and 2.1e-4 integrated per segment, 4.3e-4 and 4.9e-4 from the table.
        for (table_size, tol) in [(0, 3e-4), (128, 7e-4)] {
            let opts = TetDvrOptions {
                table_size,
                termination: 1.0,
                ..TetDvrOptions::default()
            };
            let img = vol.render(&cam, &tf, &opts, &job).unwrap();
            let (w, compared) = worst(&img.rgba, &reference);
            eprintln!("{split:?} table {table_size}: worst {w} over {compared} rays");
            assert!(compared > 1500, "{compared}");
            assert!(w < tol, "{split:?} table {table_size}: {w}");
            assert!(img.samples > 0);
        }
    }
}

#[test]
fn tetrahedra_and_the_regular_grid_render_the_same_linear_field_alike() {
    let grid = linear_grid(9);
    let tf = tf();
    let cam = camera(40);
    let tets = TetGrid::from_grid(&grid, TetSplit::Five).unwrap();
    let img = TetVolume::new(&tets)
        .render(&cam, &tf, &TetDvrOptions::default(), &Job::new())
        .unwrap();
    let regular = render_dvr(
        &grid,
        &cam,
        &tf,
        &DvrOptions {
            classification: Classification::Preintegrated,
            step: Some(0.02),
            ..DvrOptions::default()
        },
    )
    .unwrap();
    let reference = exact(&cam, &tf);
    let masked: Vec<Vec4> = img
        .rgba
        .iter()
        .zip(&reference)
        .map(|(p, r)| if r.is_some() { *p } else { Vec4::ZERO })
        .collect();
    let regular_ref: Vec<Option<Vec4>> = regular
        .rgba
        .iter()
        .zip(&reference)
        .map(|(p, r)| r.map(|_| *p))
        .collect();
    let (w, compared) = worst(&masked, &regular_ref);
    eprintln!("tetrahedra against the regular grid: worst {w} over {compared} rays");
    assert!(compared > 1000);
    // Measured: 3.0e-4.
    assert!(w < 2e-3, "{w}");
}

#[test]
fn a_constant_extinction_passes_half_opacity_at_ln2_over_sigma() {
    let grid = linear_grid(7);
    let tets = TetGrid::from_grid(&grid, TetSplit::Six).unwrap();
    let sigma = 1.5f32;
    let tf = TransferFunction::from_json(&format!(
        r#"{{"points": [[-2, 1, 1, 1, {sigma}], [2, 1, 1, 1, {sigma}]]}}"#
    ))
    .unwrap();
    let cam = Camera::look_at(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 1.0 },
        8,
        8,
    )
    .unwrap();
    let img = TetVolume::new(&tets)
        .render(&cam, &tf, &TetDvrOptions::default(), &Job::new())
        .unwrap();
    // Straight down through 2 units: opacity 1 − e^(−3), depth 3 + ln 2 / σ.
    for (p, z) in img.rgba.iter().zip(&img.depth) {
        assert!((p.w - (1.0 - (-2.0 * sigma).exp())).abs() < 2e-3, "{p}");
        assert!(
            (z - (3.0 + std::f32::consts::LN_2 / sigma)).abs() < 2e-3,
            "{z}"
        );
    }
}

#[test]
fn pre_integration_beats_post_classification_on_coarse_cells() {
    // A sphere's distance on a coarse grid, a thin shell in the transfer function: the
    // segments' middle values miss it where pre-integration does not.
    let mut g = Grid::new([7, 7, 7], Vec3::splat(-1.0), 2.0 / 6.0).unwrap();
    sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut g);
    let tets = TetGrid::from_grid(&g, TetSplit::Five).unwrap();
    let tf = TransferFunction::from_json(
        r#"{"points": [[-0.05, 0, 0, 0, 0], [0, 1, 0.8, 0.3, 40], [0.05, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    let cam = camera(32);
    let vol = TetVolume::new(&tets);
    let job = Job::new();
    let render = |classification, table_size| {
        let opts = TetDvrOptions {
            classification,
            table_size,
            ..TetDvrOptions::default()
        };
        vol.render(&cam, &tf, &opts, &job).unwrap()
    };
    let exact = render(Classification::Preintegrated, 0);
    let table = render(Classification::Preintegrated, 256);
    let post = render(Classification::Post, 0);
    let err = |img: &isokit_render::dvr::DvrImage| {
        let e: f32 = img
            .rgba
            .iter()
            .zip(&exact.rgba)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .sum();
        e / img.rgba.len() as f32
    };
    let (e_table, e_post) = (err(&table), err(&post));
    eprintln!("mean error: table {e_table}, post {e_post}");
    assert!(exact.rgba.iter().filter(|p| p.w > 0.1).count() > 200);
    assert!(e_table < 0.05 * e_post, "table {e_table}, post {e_post}");
}

#[test]
fn shading_termination_and_non_finite_cells() {
    let mut grid = linear_grid(6);
    grid.set(2, 3, 3, f32::NAN);
    let tets = TetGrid::from_grid(&grid, TetSplit::Five).unwrap();
    let vol = TetVolume::new(&tets);
    let tf = tf();
    let cam = camera(24);
    let job = Job::new();
    let plain = vol
        .render(&cam, &tf, &TetDvrOptions::default(), &job)
        .unwrap();
    let shaded = vol
        .render(
            &cam,
            &tf,
            &TetDvrOptions {
                shade: true,
                ..TetDvrOptions::default()
            },
            &job,
        )
        .unwrap();
    let early = vol
        .render(
            &cam,
            &tf,
            &TetDvrOptions {
                termination: 0.3,
                ..TetDvrOptions::default()
            },
            &job,
        )
        .unwrap();
    for img in [&plain, &shaded, &early] {
        assert!(img.rgba.iter().all(|p| p.is_finite() && p.w <= 1.0));
    }
    // Shading changes colours, not opacities; stopping early stops at the set opacity.
    assert!(
        plain
            .rgba
            .iter()
            .zip(&shaded.rgba)
            .any(|(a, b)| (a.x - b.x).abs() > 1e-3)
    );
    assert!(plain.rgba.iter().zip(&shaded.rgba).all(|(a, b)| a.w == b.w));
    assert!(early.samples < plain.samples);
    assert!(early.rgba.iter().all(|p| p.w < 0.3 + 0.35));
    let bad = TetDvrOptions {
        termination: 1.5,
        ..TetDvrOptions::default()
    };
    assert!(vol.render(&cam, &tf, &bad, &job).is_err());
}

#[test]
fn a_graded_grid_of_cells_ten_times_apart_in_size_keeps_its_accuracy() {
    // The lattice's x squeezed towards 0 by g(x) = (x + 3x³) / 4 (g' from 0.25 to 2.5),
    // the field linear in the moved points: still the box, still linear along every ray.
    let even = TetGrid::from_grid(&linear_grid(13), TetSplit::Six).unwrap();
    let points: Vec<Vec3> = even
        .points()
        .iter()
        .map(|p| Vec3::new((p.x + 3.0 * p.x.powi(3)) / 4.0, p.y, p.z))
        .collect();
    let values = points.iter().map(|p| A.dot(*p) + 0.1).collect();
    let graded = TetGrid::new(points, even.tets().to_vec(), values, "graded").unwrap();
    let vol = TetVolume::new(&graded);
    assert!(vol.longest_edge() > 1.5 * vol.mean_edge());
    let (tf, cam) = (tf(), camera(40));
    let reference = exact(&cam, &tf);
    let opts = TetDvrOptions {
        termination: 1.0,
        ..TetDvrOptions::default()
    };
    let img = vol.render(&cam, &tf, &opts, &Job::new()).unwrap();
    let (w, compared) = worst(&img.rgba, &reference);
    eprintln!("graded: worst {w} over {compared} rays");
    assert!(compared > 1000);
    // Measured: 4.4e-4 (the table spans the 95th percentile of the cells' longest edges,
    // the longer segments cut into pieces).
    assert!(w < 7e-4, "{w}");
}

/// Two grids of the same space and linear field: two cells, and the same with the upper one
/// cut around a point of the shared face into three cells and a flat one between them and
/// the lower cell; a transfer function and a camera looking up through the lower cell.
fn flat_cell_grids() -> (TetGrid, TetGrid, TransferFunction, Camera) {
    let (a, b, c) = (
        Vec3::new(-1.0, -0.8, 0.0),
        Vec3::new(1.0, -0.7, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    );
    let (bottom, top, e) = (
        Vec3::new(0.1, 0.0, -1.0),
        Vec3::new(-0.1, 0.1, 1.2),
        Vec3::new(0.05, -0.1, 0.0),
    );
    let field = |p: &Vec3| 0.4 * p.z + 0.1 * p.x;
    let orient = |t: [u32; 4], pts: &[Vec3]| isokit_field::tet::positive(t, pts);
    let make = |points: Vec<Vec3>, cells: Vec<[u32; 4]>| {
        let cells = cells.into_iter().map(|t| orient(t, &points)).collect();
        let values = points.iter().map(field).collect();
        TetGrid::new(points, cells, values, "v").unwrap()
    };
    let whole = make(vec![a, b, c, bottom, top], vec![[0, 1, 2, 3], [0, 1, 2, 4]]);
    let cut = make(
        vec![a, b, c, bottom, top, e],
        vec![
            [0, 1, 2, 3],
            [0, 1, 2, 5],
            [0, 1, 5, 4],
            [1, 2, 5, 4],
            [2, 0, 5, 4],
        ],
    );
    let tf = TransferFunction::from_json(
        r#"{"points": [[-0.6, 1, 0.5, 0.2, 1.5], [0.6, 0.2, 0.6, 1, 2.5]]}"#,
    )
    .unwrap();
    // Looking up from below, through A first.
    let cam = Camera::look_at(
        Vec3::new(0.2, 0.3, -4.0),
        Vec3::new(0.0, 0.0, 0.1),
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        32,
        32,
    )
    .unwrap();
    (whole, cut, tf, cam)
}

#[test]
fn a_flat_cell_inside_the_grid_is_stepped_across() {
    // Below: A = (a, b, c, bottom). Above the face abc: either one cell B = (a, b, c, top),
    // or the same space cut around a point e inside abc into three cells, with the flat
    // cell (a, b, c, e) between them and A. Both grids fill the same space with the same
    // linear field: the images must agree (a walk that stopped at the flat cell lost
    // everything above it).
    let (whole, cut, tf, cam) = flat_cell_grids();
    assert_eq!(cut.report().degenerate, 1);
    let opts = TetDvrOptions {
        table_size: 0,
        termination: 1.0,
        ..TetDvrOptions::default()
    };
    let job = Job::new();
    let one = TetVolume::new(&whole)
        .render(&cam, &tf, &opts, &job)
        .unwrap();
    let three = TetVolume::new(&cut).render(&cam, &tf, &opts, &job).unwrap();
    let covered = one.rgba.iter().filter(|p| p.w > 0.05).count();
    let worst = one
        .rgba
        .iter()
        .zip(&three.rgba)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max);
    eprintln!("flat cell: worst {worst} over {covered} covered pixels");
    // Measured: 3.0e-4 (the segments' sub-steps differ between one cell and three); 0.31
    // when the walk stopped at the flat cell.
    assert!(covered > 100, "{covered}");
    assert!(worst < 1e-3, "{worst}");
}

#[test]
fn the_gpu_twin_renders_what_the_cpu_twin_renders() {
    let Some(mut r) =
        common::twin::gpu_renderer("tets_dvr::the_gpu_twin_renders_what_the_cpu_twin_renders")
    else {
        return;
    };
    let tf = tf();
    let cam = camera(40);
    let reference = exact(&cam, &tf);
    let job = Job::new();
    // The linear field (against its exact integral too) and a sphere's distance, in both
    // splits; every classification, with and without shading and early termination.
    let mut sphere = Grid::new([13; 3], Vec3::splat(-1.0), 2.0 / 12.0).unwrap();
    sample_into(
        &Sphere::new(Vec3::new(0.1, 0.0, -0.05), 0.7).unwrap(),
        &mut sphere,
    );
    for (name, grid) in [("linear", linear_grid(9)), ("sphere", sphere)] {
        for split in [TetSplit::Five, TetSplit::Six] {
            let tets = TetGrid::from_grid(&grid, split).unwrap();
            let vol = TetVolume::new(&tets);
            for (classification, table_size, shade, termination) in [
                (Classification::Preintegrated, 64, false, 1.0),
                (Classification::Preintegrated, 0, false, 1.0),
                (Classification::Post, 64, false, 1.0),
                (Classification::Preintegrated, 64, true, 0.9),
            ] {
                // A smaller table than the default (64² values, 32 lengths): the test is of
                // the twins, not of the table's resolution.
                let opts = TetDvrOptions {
                    classification,
                    table_size,
                    table_lengths: 32,
                    shade,
                    termination,
                };
                let cpu = vol.render(&cam, &tf, &opts, &job).unwrap();
                let gpu = r.render_tets_dvr(&vol, &cam, &tf, &opts).unwrap();
                let (d, masks, dz) = common::dvr_difference(&cpu, &gpu, grid.spacing());
                eprintln!(
                    "{name} {split:?} {classification:?} table {table_size} shaded {shade} termination {termination}: colour/opacity {d:.1e}, depth {dz:.1e} spacing, {masks} depth masks differ, segments {} / {}",
                    cpu.samples, gpu.samples
                );
                assert!(cpu.rgba.iter().any(|p| p.w > 0.3));
                // Measured on lavapipe: up to 2.9e-6 unshaded; 1.2e-4 shaded, where a
                // segment's opacity rounds to either side of SHADE_MIN_OPACITY (1e-3, below
                // which a segment is not shaded).
                assert!(d < if shade { 1e-3 } else { 1e-5 }, "{d}");
                assert!(dz < 1e-3 && masks <= 2, "{dz} {masks}");
                let rel = (cpu.samples as f64 - gpu.samples as f64).abs() / cpu.samples as f64;
                assert!(rel < 1e-3, "{} {}", cpu.samples, gpu.samples);
                if name == "linear" && termination == 1.0 && !shade {
                    let (w, compared) = worst(&gpu.rgba, &reference);
                    let (wc, _) = worst(&cpu.rgba, &reference);
                    eprintln!(
                        "  against the exact integral: gpu {w:.1e}, cpu {wc:.1e} over {compared} rays"
                    );
                    assert!(w < wc + 1e-5, "{w} {wc}");
                }
            }
        }
    }
    // Rays in chunks (as images too large for one dispatch are traced): the same image.
    let tets = TetGrid::from_grid(&linear_grid(9), TetSplit::Six).unwrap();
    let vol = TetVolume::new(&tets);
    let opts = TetDvrOptions::default();
    let whole = r.render_tets_dvr(&vol, &cam, &tf, &opts).unwrap();
    r.set_max_rays_per_dispatch(333);
    let chunked = r.render_tets_dvr(&vol, &cam, &tf, &opts).unwrap();
    assert_eq!(whole.rgba, chunked.rgba);
    assert_eq!(whole.samples, chunked.samples);
    // A flat cell stepped across (with f32's tolerance on the GPU).
    let (_, cut, tf_flat, cam_flat) = flat_cell_grids();
    let vol = TetVolume::new(&cut);
    let opts = TetDvrOptions {
        termination: 1.0,
        ..TetDvrOptions::default()
    };
    let cpu = vol.render(&cam_flat, &tf_flat, &opts, &job).unwrap();
    let gpu = r.render_tets_dvr(&vol, &cam_flat, &tf_flat, &opts).unwrap();
    let d = common::max_diff(&cpu.rgba, &gpu.rgba);
    eprintln!(
        "flat cell: colour/opacity {d:.1e}, segments {} / {}",
        cpu.samples, gpu.samples
    );
    assert!(cpu.rgba.iter().filter(|p| p.w > 0.05).count() > 100);
    assert!(d < 1e-5, "{d}");
    // Non-finite values: their cells clear on both twins (flagged on the host for the GPU).
    let mut bad = linear_grid(6);
    bad.set(2, 3, 3, f32::NAN);
    bad.set(3, 2, 2, f32::INFINITY);
    let tets = TetGrid::from_grid(&bad, TetSplit::Five).unwrap();
    let vol = TetVolume::new(&tets);
    let cpu = vol
        .render(&cam, &tf, &TetDvrOptions::default(), &job)
        .unwrap();
    let gpu = r
        .render_tets_dvr(&vol, &cam, &tf, &TetDvrOptions::default())
        .unwrap();
    let d = common::max_diff(&cpu.rgba, &gpu.rgba);
    eprintln!(
        "non-finite values: colour/opacity {d:.1e}, segments {} / {}",
        cpu.samples, gpu.samples
    );
    assert!(d < 1e-5 && cpu.samples == gpu.samples, "{d}");
    assert!(gpu.rgba.iter().all(|p| p.is_finite()));
}
