"""Child processes that run this checkout: the ``bnerr`` console script and ``python -m``."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def bnerr_command() -> list[str]:
    """The ``bnerr`` console script of the environment running the tests (next to
    ``sys.executable``), else the module it runs."""
    script = Path(sys.executable).parent / "bnerr"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "benchmarks.cli"]


def child_env(**extra: str) -> dict[str, str]:
    """This environment with this checkout first on ``PYTHONPATH`` (the script may be installed
    from another checkout), plus ``extra``."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return dict(os.environ, PYTHONPATH=path, **extra)
