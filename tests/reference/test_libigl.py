"""isokit's exact mesh distances and signs against libigl, on meshes made here.

Run: `python -m pytest tests/reference` after `cargo build` (tools/test.sh does both).
"""

import numpy as np
import pytest
import igl

from conftest import icosphere, write_off

RNG = np.random.default_rng(20261123)


def f32(mesh):
    """Rounds vertices to f32 (isokit loads f32 vertices)."""
    V, F = mesh
    return V.astype(np.float32).astype(np.float64), F


def open_meshes():
    """Open meshes: a sphere cap, a sphere with random holes, and a crumpled open sheet."""
    V, F = f32(icosphere(3))
    centroids = V[F].mean(axis=1)
    yield "cap", V, F[centroids[:, 2] < 0.5]
    keep = RNG.random(len(F)) > 0.15
    yield "holes", V, F[keep]
    n = 24
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    P = np.stack([u, v, 0.2 * np.sin(6 * u) * np.cos(5 * v)], axis=-1).reshape(-1, 3)
    T = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            T += [[a, b, c], [a, c, d]]
    yield "sheet", P.astype(np.float32).astype(np.float64), np.array(T, dtype=np.int64)


def query(isokit, tmp_path, V, F, P, sign):
    """Runs `isokit query`; V must be f32-exact so both sides measure the same mesh."""
    assert (V.astype(np.float32).astype(np.float64) == V).all()
    mesh = tmp_path / "m.off"
    write_off(mesh, V, F)
    pts, out, cl = tmp_path / "p.npy", tmp_path / "d.npy", tmp_path / "c.npy"
    np.save(pts, P)
    r = isokit("query", mesh, "--points", pts, "-o", out, "--closest", cl, "--sign", sign)
    return np.load(out).astype(np.float64), np.load(cl).astype(np.float64), r.stderr


def points_around(V, n):
    lo, hi = V.min(axis=0), V.max(axis=0)
    pad = 0.3 * (hi - lo).max()
    return RNG.uniform(lo - pad, hi + pad, size=(n, 3))


@pytest.mark.parametrize("case", list(open_meshes()), ids=lambda c: c[0])
def test_winding_sign_matches_libigl_on_open_meshes(isokit, tmp_path, case):
    name, V, F = case
    P = points_around(V, 3000)
    d, _, err = query(isokit, tmp_path, V, F, P, "auto")
    assert "winding" in err, f"auto should pick the winding number for an open mesh: {err}"
    w = igl.winding_number(V, F, P)
    # Away from the w = 1/2 level set, where the hierarchical evaluation may round either way.
    clear = np.abs(w - 0.5) > 1e-2
    assert clear.sum() > 0.9 * len(P)
    inside = w > 0.5
    agree = (d[clear] < 0) == inside[clear]
    assert agree.all(), f"{name}: {np.count_nonzero(~agree)} of {clear.sum()} signs differ"


@pytest.mark.parametrize("case", list(open_meshes()), ids=lambda c: c[0])
def test_unsigned_distance_and_closest_points_match_libigl(isokit, tmp_path, case):
    name, V, F = case
    P = points_around(V, 2000)
    d, c, _ = query(isokit, tmp_path, V, F, P, "unsigned")
    s, _, C, _ = igl.signed_distance(P, V, F, sign_type=igl.SIGNED_DISTANCE_TYPE_UNSIGNED)
    diag = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    # Both sides see the same f32-exact vertices; isokit returns f32 distances.
    assert np.allclose(d, np.abs(s), rtol=1e-6, atol=2e-7 * diag), np.abs(d - np.abs(s)).max()
    # Closest points may differ only where two points are equally close.
    dc = np.linalg.norm(P - c, axis=1)
    assert np.allclose(dc, np.abs(s), rtol=1e-6, atol=2e-7 * diag)


def test_pseudonormal_sign_matches_libigl_on_a_closed_mesh(isokit, tmp_path):
    V, F = f32(icosphere(3))
    P = points_around(V, 3000)
    d, _, err = query(isokit, tmp_path, V, F, P, "auto")
    assert "pseudonormal" in err
    s, _, _, _ = igl.signed_distance(P, V, F, sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)
    far = np.abs(s) > 1e-4 * 2.0
    assert (np.sign(d[far]) == np.sign(s[far])).all()
    assert np.allclose(d, s, rtol=1e-6, atol=1e-6)
