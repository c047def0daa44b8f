//! Meshing a label volume (one integer region per sample, such as a segmented CT) into the
//! non-manifold surface between its regions: every face separates two regions and carries
//! both, and an edge where three or more regions meet is shared by exactly the faces of the
//! region pairs that meet there (the segmented distance fields of Kraus and Ertl's
//! "segmented distance fields" paper (seed 003, Sec. 3: junctions and other non-manifold
//! features) as a mesh).
//!
//! The method is surface nets on labels (Gibson 1998, "Constrained Elastic Surface Nets";
//! the method of VTK's `vtkSurfaceNets3D`): one vertex in each cell of the lattice (the cube
//! between 8 samples) whose samples hold more than one label, one quadrilateral for each
//! lattice edge whose two samples differ, joining the vertices of the 4 cells around that
//! edge. Labels are whole numbers from 0; samples beyond the lattice count as label 0
//! (outside), so every region other than 0 is closed. Faces are oriented with their normal
//! from the higher label towards the lower (from every region towards 0, outwards).
//!
//! Vertices start at their cells' centres (the surface between voxel-aligned regions is
//! then exact: halfway between the samples) and are then relaxed `smoothing` times towards
//! the mean of their neighbours, each kept inside its own cell (the "constrained" of
//! Gibson's title); a vertex where three regions meet moves only along the other such
//! vertices (so junction curves stay junction curves and are smoothed along themselves),
//! and one where four or more meet stays put. Each quadrilateral is cut into two triangles
//! along its shorter diagonal after smoothing.

use glam::Vec3;
use isokit_field::{FieldError, Grid, Job, TriMesh};
use std::collections::HashMap;

/// Knobs of [`label_surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelOptions {
    /// Relaxation passes (0: vertices at the cells' centres, a voxel-aligned staircase), at
    /// most [`MAX_SMOOTHING`].
    pub smoothing: usize,
    /// How far each pass moves a vertex towards its neighbours' mean (0 to 1).
    pub relaxation: f32,
}

/// The most relaxation passes [`LabelOptions::smoothing`] may ask for.
pub const MAX_SMOOTHING: usize = 10_000;

impl Default for LabelOptions {
    fn default() -> Self {
        Self {
            smoothing: 16,
            relaxation: 0.5,
        }
    }
}

/// The surface between the regions of a label volume: triangles and, for each, the two
/// regions it separates (`regions[t] = [a, b]`, `a < b`; the triangle's normal points
/// from `b` towards `a`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LabelMesh {
    /// The triangles.
    pub mesh: TriMesh,
    /// The two regions of each triangle, the lower first.
    pub regions: Vec<[i32; 2]>,
}

impl LabelMesh {
    /// The distinct region pairs with their triangle counts and areas, sorted by pair.
    pub fn pairs(&self) -> Vec<([i32; 2], usize, f64)> {
        let mut by: std::collections::BTreeMap<[i32; 2], (usize, f64)> = Default::default();
        for (t, r) in self.mesh.triangles.iter().zip(&self.regions) {
            let [a, b, c] = t.map(|i| self.mesh.positions[i as usize].as_dvec3());
            let e = by.entry(*r).or_default();
            e.0 += 1;
            e.1 += 0.5 * (b - a).cross(c - a).length();
        }
        by.into_iter().map(|(k, (n, a))| (k, n, a)).collect()
    }
}

/// The labels as integers: each sample must be a whole number from 0 to 2^24 − 1 (f32
/// holds every integer below 2^24 exactly; a larger one may be a neighbour rounded).
fn labels(data: &[f32]) -> Result<Vec<i32>, FieldError> {
    data.iter()
        .map(|&v| {
            if v.is_finite() && v.fract() == 0.0 && (0.0..16_777_216.0).contains(&v) {
                Ok(v as i32)
            } else {
                Err(FieldError::BadParameter {
                    name: "label",
                    value: v.to_string(),
                    why: "labels must be whole numbers from 0 to 2^24 - 1 (one region per sample, 0 outside)",
                })
            }
        })
        .collect()
}

