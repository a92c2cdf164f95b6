"""The model of an executable denoiser's manifest (:mod:`denoisers.external`; its docstring is
the user's reference).

Besides the keys of every program manifest (:mod:`bnerr.schemas.manifest`), it lists the
buffers written for the program (``color`` among them), its parameters with their defaults
(an int, a float or a string each), an optional tuning grid over them (each value of the
parameter's type; an int is taken for a float), whether it is temporal, and its kind.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, Field, model_validator

from bnerr.errors import DtypeError
from bnerr.schemas.fields import Boolean, Check, describe, problem
from bnerr.schemas.manifest import (
    FRAME_BUFFERS,
    Command,
    Name,
    ProgramManifest,
    Seconds,
    Text,
    expect,
)

__all__ = ["FIXED_PLACEHOLDERS", "DenoiserManifestDocument"]

#: The placeholders every command may use besides the buffers and the parameters.
FIXED_PLACEHOLDERS = ("python", "output", "frame")
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_RESERVED = (*FIXED_PLACEHOLDERS, "previous_output", *FRAME_BUFFERS)
Value = int | float | str


def _inputs(inputs: list) -> list:
    for item in inputs:
        if not isinstance(item, str) or item not in FRAME_BUFFERS:
            raise problem(f"expected buffer names among {', '.join(FRAME_BUFFERS)}, got {item!r}")
    if "color" not in inputs or len(set(inputs)) != len(inputs):
        raise problem(f"expected 'color' and no name twice, got {', '.join(inputs) or '[]'}")
    return inputs


def _params(params: dict) -> dict:
    for key, value in params.items():
        if not _IDENTIFIER.fullmatch(key) or key in _RESERVED:
            raise problem(f"expected identifiers other than {', '.join(_RESERVED)}, got {key!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise problem(
                f"expected an int, a float or a string, got {describe(value)}", at=f"params.{key}"
            )
    return params


def _grid(grid: dict) -> dict:
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise problem(f"expected a non-empty list, got {describe(values)}", at=f"grid.{key}")
    return grid


def _kind(kind: str) -> str:
    if not _IDENTIFIER.fullmatch(kind):
        raise problem(f"expected a word such as filter or learned, got {kind!r}")
    return kind


def _mismatch(value: object, default: Value) -> str:
    """What is wrong with ``value`` as a value of ``default``'s parameter ("" if nothing)."""
    kind = type(default)
    allowed = (int, float) if kind is float else (kind,)
    if isinstance(value, bool) or not isinstance(value, allowed):
        return f"expected {kind.__name__} like its default, got {value!r:.60}"
    return ""


def coerce(value: object, default: Value, what: str) -> Value:
    """``value`` with the type of ``default`` (an int is taken for a float).

    Raises:
        DtypeError: ``{what}: expected float like its default, got ...``.
    """
    wrong = _mismatch(value, default)
    if wrong:
        raise DtypeError(f"{what}: {wrong}")
    return type(default)(value)  # type: ignore[call-overload, arg-type]


class DenoiserManifestDocument(ProgramManifest):
    """An executable denoiser's manifest (:mod:`denoisers.external`)."""

    whole_file: ClassVar[bool] = True

    name: Name = Field(description="the registry name: a letter, then [A-Za-z0-9_.-]")
    command: Command = Field(description="argv with {placeholders}, run in the manifest's folder")

    inputs: Annotated[
        tuple[str, ...], Check(_inputs, minItems=1), expect("a list of buffer names", list)
    ] = Field(("color",), description="the buffers written for the program, color among them")
    params: Annotated[
        dict[str, Value], Check(_params), expect("a table of name = default", dict)
    ] = Field({}, description="parameter name -> default (an int, a float or a string)")
    grid: Annotated[
        dict[str, tuple[Any, ...]], Check(_grid), expect("a table of name = [values]", dict)
    ] = Field({}, description="a tuning grid: parameter name -> candidate values")
    temporal: Boolean = Field(False, description="frames fed in order, the previous output passed")
    timeout_s: Seconds = Field(300.0, description="seconds per frame; the program is then killed")
    kind: Annotated[str, AfterValidator(_kind), expect("a string", str)] = Field(  # type: ignore[assignment]
        None, description="default filter, or temporal when temporal"
    )
    description: Text = Field("", description="free text")

    @model_validator(mode="after")
    def _grid_of_params(self) -> DenoiserManifestDocument:
        """Each grid key a parameter, each of its values of that parameter's type."""
        for key, values in self.grid.items():
            if key not in self.params:
                declared = ", ".join(self.params) or "none declared"
                raise problem(
                    f"expected a parameter of [params] ({declared}), got {key!r}", at=f"grid.{key}"
                )
            for value in values:
                wrong = _mismatch(value, self.params[key])
                if wrong:
                    raise problem(wrong, at=f"grid.{key}")
        return self
