"""The sweep's plug-ins (:mod:`bnerr.plugins`): loading the command line's specs, in the driver
and again in every worker, and the identity each record carries so that ``--resume`` refuses to
mix cells of a changed plug-in.

A spec (``pkg.mod:attr``, ``path/file.py:Name``, a manifest or scene file) is loaded by the
registry of its group and registered under its name; the cells name it by that name. The specs
travel with the parts (:attr:`benchmarks.sweep.parts.Parts.plugins`, pairs ``(group, spec)``) and
:func:`load_specs` resolves them again wherever the parts are used (a Ray worker, a subprocess);
installed entry points are found by the registries themselves.

Each record keeps ``plugins``: ``"<group>:<name>"`` -> ``{"spec", "fingerprint"}`` for every
plug-in its cell uses (scene, strategy, sampler, denoiser, metrics), the fingerprint being
:attr:`bnerr.plugins.Plugin.fingerprint` (distribution and version, else a hash of the source).
:func:`check_resume` compares them with the plug-ins loaded now, and :func:`load_recorded` loads
them again from those specs in a process that only reports (``bnerr bench --report-only``,
``python -m benchmarks.reports DIR``), so that its report is the measuring run's: a plug-in
metric's columns, a plug-in denoiser's panel of the error-against-time chart.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence

import denoisers
import renderers
from benchmarks.sweep.plan import Cell
from benchmarks.sweep.records import Record
from bnerr import metrics, plugins, sequences, strategies
from bnerr.errors import BnerrError, PluginError

__all__ = [
    "LOADERS",
    "cell_plugins",
    "check_resume",
    "load_names",
    "load_recorded",
    "load_specs",
    "with_plugins",
]

#: Registry group -> its loader: a name or spec in, the registered name out.
LOADERS: dict[str, Callable[[str], str]] = {
    "bnerr.scenes": renderers.load_scene,
    "bnerr.strategies": strategies.REGISTRY.name_of,
    "bnerr.denoisers": denoisers.load_denoiser,
    "bnerr.samplers": sequences.load_sampler,
    "bnerr.metrics": metrics.load_metric,
}

_OWN = ":own"  # a denoiser tuned on the strategy's own frames (benchmarks.sweep.measure)


def load_names(
    group: str, values: Sequence[str] | None, specs: list[tuple[str, str]]
) -> list[str] | None:
    """``values`` with every plug-in spec loaded and replaced by its registered name; each spec
    is appended to ``specs`` as ``(group, spec)``. A denoiser spec may end in ``:own``."""
    if values is None:
        return None
    names = []
    for value in values:
        own = group == "bnerr.denoisers" and value.endswith(_OWN)
        bare = value.removesuffix(_OWN) if own else value
        name = LOADERS[group](bare)
        error = plugins.broken(group, name)
        if error is not None:  # an installed entry point that failed to load, named here
            raise error
        if name != bare:
            specs.append((group, bare))
        names.append(name + (_OWN if own else ""))
    return names


def load_specs(specs: Iterable[tuple[str, str]]) -> None:
    """Load (again) every ``(group, spec)``: what a worker does before it uses the parts."""
    for group, spec in specs:
        LOADERS[group](spec)


def cell_plugins(cell: Cell, metric_names: Iterable[str], sampler: str | None) -> dict:
    """``"<group>:<name>"`` -> ``{"spec", "fingerprint"}`` of the plug-ins a cell uses."""
    used = [
        ("bnerr.scenes", cell.scene),
        ("bnerr.strategies", cell.strategy.split("+")[0]),
        ("bnerr.denoisers", cell.denoiser.removesuffix(_OWN)),
        ("bnerr.samplers", cell.sampler),
        *(("bnerr.samplers", s) for s in ([sampler] if sampler else [])),
        *(("bnerr.metrics", m) for m in metric_names),
    ]
    found = {}
    for group, name in used:
        plugin = plugins.loaded(group, name)
        if plugin is not None:
            found[f"{group}:{name}"] = {"spec": plugin.spec, "fingerprint": plugin.fingerprint}
    return found


def with_plugins(record: Record) -> Record:
    """``record`` with its cell's plug-ins (:func:`cell_plugins`; None when it uses none)."""
    found = cell_plugins(record.cell, record.raw, record.render_sampler)
    return dataclasses.replace(record, plugins=found or None)


def check_resume(records: Iterable[Record]) -> None:
    """Refuse to resume into records measured with a plug-in that has changed since.

    Raises:
        PluginError: one line naming the plug-in, its spec and both fingerprints.
    """
    for record in records:
        for key, then in (record.plugins or {}).items():
            group, _, name = key.partition(":")
            now = plugins.loaded(group, name)
            if now is not None and now.fingerprint != then.get("fingerprint"):
                raise PluginError(
                    f"--resume: expected plug-in {name!r} ({now.spec}) unchanged since its "
                    f"cells in the results were measured, got fingerprint {now.fingerprint} "
                    f"(was {then.get('fingerprint')}; it hashes the plug-in's own file, a "
                    "manifest's program, an installed version, not what they import or read); "
                    "measure again with --overwrite, or into another --out"
                )


def load_recorded(records: Iterable[Record]) -> list[str]:
    """Load again, from their specs, the plug-ins ``records`` were measured with (each once;
    installed entry points are the registries' own), so that a report built in a new process
    sees them as the measuring process did. A spec names a file or module as it was given
    (relative to the directory the run started in), so it loads from there.

    Returns:
        one line per plug-in that cannot be loaded any more (moved, deleted, not importable
        here): its report is then built from the records alone (a metric without its columns,
        a denoiser drawn with the other denoisers).
    """
    notes, seen = [], set()
    for record in records:
        for key, entry in (record.plugins or {}).items():
            group, _, name = key.partition(":")
            spec = entry.get("spec") or ""
            if (group, spec) in seen or group not in LOADERS:
                continue
            seen.add((group, spec))
            if spec.startswith("entry point "):
                note = _installed_note(group, name, spec, entry.get("fingerprint"))
                notes.extend([note] if note else [])
                continue
            try:
                LOADERS[group](spec)
            except BnerrError as err:
                notes.append(
                    f"plug-in {name!r} ({spec}) not loaded, reported from its records: {err}"
                )
    return notes


def _installed_note(group: str, name: str, spec: str, fingerprint: object) -> str | None:
    """The note of :func:`load_recorded` for a plug-in measured as an installed entry point that
    is not installed (or will not load) here, or None when it is registered."""
    try:
        LOADERS[group](name)  # reads the registry: its installed entry points load
    except BnerrError as err:
        return f"plug-in {name!r} ({spec}) not loaded, reported from its records: {err}"
    if plugins.loaded(group, name) is not None:
        return None
    error = plugins.broken(group, spec.removeprefix("entry point "))
    why = str(error) if error is not None else "no installed distribution gives it here"
    return (
        f"plug-in {name!r} ({spec} of group {group}, measured with {fingerprint}) not loaded, "
        f"reported from its records: {why}"
    )
