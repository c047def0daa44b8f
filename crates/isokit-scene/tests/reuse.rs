//! Sampling again after an edit: the bricks taken from the previous sampling, and the band as
//! a whole, equal a fresh sampling of the edited scene, and fewer bricks are evaluated.

use isokit_field::Job;
use isokit_scene::{SampleOptions, Scene, SceneFormat, changed_boxes};
use std::path::Path;

fn scene(shape: &str) -> Scene {
    // Fixed bounds: both versions use one lattice, so a fresh sampling is comparable.
    let text = format!(
        r#"{{"sampling": {{"bounds": [[-2.5, -1.5, -1.5], [2.5, 1.5, 1.5]]}}, "shape": {shape}}}"#
    );
    Scene::from_text(&text, SceneFormat::Json, "edit.json", Path::new(".")).unwrap()
}

fn part(r: f32, dx: f32, extra: &str) -> String {
    format!(
        r#"{{"union": [
            {{"sphere": {{"radius": {r}, "center": [-1.2, 0, 0]}}}},
            {{"transform": {{"translate": [{dx}, 0, 0], "of": {{"box": {{"half": [0.4, 0.4, 0.4]}}}}}}}},
            {{"smooth_union": {{"radius": 0.2, "of": [
                {{"sphere": {{"radius": 0.3, "center": [0, 0.8, 0]}}}},
                {{"sphere": {{"radius": 0.3, "center": [0, 0.8, 0.4]}}}}]}}}}{extra}
        ]}}"#
    )
}

/// Samples `before`, then `after` reusing it, and checks the result against a fresh
/// sampling of `after`; returns (bricks reused, evaluated fraction with reuse, fresh).
fn edit(before: &str, after: &str) -> (usize, f64, f64) {
    edit_at(before, after, 96)
}

/// [`edit`] on a lattice of `resolution` samples along its longest side.
fn edit_at(before: &str, after: &str, resolution: usize) -> (usize, f64, f64) {
    let opts = SampleOptions {
        resolution,
        ..Default::default()
    };
    let job = Job::default();
    let old = scene(before).sample_kept(&opts, &job).unwrap();
    let new_scene = scene(after);
    let again = new_scene.sample_again(&opts, Some(&old), &job).unwrap();
    let fresh = new_scene.sample_kept(&opts, &job).unwrap();
    assert_eq!(again.grid.brick_count(), fresh.grid.brick_count());
    let (a, f) = (again.grid.to_grid().unwrap(), fresh.grid.to_grid().unwrap());
    let worst = a
        .data()
        .iter()
        .zip(f.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert_eq!(worst, 0.0, "{before} -> {after}: samples differ by {worst}");
    (
        again.stats.bricks_reused,
        again.stats.dense_fraction,
        fresh.stats.dense_fraction,
    )
}

#[test]
fn a_radius_edit_reuses_the_bricks_away_from_the_primitive() {
    let (reused, with, fresh) = edit(&part(0.5, 1.0, ""), &part(0.6, 1.0, ""));
    assert!(reused > 0, "no brick reused");
    assert!(
        with < 0.5 * fresh,
        "evaluated {with} of the grid, fresh {fresh}"
    );
}

#[test]
fn moving_adding_and_removing_children_and_nested_blends_match_a_fresh_sampling() {
    let extra = r#", {"sphere": {"radius": 0.2, "center": [1.8, 0.9, 0.9]}}"#;
    // A child under a transform moves; a child is added; removed.
    assert!(edit(&part(0.5, 1.0, ""), &part(0.5, 1.3, "")).0 > 0);
    assert!(edit(&part(0.5, 1.0, ""), &part(0.5, 1.0, extra)).0 > 0);
    assert!(edit(&part(0.5, 1.0, extra), &part(0.5, 1.0, "")).0 > 0);
    // The blend's radius changes: the whole smooth union is re-evaluated.
    let k = part(0.5, 1.0, "").replace(r#""radius": 0.2, "of""#, r#""radius": 0.35, "of""#);
    assert!(edit(&part(0.5, 1.0, ""), &k).0 > 0);
    // An operand inside the blend changes: the comparison goes through the blend.
    let inner = part(0.5, 1.0, "").replace("[0, 0.8, 0.4]", "[0, 0.8, 0.5]");
    assert!(edit(&part(0.5, 1.0, ""), &inner).0 > 0);
    // The root itself changes kind: nothing can be reused, and still equal.
    let root = format!(
        r#"{{"offset": {{"by": 0.05, "of": {}}}}}"#,
        part(0.5, 1.0, "")
    );
    assert_eq!(edit(&part(0.5, 1.0, ""), &root).0, 0);
    // The same scene again: every kept brick is reused.
    let same = edit(&part(0.5, 1.0, ""), &part(0.5, 1.0, ""));
    assert!(same.1 < 1e-9, "nothing evaluated: {}", same.1);
}

#[test]
fn the_changed_boxes_are_those_of_the_edited_subtree() {
    let (a, b) = (scene(&part(0.5, 1.0, "")), scene(&part(0.6, 1.0, "")));
    let boxes = changed_boxes(a.hashes(), b.hashes()).unwrap();
    // The old and the new sphere only.
    assert_eq!(boxes.len(), 2);
    assert!(boxes.iter().all(|c| c.dbox.aabb.max.x < -0.5), "{boxes:?}");
    assert!(changed_boxes(a.hashes(), a.hashes()).unwrap().is_empty());
}

#[test]
fn without_explicit_bounds_the_lattice_is_kept_while_the_shape_fits() {
    let s = |r: f32| {
        let text = format!(r#"{{"shape": {}}}"#, part(r, 1.0, ""));
        Scene::from_text(&text, SceneFormat::Json, "e.json", Path::new(".")).unwrap()
    };
    let opts = SampleOptions::default();
    let job = Job::default();
    let old = s(0.5).sample_kept(&opts, &job).unwrap();
    // Smaller: fits the old lattice, which is kept.
    let shrunk = s(0.45).sample_again(&opts, Some(&old), &job).unwrap();
    assert!(shrunk.stats.bricks_reused > 0);
    assert_eq!(shrunk.stats.dims, old.stats.dims);
    // Larger than the old lattice: a new one, nothing reused.
    let grown = s(1.1).sample_again(&opts, Some(&old), &job).unwrap();
    assert_eq!(grown.stats.bricks_reused, 0);
    assert_ne!(grown.stats.dims, old.stats.dims);
}

#[test]
fn an_operand_of_a_smooth_union_at_the_root_is_edited_alone() {
    // The demo scene's form: a blend at the root.
    let blend = |r: f32| {
        format!(
            r#"{{"smooth_union": {{"radius": 0.15, "of": [
                {{"sphere": {{"radius": {r}, "center": [-1.2, 0, 0]}}}},
                {{"box": {{"half": [0.4, 0.4, 0.4], "center": [1.0, 0, 0]}}}},
                {{"sphere": {{"radius": 0.4, "center": [0, 0.6, 0]}}}}]}}}}"#
        )
    };
    let (reused, with, fresh) = edit(&blend(0.4), &blend(0.5));
    assert!(reused > 0, "nothing reused under the blend");
    assert!(with < fresh, "{with} against {fresh}");
    let (a, b) = (scene(&blend(0.4)), scene(&blend(0.5)));
    let boxes = changed_boxes(a.hashes(), b.hashes()).unwrap();
    assert_eq!(boxes.len(), 2);
    // The blend raises the operands' cap by its window (k) and reach (k/4) for each of its
    // 2 folds.
    assert!(
        boxes
            .iter()
            .all(|c| (c.growth - 2.0 * (0.15 + 0.0375)).abs() < 1e-6)
    );
}

