"""The executable-denoiser door's probe (issue 41): bad manifests and programs that fail every
way, each refused as a typed error whose first line names the manifest or the denoiser, its
command and what was expected (tests/_probes.py); its temporary folder is gone and no process it
started is left running. The programs are shell scripts (no interpreter's start-up per case);
the EXR files they hand back are written by the test."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
import torch

from bnerr.errors import ExternalProcessError
from bnerr.external import ManifestError
from bnerr.frame import Frame
from bnerr.io import write_exr
from denoisers.external import denoiser_class
from tests._probes import Bad, assert_ended, check, ids

H, W = 8, 8
GOOD = {"name": "probe_ext", "command": ["./prog.sh", "{color}", "{output}"], "timeout_s": 20}


def _folder(tmp_path: Path, script: str, manifest: dict | str, suffix: str = ".json") -> Path:
    """A denoiser folder: ``prog.sh`` (``script``, with ``$1`` the color and ``$2`` the output)
    and its manifest ``den<suffix>`` (a dict as JSON, or the text itself)."""
    folder = tmp_path / "den"
    folder.mkdir(exist_ok=True)
    program = folder / "prog.sh"
    program.write_text("#!/bin/sh\n" + script)
    program.chmod(0o755)
    path = folder / f"den{suffix}"
    path.write_text(manifest if isinstance(manifest, str) else json.dumps(manifest))
    return path


def _load(manifest: dict | str, suffix: str = ".json", script: str = 'cp ready.exr "$2"\n'):
    return lambda tmp_path: denoiser_class(_folder(tmp_path, script, manifest, suffix))


def _run(script: str, ready: dict | None = None, **changes: object):
    """A case's run: ``script`` as the program; ``ready`` (buffers) written as ``ready.exr``."""

    def run(tmp_path: Path) -> object:
        path = _folder(tmp_path, script, {**GOOD, **changes})
        if ready is not None:
            write_exr(path.parent / "ready.exr", ready)
        return denoiser_class(path)()(Frame(color=torch.rand(3, H, W)), 0)

    return run


def _color(h: int = H, w: int = W, value: float = 0.5) -> dict:
    return {"color": torch.full((3, h, w), value)}


