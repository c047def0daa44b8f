//! Segmented distance fields sampled from surface patches (003 Sec. 3.3.2): a triangle mesh
//! whose triangles carry the region in front of them and the region behind them (PLY face
//! properties `region_front` and `region_back`). Each sample takes the unsigned distance to
//! the nearest triangle (the kd-tree of `isokit_kdtree::mesh::MeshSdf`) and the region on the
//! side of it where the sample lies; [`Segmentation::encode`] makes the value (003 Eq. 4),
//! which `isokit_levelset::segmented::mesh_segmented` meshes.
//!
//! The side: the triangles within 1e-9 (relative) of the nearest distance (several where
//! the nearest point is an edge or a corner) are grouped by their (front, back) pair; each
//! group's angle-weighted pseudonormal at the nearest point (Bærentzen and Aanæs 2005) gives
//! its side, and the group the sample is farthest off, relative to the distance, decides:
//! its front region where the sample is on its normal's side, its back region otherwise. A
//! sample off none of them (beyond a boundary's rim, in the surface's own plane) takes the
//! smallest of their regions, as 003 does where the index is not unique.
//!
//! Regions that meet where no patch separates them (the outsides of a cube's faces when each
//! face is given its own front region) are merged into the smallest of them, 003's steps
//! 4–5 on the lattice ([`Patches::sample`]); its step 6 (renumbering from 0) is the caller's
//! choice (`isokit_levelset::segmented::renumber`): the indices stay the caller's here.
//!
//! [`from_labels`] makes the field of a label volume (a segmented CT): its interfaces meshed
//! by surface nets, then sampled as patches on the volume's own lattice.

use crate::SceneError;
use glam::{DVec3, Vec3};
use isokit_field::{Grid, Job, TriMesh};
use isokit_kdtree::mesh::{MeshOptions, MeshSdf, SignMode};
use isokit_kdtree::tree::QueryStats;
use isokit_kdtree::triangle::unit_normal;
use isokit_levelset::labels::{LabelOptions, label_surface};
use isokit_levelset::segmented::{MAX_REGIONS, Segmentation};
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
        // Per (front, back) pair among the nearest triangles, their pseudonormal at the
        // nearest point: the sum of their normals, each weighted by its angle there where
        // that point is one of its corners (Bærentzen and Aanæs 2005), so the side is right
        // at the edges and corners of each patch, also at sharp ones.
        let q = hit.point;
        let mut groups: Vec<((i32, i32), DVec3)> = Vec::new();
        for (t, _) in near {
            let [a, b, c] = tri[t as usize].map(|i| pos[i as usize]);
            let Some(n) = unit_normal(a, b, c) else {
                continue;
            };
            let corner = [(a, b, c), (b, c, a), (c, a, b)]
                .into_iter()
                .find(|(v, _, _)| v.distance(q) <= tol);
            let weight = match corner {
                Some((v, x, y)) => (x - v).angle_between(y - v),
                None => 1.0,
            };
            let key = (self.front[t as usize], self.back[t as usize]);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, sum)) => *sum += weight * n,
                None => groups.push((key, weight * n)),
            }
        }
        let mut best: Option<(f64, i32)> = None; // (|offset| / d, region)
        let mut smallest = i32::MAX;
        for ((front, back), normal) in groups {
            smallest = smallest.min(front.min(back));
            let offset = (p - q).dot(normal.normalize_or_zero()) / d.max(1e-300);
            let region = if offset >= 0.0 { front } else { back };
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
    /// parallel, reporting progress to `job` (stage `segmented distance`, in slices). Then
    /// 003's steps 4–5: two neighbouring samples in different regions that are not the
    /// front and back of any patch (say the outsides of two faces of a cube, numbered apart)
    /// meet where no surface is, so their regions merge, into the smallest index, until no
    /// such pair is left. Returns the merges made, `(from, into)`.
    pub fn sample(
        &self,
        grid: &mut Grid,
        seg: &Segmentation,
        job: &Job,
    ) -> Result<Vec<(i32, i32)>, SceneError> {
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
            })?;
        Ok(self.merge_touching(grid, seg))
    }

    /// 003 Sec. 3.3.2, steps 4–5, on the lattice (see [`Patches::sample`]).
    fn merge_touching(&self, grid: &mut Grid, seg: &Segmentation) -> Vec<(i32, i32)> {
        let pairs: std::collections::HashSet<(i32, i32)> = self
            .front
            .iter()
            .zip(&self.back)
            .map(|(&f, &b)| (f.min(b), f.max(b)))
            .collect();
        let mut parent: Vec<i32> = (0..isokit_levelset::segmented::MAX_REGIONS).collect();
        fn root(parent: &mut [i32], mut r: i32) -> i32 {
            while parent[r as usize] != r {
                parent[r as usize] = parent[parent[r as usize] as usize];
                r = parent[r as usize];
            }
            r
        }
        let [nx, ny, nz] = grid.dims();
        let region = |i: usize, j: usize, k: usize| seg.decode(grid.get(i, j, k)).map(|x| x.0);
        let mut merges = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let Some(a) = region(i, j, k) else { continue };
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (x, y, z) = (i + di, j + dj, k + dk);
                        if x >= nx || y >= ny || z >= nz {
                            continue;
                        }
                        let Some(b) = region(x, y, z) else { continue };
                        if a == b || pairs.contains(&(a.min(b), a.max(b))) {
                            continue;
                        }
                        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                        if ra != rb {
                            let (into, from) = (ra.min(rb), ra.max(rb));
                            parent[from as usize] = into;
                            merges.push((from, into));
                        }
                    }
                }
            }
        }
        if !merges.is_empty() {
            for v in grid.data_mut() {
                if let Some((r, d)) = seg.decode(*v) {
                    let to = root(&mut parent, r);
                    if to != r {
                        *v = seg.encode(d, to).unwrap_or(f32::NAN);
                    }
                }
            }
            for m in merges.iter_mut() {
                m.1 = root(&mut parent, m.1);
            }
        }
        merges
    }
}

