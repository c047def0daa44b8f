//! The CPU twin of `shaders/splat.wgsl` ([`fragment`], [`resolve`], [`ShadowMap::render`],
//! with [`crate::quadric::intersect`]) and of `shaders/splat_shade.wgsl` ([`shade_splat`],
//! [`shadow_factor`], [`outline_weight`] and their helpers), with the scene, options and
//! frame types both twins share. Documented in [`crate::splat`], which re-exports it all.

use glam::{DVec3, Vec3};
use isokit_field::curvature::curvature;
use isokit_field::{Camera, Projection};
use rayon::prelude::*;
use std::time::Instant;

use crate::kernel::{self, GSample, ID_CAP, ID_SURFACE, Uniforms};
use crate::quadric::{HitKind, Quadric, QuadricSetup, View, intersect, setup_hessian};
use crate::shade::{Image, Light, Shading, default_light, shade_pixel_color};
use crate::{GBuffer, RenderError};

/// Object index of a pixel that no quadric covers.
pub const NO_OBJECT: u32 = u32::MAX;

/// Tile edge of the CPU splatter's binning, pixels.
pub const TILE: u32 = 16;

/// Largest number of quadrics a scene may hold (the object index is a u32 and each set-up
/// takes 144 bytes: 16 M quadrics are 2.25 GiB).
pub const MAX_QUADRICS: usize = 1 << 24;

/// Quadric solids with a colour each.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplatScene {
    /// The solids.
    pub quadrics: Vec<Quadric>,
    /// Linear RGB colour per solid (same length as `quadrics`).
    pub colors: Vec<Vec3>,
}

impl SplatScene {
    /// Adds a solid with its colour.
    pub fn push(&mut self, q: Quadric, color: Vec3) {
        self.quadrics.push(q);
        self.colors.push(color);
    }
    /// Number of solids.
    pub fn len(&self) -> usize {
        self.quadrics.len()
    }
    /// True when there are no solids.
    pub fn is_empty(&self) -> bool {
        self.quadrics.is_empty()
    }
    /// Checks the scene: colours match, not too many solids, colours finite.
    pub fn check(&self) -> Result<(), RenderError> {
        if self.colors.len() != self.quadrics.len() {
            return Err(RenderError::bad(
                "scene",
                format!(
                    "{} colours for {} quadrics",
                    self.colors.len(),
                    self.quadrics.len()
                ),
                "needs one colour per quadric",
            ));
        }
        if self.quadrics.len() > MAX_QUADRICS {
            return Err(RenderError::bad(
                "scene",
                self.quadrics.len(),
                "holds more than 16,777,216 quadrics",
            ));
        }
        if self.colors.iter().any(|c| !c.is_finite()) {
            return Err(RenderError::bad(
                "scene",
                "colour",
                "colours must be finite",
            ));
        }
        Ok(())
    }
    /// World bounds of all solids, `None` when empty.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        self.quadrics
            .iter()
            .map(Quadric::bounds)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }
}

/// Options of the splat pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatOptions {
    /// Near plane, world distance along the view direction; `None`: 1e-4 of the distance
    /// from the eye to the scene's centre (perspective), 0 (orthographic).
    pub near: Option<f32>,
    /// CPU twin: evaluate every fragment, as the GPU does, instead of skipping the
    /// quadrics that lie behind a tile's already covered pixels (occlusion culling: the
    /// same image, fewer fragments evaluated; for comparisons and statistics).
    pub exhaustive: bool,
}

/// Largest number of (tile, quadric) pairs the CPU twin bins (4 GiB of indices): a scene
/// whose boxes cover more is refused with an error rather than exhausting memory.
pub const MAX_BIN_ENTRIES: u64 = 1 << 30;

/// Largest number of fragments (pixel centres inside quadric boxes, summed) the CPU twin
/// splats in one pass: a protein of 6,500 atoms at 1024x768 has 2.5 million; 20,000
/// coincident atoms have 15 billion. Beyond it the pass is refused at once.
pub const MAX_FRAGMENTS: u64 = 1 << 30;

/// Counts of a splat pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatStats {
    /// Quadrics in the scene.
    pub quadrics: usize,
    /// Quadrics with a box on screen (not culled).
    pub drawn: usize,
    /// Fragments: pixel centres inside boxes (what a rasterizer would shade).
    pub fragments: u64,
    /// Fragments whose intersection was evaluated: all of them on the GPU and with
    /// [`SplatOptions::exhaustive`], fewer on the CPU with occlusion culling.
    pub evaluated: u64,
    /// Evaluated fragments whose ray hit their quadric.
    pub hits: u64,
    /// Wall time of set-up, seconds.
    pub setup_seconds: f64,
    /// Wall time of the splat, seconds.
    pub splat_seconds: f64,
}

/// The result of a splat pass.
#[derive(Clone, Debug, PartialEq)]
pub struct SplatFrame {
    /// Per pixel: position, normal, `Z` (distance along the ray), curvatures, id
    /// ([`ID_SURFACE`], [`ID_CAP`] for caps and near cuts, [`ID_MISS`](crate::kernel::ID_MISS)).
    pub gbuffer: GBuffer,
    /// Per pixel: the index of the quadric seen, or [`NO_OBJECT`].
    pub objects: Vec<u32>,
    /// The camera as ray-caster uniforms (for [`crate::shade()`] and the twins).
    pub uniforms: Uniforms,
    /// The view the set-ups were made for (near plane included).
    pub view: View,
    /// Counts and times.
    pub stats: SplatStats,
}

