//! Unstructured tetrahedral grids with one scalar per point, the data of Sigg 2006's
//! companion on volume visualization (004 Sec. 4: isosurfaces and volume rendering of
//! "unstructured tetrahedral grids", where the scalar varies linearly in each cell): plain
//! data, its checks ([`TetGrid::report`]: inverted and degenerate cells, boundary and
//! over-shared faces) and grids built from a regular grid's cubes
//! ([`TetGrid::from_grid`]: 5 or 6 tetrahedra per cube). Reading `.vtk` and `.vtu` files is
//! `isokit-io`'s job; meshing is `isokit-levelset`'s.
//!
//! Orientation follows VTK's `VTK_TETRA`: points 0, 1, 2 seen from point 3 run
//! counter-clockwise, so `det(p1 − p0, p2 − p0, p3 − p0) > 0`; a cell with a negative
//! determinant is *inverted* (counted, not refused: algorithms orient by the determinant).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::{Aabb, FieldError, Grid, finite_min_max};

/// Most cells a [`TetGrid`] holds (a face is keyed by `4 · cell + face` in 32 bits).
pub const MAX_CELLS: usize = 1 << 30;

/// A tetrahedral grid: points, cells as four point indices, one scalar per point.
///
/// Built by [`TetGrid::new`], which checks the indices and lengths; the points are finite.
/// Values may be anything, NaN included (a NaN point is outside every isosurface).
#[derive(Clone, Debug, PartialEq)]
pub struct TetGrid {
    points: Vec<Vec3>,
    tets: Vec<[u32; 4]>,
    values: Vec<f32>,
    array: String,
}

/// How [`TetGrid::from_grid`] cuts each cube of a regular grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TetSplit {
    /// Five tetrahedra (a central one and four corners), alternating with the parity of the
    /// cube so that neighbouring cubes cut their shared face along the same diagonal.
    Five,
    /// Six tetrahedra around the cube's main diagonal (Kuhn's triangulation): every cube cut
    /// alike, faces consistent by construction.
    Six,
}

/// What [`TetGrid::report`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetReport {
    /// Cells.
    pub cells: usize,
    /// Points.
    pub points: usize,
    /// Points that no cell uses.
    pub unused_points: usize,
    /// The smallest and largest finite value (`None` when no value is finite).
    pub range: Option<(f32, f32)>,
    /// Points whose value is NaN or infinite.
    pub non_finite_values: usize,
    /// Cells with a negative determinant (against VTK's orientation).
    pub inverted: usize,
    /// Cells whose volume is zero within rounding (a repeated point, four points in a
    /// plane): `|det| ≤ 1e-9 · (longest edge)³`.
    pub degenerate: usize,
    /// Faces used by one cell: the grid's boundary.
    pub boundary_faces: usize,
    /// Faces used by more than two cells (the cells overlap).
    pub over_shared_faces: usize,
}

impl TetReport {
    /// True when no cell is inverted or degenerate and no face is shared by more than two
    /// cells.
    pub fn is_valid(&self) -> bool {
        self.inverted == 0 && self.degenerate == 0 && self.over_shared_faces == 0
    }
}

