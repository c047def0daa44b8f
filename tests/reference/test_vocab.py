"""The modeling vocabulary's example parts (examples/scenes/), meshed by isokit, against
manifold3d's exact mesh operations on the same parts: the bolt flange (extrusions, a
circular array, booleans), the extruded gear (2D CSG of a circle, a circular array of teeth
and a bore, extruded) and the vase's body (a revolved polygon intersected with a twisted,
extruded hexagon: manifold3d's `revolve` and its `extrude` with `twist_degrees`). The vase's
shell (`onion`, an offset) has no exact manifold3d counterpart and is not compared.

Each comparison: volume within 0.5% and the symmetric Hausdorff distance within one voxel,
as in test_manifold.py. Run: `python -m pytest tests/reference` after `cargo build`.
"""

import json
import math
import pathlib

import manifold3d as mf

from test_manifold import RES, SEGMENTS, compare, manifold_mesh, read_obj

ROOT = pathlib.Path(__file__).resolve().parents[2]


def example(name):
    return json.loads((ROOT / "examples" / "scenes" / name).read_text())


def run_example(isokit, tmp_path, name, shape=None):
    """Meshes an example scene (its params kept) at the test's resolution, optionally with
    its shape replaced."""
    scene = example(name)
    if shape is not None:
        scene["shape"] = shape
    scene["sampling"] = {"resolution": RES}
    path = tmp_path / name
    path.write_text(json.dumps(scene))
    out = tmp_path / f"{name}.obj"
    r = isokit("scene", path, "-o", out, "--stats")
    return read_obj(out), json.loads(r.stdout)


def slab(radius, z0, z1, x=0.0, y=0.0):
    """A cylinder about z from z0 to z1 (an extruded circle)."""
    return mf.Manifold.cylinder(z1 - z0, radius, -1.0, SEGMENTS).translate([x, y, z0])


def flange_reference(scene):
    """The flange as manifold3d booleans of cylinders."""
    p = scene["params"]
    h = p["plate"]
    body = slab(1.0, -h / 2, h / 2) + slab(0.42, 0.0, 0.4)
    cut = slab(0.25, -1.0, 1.0)
    for j in range(p["bolts"]):
        a = 2 * math.pi * j / p["bolts"]
        r = p["bolt_circle"]
        cut += slab(p["bolt_radius"], -0.5, 0.5, r * math.cos(a), r * math.sin(a))
    return body - cut


def gear_reference(scene):
    """The gear as manifold3d's 2D booleans, extruded."""
    p = scene["params"]
    disk, teeth = scene["shape"]["extrude"]["of"]["difference"][0]["union"]
    tooth = teeth["circular_array"]["of"]["polygon"]["points"]
    profile = mf.CrossSection.circle(disk["circle"]["radius"], SEGMENTS)
    for j in range(p["teeth"]):
        profile += mf.CrossSection([tooth]).rotate(360.0 * j / p["teeth"])
    profile -= mf.CrossSection.circle(p["bore"], SEGMENTS)
    t = p["thickness"]
    return profile.extrude(t).translate([0.0, 0.0, -t / 2])


def vase_body(scene):
    """The vase's part under the shell: the revolved profile ∩ the twisted hexagonal prism."""
    return scene["shape"]["difference"][0]["onion"]["of"]


def vase_body_reference(scene):
    """The vase's body as manifold3d's revolve ∩ its twisted extrusion."""
    rate = scene["params"]["twist"]
    body = vase_body(scene)
    revolved, twisted = body["intersection"]
    points = revolved["revolve"]["of"]["polygon"]["points"]
    prism = twisted["twist"]["of"]["extrude"]
    height, r = prism["height"], prism["of"]["hexagon"]["radius"]
    hexagon = [[r * math.cos(k * math.pi / 3), r * math.sin(k * math.pi / 3)] for k in range(6)]
    # isokit's twist turns the section at height z by rate·z degrees about z = 0; manifold3d
    # turns the top by twist_degrees relative to the bottom (both counter-clockwise seen
    # from +z), so the bottom starts turned back by half of it.
    total = rate * height
    twisted_ref = (
        mf.CrossSection([hexagon])
        .rotate(-total / 2)
        .extrude(height, 256, total)
        .translate([0.0, 0.0, -height / 2])
    )
    return mf.CrossSection([points]).revolve(2 * SEGMENTS) ^ twisted_ref


def test_flange(isokit, tmp_path):
    ours, stats = run_example(isokit, tmp_path, "flange.json")
    ref = flange_reference(example("flange.json"))
    compare("flange", ours, manifold_mesh(ref), stats)


def test_gear(isokit, tmp_path):
    ours, stats = run_example(isokit, tmp_path, "gear.json")
    ref = gear_reference(example("gear.json"))
    compare("gear", ours, manifold_mesh(ref), stats)


def test_vase_body(isokit, tmp_path):
    scene = example("vase.json")
    ours, stats = run_example(isokit, tmp_path, "vase.json", shape=vase_body(scene))
    compare("vase body", ours, manifold_mesh(vase_body_reference(scene)), stats)
