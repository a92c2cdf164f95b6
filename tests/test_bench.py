"""Tests of ``bnerr bench`` (benchmarks.commands.bench): overrides, outputs, resume, bad input."""

import json

import pytest

from benchmarks.cli import main


pytestmark = pytest.mark.usefixtures("one_thread")


def _args(tmp_path, *extra):
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white,temporal", "--spp", "1",
        "--denoisers", "gaussian", "--frames", "2", "--warmup", "1", "--res", "16x12",
        "--reference-spp", "8", "--seed-sets", "1", "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"),
        "--quiet", *extra,
    ]


def test_bench_writes_the_tables_and_charts_with_the_overrides(tmp_path, capsys):
    assert main(_args(tmp_path)) == 0
    out = tmp_path / "out"
    records = [json.loads(line) for line in (out / "cells.jsonl").read_text().splitlines()]
    assert sorted((r["cell"]["strategy"], r["cell"]["denoiser"]) for r in records) == [
        ("temporal", "gaussian"), ("white", "gaussian")]
    cell = records[0]["cell"]
    got = tuple(cell[k] for k in ("width", "height", "frames", "warmup", "reference_spp", "seed_sets"))
    assert got == (16, 12, 2, 1, 8, 1)
    assert (out / "table.csv").exists() and "### direct" in (out / "table.md").read_text()
    assert (out / "error_vs_time_direct.png").exists()
    assert f"results written to {out}" in capsys.readouterr().out


def test_bench_resume_keeps_the_results(tmp_path):
    assert main(_args(tmp_path, "--no-charts")) == 0
    before = (tmp_path / "out" / "cells.jsonl").read_text()
    assert main(_args(tmp_path, "--no-charts", "--resume")) == 0
    assert (tmp_path / "out" / "cells.jsonl").read_text() == before


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--res", "16", "--res: expected WIDTHxHEIGHT such as 128x128, got '16'"),
        ("--spp", "0", "--spp: expected an integer >= 1, got 0"),
        ("--scenes", "nowhere", "unknown scene 'nowhere'"),
        ("--strategies", "blue", "unknown strategy 'blue'"),
        ("--denoisers", "magic", "unknown denoiser 'magic'"),
    ],
)
def test_bench_reports_bad_overrides_as_errors(tmp_path, capsys, flag, value, message):
    args = _args(tmp_path)
    args[args.index(flag) + 1] = value
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_the_speed_suite_takes_no_cell_overrides(tmp_path, capsys):
    assert main(["bench", "--suite", "speed", "--spp", "4", "--out", str(tmp_path), "--quiet"]) == 2
    assert "--suite speed: expected no cell overrides (it runs timing scripts), got --spp" in capsys.readouterr().err
