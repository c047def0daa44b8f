//! The [`Field`] trait: anything that gives a scalar value at a point.

use crate::{Aabb, Cancelled, FieldError, Grid, Job};
use glam::{DVec3, Mat3, Vec3};
use rayon::prelude::*;

/// A scalar field over 3D space. For signed distance fields the surface is the zero set,
/// negative inside, positive outside.
///
/// Implementors give at least [`Field::value`] and [`Field::bounds`]. The defaults of the
/// derivative methods use central differences of step [`Field::fd_step`]; analytic fields
/// override them.
pub trait Field: Send + Sync {
    /// Field value at `p`.
    fn value(&self, p: Vec3) -> f32;

    /// Values at many points (in parallel by default). `out.len()` must equal `points.len()`;
    /// extra entries of the longer slice are left alone.
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        out.par_iter_mut()
            .zip(points.par_iter())
            .for_each(|(o, &p)| *o = self.value(p));
    }

    /// Values at a few points close together, such as the samples of one brick, on the
    /// calling thread; `out.len()` must equal `points.len()`. Fields whose evaluation
    /// searches a spatial structure can start each search from the previous point's answer.
    /// The default calls [`Field::value`] at each point.
    fn values_nearby(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.value(p);
        }
    }

    /// A box that contains the surface (the zero set) and everything the field considers
    /// inside. [`Aabb::INFINITE`] for unbounded fields such as a plane.
    fn bounds(&self) -> Aabb;

    /// An upper bound on `|f(p) - f(q)| / |p - q|`: 1 for exact distance fields, and a
    /// larger value for fields that only bound the distance. Sphere tracing and brick
    /// skipping use it.
    fn lipschitz(&self) -> f32 {
        1.0
    }

    /// True when [`Field::value`] is the exact Euclidean signed distance everywhere (not just
    /// a bound).
    fn is_exact(&self) -> bool {
        false
    }

    /// Step of the finite-difference defaults: 1e-4 of the bounds' diagonal, at least 1e-6
    /// relative to `|p|`, and 1e-4 when the bounds are infinite.
    fn fd_step(&self, p: Vec3) -> f32 {
        let b = self.bounds();
        let scale = if b.is_finite() && !b.is_empty() {
            b.diagonal()
        } else {
            1.0
        };
        (1e-4 * scale).max(1e-6 * p.abs().max_element()).max(1e-12)
    }

    /// Gradient at `p` (central differences by default).
    fn gradient(&self, p: Vec3) -> Vec3 {
        let h = self.fd_step(p);
        let d = |e: Vec3| (self.value(p + h * e) - self.value(p - h * e)) / (2.0 * h);
        Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z))
    }

    /// Hessian at `p`, symmetric ([`finite_difference_hessian`] by default).
    fn hessian(&self, p: Vec3) -> Mat3 {
        finite_difference_hessian(self, p)
    }

    /// A box and a slack with `value(p) ≥ box.distance(p) − slack` at every point `p` (so
    /// the box holds everything where the value is below `−slack`), or `None` when nothing
    /// of the kind is known (the default). An exact distance field has its bounds with slack
    /// 0. Unions of many fields use it to skip whole groups of children by one box test.
    fn distance_box(&self) -> Option<DistanceBox> {
        None
    }

    /// A lower bound on the value at `p` known without evaluating the field, from bounding
    /// boxes alone; [`f32::NEG_INFINITY`] when nothing is known. Never NaN, never above the
    /// value. The default derives it from [`Field::distance_box`].
    fn lower_bound(&self, p: Vec3) -> f32 {
        match self.distance_box() {
            Some(d) => d.lower_bound(p),
            None => f32::NEG_INFINITY,
        }
    }

    /// The value at `p` *clamped to `±cap`*: the result `r` lies in `[−cap, cap]` and
    /// `r == clamp(value(p), −cap, cap)` wherever `|value(p)| < cap`; where `|value(p)| ≥ cap`
    /// it is `±cap` with the right sign. This licence lets a field skip work that cannot
    /// change the clamped result (a union skips children whose lower bound is above the best
    /// value, a mesh answers a band-limited query). `cap = ∞` is the full value. The default
    /// clamps [`Field::value`]. Call it through [`value_clamped`], which first tests
    /// [`Field::lower_bound`].
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.value(p).clamp(-cap, cap)
    }
}

/// See [`Field::distance_box`]: `value(p) ≥ aabb.distance(p) − slack` everywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceBox {
    /// The box.
    pub aabb: Aabb,
    /// How far below the distance to the box the value may be (≥ 0; may be infinite).
    pub slack: f32,
}

impl DistanceBox {
    /// The box of an exact distance field's bounds (slack 0).
    pub fn exact(aabb: Aabb) -> Self {
        Self { aabb, slack: 0.0 }
    }

