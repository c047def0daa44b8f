"""isokit's written files read by other tools: GLB by trimesh (the same triangles, normals
and vertex colours as the PLY isokit writes), NRRD by pynrrd at every compression level
(one gzip member), and NPY with its lattice sidecar by NumPy."""

import json

import nrrd
import numpy as np
import pytest
import trimesh

from conftest import ROOT


def srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def test_glb_is_read_by_trimesh_with_the_same_triangles_and_colours(isokit, tmp_path):
    scene = tmp_path / "c.json"
    scene.write_text(json.dumps({"shape": {"union": [
        {"sphere": {"radius": 0.5, "center": [-0.6, 0, 0]}, "color": [1, 0, 0]},
        {"sphere": {"radius": 0.5, "center": [0.6, 0, 0]}, "color": [0, 0, 1]},
    ]}}))
    glb, ply = tmp_path / "c.glb", tmp_path / "c.ply"
    isokit("scene", scene, "--res", "24", "-o", glb)
    isokit("scene", scene, "--res", "24", "-o", ply)
    g = trimesh.load(glb, force="mesh", process=False)
    p = trimesh.load(ply, process=False)
    assert len(g.faces) == len(p.faces) > 100
    np.testing.assert_array_equal(g.faces, p.faces)
    np.testing.assert_allclose(g.vertices, p.vertices, atol=0)
    # COLOR_0 holds the PLY's sRGB bytes as linear values (glTF 2.0, 3.7.2.1).
    pc = p.visual.vertex_colors[:, :3]
    gc = g.visual.vertex_colors[:, :3].astype(np.float64) / 255.0
    np.testing.assert_allclose(gc, srgb_to_linear(pc), atol=1.5 / 255)
    assert (gc[:, 0] > 0.9).any() and (gc[:, 2] > 0.9).any()
    # Normals: unit, pointing out of each sphere.
    n = g.vertex_normals
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    c = np.where(g.vertices[:, :1] < 0, [-0.6, 0, 0], [0.6, 0, 0])
    assert (np.einsum("ij,ij->i", n, g.vertices - c) > 0).mean() > 0.99


def test_convert_to_glb_keeps_the_obj_triangles(isokit, tmp_path):
    src = ROOT / "data" / "sphere.obj"
    out = tmp_path / "s.glb"
    isokit("convert", src, out)
    a = trimesh.load(src, force="mesh", process=False)
    b = trimesh.load(out, force="mesh", process=False)
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_allclose(a.vertices, b.vertices, atol=0)


@pytest.mark.parametrize("level", ["none", "fast", "best"])
def test_nrrd_is_read_by_pynrrd_at_every_compression(isokit, tmp_path, level):
    out, npy = tmp_path / "t.nrrd", tmp_path / "t.npy"
    isokit("sample", "torus", "--res", "40", "--compression", level, "-o", out)
    isokit("sample", "torus", "--res", "40", "-o", npy)
    data, header = nrrd.read(str(out))
    side = json.loads((tmp_path / "t.npy.json").read_text())
    ref = np.load(npy)  # shape (nz, ny, nx)
    assert list(data.shape) == side["dims"]  # pynrrd: (nx, ny, nz), Fortran order
    np.testing.assert_array_equal(np.transpose(data, (2, 1, 0)), ref)
    np.testing.assert_allclose(header["space origin"], side["origin"], rtol=1e-6)
    np.testing.assert_allclose(np.diag(header["space directions"]), side["spacing"], rtol=1e-6)
    assert header["encoding"] == ("raw" if level == "none" else "gzip")
    assert header["inside"] == side["inside"] == "below"
