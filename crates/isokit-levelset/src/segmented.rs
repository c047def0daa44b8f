//! Segmented distance fields (seed 003, "segmented distance fields", Sec. 3.3): one sampled
//! volume that represents surfaces with boundaries, junctions where three or more regions
//! meet, and other non-manifold features, which a signed distance cannot.
//!
//! Each sample holds `f = min(d_E, δ) + D r` (003 Eq. 4): the unsigned distance `d_E` to the
//! surface, clamped at `δ`, plus `D` times the index `r ≥ 0` of the region the sample lies
//! in (`δ < D`, both larger than the sample spacing). [`Segmentation`] encodes and decodes
//! it. Between two neighbouring samples of regions `i ≠ j` with distances `d_u` and `d_v`
//! the surface passes (003 Eq. 5) where `d_u + d_v` is at most the spacing `w` (Eq. 7: the
//! two distances are to the same piece of surface between them; where they are not, as
//! beyond the rim of a disc, there is no surface), at `t = d_u / (d_u + d_v)` along the edge
//! (Eq. 6). Eq. 7 is printed with a strict `<`; on a lattice edge perpendicular to a plane
//! `d_u + d_v = w` exactly, so here it is `≤ w (1 + 1e-4)` plus the f32 rounding of the
//! samples' `D r` (which grows with the region index).
//!
//! [`mesh_segmented`] meshes such a volume by surface nets over those crossings (one
//! vertex per cell, the mean of its crossing points, or where three or more regions meet
//! the point where the pairs' surfaces, fitted as planes nearby, meet; one quadrilateral
//! per crossed edge),
//! each face labelled with its two regions as [`crate::labels`] does: junction edges are
//! shared by exactly the faces of the pairs that meet there, boundary edges by one face.
//! [`morph_segmented`] blends two segmented fields with one region numbering (003 Sec. 5.2)
//! with the region index carried through. Sampling a segmented field from surface patches
//! (distances by a kd-tree) is the scene layer's (`isokit-scene`).

use crate::labels::{LabelMesh, surface_nets, triangulate};
use glam::DVec3;
pub use isokit_field::segmentation::{MAX_REGIONS, Segmentation};
use isokit_field::{FieldError, Grid, Job};
use std::collections::HashMap;

/// The non-manifold surface of a segmented field (see the [module](self) docs), reporting
/// progress to `job` (stage `segmented surface`, in slices). Samples that are not
/// segmented values (negative, non-finite) hold no surface.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, Job};
/// use isokit_levelset::segmented::{Segmentation, mesh_segmented};
///
/// // The plane z = 0.3 between region 0 below and region 1 above.
/// let mut g = Grid::new([5, 5, 5], Vec3::ZERO, 0.25).unwrap();
/// let seg = Segmentation::for_spacing(0.25).unwrap();
/// for k in 0..5 { for j in 0..5 { for i in 0..5 {
///     let z = g.position(i, j, k).z;
///     g.set(i, j, k, seg.encode((z - 0.3).abs(), (z > 0.3) as i32).unwrap());
/// } } }
/// let m = mesh_segmented(&g, &seg, &Job::new()).unwrap();
/// let (pair, _, area) = m.pairs()[0];
/// assert_eq!(pair, [0, 1]);
/// assert!((area - 1.0).abs() < 1e-5); // the lattice's 1 x 1 square
/// assert!(m.mesh.positions.iter().all(|p| (p.z - 0.3).abs() < 1e-5));
/// ```
pub fn mesh_segmented(grid: &Grid, seg: &Segmentation, job: &Job) -> Result<LabelMesh, FieldError> {
    let n = grid.dims().map(|d| d as i64);
    let w = grid.spacing();
    if seg.delta() < w {
        // Clamped distances would sum below the spacing wherever two regions meet.
        return Err(FieldError::BadParameter {
            name: "segmentation delta",
            value: format!("{} for spacing {w}", seg.delta()),
            why: "must be at least the lattice spacing (003 Eq. 4: larger than the interval of grid points)",
        });
    }
    let at = |s: [i64; 3]| grid.get(s[0] as usize, s[1] as usize, s[2] as usize);
    let nets = surface_nets(n, false, "segmented surface", job, |s, t| {
        seg.crossing(at(s), at(t), w)
    })?;
    let (origin, h) = (grid.origin().as_dvec3(), f64::from(w));
    // Lattice units: the mean of each cell's crossing points.
    let mut points: Vec<DVec3> = nets
        .crossings
        .iter()
        .map(|&(sum, count)| sum / f64::from(count))
        .collect();
    junctions(&mut points, &nets.cells, &nets.quads, grid, seg);
    open_rims(&mut points, &nets.cells, &nets.quads, grid, seg);
    let positions = points.iter().map(|p| (origin + *p * h).as_vec3()).collect();
    Ok(triangulate(positions, &nets.quads))
}

