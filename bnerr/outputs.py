"""Output folders and files: one writer per folder, checked before any work starts.

:func:`output_lock` takes an exclusive advisory lock (``fcntl.flock``) on ``<folder>/.bnerr.lock``
for as long as a command writes into the folder, so that a second ``bnerr bench``, ``train`` or
``render`` into the same ``--out`` refuses at once with :class:`OutputBusyError` instead of
interleaving its files with the first one's. The lock is released by the kernel when the
process ends, however it ends (a SIGKILL leaves no stale lock).

Not for: network file systems whose ``flock`` is not shared between hosts.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator
from pathlib import Path

from bnerr.errors import BnerrError

__all__ = ["LOCK_NAME", "OutputBusyError", "output_lock"]

#: The lock file's name inside a locked folder.
LOCK_NAME = ".bnerr.lock"


class OutputBusyError(BnerrError, OSError):
    """Another process is writing into the same output folder."""


@contextlib.contextmanager
def output_lock(folder: str | os.PathLike, what: str = "bnerr") -> Iterator[Path]:
    """Hold the folder's write lock for the duration of the ``with`` block.

    Args:
        folder: the output folder (created if missing).
        what: the command taking the lock, for the error message (``"bnerr bench"``).

    Yields:
        The folder as a :class:`~pathlib.Path`.

    Raises:
        OutputBusyError: another live process holds the lock.
    """
    import fcntl  # POSIX only; imported here so that the module imports everywhere

    path = Path(folder)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno not in (errno.EWOULDBLOCK, errno.EACCES):
                raise
            raise OutputBusyError(
                f"{path}: expected an output folder no other process writes to, but another "
                f"{what} holds its lock ({path / LOCK_NAME}); wait for it or choose another --out"
            ) from None
        yield path
    finally:
        os.close(fd)  # closing the descriptor releases the lock
