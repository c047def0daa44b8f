//! The host code of `shaders/tets.wgsl`: the GPU twins of ray casting a tetrahedral grid's
//! isosurface ([`GpuRenderer::render_tets`], entry point `tet_iso`; CPU twin
//! [`TetCaster::render`]) and of volume rendering through its cells
//! ([`GpuRenderer::render_tets_dvr`], entry point `tet_dvr`; CPU twin [`TetVolume::render`]).
//!
//! ## Data on the GPU
//! - the points as two `vec4<f32>` each: position and value (times the inside sign for the
//!   isosurface), the point gradient;
//! - the cells as two `vec4<u32>` each: point indices and the neighbours across the four
//!   faces ([`NO_NEIGHBOUR`] on the boundary);
//! - each cell's frame, four `vec4<f32>`: its first point (w: 1 for a degenerate cell, as
//!   [`is_degenerate`] says) and the rows of its edge matrix's inverse, computed in f64 on
//!   the host and rounded, so the kernel's barycentric coordinates are one dot product each;
//! - the boundary faces in a bounding-volume hierarchy (median splits on the longest axis,
//!   up to four faces a leaf, boxes grown by a few f32 ulps): the kernel's first face a ray
//!   meets. The CPU twin finds the same face in a kd-tree ([`isokit_kdtree`]): the nearest
//!   entering face beyond the last exit is the same whichever tree finds it;
//! - the rays (origin, unit direction), made on the host exactly as the CPU twin makes them;
//! - for volume rendering, the transfer function's points then the 3D pre-integration table.
//!
//! ## What differs from the CPU twin
//! The CPU twin walks in f64, the kernel in f32, so exits and hits agree to f32 rounding; at
//! a ray through an edge or a vertex of the cells the two may pick different (equally right)
//! exit faces. A flat cell is stepped across with an f32 tolerance (1e-6 of the ray
//! parameter) where the CPU twin takes 1e-9. WGSL gives NaN no defined meaning: a
//! non-finite value goes up as 0 and its cells are flagged, so the kernel treats them as the
//! CPU twin does (crossed, holding no surface, clear). A degenerate boundary face is tested
//! like any other here, where the kd-tree's test refuses it; either way the walk then steps
//! across the degenerate cell behind it.

use super::dvr::{TetDvrOptions, TetVolume};
use super::{FACES, TetCaster, TetHit, Walk, sample};
use crate::dvr::{Classification, DvrImage, TransferFunction, gpu::SUB_STEPS};
use crate::gpu::{GpuRenderer, WORKGROUP, check_fits, dispatch_grid, scoped};
use crate::kernel::{Uniforms, pixel_ray};
use crate::{GBuffer, RenderError};
use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DVec3, Vec3, Vec4};
use isokit_field::tet::{NO_NEIGHBOUR, is_degenerate};
use isokit_field::{Camera, TetGrid};
use isokit_gpu::{ShaderSource, wgpu};
use rayon::prelude::*;

/// `TetParams` in `tets.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct TetParams {
    pub(crate) count: u32,
    pub(crate) stride: u32,
    pub(crate) cells: u32,
    pub(crate) nodes: u32,
    pub(crate) iso: f32,
    pub(crate) smooth_normals: u32,
    pub(crate) n_tf: u32,
    pub(crate) mode: u32,
    pub(crate) table_at: u32,
    pub(crate) table_n: u32,
    pub(crate) table_m: u32,
    pub(crate) termination: f32,
    pub(crate) table_lo: f32,
    pub(crate) table_hi: f32,
    pub(crate) table_len: f32,
    pub(crate) shade: u32,
}

isokit_gpu::wgsl_layout!(TetParams {
    count: "u32",
    stride: "u32",
    cells: "u32",
    nodes: "u32",
    iso: "f32",
    smooth_normals: "u32",
    n_tf: "u32",
    mode: "u32",
    table_at: "u32",
    table_n: "u32",
    table_m: "u32",
    termination: "f32",
    table_lo: "f32",
    table_hi: "f32",
    table_len: "f32",
    shade: "u32",
});

/// The tetrahedral grid kernels, assembled: `WORKGROUP`, `SUB_STEPS`, the shading constants
/// and `NO_NEIGHBOUR` from Rust, `common/transfer.wgsl`, `common/slab.wgsl`, `tets.wgsl`
/// (entry points `tet_iso`, `tet_dvr`).
pub fn tets_shader() -> ShaderSource {
    let (ka, kd, ks, shininess) = crate::dvr::SHADE_WEIGHTS;
    ShaderSource::new("tets")
        .constant_u32("WORKGROUP", WORKGROUP)
        .constant_u32("SUB_STEPS", SUB_STEPS)
        .constant_f32("SHADE_MIN_OPACITY", crate::dvr::SHADE_MIN_OPACITY)
        .constant_f32("SHADE_KA", ka)
        .constant_f32("SHADE_KD", kd)
        .constant_f32("SHADE_KS", ks)
        .constant_u32("SHININESS", shininess)
        .constant_u32("NO_NEIGHBOUR", NO_NEIGHBOUR)
        .piece(isokit_shaders::common::TRANSFER)
        .piece(isokit_shaders::common::SLAB)
        .piece(isokit_shaders::TETS)
}

