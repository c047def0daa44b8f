//! # isokit-prism
//!
//! Mesh → narrow-band signed distance by prism scan conversion (002 Sec. 4.2.3): one
//! bounding polyhedron per triangle, scan-converted slice by slice, each covered sample
//! keeping the distance of smallest magnitude. The fast way to a dense band (e.g. the
//! initial state of a level-set computation): the work is proportional to the band's
//! volume, with no search per sample.
//!
//! What it is not for: distances far from the surface (use [`isokit_kdtree::MeshSdf`], whose
//! cost per sample does not grow with the distance), or scattered query points.
//!
//! ## How it works
//! 1. **Polyhedra** ([`PrismSdf::new`]): per triangle, planes through its edges and two
//!    planes parallel to the face at `±band`. The paper's sides bisect the dihedral angles
//!    with the neighbours; that is exact only while the band is thin compared with the
//!    triangles, so by default each triangle gets two half-prisms (one per side of its
//!    plane) whose side at an edge is the bisector where the edge is convex on that side and
//!    the plane perpendicular to the face where it is concave, shifted out where a
//!    neighbouring edge's wedge or a vertex's normal cone would stick out ([`SideRule`]).
//!    At saddle vertices the paper's prisms can leave a gap; [`CoverReport`] counts saddles
//!    and gaps (like 002 Table 4.1) and the shifts close them.
//! 2. **Scan conversion** in slabs of z-slices (bounded memory): each prism's rows are clipped
//!    by its five planes and every sample of the span gets the exact distance to the triangle
//!    in its local frame (Listing 4.1, corrected: [`local`]). The result per sample is the
//!    smallest `(|d|, sign)` key ([`scan::pack`]), so the order of prisms does not matter.
//! 3. **Sign**: the pseudonormal of the closest feature (face, edge or vertex) of the prism's
//!    triangle, the same rule as the kd-tree's, so it is right next to edges and vertices
//!    where the face's own side is not; for meshes that are not watertight, the winding number
//!    at each sample (as [`isokit_kdtree::MeshSdf`] does, and as slowly). Outside the band,
//!    `±band`: the sign spreads from the band through unreached neighbours (two samples on
//!    either side of the surface cannot both be beyond half a spacing from it), along rows
//!    first, then whole rows, and a slab region the band never reaches asks the winding
//!    number once. Bands of at most half a spacing take the winding number per sample.
//!
//! CPU ([`Engine::Cpu`], rayon over slabs) and GPU ([`Engine::Gpu`], a wgpu compute kernel in
//! `shaders/prism_scan.wgsl` with `shaders/common/prism.wgsl`, from the `isokit-shaders`
//! crate; [`gpu`] says why compute rather than the render pipeline) give the same keys up
//! to f32 rounding (identical on lavapipe); the CPU code mirrors the shader line by line.
//! Both sides of the kernel sit together in [`scan`], named after it: `scan/cpu.rs` (the CPU
//! twin, re-exported by [`scan`]) and `scan/gpu.rs` (the host code, [`gpu`]); the distance in
//! a triangle's frame that `common/prism.wgsl` shares is [`local`], and the prism record
//! uploaded to the GPU, [`GpuPrism`], is checked member by member against its WGSL twin.
//!
//! Output: a dense [`Grid`] ([`PrismSdf::grid`], [`PrismSdf::fill_grid`]) or a
//! [`BrickGrid`] holding only the bricks the band touches ([`PrismSdf::brick_grid`]).
//!
//! ## Accuracy
//! Every sample with `|d| < band` holds the exact signed distance rounded through f32 grid
//! units: within `1e-5` of the spacing for distances up to ~50 spacings (tests check every
//! band sample against the kd-tree on the shipped and random meshes). Samples with
//! `|d| ≥ band` hold `±band`.
//!
//! ```
//! use isokit_prism::{PrismSdf, PrismOptions, GridGeometry, Engine};
//! use glam::Vec3;
//! let sphere = isokit_field::generate::icosphere(Vec3::ZERO, 1.0, 3);
//! let sdf = PrismSdf::new(&sphere, PrismOptions::with_band(0.2)).unwrap();
//! let g = GridGeometry { dims: [41, 41, 41], origin: Vec3::splat(-1.25), spacing: 0.0625 };
//! let (grid, stats) = sdf.grid(&g, &Engine::Cpu).unwrap();
//! assert_eq!(grid.get(20, 20, 20), -0.2); // the centre: inside, beyond the band
//! assert!(stats.band_samples > 0);
//! ```
#![warn(missing_docs)]

