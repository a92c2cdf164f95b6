"""Tests of ``bnerr bench`` (benchmarks.commands.bench): the overrides reach the cells, the
tables and charts are written, bad overrides are one-line errors, and the output folder rules: one
writer per folder (the lock), no silent discarding of finished cells (--overwrite), typed one-line
errors for a garbled results file."""

import dataclasses
import json
import sys

import pytest

from benchmarks.cli import main
from benchmarks.reports.links import broken_links
from benchmarks.sweep.records import RESULTS_ARCHIVE, RESULTS_FILE, load_records, write_records
from bnerr.outputs import output_lock
from tests._paths import RESULTS

pytestmark = pytest.mark.usefixtures("one_thread")


def _args(out, cache, *extra):
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white",
        "--spp", "1", "--denoisers", "gaussian", "--frames", "1", "--warmup", "0",
        "--res", "8x8", "--reference-spp", "4", "--seed-sets", "1", "--out", str(out),
        "--cache", str(cache), "--quiet", "--no-charts", *extra,
    ]  # fmt: skip


def _two_strategies(tmp_path, *extra):
    """A run of white and temporal on direct at 16x12 with every cell override given."""
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white,temporal",
        "--spp", "1", "--denoisers", "gaussian", "--frames", "2", "--warmup", "1",
        "--res", "16x12", "--reference-spp", "8", "--seed-sets", "1",
        "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"), "--quiet", *extra,
    ]  # fmt: skip


def test_bench_writes_the_tables_and_charts_with_the_overrides(tmp_path, capsys):
    assert main(_two_strategies(tmp_path)) == 0
    out = tmp_path / "out"
    records = [json.loads(line) for line in (out / RESULTS_FILE).read_text().splitlines()]
    got = sorted(
        (r["cell"]["strategy"], r["cell"]["denoiser"], r["cell"]["region"]) for r in records
    )
    # the named suites measure the coherent region beside each sweep's own (Suite.coherent)
    assert got == [
        (s, "gaussian", region) for s in ("temporal", "white") for region in ("all", "coherent")
    ]
    cell = records[0]["cell"]
    keys = ("width", "height", "frames", "warmup", "reference_spp", "seed_sets")
    assert tuple(cell[k] for k in keys) == (16, 12, 2, 1, 8, 1)
    assert (out / "table.csv").exists() and "### direct" in (out / "table.md").read_text()
    assert (out / "error_vs_time_direct.png").exists()
    assert f"results written to {out}" in capsys.readouterr().out


def test_bench_resume_keeps_the_results(tmp_path):
    assert main(_two_strategies(tmp_path, "--no-charts")) == 0
    before = (tmp_path / "out" / RESULTS_FILE).read_text()
    assert main(_two_strategies(tmp_path, "--no-charts", "--resume")) == 0
    assert (tmp_path / "out" / RESULTS_FILE).read_text() == before


def _marked(records, denoiser, value):
    """``records`` with every denoised metric of ``denoiser``'s cells set to ``value``."""
    out = []
    for r in records:
        if r.cell.denoiser == denoiser:
            den = {
                m: [[[value, w] for _, w in frames] for frames in sets] for m, sets in r.den.items()
            }
            r = dataclasses.replace(r, den=den)
        out.append(r)
    return out


def test_bench_remeasure_measures_one_denoiser_again_and_keeps_the_others(tmp_path, capsys):
    run = _two_strategies(tmp_path, "--no-charts")
    run[run.index("--denoisers") + 1] = "gaussian,atrous"
    assert main(run) == 0
    out = tmp_path / "out"
    measured = {r.key: r for r in load_records(out)}
    # stand-ins for cells measured by an older version of both denoisers
    write_records(out, _marked(_marked(measured.values(), "atrous", 7.0), "gaussian", 9.0))
    assert main([*run, "--remeasure", "atrous"]) == 0
    assert "discarded 4 cells of atrous" in capsys.readouterr().err
    again = {r.key: r for r in load_records(out)}
    assert set(again) == set(measured)
    for key, record in again.items():
        if record.cell.denoiser == "atrous":  # measured again: what the first run measured
            assert record.den == measured[key].den and record.raw == measured[key].raw
        else:  # kept as they were
            assert {v for frames in record.den["mse"] for v, _ in frames} == {9.0}


