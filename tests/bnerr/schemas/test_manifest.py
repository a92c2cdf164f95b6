"""Tests for bnerr.schemas.manifest: the keys and values every program manifest shares, worded
as bnerr.external always worded them."""

import pytest

from bnerr.external import ManifestError
from bnerr.schemas.errors import validate
from bnerr.schemas.manifest import Command, Name, ProgramManifest, Seconds, Text


class _Manifest(ProgramManifest):
    name: Name
    command: Command
    timeout_s: Seconds = 300.0
    description: Text = ""


def _message(document) -> str:
    with pytest.raises(ManifestError) as caught:
        validate(_Manifest, document, ManifestError, "", source="m.toml")
    return str(caught.value)


GOOD = {"name": "a", "command": ["x"]}
CASES = [
    ({"name": "a"}, "expected the key(s) command, got none"),
    ({**GOOD, "b": 1, "a": 2},
     "unknown key(s) a, b: expected only name, command, timeout_s, description"),
    ({**GOOD, "name": 3}, "name: expected a string, got int 3"),
    ({**GOOD, "name": "../x"},
     "name: expected a letter then letters, digits, '_', '.' or '-', got '../x'"),
    ({**GOOD, "command": "x y"}, "command: expected a list of arguments (argv), got str 'x y'"),
    ({**GOOD, "command": ["x", ""]},
     "command: expected a non-empty list of non-empty strings (argv, no shell), got ['x', '']"),
    ({**GOOD, "timeout_s": True}, "timeout_s: expected a number of seconds, got bool True"),
    ({**GOOD, "timeout_s": 0}, "timeout_s: expected a number > 0, got 0"),
    ({**GOOD, "description": 1}, "description: expected a string, got int 1"),
    ([1, 2], "expected a table of keys, got list [1, 2]"),
]  # fmt: skip


@pytest.mark.parametrize("document, message", CASES)
def test_each_shared_key_is_checked_with_bnerrs_words(document, message):
    assert _message(document) == f"m.toml: {message}"


def test_a_good_manifest_keeps_its_values_typed():
    m = validate(
        _Manifest, {"name": "a.b-c", "command": ["x", "{y}"], "timeout_s": 2}, ManifestError, ""
    )
    assert (m.command, m.timeout_s, m.description) == (("x", "{y}"), 2.0, "")
