"""Tests of ``bnerr eval``'s measuring (benchmarks.commands.eval.evaluate) on synthetic frame
folders: the records are the sweep's (white first, every denoiser x region), frames are read and
never rendered, a stateful denoiser sees the warmup frames, the denoisers are tuned on the held-out
seed set when there is one, and the notes (one seed set, default parameters). The agreement with
``bnerr bench`` on frames of bnerr's tracer: tests/benchmarks/commands/eval/test_command.py."""

import pytest
import torch

from benchmarks.commands.eval.evaluate import (
    FolderReferences,
    FolderStrategy,
    default_metrics,
    evaluate,
    folder_parts,
    folder_runs,
)
from benchmarks.commands.eval.frame_folder import FrameFolder, frame_name
from benchmarks.sweep.records import load_records
from benchmarks.sweep.tuning import TUNING_SEED_SET
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.metrics import METRIC_TABLE
from tests._frame_folders import synthetic_folder

pytestmark = pytest.mark.usefixtures("one_thread")

_TEMPORAL = {
    "motion": torch.zeros(2, 8, 8),
    "depth": torch.ones(1, 8, 8),
    "normal": torch.tensor([0.0, 0.0, 1.0])[:, None, None].expand(3, 8, 8).contiguous(),
    "object_id": torch.zeros(1, 8, 8),
}


def test_every_method_becomes_a_run_white_first_with_the_table_metrics(tmp_path):
    folder = FrameFolder(synthetic_folder(tmp_path, methods=["mine", "white"], static=True))
    runs = folder_runs(folder.manifest, ["gaussian"], default_metrics())
    assert [r.strategy for r in runs] == ["white", "mine"]
    assert {(r.motion, r.width, r.seed_sets, r.frames, r.crops) for r in runs} == {
        (0, 8, 2, 2, True)
    }
    assert default_metrics() == tuple(n for n, m in dict(METRIC_TABLE).items() if m.default)


def test_evaluate_writes_the_sweeps_records(tmp_path):
    records, notes = evaluate(synthetic_folder(tmp_path / "f"), tmp_path / "out")
    assert [(r.cell.strategy, r.cell.denoiser, r.cell.region) for r in records] == [
        ("white", "gaussian", "all"),
        ("mine", "gaussian", "all"),
    ]
    assert load_records(tmp_path / "out") == records
    r = records[1]
    assert len(r.raw["mse"]) == 2 and len(r.raw["mse"][0]) == 2 and r.t == [0, 1]
    assert set(r.raw) == set(default_metrics()) and r.spectrum["raw"].power
    assert r.reference.version.startswith("eval-") and r.crop == "crops/" + r.crop.split("/")[1]
    assert notes == ["no tuning_seed_set in the manifest: the denoisers keep their defaults"]
    assert r.denoiser_params == records[0].denoiser_params  # the default ones, for both


def test_one_seed_set_says_the_intervals_need_two(tmp_path):
    _, notes = evaluate(synthetic_folder(tmp_path / "f", seed_sets=["a"]), tmp_path / "out")
    assert "one seed set: the intervals over seed sets need two" in notes[0]


def test_the_parts_read_the_folder_and_never_render(tmp_path):
    folder = FrameFolder(synthetic_folder(tmp_path, tuning_seed_set="tune"))
    parts = folder_parts(folder)
    strategy = parts.make_strategy("mine", None, 8, 8, 1, "owen_sobol", 1)
    assert isinstance(strategy, FolderStrategy) and strategy.seed_set == "1"
    assert parts.make_strategy("white", None, 8, 8, TUNING_SEED_SET, "x", 1).seed_set == "tune"
    frame = strategy.frame(1, parts.render)
    assert torch.equal(frame.color, folder.frame("mine", "1", 1).color)
    with pytest.raises(ValueRangeError, match="got a render call"):
        parts.render(None, 0, torch.zeros(8, 8), None, 1)
    with pytest.raises(ValueRangeError, match="expected a seed set in \\[0, 2\\)"):
        parts.make_strategy("mine", None, 8, 8, 2, "owen_sobol", 1)
    refs = FolderReferences(folder)
    assert refs.get(None, None, 1) is refs.get(None, None, 1)


