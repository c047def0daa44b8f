//! The fields behind source nodes: each source counted, meshes with their band method,
//! volumes continued outside their box, and the prism band a mesh gets on a sampling lattice.

use glam::{IVec3, Vec3};
use isokit_field::filter::SampledField;
use isokit_field::{Aabb, BrickGrid, DistanceBox, Field, value_clamped};
use isokit_kdtree::mesh::MeshSdf;
use isokit_prism::{Engine, GridGeometry, PrismOptions, PrismSdf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};

/// Query counters sharded by thread, so that counting does not make the threads fight over
/// one cache line.
pub(crate) struct Counter([Padded; SHARDS]);

const SHARDS: usize = 16;

#[repr(align(64))]
struct Padded(AtomicU64);

impl Counter {
    pub(crate) fn new() -> Self {
        Self(std::array::from_fn(|_| Padded(AtomicU64::new(0))))
    }
    #[inline]
    pub(crate) fn add(&self) {
        let i = rayon::current_thread_index().unwrap_or(0) % SHARDS;
        self.0[i].0.fetch_add(1, Ordering::Relaxed);
    }
    pub(crate) fn get(&self) -> u64 {
        self.0.iter().map(|c| c.0.load(Ordering::Relaxed)).sum()
    }
    pub(crate) fn reset(&self) {
        self.0.iter().for_each(|c| c.0.store(0, Ordering::Relaxed));
    }
}

/// A source field that counts its evaluations.
pub(crate) struct Counted<F> {
    pub(crate) field: F,
    pub(crate) count: Arc<Counter>,
}

impl<F: Field> Field for Counted<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.count.add();
        self.field.value(p)
    }
    fn bounds(&self) -> Aabb {
        self.field.bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.field.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.field.is_exact()
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.field.fd_step(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.field.gradient(p)
    }
    fn hessian(&self, p: Vec3) -> glam::Mat3 {
        self.field.hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.field.distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.field.lower_bound(p)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.count.add();
        self.field.value_clamped(p, cap)
    }
}

/// A sampled volume as a field: `sign · (filter(p) − iso)` inside the volume's box,
/// continued outside by adding the distance to the box.
pub(crate) struct VolumeField {
    pub(crate) field: SampledField,
    pub(crate) iso: f32,
    /// +1 inside below the isovalue, −1 inside above.
    pub(crate) sign: f32,
    /// A lower bound on `sign · (filter(p) − iso)` (the smallest sample, less the
    /// Catmull-Rom filter's undershoot).
    pub(crate) min: f32,
    /// A Lipschitz bound of the continued field, measured from the samples.
    pub(crate) lipschitz: f32,
}

impl Field for VolumeField {
    fn value(&self, p: Vec3) -> f32 {
        let b = self.field.grid().bounds();
        let q = p.clamp(b.min, b.max);
        self.sign * (self.field.value(q) - self.iso) + b.distance(p)
    }
    /// Outside the grid the value is the boundary value plus the distance to the grid's
    /// box: it can stay negative up to `−min` away.
    fn bounds(&self) -> Aabb {
        self.field.grid().bounds().expanded((-self.min).max(0.0))
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        Some(DistanceBox {
            aabb: self.field.grid().bounds(),
            slack: -self.min,
        })
    }
    /// At least the distance to the grid's box plus the smallest value, everywhere.
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.field.grid().bounds().distance(p) + self.min
    }
}

/// A Lipschitz bound of a volume source: the largest difference of neighbouring samples
/// over the spacing, times the filter's factor (sound for samples with that slope), plus 1
/// for the continuation by the distance to the box outside the grid.
pub(crate) fn volume_lipschitz(
    grid: &isokit_field::Grid,
    filter: isokit_field::filter::Filter,
) -> f32 {
    let [nx, ny, nz] = grid.dims();
    let d = grid.data();
    let mut slope = 0.0f32;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let n = grid.index(i, j, k);
                let v = d[n];
                if i + 1 < nx {
                    slope = slope.max((d[n + 1] - v).abs());
                }
                if j + 1 < ny {
                    slope = slope.max((d[n + nx] - v).abs());
                }
                if k + 1 < nz {
                    slope = slope.max((d[n + nx * ny] - v).abs());
                }
            }
        }
    }
    filter.lipschitz_factor() * slope / grid.spacing() + 1.0
}

