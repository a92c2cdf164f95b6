"""Folders that refuse writes, for fault tests: a small tmpfs that fills up, and a read-only one.

A real file system is the honest test (the errors are the kernel's, partial writes included), but
mounting needs root: where ``mount`` fails (a CI runner without root), :func:`small_disk` and
:func:`read_only` skip, and the fault tests fall back to injecting the same ``OSError`` at the
write call (see tests/benchmarks/sweep/test_runner_faults.py). As root, ``chmod`` does not stop
writes, so a read-only folder is a tmpfs remounted ``ro``; without root it is ``chmod 0o555``.
"""

from __future__ import annotations

import contextlib
import errno
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

_PAGE = 4096


def _mount(*args: str) -> None:
    done = subprocess.run(["mount", *args], capture_output=True, text=True, check=False)
    if done.returncode:
        pytest.skip(f"cannot mount a tmpfs here ({done.stderr.strip() or done.returncode})")


@contextlib.contextmanager
def small_disk(folder: Path, size: int = 256 * 1024) -> Iterator[Path]:
    """A tmpfs of ``size`` bytes mounted on ``folder`` (created) for the ``with`` block."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    folder.mkdir(parents=True, exist_ok=True)
    _mount("-t", "tmpfs", "-o", f"size={size}", "none", str(folder))
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def fill(folder: Path, leave: int = _PAGE) -> Path:
    """Fill ``folder``'s file system until about ``leave`` bytes stay free (a whole page at least,
    so that the next large write is partly taken, then refused); return the filler file."""
    filler = folder / "filler"
    free = os.statvfs(folder).f_bavail * os.statvfs(folder).f_frsize
    with open(filler, "wb") as f:
        with contextlib.suppress(OSError):
            f.write(b"\0" * max(free - leave, 0))
    return filler


@contextlib.contextmanager
def read_only(folder: Path) -> Iterator[Path]:
    """``folder`` (created, with what it holds kept) read-only for the ``with`` block."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        modes = {p: p.stat().st_mode for p in [folder, *folder.rglob("*")] if p.is_dir()}
        for p in modes:
            p.chmod(0o555)
        try:
            yield folder
        finally:
            for p, mode in modes.items():
                p.chmod(mode)
        return
    held = folder.with_name(folder.name + ".held")
    folder.rename(held)
    with small_disk(folder, 64 * 1024 * 1024):
        subprocess.run(["cp", "-a", f"{held}/.", str(folder)], check=True)
        _mount("-o", "remount,ro", str(folder))
        yield folder


def no_space(path: object = None) -> OSError:
    """The ``OSError`` a full disk raises (``ENOSPC``), as injected where no tmpfs can be had."""
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), *([str(path)] if path else []))