pub use crate::camera_uniforms;

/// The view of `u` with the near plane of `opts` for `scene`.
pub fn view_for(
    u: &Uniforms,
    scene: &SplatScene,
    opts: &SplatOptions,
) -> Result<View, RenderError> {
    let near = match opts.near {
        Some(n) if n.is_finite() && (n > 0.0 || (u.ortho != 0 && n >= 0.0)) => f64::from(n),
        Some(n) => {
            return Err(RenderError::bad(
                "near plane",
                n,
                "must be finite and positive (non-negative for orthographic views)",
            ));
        }
        None if u.ortho != 0 => 0.0,
        None => {
            let eye = DVec3::from_array(u.eye.map(f64::from));
            let d = scene
                .bounds()
                .map_or(1.0, |(lo, hi)| (0.5 * (lo + hi) - eye).length());
            (1e-4 * d).max(1e-12)
        }
    };
    Ok(View::from_uniforms(u, near))
}

/// Set-ups of every quadric for `view` in parallel, culled ones left out (in scene order).
pub fn setups(scene: &SplatScene, view: &View) -> Vec<QuadricSetup> {
    scene
        .quadrics
        .par_iter()
        .enumerate()
        .filter_map(|(i, q)| q.setup(view, i as u32))
        .collect()
}

/// The pixel range `[x0, x1) × [y0, y1)` whose centres lie in a set-up's box, clamped to
/// the image.
pub fn pixel_range(s: &QuadricSetup, width: u32, height: u32) -> [u32; 4] {
    let lo = |v: f32, n: u32| (v - 0.5).ceil().clamp(0.0, n as f32) as u32;
    let hi = |v: f32, n: u32| ((v - 0.5).floor() + 1.0).clamp(0.0, n as f32) as u32;
    [
        lo(s.bbox[0], width),
        lo(s.bbox[1], height),
        hi(s.bbox[2], width),
        hi(s.bbox[3], height),
    ]
}

/// One fragment: the ray of pixel `(px, py)` against one quadric; the hit's distance and
/// kind. The twin of the fragment shader in `shaders/splat.wgsl`.
pub fn fragment(
    s: &QuadricSetup,
    u: &Uniforms,
    near: f32,
    px: u32,
    py: u32,
) -> Option<crate::quadric::QuadricHit> {
    FragmentRay::new(u, near, px, py).hit(s)
}

/// What [`intersect`] reads of a pixel's ray: the offset of its origin from the eye (0 for
/// perspective), its direction and the distance of the near plane along it. The same for
/// every quadric covering the pixel: the CPU splatter makes it once per pixel.
#[derive(Clone, Copy, Debug)]
struct FragmentRay {
    offset: Vec3,
    d: Vec3,
    t_near: f32,
}

impl FragmentRay {
    fn new(u: &Uniforms, near: f32, px: u32, py: u32) -> Self {
        let (o, d) = kernel::pixel_ray(u, px, py);
        let forward = Vec3::from_array(u.forward);
        let (offset, t_near) = if u.ortho != 0 {
            (o - Vec3::from_array(u.eye), near)
        } else {
            (Vec3::ZERO, near / d.dot(forward))
        };
        Self { offset, d, t_near }
    }

    fn hit(&self, s: &QuadricSetup) -> Option<crate::quadric::QuadricHit> {
        intersect(s, self.offset, self.d, self.t_near)
    }
}

/// The G-buffer sample of a fragment that won its pixel: position on the ray, the normal
/// (the near cut faces the viewer), and for the quadric surface the principal curvatures
/// from the world gradient and the set-up's Hessian.
pub fn resolve(
    s: &QuadricSetup,
    u: &Uniforms,
    px: u32,
    py: u32,
    hit: &crate::quadric::QuadricHit,
) -> GSample {
    let (o, d) = kernel::pixel_ray(u, px, py);
    let position = o + hit.t * d;
    let forward = Vec3::from_array(u.forward);
    let mut out = GSample {
        position,
        depth: hit.t,
        normal: hit.normal,
        k1: 0.0,
        k2: 0.0,
        dir1: Vec3::ZERO,
        id: ID_CAP,
    };
    match hit.kind {
        HitKind::NearCut => out.normal = -forward,
        HitKind::Cap => {}
        HitKind::Surface => {
            out.id = ID_SURFACE;
            if let Some(c) = curvature(hit.gradient, setup_hessian(s)) {
                out.k1 = c.k1;
                out.k2 = c.k2;
                out.dir1 = c.dir1;
            }
        }
    }
    out
}

/// Splats a scene for a camera into a G-buffer (CPU twin, tiles in parallel).
pub fn splat(
    scene: &SplatScene,
    camera: &Camera,
    opts: &SplatOptions,
) -> Result<SplatFrame, RenderError> {
    scene.check()?;
    let u = camera_uniforms(camera)?;
    let view = view_for(&u, scene, opts)?;
    splat_view_with(scene, &u, view, opts.exhaustive)
}