/// A brick grid (e.g. a band sampled earlier) as a field: trilinear interpolation of its
/// samples, continued outside its lattice by the distance to the lattice's box.
pub(crate) struct BrickField {
    pub(crate) bricks: BrickGrid,
    pub(crate) lipschitz: f32,
}

impl BrickField {
    fn lattice_bounds(&self) -> Aabb {
        let b = &self.bricks;
        let d = Vec3::from_array(b.dims().map(|n| (n.max(1) - 1) as f32));
        Aabb::new(b.origin(), b.origin() + b.spacing() * d)
    }
}

impl Field for BrickField {
    fn value(&self, p: Vec3) -> f32 {
        let bounds = self.lattice_bounds();
        let q = p.clamp(bounds.min, bounds.max);
        trilinear_bricks(&self.bricks, q) + bounds.distance(p)
    }
    fn bounds(&self) -> Aabb {
        self.lattice_bounds()
            .expanded(self.bricks.background().abs())
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
}

/// Trilinear interpolation of a brick grid's virtual grid at `p` (inside its lattice).
fn trilinear_bricks(b: &BrickGrid, p: Vec3) -> f32 {
    let [nx, ny, nz] = b.dims();
    let t = (p - b.origin()) / b.spacing();
    let max = IVec3::new(nx as i32 - 1, ny as i32 - 1, nz as i32 - 1).max(IVec3::ZERO);
    let c0 = t.floor().as_ivec3().clamp(IVec3::ZERO, max);
    let f = (t - c0.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
    let at = |c: IVec3| {
        let c = c.clamp(IVec3::ZERO, max);
        b.get(c.x as usize, c.y as usize, c.z as usize)
    };
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let mut xy = [0.0f32; 4];
    for (n, v) in xy.iter_mut().enumerate() {
        let (dy, dz) = ((n & 1) as i32, (n >> 1) as i32);
        *v = lerp(
            at(c0 + IVec3::new(0, dy, dz)),
            at(c0 + IVec3::new(1, dy, dz)),
            f.x,
        );
    }
    lerp(lerp(xy[0], xy[1], f.y), lerp(xy[2], xy[3], f.y), f.z)
}

/// Where a mesh's prism band is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PrismBackend {
    /// A hardware GPU when one exists, else the CPU.
    Auto,
    /// The CPU.
    Cpu,
    /// Any GPU adapter.
    Gpu,
}

/// The prism band of a mesh on one lattice, in the mesh's own frame.
struct PrismBand {
    /// The band's lattice and samples (absent bricks read `±band`).
    bricks: BrickGrid,
    /// The band half-width it was computed for.
    band: f32,
}

/// A mesh as a field: the exact distance by the kd-tree, or, once [`MeshField::prepare`]
/// computed it for a lattice, the prism band on that lattice (exact at its nodes).
pub(crate) struct MeshField {
    pub(crate) sdf: Arc<MeshSdf>,
    /// `Some` for the prism method.
    pub(crate) prism: Option<(Arc<isokit_field::TriMesh>, PrismBackend)>,
    band: RwLock<Option<Arc<PrismBand>>>,
}

impl MeshField {
    pub(crate) fn new(
        sdf: Arc<MeshSdf>,
        prism: Option<(Arc<isokit_field::TriMesh>, PrismBackend)>,
    ) -> Self {
        Self {
            sdf,
            prism,
            band: RwLock::new(None),
        }
    }

