//! Direct volume rendering of a sampled scalar volume: emission–absorption along each ray
//! with a 1D transfer function (dissertation 002 Sec. 2.5.3), post-classified or
//! pre-integrated (Engel, Kraus and Ertl 2001, "High-Quality Pre-Integrated Volume Rendering
//! Using Hardware-Accelerated Pixel Shading"). This module is the CPU twin; the GPU's is
//! [`gpu`] (`shaders/dvr.wgsl`, [`crate::gpu::GpuRenderer::render_dvr`]).
//!
//! ## The model
//! A [`TransferFunction`] maps a value `v` to a linear-RGB emission `c(v)` and an extinction
//! `σ(v)` per world unit, both piecewise linear between control points. A ray through the
//! volume accumulates
//!
//! ```text
//! C = ∫ T(s) σ(v(s)) c(v(s)) ds,   T(s) = exp(−∫₀ˢ σ(v(u)) du),   A = 1 − T(end),
//! ```
//!
//! so a thick uniform medium of emission `c` shows `c`, and a ray's opacity is
//! `1 − exp(−∫σ)` whatever the step (the step's opacity is corrected for its length:
//! `α = 1 − exp(−σ·Δs)`). `v(s)` is the trilinear interpolant of the samples. The result is
//! premultiplied RGBA ([`DvrImage`]).
//!
//! ## Classification
//! - **Post-classification** ([`Classification::Post`]): `v` is sampled at the midpoint of
//!   each step of length `step`, classified, and composited front to back.
//! - **Pre-integration** ([`Classification::Preintegrated`]): `v` is sampled at the ends of
//!   each step and taken to vary linearly between them; the segment's colour and opacity come
//!   from a table over (front value, back value) for that length ([`PreintegrationTable`]),
//!   so a thin spike of the transfer function between two samples still shows. Each table
//!   entry integrates its segment through the transfer function's control points (exact
//!   optical depth on each linear piece, self-attenuation by sub-steps), which costs
//!   O(n² · pieces) for n² entries. Engel et al.'s integral-function tables neglect the
//!   attenuation within a segment; the incremental O(n²) construction of Lum, Wilson and Ma
//!   2004 ([`PreintegrationTable::incremental`], [`TableBuild::Incremental`]) approximates
//!   it and is 8–14× faster to build, 8× less exact on a smooth transfer function
//!   (`benches/dvr_table.rs`): not the default.
//!
//! ## Speed-ups
//! - **Empty-space skipping**: blocks of `block³` cells whose min/max value range the
//!   transfer function gives no extinction anywhere are stepped over. The trilinear
//!   interpolant inside a block stays within its nodes' range, so no skipped sample could
//!   have contributed; samples keep their positions on the ray's step lattice (and a
//!   pre-integrated segment entering a non-empty block gets its front value), so the image
//!   is the same with and without skipping, to rounding (tested: no pixel changes).
//! - **Early ray termination** once the opacity reaches `termination` (default 0.999): what
//!   is left out is at most `1 − termination` of the brightest emission.

pub mod gpu;

use crate::RenderError;
use crate::clip::Clip;
use crate::spherical::SphericalVolume;
use glam::{Vec3, Vec4};
use isokit_field::{Camera, Grid, filter::trilinear};
use rayon::prelude::*;

/// One control point of a [`TransferFunction`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfPoint {
    /// The value it sits at.
    pub value: f32,
    /// Linear-RGB emission.
    pub emission: Vec3,
    /// Extinction per world unit (≥ 0).
    pub sigma: f32,
}

/// A 1D transfer function: emission and extinction piecewise linear between control points
/// sorted by value, constant beyond the first and last.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    points: Vec<TfPoint>,
}

/// The most control points a [`TransferFunction`] takes (every evaluation and table entry
/// walks them).
pub const MAX_TF_POINTS: usize = 4096;

/// The presets of [`TransferFunction::preset`].
pub const TF_PRESETS: &[&str] = &["ct-bone", "ct-skin", "mri-brain", "distance-shell"];

impl TransferFunction {
    /// From control points, sorted here: 1 to [`MAX_TF_POINTS`], finite values and
    /// emissions, non-negative finite extinctions.
    pub fn new(mut points: Vec<TfPoint>) -> Result<Self, RenderError> {
        if points.is_empty() || points.len() > MAX_TF_POINTS {
            return Err(RenderError::bad(
                "transfer function",
                format!("{} points", points.len()),
                "needs 1 to 4096 control points",
            ));
        }
        for p in &points {
            if !(p.value.is_finite() && p.emission.is_finite() && p.sigma.is_finite()) {
                return Err(RenderError::bad(
                    "transfer function point",
                    format!("{p:?}"),
                    "value, emission and sigma must be finite",
                ));
            }
            if p.sigma < 0.0 || p.emission.min_element() < 0.0 {
                return Err(RenderError::bad(
                    "transfer function point",
                    format!("{p:?}"),
                    "emission and sigma must not be negative",
                ));
            }
        }
        points.sort_by(|a, b| a.value.total_cmp(&b.value));
        Ok(Self { points })
    }

