//! Measuring octrees: the error of a tree against its source at independent random points
//! near the surface, and Sigg 2006's Table 3.1 (random cell accesses in hashed and linked
//! octrees of increasing depth) on this machine.

use crate::{BuildOptions, Cell, HashedOctree, LinkedOctree, Octree, OctreeError};
use glam::Vec3;
use isokit_field::rng::SplitMix64;
use isokit_field::{Aabb, Field, TriMesh};

/// `n` random points within `band` of the surface: on the mesh's triangles moved by up to
/// `band` when a mesh is given, else by rejection from uniform points in `domain` (at most
/// 2000 rounds of 65536 candidates), kept only inside `domain`.
pub fn test_points(
    field: &dyn Field,
    mesh: Option<&TriMesh>,
    domain: Aabb,
    band: f32,
    n: usize,
    seed: u64,
) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    if let Some(mesh) = mesh.filter(|m| !m.triangles.is_empty()) {
        let mut out = Vec::with_capacity(n);
        let mut tries = 0;
        while out.len() < n && tries < 100 * n {
            tries += 1;
            let p = on_triangles(mesh, &mut r) + r.unit_vector() * (band * r.next_f32().cbrt());
            if domain.contains(p) {
                out.push(p);
            }
        }
        return out;
    }
    let mut out = Vec::with_capacity(n);
    for round in 0..2000 {
        // A million candidates without one near the surface: there is none to find.
        if out.len() >= n || (out.is_empty() && round >= 16) {
            break;
        }
        let cand: Vec<Vec3> = (0..65536)
            .map(|_| r.point_in(domain.min, domain.max))
            .collect();
        let mut v = vec![0.0f32; cand.len()];
        field.values(&cand, &mut v);
        out.extend(
            cand.iter()
                .zip(&v)
                .filter(|(_, v)| v.abs() <= band)
                .map(|(p, _)| *p),
        );
    }
    out.truncate(n);
    out
}

/// A uniformly random point on a random triangle of `mesh` (non-empty).
fn on_triangles(mesh: &TriMesh, r: &mut SplitMix64) -> Vec3 {
    let t = mesh.triangles[r.below(mesh.triangles.len())];
    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
    let (u, v) = (r.next_f32().sqrt(), r.next_f32());
    (1.0 - u) * a + u * (1.0 - v) * b + u * v * c
}

/// The error of a tree at test points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeErrors {
    /// Largest `|tree − field|` (NaN without points).
    pub max: f64,
    /// Root mean square of `|tree − field|` (NaN without points).
    pub rms: f64,
    /// The accessor's cell-cache hit rate over the points.
    pub cell_hit_rate: f64,
    /// The accessor's node-cache hit rate over the points.
    pub node_hit_rate: f64,
}

/// `|tree − field|` at `pts`, through one accessor (its cache hit rates too).
pub fn errors(tree: &HashedOctree, field: &dyn Field, pts: &[Vec3]) -> TreeErrors {
    let mut exact = vec![0.0f32; pts.len()];
    field.values(pts, &mut exact);
    let mut a = tree.accessor();
    let (mut max, mut sum) = (0.0f64, 0.0f64);
    for (&p, &e) in pts.iter().zip(&exact) {
        let d = (a.value(p) - e).abs() as f64;
        max = max.max(d);
        sum += d * d;
    }
    let none = pts.is_empty();
    TreeErrors {
        max: if none { f64::NAN } else { max },
        rms: if none {
            f64::NAN
        } else {
            (sum / pts.len() as f64).sqrt()
        },
        cell_hit_rate: a.cell_stats().hit_rate(),
        node_hit_rate: a.node_stats().hit_rate(),
    }
}

/// Where a tree misses an error bound at test points (see [`bound_misses`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundMiss {
    /// Leaves holding a test point where `|tree − field| > bound`.
    pub missed_cells: usize,
    /// Of those, leaves at the maximum level: there the maximum level, not the bound,
    /// stopped the refinement.
    pub missed_at_max_level: usize,
    /// The largest `|tree − field|` in a missed leaf at the maximum level (0 when none).
    pub worst_at_max_level: f64,
    /// The maximum level at which that worst miss would meet the bound, estimated from the
    /// trilinear reconstruction's `O(h²)` error (each level halves `h`, so quarters the
    /// error): `max_level + ceil(log4(worst / bound))`. `None` when no leaf at the maximum
    /// level misses, or for a bound of 0 (met at no level).
    pub level_for_bound: Option<u32>,
}