/// What is held per quadrilateral, counted against the memory budget as they are made: the
/// quadrilateral (24 bytes), its two triangles and regions (40), and for about one vertex per
/// quadrilateral its cell, crossing sum, position, links and the smoothing's copy (~130),
/// with room for the vectors' growth.
const QUAD_BYTES: u128 = 320;

/// Meshes the regions of the label volume `grid` (see the [module](self) docs), reporting
/// progress to `job` (stage `label surface`, in slices).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, Job};
/// use isokit_levelset::labels::{LabelOptions, label_surface};
///
/// // Two regions side by side: 1 for x < 0, 2 for x > 0, in a 4 x 4 x 4 volume.
/// let mut g = Grid::new([4, 4, 4], Vec3::ZERO, 1.0).unwrap();
/// for k in 0..4 { for j in 0..4 { for i in 0..4 { g.set(i, j, k, if i < 2 { 1.0 } else { 2.0 }); } } }
/// let opts = LabelOptions { smoothing: 0, ..LabelOptions::default() };
/// let m = label_surface(&g, &opts, &Job::new()).unwrap();
/// // The wall between them: 4 x 4 samples apart, area 4 x 4 spacings.
/// let wall = m.pairs().into_iter().find(|p| p.0 == [1, 2]).unwrap();
/// assert_eq!(wall.1, 2 * 16);
/// assert!((wall.2 - 16.0).abs() < 1e-9);
/// ```
pub fn label_surface(grid: &Grid, opts: &LabelOptions, job: &Job) -> Result<LabelMesh, FieldError> {
    let h = grid.spacing();
    label_surface_spaced(
        grid.dims(),
        grid.origin(),
        Vec3::splat(h),
        grid.data(),
        opts,
        job,
    )
}

/// [`label_surface`] of samples `data` (x fastest) on a lattice of `dims` samples from
/// `origin`, `spacing` apart along each axis (which may differ, as a CT's slices often do).
pub fn label_surface_spaced(
    dims: [usize; 3],
    origin: Vec3,
    spacing: Vec3,
    data: &[f32],
    opts: &LabelOptions,
    job: &Job,
) -> Result<LabelMesh, FieldError> {
    if !(0.0..=1.0).contains(&opts.relaxation) {
        return Err(FieldError::BadParameter {
            name: "relaxation",
            value: opts.relaxation.to_string(),
            why: "must be from 0 to 1",
        });
    }
    if opts.smoothing > MAX_SMOOTHING {
        return Err(FieldError::BadParameter {
            name: "smoothing",
            value: opts.smoothing.to_string(),
            why: "must be at most 10000 relaxation passes (each vertex stays in its cell: the surface stops moving long before)",
        });
    }
    if !(spacing.is_finite() && spacing.min_element() > 0.0 && origin.is_finite()) {
        return Err(FieldError::BadParameter {
            name: "lattice",
            value: format!("origin {origin}, spacing {spacing}"),
            why: "needs a finite origin and finite positive spacings",
        });
    }
    let count = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    if count != Some(data.len()) {
        return Err(FieldError::DataLength {
            dims,
            want: count.unwrap_or(usize::MAX),
            got: data.len(),
        });
    }
    // The integer copy of the labels.
    isokit_field::memory::check(
        "label surface",
        data.len() as u128 * 4,
        "use a smaller volume or raise the memory budget",
    )?;
    let lab = labels(data)?;
    let n = dims.map(|d| d as i64);
    let at = |s: [i64; 3]| -> i32 {
        if (0..3).all(|a| (0..n[a]).contains(&s[a])) {
            lab[(s[0] + n[0] * (s[1] + n[1] * s[2])) as usize]
        } else {
            0
        }
    };
    let nets = surface_nets(n, true, "label surface", job, |s, t| {
        let (here, there) = (at(s), at(t));
        (here != there).then_some((here, there, 0.5))
    })?;
    let (cells, quads) = (nets.cells, nets.quads);
    let centre =
        |c: [i64; 3]| origin + (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + 0.5) * spacing;
    let mut positions: Vec<Vec3> = cells.iter().map(|&c| centre(c)).collect();
    if opts.smoothing > 0 {
        smooth(
            &mut positions,
            &cells,
            &quads,
            &at,
            centre,
            spacing,
            opts,
            job,
        )?;
    }
    Ok(triangulate(positions, &quads))
}

