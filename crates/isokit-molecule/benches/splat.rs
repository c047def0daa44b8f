//! Molecules on the quadric splatter (002 Ch. 7, Sec. 7.3), CPU twin: sections 2 and 3 of
//! the splatting report, whose section 1 (throughput on generated quadrics) is
//! `cargo bench -p isokit-render --bench splat`.
//!
//! 2. **Molecule frames** at 1024x768: 1k, 10k, 100k and 1M atoms, built by
//!    tiling copies of the bundled 7ddo structure on a 3D lattice (spaced by its extent + 8 Å)
//!    and keeping the first N atoms (bonds of kept atoms kept, indices offset per copy), in
//!    both styles (spacefill; ball-and-stick with two cylinders per bond), each plain Phong,
//!    + shadows (2048² map), + shadows + outlines: set-up, splat, shadow map, shade, total.
//! 3. **Against tessellation**: a CPU z-buffer rasterizer written here (rayon over bands of 16
//!    rows, edge functions, pixel centres at (x + ½, y + ½) as `kernel::pixel_ray` defines
//!    them, back faces culled, 1/z interpolated for the depth test, then a resolve pass that
//!    intersects each winning pixel's exact ray with its triangle's plane for `Z`, the face
//!    normal and the interpolated vertex normal) renders every spacefill atom as an icosphere
//!    of 20, 80 and 320 triangles (vertices on the sphere; instanced from one template, a
//!    vertex-shader-like transform per band the atom touches). Time per frame (transform +
//!    rasterize + resolve) against the splatter's set-up + splat, timed in the same runs
//!    (splat, then the three tessellations, repeated), and the image against the
//!    splatter's exact G-buffer: pixels whose hit/miss differs, depth error where both hit
//!    (Å and atom radii), normal angle error (flat and interpolated).
//!
//! Run: `cargo bench -p isokit-molecule --bench splat` (most of the 1½ minutes that all
//! three sections took together on 2 idle cores; 2 GiB peak): medians of 5 runs (≤ 10k
//! atoms), 3 (100k) and 2 (1M). `-- --quick`: 1k and 10k atoms only, 2 runs; `-- --full`:
//! 7, 5 and 3 runs.
//! `ISOKIT_BENCH_RUNS` overrides the count for ≤ 10k atoms. A plain harness (no criterion)
//! keeps the dependency tree lean.

use glam::Vec3;
use isokit_field::Camera;
use isokit_io::generate::icosphere;
use isokit_molecule::{
    Atom, Molecule, MoleculeOptions, MoleculeStyle, framing_camera, molecule_scene, read_molecule,
};
use isokit_render::kernel::{self, Uniforms};
use isokit_render::quadric::{Quadric, QuadricSetup};
use isokit_render::splat::{
    self, OutlineOptions, ShadowOptions, SplatOptions, SplatScene, SplatShading,
};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

const WIDTH: u32 = 1024;
const HEIGHT: u32 = 768;
/// Rows per band of the triangle rasterizer.
const BAND: u32 = 16;

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn percentile(v: &mut [f32], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f32::total_cmp);
    let k = ((v.len() - 1) as f64 * p).round() as usize;
    f64::from(v[k])
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64
}

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let nproc = std::thread::available_parallelism().map_or(1, usize::from);
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemTotal"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|k| k.parse::<f64>().ok())
        })
        .map_or_else(String::new, |kb| format!(", {:.0} GiB", kb / 1048576.0));
    let date = std::process::Command::new("date")
        .arg("-u")
        .arg("+%Y-%m-%d %H:%M UTC")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!(
        "{nproc} × {cpu} (nproc {nproc}{mem}), rayon {} threads; {date}",
        rayon::current_num_threads()
    )
}

// ---------------------------------------------------------------------------------------
// 2. Molecules
// ---------------------------------------------------------------------------------------

