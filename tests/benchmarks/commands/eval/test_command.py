"""Tests of ``bnerr eval DIR`` (benchmarks.commands.eval.command): on frames of bnerr's tracer
rendered outside ``bnerr bench`` (a strategy's ``play`` calling the tracer) it gives bench's metrics
for the same frames; the tables, charts and page are written; every problem with the folder is one
line; finished results are not overwritten silently; a plug-in denoiser runs."""

import os
import shutil
import subprocess
import sys
import textwrap

import pytest
import torch

from benchmarks.cli import main
from benchmarks.commands.eval.frame_folder import MANIFEST, frame_name
from benchmarks.suites import get_suite
from benchmarks.sweep.records import load_records
from bnerr.io import write_exr
from tests._frame_folders import SYNTHETIC, render_folder, synthetic_folder, toml_text
from tests._paths import ROOT

pytestmark = pytest.mark.usefixtures("one_thread")

#: What bnerr bench measures of the same frames, and bnerr eval must measure the same.
_MEASURED = ("raw", "den", "spectrum", "tcorr", "coverage", "denoiser_params", "t")


def test_eval_gives_the_metrics_bench_gives_for_the_same_frames(tmp_path, capsys):
    frames = render_folder(tmp_path / "frames")  # direct, white + temporal, 16x16, 2 seed sets
    bench = [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white,temporal",
        "--spp", "1", "--denoisers", "gaussian", "--frames", "2", "--warmup", "1",
        "--res", "16x16", "--reference-spp", "8", "--seed-sets", "2", "--quiet",
        "--out", str(tmp_path / "bench"), "--cache", str(tmp_path / "cache"), "--no-charts",
    ]  # fmt: skip
    assert main(bench) == 0
    # the quick suite's metrics, its perceptual ones included: eval measures them as bench does
    metrics = get_suite("quick").sweeps[0].metrics
    assert main(["eval", str(frames), "--quiet", "--metrics", *metrics]) == 0
    assert f"results written to {frames / 'results'}" in capsys.readouterr().out
    got = {r.key: r for r in load_records(frames / "results")}
    want = {r.key: r for r in load_records(tmp_path / "bench")}
    assert set(got) == set(want) and len(got) == 4  # white, temporal x all, coherent
    for key, record in want.items():
        for field in _MEASURED:
            assert getattr(got[key], field) == getattr(record, field), (key, field)
        assert got[key].reference.floor == record.reference.floor
    for name in ("table.csv", "table.md", "decision.md", "index.html"):
        assert (frames / "results" / name).is_file()


def _fails(args, capsys) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bnerr eval: error: "), err
    return err[0]


def _broken(root, what):
    """Break a synthetic folder one way."""
    if what == "frame":
        (root / "mine" / "1" / frame_name(1)).unlink()
    elif what == "reference":
        (root / "reference" / frame_name(0)).unlink()
    elif what == "white":
        (root / MANIFEST).write_text(toml_text({**SYNTHETIC, "methods": ["mine"]}))
    elif what == "size":
        write_exr(root / "white" / "0" / frame_name(0), {"color": torch.zeros(3, 4, 8)})
    elif what == "nan":
        write_exr(
            root / "white" / "0" / frame_name(1), {"color": torch.full((3, 8, 8), float("inf"))}
        )
    elif what == "one nan":  # in the last method's last frame: found only by reading pixels
        color = torch.full((3, 8, 8), 0.5)
        color[2, 7, 7] = float("nan")
        write_exr(root / "mine" / "1" / frame_name(1), {"color": color})
    elif what == "truncated":
        path = root / "mine" / "1" / frame_name(1)
        path.write_bytes(path.read_bytes()[:400])
    elif what == "no rgb":
        write_exr(root / "mine" / "1" / frame_name(1), {"albedo": torch.ones(3, 8, 8)})
    elif what == "text":
        (root / "mine" / "1" / frame_name(1)).write_text("not an image\n")
    elif what == "manifest alone":
        for child in root.iterdir():
            if child.name != MANIFEST:
                shutil.rmtree(child)
    elif what == "key":
        (root / MANIFEST).write_text(toml_text({**SYNTHETIC, "fps": 24}))
    elif what == "escape":
        (root / MANIFEST).write_text(toml_text({**SYNTHETIC, "methods": ["white", "../x"]}))
    elif what == "symlink":
        os.symlink(root / "white" / "0" / frame_name(0), root / "mine" / "0" / "0002.exr")
        (root / "mine" / "0" / frame_name(0)).unlink()
        os.symlink(root / "white" / "0" / frame_name(0), root / "mine" / "0" / frame_name(0))


