//! Normal estimation: PCA over the k nearest samples, then a consistent orientation by
//! propagation over a minimum spanning tree of the k-nearest graph (Hoppe et al. 1992).

use crate::eigen::symmetric_eigen;
use crate::knn::Knn;
use crate::{PointsError, check_points};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Knobs of [`estimate_normals`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalOptions {
    /// Neighbours per point, the point itself included (clamped to the cloud size).
    pub k: usize,
    /// A normal is reported unreliable when the surface variation `λ0/(λ0+λ1+λ2)` of its
    /// neighbourhood (λ0 the smallest eigenvalue of the covariance) exceeds this. 0 for a
    /// plane, 1/3 for an isotropic blob.
    pub max_variation: f64,
}

impl Default for NormalOptions {
    fn default() -> Self {
        Self {
            k: 16,
            max_variation: 0.1,
        }
    }
}

/// Estimated normals and what is known about their quality.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalReport {
    /// One unit normal per input point, consistently oriented within each connected
    /// component of the k-nearest graph.
    pub normals: Vec<Vec3>,
    /// Surface variation `λ0/(λ0+λ1+λ2)` per point (0 when all neighbours coincide).
    pub variation: Vec<f32>,
    /// Points whose normal is unreliable: surface variation above the threshold, or a
    /// neighbourhood that spans no plane (all neighbours coincident or collinear).
    pub unreliable: Vec<usize>,
    /// Connected components of the symmetric k-nearest graph; each was seeded separately
    /// at its point of largest x, oriented towards +x.
    pub components: usize,
    /// Normals flipped by the propagation (relative to the sign PCA returned).
    pub flipped: usize,
    /// The k actually used (the requested one, clamped to the cloud size).
    pub k: usize,
}

impl NormalReport {
    /// Fraction of unreliable normals.
    pub fn unreliable_fraction(&self) -> f64 {
        self.unreliable.len() as f64 / self.normals.len().max(1) as f64
    }
}

