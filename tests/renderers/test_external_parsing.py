"""Property tests of renderers.external's parsers (issue 41): the seed file round-trips bit for
bit and refuses any other bytes (a header claiming more seeds than the file holds before
allocating them), and a renderer manifest of any bytes or any TOML table reads or raises a typed
error naming the file."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from bnerr.errors import BnerrError, FileFormatError
from renderers.external import (
    RENDERER_KEYS,
    SEED_HEADER,
    load_renderer_manifest,
    read_seed_file,
    write_seed_file,
)
from tests._frame_folders import toml_text

_FAST = settings(max_examples=40)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("renderer")
    program = root / "tracer"
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    return root


_SEEDS = st.tuples(st.integers(1, 3), st.integers(0, 6), st.integers(0, 6)).flatmap(
    lambda shape: st.lists(
        st.integers(-(2**63), 2**63 - 1), min_size=int(np.prod(shape)), max_size=int(np.prod(shape))
    ).map(lambda v: torch.tensor(v, dtype=torch.int64).view(shape))
)


@_FAST
@given(seeds=_SEEDS)
def test_seeds_round_trip_as_their_low_32_bits_and_the_bytes_bit_for_bit(folder, seeds):
    path = folder / "seeds.bin"
    write_seed_file(path, seeds)
    back = read_seed_file(path)
    assert back.dtype == torch.int64 and torch.equal(back, seeds & 0xFFFFFFFF)
    data = path.read_bytes()
    write_seed_file(folder / "again.bin", back)
    assert (folder / "again.bin").read_bytes() == data
    assert data[SEED_HEADER.size :] == (seeds & 0xFFFFFFFF).numpy().astype("<u4").tobytes()


def _header(width: int, height: int, count: int, magic: bytes = b"BNSD", version: int = 1) -> bytes:
    return SEED_HEADER.pack(magic, version, width, height, count, 1)


@_FAST
@given(
    data=st.binary(max_size=120)
    | st.tuples(
        st.integers(0, 2**32 - 1),
        st.integers(0, 2**32 - 1),
        st.integers(0, 2**32 - 1),
        st.binary(max_size=64),
    ).map(lambda t: _header(*t[:3]) + t[3])
)
def test_any_bytes_read_as_seeds_or_raise_a_typed_error(folder, data):
    path = folder / "any.bin"
    path.write_bytes(data)
    try:
        seeds = read_seed_file(path)
    except FileFormatError as err:
        assert str(path) in str(err), repr(err)
        return
    assert seeds.numel() * 4 + SEED_HEADER.size == len(data)


@pytest.mark.parametrize("cut", [0, 3, 23, 24 + 4 * 6 - 1])
def test_truncated_and_oversized_files_are_refused(folder, cut):
    full = _header(3, 2, 1) + bytes(24)
    (folder / "cut.bin").write_bytes(full[:cut])
    with pytest.raises(FileFormatError, match="expected"):
        read_seed_file(folder / "cut.bin")
    (folder / "long.bin").write_bytes(full + b"\0")
    with pytest.raises(FileFormatError, match="bytes"):
        read_seed_file(folder / "long.bin")


def test_a_header_claiming_a_million_by_a_million_is_refused_before_allocating(folder):
    path = folder / "huge.bin"
    path.write_bytes(_header(10**6, 10**6, 1) + bytes(64))
    with pytest.raises(FileFormatError, match=r"1 x 1000000 x 1000000 seeds, got 88"):
        read_seed_file(path)


# ------------------------------------------------------------------------------------------------
# The manifest

_SCALARS = st.integers() | st.floats() | st.booleans() | st.text(max_size=12)
_COMMAND = st.lists(
    st.sampled_from(["./tracer", "{seeds}", "{out}", "{spp}", "{sampler}", "{", "}", "{x}", "\x00"])
    | st.text(max_size=6),
    max_size=6,
)
_VALUES = st.recursive(_SCALARS | _COMMAND, lambda inner: st.lists(inner, max_size=3), max_leaves=6)
_TABLES = st.dictionaries(st.sampled_from([*RENDERER_KEYS, "other"]), _VALUES, max_size=8)


def _loads_or_refuses(path) -> None:
    try:
        load_renderer_manifest(path)
    except BnerrError as err:
        assert str(path) in str(err) or "--renderer-cmd" in str(err), repr(err)


@_FAST
@given(data=st.binary(max_size=200), suffix=st.sampled_from([".toml", ".json"]))
def test_any_bytes_load_or_raise_a_typed_error_naming_the_manifest(folder, data, suffix):
    path = folder / f"renderer{suffix}"
    path.write_bytes(data)
    _loads_or_refuses(path)


@settings(max_examples=30)
@given(table=_TABLES, as_json=st.booleans())
def test_any_table_loads_or_raises_a_typed_error_naming_the_manifest(folder, table, as_json):
    table.setdefault("command", ["./tracer", "{seeds}", "{out}", "{spp}"])
    path = folder / ("renderer.json" if as_json else "renderer.toml")
    path.write_text(json.dumps(table) if as_json else toml_text(table), encoding="utf-8")
    _loads_or_refuses(path)


@_FAST
@given(
    name=st.from_regex(r"[A-Za-z][A-Za-z0-9_.-]{0,8}", fullmatch=True),
    buffers=st.lists(st.sampled_from(["albedo", "normal", "depth", "variance"]), unique=True),
    dimensions=st.integers(1, 64),
    timeout=st.floats(0.001, 1e6),
    batch=st.booleans(),
    description=st.text(max_size=20),
)
def test_a_valid_manifest_reads_back_what_it_says(
    folder, name, buffers, dimensions, timeout, batch, description
):
    table = dict(
        name=name,
        command=["./tracer", "--seeds", "{seeds}", "{out}", "{spp}", "{{literal}}"],
        buffers=["color", *buffers],
        dimensions=dimensions,
        timeout_s=timeout,
        batch=batch,
        description=description,
    )
    path = folder / "valid.toml"
    path.write_text(toml_text(table), encoding="utf-8")
    m = load_renderer_manifest(path)
    assert (m.name, m.buffers, m.dimensions) == (name, ("color", *buffers), dimensions)
    assert (m.timeout_s, m.batch, m.description) == (timeout, batch, description)
    assert m.command == (os.path.realpath(folder / "tracer"), *table["command"][1:])


def test_deep_nesting_huge_integers_and_nul_arguments_are_refused(folder):
    for suffix, text in [
        (".json", "[" * 5000),
        (".toml", "command = " + "[" * 5000),
        (".json", '{"dimensions": ' + "9" * 5000 + "}"),
        (".toml", 'name = "n"\ncommand = ["./tracer", "{seeds}\\u0000", "{out}", "{spp}"]'),
    ]:
        path = folder / f"bad{suffix}"
        path.write_text(text, encoding="utf-8")
        with pytest.raises(BnerrError, match="bad"):
            load_renderer_manifest(path)
