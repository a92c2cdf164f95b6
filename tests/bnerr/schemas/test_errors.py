"""Tests for bnerr.schemas.errors: the one mapping from pydantic's errors to bnerr's one-line
typed errors (the path as the user wrote it, a union's tags dropped, the class a check names)."""

from typing import Annotated

import pytest
from pydantic import TypeAdapter

from bnerr.errors import DtypeError, SceneFileError, UnknownNameError
from bnerr.schemas.errors import validate
from bnerr.schemas.fields import Table, number, problem
from bnerr.schemas.scene import SceneDocument


class _Inner(Table):
    radius: Annotated[float, number(1e-6, 1e6)]


class _Outer(Table):
    shapes: list[_Inner] = []
    plain: int = 0


def test_a_nested_value_is_named_by_its_path():
    with pytest.raises(SceneFileError) as caught:
        validate(_Outer, {"shapes": [{"radius": 1}, {"radius": -0.7}]}, SceneFileError, "doc")
    assert str(caught.value) == (
        "shapes[1].radius: expected a finite number in [1e-06, 1000000.0], got float -0.7"
    )


def test_a_missing_key_names_its_table_and_the_document_its_root():
    with pytest.raises(SceneFileError, match=r"^shapes\[0\]: expected key 'radius', got none$"):
        validate(_Outer, {"shapes": [{}]}, SceneFileError, "doc")
    with pytest.raises(SceneFileError, match=r"^doc: expected a table, got int 3$"):
        validate(_Outer, 3, SceneFileError, "doc")


def test_pydantics_own_messages_keep_the_one_line_form():
    with pytest.raises(SceneFileError, match=r"^plain: input should be a valid integer.*got str"):
        validate(_Outer, {"plain": "x"}, SceneFileError, "doc")


def test_a_check_may_name_another_error_class_and_path():
    def refuse(value):
        raise problem("expected nothing, got something", at="elsewhere", error="UnknownNameError")

    from pydantic import BeforeValidator

    adapter = TypeAdapter(Annotated[int, BeforeValidator(refuse)])
    with pytest.raises(UnknownNameError, match="^elsewhere: expected nothing, got something$"):
        validate(adapter, 1, DtypeError, "doc")


def test_a_union_tag_is_not_part_of_the_path():
    document = {
        "max_depth": 3,
        "camera": {"origin": {"type": "orbit", "radius": -1}, "target": [0, 0, 0], "fov": 40},
        "shapes": [],
    }
    with pytest.raises(SceneFileError, match=r"^camera\.origin\.radius: expected a finite"):
        validate(SceneDocument, document, SceneFileError, "scene")
