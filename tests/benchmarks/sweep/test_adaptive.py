"""Tests of benchmarks.sweep.adaptive (bnerr bench --until-resolved): seed sets added only where
a verdict is open, up to the cap, resumed to the same verdicts; with a stand-in measurement whose
effects are known, and end to end on the tiny suite's real renders."""

from __future__ import annotations

import dataclasses
import math
import zlib
from pathlib import Path

import pytest
import torch

from benchmarks.sweep import adaptive
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.plan import Run
from benchmarks.sweep.records import (
    Record,
    compact_records,
    final_records,
    load_records,
    write_records,
)
from benchmarks.sweep.runner import run_suite
from bnerr.errors import UnknownNameError, ValueRangeError
from tests._records import metric_pairs, small_record
from tests._suites import tiny_suite

# temporal's true ratio to white: far below at 1 spp (settled at the first look), equal in
# expectation at 4 spp with a 20 % seed-set spread (open to the cap)
EFFECT = {1: 0.5, 4: 1.0}


def _values(run: Run, group: int) -> list[float]:
    """One seed set's per-frame MSE: a seed-set effect (log-sd 0.2 at 4 spp; 0.002 at 1, since
    the first look's t quantile at 2 seed sets, df 1, is 51) on the strategy's true level, the
    same draws whatever the look (seed set g is the same render)."""
    gen = torch.Generator().manual_seed(zlib.crc32(f"{run.strategy} {run.spp} {group}".encode()))
    sd = 0.2 if run.spp == 4 else 0.002
    level = EFFECT[run.spp] if run.strategy == "temporal" else 1.0
    z = float(torch.randn(1, generator=gen, dtype=torch.float64))
    return [level * math.exp(sd * z + 0.01 * f) for f in range(run.frames)]


class _StandIn:
    """A ``run_suite`` stand-in: a results file in memory, resumed like the real one; counts the
    runs it measured per call."""

    def __init__(self, fail_after: int | None = None) -> None:
        self.records: dict[str, Record] = {}
        self.calls: list[list[tuple[str, int, int]]] = []
        self.fail_after = fail_after  # cells measured before an interruption

    def __call__(self, suite, out, *, runs, resume, overwrite, **options) -> list[Record]:
        if not resume:
            self.records.clear()
        elif Path(out).is_dir():  # a real folder: resumed from its file, as run_suite is
            self.records = {r.key: r for r in load_records(out)}
        measured = []
        for run in runs:
            for cell in run.cells():
                if cell.key() in self.records:
                    continue
                if self.fail_after is not None and len(self.records) >= self.fail_after:
                    raise KeyboardInterrupt("simulated interruption")
                pairs = metric_pairs([_values(run, g) for g in range(run.seed_sets)])
                rec = small_record(
                    run.strategy, cell.denoiser, raw={"mse": pairs}, den={"mse": pairs},
                    frames=run.frames, seed_sets=run.seed_sets,
                )  # fmt: skip
                self.records[cell.key()] = dataclasses.replace(
                    rec, cell=cell, looks=list(run.looks)
                )
                measured.append((run.strategy, run.spp, run.seed_sets))
        self.calls.append(measured)
        if Path(out).is_dir():
            write_records(out, self.records.values())
        return list(self.records.values())


def _suite():
    return tiny_suite(spp=(1, 4), denoisers=("gaussian",), seed_sets=2)


def test_seed_sets_are_added_only_where_the_verdict_is_open_up_to_the_cap():
    measure = _StandIn()
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=measure)
    final = {
        (r.cell.strategy, r.cell.spp): r.cell.seed_sets
        for r in final_records(measure.records.values())
    }
    # the large effect stops at the first look; the open cell goes 2 -> 4 -> 8 -> 16
    assert final == {("white", 1): 2, ("temporal", 1): 2, ("white", 4): 16, ("temporal", 4): 16}
    assert [sorted({c[2] for c in call}) for call in measure.calls] == [[2], [4], [8], [16]]
    assert all(r.looks == [2, 4, 8, 16] for r in measure.records.values())
    # resumed: the rounds replay from each look's records, nothing is measured again
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=measure, resume=True)
    assert all(call == [] for call in measure.calls[4:])


