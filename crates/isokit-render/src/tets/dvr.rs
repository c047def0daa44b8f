//! Direct volume rendering through the cells of a [`TetGrid`] (004 Sec. 4: volume rendering
//! of unstructured tetrahedral grids), with the emission–absorption model and transfer
//! functions of [`crate::dvr`].
//!
//! Each ray walks its cells front to back as the isosurface caster ([`super::TetCaster`])
//! does. In a cell the value is linear, so along the ray it goes linearly from the entry's
//! value `v_f` to the exit's `v_b` over the segment's length `l`: the segment's colour and
//! opacity are exactly one entry of the 3D pre-integration table over (front value, back
//! value, length) ([`PreintegrationTable3`]; Engel, Kraus and Ertl 2001 Sec. 4, after Röttger,
//! Kraus and Ertl 2000, "Hardware-Accelerated Volume and Isosurface Rendering Based on
//! Cell-Projection"), interpolated trilinearly. The lengths the table spans run from 0 to
//! the 95th percentile of the cells' longest edges (a segment in a tetrahedron is no longer
//! than its longest edge); a longer segment is cut into equal pieces that fit, each still
//! linear in value, so a few long cells of a graded mesh do not coarsen the length axis for
//! all the others. With `table_size` 0
//! each segment is integrated on its own instead ([`TransferFunction::segment`], the
//! table's entries' own rule): slower, and without the table's interpolation error.
//!
//! Post-classification ([`Classification::Post`]) classifies each segment by the value at
//! its middle, as a constant extinction over the segment: cheap, and only as good as the
//! cells are small against the transfer function's features.
//!
//! Shading ([`TetDvrOptions::shade`]) uses the point gradients (the volume-weighted mean of
//! the cells' gradients) interpolated at the segment's middle, by [`shade_sample`]. Cells
//! with a non-finite value are transparent; rays start at the first boundary face they meet
//! (the camera must be outside the grid). The GPU twin is
//! [`crate::gpu::GpuRenderer::render_tets_dvr`] (`shaders/tets.wgsl`, entry point `tet_dvr`).

use super::{Walk, cell_values, interpolated_gradient, point_gradients};
use crate::RenderError;
use crate::dvr::{
    Classification, DvrImage, PreintegrationTable3, SHADE_MIN_OPACITY, TransferFunction, Within,
    gpu::SUB_STEPS, shade_sample,
};
use glam::{DVec3, Vec3, Vec4};
use isokit_field::{Camera, Job, TetGrid};
use rayon::prelude::*;
use std::ops::ControlFlow;

/// Knobs of [`TetVolume::render`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetDvrOptions {
    /// Pre-integration (a segment per cell from the table) or post-classification (the
    /// segment's middle value).
    pub classification: Classification,
    /// Opacity at which a ray stops (early ray termination); 1 disables it.
    pub termination: f32,
    /// Entries of the 3D table per value axis (2 to 1024); 0: each segment integrated on
    /// its own, no table.
    pub table_size: usize,
    /// Entries of the 3D table along the length axis (2 to 1024).
    pub table_lengths: usize,
    /// Blinn-Phong shading by the interpolated point gradients ([`shade_sample`]).
    pub shade: bool,
}

impl Default for TetDvrOptions {
    fn default() -> Self {
        Self {
            classification: Classification::Preintegrated,
            termination: 0.999,
            table_size: 128,
            table_lengths: 64,
            shade: false,
        }
    }
}

/// A tetrahedral grid prepared for direct volume rendering: the walk, the point gradients,
/// the edge lengths the table and the presets need.
pub struct TetVolume<'g> {
    pub(super) grid: &'g TetGrid,
    pub(super) walk: Walk,
    pub(super) gradients: Vec<Vec3>,
    longest_edge: f32,
    /// The 95th percentile of the cells' longest edges: the table's longest segment.
    table_edge: f32,
    mean_edge: f32,
}