/// Where three or more regions meet, a cell's crossings lie on two or more surfaces, and
/// their mean sits between them, up to half a spacing off the junction line. There, each
/// pair's surface is fitted as a plane to its crossing points on the lattice edges of the
/// 6 × 6 × 6 samples around the cell whose ends see only that pair's regions around them
/// (the least-squares plane, by the smallest eigenvector of their covariance), and the
/// vertex moves to the least-squares point of those planes
/// (a QEF with rank truncation, as dual contouring solves, Ju et al. 2002): onto the
/// junction line (or point), moving only across it, so along the line the vertex keeps its
/// place (where the line leaves the lattice it stays at the lattice's edge). A solution
/// outside the cell grown by half a spacing keeps the mean. Lattice units.
fn junctions(
    points: &mut [DVec3],
    cells: &[[i64; 3]],
    quads: &[([u32; 4], [i32; 2])],
    grid: &Grid,
    seg: &Segmentation,
) {
    let mut pairs: Vec<Vec<[i32; 2]>> = vec![Vec::new(); points.len()];
    for (q, r) in quads {
        for &v in q {
            if !pairs[v as usize].contains(r) {
                pairs[v as usize].push(*r);
            }
        }
    }
    let n = grid.dims().map(|d| d as i64);
    let w = grid.spacing();
    let at = |s: [i64; 3]| grid.get(s[0] as usize, s[1] as usize, s[2] as usize);
    // Whether the samples around `s` (3³, within the lattice) are all in region i or j.
    let clean = |s: [i64; 3], i: i32, j: i32| {
        (-1..=1).all(|dz| {
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let q = [s[0] + dx, s[1] + dy, s[2] + dz];
                    (0..3).any(|a| q[a] < 0 || q[a] >= n[a])
                        || seg.decode(at(q)).is_some_and(|(r, _)| r == i || r == j)
                })
            })
        })
    };
    for (v, p) in points.iter_mut().enumerate() {
        let mut regions: Vec<i32> = pairs[v].iter().flatten().copied().collect();
        regions.sort_unstable();
        regions.dedup();
        if regions.len() < 3 {
            continue;
        }
        let c = cells[v];
        // Each pair's crossing points on the edges among the 6³ samples around the cell,
        // where both ends' neighbourhoods hold only that pair's regions (elsewhere a
        // sample's distance may be to another pair's surface, which biases Eq. 6).
        let mut by_pair: HashMap<[i32; 2], Vec<DVec3>> = HashMap::new();
        for z in c[2] - 2..=c[2] + 3 {
            for y in c[1] - 2..=c[1] + 3 {
                for x in c[0] - 2..=c[0] + 3 {
                    let s = [x, y, z];
                    if (0..3).any(|a| s[a] < 0 || s[a] >= n[a]) {
                        continue;
                    }
                    for a in 0..3 {
                        let mut t = s;
                        t[a] += 1;
                        if t[a] >= n[a] || t[a] > c[a] + 3 {
                            continue;
                        }
                        let Some((i, j, along)) = seg.crossing(at(s), at(t), w) else {
                            continue;
                        };
                        if !clean(s, i, j) || !clean(t, i, j) {
                            continue;
                        }
                        let mut e = DVec3::new(x as f64, y as f64, z as f64);
                        e[a] += f64::from(along);
                        by_pair.entry([i.min(j), i.max(j)]).or_default().push(e);
                    }
                }
            }
        }
        let planes: Vec<(DVec3, DVec3)> = pairs[v]
            .iter()
            .filter_map(|pair| fit_plane(by_pair.get(pair)?))
            .collect();
        if planes.len() < 2 {
            continue;
        }
        let x = *p + qef_step(*p, &planes);
        let lo = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) - 0.5;
        if x.is_finite() && (0..3).all(|a| x[a] >= lo[a] && x[a] <= lo[a] + 2.0) {
            *p = x;
        }
    }
}

/// The step from `p` to the least-squares point of the planes `(point, unit normal)`, with
/// singular values below a tenth of the largest dropped (the directions along a junction
/// line, where the planes do not constrain it, keep `p`).
fn qef_step(p: DVec3, planes: &[(DVec3, DVec3)]) -> DVec3 {
    use nalgebra::{Matrix3, Vector3};
    let (mut ata, mut atr) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
    for (c, nrm) in planes {
        let nv = Vector3::new(nrm.x, nrm.y, nrm.z);
        ata += nv * nv.transpose();
        atr += nv * nrm.dot(*c - p);
    }
    let svd = ata.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return DVec3::ZERO;
    };
    let smax = svd.singular_values.max().max(0.0).sqrt();
    let mut inv = Matrix3::<f64>::zeros();
    for i in 0..3 {
        let s = svd.singular_values[i].max(0.0).sqrt();
        if smax > 0.0 && s > 0.1 * smax {
            inv[(i, i)] = 1.0 / (s * s);
        }
    }
    let x = vt.transpose() * inv * u.transpose() * atr;
    DVec3::new(x[0], x[1], x[2])
}

