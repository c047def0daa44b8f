//! Prism scan conversion against the alternatives on this machine, in the shape of 002
//! Tables 4.2–4.5: per case, the prism CPU time (build + scan + signs), the kd-tree's
//! per-sample time on the same band samples (the samples where the kd-tree's |d| < band, each a
//! band-limited query warm-started along rows), the kd-tree over the whole grid (what `isokit
//! sdf --method kdtree --band` does; always run: it is the reference), and an SDFGen-style
//! brute force (every triangle's band box scanned with the exact closest point, no prisms; by
//! default only where the boxes hold fewer than 6e8 samples). Samples per second are band
//! samples per second; ratios are the other tool's time over the prism time. Every case also
//! checks the prism result against the kd-tree on every sample the kd-tree puts in the band,
//! including any the prisms left at ±band (last column: the largest difference). The prism
//! time is the best of two runs, the others one run each.
//!
//! It also times the paper's prisms (bisectors on both sides, `SideRule::Bisector`) and
//! counts the band samples where they differ from the exact result, and with `--gpu` the GPU
//! path (meaningful only on a hardware GPU).
//!
//! Run: `cargo bench -p isokit-prism --bench prism` (default: under 10 minutes on 2 cores);
//! `-- --quick` for a smoke run, `-- --full` adds 512^3 and the 327k-triangle sphere,
//! `-- --gpu` adds a GPU column.
//! A plain harness (no criterion, as `isokit-kdtree/benches/knobs.rs`).

use glam::{DVec3, Vec3};
use isokit_field::Grid;
use isokit_io::{TriMesh, generate};
use isokit_kdtree::mesh::MeshSdf;
use isokit_kdtree::tree::QueryStats;
use isokit_kdtree::triangle::closest_point;
use isokit_prism::{Engine, GridGeometry, PrismGpu, PrismOptions, PrismSdf, SideRule};
use rayon::prelude::*;
use std::time::Instant;

struct Case {
    table: &'static str,
    mesh_name: String,
    mesh: TriMesh,
    res: usize,
    band_rel: f32,
}

