"""Tests for bnerr.schemas: every format ``bnerr schema`` names has a valid JSON Schema of the
2020-12 draft, and an unknown name is refused naming the known ones."""

import jsonschema
import pytest

from bnerr.errors import UnknownNameError
from bnerr.schemas import FORMATS, json_schema


@pytest.mark.parametrize("name", sorted(FORMATS))
def test_every_format_has_a_valid_json_schema(name):
    schema = json_schema(name)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$schema"].endswith("2020-12/schema") and schema["type"] == "object"
    assert schema["additionalProperties"] is False


def test_an_unknown_format_is_refused():
    with pytest.raises(UnknownNameError, match="expected one of scene, camera"):
        json_schema("blend")
