//! Lattice memos of a live-editing cache (`SourceCache::memoizing`): after an edit beside a
//! mesh, the bricks sampled again read the mesh's values back instead of querying its
//! kd-tree, and the band is bit for bit a fresh sampling's.

use isokit_field::Job;
use isokit_scene::file::parse;
use isokit_scene::{SampleOptions, Scene, SceneFormat, SourceCache};
use std::path::Path;

fn data() -> String {
    format!("{}/../../data", env!("CARGO_MANIFEST_DIR"))
}

/// The demo scene's shape: a mesh (moved by `dx`) blended with a sphere of radius `r`, and
/// `extra` small spheres.
fn text(r: f32, dx: f32, extra: usize) -> String {
    let mut of = vec![
        format!(
            r#"{{"transform": {{"translate": [{dx}, 0, 0], "of": {{"mesh": {{"path": "{}/torus.off"}}}}}}}}"#,
            data()
        ),
        format!(r#"{{"sphere": {{"radius": {r}, "center": [0.3, 0.2, 0]}}}}"#),
    ];
    for i in 0..extra {
        of.push(format!(
            r#"{{"sphere": {{"radius": 0.12, "center": [0.9, {}, 0.3]}}}}"#,
            0.5 - 0.2 * i as f32
        ));
    }
    format!(
        r#"{{"sampling": {{"resolution": 64, "bounds": [[-1.6, -1.6, -1.0], [1.6, 1.6, 1.0]]}},
            "shape": {{"smooth_union": {{"radius": 0.1, "of": [{}]}}}}}}"#,
        of.join(", ")
    )
}

fn compile(text: &str, cache: &mut SourceCache) -> Scene {
    let file = parse(text, SceneFormat::Json, "memo.json").unwrap();
    Scene::from_file_with(file, Path::new("."), cache).unwrap()
}

fn mesh_stats(s: &isokit_scene::SampleStats) -> (u64, u64) {
    let m = s
        .sources
        .iter()
        .find(|s| s.kind == "mesh" || s.kind == "points")
        .unwrap();
    (m.queries, m.memo_hits)
}

/// The same blend with the mesh (or the cloud, `points`) under a scale and a translation.
fn scaled(r: f32, points: bool) -> String {
    let source = if points {
        format!(r#"{{"points": {{"path": "{}/torus_cloud.ply"}}}}"#, data())
    } else {
        format!(r#"{{"mesh": {{"path": "{}/torus.off"}}}}"#, data())
    };
    format!(
        r#"{{"sampling": {{"resolution": 56, "bounds": [[-1.6, -1.6, -1.0], [1.6, 1.6, 1.0]]}},
            "shape": {{"smooth_union": {{"radius": 0.1, "of": [
                {{"transform": {{"scale": 0.8, "translate": [0.1, -0.05, 0.02], "of": {source}}}}},
                {{"sphere": {{"radius": {r}, "center": [0.3, 0.2, 0]}}}}]}}}}}}"#
    )
}

/// Samples `before`, then `after` reusing it through one memoizing cache; checks the band
/// against a fresh sampling of `after` (no cache) and returns the mesh's queries and memo
/// hits in the second sampling, and its queries in the fresh one.
fn edit(before: &str, after: &str) -> (u64, u64, u64) {
    let job = Job::default();
    let mut cache = SourceCache::memoizing();
    let first = compile(before, &mut cache);
    let opts = SampleOptions::from_scene(&first);
    let old = first.sample_kept(&opts, &job).unwrap();
    assert_eq!(
        mesh_stats(&old.stats).1,
        0,
        "a first sampling has nothing to read"
    );
    let new = compile(after, &mut cache);
    let again = new.sample_again(&opts, Some(&old), &job).unwrap();
    let fresh_scene = compile(after, &mut SourceCache::default());
    let fresh = fresh_scene.sample_kept(&opts, &job).unwrap();
    let (a, f) = (again.grid.to_grid().unwrap(), fresh.grid.to_grid().unwrap());
    let differ = a
        .data()
        .iter()
        .zip(f.data())
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    assert_eq!(differ, 0, "{differ} samples differ from a fresh sampling");
    let (q, h) = mesh_stats(&again.stats);
    eprintln!(
        "mesh queries {q} with {h} read back; fresh sampling {}",
        mesh_stats(&fresh.stats).0
    );
    (q, h, mesh_stats(&fresh.stats).0)
}

