//! Sharp features from scenes' exact fields: dual contouring against marching cubes on a
//! box, a box minus a cylinder and two intersecting boxes, one rotated 30°; and marching
//! cubes on a box whose faces lie on the sampling lattice.

use glam::{DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_field::{Job, TriMesh};
use isokit_kdtree::{MeshOptions as SdfOptions, MeshSdf, QueryStats, SignMode};
use isokit_levelset::intersect::self_intersections;
use isokit_levelset::weld::merge_coincident;
use isokit_scene::{MeshOptions, MeshStats, Mesher, SampleOptions, Scene, SceneFormat, mesh_scene};
use std::path::Path;

mod common;

fn scene(json: &str) -> Scene {
    Scene::from_text(json, SceneFormat::Json, "test.json", Path::new(".")).unwrap()
}

/// The scene meshed at `res` samples along the longest side: the mesh and the spacing.
fn mesh(s: &Scene, res: usize, mesher: Mesher) -> (TriMesh, f32) {
    let (m, st) = mesh_with_stats(s, res, mesher);
    (m, st.sampling.spacing)
}

/// The scene meshed at `res` samples along the longest side, with the meshing's statistics.
fn mesh_with_stats(s: &Scene, res: usize, mesher: Mesher) -> (TriMesh, MeshStats) {
    let mut sampling = SampleOptions::from_scene(s);
    sampling.resolution = res;
    let opts = MeshOptions {
        sampling,
        dense: false,
        mesher,
        error: None,
    };
    mesh_scene(s, &opts, &Job::default()).unwrap()
}

/// Points on the exact surface: random points near it projected by `p ← p − f ∇f` (exact
/// distance fields); points outside convex edges and corners land on them.
fn surface_points(s: &Scene, n: usize, seed: u64) -> Vec<Vec3> {
    let f = s.field();
    let b = s.domain();
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = Vec3::new(
            rng.range(b.min.x, b.max.x),
            rng.range(b.min.y, b.max.y),
            rng.range(b.min.z, b.max.z),
        );
        if f.value(p).abs() > 0.1 {
            continue;
        }
        for _ in 0..8 {
            let g = f.gradient(p);
            p -= f.value(p) * g.normalize_or_zero();
        }
        if f.value(p).abs() < 1e-5 {
            out.push(p);
        }
    }
    out
}

/// Closed (watertight), consistently oriented and without degenerate triangles; `what` names
/// the mesh in the failure.
fn assert_closed(m: &TriMesh, what: &str) {
    let v = m.validate();
    assert!(
        v.watertight && v.consistently_oriented && v.degenerate_triangles == 0,
        "{what}: {v}"
    );
}

/// Largest distance from the points to the mesh (one-sided Hausdorff, surface to mesh).
fn hausdorff_to(points: &[Vec3], m: &TriMesh) -> f64 {
    let sdf = MeshSdf::new(
        m,
        SdfOptions {
            sign: SignMode::Unsigned,
            ..SdfOptions::default()
        },
    )
    .unwrap();
    let mut stats = QueryStats::default();
    points
        .iter()
        .map(|p| {
            sdf.closest_within(p.as_dvec3(), f64::INFINITY, &mut stats)
                .map_or(f64::INFINITY, |h| h.distance.abs())
        })
        .fold(0.0, f64::max)
}

/// Largest `|f|` at the mesh's vertices.
fn vertex_error(s: &Scene, m: &TriMesh) -> f64 {
    m.positions
        .iter()
        .map(|p| s.field().value(*p).abs() as f64)
        .fold(0.0, f64::max)
}

struct Report {
    dual_pairs: usize,
    dual_vertex: f64,
    dual_hausdorff: f64,
    mc_hausdorff: f64,
}

