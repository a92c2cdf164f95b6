"""``decision.md``: per scene, condition, spp and denoiser, the strategy to use.

For each scene, condition, spp and denoiser (:func:`decision_table`): the strategy with the lowest
post-denoise MSE, its ratio to white with the interval, and its cost per frame (render +
permutation ms): the table a renderer team choosing a strategy reads. Built from the rows of
:func:`benchmarks.reports.table.summarize`.

Not for: deciding for the reader beyond the measured ratios: a strategy is bold only when its
whole interval, corrected for having been chosen as the best of the cell's strategies, lies below
white's; equal (within a stated margin) and not resolved are said as such.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from benchmarks.reports.groups import group_key, group_order, group_title, strategy_order
from benchmarks.reports.markdown import table_lines
from bnerr.metrics import Estimate, better, equivalent, relevel_ratio
from bnerr.strategies import baseline, bounds, strategy_identity

__all__ = [
    "EQUAL_MARGIN",
    "LEVEL",
    "best_rows",
    "corrected",
    "decision_excludes",
    "decision_table",
    "headline_table",
    "rival_counts",
    "verdict",
]


def decision_excludes(names: Iterable[str] = ()) -> tuple[str, ...]:
    """What the decision table leaves out by default: the bounds (family ``"bound"``: the oracle
    renders K candidates per frame, an upper bound on what the temporal method approximates, not
    a strategy to adopt; the vertical bound then searches the whole image), the registered ones
    and those among ``names`` (a variant of a bound, a record's bound no longer registered), in
    table order."""
    found = {*bounds(), *(n for n in names if strategy_identity(n).bound)}
    return tuple(strategy_order(found))


def _excludes(rows: Sequence[dict], exclude: Sequence[str] | None) -> Sequence[str]:
    return decision_excludes(r["strategy"] for r in rows) if exclude is None else exclude


def best_rows(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> dict[tuple, dict]:
    """Per (group key, spp, denoiser): the row of the strategy with the lowest pooled post-denoise
    MSE (the baseline included, ``exclude`` left out, by default :func:`decision_excludes`; ties
    go to the earlier strategy in the report's order)."""
    exclude = _excludes(rows, exclude)
    best: dict[tuple, dict] = {}
    order = {s: i for i, s in enumerate(strategy_order(r["strategy"] for r in rows))}
    for row in rows:
        if row.get("den_mse") is None or row["strategy"] in exclude:
            continue
        key = (group_key(row), row["spp"], row["denoiser"])
        old = best.get(key)
        rank = (row["den_mse"], order[row["strategy"]])
        if old is None or rank < (old["den_mse"], order[old["strategy"]]):
            best[key] = row
    return best


def _left_out(exclude: Sequence[str]) -> str:
    """The decision table's note on the strategies it leaves out (a bound's ``bound_note``)."""
    notes = {s: strategy_identity(s).bound_note for s in exclude}
    return "".join(f" Left out: {s}" + (f" ({notes[s]})." if notes[s] else ".") for s in exclude)


#: The level of the decision table's intervals before the correction for choosing the best.
LEVEL = 0.95
#: Equivalence margin: a best strategy whose corrected interval lies inside ``1 -+ EQUAL_MARGIN``
#: is "equal to white" within it. 5 %: the smallest gain the suites report as worth adopting, and
#: what 4 seed sets resolve in most cells (``bnerr.metrics.power``: the median seed-set spread
#: of 0.04 gives an interval half-width near 6 %).
EQUAL_MARGIN = 0.05


def rival_counts(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> dict[tuple, int]:
    """Per (group key, spp, denoiser): how many strategies other than the baseline compete for
    the best (the m of the Bonferroni correction of :func:`verdict`); ``exclude`` as in
    :func:`best_rows`."""
    exclude = _excludes(rows, exclude)
    names: dict[tuple, set[str]] = {}
    for row in rows:
        if row.get("den_mse") is None or row["strategy"] in (*exclude, baseline()):
            continue
        names.setdefault((group_key(row), row["spp"], row["denoiser"]), set()).add(row["strategy"])
    return {key: len(v) for key, v in names.items()}


def corrected(row: dict, rivals: int) -> Estimate:
    """The best row's post-denoise ratio to white with its interval widened for having been chosen
    as the lowest of ``rivals`` strategies: the t-interval at level ``1 - (1 - LEVEL) / rivals``
    (Bonferroni), so a bold cell keeps its stated 95 % family coverage."""
    est = Estimate(row["den_mse_ratio"], row["den_mse_ratio_lo"], row["den_mse_ratio_hi"], 0, LEVEL)
    sets = row["seed_sets"]
    df = sets - 1 if sets >= 2 else max(row["frames"] - 1, 1)
    return relevel_ratio(est, 1.0 - (1.0 - LEVEL) / max(rivals, 1), df)


def verdict(est: Estimate) -> str:
    """``"better"`` (superiority: the corrected interval below 1), ``"equal"`` (equivalence within
    :data:`EQUAL_MARGIN`) or ``"not resolved"`` (neither: more seed sets would be needed)."""
    if better(est):
        return "better"
    return "equal" if equivalent(est, EQUAL_MARGIN) else "not resolved"


_MARKS = {"better": "", "equal": " ≈", "not resolved": " n.r."}


def _decision_cell(row: dict, rivals: int) -> str:
    cost = f"{row['render_ms']:.0f} + {row['perm_ms']:.1f} ms"
    if row["strategy"] == baseline() or row.get("den_mse_ratio") is None:
        return f"{row['strategy']} ({cost})"
    est = corrected(row, rivals)
    said = verdict(est)
    name = f"**{row['strategy']}**" if said == "better" else row["strategy"]
    ratio = f"{est.value:.2f} [{est.lo:.2f}, {est.hi:.2f}]{_MARKS[said]}"
    return f"{name} {ratio} ({cost})"


def decision_table(
    rows: Sequence[dict],
    title: str = "Which strategy to use",
    exclude: Sequence[str] | None = None,
) -> str:
    """For each scene, condition and spp, per denoiser: the strategy with the lowest post-denoise
    MSE, its MSE as a fraction of white's (95% paired interval) and its cost per frame (render +
    permutation milliseconds, the strategy's whole overhead included); ``exclude`` left out (by
    default :func:`decision_excludes`)."""
    exclude = _excludes(rows, exclude)
    best = best_rows(rows, exclude)
    rivals = rival_counts(rows, exclude)
    # The note names the first registered bound (the oracle) always, the others if run.
    named = {*bounds()[:1], *(r["strategy"] for r in rows)}
    groups = sorted({k[0] for k in best}, key=group_order)
    denoisers = sorted({k[2] for k in best})
    body = []
    for group in groups:
        for spp in sorted({k[1] for k in best if k[0] == group}):
            cells = [best.get((group, spp, d)) for d in denoisers]
            body.append(
                [group_title(group), str(spp)]
                + [
                    "-" if c is None else _decision_cell(c, rivals.get((group, spp, d), 1))
                    for c, d in zip(cells, denoisers, strict=True)
                ]
            )
    lines = [
        f"# {title}",
        "",
        "Per scene, condition, spp and denoiser: the strategy with the lowest post-denoise MSE, "
        "its MSE as a fraction of white's with its paired interval, and its cost per frame "
        "(render + permutation ms). The interval is a Student t-interval on the seed sets' log "
        "ratios at 95 %, widened for having picked the lowest of the m strategies in the cell "
        "(Bonferroni, level 1 - 0.05/m), so that bold keeps its 95 % family coverage. Bold: "
        "below white beyond that interval (superiority); ≈: equal to white within "
        f"{EQUAL_MARGIN:.0%} (the whole interval inside 1 -+ {EQUAL_MARGIN}, equivalence); "
        "n.r.: not resolved, neither below white nor equal to it at this many seed sets; white: "
        "no strategy was lower." + _left_out([s for s in exclude if s in named]),
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
    ]
    return "\n".join(lines)


def _headline_cell(row: dict | None, rivals: int) -> str:
    """``**name ratio**`` below white beyond the corrected interval, ``name ratio ≈`` equal to
    white within the margin, ``name ratio n.r.`` not resolved, ``white`` when no strategy was
    lower, ``-`` when not measured."""
    if row is None:
        return "-"
    if row["strategy"] == baseline() or row.get("den_mse_ratio") is None:
        return row["strategy"]
    said = verdict(corrected(row, rivals))
    text = f"{row['strategy']} {row['den_mse_ratio']:.2f}"
    return f"**{text}**" if said == "better" else text + _MARKS[said]


def headline_table(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    exclude: Sequence[str] | None = None,
) -> str:
    """The README's headline: the decision table of ``scenes`` in that order, each without a
    condition (the scene's own motion, depth, every pixel, the default sampler), one column per
    denoiser of ``denoisers``, each cell the best strategy and its ratio to white (bold: below
    white beyond the interval). Markdown lines, no title."""
    exclude = _excludes(rows, exclude)
    best = best_rows(rows, exclude)
    rivals = rival_counts(rows, exclude)
    plain = {k[0] for k in best if group_title(k[0]) == k[0][0]}
    body = [
        [scene, str(spp)]
        + [
            _headline_cell(best.get((group, spp, d)), rivals.get((group, spp, d), 1))
            for d in denoisers
        ]
        for scene in scenes
        for group in sorted((g for g in plain if g[0] == scene), key=group_order)
        for spp in sorted({k[1] for k in best if k[0] == group})
    ]
    return "\n".join(table_lines(["scene", "spp", *denoisers], body)) + "\n"
