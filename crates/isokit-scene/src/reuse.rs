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
//! earlier decision and samples.

use crate::sample::Clamped;
use crate::{NodeHash, Plan, SampleOptions, SampleStats, Scene, SceneError};
use isokit_field::{Aabb, BrickGrid, DistanceBox, Field, Job, Reuse};
use std::time::Instant;

/// A sampling kept for the next one ([`Scene::sample_again`]).
#[derive(Clone, Debug)]
pub struct Sampled {
    /// The band.
    pub grid: BrickGrid,
    /// What it cost.
    pub stats: SampleStats,
    hashes: Vec<NodeHash>,
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
    let mut out = Vec::new();
    if old.is_empty() || new.is_empty() {
        return None;
    }
    diff(old, 0, new, 0, 0.0, &mut out)?;
    Some(out)
}

fn diff(
    old: &[NodeHash],
    i: usize,
    new: &[NodeHash],
    j: usize,
    growth: f32,
    out: &mut Vec<Changed>,
) -> Option<()> {
    let (a, b) = (&old[i], &new[j]);
    if a.hash == b.hash && a.node == b.node {
        return Some(());
    }
    let whole = |h: &NodeHash, out: &mut Vec<Changed>| {
        out.push(Changed {
            dbox: h.distance_box?,
            growth,
        });
        Some(())
    };
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
                    (Some(&x), Some(&y)) => diff(old, x, new, y, g, out)?,
                    (Some(&x), None) => out.push(Changed {
                        dbox: old[x].distance_box?,
                        growth: g,
                    }),
                    (None, Some(&y)) => out.push(Changed {
                        dbox: new[y].distance_box?,
                        growth: g,
                    }),
                    (None, None) => {}
                }
            }
            Some(())
        }
        _ => {
            whole(a, out)?;
            whole(b, out)
        }
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
        let changed = usable.and_then(|p| changed_boxes(&p.hashes, self.hashes()));
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
        // A brick is untouched when every changed subtree's value there lies above the cap
        // it is evaluated with (so it is clamped to that cap before and after the edit).
        let test = |b: Aabb| {
            changed.as_ref().is_none_or(|list| {
                list.iter().any(|c| {
                    box_gap(&b, &c.dbox.aabb) - c.dbox.slack
                        <= (cap + c.growth) * 1.001 + plan.spacing
                })
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
