//! The multi-view autostereoscopic display of `isokit render` (paper 001).

use anyhow::{Result, bail};
use isokit_render::MultiView;
use std::path::PathBuf;

/// A multi-view autostereoscopic display (paper 001).
#[derive(clap::Args, Debug, Clone)]
pub struct MultiViewArgs {
    /// Render for a multi-view autostereoscopic display with this many views (2 to 64):
    /// one ray per subpixel from the eye of the view it shows (paper 001). With --gbuffer
    /// the G-buffer is per subpixel (3·width wide).
    #[arg(long)]
    pub views: Option<u32>,
    /// Distance between neighbouring views' eyes, world units [default: 1% of the distance
    /// from the eye to the target].
    #[arg(long)]
    pub view_separation: Option<f32>,
    /// Subpixels under one lens [default: the number of views].
    #[arg(long)]
    pub lens_pitch: Option<f32>,
    /// Horizontal shift of the lenses per pixel row, in pixels (slanted lenses).
    #[arg(long, default_value_t = 0.0)]
    pub lens_slant: f32,
    /// With --views: also write each view rendered alone to this folder (view_00.png, …).
    #[arg(long)]
    pub views_out: Option<PathBuf>,
}

impl MultiViewArgs {
    /// The display, checked, and whether its separation is to be the default (1% of the
    /// distance from the eye to the target, resolved with the camera).
    pub fn multiview(&self) -> Result<(Option<MultiView>, bool)> {
        let Some(n) = self.views else {
            if self.views_out.is_some() {
                bail!("--views-out needs --views");
            }
            return Ok((None, false));
        };
        let mv = MultiView {
            pitch: self.lens_pitch.unwrap_or(n as f32),
            slant: self.lens_slant,
            ..MultiView::new(n, self.view_separation.unwrap_or(0.0))
        };
        mv.check()?;
        Ok((Some(mv), self.view_separation.is_none()))
    }
}