/// The leaves of `tree` that miss `bound` at one of `pts` (test points, e.g. from
/// [`test_points`]), and the maximum level that would meet it.
pub fn bound_misses(tree: &HashedOctree, field: &dyn Field, pts: &[Vec3], bound: f64) -> BoundMiss {
    let mut exact = vec![0.0f32; pts.len()];
    field.values(pts, &mut exact);
    let l = tree.domain().max_level();
    let mut a = tree.accessor();
    let mut cells = std::collections::HashSet::new();
    let mut worst = 0.0f64;
    for (&p, &e) in pts.iter().zip(&exact) {
        let d = (a.value(p) - e).abs() as f64;
        if d > bound {
            let c = tree.locate_binary(p);
            cells.insert((c.level, c.pos.to_array()));
            if c.level == l {
                worst = worst.max(d);
            }
        }
    }
    let at_max = cells.iter().filter(|(level, _)| *level == l).count();
    let level_for_bound = (at_max > 0 && bound > 0.0 && worst.is_finite())
        .then(|| l + ((worst / bound).log2() / 2.0).ceil().max(1.0) as u32);
    BoundMiss {
        missed_cells: cells.len(),
        missed_at_max_level: at_max,
        worst_at_max_level: worst,
        level_for_bound,
    }
}

/// One row of [`table_3_1`]: one dataset at one maximum level.
#[derive(Clone, Debug, PartialEq)]
pub struct AccessRow {
    /// The dataset's name.
    pub dataset: String,
    /// Maximum level.
    pub level: u32,
    /// Cells of the tree.
    pub cells: usize,
    /// Nodes of the tree.
    pub nodes: usize,
    /// Seconds to build the hashed tree.
    pub build_seconds: f64,
    /// Seconds to convert it to the linked tree.
    pub convert_seconds: f64,
    /// Mean level of the leaves found, counted from the finest.
    pub average_access_level_from_finest: f64,
    /// Fastest seconds for the accesses: hashed (top-down), hashed (binary search over
    /// levels), hashed through a cached accessor, linked.
    pub hashed_seconds: f64,
    /// See [`AccessRow::hashed_seconds`].
    pub hashed_binary_seconds: f64,
    /// See [`AccessRow::hashed_seconds`].
    pub hashed_cached_seconds: f64,
    /// The cached accessor's cell-cache hit rate.
    pub cell_cache_hit_rate: f64,
    /// See [`AccessRow::hashed_seconds`].
    pub linked_seconds: f64,
    /// Fastest seconds for trilinear values at the points, hashed and linked.
    pub hashed_value_seconds: f64,
    /// See [`AccessRow::hashed_value_seconds`].
    pub linked_value_seconds: f64,
    /// Bytes per cell of both trees (Sigg 2006, Sec. 3.2: the ratio is the claim, ERRATA 8).
    pub hashed_bytes_per_cell: f64,
    /// See [`AccessRow::hashed_bytes_per_cell`].
    pub linked_bytes_per_cell: f64,
}

/// Points near the surface: on the mesh's triangles, or on the unit sphere, moved by up to
/// `reach`.
fn access_points(mesh: Option<&TriMesh>, reach: f32, n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let on = match mesh {
                Some(m) => on_triangles(m, &mut r),
                None => r.unit_vector(),
            };
            on + r.unit_vector() * (reach * r.next_f32())
        })
        .collect()
}

