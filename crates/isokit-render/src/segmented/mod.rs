//! Ray casting a segmented distance field (003 Sec. 4): the surfaces between the regions of a
//! field sampled as `f = min(d_E, δ) + D r` (003 Eq. 4, [`Segmentation`]), with junctions and
//! boundaries, found along each ray with the region pair that owns each hit.
//!
//! Interpolating segmented values across regions makes values of neither (003 Sec. 4.2,
//! Fig. 7: between regions 1 and 3 a linear filter yields region 2), so each sample along
//! the ray takes its lattice point's value by nearest-neighbour lookup, as 003 requires.
//! Between two consecutive samples whose lattice points `P_u`, `P_v` differ, the surface
//! passes where 003 Eq. 5–7 say ([`Segmentation::crossing`], with `w` the points' distance):
//! at `X = P_u + t (P_v − P_u)` with `t` from Eq. 6, the point the mesher
//! (`isokit_levelset::segmented::mesh_segmented`) puts on that lattice edge; the hit is
//! where the ray meets the plane through `X` with the normal there (exact for planar
//! surfaces). The march steps half a spacing, so consecutive samples' points differ by at
//! most one index per axis; where a sample's distance says no surface is near, it jumps
//! ahead by that distance less 1.87 spacings (empty-space skipping by the distances the
//! field holds, up to the clamp `δ`).
//!
//! 003's own route tabulates Eq. 5–7 as the *vertex generation diagram* ([`VertexDiagram`]):
//! a 2D table over (front value, back value) holding whether a surface passes and where, so
//! the renderer makes one look-up per step (003 Sec. 4.2). Eq. 7 depends on how far apart
//! the two samples' points are; consecutive samples' points are neighbours across a face, an
//! edge or a corner of a lattice cell (`1`, `√2` or `√3` spacings apart), so the diagram has
//! one layer for each. Its entries stand for the values up to half an entry either side, so
//! each layer takes Eq. 7's bound one entry (`D / levels`) wider, lest a pair at the bound
//! be lost: near a boundary's rim it may accept a pair up to one entry beyond Eq. 7's
//! bound. Its resolution, levels per region period, is a knob.
//!
//! Normals: the gradient of the pair's signed distance (`+d` in the front region, `−d` in the
//! back region, `+d` elsewhere) interpolated trilinearly over the lattice cell around the
//! hit, turned to face the ray. The GPU twin is [`crate::gpu::GpuRenderer::render_segmented`]
//! (`shaders/segmented.wgsl`, host code in `segmented/gpu.rs`).

use crate::kernel::{GSample, ID_SURFACE, Uniforms, pixel_ray};
use crate::{GBuffer, RenderError};
use glam::{IVec3, Vec3};
use isokit_field::segmentation::Segmentation;
use isokit_field::{Grid, Job};
use rayon::prelude::*;

pub(crate) mod gpu;

/// 003's vertex generation diagram: for a pair of segmented values (front, back), whether
/// a surface passes between them and where (Eq. 5–7), tabulated at `levels` values per
/// region period over `regions` regions, looked up at the nearest entry; one layer for
/// samples `h`, `√2 h` and `√3 h` apart.
#[derive(Clone, Debug)]
pub struct VertexDiagram {
    seg: Segmentation,
    /// Entries per region period.
    levels: usize,
    /// Entries per axis (`levels · regions`).
    n: usize,
    /// Per entry: `t` of Eq. 6, or a negative value where no surface passes; three layers.
    t: Vec<f32>,
}

/// The largest diagram: 2^24 entries a layer.
const MAX_DIAGRAM: usize = 1 << 24;

