//! Sampling a scene again after an edit, evaluating only the bricks the edit can have
//! changed (what a live viewer does on every save).
//!
//! Two compiled versions of a scene list every node's content hash in pre-order
//! ([`Scene::hashes`]). Walking both from the root, a node with equal hashes computes the
//! same field; a union, intersection or difference, or one of their blends, whose hash
//! differs but whose own parameters do not passes the comparison on to its operands (which
//! share its frame and enter only through their values clamped to a cap: the node's own for
//! the sharp operations, raised by the window and the reach of each fold for the blends
//! (Quilez's polynomial smooth minimum, hg_sdf's chamfer and stairs); an operand added to
//! or removed from a union, a difference or one of their blends is one more changed
//! subtree, while an intersection whose operand count changed changed as a whole); any
//! other node that differs changed as a whole, and its distance boxes before and after the
//! edit bound where it can matter. Where a changed operand's value lies at or above the cap
//! it is evaluated with, before and after the edit, it is clamped to that cap both times and
//! the node computes the same value bit for bit, so a brick farther than that cap (plus the
//! box's slack) from every changed box samples the same values as before: it keeps its
//! earlier decision and samples. Within that reach of a box, the changed subtrees
//! themselves (kept with the sampling) decide: a brick keeps its samples where, over the
//! whole brick, the subtree's value before and after the edit lies beyond the cap on the
//! same side (its value at the brick's centre less its slope bound times the brick's
//! reach), both clamped to the same `±cap` (an operand added or removed only above: an
//! absent operand acts as one far outside). A sphere's radius edited beside a mesh then
//! samples again the shell where the sphere's surface moved, not its whole box.

use crate::sample::Clamped;
use crate::{NodeHash, Plan, SampleOptions, SampleStats, Scene, SceneError};
use isokit_field::{Aabb, BrickGrid, DistanceBox, Field, Job, Reuse};
use std::sync::Arc;
use std::time::Instant;

/// A sampling kept for the next one ([`Scene::sample_again`]).
#[derive(Clone, Debug)]
pub struct Sampled {
    /// The band.
    pub grid: BrickGrid,
    /// What it cost.
    pub stats: SampleStats,
    hashes: Vec<NodeHash>,
    subtrees: Subtrees,
    plan: Plan,
    opts: SampleOptions,
    lipschitz: f32,
}

/// The indices of the children of node `i` of a pre-order list.
fn children(list: &[NodeHash], i: usize) -> Vec<usize> {
    let d = list[i].depth;
    let mut out = Vec::new();
    for (j, h) in list.iter().enumerate().skip(i + 1) {
        if h.depth <= d {
            break;
        }
        if h.depth == d + 1 {
            out.push(j);
        }
    }
    out
}

/// Each node's compiled field, as [`Scene`] keeps them (in the order of its hashes).
#[derive(Clone, Default)]
struct Subtrees(Vec<Option<Arc<dyn Field>>>);

impl std::fmt::Debug for Subtrees {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Subtrees({} nodes)", self.0.len())
    }
}

/// A subtree that differs between two versions of a scene: its index in the old version's
/// pre-order list and in the new one's (`None`: added or removed), and how much more than
/// the root's cap it is evaluated with.
#[derive(Clone, Copy, Debug)]
struct Pair {
    old: Option<usize>,
    new: Option<usize>,
    growth: f32,
}

/// A region an edit may have changed: a distance box, and how much more than the root's
/// cap the changed subtree is evaluated with (the blends above it raise the cap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Changed {
    /// The changed subtree's distance box (before or after the edit), in world coordinates.
    pub dbox: DistanceBox,
    /// The subtree's cap less the root's.
    pub growth: f32,
}

/// Where the new scene's field, clamped to a cap, may differ from the old one's: the
/// distance boxes of the subtrees that differ, found by walking both versions down through
/// unions, intersections, differences and blends whose own parameters are unchanged; `None`
/// when a changed subtree has no distance box (anything may have changed).
pub fn changed_boxes(old: &[NodeHash], new: &[NodeHash]) -> Option<Vec<Changed>> {
    boxes_of(old, new, &changed_pairs(old, new)?)
}

/// The subtrees that differ (see [`changed_boxes`]); `None` when either list is empty.
fn changed_pairs(old: &[NodeHash], new: &[NodeHash]) -> Option<Vec<Pair>> {
    if old.is_empty() || new.is_empty() {
        return None;
    }
    let mut out = Vec::new();
    diff(old, 0, new, 0, 0.0, &mut out);
    Some(out)
}

