"""docs/EVAL.md ("Evaluate frames from your renderer") runs as written: its Python block writes
the example folder, then every command of its ``sh`` blocks runs in a shell, ``bnerr`` being this
checkout's command line, and writes what the page says."""

import os
import re
import stat
import subprocess
import sys

import pytest

from tests._paths import ROOT

DOC = ROOT / "docs" / "EVAL.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", DOC.read_text(), flags=re.M | re.S)


def test_the_page_has_its_layout_keys_and_commands():
    text = DOC.read_text()
    assert text.startswith("# Evaluate frames from your renderer")
    from benchmarks.frame_folder import MANIFEST_KEYS

    assert all(f"| `{key}` |" in text for key in MANIFEST_KEYS)
    assert len(_blocks("python")) == 1 and _blocks("sh")


@pytest.mark.usefixtures("one_thread")
def test_the_commands_of_the_page_run_as_written(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    shim = tmp_path / "bin" / "bnerr"
    shim.parent.mkdir()
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m benchmarks.cli "$@"\n')
    shim.chmod(shim.stat().st_mode | stat.S_IEXEC)
    env["PATH"] = f"{shim.parent}{os.pathsep}{env['PATH']}"
    work = tmp_path / "work"
    work.mkdir()
    (work / "write_frames.py").write_text(_blocks("python")[0])
    run = dict(cwd=work, env=env, capture_output=True, text=True, timeout=600)
    done = subprocess.run([sys.executable, "write_frames.py"], **run)
    assert done.returncode == 0, done.stderr
    for block in _blocks("sh"):
        done = subprocess.run(["sh", "-e", "-c", block], **run)
        assert done.returncode == 0, done.stderr
    assert (work / "frames" / "results" / "index.html").is_file()
    assert "| 1 | median |" in (work / "frames-eval" / "table.md").read_text()