def test_bench_remeasure_names_a_denoiser_of_the_suite(tmp_path, capsys):
    assert main(_two_strategies(tmp_path, "--no-charts")) == 0
    before = (tmp_path / "out" / RESULTS_FILE).read_bytes()
    assert main(_two_strategies(tmp_path, "--no-charts", "--remeasure", "unet")) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "bnerr bench: error: --remeasure: expected denoisers of the suite (gaussian), got unet"
    )
    assert (tmp_path / "out" / RESULTS_FILE).read_bytes() == before


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--res", "16", "--res: expected WxH with integers (e.g. 320x240), got '16'"),
        ("--spp", "0", "--spp: expected an integer >= 1, got 0"),
        ("--scenes", "nowhere", "unknown scene 'nowhere'"),
        ("--strategies", "blue", "unknown strategy 'blue'"),
        ("--denoisers", "magic", "unknown denoiser 'magic'"),
    ],
)
def test_bench_reports_bad_overrides_as_errors(tmp_path, capsys, flag, value, message):
    args = _two_strategies(tmp_path)
    args[args.index(flag) + 1] = value
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_the_speed_suite_takes_no_cell_overrides(tmp_path, capsys):
    assert main(["bench", "--suite", "speed", "--spp", "4", "--out", str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--suite speed: expected no cell overrides (it runs timing scripts), got --spp" in err


def test_a_second_bench_into_a_locked_folder_refuses(tmp_path, capsys):
    out = tmp_path / "out"
    with output_lock(out, "bnerr bench"):  # another bench holding the folder
        assert main(_args(out, tmp_path / "cache")) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("bnerr bench: error: ") and "\n" not in err
    assert "holds its lock" in err and not (out / RESULTS_FILE).exists()


def test_a_fresh_run_refuses_finished_cells_unless_told_to_overwrite(tmp_path, capsys):
    out, cache = tmp_path / "out", tmp_path / "cache"
    assert main(_args(out, cache)) == 0
    before = (out / RESULTS_FILE).read_bytes()
    capsys.readouterr()
    assert main(_args(out, cache)) == 2
    err = capsys.readouterr().err.strip()
    assert "expected no finished cells" in err and "--overwrite" in err and "\n" not in err
    assert (out / RESULTS_FILE).read_bytes() == before
    assert main(_args(out, cache, "--resume")) == 0
    assert (out / RESULTS_FILE).read_bytes() == before
    first = [(r.key, r.raw, r.den) for r in load_records(out)]
    (out / RESULTS_FILE).write_bytes(before.replace(b'"spp": 1,', b'"spp": 1 ,'))  # a marker
    assert main(_args(out, cache, "--overwrite")) == 0
    assert b'"spp": 1 ,' not in (out / RESULTS_FILE).read_bytes()  # measured again, rewritten
    assert [(r.key, r.raw, r.den) for r in load_records(out)] == first  # same renders, same bits


@pytest.mark.parametrize(
    ("garbage", "message"),
    [
        (b"\x89PNG\r\n\x1a\n\x00\xff", "got bad bytes on line 1"),
        # a complete line that is not JSON (a last line cut short, without its newline, is an
        # interrupted append: resume drops it with a warning,
        # tests/benchmarks/sweep/test_records.py)
        (b'{"key": "trunc\n', "expected one JSON record per line, got bad line 1"),
    ],
)
def test_resume_from_garbage_gives_a_one_line_error(tmp_path, capsys, garbage, message):
    out = tmp_path / "out"
    out.mkdir()
    (out / RESULTS_FILE).write_bytes(garbage)
    assert main(_args(out, tmp_path / "cache", "--resume")) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"bnerr bench: error: {out / RESULTS_FILE}: ") and message in err
    assert "\n" not in err and "Traceback" not in err


@pytest.mark.parametrize("other", [["--overwrite"], ["--remeasure", "gaussian"]])
def test_resume_overwrite_and_remeasure_exclude_each_other(tmp_path, capsys, other):
    assert main(_args(tmp_path / "out", tmp_path / "cache", "--resume", *other)) == 2
    assert "not allowed with argument" in capsys.readouterr().err


def test_bench_ray_without_ray_says_how_to_install_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    assert main(_args(tmp_path / "out", tmp_path / "cache", "--ray")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "pip install '.[cluster]'" in err
    assert err.startswith("bnerr bench: error: --ray: expected the optional extra 'cluster'")
    assert not (tmp_path / "out").exists()  # refused before any work


def test_bench_ray_cpus_must_be_positive(tmp_path, capsys):
    pytest.importorskip("ray", reason="ray is not installed (pip install '.[cluster]')")
    assert main(_args(tmp_path / "out", tmp_path / "cache", "--ray", "--ray-cpus", "0")) == 2
    assert "--ray-cpus" in capsys.readouterr().err


def test_bench_own_tuning_column_sits_in_table_csv(tmp_path):
    args = _two_strategies(tmp_path)
    args[args.index("--denoisers") + 1] = "gaussian,gaussian:own"
    assert main(args) == 0
    table = (tmp_path / "out" / "table.csv").read_text()
    assert ",gaussian:own," in table and ",gaussian," in table
    assert "gaussian:own" in (tmp_path / "out" / "table.md").read_text()


def test_report_only_rewrites_the_tables_without_measuring(tmp_path, capsys):
    assert main(_two_strategies(tmp_path, "--no-charts")) == 0
    out = tmp_path / "out"
    cells, table = (out / RESULTS_FILE).read_text(), (out / "table.md").read_text()
    (out / "table.md").unlink()
    (out / "decision.md").unlink()
    cache = tmp_path / "cache"
    before = sorted(p.name for p in cache.rglob("*"))
    args = ["bench", "--suite", "quick", "--out", str(out), "--cache", str(cache), "--quiet"]
    assert main([*args, "--report-only", "--no-charts"]) == 0
    # Nothing measured or rendered: the cells and the reference cache are as they were.
    assert (out / RESULTS_FILE).read_text() == cells
    assert sorted(p.name for p in cache.rglob("*")) == before
    assert (out / "table.md").read_text() == table  # the same title and figures
    assert (out / "decision.md").exists()
    # --compress keeps the cells compressed, and a folder holding them so keeps them so
    assert main([*args, "--report-only", "--no-charts", "--compress"]) == 0
    assert not (out / RESULTS_FILE).exists() and (out / RESULTS_ARCHIVE).exists()
    assert main([*args, "--report-only", "--no-charts"]) == 0
    assert (out / RESULTS_ARCHIVE).exists() and (out / "table.md").read_text() == table
    assert (out / "index.html").exists() and (tmp_path / "index.html").exists()  # the pages


def test_report_only_compact_rounds_an_older_folders_records_and_compresses_them(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(_two_strategies(tmp_path, "--no-charts")) == 0
    measured = load_records(out)
    assert measured == [r.rounded() for r in measured]  # a run keeps its records rounded
    # A folder written before records were rounded: the same cells at full precision.
    third = 1.0 / 3.0
    older = [dataclasses.replace(r, reference=dataclasses.replace(r.reference, floor=third))
             for r in measured]  # fmt: skip
    write_records(out, older)
    args = ["bench", "--suite", "quick", "--out", str(out), "--quiet", "--no-charts"]
    assert main([*args, "--compact"]) == 2
    assert "--compact: expected with --report-only" in capsys.readouterr().err
    assert load_records(out) == older  # refused before anything was touched
    assert main([*args, "--report-only", "--compact"]) == 0
    assert (out / RESULTS_ARCHIVE).exists() and not (out / RESULTS_FILE).exists()
    assert load_records(out) == [r.rounded() for r in older]
    assert {r.reference.floor for r in load_records(out)} == {0.3333}


def test_a_measuring_run_compresses_the_cells_before_the_page_links_them(tmp_path):
    # --overwrite into a folder holding cells.jsonl.xz measures into a plain cells.jsonl, then
    # compresses it: the page is written after, so it links the file the folder holds.
    assert main(_two_strategies(tmp_path, "--no-charts", "--compress")) == 0
    assert main(_two_strategies(tmp_path, "--no-charts", "--overwrite")) == 0
    out = tmp_path / "out"
    assert (out / RESULTS_ARCHIVE).exists() and not (out / RESULTS_FILE).exists()
    assert RESULTS_ARCHIVE in (out / "index.html").read_text()
    assert broken_links(out / "index.html", root=tmp_path) == []


def test_report_only_refuses_overrides_and_an_empty_folder(tmp_path, capsys):
    out = tmp_path / "empty"
    args = ["bench", "--suite", "quick", "--out", str(out), "--quiet", "--report-only"]
    assert main(args) == 2
    assert "expected finished cells" in capsys.readouterr().err
    assert main([*args, "--spp", "4"]) == 2
    assert "--report-only: expected no cell overrides" in capsys.readouterr().err


def test_speed_report_only_rewrites_speed_md_from_the_committed_figures(tmp_path):
    import shutil

    out = tmp_path / "speed"
    shutil.copytree(RESULTS / "speed", out)
    figures = (out / "speed.json").read_text()
    (out / "speed.md").unlink()
    assert main(["bench", "--suite", "speed", "--report-only", "--out", str(out), "--quiet"]) == 0
    assert (out / "speed.json").read_text() == figures  # nothing measured
    text = (out / "speed.md").read_text()
    assert "|" in text and "OIDN" in text  # one table per part, denoisers against OIDN
    committed = RESULTS / "speed" / "speed.md"
    assert text == committed.read_text()  # speed.md follows from speed.json alone, rows sorted


def test_speed_report_only_refuses_figures_of_unknown_scripts(tmp_path, capsys):
    out = tmp_path / "speed"
    out.mkdir()
    (out / "speed.json").write_text('{"os": {}}')
    assert main(["bench", "--suite", "speed", "--report-only", "--out", str(out), "--quiet"]) == 2
    assert "expected figures of the scripts" in capsys.readouterr().err


def test_bench_keeps_a_progress_bar_on_stderr_unless_quiet(tmp_path, capsys):
    loud = [a for a in _args(tmp_path / "out", tmp_path / "cache") if a != "--quiet"]
    assert main(loud) == 0
    err = capsys.readouterr().err
    assert "1/1" in err and "frame" in err  # the measured frames, counted as they finish
    assert main(_args(tmp_path / "out2", tmp_path / "cache")) == 0
    assert "1/1" not in capsys.readouterr().err


def test_scripts_is_for_the_speed_suite_only(tmp_path, capsys):
    args = ["bench", "--suite", "quick", "--scripts", "speed.permute", "--out", str(tmp_path)]
    assert main([*args, "--quiet"]) == 2
    assert "--scripts: expected a suite of timing scripts (speed)" in capsys.readouterr().err


def test_until_resolved_adds_seed_sets_to_open_cells_up_to_the_cap(tmp_path, capsys):
    # 2 seed sets, cap 4: every open cell is measured again at 4; the report shows the last look
    args = _two_strategies(tmp_path, "--no-charts", "--until-resolved", "--seed-set-cap", "4")
    args[args.index("--seed-sets") + 1] = "2"
    assert main(args) == 0
    records = load_records(tmp_path / "out")
    assert {r.cell.seed_sets for r in records} <= {2, 4}
    assert all(r.looks == [2, 4] for r in records)
    decision = (tmp_path / "out" / "decision.md").read_text()
    assert " seed sets" in decision and "n.r." not in decision
    before = (tmp_path / "out" / RESULTS_FILE).read_bytes()
    assert main([*args, "--resume"]) == 0  # resumed: the same verdicts, nothing measured
    assert (tmp_path / "out" / RESULTS_FILE).read_bytes() == before


def test_the_adaptive_options_need_until_resolved_and_a_run_that_measures(tmp_path, capsys):
    assert main(_two_strategies(tmp_path, "--seed-set-cap", "8")) == 2
    assert "--seed-set-cap: expected with --until-resolved" in capsys.readouterr().err
    out = ["--out", str(tmp_path / "o"), "--quiet"]
    assert main(["bench", "--suite", "quick", *out, "--report-only", "--until-resolved"]) == 2
    assert "--until-resolved: expected a run that measures" in capsys.readouterr().err


def test_bench_device_must_be_available_and_goes_without_ray(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("torch.cuda.is_available", lambda: False)
    assert main(["bench", "--out", str(tmp_path), "--device", "cuda"]) == 2
    assert "--device: expected an available device (cpu), got cuda" in capsys.readouterr().err
    monkeypatch.setattr("torch.cuda.is_available", lambda: True)
    monkeypatch.setattr("torch.cuda.device_count", lambda: 1)
    assert main(["bench", "--out", str(tmp_path), "--device", "cuda", "--ray"]) == 2
    assert "--device cuda: expected it without --ray" in capsys.readouterr().err
    assert main(["bench", "--suite", "speed", "--out", str(tmp_path), "--device", "cuda"]) == 2
    assert "expected no cell overrides (it runs timing scripts), got --device" in (
        capsys.readouterr().err
    )
