//! The generalized winding number of an oriented point cloud, after Barill, Dickson,
//! Schmidt, Levin and Jacobson 2018, "Fast Winding Numbers for Soups and Clouds".
//!
//! Each sample `p_i` with outward unit normal `n_i` stands for a small disc of area `a_i`;
//! its contribution at `q` is the dipole `a_i n_i·(p_i − q) / (4π |p_i − q|³)` (Sec. 3,
//! the dipole of each point), so the sum ([`WindingNumber::exact`]) is ≈ 1 inside a closed sampled surface and
//! ≈ 0 outside, and crosses 1/2 on it. The areas ([`point_areas`]) are those of the samples'
//! Voronoi cells in their tangent planes among their k nearest neighbours (Sec. 3: the
//! paper takes them from a Delaunay triangulation of the projected neighbours; the clipped
//! cell here is its dual). [`WindingNumber::value`] is the hierarchical evaluation of Sec. 4:
//! a binary tree over the samples, each node holding the sum of its dipoles `Σ a_i n_i` at
//! its area-weighted centre and their first moment `Σ a_i n_i ⊗ (p_i − centre)` (the
//! expansion to second order in the distance, Sec. 4); a node whose centre is farther
//! than `beta` times its radius from `q` is replaced by its expansion, the others are
//! opened, and leaves are summed directly. Barill et al. use `beta = 2`.
//!
//! `PointSdf` takes the sign of its far field from it ([`crate::SignRule`]): inside where the
//! winding number exceeds 1/2.

use crate::knn::Knn;
use crate::{PointsError, check_points, unit_normals};
use glam::{DMat3, DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Samples per leaf of the tree.
const LEAF: usize = 8;

/// Knobs of [`WindingNumber`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindingOptions {
    /// Neighbours whose projections bound each sample's Voronoi cell ([`point_areas`]).
    pub area_k: usize,
    /// Accuracy: a node's expansion replaces its samples where the query point is farther
    /// than `beta` times the node's radius from its centre (Barill et al. 2018, Sec. 4: 2).
    pub beta: f64,
}

impl Default for WindingOptions {
    fn default() -> Self {
        Self {
            area_k: 16,
            beta: 2.0,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Area-weighted centre of the node's samples.
    center: DVec3,
    /// Largest distance from `center` to a sample of the node.
    radius: f64,
    /// Σ a_i n_i over the node's samples.
    dipole: DVec3,
    /// Σ (a_i n_i) ⊗ (p_i − center): the second-order term.
    moment: DMat3,
    /// The node's samples: `start..end` of the tree order.
    start: u32,
    end: u32,
    /// Children (both or neither); `u32::MAX` for a leaf.
    left: u32,
    right: u32,
}

/// The winding number of an oriented point cloud, built once and queried in parallel (see
/// the [module](self) docs).
///
/// ```
/// use isokit_points::winding::{WindingNumber, WindingOptions};
/// use glam::DVec3;
///
/// let cloud = isokit_io::generate::torus_cloud(1.0, 0.3, 4000, 7);
/// let w = WindingNumber::new(&cloud.points, cloud.normals.as_ref().unwrap(),
///     &WindingOptions::default()).unwrap();
/// let inside = DVec3::new(1.0, 0.0, 0.0); // on the tube's centre line
/// assert!((w.exact(inside) - 1.0).abs() < 0.02);
/// // The tree's first-order expansions are off by up to about 0.1 at β = 2.
/// assert!((w.value(inside) - 1.0).abs() < 0.15);
/// assert!(w.value(DVec3::ZERO).abs() < 0.15); // in the hole
/// assert!(w.value(DVec3::new(0.0, 0.0, 2.0)).abs() < 0.02); // far above
/// ```
#[derive(Clone, Debug)]
pub struct WindingNumber {
    /// Samples in tree order.
    pts: Vec<DVec3>,
    /// `a_i n_i` in tree order.
    dip: Vec<DVec3>,
    nodes: Vec<Node>,
    beta: f64,
    total_area: f64,
}

/// Area of sample `i`'s Voronoi cell in its tangent plane, clipped by the bisectors of its
/// neighbours `nb` (index, squared distance; the sample itself may be among them) projected
/// onto that plane, within the square of half-side the farthest neighbour's distance.
/// Neighbours facing away (`n_i·n_j < −0.5`: the other sheet of a thin part) are skipped,
/// as are those that project onto the sample.
pub(crate) fn voronoi_area(i: usize, pts: &[DVec3], nrm: &[DVec3], nb: &[(usize, f64)]) -> f64 {
    let (p, n) = (pts[i], nrm[i]);
    let r = nb.iter().map(|&(_, d2)| d2).fold(0.0, f64::max).sqrt();
    if r <= 0.0 {
        return 0.0;
    }
    // Tangent basis (glam's is Duff et al. 2017's branchless orthonormal basis).
    let (u, v) = n.any_orthonormal_pair();
    let mut poly = vec![
        DVec2::new(-r, -r),
        DVec2::new(r, -r),
        DVec2::new(r, r),
        DVec2::new(-r, r),
    ];
    let mut next = Vec::with_capacity(16);
    for &(j, _) in nb {
        if j == i || nrm[j].dot(n) < -0.5 {
            continue;
        }
        let d = pts[j] - p;
        let q = DVec2::new(d.dot(u), d.dot(v));
        let qq = q.length_squared();
        if qq <= 1e-24 * r * r {
            continue;
        }
        // Keep {x : x·q ≤ |q|²/2} (Sutherland–Hodgman against one half-plane).
        let side = |x: DVec2| x.dot(q) - 0.5 * qq;
        next.clear();
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let (sa, sb) = (side(a), side(b));
            if sa <= 0.0 {
                next.push(a);
            }
            if (sa < 0.0) != (sb < 0.0) && sa != sb {
                next.push(a + (b - a) * (sa / (sa - sb)));
            }
        }
        std::mem::swap(&mut poly, &mut next);
        if poly.len() < 3 {
            return 0.0;
        }
    }
    let mut twice = 0.0;
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        twice += a.perp_dot(b);
    }
    0.5 * twice.abs()
}