def test_only_the_resolved_regions_open_verdicts_add_seed_sets():
    # the tiny suite measures every pixel: resolving that region is the default design, and
    # resolving another region (none of its cells) stops at the first look with 4 spp open
    whole, scoped, other = _StandIn(), _StandIn(), _StandIn()
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=whole)
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=scoped, resolve=("all",))
    assert scoped.records == whole.records
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=other, resolve=("edges",))
    assert len(other.calls) == 1
    assert {r.cell.seed_sets for r in other.records.values()} == {2}
    # the suite's own resolve is the default, and --resolve overrides it
    suite = dataclasses.replace(_suite(), resolve=("edges",))
    own = _StandIn()
    adaptive.run_until_resolved(suite, "unused", cap=16, measure=own)
    assert own.records == other.records
    adaptive.run_until_resolved(suite, "unused", cap=16, measure=own, resolve=())
    assert own.records.keys() >= whole.records.keys()
    with pytest.raises(UnknownNameError):
        dataclasses.replace(_suite(), resolve=("lights",))


class _PerDenoiser(_StandIn):
    """The stand-in with a second denoiser, ``median``, on which every strategy is white noise
    with a 20 % seed-set spread at every spp (its cells open to the cap)."""

    def __call__(self, suite, out, *, runs, resume, overwrite, **options) -> list[Record]:
        super().__call__(suite, out, runs=runs, resume=resume, overwrite=overwrite)
        for key, rec in self.records.items():
            if rec.cell.denoiser == "median":
                spread = [_spread(rec.cell, g) for g in range(rec.cell.seed_sets)]
                self.records[key] = dataclasses.replace(rec, den={"mse": metric_pairs(spread)})
        return list(self.records.values())


def _spread(cell, group: int) -> list[float]:
    gen = torch.Generator().manual_seed(zlib.crc32(f"{cell.strategy} {cell.spp} {group}".encode()))
    z = float(torch.randn(1, generator=gen, dtype=torch.float64))
    return [math.exp(0.2 * z + 0.01 * f) for f in range(cell.frames)]


def test_a_settled_cell_keeps_its_look_when_its_run_grows_for_another():
    suite = tiny_suite(spp=(1, 4), denoisers=("gaussian", "median"), seed_sets=2)
    plain, stopping = _PerDenoiser(), _PerDenoiser()
    adaptive.run_until_resolved(suite, "unused", cap=8, measure=plain)
    adaptive.run_until_resolved(suite, "unused", cap=8, measure=stopping, stop_settled=True)

    def sets(measure):
        return {
            (r.cell.strategy, r.cell.spp, r.cell.denoiser): r.cell.seed_sets
            for r in final_records(measure.records.values())
        }

    # at 1 spp gaussian's cell is settled at the first look and median's is open: without
    # stopping both grow to the cap, with it gaussian's keeps its 2 seed sets
    assert sets(plain)[("temporal", 1, "gaussian")] == 8
    assert sets(stopping)[("temporal", 1, "gaussian")] == 2
    assert sets(stopping)[("white", 1, "gaussian")] == 2
    assert sets(stopping)[("temporal", 1, "median")] == 8
    assert sets(stopping)[("temporal", 4, "gaussian")] == 8  # open: grows as before
    # the records it keeps are the plain run's at that look, seed set for seed set
    kept = {r.key: r for r in stopping.records.values()}
    assert all(plain.records[k].den == r.den for k, r in kept.items())


def test_an_interrupted_run_resumes_to_the_same_verdicts():
    whole = _StandIn()
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=whole)
    cut = _StandIn(fail_after=5)  # 4 cells at 2 seed sets, then one of the 2 at 4
    with pytest.raises(KeyboardInterrupt):
        adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=cut)
    cut.fail_after = None
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=cut, resume=True)
    assert cut.records == whole.records


