"""House test: every committed page and report of ``results/`` links only files that are there.

Every ``*.html`` (its ``href``, ``src``, comparison strips and ``#anchors``) and every ``*.md``
(its links and images) under ``results/``, checked by :func:`benchmarks.reports.links.broken_links`
with ``results/`` as the folder no link may leave: a link to a missing file (the quality page
once linked ``cells.jsonl`` beside ``cells.jsonl.gz``), to an id the page lacks, or to the network
fails here. The per-cell tables written on demand (:data:`benchmarks.reports.page.ON_DEMAND`) are
ignored by git, so a regenerated ``results/`` commits none of them, and so are the full-size
animations (``animations/*.mp4``, which ``bnerr animate`` writes).
"""

from __future__ import annotations

import shutil
import subprocess

import pytest

from benchmarks.reports.links import broken_links
from benchmarks.reports.page import ON_DEMAND
from tests._paths import RESULTS, ROOT

PAGES = sorted([*RESULTS.rglob("*.html"), *RESULTS.rglob("*.md")])


def test_results_has_pages_to_check():
    names = {p.relative_to(RESULTS).as_posix() for p in PAGES}
    assert {"index.html", "quality/index.html", "quality/README.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(RESULTS).as_posix())
def test_every_link_of_a_committed_page_resolves(page):
    assert broken_links(page, root=RESULTS) == []


def test_the_tables_written_on_demand_are_ignored_by_git():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    paths = [f"results/{suite}/{name}" for suite in ("quality", "new_suite") for name in ON_DEMAND]
    paths.append("results/animations/cornell.mp4")
    done = subprocess.run(
        ["git", "check-ignore", "--no-index", *paths], cwd=ROOT, capture_output=True, text=True
    )
    assert done.stdout.split() == paths
