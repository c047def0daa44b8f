//! Segmented distance fields sampled from surface patches (003 Sec. 3.3.2): a triangle mesh
//! whose triangles carry the region in front of them and the region behind them (PLY face
//! properties `region_front` and `region_back`). Each sample takes the unsigned distance to
//! the nearest triangle (the kd-tree of `isokit_kdtree::mesh::MeshSdf`) and the region on the
//! side of it where the sample lies; [`Segmentation::encode`] makes the value (003 Eq. 4),
//! which `isokit_levelset::segmented::mesh_segmented` meshes.
//!
//! The side: among the triangles within 1e-9 (relative) of the nearest distance (several
//! where the nearest point is an edge or a vertex), the one whose plane the sample is
//! farthest off, relative to the distance, decides: its front region where the sample is on
//! its normal's side, its back region otherwise. A sample in the plane of all of them
//! (beyond a boundary's rim, in the surface's own plane) takes the smallest of their regions,
//! as 003 does where the index is not unique. Regions are taken as given: the paper's
//! renumbering of regions that touch without a patch between them (its steps 4–6) is left
//! to the caller's numbering.

use crate::SceneError;
use glam::{DVec3, Vec3};
use isokit_field::{Grid, Job, TriMesh};
use isokit_kdtree::mesh::{MeshOptions, MeshSdf, SignMode};
use isokit_kdtree::tree::QueryStats;
use isokit_kdtree::triangle::{closest_point, unit_normal};
use isokit_levelset::segmented::Segmentation;
use rayon::prelude::*;

/// Surface patches: a mesh and, per triangle, the regions in front (the side its normal
/// points to, counter-clockwise winding) and behind.
pub struct Patches {
    sdf: MeshSdf,
    front: Vec<i32>,
    back: Vec<i32>,
}

impl Patches {
    /// Checks the counts and builds the kd-tree (`name` is used in messages).
    pub fn new(
        mesh: &TriMesh,
        front: Vec<i32>,
        back: Vec<i32>,
        name: &str,
    ) -> Result<Self, SceneError> {
        let n = mesh.triangles.len();
        if front.len() != n || back.len() != n {
            return Err(SceneError::new(
                name,
                "",
                format!(
                    "{} front and {} back regions for {n} triangles",
                    front.len(),
                    back.len()
                ),
            ));
        }
        if let Some(r) = front
            .iter()
            .chain(&back)
            .find(|r| !(0..isokit_levelset::segmented::MAX_REGIONS).contains(*r))
        {
            return Err(SceneError::new(
                name,
                "",
                format!("region {r}: regions run from 0 to 4095"),
            ));
        }
        let opts = MeshOptions {
            sign: SignMode::Unsigned,
            ..MeshOptions::default()
        };
        let sdf = MeshSdf::new(mesh, opts).map_err(|e| SceneError::new(name, "", e.to_string()))?;
        Ok(Self { sdf, front, back })
    }

    /// The unsigned distance from `p` to the patches and the region `p` lies in.
    pub fn query(&self, p: DVec3, stats: &mut QueryStats) -> Option<(f64, i32)> {
        let hit = self.sdf.closest_within(p, f64::INFINITY, stats)?;
        let d = hit.distance;
        let tol = 1e-9 * (1.0 + d + p.abs().max_element());
        let near = if hit.feature == isokit_kdtree::triangle::Feature::Face {
            vec![(hit.triangle, d)]
        } else {
            self.sdf.within(p, d + tol, stats)
        };
        let (pos, tri) = (self.sdf.positions(), self.sdf.triangles());
        let mut best: Option<(f64, i32)> = None; // (|offset| / d, region)
        let mut smallest = i32::MAX;
        for (t, _) in near {
            let [a, b, c] = tri[t as usize].map(|i| pos[i as usize]);
            let (Some(n), q) = (unit_normal(a, b, c), closest_point(p, a, b, c)) else {
                continue;
            };
            let offset = (p - q.point).dot(n) / d.max(1e-300);
            let region = if offset >= 0.0 {
                self.front[t as usize]
            } else {
                self.back[t as usize]
            };
            smallest = smallest.min(self.front[t as usize].min(self.back[t as usize]));
            if best.is_none_or(|(o, _)| offset.abs() > o) {
                best = Some((offset.abs(), region));
            }
        }
        let region = match best {
            Some((o, r)) if o > 1e-6 => r,
            _ if smallest < i32::MAX => smallest,
            _ => self.front[hit.triangle as usize],
        };
        Some((d, region))
    }

    /// Fills `grid` (its lattice) with the segmented distance (003 Eq. 4), samples in
    /// parallel, reporting progress to `job` (stage `segmented distance`, in slices).
    pub fn sample(&self, grid: &mut Grid, seg: &Segmentation, job: &Job) -> Result<(), SceneError> {
        let [nx, ny, nz] = grid.dims();
        let (origin, h) = (grid.origin(), grid.spacing());
        let counter = job.counter("segmented distance", nz as u64);
        let slice = nx * ny;
        grid.data_mut()
            .par_chunks_mut(slice)
            .enumerate()
            .try_for_each(|(k, out)| -> Result<(), SceneError> {
                job.check()
                    .map_err(|e| SceneError::new("segmented distance", "", e.to_string()))?;
                let mut stats = QueryStats::default();
                for (e, o) in out.iter_mut().enumerate() {
                    let (i, j) = (e % nx, e / nx);
                    let p = origin + Vec3::new(i as f32, j as f32, k as f32) * h;
                    *o = match self.query(p.as_dvec3(), &mut stats) {
                        Some((d, r)) => seg.encode(d as f32, r).unwrap_or(f32::NAN),
                        None => f32::NAN,
                    };
                }
                counter.advance(1);
                Ok(())
            })
    }
}
