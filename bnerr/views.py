"""A read-only mapping computed afresh on every access from the registries it is derived from.

Tables such as ``bnerr.strategies.OWN_SAMPLERS`` or ``denoisers.tuning.GRIDS`` are read off the
registered classes; a plain dict built at import would miss a class registered later (a
plug-in, a test's toy class) and could disagree with the classes. :class:`LiveMapping` asks its
function every time instead.

Not for: anything that needs to be fast in a loop (each access rebuilds the table).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import TypeVar

__all__ = ["LiveMapping"]

K = TypeVar("K")
V = TypeVar("V")


class LiveMapping(Mapping[K, V]):
    """A mapping whose contents are ``table()``, called on every access."""

    def __init__(self, table: Callable[[], Mapping[K, V]]) -> None:
        self._table = table

    def __getitem__(self, key: K) -> V:
        return self._table()[key]

    def __iter__(self) -> Iterator[K]:
        return iter(self._table())

    def __len__(self) -> int:
        return len(self._table())

    def __repr__(self) -> str:
        return repr(dict(self._table()))
