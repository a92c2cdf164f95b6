"""The repository's folders, for tests that read committed files (results/, examples/) or start a
child Python that imports this checkout and its tests (``tests.*``)."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
