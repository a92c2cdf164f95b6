"""``decision.md``: per scene, condition, spp and denoiser, the strategy to use.

For each scene, condition, spp and denoiser (:func:`decision_table`): the strategy with the lowest
post-denoise MSE, its ratio to white with the interval, and its cost per frame (render +
permutation ms): the table a renderer team choosing a strategy reads. Built from the rows of
:func:`benchmarks.reports.table.summarize`.

Not for: deciding for the reader beyond the measured ratios: a strategy is bold only when its
whole interval lies below white's.
"""

from __future__ import annotations

from collections.abc import Sequence

from benchmarks.reports.groups import group_key, group_order, group_title, strategy_order
from benchmarks.reports.markdown import table_lines

__all__ = ["DECISION_EXCLUDES", "best_rows", "decision_table", "headline_table"]


#: Left out of the decision table by default: the oracle renders K candidates per frame (an
#: upper bound on what the temporal method approximates, not a strategy to adopt), and so does
#: the vertical bound, which then searches the whole image.
DECISION_EXCLUDES: tuple[str, ...] = ("oracle", "vertical")


def best_rows(
    rows: Sequence[dict], exclude: Sequence[str] = DECISION_EXCLUDES
) -> dict[tuple, dict]:
    """Per (group key, spp, denoiser): the row of the strategy with the lowest pooled post-denoise
    MSE (white included, ``exclude`` left out; ties go to the earlier strategy in the report's
    order)."""
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
    """The decision table's note on the strategies it leaves out."""
    why = {
        "oracle": "it renders K candidates per frame: an upper bound, not a strategy to adopt",
        "vertical": "it renders K candidates per frame and searches the image: a second bound",
    }
    return "".join(f" Left out: {s}" + (f" ({why[s]})." if s in why else ".") for s in exclude)


def _decision_cell(row: dict) -> str:
    cost = f"{row['render_ms']:.0f} + {row['perm_ms']:.1f} ms"
    if row["strategy"] == "white" or row.get("den_mse_ratio") is None:
        return f"{row['strategy']} ({cost})"
    name = row["strategy"]
    if row["den_mse_ratio_hi"] < 1.0:
        name = f"**{name}**"
    ratio = (
        f"{row['den_mse_ratio']:.2f} [{row['den_mse_ratio_lo']:.2f}, {row['den_mse_ratio_hi']:.2f}]"
    )
    return f"{name} {ratio} ({cost})"


def decision_table(
    rows: Sequence[dict],
    title: str = "Which strategy to use",
    exclude: Sequence[str] = DECISION_EXCLUDES,
) -> str:
    """For each scene, condition and spp, per denoiser: the strategy with the lowest post-denoise
    MSE, its MSE as a fraction of white's (95% paired interval) and its cost per frame (render +
    permutation milliseconds, the strategy's whole overhead included); ``exclude`` left out."""
    best = best_rows(rows, exclude)
    measured = {r["strategy"] for r in rows}  # the note names the oracle always, others if run
    groups = sorted({k[0] for k in best}, key=group_order)
    denoisers = sorted({k[2] for k in best})
    body = []
    for group in groups:
        for spp in sorted({k[1] for k in best if k[0] == group}):
            cells = [best.get((group, spp, d)) for d in denoisers]
            body.append(
                [group_title(group), str(spp)]
                + ["-" if c is None else _decision_cell(c) for c in cells]
            )
    lines = [
        f"# {title}",
        "",
        "Per scene, condition, spp and denoiser: the strategy with the lowest post-denoise MSE, "
        "its MSE as a fraction of white's with the 95% paired interval (a Student t-interval on "
        "the seed sets' log ratios), and its cost per frame (render + permutation ms). Bold: "
        "below white beyond the interval (superiority); a strategy named without bold is lowest "
        "by its point estimate only; white: no strategy was lower."
        + _left_out([s for s in exclude if s == "oracle" or s in measured]),
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
    ]
    return "\n".join(lines)


def _headline_cell(row: dict | None) -> str:
    """``**name ratio**`` below white beyond the interval, ``name ratio`` by its point estimate
    only, ``white`` when no strategy was lower, ``-`` when not measured."""
    if row is None:
        return "-"
    if row["strategy"] == "white" or row.get("den_mse_ratio") is None:
        return row["strategy"]
    text = f"{row['strategy']} {row['den_mse_ratio']:.2f}"
    return f"**{text}**" if row["den_mse_ratio_hi"] < 1.0 else text


def headline_table(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    exclude: Sequence[str] = DECISION_EXCLUDES,
) -> str:
    """The README's headline: the decision table of ``scenes`` in that order, each without a
    condition (the scene's own motion, depth, every pixel, the default sampler), one column per
    denoiser of ``denoisers``, each cell the best strategy and its ratio to white (bold: below
    white beyond the interval). Markdown lines, no title."""
    best = best_rows(rows, exclude)
    plain = {k[0] for k in best if group_title(k[0]) == k[0][0]}
    body = [
        [scene, str(spp)] + [_headline_cell(best.get((group, spp, d))) for d in denoisers]
        for scene in scenes
        for group in sorted((g for g in plain if g[0] == scene), key=group_order)
        for spp in sorted({k[1] for k in best if k[0] == group})
    ]
    return "\n".join(table_lines(["scene", "spp", *denoisers], body)) + "\n"
