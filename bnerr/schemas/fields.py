"""The building blocks of every format's model: the table base class and the checked values.

Every model of :mod:`bnerr.schemas` derives from :class:`Table` (a TOML table or JSON object
whose keys are all known; an unknown key is refused naming the known ones) and types its values
with the annotated types below. Each check raises :func:`problem`'s error, whose message is
bnerr's "expected X, got Y" and whose type names the :mod:`bnerr.errors` class to raise;
:func:`bnerr.schemas.errors.validate` puts the key's path in front. The JSON Schema of each type
says the same bounds, so that an editor refuses what the loader refuses, as far as a schema can.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Annotated, Any, ClassVar, Union, get_args

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    GetCoreSchemaHandler,
    GetJsonSchemaHandler,
    Tag,
    model_validator,
)
from pydantic_core import PydanticCustomError, core_schema

__all__ = [
    "NAME_PATTERN",
    "Boolean",
    "Check",
    "Kinds",
    "Table",
    "array",
    "choice",
    "describe",
    "expected",
    "integer",
    "number",
    "problem",
    "string",
]

#: A name in a scene file: 1 to 64 letters, digits, ``_`` or ``-`` (not first).
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


def describe(value: object) -> str:
    """``value`` for a message: its type and its repr, cut at 60 characters."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def problem(
    message: str, at: str | None = None, key: str | None = None, error: str = ""
) -> PydanticCustomError:
    """The validation error of one value: ``message`` (``"expected X, got Y"``); the path ``at``
    when it is not the value's own (a check of a whole table naming another key), or ``key``,
    one of the value's keys; and the name of the :mod:`bnerr.errors` class to raise (default:
    the format's)."""
    context = {"message": message, "at": at, "key": key}
    return PydanticCustomError(error or "bnerr", "{message}", context)


def expected(what: str, value: object, error: str = "") -> PydanticCustomError:
    """:func:`problem` of the usual form: ``expected {what}, got {describe(value)}``."""
    return problem(f"expected {what}, got {describe(value)}", error=error)


class Table(BaseModel):
    """A table whose keys are all known (the fields' names); anything else is refused with the
    list of the known keys (:meth:`check_keys`, which a format may word its own way).
    ``table_expected`` is how a message names a value that is not a table."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    table_expected: ClassVar[str] = "a table"
    #: A whole file's table: it may name its JSON Schema in a key ``$schema`` (a string, for
    #: an editor; the loader ignores it).
    whole_file: ClassVar[bool] = False

    @classmethod
    def check_keys(cls, data: dict) -> None:
        """Refuse the first key of ``data`` that is not a field."""
        unknown = [k for k in data if k not in cls.model_fields]
        if unknown:
            known = ", ".join(cls.model_fields)
            raise problem(f"unknown key {unknown[0]!r}, expected one of {known}")

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            raise expected(cls.table_expected, data)
        if cls.whole_file and "$schema" in data:
            if not isinstance(data["$schema"], str):
                raise problem(f"expected a string, got {describe(data['$schema'])}", key="$schema")
            data = {k: v for k, v in data.items() if k != "$schema"}
        cls.check_keys(data)
        return data

    @classmethod
    def __get_pydantic_json_schema__(
        cls, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler
    ) -> dict[str, Any]:
        out = handler(schema)
        if cls.whole_file:
            out = handler.resolve_ref_schema(out)
            described = {"type": "string", "description": "the JSON Schema of this file"}
            out["properties"] = {"$schema": described, **out.get("properties", {})}
        return out


class Check:
    """Annotation metadata: ``check`` runs on the raw value before the annotated type's own
    validation (returning it, converted) and ``schema`` adds to the type's JSON Schema."""

    def __init__(self, check: Callable[[Any], Any], **schema: Any) -> None:
        self.check, self.schema = check, schema

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        return core_schema.no_info_before_validator_function(self.check, handler(source))

    def __get_pydantic_json_schema__(
        self, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler
    ) -> dict[str, Any]:
        return {**handler(schema), **self.schema}


def number(lo: float, hi: float) -> Check:
    """A finite int or float in ``[lo, hi]``, as a float (a bool is not a number)."""

    def check(value: object) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise expected("a number", value)
        try:
            x = float(value)
        except OverflowError:  # an int of 400 digits
            raise expected(f"a number in [{lo}, {hi}]", value) from None
        if not math.isfinite(x) or not lo <= x <= hi:
            raise expected(f"a finite number in [{lo}, {hi}]", value)
        return x

    return Check(check, minimum=lo, maximum=hi)


def integer(lo: int, hi: int) -> Check:
    """An int in ``[lo, hi]`` (a bool or a float is not one)."""

    def check(value: object) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise expected("an integer", value)
        if not lo <= value <= hi:
            raise expected(f"an integer in [{lo}, {hi}]", value)
        return value

    return Check(check, minimum=lo, maximum=hi)


def array(n: int, what: str) -> Check:
    """An array of ``n`` values (a tuple of them once checked); ``what`` names it."""

    def check(value: object) -> object:
        if not isinstance(value, list) or len(value) != n:
            raise expected(what, value)
        return value

    return Check(check)


def _boolean(value: object) -> bool:
    if not isinstance(value, bool):
        raise expected("true or false", value)
    return value


#: ``true`` or ``false`` (no 0, 1 or string).
Boolean = Annotated[bool, Check(_boolean)]


def choice(*names: str) -> Check:
    """One of the strings ``names``."""

    def check(value: object) -> str:
        if not isinstance(value, str) or value not in names:
            raise expected(f"one of {', '.join(names)}", value)
        return value

    return Check(check, enum=list(names))


def string(
    what: str, pattern: re.Pattern[str] | None = None, test: Callable[[str], bool] | None = None
) -> Check:
    """A str matching ``pattern`` in full and passing ``test``; ``what`` names it in a message."""

    def check(value: object) -> str:
        if not isinstance(value, str) or (pattern and not pattern.fullmatch(value)):
            raise expected(what, value)
        if test is not None and not test(value):
            raise expected(what, value)
        return value

    return Check(check, **({"pattern": f"^{pattern.pattern}$"} if pattern else {}))


class Kinds:
    """Annotation metadata: a table of one of several kinds ``models``, told apart by its key
    ``type`` (each model's ``type`` field is a ``Literal`` of its kind's name); or, where
    ``plain`` is given, a value of that type written without a table (a bare ``[x, y, z]``)."""

    def __init__(self, *models: type[Table], plain: Any = None) -> None:
        self.names = [get_args(m.model_fields["type"].annotation)[0] for m in models]
        branches = [Annotated[m, Tag(n)] for m, n in zip(models, self.names)]
        if plain is not None:
            branches.append(Annotated[plain, Tag("")])
        self.union = Annotated[Union[tuple(branches)], Discriminator(self._tag)]  # noqa: UP007
        self.plain = plain is not None

    @staticmethod
    def _tag(value: object) -> str:
        return value["type"] if isinstance(value, dict) else ""

    def _check(self, value: object) -> object:
        if self.plain and isinstance(value, list):
            return value
        if not isinstance(value, dict):
            raise expected("a table", value)
        names = ", ".join(self.names)
        if "type" not in value:
            raise problem(f"expected key 'type' (one of {names}), got none")
        if not isinstance(value["type"], str) or value["type"] not in self.names:
            raise problem(f"expected one of {names}, got {describe(value['type'])}", key="type")
        return value

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        inner = handler.generate_schema(self.union)
        return core_schema.no_info_before_validator_function(self._check, inner)
