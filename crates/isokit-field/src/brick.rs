//! Sparse brick grids: only the bricks near the surface are stored.

use crate::{Field, FieldError, Grid, Job, grid::checked_len};
use glam::{IVec3, Vec3};
use rayon::prelude::*;
use std::cell::Cell;

/// Per-brick bookkeeping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrickInfo {
    /// Brick coordinates (brick `(a, b, c)` owns samples `B*(a, b, c) .. B*(a, b, c) + B`).
    pub coord: [u32; 3],
    /// Smallest sample over the brick's cells (its own samples plus the next layer, so every
    /// cell that starts in the brick is covered). Used for empty-space skipping.
    pub min: f32,
    /// Largest sample over the same region.
    pub max: f32,
}

/// A sparse node-centered grid split into cubic bricks of `B = 2^n` samples a side, each
/// stored with an apron of `A` extra samples on every side so filters can read neighbours
/// without leaving the brick. Unsampled space reads as `background` (for a narrow-band
/// distance field: `+band`), or as `-background` in absent bricks known to lie inside
/// (see [`BrickGrid::is_inside`]), so a band field keeps its sign everywhere.
///
/// The virtual grid has the same geometry as a [`Grid`]: sample `(i, j, k)` at
/// `origin + spacing * (i, j, k)`. Lookup goes through a dense index of bricks (the
/// "reference texture" of a GPU brick cache), so it costs one extra read.
///
/// ```
/// use isokit_field::{BrickGrid, Grid};
/// use glam::Vec3;
/// let mut g = Grid::new([20, 20, 20], Vec3::ZERO, 0.1).unwrap();
/// for ([i, j, k], v) in g.clone().iter() { let _ = v; g.set(i, j, k, i as f32 - 10.0); }
/// // Keep only bricks whose values come within 1.5 of zero.
/// let b = BrickGrid::from_grid(&g, 8, 2, 1.5, 99.0).unwrap();
/// assert!(b.brick_count() < b.brick_dims().iter().product::<usize>());
/// assert_eq!(b.get(10, 3, 3), 0.0);
/// // Dropped bricks read as the background, negated where they lie inside (x < 10).
/// assert_eq!(b.get(19, 0, 0), 99.0);
/// assert_eq!(b.get(0, 0, 0), -99.0);
/// ```
#[derive(Clone, Debug)]
pub struct BrickGrid {
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    brick: usize,
    apron: usize,
    background: f32,
    brick_dims: [usize; 3],
    /// Index into `infos` per brick position, `u32::MAX` when absent.
    index: Vec<u32>,
    infos: Vec<BrickInfo>,
    /// Brick samples, `(brick + 2 apron)^3` per brick, x fastest, in `infos` order. Shared
    /// by clones (a sampled grid is read, not written): a renderer's volume and a live
    /// viewer's memory of the last sampling hold the same samples.
    pool: std::sync::Arc<Vec<f32>>,
    evaluated: u64,
    reused: usize,
}

/// Where a sampled grid lies in the lattice its sample positions are computed from: the
/// lattice's sample `(0, 0, 0)` and the index of the grid's first sample in it.
#[derive(Clone, Copy)]
struct Window {
    origin: Vec3,
    first: [i32; 3],
}

/// An earlier sampling to take bricks from ([`BrickGrid::sample_field_reusing`]).
#[derive(Clone, Copy)]
pub struct Reuse<'a> {
    /// The earlier sampling.
    pub previous: &'a BrickGrid,
    /// Whether the field may have changed anywhere in a box (world coordinates).
    pub changed: &'a (dyn Fn(crate::Aabb) -> bool + Sync),
}

const ABSENT: u32 = u32::MAX;
/// An absent brick that lies inside the surface: reads as `-background`.
const ABSENT_INSIDE: u32 = u32::MAX - 1;

/// What becomes of one brick position while building.
enum Slot {
    Stored(BrickInfo, Vec<f32>),
    Inside([u32; 3]),
    Outside,
}

impl BrickGrid {
    /// The largest brick edge in samples.
    pub const MAX_BRICK: usize = 256;

    /// Checks a brick edge: a power of two from 2 to [`BrickGrid::MAX_BRICK`].
    pub fn check_brick(brick: usize) -> Result<(), FieldError> {
        if brick.is_power_of_two() && (2..=Self::MAX_BRICK).contains(&brick) {
            Ok(())
        } else {
            Err(FieldError::BadParameter {
                name: "brick",
                value: brick.to_string(),
                why: "must be a power of two from 2 to 256",
            })
        }
    }

