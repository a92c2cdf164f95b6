"""Tests for bnerr.schemas.scene: every shipped scene file passes both the model and a stock JSON
Schema validator given ``bnerr schema scene``'s output, a bad file fails both, and the model's
choices are renderers.scene's."""

import json
import tomllib
from pathlib import Path

import jsonschema
import pytest

from bnerr.schemas import json_schema
from bnerr.schemas.scene import Camera, SceneDocument
from renderers.scene import FOV_AXES

ROOT = Path(__file__).resolve().parents[3]
SHIPPED = sorted((ROOT / "examples" / "scenes").glob("*.toml"))


@pytest.fixture(scope="module")
def validator():
    schema = json_schema("scene")
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_there_are_shipped_scene_files():
    assert len(SHIPPED) >= 6


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_scene_file_passes_the_json_schema_and_the_model(path, validator):
    document = tomllib.loads(path.read_text(encoding="utf-8"))
    validator.validate(document)
    validator.validate(json.loads(json.dumps(document)))  # the same scene written as JSON
    SceneDocument.model_validate(document)


BAD = {
    "negative radius": (("shapes", 1, "radius"), -0.7),
    "unknown key": (("shapes", 1, "colour"), [1, 1, 1]),
    "string number": (("camera", "fov"), "40"),
    "bool number": (("max_depth",), True),
    "unknown kind": (("shapes", 1, "type"), "cone"),
    "short vector": (("camera", "up"), [0, 1]),
    "color over 1": (("shapes", 0, "albedo"), [2, 0, 0]),
    "bad name": (("name",), "../x"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_scene_file_fails_the_json_schema(case, validator):
    document = tomllib.loads((ROOT / "examples" / "scenes" / "direct.toml").read_text())
    path, value = BAD[case]
    target = document
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    with pytest.raises(jsonschema.ValidationError):
        validator.validate(document)


def test_the_field_of_view_axes_are_the_renderers():
    schema = Camera.model_json_schema()
    assert tuple(schema["properties"]["fov_axis"]["enum"]) == FOV_AXES


def test_a_file_may_name_its_schema_for_an_editor():
    from bnerr.errors import SceneFileError
    from renderers.scene_file import loads_scene

    document = tomllib.loads((ROOT / "examples" / "scenes" / "direct.toml").read_text())
    named = {"$schema": "./scene.schema.json", **document}
    assert loads_scene(json.dumps(named), "json") == loads_scene(json.dumps(document), "json")
    assert "$schema" in json_schema("scene")["properties"]
    with pytest.raises(SceneFileError, match=r"^s\.json: \$schema: expected a string, got int 3$"):
        loads_scene(json.dumps({**document, "$schema": 3}), "json", "s.json")
