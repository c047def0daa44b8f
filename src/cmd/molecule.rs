//! `isokit molecule FILE -o image.png [...]`: a PDB or mmCIF structure splatted as quadrics
//! (ball-and-stick or space-filling, CPK colours), with soft shadows and outlines on
//! request.

use super::args::{Backend, open_renderer, shading_names};
use super::camera_args::CameraArgs;
use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_molecule::{MoleculeOptions, MoleculeStyle, read_molecule};
use isokit_render::check_image_size;
use isokit_render::splat::ShadowOptions;
use isokit_scene::MoleculeSettings;
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
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_WIDTH)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_HEIGHT)]
    pub height: u64,
    /// Backend: auto (`ISOKIT_BACKEND=cpu|gpu` when set, else a hardware GPU when one
    /// exists and the CPU otherwise), cpu, gpu (any adapter, software ones included; an
    /// error without one).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Also write the G-buffer as OpenEXR (channels P.X P.Y P.Z N.X N.Y N.Z Z K1 K2 A; the
    /// camera as the header attributes worldToCamera and worldToNDC).
    #[arg(long)]
    pub gbuffer: Option<PathBuf>,
    /// Shading mode of the ray caster's deferred shading.
    #[arg(long, default_value = "phong", value_parser = shading_names())]
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
    /// Leave out water (residues HOH, WAT, H2O, DOD, TIP, TIP3, SOL, D2O).
    #[arg(long)]
    pub no_water: bool,
    /// Only these chains, "A,B" (chain identifiers as in the file).
    #[arg(long, value_delimiter = ',')]
    pub chains: Vec<String>,
    #[command(flatten)]
    pub camera: CameraArgs,
}

/// Runs `isokit molecule`.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    if let Some(g) = &a.gbuffer {
        check_output(g, &[".exr"])?;
    }
    let (width, height) = check_image_size(a.width, a.height)?;
    let mode = super::args::shading_mode(&a.shading)?;
    // Refuse bad shadow knobs before the work (ShadowMap checks them again).
    if a.shadows {
        if !(16..=8192).contains(&a.shadow_map) {
            bail!("--shadow-map {}: must be 16 to 8192 texels", a.shadow_map);
        }
        if !(a.softness.is_finite() && (0.0..=64.0).contains(&a.softness)) {
            bail!("--softness {}: must be 0 to 64 texels", a.softness);
        }
    }
    let kind = a.camera.projection()?;
    let camera = a.camera.spec()?;
    let t0 = Instant::now();
    let mut mol = read_molecule(&a.input)?;
    if a.no_water || !a.chains.is_empty() {
        mol = mol
            .select(a.no_water, &a.chains)
            .map_err(anyhow::Error::msg)
            .with_context(|| a.input.display().to_string())?;
        if mol.is_empty() {
            bail!(
                "{}: no atom is left after --no-water and --chains",
                a.input.display()
            );
        }
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    let model = MoleculeOptions {
        style: match a.style {
            Style::Balls => MoleculeStyle::Balls,
            Style::Spacefill => MoleculeStyle::Spacefill,
        },
        ball_scale: a.ball_scale,
        bond_radius: a.bond_radius,
    };
    let camera = isokit_scene::molecule_camera(&mol, &model, camera.as_ref(), kind, width, height)?;
    let settings = MoleculeSettings {
        width,
        height,
        model,
        mode,
        shadows: a.shadows.then_some(ShadowOptions {
            resolution: a.shadow_map,
            softness: a.softness,
            light: None,
        }),
        outlines: a.outlines,
        camera,
    };
    let mut renderer = open_renderer(a.backend)?;
    let mf = renderer
        .render_molecule(&mol, &settings)
        .with_context(|| a.input.display().to_string())?;
    let (frame, image, st) = (&mf.frame, &mf.image, &mf.stats);
    // The G-buffer first: a failure there leaves the previous image in place.
    if let Some(g) = &a.gbuffer {
        frame.gbuffer.write_exr_with_camera(g, &mf.camera)?;
    }
    image.write_png(&a.output)?;
    eprintln!(
        "{} ({}): {} atoms, {} bonds -> {} quadrics ({} on screen); {}: {}x{} {}{}{} image, {} pixels covered, {} fragments; read {:.2} s, set-up {:.3} s, splat {:.3} s, shadow map {:.3} s, shade {:.3} s -> {}{}",
        a.input.display(),
        mol.name,
        st.atoms,
        st.bonds,
        st.quadrics,
        st.drawn,
        st.device,
        width,
        height,
        mode.name(),
        if a.shadows { " + shadows" } else { "" },
        if a.outlines { " + outlines" } else { "" },
        st.covered_pixels,
        st.fragments,
        read_seconds,
        st.setup_seconds,
        st.splat_seconds,
        st.shadow_map_seconds,
        st.shade_seconds,
        a.output.display(),
        a.gbuffer
            .as_ref()
            .map_or(String::new(), |g| format!(", {}", g.display()))
    );
    if a.stats {
        let mut j = serde_json::to_value(st)?;
        if let Some(o) = j.as_object_mut() {
            o.insert("molecule".into(), mol.name.clone().into());
            o.insert("width".into(), width.into());
            o.insert("height".into(), height.into());
            o.insert(
                "style".into(),
                format!("{:?}", settings.model.style).to_lowercase().into(),
            );
            o.insert("shadows".into(), a.shadows.into());
            o.insert("outlines".into(), a.outlines.into());
            o.insert("read_seconds".into(), read_seconds.into());
            o.insert("output".into(), a.output.display().to_string().into());
        }
        println!("{j}");
    }
    Ok(())
}
