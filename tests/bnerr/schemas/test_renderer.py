"""Tests for bnerr.schemas.renderer: the shipped native renderer's manifest passes the model and
the JSON Schema; bad buffers, samplers and dimensions fail both."""

import tomllib
from pathlib import Path

import jsonschema
import pytest

from bnerr.external import ManifestError
from bnerr.schemas import json_schema
from bnerr.schemas.errors import validate
from bnerr.schemas.renderer import SAMPLERS, RendererManifestDocument

ROOT = Path(__file__).resolve().parents[3]
GOOD = {"name": "native", "command": ["./tracer", "{seeds}", "{spp}", "{out}"]}


def _manifests():
    return sorted(p for p in (ROOT / "examples").rglob("*.toml") if "{seeds}" in p.read_text())


def test_the_shipped_renderer_manifests_pass_both():
    for path in _manifests():
        document = tomllib.loads(path.read_text(encoding="utf-8"))
        jsonschema.validate(document, json_schema("renderer"))
        validate(RendererManifestDocument, document, ManifestError, "", source=str(path))


def test_the_defaults():
    m = validate(RendererManifestDocument, GOOD, ManifestError, "")
    assert (m.buffers, m.samplers, m.dimensions, m.timeout_s, m.batch) == (
        ("color",),
        SAMPLERS[:1],
        8,
        300.0,
        False,
    )


@pytest.mark.parametrize(
    "change, words",
    [
        ({"buffers": ["albedo"]}, "buffers: expected 'color' among them"),
        ({"samplers": ["sobol9"]}, "samplers: expected distinct names among owen_sobol, ldbn"),
        ({"samplers": ["ldbn", "ldbn"]}, "samplers: expected distinct names"),
        ({"dimensions": 0}, "expected dimensions >= 1 and timeout_s > 0, got 0 and 300.0"),
        ({"batch": "yes"}, "batch: expected true or false, got str 'yes'"),
    ],
)
def test_bad_values_fail_the_model(change, words):
    document = {**GOOD, **change}
    with pytest.raises(
        ManifestError, match=f"^r.toml: {words.replace('(', '.').replace(')', '.')}"
    ):
        validate(RendererManifestDocument, document, ManifestError, "", source="r.toml")
    if "color" not in words:  # 'color' among the buffers is the loader's alone
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(document, json_schema("renderer"))
