"""``bnerr bench --renderer-cmd`` / ``--renderer``: the C example of examples/native/ driven through
the seed protocol, with the commands of docs/RENDERER_PROTOCOL.md run as written, and the
ordering bnerr's own tracer shows on its ``direct`` scene: after a Gaussian at 1 spp, ``temporal``,
``ldbn`` and the oracle below white beyond their intervals, raw MSE within white's.

Measured (64x64, 1 spp, 4 seed sets x 3 frames, reference 512 spp; the figures of the doc page):
post-Gaussian MSE / white's, temporal 0.74 [0.62, 0.89], ldbn 0.31 [0.27, 0.36], oracle 0.26
[0.23, 0.30]. The whole test takes about a minute (two benches, one C build, one export).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.sweep.records import load_records
from bnerr.metrics import better, paired_ratio
from tests._native import BUILD_LINES, PROTOCOL_DOC, doc_commands, run_line

_LEVEL = 0.95


@pytest.fixture(scope="module")
def native(native_example):
    """The example's folder where the doc's bench commands have run as written."""
    for line in doc_commands(PROTOCOL_DOC)[BUILD_LINES:]:
        run_line(line, native_example)
    return native_example


def _ratio(records, strategy: str, kind: str):
    cells = {
        r.cell.strategy: r
        for r in records
        if r.cell.region == "all" and (kind == "raw" or r.cell.denoiser == "gaussian")
    }
    values, white = (np.asarray(getattr(cells[s], kind)["mse"]) for s in (strategy, "white"))
    return paired_ratio(values, white, level=_LEVEL)


def test_the_doc_commands_build_the_tracer_and_export_the_keys_it_reads():
    lines = doc_commands(PROTOCOL_DOC)
    assert lines[0].startswith("cc ") and "examples/native/tracer.c" in lines[0]
    assert lines[1].startswith("bnerr export --ldbn screen --format h")
    assert "--renderer-cmd" in lines[2] and "--renderer examples/native/renderer.toml" in lines[3]


@pytest.mark.slow
@pytest.mark.parametrize("strategy", ["temporal", "ldbn", "oracle"])
def test_the_native_renderer_shows_bnerr_ordering_after_a_gaussian(native, strategy):
    records = load_records(native / "out" / "native")
    assert {r.cell.scene for r in records} == {"tracer"}
    ratio = _ratio(records, strategy, "den")
    assert better(ratio), f"{strategy} / white after a Gaussian = {ratio}"
    raw = _ratio(records, strategy, "raw")
    assert raw.lo <= 1.0 <= raw.hi, f"{strategy} / white raw = {raw}"


@pytest.mark.slow
def test_the_manifest_runs_the_same_renderer_and_records_its_time_as_the_render_cost(native):
    records = load_records(native / "out" / "native_manifest")
    assert {r.cell.scene for r in records} == {"native"}
    assert {r.cell.strategy for r in records} == {"white", "ldbn"}
    assert {r.render_sampler for r in records} == {"owen_sobol", "ldbn"}
    for record in records:
        assert all(ms > 0 for frames in record.timings.render_ms for ms in frames), record.timings


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--renderer-cmd", "tracer 'open"], "expected a command line, got No closing quotation"),
        (["--renderer-cmd", "cat {seeds}"], r"expected the placeholder\(s\) \{seeds\}, \{out\}"),
        (
            ["--renderer-cmd", "cat {seeds} {out} {spp}", "--scenes", "direct"],
            "--scenes: expected ",
        ),
        (["--renderer", "missing.toml"], "expected a renderer manifest file, got no such file"),
    ],
)
def test_a_wrong_renderer_is_one_error_line_before_any_work(tmp_path, capsys, extra, message):
    code = main(["bench", "--suite", "quick", "--out", str(tmp_path / "o"), "--quiet", *extra])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("bnerr bench: error: "), err
    assert re.search(message, err), err
    assert not (tmp_path / "o" / "cells.jsonl").exists()
