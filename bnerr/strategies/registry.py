"""The strategy registry: name -> class, filled by :class:`bnerr.strategies.base.Strategy`'s
subclasses as they are defined (``bnerr.strategies.STRATEGIES`` is :data:`REGISTRY`), and by the
plug-ins (:mod:`bnerr.plugins`): a spec loaded with :meth:`StrategyRegistry.load`, and the
installed ``bnerr.strategies`` entry points, loaded the first time the registry is read."""

from __future__ import annotations

import inspect
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from bnerr import plugins
from bnerr.errors import PluginError, ValueRangeError, check_name

__all__ = ["REGISTRY", "StrategyRegistry"]


#: A strategy's identity (docs/ARCHITECTURE.md's contribution table) and its default when a
#: plug-in declares none: family ``"other"`` (none declared), a rank after every shipped one,
#: no notes. ``color`` is never inherited (``Strategy`` docstring).
_IDENTITY_DEFAULTS: dict[str, object] = {
    "family": "other",
    "rank": 1000,
    "raw_mse_note": "",
    "bound_note": "",
}


def _shipped(cls: type) -> bool:
    return cls.__module__.split(".")[0] == "bnerr"


def _own_identity(cls: Any) -> None:
    """Give a plug-in class that subclasses a shipped strategy the identity defaults for each of
    :data:`_IDENTITY_DEFAULTS` it does not declare itself (nor a class of its own between it and
    the shipped one): subclassing ``WhiteStrategy`` must not make a plug-in a second baseline,
    nor list a new family at white's rank 0. What it declares is kept."""
    if _shipped(cls):
        return
    for attr, default in _IDENTITY_DEFAULTS.items():
        owner = next((c for c in cls.__mro__ if attr in vars(c)), None)
        if owner is not None and _shipped(owner) and owner.__name__ != "Strategy":
            setattr(cls, attr, default)


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
        self._installed = False

    def _load_installed(self) -> None:
        """Register the installed ``bnerr.strategies`` entry points (once)."""
        if self._installed:
            return
        self._installed = True  # a plug-in that reads the registry while loading sees the rest
        try:
            for plugin in plugins.installed("bnerr.strategies"):
                try:
                    self.add_plugin(plugin)
                except (PluginError, ValueRangeError) as err:  # left out, said once
                    name = plugin.spec.removeprefix("entry point ")
                    error = (
                        err if isinstance(err, PluginError) else PluginError(f"{plugin.who}: {err}")
                    )
                    plugins.skip_broken("bnerr.strategies", name, error)
        except BaseException:
            self._installed = False
            raise

    def add_plugin(self, plugin: plugins.Plugin) -> str:
        """Check a loaded strategy plug-in and return its name: a subclass of the shipped
        ``Strategy`` (it registered itself when defined) with a ``name`` and a ``family``."""
        cls = plugin.obj
        name = getattr(cls, "name", None)
        if isinstance(cls, type) and name and hasattr(cls, "create"):
            known = self._classes.get(name)
            if known is None or _same_source(known, cls):
                # loaded before and forgotten since (remove), or the same file imported under a
                # second module name (a file spec and an installed entry point): registered again
                self.add(cls)
        if not isinstance(cls, type) or not name or self._classes.get(name) is not cls:
            got = cls.__name__ if isinstance(cls, type) else type(cls).__name__
            raise PluginError(
                f"{plugin.who}: expected a subclass of bnerr.strategies.base.Strategy (or of a "
                f"shipped strategy) with a name, got {got}"
            )
        _own_identity(cls)
        family = getattr(cls, "family", None)
        if not isinstance(family, str) or not family:
            raise PluginError(
                f"{plugin.who}: expected a strategy class that declares its family (a non-empty "
                f"str: 'baseline', 'rival', 'temporal', 'ldbn', 'bound' or a new one), got "
                f"{family!r}"
            )
        plugins.record("bnerr.strategies", name, plugin)
        return str(name)

    def load(self, spec: str) -> str:
        """Load the strategy plug-in ``spec`` (``pkg.mod:Cls`` or ``file.py:Cls``), register it
        and return its name."""
        return self.add_plugin(plugins.resolve(spec))

    def name_of(self, name_or_spec: str) -> str:
        """``name_or_spec`` itself when registered (or not a spec), else the name of the
        plug-in it specifies (loaded and registered)."""
        if name_or_spec in self or not plugins.is_spec(name_or_spec):
            return name_or_spec
        return self.load(name_or_spec)

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
        self._load_installed()
        return dict(sorted(self._classes.items()))

    def __getitem__(self, name: str) -> Any:
        if name not in self._classes and name not in self._variants:
            self._load_installed()
        if name in self._classes:
            return self._classes[name]
        error = plugins.broken("bnerr.strategies", name)
        if error is not None and name not in self._variants:
            raise error  # an installed entry point that failed to load, named here
        return self._classes[self._variants[name]]

    def __contains__(self, name: object) -> bool:
        if name not in self._classes and name not in self._variants:
            self._load_installed()
        return name in self._classes or name in self._variants

    def __iter__(self) -> Iterator[str]:
        self._load_installed()
        return iter(sorted({*self._classes, *self._variants}))

    def __len__(self) -> int:
        self._load_installed()
        return len({*self._classes, *self._variants})

    def __repr__(self) -> str:
        self._load_installed()
        return f"StrategyRegistry({', '.join(self)})"


#: Every registered strategy, name -> class (``bnerr.strategies.STRATEGIES``).
REGISTRY = StrategyRegistry()


def _same_source(a: type, b: type) -> bool:
    """Whether two classes are one class of one source file (imported under two module names)."""
    try:
        files = [inspect.getsourcefile(c) for c in (a, b)]
    except TypeError:  # a class without a source file
        return False
    if None in files:
        return False
    same = Path(str(files[0])).resolve() == Path(str(files[1])).resolve()
    return same and a.__qualname__ == b.__qualname__