impl TetGrid {
    /// A grid from its parts, checked: `values` holds one value per point, every index names
    /// a point, every point is finite, and there is at least one cell. `array` names the
    /// scalar (as the file called it).
    pub fn new(
        points: Vec<Vec3>,
        tets: Vec<[u32; 4]>,
        values: Vec<f32>,
        array: impl Into<String>,
    ) -> Result<Self, FieldError> {
        let bad = |value: String, why: &'static str| FieldError::BadParameter {
            name: "tetrahedral grid",
            value,
            why,
        };
        if values.len() != points.len() {
            return Err(bad(
                format!("{} values for {} points", values.len(), points.len()),
                "one value per point is needed",
            ));
        }
        if tets.is_empty() {
            return Err(bad("0 cells".into(), "at least one cell is needed"));
        }
        if tets.len() > MAX_CELLS {
            return Err(bad(
                format!("{} cells", tets.len()),
                "at most 2^30 cells are supported",
            ));
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(bad(
                format!("point {i} at {}", points[i]),
                "points must be finite",
            ));
        }
        let n = points.len() as u64;
        if let Some((c, t)) = tets
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| u64::from(i) >= n))
        {
            return Err(bad(
                format!("cell {c} with points {t:?} of {n}"),
                "every index must name a point",
            ));
        }
        Ok(Self {
            points,
            tets,
            values,
            array: array.into(),
        })
    }

    /// The tetrahedra of a regular grid's cubes with its samples at their corners (for tests
    /// and comparisons: the linear interpolation in each tetrahedron agrees with the grid's
    /// trilinear one at the samples, not between them).
    pub fn from_grid(grid: &Grid, split: TetSplit) -> Result<Self, FieldError> {
        let [nx, ny, nz] = grid.dims();
        if nx < 2 || ny < 2 || nz < 2 {
            return Err(FieldError::BadParameter {
                name: "grid dims",
                value: format!("{:?}", grid.dims()),
                why: "a tetrahedral grid needs at least 2 samples per axis",
            });
        }
        let cubes = (nx - 1) * (ny - 1) * (nz - 1);
        let per = match split {
            TetSplit::Five => 5,
            TetSplit::Six => 6,
        };
        if grid.len() > u32::MAX as usize || cubes.saturating_mul(per) > u32::MAX as usize {
            return Err(FieldError::BadParameter {
                name: "grid dims",
                value: format!("{:?}", grid.dims()),
                why: "too many points or cells for 32-bit indices",
            });
        }
        let (o, h) = (grid.origin(), grid.spacing());
        let points: Vec<Vec3> = (0..grid.len())
            .map(|i| {
                let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
                o + h * Vec3::new(x as f32, y as f32, z as f32)
            })
            .collect();
        // Corner c of a cube is (c & 1, c >> 1 & 1, c >> 2 & 1).
        const SIX: [[usize; 4]; 6] = [
            [0, 1, 3, 7],
            [0, 1, 5, 7],
            [0, 2, 3, 7],
            [0, 2, 6, 7],
            [0, 4, 5, 7],
            [0, 4, 6, 7],
        ];
        const FIVE_EVEN: [[usize; 4]; 5] = [
            [1, 2, 4, 7],
            [0, 1, 2, 4],
            [3, 1, 2, 7],
            [5, 1, 4, 7],
            [6, 2, 4, 7],
        ];
        const FIVE_ODD: [[usize; 4]; 5] = [
            [0, 3, 5, 6],
            [1, 0, 3, 5],
            [2, 0, 3, 6],
            [4, 0, 5, 6],
            [7, 3, 5, 6],
        ];
        let mut tets = Vec::with_capacity(cubes * per);
        for z in 0..nz - 1 {
            for y in 0..ny - 1 {
                for x in 0..nx - 1 {
                    let corner = |c: usize| {
                        grid.index(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2 & 1)) as u32
                    };
                    let table: &[[usize; 4]] = match split {
                        TetSplit::Six => &SIX,
                        TetSplit::Five if (x + y + z) % 2 == 0 => &FIVE_EVEN,
                        TetSplit::Five => &FIVE_ODD,
                    };
                    tets.extend(table.iter().map(|t| positive(t.map(corner), &points)));
                }
            }
        }
        Self::new(points, tets, grid.data().to_vec(), "grid")
    }

    /// The points.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }
    /// The cells.
    pub fn tets(&self) -> &[[u32; 4]] {
        &self.tets
    }
    /// One value per point.
    pub fn values(&self) -> &[f32] {
        &self.values
    }
    /// The values, to change in place (they carry no invariant).
    pub fn values_mut(&mut self) -> &mut [f32] {
        &mut self.values
    }
    /// The scalar's name.
    pub fn array(&self) -> &str {
        &self.array
    }
    /// The box around the points.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.points)
    }

    /// Six times the signed volume of cell `c`, in f64 (positive in VTK's orientation).
    pub fn det(&self, c: usize) -> f64 {
        det(&self.points, &self.tets[c])
    }

    /// Counts what a user should know before trusting the grid (see [`TetReport`]).
    pub fn report(&self) -> TetReport {
        let mut r = self.report_cells();
        let faces = self.faces();
        r.boundary_faces = faces.boundary;
        r.over_shared_faces = faces.over_shared;
        r
    }

    /// [`TetGrid::report`] without the face topology (`boundary_faces` and
    /// `over_shared_faces` are 0): the cells' orientation and size, the points used and the
    /// values, in one parallel pass over the cells, without sorting the faces.
    pub fn report_cells(&self) -> TetReport {
        let (inverted, degenerate) = self
            .tets
            .par_iter()
            .map(|t| {
                let p = t.map(|i| self.points[i as usize].as_dvec3());
                let d = orientation(&p);
                if is_degenerate(&p, d) {
                    (0, 1)
                } else {
                    (usize::from(d < 0.0), 0)
                }
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        let mut used = vec![false; self.points.len()];
        for t in &self.tets {
            t.iter().for_each(|&i| used[i as usize] = true);
        }
        let mut r = TetReport {
            cells: self.tets.len(),
            points: self.points.len(),
            inverted,
            degenerate,
            unused_points: used.iter().filter(|u| !**u).count(),
            ..TetReport::default()
        };
        r.range = finite_min_max(&self.values);
        r.non_finite_values = self.values.iter().filter(|v| !v.is_finite()).count();
        r
    }

    /// The cells across each cell's faces (face `k` is the one opposite point `k`), as
    /// [`NO_NEIGHBOUR`] on the boundary and where more than two cells share a face. Holds
    /// 16 bytes per face while it sorts them (a packed key: the face's sorted points, the
    /// cell and the face), in parallel.
    pub fn faces(&self) -> TetFaces {
        let mut keys: Vec<u128> = self
            .tets
            .par_iter()
            .enumerate()
            .flat_map_iter(|(c, t)| {
                (0..4u32).map(move |k| {
                    let mut f = [0u32; 3];
                    let mut n = 0;
                    for (i, &p) in t.iter().enumerate() {
                        if i != k as usize {
                            f[n] = p;
                            n += 1;
                        }
                    }
                    f.sort_unstable();
                    let face =
                        (u128::from(f[0]) << 64) | (u128::from(f[1]) << 32) | u128::from(f[2]);
                    (face << 32) | u128::from(4 * c as u32 + k)
                })
            })
            .collect();
        keys.par_sort_unstable();
        let mut out = TetFaces {
            neighbours: vec![[NO_NEIGHBOUR; 4]; self.tets.len()],
            boundary: 0,
            over_shared: 0,
        };
        let face = |k: u128| k >> 32;
        let slot = |k: u128| ((k as u32 / 4) as usize, (k as u32 % 4) as usize);
        let mut i = 0;
        while i < keys.len() {
            let j = i + keys[i..]
                .iter()
                .take_while(|&&k| face(k) == face(keys[i]))
                .count();
            match j - i {
                1 => out.boundary += 1,
                2 => {
                    let ((a, ka), (b, kb)) = (slot(keys[i]), slot(keys[i + 1]));
                    out.neighbours[a][ka] = b as u32;
                    out.neighbours[b][kb] = a as u32;
                }
                _ => out.over_shared += 1,
            }
            i = j;
        }
        out
    }
}

/// No cell across a face ([`TetFaces::neighbours`]).
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// The face topology of a [`TetGrid`] ([`TetGrid::faces`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TetFaces {
    /// Per cell, the cell across the face opposite each of its points, or [`NO_NEIGHBOUR`].
    pub neighbours: Vec<[u32; 4]>,
    /// Faces of one cell only.
    pub boundary: usize,
    /// Faces of more than two cells (left without neighbours).
    pub over_shared: usize,
}