/// [`splat`] for given uniforms and view, with occlusion culling.
pub fn splat_view(scene: &SplatScene, u: &Uniforms, view: View) -> Result<SplatFrame, RenderError> {
    splat_view_with(scene, u, view, false)
}

/// A lower bound of the distance along any ray from the eye to a quadric: the smallest
/// depth along the view direction of its world box's corners (a ray's distance is at least
/// its point's depth), shrunk by a relative 1e-5 against f32 rounding.
fn nearest_bound(q: &Quadric, view: &View) -> f32 {
    let (lo, hi) = q.bounds();
    let mut n = f64::INFINITY;
    for c in 0..8 {
        let p = DVec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        );
        n = n.min((p - view.eye).dot(view.forward));
    }
    let n = n.max(0.0);
    (n * (1.0 - 1e-5)) as f32
}

/// [`splat_view`], culling or not. With culling each tile takes its quadrics in order of a
/// lower bound of their distance and stops once every pixel of the tile is covered by a hit
/// nearer than the next quadric can be; ties in depth go to the lower quadric index either
/// way.
pub fn splat_view_with(
    scene: &SplatScene,
    u: &Uniforms,
    view: View,
    exhaustive: bool,
) -> Result<SplatFrame, RenderError> {
    let (tiles, mut stats) = splat_core(scene, u, &view, exhaustive, false)?;
    let t2 = Instant::now();
    let (w, h) = (u.width, u.height);
    let n = w as usize * h as usize;
    let mut pixels = vec![GSample::default(); n];
    let mut objects = vec![NO_OBJECT; n];
    for t in tiles {
        for (i, s, o) in t.samples {
            pixels[i as usize] = s;
            objects[i as usize] = o;
        }
    }
    stats.splat_seconds += t2.elapsed().as_secs_f64();
    Ok(SplatFrame {
        gbuffer: GBuffer::new(w, h, pixels, vec![0; n]),
        objects,
        uniforms: *u,
        view,
        stats,
    })
}

/// What one tile of [`splat_core`] produced.
struct TileOut {
    /// G-buffer samples of the winners: pixel index, sample, object.
    samples: Vec<(u32, GSample, u32)>,
    /// Depth-only mode: the winners' depth along the view direction.
    depths: Vec<(u32, f32)>,
}

/// Depth along the view direction of the nearest solid per pixel (+∞ where none): the
/// shadow map's splat, without normals, curvatures or a G-buffer (same culling, same
/// winners as [`splat_view`]).
pub fn splat_depths(scene: &SplatScene, u: &Uniforms, view: View) -> Result<Vec<f32>, RenderError> {
    let (tiles, _) = splat_core(scene, u, &view, false, true)?;
    let mut depth = vec![f32::INFINITY; u.width as usize * u.height as usize];
    for t in tiles {
        for (i, d) in t.depths {
            depth[i as usize] = d;
        }
    }
    Ok(depth)
}