/// Meshes `s` both ways and checks dual contouring's guarantees: closed, oriented, every
/// corner reproduced, Hausdorff from the surface below marching cubes', every vertex within
/// 0.05 voxel of the surface, no self-intersection, and Hausdorff from the
/// surface below 0.1 voxel. The Hausdorff distance is the largest over 40,000 points of the
/// exact surface (4,000 once missed the worst places along an edge of the rotated box, 0.27
/// voxel, and reported 0.025).
fn sharp(name: &str, s: &Scene, res: usize, corners: &[Vec3]) -> Report {
    let (dual, h) = mesh(s, res, Mesher::Dual);
    let (mc, _) = mesh(s, res, Mesher::Mc);
    let h = h as f64;
    let r = dual.validate();
    let merged = merge_coincident(&dual).validate();
    eprintln!(
        "{name}: dual {} triangles, non-manifold edges {}, after merging {} (watertight {}), mc {} triangles",
        dual.triangles.len(),
        r.non_manifold_edges,
        merged.non_manifold_edges,
        merged.watertight,
        mc.triangles.len()
    );
    assert!(r.watertight && r.consistently_oriented, "{name}: {r}");
    assert_eq!(r.degenerate_triangles, 0, "{name}: {r}");
    // 2-manifold: one fan around every vertex, also after coincident vertices are merged.
    assert_eq!(r.non_manifold_vertices, 0, "{name}: {r}");
    assert!(
        merged.watertight && merged.non_manifold_vertices == 0,
        "{name}: after merging: {merged}"
    );
    // Self-intersections (exact triangle–triangle tests): none from either mesher.
    let x = self_intersections(&mc);
    assert!(x.pairs.is_empty(), "{name}: mc: {} pairs", x.pairs.len());
    let x = self_intersections(&dual);
    let dual_pairs = x.count;
    eprintln!("{name}: dual: {} self-intersecting pairs", x.pairs.len());
    assert!(x.pairs.is_empty(), "{name}: dual: {} pairs", x.pairs.len());
    for c in corners {
        assert!(s.field().value(*c).abs() < 1e-5, "{name}: {c} is no corner");
        let near = dual
            .positions
            .iter()
            .map(|p| p.distance(*c) as f64)
            .fold(f64::INFINITY, f64::min);
        assert!(
            near < 0.05 * h,
            "{name}: corner {c}: nearest vertex {near} ({} voxel)",
            near / h
        );
    }
    let points = surface_points(s, 40_000, 11);
    let rep = Report {
        dual_pairs,
        dual_vertex: vertex_error(s, &dual) / h,
        dual_hausdorff: hausdorff_to(&points, &dual) / h,
        mc_hausdorff: hausdorff_to(&points, &mc) / h,
    };
    eprintln!(
        "{name} at res {res} (h = {h:.4}): dual max |f| at vertices {:.4} voxel, Hausdorff surface→mesh dual {:.4} voxel, mc {:.4} voxel (mc max |f| at vertices {:.4} voxel)",
        rep.dual_vertex,
        rep.dual_hausdorff,
        rep.mc_hausdorff,
        vertex_error(s, &mc) / h
    );
    assert!(
        rep.dual_vertex < 0.05,
        "{name}: vertex error {} voxel",
        rep.dual_vertex
    );
    assert!(
        rep.dual_hausdorff < 0.1,
        "{name}: Hausdorff {} voxel",
        rep.dual_hausdorff
    );
    assert!(rep.mc_hausdorff > 2.0 * rep.dual_hausdorff, "{name}");
    rep
}

fn box_corners(c: Vec3, half: Vec3) -> Vec<Vec3> {
    (0..8)
        .map(|n| {
            let s = Vec3::new(
                if n & 1 == 1 { 1.0 } else { -1.0 },
                if n & 2 == 2 { 1.0 } else { -1.0 },
                if n & 4 == 4 { 1.0 } else { -1.0 },
            );
            c + s * half
        })
        .collect()
}

#[test]
fn box_edges_and_corners_are_sharp() {
    let s =
        scene(r#"{"shape": {"box": {"half": [0.6, 0.4, 0.3], "center": [0.013, -0.021, 0.007]}}}"#);
    let corners = box_corners(Vec3::new(0.013, -0.021, 0.007), Vec3::new(0.6, 0.4, 0.3));
    sharp("box", &s, 64, &corners);
}

#[test]
fn box_minus_cylinder_is_sharp() {
    let s = scene(
        r#"{"shape": {"difference": [
            {"box": {"half": [0.6, 0.4, 0.5], "center": [0.011, 0.0, -0.013]}},
            {"cylinder": {"a": [0.05, -1, 0.02], "b": [0.05, 1, 0.02], "radius": 0.25}}
        ]}}"#,
    );
    let corners = box_corners(Vec3::new(0.011, 0.0, -0.013), Vec3::new(0.6, 0.4, 0.5));
    sharp("box minus cylinder", &s, 64, &corners);
}

