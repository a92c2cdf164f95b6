"""``bnerr bench`` runs the OpenQMC rivals end to end: a tiny smoke run (16x16, one seed set,
two frames) through the tracer, the denoiser and the tables."""

from __future__ import annotations

import csv

from benchmarks.cli import main


def test_bench_runs_the_openqmc_rivals(tmp_path):
    out = tmp_path / "out"
    args = [
        "bench", "--suite", "quick", "--scenes", "direct",
        "--strategies", "white,openqmc_sobolbn,openqmc_latticebn", "--spp", "2",
        "--denoisers", "gaussian", "--frames", "2", "--warmup", "0", "--res", "16x16",
        "--reference-spp", "4", "--seed-sets", "1", "--out", str(out),
        "--cache", str(tmp_path / "cache"), "--quiet", "--no-charts",
    ]  # fmt: skip
    assert main(args) == 0
    tables = sorted(out.rglob("*.csv"))
    assert tables, "bench wrote no table"
    text = "".join(p.read_text() for p in tables)
    assert "openqmc_sobolbn" in text and "openqmc_latticebn" in text
    rows = [r for p in tables for r in csv.DictReader(p.open())]
    assert rows