/// The first `n` atoms of copies of `base` tiled on a near-cubic 3D lattice spaced by the
/// structure's extent + 8 Å; bonds between kept atoms kept, indices offset per copy.
fn replicate(base: &Molecule, n: usize) -> Molecule {
    let m = base.atoms.len();
    let (lo, hi) = base.bounds().unwrap();
    let step = hi - lo + Vec3::splat(8.0);
    let k = n.div_ceil(m);
    let nx = (k as f64).cbrt().ceil() as usize;
    let ny = ((k as f64 / nx as f64).sqrt().ceil() as usize).max(1);
    let mut out = Molecule {
        name: format!("{} x{k}", base.name),
        atoms: Vec::with_capacity(n),
        bonds: Vec::new(),
    };
    for c in 0..k {
        let (i, j, l) = (c % nx, (c / nx) % ny, c / (nx * ny));
        let off = step * Vec3::new(i as f32, j as f32, l as f32);
        let first = out.atoms.len();
        for a in base.atoms.iter().take(n - first) {
            out.atoms.push(Atom::new(a.element, a.position + off));
        }
        let o = first as u32;
        for &[a, b] in &base.bonds {
            if (o + b) < n as u32 {
                out.bonds.push([o + a, o + b]);
            }
        }
    }
    out
}

fn fmt_count(n: usize) -> String {
    if n >= 1_000_000 && n.is_multiple_of(1_000_000) {
        format!("{}M", n / 1_000_000)
    } else if n >= 1000 && n.is_multiple_of(1000) {
        format!("{}k", n / 1000)
    } else {
        n.to_string()
    }
}

/// What section 3 needs of a spacefill molecule: its frame, camera and timings.
struct SpacefillRef {
    label: String,
    atoms: Vec<(Vec3, f32)>,
    scene: SplatScene,
    camera: Camera,
    quadric_bytes: usize,
}