/// Rodrigues' rotation of `p` by `deg` about unit axis `k`.
fn rotate(p: DVec3, k: DVec3, deg: f64) -> DVec3 {
    let (sn, cs) = deg.to_radians().sin_cos();
    p * cs + k.cross(p) * sn + k * k.dot(p) * (1.0 - cs)
}

#[test]
fn intersecting_boxes_rotated_30_degrees_are_sharp() {
    let s = scene(
        r#"{"shape": {"union": [
            {"box": {"half": [0.5, 0.35, 0.3]}},
            {"transform": {"translate": [0.35, 0.3, 0.2], "rotate": {"axis": [1, 2, 3], "degrees": 30},
                           "of": {"box": {"half": [0.4, 0.3, 0.35]}}}}
        ]}}"#,
    );
    // The corners of either box that lie outside the other are corners of the union.
    let k = DVec3::new(1.0, 2.0, 3.0).normalize();
    let t = DVec3::new(0.35, 0.3, 0.2);
    let mut corners: Vec<Vec3> = box_corners(Vec3::ZERO, Vec3::new(0.5, 0.35, 0.3));
    corners.extend(
        box_corners(Vec3::ZERO, Vec3::new(0.4, 0.3, 0.35))
            .into_iter()
            .map(|c| (t + rotate(c.as_dvec3(), k, 30.0)).as_vec3()),
    );
    let f = s.field();
    corners.retain(|c| {
        // On the surface of the union: not inside the other box.
        f.value(*c).abs() < 1e-5
    });
    assert!(
        corners.len() >= 10,
        "{} corners on the surface",
        corners.len()
    );
    // The edges at a general angle to the lattice: vertices on an edge beyond their cell
    // where a cell holds both faces but not the edge (or, with a third plane passing by,
    // the edge of two of them), quads straddling an edge split along the diagonal that
    // does not fold, mesh edges that still cut across an edge split on it, and vertices
    // clamped next to an edge or corner moved onto it (`isokit_levelset::dual`). Every
    // vertex within 0.05 voxel (0.14 with every vertex clamped into its cell), no
    // self-intersection (3 pairs then). Hausdorff 0.037 voxel over these points (0.066 with
    // the splits alone); 0.27 before the mesh edges cutting across an edge were split (in
    // two places along one edge of the rotated box a vertex that should lie on the edge lay
    // on one of its faces, and the triangles there cut the other face by a third of a cell).
    let rep = sharp("two boxes, one rotated 30°", &s, 64, &corners);
    assert_eq!(rep.dual_pairs, 0, "self-intersecting pairs");
}

/// Random scenes of two boxes, one rotated about a random axis by 10–80° and moved, united,
/// subtracted or intersected: their edges and corners at general angles to the lattice and
/// to each other, with the thin wedges, shallow creases and small facets such scenes have
/// (which a lattice of this spacing cannot resolve, so the 0.1-voxel bound of the named
/// shapes is not asserted here). Every mesh closed and oriented, no self-intersection, dual
/// contouring closer to the surface than marching cubes in every scene, and the median and
/// the count within 0.2 voxel held to what was measured.
#[test]
fn random_two_box_scenes_are_closer_than_marching_cubes() {
    let mut r = SplitMix64::new(7);
    let (mut duals, mut mcs) = (Vec::new(), Vec::new());
    for case in 0..9 {
        let axis = r.unit_vector();
        let degrees = r.range(10.0, 80.0);
        let t = Vec3::new(0.3, 0.25, 0.2) + r.point_in(Vec3::splat(-0.3), Vec3::splat(0.3));
        let op = ["union", "difference", "intersection"][case % 3];
        let s = scene(&format!(
            r#"{{"shape": {{"{op}": [
                {{"box": {{"half": [0.5, 0.35, 0.3]}}}},
                {{"transform": {{"translate": [{}, {}, {}], "rotate": {{"axis": [{}, {}, {}], "degrees": {degrees}}},
                               "of": {{"box": {{"half": [0.4, 0.3, 0.35]}}}}}}}}
            ]}}}}"#,
            t.x, t.y, t.z, axis.x, axis.y, axis.z
        ));
        let (dual, h) = mesh(&s, 48, Mesher::Dual);
        let (mc, _) = mesh(&s, 48, Mesher::Mc);
        assert_closed(&dual, &format!("case {case} ({op})"));
        let x = self_intersections(&dual);
        assert_eq!(x.count, 0, "case {case} ({op}): crossing pairs");
        let points = surface_points(&s, 20_000, case as u64);
        let (hd, hm) = (
            hausdorff_to(&points, &dual) / h as f64,
            hausdorff_to(&points, &mc) / h as f64,
        );
        eprintln!(
            "case {case} ({op}, {degrees:.1}°): Hausdorff surface→mesh dual {hd:.3} voxel, mc {hm:.3}"
        );
        assert!(hd < hm, "case {case} ({op}): dual {hd}, mc {hm}");
        duals.push(hd);
        mcs.push(hm);
    }
    duals.sort_by(f64::total_cmp);
    mcs.sort_by(f64::total_cmp);
    let within = duals.iter().filter(|&&d| d <= 0.2).count();
    eprintln!(
        "two-box scenes at res 48: median Hausdorff dual {:.3} voxel, mc {:.3}; dual within 0.2 voxel in {within} of {}",
        duals[duals.len() / 2],
        mcs[mcs.len() / 2],
        duals.len()
    );
    // Measured: median 0.034 voxel (marching cubes 0.786), 6 of 9 within 0.2 voxel; the
    // others 0.25–0.42 where a wedge, a shallow crease or a small facet is finer than a cell.
    assert!(
        duals[duals.len() / 2] < 0.1,
        "median {}",
        duals[duals.len() / 2]
    );
    assert!(within >= 6, "{within} of {} within 0.2 voxel", duals.len());
}

