//! Argument groups shared by several commands: the backend, the shading mode, the inside
//! side. The ray caster's knobs are in `raycast_args`, the multi-view display in
//! `multiview_args`, on-the-fly CSG in `csg_args`. Every list of choices comes from the
//! library.

use anyhow::Result;
use isokit_gpu::BackendChoice;
use isokit_render::ShadingMode;

/// The default image width of `render`, `demo` and `molecule`, in pixels.
pub const DEFAULT_WIDTH: u64 = 640;
/// The default image height of `render`, `demo` and `molecule`, in pixels.
pub const DEFAULT_HEIGHT: u64 = 480;

/// Which implementation runs.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// `ISOKIT_BACKEND=cpu|gpu` when set; else a hardware GPU when one exists, the CPU
    /// (with a note) when none does or the only adapter is a software one (lavapipe).
    Auto,
    /// The CPU twin (rayon).
    Cpu,
    /// The GPU twin (wgpu), on any adapter, software ones included; an error without one.
    Gpu,
}

impl Backend {
    /// The library's request.
    pub fn choice(self) -> BackendChoice {
        match self {
            Backend::Auto => BackendChoice::Auto,
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
        }
    }
}

/// The renderer a backend request opens, printing the note when `auto` chose the CPU.
/// Callers open it where they render, after the input was read (so that a missing file is
/// reported alone), and once per command.
pub fn open_renderer(backend: Backend) -> Result<isokit_scene::Renderer> {
    let r = isokit_scene::Renderer::new(backend.choice())?;
    if let Some(note) = r.note() {
        eprintln!("{note}");
    }
    Ok(r)
}

/// Parses shading mode names with the library's error (which lists the modes), and shows
/// the library's list of modes in `--help`.
#[derive(Clone, Copy, Debug)]
pub struct ShadingNames;

impl clap::builder::TypedValueParser for ShadingNames {
    type Value = String;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<String, clap::Error> {
        let s = value.to_string_lossy();
        match s.parse::<ShadingMode>() {
            Ok(_) => Ok(s.into_owned()),
            Err(msg) => {
                let name = arg.map_or("--shading".to_owned(), |a| a.to_string());
                Err(clap::Error::raw(
                    clap::error::ErrorKind::InvalidValue,
                    format!("{name}: {msg}\n"),
                )
                .with_cmd(cmd))
            }
        }
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(
            ShadingMode::ALL
                .iter()
                .map(|(n, _)| clap::builder::PossibleValue::new(*n)),
        ))
    }
}

/// The shading modes' names, from the library's list.
pub fn shading_names() -> ShadingNames {
    ShadingNames
}

/// Parses a shading mode name (one of [`ShadingMode::ALL`]).
pub fn shading_mode(name: &str) -> Result<ShadingMode> {
    name.parse().map_err(anyhow::Error::msg)
}

/// Which side of the isovalue is inside.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum InsideArg {
    /// Below the isovalue (distance fields).
    #[default]
    Below,
    /// Above the isovalue (densities such as CT).
    Above,
}

impl InsideArg {
    /// The library's side.
    pub fn inside(self) -> isokit_render::Inside {
        match self {
            InsideArg::Below => isokit_render::Inside::Below,
            InsideArg::Above => isokit_render::Inside::Above,
        }
    }
}
