"""Where a suite's worker time goes: seed sets of its runs measured part by part, scaled to the
seed sets its results took.

``python -m benchmarks.sweep.profile --suite quality --results results/quality --every 3``
measures seed set 0 of every third run of the suite's plan, serially in this process, under
:mod:`cProfile`, and splits each task's time into the parts of
:func:`benchmarks.sweep.measure.measure_seed_set`:

- ``render``: the strategy's frames (its renders and its own work, warmup frames included), the
  time spent inside :func:`bnerr.strategies.play`;
- ``warmup denoise``: the stateful denoisers fed the warmup frames;
- ``denoise``: the denoisers on the measured frames;
- ``metrics``: every image's metrics in every pixel region;
- ``spectra``: the error spectra of the charts;
- ``references``: reading the references from the cache;
- ``other``: the rest of the task (masks, crops, merging).

Each sampled run stands for itself and the ``every - 1`` runs after it; a run's part times are
multiplied by the seed sets its cells reached in ``--results`` (the adaptive design's last look),
so the table is an estimate of the worker-minutes of that run of the suite. The profiler adds a
few per cent, mostly to the Python-heavy parts; the shares are what it is for. Tuning and Ray's
overhead lie outside the tasks: the wall time times the workers, less the table's total, is their
share.

Not for: the speed of each part at 1080p (the ``speed`` suite).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks.suites import get_suite
from benchmarks.sweep.measure import measure_seed_set
from benchmarks.sweep.parts import Parts, real_parts
from benchmarks.sweep.plan import Run, plan
from benchmarks.sweep.records import bare_key, final_records, load_records
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.runner import TUNED_PARAMS_FILE, load_params
from benchmarks.sweep.tuning import tune_denoisers
from bnerr.errors import ValueRangeError
from bnerr.io import atomic_write

__all__ = ["PARTS", "profile_seed_set", "seed_sets_reached"]

#: The parts of a task, and the function of benchmarks.sweep.measure whose time each one is.
PARTS: dict[str, tuple[str, str]] = {
    "render": ("bnerr/strategies/base.py", "play"),
    "warmup denoise": ("benchmarks/sweep/measure.py", "feed_warmup"),
    "denoise": ("benchmarks/sweep/measure.py", "denoise_frame"),
    "metrics": ("benchmarks/sweep/measure.py", "_update_regions"),
    "spectra": ("benchmarks/sweep/measure.py", "_spectrum"),
    "references": ("benchmarks/sweep/references.py", "get"),
}


def profile_seed_set(
    run: Run, parts: Parts, references: ReferenceCache, denoisers: dict, group: int = 0
) -> dict[str, float]:
    """Seconds per part (:data:`PARTS`, then ``other`` and ``total``) of measuring seed set
    ``group`` of ``run`` (:func:`benchmarks.sweep.measure.measure_seed_set`)."""
    profiler = cProfile.Profile()
    start = time.perf_counter()
    profiler.runcall(measure_seed_set, run, parts, references, denoisers, group)
    total = time.perf_counter() - start
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    seconds = {}
    for part, (path, name) in PARTS.items():
        seconds[part] = sum(
            row[3]  # cumulative time: recursion and a generator's resumptions counted once
            for (file, _, func), row in stats.items()
            if func == name and file.endswith(path)
        )
    seconds["other"] = max(total - sum(seconds.values()), 0.0)
    seconds["total"] = total
    return seconds


def seed_sets_reached(runs: Sequence[Run], results: str | Path) -> list[int]:
    """The seed sets each run's cells reached in the records of ``results`` (the most of any of
    its cells; the plan's own count for a run with none there)."""
    most: dict[str, int] = {}
    for r in final_records(load_records(results)):
        key = bare_key(r.cell)
        most[key] = max(most.get(key, 0), r.cell.seed_sets)
    return [
        max((most.get(bare_key(c), 0) for c in run.cells()), default=0) or run.seed_sets
        for run in runs
    ]


def _table(rows: dict[str, float], wall: float | None, workers: int) -> str:
    total = rows["total"]
    lines = ["| part | worker-minutes | share |", "|---|---|---|"]
    for part, minutes in rows.items():
        if part != "total":
            lines.append(f"| {part} | {minutes:.1f} | {minutes / total:.0%} |")
    lines.append(f"| **tasks in all** | **{total:.1f}** | |")
    if wall is not None:
        outside = wall * workers - total
        lines.append(f"| outside the tasks ({workers} x {wall:.1f} min wall) | {outside:.1f} | |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="quality")
    parser.add_argument("--results", required=True, help="the suite's results folder")
    parser.add_argument("--every", type=int, default=1, help="profile every Nth run of the plan")
    parser.add_argument("--cache", default="cache/references")
    parser.add_argument("--wall", type=float, help="the run's wall minutes, to show the rest")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", help="also write the table's numbers as JSON here")
    args = parser.parse_args(argv)
    if args.every < 1:
        raise ValueRangeError(f"--every: expected an integer >= 1, got {args.every}")
    runs = plan(get_suite(args.suite))
    reached = seed_sets_reached(runs, args.results)
    parts = real_parts()
    references = ReferenceCache(args.cache, parts)
    store = load_params(Path(args.results) / TUNED_PARAMS_FILE)
    minutes = dict.fromkeys([*PARTS, "other", "total"], 0.0)
    # one task first, not counted: a worker pays the first imports and caches once, not per task
    measure_seed_set(
        runs[0], parts, references, tune_denoisers(runs[0], parts, references, store), 0
    )
    for i in range(0, len(runs), args.every):
        run, weight = runs[i], sum(reached[i : i + args.every])
        denoisers = tune_denoisers(run, parts, references, store)
        seconds = profile_seed_set(run, parts, references, denoisers)
        for part, value in seconds.items():
            minutes[part] += value * weight / 60
        print(f"{run.label}: {seconds['total']:.2f} s x {weight} seed sets", flush=True)
    print(_table(minutes, args.wall, args.workers))
    if args.out:
        with atomic_write(args.out) as tmp:
            tmp.write_text(json.dumps(minutes, indent=1) + "\n")


if __name__ == "__main__":
    main()
