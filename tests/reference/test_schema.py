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
