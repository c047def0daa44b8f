//! Antialiasing by supersampling: a frame traced and shaded at `k` times the width and the
//! height (a regular `k × k` grid of rays per pixel, each through the centre of its
//! subpixel) is resolved to the output size. The image is the box-filtered mean of the
//! subpixels' linear colours (silhouettes, depth edges and caps blend with what lies
//! behind them); the G-buffer keeps, per pixel, the hit subpixel nearest the pixel's centre
//! (positions, normals and curvatures are never averaged across an edge) and its `A`
//! channel becomes the coverage, the fraction of the pixel's rays that hit.
//!
//! The rays are the ordinary camera rays of the larger image, so the CPU and the GPU twins
//! need no kernel of their own: both trace the larger frame and this module resolves it on
//! the CPU.

use crate::{GBuffer, Image, RenderError};
use rayon::prelude::*;

/// The most rays per pixel [`grid_side`] accepts (a 8 × 8 grid).
pub const MAX_SAMPLES: u32 = 64;

/// The side `k` of the `k × k` grid of rays for `samples` rays per pixel: `samples` must be
/// a perfect square from 1 to [`MAX_SAMPLES`] (1, 4, 9, 16, 25, 36, 49, 64).
pub fn grid_side(samples: u32) -> Result<u32, RenderError> {
    let k = (1..=8).find(|k| k * k == samples);
    k.ok_or_else(|| RenderError::BadParameter {
        name: "samples",
        value: samples.to_string(),
        why: "must be a square number of rays per pixel: 1, 4, 9, 16, 25, 36, 49 or 64",
    })
}

/// The box filter of `image` over blocks of `k × k` pixels (linear RGBA means); `image`'s
/// sides are multiples of `k`.
pub fn resolve_image(image: &Image, k: u32) -> Image {
    let (w, h) = (image.width / k, image.height / k);
    let n = (k * k) as f32;
    let pixels = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut sum = [0.0f32; 4];
            for sy in 0..k {
                let row = (y * k + sy) * image.width;
                for sx in 0..k {
                    let p = image.pixels[(row + x * k + sx) as usize];
                    for c in 0..4 {
                        sum[c] += p[c];
                    }
                }
            }
            sum.map(|v| v / n)
        })
        .collect();
    Image {
        width: w,
        height: h,
        pixels,
    }
}

/// The index in the supersampled G-buffer `g` of the hit subpixel of output pixel `(x, y)`
/// nearest the pixel's centre (the first of equals in row order), `None` when none hit;
/// also the number of its subpixels that hit.
pub fn nearest_hit(g: &GBuffer, k: u32, x: u32, y: u32) -> (Option<usize>, u32) {
    let centre = 0.5 * (k as f32 - 1.0);
    let mut best: Option<(f32, usize)> = None;
    let mut hits = 0;
    for sy in 0..k {
        for sx in 0..k {
            let j = ((y * k + sy) * g.width() + x * k + sx) as usize;
            if g.pixels()[j].is_hit() {
                hits += 1;
                let d = (sx as f32 - centre).powi(2) + (sy as f32 - centre).powi(2);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, j));
                }
            }
        }
    }
    (best.map(|(_, j)| j), hits)
}

/// The G-buffer of the output size from the supersampled one: per pixel the hit subpixel
/// nearest the pixel's centre ([`nearest_hit`]; a miss when none hit), the field
/// evaluations of all its rays, and the coverage ([`GBuffer::coverage`]) of its rays that
/// hit.
pub fn resolve_gbuffer(g: &GBuffer, k: u32) -> GBuffer {
    let (w, h) = (g.width() / k, g.height() / k);
    let n = (k * k) as f32;
    let resolved: Vec<_> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let (best, hits) = nearest_hit(g, k, x, y);
            let mut evaluations = 0u32;
            for sy in 0..k {
                let row = ((y * k + sy) * g.width() + x * k) as usize;
                for &e in &g.samples()[row..row + k as usize] {
                    evaluations = evaluations.saturating_add(e);
                }
            }
            let sample = g.pixels()[best.unwrap_or(((y * k) * g.width() + x * k) as usize)];
            (sample, evaluations, hits as f32 / n)
        })
        .collect();
    let mut pixels = Vec::with_capacity(resolved.len());
    let mut samples = Vec::with_capacity(resolved.len());
    let mut coverage = Vec::with_capacity(resolved.len());
    for (p, s, c) in resolved {
        pixels.push(p);
        samples.push(s);
        coverage.push(c);
    }
    GBuffer::new(w, h, pixels, samples).with_coverage(coverage)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{GSample, ID_MISS, ID_SURFACE};
    use glam::Vec3;

    fn sample(id: u32, x: f32) -> GSample {
        GSample {
            position: Vec3::splat(x),
            depth: x,
            normal: Vec3::Z,
            k1: 0.0,
            k2: 0.0,
            dir1: Vec3::X,
            id,
        }
    }

    #[test]
    fn only_square_sample_counts_are_accepted() {
        assert_eq!(grid_side(1).unwrap(), 1);
        assert_eq!(grid_side(4).unwrap(), 2);
        assert_eq!(grid_side(64).unwrap(), 8);
        for bad in [0, 2, 3, 5, 65, 81] {
            let e = grid_side(bad).unwrap_err().to_string();
            assert!(e.contains("1, 4, 9, 16"), "{e}");
        }
    }

    #[test]
    fn a_half_covered_pixel_has_coverage_one_half_and_the_central_hit() {
        // One output pixel of 2 × 2 rays: the left column hits.
        let px = vec![
            sample(ID_SURFACE, 1.0),
            sample(ID_MISS, 0.0),
            sample(ID_SURFACE, 2.0),
            sample(ID_MISS, 0.0),
        ];
        let g = GBuffer::new(2, 2, px, vec![1, 2, 3, 4]);
        let r = resolve_gbuffer(&g, 2);
        assert_eq!((r.width(), r.height()), (1, 1));
        assert_eq!(r.coverage(), vec![0.5]);
        assert!(r.pixels()[0].is_hit());
        assert_eq!(r.samples(), &[10]);
        assert_eq!(r.channels()[9], vec![0.5]);
        let img = Image {
            width: 2,
            height: 2,
            pixels: vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0; 4],
                [1.0, 0.0, 0.0, 1.0],
                [0.0; 4],
            ],
        };
        assert_eq!(resolve_image(&img, 2).pixels, vec![[0.5, 0.0, 0.0, 0.5]]);
    }
}
