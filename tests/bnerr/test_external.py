"""bnerr.external: the manifest reading and the subprocess runner shared by the executable
denoisers and the seed protocol's renderers."""

from __future__ import annotations

import sys
import time

import pytest

from bnerr.errors import ExternalProcessError
from bnerr.external import (
    ManifestError,
    command_placeholders,
    log_tail,
    read_manifest,
    resolve_program,
    run_program,
)
from bnerr.schemas.manifest import Command, Name, ProgramManifest, Seconds


class _Manifest(ProgramManifest):
    """A program manifest of three keys, as a renderer's or a denoiser's model declares them."""

    name: Name
    command: Command
    timeout_s: Seconds = 5.0


def _run(tmp_path, code: str, timeout_s: float = 30.0) -> float:
    argv = [sys.executable, "-c", code]
    return run_program("test program", argv, cwd=tmp_path, timeout_s=timeout_s, work=tmp_path)


def test_a_run_returns_its_wall_milliseconds(tmp_path):
    ms = _run(tmp_path, "import time; time.sleep(0.05)")
    assert 50 <= ms < 30_000


def test_a_failing_run_names_the_program_its_status_and_its_stderr_tail(tmp_path):
    lines = "'\\n'.join(f'line {i}' for i in range(30))"
    code = f"import sys; print({lines}, file=sys.stderr); sys.exit(3)"
    with pytest.raises(ExternalProcessError) as err:
        _run(tmp_path, code)
    text = str(err.value)
    assert text.startswith("test program: command ")
    assert "expected exit status 0, got exit status 3" in text
    assert "last 20 line(s) of the program's stderr" in text
    assert "line 29" in text and "line 9\n" not in text


def test_a_run_past_its_limit_has_its_whole_process_group_killed(tmp_path):
    child = tmp_path / "child.pid"
    code = (
        "import subprocess, sys, time; "
        f"p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); "
        f"open({str(child)!r}, 'w').write(str(p.pid)); time.sleep(60)"
    )
    start = time.perf_counter()
    with pytest.raises(ExternalProcessError, match="an exit within timeout_s = 1 s"):
        _run(tmp_path, code, timeout_s=1.0)
    assert time.perf_counter() - start < 30
    pid = int(child.read_text())
    for _ in range(50):  # the grandchild dies with its group (and init reaps it)
        try:
            with open(f"/proc/{pid}/stat") as stat:
                if stat.read().split()[2] == "Z":
                    break
        except FileNotFoundError:
            break
        time.sleep(0.1)
    else:
        pytest.fail(f"the grandchild {pid} outlived its group's kill")


def test_a_program_that_will_not_start_is_an_external_process_error(tmp_path):
    with pytest.raises(ExternalProcessError, match="expected a program that starts"):
        run_program("x", [str(tmp_path / "none")], cwd=tmp_path, timeout_s=5, work=tmp_path)


def test_the_log_tail_falls_back_to_stdout_and_is_empty_without_output(tmp_path):
    assert log_tail(tmp_path) == ""
    (tmp_path / "stdout.txt").write_text("hello\n")
    assert "program's stdout:\n    hello" in log_tail(tmp_path)


def test_a_manifest_gets_its_defaults_and_refuses_unknown_or_missing_keys(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text('name = "a"\ncommand = ["x"]\n')
    manifest = read_manifest(path, _Manifest, "manifest")
    assert (manifest.name, manifest.command, manifest.timeout_s) == ("a", ("x",), 5.0)
    path.write_text('name = "a"\ncommand = ["x"]\nextra = 1\n')
    with pytest.raises(ManifestError, match="unknown key.s. extra: expected only name"):
        read_manifest(path, _Manifest, "manifest")
    path.write_text('name = "a"\n')
    with pytest.raises(ManifestError, match="expected the key.s. command, got none"):
        read_manifest(path, _Manifest, "manifest")
    path.write_text('name = "a\n')
    with pytest.raises(ManifestError, match="expected valid TOML, got .*line 1"):
        read_manifest(path, _Manifest, "manifest")


def test_placeholders_are_checked_and_programs_kept_inside_the_manifest_folder(tmp_path):
    path = tmp_path / "m.toml"
    assert command_placeholders(path, ["a{x}", "{{y}}"], {"x"}) == {"x"}
    with pytest.raises(ManifestError, match=r"expected placeholders among \{x\}, got \{z\}"):
        command_placeholders(path, ["{z}"], {"x"})
    program = tmp_path / "run.sh"
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    assert resolve_program(path, ["./run.sh", "{x}"]) == [str(program), "{x}"]
    with pytest.raises(ManifestError, match="inside the manifest's folder"):
        resolve_program(path, ["../run.sh"])
    with pytest.raises(ManifestError, match="expected a program on PATH"):
        resolve_program(path, ["no-such-program-anywhere"])
