"""docs/EVAL.md ("Evaluate frames from your renderer") runs as written: its Python block writes
the example folder, then every command of its ``sh`` blocks runs, ``bnerr`` being this
checkout's command line, and writes what the page says.

The first command runs through a shell and the console script, in a process of its own; the
Python block (as a script, ``runpy``) and the other commands run in the test process
(:func:`tests._cli.bnerr_in_process`: the argv a shell would pass, from a fresh process's
state), which saves a process's 4.7 s of imports each."""

import os
import re
import runpy
import stat
import subprocess
import sys

import pytest

from tests._cli import bnerr_in_process
from tests._paths import ROOT

DOC = ROOT / "docs" / "EVAL.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", DOC.read_text(), flags=re.M | re.S)


def test_the_page_has_its_layout_keys_and_commands():
    text = DOC.read_text()
    assert text.startswith("# Evaluate frames from your renderer")
    from benchmarks.commands.eval.frame_folder import MANIFEST_KEYS

    assert all(f"| `{key}` |" in text for key in MANIFEST_KEYS)
    assert len(_blocks("python")) == 1 and _blocks("sh")


def _lines(block: str) -> list[str]:
    lines = [line.strip() for line in block.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


@pytest.mark.usefixtures("one_thread")
def test_the_commands_of_the_page_run_as_written(tmp_path, capsys, monkeypatch):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    shim = tmp_path / "bin" / "bnerr"
    shim.parent.mkdir()
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m benchmarks.cli "$@"\n')
    shim.chmod(shim.stat().st_mode | stat.S_IEXEC)
    env["PATH"] = f"{shim.parent}{os.pathsep}{env['PATH']}"
    work = tmp_path / "work"
    work.mkdir()
    (work / "write_frames.py").write_text(_blocks("python")[0])
    with monkeypatch.context() as patch:
        patch.chdir(work)
        runpy.run_path("write_frames.py", run_name="__main__")
    first, *others = [line for block in _blocks("sh") for line in _lines(block)]
    assert first.startswith("bnerr ") and others
    run = dict(cwd=work, env=env, capture_output=True, text=True, timeout=600)
    done = subprocess.run(["sh", "-e", "-c", first], **run)
    assert done.returncode == 0, done.stderr
    for line in others:
        code, _, err = bnerr_in_process(line, capsys, work)
        assert code == 0, f"{line}\n{err}"
    assert (work / "frames" / "results" / "index.html").is_file()
    assert "| 1 | median |" in (work / "frames-eval" / "table.md").read_text()
