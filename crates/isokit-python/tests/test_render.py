"""Rendering: frames, G-buffers, cameras, notebooks' PNGs, molecules."""

import pathlib

import numpy as np
import pytest

import isokit

ROOT = pathlib.Path(__file__).resolve().parents[3]


def test_render_a_shape():
    s = isokit.sphere(0.8) - isokit.box(half=0.4, center=(0.6, 0.6, 0.6))
    fr = s.render(width=96, height=64, backend="cpu")
    assert fr.image.shape == (64, 96, 4) and fr.image.dtype == np.uint8
    assert np.array_equal(np.asarray(fr), fr.image)
    g = fr.gbuffer
    assert list(g) == list(isokit.GBUFFER_CHANNELS)
    assert all(v.shape == (64, 96) and v.dtype == np.float32 for v in g.values())
    hit = g["A"] > 0
    assert 0.1 < hit.mean() < 0.9
    # Hit positions lie on the surface; normals are unit.
    P = np.stack([g["P.X"], g["P.Y"], g["P.Z"]], axis=-1)[hit]
    assert np.abs(s(P.astype(np.float64))).max() < 5e-3
    N = np.stack([g["N.X"], g["N.Y"], g["N.Z"]], axis=-1)[hit]
    assert np.allclose(np.linalg.norm(N, axis=1), 1, atol=1e-3)
    assert fr.stats["hits"] == int(hit.sum()) - fr.stats["caps"] or fr.stats["hits"] > 0
    assert fr.stats["backend"] == "cpu"


def test_cameras_and_shading_modes():
    s = isokit.torus()
    a = s.render(width=64, height=48, camera=isokit.Camera(eye=(0, 0, 4)), backend="cpu")
    b = s.render(width=64, height=48, camera={"eye": [0, 0, 4]}, backend="cpu")
    assert np.array_equal(a.image, b.image)
    # Looking down the torus's axis: the hole in the middle is background.
    assert a.gbuffer["A"][24, 32] == 0 and a.gbuffer["A"][24, 32 + 14] > 0
    for mode in ("normal", "curvature"):
        assert s.render(width=32, height=24, shading=mode, backend="cpu").image.any()
    assert "phong" in isokit.SHADING_MODES
    with pytest.raises(ValueError, match="shading mode"):
        s.render(width=32, height=24, shading="curvture")
    with pytest.raises(ValueError, match="keys are"):
        s.render(camera={"eye": [0, 0, 3], "fovy": 30})


def test_png_for_notebooks(tmp_path):
    s = isokit.capsule()
    png = s._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    f = s.sample(res=32)
    assert f._repr_png_()[:4] == b"\x89PNG"
    fr = s.render(width=40, height=30, backend="cpu")
    fr.save(tmp_path / "c.png")
    fr.save_gbuffer(tmp_path / "c.exr")
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "c.exr").stat().st_size > 0


def test_render_a_field():
    f = isokit.sphere(0.5).sample(res=32)
    fr = f.render(width=48, height=48, backend="cpu")
    assert fr.gbuffer["A"].any()


def test_molecule():
    path = ROOT / "data" / "molecules" / "1a8o.cif.gz"
    if not path.exists():
        pytest.skip("data/molecules/1a8o.cif.gz is not in this checkout")
    m = isokit.molecule(path)
    assert m.atoms > 100
    fr = m.render(width=64, height=48, style="spacefill", backend="cpu")
    assert fr.image.shape == (48, 64, 4) and fr.gbuffer["A"].any()
    with pytest.raises(ValueError, match="style"):
        m.render(style="ribbons")


def _ball(n=32, r=0.6):
    g = np.linspace(-1.0, 1.0, n)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    d = np.sqrt(x * x + y * y + z * z) - r
    return isokit.Field(d.astype(np.float32), origin=(-1, -1, -1), spacing=2.0 / (n - 1))


def test_render_volume_directly_with_a_transfer_function(tmp_path):
    f = _ball()
    tf = {"points": [[-0.05, 1, 0.5, 0.2, 3], [0, 0, 0, 0, 0]]}
    cam = {"eye": [0, 0, 4], "target": [0, 0, 0]}
    frames = {}
    for cls in ["post", "preintegrated"]:
        fr = f.render_volume(tf, width=24, height=24, classification=cls, camera=cam, backend="cpu")
        frames[cls] = fr
        g = fr.gbuffer
        assert sorted(g) == ["A", "B", "G", "R", "Z"]
        # The centre's ray crosses 1.2 of the sphere at sigma 3.
        assert abs(g["A"][12, 12] - (1 - np.exp(-3.6))) < 0.03
        assert g["A"][0, 0] == 0 and np.isinf(g["Z"][0, 0])
        assert abs(g["Z"][12, 12] - 3.63) < 0.1
        assert fr.stats["mode"] == "dvr" and fr.stats["classification"] == cls
        assert fr.image.shape == (24, 24, 4)
    # Shading keeps the opacity and lights the centre, which faces the eye.
    lit = f.render_volume(tf, width=24, height=24, shading="phong", camera=cam, backend="cpu")
    assert np.array_equal(lit.gbuffer["A"], frames["post"].gbuffer["A"])
    assert lit.stats["shading"] == "phong" and lit.stats["gradient"] == "tricubic"
    central = f.render_volume(
        tf, width=24, height=24, shading="phong", gradient="central", camera=cam, backend="cpu"
    )
    assert central.stats["gradient"] == "central"
    assert np.array_equal(central.gbuffer["A"], lit.gbuffer["A"])
    # Both gradients light the centre alike (the sphere's normal faces the eye there).
    assert abs(central.gbuffer["R"][12, 12] - lit.gbuffer["R"][12, 12]) < 0.02
    # A JSON file and a preset do as well.
    p = tmp_path / "tf.json"
    p.write_text('{"points": [[-0.05, 1, 0.5, 0.2, 3], [0, 0, 0, 0, 0]]}')
    same = f.render_volume(p, width=24, height=24, camera=cam, backend="cpu")
    assert np.array_equal(same.gbuffer["R"], frames["post"].gbuffer["R"])
    assert f.render_volume("distance-shell", width=16, height=16, backend="cpu").gbuffer["A"].max() > 0.5
    same.save_gbuffer(tmp_path / "v.exr")
    assert (tmp_path / "v.exr").stat().st_size > 0
    for bad, err in [
        ({"points": [[0, 1, 1]]}, ValueError),
        ("no-such-preset", ValueError),
        (3, TypeError),
    ]:
        with pytest.raises(err):
            f.render_volume(bad, width=8, height=8, backend="cpu")
    with pytest.raises(ValueError, match="classification"):
        f.render_volume(tf, classification="pre", width=8, height=8)
    with pytest.raises(ValueError, match="phong"):
        f.render_volume(tf, shading="tone", width=8, height=8)
    # The incremental table: close to the integrated one's image.
    inc = f.render_volume(
        tf, width=24, height=24, classification="preintegrated", table_build="incremental",
        camera=cam, backend="cpu",
    )
    assert np.abs(inc.gbuffer["A"] - frames["preintegrated"].gbuffer["A"]).max() < 0.03
    with pytest.raises(ValueError, match="table_build"):
        f.render_volume(tf, table_build="fast", width=8, height=8)
    with pytest.raises(ValueError, match="gradient"):
        f.render_volume(tf, shading="phong", gradient="sobel", width=8, height=8)
