"""The decision table as a picture: the heatmap every suite's page opens with.

One HTML table (``class="heatmap"``), a row per scene (and condition) and spp, a column per
denoiser, each cell the decision's verdict on that cell (:mod:`benchmarks.reports.decision`):

- **colour**: the ratio to white of the cell's lowest rival of white (the strategy its verdict is
  on), on one diverging scale in log2: blue below 1 (better than white), near-white grey at 1,
  red above 1 (worse), saturated at half and at twice white's MSE (:func:`ratio_colour`);
- **text**: the winner's name (white where no strategy was lower) and the ratio, marked as in
  ``decision.md``: bold for better (the corrected interval below 1), ``≈`` equal within the
  margin, ``worse``, ``open``;
- **hover** (the cell's ``title``): the corrected interval, the verdict, m and the seed sets.

Where the records hold ColorVideoVDP (:mod:`benchmarks.reports.perceptual`) a second heatmap
shows the same cells judged in JOD, coloured by the best rival's JOD minus white's (blue: seen
as better, saturated at 1 JOD).

Each cell carries ``data-verdict`` and ``data-value`` for the browser tests. Static HTML with
inline colours: the page needs no script for it.

Not for: the numbers of every strategy (``table.md``) or the text of the verdicts
(``decision.md``, ``perceptual.md``, which follow it on the page).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass

from benchmarks.reports.decision import (
    EQUAL_MARGIN,
    best_rows,
    corrected,
    decision_excludes,
    rival_counts,
    verdict,
)
from benchmarks.reports.groups import group_order, group_title
from benchmarks.reports.perceptual import JUDGES, judge_cells, judged
from bnerr.strategies import baseline

__all__ = ["HeatCell", "decision_heatmap", "heatmap_html", "jod_heatmap", "ratio_colour"]

#: The scale's ends: blue (better), the neutral middle, red (worse) (ColorBrewer's RdBu).
_BLUE, _GREY, _RED = (33, 102, 172), (247, 247, 247), (178, 24, 43)


def ratio_colour(position: float) -> str:
    """The CSS colour of ``position`` on the diverging scale: -1 full blue (better), 0 the
    neutral grey, +1 full red (worse); clamped to [-1, 1], NaN grey."""
    t = 0.0 if math.isnan(position) else max(-1.0, min(1.0, position))
    end = _BLUE if t < 0 else _RED
    rgb = [round(g + (e - g) * abs(t)) for g, e in zip(_GREY, end, strict=True)]
    return f"rgb({rgb[0]},{rgb[1]},{rgb[2]})"


@dataclass(frozen=True)
class HeatCell:
    """One cell: the winner's name, its value as shown, its position on the scale (-1 better
    ... +1 worse), the verdict and the hover text."""

    name: str
    value: str
    position: float
    verdict: str
    hover: str


#: How a verdict is marked after the value (bold for "better"), as in decision.md.
_MARKS = {"better": "", "equal": " ≈", "worse": " worse", "open": " open"}


def _td(cell: HeatCell | None) -> str:
    if cell is None:
        return '<td class="hm-none">-</td>'
    colour = ratio_colour(cell.position)
    ink = "#fff" if abs(cell.position) > 0.55 else "#111"
    text = f"{html.escape(cell.name)}<br>{cell.value}{_MARKS[cell.verdict]}"
    if cell.verdict == "better":
        text = f"<b>{text}</b>"
    return (
        f'<td class="hm-cell" data-verdict="{cell.verdict}" data-value="{cell.value}" '
        f'style="background:{colour};color:{ink}" title="{html.escape(cell.hover)}">{text}</td>'
    )


def _legend(ticks: Sequence[tuple[float, str]], caption: str) -> str:
    stops = ",".join(f"{ratio_colour(p)} {50 + 50 * p:.0f}%" for p in (-1.0, 0.0, 1.0))
    labels = "".join(
        f'<span style="left:{50 + 50 * p:.1f}%">{html.escape(label)}</span>' for p, label in ticks
    )
    return (
        f'<div class="hm-legend"><div class="hm-bar" style="background:linear-gradient(90deg,'
        f'{stops})"></div><div class="hm-ticks">{labels}</div>'
        f"<small>{html.escape(caption)}</small></div>"
    )


def heatmap_html(
    cells: dict[tuple, HeatCell], title: str, ticks: Sequence[tuple[float, str]], caption: str
) -> str:
    """The heatmap of ``cells`` (by (group key, spp, denoiser)): a row per group and spp, a
    column per denoiser; '' when there are none."""
    if not cells:
        return ""
    groups = sorted({k[0] for k in cells}, key=group_order)
    denoisers = sorted({k[2] for k in cells})
    head = "".join(f"<th>{html.escape(d)}</th>" for d in ["scene", "spp", *denoisers])
    body = "".join(
        f"<tr><th>{html.escape(group_title(g))}</th><th>{spp}</th>"
        + "".join(_td(cells.get((g, spp, d))) for d in denoisers)
        + "</tr>\n"
        for g in groups
        for spp in sorted({k[1] for k in cells if k[0] == g})
    )
    return (
        f'<figure class="hm"><figcaption>{html.escape(title)}</figcaption>'
        f'<table class="heatmap"><thead><tr>{head}</tr></thead><tbody>\n{body}</tbody></table>'
        f"{_legend(ticks, caption)}</figure>"
    )


def _mse_cell(row: dict, rivals: int, white_lowest: bool) -> HeatCell:
    est = corrected(row, rivals)
    said = verdict(est)
    name = baseline() if white_lowest else row["strategy"]
    rival = f" (lowest rival {row['strategy']})" if white_lowest else ""
    hover = (
        f"{name}{rival}: post-denoise MSE {est.value:.3f} of white's [{est.lo:.3f}, "
        f"{est.hi:.3f}] (95 %, corrected for the best of m = {rivals}); {said}; "
        f"{row['seed_sets']} seed sets"
    )
    position = math.log2(est.value) if est.value > 0 else -1.0
    return HeatCell(name, f"{est.value:.2f}", position, said, hover)


def decision_heatmap(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> str:
    """The MSE decision's heatmap (the module docstring); '' without a ratio to white."""
    if exclude is None:
        exclude = decision_excludes(r["strategy"] for r in rows)
    best = best_rows(rows, exclude)
    lowest = best_rows(rows, [*exclude, baseline()])
    rivals = rival_counts(rows, exclude)
    cells = {
        key: _mse_cell(row, rivals.get(key, 1), best[key]["strategy"] == baseline())
        for key, row in lowest.items()
        if row.get("den_mse_ratio") is not None and key in best
    }
    ticks = [(-1.0, "0.5"), (math.log2(0.7), "0.7"), (0.0, "1"), (math.log2(1.4), "1.4")]
    caption = (
        "Post-denoise MSE of the cell's lowest rival of white as a fraction of white's: blue "
        "below white, red above; bold: better beyond the interval corrected for the best of m "
        f"and the looks; ≈ equal within {EQUAL_MARGIN:.0%}. Hover a cell for its interval."
    )
    return heatmap_html(cells, "The decision (MSE)", [*ticks, (1.0, "2")], caption)


def jod_heatmap(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> str:
    """The same cells judged in JOD (ColorVideoVDP), '' where the rows hold none."""
    judge = JUDGES[0]
    if not judged(rows, judge):
        return ""
    cells = {}
    for key, found in judge_cells(rows, judge, exclude).items():
        est = found.estimate
        hover = (
            f"{found.row['strategy']}: {est.value:+.2f} JOD against white [{est.lo:+.2f}, "
            f"{est.hi:+.2f}] (95 %, corrected for the best of m = {found.rivals}); "
            f"{found.verdict}; {found.row['seed_sets']} seed sets"
        )
        position = -est.value  # higher is better: blue
        cells[key] = HeatCell(
            found.row["strategy"], f"{est.value:+.2f}", position, found.verdict, hover
        )
    ticks = [(-1.0, "+1"), (-0.5, "+0.5"), (0.0, "0"), (0.5, "-0.5"), (1.0, "-1")]
    caption = (
        "The best rival's JOD minus white's, in JOD (ColorVideoVDP on the denoised sequences, "
        "perceptual.md): blue seen as better than white, red as worse."
    )
    return heatmap_html(cells, "The same cells judged in JOD", ticks, caption)
