"""Tests of bnerr.ldbn.device and benchmarks/ldbn_device.sh, the GPU run, on the CPU at a tiny
size: the script end to end, a run stopped at its deadline, the compressed table and its
conversion, and the iteration timing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from bnerr.ldbn.device import convert, main, measure

ROOT = Path(__file__).resolve().parents[3]
TINY = ["--tiny", "--device", "cpu", "--measure", "--sets", "screen_128"]


def test_the_device_script_runs_tiny_on_the_cpu(tmp_path):
    env = dict(os.environ, OUT=str(tmp_path / "out"), PYTHON=sys.executable, PYTHONPATH=str(ROOT))
    run = subprocess.run(
        ["bash", str(ROOT / "benchmarks" / "ldbn_device.sh"), *TINY],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    out = tmp_path / "out"
    keys = np.load(out / "ldbn_screen_16.npy")
    assert keys.shape == (2, 1, 16, 16, 6) and keys.dtype == np.int32
    assert "finished" in (out / "NOTE.txt").read_text()
    assert (out / "ldbn_screen_16.ckpt.npz").exists()


def test_a_run_past_its_deadline_writes_a_note_and_a_rerun_finishes(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["--out", str(out), *TINY, "--budget", "0", "--margin", "0"]) == 0
    assert "UNFINISHED" in (out / "NOTE.txt").read_text()
    assert not (out / "ldbn_screen_16.npy").exists()
    assert main(["--out", str(out), *TINY]) == 0
    assert "finished ->" in (out / "NOTE.txt").read_text()
    assert "[" in capsys.readouterr().out  # timestamped progress lines


def test_a_large_table_is_compressed_and_converts_to_npy(tmp_path):
    out = tmp_path / "out"
    assert main(["--out", str(out), *TINY, "--max-file-mib", "0"]) == 0
    packed = out / "ldbn_screen_16.npz"
    convert(packed, tmp_path / "a.npy")
    convert(out / "ldbn_screen_16.ckpt.npz", tmp_path / "b.npy")
    a, b = np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy")
    assert a.shape == (2, 1, 16, 16, 6) and np.array_equal(a, b)


def test_measure_times_alone_and_batched():
    alone, batched = measure(8, 2, 2, "cpu", components=4)
    assert alone > 0 and batched > 0