fn best<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = None;
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("reps > 0"))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let full = args.iter().any(|a| a == "--full");
    let gpu = if args.iter().any(|a| a == "--gpu") {
        Some(PrismGpu::open().expect("--gpu: no GPU adapter"))
    } else {
        None
    };
    if let Some(g) = &gpu {
        println!("GPU: {}", g.gpu().describe());
    }
    let sphere = |level| generate::icosphere(Vec3::ZERO, 1.0, level);
    let knot = generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 192, 16);
    let mut cases = Vec::new();
    let mut push = |table, name: String, mesh: &TriMesh, res, band_rel| {
        cases.push(Case {
            table,
            mesh_name: name,
            mesh: mesh.clone(),
            res,
            band_rel,
        })
    };
    let main_res = if quick { 64 } else { 256 };
    let s5 = sphere(5);
    push("4.2", "sphere5 (20k)".into(), &s5, main_res, 0.1);
    push("4.2", "trefoil (6k)".into(), &knot, main_res, 0.1);
    let bunny =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/external/bunny00.off");
    if let Ok(b) = isokit_io::read_mesh(&bunny) {
        push(
            "4.2",
            format!("bunny ({}k)", b.triangles.len() / 1000),
            &b,
            main_res,
            0.1,
        );
    }
    let levels: &[usize] = if quick {
        &[3, 4]
    } else if full {
        &[3, 4, 5, 6, 7]
    } else {
        &[3, 4, 5, 6]
    };
    for &l in levels {
        let m = sphere(l);
        push(
            "4.3",
            format!("sphere{l} ({})", m.triangles.len()),
            &m,
            main_res,
            0.1,
        );
    }
    let bands: &[f32] = if quick {
        &[0.1, 0.4]
    } else {
        &[0.1, 0.2, 0.4, 0.8]
    };
    for &b in bands {
        push("4.4", "sphere5 (20k)".into(), &s5, main_res, b);
    }
    let resolutions: &[usize] = if quick {
        &[32, 64]
    } else if full {
        &[64, 128, 256, 512]
    } else {
        &[64, 128, 256, 384]
    };
    for &r in resolutions {
        push("4.5", "sphere5 (20k)".into(), &s5, r, 0.1);
    }

    println!(
        "| table | mesh | res | band | band samples | prism s (setup + scan) | Msamples/s | evals / sample | kd-tree, band samples s | ratio | kd-tree, grid s | ratio | brute force, band boxes s | ratio | paper sides s | paper sides wrong | GPU s | max err / h |"
    );
    println!(
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for c in &cases {
        let reps = if quick { 1 } else { 2 };
        let b = c.mesh.bounds();
        let extent = b.size().max_element();
        let band = (c.band_rel * extent) as f64;
        // The paper's bands are a fraction of the extent around the model; pad so the band fits.
        let (dims, origin, spacing) =
            Grid::covering_geometry(b, c.res, (c.band_rel * extent).max(0.05 * extent))
                .expect("grid");
        let g = GridGeometry {
            dims,
            origin,
            spacing,
        };
        let (t_prism, (grid, stats, setup)) = best(reps, || {
            let sdf = PrismSdf::new(&c.mesh, PrismOptions::with_band(band)).expect("mesh");
            let (grid, stats) = sdf.grid(&g, &Engine::Cpu).expect("scan");
            (grid, stats, sdf.build_seconds())
        });
        // The paper's prisms (bisectors on both sides): time, and band samples that differ
        // from the exact sides' result by more than 1e-5 of the spacing.
        let (t_paper, paper) = best(reps, || {
            let opts = PrismOptions {
                sides: SideRule::Bisector,
                ..PrismOptions::with_band(band)
            };
            let sdf = PrismSdf::new(&c.mesh, opts).expect("mesh");
            sdf.grid(&g, &Engine::Cpu).expect("scan").0
        });
        let t_gpu = gpu.as_ref().map(|pg| {
            best(reps, || {
                let sdf = PrismSdf::new(&c.mesh, PrismOptions::with_band(band)).expect("mesh");
                sdf.grid(&g, &Engine::Gpu(pg)).expect("gpu scan")
            })
            .0
        });
        // The reference: the kd-tree's band-limited distance at every sample of the grid
        // (what `isokit sdf --method kdtree --band` computes, `MeshSdf::fill_grid`). The band
        // samples are the ones where *it* says |d| < band, so a band sample the prisms left
        // at ±band is compared too, not skipped.
        let [nx, ny, _] = dims;
        let h = spacing as f64;
        let o = origin.as_dvec3();
        let sdf = MeshSdf::new(&c.mesh, Default::default()).expect("mesh");
        let (t_kd_grid, reference) = best(1, || {
            let mut g2 = Grid::new(dims, origin, spacing).expect("grid");
            sdf.fill_grid(&mut g2, band, &Default::default())
                .expect("not cancelled");
            g2
        });
        let samples: Vec<(usize, DVec3)> = reference
            .data()
            .iter()
            .enumerate()
            .filter(|(_, v)| (v.abs() as f64) < band)
            .map(|(n, _)| {
                let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
                (n, o + h * DVec3::new(i as f64, j as f64, k as f64))
            })
            .collect();
        let errs = samples
            .iter()
            .map(|&(n, _)| (f64::from(reference.data()[n]) - f64::from(grid.data()[n])).abs())
            .fold(0.0, f64::max);
        let paper_wrong = samples
            .iter()
            .filter(|&&(n, _)| {
                ((reference.data()[n] - paper.data()[n]).abs() as f64) > 1e-5 * spacing as f64
            })
            .count();
        drop((paper, reference));
        // The kd-tree on the band samples alone, warm-started along rows.
        let (t_kd, ()) = best(1, || {
            samples.par_chunks(4096).for_each(|chunk| {
                let mut st = QueryStats::default();
                let mut hint = None;
                for &(_, p) in chunk {
                    let (_, t) = sdf.signed_distance_band_near(p, band, hint, &mut st);
                    hint = t.or(hint);
                }
            });
        });
        let t_kd_grid = Some(t_kd_grid);
        // SDFGen-style: exact distances in every triangle's band box (unsigned; the sign pass
        // is not timed), when the box volume is modest.
        let box_samples: f64 = c
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| c.mesh.positions[i as usize]);
                let lo = p[0].min(p[1]).min(p[2]) - Vec3::splat(band as f32);
                let hi = p[0].max(p[1]).max(p[2]) + Vec3::splat(band as f32);
                ((hi - lo) / spacing + Vec3::ONE)
                    .max(Vec3::ZERO)
                    .to_array()
                    .iter()
                    .product::<f32>() as f64
            })
            .sum();
        let t_brute =
            (box_samples < 4e9).then(|| best(1, || brute_band_boxes(&c.mesh, &g, band)).0);
        let fmt = |t: Option<f64>| t.map_or("–".to_string(), |t| format!("{t:.2}"));
        let ratio = |t: Option<f64>| t.map_or("–".to_string(), |t| format!("{:.1}", t / t_prism));
        println!(
            "| {} | {} | {}³ | {:.1} | {} | {:.2} ({:.2} + {:.2}) | {:.1} | {:.2} | {:.2} | {:.1} | {} | {} | {} | {} | {:.2} | {} | {} | {:.1e} |",
            c.table,
            c.mesh_name,
            c.res,
            c.band_rel,
            samples.len(),
            t_prism,
            setup,
            t_prism - setup,
            samples.len() as f64 / t_prism / 1e6,
            stats.evaluated as f64 / stats.band_samples.max(1) as f64,
            t_kd,
            t_kd / t_prism,
            fmt(t_kd_grid),
            ratio(t_kd_grid),
            fmt(t_brute),
            ratio(t_brute),
            t_paper,
            paper_wrong,
            fmt(t_gpu),
            errs / h,
        );
    }
}

