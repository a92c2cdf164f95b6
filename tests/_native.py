"""The C example of examples/native/ as the doc pages run it: the command lines of a page's
first ``bash`` block, run as written (``bnerr`` being this checkout's command line) in a copy of
the example, where the tracer is built and the LDBN keys exported once per session."""

from __future__ import annotations

import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

from tests._paths import ROOT
from tests._processes import bnerr_command, child_env

#: The pages whose first ``bash`` block builds and runs the example.
PROTOCOL_DOC = ROOT / "docs" / "RENDERER_PROTOCOL.md"
EVAL_DOC = ROOT / "docs" / "EVAL.md"
#: The lines every such block starts with: the build and the export.
BUILD_LINES = 2


def doc_commands(doc: Path) -> list[str]:
    """The command lines of the doc page's first ``bash`` block."""
    block = doc.read_text(encoding="utf-8").split("```bash\n")[1].split("```")[0]
    return [line for line in block.splitlines() if line.strip()]


def run_line(line: str, cwd: Path) -> None:
    """Run one doc command line in ``cwd`` (no shell: split with shlex); fail the test with its
    output when it fails."""
    argv = shlex.split(line)
    argv = [*bnerr_command(), *argv[1:]] if argv[0] == "bnerr" else argv
    done = subprocess.run(
        argv, cwd=cwd, env=child_env(), capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, f"{line}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"


def build_native(root: Path) -> Path:
    """``root`` holding a copy of examples/native/ in which the protocol page's build and export
    lines have run (skipped where no C compiler exists)."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler 'cc' on the PATH: the native example cannot be built")
    (root / "examples").mkdir()
    shutil.copytree(
        ROOT / "examples" / "native",
        root / "examples" / "native",
        ignore=shutil.ignore_patterns("tracer", "keys"),
    )
    for line in doc_commands(PROTOCOL_DOC)[:BUILD_LINES]:
        run_line(line, root)
    return root
