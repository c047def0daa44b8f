"""Sampled fields: lattice and axis order, lazy against dense, saving (NRRD, NPY and its
lattice sidecar), level-set operations."""

import json

import numpy as np
import pytest

import isokit


def test_sample_lattice_and_axis_order():
    s = isokit.sphere(radius=0.6, center=(0.2, -0.1, 0.05))
    f = s.sample(res=48, method="dense")
    nz, ny, nx = f.values.shape
    assert f.dims == (nx, ny, nz) and f.values.dtype == np.float32
    assert f.band is None and f.dense_fraction == 1.0
    k, j, i = 7, 20, 31
    p = np.array(f.origin) + f.spacing * np.array([i, j, k])
    assert abs(f.values[k, j, i] - s(p[None])[0]) < 1e-6
    lo, hi = f.bounds
    assert np.allclose(hi, np.array(lo) + f.spacing * (np.array(f.dims) - 1))
    assert np.asarray(f).shape == f.values.shape


def test_lazy_sampling_equals_dense_within_the_band():
    s = isokit.sphere(0.4, center=(-1, -1, -1)) | isokit.sphere(0.4, center=(1, 1, 1))
    lazy = s.sample(res=64)
    dense = s.sample(res=64, method="dense")
    assert lazy.band is not None and lazy.dense_fraction < 0.5
    assert lazy.stats["bricks_kept"] < lazy.stats["bricks_total"]
    b = lazy.band
    assert np.allclose(lazy.values, np.clip(dense.values, -b, b), atol=1e-6)


def test_save_npy_with_sidecar_and_nrrd(tmp_path, isokit_bin):
    s = isokit.torus(major=0.7, minor=0.25)
    f = s.sample(res=40)
    f.save(tmp_path / "t.npy")
    side = json.loads((tmp_path / "t.npy.json").read_text())
    assert side["axis_order"] == "zyx" and side["inside"] == "below"
    assert side["dims"] == list(f.dims) and np.allclose(side["origin"], f.origin)
    assert np.allclose(side["spacing"], [f.spacing] * 3) and side["band"] == pytest.approx(f.band)
    assert np.array_equal(np.load(tmp_path / "t.npy"), f.values)
    f.save(tmp_path / "t.nrrd")
    # The command reads both with their geometry: the same world-space mesh.
    for name in ("t.npy", "t.nrrd"):
        isokit_bin("mesh", tmp_path / name, "-o", tmp_path / f"{name}.obj")
    for name in ("t.npy", "t.nrrd"):
        vs = [list(map(float, line.split()[1:4])) for line in open(tmp_path / f"{name}.obj")
              if line.startswith("v ")]
        vs = np.array(vs)
        assert np.allclose(vs.min(axis=0), [-0.95, -0.95, -0.25], atol=0.02), name
    # A shape from the saved file evaluates like the field.
    g = isokit.volume(tmp_path / "t.npy")
    p = np.array([[0.7, 0.0, 0.0], [0.0, 0.0, 0.0]])
    # Clamped to the band: the tube's centre (0.25 deep) lies beyond it.
    assert np.allclose(g(p), [-min(0.25, f.band), f.band], atol=0.01)
    with pytest.raises(ValueError, match="nrrd or .npy"):
        f.save(tmp_path / "t.vtk")


def test_reinit_restores_a_distance():
    s = isokit.sphere(0.6)
    f = s.sample(res=48, method="dense")
    squashed = isokit.Field(f.values * (1 + f.values ** 2), origin=f.origin, spacing=f.spacing)
    r = squashed.reinit()
    assert r.stats["converged"]
    near = np.abs(f.values) < 0.3
    assert np.abs(r.values[near] - f.values[near]).max() < 0.5 * f.spacing


def test_offsets_and_evolve_move_the_surface():
    s = isokit.sphere(0.5)
    f = s.sample(res=49, bounds=((-1, -1, -1), (1, 1, 1)), method="dense")
    c = tuple(n // 2 for n in f.values.shape)

    def radius(field):
        # Along +x from the centre sample: the zero crossing.
        row = field.values[c[0], c[1], :]
        x = np.array(field.origin[0]) + field.spacing * np.arange(len(row))
        i = np.where((row[:-1] < 0) & (row[1:] >= 0))[0][-1]
        return x[i] - row[i] * (x[i + 1] - x[i]) / (row[i + 1] - row[i])

    assert abs(radius(f) - 0.5) < 0.01
    assert abs(radius(f.offset(0.2)) - 0.7) < 0.02
    assert abs(radius(f.dilate(0.1)) - 0.6) < 0.02
    assert abs(radius(f.erode(0.1)) - 0.4) < 0.02
    assert abs(radius(f.opening(0.05)) - 0.5) < 0.02
    assert abs(radius(f.closing(0.05)) - 0.5) < 0.02
    e = f.evolve(speed=1.0, t=0.15)
    assert abs(radius(e) - 0.65) < 0.03 and e.stats["steps"] > 0
    # A speed given as a shape: |p| (a sphere offset by its radius), so dr/dt = r.
    grown = f.evolve(speed=isokit.sphere(1.0).offset(-1.0), t=0.1)
    assert abs(radius(grown) - 0.5 * np.exp(0.1)) < 0.02
    m = isokit.morph(f, f.offset(0.2), 0.5)
    assert abs(radius(m) - 0.6) < 0.02


def test_level_set_morph():
    a = isokit.sphere(0.5).sample(res=40, bounds=((-1, -1, -1), (1, 1, 1)), method="dense")
    b = isokit.box(half=0.45).sample(res=40, bounds=((-1, -1, -1), (1, 1, 1)), method="dense")
    out, stats = isokit.morph_level_set(a, b)
    # Within a voxel of the box (the default tolerance is half a voxel; the corners' last
    # fraction stalls).
    assert stats["deviation"] < a.spacing and stats["steps"] > 0
    assert out.dims == a.dims
    p = np.array([[0.45, 0.0, 0.0], [0.0, 0.45, 0.0], [0.2, 0.1, 0.45]])  # on the box's faces
    assert np.abs(out.to_shape()(p)).max() < 1.5 * a.spacing


def test_fields_mesh_and_become_shapes():
    f = isokit.sphere(0.6).sample(res=40)
    V, F = f.mesh()
    assert len(F) > 100 and np.abs(np.linalg.norm(V, axis=1) - 0.6).max() < 0.02
    seen = []
    V1, F1 = f.mesh(progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert np.array_equal(F1, F)
    assert seen and seen[-1][0] == "meshing" and seen[-1][1] == seen[-1][2] > 0
    g = f.to_shape() - isokit.sphere(0.3)
    assert g(np.array([[0.0, 0, 0]]))[0] > 0.25
    dens = isokit.Field(-f.values, origin=f.origin, spacing=f.spacing, inside="above")
    assert dens.inside == "above"
    V2, _ = dens.mesh()
    assert np.abs(np.linalg.norm(V2, axis=1) - 0.6).max() < 0.02
    with pytest.raises(ValueError, match="distance field"):
        dens.reinit()