impl VertexDiagram {
    /// The diagram of `seg` over regions `0..regions` at `levels` entries per period `D`,
    /// for samples on a lattice of spacing `h` (refused beyond 2^24 entries a layer).
    pub fn new(
        seg: &Segmentation,
        regions: usize,
        levels: usize,
        h: f32,
    ) -> Result<Self, RenderError> {
        let n = levels.saturating_mul(regions);
        if levels < 2 || regions == 0 || n.saturating_mul(n) > MAX_DIAGRAM {
            return Err(RenderError::bad(
                "vertex generation diagram",
                format!("{levels} levels x {regions} regions"),
                "needs 2 or more levels, 1 or more regions and at most 2^24 entries",
            ));
        }
        let value = |a: usize| (a as f32 + 0.5) * seg.period() / levels as f32;
        let t = (0..3 * n * n)
            .into_par_iter()
            .map(|e| {
                // An entry stands for values up to half its width either side: Eq. 7's
                // bound grows by one width, or a pair at the bound would be lost.
                let w = ((e / (n * n) + 1) as f32).sqrt() * h + seg.period() / levels as f32;
                let e = e % (n * n);
                seg.crossing(value(e % n), value(e / n), w)
                    .map_or(-1.0, |(_, _, t)| t)
            })
            .collect();
        Ok(Self {
            seg: *seg,
            levels,
            n,
            t,
        })
    }

    /// The regions of `u` and `v` and `t` of Eq. 6 where the diagram says a surface passes
    /// between samples whose lattice points differ on `axes` axes (1 to 3).
    pub fn lookup(&self, u: f32, v: f32, axes: usize) -> Option<(i32, i32, f32)> {
        let index = |x: f32| {
            let a = (x / self.seg.period() * self.levels as f32).floor();
            (a >= 0.0 && (a as usize) < self.n).then_some(a as usize)
        };
        let (a, b) = (index(u)?, index(v)?);
        let layer = axes.clamp(1, 3) - 1;
        let t = self.t[a + self.n * (b + self.n * layer)];
        (t >= 0.0).then(|| ((a / self.levels) as i32, (b / self.levels) as i32, t))
    }
}

/// A hit on the surface between two regions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentedHit {
    /// Ray parameter (distance along a unit direction).
    pub t: f32,
    /// World position.
    pub position: Vec3,
    /// Unit normal, facing the ray.
    pub normal: Vec3,
    /// The region the ray comes from and the region beyond the surface.
    pub regions: [i32; 2],
}

/// A segmented field prepared for ray casting.
pub struct SegmentedCaster<'g> {
    pub(crate) grid: &'g Grid,
    pub(crate) seg: Segmentation,
    pub(crate) diagram: Option<VertexDiagram>,
}

/// What [`SegmentedCaster::render`] makes: the G-buffer and, per pixel, the region pair
/// the hit lies between (`[a, b]`, `a < b`; `None` where the ray missed).
pub struct SegmentedImage {
    /// Positions, depths, normals (no curvature: 0).
    pub gbuffer: GBuffer,
    /// The pair of regions per pixel, rows from the top.
    pub pairs: Vec<Option<[i32; 2]>>,
}

impl<'g> SegmentedCaster<'g> {
    /// Prepares `grid`, sampled with `seg`; with `diagram`, crossings come from the vertex
    /// generation diagram at that many levels per period, else from Eq. 5–7 directly.
    pub fn new(
        grid: &'g Grid,
        seg: Segmentation,
        diagram: Option<usize>,
    ) -> Result<Self, RenderError> {
        let diagram = match diagram {
            Some(levels) => {
                let top = grid
                    .data()
                    .iter()
                    .filter_map(|&f| seg.decode(f))
                    .map(|(r, _)| r)
                    .max()
                    .unwrap_or(0);
                Some(VertexDiagram::new(
                    &seg,
                    top as usize + 1,
                    levels,
                    grid.spacing(),
                )?)
            }
            None => None,
        };
        Ok(Self { grid, seg, diagram })
    }

    /// The lattice point nearest `x` (clamped into the grid), and its value.
    fn nearest(&self, x: Vec3) -> (IVec3, f32) {
        // Halves round up (WGSL's `round` takes halves to even; the GPU twin floors too).
        let g = ((x - self.grid.origin()) / self.grid.spacing() + 0.5).floor();
        let hi = IVec3::from_array(self.grid.dims().map(|d| d as i32 - 1));
        let c = g.as_ivec3().clamp(IVec3::ZERO, hi);
        (c, self.grid.get_clamped(c))
    }

