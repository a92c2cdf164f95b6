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


def test_a_command_imports_only_its_own_module_and_help_neither_kornia_nor_scipy():
    # bnerr render must not pay for importing every other command's dependencies at start-up,
    # nor any command for kornia (0.8 s: its __init__ loads all of it) and scipy.special (0.4 s)
    # before it filters or computes an interval: bnerr --help imports every command's module.
    import subprocess
    import sys

    code = (
        "import sys; from benchmarks.cli import main\n"
        "def run(*argv):\n    try:\n        main(list(argv))\n    except SystemExit:\n"
        "        pass\n"
        "run('scenes', '--help')\n"
        "found = sorted(m for m in sys.modules if m.startswith('benchmarks.commands.'))\n"
        "run('--help')\n"
        "print(found, sorted({m.split('.')[0] for m in sys.modules} & {'kornia', 'scipy'}),"
        " sep='\\n', file=sys.stderr)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    *_, commands, heavy = out.stderr.strip().splitlines()
    assert commands == "['benchmarks.commands.scenes']" and heavy == "[]"


def _entry_process(args, tmp_path):
    """``benchmarks.cli.entry`` in a new process with an atexit handler that prints a marker."""
    import subprocess
    import sys

    code = (
        "import atexit, sys; from benchmarks.cli import entry\n"
        "atexit.register(lambda: print('teardown ran', flush=True))\n"
        f"sys.argv = ['bnerr', *{list(args)!r}]\n"
        "entry()"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path
    )


def test_render_exits_without_the_interpreters_teardown_and_keeps_its_files(tmp_path):
    out = tmp_path / "frames"
    args = ["render", "--scene", "direct", "--res", "8x8", "--spp", "1", "--frames", "1",
            "--no-compile", "--out", str(out)]  # fmt: skip
    done = _entry_process(args, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "teardown ran" not in done.stdout and "direct_0000.exr" in done.stdout
    written = sorted(p.name for p in out.iterdir())  # as a normal exit leaves them
    assert written == [".bnerr.lock", "direct_0000.exr", "direct_0000.png"]
    refused = _entry_process(["render", "--scene", "direct", "--spp", "0"], tmp_path)
    assert refused.returncode == 2 and "teardown ran" in refused.stdout  # argparse's refusal


def test_other_commands_exit_through_the_interpreters_teardown(tmp_path):
    done = _entry_process(["scenes"], tmp_path)
    assert done.returncode == 0 and done.stdout.rstrip().endswith("teardown ran")


def test_a_stream_that_refuses_its_flush_gives_exit_code_120(monkeypatch):
    class Closed:
        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    class Exited(Exception):
        pass

    def fake_exit(code):
        raise Exited(code)

    monkeypatch.setattr(cli, "_run", lambda argv: (0, True))
    monkeypatch.setattr(cli.os, "_exit", fake_exit)
    with pytest.raises(Exited, match="^0$"):
        cli.entry()
    monkeypatch.setattr(cli.sys, "stdout", Closed())
    with pytest.raises(Exited, match="^120$"):
        cli.entry()
