"""What the Cycles tests share: whether a Python with ``bpy`` is here (``make cycles``), and the
call that skips a test with the reason where it is not."""

from __future__ import annotations

import functools
import subprocess

import pytest

from bnerr.errors import MissingExtraError


@functools.cache
def bpy_missing() -> str:
    """Why the Cycles tests cannot run here ("" when they can)."""
    from renderers.cycles.session import bpy_python

    try:
        python = bpy_python()
    except MissingExtraError as err:
        return str(err)
    done = subprocess.run(
        [str(python), "-c", "import bpy"], capture_output=True, text=True, timeout=120
    )
    if done.returncode != 0:
        return f"bpy does not import under {python}: {done.stderr.strip().splitlines()[-1:]}"
    return ""


def skip_without_bpy() -> None:
    """Skip the calling test, with the reason, where no Python with ``bpy`` is installed."""
    reason = bpy_missing()
    if reason:
        pytest.skip(reason)