/// The tiled splat shared by [`splat_view_with`] and [`splat_depths`].
fn splat_core(
    scene: &SplatScene,
    u: &Uniforms,
    view: &View,
    exhaustive: bool,
    depth_only: bool,
) -> Result<(Vec<TileOut>, SplatStats), RenderError> {
    scene.check()?;
    isokit_field::memory::check(
        &format!("the set-ups of {} quadrics", scene.len()),
        scene.len() as u128 * (std::mem::size_of::<QuadricSetup>() as u128 + 8),
        "splat fewer quadrics, or raise the budget",
    )?;
    let t0 = Instant::now();
    let set = setups(scene, view);
    let near_t: Vec<f32> = if exhaustive {
        Vec::new()
    } else {
        set.par_iter()
            .map(|s| nearest_bound(&scene.quadrics[s.object as usize], view))
            .collect()
    };
    let setup_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let (w, h) = (u.width, u.height);
    let near = view.near as f32;
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let tiles_of = |r: [u32; 4]| -> u64 {
        if r[0] >= r[2] || r[1] >= r[3] {
            0
        } else {
            u64::from((r[2] - 1) / TILE - r[0] / TILE + 1)
                * u64::from((r[3] - 1) / TILE - r[1] / TILE + 1)
        }
    };
    let ranges: Vec<[u32; 4]> = set.iter().map(|s| pixel_range(s, w, h)).collect();
    let entries: u64 = ranges.iter().map(|r| tiles_of(*r)).sum();
    if entries > MAX_BIN_ENTRIES {
        return Err(RenderError::bad(
            "scene",
            format!(
                "{} quadrics whose boxes cover {entries} (tile, quadric) pairs",
                set.len()
            ),
            "exceeds the CPU splatter's 2^30 binning limit; render a smaller image or fewer overlapping quadrics",
        ));
    }
    isokit_field::memory::check(
        &format!(
            "the tile bins of {} quadrics ({entries} tile and quadric pairs)",
            set.len()
        ),
        u128::from(entries) * 4 + u128::from(tx * ty) * 24,
        "render a smaller image or fewer overlapping quadrics, or raise the budget",
    )?;
    let fragments: u64 = ranges
        .iter()
        .map(|r| u64::from(r[2].saturating_sub(r[0])) * u64::from(r[3].saturating_sub(r[1])))
        .sum();
    // Occlusion culling works per quadric, so quadrics piled on one another (thousands of
    // coincident atoms) are all evaluated at every pixel they cover: refused when that is
    // more than the CPU twin can do in reasonable time.
    if fragments > MAX_FRAGMENTS {
        return Err(RenderError::bad(
            "scene",
            format!(
                "{} quadrics whose boxes cover {fragments} pixels ({:.0} times the {w}x{h} image)",
                set.len(),
                fragments as f64 / (f64::from(w) * f64::from(h))
            ),
            "exceeds the CPU splatter's 2^30 fragments (overlapping or coincident quadrics); remove duplicates, render a smaller image or use --backend gpu",
        ));
    }
    // Bin set-up indices into tiles (scene order within each tile).
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); (tx * ty) as usize];
    for (k, r) in ranges.iter().enumerate() {
        if tiles_of(*r) == 0 {
            continue;
        }
        for by in r[1] / TILE..=(r[3] - 1) / TILE {
            for bx in r[0] / TILE..=(r[2] - 1) / TILE {
                bins[(bx + tx * by) as usize].push(k as u32);
            }
        }
    }
    let tiles: Vec<(TileOut, u64, u64)> = bins
        .into_par_iter()
        .enumerate()
        .map(|(ti, mut list)| {
            let (bx, by) = (ti as u32 % tx, ti as u32 / tx);
            let (x0, y0) = (bx * TILE, by * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let tw = (x1 - x0) as usize;
            let mut best_t = vec![f32::INFINITY; tw * (y1 - y0) as usize];
            let mut best_k = vec![u32::MAX; best_t.len()];
            // Per pixel: its ray (made on first use) and the winning hit so far.
            let mut rays: Vec<Option<FragmentRay>> = vec![None; best_t.len()];
            let mut best_hit: Vec<Option<crate::quadric::QuadricHit>> = vec![None; best_t.len()];
            let (mut evaluated, mut hits) = (0u64, 0u64);
            if !exhaustive {
                list.sort_unstable_by(|a, b| {
                    near_t[*a as usize]
                        .total_cmp(&near_t[*b as usize])
                        .then(a.cmp(b))
                });
            }
            // Pixels of the tile still uncovered, and an upper bound of the covered depths
            // (refreshed every few quadrics once all are covered).
            let mut uncovered = best_t.len();
            let mut far = f32::INFINITY;
            for (n, &k) in list.iter().enumerate() {
                if !exhaustive && uncovered == 0 {
                    if far == f32::INFINITY || n % 16 == 0 {
                        far = best_t.iter().copied().fold(0.0, f32::max);
                    }
                    if near_t[k as usize] > far {
                        break;
                    }
                }
                let s = &set[k as usize];
                let r = ranges[k as usize];
                for py in r[1].max(y0)..r[3].min(y1) {
                    for px in r[0].max(x0)..r[2].min(x1) {
                        evaluated += 1;
                        let i = (px - x0) as usize + tw * (py - y0) as usize;
                        let ray = *rays[i].get_or_insert_with(|| FragmentRay::new(u, near, px, py));
                        if let Some(hit) = ray.hit(s) {
                            hits += 1;
                            if hit.t < best_t[i] || (hit.t == best_t[i] && k < best_k[i]) {
                                if best_k[i] == u32::MAX {
                                    uncovered -= 1;
                                }
                                best_t[i] = hit.t;
                                best_k[i] = k;
                                best_hit[i] = Some(hit);
                            }
                        }
                    }
                }
            }
            let mut out = TileOut {
                samples: Vec::new(),
                depths: Vec::new(),
            };
            let forward = Vec3::from_array(u.forward);
            for (i, (&k, hit)) in best_k.iter().zip(&best_hit).enumerate() {
                let (Some(hit), Some(ray)) = (hit, rays[i]) else {
                    continue;
                };
                let (px, py) = (x0 + (i % tw) as u32, y0 + (i / tw) as u32);
                if depth_only {
                    out.depths.push((px + w * py, hit.t * ray.d.dot(forward)));
                    continue;
                }
                let s = &set[k as usize];
                out.samples
                    .push((px + w * py, resolve(s, u, px, py, hit), s.object));
            }
            (out, evaluated, hits)
        })
        .collect();
    let mut stats = SplatStats {
        quadrics: scene.len(),
        drawn: set.len(),
        fragments,
        setup_seconds,
        ..Default::default()
    };
    let tiles = tiles
        .into_iter()
        .map(|(t, evaluated, hits)| {
            stats.evaluated += evaluated;
            stats.hits += hits;
            t
        })
        .collect();
    stats.splat_seconds = t1.elapsed().as_secs_f64();
    Ok((tiles, stats))
}