/// The distance boxes of the two sides of every pair; `None` when one has none.
fn boxes_of(old: &[NodeHash], new: &[NodeHash], pairs: &[Pair]) -> Option<Vec<Changed>> {
    let mut out = Vec::new();
    for p in pairs {
        for (list, i) in [(old, p.old), (new, p.new)] {
            if let Some(i) = i {
                out.push(Changed {
                    dbox: list[i].distance_box?,
                    growth: p.growth,
                });
            }
        }
    }
    Some(out)
}

fn diff(old: &[NodeHash], i: usize, new: &[NodeHash], j: usize, growth: f32, out: &mut Vec<Pair>) {
    let (a, b) = (&old[i], &new[j]);
    if a.hash == b.hash && a.node == b.node {
        return;
    }
    match (a.pass, b.pass) {
        // The same operation with the same parameters. A blend's growth depends on its
        // number of operands (its reach is one per fold), so an operand added or removed
        // changes it: the other operands are then evaluated with another cap, which changes
        // nothing where the blend's clamped result is exact, and where an added or removed
        // operand lies a window above the running value it leaves the fold's value as it
        // was, bit for bit (each blend returns the sharp operation there); the larger
        // growth bounds where it can matter. That holds only where a missing operand acts
        // as one far outside (unions, and a difference's subtrahends); an intersection
        // whose operand count changed changed as a whole.
        (Some(pa), Some(pb))
            if a.node == b.node
                && pa.own == pb.own
                && (pa.far_when_absent || children(old, i).len() == children(new, j).len()) =>
        {
            let g = growth + pa.growth.max(pb.growth);
            let (ca, cb) = (children(old, i), children(new, j));
            for k in 0..ca.len().max(cb.len()) {
                match (ca.get(k), cb.get(k)) {
                    (Some(&x), Some(&y)) => diff(old, x, new, y, g, out),
                    (x, y) => out.push(Pair {
                        old: x.copied(),
                        new: y.copied(),
                        growth: g,
                    }),
                }
            }
        }
        _ => out.push(Pair {
            old: Some(i),
            new: Some(j),
            growth,
        }),
    }
}

/// The field of node `i` of a version (`None`: no such operand; `Some(None)`: not known,
/// which counts as changed).
fn subtree(list: &[Option<Arc<dyn Field>>], i: Option<usize>) -> Option<Option<&dyn Field>> {
    i.map(|i| list.get(i).and_then(|f| f.as_deref()))
}

/// Which side of `±limit` subtree `f` lies on over the ball of radius `reach` around `p`
/// (`1` above, `−1` below, `0` either or not known), from its value there and its slope
/// bound.
fn side(f: &dyn Field, p: glam::Vec3, reach: f32, limit: f32) -> i8 {
    let l = f.lipschitz();
    if !(l.is_finite() && l >= 0.0) {
        return 0;
    }
    let spread = l * reach;
    // Exact below the cap; at or beyond it, the value lies at least that far.
    let v = isokit_field::value_clamped(f, p, limit + spread * 1.001 + f32::EPSILON * limit);
    if v - spread > limit {
        1
    } else if v + spread < -limit {
        -1
    } else {
        0
    }
}

/// The distance between two boxes (0 where they meet).
fn box_gap(a: &Aabb, b: &Aabb) -> f32 {
    let d = (a.min - b.max).max(b.min - a.max).max(glam::Vec3::ZERO);
    d.length()
}

impl Sampled {
    /// The options it was sampled with.
    pub fn options(&self) -> &SampleOptions {
        &self.opts
    }
}

impl Scene {
    /// [`Scene::sample_job`], keeping what the next sampling needs to reuse bricks.
    pub fn sample_kept(&self, opts: &SampleOptions, job: &Job) -> Result<Sampled, SceneError> {
        self.sample_again(opts, None, job)
    }

