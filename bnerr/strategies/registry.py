"""The strategy registry: name -> class, filled by :class:`bnerr.strategies.base.Strategy`'s
subclasses as they are defined (``bnerr.strategies.STRATEGIES`` is :data:`REGISTRY`)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from bnerr.errors import ValueRangeError, check_name

__all__ = ["REGISTRY", "StrategyRegistry"]


class StrategyRegistry(Mapping[str, Any]):
    """Strategy name -> class, filled by the classes themselves (``Strategy.__init_subclass__``).

    The classes are typed ``Any`` here: this module is a leaf that the interface
    (:mod:`bnerr.strategies.base`) and the variant grammar both import, so it cannot name
    :class:`bnerr.strategies.base.Strategy` without a circle.

    Iterates in sorted order (the benchmark's tables and command line list names this way).
    Besides the classes' names it holds the registered temporal variants
    (:data:`bnerr.strategies.VARIANTS`), each mapped to its base's class.
    """

    def __init__(self) -> None:
        self._classes: dict[str, Any] = {}
        self._variants: dict[str, str] = {}

    def add(self, cls: Any) -> None:
        """Register ``cls`` under ``cls.name``; a name taken by another class is refused."""
        known = self._classes.get(cls.name)
        if known is not None and known.__qualname__ != cls.__qualname__:
            raise ValueRangeError(
                f"strategy name: expected a name no other strategy has, got {cls.name!r} "
                f"(taken by {known.__module__}.{known.__qualname__})"
            )
        taken = {c.stream: n for n, c in self._classes.items() if n != cls.name}
        if "stream" in cls.__dict__ and cls.stream in taken:
            raise ValueRangeError(
                f"{cls.__qualname__}.stream: expected a seed stream no other strategy uses, got "
                f"{cls.stream} (used by {taken[cls.stream]})"
            )
        self._classes[cls.name] = cls

    def add_variant(self, name: str, base: str) -> None:
        """Register the temporal variant ``name`` of the strategy ``base``."""
        self._variants[name] = check_name(base, tuple(self._classes), "variant base")

    def remove(self, name: str) -> None:
        """Forget ``name`` (a class's name or a variant), e.g. a test's toy strategy."""
        self._classes.pop(name, None)
        self._variants.pop(name, None)

    def classes(self) -> dict[str, Any]:
        """The registered classes by name (variants excluded), sorted by name."""
        return dict(sorted(self._classes.items()))

    def __getitem__(self, name: str) -> Any:
        if name in self._classes:
            return self._classes[name]
        return self._classes[self._variants[name]]

    def __contains__(self, name: object) -> bool:
        return name in self._classes or name in self._variants

    def __iter__(self) -> Iterator[str]:
        return iter(sorted({*self._classes, *self._variants}))

    def __len__(self) -> int:
        return len({*self._classes, *self._variants})

    def __repr__(self) -> str:
        return f"StrategyRegistry({', '.join(self)})"


#: Every registered strategy, name -> class (``bnerr.strategies.STRATEGIES``).
REGISTRY = StrategyRegistry()