def test_a_stateful_denoiser_sees_the_warmup_frames(tmp_path):
    root = synthetic_folder(tmp_path / "f", warmup=1, layers=_TEMPORAL, buffers=list(_TEMPORAL))
    (root / "mine" / "1" / frame_name(0)).unlink()  # a warmup frame
    records, _ = evaluate(root, tmp_path / "a")  # gaussian reads only the measured frames
    assert records[0].t == [1, 2]
    with pytest.raises(FileFormatError, match="mine/1/0000.exr: expected a frame"):
        evaluate(root, tmp_path / "b", denoisers=["taa"])
    assert not (tmp_path / "b" / "cells.jsonl").exists()


def test_the_denoisers_are_tuned_on_the_held_out_seed_set(tmp_path):
    root = synthetic_folder(tmp_path / "f", tuning_seed_set="tune")
    records, notes = evaluate(root, tmp_path / "a", denoisers=["gaussian", "gaussian:own"])
    fair = {r.cell.strategy: r.denoiser_params for r in records if r.cell.denoiser == "gaussian"}
    assert fair["white"] == fair["mine"] and notes == []
    for path in (root / "mine" / "tune").iterdir():
        path.unlink()
    with pytest.raises(FileFormatError, match="mine/tune/0000.exr: expected a frame"):
        evaluate(root, tmp_path / "b", denoisers=["gaussian:own"])
    evaluate(root, tmp_path / "c", denoisers=["gaussian"])  # white's tuning frames suffice


def test_own_tuning_needs_a_tuning_seed_set(tmp_path):
    with pytest.raises(ValueRangeError, match="gaussian:own: expected a tuning_seed_set"):
        evaluate(synthetic_folder(tmp_path / "f"), tmp_path / "out", denoisers=["gaussian:own"])


def test_the_render_cost_is_the_frames_bnerr_timings_else_0(tmp_path):
    """docs/EVAL.md: a frame whose header holds ``bnerr_timings`` has that render time recorded,
    one without it reads 0 (issue 54: no test checked either)."""
    from bnerr.frame import Frame
    from bnerr.io import read_frame, write_frame

    root = synthetic_folder(tmp_path / "f")
    for t in range(2):  # mine's frames carry their render time, white's carry none
        for seed_set in ("0", "1"):
            path = root / "mine" / seed_set / frame_name(t)
            frame = read_frame(path)
            write_frame(path, Frame(color=frame.color, timings={"render": 12.5 + t}))
    records, _ = evaluate(root, tmp_path / "out")
    render = {r.cell.strategy: r.timings.render_ms for r in records}
    assert render["white"] == [[0.0, 0.0], [0.0, 0.0]]
    assert render["mine"] == [[12.5, 13.5], [12.5, 13.5]]


def test_flicker_is_not_measured_with_one_frame(tmp_path):
    """docs/EVAL.md: the flicker metrics compare consecutive measured frames, so with ``frames =
    1`` they are not measured: no pair holds a pixel, and the table's columns are empty."""
    from benchmarks.reports.table import summarize

    root = synthetic_folder(tmp_path / "f", frames=1)
    records, _ = evaluate(root, tmp_path / "out")
    for record in records:
        for kind in (record.raw, record.den):
            for name in ("tmse", "trelmse", "mse_tavg"):
                assert all(pair[1] == 0 for frames in kind[name] for pair in frames), name
            assert any(pair[1] > 0 for frames in kind["mse"] for pair in frames)
    for row in summarize(records):
        assert row["den_tmse"] is None and row["den_mse_tavg"] is None
        assert row["den_mse"] is not None