/// The segmented distance field of a label volume (one whole number per sample, each a
/// region; 003 Sec. 3.3.2 from a segmentation such as a labelled CT), on the volume's own
/// lattice: the interfaces between the labels are meshed by surface nets
/// ([`label_surface`], relaxed as `opts` say; each face's lower label in front, on its
/// normal's side), then sampled as [`Patches`]. Labels must be below
/// [`MAX_REGIONS`]; a volume of one label holds that region at the clamp `δ` everywhere.
/// Samples beyond the lattice count as label 0, as in [`label_surface`], so a region that
/// touches the lattice's edge is closed there against region 0.
pub fn from_labels(
    labels: &Grid,
    seg: &Segmentation,
    opts: &LabelOptions,
    job: &Job,
) -> Result<Grid, SceneError> {
    let err = |why: String| SceneError::new("label volume", "", why);
    if let Some(&bad) = labels
        .data()
        .iter()
        .find(|&&l| !(l >= 0.0 && l < MAX_REGIONS as f32 && l.fract() == 0.0))
    {
        return Err(err(format!(
            "label {bad}: a segmented field takes whole labels from 0 to {}",
            MAX_REGIONS - 1
        )));
    }
    let surface = label_surface(labels, opts, job).map_err(|e| err(e.to_string()))?;
    let mut grid = labels.clone();
    if surface.mesh.triangles.is_empty() {
        for v in grid.data_mut() {
            *v = seg
                .encode(seg.delta(), *v as i32)
                .map_err(|e| err(e.to_string()))?;
        }
        return Ok(grid);
    }
    let front = surface.regions.iter().map(|r| r[0]).collect();
    let back = surface.regions.iter().map(|r| r[1]).collect();
    let patches = Patches::new(&surface.mesh, front, back, "label interfaces")?;
    patches.sample(&mut grid, seg, job)?;
    Ok(grid)
}
