"""Tests for bnerr.schemas.fields: each checked value refuses what the hand-written readers
refused, with the same words, and tells JSON Schema its bounds."""

from typing import Annotated

import pytest
from pydantic import TypeAdapter

from bnerr.errors import SceneFileError
from bnerr.schemas.errors import validate
from bnerr.schemas.fields import (
    Boolean,
    Kinds,
    Table,
    array,
    choice,
    describe,
    integer,
    number,
    string,
)


def _message(annotation, value) -> str:
    with pytest.raises(SceneFileError) as caught:
        validate(TypeAdapter(annotation), value, SceneFileError, "x")
    return str(caught.value)


def test_numbers_are_finite_in_range_and_never_bools():
    unit = Annotated[float, number(0.0, 1.0)]
    assert validate(TypeAdapter(unit), 1, SceneFileError, "x") == 1.0
    assert _message(unit, True) == "x: expected a number, got bool True"
    assert _message(unit, 2) == "x: expected a finite number in [0.0, 1.0], got int 2"
    assert _message(unit, float("nan")).endswith("got float nan")
    assert "a number in [0.0, 1.0]" in _message(unit, 10**400)
    assert TypeAdapter(unit).json_schema() == {"type": "number", "minimum": 0.0, "maximum": 1.0}


def test_integers_booleans_choices_strings_and_arrays():
    assert _message(Annotated[int, integer(1, 3)], 1.0) == "x: expected an integer, got float 1.0"
    assert (
        _message(Annotated[int, integer(1, 3)], 4) == "x: expected an integer in [1, 3], got int 4"
    )
    assert _message(Boolean, 1) == "x: expected true or false, got int 1"
    assert _message(Annotated[str, choice("a", "b")], "c") == "x: expected one of a, b, got str 'c'"
    word = Annotated[str, string("a word", test=str.isalpha)]
    assert _message(word, "a b") == "x: expected a word, got str 'a b'"
    pair = Annotated[tuple[int, int], array(2, "a pair")]
    assert _message(pair, [1]) == "x: expected a pair, got list [1]"
    assert validate(TypeAdapter(pair), [1, 2], SceneFileError, "x") == (1, 2)


def test_describe_cuts_long_values():
    assert describe("a" * 100).endswith("...") and len(describe("a" * 100)) == len("str ") + 60


class _Dot(Table):
    type: str = "dot"
    size: Annotated[float, number(0.0, 9.0)] = 1.0


def test_a_table_refuses_unknown_keys_naming_the_known_ones():
    assert _message(_Dot, {"colour": 1}) == "x: unknown key 'colour', expected one of type, size"
    assert _message(_Dot, [1]) == "x: expected a table, got list [1]"


def test_kinds_name_the_kinds_and_accept_a_plain_value():
    from typing import Literal

    class A(Table):
        type: Literal["a"]
        n: Annotated[int, integer(0, 9)] = 0

    class B(Table):
        type: Literal["b"]

    either = Annotated[A | B | tuple[int], Kinds(A, B, plain=tuple[int])]
    assert validate(TypeAdapter(either), [3], SceneFileError, "x") == (3,)
    assert _message(either, {"type": "c"}) == "type: expected one of a, b, got str 'c'"
    assert _message(either, {}) == "x: expected key 'type' (one of a, b), got none"
    assert (
        _message(either, {"type": "a", "n": 10}) == "n: expected an integer in [0, 9], got int 10"
    )