/// Faces per leaf of the boundary faces' hierarchy.
const LEAF_FACES: usize = 4;

/// The boundary faces' bounding-volume hierarchy as `tets.wgsl` reads it: two `vec4<f32>`
/// per node, `(min, first)` and `(max, count)` with `first` and `count` bit-cast `u32`s (an
/// inner node has `count` 0 and its children at `first` and `first + 1`; a leaf's faces are
/// `faces[first..first + count]`), and the faces `(cell, face)` in leaf order.
struct Hierarchy {
    nodes: Vec<[f32; 4]>,
    faces: Vec<[u32; 2]>,
}

impl Hierarchy {
    fn new(grid: &TetGrid, walk: &Walk) -> Self {
        let boxes: Vec<(Vec3, Vec3)> = walk
            .boundary
            .iter()
            .map(|&(c, k)| {
                let t = grid.tets()[c as usize];
                let p = FACES[k as usize].map(|i| grid.points()[t[i] as usize]);
                let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                // Grown by a few ulps of the coordinates, so the f32 slab test never drops
                // a face the triangle test would hit (flat boxes of axis-aligned faces).
                let pad = 4.0 * f32::EPSILON * (1.0 + lo.abs().max(hi.abs()).max_element());
                (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
            })
            .collect();
        let mut order: Vec<usize> = (0..boxes.len()).collect();
        let mut nodes: Vec<[f32; 4]> = Vec::new();
        if !order.is_empty() {
            nodes.resize(2, [0.0; 4]);
            let mut todo = vec![(0usize, 0usize, order.len())];
            while let Some((node, start, end)) = todo.pop() {
                let (lo, hi) = order[start..end]
                    .iter()
                    .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &i| {
                        (lo.min(boxes[i].0), hi.max(boxes[i].1))
                    });
                let (first, count) = if end - start <= LEAF_FACES {
                    (start as u32, (end - start) as u32)
                } else {
                    let centre = |i: usize| boxes[i].0 + boxes[i].1;
                    let axis = (hi - lo).max_position();
                    let mid = (start + end) / 2;
                    order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                        centre(a)[axis].total_cmp(&centre(b)[axis])
                    });
                    let children = nodes.len() / 2;
                    nodes.resize(nodes.len() + 4, [0.0; 4]);
                    todo.push((children, start, mid));
                    todo.push((children + 1, mid, end));
                    (children as u32, 0)
                };
                nodes[2 * node] = lo.extend(f32::from_bits(first)).to_array();
                nodes[2 * node + 1] = hi.extend(f32::from_bits(count)).to_array();
            }
        }
        let faces = order
            .iter()
            .map(|&i| {
                let (c, k) = walk.boundary[i];
                [c, u32::from(k)]
            })
            .collect();
        Self { nodes, faces }
    }
}

/// What both kernels read of a grid: the points (value times `sign`, the gradients), the
/// cells, their frames and the hierarchy.
struct GridData {
    points: Vec<[f32; 4]>,
    cells: Vec<[u32; 4]>,
    frames: Vec<[f32; 4]>,
    hierarchy: Hierarchy,
}

impl GridData {
    fn new(grid: &TetGrid, walk: &Walk, sign: f32, gradients: &[Vec3]) -> Self {
        // WGSL gives NaN and infinity no defined meaning: a non-finite value goes up as 0
        // and its cells are flagged, to be treated as the CPU twin treats them.
        let points = grid
            .points()
            .iter()
            .zip(grid.values())
            .zip(gradients)
            .flat_map(|((p, &v), g)| {
                let v = if v.is_finite() { sign * v } else { 0.0 };
                [p.extend(v).to_array(), g.extend(0.0).to_array()]
            })
            .collect();
        let cells = grid
            .tets()
            .iter()
            .zip(&walk.neighbours)
            .flat_map(|(t, n)| [*t, *n])
            .collect();
        let frames = grid
            .tets()
            .par_iter()
            .flat_map_iter(|t| {
                let p = t.map(|i| grid.points()[i as usize].as_dvec3());
                let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
                let flat = is_degenerate(&p, m.determinant());
                let inv = if flat { DMat3::ZERO } else { m.inverse() };
                let row = |i: usize| inv.row(i).as_vec3().extend(0.0).to_array();
                let unknown = t.iter().any(|&i| !grid.values()[i as usize].is_finite());
                let flag = if flat {
                    FLAT
                } else if unknown {
                    NOT_FINITE
                } else {
                    0.0
                };
                let p0 = p[0].as_vec3().extend(flag);
                [p0.to_array(), row(0), row(1), row(2)]
            })
            .collect();
        Self {
            points,
            cells,
            frames,
            hierarchy: Hierarchy::new(grid, walk),
        }
    }
}

