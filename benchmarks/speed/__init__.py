"""The speed suite: each timing script's ``measure()``, written to ``speed.json`` and ``speed.md``.

Each script of the suite (:attr:`benchmarks.suites.Suite.scripts`, e.g. ``speed.permute`` for
:mod:`benchmarks.speed.permute`) returns its figures as a (nested) dict; :func:`run_speed` stores
them as they come in ``speed.json``, under the script's name, and :func:`speed_markdown` writes
``speed.md``: one table per part, each figure with its unit and its ratio to the part's anchor.
Each script carries the writer of its own table (its ``table(values, figures)``):

- the tracer (:mod:`~benchmarks.speed.tracer`) against Mitsuba 3's ``scalar_rgb`` and
  ``llvm_ad_rgb`` variants, and ``bnerr render`` as a whole new process, cold and warm
  (:mod:`~benchmarks.speed.process`), against a Mitsuba LLVM process;
- the permutation passes (:mod:`~benchmarks.speed.permute`) against a memory copy of the bytes
  each reads and writes (:mod:`~benchmarks.speed.copy`, which :func:`run_speed` runs right after
  ``speed.permute``, in the same run), and the closing-the-gap options (its ``gap`` figures)
  against the plain sort pass;
- the samplers (:mod:`~benchmarks.speed.sequences`) against independent ``white`` values;
- the masks (:mod:`~benchmarks.speed.masks`): the time to make each, and its low-frequency
  fraction against white noise's;
- the denoisers (:mod:`~benchmarks.speed.denoise`) against OIDN.

A script without a table is listed figure by figure under its path. A figure the JSON lacks
(a script older than its table, a failed or missing renderer) shows as "-" with a note
(:mod:`~benchmarks.speed.formatting`).

Not for: the per-cell sweeps (:mod:`benchmarks.sweep.runner`).
"""

from __future__ import annotations

import dataclasses
import importlib
import json
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import torch

from benchmarks.suites import Suite
from bnerr.errors import FileFormatError, check_name
from bnerr.io import atomic_write

__all__ = [
    "ANCHOR_SCRIPTS",
    "SECTION_ORDER",
    "rewrite_speed_report",
    "run_speed",
    "speed_markdown",
]

#: Script -> the script that measures its anchor, run right after it by :func:`run_speed` (when
#: the suite does not list it itself), so that both are measured in the same run.
ANCHOR_SCRIPTS: dict[str, str] = {"speed.permute": "speed.copy"}
#: The order of the parts in ``speed.md`` (scripts not listed follow, in the figures' order).
SECTION_ORDER: tuple[str, ...] = (
    "speed.tracer",
    "speed.process",
    "speed.permute",
    "speed.sequences",
    "speed.masks",
    "speed.denoise",
)


def _jsonable(value: Any) -> Any:
    """``value`` with tensors, numpy scalars, tuples and dataclasses turned into JSON types."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.generic, torch.Tensor)):
        return value.item() if value.ndim == 0 else value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _jsonable(dataclasses.asdict(value))
    return value


def _leaves(value: Any, prefix: str = "") -> Iterable[tuple[str, Any]]:
    """``(path, shown value)`` of every leaf of a nested dict; floats to 6 significant digits."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{prefix}/{key}" if prefix else str(key))
    else:
        yield prefix, (f"{value:.6g}" if isinstance(value, float) else value)


def _summary(measure: Any) -> str:
    """The first paragraph of a ``measure()`` docstring, on one line."""
    return " ".join((measure.__doc__ or "").strip().split("\n\n")[0].split())


_Writer = Callable[[Mapping[str, Any], Mapping[str, Any]], list[str]]


def _module(script: str) -> ModuleType | None:
    """The module of ``script`` (``speed.permute`` -> :mod:`benchmarks.speed.permute`), or None
    for a name that is no module here (figures of a script since removed)."""
    name = f"benchmarks.{script}"
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        if err.name is not None and name.startswith(err.name):
            return None
        raise


def _writer(script: str) -> _Writer | None:
    """The writer of ``script``'s table: its module's ``table(values, figures)``, or None."""
    module = _module(script)
    return getattr(module, "table", None) if module is not None else None


def _listing(script: str, values: Any, summary: str) -> list[str]:
    """A script without a table: every figure under its path."""
    lines = [f"## {script}", ""]
    lines += [summary, ""] if summary else []
    lines += ["| figure | value |", "|---|---|"]
    lines += [f"| {path} | {value} |" for path, value in _leaves(values)]
    return lines + [""]


