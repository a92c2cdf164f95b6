"""Tests for bnerr.schemas.denoiser: the shipped executable denoiser's manifest passes the model
and the JSON Schema; inputs, parameters and the grid are checked as denoisers.external always
checked them, and coerce turns a grid or call value into its parameter's type."""

import tomllib
from pathlib import Path

import jsonschema
import pytest

from bnerr.errors import DtypeError
from bnerr.external import ManifestError
from bnerr.schemas import json_schema
from bnerr.schemas.denoiser import DenoiserManifestDocument, coerce
from bnerr.schemas.errors import validate

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "external_denoiser" / "manifest.toml"
GOOD = {"name": "d", "command": ["./p", "{color}", "{output}"]}


def _check(document):
    return validate(DenoiserManifestDocument, document, ManifestError, "", source="d.toml")


def test_the_shipped_manifest_passes_both():
    document = tomllib.loads(EXAMPLE.read_text(encoding="utf-8"))
    jsonschema.validate(document, json_schema("denoiser"))
    m = _check(document)
    assert m.params and all(key in m.params for key in m.grid)


@pytest.mark.parametrize(
    "change, words",
    [
        ({"inputs": ["color", "alpha"]}, "inputs: expected buffer names among color"),
        ({"inputs": ["albedo"]}, "inputs: expected 'color' and no name twice, got albedo"),
        ({"params": {"color": 1}}, "params: expected identifiers other than python"),
        ({"params": {"s": [1]}}, "params.s: expected an int, a float or a string, got list"),
        ({"grid": {"s": [1]}}, "grid.s: expected a parameter of [params] (none declared)"),
        ({"params": {"s": 1}, "grid": {"s": [2.5]}}, "grid.s: expected int like its default"),
        ({"params": {"s": 1}, "grid": {"s": []}}, "grid.s: expected a non-empty list, got list"),
        ({"kind": "a b"}, "kind: expected a word such as filter or learned, got 'a b'"),
    ],
)
def test_bad_values_are_refused_naming_the_key(change, words):
    with pytest.raises(ManifestError) as caught:
        _check({**GOOD, **change})
    assert str(caught.value).startswith(f"d.toml: {words}")


def test_coerce_takes_an_int_for_a_float_and_nothing_else():
    assert coerce(2, 1.0, "s") == 2.0 and isinstance(coerce(2, 1.0, "s"), float)
    with pytest.raises(DtypeError, match="^s: expected int like its default, got 2.5$"):
        coerce(2.5, 1, "s")
    with pytest.raises(DtypeError, match="expected float like its default, got True"):
        coerce(True, 1.0, "s")
