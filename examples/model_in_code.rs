//! A modeling script in Rust, through the facade only: a part built in code around a mesh
//! held in memory, sampled lazily to a band, meshed, and rendered.
//!
//! ```sh
//! cargo run --release --example model_in_code -- out/   # writes out/part.obj, out/part.png
//! ```

use isokit::field::Job;
use isokit::field::generate::{trefoil, tube};
use isokit::scene::{
    MeshOptions, Node, RenderSettings, RenderTarget, Renderer, SampleOptions, Scene, SignMode,
    mesh_scene,
};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    std::fs::create_dir_all(&out)?;

    // A trefoil knot tube as a triangle mesh in memory (no file), signed by pseudonormals.
    let knot = tube(|u| trefoil(u, 0.5), 0.15, 192, 16);
    // The part: the knot fused to a plate by a smooth union, with a hole through the plate.
    let part = Node::difference(vec![
        Node::smooth_union(
            0.1,
            vec![
                Node::mesh_data(knot, SignMode::Auto),
                Node::rounded_box([1.1, 1.1, 0.08], 0.04, [0.0, 0.0, -0.55]),
            ],
        ),
        Node::cylinder([0.0, 0.0, -1.0], [0.0, 0.0, 0.0], 0.25),
    ]);
    let scene = Scene::from_node(part)?;

    // The band: only bricks near the surface are computed.
    let sampling = SampleOptions {
        resolution: 96,
        ..Default::default()
    };
    let (band, stats) = scene.sample(&sampling)?;
    println!(
        "band: {} bricks of {} kept, {:.1}% of the dense {}x{}x{} grid evaluated in {:.2} s",
        band.brick_count(),
        stats.bricks_total,
        100.0 * stats.dense_fraction,
        stats.dims[0],
        stats.dims[1],
        stats.dims[2],
        stats.seconds
    );

    // A watertight mesh of the surface.
    let (mesh, ms) = mesh_scene(
        &scene,
        &MeshOptions {
            sampling,
            dense: false,
            ..MeshOptions::default()
        },
        &Job::default(),
    )?;
    let report = mesh.validate();
    println!(
        "mesh: {} triangles, watertight {}, {} component(s)",
        ms.triangles, report.watertight, report.components
    );
    assert!(report.watertight && report.consistently_oriented);
    isokit::io::write_mesh(&out.join("part.obj"), &mesh)?;

    // A picture, on a hardware GPU when one exists, else the CPU twin.
    let mut renderer = Renderer::new(isokit::render::gpu::BackendChoice::Auto)?;
    if let Some(note) = renderer.note() {
        println!("{note}");
    }
    let settings = RenderSettings {
        width: 480,
        height: 360,
        resolution: Some(96),
        ..Default::default()
    };
    let frame = renderer.render(RenderTarget::Scene(&scene), &settings, &Job::default())?;
    frame.image.write_png(&out.join("part.png"))?;
    println!(
        "image: {} hits, {:.1} samples per ray, traced in {:.3} s on the {}",
        frame.stats.hits,
        frame.stats.samples_per_ray,
        frame.stats.trace_seconds,
        frame.stats.device
    );
    Ok(())
}