/// Areas of the samples for the winding number (Barill et al. 2018, Sec. 3): each
/// sample's Voronoi cell in its tangent plane among its `k` nearest neighbours (those
/// facing away, `n_i·n_j < −0.5`, skipped). On a uniform sampling of a closed surface their
/// sum is close to the surface's area.
///
/// Errors: empty input, non-finite points, mismatched lengths, bad normals, `k = 0`.
pub fn point_areas(points: &[Vec3], normals: &[Vec3], k: usize) -> Result<Vec<f64>, PointsError> {
    check_points(points)?;
    let nrm = unit_normals(points, normals)?;
    if k == 0 {
        return Err(PointsError::Parameter(
            "area neighbours must be at least 1".into(),
        ));
    }
    let knn = Knn::new(points)?;
    let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
    Ok(areas_with(&knn, &pts, &nrm, k))
}

/// [`point_areas`] over checked samples and an existing tree of them.
pub(crate) fn areas_with(knn: &Knn, pts: &[DVec3], nrm: &[DVec3], k: usize) -> Vec<f64> {
    let m = (k + 1).min(pts.len());
    (0..pts.len())
        .into_par_iter()
        .map_init(Vec::new, |nb, i| {
            knn.nearest_again(pts[i], m, nb);
            voronoi_area(i, pts, nrm, nb)
        })
        .collect()
}

impl WindingNumber {
    /// Builds the winding number of oriented samples: areas by [`point_areas`], then the
    /// tree.
    ///
    /// Errors: empty input, non-finite points, mismatched lengths, bad normals, `area_k =
    /// 0`, `beta` not finite and positive.
    pub fn new(
        points: &[Vec3],
        normals: &[Vec3],
        opts: &WindingOptions,
    ) -> Result<Self, PointsError> {
        let areas = point_areas(points, normals, opts.area_k)?;
        let nrm = unit_normals(points, normals)?;
        let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
        Self::build(pts, nrm, areas, opts.beta)
    }

    /// Builds the tree over samples with given areas (e.g. to compare with another
    /// implementation on the same areas).
    ///
    /// Errors: empty input, non-finite points, mismatched lengths, bad normals, negative or
    /// non-finite areas, `beta` not finite and positive.
    pub fn with_areas(
        points: &[Vec3],
        normals: &[Vec3],
        areas: &[f64],
        beta: f64,
    ) -> Result<Self, PointsError> {
        check_points(points)?;
        let nrm = unit_normals(points, normals)?;
        if areas.len() != points.len() {
            return Err(PointsError::Parameter(format!(
                "{} areas for {} points",
                areas.len(),
                points.len()
            )));
        }
        if let Some(i) = areas.iter().position(|a| !(a.is_finite() && *a >= 0.0)) {
            return Err(PointsError::Parameter(format!(
                "area {i} is {}: areas must be finite and non-negative",
                areas[i]
            )));
        }
        let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
        Self::build(pts, nrm, areas.to_vec(), beta)
    }