/// Exact unsigned distance in the band box of every triangle (Batty's SDFGen without its
/// sweep), parallel over z-slabs: the brute-force baseline without prisms.
fn brute_band_boxes(mesh: &TriMesh, g: &GridGeometry, band: f64) -> Vec<f32> {
    let [nx, ny, nz] = g.dims;
    let h = g.spacing as f64;
    let o = g.origin.as_dvec3();
    let tris: Vec<[DVec3; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.positions[i as usize].as_dvec3()))
        .collect();
    let boxes: Vec<([usize; 3], [usize; 3])> = tris
        .iter()
        .map(|p| {
            let lo = (p[0].min(p[1]).min(p[2]) - DVec3::splat(band) - o) / h;
            let hi = (p[0].max(p[1]).max(p[2]) + DVec3::splat(band) - o) / h;
            let l = [0, 1, 2].map(|a| lo[a].ceil().max(0.0) as usize);
            let u = [0, 1, 2].map(|a| (hi[a].floor().max(-1.0) as i64).min(g.dims[a] as i64 - 1));
            (l, u.map(|x| x.max(-1) as usize))
        })
        .collect();
    let mut out = vec![band as f32; nx * ny * nz];
    let slab = 4;
    out.par_chunks_mut(nx * ny * slab)
        .enumerate()
        .for_each(|(s, chunk)| {
            let k0 = s * slab;
            let k1 = k0 + chunk.len() / (nx * ny);
            for (t, (l, u)) in tris.iter().zip(&boxes) {
                if u.contains(&usize::MAX) || u[2] < k0 || l[2] >= k1 {
                    continue;
                }
                for k in l[2].max(k0)..=u[2].min(k1 - 1) {
                    for j in l[1]..=u[1] {
                        for i in l[0]..=u[0] {
                            let p = o + h * DVec3::new(i as f64, j as f64, k as f64);
                            let d = closest_point(p, t[0], t[1], t[2]).dist2.sqrt() as f32;
                            let v = &mut chunk[i + nx * (j + ny * (k - k0))];
                            if d < *v {
                                *v = d;
                            }
                        }
                    }
                }
            }
        });
    out
}