    /// An empty brick grid over a virtual grid of `dims` samples.
    ///
    /// `brick` must be a power of two from 2 to 256 and `apron` at most `brick`.
    pub fn new(
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        brick: usize,
        apron: usize,
        background: f32,
    ) -> Result<Self, FieldError> {
        if !(brick.is_power_of_two() && (2..=256).contains(&brick)) {
            return Err(FieldError::BadParameter {
                name: "brick size",
                value: brick.to_string(),
                why: "must be a power of two from 2 to 256",
            });
        }
        if apron > brick {
            return Err(FieldError::BadParameter {
                name: "apron",
                value: apron.to_string(),
                why: "must not exceed the brick size",
            });
        }
        // Validates geometry and size without allocating the dense samples.
        checked_len(dims)?;
        Grid::new([1, 1, 1], origin, spacing)?;
        let brick_dims = dims.map(|d| d.div_ceil(brick));
        let n = brick_dims.iter().product::<usize>();
        if n >= ABSENT_INSIDE as usize {
            return Err(FieldError::BadParameter {
                name: "brick size",
                value: brick.to_string(),
                why: "too small for this grid (more than 2^32 bricks)",
            });
        }
        // The index, plus the per-brick lists the builders make (coordinates, decisions).
        crate::memory::check(
            &format!(
                "the index of {n} bricks of {brick}^3 samples (of {} x {} x {} samples)",
                dims[0], dims[1], dims[2]
            ),
            n as u128 * 48,
            "lower the resolution or use larger bricks, or raise the budget",
        )?;
        Ok(Self {
            dims,
            origin,
            spacing,
            brick,
            apron,
            background,
            brick_dims,
            index: vec![ABSENT; n],
            infos: Vec::new(),
            pool: std::sync::Arc::new(Vec::new()),
            evaluated: 0,
            reused: 0,
        })
    }

    /// Converts a dense grid, keeping the bricks whose values come within `band` of zero
    /// (`min <= band && max >= -band`); pass `f32::INFINITY` to keep every brick. Dropped
    /// bricks whose values all lie below `-band` are marked inside and read as
    /// `-background`.
    pub fn from_grid(
        grid: &Grid,
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
    ) -> Result<Self, FieldError> {
        let mut b = Self::new(
            grid.dims(),
            grid.origin(),
            grid.spacing(),
            brick,
            apron,
            background,
        )?;
        let side = brick + 2 * apron;
        let coords = b.all_brick_coords();
        let bricks: Vec<Slot> = coords
            .par_iter()
            .map(|&c| {
                let info = b.info_from(c, |i, j, k| grid.get_clamped(IVec3::new(i, j, k)));
                if info.max < -band {
                    Slot::Inside(c)
                } else if info.min > band {
                    Slot::Outside
                } else {
                    let mut data = vec![0.0; side * side * side];
                    b.fill_brick(c, &mut data, |i, j, k| {
                        grid.get_clamped(IVec3::new(i, j, k))
                    });
                    Slot::Stored(info, data)
                }
            })
            .collect();
        for slot in bricks {
            match slot {
                Slot::Stored(info, data) => b.push(info, data),
                Slot::Inside(c) => b.mark_inside(c),
                Slot::Outside => {}
            }
        }
        Ok(b)
    }

    /// Samples `field` lazily: a brick is evaluated only when the field's value at the brick
    /// centre, less the Lipschitz bound times the distance to the brick's farthest sample
    /// (apron included), says the surface may lie within `band`. Everything else reads as
    /// `background`, or `-background` where the centre value is negative (inside). The
    /// field may clamp its values to `±cap` for any `cap > band + L·r` (`L` its Lipschitz
    /// bound, `r` the brick's half-diagonal with apron) without changing which bricks are
    /// kept. Each sample is evaluated once: aprons copy neighbouring bricks where
    /// those are kept. [`BrickGrid::evaluated_fraction`] reports the share of the dense grid
    /// that was evaluated (one sample per skipped brick included).
    #[expect(clippy::too_many_arguments, reason = "grid geometry plus brick layout")]
    pub fn sample_field(
        field: &dyn Field,
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
    ) -> Result<Self, FieldError> {
        Self::sample_field_job(
            field,
            dims,
            origin,
            spacing,
            brick,
            apron,
            band,
            background,
            &Job::default(),
        )
    }