/// Seconds for `locate` over all points on one thread, and a checksum of the cells found.
fn time_locate(pts: &[Vec3], mut locate: impl FnMut(Vec3) -> Cell) -> (f64, u64) {
    let t = std::time::Instant::now();
    let mut sum = 0u64;
    for &p in pts {
        let c = locate(p);
        sum = sum.wrapping_mul(31).wrapping_add(
            c.level as u64
                ^ ((c.pos.x as u64) << 8)
                ^ ((c.pos.y as u64) << 24)
                ^ ((c.pos.z as u64) << 40),
        );
    }
    (t.elapsed().as_secs_f64(), std::hint::black_box(sum))
}

/// Seconds for `value` over all points on one thread, and their sum.
fn time_value(pts: &[Vec3], mut value: impl FnMut(Vec3) -> f32) -> (f64, f64) {
    let t = std::time::Instant::now();
    let mut sum = 0.0f64;
    for &p in pts {
        sum += value(p) as f64;
    }
    (t.elapsed().as_secs_f64(), std::hint::black_box(sum))
}

/// Sigg 2006, Table 3.1 on this machine: for each dataset (a field, optionally its mesh for
/// the access points) and each maximum level, the thesis's construction (every cell the
/// surface may pass subdivided to the finest level, hanging nodes interpolated), `accesses`
/// random cell accesses near the surface timed on one thread in each variant (fastest of
/// `repeat`, interleaved so drift hits all alike), checked to find the same cells and values.
pub fn table_3_1(
    datasets: &[(&str, &dyn Field, Option<&TriMesh>)],
    levels: std::ops::RangeInclusive<u32>,
    accesses: usize,
    repeat: usize,
    seed: u64,
    mut report: impl FnMut(&AccessRow),
) -> Result<Vec<AccessRow>, OctreeError> {
    let mut rows = Vec::new();
    for &(name, field, m) in datasets {
        // A cube twice the object's longest side, centred on it.
        let b = field.bounds();
        let bounds = b.expanded(0.5 * b.size().max_element());
        let pts = access_points(m, 0.01 * b.diagonal(), accesses, seed);
        for level in levels.clone() {
            let opts = BuildOptions {
                refine_hanging: false,
                ..BuildOptions::new(level)
            };
            let h = HashedOctree::build(field, bounds, &opts)?;
            let t = std::time::Instant::now();
            let k = LinkedOctree::from_hashed(&h);
            let convert = t.elapsed().as_secs_f64();
            let mut best = [f64::INFINITY; 6];
            let mut hit_rate = 0.0;
            for _ in 0..repeat.max(1) {
                let (t0, hsum) = time_locate(&pts, |p| h.locate(p));
                let (t1, ksum) = time_locate(&pts, |p| k.locate(p));
                let (t2, bsum) = time_locate(&pts, |p| h.locate_binary(p));
                let mut acc = h.accessor();
                let (t3, csum) = time_locate(&pts, |p| acc.locate(p));
                hit_rate = acc.cell_stats().hit_rate();
                let (t4, hvs) = time_value(&pts, |p| h.value(p));
                let (t5, kvs) = time_value(&pts, |p| k.value(p));
                if hsum != ksum || bsum != ksum || csum != ksum || hvs.to_bits() != kvs.to_bits() {
                    return Err(OctreeError::bad(
                        "trees",
                        level,
                        "the hashed and linked trees disagree: this is a bug",
                    ));
                }
                for (b, t) in best.iter_mut().zip([t0, t1, t2, t3, t4, t5]) {
                    *b = b.min(t);
                }
            }
            let mean_level =
                pts.iter().map(|&p| h.locate(p).level as f64).sum::<f64>() / pts.len() as f64;
            let row = AccessRow {
                dataset: name.to_owned(),
                level,
                cells: h.cell_count(),
                nodes: h.node_count(),
                build_seconds: h.stats().seconds,
                convert_seconds: convert,
                average_access_level_from_finest: level as f64 - mean_level,
                hashed_seconds: best[0],
                linked_seconds: best[1],
                hashed_binary_seconds: best[2],
                hashed_cached_seconds: best[3],
                cell_cache_hit_rate: hit_rate,
                hashed_value_seconds: best[4],
                linked_value_seconds: best[5],
                hashed_bytes_per_cell: h.bytes_per_cell(),
                linked_bytes_per_cell: k.bytes_per_cell(),
            };
            report(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}