impl SplatFrame {
    /// Checks that the parts agree: the G-buffer is the uniforms' size (one sample per
    /// pixel, a single view) and there is one object index per pixel. Frames made by [`splat`] always do;
    /// frames assembled by hand may not.
    pub fn check(&self) -> Result<(), RenderError> {
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        if w != self.uniforms.width
            || h != self.uniforms.height
            || self.objects.len() != w as usize * h as usize
            || self.uniforms.subpixels > 1
        {
            return Err(RenderError::bad(
                "splat frame",
                format!(
                    "{w}x{h} G-buffer, {} objects, {}x{} uniforms",
                    self.objects.len(),
                    self.uniforms.width,
                    self.uniforms.height
                ),
                "G-buffer, object indices and uniforms must agree in size (one view)",
            ));
        }
        Ok(())
    }

    /// Merges a G-buffer rendered for the same camera by another renderer (the isosurface
    /// ray caster, [`crate::render`]) into this frame by depth: each pixel keeps the nearer of
    /// the two hits, as one depth buffer would (both store `Z`, the distance from the eye
    /// along the same pixel ray). Pixels taken from `other` get [`NO_OBJECT`] (shaded in
    /// [`Shading::color`]). Returns how many pixels came from `other`; errors when the sizes
    /// differ.
    pub fn merge_nearest(&mut self, other: &GBuffer) -> Result<usize, RenderError> {
        self.check()?;
        let (w, h) = (self.gbuffer.width(), self.gbuffer.height());
        if other.width() != w || other.height() != h {
            return Err(RenderError::bad(
                "G-buffer",
                format!("{}x{}", other.width(), other.height()),
                "must match the splatted frame's size",
            ));
        }
        let mut pixels = self.gbuffer.pixels().to_vec();
        let mut taken = 0;
        for (i, (p, q)) in pixels.iter_mut().zip(other.pixels()).enumerate() {
            if q.is_hit() && (!p.is_hit() || q.depth < p.depth) {
                *p = *q;
                self.objects[i] = NO_OBJECT;
                taken += 1;
            }
        }
        let samples = self.gbuffer.samples().to_vec();
        self.gbuffer = GBuffer::new(w, h, pixels, samples);
        Ok(taken)
    }
}

/// Shadow-map and soft-shadow parameters (002 Sec. 7.3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowOptions {
    /// Side of the square shadow map, texels.
    pub resolution: u32,
    /// Radius of the filter disc (the penumbra width), texels.
    pub softness: f32,
    /// Spot-light position; `None`: behind and above the camera along the default key
    /// light, as far from the scene's centre as the eye.
    pub light: Option<Vec3>,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        Self {
            resolution: 1024,
            softness: 3.0,
            light: None,
        }
    }
}

/// Outline (silhouette and crease) parameters (002 Sec. 7.3.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutlineOptions {
    /// Linear RGB colour of the lines.
    pub color: Vec3,
    /// Silhouette ramp `(start, full)` of the relative depth residual (see
    /// [`outline_weight`]).
    pub depth: [f32; 2],
    /// Normal-gradient ramp `(start, full)`: `|∇N| / 4`.
    pub crease: [f32; 2],
}

impl Default for OutlineOptions {
    fn default() -> Self {
        Self {
            color: Vec3::splat(0.02),
            depth: [0.002, 0.008],
            crease: [0.8, 1.4],
        }
    }
}

/// What [`shade_splat`] does beyond [`Shading`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplatShading {
    /// The deferred mode, lights and terms (the base colour comes per object).
    pub shading: Shading,
    /// Soft shadows from a spot light.
    pub shadows: Option<ShadowOptions>,
    /// Silhouettes and creases.
    pub outlines: Option<OutlineOptions>,
}

/// Parameters of a shadow map as the shading pass reads them: `ShadowParams` in
/// `shaders/splat_shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadowParams {
    /// Light position.
    pub eye: [f32; 3],
    /// Map side, texels.
    pub resolution: u32,
    /// Light's right vector.
    pub right: [f32; 3],
    /// Half the view height at unit distance.
    pub half_height: f32,
    /// Light's up vector.
    pub up: [f32; 3],
    /// Filter radius, texels.
    pub softness: f32,
    /// Light's axis.
    pub forward: [f32; 3],
    /// Depth bias, relative to the depth.
    pub bias: f32,
}

// The WGSL twin, member by member (`ShadowParams` in `shaders/splat_shade.wgsl`; checked by
// the GPU host code's unit tests).
isokit_gpu::wgsl_layout!(ShadowParams {
    eye: "vec3<f32>",
    resolution: "u32",
    right: "vec3<f32>",
    half_height: "f32",
    up: "vec3<f32>",
    softness: "f32",
    forward: "vec3<f32>",
    bias: "f32",
});

/// A shadow map: depth along the light's axis of the nearest solid per texel (+∞ where
/// none), rendered by the splatter from the spot light's view.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowMap {
    /// How the map projects.
    pub params: ShadowParams,
    /// Depths, row-major, row 0 at the top.
    pub depth: Vec<f32>,
    /// The light (a point light at the spot's position, for shading).
    pub light: Light,
}

impl ShadowMap {
    /// Renders the shadow map of `scene` for a spot light at `light` aimed at the scene's
    /// centre with a cone just containing the scene's bounding sphere.
    pub fn render(
        scene: &SplatScene,
        light: Vec3,
        opts: &ShadowOptions,
    ) -> Result<Self, RenderError> {
        let (u, view, mut map) = Self::prepare(scene, light, opts)?;
        map.depth = splat_depths(scene, &u, view)?;
        Ok(map)
    }

