//! Ray casting the isosurface of a [`TetGrid`] through its cells (004 Sec. 4: isosurfaces of
//! unstructured tetrahedral grids), with no resampling to a regular grid.
//!
//! A ray enters the grid through a boundary face (found in a kd-tree of the boundary faces
//! that face the ray), then walks from cell to cell across shared faces. In each cell the
//! scalar is linear, so along the ray it is linear too: with the barycentric coordinates
//! `λ(t) = α + β t` of the ray's points, the ray leaves the cell where the first `λ_k` with
//! `β_k < 0` reaches 0 (through the face opposite point `k`), and the value `Σ λ_k v_k`
//! crosses the isovalue at most once in between, at a parameter found exactly (one division).
//! Where the walk leaves the grid it looks for the next boundary face beyond, so grids that
//! are not convex (or not connected) are rendered whole. Where the values are finite, the
//! hit is therefore the point of the piecewise-linear isosurface that marching tetrahedra
//! triangulate
//! (`isokit_levelset::tets`), which the tests compare ray by ray.
//!
//! Normals: the gradient of the linear interpolant is constant in a cell (`flat`); by
//! default the gradients at the points (the volume-weighted mean of their cells') are
//! interpolated with the hit's barycentric coordinates (`smooth`, as Gouraud-Phong
//! normals on a mesh). The surface carries no curvature (it is piecewise planar), so the
//! G-buffer's curvatures are 0.
//!
//! The GPU twin is [`crate::gpu::GpuRenderer::render_tets`] (`shaders/tets.wgsl`, entry
//! point `tet_iso`; host code in `tets/gpu.rs`): the same walk in f32, with each cell's
//! inverse edge matrix made in f64 on the host and the entry faces found in a hierarchy of
//! boxes; it agrees with this one to f32 rounding (at a ray through a cell's edge the two
//! may leave by different, equally right faces). A cell with a non-finite value holds no
//! hit (the walk goes on through it; marching tetrahedra, which treat NaN as outside,
//! close the surface around such a point instead, so there the two differ); a degenerate
//! cell (|det| ≤ 1e-9 of its longest edge cubed, as [`TetGrid::report`] counts them) has
//! no inside: the walk steps across it into the neighbour the ray runs on into. The camera
//! must be outside the grid (rays start at the first boundary face they meet).
//!
//! [`dvr`] renders the same walk as a volume: each cell's segment of the ray is one entry
//! of a pre-integration table.

use crate::kernel::{GSample, ID_SURFACE, Uniforms, pixel_ray};
use crate::{GBuffer, RenderError};
use glam::{DMat3, DVec3, Vec3};
use isokit_field::curvature::Inside;
use isokit_field::tet::is_degenerate;
use isokit_field::{Aabb, Job, TetGrid};
use isokit_kdtree::tree::{BuildParams, KdTree, QueryStats};
use isokit_kdtree::triangle::ray_triangle;
use rayon::prelude::*;
use std::ops::ControlFlow;

use isokit_field::tet::NO_NEIGHBOUR as NONE;

pub mod dvr;
pub(crate) mod gpu;

/// The points of face `k` (the face opposite point `k`) of a cell, seen from outside the
/// cell counter-clockwise for a positively oriented cell.
const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// How normals are made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TetNormals {
    /// The point gradients interpolated at the hit.
    #[default]
    Smooth,
    /// The cell's own gradient (the exact normal of the piecewise-planar surface).
    Flat,
}

/// The cells a ray crosses, in order: neighbours across faces and the boundary faces in a
/// kd-tree (shared by the isosurface caster and volume rendering through the cells).
pub(crate) struct Walk {
    pub(crate) neighbours: Vec<[u32; 4]>,
    /// `(cell, face)` of every boundary face, the kd-tree's primitives.
    pub(crate) boundary: Vec<(u32, u8)>,
    tree: KdTree,
}

