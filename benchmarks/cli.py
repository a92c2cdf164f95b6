"""The ``bnerr`` command line.

Subcommands live one per module in :mod:`benchmarks.commands`; each module defines
``register(subparsers)`` that adds its parser and sets ``func`` (called with the parsed args,
returning an exit code). They are discovered here, so adding a command touches no other file.
A run of one command imports only that command's module (its imports are what the command needs:
the renderer, the denoisers, the sweep); ``bnerr --help`` and an unknown name import them all,
to list them. Measured here: ``bnerr render --help`` starts in 2.4-2.5 s, ``bnerr --help`` (every
command) in 3.7-4.0 s.
The CLI lives in :mod:`benchmarks` because it is the top of the import graph: ``bnerr render``
and ``bnerr train`` need the renderer, which :mod:`bnerr` must not import.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import os
import pkgutil
import sys
import warnings
from typing import NoReturn, TextIO

import benchmarks.commands as commands
from bnerr.errors import BnerrError

__all__ = ["OneLineParser", "UsageError", "build_parser", "entry", "main"]


def command_names() -> list[str]:
    """The subcommands, from the modules of :mod:`benchmarks.commands` (none imported)."""
    infos = pkgutil.iter_modules(commands.__path__)
    return sorted(info.name for info in infos if not info.name.startswith("_"))


class UsageError(SystemExit):
    """A command line argparse refused, already printed as one line (exit code 2)."""


class OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose refusal is one line, ``bnerr <command>: error: <message>``, like
    every other error of the CLI (argparse's own prints its usage first); its subparsers are of
    this class too (``add_subparsers`` makes them of the parent's class)."""

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {message} (see {self.prog} --help)", file=sys.stderr)
        raise UsageError(2)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``bnerr`` parser with every subcommand, or only ``only`` (its module alone imported)."""

    parser = OneLineParser(
        prog="bnerr",
        description=(
            "Measure how much distributing Monte Carlo error as blue noise in screen space "
            "lowers the error after denoising, and what it costs."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in [only] if only is not None else command_names():
        importlib.import_module(f"{commands.__name__}.{name}").register(sub)
    return parser


def _one_line(err: BaseException) -> str | None:
    """The one-line message of an error a user can act on, or None for a bug (a traceback)."""
    if isinstance(err, BnerrError):
        return str(err)
    if isinstance(err, OSError):  # a file system's refusal the checks could not foresee
        where = f"{err.filename}: " if err.filename else ""
        return f"{where}{err.strerror or err}"
    if isinstance(err, MemoryError) or (
        isinstance(err, RuntimeError) and "alloc" in str(err).lower() and "memory" in str(err)
    ):
        return f"out of memory ({str(err).splitlines()[0] if str(err) else type(err).__name__})"
    return None


def _show_warning(
    command: str,
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """A warning during a command as one line, ``bnerr <command>: warning: <message>`` (a
    reference cache that refuses writes, a torn results line dropped on resume...), not Python's
    two lines of file, line number and source."""
    print(f"bnerr {command}: warning: {message}", file=file or sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; a user's error (bad input, file system, memory) is one line on stderr
    and exit code 2, never a traceback; a warning is one line on stderr too."""
    return _run(argv)[0]


def entry() -> NoReturn:
    """The ``bnerr`` console script: :func:`main`, then the process ends.

    A command whose parser sets ``fast_exit`` (``bnerr render``: every file it wrote is closed
    and renamed into place, its lock released, the background build a detached process) ends
    with ``os._exit`` once stdout and stderr are flushed, skipping the interpreter's teardown:
    with torch loaded, that teardown (clearing every module, the garbage collector over torch's
    objects) took 0.65-0.8 s here, a quarter of a warm `bnerr render` process. Commands that
    leave work to ``atexit`` (Ray's shutdown, temporary folders) exit normally.
    """
    code, fast = _run(None)
    if fast:
        os._exit(code if _flushed() else 120)
    sys.exit(code)


def _flushed() -> bool:
    """Flush stdout and stderr; False if one refused (a reader that closed its pipe): the exit
    code is then 120, Python's own when its teardown cannot flush."""
    ok = True
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe, a closed file
            ok = False
    return ok


def _run(argv: list[str] | None) -> tuple[int, bool]:
    """:func:`main`'s exit code, and whether the command may skip the interpreter's teardown."""
    argv = sys.argv[1:] if argv is None else argv
    wanted = next((a for a in argv if not a.startswith("-")), None)
    only = wanted if wanted in command_names() else None
    try:
        args = build_parser(only).parse_args(argv)
    except UsageError:
        return 2, False
    fast = bool(getattr(args, "fast_exit", False))
    try:
        with warnings.catch_warnings():
            warnings.showwarning = functools.partial(_show_warning, args.command)
            return int(args.func(args) or 0), fast
    except (BnerrError, OSError, MemoryError, RuntimeError) as err:
        message = _one_line(err)
        if message is None:
            raise
        print(f"bnerr {args.command}: error: {message}", file=sys.stderr)
        return 2, fast


if __name__ == "__main__":
    entry()
