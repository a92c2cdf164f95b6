"""The repository's folders, for tests that read committed files (results/, examples/) or start a
child Python that imports this checkout and its tests (``tests.*``); :func:`bnerr_cli` runs a
``bnerr`` command line in such a child."""

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
EXAMPLES = ROOT / "examples"


def bnerr_cli(
    *args: str,
    path: Sequence[Path] = (),
    cwd: Path = ROOT,
    timeout: float = 300,
    program: Sequence[str] = ("-m", "benchmarks.cli"),
) -> subprocess.CompletedProcess:
    """``bnerr ARGS`` (``python -m benchmarks.cli``; ``program`` another module) in a child Python
    on one thread that imports this checkout, then the folders ``path`` (plug-ins), from
    ``cwd``; its output captured as text."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), *map(str, path)]))
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    command = [sys.executable, *program, *args]
    return subprocess.run(
        command, env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout
    )