    /// The tree over checked samples (unit normals, valid areas).
    pub(crate) fn build(
        pts: Vec<DVec3>,
        nrm: Vec<DVec3>,
        areas: Vec<f64>,
        beta: f64,
    ) -> Result<Self, PointsError> {
        if !(beta.is_finite() && beta > 0.0) {
            return Err(PointsError::Parameter(format!(
                "winding number beta {beta} must be finite and positive"
            )));
        }
        if pts.len() > u32::MAX as usize / 2 {
            return Err(PointsError::Parameter(format!(
                "{} points exceed the 2^31 limit of the winding-number tree",
                pts.len()
            )));
        }
        let mut order: Vec<u32> = (0..pts.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * pts.len() / LEAF + 1);
        split(&pts, &mut order, 0, &mut nodes);
        let tp: Vec<DVec3> = order.iter().map(|&i| pts[i as usize]).collect();
        let dip: Vec<DVec3> = order
            .iter()
            .map(|&i| nrm[i as usize] * areas[i as usize])
            .collect();
        let ta: Vec<f64> = order.iter().map(|&i| areas[i as usize]).collect();
        // Expansions bottom-up: children come after their parent in `nodes`.
        for n in (0..nodes.len()).rev() {
            let node = nodes[n];
            let (s, e) = (node.start as usize, node.end as usize);
            let area: f64 = ta[s..e].iter().sum();
            let center = if area > 0.0 {
                (s..e).map(|i| tp[i] * ta[i]).sum::<DVec3>() / area
            } else {
                (s..e).map(|i| tp[i]).sum::<DVec3>() / (e - s) as f64
            };
            let radius = tp[s..e]
                .iter()
                .map(|p| p.distance_squared(center))
                .fold(0.0, f64::max)
                .sqrt();
            let outer = |a: DVec3, d: DVec3| DMat3::from_cols(a * d.x, a * d.y, a * d.z);
            let (dipole, moment) = if node.left == u32::MAX {
                (s..e).fold((DVec3::ZERO, DMat3::ZERO), |(a, m), i| {
                    (a + dip[i], m + outer(dip[i], tp[i] - center))
                })
            } else {
                [node.left, node.right]
                    .iter()
                    .fold((DVec3::ZERO, DMat3::ZERO), |(a, m), &c| {
                        let c = &nodes[c as usize];
                        (
                            a + c.dipole,
                            m + c.moment + outer(c.dipole, c.center - center),
                        )
                    })
            };
            nodes[n].center = center;
            nodes[n].radius = radius;
            nodes[n].dipole = dipole;
            nodes[n].moment = moment;
        }
        Ok(Self {
            total_area: ta.iter().sum(),
            pts: tp,
            dip,
            nodes,
            beta,
        })
    }

    /// Sum of the sample areas (≈ the surface's area on a good sampling).
    pub fn total_area(&self) -> f64 {
        self.total_area
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pts.len()
    }

    /// True without samples (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.pts.is_empty()
    }

    /// The winding number at `q` by the tree (Sec. 4). NaN at a non-finite `q`.
    pub fn value(&self, q: DVec3) -> f64 {
        if !q.is_finite() {
            return f64::NAN;
        }
        let b2 = self.beta * self.beta;
        let mut w = 0.0;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let r = node.center - q;
            let d2 = r.length_squared();
            if d2 > b2 * node.radius * node.radius {
                w += expansion(node, r, d2);
            } else if node.left == u32::MAX {
                for i in node.start as usize..node.end as usize {
                    let r = self.pts[i] - q;
                    w += dipole(self.dip[i], r, r.length_squared());
                }
            } else {
                stack.push(node.left);
                stack.push(node.right);
            }
        }
        w
    }

    /// The winding number at `q` by the direct sum over every sample (the reference
    /// for [`WindingNumber::value`]).
    pub fn exact(&self, q: DVec3) -> f64 {
        self.pts
            .iter()
            .zip(&self.dip)
            .map(|(&p, &a)| {
                let r = p - q;
                dipole(a, r, r.length_squared())
            })
            .sum()
    }

    /// [`WindingNumber::value`] at many points, in parallel.
    pub fn values_at(&self, points: &[DVec3]) -> Vec<f64> {
        points.par_iter().map(|&q| self.value(q)).collect()
    }
}

/// A node's expansion seen from `r = center − q` (|r|² = `d2` > 0): the dipole term
/// `A·F(r)` plus the first-order term `J(r) : M`, with `F(r) = r/(4π|r|³)` and its Jacobian
/// `J = (I − 3 r̂ r̂ᵀ)/(4π|r|³)` (Barill et al. 2018, Sec. 4).
#[inline]
fn expansion(node: &Node, r: DVec3, d2: f64) -> f64 {
    let inv3 = 1.0 / (d2 * d2.sqrt());
    let m = node.moment;
    let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    let rmr = r.dot(m * r);
    (node.dipole.dot(r) * inv3 + inv3 * trace - 3.0 * inv3 / d2 * rmr) / (4.0 * PI)
}

