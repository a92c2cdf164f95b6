"""Tests of benchmarks.sweep.runner: the whole sweep end to end (tuning, timings, references,
resume, refusing to discard finished cells).

Everything renders with the real path tracer and denoisers at 16x12 so that the whole file runs
in seconds.
"""

import dataclasses
import json
import shutil

import pytest
import torch

from benchmarks.reports.table import csv_text, summarize
from benchmarks.suites import Condition
from benchmarks.sweep import runner
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.plan import Cell, plan
from benchmarks.sweep.records import (
    RESULTS_FILE,
    Record,
    ResultsExistError,
    load_records,
    write_records,
)
from benchmarks.sweep.runner import run_suite
from bnerr.errors import FileFormatError, ValueRangeError
from tests._suites import tiny_suite

pytestmark = pytest.mark.usefixtures("one_thread")


class _Counting:
    """Wraps the renderer: counts calls and can fail after a number of them (an interruption)."""

    def __init__(self, render, fail_after=None):
        self.render, self.calls, self.fail_after = render, 0, fail_after

    def __call__(self, *args, **kwargs):
        if self.fail_after is not None and self.calls >= self.fail_after:
            raise KeyboardInterrupt("simulated interruption")
        self.calls += 1
        return self.render(*args, **kwargs)


def _parts(**changes):
    return dataclasses.replace(real_parts(), **changes)


# -- end to end ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """One uninterrupted run of the tiny suite: (output dir, cache dir, records, render count)."""
    out = tmp_path_factory.mktemp("out")
    cache = tmp_path_factory.mktemp("cache")
    counting = _Counting(real_parts().render)
    records = run_suite(
        tiny_suite(), out, parts=_parts(render=counting), cache_dir=cache, progress=False
    )
    return out, cache, records, counting.calls


def test_every_cell_gets_a_record_with_per_frame_pairs(tiny):
    out, _, records, _ = tiny
    assert len(records) == 2 * 2  # strategies x denoisers
    assert load_records(out) == records
    for rec in records:
        assert isinstance(rec, Record) and isinstance(rec.cell, Cell)
        assert rec.key == rec.cell.key()
        assert rec.t == [1, 2]  # warmup frame 0 is rendered, not measured
        assert set(rec.raw) == set(rec.den) == set(tiny_suite().sweeps[0].metrics)
        s = torch.tensor(rec.raw["mse"])
        assert s.shape == (2, 2, 2) and torch.all(
            s[..., 1] == 3 * 16 * 12
        )  # [seed sets, frames, 2]
        assert rec.dimensions == 4
        assert rec.reference.spp == 16 and rec.reference.floor > 0
        assert rec.reference.version == real_parts().code_version


def test_raw_metrics_are_shared_by_the_cells_of_a_run_and_denoisers_differ(tiny):
    _, _, records, _ = tiny
    white = [r for r in records if r.cell.strategy == "white"]
    assert white[0].raw == white[1].raw
    assert white[0].den["mse"] != white[1].den["mse"]


def test_timings_cover_render_permutation_and_denoise(tiny):
    _, _, records, _ = tiny
    for rec in records:
        for name in ("render_ms", "perm_ms", "denoise_ms"):
            values = torch.tensor(getattr(rec.timings, name))
            assert values.shape == (2, 2) and bool((values >= 0).all())
        assert min(min(row) for row in rec.timings.render_ms) > 0


def test_denoisers_are_tuned_once_on_white_noise_and_shared(tiny):
    out, _, records, _ = tiny
    stored = json.loads((out / runner.TUNED_PARAMS_FILE).read_text())["entries"]
    key = "direct/m1/owen_sobol/16x12"
    for name in ("gaussian", "median"):
        params = stored[name][key]["1"]["params"]
        assert all(r.denoiser_params == params for r in records if r.cell.denoiser == name)