mod build;
pub mod local;
mod placed;
pub mod scan;
mod sign;

/// The GPU host code of the scan conversion (the same module as [`scan::gpu`]).
pub use scan::gpu;

pub use build::{CoverReport, SideRule};
pub use gpu::PrismGpu;
pub use isokit_kdtree::mesh::{MeshOptions, SignMethod, SignMode};
pub use placed::{GpuPrism, GridGeometry, PLANE_MARGIN};

use build::WorldPrism;
use isokit_field::TriMesh;
use isokit_field::{BrickGrid, Field, FieldError, Grid};
use isokit_gpu::GpuError;
use isokit_kdtree::mesh::{MeshError, MeshSdf};
use isokit_kdtree::pseudonormal::Pseudonormals;
use rayon::prelude::*;
use std::time::Instant;

/// Options of [`PrismSdf::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrismOptions {
    /// Half-width of the band in world units: samples with `|d| < band` are exact, the rest
    /// hold `±band`.
    pub band: f64,
    /// Close the gaps the prisms leave at saddle vertices (on by default; off only to
    /// measure what the repair is for).
    pub repair: bool,
    /// The kd-tree's options (sign mode, tree knobs, winding-number accuracy): the sign is
    /// decided as [`isokit_kdtree::MeshSdf`] decides it (`SignMode::Auto`: pseudonormals on
    /// watertight, consistently oriented meshes without degenerate triangles, the winding
    /// number otherwise), and the kd-tree is the exact reference and the winding number.
    pub mesh: MeshOptions,
    /// Fill the samples outside the band with `±band` (on by default); off leaves them NaN.
    pub fill_outside: bool,
    /// Slices per slab on the CPU (memory: one slab of keys per thread). 0 picks 8.
    pub slab_slices: usize,
    /// The prisms' sides on the concave side of an edge: [`SideRule::Exact`] (default) or
    /// the paper's bisectors ([`SideRule::Bisector`], faster, may leak at wide bands).
    pub sides: SideRule,
}

impl PrismOptions {
    /// The defaults with band half-width `band`.
    pub fn with_band(band: f64) -> Self {
        Self {
            band,
            repair: true,
            mesh: MeshOptions::default(),
            fill_outside: true,
            slab_slices: 0,
            sides: SideRule::Exact,
        }
    }
}

/// Why a prism scan cannot run.
#[derive(Debug, thiserror::Error)]
pub enum PrismError {
    /// The mesh cannot become a distance field (empty, bad indices, non-finite vertices).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The band must be finite and positive.
    #[error("band {0} must be finite and positive")]
    BadBand(f64),
    /// The grid's geometry or size is invalid.
    #[error(transparent)]
    Field(#[from] FieldError),
    /// The GPU failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Where the scan runs.
#[derive(Debug)]
pub enum Engine<'a> {
    /// The CPU twin, rayon over slabs.
    Cpu,
    /// The wgpu kernel.
    Gpu(&'a PrismGpu),
}

impl<'a> From<Option<&'a PrismGpu>> for Engine<'a> {
    /// The GPU when there is one, else the CPU twin.
    fn from(gpu: Option<&'a PrismGpu>) -> Self {
        gpu.map_or(Engine::Cpu, Engine::Gpu)
    }
}

impl Engine<'_> {
    /// Where the scan runs, for reports: `GPU <adapter>` or `CPU, <n> threads`.
    pub fn describe(&self) -> String {
        match self {
            Engine::Gpu(g) => format!("GPU {}", g.gpu().describe()),
            Engine::Cpu => format!("CPU, {} threads", rayon::current_num_threads()),
        }
    }
}

