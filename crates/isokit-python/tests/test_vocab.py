"""The modeling vocabulary from Python: every node kind of the scene files' vocabulary
(2D profiles, extrude, revolve, non-uniform scale, mirror, orient, affine, repetition,
deformations, round/onion, chamfer and stairs blends), `isokit.param` and colours.

Each function's `to_json()` is the README's scene-file form; a shape built in Python has
the same field as `isokit.load_scene` of that form and as `isokit scene` of it; the three
example parts rebuilt in Python give the bundled files' fields; bad arguments raise."""

import importlib.util
import json
import math

import numpy as np
import pytest

import isokit
from conftest import ROOT

P = isokit.param


def _flange_example():
    spec = importlib.util.spec_from_file_location("flange_example", ROOT / "examples" / "python" / "flange.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def references(doc, at=""):
    """{JSON pointer: "$name"} of every parameter reference in a scene document."""
    out = {}
    if isinstance(doc, str) and doc.startswith("$"):
        out[at] = doc
    elif isinstance(doc, dict):
        for k, v in doc.items():
            out.update(references(v, f"{at}/{k}"))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out.update(references(v, f"{at}/{i}"))
    return out


def resolved(doc, params):
    """The document with each reference replaced by its parameter's value."""
    if isinstance(doc, str) and doc.startswith("$"):
        return params[doc[1:]]
    if isinstance(doc, dict):
        return {k: resolved(v, params) for k, v in doc.items()}
    if isinstance(doc, list):
        return [resolved(v, params) for v in doc]
    return doc


def close(a, b):
    """Equal trees, numbers within float32 rounding (a scene file holds float32s)."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(close(x, y) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=1e-7, abs_tol=1e-9)
    return a == b


def assert_same_scene(shape, doc, tmp_path, name="expected"):
    """`shape.to_json()` is the scene document `doc` (its references where `doc` has them,
    its other numbers as the file reads them), and `load_scene(doc)` has the same field."""
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(doc))
    loaded = isokit.load_scene(path)
    ours = json.loads(shape.to_json())
    assert references(ours) == references(doc)
    assert ours.get("params", {}) == doc.get("params", {})
    theirs = json.loads(loaded.to_json())  # load_scene keeps the references too
    assert references(theirs) == references(doc)
    assert close(resolved(ours["shape"], ours.get("params", {})),
                 resolved(theirs["shape"], theirs.get("params", {}))), (ours, theirs)
    p = np.random.default_rng(5).uniform(-1.5, 1.5, size=(4000, 3))
    assert np.array_equal(shape(p), loaded(p))
    assert shape.dim == loaded.dim
    return path


C = {"circle": {"radius": 0.5}}  # the profile the operations below extrude

# (the Python call, the README's scene-file form, whether `isokit scene` can sample it: a
# bounded solid)
CASES = [
    (lambda: isokit.circle(radius=0.5, center=(0.1, 0.2)),
     {"circle": {"radius": 0.5, "center": [0.1, 0.2]}}, False),
    (lambda: isokit.rectangle(half=(0.5, 0.3), center=(0.1, 0.0)),
     {"rectangle": {"half": [0.5, 0.3], "center": [0.1, 0]}}, False),
    (lambda: isokit.rounded_rectangle(half=(0.5, 0.3), radius=0.1, center=(0, 0.1)),
     {"rounded_rectangle": {"half": [0.5, 0.3], "radius": 0.1, "center": [0, 0.1]}}, False),
    (lambda: isokit.polygon([[0, 0], [1, 0], [0.2, 0.8]]),
     {"polygon": {"points": [[0, 0], [1, 0], [0.2, 0.8]]}}, False),
    (lambda: isokit.polygon(np.array([[0, 0], [1, 0], [0.2, 0.8]])),
     {"polygon": {"points": [[0, 0], [1, 0], [0.2, 0.8]]}}, False),
    (lambda: isokit.ellipse(radii=(0.6, 0.3), center=(0.0, -0.1)),
     {"ellipse": {"radii": [0.6, 0.3], "center": [0, -0.1]}}, False),
    (lambda: isokit.slot(a=(-0.4, 0), b=(0.4, 0.1), radius=0.2),
     {"slot": {"a": [-0.4, 0], "b": [0.4, 0.1], "radius": 0.2}}, False),
    (lambda: isokit.hexagon(radius=0.5, center=(0.1, 0)),
     {"hexagon": {"radius": 0.5, "center": [0.1, 0]}}, False),
    (lambda: (isokit.circle(radius=0.5) - isokit.rectangle(half=(0.2, 0.2))).offset(0.05),
     {"offset": {"by": 0.05, "of": {"difference": [C, {"rectangle": {"half": [0.2, 0.2]}}]}}}, False),
    (lambda: isokit.circle(radius=0.5).extrude(height=0.4),
     {"extrude": {"height": 0.4, "of": C}}, True),
    (lambda: isokit.circle(radius=0.5).extrude(height=0.4, round=0.05),
     {"extrude": {"height": 0.4, "round": 0.05, "of": C}}, True),
    (lambda: isokit.circle(radius=0.2, center=(0.5, 0)).revolve(offset=0.3),
     {"revolve": {"offset": 0.3, "of": {"circle": {"radius": 0.2, "center": [0.5, 0]}}}}, True),
    (lambda: isokit.sphere(0.5).transform(scale=(1, 2, 1)),
     {"transform": {"scale": [1, 2, 1], "of": {"sphere": {"radius": 0.5}}}}, True),
    (lambda: isokit.sphere(0.5).transform(translate=(0.1, 0, 0), rotate=((0, 0, 1), 30), scale=0.8),
     {"transform": {"translate": [0.1, 0, 0], "rotate": {"axis": [0, 0, 1], "degrees": 30},
                    "scale": 0.8, "of": {"sphere": {"radius": 0.5}}}}, True),
    (lambda: isokit.sphere(0.3, center=(0.5, 0, 0)).mirror(normal=(1, 0, 0), offset=0.1),
     {"mirror": {"normal": [1, 0, 0], "offset": 0.1,
                 "of": {"sphere": {"radius": 0.3, "center": [0.5, 0, 0]}}}}, True),
    (lambda: isokit.cylinder(a=(0, 0, -0.5), b=(0, 0, 0.5), radius=0.2).orient(axis=(1, 1, 0)),
     {"orient": {"axis": [1, 1, 0], "of": {"cylinder": {"a": [0, 0, -0.5], "b": [0, 0, 0.5],
                                                        "radius": 0.2}}}}, True),
    (lambda: isokit.box(0.4).affine(matrix=[[1, 0.3, 0, 0.1], [0, 1, 0, 0], [0, 0, 2, 0]]),
     {"affine": {"matrix": [[1, 0.3, 0, 0.1], [0, 1, 0, 0], [0, 0, 2, 0]],
                 "of": {"box": {"half": [0.4, 0.4, 0.4]}}}}, True),
    (lambda: isokit.sphere(0.2).repeat(period=(1, 0, 0)),
     {"repeat": {"period": [1, 0, 0], "of": {"sphere": {"radius": 0.2}}}}, False),
    (lambda: isokit.sphere(0.2).array(count=(3, 2, 1), spacing=(0.5, 0.5, 0)),
     {"array": {"count": [3, 2, 1], "spacing": [0.5, 0.5, 0], "of": {"sphere": {"radius": 0.2}}}}, True),
    (lambda: isokit.sphere(0.2, center=(0.7, 0, 0)).circular_array(count=5, axis=(0, 0, 1)),
     {"circular_array": {"count": 5, "axis": [0, 0, 1],
                         "of": {"sphere": {"radius": 0.2, "center": [0.7, 0, 0]}}}}, True),
    (lambda: isokit.sphere(0.2, center=(0.7, 0, 0)).circular_array(count=3, axis=(1, 0, 0)),
     {"circular_array": {"count": 3, "axis": [1, 0, 0],
                         "of": {"sphere": {"radius": 0.2, "center": [0.7, 0, 0]}}}}, True),
    (lambda: isokit.box(half=(0.4, 0.2, 0.8)).twist(rate=45, axis=(0, 0, 1)),
     {"twist": {"rate": 45, "axis": [0, 0, 1], "of": {"box": {"half": [0.4, 0.2, 0.8]}}}}, True),
    (lambda: isokit.box(half=(0.8, 0.1, 0.1)).bend(rate=30),
     {"bend": {"rate": 30, "of": {"box": {"half": [0.8, 0.1, 0.1]}}}}, True),
    (lambda: isokit.cylinder(a=(0, 0, -0.5), b=(0, 0, 0.5), radius=0.4).taper(rate=-0.3),
     {"taper": {"rate": -0.3, "of": {"cylinder": {"a": [0, 0, -0.5], "b": [0, 0, 0.5],
                                                   "radius": 0.4}}}}, True),
    (lambda: isokit.sphere(0.3).elongate(by=(0.5, 0, 0)),
     {"elongate": {"by": [0.5, 0, 0], "of": {"sphere": {"radius": 0.3}}}}, True),
    (lambda: isokit.box(0.4).round(radius=0.05),
     {"round": {"radius": 0.05, "of": {"box": {"half": [0.4, 0.4, 0.4]}}}}, True),
    (lambda: isokit.sphere(0.5).onion(thickness=0.05),
     {"onion": {"thickness": 0.05, "of": {"sphere": {"radius": 0.5}}}}, True),
    (lambda: isokit.chamfer_union(isokit.sphere(0.5), isokit.box(0.3, center=(0.5, 0, 0)), radius=0.1),
     {"chamfer_union": {"radius": 0.1, "of": [{"sphere": {"radius": 0.5}},
                                              {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}]}}, True),
    (lambda: isokit.sphere(0.5).chamfer_intersection(isokit.box(0.4), radius=0.1),
     {"chamfer_intersection": {"radius": 0.1, "of": [{"sphere": {"radius": 0.5}},
                                                     {"box": {"half": [0.4] * 3}}]}}, True),
    (lambda: isokit.chamfer_difference(isokit.box(0.5), isokit.sphere(0.3, center=(0.5, 0, 0)), radius=0.1),
     {"chamfer_difference": {"radius": 0.1, "of": [{"box": {"half": [0.5] * 3}},
                                                   {"sphere": {"radius": 0.3, "center": [0.5, 0, 0]}}]}}, True),
    (lambda: isokit.stairs_union(isokit.sphere(0.5), isokit.box(0.3, center=(0.5, 0, 0)), radius=0.2, steps=3),
     {"stairs_union": {"radius": 0.2, "steps": 3,
                       "of": [{"sphere": {"radius": 0.5}}, {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}]}}, True),
    (lambda: isokit.sphere(0.5).stairs_intersection(isokit.box(0.4), radius=0.2),
     {"stairs_intersection": {"radius": 0.2, "of": [{"sphere": {"radius": 0.5}},
                                                    {"box": {"half": [0.4] * 3}}]}}, True),
    (lambda: isokit.box(0.5).stairs_difference(isokit.sphere(0.3, center=(0.5, 0, 0)), radius=0.2, steps=5),
     {"stairs_difference": {"radius": 0.2, "steps": 5, "of": [{"box": {"half": [0.5] * 3}},
                                                              {"sphere": {"radius": 0.3, "center": [0.5, 0, 0]}}]}}, True),
    (lambda: isokit.sphere(0.5).with_color((0.8, 0.1, 0.1)),
     {"sphere": {"radius": 0.5}, "color": [0.8, 0.1, 0.1]}, True),
    (lambda: isokit.circle(radius=0.5, color=(0.1, 0.2, 0.3)).extrude(height=0.3),
     {"extrude": {"height": 0.3, "of": {"circle": {"radius": 0.5}, "color": [0.1, 0.2, 0.3]}}}, True),
]


@pytest.mark.parametrize("i", range(len(CASES)))
def test_each_function_writes_its_scene_file_form_and_has_its_field(i, tmp_path, isokit_bin):
    make, doc, sampled = CASES[i]
    shape = make()
    path = assert_same_scene(shape, {"shape": doc}, tmp_path)
    assert shape.kind == next(iter(doc))
    if sampled:
        out = tmp_path / "cli.npy"
        isokit_bin("scene", path, "-o", out, "--res", 24)
        assert np.array_equal(np.load(out), shape.sample(res=24).values)


def test_profiles_are_2d_and_exact():
    circle = isokit.circle(radius=0.5, center=(0.2, 0))
    assert circle.dim == 2 and isokit.sphere().dim == 3
    assert circle.extrude(height=1).dim == 3 and circle.revolve(offset=1).dim == 3
    assert (circle | isokit.rectangle()).dim == 2 and circle.translate(1, 0, 0).dim == 2
    p = np.random.default_rng(1).uniform(-1, 1, size=(500, 3))
    # z is immaterial: the exact 2D distance to the circle.
    assert np.allclose(circle(p), np.hypot(p[:, 0] - 0.2, p[:, 1]) - 0.5, atol=1e-6)
    # The extruded disk: exact distance to a cylinder of height 1.
    q = np.array([[0.2, 0.0, 0.8], [1.0, 0.0, 0.0], [1.0, 0.0, 0.9]])
    assert np.allclose(circle.extrude(height=1.0)(q), [0.3, 0.3, math.hypot(0.3, 0.4)], atol=1e-6)
    # Revolved about z at offset 1: a torus of radii 1.2 and 0.5.
    torus = isokit.torus(major=1.2, minor=0.5)
    tube = circle.revolve(offset=1.0)
    assert np.allclose(tube(p), torus(p), atol=1e-5)
    sig = __import__("inspect").signature(isokit.circle)
    assert list(sig.parameters) == ["radius", "center", "color"]
    assert "extrude" in isokit.circle.__doc__ and "Example" in isokit.hexagon.__doc__
    assert circle._repr_png_() is None


def test_defaults_are_the_scene_files(tmp_path):
    # isokit.KIND() with no arguments is the scene file's {"KIND": {}}.
    for key in ("circle", "rectangle", "rounded_rectangle", "ellipse", "slot", "hexagon"):
        assert_same_scene(getattr(isokit, key)(), {"shape": {key: {}}}, tmp_path, key)
    assert_same_scene(isokit.circle().revolve(offset=2), {"shape": {"revolve": {"offset": 2, "of": {"circle": {}}}}},
                      tmp_path, "rev")
    twist = isokit.box().twist(rate=10)
    assert "axis" not in json.loads(twist.to_json())["shape"]["twist"]  # the default, z
    assert json.loads(isokit.box().stairs_union(isokit.sphere(), radius=0.1).to_json())[
        "shape"]["stairs_union"]["steps"] == 4


def test_params_are_written_as_references(tmp_path, isokit_bin):
    r, n = P("r", 0.15), P("n", 5)
    assert (r.name, r.value) == ("r", 0.15) and "isokit.param" in repr(r)
    hole = isokit.circle(radius=r, center=(P("c", 0.6), 0)).extrude(height=1.0)
    part = isokit.cylinder(a=(0, 0, -0.1), b=(0, 0, 0.1), radius=1.0) - hole.circular_array(count=n)
    doc = {"params": {"r": 0.15, "c": 0.6, "n": 5}, "shape": {"difference": [
        {"cylinder": {"a": [0, 0, -0.1], "b": [0, 0, 0.1], "radius": 1.0}},
        {"circular_array": {"count": "$n", "of": {"extrude": {"height": 1.0, "of": {
            "circle": {"radius": "$r", "center": ["$c", 0]}}}}}}]}}
    path = assert_same_scene(part, doc, tmp_path)
    # The value is used; the same scene through the command.
    assert part(np.array([[0.6, 0.0, 0.0]]))[0] == pytest.approx(0.15, abs=1e-6)  # in the hole
    out = tmp_path / "cli.npy"
    isokit_bin("scene", path, "-o", out, "--res", 32)
    assert np.array_equal(np.load(out), part.sample(res=32).values)
    # References survive every operation that takes the shape as a child.
    s = isokit.sphere(radius=P("r", 0.3))
    wrapped = ((s | isokit.box(0.1)).translate(1, 0, 0).offset(0.1).twist(rate=P("k", 20))
               .smooth_union(isokit.sphere(0.1), 0.05).with_color((1, 0, 0)))
    wrapped = isokit.union(~wrapped, isokit.sphere(radius=P("r", 0.3), center=(0, 2, 0)))
    refs = references(json.loads(wrapped.to_json()))
    assert sorted(refs.values()) == ["$k", "$r", "$r"]
    assert_same_scene(wrapped, json.loads(wrapped.to_json()), tmp_path, "wrapped")
    # Primitives take parameters for numbers and vector components.
    box = isokit.box(half=P("h", 0.4), center=(P("x", 0.1), 0, 0))
    assert json.loads(box.to_json())["shape"]["box"] == {"half": ["$h", "$h", "$h"], "center": ["$x", 0.0, 0.0]}
    assert box(np.array([[0.1, 0.0, 0.0]]))[0] == pytest.approx(-0.4)


def test_colors(tmp_path):
    s = isokit.sphere(0.5).with_color((0.2, 0.4, 0.6))
    assert s.color == pytest.approx((0.2, 0.4, 0.6)) and isokit.sphere().color is None
    assert s.with_color((1, 1, 1)).color == (1, 1, 1)  # replaced, not nested
    assert json.loads(s.to_json())["shape"]["color"] == pytest.approx([0.2, 0.4, 0.6])
    ours = _flange_example().flange()
    shape = json.loads(ours.to_json())["shape"]
    assert shape["difference"][0]["color"] == pytest.approx([0.72, 0.72, 0.76])
    assert shape["difference"][2]["color"] == pytest.approx([0.85, 0.35, 0.1])
    # The renderer draws the parts in their colours as it does for the scene file (its
    # shape and camera, default settings otherwise), and not as the same part uncoloured.
    doc = json.loads((ROOT / "examples" / "scenes" / "flange.json").read_text())
    doc = {k: doc[k] for k in ("params", "shape", "camera")}
    (tmp_path / "flange.json").write_text(json.dumps(doc))
    for part in doc["shape"]["difference"]:
        part.pop("color", None)
    (tmp_path / "grey.json").write_text(json.dumps(doc))
    frames = [s.render(width=48, height=36, backend="cpu", camera=flange_camera(), res=48)
              for s in (ours, isokit.load_scene(tmp_path / "flange.json"), isokit.load_scene(tmp_path / "grey.json"))]
    a, b, grey = (np.asarray(f) for f in frames)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, grey)


def flange_camera():
    return {"eye": [1.8, -2.2, 2.0], "target": [0, 0, 0.1], "up": [0, 0, 1], "fov": 40}


def vase():
    wall, twist = P("wall", 0.06), P("twist", 60)
    profile = isokit.polygon([[-0.1, -0.8], [0.4, -0.8], [0.55, -0.45], [0.55, -0.1], [0.35, 0.35],
                              [0.28, 0.6], [0.36, 0.8], [-0.1, 0.8]])
    hexagonal = isokit.hexagon(radius=0.56).extrude(height=1.8).twist(rate=twist, axis=(0, 0, 1))
    body = profile.revolve(offset=0) & hexagonal
    return body.onion(thickness=wall) - isokit.box(half=(1, 1, 0.1), center=(0, 0, 0.85))


def gear():
    teeth, thickness, bore = P("teeth", 12), P("thickness", 0.3), P("bore", 0.2)
    tooth = isokit.polygon([[0.75, -0.09], [0.98, -0.05], [0.98, 0.05], [0.75, 0.09]])
    wheel = isokit.circle(radius=0.8) | tooth.circular_array(count=teeth, axis=(0, 0, 1))
    return (wheel - isokit.circle(radius=bore)).extrude(height=thickness)


@pytest.mark.parametrize("name", ["flange", "vase", "gear"])
def test_the_example_parts_rebuilt_in_python_give_the_same_fields(name, tmp_path, isokit_bin):
    part = {"flange": lambda: _flange_example().flange(), "vase": vase, "gear": gear}[name]()
    bundled_path = ROOT / "examples" / "scenes" / f"{name}.json"
    bundled = json.loads(bundled_path.read_text())
    # The same tree, parameters as references where the file has them.
    path = assert_same_scene(part, {"params": bundled["params"], "shape": bundled["shape"]}, tmp_path)
    # The same field as the bundled file (with its settings) through load_scene and the command.
    scene = isokit.load_scene(bundled_path)
    p = np.random.default_rng(11).uniform(-1.1, 1.1, size=(20000, 3))
    assert np.array_equal(part(p), scene(p))
    ours, theirs = tmp_path / "ours.npy", tmp_path / "theirs.npy"
    isokit_bin("scene", path, "-o", ours, "--res", 48, "--band", 0.05)
    isokit_bin("scene", bundled_path, "-o", theirs, "--res", 48, "--band", 0.05)
    values = part.sample(res=48, band=0.05).values
    assert np.array_equal(np.load(ours), np.load(theirs))
    assert np.array_equal(np.load(ours), values)


def test_the_flange_example_script_checks_itself(tmp_path):
    _flange_example().main(tmp_path)
    assert "$bolts" in (tmp_path / "flange.json").read_text()


BAD = [
    # 2D where 3D is needed, and the reverse.
    (lambda: isokit.circle().twist(rate=10), ValueError, "twist needs a 3D shape"),
    (lambda: isokit.circle().bend(rate=10), ValueError, "3D shape"),
    (lambda: isokit.circle().orient(axis=(1, 0, 0)), ValueError, "orient turns a solid"),
    (lambda: isokit.sphere().extrude(height=1), ValueError, "extrude needs a 2D profile"),
    (lambda: isokit.sphere().revolve(), ValueError, "revolve needs a 2D profile"),
    (lambda: isokit.sphere() | isokit.circle(), ValueError, "mixes 2D profiles and 3D shapes"),
    (lambda: isokit.circle() - isokit.sphere(), ValueError, "mixes"),
    (lambda: isokit.union(isokit.circle(), isokit.sphere()), ValueError, "mixes"),
    (lambda: isokit.chamfer_union(isokit.circle(), isokit.sphere(), radius=0.1), ValueError, "mixes"),
    (lambda: isokit.circle().smooth_union(isokit.sphere(), 0.1), ValueError, "mixes"),
    (lambda: isokit.circle().rotate("x", 30), ValueError, "about the z axis only"),
    (lambda: isokit.circle().repeat(period=(1, 1, 1)), ValueError, "xy-plane only"),
    (lambda: isokit.circle().mesh(res=16), ValueError, "extrude or revolve it first"),
    (lambda: isokit.circle().sample(res=16), ValueError, "2D profile"),
    (lambda: isokit.circle().render(width=8, height=8), ValueError, "2D profile"),
    # Counts.
    (lambda: isokit.sphere().circular_array(count=0), ValueError, "count"),
    (lambda: isokit.sphere().circular_array(count=-3), ValueError, "count"),
    (lambda: isokit.sphere().circular_array(count=2.5), ValueError, "count"),
    (lambda: isokit.sphere().circular_array(count=10**12), ValueError, "count"),
    (lambda: isokit.sphere().array(count=(0, 1, 1), spacing=(1, 1, 1)), ValueError, "at least 1"),
    (lambda: isokit.sphere().stairs_union(isokit.box(), radius=0.1, steps=0), ValueError, "steps"),
    (lambda: isokit.sphere().circular_array(count=P("n", 2.5)), ValueError, "count"),
    # NaN and infinities.
    (lambda: isokit.circle(radius=float("nan")), ValueError, "finite"),
    (lambda: isokit.circle(radius=math.inf), ValueError, "finite"),
    (lambda: isokit.sphere().twist(rate=float("nan")), ValueError, "finite"),
    (lambda: isokit.circle().extrude(height=float("nan")), ValueError, "finite"),
    (lambda: isokit.sphere().transform(scale=(1, float("nan"), 1)), ValueError, "finite"),
    (lambda: isokit.polygon([[0, 0], [1, float("nan")], [0, 1]]), ValueError, "finite"),
    (lambda: P("r", float("nan")), ValueError, "finite"),
    # Wrong lengths.
    (lambda: isokit.circle(center=(1, 2, 3)), ValueError, "length 3"),
    (lambda: isokit.rectangle(half=(1,)), ValueError, "length 1"),
    (lambda: isokit.sphere().array(count=(1, 2), spacing=(1, 1, 1)), ValueError, "length"),
    (lambda: isokit.sphere().affine(matrix=[[1, 0, 0, 0], [0, 1, 0, 0]]), ValueError, "length"),
    (lambda: isokit.sphere().transform(scale=(1, 2)), ValueError, "scale"),
    (lambda: isokit.sphere().mirror(normal=(1, 0)), ValueError, "length"),
    (lambda: isokit.polygon([[0, 0], [1, 0]]), ValueError, "at least 3"),
    (lambda: isokit.polygon([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), ValueError, "length"),
    (lambda: isokit.sphere().with_color((1, 0)), ValueError, "three components"),
    # Out of range, wrong types.
    (lambda: isokit.circle(radius=-1), ValueError, "radius"),
    (lambda: isokit.circle().extrude(height=1, round=0.8), ValueError, "round"),
    (lambda: isokit.sphere().mirror(normal=(0, 0, 0)), ValueError, "nonzero"),
    (lambda: isokit.sphere().affine(matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0]]), ValueError, "affine"),
    (lambda: isokit.sphere().elongate(by=(-1, 0, 0)), ValueError, "≥ 0"),
    (lambda: isokit.sphere().with_color((2, 0, 0)), ValueError, r"\[0, 1\]"),
    (lambda: isokit.circle(color=(0, 0, -1)), ValueError, r"\[0, 1\]"),
    (lambda: isokit.circle(radius="big"), TypeError, "radius must be a number"),
    (lambda: isokit.circle(radius=True), TypeError, "radius must be a number"),
    (lambda: isokit.circle().extrude(height=isokit.sphere()), TypeError, "height must be a number"),
    (lambda: isokit.sphere().twist(rate=None), ValueError, "rate"),
    (lambda: isokit.chamfer_union(radius=0.1), ValueError, "at least one shape"),
    (lambda: isokit.chamfer_union(isokit.sphere(), 3, radius=0.1), TypeError, "takes shapes"),
    (lambda: isokit.sphere().transform(rotate=30), TypeError, "rotate must be"),
    (lambda: isokit.sphere().scale((1, 2, 1)), TypeError, "transform"),
    # Parameters.
    (lambda: P("1r", 1), ValueError, "letter"),
    (lambda: P("r", "x"), TypeError, "number"),
    (lambda: isokit.sphere(radius=P("r", 1)) | isokit.sphere(radius=P("r", 2)), ValueError, "give different values"),
    (lambda: isokit.sphere(P("r", -1)), ValueError, "radius"),
]


@pytest.mark.parametrize("i", range(len(BAD)))
def test_bad_arguments_raise(i):
    make, exc, match = BAD[i]
    with pytest.raises(exc, match=match):
        make()


def test_errors_name_the_node():
    with pytest.raises(ValueError, match=r"isokit\.circular_array: shape\.circular_array\.count"):
        isokit.sphere().circular_array(count=0)
    with pytest.raises(ValueError, match=r"isokit\.twist: shape\.twist\.of"):
        isokit.circle().twist(rate=5)


def test_sources_below_the_new_nodes_are_found(tmp_path, monkeypatch):
    """Paths below any node (a twist, a coloured node) are read relative to the scene file,
    and in-memory meshes below them are saved by `to_json(save_sources_to=)`."""
    from conftest import icosphere
    V, F = icosphere(2, radius=0.5)
    ball = isokit.mesh((V, F))
    s = ball.twist(rate=20).with_color((0.5, 0.5, 0.5)) | ball.with_color((0.1, 0.2, 0.3)).translate(2, 0, 0)
    with pytest.raises(ValueError, match="save_sources_to"):
        s.to_json()
    (tmp_path / "scene").mkdir()
    s.save(tmp_path / "scene" / "s.json")
    doc = json.loads((tmp_path / "scene" / "s.json").read_text())
    twisted = doc["shape"]["union"][0]["twist"]["of"]["mesh"]["path"]
    assert not twisted.startswith("/") and (tmp_path / "scene" / twisted).exists()
    monkeypatch.chdir(tmp_path)  # elsewhere: the relative paths are the scene file's
    back = isokit.load_scene(tmp_path / "scene" / "s.json")
    p = np.array([[0.0, 0, 0], [0.6, 0, 0], [2.0, 0, 0.2], [2.6, 0, 0]])
    assert np.allclose(back(p), s(p), atol=1e-6)


def test_profile_signatures_and_stubs_are_the_scene_files():
    import ast
    import inspect
    profiles = {k: dict(p) for k, p in isokit._isokit._profiles()}
    assert set(profiles) == {"circle", "rectangle", "rounded_rectangle", "ellipse", "slot", "hexagon"}
    stub = ast.parse((ROOT / "crates" / "isokit-python" / "python" / "isokit" / "__init__.pyi").read_text())
    stubs = {f.name: f for f in stub.body if isinstance(f, ast.FunctionDef)}
    for key, defaults in profiles.items():
        sig = inspect.signature(getattr(isokit, key))
        assert {n: p.default for n, p in sig.parameters.items() if n != "color"} == defaults
        args = stubs[key].args
        assert dict(zip([a.arg for a in args.args], [ast.literal_eval(d) for d in args.defaults])) == defaults
    methods = {f.name for c in stub.body if isinstance(c, ast.ClassDef) and c.name == "Shape"
               for f in c.body if isinstance(f, ast.FunctionDef)}
    for name in ("extrude", "revolve", "transform", "mirror", "orient", "affine", "repeat", "array",
                 "circular_array", "twist", "bend", "taper", "elongate", "round", "onion", "with_color",
                 "chamfer_union", "stairs_difference"):
        assert name in methods and getattr(isokit.Shape, name).__doc__, name


def test_deep_arguments_and_long_chains_are_refused_or_built_without_a_crash():
    deep = [0.5]
    for _ in range(100000):
        deep = [deep]
    with pytest.raises(ValueError, match="nested more than"):
        isokit.polygon(deep)
    with pytest.raises(TypeError, match="three numbers"):
        isokit.sphere().translate(deep)  # not searched for parameters past the limit
    # A long chain of 2D unions (each checked without rebuilding the others' fields).
    ring = isokit.union(*[isokit.circle(radius=0.05, center=(math.cos(t), math.sin(t)))
                          for t in np.linspace(0, 2 * math.pi, 400, endpoint=False)])
    for t in range(100):
        ring = ring | isokit.circle(radius=0.01, center=(0, t * 0.001))
    assert ring.dim == 2 and ring.extrude(height=0.1).dim == 3


def test_references_at_default_values_and_in_loaded_scenes_are_kept(tmp_path):
    # A parameter whose value is the key's default (a scene file leaves such keys out).
    rev = isokit.circle(radius=0.2, center=(0.5, 0)).revolve(offset=P("d", 0))
    assert json.loads(rev.to_json())["shape"]["revolve"]["offset"] == "$d"
    arr = isokit.sphere(0.1).circular_array(count=3, axis=(P("ax", 0), 0, 1))
    assert json.loads(arr.to_json())["shape"]["circular_array"]["axis"] == ["$ax", 0, 1]
    # A scene file read by load_scene keeps its references; to_json writes them back.
    for name in ("flange", "vase", "gear"):
        path = ROOT / "examples" / "scenes" / f"{name}.json"
        doc = json.loads(path.read_text())
        loaded = isokit.load_scene(path)
        ours = json.loads(loaded.to_json())
        assert references(ours) == references(doc) and ours["params"] == doc["params"]
        # ... through operations too, and an edited parameter takes effect.
        moved = loaded.translate(0, 0, 1)
        edited = json.loads(moved.to_json())
        assert sorted(references(edited).values()) == sorted(references(doc).values())
    doc = json.loads((ROOT / "examples" / "scenes" / "flange.json").read_text())
    doc["params"]["bolts"] = 8
    (tmp_path / "f8.json").write_text(json.dumps(doc))
    f8 = isokit.load_scene(tmp_path / "f8.json")
    assert json.loads(f8.to_json())["shape"]["difference"][2]["circular_array"]["count"] == "$bolts"
    # Strings that only look like references (a file named $ball.ply) stay what they are.
    from conftest import icosphere
    isokit.mesh(icosphere(1, 0.5)).save(tmp_path / "m" / "s.json")
    m = json.loads((tmp_path / "m" / "s.json").read_text())
    (tmp_path / "m" / m["shape"]["mesh"]["path"]).rename(tmp_path / "m" / "$ball.ply")
    m["shape"] = {"union": [{"mesh": {"path": "$ball.ply"}}, {"sphere": {"radius": "$r"}}]}
    m["params"] = {"r": 0.25, "ball": 1.0}
    (tmp_path / "m" / "s.json").write_text(json.dumps(m))
    back = json.loads(isokit.load_scene(tmp_path / "m" / "s.json").to_json())
    assert back["shape"]["union"][0]["mesh"]["path"].endswith("/$ball.ply")
    assert back["shape"]["union"][1]["sphere"]["radius"] == "$r"
    # TOML scenes are written with their numbers.
    (tmp_path / "t.toml").write_text('params = {r = 0.5}\n[shape.sphere]\nradius = "$r"\n')
    assert json.loads(isokit.load_scene(tmp_path / "t.toml").to_json())["shape"]["sphere"]["radius"] == 0.5


def test_the_older_methods_take_parameters_too(tmp_path):
    r, d, t, k = P("r", 0.1), P("d", 30), P("t", 0.05), P("k", 1.5)
    a, b = isokit.sphere(0.5), isokit.box(0.3, center=(0.5, 0, 0))
    cases = [
        (a.smooth_union(b, r), {"smooth_union": {"radius": "$r", "of": [{"sphere": {"radius": 0.5}},
                                                                       {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}]}}),
        (isokit.smooth_union(a, b, radius=r), {"smooth_union": {"radius": "$r", "of": [
            {"sphere": {"radius": 0.5}}, {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}]}}),
        (a.smooth_difference(b, r), {"smooth_difference": {"radius": "$r", "of": [
            {"sphere": {"radius": 0.5}}, {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}]}}),
        (a.offset(r), {"offset": {"by": "$r", "of": {"sphere": {"radius": 0.5}}}}),
        (a.shell(t), {"shell": {"thickness": "$t", "of": {"sphere": {"radius": 0.5}}}}),
        (a.translate(r, 0, 0), {"transform": {"translate": ["$r", 0, 0], "of": {"sphere": {"radius": 0.5}}}}),
        (a.translate((0, r, 0)), {"transform": {"translate": [0, "$r", 0], "of": {"sphere": {"radius": 0.5}}}}),
        (b.rotate((0, 0, 1), d), {"transform": {"rotate": {"axis": [0, 0, 1], "degrees": "$d"},
                                                "of": {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}}}),
        (b.rotate("x", d), {"transform": {"rotate": {"axis": [1, 0, 0], "degrees": "$d"},
                                          "of": {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}}}),
        (b.scale(k), {"transform": {"scale": "$k", "of": {"box": {"half": [0.3] * 3, "center": [0.5, 0, 0]}}}}),
    ]
    for i, (shape, doc) in enumerate(cases):
        params = {n[1:]: {"$r": 0.1, "$d": 30, "$t": 0.05, "$k": 1.5}[n] for n in references(doc).values()}
        assert_same_scene(shape, {"params": params, "shape": doc}, tmp_path, f"old{i}")
    # Plain numbers still build the same trees as before.
    assert a.offset(0.1)(np.zeros((1, 3)))[0] == pytest.approx(-0.6)
    with pytest.raises(TypeError, match="radius must be a number"):
        a.smooth_union(b, "wide")