/// One of those scenes (two boxes intersected, one rotated 65.4° about a general axis) where
/// a vertex lay on one face a quarter of a cell from a sharp edge and the split of its mesh
/// edge on the edge crossed the next triangle (the split point fell behind the edge's next
/// vertex): 0.226 voxel over these points before such an edge's end was moved onto the sharp
/// edge instead, 0.011 after. The exact parameters matter: rounded to seven digits, the
/// lattice's crossings move and a vertex next to a corner is left 0.37 voxel short of it
/// (its move onto the corner folds; measured through `isokit scene` over 300,000 points), so
/// this case is pinned as it was found.
#[test]
fn a_mesh_edge_whose_split_crosses_has_its_end_moved_onto_the_sharp_edge() {
    let s = scene(
        r#"{"shape": {"intersection": [{"box": {"half": [0.5, 0.35, 0.3]}},
            {"transform": {"translate": [0.36551443666238526, 0.08576558741274073, -0.015983550530679624],
                           "rotate": {"axis": [0.8161187903968214, 0.4105571867237493, -1.227126096156625],
                                      "degrees": 65.37203556383538},
                           "of": {"box": {"half": [0.4, 0.3, 0.35]}}}}]}}"#,
    );
    let (dual, h) = mesh(&s, 64, Mesher::Dual);
    let points = surface_points(&s, 40_000, 3);
    let hd = hausdorff_to(&points, &dual) / h as f64;
    eprintln!("two boxes intersected, one rotated 65.4°: Hausdorff surface→mesh {hd:.3} voxel");
    assert!(hd < 0.1, "Hausdorff {hd} voxel");
}

/// The largest angle between the normals of two triangles that share an edge, in degrees
/// (180: folded flat back onto each other).
fn largest_fold_degrees(m: &TriMesh) -> f64 {
    let normal = |t: &[u32; 3]| {
        let p = t.map(|v| m.positions[v as usize].as_dvec3());
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    };
    let mut by_edge = std::collections::HashMap::new();
    let mut worst = 0.0f64;
    for t in &m.triangles {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            match by_edge.remove(&(b, a)) {
                Some(n) => {
                    let c: DVec3 = normal(t);
                    worst = worst.max(c.dot(n).clamp(-1.0, 1.0).acos().to_degrees());
                }
                None => {
                    by_edge.insert((a, b), normal(t));
                }
            }
        }
    }
    worst
}