/// One cell a ray crosses: the ray's barycentric coordinates in it are `α + β t`, and it
/// runs through the cell from `t_in` to `t_out`, leaving through the face opposite point
/// `exit`.
pub(crate) struct Crossing {
    pub(crate) cell: u32,
    pub(crate) inv: DMat3,
    pub(crate) alpha: [f64; 4],
    pub(crate) beta: [f64; 4],
    pub(crate) t_in: f64,
    pub(crate) t_out: f64,
    exit: usize,
    /// The first cell after the ray entered the grid through a boundary face.
    pub(crate) entered: bool,
}

impl Crossing {
    /// The linear interpolant of the point values `v` at ray parameter `t`.
    pub(crate) fn value(&self, v: &[f64; 4], t: f64) -> f64 {
        (0..4)
            .map(|k| (self.alpha[k] + self.beta[k] * t) * v[k])
            .sum()
    }

    /// The barycentric coordinates at ray parameter `t`.
    pub(crate) fn lambda(&self, t: f64) -> [f64; 4] {
        std::array::from_fn(|k| self.alpha[k] + self.beta[k] * t)
    }
}

impl Walk {
    /// Faces of more than two cells (overlapping cells) are left unconnected, which ends a
    /// ray's walk there rather than guessing.
    pub(crate) fn new(grid: &TetGrid) -> Self {
        let neighbours = grid.faces().neighbours;
        let boundary: Vec<(u32, u8)> = neighbours
            .iter()
            .enumerate()
            .flat_map(|(c, n)| {
                (0..4u8)
                    .filter(move |&k| n[k as usize] == NONE)
                    .map(move |k| (c as u32, k))
            })
            .collect();
        let boxes: Vec<Aabb> = boundary
            .iter()
            .map(|&(c, k)| {
                let t = grid.tets()[c as usize];
                let corners = FACES[k as usize].map(|i| grid.points()[t[i] as usize]);
                Aabb::from_points(&corners)
            })
            .collect();
        let tree = KdTree::build(&boxes, BuildParams::default());
        Self {
            neighbours,
            boundary,
            tree,
        }
    }

    /// Boundary faces (each a face of one cell only).
    pub(crate) fn boundary_faces(&self) -> usize {
        self.boundary.len()
    }

    /// The first boundary face beyond `t_min` through which the ray enters the grid.
    fn entry(&self, grid: &TetGrid, o: DVec3, d: DVec3, t_min: f64) -> Option<(u32, f64)> {
        let mut stats = QueryStats::default();
        self.tree
            .ray_first_in(
                o,
                d,
                t_min,
                f64::MAX,
                |id, best| {
                    let (c, k) = self.boundary[id as usize];
                    let p = corners(grid, c);
                    let [a, b, e] = FACES[k as usize].map(|i| p[i]);
                    // Entering: the ray runs towards the cell's opposite point.
                    let inward = (p[k as usize] - a).dot((b - a).cross(e - a));
                    let towards = d.dot((b - a).cross(e - a));
                    if inward * towards <= 0.0 {
                        return None;
                    }
                    ray_triangle(o, d, a, b, e, best)
                        .map(|h| h.t)
                        .filter(|&t| t > t_min)
                },
                &mut stats,
            )
            .map(|(id, t)| (self.boundary[id as usize].0, t))
    }

