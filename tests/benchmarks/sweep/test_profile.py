"""Tests of benchmarks.sweep.profile: a task's parts add up to its time, and each run counts the
seed sets its cells reached."""

import dataclasses

import pytest

from benchmarks.suites import Suite, Sweep
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.plan import plan
from benchmarks.sweep.profile import PARTS, main, profile_seed_set, seed_sets_reached
from benchmarks.sweep.records import write_records
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.tuning import make_denoisers
from bnerr.errors import ValueRangeError
from tests._records import metric_pairs, small_record

pytestmark = pytest.mark.usefixtures("one_thread")


def _run(**changes):
    sweep = Sweep(scenes=("direct",), strategies=("white",), spp=(1,),
                  denoisers=("gaussian", "taa"), frames=2, warmup=2, res=(16, 16),
                  reference_spp=4, seed_sets=1)  # fmt: skip
    (run,) = plan(Suite("t", "t", sweeps=(sweep,)))
    return dataclasses.replace(run, **changes)


def test_the_parts_of_a_task_add_up_to_its_time(tmp_path):
    parts = real_parts()
    run = _run()
    denoisers = make_denoisers(parts, dict.fromkeys(run.denoisers))
    seconds = profile_seed_set(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    assert list(seconds) == [*PARTS, "other", "total"]
    # every part ran: the stateful taa was fed the warmup frames, which the stateless white
    # strategy rendered for it
    assert all(seconds[part] > 0 for part in ("render", "warmup denoise", "denoise", "metrics"))
    assert all(value >= 0 for value in seconds.values())
    assert sum(v for k, v in seconds.items() if k != "total") == pytest.approx(seconds["total"])


def test_each_run_counts_the_seed_sets_its_cells_reached(tmp_path):
    run = _run()
    pairs = {"mse": metric_pairs([[1.0, 1.0]] * 8)}
    reached = small_record("white", "gaussian", raw=pairs, den=pairs, frames=2, seed_sets=8, spp=1)
    cell = dataclasses.replace(
        reached.cell, **{f: getattr(run, f) for f in ("warmup", "reference_spp")}
    )
    write_records(tmp_path, [dataclasses.replace(reached, cell=cell)])
    other = dataclasses.replace(run, strategy="ldbn", seed_sets=3)
    assert seed_sets_reached([run, other], tmp_path) == [8, 3]  # ldbn has no record: the plan's


def test_every_must_be_a_positive_count(tmp_path):
    with pytest.raises(ValueRangeError, match="--every: expected an integer >= 1, got 0"):
        main(["--results", str(tmp_path), "--every", "0"])
