"""Tests for the bnerr package itself: importing it loads nothing heavy, and the package a test
under tests/bnerr/ imports is the real one (tests/bnerr/ is ``tests.bnerr``, not ``bnerr``)."""

import subprocess
import sys
from pathlib import Path

import bnerr
import denoisers
import renderers
from benchmarks import cli
from tests._paths import ROOT


def test_the_imported_packages_are_the_sources_not_the_test_folders():
    for package in (bnerr, renderers, denoisers):
        assert Path(package.__file__).resolve() == ROOT / package.__name__ / "__init__.py"
    assert Path(cli.__file__).resolve() == ROOT / "benchmarks" / "cli.py"
    assert __name__ == "tests.bnerr.test_init"


def test_importing_bnerr_loads_no_submodule_but_the_moved_paths_and_exports_nothing():
    code = "import sys, bnerr; print(sorted(m for m in sys.modules if m.startswith('bnerr.')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0 and out.stdout.strip() == "['bnerr._moved']"  # the standard library
    assert bnerr.__all__ == []
