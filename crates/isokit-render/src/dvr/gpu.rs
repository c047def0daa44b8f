//! The host code of `shaders/dvr.wgsl`: direct volume rendering on the GPU
//! ([`GpuRenderer::render_dvr`]); the CPU twin is `dvr/mod.rs` ([`super::render_dvr`]).
//!
//! The host prepares what both twins share (`prepare` in the parent module: the checked
//! step, the pre-integration table, the empty-block flags) and the rays (one origin and
//! direction per pixel, from the camera exactly as the CPU twin makes them); the kernel
//! traces each ray as `trace_ray` does. The volume goes to the GPU as a storage buffer of f32
//! (x fastest), the transfer function as two `vec4<f32>` per control point. The GPU computes
//! in f32 where the CPU twin integrates partial segments in f64, and its compiler may fuse
//! multiply-adds, so the two agree to rounding (`tests/dvr.rs` measures it), not bit for bit.

use super::{DvrImage, DvrOptions, Prepared, RayResult, TransferFunction, prepare};
use crate::clip::Clip;
use crate::gpu::{GpuRenderer, WORKGROUP, check_fits, dispatch_grid, scoped};
use crate::spherical::{IsoOptions, SphericalVolume, iso_knobs, iso_sample};
use crate::{GBuffer, RenderError};
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use isokit_field::{Camera, Grid};
use isokit_gpu::{ShaderSource, wgpu};

/// Sub-steps per linear piece of the transfer function in a pre-integrated segment (both
/// twins; prepended to the WGSL as `SUB_STEPS`).
pub const SUB_STEPS: u32 = 4;

/// `DvrParams` in `dvr.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct DvrParams {
    pub(crate) dims: [u32; 3],
    pub(crate) count: u32,
    pub(crate) origin: [f32; 3],
    pub(crate) spacing: f32,
    pub(crate) bmin: [f32; 3],
    pub(crate) step: f32,
    pub(crate) bmax: [f32; 3],
    pub(crate) termination: f32,
    pub(crate) blocks: [u32; 3],
    pub(crate) block: u32,
    pub(crate) n_tf: u32,
    pub(crate) preintegrated: u32,
    pub(crate) table_n: u32,
    pub(crate) stride: u32,
    pub(crate) table_lo: f32,
    pub(crate) table_hi: f32,
    pub(crate) table_len: f32,
    pub(crate) shade: u32,
    pub(crate) clip_sign: f32,
    pub(crate) lattice: u32,
    pub(crate) wrap: u32,
    pub(crate) wedge: u32,
    pub(crate) sph_lo: [f32; 3],
    pub(crate) iso: f32,
    pub(crate) sph_hi: [f32; 3],
    pub(crate) iso_sign: f32,
    pub(crate) sph_step: [f32; 3],
    pub(crate) sph_pad: f32,
}

isokit_gpu::wgsl_layout!(DvrParams {
    dims: "vec3<u32>",
    count: "u32",
    origin: "vec3<f32>",
    spacing: "f32",
    bmin: "vec3<f32>",
    step: "f32",
    bmax: "vec3<f32>",
    termination: "f32",
    blocks: "vec3<u32>",
    block: "u32",
    n_tf: "u32",
    preintegrated: "u32",
    table_n: "u32",
    stride: "u32",
    table_lo: "f32",
    table_hi: "f32",
    table_len: "f32",
    shade: "u32",
    clip_sign: "f32",
    lattice: "u32",
    wrap: "u32",
    wedge: "u32",
    sph_lo: "vec3<f32>",
    iso: "f32",
    sph_hi: "vec3<f32>",
    iso_sign: "f32",
    sph_step: "vec3<f32>",
    sph_pad: "f32",
});