    /// From JSON `{"points": [[value, r, g, b, sigma], ...]}` (linear-RGB emission, sigma
    /// the extinction per world unit).
    ///
    /// ```
    /// use isokit_render::dvr::TransferFunction;
    /// let tf = TransferFunction::from_json(
    ///     r#"{"points": [[0, 0, 0, 0, 0], [1, 1, 0.5, 0.2, 4]]}"#).unwrap();
    /// let (c, sigma) = tf.eval(0.5);
    /// assert!((c.x - 0.5).abs() < 1e-6 && (sigma - 2.0).abs() < 1e-6);
    /// assert!(TransferFunction::from_json(r#"{"points": [[0, 1, 1]]}"#).is_err());
    /// ```
    pub fn from_json(text: &str) -> Result<Self, RenderError> {
        let bad = |why: &'static str| RenderError::bad("transfer function", "JSON", why);
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|_| bad("is not valid JSON"))?;
        let list = v
            .get("points")
            .and_then(|p| p.as_array())
            .ok_or_else(|| bad("needs {\"points\": [[value, r, g, b, sigma], ...]}"))?;
        let points = list
            .iter()
            .map(|p| {
                let n: Vec<f64> = p
                    .as_array()
                    .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
                    .unwrap_or_default();
                if n.len() != 5 || p.as_array().map(Vec::len) != Some(5) {
                    return Err(bad("each point must be 5 numbers [value, r, g, b, sigma]"));
                }
                Ok(TfPoint {
                    value: n[0] as f32,
                    emission: Vec3::new(n[1] as f32, n[2] as f32, n[3] as f32),
                    sigma: n[4] as f32,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(points)
    }

    /// What a user names for `grid`: the path of a JSON file ([`TransferFunction::from_json`],
    /// read within the memory budget) or else a preset ([`TransferFunction::preset`] over the
    /// grid's value range and spacing).
    pub fn load(spec: &str, grid: &Grid) -> Result<Self, RenderError> {
        Self::load_for(spec, value_range(grid), grid.spacing())
    }

    /// [`TransferFunction::load`] for data of any kind: presets over the value range
    /// `range` and the length `spacing` (a tetrahedral grid's mean edge, for instance).
    pub fn load_for(spec: &str, range: (f32, f32), spacing: f32) -> Result<Self, RenderError> {
        let path = std::path::Path::new(spec);
        if path.is_file() {
            let bytes = isokit_io::reader::read_file(path)?;
            let text = String::from_utf8(bytes).map_err(|_| {
                RenderError::bad(
                    "transfer function",
                    spec,
                    "is a file that is not UTF-8 text",
                )
            })?;
            return Self::from_json(&text);
        }
        Self::preset(spec, range, spacing)
    }

    /// A preset by name ([`TF_PRESETS`]). `ct-bone` and `ct-skin` are in Hounsfield units;
    /// the others are defined on values normalized to 0–1 over `range` (the volume's min and
    /// max), except `distance-shell`, which is on signed distances: a glowing shell from
    /// `−2 spacing` to `0` of a distance field, scaled by `spacing`.
    pub fn preset(name: &str, range: (f32, f32), spacing: f32) -> Result<Self, RenderError> {
        let (lo, hi) = range;
        let span = if hi > lo { hi - lo } else { 1.0 };
        let norm = |t: f32| lo + t * span;
        let p = |value: f32, r: f32, g: f32, b: f32, sigma: f32| TfPoint {
            value,
            emission: Vec3::new(r, g, b),
            sigma,
        };
        let points = match name {
            "ct-bone" => vec![
                p(150.0, 0.0, 0.0, 0.0, 0.0),
                p(300.0, 0.9, 0.75, 0.6, 20.0),
                p(1200.0, 1.0, 1.0, 0.95, 200.0),
            ],
            "ct-skin" => vec![
                p(-600.0, 0.0, 0.0, 0.0, 0.0),
                p(-300.0, 0.9, 0.6, 0.5, 5.0),
                p(-100.0, 0.95, 0.7, 0.6, 10.0),
                p(100.0, 0.0, 0.0, 0.0, 0.0),
            ],
            "mri-brain" => vec![
                p(norm(0.1), 0.0, 0.0, 0.0, 0.0),
                p(norm(0.3), 0.6, 0.4, 0.3, 2.0),
                p(norm(0.6), 0.9, 0.8, 0.7, 8.0),
                p(norm(1.0), 1.0, 1.0, 1.0, 20.0),
            ],
            "distance-shell" => {
                let h = if spacing > 0.0 { spacing } else { 1.0 };
                vec![
                    p(-2.0 * h, 0.0, 0.0, 0.0, 0.0),
                    p(-h, 1.0, 0.6, 0.2, 4.0 / h),
                    p(0.0, 0.0, 0.0, 0.0, 0.0),
                ]
            }
            _ => {
                return Err(RenderError::bad(
                    "transfer function",
                    name,
                    "is neither a file nor a preset (ct-bone, ct-skin, mri-brain, distance-shell)",
                ));
            }
        };
        Self::new(points)
    }

    /// The control points, sorted by value.
    pub fn points(&self) -> &[TfPoint] {
        &self.points
    }

    /// Emission and extinction at `v` (constant beyond the ends; NaN gives none).
    pub fn eval(&self, v: f32) -> (Vec3, f32) {
        let p = &self.points;
        if v.is_nan() {
            return (Vec3::ZERO, 0.0);
        }
        let i = p.partition_point(|q| q.value <= v);
        if i == 0 {
            return (p[0].emission, p[0].sigma);
        }
        if i == p.len() {
            let l = p[p.len() - 1];
            return (l.emission, l.sigma);
        }
        let (a, b) = (p[i - 1], p[i]);
        let t = (v - a.value) / (b.value - a.value);
        (
            a.emission.lerp(b.emission, t),
            a.sigma + (b.sigma - a.sigma) * t,
        )
    }

    /// The largest extinction over values in `[lo, hi]` (the ends and the control points
    /// between them: the extinction is piecewise linear).
    pub fn max_sigma(&self, lo: f32, hi: f32) -> f32 {
        let ends = self.eval(lo).1.max(self.eval(hi).1);
        self.points
            .iter()
            .filter(|q| q.value > lo && q.value < hi)
            .fold(ends, |m, q| m.max(q.sigma))
    }

    /// Colour (premultiplied) and opacity of a segment of length `len` along which the value
    /// goes linearly from `vf` to `vb`: through each linear piece of the transfer function
    /// in `sub` sub-steps, with the optical depth of each exact (the trapezoid of a linear
    /// extinction) and its colour at its middle.
    pub fn segment(&self, vf: f32, vb: f32, len: f32, sub: usize) -> Vec4 {
        let (vf, vb, len) = (vf as f64, vb as f64, len as f64);
        // Breakpoints in the segment parameter t ∈ [0, 1].
        let mut ts = vec![0.0, 1.0];
        if vb != vf {
            for q in &self.points {
                let t = (q.value as f64 - vf) / (vb - vf);
                if t > 0.0 && t < 1.0 {
                    ts.push(t);
                }
            }
        }
        ts.sort_by(f64::total_cmp);
        let at = |t: f64| self.eval((vf + (vb - vf) * t) as f32);
        let (mut c, mut trans) = (glam::DVec3::ZERO, 1.0f64);
        for w in ts.windows(2) {
            let n = sub.max(1);
            for k in 0..n {
                let t0 = w[0] + (w[1] - w[0]) * k as f64 / n as f64;
                let t1 = w[0] + (w[1] - w[0]) * (k + 1) as f64 / n as f64;
                let depth = 0.5 * (at(t0).1 as f64 + at(t1).1 as f64) * (t1 - t0) * len;
                if depth <= 0.0 {
                    continue;
                }
                let alpha = 1.0 - (-depth).exp();
                c += trans * alpha * at(0.5 * (t0 + t1)).0.as_dvec3();
                trans *= 1.0 - alpha;
            }
        }
        c.as_vec3().extend((1.0 - trans) as f32)
    }
}

/// How samples become colour and opacity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Classification {
    /// Sample, then classify (one sample per step, at its middle).
    #[default]
    Post,
    /// Segments between samples from a pre-integrated table.
    Preintegrated,
}

impl Classification {
    /// `post` or `preintegrated`, as the command line and Python spell it.
    pub fn name(self) -> &'static str {
        match self {
            Classification::Post => "post",
            Classification::Preintegrated => "preintegrated",
        }
    }
}

/// Checks a pre-integration table's value range and segment length; the upper end used
/// (`lo + 1` for an empty range).
fn table_range(what: &'static str, lo: f32, hi: f32, len: f32) -> Result<f32, RenderError> {
    if !(lo.is_finite() && hi.is_finite() && len.is_finite() && len > 0.0) {
        return Err(RenderError::bad(
            what,
            format!("[{lo}, {hi}], {len}"),
            "must be finite, the length positive",
        ));
    }
    Ok(if hi > lo { hi } else { lo + 1.0 })
}

/// Checks a 2D table's size, value range and segment length; the upper end used.
fn table_checks(lo: f32, hi: f32, n: usize, len: f32) -> Result<f32, RenderError> {
    if !(2..=4096).contains(&n) {
        return Err(RenderError::bad(
            "pre-integration table size",
            n,
            "must be 2 to 4096",
        ));
    }
    table_range("pre-integration range or length", lo, hi, len)
}

/// The value of entry `i` of a table of `n` values evenly spaced over `[lo, hi]`.
fn table_value(lo: f32, hi: f32, n: usize, i: usize) -> f32 {
    lo + (hi - lo) * i as f32 / (n - 1) as f32
}

/// The cell and fraction of table coordinate `x` along an axis of `n` entries (clamped;
/// NaN reads entry 0).
fn table_cell(x: f32, n: usize) -> (usize, f32) {
    let x = x.clamp(0.0, (n - 1) as f32);
    let x = if x.is_nan() { 0.0 } else { x };
    let i = (x as usize).min(n - 2);
    (i, x - i as f32)
}

/// Colour and opacity of segments of one length, tabulated over (front, back) values on
/// `n` values evenly spaced over `[lo, hi]` and interpolated bilinearly between them.
#[derive(Clone, Debug)]
pub struct PreintegrationTable {
    pub(crate) lo: f32,
    pub(crate) hi: f32,
    pub(crate) n: usize,
    len: f32,
    pub(crate) entries: Vec<Vec4>,
}

impl PreintegrationTable {
    /// The table of `tf` for segments of length `len` over values `[lo, hi]`, `n × n`
    /// entries (2 to 4096), each from [`TransferFunction::segment`] with 4 sub-steps per
    /// linear piece.
    pub fn new(
        tf: &TransferFunction,
        lo: f32,
        hi: f32,
        n: usize,
        len: f32,
    ) -> Result<Self, RenderError> {
        let hi = table_checks(lo, hi, n, len)?;
        let value = |i: usize| table_value(lo, hi, n, i);
        let entries = (0..n * n)
            .into_par_iter()
            .map(|e| tf.segment(value(e % n), value(e / n), len, gpu::SUB_STEPS as usize))
            .collect();
        Ok(Self {
            lo,
            hi,
            n,
            len,
            entries,
        })
    }

