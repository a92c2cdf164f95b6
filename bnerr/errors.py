"""Typed errors and the input checks that raise them.

Every public function of bnerr, renderers, denoisers and benchmarks checks its input at the
boundary with these helpers (STYLE.md habit 4) and raises one of these errors, whose message names
what was expected and what came. Private helpers trust their callers.

The error classes also derive from the matching builtin (``ValueError``, ``TypeError``,
``OSError``) so that callers who catch the builtin keep working.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import torch

__all__ = [
    "BnerrError",
    "DtypeError",
    "FileFormatError",
    "NonFiniteError",
    "ShapeError",
    "UnknownNameError",
    "FLOAT_DTYPES",
    "INT_DTYPES",
    "ValueRangeError",
    "check_dtype",
    "check_finite",
    "check_name",
    "check_offset",
    "check_positive_int",
    "check_range",
    "check_shape",
    "check_tensor",
]


#: The floating dtypes bnerr's ops accept (computations run in float32 unless said otherwise).
FLOAT_DTYPES: tuple[torch.dtype, ...] = (torch.float16, torch.bfloat16, torch.float32, torch.float64)
#: The signed integer dtypes bnerr's ops accept where an integer tensor is expected.
INT_DTYPES: tuple[torch.dtype, ...] = (torch.int8, torch.int16, torch.int32, torch.int64)


class BnerrError(Exception):
    """Base class of every error bnerr raises on bad input."""


class ShapeError(BnerrError, ValueError):
    """A tensor has the wrong number of dimensions or the wrong size."""


class DtypeError(BnerrError, TypeError):
    """A tensor (or value) has the wrong type or dtype."""


class ValueRangeError(BnerrError, ValueError):
    """A number lies outside its allowed range (a negative size, a block size of 9, ...)."""


class NonFiniteError(BnerrError, ValueError):
    """A tensor that must be finite holds NaN or infinity."""


class UnknownNameError(BnerrError, ValueError):
    """A name (scene, sampler, denoiser, strategy, suite) is not registered."""


class FileFormatError(BnerrError, OSError):
    """A file is missing, unreadable, corrupt or not in the expected format."""


def check_tensor(x: object, name: str) -> torch.Tensor:
    """Raise :class:`DtypeError` unless ``x`` is a ``torch.Tensor``; return it."""
    if not isinstance(x, torch.Tensor):
        raise DtypeError(f"{name}: expected a torch.Tensor, got {type(x).__name__}")
    return x


def check_shape(x: torch.Tensor, spec: str, name: str) -> dict[str, int]:
    """Check ``x`` against a shape spec such as ``"H W"``, ``"C H W"`` or ``"3 H W"``.

    Letters bind sizes (the same letter must have the same size everywhere in the spec), digits
    require that exact size, ``*`` accepts any size. Returns the bound sizes, e.g.
    ``{"H": 64, "W": 32}``.
    """
    check_tensor(x, name)
    dims = spec.split()
    if x.ndim != len(dims):
        raise ShapeError(
            f"{name}: expected {len(dims)} dimensions [{', '.join(dims)}], "
            f"got {x.ndim} with shape {list(x.shape)}"
        )
    bound: dict[str, int] = {}
    for axis, (want, got) in enumerate(zip(dims, x.shape)):
        if want == "*":
            continue
        if want.isdigit():
            if int(want) != got:
                raise ShapeError(
                    f"{name}: expected shape [{', '.join(dims)}] with size {want} on axis {axis}, "
                    f"got shape {list(x.shape)}"
                )
        elif bound.setdefault(want, got) != got:
            raise ShapeError(
                f"{name}: expected shape [{', '.join(dims)}] ({want} equal on every axis), "
                f"got shape {list(x.shape)}"
            )
    return bound


def check_dtype(x: torch.Tensor, dtypes: torch.dtype | Iterable[torch.dtype], name: str) -> None:
    """Raise :class:`DtypeError` unless ``x.dtype`` is one of ``dtypes``."""
    check_tensor(x, name)
    allowed = (dtypes,) if isinstance(dtypes, torch.dtype) else tuple(dtypes)
    if x.dtype not in allowed:
        want = " or ".join(str(d).removeprefix("torch.") for d in allowed)
        raise DtypeError(f"{name}: expected dtype {want}, got {str(x.dtype).removeprefix('torch.')}")


def check_finite(x: torch.Tensor, name: str) -> None:
    """Raise :class:`NonFiniteError` if ``x`` holds NaN or infinity, saying how many."""
    bad = ~torch.isfinite(x)
    if bool(bad.any()):
        n_nan = int(torch.isnan(x).sum())
        n_inf = int(bad.sum()) - n_nan
        raise NonFiniteError(
            f"{name}: expected finite values, got {n_nan} NaN and {n_inf} infinite "
            f"of {x.numel()}"
        )


def check_positive_int(value: object, name: str, *, minimum: int = 1) -> int:
    """Return ``value`` as an int if it is an integer >= ``minimum``; raise otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise DtypeError(f"{name}: expected an integer, got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ValueRangeError(f"{name}: expected an integer >= {minimum}, got {value}")
    return value


def check_range(value: object, name: str, lo: float, hi: float) -> float:
    """Return ``value`` if ``lo <= value <= hi``; raise :class:`ValueRangeError` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DtypeError(f"{name}: expected a number, got {type(value).__name__} {value!r}")
    if not lo <= value <= hi:
        raise ValueRangeError(f"{name}: expected a value in [{lo}, {hi}], got {value}")
    return value


def check_name(name: object, known: Sequence[str], what: str) -> str:
    """Return ``name`` if it is one of ``known``; raise :class:`UnknownNameError` listing them."""
    if not isinstance(name, str) or name not in known:
        raise UnknownNameError(f"unknown {what} {name!r}: expected one of {', '.join(sorted(known))}")
    return name


def check_offset(offset: object, name: str = "offset") -> tuple[int, int]:
    """A pair of Python integers ``(oy, ox)`` (a tuple or list; bools are refused)."""
    if (
        not isinstance(offset, (tuple, list))
        or len(offset) != 2
        or any(isinstance(o, bool) or not isinstance(o, int) for o in offset)
    ):
        raise DtypeError(f"{name}: expected a pair of integers (oy, ox), got {offset!r}")
    return offset[0], offset[1]