/// The direct volume rendering kernel, assembled: `WORKGROUP`, `SUB_STEPS` and the shading
/// constants from Rust,
/// `common/bspline.wgsl`, `common/transfer.wgsl`, `common/slab.wgsl`, `dvr.wgsl` (entry points `dvr`,
/// `spherical_iso`).
pub fn dvr_shader() -> ShaderSource {
    let (ka, kd, ks, shininess) = super::SHADE_WEIGHTS;
    ShaderSource::new("dvr")
        .constant_u32("WORKGROUP", WORKGROUP)
        .constant_u32("SUB_STEPS", SUB_STEPS)
        .constant_f32("SHADE_MIN_OPACITY", super::SHADE_MIN_OPACITY)
        .constant_f32("SHADE_KA", ka)
        .constant_f32("SHADE_KD", kd)
        .constant_f32("SHADE_KS", ks)
        .constant_u32("SHININESS", shininess)
        .piece(isokit_shaders::common::BSPLINE)
        .piece(isokit_shaders::common::TRANSFER)
        .piece(isokit_shaders::common::SLAB)
        .piece(isokit_shaders::DVR)
}

impl GpuRenderer {
    /// [`super::render_dvr`] on the GPU: the same image to rounding. Volumes with
    /// non-finite samples are refused (WGSL gives NaN and infinity no defined meaning; the
    /// CPU twin renders them as clear).
    pub fn render_dvr(
        &self,
        grid: &Grid,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &DvrOptions,
    ) -> Result<DvrImage, RenderError> {
        self.render_dvr_clipped(grid, camera, tf, opts, None)
    }

