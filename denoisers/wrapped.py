"""A plain function or ``torch.nn.Module`` as a :class:`~denoisers.base.Denoiser`: the adapter of
the denoiser plug-ins that are not ``Denoiser`` subclasses (:mod:`bnerr.plugins`).

``as_denoiser(fn, name=..., kind=..., grid=...)`` returns a ``Denoiser`` subclass whose
:meth:`~denoisers.base.Denoiser.denoise` calls ``fn(frame, **params)`` (a module under
``torch.no_grad()`` and in eval mode) and returns its ``[3, H, W]`` image as float32. ``name``,
``kind`` and ``grid`` default to the attributes of the same names on ``fn``; ``grid`` (parameter
name -> the values tuning tries) also declares the keyword parameters the denoiser takes, each
defaulting to its first value. ``stateful`` and ``requires`` (the auxiliary buffers it reads)
come from ``fn``'s attributes too. The base class checks the frame before and the output after,
as for every shipped denoiser.

Not for: denoisers run as a separate executable (``denoisers.external``).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import torch

from bnerr.errors import DtypeError, ValueRangeError
from bnerr.frame import Frame
from denoisers.base import Denoiser

__all__ = ["as_denoiser"]


def _declared(fn: object, key: str, given: object, default: object) -> Any:
    return given if given is not None else getattr(fn, key, default)


def _signature(grid: Mapping[str, Sequence[object]]) -> inspect.Signature:
    self = inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)
    keywords = [
        inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=values[0])
        for key, values in grid.items()
    ]
    return inspect.Signature([self, *keywords])


def as_denoiser(
    fn: Callable[..., torch.Tensor],
    *,
    name: str | None = None,
    kind: str | None = None,
    grid: Mapping[str, Sequence[object]] | None = None,
) -> type[Denoiser]:
    """A :class:`Denoiser` subclass calling ``fn(frame, **params) -> [3, H, W]``.

    Args:
        fn: a function of a :class:`~bnerr.frame.Frame`, or a ``torch.nn.Module`` taking one.
        name: the registry name (default ``fn.name``, else ``fn.__name__``).
        kind: ``"filter"``, ``"temporal"``, ``"learned"``, ``"reference"`` or a new one (default
            ``fn.kind``, else ``"learned"`` for a module and ``"filter"`` for a function).
        grid: its tuning grid, parameter -> values (default ``fn.grid``, else none).

    Raises:
        DtypeError: ``fn`` is not callable, or ``name`` is not a non-empty string.
        ValueRangeError: a grid entry with no values.
    """
    if not callable(fn) or isinstance(fn, type):
        raise DtypeError(f"as_denoiser: expected a function or module instance, got {fn!r}")
    module = isinstance(fn, torch.nn.Module)
    label = _declared(fn, "name", name, getattr(fn, "__name__", type(fn).__name__.lower()))
    if not isinstance(label, str) or not label:
        raise DtypeError(f"as_denoiser: name: expected a non-empty str, got {label!r}")
    table = _grid_table(fn, grid, label)
    attributes = {
        "name": label,
        "kind": _declared(fn, "kind", kind, "learned" if module else "filter"),
        "grid": table,
        "stateful": bool(getattr(fn, "stateful", False)),
        "requires": frozenset(getattr(fn, "requires", ())),
        "plugin_source": fn,
        **_methods(fn, label, table),
        "__doc__": inspect.getdoc(fn) or f"The denoiser {label!r} (a wrapped callable).",
    }
    return type(f"Wrapped_{label}", (Denoiser,), attributes)


def _grid_table(
    fn: object, grid: Mapping[str, Sequence[object]] | None, label: str
) -> dict[str, Sequence[object]]:
    """The tuning grid ``grid`` (else ``fn.grid``, else none) as a dict, every entry with values."""
    table = dict(_declared(fn, "grid", grid, {}))
    empty = [key for key, values in table.items() if not values]
    if empty:
        raise ValueRangeError(
            f"as_denoiser {label!r}: grid: expected values for every parameter, got none for "
            f"{', '.join(empty)}"
        )
    return table


def _methods(
    fn: Callable[..., torch.Tensor], label: str, table: Mapping[str, Sequence[object]]
) -> dict[str, Callable[..., Any]]:
    """``__init__`` (the grid's keywords, each defaulting to its first value), ``denoise`` (``fn``
    under ``torch.no_grad()``, a module in eval mode, its output checked and made float32) and
    ``params`` of the wrapped class."""
    module = isinstance(fn, torch.nn.Module)

    def __init__(self: Any, **params: object) -> None:
        self._params = {key: params.get(key, values[0]) for key, values in table.items()}

    __init__.__signature__ = _signature(table)  # type: ignore[attr-defined]

    def denoise(self: Any, frame: Frame) -> torch.Tensor:
        if module:
            fn.eval()  # type: ignore[attr-defined]
        with torch.no_grad():
            out = fn(frame, **self._params)
        if not isinstance(out, torch.Tensor):
            raise DtypeError(f"denoiser {label!r}: expected a tensor, got {type(out).__name__}")
        if not out.is_floating_point() or out.device != frame.color.device:
            raise DtypeError(
                f"denoiser {label!r}: expected a floating tensor on the frame's device "
                f"{frame.color.device}, got {out.dtype} on {out.device}"
            )
        return out.to(dtype=torch.float32)  # float16/64 out: float32, as the interface says

    def params(self: Any) -> dict[str, Any]:
        return dict(self._params)

    return {"__init__": __init__, "denoise": denoise, "params": params}
