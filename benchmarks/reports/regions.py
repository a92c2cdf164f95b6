"""How much of the image each restricted pixel region covers: the section ``table.md`` ends with
when the records hold a region other than ``all`` with its coverage (the coherent region's
records always do: :attr:`benchmarks.sweep.records.Record.coverage`).

A region's coverage depends on the scene, its condition and the resolution, never on the
strategy or the denoiser: one row per group (:mod:`benchmarks.reports.groups`) and resolution,
the mean fraction over every measured frame of every seed set, with its smallest frame.

Not for: the metrics inside a region (the group sections of ``table.md``, ``gap.md``).
"""

from __future__ import annotations

from collections.abc import Iterable

from benchmarks.reports.groups import group_order, group_title
from benchmarks.reports.markdown import table_lines
from benchmarks.sweep.records import Record

__all__ = ["coverage_markdown"]


def _key(record: Record) -> tuple:
    c = record.cell
    return (c.scene, c.motion, c.depth, c.region, c.sampler)


def coverage_markdown(records: Iterable[Record]) -> str:
    """The ``## Pixel regions`` section (Markdown), or ``""`` when no record holds a coverage
    (results written before it was recorded: their ``table.md`` stays as it was)."""
    found: dict[tuple, list[float]] = {}
    for r in records:
        if r.coverage is not None:
            key = (_key(r), r.cell.width, r.cell.height)
            found.setdefault(key, [v for row in r.coverage for v in row])
    if not found:
        return ""
    order = sorted(found, key=lambda k: (group_order(k[0]), k[1], k[2]))
    body = [
        [
            group_title(key),
            f"{w}x{h}",
            f"{100 * sum(found[(key, w, h)]) / len(found[(key, w, h)]):.1f} %",
            f"{100 * min(found[(key, w, h)]):.1f} %",
        ]
        for key, w, h in order
    ]
    lines = [
        "## Pixel regions",
        "",
        "The share of the image each restricted region covers (coherent: one object with similar "
        "normals, depth and albedo in every 5x5 window, seen at the same surface in the previous "
        "frame; edges: within one pixel of an object-id change), mean and smallest over the "
        "measured frames.",
        "",
        *table_lines(["group", "resolution", "mean", "smallest frame"], body),
        "",
    ]
    return "\n".join(lines)
