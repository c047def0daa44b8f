//! The `isokit` command-line program. See `isokit --help` and the README.

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// isokit: distance fields and implicit surfaces from meshes, clouds and analytic shapes.
#[derive(Parser, Debug)]
#[command(name = "isokit", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Describe a mesh, point cloud, volume or image: counts, bounds, and for meshes a
    /// validation report (degenerate and duplicate triangles, boundary and non-manifold
    /// edges, watertight and orientation).
    Info(cmd::info::Args),
    /// Convert between mesh formats (OBJ, PLY, STL, OFF; glTF/GLB in), point-cloud formats
    /// (PLY, XYZ) or volume formats (NRRD, NPY; NIfTI in).
    Convert(cmd::convert::Args),
    /// Sample an analytic primitive's exact signed distance to a grid (NRRD or NPY).
    Sample(Box<cmd::sample::Args>),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info(a) => cmd::info::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Sample(a) => cmd::sample::run(*a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One clear line: the error and its causes joined by ": ".
            eprintln!("isokit: error: {e:#}");
            ExitCode::from(2)
        }
    }
}
