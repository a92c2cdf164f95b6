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
import sys

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


#: A renderer that writes colour only (seed / 2^32 in grey), as a new user's first one does.
COLOR_ONLY = """
import struct, sys
import numpy as np, OpenEXR
seeds, out = sys.argv[1:3]
data = open(seeds, 'rb').read()
_, _, w, h, k, _ = struct.unpack_from('<4s5I', data)
s = np.frombuffer(data, '<u4', offset=24).reshape(k, h, w)[0]
r = np.ascontiguousarray(0.5 + (s / 2**32 - 0.5) * 0.2, dtype=np.float32)
OpenEXR.File({'type': OpenEXR.scanlineimage}, {'R': r, 'G': r, 'B': r}).write(out)
"""


def test_a_colour_only_renderer_runs_the_default_bench_without_its_regions(
    tmp_path, capsys, monkeypatch
):
    """Issue 54: with the default ``buffers = ["color"]`` the quick suite stopped after 7 frames
    ("expected an object_id buffer for region 'coherent'"); the coherent region is left out and
    said once, the scene is named after the script, not ``python``."""
    (tmp_path / "grey.py").write_text(COLOR_ONLY)
    monkeypatch.chdir(tmp_path)
    command = f"{sys.executable} grey.py {{seeds}} {{out}} {{spp}}"
    args = [
        "bench", "--suite", "quick", "--renderer-cmd", command,
        "--strategies", "white", "temporal", "--spp", "1", "--denoisers", "gaussian",
        "--res", "8x8", "--frames", "1", "--warmup", "1", "--seed-sets", "2",
        "--reference-spp", "2", "--out", str(tmp_path / "o"), "--cache", str(tmp_path / "c"),
        "--quiet", "--no-charts",
    ]  # fmt: skip
    assert main(args) == 0, capsys.readouterr().err
    err = capsys.readouterr().err
    notes = [line for line in err.splitlines() if "left out the region" in line]
    assert len(notes) == 1 and "coherent" in notes[0] and "object_id" in notes[0], err
    records = load_records(tmp_path / "o")
    assert {r.cell.scene for r in records} == {"grey"}
    assert {r.cell.region for r in records} == {"all"}
