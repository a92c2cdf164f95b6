"""``bnerr bench --scenes examples/mitsuba_temporal.xml`` in a subprocess: a Mitsuba 3 XML scene
with a camera path (``mitsuba_temporal.camera.toml``) through a tiny suite, white and temporal,
every denoiser SCENE_FILES.md says runs on Mitsuba's buffers; Mitsuba renders the frames and
the references. Skips with its reason where Mitsuba's llvm_ad_rgb variant cannot run (no
Mitsuba, or an LLVM older than 19)."""

import csv
import math
import os
import subprocess
import sys

import pytest

from denoisers.oidn import available_denoisers
from renderers import mitsuba_render as mr
from tests._paths import ROOT

REASON = mr.unavailable_reason("llvm_ad_rgb")
#: The denoisers docs/SCENE_FILES.md says were checked on Mitsuba's frames (issue 54: only the
#: Gaussian was run), oidn where its package is installed.
CHECKED = ("gaussian", "atrous", "svgf", "taa", "joint_bilateral", "guided")
DENOISERS = available_denoisers([*CHECKED, "oidn"])
COMMAND = (
    "bench --suite quick --scenes examples/mitsuba_temporal.xml --strategies white temporal "
    f"--denoisers {' '.join(DENOISERS)} --spp 1 --frames 2 --warmup 1 --seed-sets 1 "
    "--reference-spp 16 --res 16x16 --quiet --no-charts"
)


@pytest.mark.skipif(REASON is not None, reason=f"Mitsuba 3 llvm_ad_rgb unusable here: {REASON}")
def test_a_mitsuba_xml_scene_runs_through_a_suite(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    args = [*COMMAND.split(), "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", *args],
        env=env, cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader((tmp_path / "out" / "table.csv").open()))
    cells = {(r["scene"], r["strategy"], r["denoiser"]) for r in rows}
    assert {("mitsuba_temporal", s, d) for s in ("white", "temporal") for d in DENOISERS} <= cells
    assert set(CHECKED) <= set(DENOISERS)
    for row in rows:  # each denoiser gave a finite, measured result on Mitsuba's buffers
        assert float(row["den_mse"]) > 0 and math.isfinite(float(row["den_mse"])), row
    references = sorted((tmp_path / "cache" / "mitsuba_temporal").glob("*.exr"))
    assert len(references) == 3  # frames 0-2 (warmup 1, 2 measured), Mitsuba's version in the key
    assert all("_mitsuba-" in path.name for path in references)
    records = (tmp_path / "out" / "cells.jsonl").read_text()
    assert '"bnerr.scenes:mitsuba_temporal"' in records and "sha256:" in records