def test_forget_cells_drops_the_runs_cells_of_the_denoisers_and_their_parameters_only(
    tiny, tmp_path
):
    out, _, records, _ = tiny
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    white = plan(tiny_suite(strategies=("white",)))  # the suite narrowed by an override
    gone = [r.key for r in records if r.cell.denoiser == "median" and r.cell.strategy == "white"]
    assert gone and runner.forget_cells(copy, white, {"median"}) == len(gone)
    assert [r.key for r in load_records(copy)] == [r.key for r in records if r.key not in gone]
    stored = json.loads((copy / runner.TUNED_PARAMS_FILE).read_text())["entries"]
    assert "median" not in stored and stored["gaussian"]  # its one scene and spp went
    assert runner.forget_cells(copy, white, {"median"}) == 0
    every = plan(tiny_suite())
    assert runner.forget_cells(copy, every, {"median"}) == len(gone)  # temporal's, this time
    assert runner.forget_cells(tmp_path / "empty", every, {"median"}) == 0  # nothing there


def test_references_are_cached_per_measured_frame(tiny):
    _, cache, _, renders = tiny
    assert len(list(cache.rglob("*.exr"))) == 2  # frames 1 and 2; the warmup frame needs none
    # 2 references + 2 white tuning frames + per seed set: white's 2 measured frames (stateless:
    # its warmup is skipped) and temporal's warmup and 2 measured frames
    assert renders == 2 + 2 + 2 * (2 + 3)


def test_rerun_with_resume_measures_nothing(tiny):
    out, cache, records, _ = tiny
    counting = _Counting(real_parts().render)
    again = run_suite(
        tiny_suite(),
        out,
        parts=_parts(render=counting),
        cache_dir=cache,
        resume=True,
        progress=False,
    )
    assert counting.calls == 0 and again == records


def test_the_tables_of_a_tiny_run_have_the_flicker_columns(tiny, tmp_path):
    # 16x12, 2 seed sets x 2 measured frames: one pair of frames per seed set after denoising.
    _, _, records, _ = tiny
    rows = summarize(records)
    text = csv_text(rows)
    header = text.splitlines()[0].split(",")
    for column in ("den_tmse", "den_tmse_lo", "den_tmse_ratio_hi", "den_mse_tavg_ratio"):
        assert column in header
    temporal = [r for r in rows if r["strategy"] == "temporal"]
    assert all(r["den_tmse"] > 0 and r["den_tmse_ratio"] > 0 for r in temporal)
    for rec in records:  # the first measured frame of each seed set has no frame before it
        assert [frame[0][1] for frame in rec.den["tmse"]] == [0.0, 0.0]


def test_resume_warns_when_kept_cells_lack_a_metric_and_does_not_measure_them(tiny, tmp_path):
    _, cache, records, _ = tiny
    old = [
        dataclasses.replace(
            r,
            raw={k: v for k, v in r.raw.items() if k != "tmse"},
            den={k: v for k, v in r.den.items() if k != "tmse"},
        )
        for r in records
    ]  # written before the metric existed
    write_records(tmp_path, old)
    counting = _Counting(real_parts().render)
    with pytest.warns(UserWarning, match=r"without tmse \(4 cells\).*--overwrite"):
        kept = run_suite(
            tiny_suite(), tmp_path, parts=_parts(render=counting), cache_dir=cache,
            resume=True, progress=False,
        )  # fmt: skip
    assert counting.calls == 0 and kept == old
    assert all(r["den_tmse"] is None for r in summarize(kept))  # not measured, not a crash


def test_an_interrupted_run_resumes_to_the_same_results(tiny, tmp_path):
    _, cache, records, _ = tiny
    # References are cached: 2 tuning frames + 2 x 2 white frames, then the temporal run dies.
    parts = _parts(render=_Counting(real_parts().render, fail_after=6))
    with pytest.raises(KeyboardInterrupt):
        run_suite(tiny_suite(), tmp_path, parts=parts, cache_dir=cache, progress=False)
    partial = load_records(tmp_path)
    assert len(partial) == 2 and {r.cell.strategy for r in partial} == {"white"}
    done = run_suite(
        tiny_suite(), tmp_path, parts=_parts(), cache_dir=cache, resume=True, progress=False
    )
    strip = lambda recs: sorted((r.key, r.raw, r.den, r.denoiser_params) for r in recs)  # noqa: E731
    assert strip(done) == strip(
        records
    )  # bit-identical metrics: renders and seeds are deterministic


