//! `isokit molecule FILE -o image.png [...]`: a PDB or mmCIF structure splatted as quadrics
//! (ball-and-stick or space-filling, CPK colours), with soft shadows and outlines on
//! request.

use super::check_output;
use super::render::{Backend, backend_name, open_backend};
use anyhow::{Context, Result, bail};
use isokit_molecule::{
    MoleculeOptions, MoleculeStyle, framing_camera, molecule_scene, read_molecule,
};
use isokit_render::splat::{
    OutlineOptions, ShadowOptions, SplatOptions, SplatShading, shade_splat, splat,
};
use isokit_render::{Shading, ShadingMode, check_image_size};
use std::path::PathBuf;
use std::time::Instant;

/// Model style.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// Ball-and-stick: small spheres and half-bond cylinders.
    Balls,
    /// Space-filling: van der Waals spheres.
    Spacefill,
}

/// Arguments of `isokit molecule`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A structure: PDB (.pdb, .ent) or mmCIF (.cif, .mmcif), optionally gzipped (.gz).
    pub input: PathBuf,
    /// Output image (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Model style.
    #[arg(long, value_enum, default_value_t = Style::Balls)]
    pub style: Style,
    /// Soft shadows from a spot light (a shadow map filtered by 64 jittered samples, 8 to
    /// test for a penumbra first).
    #[arg(long)]
    pub shadows: bool,
    /// Silhouette and crease outlines (edge detection on depth and normals).
    #[arg(long)]
    pub outlines: bool,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1024)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = 768)]
    pub height: u64,
    /// Backend: auto (`ISOKIT_BACKEND=cpu|gpu` when set, else a hardware GPU when one
    /// exists and the CPU otherwise), cpu, gpu (any adapter, software ones included; an
    /// error without one).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Also write the G-buffer as OpenEXR (channels P.X P.Y P.Z N.X N.Y N.Z Z K1 K2 A).
    #[arg(long)]
    pub gbuffer: Option<PathBuf>,
    /// Shading mode of the ray caster's deferred shading (phong, tone, normal, curvature, …).
    #[arg(long, default_value = "phong")]
    pub shading: String,
    /// Ball radius as a fraction of the van der Waals radius (ball-and-stick).
    #[arg(long, default_value_t = 0.25)]
    pub ball_scale: f32,
    /// Bond radius in Å (ball-and-stick).
    #[arg(long, default_value_t = 0.15)]
    pub bond_radius: f32,
    /// Shadow map side in texels.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map: u32,
    /// Penumbra width: radius of the shadow filter in shadow-map texels.
    #[arg(long, default_value_t = 3.0)]
    pub softness: f32,
    /// Print what it did as one JSON object on stdout.
    #[arg(long)]
    pub stats: bool,
}

/// Runs `isokit molecule`.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    if let Some(g) = &a.gbuffer {
        check_output(g, &[".exr"])?;
    }
    let (width, height) = check_image_size(a.width, a.height)?;
    let mode: ShadingMode = a.shading.parse().map_err(anyhow::Error::msg)?;
    // Refuse bad shadow knobs before the work (ShadowMap checks them again).
    if a.shadows {
        if !(16..=8192).contains(&a.shadow_map) {
            bail!("--shadow-map {}: must be 16 to 8192 texels", a.shadow_map);
        }
        if !(a.softness.is_finite() && (0.0..=64.0).contains(&a.softness)) {
            bail!("--softness {}: must be 0 to 64 texels", a.softness);
        }
    }
    let t0 = Instant::now();
    let mol = read_molecule(&a.input)?;
    let read_seconds = t0.elapsed().as_secs_f64();
    let opts = MoleculeOptions {
        style: match a.style {
            Style::Balls => MoleculeStyle::Balls,
            Style::Spacefill => MoleculeStyle::Spacefill,
        },
        ball_scale: a.ball_scale,
        bond_radius: a.bond_radius,
    };
    let scene = molecule_scene(&mol, &opts).with_context(|| a.input.display().to_string())?;
    let camera = framing_camera(&scene, width, height)?;
    let shading = SplatShading {
        shading: Shading {
            mode,
            background: [1.0, 1.0, 1.0, 1.0],
            ..Shading::default()
        },
        shadows: a.shadows.then_some(ShadowOptions {
            resolution: a.shadow_map,
            softness: a.softness,
            light: None,
        }),
        outlines: a.outlines.then(OutlineOptions::default),
    };
    let gpu = open_backend(a.backend)?;
    let (frame, (image, shade_stats)) = match &gpu {
        Some(g) => {
            let f = g.splat(&scene, &camera, &SplatOptions::default())?;
            let s = g.shade_splat(&f, &scene, &shading)?;
            (f, s)
        }
        None => {
            let f = splat(&scene, &camera, &SplatOptions::default())?;
            let s = shade_splat(&f, &scene, &shading)?;
            (f, s)
        }
    };
    // The G-buffer first: a failure there leaves the previous image in place.
    if let Some(g) = &a.gbuffer {
        frame.gbuffer.write_exr(g)?;
    }
    image.write_png(&a.output)?;
    let st = &frame.stats;
    let backend = backend_name(gpu.as_ref());
    eprintln!(
        "{} ({}): {} atoms, {} bonds -> {} quadrics ({} on screen); {backend}: {}x{} {}{}{} image, {} pixels covered, {} fragments; read {:.2} s, set-up {:.3} s, splat {:.3} s, shadow map {:.3} s, shade {:.3} s -> {}{}",
        a.input.display(),
        mol.name,
        mol.atoms.len(),
        mol.bonds.len(),
        st.quadrics,
        st.drawn,
        width,
        height,
        mode.name(),
        if a.shadows { " + shadows" } else { "" },
        if a.outlines { " + outlines" } else { "" },
        frame.gbuffer.hit_count(),
        st.fragments,
        read_seconds,
        st.setup_seconds,
        st.splat_seconds,
        shade_stats.shadow_map_seconds,
        shade_stats.shade_seconds,
        a.output.display(),
        a.gbuffer
            .as_ref()
            .map_or(String::new(), |g| format!(", {}", g.display()))
    );
    if a.stats {
        let j = serde_json::json!({
            "molecule": mol.name,
            "atoms": mol.atoms.len(),
            "bonds": mol.bonds.len(),
            "quadrics": st.quadrics,
            "drawn": st.drawn,
            "fragments": st.fragments,
            "fragment_hits": st.hits,
            "covered_pixels": frame.gbuffer.hit_count(),
            "width": width,
            "height": height,
            "style": format!("{:?}", opts.style).to_lowercase(),
            "shadows": a.shadows,
            "outlines": a.outlines,
            "shadow_samples": shade_stats.shadow_samples,
            "penumbra_pixels": shade_stats.penumbra_pixels,
            "read_seconds": read_seconds,
            "setup_seconds": st.setup_seconds,
            "splat_seconds": st.splat_seconds,
            "shadow_map_seconds": shade_stats.shadow_map_seconds,
            "shade_seconds": shade_stats.shade_seconds,
            "backend": if gpu.is_some() { "gpu" } else { "cpu" },
            "device": backend,
            "output": a.output.display().to_string(),
        });
        println!("{j}");
    }
    Ok(())
}
