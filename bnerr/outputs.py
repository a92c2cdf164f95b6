"""Output folders and files: one writer per folder, checked before any work starts.

:func:`check_output` validates an output path before a command does any work: that a folder is
not an existing file and a file not an existing folder, that the place can be written (it creates
the folder and writes a probe file there, which catches read-only file systems and ``/proc``),
and that the file system has room for a rough estimate of what will be written. Every failure
is an :class:`OutputPathError` with a one-line message.

:func:`temporary_name` is the name :func:`bnerr.io.atomic_write` gives its temporary files:
hidden, recognisable, and carrying the writer's process id, so that
:func:`clean_stale_temporaries` can remove the ones a killed process left behind (SIGKILL runs
no cleanup) without touching a live writer's.

:func:`output_lock` takes an exclusive advisory lock (``fcntl.flock``) on ``<folder>/.bnerr.lock``
for as long as a command writes into the folder, so that a second ``bnerr bench``, ``train`` or
``render`` into the same ``--out`` refuses at once with :class:`OutputBusyError` instead of
interleaving its files with the first one's. The lock is released by the kernel when the
process ends, however it ends (a SIGKILL leaves no stale lock).

:func:`undo_on_failure` holds that lock and removes what the command created in the folder
(files, folders, the lock file, the folder itself) when it fails with an exception: a refusal
that comes late (a plug-in that raises mid-run) leaves nothing half-written behind, and a busy
folder's files (another process's) are never touched.

Not for: network file systems whose ``flock`` is not shared between hosts.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path

from bnerr.errors import BnerrError, DtypeError

__all__ = [
    "LOCK_NAME",
    "OutputBusyError",
    "OutputPathError",
    "check_folder_path",
    "check_output",
    "clean_stale_temporaries",
    "output_lock",
    "temporary_name",
    "undo_on_failure",
]

#: The lock file's name inside a locked folder.
LOCK_NAME = ".bnerr.lock"


class OutputBusyError(BnerrError, OSError):
    """Another process is writing into the same output folder."""


class OutputPathError(BnerrError, OSError):
    """An output path cannot be written: wrong kind, not writable, or no room on its disk."""


#: ``.<name>.bnerr-tmp-<pid>-<8 hex><suffix>``: the temporaries of :func:`temporary_name`.
_TEMP = re.compile(r"^\.(?P<name>.+)\.bnerr-tmp-(?P<pid>\d+)-[0-9a-f]{8}(?P<suffix>.*)$")
#: ``.<name>.<12 hex>.tmp<suffix>``: the temporaries of earlier versions (no process id).
_LEGACY_TEMP = re.compile(r"^\.(?P<name>.+)\.[0-9a-f]{12}\.tmp(?P<suffix>.*)$")


def temporary_name(path: Path, suffix: str) -> Path:
    """The hidden temporary file next to ``path`` that an atomic write renames over it."""
    return path.with_name(f".{path.name}.bnerr-tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{suffix}")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: someone else's live process
        return True
    return True


def clean_stale_temporaries(folder: str | os.PathLike, names: Iterable[str] = ()) -> list[Path]:
    """Remove the temporaries of atomic writes that a killed process left in ``folder``.

    Removed: :func:`temporary_name` files whose writer process no longer runs, and, for the
    file names in ``names`` (whose writer the caller knows is itself, for example because it
    holds the folder's :func:`output_lock`), temporaries of any age and of the older naming
    ``.<name>.<hex>.tmp<suffix>``. Files that vanish meanwhile or cannot be removed are skipped.

    Returns:
        The removed paths, sorted.
    """
    owned = set(names)
    removed = []
    try:
        entries = sorted(Path(folder).iterdir())
    except OSError:
        return []
    for entry in entries:
        match = _TEMP.match(entry.name)
        stale = match is not None and (match["name"] in owned or not _alive(int(match["pid"])))
        legacy = _LEGACY_TEMP.match(entry.name)
        stale = stale or (legacy is not None and legacy["name"] in owned)
        if stale and entry.is_file():
            with contextlib.suppress(OSError):
                entry.unlink()
                removed.append(entry)
    return removed


def _one_line(err: BaseException) -> str:
    if isinstance(err, OSError) and err.strerror:
        return err.strerror
    return str(err).splitlines()[0] if str(err) else type(err).__name__


def _nearest_existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _make_folder(folder: Path, name: str) -> None:
    check_folder_path(folder, name)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as err:
        raise OutputPathError(
            f"{name} {folder}: expected a folder that can be created, got {_one_line(err)}"
        ) from None


def _probe(folder: Path, name: str) -> None:
    probe = folder / f".bnerr-probe-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    try:
        with open(probe, "wb") as handle:
            handle.write(b"0")
    except OSError as err:
        raise OutputPathError(
            f"{name} {folder}: expected a writable folder, got {_one_line(err)}"
        ) from None
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()


def check_folder_path(path: str | os.PathLike, name: str) -> Path:
    """Check, creating nothing, that ``path`` can be a folder: it is one, or the nearest part of it
    that exists is a folder (the caller creates it when it writes there).

    Raises:
        OutputPathError: ``path``, or a part of it, is an existing file.
    """
    folder = Path(path)
    existing = _nearest_existing(folder)
    if existing.exists() and not existing.is_dir():
        where = "an existing file" if existing == folder else f"{existing}, an existing file"
        raise OutputPathError(f"{name} {folder}: expected a folder, got {where}")
    return folder


def check_output(
    path: str | os.PathLike,
    kind: str,
    *,
    need_bytes: float = 0,
    name: str = "--out",
) -> Path:
    """Check, before any work, that ``path`` can be written as ``kind`` (``"file"`` or ``"dir"``).

    Creates the folder (``path`` for a ``"dir"``, its parent for a ``"file"``) and writes and
    removes a probe file there. ``need_bytes`` is a rough estimate of what will be written;
    the file system must have that much free.

    Raises:
        OutputPathError: ``path`` is an existing file where a folder is expected or the other
            way round (or neither a file nor a folder), its folder cannot be created or written
            (read-only file system, ``/proc``, permissions), or its disk has too little room.
        DtypeError: ``path`` is not a str or path, or ``kind`` is neither name.
    """
    if not isinstance(path, (str, os.PathLike)) or kind not in ("file", "dir"):
        raise DtypeError(
            f"check_output: expected a path and 'file' or 'dir', got {path!r}, {kind!r}"
        )
    out = Path(path)
    if kind == "dir" and out.exists() and not out.is_dir():
        raise OutputPathError(f"{name} {out}: expected a folder, got an existing file")
    if kind == "file" and out.is_dir():
        raise OutputPathError(f"{name} {out}: expected a file name, got an existing folder")
    if kind == "file" and out.exists() and not out.is_file():
        raise OutputPathError(f"{name} {out}: expected a regular file, got another kind of file")
    folder = out if kind == "dir" else out.parent
    _make_folder(folder, name)
    _probe(folder, name)
    free = shutil.disk_usage(folder).free
    if need_bytes > free:
        raise OutputPathError(
            f"{name} {out}: expected {need_bytes / 2**20:.1f} MiB of free disk space for the "
            f"output, got {free / 2**20:.1f} MiB free"
        )
    return out


@contextlib.contextmanager
def output_lock(
    folder: str | os.PathLike, what: str = "bnerr", lock_name: str = LOCK_NAME
) -> Iterator[Path]:
    """Hold the folder's write lock for the duration of the ``with`` block.

    Args:
        folder: the output folder (created if missing).
        what: the command taking the lock, for the error message (``"bnerr bench"``).
        lock_name: the lock file's name in ``folder``; a command that writes one named file
            into a shared folder (``bnerr train``) locks that file's own name instead.

    Yields:
        The folder as a :class:`~pathlib.Path`.

    Raises:
        OutputBusyError: another live process holds the lock.
    """
    import fcntl  # POSIX only; imported here so that the module imports everywhere

    path = Path(folder)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path / lock_name, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno not in (errno.EWOULDBLOCK, errno.EACCES):
                raise
            raise OutputBusyError(
                f"{path}: expected an output folder no other process writes to, but another "
                f"{what} holds its lock ({path / lock_name}); wait for it or choose another --out"
            ) from None
        yield path
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def _entries(folder: Path) -> set[Path] | None:
    """Every path under ``folder`` (itself included), or None when it does not exist."""
    if not folder.is_dir():
        return None
    found = {folder}
    for base, dirs, files in os.walk(folder):
        found.update(Path(base, name) for name in [*dirs, *files])
    return found


@contextlib.contextmanager
def undo_on_failure(
    folder: str | os.PathLike, what: str = "bnerr", lock_name: str = LOCK_NAME
) -> Iterator[Path]:
    """Hold the folder's write lock (:func:`output_lock`) for the ``with`` block; if the block
    raises, remove every file and folder under ``folder`` that was not there when it took the
    lock, then the lock file and ``folder`` itself if they were new, and re-raise.

    What was there before is left as it was (a command that overwrites a file does so
    atomically, :func:`bnerr.io.atomic_write`), and so is everything when the lock is busy: the
    files another process is writing are never touched.

    Raises:
        OutputBusyError: another live process holds the lock (nothing is removed).
    """
    path = Path(folder)
    folder_was = path.is_dir()
    lock_was = (path / lock_name).exists()
    locked = False
    try:
        with output_lock(path, what, lock_name):
            locked = True
            before = _entries(path) or set()
            try:
                yield path
            except BaseException:
                after = (_entries(path) or set()) - before - {path / lock_name}
                _remove(sorted(after, key=lambda p: len(p.parts), reverse=True))
                raise
    except BaseException:
        if locked:  # the lock released: its file, then the folder, if this call made them
            _remove(([] if lock_was else [path / lock_name]) + ([] if folder_was else [path]))
        raise


def _remove(paths: list[Path]) -> None:
    """Remove each path (a folder only when empty), deepest first as given; errors skipped."""
    for entry in paths:
        with contextlib.suppress(OSError):
            if entry.is_dir() and not entry.is_symlink():
                entry.rmdir()
            else:
                entry.unlink()