def test_a_resume_that_measures_one_denoiser_again_keeps_the_others_crops(tiny, tmp_path):
    import numpy as np

    _, cache, _, _ = tiny
    run_suite(tiny_suite(), tmp_path, cache_dir=cache, progress=False)
    crops = sorted((tmp_path / "crops").glob("*.npz"))
    before = {p.name: dict(np.load(p)) for p in crops}
    results = tmp_path / RESULTS_FILE
    kept = [line for line in results.read_text().splitlines() if '"median"' not in line]
    results.write_text("\n".join(kept) + "\n")  # the median's cells to measure again
    done = run_suite(tiny_suite(), tmp_path, cache_dir=cache, resume=True, progress=False)
    assert {r.cell.denoiser for r in done} == {"gaussian", "median"}
    for path in crops:
        after = dict(np.load(path))
        assert sorted(after) == sorted(before[path.name])  # the gaussian's crops are still there
        assert all(np.array_equal(after[k], before[path.name][k]) for k in after), path.name


def test_the_appended_results_file_is_the_one_a_full_rewrite_gives(tiny, tmp_path):
    from benchmarks.sweep.records import write_records

    out, _, records, _ = tiny
    write_records(tmp_path, records)
    assert (out / RESULTS_FILE).read_bytes() == (tmp_path / RESULTS_FILE).read_bytes()


def test_a_run_resumes_after_an_append_cut_short(tiny, tmp_path):
    out, cache, records, _ = tiny
    data = (out / RESULTS_FILE).read_bytes()
    (tmp_path / RESULTS_FILE).write_bytes(data[: len(data) - 40])  # the last line torn
    counting = _Counting(real_parts().render)
    with pytest.warns(UserWarning, match="cut short"):
        done = run_suite(
            tiny_suite(), tmp_path, parts=_parts(render=counting), cache_dir=cache, resume=True,
            progress=False,
        )  # fmt: skip
    assert counting.calls > 0  # the torn cell's run is measured again
    strip = lambda recs: [(r.key, r.raw, r.den, r.denoiser_params) for r in recs]  # noqa: E731
    assert strip(done) == strip(records) and strip(load_records(tmp_path)) == strip(records)
    assert len(load_records(tmp_path)) == len(records)  # nothing lost, nothing twice


def test_a_resume_that_kept_a_later_run_writes_the_file_in_plan_order(tiny, tmp_path):
    # a Ray sweep killed after its temporal run finished first kept only that run's cells
    out, cache, records, _ = tiny
    lines = (out / RESULTS_FILE).read_bytes().splitlines(keepends=True)
    (tmp_path / RESULTS_FILE).write_bytes(b"".join(lines[2:]))
    assert {r.cell.strategy for r in load_records(tmp_path)} == {"temporal"}
    run_suite(tiny_suite(), tmp_path, cache_dir=cache, resume=True, progress=False)
    strip = lambda recs: [(r.key, r.raw, r.den, r.denoiser_params) for r in recs]  # noqa: E731
    assert strip(load_records(tmp_path)) == strip(records)  # white first, as uninterrupted


def test_a_fresh_run_refuses_a_folder_with_finished_cells_unless_told_to_overwrite(tiny, tmp_path):
    out, cache, records, _ = tiny
    (tmp_path / RESULTS_FILE).write_bytes((out / RESULTS_FILE).read_bytes())
    before = (tmp_path / RESULTS_FILE).read_bytes()
    counting = _Counting(real_parts().render)
    with pytest.raises(
        ResultsExistError, match=r"expected no finished cells .* got 4; pass --resume"
    ):
        run_suite(
            tiny_suite(), tmp_path, parts=_parts(render=counting), cache_dir=cache, progress=False
        )
    assert counting.calls == 0 and (tmp_path / RESULTS_FILE).read_bytes() == before
    again = run_suite(
        tiny_suite(), tmp_path, parts=_parts(), cache_dir=cache, overwrite=True, progress=False
    )
    strip = lambda recs: sorted((r.key, r.raw, r.den) for r in recs)  # noqa: E731
    assert strip(again) == strip(records)


def test_resume_from_a_garbled_results_file_names_the_file_and_line(tmp_path):
    good = b'{"key": 1}\n'  # not reached: the bad line comes first
    (tmp_path / RESULTS_FILE).write_bytes(b"\n\xff\xfe\x00garbage\n" + good)
    with pytest.raises(
        FileFormatError, match=r"cells.jsonl: expected UTF-8 JSON records, got bad bytes on line 2"
    ):
        run_suite(
            tiny_suite(),
            tmp_path,
            parts=_parts(),
            cache_dir=tmp_path / "c",
            resume=True,
            progress=False,
        )