impl<'g> TetVolume<'g> {
    /// Prepares `grid` (its faces' topology, the boundary faces' kd-tree, the gradients).
    pub fn new(grid: &'g TetGrid) -> Self {
        let per_cell: Vec<(f32, f64)> = grid
            .tets()
            .par_iter()
            .map(|t| {
                let p = t.map(|i| grid.points()[i as usize]);
                let (mut longest, mut sum) = (0.0f32, 0.0f64);
                for a in 0..4 {
                    for b in a + 1..4 {
                        let e = p[a].distance(p[b]);
                        longest = longest.max(e);
                        sum += f64::from(e);
                    }
                }
                (longest, sum)
            })
            .collect();
        let sum: f64 = per_cell.iter().map(|c| c.1).sum();
        let mut longest_edges: Vec<f32> = per_cell.iter().map(|c| c.0).collect();
        let longest = longest_edges.iter().copied().fold(0.0f32, f32::max);
        let table_edge = if longest_edges.is_empty() {
            0.0
        } else {
            let k = (longest_edges.len() * 95 / 100).min(longest_edges.len() - 1);
            *longest_edges.select_nth_unstable_by(k, f32::total_cmp).1
        };
        let edges = 6.0 * grid.tets().len().max(1) as f64;
        Self {
            grid,
            walk: Walk::new(grid),
            gradients: point_gradients(grid, 1.0),
            longest_edge: longest,
            table_edge,
            mean_edge: (sum / edges) as f32,
        }
    }

    /// The longest cell edge: the longest segment a ray can have in one cell.
    pub fn longest_edge(&self) -> f32 {
        self.longest_edge
    }

    /// The mean cell edge (the grid's "spacing" for transfer-function presets scaled by
    /// one, [`TransferFunction::preset`]).
    pub fn mean_edge(&self) -> f32 {
        self.mean_edge
    }

    /// Boundary faces (each a face of one cell only).
    pub fn boundary_faces(&self) -> usize {
        self.walk.boundary_faces()
    }