/// `a·r / (4π |r|³)`: one dipole of (area-weighted) normal `a` seen from `r` away; 0 at
/// `r = 0` (a query exactly at a sample).
#[inline]
fn dipole(a: DVec3, r: DVec3, d2: f64) -> f64 {
    if d2 > 0.0 {
        a.dot(r) / (4.0 * PI * d2 * d2.sqrt())
    } else {
        0.0
    }
}

/// Splits `order` (the samples of a new node whose samples start at `start`) at the median
/// of the longest side of its box, recursively; pushes the node and then its subtrees.
fn split(pts: &[DVec3], order: &mut [u32], start: usize, nodes: &mut Vec<Node>) -> u32 {
    let id = nodes.len() as u32;
    nodes.push(Node {
        center: DVec3::ZERO,
        radius: 0.0,
        dipole: DVec3::ZERO,
        moment: DMat3::ZERO,
        start: start as u32,
        end: (start + order.len()) as u32,
        left: u32::MAX,
        right: u32::MAX,
    });
    if order.len() <= LEAF {
        return id;
    }
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for &i in order.iter() {
        lo = lo.min(pts[i as usize]);
        hi = hi.max(pts[i as usize]);
    }
    let ext = hi - lo;
    if ext.max_element() <= 0.0 {
        // All samples coincide: one leaf.
        return id;
    }
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        pts[a as usize][axis].total_cmp(&pts[b as usize][axis])
    });
    let (a, b) = order.split_at_mut(mid);
    let left = split(pts, a, start, nodes);
    let right = split(pts, b, start + mid, nodes);
    nodes[id as usize].left = left;
    nodes[id as usize].right = right;
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A regular planar grid of spacing 1 gets unit areas inside (its Voronoi cells are unit
    /// squares), and the facing-away rule keeps a second sheet from shrinking them.
    #[test]
    fn voronoi_areas_of_a_regular_grid() {
        let mut p = Vec::new();
        let mut n = Vec::new();
        for j in -5..=5 {
            for i in -5..=5 {
                p.push(Vec3::new(i as f32, j as f32, 0.0));
                n.push(Vec3::Z);
                // The other sheet, 0.3 below, facing down.
                p.push(Vec3::new(i as f32, j as f32, -0.3));
                n.push(-Vec3::Z);
            }
        }
        let a = point_areas(&p, &n, 24).unwrap();
        let centre = p.iter().position(|q| *q == Vec3::ZERO).unwrap();
        assert!((a[centre] - 1.0).abs() < 1e-9, "{}", a[centre]);
        assert!(point_areas(&p, &n, 0).is_err());
        assert!(point_areas(&p, &n[1..], 8).is_err());
    }

    /// Tree against direct sum, and the sphere's inside and outside.
    #[test]
    fn tree_matches_the_direct_sum_on_a_sphere() {
        let mut rng = isokit_field::rng::SplitMix64::new(3);
        let p: Vec<Vec3> = (0..3000).map(|_| rng.unit_vector()).collect();
        let w = WindingNumber::new(&p, &p, &WindingOptions::default()).unwrap();
        for q in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.1), DVec3::splat(2.0)] {
            let (a, b) = (w.value(q), w.exact(q));
            // The expansions stop at first order, so the error falls like 1/beta²: at the
            // centre 0.086 at beta 2, 0.026 at 4, 0.006 at 8 (every sample at distance 1,
            // the worst case: each level's nodes sit at the acceptance boundary).
            assert!((a - b).abs() < 0.1, "{q}: {a} vs {b}");
            let fine = WindingNumber::with_areas(&p, &p, &point_areas(&p, &p, 16).unwrap(), 8.0)
                .unwrap()
                .value(q);
            assert!((fine - b).abs() < 0.01, "{q}: {fine} vs {b}");
        }
        assert!((w.exact(DVec3::ZERO) - 1.0).abs() < 0.02);
        assert!((w.value(DVec3::ZERO) - 1.0).abs() < 0.1);
        assert!(w.value(DVec3::splat(2.0)).abs() < 0.02);
        assert!(w.value(DVec3::NAN).is_nan());
        assert!(WindingNumber::with_areas(&p, &p, &vec![-1.0; p.len()], 2.0).is_err());
        assert!(WindingNumber::with_areas(&p, &p, &vec![1.0; p.len()], 0.0).is_err());
    }
}