    /// [`super::render_dvr_clipped`] on the GPU: the clip field goes up as a second
    /// storage buffer on the volume's lattice and every step is cut as the CPU twin cuts it.
    pub fn render_dvr_clipped(
        &self,
        grid: &Grid,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &DvrOptions,
        clip: Option<&Clip>,
    ) -> Result<DvrImage, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        if grid.data().iter().any(|v| !v.is_finite()) {
            return Err(RenderError::BadVolume {
                dims: grid.dims(),
                why: "has non-finite samples, which the GPU twin of direct volume rendering does not take (render it on the CPU)",
            });
        }
        let p = prepare(grid, tf, opts)?;
        if let Some(c) = clip {
            c.fits(grid)?;
        }
        let b = grid.bounds();
        let params = DvrParams {
            dims: grid.dims().map(|d| d as u32),
            origin: grid.origin().to_array(),
            spacing: grid.spacing(),
            bmin: b.min.to_array(),
            bmax: b.max.to_array(),
            clip_sign: clip.map_or(0.0, Clip::keep_sign),
            ..DvrParams::default()
        };
        let clip_data: &[f32] = clip.map_or(&[0.0], |c| c.grid().data());
        let input = Input {
            volume: grid.data(),
            clip: clip_data,
            tf: Some(tf),
            p: Some(&p),
        };
        let rays = self.run_dvr(Entry::Dvr, camera, params, &input)?;
        Ok(DvrImage::from_rays(width, height, &p, &rays))
    }

    /// [`super::render_dvr_spherical`] on the GPU: the same image to rounding (the
    /// lattice's mapping uses the GPU's `acos` and `atan2`).
    pub fn render_dvr_spherical(
        &self,
        vol: &SphericalVolume,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &DvrOptions,
    ) -> Result<DvrImage, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        let p = super::prepare_spherical(vol, tf, opts)?;
        let input = Input {
            volume: vol.samples().data(),
            clip: &[0.0],
            tf: Some(tf),
            p: Some(&p),
        };
        let rays = self.run_dvr(Entry::Dvr, camera, spherical_params(vol), &input)?;
        Ok(DvrImage::from_rays(width, height, &p, &rays))
    }

    /// [`crate::spherical::render_iso`] on the GPU (`spherical_iso` in `dvr.wgsl`): the
    /// same G-buffer to rounding.
    pub fn render_spherical_iso(
        &self,
        vol: &SphericalVolume,
        camera: &Camera,
        opts: &IsoOptions,
    ) -> Result<GBuffer, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        let (step, sign) = iso_knobs(vol, opts)?;
        let params = DvrParams {
            step,
            iso: opts.iso,
            iso_sign: sign,
            ..spherical_params(vol)
        };
        let input = Input {
            volume: vol.samples().data(),
            clip: &[0.0],
            tf: None,
            p: None,
        };
        let (rgba, extra) = self.dispatch_dvr(Entry::SphericalIso, camera, params, &input)?;
        let (pixels, samples) = rgba
            .iter()
            .zip(&extra)
            .enumerate()
            .map(|(pix, (n, x))| {
                let ray = super::pixel_ray(camera, pix as u32);
                let hit = (x[3] > 0.5).then(|| (x[0], Vec3::new(n[0], n[1], n[2]), n[3] > 0.5));
                (iso_sample(ray, hit), x[1] as u32)
            })
            .unzip();
        Ok(GBuffer::new(width, height, pixels, samples))
    }

    /// Runs the `dvr` entry point: one [`RayResult`] per pixel.
    fn run_dvr(
        &self,
        entry: Entry,
        camera: &Camera,
        params: DvrParams,
        input: &Input<'_>,
    ) -> Result<Vec<RayResult>, RenderError> {
        let (rgba, extra) = self.dispatch_dvr(entry, camera, params, input)?;
        Ok(rgba
            .iter()
            .zip(&extra)
            .map(|(c, x)| {
                let depth = if x[3] > 0.5 { x[0] } else { f32::INFINITY };
                (Vec4::from_array(*c), depth, x[1] as u32, x[2] as u32)
            })
            .collect())
    }

    /// Uploads what `dvr.wgsl` reads (the rays from `camera`, the samples, the transfer
    /// function, table and empty blocks of `input.p`, the clip) with `params` completed
    /// by them, runs `entry` once per pixel and reads back its two outputs.
    fn dispatch_dvr(
        &self,
        entry: Entry,
        camera: &Camera,
        mut params: DvrParams,
        input: &Input<'_>,
    ) -> Result<Outputs, RenderError> {
        let gpu = &self.gpu;
        let (width, height) = (camera.width(), camera.height());
        let count = width as usize * height as usize;
        check_fits(gpu, "the volume", 4 * input.volume.len() as u64)?;
        check_fits(gpu, "the clip field", 4 * input.clip.len() as u64)?;
        check_fits(gpu, "the rays", 32 * count as u64)?;
        let (slot, name) = match entry {
            Entry::Dvr => (&self.dvr, "dvr"),
            Entry::SphericalIso => (&self.spherical_iso, "spherical_iso"),
        };
        let pipeline = match slot.get() {
            Some(pl) => pl,
            None => {
                let s = dvr_shader();
                let pl = gpu.compute_pipeline(s.label(), s.text(), name)?;
                slot.get_or_init(|| pl)
            }
        };
        let rays: Vec<[f32; 4]> = (0..count)
            .flat_map(|pix| {
                let r = super::pixel_ray(camera, pix as u32);
                [
                    r.origin.extend(0.0).to_array(),
                    r.dir.extend(0.0).to_array(),
                ]
            })
            .collect();
        let points: Vec<[f32; 4]> = match input.tf {
            Some(tf) => tf
                .points()
                .iter()
                .flat_map(|q| {
                    [
                        [q.value, q.sigma, 0.0, 0.0],
                        q.emission.extend(0.0).to_array(),
                    ]
                })
                .collect(),
            None => vec![[0.0; 4]; 2],
        };
        let (table, table_n, table_lo, table_hi, table_len) =
            match input.p.and_then(|p| p.table.as_ref()) {
                Some(t) => (
                    t.entries.iter().map(|e| e.to_array()).collect(),
                    t.n as u32,
                    t.lo,
                    t.hi,
                    t.len(),
                ),
                None => (vec![[0.0f32; 4]], 2, 0.0, 1.0, 1.0),
            };
        let (empty, blocks, block): (Vec<u32>, [u32; 3], u32) =
            match input.p.and_then(|p| p.blocks.as_ref()) {
                Some(b) => (
                    b.empty.iter().map(|&e| u32::from(e)).collect(),
                    b.counts.map(|c| c as u32),
                    b.b as u32,
                ),
                None => (vec![0], [1; 3], 0),
            };
        let (groups, stride) = dispatch_grid(gpu, count);
        params.count = count as u32;
        params.stride = stride;
        params.blocks = blocks;
        params.block = block;
        params.table_n = table_n;
        params.table_lo = table_lo;
        params.table_hi = table_hi;
        params.table_len = table_len;
        params.n_tf = input.tf.map_or(1, |tf| tf.points().len() as u32);
        if let Some(p) = input.p {
            params.step = p.step;
            params.termination = p.termination;
            params.preintegrated = u32::from(p.table.is_some());
            // 0: no shading; 1: central differences; 2: the tricubic gradient.
            params.shade = match (p.shade, p.gradient, params.lattice) {
                (false, _, _) => 0,
                (true, super::DvrGradient::Tricubic, 0) => 2,
                (true, _, _) => 1,
            };
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let (_inputs, rgba, extra, bind) = scoped(gpu, "allocating the dvr buffers", || {
            let inputs = [
                gpu.upload("dvr params", &[params], wgpu::BufferUsages::UNIFORM),
                gpu.upload("dvr volume", input.volume, storage),
                gpu.upload("dvr transfer function", &points, storage),
                gpu.upload("dvr table", &table, storage),
                gpu.upload("dvr empty blocks", &empty, storage),
                gpu.upload("dvr rays", &rays, storage),
                gpu.upload("dvr clip", input.clip, storage),
            ];
            let rgba = gpu.buffer("dvr rgba", 16 * count as u64, storage);
            let extra = gpu.buffer("dvr depth", 16 * count as u64, storage);
            let [a, b, c, d, e, f, k] = &inputs;
            let bind = gpu.bind_buffers("dvr", pipeline, &[a, b, c, d, e, f, &rgba, &extra, k]);
            (inputs, rgba, extra, bind)
        })?;
        gpu.dispatch(name, pipeline, &bind, groups)?;
        let rgba: Vec<[f32; 4]> = gpu.read_buffer(&rgba, 0, count)?;
        let extra: Vec<[f32; 4]> = gpu.read_buffer(&extra, 0, count)?;
        Ok((rgba, extra))
    }
}

/// What a dispatch of `dvr.wgsl` writes per pixel: `out_rgba` and `out_extra`.
type Outputs = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// The entry points of `dvr.wgsl`.
#[derive(Clone, Copy)]
enum Entry {
    Dvr,
    SphericalIso,
}

/// What a dispatch of `dvr.wgsl` reads besides its parameters.
struct Input<'a> {
    volume: &'a [f32],
    clip: &'a [f32],
    tf: Option<&'a TransferFunction>,
    p: Option<&'a Prepared>,
}

/// The parameters that describe a spherical volume's lattice.
fn spherical_params(vol: &SphericalVolume) -> DvrParams {
    let l = vol.lattice();
    let b = vol.bounds();
    DvrParams {
        dims: vol.samples().dims().map(|d| d as u32),
        spacing: vol.spacing(),
        bmin: b.min.to_array(),
        bmax: b.max.to_array(),
        lattice: 1,
        wrap: u32::from(vol.periodic()),
        wedge: u32::from(vol.wedge()),
        sph_lo: [l.r[0], l.theta[0], l.phi[0]],
        sph_hi: [l.r[1], l.theta[1], l.phi[1]],
        sph_step: vol.delta().to_array(),
        ..DvrParams::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dvr_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<DvrParams>();
    }
}