    /// Renders the grid through `camera` with `tf` (see the [module](self) docs),
    /// reporting progress to `job` (stage `volume rendering tetrahedra`, in rows). The
    /// image's `samples` counts the cell segments composited, its `step` is 0 (a segment is
    /// a cell's) and no blocks are skipped.
    pub fn render(
        &self,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &TetDvrOptions,
        job: &Job,
    ) -> Result<DvrImage, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        let table = self.table(tf, opts)?;
        let counter = job.counter("volume rendering tetrahedra", u64::from(height));
        let rows = (0..height)
            .into_par_iter()
            .map(|y| {
                job.check()?;
                let row: Vec<(Vec4, f32, u32)> = (0..width)
                    .map(|x| {
                        let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                        let d = ray.dir.as_dvec3().normalize_or_zero();
                        self.trace(ray.origin.as_dvec3(), d, tf, table.as_ref(), opts)
                    })
                    .collect();
                counter.advance(1);
                Ok(row)
            })
            .collect::<Result<Vec<_>, isokit_field::Cancelled>>()
            .map_err(isokit_field::FieldError::from)?;
        let rays: Vec<(Vec4, f32, u32)> = rows.into_iter().flatten().collect();
        Ok(DvrImage {
            width,
            height,
            rgba: rays.iter().map(|r| r.0).collect(),
            depth: rays.iter().map(|r| r.1).collect(),
            samples: rays.iter().map(|r| u64::from(r.2)).sum(),
            skipped_blocks: 0,
            step: 0.0,
            classification: opts.classification,
            shaded: opts.shade,
            gradient: "point",
        })
    }

    /// The 3D pre-integration table `opts` ask for (none for post-classification or a
    /// `table_size` of 0), shared by both twins.
    pub(crate) fn table(
        &self,
        tf: &TransferFunction,
        opts: &TetDvrOptions,
    ) -> Result<Option<PreintegrationTable3>, RenderError> {
        if !(0.0..=1.0).contains(&opts.termination) {
            return Err(RenderError::bad(
                "termination",
                opts.termination,
                "must be an opacity from 0 to 1",
            ));
        }
        Ok(match (opts.classification, opts.table_size) {
            (Classification::Preintegrated, n) if n > 0 => {
                let (lo, hi) =
                    isokit_field::finite_min_max(self.grid.values()).unwrap_or((0.0, 1.0));
                // Up to the 95th percentile of the cells' longest edges (a little beyond:
                // exits are found in f64), so a few long cells do not stretch the length
                // axis for all the others; longer segments are cut into pieces.
                let max_len = (self.table_edge * (1.0 + 1e-5)).max(f32::MIN_POSITIVE);
                Some(PreintegrationTable3::new(
                    tf,
                    lo,
                    hi,
                    n,
                    opts.table_lengths,
                    max_len,
                )?)
            }
            _ => None,
        })
    }

    /// One ray `o + t d` (`d` of unit length): premultiplied colour and opacity, the depth
    /// where the opacity passes 0.5 (infinite where it never does), the segments
    /// composited.
    pub fn trace(
        &self,
        o: DVec3,
        d: DVec3,
        tf: &TransferFunction,
        table: Option<&PreintegrationTable3>,
        opts: &TetDvrOptions,
    ) -> (Vec4, f32, u32) {
        let (mut c, mut trans) = (Vec3::ZERO, 1.0f32);
        let mut depth = f32::INFINITY;
        let mut segments = 0u32;
        let dir = d.as_vec3();
        // A segment longer than the table's lengths is cut into pieces that fit (the value
        // stays linear along each).
        let max_len = table.map_or(f32::INFINITY, |t| t.max_len());
        self.walk.walk(self.grid, o, d, |x| {
            let v = cell_values(self.grid, x.cell, 1.0);
            let len = (x.t_out - x.t_in) as f32;
            if v.iter().any(|v| !v.is_finite()) || len <= 0.0 {
                return ControlFlow::Continue(());
            }
            segments += 1;
            let (v_in, v_out) = (x.value(&v, x.t_in) as f32, x.value(&v, x.t_out) as f32);
            // The gradient at the segment's middle, made only for a piece that is shaded.
            let mut gradient: Option<Vec3> = None;
            let mut shading = || {
                *gradient.get_or_insert_with(|| {
                    let mid = x.lambda(0.5 * (x.t_in + x.t_out));
                    let idx = self.grid.tets()[x.cell as usize];
                    interpolated_gradient(&self.gradients, idx, &mid).as_vec3()
                })
            };
            let pieces = if len > max_len {
                (len / max_len).ceil().min(1e6) as u32
            } else {
                1
            };
            let piece = len / pieces as f32;
            for k in 0..pieces {
                let at = |f: f32| v_in + (v_out - v_in) * f;
                let (vf, vb) = (
                    at(k as f32 / pieces as f32),
                    at((k + 1) as f32 / pieces as f32),
                );
                let (seg, within) = match opts.classification {
                    Classification::Post => {
                        let (e, sigma) = tf.eval(0.5 * (vf + vb));
                        let alpha = 1.0 - (-sigma * piece).exp();
                        ((e * alpha).extend(alpha), Within::Constant(sigma))
                    }
                    Classification::Preintegrated => {
                        let seg = match table {
                            Some(t) => t.lookup(vf, vb, piece),
                            None => tf.segment(vf, vb, piece, SUB_STEPS as usize),
                        };
                        (seg, Within::Linear(vf, vb))
                    }
                };
                let seg = if opts.shade && seg.w > SHADE_MIN_OPACITY {
                    shade_sample(seg, shading(), dir)
                } else {
                    seg
                };
                c += trans * seg.truncate();
                let before = trans;
                trans *= 1.0 - seg.w;
                if before > 0.5 && trans <= 0.5 {
                    let alpha = 1.0 - 0.5 / before;
                    let into = match (table, &within) {
                        // Bisection on the table's own entries: consistent with the
                        // composited segment, and no integration per step.
                        (Some(t), Within::Linear(..)) => {
                            let (mut lo, mut hi) = (0.0f32, 1.0f32);
                            for _ in 0..24 {
                                let m = 0.5 * (lo + hi);
                                if t.lookup(vf, vf + (vb - vf) * m, piece * m).w >= alpha {
                                    hi = m;
                                } else {
                                    lo = m;
                                }
                            }
                            hi * piece
                        }
                        _ => within.opacity_at(tf, piece, alpha),
                    };
                    depth = x.t_in as f32 + k as f32 * piece + into;
                }
                if 1.0 - trans >= opts.termination {
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        });
        (c.extend(1.0 - trans), depth, segments)
    }
}