/// A cell's flag in its frame's `w`: degenerate (no inside; the walk steps across it).
const FLAT: f32 = 1.0;
/// A cell's flag in its frame's `w`: a point value is not finite (crossed, but it holds no
/// surface and is clear, as on the CPU twin).
const NOT_FINITE: f32 = 2.0;

/// The entry points of `tets.wgsl`.
#[derive(Clone, Copy)]
enum Entry {
    Iso,
    Dvr,
}

impl GpuRenderer {
    /// [`TetCaster::render`] on the GPU: the same G-buffer to f32 rounding (the kernel
    /// walks in f32; [`crate::tets`] says more).
    pub fn render_tets(
        &self,
        caster: &TetCaster<'_>,
        u: &Uniforms,
    ) -> Result<GBuffer, RenderError> {
        let (w, h) = crate::check_image_size(u64::from(u.width), u64::from(u.height))?;
        let data = GridData::new(caster.grid, &caster.walk, caster.sign, &caster.gradients);
        let rays: Vec<(DVec3, DVec3)> = (0..w * h)
            .map(|pix| {
                let (o, d) = pixel_ray(u, pix % w, pix / w);
                (o.as_dvec3(), d.as_dvec3().normalize_or_zero())
            })
            .collect();
        let params = TetParams {
            iso: caster.iso,
            smooth_normals: u32::from(caster.normals == super::TetNormals::Smooth),
            ..TetParams::default()
        };
        let out = self.dispatch_tets(Entry::Iso, &data, &rays, params, &[[0.0; 4]])?;
        let (pixels, samples) = out
            .chunks_exact(2)
            .zip(&rays)
            .map(|(r, &(o, d))| {
                let hit = (r[0][1] > 0.5).then(|| {
                    let t = f64::from(r[0][0]);
                    TetHit {
                        t,
                        position: o + t * d,
                        normal: Vec3::new(r[1][0], r[1][1], r[1][2]).as_dvec3(),
                        cell: 0,
                    }
                });
                (
                    hit.map_or(crate::kernel::GSample::default(), sample),
                    r[0][2] as u32,
                )
            })
            .unzip();
        Ok(GBuffer::new(w, h, pixels, samples))
    }