/// What [`surface_nets`] makes: the cells holding a vertex (by their lowest sample), the
/// quadrilaterals with their region pairs, and per cell the sum and count of the crossing
/// points on its edges.
pub(crate) struct Nets {
    pub(crate) cells: Vec<[i64; 3]>,
    pub(crate) quads: Vec<([u32; 4], [i32; 2])>,
    pub(crate) crossings: Vec<(glam::DVec3, u32)>,
}

/// Surface nets over a lattice of `n` samples: for each edge from sample `s` to `t = s + e_a`
/// that `edge(s, t)` says the surface crosses (`Some((region at s, region at t, where
/// along the edge from s, 0 to 1))`), a quadrilateral through the vertices of the 4 cells
/// around it, oriented with its normal from the higher region towards the lower. With
/// `pad` the edges reach one sample beyond the lattice on every side (where `edge` decides
/// what lies there); without it only edges between samples of the lattice count. Cells are
/// those from −1 to n − 1 along each axis; the crossing points are in lattice units (sample
/// `s` at `s`).
pub(crate) fn surface_nets(
    n: [i64; 3],
    pad: bool,
    stage: &'static str,
    job: &Job,
    mut edge: impl FnMut([i64; 3], [i64; 3]) -> Option<(i32, i32, f32)>,
) -> Result<Nets, FieldError> {
    // Cells are keyed by their lowest sample, −1 to n − 1 along each axis.
    let key = |c: [i64; 3]| ((c[2] + 1) * (n[1] + 1) + (c[1] + 1)) * (n[0] + 1) + (c[0] + 1);
    let cell_count = (n[0] + 1) as u128 * (n[1] + 1) as u128 * (n[2] + 1) as u128;
    let mut vertex = VertexMap::new(cell_count);
    let mut cells: Vec<[i64; 3]> = Vec::new();
    let mut crossings: Vec<(glam::DVec3, u32)> = Vec::new();
    let mut quads: Vec<([u32; 4], [i32; 2])> = Vec::new();
    let first = if pad { -1 } else { 0 };
    let counter = job.counter(stage, (n[2] - first) as u64);
    for z in first..n[2] {
        job.check()?;
        for y in first..n[1] {
            for x in first..n[0] {
                let s = [x, y, z];
                for a in 0..3 {
                    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                    // The edge from s to s + e_a: its ends beyond the lattice only with
                    // `pad`, and never both (those meet no sample).
                    if s[b] < 0 || s[c] < 0 || (!pad && (s[a] < 0 || s[a] + 1 >= n[a])) {
                        continue;
                    }
                    let mut t = s;
                    t[a] += 1;
                    let Some((here, there, along)) = edge(s, t) else {
                        continue;
                    };
                    if quads.len().is_multiple_of(4096) {
                        isokit_field::memory::check(
                            stage,
                            (quads.len() as u128 + 4096) * QUAD_BYTES,
                            "use a smaller volume or raise the memory budget (--max-memory, ISOKIT_MAX_MEMORY)",
                        )?;
                    }
                    let mut point = glam::DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
                    point[a] += f64::from(along);
                    // The 4 cells around the edge, counter-clockwise seen from +e_a.
                    let mut ring = [[0i64; 3]; 4];
                    for (k, (db, dc)) in [(-1, -1), (0, -1), (0, 0), (-1, 0)].iter().enumerate() {
                        let mut cell = s;
                        cell[b] += db;
                        cell[c] += dc;
                        ring[k] = cell;
                    }
                    let mut q = ring.map(|cell| {
                        let v = vertex.get_or_insert(key(cell), &mut cells, cell);
                        if v as usize == crossings.len() {
                            crossings.push((glam::DVec3::ZERO, 0));
                        }
                        let e = &mut crossings[v as usize];
                        e.0 += point;
                        e.1 += 1;
                        v
                    });
                    // Normal from the higher region to the lower: +e_a when s holds the
                    // higher.
                    if here < there {
                        q.reverse();
                    }
                    quads.push((q, [here.min(there), here.max(there)]));
                }
            }
        }
        counter.advance(1);
    }
    Ok(Nets {
        cells,
        quads,
        crossings,
    })
}