    /// The same table built incrementally in O(n²) (Lum, Wilson and Ma 2004, "High-Quality
    /// Lighting and Efficient Pre-Integration for Volume Rendering", Sec. 4): the segment
    /// from value `v_f` to `v_b` (`k = |b − f|` table intervals) is the segment from `v_f` to
    /// the entry before `v_b`, shortened to `k − 1` of the `k` parts of its length, then one
    /// interval's part. Optical depth scales exactly with length for a given value range
    /// (`τ = L/(v_b − v_f)·∫σ dv`), so the first part's is `τ·(k − 1)/k`; its colour is
    /// rescaled with its opacity (the colour-to-opacity ratio kept: Lum et al.'s
    /// approximation of the attenuation inside the segment); the last interval is one
    /// constant-ratio piece with the trapezoid of its extinction and its emission weighted
    /// by extinction. Within one table interval the transfer function is taken linear, so
    /// control points closer than an interval blur; [`PreintegrationTable::new`] integrates
    /// every entry through the control points instead (O(n²·pieces), exact to its
    /// sub-steps). `benches/dvr_table.rs` measures both.
    pub fn incremental(
        tf: &TransferFunction,
        lo: f32,
        hi: f32,
        n: usize,
        len: f32,
    ) -> Result<Self, RenderError> {
        let hi = table_checks(lo, hi, n, len)?;
        let d = f64::from(len);
        let at = |i: usize| {
            let (c, sigma) = tf.eval(table_value(lo, hi, n, i));
            (c.as_dvec3(), f64::from(sigma))
        };
        let nodes: Vec<(glam::DVec3, f64)> = (0..n).map(at).collect();
        // Interval j (from node j to j + 1): extinction per unit length (trapezoid) and
        // emission weighted by extinction.
        let intervals: Vec<(glam::DVec3, f64)> = nodes
            .windows(2)
            .map(|w| {
                let ((c0, s0), (c1, s1)) = (w[0], w[1]);
                let tau = 0.5 * (s0 + s1);
                let c = if s0 + s1 > 0.0 {
                    (c0 * s0 + c1 * s1) / (s0 + s1)
                } else {
                    0.5 * (c0 + c1)
                };
                (c, tau)
            })
            .collect();
        // One row per front value: entries towards larger and smaller back values, each from
        // its neighbour nearer the front.
        let rows: Vec<Vec<Vec4>> = (0..n)
            .into_par_iter()
            .map(|f| {
                let mut row = vec![(glam::DVec3::ZERO, 0.0f64); n];
                // Constant value over the whole length: exact.
                let (c, sigma) = nodes[f];
                row[f] = (c * (1.0 - (-sigma * d).exp()), sigma * d);
                for dir in [1isize, -1] {
                    let mut b = f as isize + dir;
                    while (0..n as isize).contains(&b) {
                        let k = (b - f as isize).unsigned_abs() as f64;
                        let (cp, tp) = row[(b - dir) as usize];
                        // The earlier part, k − 1 of k parts of the length.
                        let t1 = tp * (k - 1.0) / k;
                        let a_prev = 1.0 - (-tp).exp();
                        let a1 = 1.0 - (-t1).exp();
                        let c1 = if a_prev > 0.0 { cp * (a1 / a_prev) } else { cp };
                        // The last interval, one part of the length.
                        let j = if dir > 0 { b - 1 } else { b } as usize;
                        let (cj, sj) = intervals[j];
                        let t2 = sj * d / k;
                        let c2 = cj * (1.0 - (-t2).exp());
                        row[b as usize] = (c1 + (1.0 - a1) * c2, t1 + t2);
                        b += dir;
                    }
                }
                row.iter()
                    .map(|&(c, tau)| c.as_vec3().extend((1.0 - (-tau).exp()) as f32))
                    .collect()
            })
            .collect();
        let mut entries = vec![Vec4::ZERO; n * n];
        for (f, row) in rows.iter().enumerate() {
            for (b, &e) in row.iter().enumerate() {
                entries[f + n * b] = e;
            }
        }
        Ok(Self {
            lo,
            hi,
            n,
            len,
            entries,
        })
    }

    /// The segment length the table is for.
    pub fn len(&self) -> f32 {
        self.len
    }