/// A cylinder rotated about a general axis (its rims at a general angle to the lattice):
/// three cells' vertices on a rim next to each other made a sliver lying on the cap, folded
/// back against the side (neighbouring normals up to 180° apart, where every edge of the
/// cylinder is 90°), and the split nearer the surface kept it; the quad takes its other
/// diagonal there.
#[test]
fn rims_of_a_rotated_cylinder_have_no_folded_slivers() {
    let s = scene(
        r#"{"shape": {"transform": {"rotate": {"axis": [1, 0, 0], "degrees": 20},
            "of": {"cylinder": {"a": [0, 0, 0], "b": [0, 0, 0.6], "radius": 0.3}}}}}"#,
    );
    for res in [48, 64] {
        let (dual, _) = mesh(&s, res, Mesher::Dual);
        assert_closed(&dual, "rotated cylinder");
        let worst = largest_fold_degrees(&dual);
        eprintln!(
            "rotated cylinder at {res}: largest angle between neighbouring normals {worst:.1}°"
        );
        assert!(
            worst < 120.0,
            "res {res}: neighbouring normals {worst:.1}° apart"
        );
    }
}

/// The report's case through the scene pipeline: a box face at x = 0.75 on a lattice from
/// −1.05 with spacing 0.0125. Marching cubes gives no duplicate vertices and no degenerate
/// triangles, and stays watertight after merging coincident vertices.
#[test]
fn marching_cubes_on_a_box_on_the_lattice() {
    let s = scene(r#"{"shape": {"box": {"half": [0.75, 0.5, 0.25]}}, "sampling": {"band": 0.05}}"#);
    let mut sampling = SampleOptions::from_scene(&s);
    sampling.lattice = Some(([169; 3], Vec3::splat(-1.05), 0.0125));
    let opts = MeshOptions {
        sampling,
        dense: false,
        mesher: Mesher::Mc,
        error: None,
    };
    let (m, _) = mesh_scene(&s, &opts, &Job::default()).unwrap();
    let r = m.validate();
    eprintln!("box on the lattice, marching cubes: {r}");
    assert_eq!(r.duplicate_vertices, 0, "{r}");
    assert_eq!(r.degenerate_triangles, 0, "{r}");
    let merged = merge_coincident(&m).validate();
    assert!(
        merged.watertight && merged.consistently_oriented,
        "{merged}"
    );
    assert_eq!(merged.degenerate_triangles, 0, "{merged}");
    assert_eq!(merged.components, 1);
}

/// Random CSG trees of primitives (unions, differences, smooth blends, offsets, shells, thin
/// capsules and tori). Both meshers: closed, oriented, no degenerate triangles and no
/// self-intersections, on every tree (dual contouring's vertices clamped into their cells or
/// on features fold where the lattice cannot resolve a feature; its checks undo that, see
/// `isokit_levelset::dual`); dual contouring's triangles facing the wrong way are rare.
#[test]
fn random_csg_trees_mesh_closed_and_dual_folds_are_counted() {
    let mut r = SplitMix64::new(2027);
    let (mut meshed, mut trees_with, mut pairs, mut triangles, mut folded) = (0, 0, 0, 0, 0);
    let cases = 16;
    for case in 0..cases {
        let tree = common::random_tree(&mut r, 3, &[]);
        let s = scene(&format!(
            r#"{{"shape": {tree}, "sampling": {{"bounds": [[-1.5, -1.5, -1.5], [1.5, 1.5, 1.5]], "resolution": 40}}}}"#
        ));
        let (mc, _) = mesh(&s, 40, Mesher::Mc);
        if mc.triangles.is_empty() {
            // The tree is empty or fills the box (no surface in it).
            continue;
        }
        meshed += 1;
        assert_closed(&mc, &format!("case {case} mc\n{tree}"));
        let x = self_intersections(&mc);
        assert!(
            x.pairs.is_empty(),
            "case {case} mc: {} pairs\n{tree}",
            x.pairs.len()
        );
        let (dual, st) = mesh_with_stats(&s, 40, Mesher::Dual);
        assert_closed(&dual, &format!("case {case} dual\n{tree}"));
        let x = self_intersections(&dual);
        trees_with += (x.count > 0) as usize;
        pairs += x.count;
        triangles += dual.triangles.len();
        folded += st.folded_triangles.unwrap_or(0);
    }
    eprintln!(
        "dual contouring on {meshed} random CSG trees (of {cases}) at res 40: {trees_with} trees with self-intersections, {pairs} intersecting pairs among {triangles} triangles, {folded} triangles folded"
    );
    assert!(
        meshed >= cases / 2,
        "{meshed} of {cases} trees have a surface"
    );
    // 19 pairs among 50,200 triangles before the folds were checked and undone, 3 with
    // moves and flips alone.
    assert_eq!(pairs, 0, "{pairs} pairs among {triangles} triangles");
    // Triangles still facing the wrong way (against their crossing's normal and the exact
    // gradient at their centroid): rare, where thin capsules and tori are not resolved (18
    // among 50,200 when measured).
    assert!(
        folded * 2000 < triangles,
        "{folded} folded triangles among {triangles}"
    );
}

/// Adaptive dual contouring (cells merged into octree nodes within an error bound) on the
/// sharp scenes: closed, 2-manifold and oriented; every vertex within the bound (merged
/// ones) or as the uniform mesher places it; no self-intersection the uniform mesh lacks;
/// far fewer triangles.
#[test]
fn adaptive_meshes_of_the_sharp_scenes() {
    let scenes = [
        r#"{"box": {"half": [0.6, 0.4, 0.3], "center": [0.013, -0.021, 0.007]}}"#,
        r#"{"difference": [
            {"box": {"half": [0.6, 0.4, 0.5], "center": [0.011, 0.0, -0.013]}},
            {"cylinder": {"a": [0.05, -1, 0.02], "b": [0.05, 1, 0.02], "radius": 0.25}}]}"#,
        r#"{"union": [
            {"box": {"half": [0.5, 0.35, 0.3]}},
            {"transform": {"translate": [0.35, 0.3, 0.2], "rotate": {"axis": [1, 2, 3], "degrees": 30},
                           "of": {"box": {"half": [0.4, 0.3, 0.35]}}}}]}"#,
    ];
    let names = ["box", "box minus cylinder", "two boxes, one rotated 30°"];
    for (name, shape) in names.iter().zip(scenes) {
        let s = scene(&format!(r#"{{"shape": {shape}}}"#));
        let (uniform, h) = mesh(&s, 64, Mesher::Dual);
        let h = h as f64;
        let points = surface_points(&s, 3000, 5);
        let uh = hausdorff_to(&points, &uniform) / h;
        let uv = vertex_error(&s, &uniform) / h;
        let ux = self_intersections(&uniform).count;
        for e in [0.01, 0.1] {
            let mut sampling = SampleOptions::from_scene(&s);
            sampling.resolution = 64;
            let opts = MeshOptions {
                sampling,
                dense: false,
                mesher: Mesher::Dual,
                error: Some(e * h),
            };
            let (m, st) = mesh_scene(&s, &opts, &Job::default()).unwrap();
            let r = m.validate();
            assert!(
                r.watertight && r.consistently_oriented && r.non_manifold_edges == 0,
                "{name} E {e}: {r}"
            );
            assert_eq!(r.degenerate_triangles, 0, "{name} E {e}: {r}");
            let merged = merge_coincident(&m).validate();
            assert!(
                r.non_manifold_vertices == 0
                    && merged.watertight
                    && merged.non_manifold_vertices == 0,
                "{name} E {e}: {r}; after merging: {merged}"
            );
            assert_eq!(
                r.euler_characteristic,
                uniform.validate().euler_characteristic
            );
            let x = self_intersections(&m);
            let hd = hausdorff_to(&points, &m) / h;
            let ve = vertex_error(&s, &m) / h;
            eprintln!(
                "{name} at 64, E = {e} voxel: {} triangles (uniform {}), {} cells merged, vertex error {ve:.4} voxel (uniform {uv:.4}), Hausdorff surface→mesh {hd:.4} voxel (uniform {uh:.4}), {} self-intersecting pairs",
                m.triangles.len(),
                uniform.triangles.len(),
                st.merged_cells.unwrap_or(0),
                x.pairs.len()
            );
            assert!(ve <= uv.max(e) + 1e-4, "{name} E {e}: vertex error {ve}");
            // No self-intersection beyond the uniform mesh's (none there on these scenes).
            assert!(
                x.count <= ux,
                "{name} E {e}: {} pairs, uniform {ux}",
                x.count
            );
            // Within the bound of the uniform mesh's Hausdorff distance.
            assert!(hd <= uh + e + 0.02, "{name} E {e}: Hausdorff {hd} voxel");
            assert!(
                m.triangles.len() * 2 < uniform.triangles.len(),
                "{name} E {e}"
            );
        }
    }
}