/// The least-squares plane through `points` (three or more, not on one line): its centroid
/// and unit normal (the covariance's eigenvector of the smallest eigenvalue).
fn fit_plane(points: &[DVec3]) -> Option<(DVec3, DVec3)> {
    if points.len() < 3 {
        return None;
    }
    let c = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for p in points {
        let d = nalgebra::Vector3::new(p.x - c.x, p.y - c.y, p.z - c.z);
        m += d * d.transpose();
    }
    let e = m.symmetric_eigen();
    let (mut small, mut mid) = (0, 1);
    for k in 0..3 {
        if e.eigenvalues[k] < e.eigenvalues[small] {
            small = k;
        }
    }
    for k in 0..3 {
        if k != small && (mid == small || e.eigenvalues[k] < e.eigenvalues[mid]) {
            mid = k;
        }
    }
    // Points along one line fix no plane.
    let spread = e.eigenvalues[mid];
    if spread.is_nan() || spread <= 1e-9 * e.eigenvalues.max().max(1e-300) {
        return None;
    }
    let nrm = e.eigenvectors.column(small);
    Some((c, DVec3::new(nrm[0], nrm[1], nrm[2]).normalize()))
}

/// Where the surface ends (an edge of one quadrilateral: a disc's rim), a cell's crossings
/// lie on the inner side only, so their mean sits inside the end. The segmented distances
/// say where the end is: on an edge of the cell between two regions that the surface does
/// not cross (`d_u + d_v > w`, Eq. 7), the samples are `d_u` and `d_v` from the rim, so
/// the rim passes `ρ = √(((d_u + d_v)/2)² − (w/2)²)` from the edge's point at `t = d_u / (d_u +
/// d_v)` (exact where the edge is perpendicular to the surface and halved by it). Such a
/// vertex moves to the mean of those rim points, within the surface's plane there (the
/// mean normal of its quadrilaterals); a rim cell without such an edge moves to its centre
/// within that plane. Cells beyond the lattice (index −1 or n − 1, where the surface ends
/// because the lattice does) keep their place.
fn open_rims(
    points: &mut [DVec3],
    cells: &[[i64; 3]],
    quads: &[([u32; 4], [i32; 2])],
    grid: &Grid,
    seg: &Segmentation,
) {
    let n = grid.dims().map(|d| d as i64);
    let w = grid.spacing();
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    let mut normals = vec![DVec3::ZERO; points.len()];
    for (q, _) in quads {
        let nq = (points[q[2] as usize] - points[q[0] as usize])
            .cross(points[q[3] as usize] - points[q[1] as usize]);
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            normals[q[k] as usize] += nq;
        }
    }
    let mut rim = vec![false; points.len()];
    for (&(a, b), &k) in &uses {
        if k == 1 {
            rim[a as usize] = true;
            rim[b as usize] = true;
        }
    }
    let at = |s: [i64; 3]| seg.decode(grid.get(s[0] as usize, s[1] as usize, s[2] as usize));
    for (i, p) in points.iter_mut().enumerate() {
        let c = cells[i];
        let inside = (0..3).all(|a| c[a] >= 0 && c[a] + 1 < n[a]);
        let nrm = normals[i].normalize_or_zero();
        if !(rim[i] && inside && nrm != DVec3::ZERO) {
            continue;
        }
        let m = *p;
        let in_plane = |q: DVec3| q - nrm * (q - m).dot(nrm);
        let (mut sum, mut count) = (DVec3::ZERO, 0u32);
        for a in 0..3 {
            for k in 0..4 {
                // The cell's 4 edges along axis a.
                let mut s0 = c;
                s0[(a + 1) % 3] += k & 1;
                s0[(a + 2) % 3] += (k >> 1) & 1;
                let mut s1 = s0;
                s1[a] += 1;
                let (Some((ri, du)), Some((rj, dv))) = (at(s0), at(s1)) else {
                    continue;
                };
                let total = du + dv;
                if ri == rj
                    || total <= seg.reach(w, ri.max(rj))
                    || du >= seg.delta()
                    || dv >= seg.delta()
                {
                    continue;
                }
                let mut e = DVec3::new(s0[0] as f64, s0[1] as f64, s0[2] as f64);
                e[a] += f64::from(du / total);
                let half = f64::from(total / w) / 2.0;
                let rho = (half * half - 0.25).max(0.0).sqrt();
                let to = in_plane(m) - in_plane(e);
                let reach = to.length();
                if reach > 0.0 {
                    sum += in_plane(e) + to * (rho.min(reach) / reach);
                    count += 1;
                }
            }
        }
        *p = if count > 0 {
            sum / f64::from(count)
        } else {
            in_plane(DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) + 0.5)
        };
    }
}