/// [`edit`], asserting that values were read back and that the source was queried less
/// than `1/factor` as often as in a fresh sampling.
fn reads_back(before: &str, after: &str, factor: u64, what: &str) {
    let (queries, hits, fresh) = edit(before, after);
    assert!(hits > 0, "{what}: no value read back");
    assert!(
        queries * factor < fresh,
        "{what}: the source was queried {queries} times (fresh {fresh}), {hits} read back"
    );
}

#[test]
fn a_radius_edit_beside_a_mesh_reads_the_mesh_back() {
    reads_back(&text(0.4, 0.0, 0), &text(0.45, 0.0, 0), 20, "radius");
}

#[test]
fn a_new_operand_of_the_blend_reads_the_mesh_back() {
    reads_back(&text(0.4, 0.0, 0), &text(0.4, 0.0, 2), 5, "new operand");
}

#[test]
fn moving_the_mesh_queries_it_again() {
    // Another frame: another memo, empty at first; what is read back are the apron nodes
    // a brick shares with a neighbour sampled before it in the same sampling. The band is
    // still exact.
    let (queries, hits, fresh) = edit(&text(0.4, 0.0, 0), &text(0.4, 0.05, 0));
    assert!(
        queries >= fresh / 2,
        "queried {queries}, fresh {fresh}, {hits} read back"
    );
}

#[test]
fn without_a_memoizing_cache_nothing_is_read_back() {
    let opts = SampleOptions {
        resolution: 48,
        ..Default::default()
    };
    let job = Job::default();
    let mut cache = SourceCache::default();
    let a = compile(&text(0.4, 0.0, 0), &mut cache);
    let old = a.sample_kept(&opts, &job).unwrap();
    let b = compile(&text(0.45, 0.0, 0), &mut cache);
    let again = b.sample_again(&opts, Some(&old), &job).unwrap();
    assert_eq!(mesh_stats(&again.stats).1, 0);
}

#[test]
fn a_full_resampling_only_fills_the_memo() {
    // No previous sampling given (what `isokit view --no-reuse` does): evaluated in full.
    let opts = SampleOptions {
        resolution: 48,
        ..Default::default()
    };
    let job = Job::default();
    let mut cache = SourceCache::memoizing();
    let a = compile(&text(0.4, 0.0, 0), &mut cache);
    a.sample_kept(&opts, &job).unwrap();
    let b = compile(&text(0.45, 0.0, 0), &mut cache);
    let again = b.sample_again(&opts, None, &job).unwrap();
    let fresh = compile(&text(0.45, 0.0, 0), &mut SourceCache::default())
        .sample_kept(&opts, &job)
        .unwrap();
    assert_eq!(mesh_stats(&again.stats).1, 0);
    assert_eq!(mesh_stats(&again.stats).0, mesh_stats(&fresh.stats).0);
}

#[test]
fn scaled_and_translated_meshes_and_clouds_read_back() {
    for points in [false, true] {
        let what = if points { "cloud" } else { "mesh" };
        reads_back(&scaled(0.4, points), &scaled(0.45, points), 10, what);
    }
}

#[test]
fn a_prism_band_is_not_memoized() {
    // Its values come from a band built for each sampling's lattice and cap.
    let prism =
        |r: f32| text(r, 0.0, 0).replace(r#"torus.off""#, r#"torus.off", "method": "prism_cpu""#);
    assert!(prism(0.4).contains("prism_cpu"));
    let (_, hits, _) = edit(&prism(0.4), &prism(0.45));
    assert_eq!(hits, 0);
}
