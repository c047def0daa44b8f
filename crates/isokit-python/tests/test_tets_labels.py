"""Tetrahedral grids (`isokit.read_tets` → `TetGrid`) and label volumes
(`isokit.mesh_labels`) from Python, against what VTK reported for the bundled grid
(`data/tets/reference.json`) and the exact interfaces of touching blocks."""

import json

import numpy as np
import pytest

import isokit

from conftest import ROOT

TORUS = ROOT / "data" / "tets" / "torus.vtu"
REFERENCE = json.loads((ROOT / "data" / "tets" / "reference.json").read_text())


def area(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def test_a_tet_grid_reads_and_meshes_as_vtk_counts_it():
    g = isokit.read_tets(TORUS)
    assert g.points.shape == (REFERENCE["points"], 3)
    assert g.cells.shape == (REFERENCE["cells"], 4)
    assert g.values.shape == (REFERENCE["points"],)
    r = g.report()
    assert r["cells"] == REFERENCE["cells"] and r["inverted"] == 0
    assert r["range"] == pytest.approx(REFERENCE["range"], rel=1e-6)
    m = g.mesh(iso=0.0)
    c = REFERENCE["contour"]
    assert len(m.faces) == c["triangles"]
    assert area(*m).sum() == pytest.approx(c["area"], rel=1e-6)
    assert m.volume() == pytest.approx(c["volume"], rel=1e-6)
    # The other side inside: the same surface facing the other way.
    flipped = isokit.read_tets(TORUS).mesh(iso=0.0, inside="above")
    assert flipped.volume() == pytest.approx(-c["volume"], rel=1e-6)
    assert "TetGrid" in repr(g)


def test_a_tet_grid_renders_its_surface_and_its_volume():
    g = isokit.read_tets(TORUS)
    f = g.render(width=96, height=72, backend="cpu")
    assert f.stats["device"] == "cpu"
    # As `isokit render` on the same grid and camera (tests/tets_cli.rs: 473 pixels).
    assert f.stats["hits"] > 300
    v = g.render_volume("distance-shell", width=64, height=48, backend="cpu")
    assert v.stats["classification"] == "preintegrated" and v.stats["samples"] > 0
    post = g.render_volume("distance-shell", width=64, height=48, backend="cpu",
                           classification="post")
    assert post.stats["classification"] == "post"
    # The same segments, classified two ways: close on this smooth transfer function.
    assert np.abs(v.image.astype(float) - post.image.astype(float)).mean() / 255 < 0.05
    with pytest.raises(ValueError, match="no curvature"):
        g.render(shading="curvature", backend="cpu")
    with pytest.raises(ValueError, match="inside"):
        g.render(inside="sideways")
    with pytest.raises(ValueError, match="classification"):
        g.render_volume("distance-shell", classification="both")


def test_bad_grids_are_refused_clearly(tmp_path):
    with pytest.raises(Exception, match="No such file"):
        isokit.read_tets(tmp_path / "missing.vtu")
    bad = tmp_path / "bad.vtk"
    bad.write_text("# vtk DataFile Version 3.0\nbad\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 float\n0 0 0\n")
    with pytest.raises(Exception):
        isokit.read_tets(bad)


def blocks():
    """Region 1 for x < 5, 2 for x >= 5 and y < 5, 3 for x >= 5 and y >= 5, inside a
    border of 0 (12 x 10 x 8 samples, indexed [z, y, x])."""
    lab = np.zeros((8, 10, 12), dtype=np.int32)
    inner = lab[1:7, 1:9, 1:11]
    x = np.arange(1, 11)[None, None, :]
    y = np.arange(1, 9)[None, :, None]
    inner[...] = np.where(x < 5, 1, np.where(y < 5, 2, 3))
    return lab


def test_labels_mesh_into_their_interfaces_with_exact_areas():
    m = isokit.mesh_labels(blocks(), spacing=0.5, smooth=0)
    regions = m.stats["regions"]
    assert regions.shape == (len(m.faces), 2) and regions.dtype == np.int32
    pairs = {tuple(p) for p in regions}
    assert pairs == {(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)}
    a = area(*m)
    # Unsmoothed, the interfaces are the voxel faces between the regions: 1|2 is the plane
    # x = 2.25 over 4 samples in y and 6 in z (2 x 3 world units), 2|3 the plane y = 2.25
    # over 6 x 6 samples.
    by = {p: a[(regions == p).all(axis=1)].sum() for p in [(1, 2), (1, 3), (2, 3)]}
    assert by[(1, 2)] == pytest.approx(2.0 * 3.0, rel=1e-5)
    assert by[(1, 3)] == pytest.approx(2.0 * 3.0, rel=1e-5)
    assert by[(2, 3)] == pytest.approx(3.0 * 3.0, rel=1e-5)
    smooth = isokit.mesh_labels(blocks(), spacing=0.5)
    assert {tuple(p) for p in smooth.stats["regions"]} == pairs
    with pytest.raises(ValueError, match="whole numbers"):
        isokit.mesh_labels(blocks() + 0.25)
