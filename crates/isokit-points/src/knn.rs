//! Nearest samples: a static kd-tree over the samples in f64, built for the many k-nearest
//! queries (k up to a few dozen, one per sample and one per evaluation) that the partition
//! of unity makes.
//!
//! The tree is implicit. Every inner node halves its samples by count at the median of its
//! widest axis, all leaves lie at one depth (8–16 samples each beyond 16 samples), and the
//! children of node `i` are `2i + 1` and `2i + 2`; it stores the samples in leaf order and
//! the bounding box of every node's samples. A query descends into the child whose box is
//! nearer first, and into a child at all only when the squared distance from the query to
//! its box does not exceed the k-th distance found so far. The k best are kept in a max-heap. Boxes of the samples,
//! not the cells between split planes: samples of a surface fill thin boxes, and the cells
//! around them reach far off the surface, where the band's queries lie (cells made the
//! 64-nearest queries of a narrow band visit 79 leaves each, boxes 22, and 19 when bounded by
//! the previous sample's answer).
//!
//! Answers are exact and do not depend on the tree's shape, ties included: the k samples
//! smallest by (squared distance, index). A box's distance is summed in the same order as a
//! sample's distance from per-axis gaps that are never larger, so in floating point it never
//! exceeds the distance of a sample inside the box, and the search never skips a sample that
//! belongs to the answer.

use crate::PointsError;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Largest number of samples in a leaf (leaves hold between half of it and it).
const LEAF: usize = 16;

/// A static kd-tree over the samples, answering k-nearest and radius queries in f64.
pub struct Knn {
    /// Number of inner nodes; leaves follow them in heap order.
    inner: usize,
    /// Where each leaf's samples start in `pts`, and one more entry: the sample count.
    leaf_start: Vec<u32>,
    /// The samples in leaf order.
    pts: Vec<[f64; 3]>,
    /// Their indices in the caller's order.
    idx: Vec<u32>,
    /// Where each of the caller's samples lies in `pts`.
    pos_of: Vec<u32>,
    /// The bounding box of every node's samples (inner nodes, then leaves, in heap order),
    /// as `[min x, min y, min z, max x, max y, max z]`.
    boxes: Vec<[f64; 6]>,
}

impl std::fmt::Debug for Knn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Knn")
            .field("len", &self.pts.len())
            .field("leaves", &(self.leaf_start.len() - 1))
            .finish()
    }
}

/// One sample with its caller's index, while the tree is built.
type Item = ([f64; 3], u32);

/// The bounding box of points, `[min x, min y, min z, max x, max y, max z]` (inverted and
/// infinite for none).
fn bbox<'a>(points: impl Iterator<Item = &'a [f64; 3]>) -> [f64; 6] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in points {
        for a in 0..3 {
            b[a] = b[a].min(p[a]);
            b[a + 3] = b[a + 3].max(p[a]);
        }
    }
    b
}

/// Orders the samples of one node around the median of its widest axis (the first
/// `len / 2` samples end up at or below it, the others at or above it) and returns the
/// node's box, which chose the axis.
fn split_node(s: &mut [Item]) -> [f64; 6] {
    let b = bbox(s.iter().map(|it| &it.0));
    let ext = [b[3] - b[0], b[4] - b[1], b[5] - b[2]];
    let a = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let mid = s.len() / 2;
    if mid < s.len() {
        s.select_nth_unstable_by(mid, |x, y| x.0[a].total_cmp(&y.0[a]));
    }
    b
}