    /// For the prism method: scan-converts the mesh on the lattice of spacing `spacing`
    /// through `origin` (in the mesh's frame), over its box grown by `band`, so that every
    /// value with `|d| < band` at a lattice node is exact. Returns the backend used.
    pub(crate) fn prepare(
        &self,
        origin: Vec3,
        spacing: f32,
        band: f32,
        gpu: Option<&isokit_prism::PrismGpu>,
    ) -> Result<Option<&'static str>, String> {
        let Some((mesh, backend)) = &self.prism else {
            return Ok(None);
        };
        // The lattice nodes covering the mesh's box grown by the band, aligned with
        // `origin + spacing · ℤ³`.
        let b = self.sdf.bounds().expanded(band + spacing);
        let lo = ((b.min - origin) / spacing).floor();
        let hi = ((b.max - origin) / spacing).ceil();
        let dims_f = hi - lo + Vec3::ONE;
        if !dims_f.is_finite() || dims_f.max_element() > isokit_field::MAX_AXIS as f32 {
            return Err(format!(
                "the prism band's lattice ({dims_f} samples) is too large"
            ));
        }
        let dims = dims_f.to_array().map(|d| d as usize);
        let g = GridGeometry {
            dims,
            origin: origin + spacing * lo,
            spacing,
        };
        let sdf = PrismSdf::new(mesh, PrismOptions::with_band(f64::from(band)))
            .map_err(|e| e.to_string())?;
        let (engine, name) = match (backend, gpu) {
            (PrismBackend::Cpu, _) | (PrismBackend::Auto, None) => (Engine::Cpu, "cpu"),
            (PrismBackend::Gpu | PrismBackend::Auto, Some(g)) => (Engine::Gpu(g), "gpu"),
            (PrismBackend::Gpu, None) => {
                return Err("prism_gpu: no GPU adapter".to_owned());
            }
        };
        let (bricks, _) = sdf
            .brick_grid(&g, 8, 0, &engine)
            .map_err(|e| e.to_string())?;
        let mut slot = self.band.write().unwrap_or_else(|e| e.into_inner());
        *slot = Some(Arc::new(PrismBand { bricks, band }));
        Ok(Some(name))
    }

    /// True when the band may be computed on a GPU (`prism` or `prism_gpu`).
    pub(crate) fn wants_gpu(&self) -> bool {
        matches!(
            self.prism,
            Some((_, PrismBackend::Auto | PrismBackend::Gpu))
        )
    }

    /// True when the band must be computed on a GPU (`prism_gpu`).
    pub(crate) fn forces_gpu(&self) -> bool {
        matches!(self.prism, Some((_, PrismBackend::Gpu)))
    }

    fn band(&self) -> Option<Arc<PrismBand>> {
        self.prism.as_ref()?;
        self.band.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The prism band's value at `p` when `p` lies in its lattice: trilinear between nodes
    /// (exact at them); `None` outside the lattice.
    fn band_value(&self, band: &PrismBand, p: Vec3) -> Option<f32> {
        let b = &band.bricks;
        let t = (p - b.origin()) / b.spacing();
        let [nx, ny, nz] = b.dims();
        let inside = t.cmpge(Vec3::ZERO).all()
            && t.x <= (nx - 1) as f32
            && t.y <= (ny - 1) as f32
            && t.z <= (nz - 1) as f32;
        if !inside {
            return None;
        }
        let r = t.round();
        if (t - r).abs().max_element() < 1e-3 {
            let c = r.as_ivec3();
            return Some(b.get(c.x as usize, c.y as usize, c.z as usize));
        }
        Some(trilinear_bricks(b, p))
    }
}

impl Field for MeshField {
    fn value(&self, p: Vec3) -> f32 {
        self.sdf.value(p)
    }
    fn bounds(&self) -> Aabb {
        self.sdf.bounds()
    }
    fn is_exact(&self) -> bool {
        true
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.sdf.gradient(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.sdf.distance_box()
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        if let Some(band) = self.band()
            && cap <= band.band
            && let Some(v) = self.band_value(&band, p)
        {
            return v.clamp(-cap, cap);
        }
        value_clamped(&*self.sdf, p, cap)
    }
}
