"""The one ``WxH`` resolution parser: ``bnerr bench``, ``render`` and ``animate`` take it through
:mod:`benchmarks.commands._args` (the commands' table of option types), ``python -m
benchmarks.speed.tracer`` from here, so that no wing imports the commands' private module.
"""

from __future__ import annotations

from bnerr.errors import DtypeError, ValueRangeError

__all__ = ["parse_resolution"]


def parse_resolution(text: str, flag: str = "--res") -> tuple[int, int]:
    """``"320x240"`` -> ``(320, 240)`` (width, height), both >= 1; ``X`` works as well as ``x``.

    Raises:
        DtypeError: not of the form ``WxH`` with integers.
        ValueRangeError: a size < 1.
    """
    w, sep, h = str(text).lower().partition("x")
    try:
        width, height = int(w), int(h)
    except ValueError:
        raise DtypeError(
            f"{flag}: expected WxH with integers (e.g. 320x240), got {text!r}"
        ) from None
    if width < 1 or height < 1:
        raise ValueRangeError(f"{flag}: expected width and height >= 1, got {width}x{height}")
    return width, height