    /// Everything [`ShadowMap::render`] does but the splat (shared with the GPU twin): checks
    /// the options, and returns the light's camera as uniforms, its view (near plane
    /// included) and the map with `depth` still empty.
    pub fn prepare(
        scene: &SplatScene,
        light: Vec3,
        opts: &ShadowOptions,
    ) -> Result<(Uniforms, View, Self), RenderError> {
        let res = opts.resolution;
        if !(16..=8192).contains(&res) {
            return Err(RenderError::bad(
                "shadow map resolution",
                res,
                "must be 16 to 8192",
            ));
        }
        if !(opts.softness.is_finite() && (0.0..=64.0).contains(&opts.softness)) {
            return Err(RenderError::bad(
                "shadow softness",
                opts.softness,
                "must be 0 to 64 texels",
            ));
        }
        let (lo, hi) = scene
            .bounds()
            .ok_or_else(|| RenderError::bad("scene", "empty", "a shadow map needs a solid"))?;
        let centre = (0.5 * (lo + hi)).as_vec3();
        let radius = (0.5 * (hi - lo).length()) as f32;
        let dist = (centre - light).length();
        if !(light.is_finite() && dist > radius * 1.001) {
            return Err(RenderError::bad(
                "light position",
                light,
                "must be finite and outside the scene's bounding sphere",
            ));
        }
        let half = (radius / dist).asin() * 1.02;
        let up = if (centre - light).normalize().cross(Vec3::Y).length() < 1e-3 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let cam = Camera::look_at(
            light,
            centre,
            up,
            Projection::Perspective {
                fov_y_degrees: 2.0 * half.to_degrees(),
            },
            res,
            res,
        )?;
        let u = camera_uniforms(&cam)?;
        let near = (dist - radius) * 0.5;
        let view = View::from_uniforms(&u, f64::from(near));
        let map = Self {
            params: ShadowParams {
                eye: u.eye,
                resolution: res,
                right: u.right,
                half_height: u.half_height,
                up: u.up,
                softness: opts.softness,
                forward: u.forward,
                bias: 2e-3,
            },
            depth: Vec::new(),
            light: Light {
                direction: None,
                position: Some(light),
                color: Vec3::ONE,
                intensity: 1.0,
            },
        };
        Ok((u, view, map))
    }
}

/// PCG-style integer hash (the same in WGSL).
pub fn hash_u32(x: u32) -> u32 {
    let s = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let w = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
    (w >> 22) ^ w
}

/// Shadow-map samples per pixel in a penumbra (002 Sec. 7.3.2).
pub const SHADOW_SAMPLES: u32 = 64;
/// The first samples, spanning the disc, that decide whether a pixel is in a penumbra.
pub const PENUMBRA_TEST_SAMPLES: u32 = 8;

/// Sample `k` (0..64) of the jittered polar grid for screen pixel `(px, py)`: 8 rings × 8
/// angles, the outer ring first (so the first 8 samples span the disc for the penumbra
/// test), jittered per pixel modulo a 4x4 tile (002 Sec. 7.3.2). Offset in units of the
/// filter radius.
pub fn shadow_sample(k: u32, px: u32, py: u32) -> [f32; 2] {
    let ring = 7 - k / 8;
    let angle = k % 8;
    let key = k + 64 * ((px & 3) + 4 * (py & 3));
    let j1 = (hash_u32(key) >> 8) as f32 / 16_777_216.0;
    let j2 = (hash_u32(key ^ 0x9e37_79b9) >> 8) as f32 / 16_777_216.0;
    let r = ((ring as f32 + j1) / 8.0).sqrt();
    let th = std::f32::consts::TAU * (angle as f32 + j2) / 8.0;
    [r * th.cos(), r * th.sin()]
}

