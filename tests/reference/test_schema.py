"""The JSON Schema of scene files (docs/scene.schema.json, generated from the Rust types)
checked by an independent validator (jsonschema): every shipped scene is valid, and
misspelt keys, unknown node kinds and bad enum values are not."""

import json
import pathlib

import jsonschema
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCHEMA = json.loads((ROOT / "docs" / "scene.schema.json").read_text())


def validator():
    cls = jsonschema.validators.validator_for(SCHEMA)
    cls.check_schema(SCHEMA)
    return cls(SCHEMA)


@pytest.mark.parametrize(
    "path", sorted((ROOT / "examples" / "scenes").glob("*.json")), ids=lambda p: p.name
)
def test_shipped_scenes_are_valid(path):
    validator().validate(json.loads(path.read_text()))


@pytest.mark.parametrize(
    "scene",
    [
        {"shape": {"sphre": {"radius": 1}}},
        {"shape": {"sphere": {"radius": 1, "centre": [0, 0, 0]}}},
        {"shape": {"mesh": {"path": "m.obj", "sign": "both"}}},
        {"shape": {"mesh": {"path": "m.obj", "method": "scanline"}}},
        {"shape": {"sphere": {}}, "shading": {"mode": "sparkly"}},
        {"camera": {"eye": [0, 0, 1]}},
    ],
)
def test_invalid_scenes_are_rejected(scene):
    errors = list(validator().iter_errors(scene))
    assert errors, f"{scene} passed the schema"


def test_every_new_key_is_in_the_schema():
    v = validator()
    v.validate(
        {
            "version": 1,
            "shape": {
                "union": [
                    {"mesh": {"path": "m.obj", "method": "prism_gpu"}},
                    {"octree": {"max_level": 6, "of": {"torus": {}}}},
                    {"volume": {"path": "v.nrrd", "filter": "catmull_rom", "inside": "above"}},
                ]
            },
            "shading": {"mode": "curvature"},
        }
    )


def test_params_colours_and_the_vocabulary_are_in_the_schema():
    v = validator()
    v.validate(
        {
            "params": {"r": 0.3, "n": 6},
            "shape": {
                "difference": [
                    {"extrude": {"height": "$r", "of": {"rectangle": {"half": [1, "$r"]}}}},
                    {"circular_array": {"count": "$n", "axis": [0, 0, 1], "of": {"sphere": {}}}},
                    {"transform": {"scale": [1, 2, 1], "of": {"revolve": {"offset": 1, "of": {"circle": {}}}}}},
                    {"mirror": {"normal": [1, 0, 0], "of": {"polygon": {"points": [[0, 0], [1, 0], [0, 1]]}}}},
                    {"repeat": {"period": [2, 0, 0], "of": {"sphere": {}}}},
                    {"array": {"count": [2, 2, 1], "spacing": [1, 1, 0], "of": {"sphere": {}}}},
                    {"twist": {"rate": 30, "axis": [0, 0, 1], "of": {"box": {}}}, "color": [1, 0, 0]},
                ]
            },
        }
    )
    for bad in [
        {"params": {"r": "$s"}, "shape": {"sphere": {}}},
        {"shape": {"sphere": {"radius": "r"}}},
        {"shape": {"sphere": {"radius": "$1r"}}},
        {"shape": {"sphere": {}, "color": [2, 0, 0]}},
        {"shape": {"extrude": {"height": 1}}},
    ]:
        assert list(v.iter_errors(bad)), f"{bad} passed the schema"
