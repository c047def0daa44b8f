"""Scripts and scene files describe the same thing: `to_json` → `load_scene` and →
`isokit scene` give the script's field; in-memory sources are refused or saved."""

import json

import numpy as np
import pytest

import isokit
from conftest import icosphere


def part():
    body = isokit.rounded_box(half=(1.0, 0.25, 0.7), radius=0.05)
    boss = isokit.cylinder(a=(0, 0, 0), b=(0, 0.6, 0), radius=0.3)
    hole = isokit.cylinder(a=(0, -1, 0), b=(0, 1, 0), radius=0.15)
    return body.smooth_union(boss, 0.1) - hole.rotate("z", 10).translate(0.05, 0, 0)


def test_to_json_and_load_scene_round_trip(tmp_path, rng):
    s = part()
    text = s.to_json()
    data = json.loads(text)
    assert "difference" in data["shape"]
    path = tmp_path / "part.json"
    path.write_text(text)
    back = isokit.load_scene(path)
    p = rng.uniform(-1.2, 1.2, size=(2000, 3))
    assert np.array_equal(back(p), s(p))
    assert json.loads(back.to_json()) == data
    # TOML too.
    toml = tmp_path / "s.toml"
    toml.write_text('[shape.sphere]\nradius = 0.5\n')
    assert isokit.load_scene(toml)(np.zeros((1, 3)))[0] == -0.5


def test_script_and_isokit_scene_give_the_same_field(tmp_path, isokit_bin):
    s = part()
    path = tmp_path / "part.json"
    s.save(path)
    out = tmp_path / "part.npy"
    isokit_bin("scene", path, "-o", out, "--res", 64)
    theirs = np.load(out)
    ours = s.sample(res=64).values
    assert theirs.shape == ours.shape
    assert np.array_equal(theirs, ours)


def test_in_memory_sources_are_refused_or_saved(tmp_path, isokit_bin):
    V, F = icosphere(2, radius=0.8)
    s = isokit.mesh((V, F)) - isokit.sphere(0.5, center=(0.8, 0, 0))
    with pytest.raises(ValueError, match=r"shape\.difference\[0\]\.mesh.*save_sources_to"):
        s.to_json()
    text = s.to_json(save_sources_to=tmp_path / "src")
    files = list((tmp_path / "src").iterdir())
    assert len(files) == 1 and files[0].suffix == ".ply"
    scene = tmp_path / "src" / "scene.json"
    scene.write_text(text)
    back = isokit.load_scene(scene)
    p = np.array([[0.0, 0, 0], [0, 0, 1.0], [0.8, 0, 0]])
    assert np.allclose(back(p), s(p), atol=1e-6)
    # `save` writes the sources beside the scene, with relative paths: the folder can move.
    s.save(tmp_path / "moved" / "scene.json")
    data = json.loads((tmp_path / "moved" / "scene.json").read_text())
    rel = data["shape"]["difference"][0]["mesh"]["path"]
    assert not rel.startswith("/") and (tmp_path / "moved" / rel).exists()
    (tmp_path / "moved").rename(tmp_path / "elsewhere")
    again = isokit.load_scene(tmp_path / "elsewhere" / "scene.json")
    assert np.allclose(again(p), s(p), atol=1e-6)
    out = tmp_path / "m.npy"
    isokit_bin("scene", tmp_path / "elsewhere" / "scene.json", "-o", out, "--res", 40)
    assert np.array_equal(np.load(out), again.sample(res=40).values)


def test_fields_in_scenes_are_saved_as_volumes(tmp_path):
    f = isokit.sphere(0.5).sample(res=32)
    s = isokit.volume(f) | isokit.sphere(0.2, center=(0.6, 0, 0))
    text = s.to_json(save_sources_to=tmp_path)
    assert ".nrrd" in text
    (tmp_path / "s.json").write_text(text)
    back = isokit.load_scene(tmp_path / "s.json")
    p = np.array([[0.0, 0, 0], [0.3, 0.2, 0.1], [0.6, 0, 0]])
    assert np.allclose(back(p), s(p), atol=1e-5)