@pytest.mark.parametrize(
    ("what", "says"),
    [
        ("frame", "mine/1/0001.exr: expected a frame the manifest implies, got no such file"),
        ("reference", "reference/0000.exr: expected a reference the manifest implies"),
        ("white", "methods: expected the white baseline (a method named 'white'"),
        ("size", "white/0/0000.exr: expected 8 x 8 (the manifest's resolution), got 8 x 4"),
        ("nan", "white/0/0001.exr: color: expected finite values, got 0 NaN and 192 infinite"),
        ("key", "manifest.toml: unknown keys fps; expected keys from scene, spp, resolution"),
        ("escape", "methods: expected plain folder names inside the folder"),
        ("symlink", "mine/0/0000.exr: expected a file inside"),
        ("one nan", "mine/1/0001.exr: color: expected finite values, got 1 NaN"),
        ("truncated", "mine/1/0001.exr: corrupt or truncated OpenEXR file"),
        ("no rgb", "mine/1/0001.exr: expected channels R, G, B for the frame's color"),
        ("text", "mine/1/0001.exr: expected an OpenEXR file, got no EXR magic number"),
        ("manifest alone", "reference/0000.exr: expected a reference the manifest implies"),
    ],
)
def test_a_broken_folder_is_one_line_and_nothing_is_written(tmp_path, capfd, what, says):
    """docs/EVAL.md: every problem is found "before anything is written": not the lock, not a
    crop, not the results folder (issue 54: the lock stayed after every refusal, and a NaN, a
    truncated file or missing channels left crops); one line on the process's stderr, OpenEXR's
    own lines included."""
    root = synthetic_folder(tmp_path / "f")
    _broken(root, what)
    capfd.readouterr()
    assert main(["eval", str(root), "--quiet", "--no-charts"]) == 2
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bnerr eval: error: "), err
    assert says in lines[0] and out == ""
    assert not (root / "results").exists()


def test_one_huge_finite_pixel_gives_a_result_not_a_traceback(tmp_path, capsys):
    """Issue 54: one pixel of 1e24 (a firefly, a corrupt file) made the ratio's upper bound
    overflow ``math.exp`` after cells.jsonl was written, so the rerun was refused. The ratio is
    a number the report shows (its bound inf) and the run finishes."""
    root = synthetic_folder(tmp_path / "f")
    color = torch.full((3, 8, 8), 0.5)
    color[0, 2, 2] = 1e24
    write_exr(root / "mine" / "1" / frame_name(1), {"color": color})
    out = tmp_path / "out"
    assert main(["eval", str(root), "--out", str(out), "--quiet", "--no-charts"]) == 0
    assert "inf]" in (out / "table.md").read_text()
    mine = [r for r in load_records(out) if r.cell.strategy == "mine"]
    assert mine and all(max(p[0] / p[1] for s in r.raw["mse"] for p in s) > 1e40 for r in mine)


def test_eval_refuses_to_discard_finished_results_and_says_one_seed_set(tmp_path, capsys):
    root = synthetic_folder(tmp_path / "f", seed_sets=["only"])
    out = tmp_path / "out"
    assert main(["eval", str(root), "--out", str(out), "--no-charts"]) == 0
    captured = capsys.readouterr()
    assert "note: one seed set: the intervals over seed sets need two" in captured.err
    assert "### gradient" in captured.out and (out / "table.md").is_file()
    refused = _fails(["eval", str(root), "--out", str(out), "--quiet"], capsys)
    assert "--overwrite" in refused and "--resume" not in refused  # eval has no --resume
    assert main(["eval", str(root), "--out", str(out), "--quiet", "--overwrite"]) == 0
    assert "note: one seed set" in capsys.readouterr().err  # said under --quiet too
    assert "nothing" in _fails(["eval", str(tmp_path / "nothing"), "--quiet"], capsys)
    assert not (tmp_path / "nothing").exists()
    assert "denoiser" in _fails(["eval", str(root), "--denoisers", "nope", "--quiet"], capsys)


BOX = '''
import torch.nn.functional as F


def box(frame):
    """A 3x3 box filter."""
    return F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]


box.name = "box3"
'''


def test_a_plug_in_denoiser_runs_by_its_spec(tmp_path):
    root = synthetic_folder(tmp_path / "f")
    (tmp_path / "box.py").write_text(textwrap.dedent(BOX))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    args = ["eval", str(root), "--denoisers", f"gaussian,{tmp_path / 'box.py'}:box"]
    cmd = [sys.executable, "-m", "benchmarks.cli", *args, "--quiet", "--no-charts"]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    records = load_records(root / "results")
    assert {r.cell.denoiser for r in records} == {"gaussian", "box3"}
    box = [r for r in records if r.cell.denoiser == "box3"]
    assert all("box.py:box" in str(r.plugins) for r in box)