/// Fraction of the spot light that reaches world point `p` with normal `n`, seen at screen
/// pixel `(px, py)`: percentage-closer filtering of the shadow map over a disc of
/// `softness` texels by 64 jittered samples, stopped after the first 8 when they agree (all
/// lit or all shadowed: not in a penumbra). Points outside the light's cone are lit.
/// Returns the fraction and the number of samples taken.
pub fn shadow_factor(
    sp: &ShadowParams,
    map: &[f32],
    p: Vec3,
    n: Vec3,
    px: u32,
    py: u32,
) -> (f32, u32) {
    let eye = Vec3::from_array(sp.eye);
    let fwd = Vec3::from_array(sp.forward);
    let d = p - eye;
    let depth = d.dot(fwd);
    if depth.is_nan() || depth <= 0.0 {
        return (1.0, 0);
    }
    let res = sp.resolution as f32;
    // Normal offset: one and a half texels' world size along the normal.
    let texel = 2.0 * sp.half_height * depth / res;
    let q = p + n * (1.5 * texel);
    let dq = q - eye;
    let depth_q = dq.dot(fwd);
    if depth_q.is_nan() || depth_q <= 0.0 {
        return (1.0, 0);
    }
    let sx = dq.dot(Vec3::from_array(sp.right)) / (depth_q * sp.half_height);
    let sy = dq.dot(Vec3::from_array(sp.up)) / (depth_q * sp.half_height);
    let (cx, cy) = ((sx + 1.0) * 0.5 * res, (1.0 - sy) * 0.5 * res);
    let limit = depth_q * (1.0 - sp.bias);
    let lit = |k: u32| -> u32 {
        let o = shadow_sample(k, px, py);
        let (x, y) = (cx + o[0] * sp.softness, cy + o[1] * sp.softness);
        if !(x >= 0.0 && y >= 0.0 && x < res && y < res) {
            return 1;
        }
        let i = x as usize + sp.resolution as usize * y as usize;
        // A map shorter than resolution² (not made by `ShadowMap`) lights what it lacks.
        u32::from(map.get(i).is_none_or(|d| *d >= limit))
    };
    let mut count = 0;
    for k in 0..PENUMBRA_TEST_SAMPLES {
        count += lit(k);
    }
    if count == 0 || count == PENUMBRA_TEST_SAMPLES {
        return (
            count as f32 / PENUMBRA_TEST_SAMPLES as f32,
            PENUMBRA_TEST_SAMPLES,
        );
    }
    for k in PENUMBRA_TEST_SAMPLES..SHADOW_SAMPLES {
        count += lit(k);
    }
    (count as f32 / SHADOW_SAMPLES as f32, SHADOW_SAMPLES)
}

/// The four bilinear fetches at the pixel corners `(x ± ½, y ± ½)` in the order
/// `(−−, +−, −+, ++)`, each the mean of a 2x2 block (edge pixels repeated, as a
/// clamp-to-edge sampler): what a GPU's bilinear filter returns there.
pub fn corner_fetches<const C: usize>(
    img: &[[f32; C]],
    width: u32,
    height: u32,
    x: u32,
    y: u32,
) -> [[f32; C]; 4] {
    let at = |xx: i64, yy: i64| -> [f32; C] {
        let xx = xx.clamp(0, i64::from(width) - 1) as usize;
        let yy = yy.clamp(0, i64::from(height) - 1) as usize;
        img[xx + width as usize * yy]
    };
    let corner = |sx: i64, sy: i64| -> [f32; C] {
        let (x, y) = (i64::from(x), i64::from(y));
        let (a, b, c, d) = (at(x, y), at(x + sx, y), at(x, y + sy), at(x + sx, y + sy));
        std::array::from_fn(|i| 0.25 * (a[i] + b[i] + c[i] + d[i]))
    };
    [corner(-1, -1), corner(1, -1), corner(-1, 1), corner(1, 1)]
}

/// The Sobel derivatives from the four corner fetches: with `C±±` the corner means,
/// `Gx = 4 (C+− + C++ − C−− − C−+)` and `Gy = 4 (C−+ + C++ − C−− − C+−)` equal the 3x3
/// Sobel masks exactly (002 Fig. 7.6: four fetches instead of eight).
pub fn sobel4<const C: usize>(
    img: &[[f32; C]],
    width: u32,
    height: u32,
    x: u32,
    y: u32,
) -> ([f32; C], [f32; C]) {
    let [mm, pm, mp, pp] = corner_fetches(img, width, height, x, y);
    let gx = std::array::from_fn(|i| 4.0 * (pm[i] + pp[i] - mm[i] - mp[i]));
    let gy = std::array::from_fn(|i| 4.0 * (mp[i] + pp[i] - mm[i] - pm[i]));
    (gx, gy)
}

fn ramp(v: f32, r: [f32; 2]) -> f32 {
    ((v - r[0]) / (r[1] - r[0]).max(1e-12)).clamp(0.0, 1.0)
}

/// Outline weight at pixel `(x, y)` from the depth image (`Z`, misses at a far depth) and
/// the normal image (0 for misses), four fetches each: the larger of
/// - the silhouette ramp of `|mean(C±±) − Z| / min(Z, C±±)`, the depth's departure from
///   the mean of its four corner fetches (0 on any plane or linear ramp, a quarter of the
///   jump beside a step), and
/// - the crease ramp of the Sobel magnitude of the normals `|∇N| / 4`.
///
/// 002 applies the Sobel magnitude to depth as well; that fires on every slanted plane
/// seen at a grazing angle (a floor), whose depth gradient is large but smooth. The same
/// four depth fetches give the residual used here instead.
pub fn outline_weight(
    depth: &[[f32; 1]],
    normals: &[[f32; 3]],
    width: u32,
    height: u32,
    x: u32,
    y: u32,
    o: &OutlineOptions,
) -> f32 {
    let c = corner_fetches(depth, width, height, x, y);
    let z = depth[x as usize + width as usize * y as usize][0];
    let mean = 0.25 * (c[0][0] + c[1][0] + c[2][0] + c[3][0]);
    let zmin = c.iter().map(|v| v[0]).fold(z, f32::min);
    let sil = (mean - z).abs() / zmin.max(1e-30);
    let (nx, ny) = sobel4(normals, width, height, x, y);
    let crease = (0..3)
        .map(|i| nx[i] * nx[i] + ny[i] * ny[i])
        .sum::<f32>()
        .sqrt()
        / 4.0;
    ramp(sil, o.depth).max(ramp(crease, o.crease))
}

