"""Plug-ins: strategies, denoisers, samplers, metrics and scenes from outside bnerr, measured like
the shipped ones without a fork (the way FBKSD, pytest, Mitsuba 3 and Ray are extended).

A plug-in comes three ways:

- a spec ``"pkg.mod:attr"``: the attribute (dotted for a nested one, ``mod:Cls.make``) of an
  importable module;
- a spec ``"path/to/file.py:Name"``: the file is imported under a stable module name derived from
  its resolved path (:func:`file_module_name`), so that two files called ``plugin.py`` never
  collide and a file imported twice is the same module; its folder is on ``sys.path`` only while
  it is imported (a sibling import works, nothing stays behind);
- an installed distribution's entry point in one of :data:`GROUPS` (``bnerr.strategies``,
  ``bnerr.denoisers``, ``bnerr.samplers``, ``bnerr.metrics``, ``bnerr.scenes``): loaded once,
  lazily, the first time the registry of its group is read (:class:`PluginRegistry`), and cached.
  One that fails to load (or is the wrong kind) is left out with one warning naming it and its
  distribution, so that it breaks no command that does not use it; naming it gives its error.

This module is generic: it knows no registry. Each registry (``bnerr.strategies``,
``bnerr.sequences``, ``bnerr.metrics``, ``denoisers``, ``renderers.catalog``) checks what a
plug-in must be, adapts it and registers it under its name next to the shipped entries, so that
every lookup by name (the identity lookups, the command line's choices) finds it like a shipped
one. :func:`record` keeps each registered plug-in's :class:`Plugin` (its spec and
:func:`plugin_fingerprint`), which the benchmark writes into its records.

Every failure is a :class:`~bnerr.errors.PluginError` whose one-line message names the plug-in
(its spec or entry point, and its distribution) and what was expected: an import that fails, a
missing attribute, an object of the wrong kind, a constructor that raises.

Not for: sandboxing. A plug-in is code run in this process with its rights.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import sys
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from bnerr.errors import BnerrError, PluginError

__all__ = [
    "GROUPS",
    "Plugin",
    "PluginRegistry",
    "broken",
    "call_plugin",
    "file_module_name",
    "installed",
    "is_spec",
    "loaded",
    "plugin_failure",
    "plugin_fingerprint",
    "plugin_name",
    "record",
    "registered_file",
    "resolve",
    "skip_broken",
]

#: The entry-point groups a distribution can register plug-ins in.
GROUPS: tuple[str, ...] = (
    "bnerr.strategies",
    "bnerr.denoisers",
    "bnerr.samplers",
    "bnerr.metrics",
    "bnerr.scenes",
)


@dataclass(frozen=True)
class Plugin:
    """A loaded plug-in.

    Attributes:
        spec: what named it: ``"pkg.mod:attr"``, ``"path/file.py:Name"`` (as given), or
            ``"entry point NAME"`` for an installed one.
        obj: the object loaded.
        distribution: ``"name version"`` of the distribution that provides it, or None (a file,
            or a module on ``sys.path`` that no distribution owns).
        files: files whose bytes identify it instead of its code's (an executable denoiser's
            manifest, a scene file).
    """

    spec: str
    obj: Any
    distribution: str | None = None
    files: tuple[str, ...] = ()

    @property
    def who(self) -> str:
        """How error messages name it: the spec and the distribution."""
        return f"plug-in {self.spec!r} ({self.distribution or 'no distribution'})"

    @property
    def fingerprint(self) -> str:
        """:func:`plugin_fingerprint` of its object: for an installed one the distribution's
        ``name==version`` and its module's source hash (an editable install's edit changes it
        though the version does not); for a manifest or scene file the hash of its files (an
        executable denoiser's program file among them)."""
        if self.distribution is not None:
            source = _source_hash(self.obj)
            version = self.distribution.replace(" ", "==")
            return f"{version}+{source}" if source else version
        if self.files:
            return "sha256:" + _file_hash([Path(f) for f in self.files])
        return plugin_fingerprint(self.obj)


def is_spec(text: object) -> bool:
    """Whether ``text`` reads as a plug-in spec ``module:attr`` or ``file.py:Name`` (a registered
    name that holds a colon, such as ``gaussian:own``, is the caller's to tell apart first)."""
    if not isinstance(text, str) or ":" not in text:
        return False
    where, _, attr = text.rpartition(":")
    return bool(where) and all(part.isidentifier() for part in attr.split("."))


def file_module_name(path: str | Path) -> str:
    """The module name a plug-in file is imported under: its stem and 12 hex digits of SHA-256 of
    its resolved path (stable across runs and processes, distinct for distinct files)."""
    resolved = Path(path).resolve()
    digest = hashlib.sha256(str(resolved).encode()).hexdigest()[:12]
    stem = "".join(c if c.isalnum() else "_" for c in resolved.stem)
    return f"bnerr_plugin_{stem}_{digest}"


def _import_file(path: Path, spec: str) -> ModuleType:
    name = file_module_name(path)
    if name in sys.modules:
        return sys.modules[name]
    if not path.is_file():
        raise PluginError(f"plug-in {spec!r}: expected an existing Python file, got no {path}")
    module_spec = importlib.util.spec_from_file_location(name, path)
    if module_spec is None or module_spec.loader is None:
        raise PluginError(f"plug-in {spec!r}: expected an importable Python file, got {path}")
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module
    folder = str(path.resolve().parent)
    sys.path.insert(0, folder)  # a sibling import works while the file runs
    try:
        module_spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    finally:
        if folder in sys.path:
            sys.path.remove(folder)
    return module


def _import(where: str, spec: str) -> ModuleType:
    try:
        if where.endswith(".py"):
            return _import_file(Path(where), spec)
        return importlib.import_module(where)
    except PluginError:
        raise
    except (Exception, SystemExit) as err:  # a plug-in's sys.exit() must not end bnerr
        raise PluginError(
            f"plug-in {spec!r} ({_distribution_of(where) or 'no distribution'}): expected an "
            f"importable module {where!r}, got {type(err).__name__}: {_first_line(err)}"
        ) from err


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else "(no message)"


@functools.cache
def _top_level_distributions() -> dict[str, list[str]]:
    return dict(importlib.metadata.packages_distributions())


def _distribution_of(module: str) -> str | None:
    """``"name version"`` of the installed distribution owning ``module``'s top package."""
    if module.endswith(".py"):
        return None
    names = _top_level_distributions().get(module.split(".")[0])
    if not names:
        return None
    try:
        return f"{names[0]} {importlib.metadata.version(names[0])}"
    except importlib.metadata.PackageNotFoundError:
        return None


def resolve(spec: str) -> Plugin:
    """The object a spec ``"pkg.mod:attr"`` or ``"path/to/file.py:Name"`` names (cached per
    spec: resolving it again returns the same object).

    Raises:
        PluginError: not a spec, the import fails or the attribute is missing.
    """
    if not is_spec(spec):
        raise PluginError(
            f"plug-in spec: expected 'pkg.module:attr' or 'path/to/file.py:Name', got {spec!r}"
        )
    return _resolve(spec)


@functools.cache
def _resolve(spec: str) -> Plugin:
    where, _, attr = spec.rpartition(":")
    module = _import(where, spec)
    distribution = _distribution_of(where)
    obj: Any = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise PluginError(
                f"plug-in {spec!r} ({distribution or 'no distribution'}): expected an attribute "
                f"{attr!r} in {where!r}, got none"
            )
        obj = getattr(obj, part)
    return Plugin(spec, obj, distribution)


_BROKEN: dict[tuple[str, str], PluginError] = {}


def broken(group: str, name: str) -> PluginError | None:
    """The error of the installed entry point ``name`` of ``group`` that could not be loaded or
    registered (:func:`installed`, :class:`PluginRegistry`), or None."""
    return _BROKEN.get((group, name))


def skip_broken(group: str, name: str, err: PluginError) -> None:
    """Keep ``err`` as entry point ``name``'s (:func:`broken`) and say it once, as a warning:
    one broken installed plug-in must not stop every command, only one that names it."""
    if (group, name) not in _BROKEN:
        _BROKEN[(group, name)] = err
        warnings.warn(f"{err}; it is left out", stacklevel=3)


@functools.cache
def installed(group: str) -> tuple[Plugin, ...]:
    """The plug-ins installed distributions declare as entry points of ``group`` (one of
    :data:`GROUPS`), each loaded once (cached), sorted by entry-point name.

    An entry point that cannot be loaded is left out with one warning naming it and its
    distribution (:func:`skip_broken`); a command that names it gets its error
    (:func:`broken`, :class:`PluginRegistry`).

    Raises:
        PluginError: an unknown group.
    """
    if group not in GROUPS:
        raise PluginError(f"entry-point group: expected one of {', '.join(GROUPS)}, got {group!r}")
    found = []
    for point in sorted(importlib.metadata.entry_points(group=group), key=lambda p: p.name):
        dist = getattr(point, "dist", None)
        distribution = f"{dist.name} {dist.version}" if dist is not None else None
        plugin = Plugin(f"entry point {point.name}", None, distribution)
        try:
            obj = point.load()
        except (Exception, SystemExit) as err:  # a plug-in's sys.exit() must not end bnerr
            skip_broken(
                group,
                point.name,
                PluginError(
                    f"{plugin.who} of group {group}: expected {point.value!r} to load, got "
                    f"{type(err).__name__}: {_first_line(err)}"
                ),
            )
            continue
        found.append(Plugin(plugin.spec, obj, distribution))
    return tuple(found)


def plugin_name(plugin: Plugin, what: str) -> str:
    """The name a plug-in registers under: its object's ``name`` attribute (a class's), else the
    entry point's name, else the spec's attribute name."""
    name = getattr(plugin.obj, "name", None)
    if not isinstance(name, str) or not name:
        name = plugin.spec.removeprefix("entry point ").rpartition(":")[2].split(".")[-1]
    if not name or ":" in name or "/" in name:
        raise PluginError(f"{plugin.who}: expected a {what} name without ':' or '/', got {name!r}")
    return name


def call_plugin(
    plugin: Plugin, what: str, build: Callable[..., Any], *args: Any, **kwargs: Any
) -> Any:
    """``build(*args, **kwargs)`` (a plug-in's constructor or factory), with any error it raises
    other than bnerr's own typed ones turned into a :class:`PluginError` naming the plug-in."""
    try:
        return build(*args, **kwargs)
    except BnerrError:
        raise
    except (Exception, SystemExit) as err:
        raise plugin_failure(plugin, f"its {what} to build", err) from err


def plugin_failure(plugin: Plugin, expected: str, err: BaseException) -> PluginError:
    """The one-line :class:`PluginError` of a plug-in's code that raised ``err`` where
    ``expected`` was to happen (``"its scene to build"``, ``"to denoise frame 3"``)."""
    return PluginError(
        f"{plugin.who}: expected {expected}, got {type(err).__name__}: {_first_line(err)}"
    )


def _module_of(obj: object) -> ModuleType | None:
    target = getattr(obj, "plugin_source", obj)  # an adapter names what it wraps
    target = inspect.unwrap(target) if callable(target) else target
    if not (inspect.isfunction(target) or inspect.isclass(target) or inspect.ismodule(target)):
        target = type(target)
    return inspect.getmodule(target)


def _source_hash(obj: object) -> str | None:
    """``sha256:`` and 16 hex digits of the source file of the module defining ``obj``, or
    None when it has none (a built-in, a module made in memory)."""
    module = _module_of(obj)
    file = getattr(module, "__file__", None) if module is not None else None
    if not file or not Path(file).is_file():
        return None
    return "sha256:" + _file_hash([Path(file)])


def plugin_fingerprint(obj: object) -> str:
    """A short string identifying a plug-in's code: ``sha256:`` and 16 hex digits of its source
    file (the file of the module that defines it), after ``name==version+`` of the installed
    distribution that owns that module; ``"unknown"`` when neither can be found.

    What it does not see: other files the module imports or reads, and what an executable
    plug-in's program runs besides its own file (docs/PLUGINS.md, section 7)."""
    module = _module_of(obj)
    if module is None:
        return "unknown"
    owner = _distribution_of(module.__name__)
    source = _source_hash(obj)
    if owner is not None:
        return owner.replace(" ", "==") + (f"+{source}" if source else "")
    return source or "unknown"


def _file_hash(files: list[Path]) -> str:
    """16 hex digits of SHA-256 over the files' bytes, in order (a missing file hashes its
    name)."""
    digest = hashlib.sha256()
    for file in files:
        digest.update(file.read_bytes() if file.is_file() else str(file).encode())
    return digest.hexdigest()[:16]


_LOADED: dict[tuple[str, str], Plugin] = {}


def record(group: str, name: str, plugin: Plugin) -> None:
    """Remember that ``plugin`` is registered as ``name`` in ``group``'s registry."""
    _LOADED[(group, name)] = plugin


def loaded(group: str, name: str) -> Plugin | None:
    """The plug-in registered as ``name`` in ``group``'s registry, or None for a shipped entry."""
    return _LOADED.get((group, name))


def registered_file(group: str, path: str | Path) -> str | None:
    """The name a file plug-in (a manifest, a scene file) is registered under in ``group``, or
    None when that file (by resolved path) is not loaded: loading the same file again (a
    worker, a second command-line spec) returns the registered entry instead of building a new
    one that would clash with it by name."""
    resolved = (str(Path(path).resolve()),)
    for (where, name), plugin in _LOADED.items():
        if where == group and plugin.files[:1] == resolved:  # the manifest, then its program
            return name
    return None


class PluginRegistry(dict):
    """A registry dict (name -> entry) that adds its group's installed plug-ins the first time
    it is read: ``adapt(plugin) -> (name, entry)`` checks and adapts each one (raising
    :class:`PluginError` for the wrong kind). Shipped entries are given at construction; a name
    a plug-in shares with a shipped entry is refused. Iterates in sorted order, or with
    ``sort=False`` in the order entries came (the shipped ones first)."""

    def __init__(
        self,
        group: str,
        adapt: Callable[[Plugin], tuple[str, Any]],
        entries: dict[str, Any],
        *,
        sort: bool = True,
    ) -> None:
        super().__init__(sorted(entries.items()) if sort else entries)
        self.group, self._adapt, self._state, self._sort = group, adapt, "new", sort

    def _load(self) -> None:
        if self._state != "new":
            return
        self._state = "loading"  # a plug-in that reads the registry while it loads sees the shipped
        try:
            for plugin in installed(self.group):
                try:
                    self.add(plugin)
                except PluginError as err:  # the wrong kind: left out, said once
                    skip_broken(self.group, plugin.spec.removeprefix("entry point "), err)
        except BaseException:
            self._state = "new"
            raise
        self._state = "done"

    def add(self, plugin: Plugin) -> str:
        """Check, adapt and register ``plugin``; return its name (again: the same name)."""
        name, entry = self._adapt(plugin)
        known = loaded(self.group, name)
        if dict.__contains__(self, name) and (known is None or known.obj is not plugin.obj):
            raise PluginError(
                f"{plugin.who}: expected a name no other {self.group.split('.')[-1]} entry has, "
                f"got {name!r}"
            )
        dict.__setitem__(self, name, entry)
        if self._sort:
            items = sorted(dict.items(self))
            dict.clear(self)
            dict.update(self, items)
        record(self.group, name, plugin)
        return name

    def __getitem__(self, name: str) -> Any:
        if not dict.__contains__(self, name):
            self._load()
            error = broken(self.group, name)
            if error is not None and not dict.__contains__(self, name):
                raise error
        return dict.__getitem__(self, name)

    def __contains__(self, name: object) -> bool:
        if not dict.__contains__(self, name):
            self._load()
        return dict.__contains__(self, name)

    def __iter__(self) -> Iterator[str]:
        self._load()
        return dict.__iter__(self)

    def __len__(self) -> int:
        self._load()
        return dict.__len__(self)

    def get(self, name: str, default: Any = None) -> Any:
        return self[name] if name in self else default

    def keys(self):
        self._load()
        return dict.keys(self)

    def values(self):
        self._load()
        return dict.values(self)

    def items(self):
        self._load()
        return dict.items(self)

    def __repr__(self) -> str:
        self._load()
        return f"PluginRegistry({self.group}: {', '.join(dict.keys(self))})"
