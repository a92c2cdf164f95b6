"""External programs behind a manifest: the parts shared by the executable denoisers
(:mod:`denoisers.external`) and the renderers driven through the seed protocol
(:mod:`renderers.external`).

A manifest is a TOML (``*.toml``, read with :mod:`tomllib`) or JSON (``*.json``) table whose
``command`` is a list of arguments (argv, never a shell string) with ``{placeholders}``:

- :func:`read_manifest` parses the file and validates it against its model in
  :mod:`bnerr.schemas` (unknown keys refused listing the known ones, missing required ones, every
  value's type); a malformed file is reported with its line;
- :func:`command_placeholders` checks the placeholders of the command (an unknown one, or a
  format spec, is refused; ``{{`` and ``}}`` are literal braces);
- :func:`resolve_program` checks the program's own file (``command[0]``, or ``command[1]`` when
  ``command[0]`` is ``{python}``): given as a relative path it must exist and lie inside the
  manifest's folder once ``..`` and symlinks are resolved, and is made absolute; an absolute path
  is taken as written; a bare name (``oidnDenoise``) is looked up on ``PATH``;
- :func:`run_program` runs one argv in a session of its own (``start_new_session``) with stdin
  closed and stdout/stderr in files, kills its whole process group past the time limit, checks
  its exit status and returns its wall time (what the program left running in its group is killed
  when it exits); every failure is an
  :class:`~bnerr.errors.ExternalProcessError` whose first line names the program, its command and
  what was expected, followed by the last lines of its stderr (:func:`log_tail`).
"""

from __future__ import annotations

import contextlib
import os
import shlex
import shutil
import signal
import string
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TypeVar

from bnerr.errors import ExternalProcessError, FileFormatError
from bnerr.schemas.documents import parse, read
from bnerr.schemas.errors import validate

__all__ = [
    "MAX_MANIFEST_BYTES",
    "ManifestError",
    "command_placeholders",
    "log_tail",
    "program_error",
    "read_manifest",
    "resolve_program",
    "run_program",
]

#: How many of the program's last stderr (else stdout) lines an error quotes.
STDERR_LINES = 20
#: Largest manifest read, in bytes.
MAX_MANIFEST_BYTES = 1 << 20
M = TypeVar("M")


class ManifestError(FileFormatError):
    """A manifest (an executable denoiser's, an external renderer's) is malformed, holds an
    unknown key or a value of the wrong type, or names a program that is missing or lies outside
    its folder; the message names the file."""


# ------------------------------------------------------------------------------------------------
# Reading a manifest


def read_manifest(path: Path, model: type[M], what: str) -> M:
    """The manifest file ``path`` validated as ``model`` (a :mod:`bnerr.schemas` manifest:
    its defaults filled in); ``what`` names the kind in the messages.

    Raises:
        ManifestError: not ``*.toml`` / ``*.json``, unreadable, over 1 MiB, malformed (with the
            line), not a table, an unknown key, a missing required one or a bad value.
    """
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ManifestError(f"{path}: expected a {what} named *.toml or *.json, got {suffix!r}")
    fmt = suffix[1:]
    data = read(path, ManifestError, MAX_MANIFEST_BYTES)
    document = parse(data, fmt, str(path), ManifestError, what=f"valid {fmt.upper()}")
    return validate(model, document, ManifestError, "", source=str(path))


def command_placeholders(path: Path, command: Sequence[str], known: set[str]) -> set[str]:
    """The placeholders ``command`` uses; an unknown one (or a format spec) is refused."""
    used: set[str] = set()
    for arg in command:
        if "\0" in arg:  # no program can receive it (argv strings end at NUL)
            raise ManifestError(f"{path}: command: expected arguments without NUL, got {arg!r:.80}")
        try:
            fields = [(f, s, c) for _, f, s, c in string.Formatter().parse(arg) if f is not None]
        except ValueError as err:
            raise ManifestError(f"{path}: command: argument {arg!r}: {err}") from None
        for field, spec, conversion in fields:
            if field not in known or spec or conversion:
                raise ManifestError(
                    f"{path}: command: argument {arg!r}: expected placeholders among "
                    f"{', '.join('{' + k + '}' for k in sorted(known))}, got {{{field}}}"
                )
            used.add(field)
    return used