/// Counts of a shading pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadeStats {
    /// Shadow-map samples taken over all pixels.
    pub shadow_samples: u64,
    /// Pixels that needed all 64 samples (in a penumbra).
    pub penumbra_pixels: u64,
    /// Wall time of the shadow map, seconds.
    pub shadow_map_seconds: f64,
    /// Wall time of the shading, seconds.
    pub shade_seconds: f64,
}

impl ShadeStats {
    /// Counts one pixel that took `k` shadow-map samples (64: it was in a penumbra).
    pub fn count_pixel(&mut self, k: u32) {
        self.shadow_samples += u64::from(k);
        self.penumbra_pixels += u64::from(k == SHADOW_SAMPLES);
    }
}

/// The spot light's default position for a frame: along the default key light's direction,
/// as far from the scene's centre as the eye.
pub fn default_spot(u: &Uniforms, scene: &SplatScene) -> Vec3 {
    let l = default_light(u);
    let dir = l.direction.unwrap_or(Vec3::NEG_Y);
    let eye = Vec3::from_array(u.eye);
    let (c, r) = scene.bounds().map_or((Vec3::ZERO, 1.0), |(lo, hi)| {
        (
            (0.5 * (lo + hi)).as_vec3(),
            (0.5 * (hi - lo).length()) as f32,
        )
    });
    c - dir * (eye - c).length().max(3.0 * r)
}

/// The far depth that misses take in the outline filter: 1.5 × the farthest hit.
pub fn miss_depth(g: &GBuffer) -> f32 {
    let far = g
        .pixels()
        .iter()
        .filter(|p| p.is_hit())
        .map(|p| p.depth)
        .fold(0.0f32, f32::max);
    if far > 0.0 { 1.5 * far } else { 1.0 }
}

/// Deferred shading of a splat frame (CPU twin): per-object colour, optional soft shadows
/// and outlines.
pub fn shade_splat(
    frame: &SplatFrame,
    scene: &SplatScene,
    opts: &SplatShading,
) -> Result<(Image, ShadeStats), RenderError> {
    opts.shading.check()?;
    scene.check()?;
    frame.check()?;
    let u = &frame.uniforms;
    let mut stats = ShadeStats::default();
    let t0 = Instant::now();
    let shadow = match &opts.shadows {
        Some(so) if !scene.is_empty() => {
            let pos = so.light.unwrap_or_else(|| default_spot(u, scene));
            Some(ShadowMap::render(scene, pos, so)?)
        }
        _ => None,
    };
    stats.shadow_map_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let lights: Vec<Light> = match &shadow {
        Some(m) => vec![m.light],
        None => opts.shading.lights_or_default(u),
    };
    let (w, h) = (u.width, u.height);
    let g = &frame.gbuffer;
    // The outline images, only when outlines are drawn.
    let outline_images = opts.outlines.map(|o| {
        let far = miss_depth(g);
        let depth: Vec<[f32; 1]> = g
            .pixels()
            .iter()
            .map(|p| [if p.is_hit() { p.depth } else { far }])
            .collect();
        let normals: Vec<[f32; 3]> = g
            .pixels()
            .iter()
            .map(|p| {
                if p.is_hit() {
                    p.normal.to_array()
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        (o, depth, normals)
    });
    let pixel_angle = 2.0 * u.half_height / h as f32;
    let sh = &opts.shading;
    let results: Vec<([f32; 4], u32)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (px, py) = (i % w, i / w);
            let s = &g.pixels()[i as usize];
            let mut samples = 0;
            let mut c = if s.is_hit() {
                let v = kernel::pixel_ray(u, px, py).1;
                let footprint = if u.ortho != 0 {
                    pixel_angle
                } else {
                    pixel_angle * s.depth
                };
                let obj = frame.objects[i as usize];
                let color = scene.colors.get(obj as usize).copied().unwrap_or(sh.color);
                let mut c = shade_pixel_color(s, v, footprint, sh, &lights, color);
                if let Some(m) = &shadow {
                    let (f, k) = shadow_factor(&m.params, &m.depth, s.position, s.normal, px, py);
                    samples = k;
                    let amb = sh.ambient * color;
                    for (ch, v) in c.iter_mut().take(3).enumerate() {
                        *v = amb[ch] + f * (*v - amb[ch]);
                    }
                }
                c
            } else {
                sh.background
            };
            if let Some((o, depth, normals)) = &outline_images {
                let wgt = outline_weight(depth, normals, w, h, px, py, o);
                for (ch, v) in c.iter_mut().take(3).enumerate() {
                    *v += wgt * (o.color[ch] - *v);
                }
                c[3] = c[3].max(wgt);
            }
            (c, samples)
        })
        .collect();
    stats.shade_seconds = t1.elapsed().as_secs_f64();
    let mut pixels = Vec::with_capacity(results.len());
    for (c, k) in results {
        stats.count_pixel(k);
        pixels.push(c);
    }
    Ok((
        Image {
            width: w,
            height: h,
            pixels,
        },
        stats,
    ))
}
