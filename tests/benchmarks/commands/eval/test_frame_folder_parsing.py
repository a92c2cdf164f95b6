"""Property tests of benchmarks.commands.eval.frame_folder's parsers (issue 41): whatever bytes or
TOML a ``manifest.toml`` holds, whatever names a layout path is asked for and whatever bytes a frame
file holds, the folder either reads or refuses with one of the project's typed errors and a message
naming the file; a valid manifest reads back the values it was written with."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.commands.eval.frame_folder import (
    AUX_BUFFERS,
    MANIFEST,
    MANIFEST_KEYS,
    MAX_PIXELS,
    FrameFolder,
    Manifest,
    load_manifest,
)
from bnerr.errors import BnerrError
from tests._frame_folders import toml_text

_FAST = settings(max_examples=40)

# Values of every TOML kind, nested a little: what a hand-edited manifest may hold.
_SCALARS = (
    st.integers(-(2**63), 2**63 - 1)
    | st.floats()
    | st.booleans()
    | st.text(max_size=12)
    | st.sampled_from(["white", "0", "..", "/abs", ".hidden", "reference", "a/b", " x"])
)
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)
_KEYS = st.sampled_from([*MANIFEST_KEYS, "unknown", ""])
_NAME = st.text(
    st.characters(categories=("L", "N")) | st.sampled_from("_- ."), min_size=1, max_size=8
).filter(lambda s: s == s.strip() and not s.startswith("."))


def _refused_or_read(folder) -> Manifest | None:
    try:
        return load_manifest(folder)
    except BnerrError as err:
        assert str(err).strip() and MANIFEST in str(err), repr(err)
        return None


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("manifest")


@_FAST
@given(data=st.binary(max_size=300))
def test_any_bytes_read_or_raise_a_typed_error_naming_the_manifest(folder, data):
    (folder / MANIFEST).write_bytes(data)
    _refused_or_read(folder)


@settings(max_examples=25)
@given(table=st.dictionaries(_KEYS, _VALUES, max_size=8))
def test_any_toml_table_reads_or_raises_a_typed_error_naming_the_manifest(folder, table):
    (folder / MANIFEST).write_text(toml_text(table), encoding="utf-8")
    _refused_or_read(folder)


_VALID = st.fixed_dictionaries(
    {
        "scene": st.text(min_size=1, max_size=10),
        "spp": st.integers(1, 4096),
        "resolution": st.tuples(st.integers(1, 8192), st.integers(1, 8192))
        .filter(lambda r: r[0] * r[1] <= MAX_PIXELS)
        .map(list),
        "methods": st.lists(
            _NAME.filter(lambda n: n not in ("white", "reference", "results")),
            max_size=3,
            unique=True,
        ).map(lambda m: ["white", *m]),
        "seed_sets": st.lists(_NAME, min_size=1, max_size=4, unique=True),
        "frames": st.integers(1, 100),
    },
    optional={
        "warmup": st.integers(0, 10),
        "buffers": st.lists(st.sampled_from(list(AUX_BUFFERS)), unique=True),
        "static": st.booleans(),
        "reference_spp": st.integers(0, 1 << 20),
        "sampler": st.text(min_size=1, max_size=10),
        "dimensions": st.integers(0, 64),
        "tuning_seed_set": _NAME,
    },
).filter(lambda m: m.get("tuning_seed_set") not in m["seed_sets"])


@_FAST
@given(table=_VALID)
def test_a_valid_manifest_reads_back_what_it_says(folder, table):
    (folder / MANIFEST).write_text(toml_text(table), encoding="utf-8")
    m = load_manifest(folder)
    assert (m.width, m.height) == tuple(table["resolution"])
    assert m.methods == tuple(table["methods"]) and m.seed_sets == tuple(table["seed_sets"])
    for key in ("scene", "spp", "frames", "warmup", "static", "reference_spp", "sampler"):
        if key in table:
            assert getattr(m, key) == table[key], key
    assert m.buffers == tuple(table.get("buffers", ()))
    assert m.tuning_seed_set == table.get("tuning_seed_set")
    assert m.regions[0] == "all"


def test_deep_nesting_and_huge_integers_are_refused_as_typed_errors(folder):
    for text in ("frames = " + "[" * 5000, "frames = " + "9" * 5000, "scene = '\\u0000'"):
        (folder / MANIFEST).write_text(text, encoding="utf-8")
        with pytest.raises(BnerrError, match=MANIFEST):
            load_manifest(folder)


@pytest.fixture(scope="module")
def valid_folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("layout")
    table = {"scene": "s", "spp": 1, "resolution": [4, 4], "methods": ["white"], "seed_sets": ["0"]}
    (root / MANIFEST).write_text(toml_text({**table, "frames": 1}), encoding="utf-8")
    (root / "white" / "0").mkdir(parents=True)
    return FrameFolder(root)


_PART = st.text(max_size=6) | st.sampled_from(["..", ".", "/", "/etc", "a/../..", "\x00", "white"])


@_FAST
@given(parts=st.lists(_PART, min_size=1, max_size=3))
def test_a_layout_path_stays_inside_the_folder_or_is_refused(valid_folder, parts):
    try:
        path = valid_folder.path(*parts)
    except BnerrError as err:
        assert str(err).strip()
        return
    root = valid_folder.root.resolve()
    assert path.resolve().is_relative_to(root) and path.resolve() != root


_EXR = b"\x76\x2f\x31\x01\x02\x00\x00\x00"


@_FAST
@given(data=st.binary(max_size=200), magic=st.booleans())
def test_any_frame_file_bytes_are_checked_or_refused_before_reading(valid_folder, data, magic):
    path = valid_folder.frame_path("white", "0", 0)
    path.write_bytes((_EXR if magic else b"") + data)
    try:
        valid_folder.check_file(path)
    except BnerrError as err:
        assert str(path) in str(err), repr(err)


def test_a_header_claiming_a_huge_attribute_is_refused_before_reading_it(valid_folder):
    path = valid_folder.frame_path("white", "0", 0)
    attribute = b"dataWindow\x00box2i\x00" + (2**31 - 1).to_bytes(4, "little")
    path.write_bytes(_EXR + attribute + bytes(16))
    with pytest.raises(BnerrError, match="dataWindow"):
        valid_folder.check_file(path)


def test_names_with_control_characters_are_refused(folder):
    for bad in ("a\x00", "a\nb", "\x7f"):
        table = {
            "scene": "s",
            "spp": 1,
            "resolution": [4, 4],
            "methods": ["white"],
            "seed_sets": [bad],
            "frames": 1,
        }
        (folder / MANIFEST).write_text(toml_text(table), encoding="utf-8")
        with pytest.raises(BnerrError, match="control characters"):
            load_manifest(folder)
        # issue 54: this was `assert string.printable`, always true; each name holds a character
        # that is not printable, which is what the refusal is about
        assert not bad.isprintable()