fn molecules(
    base: &Molecule,
    sizes: &[usize],
    runs_for: impl Fn(usize) -> usize,
) -> Vec<SpacefillRef> {
    let shadows = ShadowOptions {
        resolution: 2048,
        ..ShadowOptions::default()
    };
    let variants: [(&str, SplatShading); 3] = [
        ("Phong", SplatShading::default()),
        (
            "+ shadows",
            SplatShading {
                shadows: Some(shadows),
                ..SplatShading::default()
            },
        ),
        (
            "+ shadows + outlines",
            SplatShading {
                shadows: Some(shadows),
                outlines: Some(OutlineOptions::default()),
                ..SplatShading::default()
            },
        ),
    ];
    println!(
        "\n## 2. Molecule frames (1024x768; times in ms, medians; shadow map 2048², 64-sample PCF)\n"
    );
    println!(
        "| atoms | style | quadrics | runs | shading | set-up | splat | shadow map | shade | total | fps | fragments evaluated of those in boxes (camera + shadow map) | pixels hit |"
    );
    println!(
        "| ---: | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    let mut refs = Vec::new();
    for &n in sizes {
        let mol = replicate(base, n);
        for style in [MoleculeStyle::Spacefill, MoleculeStyle::Balls] {
            let scene = molecule_scene(
                &mol,
                &MoleculeOptions {
                    style,
                    ..MoleculeOptions::default()
                },
            )
            .unwrap();
            let camera = framing_camera(&scene, WIDTH, HEIGHT).unwrap();
            let runs = runs_for(n);
            let (mut su, mut sp) = (Vec::new(), Vec::new());
            let mut shade: Vec<[Vec<f64>; 3]> = vec![Default::default(); variants.len()];
            let mut frame = None;
            for _ in 0..runs {
                let f = splat::splat(&scene, &camera, &SplatOptions::default()).unwrap();
                su.push(f.stats.setup_seconds);
                sp.push(f.stats.splat_seconds);
                for (k, (_, v)) in variants.iter().enumerate() {
                    let (_, st) = splat::shade_splat(&f, &scene, v).unwrap();
                    shade[k][0].push(st.shadow_map_seconds);
                    shade[k][1].push(st.shade_seconds);
                    shade[k][2].push(
                        f.stats.setup_seconds
                            + f.stats.splat_seconds
                            + st.shadow_map_seconds
                            + st.shade_seconds,
                    );
                }
                frame = Some(f);
            }
            let frame = frame.unwrap();
            // The shadow map's own splat, once, for its fragment count.
            let light = splat::default_spot(&frame.uniforms, &scene);
            let (lu, lview, _) = splat::ShadowMap::prepare(&scene, light, &shadows).unwrap();
            let map = splat::splat_view(&scene, &lu, lview).unwrap().stats;
            let style_name = match style {
                MoleculeStyle::Spacefill => "spacefill",
                MoleculeStyle::Balls => "ball-and-stick",
            };
            for (k, (vname, _)) in variants.iter().enumerate() {
                let total = median(&shade[k][2]);
                let cam_frags = format!(
                    "{:.2} of {:.2}",
                    frame.stats.evaluated as f64 / 1e6,
                    frame.stats.fragments as f64 / 1e6
                );
                let frags = if k == 0 {
                    format!("{cam_frags} M")
                } else {
                    format!(
                        "{cam_frags} + {:.1} of {:.1} M",
                        map.evaluated as f64 / 1e6,
                        map.fragments as f64 / 1e6
                    )
                };
                println!(
                    "| {} | {style_name} | {} | {runs} | {vname} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {frags} | {:.0}k |",
                    fmt_count(n),
                    scene.len(),
                    1e3 * median(&su),
                    1e3 * median(&sp),
                    1e3 * median(&shade[k][0]),
                    1e3 * median(&shade[k][1]),
                    1e3 * total,
                    1.0 / total,
                    frame.gbuffer.hit_count() as f64 / 1e3,
                );
            }
            if style == MoleculeStyle::Spacefill {
                refs.push(SpacefillRef {
                    label: fmt_count(n),
                    atoms: mol
                        .atoms
                        .iter()
                        .map(|a| (a.position, a.element.vdw_radius()))
                        .collect(),
                    quadric_bytes: scene.len()
                        * (std::mem::size_of::<Quadric>() + std::mem::size_of::<Vec3>())
                        + frame.stats.drawn * std::mem::size_of::<QuadricSetup>(),
                    scene,
                    camera,
                });
            }
        }
    }
    refs
}

// ---------------------------------------------------------------------------------------
// 3. Tessellated spheres on a CPU z-buffer rasterizer
// ---------------------------------------------------------------------------------------

/// The unit icosphere every atom instances.
struct Template {
    dirs: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
}

impl Template {
    fn new(level: usize) -> Self {
        let m = icosphere(Vec3::ZERO, 1.0, level);
        Self {
            dirs: m.positions,
            tris: m.triangles,
        }
    }
}

/// A rasterized G-buffer: `Z` along the pixel's ray (∞ for misses), the face normal and the
/// interpolated vertex normal.
struct RasterFrame {
    depth: Vec<f32>,
    flat: Vec<Vec3>,
    smooth: Vec<Vec3>,
}

const NO_ID: u64 = u64::MAX;

/// Renders atoms `(centre, radius)` as instances of `tpl` for the uniforms `u`
/// (perspective): bin atoms into bands of [`BAND`] rows by their sphere's conservative
/// screen box, then per band (in parallel) transform each atom's template, rasterize its
/// front faces with edge functions and a 1/z test, and resolve the winners exactly.
fn rasterize(atoms: &[(Vec3, f32)], tpl: &Template, u: &Uniforms) -> RasterFrame {
    let (w, h) = (u.width, u.height);
    let eye = Vec3::from_array(u.eye);
    let (right, up, fwd) = (
        Vec3::from_array(u.right),
        Vec3::from_array(u.up),
        Vec3::from_array(u.forward),
    );
    let (cx, cy) = (0.5 * w as f32, 0.5 * h as f32);
    let sx = w as f32 / (2.0 * u.half_height * u.aspect);
    let sy = h as f32 / (2.0 * u.half_height);
    let cam = |v: Vec3| Vec3::new(v.dot(right), v.dot(up), v.dot(fwd));
    // The template in the camera's frame (a per-frame rotation of 12–162 vertices).
    let tdirs: Vec<Vec3> = tpl.dirs.iter().map(|&d| cam(d)).collect();
    // Atoms in camera space and their band ranges.
    let nb = h.div_ceil(BAND) as usize;
    let placed: Vec<(Vec3, f32, u32, u32)> = atoms
        .par_iter()
        .map(|&(c, r)| {
            let p = cam(c - eye);
            if p.z - r <= 1e-6 * p.z.abs().max(1.0) {
                return (p, r, 1, 0); // crosses the eye plane: left out (never here)
            }
            let hi = if p.y + r > 0.0 {
                (p.y + r) / (p.z - r)
            } else {
                (p.y + r) / (p.z + r)
            };
            let lo = if p.y - r < 0.0 {
                (p.y - r) / (p.z - r)
            } else {
                (p.y - r) / (p.z + r)
            };
            let (y0, y1) = (cy - sy * hi, cy - sy * lo);
            let xr = if p.x + r > 0.0 {
                (p.x + r) / (p.z - r)
            } else {
                (p.x + r) / (p.z + r)
            };
            let xl = if p.x - r < 0.0 {
                (p.x - r) / (p.z - r)
            } else {
                (p.x - r) / (p.z + r)
            };
            let (x0, x1) = (cx + sx * xl, cx + sx * xr);
            if y1 < 0.0 || y0 > h as f32 || x1 < 0.0 || x0 > w as f32 {
                return (p, r, 1, 0);
            }
            let b0 = (y0.max(0.0) as u32 / BAND).min(nb as u32 - 1);
            let b1 = (y1.min(h as f32 - 1.0).max(0.0) as u32 / BAND).min(nb as u32 - 1);
            (p, r, b0, b1)
        })
        .collect();
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nb];
    for (i, &(_, _, b0, b1)) in placed.iter().enumerate() {
        for b in b0..=b1 {
            bins[b as usize].push(i as u32);
        }
    }
    let bands: Vec<(Vec<f32>, Vec<Vec3>, Vec<Vec3>)> = bins
        .par_iter()
        .enumerate()
        .map(|(b, list)| {
            let y0 = b as u32 * BAND;
            let y1 = (y0 + BAND).min(h);
            let n = (w * (y1 - y0)) as usize;
            let mut zb = vec![0f32; n]; // 1/z: 0 is infinitely far
            let mut ids = vec![NO_ID; n];
            let mut vs: Vec<Vec3> = Vec::with_capacity(tdirs.len());
            for &a in list {
                let (c, r, _, _) = placed[a as usize];
                // Vertex stage: camera space → (pixel x, pixel y, 1/z).
                vs.clear();
                vs.extend(tdirs.iter().map(|&d| {
                    let p = c + r * d;
                    let iz = 1.0 / p.z;
                    Vec3::new(cx + sx * p.x * iz, cy - sy * p.y * iz, iz)
                }));
                for (ti, t) in tpl.tris.iter().enumerate() {
                    let va = vs[t[0] as usize];
                    let mut vb = vs[t[1] as usize];
                    let mut vc = vs[t[2] as usize];
                    // Counter-clockwise seen from outside is clockwise on the y-down screen:
                    // front faces have negative signed area here.
                    let mut area = (vb.x - va.x) * (vc.y - va.y) - (vc.x - va.x) * (vb.y - va.y);
                    if area >= 0.0 {
                        continue; // back face or degenerate
                    }
                    std::mem::swap(&mut vb, &mut vc);
                    area = -area;
                    let minx = va.x.min(vb.x).min(vc.x);
                    let maxx = va.x.max(vb.x).max(vc.x);
                    let miny = va.y.min(vb.y).min(vc.y);
                    let maxy = va.y.max(vb.y).max(vc.y);
                    let px0 = (minx - 0.5).ceil().max(0.0) as i64;
                    let px1 = ((maxx - 0.5).floor() as i64).min(i64::from(w) - 1);
                    let py0 = ((miny - 0.5).ceil() as i64).max(i64::from(y0));
                    let py1 = ((maxy - 0.5).floor() as i64).min(i64::from(y1) - 1);
                    if px0 > px1 || py0 > py1 {
                        continue;
                    }
                    // E_ab(p) = (b.x − a.x)(p.y − a.y) − (b.y − a.y)(p.x − a.x).
                    let e = |a: Vec3, b: Vec3, x: f32, y: f32| {
                        (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x)
                    };
                    let (d0, d1, d2) = (-(vc.y - vb.y), -(va.y - vc.y), -(vb.y - va.y));
                    let inv = 1.0 / area;
                    let dz = (d0 * va.z + d1 * vb.z + d2 * vc.z) * inv;
                    let id = (u64::from(a) << 32) | ti as u64;
                    for py in py0..=py1 {
                        let (fx, fy) = (px0 as f32 + 0.5, py as f32 + 0.5);
                        let mut w0 = e(vb, vc, fx, fy);
                        let mut w1 = e(vc, va, fx, fy);
                        let mut w2 = e(va, vb, fx, fy);
                        let mut z = (w0 * va.z + w1 * vb.z + w2 * vc.z) * inv;
                        let row = (py as usize - y0 as usize) * w as usize;
                        for px in px0..=px1 {
                            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                                let i = row + px as usize;
                                if z > zb[i] {
                                    zb[i] = z;
                                    ids[i] = id;
                                }
                            }
                            w0 += d0;
                            w1 += d1;
                            w2 += d2;
                            z += dz;
                        }
                    }
                }
            }
            // Resolve: the winner's plane against the pixel's exact ray.
            let mut depth = vec![f32::INFINITY; n];
            let mut flat = vec![Vec3::ZERO; n];
            let mut smooth = vec![Vec3::ZERO; n];
            for (i, &id) in ids.iter().enumerate() {
                if id == NO_ID {
                    continue;
                }
                let (a, ti) = ((id >> 32) as usize, (id & 0xffff_ffff) as usize);
                let (centre, r) = atoms[a];
                let t = tpl.tris[ti].map(|k| k as usize);
                let rel = centre - eye;
                let (d0, d1, d2) = (tpl.dirs[t[0]], tpl.dirs[t[1]], tpl.dirs[t[2]]);
                let (v0, v1, v2) = (rel + r * d0, rel + r * d1, rel + r * d2);
                let (px, py) = ((i % w as usize) as u32, y0 + (i / w as usize) as u32);
                let (_, d) = kernel::pixel_ray(u, px, py);
                let nrm = (v1 - v0).cross(v2 - v0);
                let tt = nrm.dot(v0) / nrm.dot(d);
                let p = tt * d;
                let nn = nrm.length_squared();
                let b0 = (v1 - p).cross(v2 - p).dot(nrm) / nn;
                let b1 = (v2 - p).cross(v0 - p).dot(nrm) / nn;
                let b2 = 1.0 - b0 - b1;
                depth[i] = tt;
                flat[i] = nrm / nn.sqrt();
                smooth[i] = (b0 * d0 + b1 * d1 + b2 * d2).normalize_or_zero();
            }
            (depth, flat, smooth)
        })
        .collect();
    let total = (w * h) as usize;
    let mut out = RasterFrame {
        depth: Vec::with_capacity(total),
        flat: Vec::with_capacity(total),
        smooth: Vec::with_capacity(total),
    };
    for (d, f, s) in bands {
        out.depth.extend(d);
        out.flat.extend(f);
        out.smooth.extend(s);
    }
    out
}

