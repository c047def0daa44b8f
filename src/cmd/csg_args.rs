//! On-the-fly CSG of two volumes while ray casting (`isokit render --csg OP --with B`; Sigg
//! 2006, Sec. 6.4.3).

use anyhow::{Result, bail};
use isokit_render::Combine;
use std::path::PathBuf;

/// The operation of `--csg`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgOp {
    /// A ∪ B.
    Union,
    /// A ∩ B.
    Intersection,
    /// A − B.
    Difference,
    /// (1 − t)·A + t·B.
    Morph,
}

/// On-the-fly CSG of two volumes.
#[derive(clap::Args, Debug, Clone)]
pub struct CsgArgs {
    /// Combine the input volume A with a second volume B (--with, same dimensions, origin
    /// and spacing) per sample while ray casting: union (min), intersection (max),
    /// difference A − B (max(a, −b)), or morph ((1 − t)·a + t·b). Volumes only.
    #[arg(long, value_enum, requires = "with")]
    pub csg: Option<CsgOp>,
    /// The second volume of --csg.
    #[arg(long, requires = "csg")]
    pub with: Option<PathBuf>,
    /// The morph parameter t in [0, 1] of --csg morph [default: 0.5].
    #[arg(long)]
    pub morph_t: Option<f32>,
}

impl CsgArgs {
    /// The combination, checked (`--morph-t` only with `morph`).
    pub fn combine(&self) -> Result<Option<Combine>> {
        if self.morph_t.is_some() && self.csg != Some(CsgOp::Morph) {
            bail!("--morph-t applies to --csg morph only");
        }
        let c = match self.csg {
            None => return Ok(None),
            Some(CsgOp::Union) => Combine::Union,
            Some(CsgOp::Intersection) => Combine::Intersection,
            Some(CsgOp::Difference) => Combine::Difference,
            Some(CsgOp::Morph) => Combine::Morph(self.morph_t.unwrap_or(0.5)),
        };
        c.check()?;
        Ok(Some(c))
    }
}
