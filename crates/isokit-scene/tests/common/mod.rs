//! Pieces the scene tests share.

use glam::Vec3;
use isokit_field::rng::SplitMix64;

/// A random shape tree (JSON) over primitives and, at the leaves, `extra` sources.
pub fn random_tree(r: &mut SplitMix64, depth: usize, extra: &[&str]) -> String {
    let v = |r: &mut SplitMix64, s: f32| {
        let p = r.point_in(Vec3::splat(-s), Vec3::splat(s));
        format!("[{}, {}, {}]", p.x, p.y, p.z)
    };
    if depth == 0 || r.below(4) == 0 {
        if !extra.is_empty() && r.below(3) == 0 {
            return extra[r.below(extra.len())].to_owned();
        }
        return match r.below(5) {
            0 => format!(
                r#"{{"sphere": {{"radius": {}, "center": {}}}}}"#,
                r.range(0.2, 0.8),
                v(r, 0.6)
            ),
            1 => format!(
                r#"{{"box": {{"half": [{}, {}, {}], "center": {}}}}}"#,
                r.range(0.1, 0.6),
                r.range(0.1, 0.6),
                r.range(0.1, 0.6),
                v(r, 0.6)
            ),
            2 => format!(
                r#"{{"torus": {{"major": {}, "minor": {}, "center": {}}}}}"#,
                r.range(0.3, 0.6),
                r.range(0.05, 0.3),
                v(r, 0.5)
            ),
            3 => format!(
                r#"{{"capsule": {{"a": {}, "b": {}, "radius": {}}}}}"#,
                v(r, 0.8),
                v(r, 0.8),
                r.range(0.05, 0.3)
            ),
            _ => format!(
                r#"{{"ellipsoid": {{"radii": [{}, {}, {}], "center": {}}}}}"#,
                r.range(0.1, 0.6),
                r.range(0.1, 0.6),
                r.range(0.1, 0.6),
                v(r, 0.5)
            ),
        };
    }
    let kids = |r: &mut SplitMix64, n: usize| {
        (0..n)
            .map(|_| random_tree(r, depth - 1, extra))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let t = [0.0f32, 1.0, -0.5, 0.3, 2.0];
    let (n1, n2, k) = (1 + r.below(3), 2 + r.below(2), r.range(0.0, 0.5));
    match r.below(11) {
        0 => format!(r#"{{"union": [{}]}}"#, kids(r, n1)),
        1 => format!(r#"{{"intersection": [{}]}}"#, kids(r, n1)),
        2 => format!(r#"{{"difference": [{}]}}"#, kids(r, n2)),
        3 => format!(
            r#"{{"union": [{{"complement": {}}}, {}]}}"#,
            random_tree(r, depth - 1, extra),
            kids(r, 1)
        ),
        4 => format!(
            r#"{{"smooth_union": {{"radius": {}, "of": [{}]}}}}"#,
            k,
            kids(r, n1)
        ),
        5 => format!(
            r#"{{"smooth_intersection": {{"radius": {}, "of": [{}]}}}}"#,
            k,
            kids(r, n1)
        ),
        6 => format!(
            r#"{{"smooth_difference": {{"radius": {}, "of": [{}]}}}}"#,
            k,
            kids(r, n2)
        ),
        7 => format!(
            r#"{{"offset": {{"by": {}, "of": {}}}}}"#,
            r.range(-0.2, 0.2),
            kids(r, 1)
        ),
        8 => format!(
            r#"{{"shell": {{"thickness": {}, "of": {}}}}}"#,
            r.range(0.02, 0.2),
            kids(r, 1)
        ),
        9 => format!(
            r#"{{"morph": {{"t": {}, "from": {}, "to": {}}}}}"#,
            t[r.below(t.len())],
            kids(r, 1),
            kids(r, 1)
        ),
        _ => format!(
            r#"{{"transform": {{"translate": {}, "rotate": {{"axis": {}, "degrees": {}}}, "scale": {}, "of": {}}}}}"#,
            v(r, 0.3),
            v(r, 1.0),
            r.range(-180.0, 180.0),
            r.range(0.3, 2.5),
            kids(r, 1)
        ),
    }
}
