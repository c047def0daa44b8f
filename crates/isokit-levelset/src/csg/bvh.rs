//! A bounding-volume hierarchy over the children of a large union, by their
//! [`DistanceBox`]es: `f_i(p) ≥ dist(p, box_i) − slack_i`, so a node whose box is at
//! distance `d` from `p` bounds every child below it by `d − max slack`, and a union looking
//! for the smallest value skips the node once that bound is above its best value.

use isokit_field::{Aabb, DistanceBox};

/// Children per leaf.
const LEAF: usize = 4;

struct Node {
    dbox: DistanceBox,
    /// Leaf: the range `first..first + count` of `order`; inner: children `first` and
    /// `first + 1` of `nodes` (count 0).
    first: u32,
    count: u32,
}

/// The hierarchy: nodes over a permutation of the children; children without a distance box
/// are kept apart and always visited.
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    unboxed: Vec<u32>,
}

impl Bvh {
    /// Builds the hierarchy over the children's distance boxes (`None`: no box known).
    pub(crate) fn build(boxes: Vec<Option<DistanceBox>>) -> Self {
        let mut boxed = Vec::new();
        let mut unboxed = Vec::new();
        for (i, b) in boxes.iter().enumerate() {
            match b {
                Some(d) if d.aabb.is_finite() && !d.aabb.is_empty() && d.slack.is_finite() => {
                    boxed.push(i as u32)
                }
                _ => unboxed.push(i as u32),
            }
        }
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * boxed.len() / LEAF + 1),
            order: boxed,
            unboxed,
        };
        if !bvh.order.is_empty() {
            let n = bvh.order.len();
            bvh.nodes.push(Node {
                dbox: DistanceBox::exact(Aabb::EMPTY),
                first: 0,
                count: 0,
            });
            bvh.split(0, 0, n, &boxes);
        }
        bvh
    }

    /// Fills node `at` over `order[lo..hi]`, median split on the longest axis of the centres.
    fn split(&mut self, at: usize, lo: usize, hi: usize, boxes: &[Option<DistanceBox>]) {
        let get = |i: u32| boxes[i as usize].expect("only boxed children are ordered");
        let dbox = self.order[lo..hi]
            .iter()
            .map(|&i| get(i))
            .reduce(|a, b| a.union(&b))
            .expect("non-empty range");
        if hi - lo <= LEAF {
            self.nodes[at] = Node {
                dbox,
                first: lo as u32,
                count: (hi - lo) as u32,
            };
            return;
        }
        let centres = Aabb::from_points(
            self.order[lo..hi]
                .iter()
                .map(|&i| get(i).aabb.center())
                .collect::<Vec<_>>()
                .iter(),
        );
        let axis = centres.size().max_position();
        let mid = lo + (hi - lo) / 2;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
            get(a).aabb.center()[axis].total_cmp(&get(b).aabb.center()[axis])
        });
        let left = self.nodes.len();
        let placeholder = || Node {
            dbox: DistanceBox::exact(Aabb::EMPTY),
            first: 0,
            count: 0,
        };
        self.nodes.push(placeholder());
        self.nodes.push(placeholder());
        self.nodes[at] = Node {
            dbox,
            first: left as u32,
            count: 0,
        };
        self.split(left, lo, mid, boxes);
        self.split(left + 1, mid, hi, boxes);
    }

    /// A lower bound on the minimum over all children at `p` from the boxes alone.
    pub(crate) fn lower_bound(&self, p: glam::Vec3) -> f32 {
        if !self.unboxed.is_empty() {
            return f32::NEG_INFINITY;
        }
        self.nodes
            .first()
            .map_or(f32::INFINITY, |n| n.dbox.lower_bound(p))
    }

    /// The smallest of `eval(i, limit)` over the children, skipping every subtree whose
    /// bound is at least `min(best so far, cap)`; `eval` receives that limit and may return
    /// `∞` for a child its own bound excludes.
    pub(crate) fn min(
        &self,
        p: glam::Vec3,
        cap: f32,
        mut eval: impl FnMut(usize, f32) -> f32,
    ) -> f32 {
        let mut acc = f32::INFINITY;
        for &i in &self.unboxed {
            acc = acc.min(eval(i as usize, acc.min(cap)));
        }
        if self.nodes.is_empty() {
            return acc;
        }
        let mut stack = [0u32; 64];
        let mut top = 1;
        stack[0] = 0;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.dbox.lower_bound(p) >= acc.min(cap) {
                continue;
            }
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &i in &self.order[range] {
                    acc = acc.min(eval(i as usize, acc.min(cap)));
                }
                continue;
            }
            // Visit the nearer child first: push it last.
            let (a, b) = (node.first, node.first + 1);
            let (la, lb) = (
                self.nodes[a as usize].dbox.lower_bound(p),
                self.nodes[b as usize].dbox.lower_bound(p),
            );
            let (near, far) = if la <= lb { (a, b) } else { (b, a) };
            if top + 2 > stack.len() {
                // Deeper than any balanced tree of 2^60 children: visit the rest linearly.
                for &i in &self.order {
                    acc = acc.min(eval(i as usize, acc.min(cap)));
                }
                return acc;
            }
            stack[top] = far;
            stack[top + 1] = near;
            top += 2;
        }
        acc
    }
}
