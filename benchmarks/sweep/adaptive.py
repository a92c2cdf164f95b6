"""``bnerr bench --until-resolved``: seed sets added in batches only where a verdict is open.

Every run of the suite gets a group-sequential design (:mod:`bnerr.metrics.sequential`): looks
at its seed sets, then doubled (or ``batch`` more) up to ``cap``, fixed before the first seed
set and recorded with its cells (``Record.looks``). The looks' sizes are
:func:`bnerr.metrics.sequential.looks`: from the suite's ``n_1`` seed sets, ``n_1, 2 n_1, 4 n_1,
..., cap`` (4, 8, 16, 32 at 4 seed sets and the default cap; the last look is the cap itself, so
4 seed sets and a cap of 24 look at 4, 8, 16, 24), or ``n_1, n_1 + batch, ..., cap``; the
boundary spends ``alpha / K`` at each of these K looks, and each look's records hold exactly its
``n_k`` seed sets. After each round the decision table's verdict of every cell
(:func:`benchmarks.reports.decision.cell_verdicts`: the lowest strategy against white, corrected
for the best of m and for the look) is computed from the records of that round's look; the runs
of a scene, condition and spp with an open cell are planned again at the next look, the others
keep theirs, and :func:`benchmarks.sweep.runner.run_suite` (or the Ray runner) measures what is
missing, appending to the same ``cells.jsonl`` as ``--resume``.

**Seed sets are kept between looks** (:mod:`benchmarks.sweep.reuse`): seed set g is the same
render at every look, so a run at its next look renders only its new seed sets (``n_{k-1} ..
n_k - 1``) and joins them to its records of the previous look. A cell that goes from 4 to the cap
of 32 costs 32 seed sets, not 4 + 8 + 16 + 32 = 60.

Each look's records stay in the file (the key of a cell holds its seed sets), so an interrupted
run resumes to the same verdicts: the rounds are replayed from the records of each look, and
only the missing ones are measured. The reports show each cell's last look
(:func:`benchmarks.sweep.records.final_records`), and regenerate from the file as any run's. A
folder compacted for keeping (``bnerr bench --report-only --compact``, as the committed
``results/`` are) holds each cell's last look only; a resumed run replays the earlier rounds
from it (:func:`benchmarks.sweep.records.earlier_look`: a look's seed sets are the first rows of
every later look's), so resuming it measures nothing that was measured.

**A larger cap, resumed** (``--resume`` with a ``--seed-set-cap`` above the finished run's): the
folder's records were judged under the old design (``Record.looks``, 4 and 8 at a cap of 8),
whose boundaries spend ``alpha / 2`` at each look; keeping them while the new looks spend
``alpha / 3`` would spend more than alpha in all. :func:`redesign` therefore puts every kept
record under the new design (4, 8, 16) before the first round, and writes the file so, and the
rounds judge every look again at the new boundaries: the verdicts are those a run planned at the
larger cap from its first seed set would give, since its seed sets are the same renders, and
only the new seed sets are measured. Raising the cap after seeing a run's verdicts is still a
decision taken on the data, at the level of the whole suite; the records say which design they
were judged under. A design whose looks up to a record's seed sets differ from the record's (a
new ``--batch``) is refused: its looks are other counts than those measured.

Not for: the statistics (:mod:`bnerr.metrics.sequential`) or measuring a run
(:mod:`benchmarks.sweep.runner`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from benchmarks.reports.decision import cell_verdicts
from benchmarks.reports.groups import group_key
from benchmarks.reports.table import summarize
from benchmarks.suites import Suite
from benchmarks.sweep.plan import Run, plan
from benchmarks.sweep.records import (
    Record,
    bare_key,
    earlier_look,
    final_records,
    load_records,
    write_records,
)
from benchmarks.sweep.runner import run_suite
from bnerr.errors import ValueRangeError
from bnerr.metrics.sequential import looks

__all__ = ["DEFAULT_CAP", "adaptive_runs", "grow", "redesign", "run_until_resolved"]

#: The default cap on seed sets: what a 2 % difference needs at the median spread
#: (``bnerr.metrics.power``: about 30).
DEFAULT_CAP = 32

Measure = Callable[..., list[Record]]


def adaptive_runs(suite: Suite, cap: int, batch: int | None = None) -> list[Run]:
    """The suite's runs at their first look, each with its design's looks.

    Raises:
        ValueRangeError: a run with fewer than 2 seed sets, or more than ``cap``; a design of
            more than :data:`bnerr.metrics.sequential.MAX_LOOKS` looks.
    """
    runs = plan(suite)
    for run in runs:
        if not 2 <= run.seed_sets <= cap:
            raise ValueRangeError(
                f"--until-resolved: expected 2 <= seed sets <= the cap {cap} in every run, got "
                f"{run.seed_sets} ({run.label})"
            )
    try:
        designs = {n: looks(n, cap, batch) for n in {r.seed_sets for r in runs}}
    except ValueRangeError as err:  # too many looks: name the options that asked for them
        given = f"--seed-set-cap {cap}" + (f" --batch {batch}" if batch else "")
        raise ValueRangeError(f"{given}: {err}") from None
    return [dataclasses.replace(r, looks=designs[r.seed_sets]) for r in runs]


def _open_cells(
    runs: Sequence[Run], records: Sequence[Record], regions: Sequence[str] = ()
) -> set[tuple]:
    """The (group key, spp, denoiser) of the cells whose verdict is open at the runs' current
    looks, judged on the records of exactly those looks; with ``regions``, only the cells of
    those pixel regions count (the others' verdicts are read, not pursued)."""
    planned = {c.key() for run in runs for c in run.cells()}
    current = [r for r in records if r.key in planned and r.has_pixels]
    verdicts = cell_verdicts(summarize(current))
    return {
        key
        for key, (said, _) in verdicts.items()
        if said == "open" and (not regions or key[0][3] in regions)
    }


def grow(
    runs: Sequence[Run],
    records: Sequence[Record],
    regions: Sequence[str] = (),
    stop_settled: bool = False,
) -> list[Run]:
    """The runs of the next round: those with a cell whose verdict is open (in one of
    ``regions``, or in any region when empty), and not yet at their cap, at their next look;
    the others as they are. ``stop_settled``: a grown run keeps only the denoisers with an open
    cell, so a settled cell keeps the look that settled it (and a run left without a stateful
    denoiser skips its warmup frames, as any stateless run does)."""
    open_cells = _open_cells(runs, records, regions)
    open_groups = {(group, spp) for group, spp, _ in open_cells}
    out = []
    for run in runs:
        keys = {(group_key(dataclasses.asdict(c)), c.spp) for c in run.cells()}
        if keys & open_groups and run.seed_sets < run.looks[-1]:
            later = [n for n in run.looks if n > run.seed_sets]
            kept = run.denoisers
            if stop_settled:
                kept = tuple(d for d in kept if any((*k, d) in open_cells for k in keys))
            run = dataclasses.replace(run, seed_sets=later[0], denoisers=kept)
        out.append(run)
    return out


def _replayed(runs: Sequence[Run], kept: Sequence[Record]) -> tuple[list[Run], list[Record]]:
    """``runs`` split into those to measure and the records of those a compacted file holds at a
    later look only (:func:`benchmarks.sweep.records.earlier_look` of each of their cells)."""
    have = {r.key for r in kept}
    latest = {bare_key(r.cell): r for r in final_records(kept) if r.looks}
    todo: list[Run] = []
    replayed: list[Record] = []
    for run in runs:
        cells = run.cells()
        later = [latest.get(bare_key(c)) for c in cells]
        if any(c.key() in have for c in cells) or not all(
            r is not None and run.seed_sets in (r.looks or ()) and r.cell.seed_sets > run.seed_sets
            for r in later
        ):
            todo.append(run)
            continue
        replayed += [earlier_look(r, run.seed_sets) for r in later if r is not None]
    return todo, replayed


def _under(record: Record, design: tuple[int, ...]) -> Record:
    """``record`` judged under ``design``: its looks replaced, when the looks it was measured
    at (those up to its seed sets) are ``design``'s.

    Raises:
        ValueRangeError: ``design`` does not look at the record's seed sets, or looks at other
            counts before them.
    """
    old = list(record.looks or ())
    n = record.cell.seed_sets
    if old == list(design):
        return record
    if n not in design or [k for k in old if k <= n] != [k for k in design if k <= n]:
        raise ValueRangeError(
            f"--until-resolved --resume: expected a design that looks at the measured seed sets "
            f"{[k for k in old if k <= n]} of {record.cell.strategy}/{record.cell.denoiser} "
            f"({record.cell.scene}, {record.cell.spp} spp) first, got the looks {list(design)}; "
            "keep the run's --batch, or start a new --out"
        )
    return dataclasses.replace(record, looks=list(design))


def redesign(runs: Sequence[Run], kept: Sequence[Record]) -> list[Record]:
    """``kept`` with every adaptive record of a cell of ``runs`` judged under its run's design
    (``Run.looks``): a finished run resumed at a larger cap is judged again, at every look, at
    the new design's boundaries (see the module's notes); the others as they are.

    Raises:
        ValueRangeError: a record measured at looks the new design does not take.
    """
    design = {bare_key(c): run.looks for run in runs for c in run.cells()}
    return [
        _under(r, design[bare_key(r.cell)]) if r.looks and bare_key(r.cell) in design else r
        for r in kept
    ]


def _kept(out_dir: str | Path) -> list[Record]:
    """The records a resumed run starts from (a torn tail dropped quietly: the runner warns as it
    drops it again)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_records(out_dir, torn_tail=True)


def _measure_round(
    measure: Measure,
    suite: Suite,
    out_dir: str | Path,
    runs: Sequence[Run],
    kept: list[Record],
    **options: Any,
) -> tuple[list[Record], list[Record]]:
    """The records the folder holds after ``measure`` of the runs at their current look, and
    the records replayed, never measured, for the runs that ``kept`` (what the folder held
    before) has at a later look only, as a compacted file does."""
    todo, replayed = _replayed(runs, kept)
    if not replayed:
        return measure(suite, out_dir, runs=runs, **options), []
    return (measure(suite, out_dir, runs=todo, **options) if todo else kept), replayed


def run_until_resolved(
    suite: Suite,
    out_dir: str | Path,
    *,
    cap: int = DEFAULT_CAP,
    batch: int | None = None,
    measure: Measure = run_suite,
    resume: bool = False,
    overwrite: bool = False,
    resolve: Sequence[str] | None = None,
    stop_settled: bool | None = None,
    **options: Any,
) -> list[Record]:
    """Measure ``suite`` at its seed sets, then add seed sets (doubling, or ``batch`` more) to the
    runs with an open verdict until none is open or each is at ``cap``; return every record.

    ``resolve``: the pixel regions whose open verdicts add seed sets (None: the suite's
    ``Suite.resolve``; empty: every region). The other regions' cells are measured on the same
    renders and keep their verdicts, at the seed sets their runs reached. ``stop_settled``
    (None: the suite's ``Suite.stop_settled``): a settled cell gets no more seed sets although
    its run grows for another cell (:func:`grow`).

    Args:
        measure: :func:`benchmarks.sweep.runner.run_suite` or a function like it (the Ray
            runner), called once per round with ``runs``.
        resume, overwrite: the first round's, as ``run_suite``; the later rounds resume.
        options: passed to ``measure`` (parts, cache_dir, progress, ...).
    """
    runs = adaptive_runs(suite, cap, batch)
    regions = tuple(suite.resolve if resolve is None else resolve)
    stop = suite.stop_settled if stop_settled is None else stop_settled
    first = {"resume": resume, "overwrite": overwrite}
    held = _kept(out_dir) if resume else []
    judged = redesign(runs, held)
    if judged != held:  # a larger cap: the file says which design its verdicts are under
        write_records(out_dir, judged)
        held = judged
    held, replayed = _measure_round(measure, suite, out_dir, runs, held, **first, **options)
    while True:
        grown = grow(runs, held + replayed, regions, stop)
        if grown == runs:
            return held + replayed
        runs = grown
        # what the folder holds is what the last round returned: the file is not read again
        later = {"resume": True, "overwrite": False}
        held, replayed = _measure_round(measure, suite, out_dir, runs, held, **later, **options)
