"""docs/PLUGINS.md, run: every command of its ```sh blocks exactly as written, in a folder
holding a copy of ``examples/`` and the page's ``my_plugins.py`` (its ```python block), with
``bnerr`` this checkout's and the page's ``pyproject.toml`` entry points installed (a
``*.dist-info`` on the path, as ``pip install`` leaves it). Then the page's ```text example of a
refused ``--resume`` is the line bnerr prints after ``my_plugins.py`` changes. So the page
cannot drift from the code.

The first ``bnerr bench`` runs through a shell and the console script, in a process of its own
with the folders on PYTHONPATH; the other ``bnerr`` commands run in the test process
(:func:`tests._cli.bnerr_in_process`: the argv a shell would pass, each command starting from
what a new process would, 4.7 s of imports saved each), ``sed`` through a shell."""

import csv
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests._cli import bnerr_in_process
from tests._paths import EXAMPLES, ROOT

PAGE = ROOT / "docs" / "PLUGINS.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", PAGE.read_text(), flags=re.S | re.M)


def _commands() -> list[str]:
    lines = [line.strip() for block in _blocks("sh") for line in block.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def _install(site: Path) -> None:
    """The page's entry points, installed as ``pip install`` would (a dist-info)."""
    (toml,) = [block for block in _blocks("toml") if "entry-points" in block]
    groups = tomllib.loads(toml)["project"]["entry-points"]
    info = site / "my_plugins-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my_plugins\nVersion: 0.1\n")
    points = [f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items())
              for group, entries in groups.items()]  # fmt: skip
    (info / "entry_points.txt").write_text("\n".join(points))
    (info / "RECORD").write_text("")


def _folder(tmp_path: Path) -> tuple[Path, dict, list[Path]]:
    work = tmp_path / "work"
    for name in ("external_denoiser", "scenes"):
        shutil.copytree(EXAMPLES / name, work / "examples" / name)
    (source,) = [b for b in _blocks("python") if b.startswith("# my_plugins.py\n")]
    (work / "my_plugins.py").write_text(source)
    _install(tmp_path / "site")
    shim = tmp_path / "bin" / "bnerr"  # the console script, importing this checkout
    shim.parent.mkdir()
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m benchmarks.cli "$@"\n')
    shim.chmod(0o755)
    env = dict(os.environ, PATH=f"{shim.parent}{os.pathsep}{os.environ['PATH']}")
    env.update(PYTHONPATH=os.pathsep.join([str(ROOT), str(work), str(tmp_path / "site")]))
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return work, env, [work, tmp_path / "site"]


def _run(command: str, work: Path, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run(
        command, shell=True, cwd=work, env=env, capture_output=True, text=True, timeout=600
    )


def _column(table: Path, column: str) -> set[str]:
    return {row[column] for row in csv.DictReader(table.open())}


def _status(
    command: str, work: Path, env: dict, path: list[Path], capsys, *, shell: bool = False
) -> tuple[int, str]:
    """Run ``command`` (a ``bnerr`` line in this process unless ``shell``, else through a
    shell): its exit status and stderr."""
    if command.startswith("bnerr ") and not shell:
        code, _, err = bnerr_in_process(command, capsys, work, path)
        return code, err
    done = _run(command, work, env)
    return done.returncode, done.stderr


# 14 commands: 99 s of CPU when each was a process, 31 s with the bnerr ones in this process (of
# which 17 s in the processes left: the first bench, sed, the example denoiser's programs)
@pytest.mark.slow
@pytest.mark.usefixtures("one_thread")
def test_every_command_of_the_plugins_page_runs_as_written(tmp_path, capsys):
    work, env, path = _folder(tmp_path)
    commands = _commands()
    assert len(commands) >= 10 and all(c.split()[0] in ("bnerr", "sed") for c in commands)
    shell = next(c for c in commands if c.startswith("bnerr bench "))  # the console script
    for command in commands:
        code, err = _status(command, work, env, path, capsys, shell=command == shell)
        assert code == 0, f"{command}\n{err}"
    out = work / "out"
    assert {"box", "gaussian"} <= _column(out / "box" / "table.csv", "denoiser")
    assert {"1", "2"} == _column(out / "box" / "table.csv", "spp")  # --resume added spp 2
    assert "example_joint_bilateral" in _column(out / "external" / "table.csv", "denoiser")
    assert {"white", "frozen"} == _column(out / "strategy" / "table.csv", "strategy")
    assert "hashy" in _column(out / "strategy" / "table.csv", "sampler")
    assert {"my_direct", "tiny"} == _column(out / "scenes" / "table.csv", "scene")
    assert "my_box" in _column(out / "installed" / "table.csv", "denoiser")
    assert (out / "animation" / "direct.mp4").is_file() and (out / "boxed.exr").is_file()
    assert len(list((out / "frozen").glob("direct_*.exr"))) == 2

    (shown,) = [b.strip() for b in _blocks("text") if "--resume" in b]
    (resume,) = [c for c in commands if c.endswith("--resume")]
    with (work / "my_plugins.py").open("a") as file:
        file.write("# changed\n")
    code, err = _status(resume, work, env, path, capsys)
    assert code == 2
    pattern = ".*".join(re.escape(part) for part in shown.split("..."))
    assert re.fullmatch(pattern, err.strip().splitlines()[-1]), err