/// 003's step 6: renumbers the regions of a segmented field from 0 in ascending order, so
/// the indices are dense (a vertex generation diagram then spans no unused region). Returns
/// the old index of each new one (`old[new]`); samples that are not segmented values
/// (negative, not finite) are left as they are, and one that decodes to a region beyond
/// [`MAX_REGIONS`] is an error. Distances are kept to f32 rounding (each sample decoded and encoded
/// again).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::Grid;
/// use isokit_levelset::segmented::{Segmentation, renumber};
///
/// let seg = Segmentation::new(1.0, 2.0).unwrap();
/// let mut g = Grid::new([3, 1, 1], Vec3::ZERO, 0.25).unwrap();
/// for (i, r) in [7, 3, 7].into_iter().enumerate() {
///     g.set(i, 0, 0, seg.encode(0.5, r).unwrap());
/// }
/// assert_eq!(renumber(&mut g, &seg).unwrap(), vec![3, 7]);
/// assert_eq!(seg.decode(g.get(0, 0, 0)), Some((1, 0.5)));
/// assert_eq!(seg.decode(g.get(1, 0, 0)), Some((0, 0.5)));
/// ```
pub fn renumber(grid: &mut Grid, seg: &Segmentation) -> Result<Vec<i32>, FieldError> {
    let mut present = vec![false; MAX_REGIONS as usize];
    for &f in grid.data() {
        if let Some((r, _)) = seg.decode(f) {
            let Some(p) = present.get_mut(r as usize) else {
                return Err(FieldError::BadParameter {
                    name: "segmented sample",
                    value: f.to_string(),
                    why: "decodes to a region beyond 4095 (003 Eq. 4 with this field's period)",
                });
            };
            *p = true;
        }
    }
    let old: Vec<i32> = (0..MAX_REGIONS).filter(|&r| present[r as usize]).collect();
    let mut new = vec![-1i32; MAX_REGIONS as usize];
    for (n, &o) in old.iter().enumerate() {
        new[o as usize] = n as i32;
    }
    for f in grid.data_mut() {
        if let Some((r, d)) = seg.decode(*f)
            && let Some(&n) = new.get(r as usize)
            && n >= 0
            && n != r
        {
            *f = seg.encode(d, n)?;
        }
    }
    Ok(old)
}

/// The blend `(1 − t) a + t b` of two segmented fields on one lattice with one region
/// numbering (003 Sec. 5.2), the region index carried through: where both samples are in
/// one region the distances blend; where they differ (region `i` in `a` at distance
/// `d_a`, `j` in `b` at `d_b`) the blend is that of the signed distances to the interface
/// between them, `(1 − t)(−d_a) + t d_b` seen from `i`: the sample is in `i` while
/// `t d_b < (1 − t) d_a`, in `j` after, at the blend's magnitude. For two regions (inside
/// and outside), where both distances are below `δ`, this is the linear morph of signed
/// distances; deeper than `δ` it blends clamped values (as the fields hold nothing more),
/// which is exact for the surface only where it passes within `δ` of both operands' samples.
pub fn morph_segmented(a: &Grid, b: &Grid, seg: &Segmentation, t: f32) -> Result<Grid, FieldError> {
    if a.dims() != b.dims() || a.origin() != b.origin() || a.spacing() != b.spacing() {
        return Err(FieldError::BadParameter {
            name: "morph operands",
            value: format!("{:?} and {:?}", a.dims(), b.dims()),
            why: "segmented fields blend on one lattice",
        });
    }
    if !(0.0..=1.0).contains(&t) {
        return Err(FieldError::BadParameter {
            name: "t",
            value: t.to_string(),
            why: "must be from 0 to 1",
        });
    }
    let mut out = a.clone();
    for (o, (&fa, &fb)) in out.data_mut().iter_mut().zip(a.data().iter().zip(b.data())) {
        *o = match (seg.decode(fa), seg.decode(fb)) {
            (Some((i, da)), Some((j, db))) if i == j => seg.encode((1.0 - t) * da + t * db, i)?,
            (Some((i, da)), Some((j, db))) => {
                let s = -(1.0 - t) * da + t * db;
                if s < 0.0 || (s == 0.0 && t < 0.5) {
                    seg.encode(-s, i)?
                } else {
                    seg.encode(s, j)?
                }
            }
            _ => f32::NAN,
        };
    }
    Ok(out)
}
