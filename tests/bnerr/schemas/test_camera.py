"""Tests for bnerr.schemas.camera: the shipped camera sidecar passes the model and the JSON
Schema; an optics key (which belongs to the XML scene) fails both."""

import tomllib
from pathlib import Path

import jsonschema
import pytest

from bnerr.errors import SceneFileError
from bnerr.schemas import json_schema
from bnerr.schemas.camera import CameraPath
from bnerr.schemas.errors import validate

ROOT = Path(__file__).resolve().parents[3]
SIDECAR = ROOT / "examples" / "mitsuba_temporal.camera.toml"


def test_the_shipped_sidecar_passes_the_model_and_the_json_schema():
    document = tomllib.loads(SIDECAR.read_text(encoding="utf-8"))
    jsonschema.validate(document, json_schema("camera"))
    path = validate(CameraPath, document, SceneFileError, "camera path")
    assert len(path.up) == 3 and all(isinstance(x, float) for x in path.up)


def test_an_optics_key_fails_both():
    document = {"origin": [0, 0, 1], "target": [0, 0, 0], "fov": 40}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(document, json_schema("camera"))
    with pytest.raises(SceneFileError, match="^camera path: unknown key 'fov', expected one of"):
        validate(CameraPath, document, SceneFileError, "camera path")
