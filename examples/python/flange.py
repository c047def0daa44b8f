"""The bolt flange of examples/scenes/flange.json written in Python with the modeling
vocabulary: 2D profiles extruded, a circular array of bolt holes, colours, and named
parameters (`isokit.param`) that the scene file written beside the results keeps as
`"$name"` references. The script meshes the part and checks its own results: the same
field as the bundled scene file, a watertight mesh of genus 7 (the bore and six bolt
holes), and a scene file that reads back with its parameters.

    pip install ./crates/isokit-python
    python examples/python/flange.py [OUT_DIR]

Run in CI by tools/test.sh. The vase and the gear are in
crates/isokit-python/tests/test_vocab.py.
"""

import json
import pathlib
import sys

import numpy as np

import isokit

ROOT = pathlib.Path(__file__).resolve().parents[2]


def flange():
    """The part: a plate and a boss (grey), minus a bore and a ring of bolt holes (orange)."""
    bolt_radius = isokit.param("bolt_radius", 0.08)
    bolt_circle = isokit.param("bolt_circle", 0.7)
    bolts = isokit.param("bolts", 6)
    plate = isokit.param("plate", 0.2)
    body = (isokit.circle(radius=1.0).extrude(height=plate)
            | isokit.circle(radius=0.42).extrude(height=0.4).translate(0, 0, 0.2))
    bore = isokit.circle(radius=0.25).extrude(height=2.0)
    hole = isokit.circle(radius=bolt_radius, center=(bolt_circle, 0)).extrude(height=1.0)
    holes = hole.circular_array(count=bolts, axis=(0, 0, 1))
    return body.with_color((0.72, 0.72, 0.76)) - bore - holes.with_color((0.85, 0.35, 0.1))


def genus(F):
    """The genus of a closed, connected triangle mesh (Euler: V - E + F = 2 - 2g)."""
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    assert np.all(count == 2), f"{np.sum(count != 2)} edges are not shared by two triangles"
    chi = len(np.unique(F)) - len(count) + len(F)
    return (2 - chi) // 2


def main(out):
    out.mkdir(parents=True, exist_ok=True)
    part = flange()

    # The same field as the bundled scene file, at random points and on the bolt circle.
    bundled = isokit.load_scene(ROOT / "examples" / "scenes" / "flange.json")
    p = np.random.default_rng(7).uniform(-1.1, 1.1, size=(20000, 3))
    assert np.array_equal(part(p), bundled(p)), "the script and flange.json differ"
    d = part(np.array([[0.7, 0.0, 0.0], [0.0, 0.7, 0.0], [0.85, 0.0, 0.0]]))
    assert d[0] > 0 and d[2] < 0, "a bolt hole at 0°, solid between the holes"

    # A watertight mesh with the bore and six holes: genus 7.
    V, F = part.mesh(res=112, band=0.05)
    g = genus(F)
    print(f"flange: {len(V)} vertices, {len(F)} triangles, genus {g}")
    assert g == 7, f"genus {g}, expected 7"

    # The scene file keeps the parameters: change one and read it back.
    text = part.to_json()
    doc = json.loads(text)
    assert doc["params"] == {"bolt_radius": 0.08, "bolt_circle": 0.7, "bolts": 6, "plate": 0.2}
    (out / "flange.json").write_text(text)
    doc["params"]["bolts"] = 8
    (out / "flange8.json").write_text(json.dumps(doc))
    eight = isokit.load_scene(out / "flange8.json")
    on45 = np.array([[0.7 * np.cos(np.pi / 4), 0.7 * np.sin(np.pi / 4), 0.0]])
    assert part(on45)[0] < 0 < eight(on45)[0], "eight bolts put a hole at 45°"
    print(f"wrote {out / 'flange.json'} (bolts = \"$bolts\") and flange8.json")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "flange-out"))
