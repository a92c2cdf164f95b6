"""Tests for bnerr.schemas.eval: the model of a frame folder's manifest.toml. Its JSON Schema
accepts the manifests the tests' frame folders write and refuses an unknown key, a bad buffer and
a missing key, as the model does (with the error classes bnerr eval has always raised)."""

import jsonschema
import pytest

from bnerr.errors import UnknownNameError, ValueRangeError
from bnerr.schemas import json_schema
from bnerr.schemas.errors import validate
from bnerr.schemas.eval import EvalManifest
from tests._frame_folders import SYNTHETIC

#: The tests' synthetic frame folder's manifest with every optional key set.
GOOD = {
    **SYNTHETIC,
    "buffers": ["albedo", "normal", "depth", "object_id"],
    "regions": ["all", "edges", "coherent"],
    "warmup": 1,
}


def _check(document):
    return validate(EvalManifest, document, ValueRangeError, "", source="manifest.toml")


def test_a_good_manifest_passes_the_model_and_the_json_schema():
    jsonschema.validate(GOOD, json_schema("eval"))
    m = _check(GOOD)
    assert m.resolution == (8, 8) and m.methods == ("white", "mine") and m.static is False


@pytest.mark.parametrize(
    "change, error, words",
    [
        ({"colour": 1}, UnknownNameError, "^manifest.toml: unknown keys colour; expected keys"),
        ({"buffers": ["alpha"]}, UnknownNameError, "buffers: expected names from albedo"),
        ({"spp": 0}, ValueRangeError, "^manifest.toml: spp: expected an integer >= 1, got 0$"),
        ({"methods": ["a", "a"]}, ValueRangeError, "methods: expected distinct names"),
    ],
)
def test_a_bad_manifest_fails_the_model_and_the_json_schema(change, error, words):
    document = {**GOOD, **change}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(document, json_schema("eval"))
    with pytest.raises(error, match=words):
        _check(document)


def test_every_missing_key_is_named_at_once():
    document = {k: v for k, v in GOOD.items() if k not in ("spp", "frames")}
    with pytest.raises(ValueRangeError, match="expected the keys spp, frames, got none"):
        _check(document)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(document, json_schema("eval"))


def test_regions_need_their_buffers_and_a_reference_before_the_first_frame():
    with pytest.raises(ValueRangeError, match="region 'edges': expected buffers object_id"):
        _check({**GOOD, "buffers": [], "regions": ["edges"]})
    with pytest.raises(ValueRangeError, match="region 'coherent': expected warmup >= 1"):
        _check({**GOOD, "warmup": 0})