fn angle_deg(a: Vec3, b: Vec3) -> f32 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    a.cross(b).length().atan2(a.dot(b)).to_degrees() as f32
}

fn bytes(b: usize) -> String {
    if b >= 1 << 30 {
        format!("{:.2} GiB", b as f64 / f64::from(1u32 << 30))
    } else if b >= 1 << 20 {
        format!("{:.1} MiB", b as f64 / f64::from(1u32 << 20))
    } else {
        format!("{:.0} KiB", b as f64 / 1024.0)
    }
}

fn tessellation(refs: &[SpacefillRef], runs_for: impl Fn(usize) -> usize) {
    println!(
        "\n## 3. Spacefill atoms as icospheres on a CPU z-buffer rasterizer against the splatter (1024x768, same camera; times in ms, medians)\n"
    );
    println!(
        "Each run times the splatter (set-up + splat) and then the three tessellations back to back, so each ratio pairs times taken seconds apart. Errors against the splatter's exact G-buffer; ΔZ along the pixel's ray where both hit, in Å and in radii of the atom the splatter sees (*px ΔZ > r*: pixels where another surface shows); normal angle error flat (face) / interpolated (vertex normals). *Indexed mesh* is what a conventional renderer would store (f32 position + normal per vertex, u32 indices); the rasterizer here instances one template (16 B per atom). Frame: bin + transform + rasterize + resolve (Z, both normals).\n"
    );
    println!(
        "| atoms | model | triangles | memory | runs | frame ms | ÷ splat | hit ≠ (tess misses / tess extra) | ΔZ mean / p95 Å | ΔZ mean / p95 r | px ΔZ > r | normal flat mean / p95 ° | normal interp. mean / p95 ° |"
    );
    println!(
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    let templates: Vec<Template> = (0..3).map(Template::new).collect();
    for r in refs {
        let n = r.atoms.len();
        let runs = runs_for(n);
        let u = splat::camera_uniforms(&r.camera).unwrap();
        if n < 1_000_000 {
            // Warm-up.
            let _ = splat::splat(&r.scene, &r.camera, &SplatOptions::default()).unwrap();
            for tpl in &templates {
                let _ = rasterize(&r.atoms, tpl, &u);
            }
        }
        let mut t_splat = Vec::new();
        let mut t_ex = Vec::new();
        let exhaustive = SplatOptions {
            exhaustive: true,
            ..SplatOptions::default()
        };
        let mut t_tess: Vec<Vec<f64>> = vec![Vec::new(); templates.len()];
        let mut frame = None;
        let mut tess: Vec<Option<RasterFrame>> = templates.iter().map(|_| None).collect();
        for _ in 0..runs {
            let f = splat::splat(&r.scene, &r.camera, &SplatOptions::default()).unwrap();
            t_splat.push(f.stats.setup_seconds + f.stats.splat_seconds);
            frame = Some(f);
            let f = splat::splat(&r.scene, &r.camera, &exhaustive).unwrap();
            t_ex.push(f.stats.setup_seconds + f.stats.splat_seconds);
            for (k, tpl) in templates.iter().enumerate() {
                let t = Instant::now();
                let f = rasterize(&r.atoms, tpl, &u);
                t_tess[k].push(t.elapsed().as_secs_f64());
                tess[k] = Some(f);
            }
        }
        let frame = frame.unwrap();
        let splat_ms = 1e3 * median(&t_splat);
        println!(
            "| {} | quadric splatter (set-up + splat) | – | {} (quadrics + set-ups) | {runs} | {splat_ms:.1} | 1 | exact ({:.0}k px hit) | 0 | 0 | 0 | 0 | 0 |",
            r.label,
            bytes(r.quadric_bytes),
            frame.gbuffer.hit_count() as f64 / 1e3,
        );
        let ex_ms = 1e3 * median(&t_ex);
        println!(
            "| {} | splatter, exhaustive (every fragment, as the GPU twin) | – | ″ | {runs} | {ex_ms:.1} | {:.2} | ″ | | | | | |",
            r.label,
            ex_ms / splat_ms,
        );
        let g = frame.gbuffer.pixels();
        for (k, tpl) in templates.iter().enumerate() {
            let f = tess[k].take().unwrap();
            let (mut miss, mut extra) = (0usize, 0usize);
            let (mut dz, mut dzr, mut nf, mut ns) =
                (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for (i, s) in g.iter().enumerate() {
                let hit = f.depth[i].is_finite();
                match (s.is_hit(), hit) {
                    (true, false) => miss += 1,
                    (false, true) => extra += 1,
                    (true, true) => {
                        let e = (f.depth[i] - s.depth).abs();
                        dz.push(e);
                        let obj = frame.objects[i] as usize;
                        dzr.push(e / r.atoms.get(obj).map_or(1.0, |a| a.1));
                        nf.push(angle_deg(f.flat[i], s.normal));
                        ns.push(angle_deg(f.smooth[i], s.normal));
                    }
                    _ => {}
                }
            }
            let far = dzr.iter().filter(|&&e| e > 1.0).count();
            let tris = n * tpl.tris.len();
            let mesh_bytes = n * (tpl.dirs.len() * 24 + tpl.tris.len() * 12);
            let ms = 1e3 * median(&t_tess[k]);
            println!(
                "| {} | icosphere {} triangles | {:.1} M | {} indexed mesh | {runs} | {ms:.1} | {:.2} | {} ({miss} / {extra}) | {:.3} / {:.3} | {:.3} / {:.3} | {far} | {:.2} / {:.2} | {:.2} / {:.2} |",
                r.label,
                tpl.tris.len(),
                tris as f64 / 1e6,
                bytes(mesh_bytes),
                ms / splat_ms,
                miss + extra,
                mean(&dz),
                percentile(&mut dz, 0.95),
                mean(&dzr),
                percentile(&mut dzr, 0.95),
                mean(&nf),
                percentile(&mut nf, 0.95),
                mean(&ns),
                percentile(&mut ns, 0.95),
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let full = args.iter().any(|a| a == "--full");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let base = read_molecule(&root.join("data/molecules/7ddo.pdb.gz")).unwrap();
    let small_runs = env_or(
        "ISOKIT_BENCH_RUNS",
        if quick {
            2
        } else if full {
            7
        } else {
            5
        },
    )
    .max(1);
    let runs_for = |n: usize| -> usize {
        match (n, quick, full) {
            (0..=10_000, _, _) => small_runs,
            (10_001..=100_000, true, _) => 1,
            (10_001..=100_000, _, true) => 5,
            (10_001..=100_000, _, _) => 3,
            (_, _, true) => 3,
            _ => 2,
        }
    };
    let sizes: Vec<usize> = if quick {
        vec![1_000, 10_000]
    } else {
        vec![1_000, 10_000, 100_000, 1_000_000]
    };
    println!("# isokit-molecule: molecules on the quadric splatter, CPU twin");
    println!();
    println!("Machine: {}", machine());
    println!(
        "Mode: {}; base structure {} ({} atoms, {} bonds)",
        if quick {
            "--quick"
        } else if full {
            "--full"
        } else {
            "default"
        },
        base.name,
        base.atoms.len(),
        base.bonds.len()
    );
    let t0 = Instant::now();
    let refs = molecules(&base, &sizes, runs_for);
    tessellation(&refs, runs_for);
    println!(
        "\nWall time of the whole run: {:.0} s",
        t0.elapsed().as_secs_f64()
    );
}