    fn point(&self, c: IVec3) -> Vec3 {
        self.grid.origin() + c.as_vec3() * self.grid.spacing()
    }

    /// The first surface the ray `o + t d` (`d` of unit length) meets, and the samples it
    /// took.
    pub fn trace(&self, o: Vec3, d: Vec3) -> (Option<SegmentedHit>, u32) {
        let (mut hits, samples) = self.trace_layers(o, d, 1);
        (hits.pop(), samples)
    }

    /// The first `layers` surfaces the ray meets, in the order the march finds them (the
    /// march goes on past each hit), and the samples it took: what a translucent rendering
    /// composites (003 Sec. 4's pre-integrated route, where every slab between two samples
    /// contributes the surface the diagram finds in it).
    pub fn trace_layers(&self, o: Vec3, d: Vec3, layers: usize) -> (Vec<SegmentedHit>, u32) {
        let mut hits = Vec::new();
        let b = self.grid.bounds();
        let Some((t0, t1)) = crate::dvr::slab(o, d, b.min, b.max) else {
            return (hits, 0);
        };
        // The march runs from the entry point `oe`, `s` along the ray from there, so a far
        // camera neither loses the steps to f32 rounding of `t` nor stalls the march.
        let (step, len, oe) = (0.5 * self.grid.spacing(), t1 - t0, o + t0 * d);
        let mut s = 0.0f32;
        let (mut cu, mut u) = self.nearest(oe);
        let mut samples = 1u32;
        while s < len {
            // Empty space: no surface lies within `d − 0.87 h` of the ray here (the sample's
            // distance, its lattice point up to 0.87 h off the ray), so the march jumps to a
            // spacing short of that, without testing across the jump (no surface can lie
            // between, and points that far apart may differ in region beyond a rim).
            let jump =
                self.seg.decode(u).map_or(0.0, |(_, dist)| dist) - 1.87 * self.grid.spacing();
            if jump > step {
                s = (s + jump).min(len);
                (cu, u) = self.nearest(oe + s * d);
                samples += 1;
                continue;
            }
            s = (s + step).min(len);
            let (cv, v) = self.nearest(oe + s * d);
            samples += 1;
            if cv != cu {
                let (pu, pv) = (self.point(cu), self.point(cv));
                let crossing = match &self.diagram {
                    Some(dia) => {
                        let axes = (cv - cu).abs().cmpgt(IVec3::ZERO).bitmask().count_ones();
                        dia.lookup(u, v, axes as usize)
                    }
                    None => self.seg.crossing(u, v, pu.distance(pv)),
                };
                if let Some((i, j, f)) = crossing {
                    // The ray meets the plane through the crossing with the local normal (exact
                    // for a planar surface); nearly parallel rays take the crossing's
                    // projection. The lattice points are up to 0.87 spacings off the ray, so
                    // the plane is met within 0.87 h / |d · n| of this step, before or after;
                    // never outside the box.
                    let x = pu + f * (pv - pu);
                    let normal = self.normal(x, i, j, d);
                    let dn = d.dot(normal).abs();
                    let sh = if dn > 0.1 {
                        let reach = 0.87 * self.grid.spacing() / dn;
                        ((x - oe).dot(normal) / d.dot(normal)).clamp(s - step - reach, s + reach)
                    } else {
                        (x - oe).dot(d)
                    };
                    let sh = sh.clamp(0.0, len);
                    hits.push(SegmentedHit {
                        t: t0 + sh,
                        position: oe + sh * d,
                        normal,
                        regions: [i, j],
                    });
                    if hits.len() >= layers {
                        break;
                    }
                }
            }
            (cu, u) = (cv, v);
        }
        (hits, samples)
    }