def speed_markdown(suite: Suite, figures: Mapping[str, Any], summaries: Mapping[str, str]) -> str:
    """The Markdown of ``speed.md``: one table per part, each figure with its unit and its ratio
    to the part's anchor; a script without a table lists its figures (its section headed by
    ``summaries[script]``). The scripts of :data:`ANCHOR_SCRIPTS`' values are shown in their
    part's table, not on their own."""
    lines = [f"# bnerr bench --suite {suite.name}", "", suite.description, ""]
    anchors = set(ANCHOR_SCRIPTS.values())
    order = {script: i for i, script in enumerate(SECTION_ORDER)}
    for script in sorted(figures, key=lambda name: order.get(name, len(order))):
        values = figures[script]
        writer = _writer(script)
        if script in anchors and any(part in figures for part in ANCHOR_SCRIPTS):
            continue
        if writer is not None and isinstance(values, Mapping):
            lines += writer(values, figures)
        else:
            lines += _listing(script, values, summaries.get(script, ""))
    return "\n".join(lines)


def run_speed(
    suite: Suite,
    out_dir: str | Path,
    *,
    progress: bool = True,
    only: Iterable[str] | None = None,
) -> str:
    """Call ``measure()`` of every script of the speed suite, each followed by its anchor's
    (:data:`ANCHOR_SCRIPTS`) if the suite does not list that; write ``speed.json`` and
    ``speed.md`` into ``out_dir``; return the Markdown.

    ``only``: measure just these scripts of the suite (and their anchors, so that a ratio is
    always of two figures taken side by side) and keep every other script's figures from the
    ``speed.json`` already in ``out_dir`` (after a change to one kernel: the permutation op's
    figures again, not the whole suite's quarter of an hour).

    Raises:
        UnknownNameError: ``only`` names a script the suite does not run.
        FileFormatError: with ``only``, ``out_dir/speed.json`` is unreadable.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, Any] = {}
    wanted = suite.scripts
    if only is not None:
        wanted = tuple(check_name(name, suite.scripts, "speed script") for name in only)
        if (out / "speed.json").exists():
            figures = _read_figures(suite, out / "speed.json")
    summaries = {
        name: _summary(importlib.import_module(f"benchmarks.{name}").measure) for name in figures
    }
    scripts: list[str] = []
    for script in wanted:
        scripts.append(script)
        anchor = ANCHOR_SCRIPTS.get(script)
        if anchor is not None and anchor not in wanted:
            scripts.append(anchor)
    for script in scripts:
        if progress:
            print(f"bnerr bench --suite {suite.name}: {script} ...", flush=True)
        module = importlib.import_module(f"benchmarks.{script}")
        figures[script] = _jsonable(module.measure())
        summaries[script] = _summary(module.measure)
    text = json.dumps(figures, indent=1, sort_keys=True) + "\n"
    with atomic_write(out / "speed.json") as tmp:
        Path(tmp).write_text(text)
    # the tables from the file as written (sorted keys), so --report-only gives the same bytes
    return _write_markdown(suite, out, json.loads(text), summaries)


def _write_markdown(
    suite: Suite, out: Path, figures: Mapping[str, Any], summaries: Mapping[str, str]
) -> str:
    text = speed_markdown(suite, figures, summaries)
    with atomic_write(out / "speed.md") as tmp:
        Path(tmp).write_text(text)
    return text


def _read_figures(suite: Suite, path: Path) -> dict[str, Any]:
    """The figures of ``speed.json`` at ``path``, each under a script the suite runs."""
    try:
        figures = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise FileFormatError(f"{path}: expected the speed suite's figures, got: {err}") from err
    if not isinstance(figures, dict):
        raise FileFormatError(f"{path}: expected a JSON object, got {type(figures).__name__}")
    known = set(suite.scripts) | set(ANCHOR_SCRIPTS.values())
    unknown = sorted(set(figures) - known)
    if unknown:
        raise FileFormatError(
            f"{path}: expected figures of the scripts {sorted(known)}, got {', '.join(unknown)}"
        )
    return figures


def rewrite_speed_report(suite: Suite, out_dir: str | Path) -> str:
    """Rewrite ``speed.md`` from the figures in ``out_dir/speed.json`` without measuring (after a
    change to the tables); the summaries come from the scripts' ``measure`` docstrings.

    Raises:
        FileFormatError: ``speed.json`` is missing or not the speed suite's JSON object.
    """
    out = Path(out_dir)
    figures = _read_figures(suite, out / "speed.json")
    summaries = {
        script: _summary(importlib.import_module(f"benchmarks.{script}").measure)
        for script in figures
    }
    return _write_markdown(suite, out, figures, summaries)
