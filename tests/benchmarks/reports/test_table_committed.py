"""Tests of benchmarks.reports.table against the committed results: every committed table
regenerates byte for byte from its cells, the decision table names the lowest post-denoise error
of the committed suites, and the README's headline is the committed quality decision (the
toy-record tests of the same module are in test_table.py)."""

import functools
import re

import pytest

import benchmarks.reports as reports
from benchmarks.reports import decision, perceptual, seed, write_report
from benchmarks.reports.gap import write_gap_tables
from benchmarks.reports.groups import group_key
from benchmarks.reports.page import ON_DEMAND
from benchmarks.reports.table import summarize
from benchmarks.suites import get_suite
from benchmarks.sweep.records import (
    RESULTS_ARCHIVE,
    RESULTS_FILE,
    Record,
    final_records,
    load_records,
)
from tests._paths import RESULTS

#: The tables a results folder's report writes from its cells.jsonl (charts aside: PNG bytes
#: depend on the fonts and matplotlib build).
_TABLES = ("table.md", "table.csv", "decision.md", "gap.md", "gap.csv", "denoisers.md")


@functools.cache
def _committed_records(suite: str) -> tuple[Record, ...]:
    """The committed records of ``results/<suite>`` that its reports show (each cell's last look
    of an adaptive run, :func:`final_records`), read once per test process (the quality suite's
    take seconds to parse)."""
    return tuple(r for r in final_records(load_records(RESULTS / suite)) if r.has_pixels)


@functools.cache
def _committed_rows(suite: str) -> tuple[dict, ...]:
    """``summarize`` of :func:`_committed_records`, computed once per test process and shared by
    every test below that reads the committed rows (the quality suite's take about 16 s)."""
    return tuple(summarize(list(_committed_records(suite))))


@pytest.fixture(scope="module", autouse=True)
def _release_committed():
    """Drop the committed records and rows when this file is done: the quality suite's are
    millions of objects, which every later garbage collection of the worker would walk again
    (pytest's own collections at its end among them, about 2 s each)."""
    yield
    _committed_rows.cache_clear()
    _committed_records.cache_clear()


def _rows_of(suite: str) -> list[dict]:
    """A fresh copy of the shared rows (a test that edits one leaves the others' intact)."""
    return [dict(row) for row in _committed_rows(suite)]


def _shared_summary(suite: str, records, **options) -> list[dict]:
    """``summarize`` for ``write_report``: the shared rows when it is given exactly the committed
    records (the rows are a pure function of them), else a real summary."""
    committed = _committed_records(suite)
    same = len(records) == len(committed) and all(a is b for a, b in zip(records, committed))
    return _rows_of(suite) if same and not options else summarize(records, **options)


@pytest.mark.slow
@pytest.mark.parametrize("suite", ["quick", "stability", "gap", "quality", "seed"])
def test_every_committed_table_regenerates_byte_identical_from_its_cells(
    tmp_path, monkeypatch, suite
):
    # What bnerr bench --suite SUITE --report-only writes, file for file: a committed table that
    # no longer follows from its cells.jsonl (the code changed, the file was edited) fails here.
    folder, out = RESULTS / suite, tmp_path / suite
    assert any((folder / n).exists() for n in (RESULTS_FILE, RESULTS_ARCHIVE))
    records = _committed_records(suite)
    shares: list = []

    def gap_tables(out_dir, recs):
        shares.extend(write_gap_tables(out_dir, recs))
        return shares

    monkeypatch.setattr(reports, "summarize", functools.partial(_shared_summary, suite))
    monkeypatch.setattr(reports, "write_gap_tables", gap_tables)
    out.mkdir()
    write_report(out, records, title=f"bnerr bench --suite {suite}", charts=False)
    committed = [name for name in _TABLES if (folder / name).exists()]
    assert "table.md" in committed and "decision.md" in committed
    for name in committed:
        assert (out / name).read_bytes() == (folder / name).read_bytes(), name
    written = [n for n in _TABLES if (out / n).exists() and n not in committed]
    assert set(written) <= set(ON_DEMAND)  # the per-cell tables, left out of results/
    # The seed figures' README.md (written with the charts): its text, figures not drawn (PNG
    # bytes depend on the fonts), from the committed crops, which it only reads.
    readme = tmp_path / "readme" / suite
    readme.mkdir(parents=True)
    (readme / "crops").symlink_to(folder / "crops", target_is_directory=True)
    monkeypatch.setattr(seed, "seed_figure", lambda *args: None)
    monkeypatch.setattr(seed, "_save", lambda figure, path: None)
    seed.write_seed_report(readme, [r for r in records if r.has_pixels], shares)
    assert (readme / "README.md").exists() == (folder / "README.md").exists()
    if (folder / "README.md").exists():
        assert (readme / "README.md").read_bytes() == (folder / "README.md").read_bytes()


_COMMITTED = [RESULTS / name for name in ("quick", "quality")]


