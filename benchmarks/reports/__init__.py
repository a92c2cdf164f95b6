"""The reports of a results folder, every one derived from ``<out>/cells.jsonl`` alone, so a
report can be rebuilt without rendering anything (``python -m benchmarks.reports DIR``, or
``bnerr bench --report-only``).

:func:`write_report` writes them all:

- ``table.csv`` and ``table.md`` (:mod:`~benchmarks.reports.table`): one row per cell, and the
  readable report (headline, one section per scene and condition, the flagged cells, and the
  share of the image each restricted region covers, :mod:`~benchmarks.reports.regions`);
- ``decision.md`` (:mod:`~benchmarks.reports.decision`): the strategy to use per scene,
  condition, spp and denoiser;
- ``perceptual.md`` (:mod:`~benchmarks.reports.perceptual`): the same cells judged in JOD
  (ColorVideoVDP) and by FLIP, when the records hold them (else no file), with the pictures of
  the cells where the eye and the MSE disagree (:mod:`~benchmarks.reports.disagreement`,
  ``disagree_<metric>.png``);
- ``gap.md`` and ``gap.csv`` (:mod:`~benchmarks.reports.gap`): each strategy's share of the
  white-to-oracle distance, when the records hold white and the oracle;
- ``denoisers.md`` (:mod:`~benchmarks.reports.denoisers`): how each denoiser responds to each
  strategy's noise, when the records hold the denoisers it compares;
- the PNG charts (:mod:`~benchmarks.reports.charts`), in one colour per strategy
  (:mod:`~benchmarks.reports.palette`);
- the seed suite's figures and ``README.md`` (:mod:`~benchmarks.reports.seed`), when the
  records hold crops and the error's spectrum over the coherent region;
- ``index.html`` (:mod:`~benchmarks.reports.page`): the suite's results page, with the preview
  strips it shows (:mod:`~benchmarks.reports.previews`); the index of the whole results folder is
  :func:`~benchmarks.reports.page.write_index`, which ``bnerr bench`` calls.

Every report groups and orders its rows through :mod:`~benchmarks.reports.groups` and writes its
Markdown tables with :mod:`~benchmarks.reports.markdown`.

Records whose region held no pixel (a coherent region on a frame too small or too textured to
have one: :attr:`benchmarks.sweep.records.Record.has_pixels`) are left out of every report.

Not for: deciding anything. The reports state the measured ratios and their intervals; a cell is
flagged "worse than white" only when the whole interval lies above 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from benchmarks.reports.charts import write_charts
from benchmarks.reports.decision import decision_table
from benchmarks.reports.denoisers import write_denoise_tables
from benchmarks.reports.disagreement import shown_tiles, write_disagreements
from benchmarks.reports.gap import write_gap_tables
from benchmarks.reports.page import write_suite_page
from benchmarks.reports.perceptual import perceptual_report
from benchmarks.reports.regions import coverage_markdown
from benchmarks.reports.seed import write_seed_report
from benchmarks.reports.table import csv_text, markdown_table, summarize
from benchmarks.sweep.records import Record, final_records, load_records
from bnerr.io import atomic_write

__all__ = ["write_report"]


def write_report(
    out_dir: str | Path,
    records: Sequence[Record] | None = None,
    title: str | None = None,
    charts: bool = True,
) -> str:
    """Write ``table.csv``, ``table.md``, ``decision.md``, ``perceptual.md`` (when the records
    hold a perceptual metric), ``gap.md`` / ``gap.csv`` (when the
    records hold white and the oracle: :mod:`benchmarks.reports.gap`), the charts and the page
    ``index.html`` into ``out_dir``; return the Markdown of ``table.md``.

    Args:
        out_dir: the suite's output folder (holding ``cells.jsonl`` unless ``records`` is given).
        records: the runner's records; read from ``out_dir`` when None.
        title: heading of ``table.md`` (default: the folder's name).
        charts: draw the PNG charts too.
    """
    out = Path(out_dir)
    records = load_records(out) if records is None else list(records)
    # an empty coherent region measured nothing; an adaptive run's earlier looks are superseded
    records = [r for r in final_records(records) if r.has_pixels]
    rows = summarize(records)
    text = markdown_table(rows, title or f"bnerr bench: {out.name}")
    regions = coverage_markdown(records)  # "" for results without coverage: table.md unchanged
    text = text + "\n" + regions if regions else text
    with atomic_write(out / "table.csv") as tmp:
        Path(tmp).write_text(csv_text(rows))
    with atomic_write(out / "table.md") as tmp:
        Path(tmp).write_text(text)
    with atomic_write(out / "decision.md") as tmp:
        Path(tmp).write_text(decision_table(rows))
    perceptual = perceptual_report(rows, pictures=write_disagreements(out, records, rows))
    kept = shown_tiles(out, records, rows)  # before the page strips the crops: kept in them
    if perceptual:
        with atomic_write(out / "perceptual.md") as tmp:
            Path(tmp).write_text(perceptual)
    else:  # a report is a function of the records: none that hold no perceptual metric
        (out / "perceptual.md").unlink(missing_ok=True)
    shares = write_gap_tables(out, records)
    write_denoise_tables(out, records, rows)
    if charts:
        write_charts(rows, records, out, shares)
        write_seed_report(out, records, shares)
    write_suite_page(out, rows, records, title or f"bnerr bench: {out.name}", kept)
    return text
