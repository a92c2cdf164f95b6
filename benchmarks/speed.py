"""The speed suite: each timing script's ``measure()``, written to ``speed.json`` and ``speed.md``.

Each script of the suite (:attr:`benchmarks.suites.Suite.scripts`, e.g.
``benchmarks.speed_permute``) returns its figures as a (nested) dict; :func:`run_speed` stores them
as they come in ``speed.json`` and :func:`speed_markdown` lists every leaf value under its path in
``speed.md``, each script's section headed by the first paragraph of its ``measure()`` docstring
(what the figures are, with their units).

Not for: the per-cell sweeps (:mod:`benchmarks.runner`).
"""

from __future__ import annotations

import dataclasses
import importlib
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from benchmarks.suites import Suite
from bnerr.io import atomic_write

__all__ = ["run_speed", "speed_markdown"]


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


def speed_markdown(suite: Suite, figures: Mapping[str, Any], summaries: Mapping[str, str]) -> str:
    """The Markdown of ``speed.md``: one section per script, one table row per figure."""
    lines = [f"# bnerr bench --suite {suite.name}", "", suite.description, ""]
    for script, values in figures.items():
        summary = summaries.get(script, "")
        lines += [f"## {script}", ""]
        lines += [summary, ""] if summary else []
        lines += ["| figure | value |", "|---|---|"]
        lines += [f"| {path} | {value} |" for path, value in _leaves(values)]
        lines.append("")
    return "\n".join(lines)


def run_speed(suite: Suite, out_dir: str | Path, *, progress: bool = True) -> str:
    """Call ``measure()`` of every script of the speed suite; write ``speed.json`` and
    ``speed.md`` into ``out_dir``; return the Markdown."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, Any] = {}
    summaries: dict[str, str] = {}
    for script in suite.scripts:
        if progress:
            print(f"bnerr bench --suite {suite.name}: {script} ...", flush=True)
        module = importlib.import_module(f"benchmarks.{script}")
        figures[script] = _jsonable(module.measure())
        summaries[script] = _summary(module.measure)
    with atomic_write(out / "speed.json") as tmp:
        Path(tmp).write_text(json.dumps(figures, indent=1, sort_keys=True) + "\n")
    text = speed_markdown(suite, figures, summaries)
    with atomic_write(out / "speed.md") as tmp:
        Path(tmp).write_text(text)
    return text
