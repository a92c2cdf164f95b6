"""``bnerr eval`` on frames the C example (examples/native/tracer.c) wrote itself: the commands of
docs/EVAL.md's "Try it" block run as written, the tracer's ``--layout`` mode writes a folder
``bnerr eval`` accepts, and the ordering the seed protocol shows for the same program holds:
``ldbn`` below white after a Gaussian at 1 spp beyond its interval, raw MSE within white's.

Measured (64x64, 1 spp, 4 seed sets x 2 frames, reference 512 spp): post-Gaussian MSE / white's,
ldbn 0.59 [0.51, 0.69]; through ``bnerr bench --renderer-cmd`` 0.60 [0.55, 0.67]. About 15 s of
CPU beyond the shared build and export (one eval of 64x64 frames, torch's import included).
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.commands.eval.frame_folder import FrameFolder
from benchmarks.sweep.records import load_records
from bnerr.metrics import better, paired_ratio
from tests._native import BUILD_LINES, EVAL_DOC, PROTOCOL_DOC, doc_commands, run_line

_LEVEL = 0.95
_FOLDER = "frames-native"


@pytest.fixture(scope="module")
def evaluated(native_example):
    """The example's folder where the eval page's layout and eval commands have run."""
    for line in doc_commands(EVAL_DOC)[BUILD_LINES:]:
        run_line(line, native_example)
    return native_example / _FOLDER


def test_the_page_builds_as_the_protocol_page_then_writes_and_evaluates_the_folder():
    lines = doc_commands(EVAL_DOC)
    assert lines[:BUILD_LINES] == doc_commands(PROTOCOL_DOC)[:BUILD_LINES]
    assert lines[2].startswith(f"examples/native/tracer --layout {_FOLDER} ")
    assert lines[3].startswith(f"bnerr eval {_FOLDER} ")


def test_the_tracer_writes_the_documented_layout(evaluated):
    folder = FrameFolder(evaluated)
    m = folder.manifest
    assert (m.methods, m.seed_sets, m.frames, m.spp) == (("white", "ldbn"), tuple("0123"), 2, 1)
    assert (m.width, m.height, m.static, m.tuning_seed_set) == (64, 64, True, "tune")
    frame = folder.frame("ldbn", "3", 1)
    assert frame.albedo is not None and frame.object_id is not None
    assert frame.timings["render"] > 0
    assert folder.reference(0).color.mean() > 0


def _ratio(records, kind: str):
    cells = {
        r.cell.strategy: r
        for r in records
        if r.cell.region == "all" and r.cell.denoiser == "gaussian"
    }
    values, white = (np.asarray(getattr(cells[s], kind)["mse"]) for s in ("ldbn", "white"))
    return paired_ratio(values, white, level=_LEVEL)


def test_eval_of_the_native_frames_shows_the_seed_protocols_ordering(evaluated):
    records = load_records(evaluated / "results")
    assert {r.cell.scene for r in records} == {"native"}
    ratio = _ratio(records, "den")
    assert better(ratio), f"ldbn / white after a Gaussian = {ratio}"
    raw = _ratio(records, "raw")
    assert raw.lo <= 1.0 <= raw.hi, f"ldbn / white raw = {raw}"
    assert all(ms > 0 for r in records for frames in r.timings.render_ms for ms in frames)
