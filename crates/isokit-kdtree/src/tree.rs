//! The kd-tree with overlapping siblings of 002 Sec. 4.1, over any primitives with a
//! bounding box.
//!
//! Every node stores two parallel planes on its split axis: the upper bound of its left
//! subtree and the lower bound of its right subtree. The planes may cross (the siblings
//! overlap), coincide (the classic kd-tree) or leave a gap. Primitives too big for either
//! child stay at the node; the others go down. With `max_overlap = 0` the tree is the
//! classic kd-tree with one split plane per node, the baseline it is measured against.
//!
//! The tree knows only boxes. Queries take a closure that measures one primitive, so the
//! same tree serves triangles, segments or points.

use glam::{DVec3, Vec3};
use isokit_field::Aabb;
use isokit_field::rng::SplitMix64;
use std::collections::BinaryHeap;

const NONE: u32 = u32::MAX;
/// Deepest level the builder creates; deeper subsets become leaves. Also bounds the
/// traversal stacks.
pub const MAX_DEPTH: usize = 60;
const STACK: usize = 2 * MAX_DEPTH + 4;

/// Construction knobs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildParams {
    /// Subsets of at most this many primitives become leaves (at least 1).
    pub leaf_size: usize,
    /// Largest sibling overlap, as a fraction of the node's extent along its split axis.
    /// `0` builds the classic kd-tree (one plane per node, straddling primitives stay at
    /// the node).
    pub max_overlap: f32,
    /// Size of the random sample whose median guesses the split plane.
    pub sample_size: usize,
    /// Seed of that sampling (construction is deterministic for a given seed).
    pub seed: u64,
}

impl Default for BuildParams {
    fn default() -> Self {
        Self {
            leaf_size: 16,
            max_overlap: 0.3,
            sample_size: 33,
            seed: isokit_field::rng::DEFAULT_SEED,
        }
    }
}

impl BuildParams {
    /// Largest leaf size [`BuildParams::check_leaf_size`] accepts.
    pub const MAX_LEAF_SIZE: usize = 1 << 16;

    /// A leaf size a user gave: 1 to [`BuildParams::MAX_LEAF_SIZE`].
    pub fn check_leaf_size(n: usize) -> Result<usize, String> {
        if (1..=Self::MAX_LEAF_SIZE).contains(&n) {
            Ok(n)
        } else {
            Err(format!("{n} must be 1 to {}", Self::MAX_LEAF_SIZE))
        }
    }

    /// A maximum overlap a user gave: a fraction of a node's extent, 0 to 1.
    pub fn check_max_overlap(x: f32) -> Result<f32, String> {
        if (0.0..=1.0).contains(&x) {
            Ok(x)
        } else {
            Err(format!(
                "{x} must be a fraction of the node's extent from 0 to 1"
            ))
        }
    }

    /// The classic kd-tree baseline (no overlap) with the same leaf size.
    pub fn classic() -> Self {
        Self {
            max_overlap: 0.0,
            ..Self::default()
        }
    }
}

/// Work counters of one or many queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QueryStats {
    /// Nodes whose primitives were examined.
    pub nodes_visited: u64,
    /// Primitives measured by the closure.
    pub prims_tested: u64,
}

impl std::ops::AddAssign for QueryStats {
    fn add_assign(&mut self, o: Self) {
        self.nodes_visited += o.nodes_visited;
        self.prims_tested += o.prims_tested;
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Upper bound of the left subtree on `axis`.
    left_max: f32,
    /// Lower bound of the right subtree on `axis`.
    right_min: f32,
    left: u32,
    right: u32,
    /// Primitives stored at this node: `order[first..first + count]`.
    first: u32,
    count: u32,
    axis: u8,
}

/// Shape statistics of a built tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    /// All nodes.
    pub nodes: usize,
    /// Nodes without children.
    pub leaves: usize,
    /// Deepest level (root = 0).
    pub depth: usize,
    /// Primitives stored at inner nodes (too big for either child).
    pub prims_at_inner_nodes: usize,
    /// Inner nodes whose siblings overlap (`left_max > right_min`).
    pub overlapping_nodes: usize,
    /// Bytes of nodes and the primitive order.
    pub bytes: usize,
}

