"""Tests for bnerr.schemas.documents: reading refuses what is too large or not a regular file
before parsing, parsing names the line, and the TOML writer's floats read back exactly."""

import tomllib

import pytest

from bnerr.errors import FileFormatError
from bnerr.schemas.documents import dump_toml, format_of, parse, read


def test_read_refuses_large_and_odd_files_unread(tmp_path):
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * 11)
    with pytest.raises(FileFormatError, match="at most 10 bytes, got 11"):
        read(big, FileFormatError, 10)
    with pytest.raises(FileFormatError, match="regular file"):
        read(tmp_path, FileFormatError, 10)
    with pytest.raises(FileFormatError, match="readable file"):
        read(tmp_path / "none.toml", FileFormatError, 10)
    assert read(big, FileFormatError, 11) == b"#" * 11


@pytest.mark.parametrize(
    "text, fmt, limit, message",
    [
        ("a = \n", "toml", None, r"^f: expected TOML, got .*line 1"),
        ('{"a": 1,}', "json", None, r"^f: expected JSON, got .* \(at line 1, column 9\)$"),
        ('{"a": 1, "a": 2}', "json", None, r"key 'a' given twice"),
        (b"a = '\xff'", "toml", None, r"^f: line 1: expected UTF-8 text, got byte 0xff"),
        ("a = 1", "toml", 3, r"^f: expected at most 3 bytes, got 5"),
    ],
)
def test_parse_names_the_line_and_the_problem(text, fmt, limit, message):
    with pytest.raises(FileFormatError, match=message):
        parse(text, fmt, "f", FileFormatError, limit)


def test_format_of_reads_the_suffix(tmp_path):
    assert format_of(tmp_path / "a.TOML", FileFormatError) == "toml"
    assert format_of(tmp_path / "a.json", FileFormatError) == "json"
    with pytest.raises(FileFormatError, match="suffix .toml or .json, got '.xml'"):
        format_of(tmp_path / "a.xml", FileFormatError)


def test_dump_toml_writes_sections_and_round_trip_floats():
    document = {"x": 0.1 + 0.2, "name": "a b", "t": {"k": [1, 2]}, "s": [{"n": 1}, {"n": 2}]}
    assert tomllib.loads(dump_toml(document)) == document
    assert "[t]" in dump_toml(document) and "[[s]]" in dump_toml(document)