def test_static_scenes_share_one_reference_and_edges_restrict_pixels(tmp_path):
    cache = tmp_path / "cache"
    suite = tiny_suite(
        strategies=("white",),
        denoisers=("gaussian",),
        conditions=(Condition(motion=0), Condition(motion=0, region="edges")),
    )
    records = run_suite(suite, tmp_path / "out", parts=_parts(), cache_dir=cache, progress=False)
    assert len(list(cache.rglob("*.exr"))) == 1
    counts = {r.cell.region: torch.tensor(r.raw["mse"])[..., 1] for r in records}
    assert bool((counts["edges"] < counts["all"]).all()) and bool((counts["edges"] > 0).all())


def test_stateful_denoisers_run_end_to_end_and_resume_to_the_same_output(tmp_path):
    cache = tmp_path / "cache"
    suite = tiny_suite(strategies=("white",), denoisers=("taa", "gaussian"), warmup=2)
    records = run_suite(suite, tmp_path / "a", parts=_parts(), cache_dir=cache, progress=False)
    taa = next(r for r in records if r.cell.denoiser == "taa")
    assert taa.denoiser_params and torch.tensor(taa.den["mse"]).shape == (2, 2, 2)
    # taa saw white's warmup frames: its output at the first measured frame is not the raw frame
    assert taa.den["mse"] != taa.raw["mse"]
    # a second sweep whose first pass died resumes to the same output (reset per seed set)
    (tmp_path / "b").mkdir()
    only_gauss = [r for r in records if r.cell.denoiser == "gaussian"]
    from benchmarks.sweep.records import write_records

    write_records(tmp_path / "b", only_gauss)
    again = run_suite(
        suite, tmp_path / "b", parts=_parts(), cache_dir=cache, resume=True, progress=False
    )
    assert sorted((r.key, r.raw, r.den) for r in again) == sorted(
        (r.key, r.raw, r.den) for r in records
    )


def test_own_tuning_column_beside_the_fair_one(tmp_path):
    suite = tiny_suite(denoisers=("gaussian", "gaussian:own"))
    out = tmp_path / "out"
    records = run_suite(suite, out, parts=_parts(), cache_dir=tmp_path / "c", progress=False)
    by = {(r.cell.strategy, r.cell.denoiser): r for r in records}
    assert len(by) == 4
    # white's own frames are the fair tuning's frames: same parameters, same output
    assert by["white", "gaussian:own"].denoiser_params == by["white", "gaussian"].denoiser_params
    assert by["white", "gaussian:own"].den == by["white", "gaussian"].den
    stored = json.loads((out / runner.TUNED_PARAMS_FILE).read_text())["entries"]
    own = stored["gaussian:own"]["direct/m1/owen_sobol/16x12/temporal"]["1"]["params"]
    assert by["temporal", "gaussian:own"].denoiser_params == own
    assert set(stored["gaussian"]) == {"direct/m1/owen_sobol/16x12"}


def test_resume_refuses_cells_measured_on_another_device(tiny, tmp_path):
    out, cache, records, _ = tiny
    where = {"device": "cuda:0", "name": "GPU", "torch": torch.__version__, "cuda": ""}
    write_records(tmp_path, [dataclasses.replace(r, device=where) for r in records])
    with pytest.raises(ValueRangeError, match=r"expected kept cells measured on cpu to resume on "
                       r"cpu, got .* measured on cuda:0 \(GPU\)"):  # fmt: skip
        run_suite(tiny_suite(), tmp_path, cache_dir=cache, resume=True, progress=False)


def test_records_measured_off_the_cpu_say_where(tiny, tmp_path, monkeypatch):
    out, cache, records, _ = tiny
    where = {"device": "cuda:0", "name": "GPU", "torch": torch.__version__, "cuda": ""}
    monkeypatch.setattr(runner, "device_info", lambda device: where)
    kept = run_suite(tiny_suite(), tmp_path, cache_dir=cache, progress=False)
    assert [r.device for r in kept] == [where] * len(records)
    assert [(r.key, r.raw, r.den) for r in kept] == [(r.key, r.raw, r.den) for r in records]