    /// The lower bound it gives at `p`: the distance to the box less the slack outside a
    /// finite box, [`f32::NEG_INFINITY`] inside it or for an infinite box or slack.
    #[inline]
    pub fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = box_lower_bound(&self.aabb, p) - self.slack;
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }

    /// The box and slack of the smallest of several fields (a union): the union of the
    /// boxes with the largest slack.
    pub fn union(&self, other: &DistanceBox) -> DistanceBox {
        DistanceBox {
            aabb: self.aabb.union(&other.aabb),
            slack: self.slack.max(other.slack),
        }
    }
}

/// `field`'s value at `p` clamped to `±cap` (see [`Field::value_clamped`]), returning `cap`
/// at once where the field's [`Field::lower_bound`] is already at least `cap`. NaN for a
/// non-finite point.
#[inline]
pub fn value_clamped<F: Field + ?Sized>(field: &F, p: Vec3, cap: f32) -> f32 {
    if !p.is_finite() {
        return f32::NAN;
    }
    if cap.is_finite() && field.lower_bound(p) >= cap {
        return cap;
    }
    field.value_clamped(p, cap)
}

/// The lower bound an exact field with (P) — `{f ≤ δ} ⊂ bounds.expanded(δ)` for every
/// `δ ≥ 0`, true of exact distances — has at `p`: the distance to `bounds` outside a finite
/// box, [`f32::NEG_INFINITY`] inside it or for an infinite box.
#[inline]
pub fn box_lower_bound(bounds: &Aabb, p: Vec3) -> f32 {
    if bounds.is_finite() && !bounds.contains(p) {
        bounds.distance(p)
    } else {
        f32::NEG_INFINITY
    }
}

/// The symmetrized central differences of `field`'s gradient at `p`, with step
/// 10 × [`Field::fd_step`]: the default [`Field::hessian`], callable by fields that override
/// it only where they have a closed form.
pub fn finite_difference_hessian<F: Field + ?Sized>(field: &F, p: Vec3) -> Mat3 {
    let h = field.fd_step(p) * 10.0;
    let cols = [Vec3::X, Vec3::Y, Vec3::Z]
        .map(|e| (field.gradient(p + h * e) - field.gradient(p - h * e)) / (2.0 * h));
    let m = Mat3::from_cols(cols[0], cols[1], cols[2]);
    (m + m.transpose()) * 0.5
}

/// Forwards every method, so references and boxes of fields are fields.
macro_rules! forward_field {
    ($($t:ty),*) => {$(
        impl<F: Field + ?Sized> Field for $t {
            fn value(&self, p: Vec3) -> f32 {
                (**self).value(p)
            }
            fn values(&self, points: &[Vec3], out: &mut [f32]) {
                (**self).values(points, out)
            }
            fn values_nearby(&self, points: &[Vec3], out: &mut [f32]) {
                (**self).values_nearby(points, out)
            }
            fn bounds(&self) -> Aabb {
                (**self).bounds()
            }
            fn lipschitz(&self) -> f32 {
                (**self).lipschitz()
            }
            fn is_exact(&self) -> bool {
                (**self).is_exact()
            }
            fn fd_step(&self, p: Vec3) -> f32 {
                (**self).fd_step(p)
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                (**self).gradient(p)
            }
            fn hessian(&self, p: Vec3) -> Mat3 {
                (**self).hessian(p)
            }
            fn distance_box(&self) -> Option<DistanceBox> {
                (**self).distance_box()
            }
            fn lower_bound(&self, p: Vec3) -> f32 {
                (**self).lower_bound(p)
            }
            fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
                (**self).value_clamped(p, cap)
            }
        }
    )*};
}
forward_field!(&F, Box<F>, std::sync::Arc<F>);

/// Samples `field` at every node of `grid` (in parallel, one z-slice per task), overwriting
/// its samples.
pub fn sample_into(field: &dyn Field, grid: &mut Grid) {
    // A default job is never cancelled.
    let _ = sample_into_job(field, grid, &Job::default());
}

/// [`sample_into`] with progress (stage `"sampling"`, one unit per sample) and cancellation
/// checked before every slice.
pub fn sample_into_job(field: &dyn Field, grid: &mut Grid, job: &Job) -> Result<(), Cancelled> {
    let [nx, ny, _] = grid.dims();
    let (origin, h) = (grid.origin(), grid.spacing());
    let progress = job.counter("sampling", grid.len() as u64);
    grid.data_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slice)| {
            if job.is_cancelled() {
                return;
            }
            let pts: Vec<Vec3> = (0..nx * ny)
                .map(|n| origin + h * Vec3::new((n % nx) as f32, (n / nx) as f32, k as f32))
                .collect();
            // The slice is already in parallel; evaluate it sequentially.
            for (o, p) in slice.iter_mut().zip(pts) {
                *o = field.value(p);
            }
            progress.advance(slice.len() as u64);
        });
    job.check()
}