/// What one scan did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScanStats {
    /// Samples of the grid.
    pub samples: u64,
    /// Samples with `|d| < band` (exact values).
    pub band_samples: u64,
    /// Prism–sample distance evaluations (CPU only; 0 on the GPU).
    pub evaluated: u64,
    /// Winding numbers evaluated for signs.
    pub windings: u64,
    /// Slabs processed.
    pub slabs: u64,
    /// Seconds placing the prisms on the grid.
    pub place_seconds: f64,
    /// Seconds scanning (CPU: with decoding and signs, which run in the same parallel tasks).
    pub scan_seconds: f64,
    /// Seconds decoding keys and filling signs (GPU path only).
    pub sign_seconds: f64,
}

/// A mesh prepared for prism scan conversion at one band width.
#[derive(Debug)]
pub struct PrismSdf {
    world: Vec<WorldPrism>,
    report: CoverReport,
    sdf: MeshSdf,
    opts: PrismOptions,
    warning: Option<String>,
    build_seconds: f64,
}

impl PrismSdf {
    /// Builds the polyhedra (and, for signs, the kd-tree's pseudonormals or winding-number
    /// hierarchy). Errors: an empty mesh, bad indices, non-finite vertices, a band that is not
    /// finite and positive.
    pub fn new(mesh: &TriMesh, opts: PrismOptions) -> Result<Self, PrismError> {
        if !(opts.band.is_finite() && opts.band > 0.0) {
            return Err(PrismError::BadBand(opts.band));
        }
        let t0 = Instant::now();
        let sdf = MeshSdf::new(mesh, opts.mesh)?;
        let pseudo = (sdf.sign_method() == SignMethod::Pseudonormal)
            .then(|| Pseudonormals::new(sdf.positions(), sdf.triangles()));
        let (world, report) =
            build::build(mesh, opts.band, opts.repair, opts.sides, pseudo.as_ref());
        let warning = (sdf.sign_method() == SignMethod::Winding).then(|| {
            format!(
                "the mesh is not watertight and consistently oriented ({}): signs come from the generalized winding number at every sample, which is much slower than the prism scan",
                sdf.sign_reason()
            )
        });
        Ok(Self {
            world,
            report,
            sdf,
            opts,
            warning,
            build_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Saddles, gaps and repairs found while building.
    pub fn report(&self) -> &CoverReport {
        &self.report
    }

    /// The options.
    pub fn options(&self) -> &PrismOptions {
        &self.opts
    }

    /// The sign method in use.
    pub fn sign_method(&self) -> SignMethod {
        self.sdf.sign_method()
    }

    /// Why that sign method was chosen.
    pub fn sign_reason(&self) -> &str {
        self.sdf.sign_reason()
    }

    /// A warning for the user, when there is one (non-watertight input: slow winding signs).
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    /// Seconds spent in [`PrismSdf::new`] (kd-tree, pseudonormals, polyhedra, gap test).
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// The exact reference this scan agrees with (the kd-tree path, same sign method).
    pub fn reference(&self) -> &MeshSdf {
        &self.sdf
    }

    /// The prisms placed on grid `g`: two half-prisms per triangle (`2t` on the side the
    /// face normal points to, `2t + 1` on the other), what the kernels read.
    pub fn place(&self, g: &GridGeometry) -> Vec<GpuPrism> {
        self.world
            .par_iter()
            .enumerate()
            .map(|(n, p)| placed::place(p, (n / 2) as u32, g))
            .collect()
    }

    fn decoder(&self, g: &GridGeometry) -> sign::Decode<'_> {
        sign::Decode {
            sdf: &self.sdf,
            winding: self.sdf.sign_method() == SignMethod::Winding,
            unsigned: self.sdf.sign_method() == SignMethod::Unsigned,
            band: self.opts.band as f32,
            spacing: g.spacing,
            origin: g.origin.as_dvec3(),
            nx: g.dims[0],
            ny: g.dims[1],
            fill: self.opts.fill_outside,
        }
    }

    /// The band on a new dense grid with geometry `g`.
    pub fn grid(&self, g: &GridGeometry, engine: &Engine) -> Result<(Grid, ScanStats), PrismError> {
        let mut grid = Grid::new(g.dims, g.origin, g.spacing)?;
        let stats = self.fill_grid(&mut grid, engine)?;
        Ok((grid, stats))
    }

    /// Overwrites every sample of `grid` with the band (exact within it, `±band` or NaN
    /// outside).
    pub fn fill_grid(&self, grid: &mut Grid, engine: &Engine) -> Result<ScanStats, PrismError> {
        let g = GridGeometry {
            dims: grid.dims(),
            origin: grid.origin(),
            spacing: grid.spacing(),
        };
        let mut stats = ScanStats {
            samples: grid.len() as u64,
            ..Default::default()
        };
        let t = Instant::now();
        let prisms = self.place(&g);
        stats.place_seconds = t.elapsed().as_secs_f64();
        let [nx, ny, nz] = g.dims;
        let signed = self.sdf.sign_method() == SignMethod::Pseudonormal;
        let dec = self.decoder(&g);
        let t = Instant::now();
        match engine {
            Engine::Cpu => {
                let slab = self.cpu_slab_slices();
                let merged = grid
                    .data_mut()
                    .par_chunks_mut(nx * ny * slab)
                    .enumerate()
                    .map(|(s, chunk)| {
                        let k0 = s * slab;
                        let k1 = k0 + chunk.len() / (nx * ny) - 1;
                        let active = active_in(&prisms, k0 as i32, k1 as i32);
                        let keys: &mut [u32] = bytemuck::cast_slice_mut(chunk);
                        keys.fill(scan::UNWRITTEN);
                        let ev = scan::scan_slab(
                            &prisms,
                            &active,
                            (k0 as i32, k1 as i32),
                            nx,
                            ny,
                            signed,
                            keys,
                        );
                        let c = dec.slab(k0, chunk);
                        (ev, c.band_samples, c.windings, 1u64)
                    })
                    .reduce(
                        || (0, 0, 0, 0),
                        |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3),
                    );
                stats.evaluated = merged.0;
                stats.band_samples = merged.1;
                stats.windings = merged.2;
                stats.slabs = merged.3;
                stats.scan_seconds = t.elapsed().as_secs_f64();
            }
            Engine::Gpu(pg) => {
                let buf = pg.upload(&prisms)?;
                let slab = pg.max_slab_slices(nx, ny).min(nz);
                for (s, chunk) in grid.data_mut().chunks_mut(nx * ny * slab).enumerate() {
                    let k0 = s * slab;
                    let k1 = k0 + chunk.len() / (nx * ny) - 1;
                    let active = active_in(&prisms, k0 as i32, k1 as i32);
                    let keys: &mut [u32] = bytemuck::cast_slice_mut(chunk);
                    pg.scan_slab(&buf, &active, (k0 as i32, k1 as i32), nx, ny, signed, keys)?;
                    stats.slabs += 1;
                }
                stats.scan_seconds = t.elapsed().as_secs_f64();
                let t = Instant::now();
                // Decode in parallel, in CPU-sized slabs (the flood fill is slab-local).
                let cs = self.cpu_slab_slices();
                let (b, w) = grid
                    .data_mut()
                    .par_chunks_mut(nx * ny * cs)
                    .enumerate()
                    .map(|(s, chunk)| {
                        let c = dec.slab(s * cs, chunk);
                        (c.band_samples, c.windings)
                    })
                    .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
                stats.band_samples = b;
                stats.windings = w;
                stats.sign_seconds = t.elapsed().as_secs_f64();
            }
        }
        Ok(stats)
    }

    fn cpu_slab_slices(&self) -> usize {
        if self.opts.slab_slices == 0 {
            8
        } else {
            self.opts.slab_slices
        }
    }

    /// The band as a [`BrickGrid`] over geometry `g`: only bricks holding a sample with
    /// `|d| < band` are stored; absent bricks read `±band` with the right sign (marked inside
    /// where negative). Computed slab by slab (one brick layer plus aprons at a time), so
    /// memory stays bounded by the stored bricks and one slab per thread.
    ///
    /// `brick` must be a power of two from 2 to 256, `apron` less than `brick / 2` (so an
    /// apron never reaches a neighbouring brick's centre sample, which decides whether that
    /// brick is stored).
    pub fn brick_grid(
        &self,
        g: &GridGeometry,
        brick: usize,
        apron: usize,
        engine: &Engine,
    ) -> Result<(BrickGrid, ScanStats), PrismError> {
        // Validate the layout before any work.
        BrickGrid::new(
            g.dims,
            g.origin,
            g.spacing,
            brick,
            apron,
            self.opts.band as f32,
        )?;
        if 2 * apron >= brick && apron > 0 {
            return Err(FieldError::BadParameter {
                name: "apron",
                value: apron.to_string(),
                why: "must be less than half the brick size for prism brick grids",
            }
            .into());
        }
        let [nx, ny, nz] = g.dims;
        let mut stats = ScanStats {
            samples: (nx * ny * nz) as u64,
            ..Default::default()
        };
        let t = Instant::now();
        let prisms = self.place(g);
        stats.place_seconds = t.elapsed().as_secs_f64();
        let signed = self.sdf.sign_method() == SignMethod::Pseudonormal;
        let layers = nz.div_ceil(brick);
        let band = self.opts.band as f32;
        let bx = nx.div_ceil(brick);
        let by = ny.div_ceil(brick);
        let t = Instant::now();
        let gpu_buf = match engine {
            Engine::Gpu(pg) => Some(pg.upload(&prisms)?),
            Engine::Cpu => None,
        };
        // One layer of bricks: the slab of slices k0 - apron ..= k0 + brick + apron (clamped).
        let layer = |l: usize| -> Result<
            (Vec<StoredBrick>, Vec<bool>, sign::SlabCounts, u64),
            PrismError,
        > {
            let k0 = (l * brick) as i64 - apron as i64;
            let k1 = ((l + 1) * brick + apron) as i64 - 1;
            let (s0, s1) = (k0.max(0) as usize, (k1.min(nz as i64 - 1)) as usize);
            let ns = s1 - s0 + 1;
            let mut vals = vec![0.0f32; nx * ny * ns];
            let active = active_in(&prisms, s0 as i32, s1 as i32);
            let keys: &mut [u32] = bytemuck::cast_slice_mut(&mut vals);
            keys.fill(scan::UNWRITTEN);
            let ev = match (engine, &gpu_buf) {
                (Engine::Gpu(pg), Some(buf)) => {
                    pg.scan_slab(buf, &active, (s0 as i32, s1 as i32), nx, ny, signed, keys)?;
                    0
                }
                _ => scan::scan_slab(
                    &prisms,
                    &active,
                    (s0 as i32, s1 as i32),
                    nx,
                    ny,
                    signed,
                    keys,
                ),
            };
            let dec = sign::Decode {
                fill: true,
                ..self.decoder(g)
            };
            let counts = dec.slab(s0, &mut vals);
            let at = |i: i64, j: i64, k: i64| -> f32 {
                let i = i.clamp(0, nx as i64 - 1) as usize;
                let j = j.clamp(0, ny as i64 - 1) as usize;
                let k = (k.clamp(0, nz as i64 - 1) as usize).clamp(s0, s1) - s0;
                vals[i + nx * (j + ny * k)]
            };
            let side = brick + 2 * apron;
            let mut stored = Vec::new();
            let mut inside = Vec::with_capacity(bx * by);
            for cb in 0..by {
                for ca in 0..bx {
                    let lo = [ca * brick, cb * brick, l * brick];
                    let mut touched = false;
                    for k in lo[2]..(lo[2] + brick).min(nz) {
                        for j in lo[1]..(lo[1] + brick).min(ny) {
                            for i in lo[0]..(lo[0] + brick).min(nx) {
                                touched |= at(i as i64, j as i64, k as i64).abs() < band;
                            }
                        }
                    }
                    let centre = [0, 1, 2].map(|a| (lo[a] + brick / 2) as i64);
                    inside.push(at(centre[0], centre[1], centre[2]) < 0.0);
                    if touched {
                        let mut data = Vec::with_capacity(side * side * side);
                        for k in 0..side {
                            for j in 0..side {
                                for i in 0..side {
                                    data.push(at(
                                        (lo[0] + i) as i64 - apron as i64,
                                        (lo[1] + j) as i64 - apron as i64,
                                        (lo[2] + k) as i64 - apron as i64,
                                    ));
                                }
                            }
                        }
                        stored.push(StoredBrick {
                            coord: [ca, cb, l],
                            data,
                        });
                    }
                }
            }
            Ok((stored, inside, counts, ev))
        };
        let results: Vec<_> = match engine {
            Engine::Cpu => (0..layers).into_par_iter().map(layer).collect(),
            Engine::Gpu(_) => (0..layers).map(layer).collect(),
        };
        let mut store = BrickStore {
            dims: g.dims,
            origin: g.origin,
            spacing: g.spacing,
            brick,
            apron,
            band,
            bx,
            by,
            index: vec![u32::MAX; bx * by * layers],
            inside: vec![false; bx * by * layers],
            bricks: Vec::new(),
        };
        for (l, r) in results.into_iter().enumerate() {
            let (stored, inside, counts, ev) = r?;
            stats.band_samples += counts.band_samples;
            stats.windings += counts.windings;
            stats.evaluated += ev;
            stats.slabs += 1;
            for (n, ins) in inside.into_iter().enumerate() {
                store.inside[l * bx * by + n] = ins;
            }
            for b in stored {
                let [a, c, l] = b.coord;
                store.index[a + bx * (c + by * l)] = store.bricks.len() as u32;
                store.bricks.push(b.data);
            }
        }
        stats.scan_seconds = t.elapsed().as_secs_f64();
        let out = BrickGrid::sample_field(
            &store, g.dims, g.origin, g.spacing, brick, apron, band, band,
        )?;
        Ok((out, stats))
    }
}

/// Indices of the prisms touching slices `k0..=k1`.
fn active_in(prisms: &[GpuPrism], k0: i32, k1: i32) -> Vec<u32> {
    prisms
        .iter()
        .enumerate()
        .filter(|(_, p)| p.spans(k0, k1))
        .map(|(i, _)| i as u32)
        .collect()
}

struct StoredBrick {
    coord: [usize; 3],
    data: Vec<f32>,
}

/// The bricks computed slab by slab, as a [`Field`] that [`BrickGrid::sample_field`] copies
/// into a brick grid. Its Lipschitz bound is declared 0 so that the sampler keeps exactly
/// the bricks whose centre value is within the band: stored bricks answer their stored
/// values (within `±band`), absent bricks answer `±band` except at their centre sample,
/// which answers the next f32 beyond the band so that the brick is skipped (and marked
/// inside when negative).
struct BrickStore {
    dims: [usize; 3],
    origin: glam::Vec3,
    spacing: f32,
    brick: usize,
    apron: usize,
    band: f32,
    bx: usize,
    by: usize,
    index: Vec<u32>,
    inside: Vec<bool>,
    bricks: Vec<Vec<f32>>,
}

impl Field for BrickStore {
    fn value(&self, p: glam::Vec3) -> f32 {
        // The lattice point (brick centres of partial bricks may lie past the grid's end).
        let q = ((p - self.origin) / self.spacing).round();
        let qi: [usize; 3] = std::array::from_fn(|a| q[a].max(0.0) as usize);
        let b = self.brick;
        let n = qi[0] / b + self.bx * (qi[1] / b + self.by * (qi[2] / b));
        match self.index.get(n) {
            Some(&s) if s != u32::MAX => {
                let side = b + 2 * self.apron;
                let c: [usize; 3] = std::array::from_fn(|a| qi[a].min(self.dims[a] - 1));
                let l = c.map(|v| v % b + self.apron);
                self.bricks[s as usize][l[0] + side * (l[1] + side * l[2])]
            }
            _ => {
                let centre = qi.iter().all(|&v| v % b == b / 2);
                let v = if centre {
                    f32::from_bits(self.band.to_bits() + 1)
                } else {
                    self.band
                };
                if self.inside.get(n).copied().unwrap_or(false) {
                    -v
                } else {
                    v
                }
            }
        }
    }

    fn bounds(&self) -> isokit_field::Aabb {
        let hi = self.origin
            + self.spacing
                * glam::Vec3::new(
                    (self.dims[0] - 1) as f32,
                    (self.dims[1] - 1) as f32,
                    (self.dims[2] - 1) as f32,
                );
        isokit_field::Aabb::new(self.origin, hi)
    }

    fn lipschitz(&self) -> f32 {
        0.0
    }
}
