//! The `isokit` command-line program. See `isokit --help` and the README.

mod cmd;

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;

/// isokit: distance fields and implicit surfaces from meshes, clouds and analytic shapes.
#[derive(Parser, Debug)]
#[command(name = "isokit", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Memory budget: the most bytes one stage may hold (dense grids, bricks, meshes, images,
    /// molecule scenes, octrees); larger requests are refused before allocating, with what
    /// would not fit and how to fit it. Bytes or K/M/G/T (powers of 1024), e.g. 8G, 512M
    /// [default: ISOKIT_MAX_MEMORY, else 3/4 of the memory available to this process].
    #[arg(long, global = true, value_name = "SIZE", value_parser = isokit_field::memory::parse_size)]
    max_memory: Option<u64>,
    /// No progress on stderr (long stages otherwise show a bar with the rate and the time
    /// left on a terminal, a line every 10% when stderr is not one).
    #[arg(short, long, global = true)]
    quiet: bool,
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
    /// Exact signed distances from a mesh at the points of an (n, 3) NPY array, with the
    /// closest points on request.
    Query(cmd::query::Args),
    /// A mesh's signed distance sampled on a grid over its bounds (every sample exact, or
    /// exact within a narrow band).
    Sdf(cmd::sdf::Args),
    /// An adaptively sampled field in a hashed octree (mesh, volume or primitive): cells,
    /// nodes, bytes per cell, build time, error against the exact field at random points near
    /// the surface, and the share of the dense finest grid evaluated.
    Octree(Box<cmd::octree::Args>),
    /// A point cloud's approximate signed distance on a grid: partition of unity of linear
    /// fields through the samples, blended with the distance to the closest sample far away;
    /// normals given or estimated.
    Points(Box<cmd::points::Args>),
    /// Evaluate a scene file (JSON or TOML CSG tree) to a band field or a mesh, computing
    /// only the bricks that can hold the surface; `--stats` prints what it cost as JSON.
    #[command(after_help = cmd::scene::node_kinds_help())]
    Scene(cmd::scene::Args),
    /// The isosurface of a volume as a watertight, 2-manifold triangle mesh.
    Mesh(cmd::mesh::Args),
    /// Ray cast the isosurface of a scene or volume into a shaded image (and a G-buffer):
    /// empty-space skipping, brick cache, adaptive sampling, tricubic curvature.
    Render(Box<cmd::render::Args>),
    /// Splat a molecule (PDB or mmCIF) as quadrics: ball-and-stick or space-filling, CPK
    /// colours, soft shadows and outlines on request.
    Molecule(Box<cmd::molecule::Args>),
    /// A live window on a scene, volume or molecule, rendered again whenever it or a file
    /// it depends on is saved (file events); orbit, pan and zoom with the mouse.
    View(cmd::view::Args),
    /// Render the bundled demo scene (a mesh blended with a sphere, curvature-shaded) to
    /// demo.png, printing each stage and its time.
    Demo(cmd::demo::Args),
    /// In-process comparisons to run on your own machine (`bench kdtree`, `bench octree`, `bench render`).
    #[command(subcommand)]
    Bench(cmd::bench::Bench),
}

/// The exit status of a command whose reader closed its standard output early
/// (`isokit info big.obj | head -3`): what a shell reports for a Unix tool ended by SIGPIPE.
const CLOSED_STDOUT: i32 = 141;

/// Ends the program quietly, with [`CLOSED_STDOUT`], when printing to standard output fails
/// because its reader has gone (Rust ignores SIGPIPE, so `println!` panics on a closed pipe);
/// every other panic goes to the default hook.
fn end_quietly_on_a_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let p = info.payload();
        let msg = p
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| p.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(CLOSED_STDOUT);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    end_quietly_on_a_closed_stdout();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) => {
            // --help and --version: printed to stdout as usual, success.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("isokit: error: {}", usage_error_line(&e));
            return ExitCode::from(2);
        }
    };
    cmd::progress::set_quiet(cli.quiet);
    match cli.max_memory {
        Some(b) => isokit_field::memory::set_budget(b),
        None => match isokit_field::memory::budget_from_env() {
            Ok(Some(b)) => isokit_field::memory::set_budget(b),
            Ok(None) => {}
            Err(e) => {
                eprintln!("isokit: error: {e}");
                return ExitCode::from(2);
            }
        },
    }
    let result = match cli.command {
        Command::Info(a) => cmd::info::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Sample(a) => cmd::sample::run(*a),
        Command::Query(a) => cmd::query::run(a),
        Command::Sdf(a) => cmd::sdf::run(a),
        Command::Octree(a) => cmd::octree::run(*a),
        Command::Points(a) => cmd::points::run(*a),
        Command::Scene(a) => cmd::scene::run(a),
        Command::Mesh(a) => cmd::mesh::run(a),
        Command::Render(a) => cmd::render::run(*a),
        Command::Molecule(a) => cmd::molecule::run(*a),
        Command::View(a) => cmd::view::run(a),
        Command::Demo(a) => cmd::demo::run(a),
        Command::Bench(b) => cmd::bench::run(b),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One clear line: the error and its causes joined by ": " (a message that spans
            // lines, as some from wgpu do, joined by "; ").
            let text = format!("{e:#}");
            let line: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("isokit: error: {}", line.join("; "));
            ExitCode::from(2)
        }
    }
}

/// One line for a command-line usage error: clap's message (its first paragraph, which
/// for some errors continues on indented lines, e.g. the missing arguments or the possible
/// values) and its tips, then where to read more.
fn usage_error_line(e: &clap::Error) -> String {
    let cmd = Cli::command();
    let sub = std::env::args_os().skip(1).find_map(|a| {
        a.to_str()
            .and_then(|a| cmd.find_subcommand(a))
            .map(|c| c.get_name().to_string())
    });
    let help = match &sub {
        Some(s) => format!("see isokit {s} --help"),
        None => "see isokit --help".to_string(),
    };
    if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        return match sub {
            Some(_) => format!("missing arguments ({help})"),
            None => format!("missing a subcommand ({help})"),
        };
    }
    let text = e.render().to_string();
    let mut parts: Vec<String> = Vec::new();
    for (n, para) in text.split("\n\n").enumerate() {
        let joined = para
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        let joined = joined
            .strip_prefix("error: ")
            .unwrap_or(&joined)
            .to_string();
        // The first paragraph is the message; later ones only when they are tips.
        if (n == 0 || joined.starts_with("tip:")) && !joined.is_empty() {
            parts.push(joined);
        }
    }
    let msg = parts.join("; ");
    format!("{msg} ({help})")
}
