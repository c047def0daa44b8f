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
//! edge. Samples beyond the lattice count as label 0 (outside), so every region other than 0
//! is closed. Faces are oriented with their normal from the higher label towards the lower
//! (from every region towards 0, outwards).
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
    /// Relaxation passes (0: vertices at the cells' centres, a voxel-aligned staircase).
    pub smoothing: usize,
    /// How far each pass moves a vertex towards its neighbours' mean (0 to 1).
    pub relaxation: f32,
}

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

/// The labels of `grid` as integers: each finite sample must be a whole number within
/// ±2^24 (where f32 holds every integer exactly).
fn labels(grid: &Grid) -> Result<Vec<i32>, FieldError> {
    grid.data()
        .iter()
        .map(|&v| {
            if v.is_finite() && v.fract() == 0.0 && v.abs() <= 16_777_216.0 {
                Ok(v as i32)
            } else {
                Err(FieldError::BadParameter {
                    name: "label",
                    value: v.to_string(),
                    why: "labels must be whole numbers within ±2^24 (one region per sample)",
                })
            }
        })
        .collect()
}

/// Bytes per quadrilateral made (two triangles, their regions, the vertex map's share).
const QUAD_BYTES: u128 = 2 * (12 + 8) + 4 * 4;

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
    if !(0.0..=1.0).contains(&opts.relaxation) {
        return Err(FieldError::BadParameter {
            name: "relaxation",
            value: opts.relaxation.to_string(),
            why: "must be from 0 to 1",
        });
    }
    let lab = labels(grid)?;
    let n = grid.dims().map(|d| d as i64);
    let at = |s: [i64; 3]| -> i32 {
        if (0..3).all(|a| (0..n[a]).contains(&s[a])) {
            lab[(s[0] + n[0] * (s[1] + n[1] * s[2])) as usize]
        } else {
            0
        }
    };
    // Cells are keyed by their lowest sample, −1 to n − 1 along each axis.
    let key = |c: [i64; 3]| ((c[2] + 1) * (n[1] + 1) + (c[1] + 1)) * (n[0] + 1) + (c[0] + 1);
    let cell_count = (n[0] + 1) as u128 * (n[1] + 1) as u128 * (n[2] + 1) as u128;
    let mut vertex = VertexMap::new(cell_count);
    let mut cells: Vec<[i64; 3]> = Vec::new();
    let mut quads: Vec<([u32; 4], [i32; 2])> = Vec::new();
    let counter = job.counter("label surface", (n[2] + 1) as u64);
    for z in -1..n[2] {
        job.check()?;
        for y in -1..n[1] {
            for x in -1..n[0] {
                let s = [x, y, z];
                let here = at(s);
                for a in 0..3 {
                    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                    // The edge from s to s + e_a; both ends beyond the lattice are 0.
                    if s[b] < 0 || s[c] < 0 {
                        continue;
                    }
                    let mut t = s;
                    t[a] += 1;
                    let there = at(t);
                    if here == there {
                        continue;
                    }
                    if quads.len().is_multiple_of(4096) {
                        isokit_field::memory::check(
                            "label surface",
                            (quads.len() as u128 + 4096) * QUAD_BYTES,
                            "use a smaller volume or raise ISOKIT_MEMORY",
                        )?;
                    }
                    // The 4 cells around the edge, counter-clockwise seen from +e_a.
                    let mut ring = [[0i64; 3]; 4];
                    for (k, (db, dc)) in [(-1, -1), (0, -1), (0, 0), (-1, 0)].iter().enumerate() {
                        let mut cell = s;
                        cell[b] += db;
                        cell[c] += dc;
                        ring[k] = cell;
                    }
                    let mut q = ring.map(|cell| vertex.get_or_insert(key(cell), &mut cells, cell));
                    // Normal from the higher label to the lower: +e_a when s holds the
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
    let (origin, h) = (grid.origin(), grid.spacing());
    let centre =
        |c: [i64; 3]| origin + (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + 0.5) * h;
    let mut positions: Vec<Vec3> = cells.iter().map(|&c| centre(c)).collect();
    if opts.smoothing > 0 {
        smooth(&mut positions, &cells, &quads, &at, centre, h, opts, job)?;
    }
    let mut triangles = Vec::with_capacity(2 * quads.len());
    let mut regions = Vec::with_capacity(2 * quads.len());
    for (q, r) in &quads {
        let p = q.map(|i| positions[i as usize]);
        let tris = if p[0].distance_squared(p[2]) <= p[1].distance_squared(p[3]) {
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        } else {
            [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
        };
        triangles.extend(tris);
        regions.extend([*r, *r]);
    }
    Ok(LabelMesh {
        mesh: TriMesh::new(positions, triangles),
        regions,
    })
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
    h: f32,
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
    let half = Vec3::splat(0.5 * h);
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