/// Estimates a unit normal per point and orients them consistently.
///
/// PCA: the normal is the eigenvector of the smallest eigenvalue of the covariance of the
/// `k` nearest samples (f64). Orientation: Prim's minimum spanning tree over the symmetric
/// k-nearest graph with edge weight `1 − |n_i·n_j|`, seeded at the point of largest x whose
/// normal is turned towards +x (ties: +y, then +z); each new vertex's normal is flipped to
/// agree with its tree parent. Components the graph leaves disconnected are seeded the same
/// way, one after the other.
///
/// Errors: an empty cloud, fewer than 3 points, or a non-finite coordinate.
pub fn estimate_normals(
    points: &[Vec3],
    opts: &NormalOptions,
) -> Result<NormalReport, PointsError> {
    check_points(points)?;
    if points.len() < 3 {
        return Err(PointsError::TooFewPoints {
            what: "normal estimation",
            need: 3,
            have: points.len(),
        });
    }
    if opts.k < 3 {
        return Err(PointsError::Parameter(format!(
            "k = {} for normals: at least 3 neighbours are needed to fit a plane",
            opts.k
        )));
    }
    if !(opts.max_variation.is_finite() && opts.max_variation >= 0.0) {
        return Err(PointsError::Parameter(format!(
            "max_variation {} must be finite and non-negative",
            opts.max_variation
        )));
    }
    let k = opts.k.min(points.len());
    let knn = Knn::new(points)?;
    let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();

    // PCA per point, and the neighbour lists for the graph.
    struct Local {
        normal: DVec3,
        variation: f64,
        degenerate: bool,
        nbrs: Vec<u32>,
    }
    let locals: Vec<Local> = pts
        .par_iter()
        .map_init(Vec::new, |buf, &p| {
            knn.nearest_again(p, k, buf);
            let n = buf.len() as f64;
            let mean = buf.iter().map(|&(j, _)| pts[j]).sum::<DVec3>() / n;
            let mut c = [[0.0f64; 3]; 3];
            for &(j, _) in buf.iter() {
                let d = (pts[j] - mean).to_array();
                for r in 0..3 {
                    for s in r..3 {
                        c[r][s] += d[r] * d[s];
                    }
                }
            }
            let (l, v) = symmetric_eigen(c);
            let sum = l[0].max(0.0) + l[1].max(0.0) + l[2].max(0.0);
            let variation = if sum > 0.0 { l[0].max(0.0) / sum } else { 0.0 };
            // No plane: all neighbours coincide (sum 0) or lie on a line (λ1 ≈ 0).
            let degenerate = sum.is_nan() || sum <= 0.0 || l[1] <= 1e-12 * sum;
            Local {
                normal: DVec3::from_array(v[0]),
                variation,
                degenerate,
                nbrs: buf.iter().map(|&(j, _)| j as u32).collect(),
            }
        })
        .collect();

    let mut normals: Vec<DVec3> = locals.iter().map(|l| l.normal).collect();
    let unreliable: Vec<usize> = locals
        .iter()
        .enumerate()
        .filter(|(_, l)| l.degenerate || l.variation > opts.max_variation)
        .map(|(i, _)| i)
        .collect();
    let variation = locals.iter().map(|l| l.variation as f32).collect();

    // Symmetric adjacency.
    let n = pts.len();
    let mut adj: Vec<Vec<u32>> = locals.iter().map(|l| l.nbrs.clone()).collect();
    for (i, l) in locals.iter().enumerate() {
        for &j in &l.nbrs {
            if j as usize != i {
                adj[j as usize].push(i as u32);
            }
        }
    }
    drop(locals);

    // Seeds in order of decreasing x: each unvisited one starts a new component.
    let mut by_x: Vec<usize> = (0..n).collect();
    by_x.sort_by(|&a, &b| {
        pts[b]
            .x
            .total_cmp(&pts[a].x)
            .then(pts[b].y.total_cmp(&pts[a].y))
            .then(pts[b].z.total_cmp(&pts[a].z))
    });
    let mut visited = vec![false; n];
    let mut flipped = 0usize;
    let mut components = 0usize;
    let mut heap = BinaryHeap::new();
    for &seed in &by_x {
        if visited[seed] {
            continue;
        }
        components += 1;
        let s = normals[seed];
        let towards_plus = if s.x != 0.0 {
            s.x > 0.0
        } else if s.y != 0.0 {
            s.y > 0.0
        } else {
            s.z >= 0.0
        };
        if !towards_plus {
            normals[seed] = -s;
            flipped += 1;
        }
        heap.push(Edge {
            cost: 0.0,
            to: seed,
            from: seed,
        });
        while let Some(Edge { to, from, .. }) = heap.pop() {
            if visited[to] {
                continue;
            }
            visited[to] = true;
            if to != from && normals[to].dot(normals[from]) < 0.0 {
                normals[to] = -normals[to];
                flipped += 1;
            }
            let nt = normals[to];
            for &j in &adj[to] {
                let j = j as usize;
                if !visited[j] {
                    heap.push(Edge {
                        cost: 1.0 - nt.dot(normals[j]).abs(),
                        to: j,
                        from: to,
                    });
                }
            }
        }
    }

    Ok(NormalReport {
        normals: normals.iter().map(|v| v.as_vec3()).collect(),
        variation,
        unreliable,
        components,
        flipped,
        k,
    })
}

/// A candidate tree edge; the heap pops the cheapest first.
struct Edge {
    cost: f64,
    to: usize,
    from: usize,
}

impl PartialEq for Edge {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Edge {}
impl PartialOrd for Edge {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Edge {
    fn cmp(&self, o: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap. Ties by index keep the result deterministic.
        o.cost
            .total_cmp(&self.cost)
            .then(o.to.cmp(&self.to))
            .then(o.from.cmp(&self.from))
    }
}