    /// Premultiplied colour and opacity of a segment from `vf` to `vb` (clamped to the range).
    pub fn lookup(&self, vf: f32, vb: f32) -> Vec4 {
        let n = self.n;
        let coord = |v: f32| table_cell((v - self.lo) / (self.hi - self.lo) * (n - 1) as f32, n);
        let ((i, fx), (j, fy)) = (coord(vf), coord(vb));
        let e = |a: usize, b: usize| self.entries[a + n * b];
        let r0 = e(i, j).lerp(e(i + 1, j), fx);
        let r1 = e(i, j + 1).lerp(e(i + 1, j + 1), fx);
        r0.lerp(r1, fy)
    }
}

/// Colour and opacity of segments of any length up to `max_len`: the 3D table over (front
/// value, back value, length) that segments of varying length need (rays through
/// tetrahedral cells, Engel et al. 2001 Sec. 4), `n × n × m` entries with the lengths
/// evenly spaced from 0 to `max_len`, interpolated trilinearly.
#[derive(Clone, Debug)]
pub struct PreintegrationTable3 {
    lo: f32,
    hi: f32,
    n: usize,
    m: usize,
    max_len: f32,
    entries: Vec<Vec4>,
}

impl PreintegrationTable3 {
    /// The table of `tf` over values `[lo, hi]` (`n` per axis, 2 to 1024) and lengths
    /// `[0, max_len]` (`m`, 2 to 1024); refused beyond 2^26 entries.
    pub fn new(
        tf: &TransferFunction,
        lo: f32,
        hi: f32,
        n: usize,
        m: usize,
        max_len: f32,
    ) -> Result<Self, RenderError> {
        if !(2..=1024).contains(&n) || !(2..=1024).contains(&m) || n * n * m > 1 << 26 {
            return Err(RenderError::bad(
                "3D pre-integration table size",
                format!("{n} x {n} x {m}"),
                "needs 2 to 1024 entries per axis and at most 2^26 in all",
            ));
        }
        let hi = table_range("3D pre-integration range or length", lo, hi, max_len)?;
        let value = |i: usize| table_value(lo, hi, n, i);
        let entries = (0..n * n * m)
            .into_par_iter()
            .map(|e| {
                let len = max_len * (e / (n * n)) as f32 / (m - 1) as f32;
                if len == 0.0 {
                    return Vec4::ZERO;
                }
                let (f, b) = (e % n, (e / n) % n);
                tf.segment(value(f), value(b), len, gpu::SUB_STEPS as usize)
            })
            .collect();
        Ok(Self {
            lo,
            hi,
            n,
            m,
            max_len,
            entries,
        })
    }

    /// The longest segment the table holds.
    pub fn max_len(&self) -> f32 {
        self.max_len
    }

    /// The table's entries, front value fastest, then back value, then length (the GPU
    /// twin's layout), with `(lo, hi, n, m)`.
    pub(crate) fn layout(&self) -> (&[Vec4], f32, f32, usize, usize) {
        (&self.entries, self.lo, self.hi, self.n, self.m)
    }

    /// Premultiplied colour and opacity of a segment from `vf` to `vb` of length `len`
    /// (values clamped to the range, lengths to `[0, max_len]`).
    pub fn lookup(&self, vf: f32, vb: f32, len: f32) -> Vec4 {
        let coord = table_cell;
        let scale = (self.n - 1) as f32 / (self.hi - self.lo);
        let (i, fi) = coord((vf - self.lo) * scale, self.n);
        let (j, fj) = coord((vb - self.lo) * scale, self.n);
        let (k, fk) = coord(len / self.max_len * (self.m - 1) as f32, self.m);
        let n = self.n;
        let e = |a: usize, b: usize, c: usize| self.entries[a + n * (b + n * c)];
        let plane = |c: usize| {
            let r0 = e(i, j, c).lerp(e(i + 1, j, c), fi);
            let r1 = e(i, j + 1, c).lerp(e(i + 1, j + 1, c), fi);
            r0.lerp(r1, fj)
        };
        plane(k).lerp(plane(k + 1), fk)
    }
}

/// Knobs of [`render_dvr`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DvrOptions {
    /// Step along the ray in world units (`None`: one grid spacing).
    pub step: Option<f32>,
    /// Post-classification or pre-integration.
    pub classification: Classification,
    /// Opacity at which a ray stops (early ray termination); 1 disables it.
    pub termination: f32,
    /// Block edge in cells for empty-space skipping; 0 disables it.
    pub block: usize,
    /// Entries per axis of the pre-integration table.
    pub table_size: usize,
    /// How the pre-integration table is built.
    pub table_build: TableBuild,
    /// The gradient that shades the samples of a Cartesian volume (spherical lattices take
    /// central differences).
    pub gradient: DvrGradient,
    /// Blinn-Phong shading of the samples by the gradient ([`shade_sample`]); off: the
    /// emission alone.
    pub shade: bool,
}

impl Default for DvrOptions {
    fn default() -> Self {
        Self {
            step: None,
            classification: Classification::Post,
            termination: 0.999,
            block: 8,
            table_size: 256,
            table_build: TableBuild::Integrated,
            shade: false,
            gradient: DvrGradient::Tricubic,
        }
    }
}

/// How the pre-integration table is built ([`DvrOptions::table_build`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TableBuild {
    /// Every entry integrated through the transfer function's control points
    /// ([`PreintegrationTable::new`], O(n²·pieces)): the default, about 8× closer to the
    /// exact segments.
    #[default]
    Integrated,
    /// Incrementally, O(n²) ([`PreintegrationTable::incremental`]): about 8–14× faster to
    /// build.
    Incremental,
}

/// The gradient that lights a shaded sample ([`DvrOptions::gradient`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DvrGradient {
    /// The tricubic B-spline's gradient (64 samples; smooth across cells, the filter of the
    /// isosurface caster's normals): the default.
    #[default]
    Tricubic,
    /// Central differences of the trilinear interpolant one spacing apart (6 trilinear
    /// values; faceted where the data is coarse).
    Central,
}

impl DvrGradient {
    /// `tricubic` or `central`, as the command line and Python spell it.
    pub fn name(self) -> &'static str {
        match self {
            DvrGradient::Tricubic => "tricubic",
            DvrGradient::Central => "central",
        }
    }
}

/// What [`render_dvr`] returns.
#[derive(Clone, Debug)]
pub struct DvrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Premultiplied linear RGB and opacity per pixel, rows from the top.
    pub rgba: Vec<Vec4>,
    /// Distance along each ray where the opacity first passes 0.5 (infinite where it never
    /// does), located within its step by the step's own model: exactly for
    /// post-classification's constant extinction, by bisection on a pre-integrated segment.
    pub depth: Vec<f32>,
    /// Samples of the volume taken.
    pub samples: u64,
    /// Blocks stepped over as empty.
    pub skipped_blocks: u64,
    /// The step taken, world units.
    pub step: f32,
    /// How the samples were classified.
    pub classification: Classification,
    /// Whether the samples were shaded by the gradient.
    pub shaded: bool,
    /// The gradient that shaded them, when they were: `tricubic`, `central` (as
    /// [`DvrGradient::name`]) or `point` (a tetrahedral grid's interpolated point
    /// gradients).
    pub gradient: &'static str,
}

/// The channels of [`DvrImage::channels`], in order.
pub const DVR_CHANNELS: [&str; 5] = ["R", "G", "B", "A", "Z"];

impl DvrImage {
    /// Composited over an opaque `background` (linear RGB).
    pub fn over(&self, background: Vec3) -> Vec<Vec3> {
        self.rgba
            .iter()
            .map(|p| p.truncate() + (1.0 - p.w) * background)
            .collect()
    }