/// Fills `grid` one z-slice per parallel task, for fields evaluated in f64 or with state
/// carried from sample to sample (a warm-started search along a row).
/// `slice(k, positions, values)` receives the f64 positions of slice `k` (x fastest, each
/// `origin + spacing · (i, j, k)` computed in f64) and writes its values; the per-slice
/// results are combined with `merge`, starting from `S::default()`. Progress goes to `job`
/// as `stage`, one unit per sample; a cancelled job stops before the next slice and returns
/// [`Cancelled`] (the grid then holds a mix of old and new samples).
pub fn fill_slices<S: Send + Default>(
    grid: &mut Grid,
    job: &Job,
    stage: &str,
    slice: impl Fn(usize, &mut dyn Iterator<Item = DVec3>, &mut [f32]) -> S + Sync,
    merge: impl Fn(S, S) -> S + Sync + Send,
) -> Result<S, Cancelled> {
    let [nx, ny, _] = grid.dims();
    let (origin, h) = (grid.origin().as_dvec3(), grid.spacing() as f64);
    let progress = job.counter(stage, grid.len() as u64);
    let s = grid
        .data_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .map(|(k, values)| {
            if job.is_cancelled() {
                return S::default();
            }
            let mut pos = (0..nx * ny)
                .map(|n| origin + h * DVec3::new((n % nx) as f64, (n / nx) as f64, k as f64));
            let s = slice(k, &mut pos, values);
            progress.advance(values.len() as u64);
            s
        })
        .reduce(S::default, &merge);
    job.check()?;
    Ok(s)
}

/// Samples `field` on a grid covering its bounds grown by `pad`, with `res` samples along
/// the longest axis.
///
/// ```
/// use isokit_field::{sample_field, Field, Aabb};
/// use glam::Vec3;
/// struct Ball;
/// impl Field for Ball {
///     fn value(&self, p: Vec3) -> f32 { p.length() - 1.0 }
///     fn bounds(&self) -> Aabb { Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)) }
/// }
/// let g = sample_field(&Ball, 33, 0.25).unwrap();
/// assert_eq!(g.dims(), [33, 33, 33]);
/// assert!(g.min_max().unwrap().0 < 0.0);
/// ```
pub fn sample_field(field: &dyn Field, res: usize, pad: f32) -> Result<Grid, FieldError> {
    let mut g = Grid::covering(field.bounds(), res, pad)?;
    sample_into(field, &mut g);
    Ok(g)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Quadratic;
    impl Field for Quadratic {
        fn value(&self, p: Vec3) -> f32 {
            p.x * p.x + 2.0 * p.y * p.z - p.z
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
        }
    }

    #[test]
    fn finite_difference_defaults() {
        let p = Vec3::new(0.3, -0.2, 0.5);
        let g = Quadratic.gradient(p);
        let want = Vec3::new(2.0 * p.x, 2.0 * p.z, 2.0 * p.y - 1.0);
        assert!((g - want).length() < 1e-3, "{g} vs {want}");
        let h = Quadratic.hessian(p);
        let want = Mat3::from_cols(
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(0.0, 2.0, 0.0),
        );
        for c in 0..3 {
            assert!((h.col(c) - want.col(c)).length() < 2e-2, "{h} vs {want}");
        }
    }

    #[test]
    fn sampling_matches_value() {
        let g = sample_field(&Quadratic, 9, 0.0).unwrap();
        for ([i, j, k], v) in g.iter() {
            assert_eq!(v, Quadratic.value(g.position(i, j, k)));
        }
        let mut out = vec![0.0; 3];
        let pts = [Vec3::ZERO, Vec3::X, Vec3::Y];
        Quadratic.values(&pts, &mut out);
        assert_eq!(out, vec![0.0, 1.0, 0.0]);
    }

    #[test]
    fn slices_see_f64_positions_and_merge() {
        let mut g = Grid::new([3, 4, 5], Vec3::new(0.5, -1.0, 2.0), 0.25).unwrap();
        let rows = fill_slices(
            &mut g,
            &Job::default(),
            "test",
            |k, positions, values| {
                for (p, v) in positions.zip(values.iter_mut()) {
                    assert_eq!(p.z, 2.0 + 0.25 * k as f64);
                    *v = (p.x + p.y + p.z) as f32;
                }
                1usize
            },
            |a, b| a + b,
        )
        .unwrap();
        assert_eq!(rows, 5);
        for ([i, j, k], v) in g.iter() {
            let p = g.position(i, j, k);
            assert_eq!(v, p.x + p.y + p.z);
        }
        let job = Job::new();
        job.cancel();
        let r = fill_slices(&mut g, &job, "test", |_, _, _| (), |(), ()| ());
        assert_eq!(r, Err(Cancelled));
    }
}
