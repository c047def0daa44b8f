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
//! Only the CPU twin exists here. A cell with a non-finite value holds no hit (the walk
//! goes on through it; marching tetrahedra, which treat NaN as outside, close the surface
//! around such a point instead, so there the two differ); a degenerate cell (|det| ≤ 1e-9
//! of its longest edge cubed, as [`TetGrid::report`] counts them) ends the walk there, and
//! the ray goes on from the next boundary face beyond it. The camera must be outside the
//! grid (rays start at the first boundary face they meet).

use crate::kernel::{GSample, ID_SURFACE, Uniforms, pixel_ray};
use crate::{GBuffer, RenderError};
use glam::{DMat3, DVec3, Vec3};
use isokit_field::curvature::Inside;
use isokit_field::tet::is_degenerate;
use isokit_field::{Aabb, Job, TetGrid};
use isokit_kdtree::tree::{BuildParams, KdTree, QueryStats};
use isokit_kdtree::triangle::ray_triangle;
use rayon::prelude::*;

use isokit_field::tet::NO_NEIGHBOUR as NONE;

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

/// A tetrahedral grid prepared for ray casting: neighbours across faces, the boundary faces
/// in a kd-tree, the scalar with the inside below the isovalue, the point gradients.
pub struct TetCaster<'g> {
    grid: &'g TetGrid,
    /// 1, or −1 when the inside is above the isovalue: the scalar times this has the
    /// inside below `iso`.
    sign: f32,
    iso: f32,
    neighbours: Vec<[u32; 4]>,
    /// `(cell, face)` of every boundary face, the kd-tree's primitives.
    boundary: Vec<(u32, u8)>,
    tree: KdTree,
    gradients: Vec<Vec3>,
    normals: TetNormals,
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
        // Faces of more than two cells (overlapping cells) are left unconnected, which ends
        // a ray's walk there rather than guessing.
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
        let gradients = point_gradients(grid, sign);
        Ok(Self {
            grid,
            sign,
            iso: sign * iso,
            neighbours,
            boundary,
            tree,
            gradients,
            normals,
        })
    }

    /// Boundary faces (each a face of one cell only).
    pub fn boundary_faces(&self) -> usize {
        self.boundary.len()
    }

    fn corners(&self, c: u32) -> [DVec3; 4] {
        self.grid.tets()[c as usize].map(|i| self.grid.points()[i as usize].as_dvec3())
    }

    /// The first boundary face beyond `t_min` through which the ray enters the grid.
    fn entry(&self, o: DVec3, d: DVec3, t_min: f64) -> Option<(u32, f64)> {
        let mut stats = QueryStats::default();
        self.tree
            .ray_first(
                o,
                d,
                f64::MAX,
                |id, best| {
                    let (c, k) = self.boundary[id as usize];
                    let p = self.corners(c);
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

    /// The first hit of the ray `o + t d` (`d` of unit length) on the isosurface, and the
    /// number of cells it visited.
    pub fn trace(&self, o: DVec3, d: DVec3) -> (Option<TetHit>, u32) {
        let cells = self.grid.tets().len() as u64;
        let mut visited = 0u32;
        let mut t_min = 0.0;
        // Each re-entry starts beyond the last exit; the walk is bounded by the cell count
        // (a ray crosses a convex cell once) against rounding loops.
        while let Some((mut c, mut t_in)) = self.entry(o, d, t_min) {
            // Inside or not where the ray enters the cell, as the cell before saw it at its
            // exit: a surface lying in a shared face (its points at the isovalue) is found
            // once even where the two cells round the value there to opposite signs.
            let mut inside = None;
            loop {
                visited += 1;
                if u64::from(visited) > 4 * cells + 64 {
                    return (None, visited);
                }
                let step = self.cross_cell(c, o, d, t_in, inside);
                inside = step.inside_out;
                if let Some(hit) = step.hit {
                    return (Some(hit), visited);
                }
                t_min = step.t_out.max(t_in);
                match step.exit.map(|k| self.neighbours[c as usize][k]) {
                    Some(n) if n != NONE => {
                        c = n;
                        t_in = t_min;
                    }
                    _ => break,
                }
            }
        }
        (None, visited)
    }

    fn cross_cell(&self, c: u32, o: DVec3, d: DVec3, t_in: f64, inside: Option<bool>) -> Step {
        let p = self.corners(c);
        let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
        let det = m.determinant();
        if is_degenerate(&p, det) {
            return Step::NONE;
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
        let Some(_) = exit else {
            return Step::NONE;
        };
        let t_out = t_out.max(t_in);
        let idx = self.grid.tets()[c as usize];
        let v = idx.map(|i| f64::from(self.sign * self.grid.values()[i as usize]));
        if v.iter().any(|x| !x.is_finite()) {
            return Step {
                hit: None,
                t_out,
                exit,
                inside_out: None,
            };
        }
        let iso = f64::from(self.iso);
        let value = |t: f64| (0..4).map(|k| (alpha[k] + beta[k] * t) * v[k]).sum::<f64>() - iso;
        let (f_in, f_out) = (value(t_in), value(t_out));
        let inside_in = inside.unwrap_or(f_in < 0.0);
        if inside_in == (f_out < 0.0) {
            return Step {
                hit: None,
                t_out,
                exit,
                inside_out: Some(f_out < 0.0),
            };
        }
        // Where this cell's own sign at the entry disagrees with the state carried in, the
        // value there is within rounding of the isovalue: the hit is the entry.
        let t = if (f_in < 0.0) != inside_in {
            t_in
        } else {
            (t_in + f_in / (f_in - f_out) * (t_out - t_in)).clamp(t_in, t_out)
        };
        let lambda: [f64; 4] = std::array::from_fn(|k| alpha[k] + beta[k] * t);
        // The cell's gradient: Σ v_k ∇λ_k, with ∇λ_{1..3} the rows of M⁻¹.
        let rows = inv.transpose();
        let g1 = [rows.x_axis, rows.y_axis, rows.z_axis];
        let flat = g1
            .iter()
            .zip(&v[1..])
            .map(|(g, &vk)| *g * (vk - v[0]))
            .sum::<DVec3>();
        let smooth = (0..4)
            .map(|k| self.gradients[idx[k] as usize].as_dvec3() * lambda[k].clamp(0.0, 1.0))
            .sum::<DVec3>();
        let normal = match self.normals {
            TetNormals::Smooth if smooth.length_squared() > 0.0 => smooth.normalize(),
            _ => flat.normalize_or_zero(),
        };
        Step {
            hit: Some(TetHit {
                t,
                position: o + t * d,
                normal,
                cell: c,
            }),
            t_out,
            exit,
            inside_out: Some(f_out < 0.0),
        }
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

/// What crossing one cell gave.
struct Step {
    hit: Option<TetHit>,
    /// Where the ray leaves the cell.
    t_out: f64,
    /// Through the face opposite this point (`None`: it cannot be told).
    exit: Option<usize>,
    /// Whether the ray is inside where it leaves (`None`: not known, a non-finite value).
    inside_out: Option<bool>,
}

impl Step {
    const NONE: Step = Step {
        hit: None,
        t_out: f64::NEG_INFINITY,
        exit: None,
        inside_out: None,
    };
}

/// At each point the volume-weighted mean of its cells' gradients.
fn point_gradients(grid: &TetGrid, sign: f32) -> Vec<Vec3> {
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
