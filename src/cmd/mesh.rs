//! `isokit mesh FIELD -o out.obj [--mesher mc|dual [--error E]]`: the isosurface of a volume as a
//! triangle mesh; of a tetrahedral grid (`.vtk`, `.vtu`) by marching tetrahedra; with
//! `--labels`, the surface between the regions of a label volume (`labels.rs`).

use super::check_output;
use anyhow::{Result, bail};
use isokit_io::write_mesh;
use isokit_levelset::dual::{DualOptions, mesh_dual_grid_job};
use isokit_levelset::meshing::{MeshOptions, mesh_grid_job};
use std::path::PathBuf;
use std::time::Instant;

/// Which side of the isovalue is inside.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    /// Values below the isovalue (distance fields).
    Below,
    /// Values above the isovalue (densities such as CT).
    Above,
}

/// Arguments of `isokit mesh`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Volume (.nrrd .nhdr .npy .nii .nii.gz) or tetrahedral grid (.vtk .vtu: marching
    /// tetrahedra, exact in each cell, open where the surface leaves the grid; `--mesher`
    /// and `--open` do not apply).
    pub field: PathBuf,
    /// Tetrahedral grids: the point array (default: the first with one component).
    #[arg(long)]
    pub array: Option<String>,
    /// Output mesh (.obj, .ply, .stl, .off, .glb, .gltf; PLY and glTF with vertex normals).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Isovalue.
    #[arg(long, default_value_t = 0.0)]
    pub iso: f32,
    /// Which side of the isovalue is inside (the triangles face the other side).
    #[arg(long, value_enum, default_value_t = Inside::Below)]
    pub inside: Inside,
    /// Leave the surface open where it leaves the volume (by default it is closed there,
    /// so the mesh stays watertight).
    #[arg(long)]
    pub open: bool,
    #[command(flatten)]
    pub mesher: super::mesher_args::MesherOpts,
    /// The volume holds labels (a whole number per sample, 0 outside): mesh the surface
    /// between its regions, non-manifold where three or more meet, into a PLY whose faces
    /// carry `region_a` and `region_b` (int32, a < b).
    #[arg(long)]
    pub labels: bool,
    /// --labels: relaxation passes of the vertices, each kept in its cell (0: the
    /// voxel-aligned staircase) [default: 16].
    #[arg(long)]
    pub smooth: Option<usize>,
    /// The input is a PLY mesh of surface patches whose faces carry `region_front` and
    /// `region_back` (the regions on either side): sample its segmented distance field and
    /// mesh it into a PLY like `--labels` does (non-manifold junctions, open boundaries).
    #[arg(long, conflicts_with = "labels")]
    pub segmented: bool,
    /// --segmented: samples along the longest side of the patches' box, padded on each side
    /// by 10% of its diagonal [default: 64].
    #[arg(long)]
    pub res: Option<usize>,
    #[command(flatten)]
    pub segmented_knobs: super::segmented_field::SegmentedKnobs,
    #[command(flatten)]
    pub volume: super::volume_args::VolumeIn,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &super::MESH_OUTPUTS)?;
    if !a.iso.is_finite() {
        bail!("--iso {} must be finite", a.iso);
    }
    // Checked before anything is read.
    let error = a.mesher.error()?;
    if a.labels {
        return super::labels::run(&a);
    }
    if a.segmented {
        return super::labels::run_segmented(&a);
    }
    if a.smooth.is_some() {
        bail!("--smooth applies to --labels");
    }
    if let Some((_, flag)) = a.segmented_knobs.given().into_iter().find(|g| g.0) {
        bail!("{flag} applies to --segmented");
    }
    if a.res.is_some() {
        bail!("--res applies to --segmented");
    }
    super::segmented_field::refuse_unflagged(&a.field)?;
    if isokit_io::MeshFormat::from_path(&a.field).is_ok() {
        bail!(
            "{} is a mesh, not a field: `isokit sdf` samples a mesh's distance, and --segmented meshes surface patches (a PLY with region_front and region_back)",
            a.field.display()
        );
    }
    if super::tets::is_tets(&a.field) {
        // `--error` needs `--mesher dual` (checked above), refused here with it.
        if a.open || a.mesher.mesher.is_some() {
            bail!(
                "--open and --mesher apply to volumes; a tetrahedral grid is meshed by marching tetrahedra, open where the surface leaves the grid"
            );
        }
        let t = Instant::now();
        let mesh = super::tets::mesh(
            &a.field,
            a.array.as_deref(),
            a.iso,
            a.inside == Inside::Above,
        )?;
        return finish(&a, &mesh, t.elapsed().as_secs_f64());
    }
    if a.array.is_some() {
        bail!("--array applies to tetrahedral grids (.vtk .vtu)");
    }
    let mut grid = a.volume.read(&a.field)?.into_grid()?;
    let mut iso = a.iso;
    if a.inside == Inside::Above {
        grid.data_mut().iter_mut().for_each(|v| *v = -*v);
        iso = -iso;
    }
    let t = Instant::now();
    let opts = MeshOptions {
        iso,
        close_boundary: !a.open,
    };
    let mesh = match a.mesher.kind() {
        super::mesher_args::MesherArg::Mc => mesh_grid_job(&grid, &opts, &super::progress::job())?,
        super::mesher_args::MesherArg::Dual => {
            let dual = DualOptions {
                iso,
                close_boundary: !a.open,
                error,
                ..DualOptions::default()
            };
            let (mesh, st) = mesh_dual_grid_job(&grid, None, &dual, &super::progress::job())?;
            super::mesher_args::print_dual_stats(&st, error.is_some());
            mesh
        }
    };
    finish(&a, &mesh, t.elapsed().as_secs_f64())
}

/// Writes the mesh and reports it.
fn finish(a: &Args, mesh: &isokit_field::TriMesh, secs: f64) -> Result<()> {
    if mesh.triangles.is_empty() {
        eprintln!(
            "warning: no sample lies on both sides of {}; the mesh is empty",
            a.iso
        );
    }
    write_mesh(&a.output, mesh)?;
    let r = mesh.validate();
    eprintln!(
        "{} vertices, {} triangles in {secs:.2} s; watertight {}, consistently oriented {}, {} components, boundary edges {}, non-manifold edges {} -> {}",
        mesh.positions.len(),
        mesh.triangles.len(),
        r.watertight,
        r.consistently_oriented,
        r.components,
        r.boundary_edges,
        r.non_manifold_edges,
        a.output.display()
    );
    Ok(())
}
