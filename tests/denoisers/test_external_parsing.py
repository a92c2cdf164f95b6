"""Property tests of denoisers.external's manifest parser (issue 41): any bytes, any TOML or JSON
table loads or raises a typed error naming the file; a valid manifest reads back its values."""

from __future__ import annotations

import json
import os

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bnerr.errors import BnerrError
from denoisers.external import MANIFEST_KEYS, load_manifest
from tests._frame_folders import toml_text

_FAST = settings(max_examples=40)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("denoiser")
    program = root / "denoise"
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    return root


def _loads_or_refuses(path) -> None:
    try:
        load_manifest(path)
    except BnerrError as err:
        assert str(path) in str(err), repr(err)


_SCALARS = st.integers() | st.floats() | st.booleans() | st.text(max_size=12)
_COMMAND = st.lists(
    st.sampled_from(["./denoise", "{color}", "{output}", "{sigma}", "{albedo}", "{", "\x00"])
    | st.text(max_size=6),
    max_size=6,
)
_VALUES = st.recursive(
    _SCALARS | _COMMAND,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)
_TABLES = st.dictionaries(st.sampled_from([*MANIFEST_KEYS, "other"]), _VALUES, max_size=8)


@_FAST
@given(data=st.binary(max_size=200), suffix=st.sampled_from([".toml", ".json"]))
def test_any_bytes_load_or_raise_a_typed_error_naming_the_manifest(folder, data, suffix):
    path = folder / f"denoiser{suffix}"
    path.write_bytes(data)
    _loads_or_refuses(path)


@settings(max_examples=30)
@given(table=_TABLES, as_json=st.booleans())
def test_any_table_loads_or_raises_a_typed_error_naming_the_manifest(folder, table, as_json):
    table.setdefault("command", ["./denoise", "{color}", "{output}"])
    path = folder / ("denoiser.json" if as_json else "denoiser.toml")
    path.write_text(json.dumps(table) if as_json else toml_text(table), encoding="utf-8")
    _loads_or_refuses(path)


@_FAST
@given(
    name=st.from_regex(r"[A-Za-z][A-Za-z0-9_.-]{0,8}", fullmatch=True),
    sigma=st.floats(0.01, 100),
    grid=st.lists(st.floats(0.01, 100), min_size=1, max_size=4),
    temporal=st.booleans(),
    timeout=st.floats(0.001, 1e6),
    description=st.text(max_size=20),
)
def test_a_valid_manifest_reads_back_what_it_says(
    folder, name, sigma, grid, temporal, timeout, description
):
    table = dict(
        name=name,
        command=["./denoise", "{color}", "--sigma", "{sigma}", "{output}"],
        params={"sigma": sigma},
        grid={"sigma": grid},
        temporal=temporal,
        timeout_s=timeout,
        description=description,
    )
    path = folder / "valid.toml"
    path.write_text(toml_text(table), encoding="utf-8")
    m = load_manifest(path)
    assert (m.name, m.temporal, m.timeout_s, m.description) == (
        name,
        temporal,
        timeout,
        description,
    )
    assert dict(m.params) == {"sigma": sigma} and m.grid == {"sigma": tuple(grid)}
    assert m.kind == ("temporal" if temporal else "filter") and m.inputs == ("color",)
    assert m.command == (os.path.realpath(folder / "denoise"), *table["command"][1:])


def test_deep_nesting_huge_integers_and_nul_arguments_are_refused(folder):
    for suffix, text in [
        (".json", "[" * 5000),
        (".toml", "params = " + "[" * 5000),
        (".json", '{"timeout_s": ' + "9" * 5000 + "}"),
        (".toml", 'name = "n"\ncommand = ["./denoise", "{color}", "{output}\\u0000"]'),
    ]:
        path = folder / f"bad{suffix}"
        path.write_text(text, encoding="utf-8")
        with pytest.raises(BnerrError, match="bad"):
            load_manifest(path)