/// Each quadrilateral as two triangles along its shorter diagonal, with its region pair.
pub(crate) fn triangulate(positions: Vec<Vec3>, quads: &[([u32; 4], [i32; 2])]) -> LabelMesh {
    let mut triangles = Vec::with_capacity(2 * quads.len());
    let mut regions = Vec::with_capacity(2 * quads.len());
    for (q, r) in quads {
        let p = q.map(|i| positions[i as usize]);
        let tris = if p[0].distance_squared(p[2]) <= p[1].distance_squared(p[3]) {
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        } else {
            [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
        };
        triangles.extend(tris);
        regions.extend([*r, *r]);
    }
    LabelMesh {
        mesh: TriMesh::new(positions, triangles),
        regions,
    }
}

/// The vertex of each cell that has one: a dense index over all cells where that fits a
/// quarter of the memory budget, else a hash map over the surface cells only.
enum VertexMap {
    Dense(Vec<u32>),
    Sparse(HashMap<i64, u32>),
}

impl VertexMap {
    fn new(cells: u128) -> Self {
        if cells * 4 <= u128::from(isokit_field::memory::budget() / 4) {
            VertexMap::Dense(vec![u32::MAX; cells as usize])
        } else {
            VertexMap::Sparse(HashMap::new())
        }
    }

    fn get_or_insert(&mut self, key: i64, cells: &mut Vec<[i64; 3]>, cell: [i64; 3]) -> u32 {
        let mut add = || {
            cells.push(cell);
            (cells.len() - 1) as u32
        };
        match self {
            VertexMap::Dense(v) => {
                let slot = &mut v[key as usize];
                if *slot == u32::MAX {
                    *slot = add();
                }
                *slot
            }
            VertexMap::Sparse(m) => *m.entry(key).or_insert_with(add),
        }
    }
}

/// The relaxation passes of [`label_surface`]: each vertex towards the mean of its
/// neighbours along quadrilateral edges, those of a junction (3 labels in the cell) only
/// along other junction vertices, those of 4 or more labels fixed; kept in their cells.
#[allow(clippy::too_many_arguments)]
fn smooth(
    positions: &mut [Vec3],
    cells: &[[i64; 3]],
    quads: &[([u32; 4], [i32; 2])],
    at: &impl Fn([i64; 3]) -> i32,
    centre: impl Fn([i64; 3]) -> Vec3,
    spacing: Vec3,
    opts: &LabelOptions,
    job: &Job,
) -> Result<(), FieldError> {
    // Distinct labels among each cell's 8 samples (capped at 4).
    let kind: Vec<u8> = cells
        .iter()
        .map(|&c| {
            let mut seen: Vec<i32> = Vec::with_capacity(8);
            for d in 0..8 {
                let s = [c[0] + (d & 1), c[1] + ((d >> 1) & 1), c[2] + (d >> 2)];
                let l = at(s);
                if !seen.contains(&l) {
                    seen.push(l);
                }
            }
            seen.len().min(4) as u8
        })
        .collect();
    let mut links: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    for (q, _) in quads {
        for k in 0..4 {
            let (u, v) = (q[k], q[(k + 1) % 4]);
            for (from, to) in [(u, v), (v, u)] {
                // A vertex follows neighbours of its own kind or higher.
                if kind[to as usize] >= kind[from as usize] && !links[from as usize].contains(&to) {
                    links[from as usize].push(to);
                }
            }
        }
    }
    let half = 0.5 * spacing;
    for _ in 0..opts.smoothing {
        job.check()?;
        let old = positions.to_vec();
        for (i, p) in positions.iter_mut().enumerate() {
            if kind[i] >= 4 || links[i].is_empty() {
                continue;
            }
            let mean =
                links[i].iter().map(|&j| old[j as usize]).sum::<Vec3>() / links[i].len() as f32;
            let c = centre(cells[i]);
            *p = (old[i] + opts.relaxation * (mean - old[i])).clamp(c - half, c + half);
        }
    }
    Ok(())
}