CASES = [
    Bad("malformed TOML", _load('name = "x"\ncommand = [\n', ".toml"), ManifestError,
        r"den\.toml: expected valid TOML.*line"),
    Bad("malformed JSON", _load('{"name": "x",\n "command": }', ".json"), ManifestError,
        r"den\.json: expected valid JSON.*line 2"),
    Bad("unknown key", _load({**GOOD, "shell": True}), ManifestError,
        r"den\.json: unknown key\(s\) shell: expected only name, command"),
    Bad("missing command", _load({"name": "x"}), ManifestError,
        r"den\.json: expected the key\(s\) command"),
    Bad("a shell string", _load({**GOOD, "command": "./prog.sh {color} {output}"}),
        ManifestError, r"den\.json: command: expected a list of arguments"),
    Bad("unknown placeholder", _load({**GOOD, "command": ["./prog.sh", "{colour}", "{output}"]}),
        ManifestError, r"den\.json: .*colour"),
    Bad("no output placeholder", _load({**GOOD, "command": ["./prog.sh", "{color}"]}),
        ManifestError, r"den\.json: command: expected an \{output\} placeholder"),
    Bad("program escaping with ..",
        _load({**GOOD, "command": ["../prog.sh", "{color}", "{output}"]}),
        ManifestError, r"den\.json: command\[0\]: expected a path inside the manifest's folder"),
    Bad("missing program", _load({**GOOD, "command": ["./none.sh", "{color}", "{output}"]}),
        ManifestError, r"den\.json: command\[0\]: expected an existing file"),
    Bad("negative time limit", _load({**GOOD, "timeout_s": -1}), ManifestError,
        r"den\.json: timeout_s: expected a number > 0, got -1"),
    Bad("time limit as text", _load({**GOOD, "timeout_s": "60"}), ManifestError,
        r"den\.json: timeout_s: expected a number of seconds, got str"),
    Bad("unknown input buffer", _load({**GOOD, "inputs": ["color", "alpha"]}), ManifestError,
        r"den\.json: inputs: expected buffer names among .*got 'alpha'"),
    Bad("a parameter of the wrong type", _load({**GOOD, "params": {"k": [1, 2]}}), ManifestError,
        r"den\.json: params\.k: expected an int, a float or a string, got list"),
    Bad("a bad name", _load({**GOOD, "name": "../x"}), ManifestError,
        r"den\.json: name: expected a letter.*got '\.\./x'"),
    Bad("exit status", _run("echo one >&2\necho two >&2\nexit 3\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*prog\.sh.*expected exit status 0, got exit status 3"),
    Bad("killed by a signal", _run("kill -9 $$\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*got killed by signal SIGKILL"),
    Bad("time limit", _run("sleep 30\n", timeout_s=0.3), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an exit within timeout_s = 0\.3 s"),
    Bad("no output", _run("exit 0\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an output EXR.*got no such file"),
    Bad("garbage output", _run("echo garbage > \"$2\"\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an OpenEXR output"),
    Bad("partial output", _run("head -c 300 ready.exr > \"$2\"\n", _color()),
        ExternalProcessError, r"denoiser 'probe_ext'.*expected an OpenEXR output"),
    Bad("wrong size", _run("cp ready.exr \"$2\"\n", _color(H, W - 1)), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an output of 8 x 8 pixels \(width x height\), got 7 x 8"),
    Bad("wrong channels", _run("cp ready.exr \"$2\"\n", {**_color(), "depth": torch.ones(1, H, W)}),
        ExternalProcessError, r"denoiser 'probe_ext'.*expected the output channels R, G, B only"),
    Bad("NaN output", _run("cp ready.exr \"$2\"\n", _color(value=float("nan"))),
        ExternalProcessError, r"denoiser 'probe_ext'.*expected finite output values, got 192 NaN"),
    Bad("inf output", _run("cp ready.exr \"$2\"\n", _color(value=float("inf"))),
        ExternalProcessError, r"denoiser 'probe_ext'.*expected finite output values"),
    Bad("huge output", _run("truncate -s 200M \"$2\"\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an output EXR of at most \d+ bytes, got 209715200"),
    Bad("output is a folder", _run("mkdir \"$2\"\n"), ExternalProcessError,
        r"denoiser 'probe_ext'.*expected an output EXR"),
]  # fmt: skip


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """The temporary folders the door makes go under ``tmp_path/tmp``: checked empty after."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    yield folder
    assert list(folder.iterdir()) == [], "the door left temporary files behind"


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_a_bad_manifest_or_program_is_refused_naming_it(case, tmp_path, private_tmp):
    check(case, tmp_path)


def test_the_message_keeps_the_last_lines_of_stderr(tmp_path, private_tmp):
    script = "i=0\nwhile [ $i -lt 40 ]; do echo line $i >&2; i=$((i+1)); done\nexit 1\n"
    message = str(
        check(Bad("stderr", _run(script), ExternalProcessError, "exit status 1"), tmp_path)
    )
    assert "line 39" in message and "line 20" in message and "line 19" not in message


@pytest.mark.parametrize("ending", ["sleep 30\n", "exit 0\n", "exit 4\n"])
def test_no_process_the_program_started_is_left_running(tmp_path, private_tmp, ending):
    """Past its time limit, or exiting (well or not) with a child still running in the
    background: its whole process group is killed."""
    pids = tmp_path / "pids"
    script = f'sleep 60 &\necho $! > {pids}\ncp ready.exr "$2"\n{ending}'
    run = _run(script, _color(), timeout_s=1.0)
    try:
        run(tmp_path)
    except ExternalProcessError:
        pass
    assert_ended(int(pids.read_text()), "the program's background child")