thread_local! {
    /// The heap of [`Knn::nearest_bounded`]'s searches, one per thread: the evaluations make
    /// millions of queries, and a heap allocated per query cost 2% of their instructions.
    static HEAP: std::cell::RefCell<Vec<(u64, u32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The k best samples seen so far: a binary max-heap of (squared distance as bits, index).
/// Squared distances are never negative, and for those the bits order as the values do.
struct Best<'a> {
    k: usize,
    heap: &'a mut Vec<(u64, u32)>,
    /// Squared distance a sample or box must not exceed to be looked at: the bound the
    /// search started with until k samples are held, then the k-th best.
    limit: f64,
}

impl<'a> Best<'a> {
    fn new(k: usize, heap: &'a mut Vec<(u64, u32)>, bound: f64) -> Self {
        heap.clear();
        heap.reserve(k);
        Self {
            k,
            heap,
            limit: bound,
        }
    }

    #[inline]
    fn offer(&mut self, d2: f64, i: u32) {
        let key = (d2.to_bits(), i);
        let h = &mut *self.heap;
        if h.len() < self.k {
            h.push(key);
            let mut c = h.len() - 1;
            while c > 0 {
                let p = (c - 1) / 2;
                if h[c] <= h[p] {
                    break;
                }
                h.swap(c, p);
                c = p;
            }
        } else if key < h[0] {
            h[0] = key;
            let n = h.len();
            let mut p = 0;
            loop {
                let l = 2 * p + 1;
                if l >= n {
                    break;
                }
                let c = if l + 1 < n && h[l + 1] > h[l] {
                    l + 1
                } else {
                    l
                };
                if h[c] <= h[p] {
                    break;
                }
                h.swap(c, p);
                p = c;
            }
        } else {
            return;
        }
        if h.len() == self.k {
            self.limit = f64::from_bits(h[0].0);
        }
    }
}

#[inline]
fn dist2(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    let (dx, dy, dz) = (p[0] - q[0], p[1] - q[1], p[2] - q[2]);
    dx * dx + dy * dy + dz * dz
}

impl Knn {
    /// Builds the tree. The points must be finite (checked by the callers) and fewer than
    /// 2^32.
    pub fn new(points: &[Vec3]) -> Result<Self, PointsError> {
        if points.is_empty() {
            return Err(PointsError::Empty);
        }
        if points.len() > u32::MAX as usize {
            return Err(PointsError::Parameter(format!(
                "{} points exceed the 2^32 limit of the tree",
                points.len()
            )));
        }
        let n = points.len();
        let mut depth = 0;
        while n.div_ceil(1 << depth) > LEAF {
            depth += 1;
        }
        let inner = (1usize << depth) - 1;
        let mut items: Vec<Item> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (p.as_dvec3().to_array(), i as u32))
            .collect();
        // The ranges of one level's nodes: node m of the level holds bounds[m]..bounds[m + 1].
        // A level's nodes follow each other in heap order, so their boxes are pushed level by
        // level, the leaves' last.
        let mut bounds = vec![0, n];
        let mut boxes: Vec<[f64; 6]> = Vec::with_capacity(2 * inner + 1);
        for _ in 0..depth {
            let mut slices = Vec::with_capacity(bounds.len() - 1);
            let mut rest = &mut items[..];
            for w in bounds.windows(2) {
                let (node, tail) = rest.split_at_mut(w[1] - w[0]);
                slices.push(node);
                rest = tail;
            }
            boxes.par_extend(slices.into_par_iter().map(split_node));
            let mut next = Vec::with_capacity(2 * bounds.len() - 1);
            for w in bounds.windows(2) {
                next.push(w[0]);
                next.push(w[0] + (w[1] - w[0]) / 2);
            }
            next.push(n);
            bounds = next;
        }
        let pts: Vec<[f64; 3]> = items.iter().map(|it| it.0).collect();
        let mut pos_of = vec![0u32; n];
        for (at, it) in items.iter().enumerate() {
            pos_of[it.1 as usize] = at as u32;
        }
        boxes.par_extend(bounds.par_windows(2).map(|w| bbox(pts[w[0]..w[1]].iter())));
        Ok(Self {
            inner,
            leaf_start: bounds.into_iter().map(|b| b as u32).collect(),
            pts,
            idx: items.iter().map(|it| it.1).collect(),
            pos_of,
            boxes,
        })
    }

    /// Number of samples in the tree.
    pub fn len(&self) -> usize {
        self.pts.len()
    }

    /// True when the tree holds no samples (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.pts.is_empty()
    }

    fn leaf(&self, node: usize) -> std::ops::Range<usize> {
        let l = node - self.inner;
        self.leaf_start[l] as usize..self.leaf_start[l + 1] as usize
    }

    /// Squared distance from `q` to the box of node `node`'s samples. Summed in the same
    /// order as [`dist2`] from per-axis gaps no larger than a sample's, so it never exceeds
    /// the distance of a sample in the box.
    #[inline]
    fn box_dist2(&self, node: usize, q: &[f64; 3]) -> f64 {
        let b = &self.boxes[node];
        let g = |a: usize| (b[a] - q[a]).max(q[a] - b[a + 3]).max(0.0);
        let (gx, gy, gz) = (g(0), g(1), g(2));
        gx * gx + gy * gy + gz * gz
    }

    /// Visits the samples of the subtree at `node` that may be among the best, nearer
    /// child first.
    fn search(&self, node: usize, q: &[f64; 3], best: &mut Best<'_>) {
        if node >= self.inner {
            let r = self.leaf(node);
            for (p, &i) in self.pts[r.clone()].iter().zip(&self.idx[r]) {
                let d2 = dist2(p, q);
                if d2 <= best.limit {
                    best.offer(d2, i);
                }
            }
            return;
        }
        let (l, r) = (2 * node + 1, 2 * node + 2);
        let (dl, dr) = (self.box_dist2(l, q), self.box_dist2(r, q));
        let ((n, dn), (f, df)) = if dl <= dr {
            ((l, dl), (r, dr))
        } else {
            ((r, dr), (l, dl))
        };
        if dn <= best.limit {
            self.search(n, q, best);
        }
        if df <= best.limit {
            self.search(f, q, best);
        }
    }

    /// The `k` nearest samples of `p` (fewer when the tree holds fewer), as (index, squared
    /// distance) sorted by distance (ties by index), written into `out`. A non-finite `p`
    /// gets the first `k` samples with NaN distances.
    pub fn nearest(&self, p: DVec3, k: usize, out: &mut Vec<(usize, f64)>) {
        self.nearest_bounded(p, k, f64::INFINITY, out);
    }

    /// [`Knn::nearest`] where `out` holds on entry the answer for an earlier point, best a
    /// nearby one (the previous sample of a grid): the search starts bounded by the largest
    /// distance from `p` to the first `k` of those samples, so it visits only the part of the
    /// tree that can hold the answer. The answer is the same whatever `out` holds: with fewer
    /// than `k` entries, an index outside the tree, or repeated indices (fewer than `k`
    /// samples within the bound) the search is unbounded.
    pub fn nearest_again(&self, p: DVec3, k: usize, out: &mut Vec<(usize, f64)>) {
        let k = k.min(self.len());
        let q = p.to_array();
        let mut bound = f64::INFINITY;
        if k > 0 && out.len() >= k {
            bound = 0.0;
            for &(j, _) in &out[..k] {
                match self.pos_of.get(j) {
                    Some(&at) => bound = bound.max(dist2(&self.pts[at as usize], &q)),
                    None => bound = f64::INFINITY,
                }
            }
        }
        self.nearest_bounded(p, k, bound, out);
        if out.len() < k && bound < f64::INFINITY {
            self.nearest_bounded(p, k, f64::INFINITY, out);
        }
    }

    fn nearest_bounded(&self, p: DVec3, k: usize, bound: f64, out: &mut Vec<(usize, f64)>) {
        out.clear();
        let k = k.min(self.len());
        if !p.is_finite() {
            out.extend((0..k).map(|i| (i, f64::NAN)));
            return;
        }
        if k == 0 {
            return;
        }
        HEAP.with_borrow_mut(|heap| {
            let mut best = Best::new(k, heap, bound);
            self.search(0, &p.to_array(), &mut best);
            // By distance, then the runs of equal distances by index (rare): the same order
            // as sorting the (distance, index) pairs, in fewer instructions (one integer
            // compare per step instead of a pair).
            heap.sort_unstable_by_key(|e| e.0);
            let mut run = 0;
            for i in 1..=heap.len() {
                if i == heap.len() || heap[i].0 != heap[run].0 {
                    if i - run > 1 {
                        heap[run..i].sort_unstable_by_key(|e| e.1);
                    }
                    run = i;
                }
            }
            out.extend(heap.iter().map(|&(d2, i)| (i as usize, f64::from_bits(d2))));
        });
    }

    /// The nearest sample of `p`: (index, squared distance); the lowest index among equally
    /// near ones. A non-finite `p` gets sample 0 at a NaN distance.
    pub fn nearest_one(&self, p: DVec3) -> (usize, f64) {
        if !p.is_finite() {
            return (0, f64::NAN);
        }
        let mut heap = Vec::new();
        let mut best = Best::new(1, &mut heap, f64::INFINITY);
        self.search(0, &p.to_array(), &mut best);
        (heap[0].1 as usize, f64::from_bits(heap[0].0))
    }

    fn within_rec(&self, node: usize, q: &[f64; 3], r2: f64, out: &mut Vec<(usize, f64)>) {
        if node >= self.inner {
            for i in self.leaf(node) {
                let d2 = dist2(&self.pts[i], q);
                if d2 <= r2 {
                    out.push((self.idx[i] as usize, d2));
                }
            }
            return;
        }
        for c in [2 * node + 1, 2 * node + 2] {
            if self.box_dist2(c, q) <= r2 {
                self.within_rec(c, q, r2, out);
            }
        }
    }

    /// All samples within distance `sqrt(r2)` of `p` (unsorted), as (index, squared distance).
    pub fn within(&self, p: DVec3, r2: f64, out: &mut Vec<(usize, f64)>) {
        out.clear();
        let q = p.to_array();
        if p.is_finite() && self.box_dist2(0, &q) <= r2 {
            self.within_rec(0, &q, r2, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::rng::SplitMix64;

    /// The k smallest (squared distance, index) by brute force.
    fn brute(pts: &[Vec3], q: DVec3, k: usize) -> Vec<(usize, f64)> {
        let mut all: Vec<(usize, f64)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| (i, dist2(&p.as_dvec3().to_array(), &q.to_array())))
            .collect();
        all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        all.truncate(k);
        all
    }

    fn clouds() -> Vec<Vec<Vec3>> {
        let mut rng = SplitMix64::new(5);
        let mut u = || rng.next_f32();
        let random: Vec<Vec3> = (0..3000)
            .map(|_| Vec3::new(u(), u(), u()) * 2.0 - 1.0)
            .collect();
        // A sphere's surface, a regular lattice (many exact ties) with repeated points, one
        // point, and a plane (zero extent along z).
        let sphere: Vec<Vec3> = random.iter().map(|p| p.normalize_or_zero()).collect();
        let mut lattice: Vec<Vec3> = (0..1000)
            .map(|i| Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32))
            .collect();
        lattice.extend_from_within(..50);
        let plane: Vec<Vec3> = (0..500)
            .map(|i| Vec3::new((i % 25) as f32 * 0.1, (i / 25) as f32 * 0.1, 0.0))
            .collect();
        vec![random, sphere, lattice, vec![Vec3::ONE], plane]
    }

    /// k-nearest, nearest-one and radius queries equal brute force exactly, ties included,
    /// at random points and at the samples themselves.
    #[test]
    fn queries_equal_brute_force() {
        let mut rng = SplitMix64::new(9);
        for pts in clouds() {
            let knn = Knn::new(&pts).unwrap();
            assert_eq!(knn.len(), pts.len());
            let mut queries: Vec<DVec3> = (0..200)
                .map(|_| {
                    DVec3::new(
                        rng.next_f32() as f64 * 12.0 - 2.0,
                        rng.next_f32() as f64 * 12.0 - 2.0,
                        rng.next_f32() as f64 * 12.0 - 2.0,
                    ) * 0.25
                })
                .collect();
            queries.extend(pts.iter().step_by(7).map(|p| p.as_dvec3()));
            queries.extend(pts.iter().step_by(11).map(|p| p.as_dvec3().round()));
            let mut out = Vec::new();
            for q in queries {
                for k in [1, 2, 16, 64, pts.len() + 3] {
                    let want = brute(&pts, q, k);
                    knn.nearest(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}");
                    // Bounded by the answer at a nearby point, by its own answer, by an
                    // arbitrary set, by too few samples: the same answer.
                    knn.nearest(q + DVec3::new(0.03, -0.02, 0.01), k, &mut out);
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from a nearby answer");
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from its own answer");
                    out.clear();
                    out.extend((0..pts.len()).rev().step_by(3).map(|i| (i, 0.0)));
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from far samples");
                    out.truncate(k.saturating_sub(1));
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from too few");
                    out = vec![(0, 0.0); k];
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from one sample repeated");
                    out = vec![(pts.len() + 5, 0.0); k];
                    knn.nearest_again(q, k, &mut out);
                    assert_eq!(out, want, "k {k} at {q}, from indices outside the tree");
                }
                let (i, d2) = knn.nearest_one(q);
                assert_eq!(vec![(i, d2)], brute(&pts, q, 1));
                let r2 = brute(&pts, q, 20.min(pts.len())).last().unwrap().1;
                knn.within(q, r2, &mut out);
                out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                let mut all = brute(&pts, q, pts.len());
                all.retain(|&(_, d)| d <= r2);
                assert_eq!(out, all);
            }
        }
    }

    /// An empty cloud is an error; a non-finite query gets NaN distances, nothing within
    /// a radius, and no panic.
    #[test]
    fn empty_clouds_and_nan_queries() {
        assert!(Knn::new(&[]).is_err());
        let knn = Knn::new(&[Vec3::ZERO, Vec3::ONE, Vec3::X]).unwrap();
        let mut out = Vec::new();
        for q in [DVec3::NAN, DVec3::new(0.0, f64::INFINITY, 0.0)] {
            knn.nearest(q, 2, &mut out);
            assert!(
                out.len() == 2 && out.iter().all(|o| o.1.is_nan()),
                "{out:?}"
            );
            knn.nearest_again(q, 2, &mut out);
            assert!(
                out.len() == 2 && out.iter().all(|o| o.1.is_nan()),
                "{out:?}"
            );
            assert!(knn.nearest_one(q).1.is_nan());
            knn.within(q, 1e300, &mut out);
            assert!(out.is_empty());
        }
    }
}