    /// Calls `visit` on the cells the ray `o + t d` (`d` of unit length) crosses, front to
    /// back, until it breaks; returns the number of cells visited. Where the walk leaves
    /// the grid it goes on from the next boundary face beyond; a degenerate (flat) cell is
    /// not visited: the walk goes on into the neighbour of it that the ray runs into there,
    /// or, where there is none, from the next boundary face beyond.
    pub(crate) fn walk(
        &self,
        grid: &TetGrid,
        o: DVec3,
        d: DVec3,
        mut visit: impl FnMut(&Crossing) -> ControlFlow<()>,
    ) -> u32 {
        let cells = grid.tets().len() as u64;
        let mut visited = 0u32;
        let mut t_min = 0.0;
        // Each re-entry starts beyond the last exit; the walk is bounded by the cell count
        // (a ray crosses a convex cell once) against rounding loops.
        while let Some((mut c, mut t_in)) = self.entry(grid, o, d, t_min) {
            let mut entered = true;
            loop {
                visited += 1;
                if u64::from(visited) > 4 * cells + 64 {
                    return visited;
                }
                let Some(x) = cross(grid, c, o, d, t_in, entered) else {
                    // A flat cell has no inside to cross: go on into the neighbour of it
                    // that the ray runs on into from here, if any.
                    match self.step_across(grid, c, o, d, t_in) {
                        Some(n) => {
                            c = n;
                            continue;
                        }
                        None => {
                            t_min = t_in;
                            break;
                        }
                    }
                };
                if visit(&x).is_break() {
                    return visited;
                }
                t_min = x.t_out;
                match self.neighbours[c as usize][x.exit] {
                    NONE => break,
                    n => {
                        c = n;
                        t_in = t_min;
                        entered = false;
                    }
                }
            }
        }
        visited
    }
}

impl Walk {
    /// The neighbour of the flat (or unleavable) cell `c` that the ray is inside of just
    /// beyond `t_in`: it enters that cell no later than `t_in` and leaves it after; of
    /// several, the one it stays in longest.
    fn step_across(&self, grid: &TetGrid, c: u32, o: DVec3, d: DVec3, t_in: f64) -> Option<u32> {
        let tol = 1e-9 * (1.0 + t_in.abs());
        self.neighbours[c as usize]
            .iter()
            .filter(|&&n| n != NONE)
            .filter_map(|&n| {
                let x = cross(grid, n, o, d, t_in, false)?;
                let enter = (0..4)
                    .filter(|&k| x.beta[k] > 0.0)
                    .map(|k| -x.alpha[k] / x.beta[k])
                    .fold(f64::NEG_INFINITY, f64::max);
                (enter <= t_in + tol && x.t_out > t_in + tol).then_some((n, x.t_out))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(n, _)| n)
    }
}

fn corners(grid: &TetGrid, c: u32) -> [DVec3; 4] {
    grid.tets()[c as usize].map(|i| grid.points()[i as usize].as_dvec3())
}

/// The ray's way through cell `c` from `t_in`; `None` for a degenerate cell (|det| ≤ 1e-9
/// of its longest edge cubed) or one the ray does not leave.
fn cross(grid: &TetGrid, c: u32, o: DVec3, d: DVec3, t_in: f64, entered: bool) -> Option<Crossing> {
    let p = corners(grid, c);
    let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    if is_degenerate(&p, m.determinant()) {
        return None;
    }
    let inv = m.inverse();
    let (a3, b3) = (inv * (o - p[0]), inv * d);
    let alpha = [1.0 - a3.element_sum(), a3.x, a3.y, a3.z];
    let beta = [-b3.element_sum(), b3.x, b3.y, b3.z];
    // The exit: the first barycentric coordinate to fall to 0.
    let mut exit = None;
    let mut t_out = f64::INFINITY;
    for k in 0..4 {
        if beta[k] < 0.0 {
            let t = -alpha[k] / beta[k];
            if t < t_out {
                (t_out, exit) = (t, Some(k));
            }
        }
    }
    Some(Crossing {
        cell: c,
        inv,
        alpha,
        beta,
        t_in,
        t_out: t_out.max(t_in),
        exit: exit?,
        entered,
    })
}

/// The values of cell `c`'s points times `sign`.
pub(crate) fn cell_values(grid: &TetGrid, c: u32, sign: f32) -> [f64; 4] {
    grid.tets()[c as usize].map(|i| f64::from(sign * grid.values()[i as usize]))
}

/// The gradient of the linear interpolant of `v` in a cell whose `inv` is the inverse of
/// its edge matrix: `Σ v_k ∇λ_k`, with `∇λ_{1..3}` the rows of `inv`.
pub(crate) fn cell_gradient(inv: &DMat3, v: &[f64; 4]) -> DVec3 {
    let rows = inv.transpose();
    [rows.x_axis, rows.y_axis, rows.z_axis]
        .iter()
        .zip(&v[1..])
        .map(|(g, &vk)| *g * (vk - v[0]))
        .sum()
}

/// The point gradients of `idx` interpolated with the barycentric coordinates `lambda`.
pub(crate) fn interpolated_gradient(gradients: &[Vec3], idx: [u32; 4], lambda: &[f64; 4]) -> DVec3 {
    (0..4)
        .map(|k| gradients[idx[k] as usize].as_dvec3() * lambda[k].clamp(0.0, 1.0))
        .sum()
}

/// A tetrahedral grid prepared for ray casting: the walk, the scalar with the inside below
/// the isovalue, the point gradients.
pub struct TetCaster<'g> {
    pub(crate) grid: &'g TetGrid,
    /// 1, or −1 when the inside is above the isovalue: the scalar times this has the
    /// inside below `iso`.
    pub(crate) sign: f32,
    pub(crate) iso: f32,
    pub(crate) walk: Walk,
    pub(crate) gradients: Vec<Vec3>,
    pub(crate) normals: TetNormals,
}