def test_a_larger_cap_resumed_judges_every_look_again_under_the_new_design(tmp_path):
    measure = _StandIn()
    adaptive.run_until_resolved(_suite(), tmp_path, cap=4, measure=measure)
    assert {r.cell.seed_sets for r in load_records(tmp_path)} == {2, 4}
    compact_records(tmp_path)  # as results/ keep it: the last looks only
    adaptive.run_until_resolved(_suite(), tmp_path, cap=16, measure=measure, resume=True)
    # only the new looks are measured, and every record is now under the cap-16 design
    assert [sorted({c[2] for c in call}) for call in measure.calls[2:]] == [[], [], [8], [16]]
    assert all(r.looks == [2, 4, 8, 16] for r in load_records(tmp_path))
    # the verdicts and records are those of a run planned at 16 from its first seed set (up
    # to the compaction's rounding)
    planned = _StandIn()
    adaptive.run_until_resolved(_suite(), "unused", cap=16, measure=planned)
    resumed = {r.key: r.rounded() for r in final_records(load_records(tmp_path))}
    assert resumed == {r.key: r.rounded() for r in final_records(planned.records.values())}


def test_a_resumed_design_must_look_at_the_measured_seed_sets(tmp_path):
    adaptive.run_until_resolved(_suite(), tmp_path, cap=4, measure=_StandIn())
    with pytest.raises(ValueRangeError, match=r"measured seed sets \[2, 4\].*looks \[2, 5"):
        adaptive.run_until_resolved(
            _suite(), tmp_path, cap=8, batch=3, measure=_StandIn(), resume=True
        )


def test_a_batch_adds_that_many_seed_sets_per_look():
    measure = _StandIn()
    adaptive.run_until_resolved(_suite(), "unused", cap=6, batch=2, measure=measure)
    assert [sorted({c[2] for c in call}) for call in measure.calls] == [[2], [4], [6]]


def test_the_seed_sets_must_fit_under_the_cap():
    with pytest.raises(ValueRangeError, match="cap 2"):
        adaptive.adaptive_runs(tiny_suite(seed_sets=3), cap=2)
    with pytest.raises(ValueRangeError, match="seed sets"):
        adaptive.adaptive_runs(tiny_suite(seed_sets=1), cap=8)


@pytest.mark.usefixtures("one_thread")
def test_end_to_end_on_real_renders_records_every_look_and_resumes(tmp_path):
    suite = tiny_suite(denoisers=("gaussian",), seed_sets=2)
    out, cache = tmp_path / "out", tmp_path / "cache"
    records = adaptive.run_until_resolved(
        suite, out, cap=4, cache_dir=cache, progress=False, measure=run_suite
    )
    assert load_records(out) == records
    assert {r.cell.seed_sets for r in records} <= {2, 4}
    assert all(r.looks == [2, 4] for r in records)
    final = final_records(records)
    assert len(final) == 2 and len({r.cell.seed_sets for r in final}) == 1
    parts = real_parts()
    calls = []
    counting = dataclasses.replace(
        parts, render=lambda *a, **k: calls.append(1) or parts.render(*a, **k)
    )
    again = adaptive.run_until_resolved(
        suite, out, cap=4, cache_dir=cache, progress=False, resume=True, parts=counting
    )
    assert again == records and not calls
    # Compacted for keeping (each cell's last look only): resumed, it replays the first look
    # from the last one's first rows, to the same verdicts, and measures nothing.
    compact_records(out)
    assert load_records(out) == final
    replayed = adaptive.run_until_resolved(
        suite, out, cap=4, cache_dir=cache, progress=False, resume=True, parts=counting
    )
    assert not calls and final_records(replayed) == final
    first_look = {r.key: r for r in records if r.cell.seed_sets == 2}
    for r in replayed:
        if r.key in first_look:  # the replayed look: the measured one's rows and verdict inputs
            assert (r.raw, r.den, r.tcorr, r.timings) == (
                first_look[r.key].raw, first_look[r.key].den, first_look[r.key].tcorr,
                first_look[r.key].timings,
            )  # fmt: skip
    assert load_records(out) == final  # nothing written back