    /// Samples the band like [`Scene::sample_job`], taking from `previous` (an earlier
    /// version of the scene) every brick the edit cannot have changed (see the module
    /// docs); [`SampleStats::bricks_reused`] counts them. The lattice of `previous` is kept
    /// when the options are the same and the new shape still fits inside it (so an edit
    /// does not move every sample); otherwise, or when the scene's slope bound changed,
    /// everything is sampled again.
    pub fn sample_again(
        &self,
        opts: &SampleOptions,
        previous: Option<&Sampled>,
        job: &Job,
    ) -> Result<Sampled, SceneError> {
        let t0 = Instant::now();
        self.reset_counts();
        let fresh = self.plan(opts)?;
        // A block is sampled whole (blocks are jobs of a distributed sampling, not edits).
        let usable = previous.filter(|p| {
            opts.block.is_none()
                && p.opts == *opts
                && p.lipschitz == self.lipschitz()
                && p.plan.brick == fresh.brick
                && fits(p.plan, fresh)
        });
        let plan = usable.map_or(fresh, |p| p.plan);
        let pairs = usable.and_then(|p| changed_pairs(&p.hashes, self.hashes()));
        let changed = usable
            .zip(pairs.as_ref())
            .and_then(|(p, pairs)| boxes_of(&p.hashes, self.hashes(), pairs));
        let reach = 0.5 * ((plan.brick + 2 * opts.apron) as f32) * plan.spacing * 3f32.sqrt();
        // Just above what the sampler's brick test needs (see `BrickGrid::sample_field`).
        let cap = (plan.band + self.lipschitz() * reach) * 1.001 + plan.spacing;
        let prism_bands = self.prepare_prism_bands(&plan, cap)?;
        let field = Clamped { scene: self, cap };
        // Memoized sources read their values back only where bricks are reused too.
        let _armed = crate::memo::arm(
            &self.memo_store,
            &self.memos,
            plan.origin,
            plan.spacing,
            plan.dims,
            usable.is_some(),
        );
        // A brick is untouched when every changed subtree's value there lies beyond the cap
        // it is evaluated with (so it is clamped to that cap before and after the edit):
        // first by the subtrees' distance boxes, then by the subtrees themselves.
        let limit = |growth: f32| (cap + growth) * 1.001 + plan.spacing;
        let before: &[Option<Arc<dyn Field>>] = usable.map_or(&[], |p| &p.subtrees.0);
        let unchanged_by = |b: &Aabb, pair: &Pair| -> bool {
            let (p, reach) = (b.center(), 0.5 * (b.max - b.min).length());
            let at = |f: Option<Option<&dyn Field>>| {
                f.map(|f| f.map_or(0, |f| side(f, p, reach, limit(pair.growth))))
            };
            let a = at(subtree(before, pair.old));
            let n = at(subtree(self.subtree_fields(), pair.new));
            match (a, n) {
                (Some(a), Some(n)) => a != 0 && a == n,
                // An absent operand acts as one far outside.
                (Some(s), None) | (None, Some(s)) => s == 1,
                (None, None) => true,
            }
        };
        let test = |b: Aabb| {
            changed.as_ref().is_none_or(|list| {
                list.iter()
                    .any(|c| box_gap(&b, &c.dbox.aabb) - c.dbox.slack <= limit(c.growth))
                    && !pairs
                        .as_ref()
                        .is_some_and(|pairs| pairs.iter().all(|pair| unchanged_by(&b, pair)))
            })
        };
        let reuse = match (usable, &changed) {
            (Some(p), Some(_)) => Some(Reuse {
                previous: &p.grid,
                changed: &test,
            }),
            _ => None,
        };
        let grid = match opts.block {
            None => BrickGrid::sample_field_reusing(
                &field,
                plan.dims,
                plan.origin,
                plan.spacing,
                plan.brick,
                opts.apron,
                plan.band,
                plan.band,
                reuse,
                job,
            ),
            Some(block) => {
                self.sampled_dims(opts)?;
                BrickGrid::sample_field_window(
                    &field,
                    plan.origin,
                    plan.spacing,
                    block.first,
                    block.dims,
                    plan.brick,
                    opts.apron,
                    plan.band,
                    plan.band,
                    job,
                )
            }
        }
        .map_err(|e| SceneError::new(self.name(), "sampling", e.to_string()))?;
        // The statistics describe what was sampled: the block where there is one.
        let sampled = Plan {
            dims: grid.dims(),
            origin: grid.origin(),
            ..plan
        };
        let dense = sampled.dims.iter().map(|&d| d as f64).product::<f64>();
        let mut stats = self.stats(
            &sampled,
            grid.evaluated_fraction(),
            dense,
            grid.brick_count(),
            grid.brick_dims().iter().product(),
            t0,
        );
        stats.prism_bands = prism_bands;
        stats.bricks_reused = grid.reused_bricks();
        Ok(Sampled {
            grid,
            stats,
            hashes: self.hashes().to_vec(),
            subtrees: Subtrees(self.subtree_fields().to_vec()),
            plan,
            opts: *opts,
            lipschitz: self.lipschitz(),
        })
    }
}

/// Whether the lattice `old` can stand for `fresh`: it covers `fresh`'s box and its
/// spacing is within 25% of `fresh`'s (a shape that shrank a lot gets a new lattice).
fn fits(old: Plan, fresh: Plan) -> bool {
    let span = |p: Plan| {
        let d = glam::Vec3::new(p.dims[0] as f32, p.dims[1] as f32, p.dims[2] as f32) - 1.0;
        (p.origin, p.origin + p.spacing * d)
    };
    let ((olo, ohi), (flo, fhi)) = (span(old), span(fresh));
    olo.cmple(flo).all() && ohi.cmpge(fhi).all() && old.spacing <= 1.25 * fresh.spacing
}