@pytest.mark.parametrize("folder", _COMMITTED, ids=lambda p: p.name)
def test_the_decision_table_names_the_lowest_post_denoise_error_of_the_committed_results(folder):
    if not _committed_records(folder.name):
        pytest.skip(f"no committed results in {folder.name}")
    rows = _rows_of(folder.name)
    best = decision.best_rows(rows)
    cells = {(r["scene"], r["spp"], r["denoiser"]) for r in rows if r["region"] == "all"}
    assert {(k[0][0], k[1], k[2]) for k in best} == cells
    for (group, spp, denoiser), row in best.items():
        same = [
            r
            for r in rows
            if group_key(r) == group
            and (r["spp"], r["denoiser"]) == (spp, denoiser)
            and r["strategy"] not in decision.decision_excludes()
        ]
        assert row["den_mse"] == min(r["den_mse"] for r in same) and row["strategy"] != "oracle"
    text = decision.decision_table(rows)
    lines = [line for line in text.splitlines() if line.startswith("| ")][1:]
    assert len(lines) == len({(k[0], k[1]) for k in best})
    rivals = decision.rival_counts(rows)
    for key, row in best.items():
        cell = decision._decision_cell(row, rivals.get(key, 1))
        assert f"({row['render_ms']:.0f} + {row['perm_ms']:.1f} ms)" in cell
        if row["strategy"] != "white":
            est = decision.corrected(row, rivals[key])
            assert f"{row['den_mse_ratio']:.2f} [" in cell
            # bold only below white beyond the interval corrected for picking the best of m
            assert est.lo <= row["den_mse_ratio_lo"] * (1 + 1e-12)
            assert est.hi >= row["den_mse_ratio_hi"] * (1 - 1e-12)
            assert cell.startswith("**") == (est.hi < 1.0)


def test_the_readmes_headline_table_is_the_committed_quality_decision():
    # The README's bold cells come from results/quality, never from a hand edit: its headline
    # table must be headline_table() of the committed records, for the scenes and denoisers it
    # names, in its order.
    readme = (RESULTS.parent / "README.md").read_text()
    found = re.search(r"\n(\| scene \| spp \| gaussian \|[^\n]*\n(?:\|[^\n]*\n)+)", readme)
    assert found, "README: the headline table (| scene | spp | gaussian | ...) is missing"
    lines = found.group(1).splitlines()
    denoisers = [c.strip() for c in lines[0].strip("|").split("|")][2:]
    scenes = list(dict.fromkeys(line.strip("|").split("|")[0].strip() for line in lines[2:]))
    rows = _rows_of("quality")
    region = get_suite("quality").resolve[0]  # the region whose verdicts the suite settles
    assert found.group(1) == decision.headline_table(rows, denoisers, scenes, region=region)
    # and its count of the verdicts is the one the table's cells give
    summary = decision.headline_summary(rows, denoisers, scenes, region=region)
    assert summary in " ".join(readme.split()), summary
    # and its one line on what a viewer sees: how many of those cells ColorVideoVDP agrees on
    agreement = perceptual.headline_agreement(rows, denoisers, scenes, region=region)
    assert agreement, "results/quality: no ColorVideoVDP verdicts to count"
    assert agreement in " ".join(readme.split()), agreement


def test_the_headline_reads_one_pixel_region_every_pixel_by_default():
    # the same rows in the unlit region (a copy): that region's headline is the whole image's
    # table, and the default headline does not read them
    rows = [r for r in _rows_of("quality") if r["region"] == "all" and r["spp"] == 4]
    unlit = [dict(r, region="unlit") for r in rows]
    denoisers, scenes = ["gaussian", "oidn"], ["direct", "cornell"]
    want = decision.headline_table(rows, denoisers, scenes)
    assert decision.headline_table(rows + unlit, denoisers, scenes) == want
    assert decision.headline_table(unlit, denoisers, scenes, region="unlit") == want
    assert decision.headline_table(rows, denoisers, scenes, region="unlit").count("\n") == 2
    summary = decision.headline_summary(rows, denoisers, scenes)
    assert decision.headline_summary(unlit, denoisers, scenes, region="unlit") == summary


def test_the_headline_counts_each_verdict_once_with_the_seed_sets_it_took():
    # the 4-spp rows as if they had stopped at the look of 4 seed sets, the others as measured
    rows = [
        dict(r, seed_sets=4) if r["spp"] == 4 else r
        for r in _rows_of("quality")
        if r["strategy"] in ("white", "ldbn", "zsobol")
    ]
    most = max(r["seed_sets"] for r in rows)
    reached = {  # the seed sets of each cell (every strategy of a cell grows with the others)
        (r["scene"], str(r["spp"]), r["denoiser"]): r["seed_sets"]
        for r in rows
        if r["region"] == "all"
    }
    table = decision.headline_table(rows, ["gaussian", "taa"], ["direct", "indirect"])
    head = table.splitlines()[0].strip("| ").split(" | ")
    body = [line.strip("| ").split(" | ") for line in table.splitlines()[2:]]
    cells = [(row[0], row[1], d, c) for row in body for d, c in zip(head[2:], row[2:])]
    assert len(cells) == 12
    assert all(c.endswith(f"({reached[scene, spp, d]})") for scene, spp, d, c in cells), cells
    assert {reached[scene, "4", d] for scene, _, d, _ in cells} == {4}
    summary = decision.headline_summary(rows, ["gaussian", "taa"], ["direct", "indirect"])
    bold = sum(c.startswith("**") for _, _, _, c in cells)
    opened = sum(" open " in c for _, _, _, c in cells)
    assert f"Of the 12 cells {12 - opened} carry a verdict: {bold} bold," in summary
    assert f"{opened} are open" in summary and f"at most {most} seed sets" in summary


# -- flicker (the temporal metrics) -------------------------------------------------------------