    /// [`BrickGrid::sample_field`] with progress reports (stage `"sampling bricks"`, one unit
    /// per brick of the lattice) and cancellation checked before every brick
    /// ([`FieldError::Cancelled`]).
    #[expect(
        clippy::too_many_arguments,
        reason = "grid geometry plus brick layout and job"
    )]
    pub fn sample_field_job(
        field: &dyn Field,
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
        job: &Job,
    ) -> Result<Self, FieldError> {
        Self::sample_field_reusing(
            field, dims, origin, spacing, brick, apron, band, background, None, job,
        )
    }

    /// [`BrickGrid::sample_field_job`] taking the bricks of an earlier sampling where the
    /// field cannot have changed: a brick of `reuse.previous` (same lattice, brick size,
    /// apron and background) whose box `reuse.changed` says is untouched keeps its decision
    /// (kept, inside, outside), samples and bookkeeping, and nothing of it is evaluated.
    /// [`BrickGrid::reused_bricks`] counts them. Without a matching lattice every brick is
    /// evaluated. The caller answers for `changed`: the field at every sample of a brick it
    /// passes (the box spans the brick's samples, its apron and the next layer) must be the
    /// same as when `previous` was sampled, with the same `band`.
    #[expect(
        clippy::too_many_arguments,
        reason = "grid geometry plus brick layout, reuse and job"
    )]
    pub fn sample_field_reusing(
        field: &dyn Field,
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
        reuse: Option<Reuse<'_>>,
        job: &Job,
    ) -> Result<Self, FieldError> {
        let window = Window {
            origin,
            first: [0; 3],
        };
        Self::sample_impl(
            field, dims, window, spacing, brick, apron, band, background, reuse, job,
        )
    }

    /// [`BrickGrid::sample_field_job`] over a block of a larger lattice: the `dims` samples
    /// from index `first` of the lattice whose sample `(0, 0, 0)` lies at `lattice_origin`.
    /// Each sample's position is computed from the whole lattice's origin and its index in
    /// it, exactly as a sampling of the whole lattice computes it, so the block's samples are
    /// those of the whole sampling bit for bit wherever the whole sampling's bricks and the
    /// block's agree on being kept (everywhere once both are clamped to `±band`: a skipped
    /// brick's samples all lie beyond the band). The grid's own origin is the block's first
    /// sample (rounded to f32). Bricks are laid from `first`, so blocks aligned to the brick
    /// size make the same decisions as the whole sampling.
    #[expect(
        clippy::too_many_arguments,
        reason = "lattice, block geometry plus brick layout and job"
    )]
    pub fn sample_field_window(
        field: &dyn Field,
        lattice_origin: Vec3,
        spacing: f32,
        first: [usize; 3],
        dims: [usize; 3],
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
        job: &Job,
    ) -> Result<Self, FieldError> {
        if first
            .iter()
            .zip(&dims)
            .any(|(&f, &d)| f.saturating_add(d) > crate::MAX_AXIS)
        {
            return Err(FieldError::BadParameter {
                name: "block",
                value: format!("{first:?} + {dims:?}"),
                why: "reaches beyond the largest lattice",
            });
        }
        let window = Window {
            origin: lattice_origin,
            first: first.map(|v| v as i32),
        };
        Self::sample_impl(
            field, dims, window, spacing, brick, apron, band, background, None, job,
        )
    }

    #[expect(
        clippy::too_many_arguments,
        reason = "grid geometry plus brick layout, reuse and job"
    )]
    fn sample_impl(
        field: &dyn Field,
        dims: [usize; 3],
        window: Window,
        spacing: f32,
        brick: usize,
        apron: usize,
        band: f32,
        background: f32,
        reuse: Option<Reuse<'_>>,
        job: &Job,
    ) -> Result<Self, FieldError> {
        job.check()?;
        let first = IVec3::from_array(window.first);
        let origin = window.origin;
        let own_origin = origin + spacing * first.as_vec3();
        let mut b = Self::new(dims, own_origin, spacing, brick, apron, background)?;
        let reuse = reuse.filter(|r| r.previous.same_lattice(&b));
        // Per brick: the earlier brick's slot where it is reused.
        let old: Vec<Option<u32>> = match &reuse {
            Some(r) => b
                .all_brick_coords()
                .par_iter()
                .map(|&c| (!(r.changed)(b.brick_box(c))).then(|| r.previous.index[b.flat(c)]))
                .collect(),
            None => Vec::new(),
        };
        let old_at = |n: usize| old.get(n).copied().flatten();
        let side = brick + 2 * apron;
        let lip = field.lipschitz().max(0.0);
        let reach = 0.5 * ((brick + 2 * apron) as f32) * spacing * 3f32.sqrt();
        let mi = b.max_index();
        let pos = |q: IVec3| origin + spacing * (q.clamp(IVec3::ZERO, mi) + first).as_vec3();
        // Pass 1: one evaluation per brick decides which bricks may hold the band.
        let coords = b.all_brick_coords();
        // `Some(true)` keep, `Some(false)` skip as outside, `None` skip as inside.
        let progress = job.counter("sampling bricks", 2 * coords.len() as u64);
        let keep: Vec<Option<bool>> = coords
            .par_iter()
            .enumerate()
            .map(|(n, &c)| {
                progress.advance(1);
                if let Some(slot) = old_at(n) {
                    return match slot {
                        ABSENT => Some(false),
                        ABSENT_INSIDE => None,
                        _ => Some(true),
                    };
                }
                let lo = IVec3::from_array(c.map(|v| (v as usize * brick) as i32));
                let centre =
                    origin + spacing * ((lo + first).as_vec3() + Vec3::splat(0.5 * brick as f32));
                let v = field.value(centre);
                if v.is_finite() && v.abs() - lip * reach > band {
                    (v > 0.0).then_some(false)
                } else {
                    Some(true)
                }
            })
            .collect();
        for (c, k) in coords.iter().zip(&keep) {
            if k.is_none() {
                b.mark_inside(*c);
            }
        }
        job.check()?;
        // What the kept bricks will hold, known before their samples are evaluated: the
        // cores, the stored bricks with aprons and the pool they are copied into.
        let kept = keep.iter().filter(|k| **k == Some(true)).count() as u128;
        let per = (brick.pow(3) + 2 * side.pow(3)) as u128 * 4 + 64;
        crate::memory::check(
            &format!(
                "the {kept} bricks of {brick}^3 samples that may hold the band (of {} x {} x {} samples)",
                dims[0], dims[1], dims[2]
            ),
            kept * per + b.index.len() as u128 * 4,
            "lower the resolution or narrow the band, or raise the budget",
        )?;
        // Pass 2: the core samples of kept bricks, each evaluated once.
        let cores: Vec<Option<Vec<f32>>> = coords
            .par_iter()
            .zip(keep.par_iter())
            .enumerate()
            .map(|(n, (&c, &k))| {
                progress.advance(1);
                if let (Some(r), Some(slot)) = (&reuse, old_at(n))
                    && k == Some(true)
                {
                    return Some(r.previous.core_of(slot as usize));
                }
                (k == Some(true) && !job.is_cancelled()).then(|| {
                    let lo = IVec3::from_array(c.map(|v| (v as usize * brick) as i32));
                    let points: Vec<Vec3> = (0..brick * brick * brick)
                        .map(|n| {
                            let l = IVec3::new(
                                (n % brick) as i32,
                                ((n / brick) % brick) as i32,
                                (n / (brick * brick)) as i32,
                            );
                            pos(lo + l)
                        })
                        .collect();
                    let mut core = vec![0.0; points.len()];
                    field.values_nearby(&points, &mut core);
                    core
                })
            })
            .collect();
        job.check()?;
        // Pass 3: aprons read neighbouring cores where kept and evaluate the field elsewhere.
        let bd = IVec3::from_array(b.brick_dims.map(|v| v as i32));
        // The virtual grid at clamped indices: a kept core's sample, or a new evaluation
        // (counted in `extra`).
        let virtual_at = |i: i32, j: i32, k: i32, extra: &Cell<u64>| -> f32 {
            let q = IVec3::new(i, j, k).clamp(IVec3::ZERO, mi);
            let bc = q / brick as i32;
            if bc.cmplt(bd).all() {
                let n = (bc.x + bd.x * (bc.y + bd.y * bc.z)) as usize;
                if let Some(core) = &cores[n] {
                    let l = (q - bc * brick as i32).as_uvec3();
                    return core[l.x as usize + brick * (l.y as usize + brick * l.z as usize)];
                }
            }
            extra.set(extra.get() + 1);
            field.value(pos(q))
        };
        let bricks: Vec<(BrickInfo, Vec<f32>, u64)> = coords
            .par_iter()
            .zip(cores.par_iter())
            .enumerate()
            .filter_map(|(n, (&c, core))| core.as_ref().map(|_| (n, c)))
            .map(|(n, c)| {
                if let (Some(r), Some(slot)) = (&reuse, old_at(n)) {
                    let slot = slot as usize;
                    return (
                        r.previous.infos[slot],
                        r.previous.brick_data(slot).to_vec(),
                        u64::MAX,
                    );
                }
                let extra = Cell::new(0u64);
                let mut data = vec![0.0; side * side * side];
                b.fill_from_cores(c, &mut data, &cores, |q| {
                    extra.set(extra.get() + 1);
                    field.value(pos(q))
                });
                // Min/max over the brick's cells: the stored samples where the apron holds
                // them, else (apron 0: the next layer) the virtual grid itself, so that the
                // bookkeeping equals `from_grid`'s on the same samples.
                let info = if apron >= 1 {
                    b.info_of_stored(c, &data)
                } else {
                    let lo = IVec3::from_array(c.map(|v| (v as usize * brick) as i32));
                    b.info_from(c, |i, j, k| {
                        let l = IVec3::new(i, j, k) - lo;
                        if l.cmpge(IVec3::ZERO).all() && l.cmplt(IVec3::splat(side as i32)).all() {
                            data[l.x as usize + side * (l.y as usize + side * l.z as usize)]
                        } else {
                            virtual_at(i, j, k, &extra)
                        }
                    })
                };
                (info, data, extra.get())
            })
            .collect();
        let kept = bricks.len() as u64;
        let skipped = keep.len() as u64 - kept;
        // Core samples beyond the grid's end are clamped copies: count only real ones.
        // Reused skipped bricks cost nothing either.
        let reused_skipped = (0..keep.len())
            .filter(|&n| keep[n] != Some(true) && old_at(n).is_some())
            .count() as u64;
        let mut evaluated = skipped - reused_skipped;
        for (info, data, extra) in bricks {
            if extra == u64::MAX {
                b.reused += 1;
                b.push(info, data);
                continue;
            }
            let lo = info.coord.map(|v| v as usize * brick);
            let real: usize = (0..3).map(|a| brick.min(dims[a] - lo[a])).product();
            evaluated += real as u64 + extra;
            b.push(info, data);
        }
        b.evaluated = evaluated;
        Ok(b)
    }

    /// Kept bricks taken from an earlier sampling by [`BrickGrid::sample_field_reusing`]
    /// without evaluating anything (skipped bricks it reused are not counted: they cost one
    /// sample each otherwise).
    pub fn reused_bricks(&self) -> usize {
        self.reused
    }

    /// Same samples, brick layout and background as `other`.
    fn same_lattice(&self, other: &BrickGrid) -> bool {
        self.dims == other.dims
            && self.origin == other.origin
            && self.spacing == other.spacing
            && self.brick == other.brick
            && self.apron == other.apron
            && self.background.to_bits() == other.background.to_bits()
    }

    fn flat(&self, c: [u32; 3]) -> usize {
        let [bx, by, _] = self.brick_dims;
        c[0] as usize + bx * (c[1] as usize + by * c[2] as usize)
    }

    /// The world box of the samples brick `c` depends on: its own, its apron's and the next
    /// layer (read by the bookkeeping when there is no apron).
    pub fn brick_box(&self, c: [u32; 3]) -> crate::Aabb {
        let lo = c.map(|v| (v as usize * self.brick) as f32 - self.apron as f32);
        let reach = self.brick as f32 + self.apron.max(1) as f32;
        let hi: [f32; 3] = std::array::from_fn(|a| {
            (c[a] as f32 * self.brick as f32 + reach).min(self.dims[a] as f32 - 1.0)
        });
        crate::Aabb::from_corners(
            self.origin + self.spacing * Vec3::from_array(lo).max(Vec3::ZERO),
            self.origin + self.spacing * Vec3::from_array(hi),
        )
    }

    /// The core samples (no apron) of stored brick `slot`.
    fn core_of(&self, slot: usize) -> Vec<f32> {
        let (brick, apron) = (self.brick, self.apron);
        let side = brick + 2 * apron;
        let data = self.brick_data(slot);
        (0..brick * brick * brick)
            .map(|n| {
                let (i, j, k) = (
                    n % brick + apron,
                    (n / brick) % brick + apron,
                    n / (brick * brick) + apron,
                );
                data[i + side * (j + side * k)]
            })
            .collect()
    }

    fn max_index(&self) -> IVec3 {
        IVec3::new(
            self.dims[0] as i32 - 1,
            self.dims[1] as i32 - 1,
            self.dims[2] as i32 - 1,
        )
    }

    fn all_brick_coords(&self) -> Vec<[u32; 3]> {
        let [bx, by, bz] = self.brick_dims;
        (0..bx * by * bz)
            .map(|n| {
                [
                    (n % bx) as u32,
                    ((n / bx) % by) as u32,
                    (n / (bx * by)) as u32,
                ]
            })
            .collect()
    }

    /// Min/max over the brick's cells, reading the virtual grid through `at`.
    fn info_from(&self, c: [u32; 3], at: impl Fn(i32, i32, i32) -> f32) -> BrickInfo {
        let (lo, hi) = self.cell_samples(c);
        let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    let v = at(i as i32, j as i32, k as i32);
                    mn = mn.min(v);
                    mx = mx.max(v);
                }
            }
        }
        BrickInfo {
            coord: c,
            min: mn,
            max: mx,
        }
    }

    /// The first and last samples (inclusive, per axis) of the cells of brick `c`: its own
    /// and the next layer, within the grid.
    fn cell_samples(&self, c: [u32; 3]) -> ([usize; 3], [usize; 3]) {
        let lo = c.map(|v| v as usize * self.brick);
        let hi = std::array::from_fn(|a| (lo[a] + self.brick).min(self.dims[a] - 1));
        (lo, hi)
    }

    /// Fills a brick's storage (apron included) from the virtual grid through `at`, which
    /// receives possibly out-of-range indices and must clamp them itself.
    fn fill_brick(&self, c: [u32; 3], data: &mut [f32], mut at: impl FnMut(i32, i32, i32) -> f32) {
        let side = self.brick + 2 * self.apron;
        let lo = IVec3::from_array(c.map(|v| (v as usize * self.brick) as i32))
            - IVec3::splat(self.apron as i32);
        for (n, v) in data.iter_mut().enumerate() {
            let l = IVec3::new(
                (n % side) as i32,
                ((n / side) % side) as i32,
                (n / (side * side)) as i32,
            );
            let g = lo + l;
            *v = at(g.x, g.y, g.z);
        }
    }

    /// Fills brick `c`'s storage (apron included) from the virtual grid of a sampling in
    /// progress, at indices clamped to the grid: a sample of a kept brick's core
    /// (`cores[n]`, `brick³` samples with x fastest), else `eval` of the clamped index. The
    /// same values as [`BrickGrid::fill_brick`] through such a lookup, with the index
    /// arithmetic done once per axis rather than per sample.
    fn fill_from_cores(
        &self,
        c: [u32; 3],
        data: &mut [f32],
        cores: &[Option<Vec<f32>>],
        mut eval: impl FnMut(IVec3) -> f32,
    ) {
        let (brick, side) = (self.brick, self.brick + 2 * self.apron);
        let mi = self.max_index();
        // Per axis and local index: the clamped index, its brick and its offset there
        // (`None` past the bricks, which a clamped index never reaches).
        let axis = |a: usize| -> Vec<(i32, Option<usize>, usize)> {
            let lo = (c[a] as usize * brick) as i32 - self.apron as i32;
            (0..side as i32)
                .map(|l| {
                    let q = (lo + l).clamp(0, mi[a]);
                    let b = q as usize / brick;
                    (q, (b < self.brick_dims[a]).then_some(b), q as usize % brick)
                })
                .collect()
        };
        let (tx, ty, tz) = (axis(0), axis(1), axis(2));
        let [bx, by, _] = self.brick_dims;
        for (lz, &(qz, cz, rz)) in tz.iter().enumerate() {
            for (ly, &(qy, cy, ry)) in ty.iter().enumerate() {
                let row = &mut data[side * (ly + side * lz)..][..side];
                let yz = cy.zip(cz).map(|(cy, cz)| bx * (cy + by * cz));
                let off = brick * (ry + brick * rz);
                for (o, &(qx, cx, rx)) in row.iter_mut().zip(&tx) {
                    let core = yz.zip(cx).and_then(|(yz, cx)| cores[yz + cx].as_deref());
                    *o = match core {
                        Some(core) => core[rx + off],
                        None => eval(IVec3::new(qx, qy, qz)),
                    };
                }
            }
        }
    }

    /// [`BrickGrid::info_from`] of brick `c` read from its storage `data` (apron included),
    /// which holds every sample of its cells when the apron is at least 1.
    fn info_of_stored(&self, c: [u32; 3], data: &[f32]) -> BrickInfo {
        debug_assert!(self.apron >= 1);
        let (side, a) = (self.brick + 2 * self.apron, self.apron);
        let (lo, hi) = self.cell_samples(c);
        // Row by row of x, as the storage lies.
        let mut range = (f32::INFINITY, f32::NEG_INFINITY);
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                let row = side * (j - lo[1] + a + side * (k - lo[2] + a)) + a;
                range = data[row..=row + hi[0] - lo[0]]
                    .iter()
                    .fold(range, |(mn, mx), &v| (mn.min(v), mx.max(v)));
            }
        }
        BrickInfo {
            coord: c,
            min: range.0,
            max: range.1,
        }
    }

    fn mark_inside(&mut self, c: [u32; 3]) {
        let [bx, by, _] = self.brick_dims;
        let [a, b, c] = c.map(|v| v as usize);
        self.index[a + bx * (b + by * c)] = ABSENT_INSIDE;
    }

    fn push(&mut self, info: BrickInfo, data: Vec<f32>) {
        let [bx, by, _] = self.brick_dims;
        let [a, b, c] = info.coord.map(|v| v as usize);
        self.index[a + bx * (b + by * c)] = self.infos.len() as u32;
        self.infos.push(info);
        std::sync::Arc::make_mut(&mut self.pool).extend_from_slice(&data);
    }

    /// Samples of the virtual grid along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    /// Position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
    /// Sample spacing.
    pub fn spacing(&self) -> f32 {
        self.spacing
    }
    /// Brick edge length in samples (without apron).
    pub fn brick_size(&self) -> usize {
        self.brick
    }
    /// Apron width in samples.
    pub fn apron(&self) -> usize {
        self.apron
    }
    /// Value of unsampled space.
    pub fn background(&self) -> f32 {
        self.background
    }
    /// Number of brick positions along x, y, z.
    pub fn brick_dims(&self) -> [usize; 3] {
        self.brick_dims
    }
    /// Number of stored bricks.
    pub fn brick_count(&self) -> usize {
        self.infos.len()
    }
    /// Bookkeeping of the stored bricks, in storage order.
    pub fn bricks(&self) -> &[BrickInfo] {
        &self.infos
    }
    /// Stored samples of brick `n` (storage order), `(B + 2A)^3` values, x fastest; local
    /// sample `(0, 0, 0)` is global sample `B * coord - A`.
    pub fn brick_data(&self, n: usize) -> &[f32] {
        let s = (self.brick + 2 * self.apron).pow(3);
        &self.pool[n * s..(n + 1) * s]
    }
    /// Bytes used by samples, index and bookkeeping.
    pub fn memory_bytes(&self) -> usize {
        self.pool.len() * 4 + self.index.len() * 4 + self.infos.len() * size_of::<BrickInfo>()
    }
    /// Fraction of the dense grid's samples that [`BrickGrid::sample_field`] evaluated
    /// (apron samples included); 0 for grids built otherwise.
    pub fn evaluated_fraction(&self) -> f64 {
        self.evaluated as f64 / self.dims.iter().product::<usize>() as f64
    }

    /// Storage index of the brick at brick coordinates `c`, if stored.
    pub fn brick_at(&self, c: [usize; 3]) -> Option<usize> {
        let [bx, by, bz] = self.brick_dims;
        if c[0] >= bx || c[1] >= by || c[2] >= bz {
            return None;
        }
        let n = self.index[c[0] + bx * (c[1] + by * c[2])];
        (n < ABSENT_INSIDE).then_some(n as usize)
    }

    /// True when the brick at brick coordinates `c` is absent and known to lie inside the
    /// surface (its samples read as `-background`).
    pub fn is_inside(&self, c: [usize; 3]) -> bool {
        let [bx, by, bz] = self.brick_dims;
        c[0] < bx
            && c[1] < by
            && c[2] < bz
            && self.index[c[0] + bx * (c[1] + by * c[2])] == ABSENT_INSIDE
    }

    /// Sample (i, j, k) of the virtual grid; `background` where no brick is stored or the
    /// index is out of range, `-background` in absent bricks marked inside.
    pub fn get(&self, i: usize, j: usize, k: usize) -> f32 {
        if i >= self.dims[0] || j >= self.dims[1] || k >= self.dims[2] {
            return self.background;
        }
        let b = self.brick;
        match self.brick_at([i / b, j / b, k / b]) {
            None if self.is_inside([i / b, j / b, k / b]) => -self.background,
            None => self.background,
            Some(n) => {
                let side = b + 2 * self.apron;
                let (li, lj, lk) = (i % b + self.apron, j % b + self.apron, k % b + self.apron);
                self.brick_data(n)[li + side * (lj + side * lk)]
            }
        }
    }

    /// Expands to a dense grid (unsampled space takes `background`).
    pub fn to_grid(&self) -> Result<Grid, FieldError> {
        let mut g = Grid::filled(self.dims, self.origin, self.spacing, self.background)?;
        let [nx, ny, _] = self.dims;
        g.data_mut()
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slice)| {
                for (n, v) in slice.iter_mut().enumerate() {
                    *v = self.get(n % nx, n / nx, k);
                }
            });
        Ok(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Aabb, sample_into};

    struct Ball(f32);
    impl Field for Ball {
        fn value(&self, p: Vec3) -> f32 {
            p.length() - self.0
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(Vec3::splat(-self.0), Vec3::splat(self.0))
        }
    }

    fn ball_grid(n: usize) -> Grid {
        let h = 2.0 / (n - 1) as f32;
        let mut g = Grid::new([n, n + 3, n - 5], Vec3::splat(-1.0), h).unwrap();
        sample_into(&Ball(0.6), &mut g);
        g
    }

    #[test]
    fn round_trip_keeping_everything_is_exact() {
        let g = ball_grid(37);
        for (brick, apron) in [(8, 2), (4, 1), (16, 0)] {
            let b = BrickGrid::from_grid(&g, brick, apron, f32::INFINITY, 1e9).unwrap();
            assert_eq!(b.brick_count(), b.brick_dims().iter().product::<usize>());
            assert_eq!(b.to_grid().unwrap(), g);
        }
    }

    #[test]
    fn band_keeps_near_bricks_and_apron_matches_neighbours() {
        let g = ball_grid(41);
        let band = 0.1;
        let b = BrickGrid::from_grid(&g, 8, 2, band, 7.0).unwrap();
        assert!(b.brick_count() < b.brick_dims().iter().product::<usize>());
        let back = b.to_grid().unwrap();
        for ([i, j, k], v) in g.iter() {
            let w = back.get(i, j, k);
            if v.abs() <= band {
                assert_eq!(w, v, "band sample dropped at {i},{j},{k}");
            } else {
                assert!(w == v || w == 7.0f32.copysign(v), "{v} read as {w}");
            }
        }
        // Apron samples equal the virtual grid (clamped at the border).
        let side = 12i32;
        for (n, info) in b.bricks().iter().enumerate() {
            let lo = IVec3::from_array(info.coord.map(|v| v as i32 * 8)) - IVec3::splat(2);
            for (m, &v) in b.brick_data(n).iter().enumerate() {
                let l = IVec3::new(
                    m as i32 % side,
                    (m as i32 / side) % side,
                    m as i32 / (side * side),
                );
                assert_eq!(v, g.get_clamped(lo + l));
            }
            assert!(info.min <= band && info.max >= -band);
        }
    }

    #[test]
    fn lazy_sampling_matches_dense_in_the_band_and_skips_far_bricks() {
        let n = 128;
        let h = 2.0 / (n - 1) as f32;
        let band = 2.0 * h;
        let lazy =
            BrickGrid::sample_field(&Ball(0.6), [n; 3], Vec3::splat(-1.0), h, 8, 1, band, band)
                .unwrap();
        let mut dense = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
        sample_into(&Ball(0.6), &mut dense);
        let from_dense = BrickGrid::from_grid(&dense, 8, 1, band, band).unwrap();
        for ([i, j, k], v) in dense.iter() {
            if v.abs() <= band {
                assert_eq!(lazy.get(i, j, k), v);
            }
        }
        // Every brick the dense conversion keeps was sampled lazily too.
        for info in from_dense.bricks() {
            assert!(lazy.brick_at(info.coord.map(|v| v as usize)).is_some());
        }
        let f = lazy.evaluated_fraction();
        // A shell of bricks around the sphere, aprons included (bricks of 8 with apron 1).
        assert!(f > 0.05 && f < 0.3, "evaluated fraction {f}");
        // Aprons, copied from neighbours or evaluated, equal the dense samples.
        for (n, info) in lazy.bricks().iter().enumerate() {
            let lo = IVec3::from_array(info.coord.map(|v| v as i32 * 8)) - IVec3::ONE;
            for (m, &v) in lazy.brick_data(n).iter().enumerate() {
                let l = IVec3::new(m as i32 % 10, (m as i32 / 10) % 10, m as i32 / 100);
                assert_eq!(v, dense.get_clamped(lo + l));
            }
        }
        eprintln!("lazy brick sampling evaluated {:.3} of the dense grid", f);
    }

    /// With apron 0 the next layer of samples (which the brick's cells reach) is not
    /// stored: the min/max must still cover it, exactly as `from_grid` computes them.
    #[test]
    fn lazy_brick_min_max_cover_the_next_layer_without_apron() {
        let n = 64;
        let h = 2.0 / (n - 1) as f32;
        let band = 3.0 * h;
        let mut dense = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
        sample_into(&Ball(0.6), &mut dense);
        for apron in [0, 1] {
            let lazy = BrickGrid::sample_field(
                &Ball(0.6),
                [n; 3],
                Vec3::splat(-1.0),
                h,
                8,
                apron,
                band,
                band,
            )
            .unwrap();
            let all = BrickGrid::from_grid(&dense, 8, apron, f32::INFINITY, band).unwrap();
            assert!(lazy.brick_count() > 0);
            for info in lazy.bricks() {
                let m = all.brick_at(info.coord.map(|v| v as usize)).unwrap();
                let want = all.bricks()[m];
                assert_eq!(
                    (info.min, info.max),
                    (want.min, want.max),
                    "apron {apron}, brick {:?}",
                    info.coord
                );
            }
        }
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert!(BrickGrid::new([8; 3], Vec3::ZERO, 1.0, 6, 1, 0.0).is_err());
        assert!(BrickGrid::new([8; 3], Vec3::ZERO, 1.0, 8, 9, 0.0).is_err());
        assert!(BrickGrid::new([1 << 20; 3], Vec3::ZERO, 1.0, 8, 1, 0.0).is_err());
        assert!(BrickGrid::new([8; 3], Vec3::ZERO, -1.0, 8, 1, 0.0).is_err());
        let b = BrickGrid::new([8; 3], Vec3::ZERO, 1.0, 8, 1, 3.0).unwrap();
        assert_eq!(b.get(100, 0, 0), 3.0);
    }

    #[test]
    fn dropped_bricks_inside_read_negative() {
        let g = ball_grid(40);
        let b = BrickGrid::from_grid(&g, 4, 1, 0.1, 0.5).unwrap();
        // The ball's centre lies deep inside: its brick is dropped and marked inside.
        let c = [19 / 4, 20 / 4, 17 / 4];
        assert!(b.brick_at(c).is_none() && b.is_inside(c));
        assert_eq!(b.get(19, 20, 17), -0.5);
        assert_eq!(b.get(0, 0, 0), 0.5);
        let lazy = BrickGrid::sample_field(
            &Ball(0.6),
            g.dims(),
            g.origin(),
            g.spacing(),
            4,
            1,
            0.1,
            0.5,
        )
        .unwrap();
        assert!(lazy.is_inside(c));
        // Every sample has the dense field's sign.
        for ([i, j, k], v) in g.iter() {
            if v.abs() > 1e-6 {
                assert_eq!(lazy.get(i, j, k) > 0.0, v > 0.0, "sample {i} {j} {k}: {v}");
                assert_eq!(b.get(i, j, k) > 0.0, v > 0.0);
            }
        }
    }
}