    /// [`TetVolume::render`] on the GPU: the same image to f32 rounding (the kernel walks
    /// in f32).
    pub fn render_tets_dvr(
        &self,
        vol: &TetVolume<'_>,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &TetDvrOptions,
    ) -> Result<DvrImage, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        let table = vol.table(tf, opts)?;
        let data = GridData::new(vol.grid, &vol.walk, 1.0, &vol.gradients);
        let rays: Vec<(DVec3, DVec3)> = (0..width * height)
            .map(|pix| {
                let r = crate::dvr::pixel_ray(camera, pix);
                (r.origin.as_dvec3(), r.dir.as_dvec3().normalize_or_zero())
            })
            .collect();
        let mut tf_data: Vec<[f32; 4]> = tf
            .points()
            .iter()
            .flat_map(|q| {
                [
                    [q.value, q.sigma, 0.0, 0.0],
                    q.emission.extend(0.0).to_array(),
                ]
            })
            .collect();
        let mut params = TetParams {
            n_tf: tf.points().len() as u32,
            termination: opts.termination,
            shade: u32::from(opts.shade),
            table_at: tf_data.len() as u32,
            table_n: 2,
            table_m: 2,
            table_hi: 1.0,
            table_len: 1.0,
            ..TetParams::default()
        };
        params.mode = match (opts.classification, &table) {
            (Classification::Post, _) => 0,
            (Classification::Preintegrated, Some(t)) => {
                let (entries, lo, hi, n, m) = t.layout();
                check_fits(
                    &self.gpu,
                    "the 3D pre-integration table",
                    16 * entries.len() as u64,
                )?;
                tf_data.extend(entries.iter().map(|e| e.to_array()));
                (params.table_lo, params.table_hi) = (lo, hi);
                (params.table_n, params.table_m) = (n as u32, m as u32);
                params.table_len = t.max_len();
                1
            }
            (Classification::Preintegrated, None) => 2,
        };
        let out = self.dispatch_tets(Entry::Dvr, &data, &rays, params, &tf_data)?;
        let (mut rgba, mut depth) = (Vec::with_capacity(rays.len()), Vec::new());
        let mut samples = 0u64;
        for r in out.chunks_exact(2) {
            rgba.push(Vec4::from_array(r[0]));
            depth.push(if r[1][3] > 0.5 {
                r[1][0]
            } else {
                f32::INFINITY
            });
            samples += r[1][1] as u64;
        }
        Ok(DvrImage {
            width,
            height,
            rgba,
            depth,
            samples,
            skipped_blocks: 0,
            step: 0.0,
            classification: opts.classification,
            shaded: opts.shade,
            gradient: "point",
        })
    }

    /// Runs `entry` once per ray, in chunks of rays whose buffers fit the device
    /// ([`Self::dispatch_tets_chunk`]), and returns the two `vec4<f32>` of each ray.
    fn dispatch_tets(
        &self,
        entry: Entry,
        data: &GridData,
        rays: &[(DVec3, DVec3)],
        params: TetParams,
        tf: &[[f32; 4]],
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let gpu = &self.gpu;
        for (what, bytes) in [
            ("the boundary faces", 8 * data.hierarchy.faces.len()),
            ("the points", 16 * data.points.len()),
            ("the cells", 16 * data.cells.len()),
            ("the cells' frames", 16 * data.frames.len()),
            (
                "the boundary faces' hierarchy",
                16 * data.hierarchy.nodes.len(),
            ),
            ("the transfer function and table", 16 * tf.len()),
        ] {
            check_fits(gpu, what, bytes as u64)?;
        }
        // 32 bytes a ray in, 32 out.
        let fit = (gpu.max_storage_bytes() / 32).max(1) as usize;
        let chunk = self.max_rays.min(fit).max(1);
        let mut out = Vec::with_capacity(2 * rays.len());
        for part in rays.chunks(chunk) {
            out.extend(self.dispatch_tets_chunk(entry, data, part, params, tf)?);
        }
        Ok(out)
    }

    /// Uploads `data`, `rays` and `tf` (volume rendering only), runs `entry` once per ray
    /// with `params` completed, and reads back its two `vec4<f32>` per ray.
    fn dispatch_tets_chunk(
        &self,
        entry: Entry,
        data: &GridData,
        rays: &[(DVec3, DVec3)],
        mut params: TetParams,
        tf: &[[f32; 4]],
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let gpu = &self.gpu;
        let count = rays.len();
        let (slot, name) = match entry {
            Entry::Iso => (&self.tet_iso, "tet_iso"),
            Entry::Dvr => (&self.tet_dvr, "tet_dvr"),
        };
        let pipeline = match slot.get() {
            Some(pl) => pl,
            None => {
                let s = tets_shader();
                let pl = gpu.compute_pipeline(s.label(), s.text(), name)?;
                slot.get_or_init(|| pl)
            }
        };
        let ray_data: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|(o, d)| {
                [
                    o.as_vec3().extend(0.0).to_array(),
                    d.as_vec3().extend(0.0).to_array(),
                ]
            })
            .collect();
        let (groups, stride) = dispatch_grid(gpu, count);
        params.count = count as u32;
        params.stride = stride;
        params.cells = (data.cells.len() / 2) as u32;
        params.nodes = (data.hierarchy.nodes.len() / 2) as u32;
        let empty = [[0.0f32; 4]; 2];
        let nodes: &[[f32; 4]] = if data.hierarchy.nodes.is_empty() {
            &empty
        } else {
            &data.hierarchy.nodes
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let (_inputs, out, bind) = scoped(gpu, "allocating the tetrahedra buffers", || {
            let inputs = [
                gpu.upload("tets params", &[params], wgpu::BufferUsages::UNIFORM),
                gpu.upload("tets points", &data.points, storage),
                gpu.upload("tets cells", &data.cells, storage),
                gpu.upload("tets frames", &data.frames, storage),
                gpu.upload("tets hierarchy", nodes, storage),
                gpu.upload("tets boundary faces", &data.hierarchy.faces, storage),
                gpu.upload("tets rays", &ray_data, storage),
                gpu.upload("tets transfer function", tf, storage),
            ];
            let out = gpu.buffer("tets output", 32 * count as u64, storage);
            let [a, b, c, d, e, f, g, t] = &inputs;
            let mut list = vec![a, b, c, d, e, f, g, &out];
            if let Entry::Dvr = entry {
                list.push(t);
            }
            let bind = gpu.bind_buffers("tets", pipeline, &list);
            (inputs, out, bind)
        })?;
        gpu.dispatch(name, pipeline, &bind, groups)?;
        Ok(gpu.read_buffer(&out, 0, 2 * count)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tet_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<TetParams>();
    }
}
