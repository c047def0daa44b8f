"""isokit's CSG scenes, meshed, against manifold3d's exact mesh booleans.

For each case the same solid is built twice: as an isokit scene (analytic primitives or a
mesh, evaluated to a narrow band and meshed by `isokit scene ... -o out.obj`) and as a
manifold3d boolean of finely tessellated inputs. The meshed result's volume must lie within
0.5% of manifold3d's and the symmetric Hausdorff distance within one voxel.

Run: `python -m pytest tests/reference` after `cargo build` (tools/test.sh does both).
"""

import json

import igl
import manifold3d as mf
import numpy as np
import pytest

from conftest import write_off

RES = 112
SEGMENTS = 256
RNG = np.random.default_rng(20261124)


def read_obj(path):
    """Vertices and triangles of an OBJ (the test's own reader)."""
    V, F = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                V.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                F.append([int(t.split("/")[0]) - 1 for t in line.split()[1:4]])
    return np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)


def volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def surface_samples(V, F, n):
    """The vertices plus `n` area-weighted random points on the triangles."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    t = RNG.choice(len(F), size=n, p=area / area.sum())
    u, v = RNG.random(n), RNG.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    P = a[t] + u[:, None] * (b[t] - a[t]) + v[:, None] * (c[t] - a[t])
    return np.vstack([V, P])


def hausdorff(A, B):
    (VA, FA), (VB, FB) = A, B
    d_ab, _, _ = igl.point_mesh_squared_distance(surface_samples(VA, FA, 20000), VB, FB)
    d_ba, _, _ = igl.point_mesh_squared_distance(surface_samples(VB, FB, 20000), VA, FA)
    return float(np.sqrt(max(d_ab.max(), d_ba.max())))


def manifold_mesh(m):
    mesh = m.to_mesh()
    return np.asarray(mesh.vert_properties)[:, :3].astype(np.float64), np.asarray(
        mesh.tri_verts
    ).astype(np.int64)


def torus(major, minor):
    """A torus around z, as manifold3d builds it: a circle revolved about the z axis."""
    circle = mf.CrossSection.circle(minor, SEGMENTS).translate([major, 0.0])
    return circle.revolve(2 * SEGMENTS)


def run_scene(isokit, tmp_path, name, shape):
    scene = tmp_path / f"{name}.json"
    scene.write_text(json.dumps({"shape": shape, "sampling": {"resolution": RES}}))
    out = tmp_path / f"{name}.obj"
    r = isokit("scene", scene, "-o", out, "--stats")
    stats = json.loads(r.stdout)
    return read_obj(out), stats


def compare(name, ours, theirs, stats):
    V, F = ours
    v_ours, v_ref = volume(V, F), volume(*theirs)
    h = hausdorff(ours, theirs)
    voxel = stats["spacing"]
    rel = abs(v_ours - v_ref) / v_ref
    print(
        f"{name}: volume isokit {v_ours:.5f} manifold3d {v_ref:.5f} (rel {rel:.2e}); "
        f"Hausdorff {h:.4f} = {h / voxel:.2f} voxels; dense_fraction {stats['dense_fraction']:.3f}"
    )
    assert rel < 0.005, f"{name}: volume differs by {rel:.3%}"
    assert h < voxel, f"{name}: Hausdorff {h} exceeds one voxel {voxel}"


def test_sphere_minus_box(isokit, tmp_path):
    shape = {
        "difference": [
            {"sphere": {"radius": 1.0}},
            {"box": {"half": [0.6, 0.6, 0.6], "center": [0.6, 0.6, 0.6]}},
        ]
    }
    ours, stats = run_scene(isokit, tmp_path, "sphere_box", shape)
    # manifold3d's cube spans [0, 1.2]^3: the box of half 0.6 centred at 0.6.
    ref = mf.Manifold.sphere(1.0, SEGMENTS) - mf.Manifold.cube([1.2, 1.2, 1.2])
    compare("sphere - box", ours, manifold_mesh(ref), stats)


def test_union_of_two_tori(isokit, tmp_path):
    shape = {
        "union": [
            {"torus": {"major": 0.8, "minor": 0.25}},
            {
                "transform": {
                    "translate": [0.8, 0, 0],
                    "rotate": {"axis": [1, 0, 0], "degrees": 90},
                    "of": {"torus": {"major": 0.8, "minor": 0.25}},
                }
            },
        ]
    }
    ours, stats = run_scene(isokit, tmp_path, "tori", shape)
    a = torus(0.8, 0.25)
    b = torus(0.8, 0.25).rotate([90.0, 0.0, 0.0]).translate([0.8, 0.0, 0.0])
    compare("torus + torus", ours, manifold_mesh(a + b), stats)


def test_mesh_minus_cylinder(isokit, tmp_path):
    # The mesh: manifold3d's own finely tessellated torus, written as OFF for isokit, so
    # both sides start from the same triangles.
    V, F = manifold_mesh(torus(0.9, 0.35))
    V = V.astype(np.float32).astype(np.float64)
    write_off(tmp_path / "torus.off", V, F)
    shape = {
        "difference": [
            {"mesh": {"path": "torus.off"}},
            {"cylinder": {"a": [0.9, 0, -1], "b": [0.9, 0, 1], "radius": 0.2}},
        ]
    }
    ours, stats = run_scene(isokit, tmp_path, "mesh_cyl", shape)
    mesh = mf.Manifold(mf.Mesh(V.astype(np.float32), F.astype(np.uint32)))
    cyl = mf.Manifold.cylinder(2.0, 0.2, 0.2, SEGMENTS, center=True).translate([0.9, 0.0, 0.0])
    compare("mesh - cylinder", ours, manifold_mesh(mesh - cyl), stats)
    # The cylinder is queried only where the mesh's band needs it (a difference skips a
    # subtrahend the point lies well outside of).
    cyl_source = [s for s in stats["sources"] if s["kind"] == "cylinder"][0]
    mesh_source = [s for s in stats["sources"] if s["kind"] == "mesh"][0]
    assert cyl_source["queries"] < 0.5 * mesh_source["queries"]


def test_scene_stats_and_lazy_output_match_dense(isokit, tmp_path):
    """`--stats` prints one JSON object; lazy and dense evaluation mesh to the same surface."""
    # Two drilled balls at opposite corners of their bounding box: mostly empty space.
    shape = {
        "union": [
            {"sphere": {"radius": 0.5, "center": [-1.5, -1.5, -1.5]}},
            {
                "difference": [
                    {"sphere": {"radius": 0.5, "center": [1.5, 1.5, 1.5]}},
                    {"cylinder": {"a": [1.5, 1.5, 0.5], "b": [1.5, 1.5, 2.5], "radius": 0.2}},
                ]
            },
        ]
    }
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps({"shape": shape}))
    lazy = json.loads(isokit("scene", scene, "-o", tmp_path / "l.obj", "--res", 64, "--stats").stdout)
    dense = json.loads(
        isokit("scene", scene, "-o", tmp_path / "d.obj", "--res", 64, "--stats", "--dense").stdout
    )
    for key in ("dense_fraction", "seconds", "sources", "dims", "spacing", "band"):
        assert key in lazy
    assert dense["dense_fraction"] == 1.0
    assert lazy["dense_fraction"] < 0.15
    A, B = read_obj(tmp_path / "l.obj"), read_obj(tmp_path / "d.obj")
    assert len(A[1]) == len(B[1])
    assert abs(volume(*A) - volume(*B)) < 1e-9 * abs(volume(*B)) + 1e-9