    /// The opaque image over `background` (linear RGB), for PNG output.
    pub fn to_image(&self, background: Vec3) -> crate::Image {
        crate::Image {
            width: self.width,
            height: self.height,
            pixels: self
                .over(background)
                .iter()
                .map(|c| c.extend(1.0).to_array())
                .collect(),
        }
    }

    /// The planes [`DVR_CHANNELS`]: premultiplied `R G B`, opacity `A` and depth `Z`.
    pub fn channels(&self) -> Vec<(&'static str, Vec<f32>)> {
        let plane = |i: usize| self.rgba.iter().map(|p| p[i]).collect();
        let mut out: Vec<(&'static str, Vec<f32>)> =
            (0..4).map(|i| (DVR_CHANNELS[i], plane(i))).collect();
        out.push(("Z", self.depth.clone()));
        out
    }

    /// Writes [`DvrImage::channels`] as OpenEXR with the camera's matrices (as the
    /// isosurface G-buffer's).
    pub fn write_exr(&self, path: &std::path::Path, camera: &Camera) -> Result<(), RenderError> {
        let channels = self.channels();
        let refs: Vec<(&str, &[f32])> = channels.iter().map(|(n, v)| (*n, v.as_slice())).collect();
        let (w, h) = (self.width as usize, self.height as usize);
        isokit_io::write_exr_with_camera(path, w, h, &refs, Some(&crate::exr_camera(camera)))?;
        Ok(())
    }

    /// What the rendering did, as the `--stats` object of `isokit render --mode dvr` (and
    /// Python's `Frame.stats`): `backend` and `seconds` are the caller's.
    pub fn stats(&self, backend: &str, seconds: f64) -> serde_json::Value {
        serde_json::json!({
            "mode": "dvr",
            "backend": backend,
            "classification": self.classification.name(),
            "shading": if self.shaded { "phong" } else { "emission" },
            "gradient": if self.shaded { Some(self.gradient) } else { None },
            "step": self.step,
            "samples": self.samples,
            "skipped_blocks": self.skipped_blocks,
            "seconds": seconds,
            "width": self.width,
            "height": self.height,
        })
    }
}

/// Min/max of the samples of each block of `b³` cells (nodes included on both sides).
pub(crate) struct Blocks {
    pub(crate) b: usize,
    pub(crate) counts: [usize; 3],
    pub(crate) empty: Vec<bool>,
}

impl Blocks {
    fn new(grid: &Grid, tf: &TransferFunction, b: usize) -> Self {
        let d = grid.dims();
        let counts = d.map(|n| (n.saturating_sub(1)).div_ceil(b).max(1));
        let empty = (0..counts[0] * counts[1] * counts[2])
            .into_par_iter()
            .map(|e| {
                let c = [
                    e % counts[0],
                    (e / counts[0]) % counts[1],
                    e / (counts[0] * counts[1]),
                ];
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for k in c[2] * b..=((c[2] + 1) * b).min(d[2] - 1) {
                    for j in c[1] * b..=((c[1] + 1) * b).min(d[1] - 1) {
                        for i in c[0] * b..=((c[0] + 1) * b).min(d[0] - 1) {
                            let v = grid.get(i, j, k);
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                    }
                }
                lo <= hi && tf.max_sigma(lo, hi) == 0.0
            })
            .collect();
        Self { b, counts, empty }
    }

    /// The empty block holding grid point `g`, as its box in grid coordinates.
    fn empty_at(&self, g: Vec3) -> Option<(Vec3, Vec3)> {
        let c = [0, 1, 2].map(|a| ((g[a].max(0.0) as usize) / self.b).min(self.counts[a] - 1));
        let e = c[0] + self.counts[0] * (c[1] + self.counts[1] * c[2]);
        self.empty[e].then(|| {
            let lo = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * self.b as f32;
            (lo, lo + Vec3::splat(self.b as f32))
        })
    }
}

/// How the extinction varies along one step, to find where in it the opacity reaches a
/// value (the depth where a ray's opacity passes 0.5 lies between samples).
pub(crate) enum Within {
    /// Post-classification: the step's one sample's extinction throughout.
    Constant(f32),
    /// Pre-integration: the value linear from front to back.
    Linear(f32, f32),
}

impl Within {
    /// The distance into a step of length `len` at which its opacity reaches `alpha`.
    pub(crate) fn opacity_at(&self, tf: &TransferFunction, len: f32, alpha: f32) -> f32 {
        match *self {
            Within::Constant(sigma) if sigma > 0.0 => (-(1.0 - alpha).ln() / sigma).min(len),
            Within::Constant(_) => len,
            Within::Linear(vf, vb) => {
                // The opacity of the step's first part grows with its length: bisection.
                let (mut lo, mut hi) = (0.0f32, 1.0f32);
                for _ in 0..24 {
                    let t = 0.5 * (lo + hi);
                    if tf
                        .segment(vf, vf + (vb - vf) * t, len * t, gpu::SUB_STEPS as usize)
                        .w
                        >= alpha
                    {
                        hi = t;
                    } else {
                        lo = t;
                    }
                }
                hi * len
            }
        }
    }
}

/// Where a ray enters and leaves a box (`None` when it misses). Direction components
/// smaller than 1e-30 count as 1e-30 of their sign, so no infinity or NaN arises (WGSL
/// gives none of them a defined meaning; the GPU twin does the same).
pub(crate) fn slab(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let safe = |x: f32| {
        if x.abs() < 1e-30 {
            1e-30f32.copysign(x)
        } else {
            x
        }
    };
    let inv = Vec3::new(1.0 / safe(d.x), 1.0 / safe(d.y), 1.0 / safe(d.z));
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    let t0 = a.min(b).max_element().max(0.0);
    let t1 = a.max(b).min_element();
    (t0 < t1).then_some((t0, t1))
}

/// What both twins trace with, prepared on the host: the checked step, the
/// pre-integration table and the empty blocks.
pub(crate) struct Prepared {
    pub(crate) step: f32,
    pub(crate) termination: f32,
    pub(crate) shade: bool,
    pub(crate) gradient: DvrGradient,
    pub(crate) table: Option<PreintegrationTable>,
    pub(crate) blocks: Option<Blocks>,
}

/// Checks the knobs against the grid and builds the table and the blocks.
pub(crate) fn prepare(
    grid: &Grid,
    tf: &TransferFunction,
    opts: &DvrOptions,
) -> Result<Prepared, RenderError> {
    let b = grid.bounds();
    let mut p = prepare_for(
        value_range(grid),
        grid.spacing(),
        (b.max - b.min).length(),
        tf,
        opts,
    )?;
    if grid.dims().iter().any(|&n| n < 2) {
        return Err(RenderError::BadVolume {
            dims: grid.dims(),
            why: "needs at least 2 samples along each axis",
        });
    }
    p.blocks = (opts.block > 0).then(|| Blocks::new(grid, tf, opts.block));
    Ok(p)
}

/// Checks the knobs for a volume of values in `range`, one voxel `spacing` long (the
/// default step) and `diagonal` across, and builds the table (no blocks).
pub(crate) fn prepare_for(
    range: (f32, f32),
    spacing: f32,
    diagonal: f32,
    tf: &TransferFunction,
    opts: &DvrOptions,
) -> Result<Prepared, RenderError> {
    let step = opts.step.unwrap_or(spacing);
    if !(step.is_finite() && step > 0.0) {
        return Err(RenderError::bad(
            "step",
            step,
            "must be positive and finite",
        ));
    }
    if !(0.0..=1.0).contains(&opts.termination) {
        return Err(RenderError::bad(
            "termination",
            opts.termination,
            "must be an opacity from 0 to 1",
        ));
    }
    if (diagonal / step) as f64 > 1e7 {
        return Err(RenderError::bad(
            "step",
            step,
            "gives more than 10 million samples per ray; take a longer step",
        ));
    }
    let table = match opts.classification {
        Classification::Post => None,
        Classification::Preintegrated => {
            let (lo, hi) = range;
            Some(match opts.table_build {
                TableBuild::Integrated => {
                    PreintegrationTable::new(tf, lo, hi, opts.table_size, step)?
                }
                TableBuild::Incremental => {
                    PreintegrationTable::incremental(tf, lo, hi, opts.table_size, step)?
                }
            })
        }
    };
    Ok(Prepared {
        step,
        termination: opts.termination,
        shade: opts.shade,
        gradient: opts.gradient,
        table,
        blocks: None,
    })
}

/// The finite samples' min and max (0 and 1 when there are none).
pub fn value_range(grid: &Grid) -> (f32, f32) {
    let (lo, hi) = grid
        .data()
        .iter()
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if lo <= hi { (lo, hi) } else { (0.0, 1.0) }
}

/// Samples are shaded ([`DvrOptions::shade`]) only above this opacity: below it the
/// gradient's six fetches are not worth their cost.
pub const SHADE_MIN_OPACITY: f32 = 1e-3;

/// Ambient, diffuse and specular weights and the shininess (a power of two, taken by
/// repeated squaring in both twins) of [`shade_sample`].
pub const SHADE_WEIGHTS: (f32, f32, f32, u32) = (0.25, 0.75, 0.35, 32);

/// The gradient of the interpolated value at `x` by central differences one spacing `h`
/// apart along each axis (the twin of `gradient` in `dvr.wgsl`).
pub(crate) fn gradient(value: &impl Fn(Vec3) -> f32, x: Vec3, h: f32) -> Vec3 {
    let d = |e: Vec3| value(x + e * h) - value(x - e * h);
    Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)) / (2.0 * h)
}

