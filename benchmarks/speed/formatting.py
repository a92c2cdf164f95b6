"""Formatting the speed suite's figures for ``speed.md``: every table's numbers go through here.

A figure the JSON lacks (a script older than its table, a failed or missing renderer) shows as
:data:`DASH`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = ["DASH", "fmt", "get", "number", "ratio"]

#: What a missing figure shows as.
DASH = "-"


def number(value: Any) -> float | None:
    """``value`` as a finite float, or None (missing, None, a string such as an error)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def fmt(value: Any, digits: int = 3) -> str:
    """A number to ``digits`` significant digits (no exponent below a million), else "-"."""
    x = number(value)
    if x is None:
        return DASH
    if abs(x) < 10**digits:  # rounded first, so that 0.00999... shows as 0.0100
        x = float(f"{x:.{digits - 1}e}")
    if x == 0 or 1e-3 <= abs(x) < 1e6:
        places = max(digits - 1 - math.floor(math.log10(abs(x))), 0) if x else 0
        return f"{x:.{places}f}"
    return f"{x:.{digits - 1}e}"


def ratio(value: Any, anchor: Any) -> str:
    """``value / anchor`` to 3 significant digits with a times sign, or "-" if either is missing."""
    a, b = number(value), number(anchor)
    if a is None or b is None or b == 0:
        return DASH
    return f"{fmt(a / b)}x"


def get(values: Any, *path: str) -> Any:
    """``values[path[0]][path[1]]...``, or None where a level is missing or not a dict."""
    for key in path:
        if not isinstance(values, Mapping):
            return None
        values = values.get(key)
    return values
