"""Tests for ``bnerr schema`` (benchmarks.commands.schema): it prints each format's JSON Schema,
which a stock validator accepts as a schema, and refuses an unknown format."""

import json

import jsonschema
import pytest

from benchmarks.cli import main
from bnerr.schemas import FORMATS


@pytest.mark.parametrize("name", sorted(FORMATS))
def test_prints_the_json_schema_of_each_format(name, capsys):
    assert main(["schema", name]) == 0
    schema = json.loads(capsys.readouterr().out)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["type"] == "object"


def test_the_scene_schema_accepts_a_shipped_scene_and_refuses_an_unknown_key(capsys):
    assert main(["schema", "scene"]) == 0
    schema = json.loads(capsys.readouterr().out)
    scene = {"max_depth": 2, "camera": {"origin": [0, 0, 1], "target": [0, 0, 0], "fov": 40}}
    scene["shapes"] = [{"type": "rectangle", "name": "l", "center": [0, 1, 0], "u": [1, 0, 0],
                        "v": [0, 0, 1], "albedo": [0, 0, 0], "emission": [1, 1, 1]}]  # fmt: skip
    jsonschema.validate(scene, schema)
    with pytest.raises(jsonschema.ValidationError, match="colour"):
        jsonschema.validate({**scene, "colour": 1}, schema)


def test_an_unknown_format_is_a_usage_error(capsys):
    assert main(["schema", "blend"]) == 2
    assert "invalid choice" in capsys.readouterr().err
