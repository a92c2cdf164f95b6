"""``perceptual.md``: the decision table's cells judged by what a viewer sees, beside the MSE.

The MSE decision (:mod:`benchmarks.reports.decision`) asks which strategy leaves the least error
energy after the denoiser; blue noise's case is that the same energy is less visible. This report
judges the same cells (scene, condition, spp, denoiser) with a perceptual metric, each a
:class:`Judge`:

- ``cvvdp`` (:mod:`bnerr.metrics.cvvdp`), ColorVideoVDP's JOD of each seed set's denoised
  sequence: **higher is better**, judged on the strategy's paired JOD *difference* to white
  (``den_cvvdp_diff``, a t-interval over seed sets), equal within :data:`JOD_MARGIN`;
- ``flip`` (HDR-FLIP per frame), lower is better, judged as the MSE is, on the paired ratio to
  white (``den_flip_ratio``), equal within the MSE's margin.

Per cell the judged strategy is the best rival of white by that metric (the bounds left out, as
in the MSE table: :func:`benchmarks.reports.decision.decision_excludes`), and its interval gets
the MSE verdict's corrections: Bonferroni for having picked the best of the cell's m rivals, and,
for a cell whose seed sets were added until its MSE verdict settled (``bnerr bench
--until-resolved``), the level its design spends at the look where it stopped. The adaptive rule
stops on the MSE, not on this metric; since each look spends only its share of alpha, the verdict
keeps its level whatever the rule (the union bound), and the coverage study measures it
(``python -m bnerr.metrics.coverage --perceptual``, :func:`bnerr.metrics.coverage.
perceptual_coverage`: at the quality suite's looks 4-8-16-32, a JOD that moves with the MSE seed
set by seed set, correlation 0 to 1, misses 1.2-4.4 % of the time at 95 % for one rival, at most
0.5 % at the Bonferroni level of m = 11; a design spending alpha at every look fails it).

Each table is followed by the count of cells whose verdict agrees with the MSE's (the same word:
better, equal, worse, open) and the list of those where one says better and the other does not.
Written only when the records hold a judge's metric (:func:`perceptual_report` is then ``""``).

Not for: the per-cell values (``table.csv``: ``den_cvvdp``, its interval and difference).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from benchmarks.reports.decision import (
    EQUAL_MARGIN,
    LEVEL,
    cell_verdicts,
    decision_excludes,
    design_of,
    is_rival,
)
from benchmarks.reports.groups import group_key, group_order, group_title, strategy_order
from benchmarks.reports.markdown import table_lines
from bnerr.metrics import Estimate, relevel_difference, relevel_ratio
from bnerr.metrics.sequential import settle

__all__ = [
    "JOD_MARGIN",
    "JUDGES",
    "Judge",
    "Judged",
    "agreement",
    "disagreeing",
    "headline_agreement",
    "judge_cells",
    "judged",
    "perceptual_report",
    "perceptual_table",
    "perceptual_verdict",
]

#: Equivalence margin in JOD: a tenth of a just-objectionable difference (1 JOD: 75 % of
#: observers prefer one; 0.1 JOD: about 53 %, a difference no viewer would act on).
JOD_MARGIN = 0.1


@dataclass(frozen=True)
class Judge:
    """A perceptual metric a verdict rests on.

    Attributes:
        metric: its name in :data:`bnerr.metrics.METRIC_TABLE`.
        unit: how the report names its values.
        higher: higher is better (judged on the paired difference to white, ``den_<m>_diff``);
            False: lower is better (the paired ratio, ``den_<m>_ratio``, as the MSE).
        margin: the equivalence margin (a difference, or a ratio's distance from 1).
    """

    metric: str
    unit: str
    higher: bool
    margin: float

    @property
    def column(self) -> str:
        """The column of ``table.csv`` the verdict reads (``_lo`` and ``_hi`` beside it)."""
        return f"den_{self.metric}_{'diff' if self.higher else 'ratio'}"

    def estimate(self, row: dict) -> Estimate:
        """The row's difference (or ratio) to white with its 95 % interval."""
        col = self.column
        return Estimate(row[col], row[f"{col}_lo"], row[f"{col}_hi"], 0, LEVEL)


#: The judges, in the report's order.
JUDGES: tuple[Judge, ...] = (
    Judge("cvvdp", "JOD", True, JOD_MARGIN),
    Judge("flip", "FLIP", False, EQUAL_MARGIN),
)


@dataclass(frozen=True)
class Judged:
    """One cell's perceptual verdict: the best rival's row, its corrected interval, the verdict
    (``"better"``, ``"equal"``, ``"worse"``, ``"open"``) and the m it was corrected for."""

    row: dict
    estimate: Estimate
    verdict: str
    rivals: int


def judged(rows: Sequence[dict], judge: Judge) -> bool:
    """Whether any row holds the judge's verdict column."""
    return any(r.get(judge.column) is not None for r in rows)


def perceptual_verdict(est: Estimate, judge: Judge) -> str:
    """``"better"`` (the interval beyond no difference on the good side), ``"worse"`` (beyond
    it on the bad side), ``"equal"`` (inside the judge's margin) or ``"open"``."""
    if not judge.higher:
        return settle(est, judge.margin)
    if est.lo > 0.0:
        return "better"
    if est.hi < 0.0:
        return "worse"
    if -judge.margin <= est.lo and est.hi <= judge.margin:
        return "equal"
    return "open"


def _corrected(row: dict, rivals: int, judge: Judge) -> Estimate:
    """The row's interval corrected as the MSE verdict's is (:func:`benchmarks.reports.decision.
    corrected`): Bonferroni for the best of ``rivals``, the look's level for an adaptive row."""
    relevel = relevel_difference if judge.higher else relevel_ratio
    design = design_of(row)
    est = judge.estimate(row)
    if design is None:
        return relevel(est, 1.0 - (1.0 - LEVEL) / max(rivals, 1), max(row["frames"] - 1, 1))
    return relevel(est, design.level(row["seed_sets"], rivals), row["seed_sets"] - 1)


def judge_cells(
    rows: Sequence[dict], judge: Judge, exclude: Sequence[str] | None = None
) -> dict[tuple, Judged]:
    """Per (group key, spp, denoiser): the verdict on the best rival of white by ``judge``
    (highest JOD difference, or lowest ratio; ties to the earlier strategy in the report's
    order), ``exclude`` left out (by default the bounds), and so are the rows that rendered
    white's own frames (:func:`benchmarks.reports.decision.renders_white`)."""
    if exclude is None:
        exclude = decision_excludes(r["strategy"] for r in rows)
    order = {s: i for i, s in enumerate(strategy_order(r["strategy"] for r in rows))}
    sign = -1.0 if judge.higher else 1.0
    cells: dict[tuple, list[dict]] = {}
    for row in rows:
        value = row.get(judge.column)
        if value is None or not math.isfinite(value) or not is_rival(row, exclude):
            continue
        cells.setdefault((group_key(row), row["spp"], row["denoiser"]), []).append(row)
    out = {}
    for key, found in cells.items():
        best = min(found, key=lambda r: (sign * r[judge.column], order[r["strategy"]]))
        est = _corrected(best, len(found), judge)
        out[key] = Judged(best, est, perceptual_verdict(est, judge), len(found))
    return out


def _number(value: float, judge: Judge) -> str:
    return f"{value:+.2f}" if judge.higher else f"{value:.2f}"


#: How a verdict is marked after the interval (bold for "better"), as in decision.md.
_MARKS = {"better": "", "equal": " ≈", "worse": " worse", "open": " open"}


def _cell(found: Judged | None, judge: Judge) -> str:
    if found is None:
        return "-"
    est, row = found.estimate, found.row
    text = f"{row['strategy']} {_number(est.value, judge)}"
    interval = f" [{_number(est.lo, judge)}, {_number(est.hi, judge)}]"
    sets = f" ({row['seed_sets']})"
    if found.verdict == "better":
        return f"**{text}**{interval}{sets}"
    return f"{text}{interval}{_MARKS[found.verdict]}{sets}"


def disagreeing(
    rows: Sequence[dict], judge: Judge, exclude: Sequence[str] | None = None
) -> list[tuple[tuple, str, Judged]]:
    """The cells where one of the MSE's verdict and the judge's is "better" and the other is not:
    ``(key, MSE verdict, judge's Judged)`` in the report's order."""
    mse = cell_verdicts(rows, exclude)
    seen = judge_cells(rows, judge, exclude)
    keys = sorted(set(mse) & set(seen), key=lambda k: (group_order(k[0]), k[1], k[2]))
    return [
        (k, mse[k][0], seen[k])
        for k in keys
        if (mse[k][0] == "better") != (seen[k].verdict == "better")
    ]


def agreement(
    rows: Sequence[dict], judge: Judge, exclude: Sequence[str] | None = None
) -> tuple[int, int, list[str]]:
    """How many of the cells both judge agree (the same verdict word), of how many, and one
    line per cell where one verdict is "better" and the other is not."""
    mse = cell_verdicts(rows, exclude)
    seen = judge_cells(rows, judge, exclude)
    keys = set(mse) & set(seen)
    agree = sum(mse[k][0] == seen[k].verdict for k in keys)
    lines = [
        f"- {group_title(k[0])}, {k[1]} spp, {k[2]}: MSE says {said}, {judge.unit} says "
        f"{found.verdict} ({found.row['strategy']} {_number(found.estimate.value, judge)})"
        for k, said, found in disagreeing(rows, judge, exclude)
    ]
    return agree, len(keys), lines


def headline_agreement(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    region: str = "all",
    judge: Judge = JUDGES[0],
) -> str:
    """The README's one line on the headline's cells (those of
    :func:`benchmarks.reports.decision.headline_table`: ``scenes`` without a condition, in pixel
    ``region``, the ``denoisers``): how many the judge's verdict agrees with the MSE's on, and
    how many where one says better and the other does not; "" when the rows hold no judge."""
    if not judged(rows, judge):
        return ""

    def headline(key: tuple) -> bool:
        group = key[0]
        whole = (*group[:3], "all", *group[4:])
        return group[0] in scenes and group[3] == region and group_title(whole) == group[0]

    mse = {k: v for k, v in cell_verdicts(rows).items() if headline(k) and k[2] in denoisers}
    seen = judge_cells(rows, judge)
    keys = [k for k in mse if k in seen]
    agree = sum(mse[k][0] == seen[k].verdict for k in keys)
    differ = sum((mse[k][0] == "better") != (seen[k].verdict == "better") for k in keys)
    return (
        f"Judged in {judge.unit} ({judge.metric}, perceptual.md), {agree} of these {len(keys)} "
        f"cells get the MSE's verdict; in {differ} one says better and the other does not."
    )


def _what(judge: Judge) -> str:
    if judge.higher:
        return (
            f"the strategy with the highest {judge.unit} after the denoiser (higher is better), "
            f"its {judge.unit} minus white's with its paired interval; bold: above white beyond "
            f"the interval; ≈: within {judge.margin} {judge.unit} of white"
        )
    return (
        f"the strategy with the lowest {judge.unit} after the denoiser, its {judge.unit} as a "
        f"fraction of white's with its paired interval; bold: below white beyond the interval; "
        f"≈: within {judge.margin:.0%} of white"
    )


def perceptual_table(
    rows: Sequence[dict],
    judge: Judge,
    exclude: Sequence[str] | None = None,
    picture: str | None = None,
) -> list[str]:
    """The Markdown lines of one judge's table, its agreement count and disagreeing cells, then
    ``picture`` (:mod:`benchmarks.reports.disagreement`: those cells' frames and errors)."""
    cells = judge_cells(rows, judge, exclude)
    groups = sorted({k[0] for k in cells}, key=group_order)
    denoisers = sorted({k[2] for k in cells})
    body = [
        [group_title(g), str(spp), *(_cell(cells.get((g, spp, d)), judge) for d in denoisers)]
        for g in groups
        for spp in sorted({k[1] for k in cells if k[0] == g})
    ]
    agree, total, differ = agreement(rows, judge, exclude)
    return [
        f"## {judge.unit} ({judge.metric})",
        "",
        f"Per scene, condition, spp and denoiser: {_what(judge)}; worse: on white's bad side "
        "beyond it; open: none of these. The intervals are corrected as the MSE table's (the "
        "best of m, the looks); (n): the seed sets.",
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
        f"{agree} of the {total} cells agree with the MSE verdict (decision.md); "
        f"{len(differ)} where one says better and the other does not" + (":" if differ else "."),
        "",
        *([*differ, ""] if differ else []),
        *(
            [
                f"![Where {judge.unit} and the MSE disagree: per cell the reference, white and "
                f"the rivals after the denoiser, then their errors x4]({picture})",
                "",
            ]
            if picture and differ
            else []
        ),
    ]


def perceptual_report(
    rows: Sequence[dict],
    exclude: Sequence[str] | None = None,
    pictures: Mapping[str, str] | None = None,
) -> str:
    """``perceptual.md``: every judge the rows hold, one table each (with its picture of the
    disagreeing cells where ``pictures`` names one by metric); ``""`` when they hold none
    (results measured before the metric existed: no file)."""
    judges = [j for j in JUDGES if judged(rows, j)]
    if not judges:
        return ""
    lines = [
        "# What a viewer sees: the decision's cells judged perceptually",
        "",
        "The cells of decision.md judged by a perceptual metric instead of the MSE. JOD: "
        "ColorVideoVDP on each seed set's denoised sequence against the reference sequence, "
        "shown on a 24-inch Full HD SDR monitor (200 cd/m^2, 0.6 m, 37.8 pixels per degree) at "
        "30 frames per second after the pages' tone map (exposure 0, Reinhard, sRGB), the same "
        "for every strategy (bnerr/metrics/cvvdp.py). Where seed sets were added until the MSE "
        "verdict settled, these verdicts use the look the MSE rule stopped at and its level, "
        "which keeps their 95 % (python -m bnerr.metrics.coverage --perceptual: 1.2-4.4 % "
        "misses however the JOD moves with the MSE).",
        "",
    ]
    for judge in judges:
        lines += perceptual_table(rows, judge, exclude, (pictures or {}).get(judge.metric))
    return "\n".join(lines)
