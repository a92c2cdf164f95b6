"""Probes of the new doors (issue 41): a table of bad inputs per door, each with what a good
refusal is.

A :class:`Bad` case is one bad input: ``run(tmp_path)`` feeds it through the door (the module's
API, or ``bnerr.main([...])`` in-process), and the case says the typed error expected and the
words its message must hold (the plug-in, file or key named, what was expected and what came).
:func:`check` runs a case and checks the refusal: the typed error of :mod:`bnerr.errors`, a
one-line message (an :class:`~bnerr.errors.ExternalProcessError` may quote the program's stderr
under its first line), the words. :func:`refused_on_the_command_line` does the same through the
CLI: exit code 2, one line ``bnerr <command>: error: ...``, no traceback.
"""

from __future__ import annotations

import os
import re
import signal
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from bnerr.errors import BnerrError, ExternalProcessError


@dataclass(frozen=True)
class Bad:
    """One bad input of a door: ``run(tmp_path)`` feeds it; ``error`` and ``words`` (a regular
    expression searched in the message's first line) are what a good refusal is."""

    name: str
    run: Callable[[Path], object]
    error: type[BnerrError]
    words: str


def ids(cases: Sequence[Bad]) -> list[str]:
    return [case.name for case in cases]


def check(case: Bad, tmp_path: Path) -> BnerrError:
    """Run ``case``; check it raised its typed error with its words on one line; return it."""
    with pytest.raises(case.error) as info:
        case.run(tmp_path)
    message = str(info.value)
    first = message.splitlines()[0] if message else ""
    if not isinstance(info.value, ExternalProcessError):
        assert "\n" not in message, f"{case.name}: expected one line, got {message!r}"
    assert re.search(case.words, first), f"{case.name}: expected {case.words!r} in {first!r}"
    return info.value


def refused_on_the_command_line(
    argv: Sequence[str], capsys: pytest.CaptureFixture, words: str
) -> str:
    """``bnerr ARGV`` in-process: exit code 2, its last stderr line ``bnerr CMD: error: ...``
    holding ``words``, no traceback; returns that line."""
    from benchmarks.cli import main

    capsys.readouterr()
    code = main(list(argv))
    err = capsys.readouterr().err
    assert code == 2, f"expected exit code 2, got {code}: {err}"
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert lines, f"expected a line 'bnerr {argv[0]}: error: ...', got {err!r}"
    assert re.search(words, lines[0]), f"expected {words!r} in {lines[0]!r}"
    return lines[0]


def _gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie not yet reaped by init counts as ended)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    stat = Path(f"/proc/{pid}/stat")
    return stat.is_file() and stat.read_text().split(")")[-1].split()[0] == "Z"


def assert_ended(pid: int, what: str, seconds: float = 5.0) -> None:
    """Fail unless process ``pid`` ends within ``seconds`` (it is then killed: nothing stays)."""
    deadline = time.monotonic() + seconds
    while not _gone(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    if not _gone(pid):
        os.kill(pid, signal.SIGKILL)
        pytest.fail(f"{what} {pid} was left running")
