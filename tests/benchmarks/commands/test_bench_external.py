"""``bnerr bench`` with the shipped example executable denoiser, by its manifest as a fresh clone
has it (``examples/external_denoiser/manifest.toml``), and with scene files: the shipped
``examples/scenes/direct.toml`` (the shipped scene ``direct`` itself) and a changed copy under
its own name (a plug-in); a strategy file and a metric module beside them. Each command runs in a
subprocess. The denoiser's per-frame time reaches ``table.csv`` and the error-against-time chart
(the PNG and the page's SVG panel, a point per strategy); then ``--report-only`` and ``python -m
benchmarks.reports`` rebuild, in new processes, the report of those plug-ins byte for byte."""

import csv
import json
import re
import shutil
import textwrap
from pathlib import Path

import pytest

from tests._paths import EXAMPLES, bnerr_cli

STRATEGY = """
from bnerr.strategies import WhiteStrategy


class Mine(WhiteStrategy):
    name = "mine"
    family = "experimental"
    stream = 0x51A7E0FF
"""

METRIC = '''
def maxerr(pred, ref):
    """the largest absolute error"""
    return float((pred - ref).abs().max())
'''

MANIFEST = "examples/external_denoiser/manifest.toml"  # as a user types it in a clone
DENOISER = "example_joint_bilateral"
REPORT = ("table.csv", "table.md", "decision.md", "index.html")


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> Path:
    """A tiny suite measured once: 2 scenes x 2 strategies x 2 denoisers, 16x16, 2 frames."""
    tmp = tmp_path_factory.mktemp("external")
    (tmp / "strat.py").write_text(textwrap.dedent(STRATEGY))
    (tmp / "plugmetric.py").write_text(METRIC)
    scene = (EXAMPLES / "scenes" / "direct.toml").read_text()
    scene = scene.replace('name = "direct"', 'name = "my_direct"').replace(
        "radius = 6.0", "radius = 6.5"
    )
    (tmp / "my_direct.toml").write_text(scene)
    done = bnerr_cli(
        "bench", "--suite", "quick",
        "--scenes", "examples/scenes/direct.toml", str(tmp / "my_direct.toml"),
        "--strategies", f"{tmp / 'strat.py'}:Mine", "--denoisers", MANIFEST, "gaussian",
        "--metrics", "mse", "plugmetric:maxerr",
        "--spp", "1", "--frames", "2", "--warmup", "0", "--res", "16x16",
        "--reference-spp", "4", "--seed-sets", "1", "--out", str(tmp / "out"),
        "--cache", str(tmp / "cache"), "--quiet",
        path=[tmp],
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return tmp


def test_example_denoiser_and_scene_files_run_and_reach_the_chart(measured):
    out = measured / "out"
    rows = list(csv.DictReader((out / "table.csv").open()))
    cells = {(r["scene"], r["strategy"], r["denoiser"]) for r in rows}
    assert cells == {
        (scene, s, d)
        for scene in ("direct", "my_direct")
        for s in ("white", "mine")
        for d in (DENOISER, "gaussian")
    }
    for row in rows:  # the whole call per frame, the interpreter's start-up included
        if row["denoiser"] == DENOISER:
            assert float(row["denoise_ms"]) > 10 and float(row["total_ms"]) > 10
        assert row["raw_maxerr"] and row["den_maxerr"]
    # the chart: the plug-in is a key denoiser, drawn in the PNG and in the page's SVG panel
    assert (out / "error_vs_time_my_direct.png").is_file()
    page = (out / "index.html").read_text()
    panel = re.search(rf'<svg[^>]*aria-label="{DENOISER}">(.*?)</svg>', page).group(1)
    assert panel.count("<circle") == 2  # white and mine at 1 spp
    assert f"{DENOISER}</figcaption>" in page
    records = [json.loads(line) for line in (out / "cells.jsonl").read_text().splitlines()]
    plugins = {k: v["spec"] for r in records for k, v in (r.get("plugins") or {}).items()}
    assert plugins[f"bnerr.denoisers:{DENOISER}"] == MANIFEST
    assert plugins["bnerr.scenes:my_direct"] == str(measured / "my_direct.toml")
    assert "bnerr.scenes:direct" not in plugins  # the shipped scene's file is the shipped scene


def _report_copy(out: Path, to: Path) -> Path:
    to.mkdir()
    for name in REPORT:
        shutil.copy(out / name, to / name)
    return to


def test_report_only_in_a_new_process_rebuilds_the_plugins_report(measured, tmp_path):
    out = measured / "out"
    before = _report_copy(out, tmp_path / "before")
    for name in REPORT:
        (out / name).unlink()
    again = bnerr_cli("bench", "--out", str(out), "--report-only", "--quiet", path=[measured])
    assert again.returncode == 0, again.stderr
    assert "not loaded" not in again.stderr
    for name in REPORT:
        assert (out / name).read_bytes() == (before / name).read_bytes(), name


def test_reports_module_in_a_new_process_rebuilds_the_plugins_report(measured, tmp_path):
    out = measured / "out"
    before = _report_copy(out, tmp_path / "before")
    (out / "table.csv").unlink()
    again = bnerr_cli(str(out), program=("-m", "benchmarks.reports"), path=[measured])
    assert again.returncode == 0, again.stderr
    assert (out / "table.csv").read_bytes() == (before / "table.csv").read_bytes()