#[test]
fn an_operand_appended_to_a_long_blend_after_a_clamped_one_matches_a_fresh_sampling() {
    // Three operands: a sphere, a far one (clamped near the third), and a third sphere at a
    // swept gap from the first, so that somewhere near the third the first lies within a
    // window of the operands' cap; then a fourth, far from both, appended and removed.
    for i in 0..12 {
        let gap = 0.12 + 0.04 * i as f32;
        let of = |extra: bool| {
            let c = -1.1 + gap + 0.3;
            let mut list = vec![
                r#"{"sphere": {"radius": 0.5, "center": [-1.6, 0, 0]}}"#.to_string(),
                r#"{"sphere": {"radius": 0.2, "center": [0.6, 1.1, 0]}}"#.to_string(),
                format!(r#"{{"sphere": {{"radius": 0.3, "center": [{c}, 0, 0]}}}}"#),
            ];
            if extra {
                list.push(r#"{"sphere": {"radius": 0.2, "center": [2.0, -1.0, 0.5]}}"#.into());
            }
            format!(
                r#"{{"smooth_union": {{"radius": 0.15, "of": [{}]}}}}"#,
                list.join(", ")
            )
        };
        edit(&of(false), &of(true));
        edit(&of(true), &of(false));
    }
}

#[test]
fn an_operand_added_to_a_blend_is_the_only_change() {
    // Every blend kind: a third operand appended, removed again, then inserted first (for
    // the unions).
    for (kind, params) in [
        ("smooth_union", ""),
        ("chamfer_union", ""),
        ("stairs_union", r#""steps": 3, "#),
        ("smooth_difference", ""),
    ] {
        let of = |extra: bool, first: bool| {
            let a = r#"{"box": {"half": [1.2, 0.5, 0.5], "center": [-0.6, 0, 0]}}"#;
            let b = r#"{"sphere": {"radius": 0.4, "center": [-1.5, 0.5, 0]}}"#;
            let c = r#"{"sphere": {"radius": 0.25, "center": [1.2, 0.7, 0.5]}}"#;
            let list = match (extra, first) {
                (false, _) => vec![a, b],
                (true, false) => vec![a, b, c],
                (true, true) => vec![c, a, b],
            };
            format!(
                r#"{{"{kind}": {{"radius": 0.15, {params}"of": [{}]}}}}"#,
                list.join(", ")
            )
        };
        let (reused, with, fresh) = edit(&of(false, false), &of(true, false));
        assert!(
            reused > 0,
            "{kind}: nothing reused when an operand is appended"
        );
        assert!(with < 0.5 * fresh, "{kind}: {with} against {fresh}");
        assert!(
            edit(&of(true, false), &of(false, false)).0 > 0,
            "{kind}: removed"
        );
        if kind != "smooth_difference" {
            // Inserted first: every pair of operands compared differs, still equal to a
            // fresh sampling.
            edit(&of(false, false), &of(true, true));
        }
    }
}

#[test]
fn an_operand_added_to_an_intersection_changes_it_as_a_whole() {
    // A missing operand of a maximum acts as one at minus infinity: a far operand added to
    // an intersection raises its value everywhere, not only near that operand, so the
    // intersection changed as a whole (a sampling that reused the bricks away from the new
    // operand would keep the old, smaller values there).
    let a = r#"{"box": {"half": [1.2, 0.5, 0.5], "center": [-0.6, 0, 0]}}"#;
    let b = r#"{"sphere": {"radius": 0.6, "center": [-1.2, 0.3, 0]}}"#;
    let c = r#"{"sphere": {"radius": 0.25, "center": [1.2, 0.7, 0.5]}}"#;
    for (kind, params) in [
        ("intersection", None),
        ("smooth_intersection", Some("")),
        ("chamfer_intersection", Some("")),
        ("stairs_intersection", Some(r#""steps": 3, "#)),
    ] {
        let of = |list: &[&str]| match params {
            None => format!(r#"{{"{kind}": [{}]}}"#, list.join(", ")),
            Some(p) => format!(
                r#"{{"{kind}": {{"radius": 0.15, {p}"of": [{}]}}}}"#,
                list.join(", ")
            ),
        };
        // Appended (the intersection becomes empty), removed again, and an operand edited
        // in place, which is still one changed subtree.
        edit(&of(&[a, b]), &of(&[a, b, c]));
        edit(&of(&[a, b, c]), &of(&[a, b]));
        let (x, y) = (scene(&of(&[a, b])), scene(&of(&[a, c])));
        assert_eq!(
            changed_boxes(x.hashes(), y.hashes()).unwrap().len(),
            2,
            "{kind}: an operand edited in place"
        );
        let (x, y) = (scene(&of(&[a, b])), scene(&of(&[a, b, c])));
        let boxes = changed_boxes(x.hashes(), y.hashes()).unwrap();
        assert_eq!(
            boxes.len(),
            2,
            "{kind}: the whole intersection, before and after"
        );
        assert!(boxes.iter().all(|c| c.growth == 0.0), "{kind}");
    }
}

#[test]
fn a_subtrahend_edit_matches_a_fresh_sampling() {
    let bore = |r: f32| {
        format!(
            r#"{{"difference": [{{"box": {{"half": [0.8, 0.4, 0.4]}}}},
                {{"sphere": {{"radius": {r}, "center": [0.8, 0.4, 0]}}}}]}}"#
        )
    };
    assert!(edit(&bore(0.3), &bore(0.45)).0 > 0);
}

#[test]
fn bricks_in_a_changed_subtrees_box_but_far_from_its_surface_are_reused() {
    // A thin spherical shell around the whole lattice, whose box holds every brick, edited
    // beside a box at the centre: the box's band lies inside the shell's box but far from
    // its surface, where the shell's value, before and after, lies above the cap.
    let s = |r: f32| {
        format!(
            r#"{{"union": [{{"shell": {{"thickness": 0.05, "of": {{"sphere": {{"radius": {r}}}}}}}}},
                {{"box": {{"half": [0.4, 0.4, 0.4]}}}}]}}"#
        )
    };
    let (reused, _, _) = edit(&s(2.4), &s(2.45));
    // Every brick of the box's own band (the shell's box, which the distance boxes alone
    // go by, holds them all).
    let opts = SampleOptions {
        resolution: 96,
        ..Default::default()
    };
    let alone = scene(r#"{"box": {"half": [0.4, 0.4, 0.4]}}"#)
        .sample_kept(&opts, &Job::default())
        .unwrap()
        .stats
        .bricks_kept;
    assert!(
        reused >= alone,
        "{reused} reused, the box alone has {alone}"
    );
    // The surface swept from outside a brick to inside it: those bricks change sides and
    // are evaluated again (the band equal to a fresh sampling, checked by `edit`; a fine
    // lattice, so that bricks lie beyond the cap on both sides of the sweep).
    let ball = |r: f32| {
        format!(
            r#"{{"union": [{{"sphere": {{"radius": {r}, "center": [-1.0, 0, 0]}}}},
                {{"box": {{"half": [0.3, 0.3, 0.3], "center": [1.6, 0, 0]}}}}]}}"#
        )
    };
    assert!(edit_at(&ball(0.2), &ball(1.4), 256).0 > 0);
    assert!(edit_at(&ball(1.4), &ball(0.2), 256).0 > 0);
}
