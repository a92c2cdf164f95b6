"""Tests of benchmarks/cli.py: a user's error is one line on stderr and exit code 2."""

import argparse
import warnings

import pytest

from benchmarks import cli


def _run(monkeypatch, func):
    def build_parser(only=None):
        parser = argparse.ArgumentParser(prog="bnerr")
        sub = parser.add_subparsers(dest="command", required=True)
        p = sub.add_parser("boom")
        p.set_defaults(func=func)
        return parser

    monkeypatch.setattr(cli, "build_parser", build_parser)
    return cli.main(["boom"])


def _run_raising(monkeypatch, error):
    return _run(monkeypatch, lambda args: (_ for _ in ()).throw(error))


def test_a_warning_is_one_line_and_the_command_goes_on(monkeypatch, capsys):
    def warn(args):
        warnings.warn("--cache /c: expected a writable reference cache, got ...", stacklevel=2)
        return 0

    assert _run(monkeypatch, warn) == 0
    err = capsys.readouterr().err
    assert err == "bnerr boom: warning: --cache /c: expected a writable reference cache, got ...\n"
    assert warnings.showwarning is not cli._show_warning  # put back after the command


@pytest.mark.parametrize(
    ("error", "message"),
    [
        (OSError(28, "No space left on device", "/x/a.exr"), "/x/a.exr: No space left on device"),
        (PermissionError(13, "Permission denied"), "Permission denied"),
        (MemoryError(), "out of memory (MemoryError)"),
        (
            RuntimeError("DefaultCPUAllocator: not enough memory: you tried to allocate 9 GB"),
            "out of",
        ),
    ],
)
def test_file_system_and_memory_errors_are_one_line(monkeypatch, capsys, error, message):
    assert _run_raising(monkeypatch, error) == 2
    err = capsys.readouterr().err
    assert err.startswith("bnerr boom: error: ") and message in err and err.count("\n") == 1


def test_a_bug_still_shows_its_traceback(monkeypatch):
    with pytest.raises(RuntimeError, match="a bug"):
        _run_raising(monkeypatch, RuntimeError("a bug"))


def test_a_command_imports_only_its_own_module():
    # bnerr render must not pay for importing every other command's dependencies at start-up.
    import subprocess
    import sys

    code = (
        "import sys; from benchmarks.cli import main\n"
        "try:\n    main(['scenes', '--help'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in sys.modules if m.startswith('benchmarks.commands.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "['benchmarks.commands.scenes']"