fn det(points: &[Vec3], t: &[u32; 4]) -> f64 {
    orientation(&t.map(|i| points[i as usize].as_dvec3()))
}

/// `det(p1 − p0, p2 − p0, p3 − p0)` of a cell's points: positive in VTK's order.
pub fn orientation(p: &[DVec3; 4]) -> f64 {
    (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0])
}

/// True when a cell of points `p` and determinant `det` has no volume within rounding:
/// `|det| ≤ 1e-9 · (longest edge)³` (what [`TetReport::degenerate`] counts).
pub fn is_degenerate(p: &[DVec3; 4], det: f64) -> bool {
    let longest2 = (0..4)
        .flat_map(|a| (a + 1..4).map(move |b| (a, b)))
        .map(|(a, b)| p[a].distance_squared(p[b]))
        .fold(0.0, f64::max);
    det.abs() <= 1e-9 * longest2.sqrt().powi(3)
}

/// Cell `t` with its last two points swapped where needed for a positive orientation.
pub fn positive(mut t: [u32; 4], points: &[Vec3]) -> [u32; 4] {
    if det(points, &t) < 0.0 {
        t.swap(2, 3);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Grid {
        let mut g = Grid::new([3, 4, 2], Vec3::new(-1.0, 0.0, 2.0), 0.5).unwrap();
        for (i, v) in g.data_mut().iter_mut().enumerate() {
            *v = i as f32;
        }
        g
    }

    #[test]
    fn cubes_cut_into_tetrahedra_fill_the_box_with_consistent_faces() {
        let g = small();
        for (split, per) in [(TetSplit::Five, 5), (TetSplit::Six, 6)] {
            let t = TetGrid::from_grid(&g, split).unwrap();
            assert_eq!(t.tets().len(), per * 2 * 3);
            let r = t.report();
            assert!(r.is_valid(), "{split:?}: {r:?}");
            // The box's boundary: 2 triangles per boundary square, on a
            // box of 2 x 3 x 1 cells.
            let (a, b, c) = (2, 3, 1);
            assert_eq!(
                r.boundary_faces,
                2 * 2 * (a * b + a * c + b * c),
                "{split:?}"
            );
            let volume: f64 = (0..t.tets().len()).map(|c| t.det(c) / 6.0).sum();
            assert!(
                (volume - 1.0 * 1.5 * 0.5).abs() < 1e-9,
                "{split:?}: {volume}"
            );
            assert_eq!(r.range, Some((0.0, 23.0)));
        }
    }

    #[test]
    fn bad_parts_are_refused_and_bad_cells_counted() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        assert!(TetGrid::new(p.clone(), vec![[0, 1, 2, 4]], vec![0.0; 4], "a").is_err());
        assert!(TetGrid::new(p.clone(), vec![[0, 1, 2, 3]], vec![0.0; 3], "a").is_err());
        assert!(TetGrid::new(p.clone(), vec![], vec![0.0; 4], "a").is_err());
        let mut nan = p.clone();
        nan[1].x = f32::NAN;
        assert!(TetGrid::new(nan, vec![[0, 1, 2, 3]], vec![0.0; 4], "a").is_err());
        let t = TetGrid::new(
            p,
            vec![[0, 1, 2, 3], [0, 2, 1, 3], [0, 1, 1, 3]],
            vec![0.0, 1.0, f32::NAN, 2.0],
            "a",
        )
        .unwrap();
        let r = t.report();
        assert_eq!((r.inverted, r.degenerate), (1, 1));
        assert_eq!(r.non_finite_values, 1);
        assert_eq!(r.range, Some((0.0, 2.0)));
        // The first two cells share all four faces; the degenerate one lists face {0, 1, 3}
        // twice (a fourth and fifth use: over-shared) and two faces with a repeated point
        // that nothing else has (boundary).
        assert_eq!((r.boundary_faces, r.over_shared_faces), (2, 1));
        let cells = t.report_cells();
        assert_eq!((cells.boundary_faces, cells.over_shared_faces), (0, 0));
        assert_eq!(
            TetReport {
                boundary_faces: 2,
                over_shared_faces: 1,
                ..cells
            },
            r
        );
        assert!(!r.is_valid());
        let n = t.faces().neighbours;
        assert_eq!(n[0], [1, 1, NO_NEIGHBOUR, 1]);
    }
}