/// A ray's hit on the isosurface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetHit {
    /// Ray parameter (the distance along a unit direction).
    pub t: f64,
    /// World position.
    pub position: DVec3,
    /// Unit outward normal (towards values on the outside).
    pub normal: DVec3,
    /// The cell hit.
    pub cell: u32,
}

impl<'g> TetCaster<'g> {
    /// Prepares `grid` for the isosurface `value = iso`, inside below it (distance fields)
    /// or above it (densities), as `inside` says.
    pub fn new(
        grid: &'g TetGrid,
        iso: f32,
        inside: Inside,
        normals: TetNormals,
    ) -> Result<Self, RenderError> {
        if !iso.is_finite() {
            return Err(RenderError::BadParameter {
                name: "iso",
                value: iso.to_string(),
                why: "the isovalue must be finite",
            });
        }
        let sign = match inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        };
        Ok(Self {
            grid,
            sign,
            iso: sign * iso,
            walk: Walk::new(grid),
            gradients: point_gradients(grid, sign),
            normals,
        })
    }

    /// Boundary faces (each a face of one cell only).
    pub fn boundary_faces(&self) -> usize {
        self.walk.boundary_faces()
    }

    /// The first hit of the ray `o + t d` (`d` of unit length) on the isosurface, and the
    /// number of cells it visited.
    pub fn trace(&self, o: DVec3, d: DVec3) -> (Option<TetHit>, u32) {
        // Inside or not where the ray enters a cell, as the cell before saw it at its exit:
        // a surface lying in a shared face (its points at the isovalue) is found once even
        // where the two cells round the value there to opposite signs.
        let mut inside = None;
        let mut hit = None;
        let visited = self.walk.walk(self.grid, o, d, |x| {
            if x.entered {
                inside = None;
            }
            let (h, inside_out) = self.cross_cell(x, o, d, inside);
            inside = inside_out;
            hit = h;
            if hit.is_some() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        (hit, visited)
    }

    /// The hit in one cell, if any, and whether the ray is inside where it leaves the cell
    /// (`None`: not known, a non-finite value).
    fn cross_cell(
        &self,
        x: &Crossing,
        o: DVec3,
        d: DVec3,
        inside: Option<bool>,
    ) -> (Option<TetHit>, Option<bool>) {
        let (t_in, t_out) = (x.t_in, x.t_out);
        let v = cell_values(self.grid, x.cell, self.sign);
        if v.iter().any(|x| !x.is_finite()) {
            return (None, None);
        }
        let iso = f64::from(self.iso);
        let (f_in, f_out) = (x.value(&v, t_in) - iso, x.value(&v, t_out) - iso);
        let inside_in = inside.unwrap_or(f_in < 0.0);
        if inside_in == (f_out < 0.0) {
            return (None, Some(f_out < 0.0));
        }
        // Where this cell's own sign at the entry disagrees with the state carried in, the
        // value there is within rounding of the isovalue: the hit is the entry.
        let t = if (f_in < 0.0) != inside_in {
            t_in
        } else {
            (t_in + f_in / (f_in - f_out) * (t_out - t_in)).clamp(t_in, t_out)
        };
        let idx = self.grid.tets()[x.cell as usize];
        let smooth = interpolated_gradient(&self.gradients, idx, &x.lambda(t));
        let normal = match self.normals {
            TetNormals::Smooth if smooth.length_squared() > 0.0 => smooth.normalize(),
            _ => cell_gradient(&x.inv, &v).normalize_or_zero(),
        };
        let hit = TetHit {
            t,
            position: o + t * d,
            normal,
            cell: x.cell,
        };
        (Some(hit), Some(f_out < 0.0))
    }

    /// The G-buffer of the camera in `u` ([`crate::camera_uniforms`]), rows in parallel,
    /// reporting progress to `job` (stage `ray casting tetrahedra`, in rows).
    pub fn render(&self, u: &Uniforms, job: &Job) -> Result<GBuffer, RenderError> {
        let (w, h) = (u.width, u.height);
        let counter = job.counter("ray casting tetrahedra", u64::from(h));
        let rows = (0..h)
            .into_par_iter()
            .map(|y| {
                job.check()?;
                let row: Vec<(GSample, u32)> = (0..w)
                    .map(|x| {
                        let (o, d) = pixel_ray(u, x, y);
                        let (o, d) = (o.as_dvec3(), d.as_dvec3().normalize_or_zero());
                        let (hit, visited) = self.trace(o, d);
                        (hit.map_or(GSample::default(), sample), visited)
                    })
                    .collect();
                counter.advance(1);
                Ok(row)
            })
            .collect::<Result<Vec<_>, isokit_field::Cancelled>>()
            .map_err(isokit_field::FieldError::from)?;
        let (pixels, samples) = rows.into_iter().flatten().unzip();
        Ok(GBuffer::new(w, h, pixels, samples))
    }
}

fn sample(h: TetHit) -> GSample {
    let n = h.normal.as_vec3();
    GSample {
        position: h.position.as_vec3(),
        depth: h.t as f32,
        normal: n,
        dir1: n.any_orthonormal_vector(),
        id: ID_SURFACE,
        ..GSample::default()
    }
}

/// At each point the volume-weighted mean of its cells' gradients.
pub(crate) fn point_gradients(grid: &TetGrid, sign: f32) -> Vec<Vec3> {
    let mut sum = vec![DVec3::ZERO; grid.points().len()];
    let mut weight = vec![0.0f64; grid.points().len()];
    for t in grid.tets() {
        let p = t.map(|i| grid.points()[i as usize].as_dvec3());
        let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
        let det = m.determinant();
        let v = t.map(|i| f64::from(sign * grid.values()[i as usize]));
        if det == 0.0 || v.iter().any(|x| !x.is_finite()) {
            continue;
        }
        // Solve Mᵀ g = (v1 − v0, v2 − v0, v3 − v0).
        let g = m.transpose().inverse() * DVec3::new(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
        for &i in t {
            sum[i as usize] += det.abs() * g;
            weight[i as usize] += det.abs();
        }
    }
    sum.into_iter()
        .zip(weight)
        .map(|(g, w)| {
            if w > 0.0 {
                (g / w).as_vec3()
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}
