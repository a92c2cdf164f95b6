"""Tests of ``bnerr bench``'s output folder rules: one writer per folder (the lock), no silent
discarding of finished cells (--overwrite), typed one-line errors for a garbled results file."""

import pytest

from benchmarks.cli import main
from benchmarks.records import RESULTS_FILE, load_records
from bnerr.outputs import output_lock

pytestmark = pytest.mark.usefixtures("one_thread")


def _args(out, cache, *extra):
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white",
        "--spp", "1", "--denoisers", "gaussian", "--frames", "1", "--warmup", "0",
        "--res", "8x8", "--reference-spp", "4", "--seed-sets", "1", "--out", str(out),
        "--cache", str(cache), "--quiet", "--no-charts", *extra,
    ]  # fmt: skip


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
        (b'{"key": "trunc', "expected one JSON record per line, got bad line 1"),
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


def test_resume_and_overwrite_exclude_each_other(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(_args(tmp_path / "out", tmp_path / "cache", "--resume", "--overwrite"))
    assert "not allowed with argument" in capsys.readouterr().err