    /// The gradient of the pair's signed distance, interpolated trilinearly in the cell
    /// around `x`, facing against `d`.
    fn normal(&self, x: Vec3, front: i32, back: i32, d: Vec3) -> Vec3 {
        let h = self.grid.spacing();
        let g = (x - self.grid.origin()) / h;
        let hi = IVec3::from_array(self.grid.dims().map(|n| (n as i32 - 2).max(0)));
        let c = g.floor().as_ivec3().clamp(IVec3::ZERO, hi);
        let f = (g - c.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
        let signed = |p: IVec3| match self.seg.decode(self.grid.get_clamped(p)) {
            Some((r, dist)) if r == back => -dist,
            Some((r, dist)) if r == front => dist,
            Some((_, dist)) => dist,
            None => 0.0,
        };
        let mut grad = Vec3::ZERO;
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..2 {
                    let s = signed(c + IVec3::new(i, j, k));
                    let w = |a: i32, fa: f32| if a == 1 { fa } else { 1.0 - fa };
                    let dw = |a: i32| if a == 1 { 1.0 } else { -1.0 };
                    grad += s * Vec3::new(
                        dw(i) * w(j, f.y) * w(k, f.z),
                        w(i, f.x) * dw(j) * w(k, f.z),
                        w(i, f.x) * w(j, f.y) * dw(k),
                    );
                }
            }
        }
        let n = grad.normalize_or_zero();
        let n = if n == Vec3::ZERO { -d } else { n };
        if n.dot(d) > 0.0 { -n } else { n }
    }

    /// The G-buffer of the camera in `u` and each pixel's region pair, rows in parallel,
    /// reporting progress to `job` (stage `ray casting regions`, in rows).
    pub fn render(&self, u: &Uniforms, job: &Job) -> Result<SegmentedImage, RenderError> {
        let mut layers = self.render_layers(u, job, 1)?;
        Ok(layers.remove(0))
    }

    /// [`SegmentedCaster::render`] of the first `layers` surfaces along each ray
    /// ([`SegmentedCaster::trace_layers`]): one image per layer, the first the nearest; a
    /// pixel's samples are counted in the first layer only.
    pub fn render_layers(
        &self,
        u: &Uniforms,
        job: &Job,
        layers: usize,
    ) -> Result<Vec<SegmentedImage>, RenderError> {
        let (w, h) = crate::check_image_size(u64::from(u.width), u64::from(u.height))?;
        check_layers(layers)?;
        let counter = job.counter("ray casting regions", u64::from(h));
        let rows = (0..h)
            .into_par_iter()
            .map(|y| {
                job.check()?;
                let row: Vec<(Vec<SegmentedHit>, u32)> = (0..w)
                    .map(|x| {
                        let (o, d) = pixel_ray(u, x, y);
                        self.trace_layers(o, d.normalize_or_zero(), layers)
                    })
                    .collect();
                counter.advance(1);
                Ok(row)
            })
            .collect::<Result<Vec<_>, isokit_field::Cancelled>>()
            .map_err(isokit_field::FieldError::from)?;
        let rays: Vec<(Vec<SegmentedHit>, u32)> = rows.into_iter().flatten().collect();
        Ok(layer_images(w, h, layers, |ray, k| {
            (
                rays[ray].0.get(k).copied(),
                if k == 0 { rays[ray].1 } else { 0 },
            )
        }))
    }
}

/// Composites shaded layers front to back, each surface with the same `opacity`, over an
/// opaque `background` (linear RGB): `shaded[k]` is the shaded image of `layers[k]` (a pixel
/// counts where that layer holds a hit). The translucent rendering of 003's pre-integrated
/// route, where every slab between two samples contributes the surface found in it.
pub fn composite(
    layers: &[SegmentedImage],
    shaded: &[crate::Image],
    opacity: f32,
    background: Vec3,
) -> Result<crate::Image, RenderError> {
    let count = shaded.first().map_or(0, |i| i.pixels.len());
    let sizes_agree = layers.iter().all(|l| l.pairs.len() == count)
        && shaded.iter().all(|i| i.pixels.len() == count);
    if !(opacity > 0.0 && opacity <= 1.0)
        || layers.len() != shaded.len()
        || layers.is_empty()
        || !sizes_agree
    {
        return Err(RenderError::bad(
            "composite",
            format!(
                "opacity {opacity}, {} layers, {} images",
                layers.len(),
                shaded.len()
            ),
            "needs an opacity above 0 up to 1 and one shaded image per layer, all of one size",
        ));
    }
    let (w, h) = (shaded[0].width, shaded[0].height);
    let pixels = (0..count)
        .map(|i| {
            let (mut c, mut trans) = (Vec3::ZERO, 1.0f32);
            for (layer, image) in layers.iter().zip(shaded) {
                if layer.pairs[i].is_none() {
                    break;
                }
                let p = image.pixels[i];
                c += trans * opacity * Vec3::new(p[0], p[1], p[2]);
                trans *= 1.0 - opacity;
            }
            (c + trans * background).extend(1.0).to_array()
        })
        .collect();
    Ok(crate::Image {
        width: w,
        height: h,
        pixels,
    })
}