/// Blinn-Phong shading of a premultiplied sample by a headlight (from the eye along the
/// ray `dir`), two-sided (the gradient's sign is the data's, not an outside): the emission
/// times `ambient + diffuse·|n·l|`, plus `specular·|n·l|^shininess` white light times the
/// opacity (the half vector is the light's direction for a headlight). Unchanged where the
/// gradient vanishes.
pub fn shade_sample(seg: Vec4, gradient: Vec3, dir: Vec3) -> Vec4 {
    let len = gradient.length();
    if len.is_nan() || len <= 1e-20 {
        return seg;
    }
    let (ka, kd, ks, shininess) = SHADE_WEIGHTS;
    let ndl = (gradient.dot(dir) / len).abs();
    let mut spec = ndl;
    let mut p = 1;
    while p < shininess {
        spec *= spec;
        p *= 2;
    }
    (seg.truncate() * (ka + kd * ndl) + Vec3::splat(ks * spec * seg.w)).extend(seg.w)
}

/// What one ray gives: premultiplied colour and opacity, the depth where the opacity
/// passes 0.5, the samples taken and the blocks skipped.
pub(crate) type RayResult = (Vec4, f32, u32, u32);

/// What a ray integrates through: values at world points, where samples are kept, and the
/// part of the ray that holds the volume.
pub(crate) trait Source: Sync {
    /// The interpolated value at `x`.
    fn value(&self, x: Vec3) -> f32;
    /// How far inside the kept region `x` lies (kept where positive), or `None` where
    /// everything is kept.
    fn keep(&self, x: Vec3) -> Option<f32>;
    /// Where the ray is within the volume's support.
    fn segment(&self, ray: isokit_field::Ray) -> Option<(f32, f32)>;
    /// A stretch of the ray where nothing is kept (a spherical lattice's inner sphere):
    /// the steps wholly inside it are passed over.
    fn hole(&self, _ray: isokit_field::Ray) -> Option<(f32, f32)> {
        None
    }
    /// The spacing of the central differences that give the shading gradient.
    fn spacing(&self) -> f32;
    /// World to the block lattice's coordinates (for empty-space skipping).
    fn to_grid(&self, x: Vec3) -> Vec3;
    /// The tricubic B-spline gradient at `x`, where the source has one.
    fn tricubic_gradient(&self, _x: Vec3) -> Option<Vec3> {
        None
    }
}

/// A volume on a Cartesian grid, clipped or not.
pub(crate) struct Cartesian<'a> {
    pub(crate) grid: &'a Grid,
    pub(crate) clip: Option<&'a Clip>,
}

impl Source for Cartesian<'_> {
    fn value(&self, x: Vec3) -> f32 {
        trilinear(self.grid, self.grid.to_grid(x))
    }
    fn keep(&self, x: Vec3) -> Option<f32> {
        self.clip.map(|c| c.keep(x))
    }
    fn segment(&self, ray: isokit_field::Ray) -> Option<(f32, f32)> {
        let b = self.grid.bounds();
        slab(ray.origin, ray.dir, b.min, b.max)
    }
    fn spacing(&self) -> f32 {
        self.grid.spacing()
    }
    fn to_grid(&self, x: Vec3) -> Vec3 {
        self.grid.to_grid(x)
    }
    fn tricubic_gradient(&self, x: Vec3) -> Option<Vec3> {
        Some(tricubic_gradient(self.grid, x))
    }
}

/// The tricubic B-spline gradient at world point `x`, world units: the 64 taps around the
/// cell (clamped to the grid) with the ray caster's f32 weights ([`crate::kernel::bspline4`],
/// `common/bspline.wgsl`), summed in the order `tricubic_gradient` in `dvr.wgsl` sums them
/// (the sampled field's direct scheme, `isokit_field::filter`, sums in f64 and agrees to
/// rounding).
pub fn tricubic_gradient(grid: &Grid, x: Vec3) -> Vec3 {
    use crate::kernel::{bspline4 as bspline_weights, bspline4_d1 as bspline_weights_d1};
    let p = grid.to_grid(x);
    let f = p.floor();
    let a = p - f;
    let d = grid.dims();
    let hi = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32) + Vec3::ONE;
    let c = f.max(Vec3::splat(-3.0)).min(hi).as_ivec3();
    let (wx, wy, wz) = (
        bspline_weights(a.x),
        bspline_weights(a.y),
        bspline_weights(a.z),
    );
    let (dx, dy, dz) = (
        bspline_weights_d1(a.x),
        bspline_weights_d1(a.y),
        bspline_weights_d1(a.z),
    );
    let mut g = Vec3::ZERO;
    for k in 0..4 {
        for j in 0..4 {
            for i in 0..4 {
                let v = grid
                    .get_clamped(c + glam::IVec3::new(i as i32 - 1, j as i32 - 1, k as i32 - 1));
                g.x += dx[i] * wy[j] * wz[k] * v;
                g.y += wx[i] * dy[j] * wz[k] * v;
                g.z += wx[i] * wy[j] * dz[k] * v;
            }
        }
    }
    g / grid.spacing()
}