/// A kd-tree with overlapping siblings over primitives given by their boxes.
#[derive(Clone, Debug)]
pub struct KdTree {
    nodes: Vec<Node>,
    /// Tight box of every node's subtree (its own primitives and all below), a second lower
    /// bound besides the planes.
    node_boxes: Vec<Aabb>,
    order: Vec<u32>,
    bounds: Aabb,
    params: BuildParams,
}

/// A traversal stack entry for point queries: node, squared lower bound, per-axis offsets
/// of the query point from the node's box.
#[derive(Clone, Copy)]
struct PointEntry {
    node: u32,
    /// The larger of the two lower bounds below.
    lb2: f64,
    /// Squared distance to the box the ancestors' planes cut out (kept apart: it is updated
    /// incrementally).
    plane2: f64,
    off: [f64; 3],
}

struct Builder<'a> {
    boxes: &'a [Aabb],
    centers: Vec<Vec3>,
    params: BuildParams,
    rng: SplitMix64,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl KdTree {
    /// Builds the tree over primitives with the given boxes. Each box must contain its
    /// primitive (queries use box distances as lower bounds). Primitives with non-finite or
    /// empty boxes are left out (they can never be found); the ids the queries report are
    /// indices into `boxes`.
    pub fn build(boxes: &[Aabb], params: BuildParams) -> Self {
        let params = BuildParams {
            leaf_size: params.leaf_size.max(1),
            max_overlap: if params.max_overlap.is_finite() {
                params.max_overlap.max(0.0)
            } else {
                0.0
            },
            sample_size: params.sample_size.clamp(1, 1025),
            seed: params.seed,
        };
        let ids: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| {
                let b = &boxes[i as usize];
                b.is_finite() && !b.is_empty()
            })
            .collect();
        let bounds = ids
            .iter()
            .fold(Aabb::EMPTY, |acc, &i| acc.union(&boxes[i as usize]));
        let mut b = Builder {
            boxes,
            centers: boxes.iter().map(|b| b.center()).collect(),
            params,
            rng: SplitMix64::new(params.seed),
            nodes: Vec::with_capacity(2 * ids.len() / params.leaf_size + 1),
            order: Vec::with_capacity(ids.len()),
        };
        if !ids.is_empty() {
            b.build(ids, 0);
        }
        // Children have larger indices than their parent: fill boxes bottom-up.
        let mut node_boxes = vec![Aabb::EMPTY; b.nodes.len()];
        for i in (0..b.nodes.len()).rev() {
            let n = b.nodes[i];
            let own = b.order[n.first as usize..(n.first + n.count) as usize]
                .iter()
                .fold(Aabb::EMPTY, |acc, &id| acc.union(&boxes[id as usize]));
            node_boxes[i] = [n.left, n.right]
                .into_iter()
                .filter(|&c| c != NONE)
                .fold(own, |acc, c| acc.union(&node_boxes[c as usize]));
        }
        Self {
            nodes: b.nodes,
            node_boxes,
            order: b.order,
            bounds,
            params,
        }
    }

    /// The parameters it was built with (after clamping).
    pub fn params(&self) -> BuildParams {
        self.params
    }

    /// Box of all primitives in the tree.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Number of primitives in the tree.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True when the tree holds no primitive.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Shape statistics.
    pub fn stats(&self) -> TreeStats {
        let mut s = TreeStats {
            nodes: self.nodes.len(),
            bytes: self.nodes.len() * (size_of::<Node>() + size_of::<Aabb>())
                + self.order.len() * 4,
            ..Default::default()
        };
        let mut stack = vec![(0u32, 0usize)];
        while let Some((n, d)) = stack.pop() {
            let Some(node) = self.nodes.get(n as usize) else {
                continue;
            };
            s.depth = s.depth.max(d);
            if node.left == NONE && node.right == NONE {
                s.leaves += 1;
            } else {
                s.prims_at_inner_nodes += node.count as usize;
                if node.left != NONE && node.right != NONE && node.left_max > node.right_min {
                    s.overlapping_nodes += 1;
                }
            }
            for c in [node.left, node.right] {
                if c != NONE {
                    stack.push((c, d + 1));
                }
            }
        }
        s
    }

    /// Calls `visit` with every node's box, depth and the ids stored there, parents before
    /// children. Used to attach per-node data (e.g. winding-number expansions): node `n` of
    /// the callback is the `n`-th call.
    pub fn for_each_node(&self, mut visit: impl FnMut(usize, &[u32], [Option<usize>; 2])) {
        for (n, node) in self.nodes.iter().enumerate() {
            let ids = &self.order[node.first as usize..(node.first + node.count) as usize];
            let kid = |c: u32| (c != NONE).then_some(c as usize);
            visit(n, ids, [kid(node.left), kid(node.right)]);
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The ids stored at node `n` and its children (`None` where absent).
    pub fn node(&self, n: usize) -> (&[u32], [Option<usize>; 2]) {
        let node = &self.nodes[n];
        let kid = |c: u32| (c != NONE).then_some(c as usize);
        (
            &self.order[node.first as usize..(node.first + node.count) as usize],
            [kid(node.left), kid(node.right)],
        )
    }

    fn root_entry(&self, p: DVec3) -> PointEntry {
        let (lo, hi) = (self.bounds.min.as_dvec3(), self.bounds.max.as_dvec3());
        let off: [f64; 3] = std::array::from_fn(|a| (lo[a] - p[a]).max(p[a] - hi[a]).max(0.0));
        let lb2 = off.iter().map(|o| o * o).sum();
        PointEntry {
            node: 0,
            lb2,
            plane2: lb2,
            off,
        }
    }

    /// Pushes the children of `node` (far first, so the near child pops first) with their
    /// incremental lower bounds, skipping those at or beyond `bound2`.
    #[inline]
    fn push_children(
        &self,
        e: &PointEntry,
        node: &Node,
        p: DVec3,
        bound2: f64,
        stack: &mut Vec<PointEntry>,
    ) {
        let a = node.axis as usize;
        let x = p[a];
        let child = |c: u32, plane_off: f64| {
            let o = e.off[a].max(plane_off);
            let mut off = e.off;
            off[a] = o;
            let plane2 = e.plane2 - e.off[a] * e.off[a] + o * o;
            // The subtree's own tight box is never looser than the planes' box.
            let b = &self.node_boxes[c as usize];
            let lo = b.min.as_dvec3() - p;
            let hi = p - b.max.as_dvec3();
            let box2 = lo.max(hi).max(DVec3::ZERO).length_squared();
            PointEntry {
                node: c,
                lb2: plane2.max(box2),
                plane2,
                off,
            }
        };
        let left = (node.left != NONE).then(|| child(node.left, x - node.left_max as f64));
        let right = (node.right != NONE).then(|| child(node.right, node.right_min as f64 - x));
        let left_near = x <= 0.5 * (node.left_max as f64 + node.right_min as f64);
        let (near, far) = if left_near {
            (left, right)
        } else {
            (right, left)
        };
        for c in [far, near].into_iter().flatten() {
            if c.lb2 < bound2 {
                stack.push(c);
            }
        }
    }

    /// The primitive nearest to `p` among those closer than `sqrt(max_dist2)`, with its
    /// squared distance. `dist2(id, bound)` measures one primitive; it may return any value
    /// `>= bound` for a primitive it can tell is farther than `bound` (e.g. by its box). Pass `f64::INFINITY` for an
    /// unbounded search; a finite bound makes narrow-band queries exit early.
    pub fn nearest(
        &self,
        p: DVec3,
        max_dist2: f64,
        mut dist2: impl FnMut(u32, f64) -> f64,
        stats: &mut QueryStats,
    ) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        self.walk_point(p, max_dist2, stats, |id, bound| {
            let d = dist2(id, bound);
            if d < bound {
                best = Some((id, d));
                d
            } else {
                bound
            }
        });
        best
    }

    /// The `k` primitives nearest to `p` (fewer if the tree is smaller), sorted by distance,
    /// as `(id, squared distance)`. `dist2` as for [`KdTree::nearest`].
    pub fn k_nearest(
        &self,
        p: DVec3,
        k: usize,
        mut dist2: impl FnMut(u32, f64) -> f64,
        stats: &mut QueryStats,
    ) -> Vec<(u32, f64)> {
        #[derive(PartialEq)]
        struct Item(f64, u32);
        impl Eq for Item {}
        impl PartialOrd for Item {
            fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Item {
            fn cmp(&self, o: &Self) -> std::cmp::Ordering {
                self.0.total_cmp(&o.0).then(self.1.cmp(&o.1))
            }
        }
        if k == 0 {
            return Vec::new();
        }
        let mut heap: BinaryHeap<Item> = BinaryHeap::with_capacity(k + 1);
        self.walk_point(p, f64::INFINITY, stats, |id, bound| {
            let d = dist2(id, bound);
            if d < bound {
                heap.push(Item(d, id));
                if heap.len() > k {
                    heap.pop();
                }
            }
            // The k-th distance once k are found.
            if heap.len() < k {
                f64::INFINITY
            } else {
                heap.peek().map_or(f64::INFINITY, |i| i.0)
            }
        });
        heap.into_sorted_vec()
            .into_iter()
            .map(|Item(d, id)| (id, d))
            .collect()
    }

    /// Every primitive within distance `radius` of `p` (inclusive), unsorted, as
    /// `(id, squared distance)`. `dist2` as for [`KdTree::nearest`].
    pub fn within(
        &self,
        p: DVec3,
        radius: f64,
        mut dist2: impl FnMut(u32, f64) -> f64,
        stats: &mut QueryStats,
    ) -> Vec<(u32, f64)> {
        let mut out = Vec::new();
        if radius.is_nan() || radius < 0.0 {
            return out;
        }
        let r2 = radius * radius;
        // Pruning at a bound a hair above r² keeps primitives exactly at the radius.
        let bound = r2 * (1.0 + 1e-12) + f64::MIN_POSITIVE;
        self.walk_point(p, bound, stats, |id, bound| {
            let d = dist2(id, bound);
            if d <= r2 {
                out.push((id, d));
            }
            bound
        });
        out
    }

    /// The depth-first walk behind the point queries, near child first: `visit(id, bound)`
    /// measures one primitive of a node whose lower bound is below the current bound and
    /// returns the new bound; nodes and children at or beyond it are skipped.
    fn walk_point(
        &self,
        p: DVec3,
        mut bound: f64,
        stats: &mut QueryStats,
        mut visit: impl FnMut(u32, f64) -> f64,
    ) {
        if self.nodes.is_empty() || p.is_nan() {
            return;
        }
        let mut stack = Vec::with_capacity(STACK);
        stack.push(self.root_entry(p));
        while let Some(e) = stack.pop() {
            if e.lb2 >= bound {
                continue;
            }
            let node = &self.nodes[e.node as usize];
            stats.nodes_visited += 1;
            for &id in &self.order[node.first as usize..(node.first + node.count) as usize] {
                stats.prims_tested += 1;
                bound = visit(id, bound);
            }
            self.push_children(&e, node, p, bound, &mut stack);
        }
    }

    /// The first primitive hit by the ray `origin + t * dir` for `t` in `[0, t_max]`.
    /// `hit(id, t_best)` returns the ray parameter of a hit closer than `t_best`, if any.
    pub fn ray_first(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_max: f64,
        hit: impl FnMut(u32, f64) -> Option<f64>,
        stats: &mut QueryStats,
    ) -> Option<(u32, f64)> {
        self.ray_first_in(origin, dir, 0.0, t_max, hit, stats)
    }

    /// [`KdTree::ray_first`] for `t` in `[t_min, t_max]`: nodes the ray has left before
    /// `t_min` are not visited (`hit` must still refuse hits before `t_min`: a node's
    /// interval is only as exact as the rounding of its planes).
    pub fn ray_first_in(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        mut hit: impl FnMut(u32, f64) -> Option<f64>,
        stats: &mut QueryStats,
    ) -> Option<(u32, f64)> {
        if self.nodes.is_empty() || !origin.is_finite() || !dir.is_finite() || dir == DVec3::ZERO {
            return None;
        }
        // Clip against the root box; the start held back a little against rounding.
        let (lo, hi) = (self.bounds.min.as_dvec3(), self.bounds.max.as_dvec3());
        let start = if t_min > 0.0 {
            t_min - 1e-9 * (1.0 + t_min)
        } else {
            0.0
        };
        let (mut t0, mut t1) = (start.max(0.0), t_max);
        for a in 0..3 {
            if dir[a] == 0.0 {
                if origin[a] < lo[a] || origin[a] > hi[a] {
                    return None;
                }
            } else {
                let (ta, tb) = ((lo[a] - origin[a]) / dir[a], (hi[a] - origin[a]) / dir[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0 > t1 {
            return None;
        }
        let mut best: Option<(u32, f64)> = None;
        let mut best_t = t_max;
        let mut stack: Vec<(u32, f64, f64)> = Vec::with_capacity(STACK);
        stack.push((0, t0, t1));
        while let Some((n, t0, t1)) = stack.pop() {
            if t0 > best_t {
                continue;
            }
            let node = &self.nodes[n as usize];
            stats.nodes_visited += 1;
            for &id in &self.order[node.first as usize..(node.first + node.count) as usize] {
                stats.prims_tested += 1;
                if let Some(t) = hit(id, best_t) {
                    if t >= 0.0 && t <= best_t {
                        best_t = t;
                        best = Some((id, t));
                    }
                }
            }
            let a = node.axis as usize;
            let (o, d) = (origin[a], dir[a]);
            // The part of [t0, t1] where the ray is on the child's side of its plane.
            let clip = |plane: f64, below: bool| -> Option<(f64, f64)> {
                if d == 0.0 {
                    let inside = if below { o <= plane } else { o >= plane };
                    return inside.then_some((t0, t1));
                }
                let t = (plane - o) / d;
                // Below the plane for t <= t when moving up, t >= t when moving down.
                let (s0, s1) = if (d > 0.0) == below {
                    (t0, t1.min(t))
                } else {
                    (t0.max(t), t1)
                };
                (s0 <= s1).then_some((s0, s1))
            };
            let left = (node.left != NONE)
                .then(|| clip(node.left_max as f64, true).map(|(a, b)| (node.left, a, b)))
                .flatten();
            let right = (node.right != NONE)
                .then(|| clip(node.right_min as f64, false).map(|(a, b)| (node.right, a, b)))
                .flatten();
            let (near, far) = if d >= 0.0 {
                (left, right)
            } else {
                (right, left)
            };
            for c in [far, near].into_iter().flatten() {
                if c.1 <= best_t {
                    stack.push(c);
                }
            }
        }
        best
    }
}

impl Builder<'_> {
    fn leaf(&mut self, ids: &[u32]) -> u32 {
        let n = self.nodes.len() as u32;
        self.nodes.push(Node {
            left_max: 0.0,
            right_min: 0.0,
            left: NONE,
            right: NONE,
            first: self.order.len() as u32,
            count: ids.len() as u32,
            axis: 0,
        });
        self.order.extend_from_slice(ids);
        n
    }

    /// Median of the centres of a random sample of `ids` along `axis`.
    fn sample_median(&mut self, ids: &[u32], axis: usize) -> f32 {
        let m = self.params.sample_size.min(ids.len());
        let mut s: Vec<f32> = (0..m)
            .map(|_| self.centers[ids[self.rng.below(ids.len())] as usize][axis])
            .collect();
        let mid = m / 2;
        s.select_nth_unstable_by(mid, f32::total_cmp);
        s[mid]
    }

    fn build(&mut self, ids: Vec<u32>, depth: usize) -> u32 {
        let n = ids.len();
        if n <= self.params.leaf_size || depth >= MAX_DEPTH {
            return self.leaf(&ids);
        }
        let cb = ids
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.including(self.centers[i as usize]));
        let axis = cb.size().max_position();
        if cb.size()[axis] <= 0.0 {
            return self.leaf(&ids);
        }
        let bb = ids
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(&self.boxes[i as usize]));
        let extent = bb.size()[axis];
        let classic = self.params.max_overlap == 0.0;
        let lo = |s: &Self, i: u32| s.boxes[i as usize].min[axis];
        let hi = |s: &Self, i: u32| s.boxes[i as usize].max[axis];

        // Approximate median by sampling; when the split is uneven, commit the smaller side
        // and repeat on the rest (002 Sec. 4.1.2). The classic tree takes one guess.
        let (mut left, mut right) = (Vec::new(), Vec::new());
        let mut work = ids;
        let mut plane;
        let mut round = 0;
        let middle = loop {
            plane = self.sample_median(&work, axis);
            let (mut l, mut m, mut r) = (Vec::new(), Vec::new(), Vec::new());
            for &i in &work {
                if hi(self, i) <= plane {
                    l.push(i);
                } else if lo(self, i) >= plane {
                    r.push(i);
                } else {
                    m.push(i);
                }
            }
            round += 1;
            let (nl, nr) = (left.len() + l.len(), right.len() + r.len());
            let shrinks = l.len().min(r.len()) > 0;
            if classic || round >= 6 || nl.max(nr) * 4 <= 3 * n || !shrinks {
                left.extend(l);
                right.extend(r);
                break m;
            }
            if nl < nr {
                left.extend(l);
                m.extend(r);
            } else {
                right.extend(r);
                m.extend(l);
            }
            work = m;
        };

        let (mut here, left_max, right_min);
        if classic {
            here = middle;
            left_max = plane;
            right_min = plane;
        } else {
            // Sweep over the straddling primitives sorted by start: the first k go left,
            // the rest right; big ones stay here.
            let allow = self.params.max_overlap * extent;
            let (mut small, big): (Vec<u32>, Vec<u32>) = middle
                .into_iter()
                .partition(|&i| hi(self, i) - lo(self, i) <= allow);
            here = big;
            small.sort_unstable_by(|&a, &b| lo(self, a).total_cmp(&lo(self, b)));
            let base_lmax = left
                .iter()
                .map(|&i| hi(self, i))
                .fold(f32::NEG_INFINITY, f32::max);
            let base_rmin = right
                .iter()
                .map(|&i| lo(self, i))
                .fold(f32::INFINITY, f32::min);
            let m = small.len();
            let (nl, nr) = (left.len(), right.len());
            let mut lmax = base_lmax;
            let (mut best_k, mut best_cost, mut best_planes) =
                (0, f64::INFINITY, (base_lmax, base_rmin));
            for k in 0..=m {
                if k > 0 {
                    lmax = lmax.max(hi(self, small[k - 1]));
                }
                let rmin = if k < m {
                    base_rmin.min(lo(self, small[k]))
                } else {
                    base_rmin
                };
                let (cl, cr) = (nl + k, nr + m - k);
                let overlap = if cl == 0 || cr == 0 {
                    0.0
                } else {
                    (lmax - rmin) as f64
                };
                let cost = overlap / extent.max(f32::MIN_POSITIVE) as f64
                    + 0.5 * (cl as f64 - cr as f64).abs() / n as f64;
                if cost < best_cost {
                    (best_k, best_cost, best_planes) = (k, cost, (lmax, rmin));
                }
            }
            left.extend_from_slice(&small[..best_k]);
            right.extend_from_slice(&small[best_k..]);
            (left_max, right_min) = best_planes;
        }
        // A split that moves nothing down would recurse forever: make a leaf instead.
        if left.len() == n || right.len() == n || here.len() == n {
            let mut all = left;
            all.append(&mut right);
            all.append(&mut here);
            return self.leaf(&all);
        }
        let me = self.nodes.len() as u32;
        self.nodes.push(Node {
            left_max,
            right_min,
            left: NONE,
            right: NONE,
            first: self.order.len() as u32,
            count: here.len() as u32,
            axis: axis as u8,
        });
        self.order.append(&mut here);
        let l = if left.is_empty() {
            NONE
        } else {
            self.build(left, depth + 1)
        };
        let r = if right.is_empty() {
            NONE
        } else {
            self.build(right, depth + 1)
        };
        let node = &mut self.nodes[me as usize];
        node.left = l;
        node.right = r;
        me
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boxes of random small segments as primitives; distance = to the segment.
    struct Segs {
        a: Vec<DVec3>,
        b: Vec<DVec3>,
    }

    impl Segs {
        fn random(n: usize, seed: u64) -> Self {
            let mut r = SplitMix64::new(seed);
            let mut a = Vec::new();
            let mut b = Vec::new();
            for i in 0..n {
                let p = r.point_in(Vec3::splat(-1.0), Vec3::splat(1.0)).as_dvec3();
                // A few long ones that must stay at inner nodes.
                let len = if i % 50 == 0 { 0.8 } else { 0.03 };
                // f32-exact ends, so the f32 boxes contain the segments (the tree's contract).
                a.push(p.as_vec3().as_dvec3());
                b.push((p + r.unit_vector().as_dvec3() * len).as_vec3().as_dvec3());
            }
            Self { a, b }
        }
        fn boxes(&self) -> Vec<Aabb> {
            self.a
                .iter()
                .zip(&self.b)
                .map(|(a, b)| Aabb::from_corners(a.as_vec3(), b.as_vec3()))
                .collect()
        }
        fn dist2(&self, i: u32, p: DVec3) -> f64 {
            let (a, b) = (self.a[i as usize], self.b[i as usize]);
            let ab = b - a;
            let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            (a + t * ab - p).length_squared()
        }
    }

    fn params() -> [BuildParams; 4] {
        [
            BuildParams::default(),
            BuildParams::classic(),
            BuildParams {
                leaf_size: 1,
                max_overlap: 0.5,
                ..Default::default()
            },
            BuildParams {
                leaf_size: 16,
                max_overlap: 0.02,
                ..Default::default()
            },
        ]
    }

    #[test]
    fn every_primitive_is_stored_once() {
        let s = Segs::random(3000, 1);
        for p in params() {
            let t = KdTree::build(&s.boxes(), p);
            let mut seen = vec![0; 3000];
            t.for_each_node(|_, ids, _| ids.iter().for_each(|&i| seen[i as usize] += 1));
            assert!(seen.iter().all(|&c| c == 1));
            let st = t.stats();
            assert!(st.depth < 40, "{st:?}");
            if p.max_overlap == 0.0 {
                assert_eq!(st.overlapping_nodes, 0);
            }
        }
    }

    #[test]
    fn child_planes_bound_their_subtrees() {
        let s = Segs::random(2000, 2);
        let boxes = s.boxes();
        for p in params() {
            let t = KdTree::build(&boxes, p);
            // Every primitive below the left child ends at or before left_max, etc.
            fn subtree(t: &KdTree, n: u32, out: &mut Vec<u32>) {
                let node = t.nodes[n as usize];
                out.extend_from_slice(
                    &t.order[node.first as usize..(node.first + node.count) as usize],
                );
                for c in [node.left, node.right] {
                    if c != NONE {
                        subtree(t, c, out);
                    }
                }
            }
            for node in &t.nodes {
                let a = node.axis as usize;
                if node.left != NONE {
                    let mut ids = Vec::new();
                    subtree(&t, node.left, &mut ids);
                    assert!(
                        ids.iter()
                            .all(|&i| boxes[i as usize].max[a] <= node.left_max)
                    );
                }
                if node.right != NONE {
                    let mut ids = Vec::new();
                    subtree(&t, node.right, &mut ids);
                    assert!(
                        ids.iter()
                            .all(|&i| boxes[i as usize].min[a] >= node.right_min)
                    );
                }
            }
        }
    }

    #[test]
    fn queries_match_brute_force() {
        let s = Segs::random(1500, 3);
        let boxes = s.boxes();
        let mut r = SplitMix64::new(4);
        let trees: Vec<KdTree> = params().iter().map(|&p| KdTree::build(&boxes, p)).collect();
        for _ in 0..300 {
            let p = r.point_in(Vec3::splat(-1.5), Vec3::splat(1.5)).as_dvec3();
            let mut all: Vec<(u32, f64)> = (0..1500).map(|i| (i, s.dist2(i, p))).collect();
            all.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
            for t in &trees {
                let mut st = QueryStats::default();
                let (id, d) = t
                    .nearest(p, f64::INFINITY, |i, _| s.dist2(i, p), &mut st)
                    .unwrap();
                assert_eq!(d, all[0].1);
                assert_eq!(s.dist2(id, p), d);
                assert!(st.prims_tested < 1500);
                let k = t.k_nearest(p, 7, |i, _| s.dist2(i, p), &mut st);
                let kd: Vec<f64> = k.iter().map(|x| x.1).collect();
                let want: Vec<f64> = all[..7].iter().map(|x| x.1).collect();
                assert_eq!(kd, want);
                let radius = all[20].1.sqrt();
                let mut w = t.within(p, radius, |i, _| s.dist2(i, p), &mut st);
                w.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
                let want: Vec<(u32, f64)> = all
                    .iter()
                    .copied()
                    .filter(|x| x.1 <= radius * radius)
                    .collect();
                assert_eq!(w, want);
                // A bounded search finds nothing when nothing is that close.
                assert!(
                    t.nearest(p, all[0].1 * 0.999, |i, _| s.dist2(i, p), &mut st)
                        .is_none()
                );
            }
        }
    }

    #[test]
    fn ray_first_matches_brute_force() {
        // Primitives: small spheres (centre, radius) given by their boxes.
        let mut r = SplitMix64::new(5);
        let c: Vec<DVec3> = (0..800)
            .map(|_| r.point_in(Vec3::splat(-1.0), Vec3::splat(1.0)).as_dvec3())
            .collect();
        let rad = 0.04;
        let boxes: Vec<Aabb> = c
            .iter()
            .map(|p| Aabb::from_center_half(p.as_vec3(), Vec3::splat(rad as f32)))
            .collect();
        let hit = |i: u32, o: DVec3, d: DVec3| -> Option<f64> {
            let oc = o - c[i as usize];
            let b = oc.dot(d);
            let disc = b * b - (oc.length_squared() - rad * rad);
            if disc < 0.0 {
                return None;
            }
            let t = -b - disc.sqrt();
            (t >= 0.0).then_some(t)
        };
        for p in params() {
            let t = KdTree::build(&boxes, p);
            let mut st = QueryStats::default();
            let (mut from, mut whole) = (QueryStats::default(), QueryStats::default());
            for _ in 0..300 {
                let o = r.point_in(Vec3::splat(-2.0), Vec3::splat(2.0)).as_dvec3();
                let mut d = r.unit_vector().as_dvec3();
                if r.below(4) == 0 {
                    d = DVec3::X; // along grid lines
                }
                let brute = (0..800u32)
                    .filter_map(|i| hit(i, o, d).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let got = t.ray_first(o, d, 100.0, |i, _| hit(i, o, d), &mut st);
                assert_eq!(got.map(|g| g.1), brute.map(|b| b.1));
                // From t_min on: the first hit beyond it, the nodes before it skipped.
                let t_min = r.below(3) as f64;
                let beyond = |i: u32| hit(i, o, d).filter(|&t| t > t_min);
                let brute = (0..800u32)
                    .filter_map(|i| beyond(i).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let got = t.ray_first_in(o, d, t_min, 100.0, |i, _| beyond(i), &mut from);
                assert_eq!(got.map(|g| g.1), brute.map(|b| b.1));
                let all = t.ray_first(o, d, 100.0, |i, _| beyond(i), &mut whole);
                assert_eq!(all.map(|g| g.1), brute.map(|b| b.1));
            }
            // Starting at t_min visits fewer nodes than filtering from 0.
            assert!(
                from.nodes_visited < whole.nodes_visited,
                "{from:?} {whole:?}"
            );
        }
    }

    #[test]
    fn degenerate_inputs() {
        let t = KdTree::build(&[], BuildParams::default());
        let mut st = QueryStats::default();
        assert!(
            t.nearest(DVec3::ZERO, f64::INFINITY, |_, _| 0.0, &mut st)
                .is_none()
        );
        // Identical boxes, NaN boxes, a NaN query point.
        let mut boxes = vec![Aabb::from_center_half(Vec3::ONE, Vec3::splat(0.1)); 100];
        boxes.push(Aabb::new(Vec3::NAN, Vec3::NAN));
        let t = KdTree::build(&boxes, BuildParams::default());
        assert_eq!(t.len(), 100);
        let got = t
            .nearest(DVec3::ZERO, f64::INFINITY, |i, _| i as f64, &mut st)
            .unwrap();
        assert_eq!(got.0, 0);
        assert!(
            t.nearest(DVec3::NAN, f64::INFINITY, |_, _| 0.0, &mut st)
                .is_none()
        );
        assert!(t.k_nearest(DVec3::ZERO, 0, |_, _| 0.0, &mut st).is_empty());
    }
}
