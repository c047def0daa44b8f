//! The volume input of `isokit render` in the isosurface mode: the samples, the second
//! operand of `--csg OP --with B` or of `--clip`, and after the rendering the caps a clip
//! cut open shaded with the volume's values (`isokit_render::clip`).

use super::Args;
use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_io::zarr::ZarrSource;
use isokit_render::clip::colour_caps;
use isokit_render::{Combine, Inside, Layout, Shading, Volume};
use isokit_scene::{Frame, RenderSettings};
use std::path::PathBuf;
use std::sync::Arc;

/// The decoded chunks a store read on demand keeps (least recently used dropped first).
const STORE_CACHE_BYTES: usize = 256 << 20;

/// Fails when a store read on demand could not read a chunk (its samples read as NaN).
pub(super) fn check_store(volume: &Volume) -> Result<()> {
    volume.store_error().map_or(Ok(()), |e| bail!("{e}"))
}

/// Refuses what `--clip` does not go with in the isosurface mode.
pub(super) fn check_clip(a: &Args) -> Result<()> {
    let Some(c) = a.clip.file() else {
        return Ok(());
    };
    if super::is_scene(&a.input) {
        bail!(
            "--clip clips volumes; {} is a scene (cut it with an intersection or difference node)",
            a.input.display()
        );
    }
    for (given, flag) in [
        (a.csg.csg.is_some(), "--csg"),
        (a.samples > 1, "--samples"),
        (a.multiview.multiview()?.0.is_some(), "--views"),
    ] {
        if given {
            bail!("--clip {} with {flag}: not supported together", c.display());
        }
    }
    Ok(())
}

/// What the caps of a clipped isosurface are shaded from: the volume's samples and range.
pub(super) struct Caps {
    grid: Grid,
    range: (f32, f32),
}

impl Caps {
    /// Shades the frame's cap pixels with the volume's values; returns how many there were.
    pub(super) fn colour(&self, frame: &mut Frame, shading: &Shading) -> usize {
        let (g, u) = (&frame.gbuffer, &frame.uniforms);
        colour_caps(&mut frame.image, g, u, shading, &self.grid, self.range)
    }
}

/// The volume to ray cast, the files it was read from, its description and, with
/// `--clip`, what its caps are shaded from.
pub(super) fn load(
    a: &Args,
    s: &RenderSettings,
) -> Result<(Volume, Vec<PathBuf>, String, Option<Caps>)> {
    if crate::cmd::volume_out::is_zarr(&a.input) && a.clip.file().is_none() && a.csg.csg.is_none() {
        let source = Arc::new(ZarrSource::open(&a.input, STORE_CACHE_BYTES)?);
        let d = source.dims();
        let what = format!(
            "{} x {} x {} volume (a Zarr store read on demand: at most {} decoded chunks held)",
            d[0],
            d[1],
            d[2],
            source.cache_chunks()
        );
        let volume = Volume::from_store(source, Layout::default())?;
        return Ok((volume, vec![a.input.clone()], what, None));
    }
    let grid = a.volume.read_grid(&a.input)?;
    let d = grid.dims();
    let mut what = format!("{} x {} x {} volume", d[0], d[1], d[2]);
    let mut files = vec![a.input.clone()];
    if let Some(clip) = a.clip.load(&grid, &a.volume)? {
        let sign = match s.options.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        };
        let operand = clip.operand(s.options.iso, sign);
        let caps = Caps {
            range: isokit_render::dvr::value_range(&grid),
            grid: grid.clone(),
        };
        let volume = Volume::from_grid(grid, Layout::default())?
            .with_operand(operand, Combine::Intersection)?;
        what.push_str(&super::dvr::clip_note(a));
        files.extend(a.clip.file().map(PathBuf::from));
        return Ok((volume, files, what, Some(caps)));
    }
    let mut volume = Volume::from_grid(grid, Layout::default())?;
    if let (Some(c), Some(with)) = (a.csg.combine()?, &a.csg.with) {
        volume = volume
            .with_operand(a.volume.read_grid(with)?, c)
            .with_context(|| format!("--with {}", with.display()))?;
        what = format!("{what}, {c:?} with {}", with.display());
        files.push(with.clone());
    }
    Ok((volume, files, what, None))
}