/// A volume on a spherical lattice: its domain is a clip.
impl Source for SphericalVolume {
    fn value(&self, x: Vec3) -> f32 {
        SphericalVolume::value(self, x)
    }
    fn keep(&self, x: Vec3) -> Option<f32> {
        Some(SphericalVolume::keep(self, x))
    }
    fn segment(&self, ray: isokit_field::Ray) -> Option<(f32, f32)> {
        SphericalVolume::segment(self, ray)
    }
    fn hole(&self, ray: isokit_field::Ray) -> Option<(f32, f32)> {
        SphericalVolume::hole(self, ray)
    }
    fn spacing(&self) -> f32 {
        SphericalVolume::spacing(self)
    }
    fn to_grid(&self, x: Vec3) -> Vec3 {
        x
    }
}

/// One ray through the volume: the CPU twin of `trace_ray` in `shaders/dvr.wgsl`.
pub(crate) fn trace_ray(
    src: &impl Source,
    tf: &TransferFunction,
    p: &Prepared,
    ray: isokit_field::Ray,
) -> RayResult {
    let (h, step) = (src.spacing(), p.step);
    let value = |x: Vec3| src.value(x);
    let Some((t0, t1)) = src.segment(ray) else {
        return (Vec4::ZERO, f32::INFINITY, 0, 0);
    };
    let (mut c, mut trans) = (Vec3::ZERO, 1.0f32);
    let mut depth = f32::INFINITY;
    let (mut samples, mut skipped) = (0u32, 0u32);
    let n = ((t1 - t0) / step).ceil().max(1.0) as u32;
    let mut k = 0u32;
    // Pre-integration: the value at the front of the current segment, once known.
    let mut front: Option<f32> = None;
    let hole = src.hole(ray);
    // The keep measure at the end of the last step, which starts the next one (like
    // `front`, forgotten when steps are passed over).
    let mut keep_front: Option<f32> = None;
    while k < n {
        let s0 = t0 + k as f32 * step;
        if let Some((a, b)) = hole
            && s0 >= a
            && s0 < b
        {
            // Steps wholly in the hole keep nothing: on to the step that holds its end.
            let next = ((b - t0) / step).floor() as u32;
            if next > k {
                k = next;
                front = None;
                keep_front = None;
                continue;
            }
        }
        if let Some(bl) = &p.blocks {
            // Post-classification samples the step's middle; a pre-integrated segment
            // needs both its ends in the empty block.
            let probe = match p.table {
                None => (s0 + step * 0.5).min(t1),
                Some(_) => s0,
            };
            if let Some((lo, hi)) = bl.empty_at(src.to_grid(ray.at(probe))) {
                // Step over the block: to the step that holds its exit.
                let o = src.to_grid(ray.origin);
                if let Some((_, exit)) = slab(o, ray.dir / h, lo, hi) {
                    let next = ((exit - t0) / step).floor() as u32;
                    if next > k {
                        k = next;
                        front = None;
                        keep_front = None;
                        skipped += 1;
                        continue;
                    }
                }
            }
        }
        let s1 = (s0 + step).min(t1);
        // The kept part [a, b] of the step: all of it without a clip.
        let kf = keep_front.or_else(|| src.keep(ray.at(s0)));
        let kb = src.keep(ray.at(s1));
        keep_front = kb;
        let (fa, fb) = match (kf, kb) {
            (Some(kf), Some(kb)) => match kept_part(kf, kb) {
                Some(part) => part,
                None => {
                    front = None;
                    k += 1;
                    continue;
                }
            },
            _ => (0.0, 1.0),
        };
        let (a, b) = (s0 + fa * (s1 - s0), s0 + fb * (s1 - s0));
        let len = b - a;
        // The step's colour and opacity, and what locates its opacity within it.
        let (seg, inside) = match &p.table {
            None => {
                samples += 1;
                let (e, sigma) = tf.eval(value(ray.at(0.5 * (a + b))));
                let alpha = 1.0 - (-sigma * len).exp();
                ((e * alpha).extend(alpha), Within::Constant(sigma))
            }
            Some(table) => {
                let vf = front.unwrap_or_else(|| {
                    samples += 1;
                    value(ray.at(s0))
                });
                let vb = value(ray.at(s1));
                samples += 1;
                front = Some(vb);
                if (fa, fb) != (0.0, 1.0) {
                    // A clipped step: its kept part on the same linear model.
                    let (va, vz) = (vf + (vb - vf) * fa, vf + (vb - vf) * fb);
                    (
                        tf.segment(va, vz, len, gpu::SUB_STEPS as usize),
                        Within::Linear(va, vz),
                    )
                } else if (len - table.len()).abs() <= 1e-6 * table.len() {
                    (table.lookup(vf, vb), Within::Linear(vf, vb))
                } else {
                    (
                        tf.segment(vf, vb, len, gpu::SUB_STEPS as usize),
                        Within::Linear(vf, vb),
                    )
                }
            }
        };
        let seg = if p.shade && seg.w > SHADE_MIN_OPACITY {
            let x = ray.at(0.5 * (a + b));
            let g = match (p.gradient, src.tricubic_gradient(x)) {
                (DvrGradient::Tricubic, Some(g)) => g,
                _ => gradient(&value, x, h),
            };
            shade_sample(seg, g, ray.dir)
        } else {
            seg
        };
        c += trans * seg.truncate();
        let before = trans;
        trans *= 1.0 - seg.w;
        if before > 0.5 && trans <= 0.5 {
            depth = a + inside.opacity_at(tf, len, 1.0 - 0.5 / before);
        }
        if 1.0 - trans >= p.termination {
            break;
        }
        k += 1;
    }
    (c.extend(1.0 - trans), depth, samples, skipped)
}

/// The kept part of a step, as fractions `(a, b)` of it, from the clip's keep measure at
/// its ends (`kf` at the front, `kb` at the back; kept where positive), taken linear
/// between them; `None` when nothing of it is kept (the twin of `kept_part` in
/// `dvr.wgsl`).
pub(crate) fn kept_part(kf: f32, kb: f32) -> Option<(f32, f32)> {
    match (kf > 0.0, kb > 0.0) {
        (true, true) => Some((0.0, 1.0)),
        (false, false) => None,
        // One end kept: the crossing k = 0 at t = kf / (kf − kb), within (0, 1].
        (true, false) => Some((0.0, (kf / (kf - kb)).min(1.0))),
        (false, true) => {
            let t = (kf / (kf - kb)).max(0.0);
            (t < 1.0).then_some((t, 1.0))
        }
    }
}