/// The most layers [`SegmentedCaster::render_layers`] makes.
pub const MAX_LAYERS: usize = 16;

/// Refuses a layer count outside 1 to [`MAX_LAYERS`].
pub(crate) fn check_layers(layers: usize) -> Result<(), RenderError> {
    if !(1..=MAX_LAYERS).contains(&layers) {
        return Err(RenderError::bad(
            "layers",
            layers,
            "must be from 1 to 16 surfaces per ray",
        ));
    }
    Ok(())
}

/// One image per layer from `hit(ray, layer)`: the hit, if any, and the samples to count.
pub(crate) fn layer_images(
    w: u32,
    h: u32,
    layers: usize,
    hit: impl Fn(usize, usize) -> (Option<SegmentedHit>, u32),
) -> Vec<SegmentedImage> {
    (0..layers)
        .map(|k| {
            let count = (w * h) as usize;
            let (mut pixels, mut samples, mut pairs) = (
                Vec::with_capacity(count),
                Vec::with_capacity(count),
                Vec::with_capacity(count),
            );
            for ray in 0..count {
                let (found, n) = hit(ray, k);
                samples.push(n);
                match found {
                    Some(hit) => {
                        let [a, b] = hit.regions;
                        pixels.push(GSample {
                            position: hit.position,
                            depth: hit.t,
                            normal: hit.normal,
                            dir1: hit.normal.any_orthonormal_vector(),
                            id: ID_SURFACE,
                            ..GSample::default()
                        });
                        pairs.push(Some([a.min(b), a.max(b)]));
                    }
                    None => {
                        pixels.push(GSample::default());
                        pairs.push(None);
                    }
                }
            }
            SegmentedImage {
                gbuffer: GBuffer::new(w, h, pixels, samples),
                pairs,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::{Camera, Projection};

    /// A segmented field of `n³` samples over `[-1, 1]³` from `(distance, region)` per
    /// point.
    fn field(n: usize, f: impl Fn(Vec3) -> (f32, i32)) -> (Grid, Segmentation) {
        let h = 2.0 / (n - 1) as f32;
        let mut g = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
        let seg = Segmentation::for_spacing(h).unwrap();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let (d, r) = f(g.position(i, j, k));
                    g.set(i, j, k, seg.encode(d, r).unwrap());
                }
            }
        }
        (g, seg)
    }

    fn camera() -> Uniforms {
        let c = Camera::look_at(
            Vec3::new(1.9, -2.6, 2.2),
            Vec3::new(0.0, 0.0, 0.1),
            Vec3::Z,
            Projection::Perspective {
                fov_y_degrees: 40.0,
            },
            64,
            64,
        )
        .unwrap();
        crate::camera_uniforms(&c).unwrap()
    }

    /// The T-junction: region 0 below z = 0, above it region 1 where x < 0 and region 2
    /// where x > 0; the surfaces are the plane z = 0 and the half-plane x = 0, z > 0.
    fn t_junction(p: Vec3) -> (f32, i32) {
        let to_wall = if p.z >= 0.0 {
            p.x.abs()
        } else {
            p.x.hypot(p.z)
        };
        let d = p.z.abs().min(to_wall);
        let r = if p.z < 0.0 {
            0
        } else if p.x < 0.0 {
            1
        } else {
            2
        };
        (d, r)
    }

    #[test]
    fn a_t_junction_is_hit_on_its_surfaces_with_the_right_pairs() {
        let (g, seg) = field(33, t_junction);
        let h = g.spacing();
        let u = camera();
        for levels in [None, Some(256)] {
            let caster = SegmentedCaster::new(&g, seg, levels).unwrap();
            let img = caster.render(&u, &Job::new()).unwrap();
            let (mut hits, mut checked, mut angle) = (0, 0, 0.0f32);
            let (mut worst, mut worst_junction, mut worst_box) = (0.0f32, 0.0f32, 0.0f32);
            for (s, pair) in img.gbuffer.pixels().iter().zip(&img.pairs) {
                let Some(pair) = pair else { continue };
                hits += 1;
                let p = s.position;
                // Within a spacing of the box's faces, where a surface leaves the box, the
                // ray's first nearest sample may lie across the surface from the ray's
                // entry: the hit is then where the ray enters, or a step or two in.
                let off = t_junction(p).0 / h;
                if p.abs().max_element() > 1.0 - h {
                    worst_box = worst_box.max(off);
                    continue;
                }
                if p.x.hypot(p.z) < 1.5 * h {
                    worst_junction = worst_junction.max(off);
                    continue;
                }
                worst = worst.max(off);
                // Away from the junction line the pair is the one of the surface there.
                checked += 1;
                let on_wall = p.x.abs() < p.z.abs();
                let (want, n) = match (on_wall, p.x < 0.0) {
                    (true, _) => ([1, 2], Vec3::X),
                    (false, true) => ([0, 1], Vec3::Z),
                    (false, false) => ([0, 2], Vec3::Z),
                };
                assert_eq!(*pair, want, "{levels:?} at {p}");
                angle = angle.max(s.normal.dot(n).abs().clamp(0.0, 1.0).acos().to_degrees());
            }
            eprintln!(
                "T-junction, diagram {levels:?}: {hits} hits; {checked} away from the junction line and the box: pairs right, worst {worst:.2e} spacing off the surfaces, normals within {angle:.2} deg; within 1.5 spacings of the junction line: worst {worst_junction:.3} spacing; within a spacing of the box: worst {worst_box:.3}"
            );
            assert!(hits > 1500 && checked > 1000, "{hits} {checked}");
            assert!(worst < 0.05, "{worst}");
            assert!(worst_junction < 0.75, "{worst_junction}");
            assert!(worst_box < 1.0, "{worst_box}");
            assert!(angle < 1.0, "{angle}");
        }
    }

    #[test]
    fn the_vertex_generation_diagram_agrees_with_eq_5_to_7() {
        let (g, seg) = field(25, t_junction);
        let u = camera();
        let job = Job::new();
        let direct = SegmentedCaster::new(&g, seg, None)
            .unwrap()
            .render(&u, &job)
            .unwrap();
        for levels in [64, 256, 1024] {
            let table = SegmentedCaster::new(&g, seg, Some(levels))
                .unwrap()
                .render(&u, &job)
                .unwrap();
            let (mut masks, mut pairs, mut dz) = (0, 0, 0.0f32);
            for (i, (a, b)) in direct.pairs.iter().zip(&table.pairs).enumerate() {
                match (a, b) {
                    (Some(x), Some(y)) => {
                        pairs += usize::from(x != y);
                        let (p, q) = (direct.gbuffer.pixels()[i], table.gbuffer.pixels()[i]);
                        // Near the junction line the normal, and so the hit, turns fast.
                        if p.position.x.hypot(p.position.z) > 1.5 * g.spacing() {
                            dz = dz.max((p.depth - q.depth).abs() / g.spacing());
                        }
                    }
                    (None, None) => {}
                    _ => masks += 1,
                }
            }
            eprintln!(
                "diagram at {levels} levels per period: {masks} hit masks and {pairs} pairs differ from Eq. 5-7, depth within {dz:.4} spacing"
            );
            assert!(masks <= 4 && pairs <= 4, "{masks} {pairs}");
            // Measured: 0.13, 0.036, 0.0091 spacing (the entries are D / levels apart).
            assert!(dz < 16.0 / levels as f32, "{dz}");
        }
        // Look-ups at the entries' own values are Eq. 5–7's answers.
        let h = g.spacing();
        let dia = VertexDiagram::new(&seg, 3, 64, h).unwrap();
        let value = |a: usize| (a as f32 + 0.5) * seg.period() / 64.0;
        for axes in 1..=3 {
            let w = (axes as f32).sqrt() * h + seg.period() / 64.0;
            for (a, b) in [
                (3, 64 + 2),
                (10, 130),
                (5, 6),
                (70, 140),
                (63, 64),
                (12, 75),
            ] {
                assert_eq!(
                    dia.lookup(value(a), value(b), axes),
                    seg.crossing(value(a), value(b), w),
                    "{a} {b} {axes}"
                );
            }
        }
        assert_eq!(dia.lookup(-1.0, 0.1, 1), None);
        assert!(VertexDiagram::new(&seg, 3, 1, h).is_err());
        assert!(VertexDiagram::new(&seg, 4096, 4096, h).is_err());
    }

    /// Two stacked planes: region 0 below z = 0, 1 between, 2 above z = 0.5.
    fn stacked(p: Vec3) -> (f32, i32) {
        let d = p.z.abs().min((p.z - 0.5).abs());
        (d, i32::from(p.z > 0.0) + i32::from(p.z > 0.5))
    }

    #[test]
    fn the_march_goes_on_past_each_surface_for_the_layers() {
        let (g, seg) = field(25, stacked);
        let caster = SegmentedCaster::new(&g, seg, None).unwrap();
        let u = camera();
        let layers = caster.render_layers(&u, &Job::new(), 3).unwrap();
        let (mut both, mut worst) = (0, 0.0f32);
        for i in 0..layers[0].pairs.len() {
            let (a, b) = (&layers[0], &layers[1]);
            if let (Some(p), Some(q)) = (a.pairs[i], b.pairs[i]) {
                both += 1;
                // From above: the upper plane first, then the lower; nothing beyond.
                assert_eq!((p, q), ([1, 2], [0, 1]));
                assert!(layers[2].pairs[i].is_none());
                let (x, y) = (a.gbuffer.pixels()[i], b.gbuffer.pixels()[i]);
                assert!(x.depth < y.depth);
                // Within a spacing of the box's sides a hit may be the ray's entry.
                let side = x.position.abs().max(y.position.abs()).max_element();
                if side < 1.0 - g.spacing() {
                    worst = worst.max((x.position.z - 0.5).abs().max(y.position.z.abs()));
                }
            }
        }
        eprintln!("stacked planes: {both} rays through both, worst {worst:.1e} off them");
        assert!(both > 500 && worst < 1e-4, "{both} {worst}");
        assert!(caster.render_layers(&u, &Job::new(), 0).is_err());
        assert!(caster.render_layers(&u, &Job::new(), 17).is_err());
    }

    #[test]
    fn a_far_camera_neither_stalls_the_march_nor_loses_the_surface() {
        // Half a spacing is far below an f32 ulp of the entry's ray parameter here: a march
        // in t would never advance.
        let (g, seg) = field(25, stacked);
        let caster = SegmentedCaster::new(&g, seg, None).unwrap();
        let o = Vec3::new(0.013, -0.021, 1.0e7);
        let (hits, samples) = caster.trace_layers(o, -Vec3::Z, 2);
        assert_eq!(hits.len(), 2, "{samples} samples");
        assert_eq!(hits[0].regions, [2, 1]);
        // The planes at z = 0.5 and 0 (positions from the entry point, not from the eye).
        assert!((hits[0].position.z - 0.5).abs() < 1e-4, "{:?}", hits[0]);
        assert!(hits[1].position.z.abs() < 1e-4, "{:?}", hits[1]);
        assert!(samples < 200, "{samples}");
    }

    #[test]
    fn layers_composite_front_to_back_over_the_background() {
        let (g, seg) = field(25, stacked);
        let caster = SegmentedCaster::new(&g, seg, None).unwrap();
        let u = camera();
        let layers = caster.render_layers(&u, &Job::new(), 2).unwrap();
        let flat = |c: [f32; 4]| crate::Image {
            width: u.width,
            height: u.height,
            pixels: vec![c; (u.width * u.height) as usize],
        };
        let shaded = [flat([1.0, 0.0, 0.0, 1.0]), flat([0.0, 1.0, 0.0, 1.0])];
        let bg = Vec3::new(0.0, 0.0, 1.0);
        let img = composite(&layers, &shaded, 0.25, bg).unwrap();
        for (i, p) in img.pixels.iter().enumerate() {
            let n = layers.iter().take_while(|l| l.pairs[i].is_some()).count();
            let want = match n {
                0 => [0.0, 0.0, 1.0],
                1 => [0.25, 0.0, 0.75],
                _ => [0.25, 0.75 * 0.25, 0.75 * 0.75],
            };
            for k in 0..3 {
                assert!((p[k] - want[k]).abs() < 1e-6, "{n}: {p:?}");
            }
        }
        assert!(composite(&layers, &shaded[..1], 0.25, bg).is_err());
        assert!(composite(&layers, &shaded, 0.0, bg).is_err());
    }

    #[test]
    fn the_gpu_twin_casts_what_the_cpu_twin_casts() {
        let Some(gpu) = isokit_gpu::testing::gpu_or_skip(
            "segmented::the_gpu_twin_casts_what_the_cpu_twin_casts",
        ) else {
            return;
        };
        let mut r = crate::gpu::GpuRenderer::new(gpu).unwrap();
        let (g, seg) = field(33, t_junction);
        let u = camera();
        for levels in [None, Some(256)] {
            let caster = SegmentedCaster::new(&g, seg, levels).unwrap();
            let cpu = caster.render(&u, &Job::new()).unwrap();
            let gpu = r.render_segmented(&caster, &u).unwrap();
            let (mut masks, mut pairs, mut dz, mut angle) = (0, 0, 0.0f32, 0.0f32);
            for i in 0..cpu.pairs.len() {
                let (p, q) = (cpu.gbuffer.pixels()[i], gpu.gbuffer.pixels()[i]);
                match (cpu.pairs[i], gpu.pairs[i]) {
                    (Some(a), Some(b)) => {
                        pairs += usize::from(a != b);
                        dz = dz.max((p.depth - q.depth).abs() / g.spacing());
                        let cos = p.normal.dot(q.normal).clamp(-1.0, 1.0);
                        angle = angle.max(cos.acos().to_degrees());
                    }
                    (None, None) => {}
                    _ => masks += 1,
                }
            }
            let same_samples = cpu.gbuffer.samples() == gpu.gbuffer.samples();
            eprintln!(
                "diagram {levels:?}: {masks} hit masks and {pairs} pairs differ, depth within {dz:.1e} spacing, normals within {angle:.1e} deg, samples equal: {same_samples}"
            );
            assert!(cpu.pairs.iter().flatten().count() > 1500);
            assert!(masks <= 2 && pairs <= 2, "{masks} {pairs}");
            // Measured on lavapipe: the same depths, normals within 0.02 deg (f32 acos of
            // a dot product within an ulp of 1), the same samples.
            assert!(dz < 1e-3 && angle < 0.1, "{dz} {angle}");
            assert!(same_samples);
        }
        // Layers: the same surfaces in the same order, also with the rays in chunks (as
        // images too large for one dispatch are traced).
        let (g, seg) = field(25, stacked);
        let caster = SegmentedCaster::new(&g, seg, Some(256)).unwrap();
        let cpu = caster.render_layers(&u, &Job::new(), 3).unwrap();
        r.set_max_rays_per_dispatch(777);
        let gpu = r.render_segmented_layers(&caster, &u, 3).unwrap();
        for (a, b) in cpu.iter().zip(&gpu) {
            assert_eq!(a.pairs, b.pairs);
            let dz = a
                .gbuffer
                .pixels()
                .iter()
                .zip(b.gbuffer.pixels())
                .map(|(p, q)| (p.depth - q.depth).abs())
                .fold(0.0f32, f32::max);
            assert!(dz < 1e-5, "{dz}");
            assert_eq!(a.gbuffer.samples(), b.gbuffer.samples());
        }
    }
}
