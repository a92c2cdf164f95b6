"""What the two program manifests share (:mod:`bnerr.schemas.renderer`,
:mod:`bnerr.schemas.denoiser`): the table's keys checked as :mod:`bnerr.external` words it, the
program's name, its command as an argument list, its time limit and its description.

The placeholders a command may use, and the program's file, are checked where the manifest is
loaded (:mod:`bnerr.external`): they depend on the other keys and on the manifest's folder.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, ClassVar

from bnerr.frame import BUFFERS
from bnerr.schemas.fields import Check, Table, describe, problem

__all__ = [
    "FRAME_BUFFERS",
    "Command",
    "Name",
    "ProgramManifest",
    "Seconds",
    "Text",
    "distinct",
    "expect",
]

#: The buffers a program may read or write: every :class:`~bnerr.frame.Frame` buffer, and the
#: per-pixel variance.
FRAME_BUFFERS: tuple[str, ...] = (*BUFFERS, "variance")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_.-]*")


def expect(what: str, *types: type) -> Check:
    """A value of one of ``types`` (a bool is never a number): ``expected {what}`` otherwise."""

    def check(value: object) -> object:
        if isinstance(value, bool) and bool not in types or not isinstance(value, types):
            raise problem(f"expected {what}, got {describe(value)}")
        return value

    return Check(check)


def _name(value: str) -> str:
    if not _NAME.fullmatch(value):
        raise problem(f"expected a letter then letters, digits, '_', '.' or '-', got {value!r}")
    return value


def _argv(value: list) -> list:
    if not value or not all(isinstance(a, str) and a for a in value):
        raise problem(
            f"expected a non-empty list of non-empty strings (argv, no shell), got {value!r:.80}"
        )
    return value


def _positive(value: float) -> float:
    if not 0 < value < math.inf:
        raise problem(f"expected a number > 0, got {value}")
    return float(value)


#: A string (free text).
Text = Annotated[str, expect("a string", str)]
#: The program's command line: a non-empty list of non-empty strings (argv, never a shell).
Command = Annotated[
    tuple[str, ...], Check(_argv, minItems=1), expect("a list of arguments (argv)", list)
]
#: A time limit in seconds: a finite number above 0.
Seconds = Annotated[
    float, Check(_positive, exclusiveMinimum=0), expect("a number of seconds", int, float)
]


#: The program's name: a letter, then letters, digits, ``_``, ``.`` or ``-``.
Name = Annotated[str, Check(_name, pattern=f"^{_NAME.pattern}$"), expect("a string", str)]


class ProgramManifest(Table):
    """The table of every program manifest: an unknown key, or a required one missing, is
    refused naming them all. Each manifest declares its keys in its own order, with
    :data:`Name`, :data:`Command`, :data:`Seconds` and :data:`Text` for the shared ones."""

    table_expected: ClassVar[str] = "a table of keys"

    @classmethod
    def check_keys(cls, data: dict) -> None:
        unknown = sorted(set(data) - set(cls.model_fields))
        if unknown:
            raise problem(
                f"unknown key(s) {', '.join(unknown)}: expected only {', '.join(cls.model_fields)}"
            )
        missing = [k for k, f in cls.model_fields.items() if f.is_required() and k not in data]
        if missing:
            raise problem(f"expected the key(s) {', '.join(missing)}, got none")


def distinct(known: tuple[str, ...]) -> Check:
    """A non-empty list of distinct names among ``known``."""

    def check(value: list) -> list:
        if not value or any(v not in known for v in value) or len(set(value)) != len(value):
            raise problem(f"expected distinct names among {', '.join(known)}, got {value!r:.80}")
        return value

    return Check(check, minItems=1, uniqueItems=True, items={"enum": list(known)})
