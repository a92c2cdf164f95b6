"""Tests of benchmarks.sweep.reuse: a look renders only its new seed sets and joins them to the
previous look's records, which then hold what one render of all its seed sets would; counted by
a render part that records its calls, on the tiny suite's real 16x12 renders."""

from __future__ import annotations

import dataclasses
import math

import pytest

from benchmarks.sweep import adaptive
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.plan import plan
from benchmarks.sweep.records import DIGITS, Record, final_records
from benchmarks.sweep.reuse import earlier_look, extend, with_reuse
from benchmarks.sweep.runner import run_suite
from bnerr.errors import ValueRangeError
from tests._records import metric_pairs, small_record
from tests._suites import tiny_suite

pytestmark = pytest.mark.usefixtures("one_thread")


def _counting():
    """The real parts with a render that counts its calls."""
    parts = real_parts()
    calls: list[int] = []
    counted = dataclasses.replace(
        parts, render=lambda *a, **k: calls.append(1) or parts.render(*a, **k)
    )
    return counted, calls


def _runs(seed_sets: int, looks: tuple[int, ...]):
    suite = tiny_suite(denoisers=("gaussian",), seed_sets=2)
    return suite, [dataclasses.replace(r, seed_sets=seed_sets, looks=looks) for r in plan(suite)]


def _by_cell(records: list[Record], seed_sets: int) -> dict[tuple, Record]:
    return {
        (r.cell.strategy, r.cell.denoiser, r.cell.region): r
        for r in records
        if r.cell.seed_sets == seed_sets
    }


def test_the_next_look_renders_only_its_new_seed_sets_and_equals_one_render(tmp_path):
    cache = tmp_path / "cache"
    suite, at2 = _runs(2, (2, 4))
    _, at4 = _runs(4, (2, 4))
    parts, calls = _counting()
    run_suite(suite, tmp_path / "refs", parts=parts, cache_dir=cache, progress=False)
    start = len(calls)  # the references are cached now; each folder tunes its denoisers once
    run_suite(suite, tmp_path / "a", runs=at2, parts=parts, cache_dir=cache, progress=False)
    first = len(calls) - start  # tuning + 2 seed sets
    grown = run_suite(
        suite, tmp_path / "a", runs=at4, parts=parts, cache_dir=cache, progress=False, resume=True
    )
    second = len(calls) - start - first  # seed sets 2 and 3 only
    whole = run_suite(suite, tmp_path / "b", runs=at4, parts=parts, cache_dir=cache, progress=False)
    assert second > 0 and len(calls) - start - first - second == first + second  # tuning + 4
    joined, fresh = _by_cell(grown, 4), _by_cell(whole, 4)
    assert joined.keys() == fresh.keys() and joined
    for name, record in joined.items():
        other = fresh[name]
        assert record.key == other.key and record.looks == [2, 4]
        assert all(len(rows) == 4 for rows in record.raw.values())  # the look's size
        assert (record.raw, record.den, record.tcorr, record.coverage, record.crop) == (
            other.raw, other.den, other.tcorr, other.coverage, other.crop
        )  # fmt: skip
        assert len(record.timings.render_ms) == 4
        # The spectra are means, joined by weight from the previous look's mean, which the
        # record kept at DIGITS significant digits: equal to within one unit of the last digit.
        for kind, spectrum in record.spectrum.items():
            assert spectrum.freq == other.spectrum[kind].freq
            assert all(
                math.isclose(a, b, rel_tol=10 ** (1 - DIGITS))
                for a, b in zip(spectrum.power, other.spectrum[kind].power, strict=True)
            )


def test_an_adaptive_run_to_the_cap_costs_the_cap_not_the_sum_of_its_looks(tmp_path, monkeypatch):
    """Every cell kept open: looks 2, 4, 8 render 8 seed sets per run, not 2 + 4 + 8."""
    decided = adaptive.cell_verdicts
    monkeypatch.setattr(
        adaptive,
        "cell_verdicts",
        lambda rows: {k: ("open", n) for k, (_, n) in decided(rows).items()},
    )
    cache = tmp_path / "cache"
    suite = tiny_suite(denoisers=("gaussian",), seed_sets=2)
    parts, calls = _counting()
    run_suite(suite, tmp_path / "warm", parts=parts, cache_dir=cache, progress=False)  # refs
    warm = len(calls)
    records = adaptive.run_until_resolved(
        suite, tmp_path / "out", cap=8, parts=parts, cache_dir=cache, progress=False
    )
    adaptive_calls = len(calls) - warm
    _, at8 = _runs(8, (2, 4, 8))
    run_suite(suite, tmp_path / "one", runs=at8, parts=parts, cache_dir=cache, progress=False)
    assert adaptive_calls == len(calls) - warm - adaptive_calls  # tuning + 8 seed sets, as one run
    assert sorted({r.cell.seed_sets for r in records}) == [2, 4, 8]
    assert all(len(rows) == 8 for r in final_records(records) for rows in r.raw.values())


def test_reuse_needs_every_cell_at_the_previous_look_and_the_same_code():
    _, at4 = _runs(4, (2, 4))
    run = dataclasses.replace(at4[0], regions=("all",))
    assert earlier_look(run) == 2 and earlier_look(dataclasses.replace(run, looks=())) is None
    assert earlier_look(dataclasses.replace(run, seed_sets=2)) is None
    kept = {r.key: r for r in [_stub(run, 2, [1.0, 2.0])]}
    assert with_reuse(run, kept, "test") == dataclasses.replace(run, reuse=2)
    assert with_reuse(run, kept, "changed") == run  # another renderer: all seed sets again
    assert with_reuse(run, {}, "test") == run
    joined = extend(dataclasses.replace(run, reuse=2), [_stub(run, 4, [3.0, 4.0])], kept)
    assert joined[0].raw == {"mse": metric_pairs([[v] * run.frames for v in (1, 2, 3, 4)])}
    assert joined[0].cell.seed_sets == 4
    with pytest.raises(ValueRangeError, match="at 2 seed sets, got none"):
        extend(dataclasses.replace(run, reuse=2), [_stub(run, 4, [3.0, 4.0])], {})


def _stub(run, seed_sets: int, levels: list[float]) -> Record:
    """A record of ``run``'s first cell at the look of ``seed_sets``, holding one seed set of
    flat MSE per ``levels`` (the look's new seed sets only, as the runner measures them)."""
    pairs = metric_pairs([[v] * run.frames for v in levels])
    record = small_record(
        run.strategy, "gaussian", raw={"mse": pairs}, den={"mse": pairs}, frames=run.frames,
        seed_sets=len(levels),
    )  # fmt: skip
    cell = dataclasses.replace(run.cells()[0], seed_sets=seed_sets)
    return dataclasses.replace(record, cell=cell)
