"""The installed ``bnerr`` console script, run as a user runs it: a new process per subcommand.

The other CLI tests call :func:`benchmarks.cli.main` in-process; these start the script the
package installs (``[project.scripts]``, :func:`benchmarks.cli.entry`, with its fast exit) from the
same environment as the interpreter running the tests, each subcommand once with the smallest
arguments it accepts, asserting on what it prints and writes. Every output goes under the test's
temporary folder (the processes also run there). ``bnerr --help`` must list exactly the commands
covered here, so a new subcommand fails this file until it has its run.
"""

from __future__ import annotations

import json
import signal
import subprocess
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from benchmarks.cli import command_names
from benchmarks.suites import Sweep
from tests._frame_folders import synthetic_folder
from tests._processes import bnerr_command, child_env

#: The subcommands this file runs (each test below names the one it runs).
COVERED = (
    "animate",
    "bench",
    "denoise",
    "eval",
    "export",
    "mask",
    "render",
    "retarget",
    "scenes",
    "schema",
    "train",
    "view",
)


def _env() -> dict[str, str]:
    """One torch thread, no background build of the compiled tracer."""
    return child_env(BNERR_BACKGROUND_BUILD="0", OMP_NUM_THREADS="1")


def bnerr(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """Run ``bnerr ARGS`` in ``cwd``; fail with its output unless it exits 0."""
    done = subprocess.run(
        [*bnerr_command(), *args], cwd=cwd, env=_env(), capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, f"bnerr {' '.join(args)}: {done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("cli")


def test_help_lists_every_subcommand_and_each_is_run_here(work):
    out = bnerr(work, "--help").stdout
    assert set(COVERED) == set(command_names())
    for name in COVERED:
        assert f"\n    {name} " in out, name


def test_scenes_lists_the_named_scenes(work):
    out = bnerr(work, "scenes").stdout
    assert "direct" in out and "cornell" in out and "what it models" in out


def test_schema_prints_the_scene_files_json_schema(work):
    schema = json.loads(bnerr(work, "schema", "scene").stdout)
    assert schema["type"] == "object" and "shapes" in schema["required"]


@pytest.fixture(scope="module")
def rendered(work) -> Path:
    done = bnerr(work, "render", "--scene", "direct", "--res", "8x8", "--spp", "1", "--out", "r")
    assert "8x8 1 spp" in done.stdout and "eager" in done.stdout
    return work / "r" / "direct_0000.exr"


def test_render_writes_the_frame_and_its_preview(rendered):
    assert rendered.is_file() and rendered.with_suffix(".png").is_file()


def test_denoise_reads_a_rendered_frame(work, rendered):
    done = bnerr(work, "denoise", "--denoiser", "gaussian", "--in", str(rendered), "--out", "d.png")
    assert "Gaussian" in done.stdout and "8x8" in done.stdout
    assert (work / "d.png").stat().st_size > 0


def test_export_writes_the_fast_mask(work):
    done = bnerr(work, "export", "--fast", "--format", "npy", "--out", "e")
    assert "1 file(s)" in done.stdout
    assert np.load(work / "e" / "fast_gauss_64.npy").shape == (1, 64, 64, 1)


@pytest.fixture(scope="module")
def mask(work) -> Path:
    done = bnerr(work, "mask", "--size", "8", "--out", "m.npy")
    assert "scalar mask 8x8" in done.stdout and "low-frequency fraction" in done.stdout
    return work / "m.npy"


def test_mask_writes_a_permutation_of_ranks(mask):
    values = np.sort(np.load(mask).ravel())
    assert values.shape == (64,) and np.all(np.diff(values) > 0)


def test_retarget_optimizes_a_written_mask(work, mask):
    done = bnerr(work, "retarget", "--mask", str(mask), "--radius", "2", "--out", "rt.npy")
    assert "method exact" in done.stdout and "identity" in done.stdout
    moves = np.load(work / "rt.npy")
    assert moves.shape == (2, 8, 8) and np.abs(moves).max() <= 2


@pytest.fixture(scope="module")
def benched(work) -> Path:
    args = ["--scenes", "direct", "--strategies", "white", "--spp", "1", "--denoisers", "gaussian"]
    args += ["--frames", "1", "--warmup", "0", "--seed-sets", "1", "--reference-spp", "4"]
    args += ["--res", "8x8", "--out", "results/quick", "--cache", "refs", "--threads", "1"]
    # the default metrics: ColorVideoVDP's import alone costs a process 6.5 s (torchvision), and
    # eval/test_command.py measures it through bench and eval
    args += ["--metrics", *Sweep.metrics]
    done = bnerr(work, "bench", "--suite", "quick", *args, "--no-charts")
    assert "| spp | denoiser | white |" in done.stdout and "results written to" in done.stdout
    return work / "results"


def test_bench_writes_the_tables_and_the_index(benched):
    for name in ("cells.jsonl", "table.md", "table.csv", "decision.md", "index.html"):
        assert (benched / "quick" / name).is_file(), name
    assert (benched / "index.html").is_file()


def test_view_serves_the_results_folder_until_interrupted(work, benched):
    cmd = [*bnerr_command(), "view", str(benched), "--port", "0"]
    proc = subprocess.Popen(cmd, cwd=work, env=_env(), stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        assert line.startswith(f"serving {benched} at http://127.0.0.1:"), line
        address = line.split(" at ")[1].split()[0]
        with urllib.request.urlopen(address + "quick/table.md", timeout=30) as reply:
            assert reply.read() == (benched / "quick" / "table.md").read_bytes()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)  # drains stdout: a full pipe would hold the server's exit
    assert proc.returncode == 0


def test_animate_writes_the_videos_and_their_readme(work):
    args = ["--scene", "direct", "--strategies", "white", "--frames", "1", "--warmup", "0"]
    args += ["--res", "16x16", "--spp", "1", "--reference-spp", "4", "--gif-crop", "8"]
    done = bnerr(work, "animate", *args, "--cache", "refs", "--out", "a", "--threads", "1")
    assert "1 animation(s) written" in done.stdout
    for name in ("direct.mp4", "direct.gif", "README.md"):
        assert (work / "a" / name).stat().st_size > 0, name
    assert "--scenes direct --strategies white" in (work / "a" / "README.md").read_text()


def test_train_writes_weights(work):
    args = ["--out", "w.pt", "--steps", "1", "--scenes", "1", "--size", "16", "--crop", "8"]
    args += ["--reference-spp", "4", "--batch-size", "1", "--no-progress", "--threads", "1"]
    done = bnerr(work, "train", *args)
    assert "finished" in done.stdout and "step      1" in done.stdout
    assert (work / "w.pt").stat().st_size > 0


def test_eval_measures_a_frame_folder(work):
    folder = synthetic_folder(work / "frames")
    bnerr(work, "eval", str(folder), "--denoisers", "gaussian", "--no-charts", "--quiet")
    table = (folder / "results" / "table.md").read_text()
    assert "white" in table and "gaussian" in table