def resolve_program(path: Path, command: list[str]) -> list[str]:
    """``command`` with the program's path checked and, if relative, made absolute against the
    manifest ``path``'s folder (see the module docstring's rule)."""
    index = 1 if command[0] == "{python}" else 0
    if index >= len(command) or command[index].startswith("-"):
        return command  # {python} -m module / -c code: no file to check
    program = command[index]
    what = f"{path}: command[{index}]"
    if "{" in program or "}" in program:
        raise ManifestError(f"{what}: expected the program's path, got a placeholder {program!r}")
    if index == 0 and "/" not in program and os.sep not in program:
        if shutil.which(program) is None:
            raise ManifestError(f"{what}: expected a program on PATH, got {program!r}: not found")
        return command
    if Path(program).is_absolute():
        return command
    folder = path.parent.resolve()
    resolved = (folder / program).resolve()
    if not resolved.is_relative_to(folder):
        raise ManifestError(
            f"{what}: expected a path inside the manifest's folder {folder}, got {program!r}, "
            f"which resolves to {resolved} (through '..' or a symlink)"
        )
    if not resolved.is_file():
        raise ManifestError(f"{what}: expected an existing file, got {program!r}: no such file")
    if index == 0 and not os.access(resolved, os.X_OK):
        raise ManifestError(f"{what}: expected an executable file, got {program!r}: not executable")
    return [*command[:index], str(resolved), *command[index + 1 :]]


# ------------------------------------------------------------------------------------------------
# Running the program


def program_error(
    what: str, argv: Sequence[str], expected: str, got: str, log: str = ""
) -> ExternalProcessError:
    """The ExternalProcessError of one failed run: ``what`` (the program, e.g. ``denoiser 'x'
    (manifest.toml)``), its command and what was expected on one line, then the log tail."""
    message = f"{what}: command {shlex.join(argv)}: expected {expected}, got {got}"
    return ExternalProcessError(message + log)


def log_tail(work: Path) -> str:
    """The last lines the program wrote to stderr (else stdout) in ``work``, indented under a
    heading; "" when it wrote nothing."""
    for stream in ("stderr", "stdout"):
        log = work / f"{stream}.txt"
        text = log.read_bytes().decode("utf-8", "replace") if log.is_file() else ""
        lines = text.rstrip().splitlines()[-STDERR_LINES:]
        if lines:
            body = "\n".join(f"    {line}" for line in lines)
            return f"\n  last {len(lines)} line(s) of the program's {stream}:\n{body}"
    return ""


def _kill_group(proc: subprocess.Popen) -> None:
    """Kill the program's process group (its session: it and everything it started), then reap
    it. Called before the program is reaped, so its id cannot name another group yet."""
    _end_group(proc.pid)
    proc.wait()


def _end_group(pgid: int) -> None:
    """Kill what the program left running in its process group once it exited (a background
    child, a daemon it forked): nothing it started outlives the call. Its group id cannot name
    another group while a member lives (the kernel keeps the id until the group is empty)."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pgid, signal.SIGKILL)


def _status(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"killed by signal {signal.Signals(-code).name}"
    return f"exit status {code}"


def run_program(what: str, argv: list[str], *, cwd: Path, timeout_s: float, work: Path) -> float:
    """Run ``argv`` in ``cwd``, in a session of its own, with the time limit; its stdout and
    stderr go to ``work/stdout.txt`` and ``work/stderr.txt``. Returns its wall time in
    milliseconds (start to exit).

    Raises:
        ExternalProcessError: it would not start, ran past ``timeout_s`` (its process group is
            killed) or exited with a non-zero status (:func:`program_error`).
    """
    with open(work / "stdout.txt", "wb") as out, open(work / "stderr.txt", "wb") as err:
        start = time.perf_counter()
        try:
            proc = subprocess.Popen(
                argv,
                cwd=cwd,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=err,
                start_new_session=True,
            )
        except OSError as error:
            reason = error.strerror or str(error)
            raise program_error(what, argv, "a program that starts", reason) from None
        try:
            code = proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            _kill_group(proc)
            raise program_error(
                what,
                argv,
                f"an exit within timeout_s = {timeout_s:g} s",
                "none (its process group was killed)",
                log_tail(work),
            ) from None
        except BaseException:  # an interrupt while waiting: leave no program running
            _kill_group(proc)
            raise
        elapsed = (time.perf_counter() - start) * 1000.0
        _end_group(proc.pid)
    if code != 0:
        raise program_error(what, argv, "exit status 0", _status(code), log_tail(work))
    return elapsed
