"""The parsers of argument values that several commands share: the ``WxH`` resolution parser
(``bnerr bench``, ``render`` and ``animate``; defined in :mod:`benchmarks.resolution`, which
``python -m benchmarks.speed.tracer`` imports as well), the name lists that take both ``--scenes
a b`` and ``--scenes a,b``, and the one table of numeric option types (``type=`` of every numeric
option of every command): :func:`positive_int`, :func:`nonnegative_int`, :func:`seed_int`,
:func:`positive_float` and :func:`finite_float`.
Each refuses, while the arguments are parsed and so before any work, what no run could use: a
count below its minimum, NaN, an infinity, and a value past :data:`MAX_COUNT` (or the range a float
option names), with argparse's one-line error and exit code 2.

Not a command: :mod:`benchmarks.cli` skips the modules whose name starts with ``_``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from benchmarks.resolution import parse_resolution

__all__ = [
    "EXPOSURE",
    "MAX_COUNT",
    "MAX_MINUTES",
    "MAX_SEED",
    "finite_float",
    "names",
    "nonnegative_int",
    "parse_resolution",
    "port_int",
    "positive_float",
    "positive_int",
    "seed_int",
]

#: The largest count (sizes, samples, frames, steps, threads...) any option takes: the largest
#: int32, the index type of torch's kernels. Far below it the memory and size checks of each
#: command refuse what does not fit; past it the number is a typo, refused while parsing.
MAX_COUNT = 2**31 - 1
#: The largest seed: torch's generators take a seed in [0, 2**64), numpy's in [0, 2**32) is
#: derived from it; a signed 64-bit value is what every consumer accepts.
MAX_SEED = 2**63 - 1


def _integer(minimum: int, maximum: int, what: str) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text}")
        if value > maximum:
            raise argparse.ArgumentTypeError(f"expected an integer <= {maximum}, got {text}")
        return value

    parse.__name__ = what.replace(" ", "_")  # argparse names the type in "invalid <name> value"
    return parse


def _float(lo: float, hi: float, *, open_lo: bool) -> Callable[[str], float]:
    bracket = "(" if open_lo else "["

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        inside = (lo < value if open_lo else lo <= value) and value <= hi
        if not math.isfinite(value) or not inside:
            raise argparse.ArgumentTypeError(
                f"expected a finite number in {bracket}{lo:g}, {hi:g}], got {text}"
            )
        return value

    return parse


#: An integer in [1, MAX_COUNT]: sizes, samples, frames, steps, threads.
positive_int = _integer(1, MAX_COUNT, "a positive integer")
#: An integer in [0, MAX_COUNT]: indices and counts where 0 means none or all.
nonnegative_int = _integer(0, MAX_COUNT, "a non-negative integer")
#: A seed (or seed set): an integer in [0, MAX_SEED].
seed_int = _integer(0, MAX_SEED, "a seed")
#: A TCP port: an integer in [0, 65535], 0 for any free one.
port_int = _integer(0, 65535, "a port number")


def positive_float(hi: float) -> Callable[[str], float]:
    """A finite number in ``(0, hi]`` (sigmas, minutes, learning rates, temperatures)."""
    return _float(0.0, hi, open_lo=True)


def finite_float(lo: float, hi: float) -> Callable[[str], float]:
    """A finite number in ``[lo, hi]`` (exposures in stops)."""
    return _float(lo, hi, open_lo=False)


def names(values: list[str] | None) -> list[str] | None:
    """The names of a ``nargs="+"`` option, space- or comma-separated (``a b``, ``a,b``, both);
    None when the option was not given."""
    if values is None:
        return None
    return [v for item in values for v in item.split(",") if v]


#: Exposure in stops of a PNG preview: 2**64 already saturates any radiance to white.
EXPOSURE = finite_float(-64.0, 64.0)
#: A wall-time cap in minutes: a year at most.
MAX_MINUTES = 60.0 * 24 * 366