impl DvrImage {
    /// From the rays' results, row by row.
    pub(crate) fn from_rays(width: u32, height: u32, p: &Prepared, rays: &[RayResult]) -> Self {
        Self {
            width,
            height,
            rgba: rays.iter().map(|r| r.0).collect(),
            depth: rays.iter().map(|r| r.1).collect(),
            samples: rays.iter().map(|r| u64::from(r.2)).sum(),
            skipped_blocks: rays.iter().map(|r| u64::from(r.3)).sum(),
            step: p.step,
            classification: if p.table.is_some() {
                Classification::Preintegrated
            } else {
                Classification::Post
            },
            shaded: p.shade,
            gradient: p.gradient.name(),
        }
    }
}

/// Renders `grid` with the emission–absorption model and `tf` (see the [module](self)
/// docs). The image size is the camera's.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Camera, Grid, Projection, primitives::Sphere, sample_into};
/// use isokit_render::dvr::{DvrOptions, TransferFunction, render_dvr};
///
/// let mut grid = Grid::new([24; 3], Vec3::splat(-1.0), 2.0 / 23.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.6).unwrap(), &mut grid);
/// // Emissive and absorbing inside the sphere (negative distances), clear outside.
/// let tf = TransferFunction::from_json(
///     r#"{"points": [[-0.01, 1, 0.5, 0.2, 5], [0, 0, 0, 0, 0]]}"#).unwrap();
/// let cam = Camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 40.0 }, 16, 16).unwrap();
/// let img = render_dvr(&grid, &cam, &tf, &DvrOptions::default()).unwrap();
/// let (centre, corner) = (img.rgba[8 * 16 + 8], img.rgba[0]);
/// // Through 1.2 of the sphere at sigma 5: opacity 1 - exp(-6).
/// assert!((centre.w - (1.0 - (-6.0f32).exp())).abs() < 0.01 && corner.w == 0.0);
/// ```
pub fn render_dvr(
    grid: &Grid,
    camera: &Camera,
    tf: &TransferFunction,
    opts: &DvrOptions,
) -> Result<DvrImage, RenderError> {
    render_dvr_clipped(grid, camera, tf, opts, None)
}

/// [`render_dvr`] with the volume clipped by `clip` ([`crate::clip`]): every step is cut to
/// the part of it the clip keeps (the clip's field linear between the step's ends), so no
/// sample where the clip cuts contributes. A clip that keeps everything changes nothing.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Camera, Grid, Projection, primitives::{Plane, Sphere}, sample_into};
/// use isokit_render::{clip::Clip, dvr::{DvrOptions, TransferFunction, render_dvr_clipped}};
///
/// let mut grid = Grid::new([24; 3], Vec3::splat(-1.0), 2.0 / 23.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.6).unwrap(), &mut grid);
/// let tf = TransferFunction::from_json(
///     r#"{"points": [[-0.01, 1, 0.5, 0.2, 5], [0, 0, 0, 0, 0]]}"#).unwrap();
/// let cam = Camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 40.0 }, 16, 16).unwrap();
/// // Keep z < 0 (the plane's value z is positive in front): half the sphere's depth.
/// let clip = Clip::from_field(&Plane::new(Vec3::NEG_Z, 0.0).unwrap(), &grid, false).unwrap();
/// let img = render_dvr_clipped(&grid, &cam, &tf, &DvrOptions::default(), Some(&clip)).unwrap();
/// assert!((img.rgba[8 * 16 + 8].w - (1.0 - (-3.0f32).exp())).abs() < 0.01);
/// ```
pub fn render_dvr_clipped(
    grid: &Grid,
    camera: &Camera,
    tf: &TransferFunction,
    opts: &DvrOptions,
    clip: Option<&Clip>,
) -> Result<DvrImage, RenderError> {
    crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
    let p = prepare(grid, tf, opts)?;
    if let Some(c) = clip {
        c.fits(grid)?;
    }
    Ok(trace_all(&Cartesian { grid, clip }, camera, tf, &p))
}

/// The ray through the centre of pixel `pix` (row-major) of `camera`'s image: the rays of
/// both twins of direct volume rendering and of the spherical isosurface.
pub(crate) fn pixel_ray(camera: &Camera, pix: u32) -> isokit_field::Ray {
    let w = camera.width();
    camera.ray((pix % w) as f32 + 0.5, (pix / w) as f32 + 0.5)
}

/// Every pixel's ray through `src`, in parallel.
fn trace_all(src: &impl Source, camera: &Camera, tf: &TransferFunction, p: &Prepared) -> DvrImage {
    let (width, height) = (camera.width(), camera.height());
    let rays: Vec<RayResult> = (0..width * height)
        .into_par_iter()
        .map(|pix| {
            let ray = pixel_ray(camera, pix);
            trace_ray(src, tf, p, ray)
        })
        .collect();
    DvrImage::from_rays(width, height, p, &rays)
}

/// [`render_dvr`] of a volume on a spherical lattice ([`crate::spherical`]): the samples'
/// world positions mapped to the lattice, the domain's boundary cutting each step as a clip
/// does (nothing outside the domain contributes). The default step is
/// [`SphericalVolume::spacing`]; no empty-space skipping (`opts.block` is not used).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Camera, Grid, Projection};
/// use isokit_render::dvr::{DvrOptions, TransferFunction, render_dvr_spherical};
/// use isokit_render::spherical::{SphericalLattice, SphericalVolume};
///
/// // A uniform medium in the shell 0.5 < r < 1: a ray through the centre crosses 1.
/// let grid = Grid::filled([4, 5, 8], Vec3::ZERO, 1.0, 1.0).unwrap();
/// let lattice = SphericalLattice { r: [0.5, 1.0], theta: [0.0, 180.0], phi: [0.0, 315.0] };
/// let vol = SphericalVolume::new(grid, lattice).unwrap();
/// let tf = TransferFunction::from_json(r#"{"points": [[0, 1, 1, 1, 2]]}"#).unwrap();
/// let cam = Camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 30.0 }, 9, 9).unwrap();
/// let img = render_dvr_spherical(&vol, &cam, &tf, &DvrOptions::default()).unwrap();
/// assert!((img.rgba[4 * 9 + 4].w - (1.0 - (-2.0f32).exp())).abs() < 1e-3);
/// ```
pub fn render_dvr_spherical(
    vol: &SphericalVolume,
    camera: &Camera,
    tf: &TransferFunction,
    opts: &DvrOptions,
) -> Result<DvrImage, RenderError> {
    crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
    let p = prepare_spherical(vol, tf, opts)?;
    Ok(trace_all(vol, camera, tf, &p))
}

/// The knobs checked and the table built for a spherical volume.
pub(crate) fn prepare_spherical(
    vol: &SphericalVolume,
    tf: &TransferFunction,
    opts: &DvrOptions,
) -> Result<Prepared, RenderError> {
    let diagonal = 2.0 * vol.lattice().r[1];
    let mut p = prepare_for(vol.value_range(), vol.spacing(), diagonal, tf, opts)?;
    // The lattice's mapping has no tricubic filter here: central differences shade.
    p.gradient = DvrGradient::Central;
    Ok(p)
}
