"""``decision.md``: per scene, condition, spp and denoiser, the strategy to use.

For each scene, condition, spp and denoiser (:func:`decision_table`): the strategy with the lowest
post-denoise MSE, its ratio to white with the interval, and its cost per frame (render +
permutation ms): the table a renderer team choosing a strategy reads. Built from the rows of
:func:`benchmarks.reports.table.summarize`.

Not for: deciding for the reader beyond the measured ratios: a strategy is bold only when its
whole interval, corrected for having been chosen as the best of the cell's strategies, lies below
white's; equal (within a stated margin), worse and open at the cap are said as such, each with
the seed sets it rests on.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from benchmarks.reports.groups import group_key, group_order, group_title, strategy_order
from benchmarks.reports.markdown import table_lines
from bnerr.metrics import Estimate, relevel_ratio, seed_sets_to_settle, t_quantile
from bnerr.metrics.sequential import Design, settle
from bnerr.strategies import baseline, bounds, strategy_identity

__all__ = [
    "EQUAL_MARGIN",
    "LEVEL",
    "SAME_FRAMES",
    "best_rows",
    "cell_verdicts",
    "corrected",
    "decision_excludes",
    "decision_table",
    "flicker_notes",
    "design_of",
    "headline_summary",
    "headline_table",
    "is_rival",
    "renders_white",
    "rival_counts",
    "to_settle",
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


#: How far from 1 a post-denoise ratio and its interval may lie in a cell where a rival rendered
#: white's very frames (:func:`renders_white`): a denoiser that is not bit-reproducible (Cycles'
#: OIDN, threaded reductions) moves the sixth digit, never the fourth.
SAME_FRAMES = 1e-4


def renders_white(row: dict) -> bool:
    """Whether ``row``'s strategy rendered white noise's own frames in its cell: not the baseline,
    its raw MSE ratio and interval exactly 1 (every seed set's frames identical) and its
    post-denoise ones within :data:`SAME_FRAMES` of 1. Such a row is white again, not a rival
    (Cycles' classic pattern under adaptive sampling that stops no pixel, for one): its
    zero-width interval would call the cell "equal to white" and stop its seed sets, so the
    decision leaves it out (:func:`best_rows`, :func:`rival_counts`)."""
    if row["strategy"] == baseline() or row.get("raw_mse_ratio") is None:
        return False
    raw = (row["raw_mse_ratio"], row["raw_mse_ratio_lo"], row["raw_mse_ratio_hi"])
    den = (row.get("den_mse_ratio"), row.get("den_mse_ratio_lo"), row.get("den_mse_ratio_hi"))
    return all(v == 1.0 for v in raw) and all(
        v is not None and abs(v - 1.0) <= SAME_FRAMES for v in den
    )


def is_rival(row: dict, exclude: Sequence[str]) -> bool:
    """Whether ``row`` competes with white for its cell: neither the baseline nor among
    ``exclude``, and not a rendering of white's own frames (:func:`renders_white`)."""
    return row["strategy"] not in (*exclude, baseline()) and not renders_white(row)


def best_rows(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> dict[tuple, dict]:
    """Per (group key, spp, denoiser): the row of the strategy with the lowest pooled post-denoise
    MSE (the baseline included, ``exclude`` left out, by default :func:`decision_excludes`, and
    so are the rows that rendered white's own frames, :func:`renders_white`; ties go to the
    earlier strategy in the report's order)."""
    exclude = _excludes(rows, exclude)
    best: dict[tuple, dict] = {}
    order = {s: i for i, s in enumerate(strategy_order(r["strategy"] for r in rows))}
    for row in rows:
        if row.get("den_mse") is None or row["strategy"] in exclude or renders_white(row):
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


def _twins_note(rows: Sequence[dict]) -> str:
    """The decision table's note on the strategies left out of some cells for rendering white's
    own frames there (:func:`renders_white`); empty when none did."""
    twins = strategy_order({r["strategy"] for r in rows if renders_white(r)})
    if not twins:
        return ""
    return (
        " Left out of the cells where it rendered white's own frames (raw MSE ratio exactly 1, "
        f"post-denoise within {SAME_FRAMES:g} of 1; white again, not a rival): "
        + ", ".join(twins)
        + "."
    )


#: The level of the decision table's intervals before the correction for choosing the best.
LEVEL = 0.95
#: Equivalence margin: a best strategy whose corrected interval lies inside ``1 -+ EQUAL_MARGIN``
#: is "equal to white" within it. 5 %: the smallest gain the suites report as worth adopting, and
#: what 4 seed sets resolve in most cells (``bnerr.metrics.power``: the median seed-set spread
#: of 0.04 gives an interval half-width near 6 %).
EQUAL_MARGIN = 0.05


def rival_counts(rows: Sequence[dict], exclude: Sequence[str] | None = None) -> dict[tuple, int]:
    """Per (group key, spp, denoiser): how many strategies other than the baseline compete for
    the best (the m of the Bonferroni correction of :func:`verdict`); ``exclude`` and the rows
    that rendered white's own frames left out, as in :func:`best_rows`."""
    exclude = _excludes(rows, exclude)
    names: dict[tuple, set[str]] = {}
    for row in rows:
        if row.get("den_mse") is None or not is_rival(row, exclude):
            continue
        names.setdefault((group_key(row), row["spp"], row["denoiser"]), set()).add(row["strategy"])
    return {key: len(v) for key, v in names.items()}


def design_of(row: dict) -> Design | None:
    """The group-sequential design a row's seed sets were added under (``row["looks"]``, from a
    ``bnerr bench --until-resolved`` record), or the fixed design of its seed sets (one look that
    spends the whole ``1 - LEVEL``); None with fewer than 2 seed sets."""
    sets = row["seed_sets"]
    if sets < 2:
        return None
    return Design(tuple(row.get("looks") or (sets,)), 1.0 - LEVEL)


def corrected(row: dict, rivals: int) -> Estimate:
    """The best row's post-denoise ratio to white with its interval widened for having been chosen
    as the lowest of ``rivals`` strategies and for the looks of its design (:func:`design_of`):
    the t-interval at level ``1 - alpha_k / rivals`` (Bonferroni; ``alpha_k = 1 - LEVEL`` for a
    fixed number of seed sets, :mod:`bnerr.metrics.sequential`), so a verdict keeps its stated
    95 % family coverage."""
    est = Estimate(row["den_mse_ratio"], row["den_mse_ratio_lo"], row["den_mse_ratio_hi"], 0, LEVEL)
    design = design_of(row)
    if design is None:
        df = max(row["frames"] - 1, 1)
        return relevel_ratio(est, 1.0 - (1.0 - LEVEL) / max(rivals, 1), df)
    return design.interval(est, row["seed_sets"], rivals)


def verdict(est: Estimate) -> str:
    """``"better"`` (superiority: the corrected interval below 1), ``"worse"`` (above 1),
    ``"equal"`` (equivalence within :data:`EQUAL_MARGIN`) or ``"open"`` (none of them: more seed
    sets would be needed; :func:`bnerr.metrics.sequential.settle`)."""
    return settle(est, EQUAL_MARGIN)


def cell_verdicts(
    rows: Sequence[dict], exclude: Sequence[str] | None = None
) -> dict[tuple, tuple[str, int]]:
    """Per (group key, spp, denoiser): the verdict on the cell's lowest strategy other than white
    (corrected, :func:`corrected`) and the seed sets it rests on. A cell whose lowest strategy is
    white is settled when its lowest rival is worse or equal; ``bnerr bench --until-resolved``
    adds seed sets to the cells still ``"open"``."""
    exclude = _excludes(rows, exclude)
    rivals = rival_counts(rows, exclude)
    lowest = best_rows(rows, [*exclude, baseline()])
    return {
        key: (verdict(corrected(row, rivals.get(key, 1))), row["seed_sets"])
        for key, row in lowest.items()
        if row.get("den_mse_ratio") is not None
    }


#: How a verdict is marked after the ratio (bold for "better").
_MARKS = {"better": "", "equal": " ≈", "worse": " worse", "open": " open"}


def to_settle(row: dict, rivals: int) -> int | None:
    """About how many seed sets would settle ``row``'s cell whatever its true ratio, at the
    spread its seed sets show (:func:`bnerr.metrics.seed_sets_to_settle` at the verdict's
    Bonferroni level; an adaptive design's looks would ask a few more): the spread is read back
    from the row's 95 % interval (``value * exp(-+ t * sd / sqrt(S))``). None with fewer than 2
    seed sets or an unbounded interval; 0 when even 100,000 would not."""
    n, value, hi = row["seed_sets"], row["den_mse_ratio"], row["den_mse_ratio_hi"]
    if n < 2 or not 0.0 < value < hi < math.inf:
        return None
    sd = math.log(hi / value) / t_quantile(LEVEL, n - 1) * math.sqrt(n)  # > 0: value < hi
    found = seed_sets_to_settle(sd, EQUAL_MARGIN, 1.0 - (1.0 - LEVEL) / max(rivals, 1))
    return 0 if found is None else found


def _settle_note(row: dict, rivals: int) -> str:
    """``", about N to settle"`` for an open cell (two significant digits)."""
    n = to_settle(row, rivals)
    if n is None:
        return ""
    if n == 0:
        return ", over 100,000 to settle"
    return f", about {float(f'{n:.2g}'):,.0f} to settle"


def _decision_cell(row: dict, rivals: int, rival: dict | None = None) -> str:
    """The best strategy with its corrected interval, verdict and seed sets (for an open one,
    about how many would settle it), then its cost; for white, the lowest rival's ratio and
    verdict after it (``rival``)."""
    cost = f"{row['render_ms']:.0f} + {row['perm_ms']:.1f} ms"
    judged = rival if row["strategy"] == baseline() or row.get("den_mse_ratio") is None else row
    if judged is None or judged.get("den_mse_ratio") is None:
        return f"{row['strategy']} ({cost})"
    est = corrected(judged, rivals)
    said = verdict(est)
    sets = f", {judged['seed_sets']} seed sets"
    if said == "open":
        sets += _settle_note(judged, rivals)
    ratio = f"{est.value:.2f} [{est.lo:.2f}, {est.hi:.2f}]{_MARKS[said]}"
    if judged is not row:
        return f"{row['strategy']} ({cost}; {judged['strategy']} {ratio}{sets})"
    name = f"**{row['strategy']}**" if said == "better" else row["strategy"]
    return f"{name} {ratio}{sets} ({cost})"


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
    lowest = best_rows(rows, [*exclude, baseline()])
    rivals = rival_counts(rows, exclude)
    # The note names the first registered bound (the oracle) always, the others if run.
    named = {*bounds()[:1], *(r["strategy"] for r in rows)}
    groups = sorted({k[0] for k in best}, key=group_order)
    denoisers = sorted({k[2] for k in best})
    body = []
    for group in groups:
        for spp in sorted({k[1] for k in best if k[0] == group}):
            keys = [(group, spp, d) for d in denoisers]
            body.append(
                [group_title(group), str(spp)]
                + [
                    "-"
                    if k not in best
                    else _decision_cell(best[k], rivals.get(k, 1), lowest.get(k))
                    for k in keys
                ]
            )
    lines = [
        f"# {title}",
        "",
        "Per scene, condition, spp and denoiser: the strategy with the lowest post-denoise MSE, "
        "its MSE as a fraction of white's with its paired interval, and its cost per frame "
        "(render + permutation ms). The interval is a Student t-interval on the seed sets' log "
        "ratios at 95 %, widened for having picked the lowest of the m strategies in the cell "
        "(Bonferroni, level 1 - 0.05/m) and, where seed sets were added until the verdict was "
        "settled (bnerr bench --until-resolved), for the looks taken (alpha spent equally over "
        "them, docs/METHODS.md), so that every verdict keeps its 95 % family coverage. Bold: "
        "below white beyond that interval (superiority); ≈: equal to white within "
        f"{EQUAL_MARGIN:.0%} (the whole interval inside 1 -+ {EQUAL_MARGIN}, equivalence); "
        "worse: above white beyond it; open: none of these at the seed sets given (the cap), "
        "more would be needed (about how many: the seed sets whose interval, at the spread "
        "measured, would settle the cell whatever its ratio). Each verdict gives the seed sets it "
        "rests on. White: no strategy "
        "was lower (then the lowest rival's ratio and verdict follow its cost)."
        + _left_out([s for s in exclude if s in named])
        + _twins_note(rows),
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
        *flicker_notes(rows, exclude),
    ]
    return "\n".join(lines)


def flicker_notes(rows: Sequence[dict], exclude: Sequence[str] = ()) -> list[str]:
    """The decision table's notes on flicker: one line per cell and strategy (``exclude`` left
    out) whose tMSE after the denoiser (:mod:`bnerr.metrics.temporal`) is above white's beyond
    its 95 % paired interval (lower bound > 1), so that a strategy chosen for its per-frame
    error is not adopted blind to the flicker it adds. No lines when no row measured it (results
    written before it existed keep their decision.md byte for byte)."""
    measured = [r for r in rows if r.get("den_tmse_ratio") is not None]
    if not measured:
        return []
    order = {s: i for i, s in enumerate(strategy_order(r["strategy"] for r in rows))}
    flagged = sorted(
        (r for r in measured if r["strategy"] not in exclude and r["den_tmse_ratio_lo"] > 1.0),
        key=lambda r: (group_order(group_key(r)), r["spp"], r["denoiser"], order[r["strategy"]]),
    )
    lines = [
        "Flicker: tMSE after the denoiser (the error of the frame-to-frame change against the "
        "reference's own change, docs/METHODS.md) as a fraction of white's, 95 % paired interval.",
        "",
    ]
    if not flagged:
        return lines + ["No strategy flickers more than white beyond its interval.", ""]
    for r in flagged:
        ratio = f"{r['den_tmse_ratio']:.2f} [{r['den_tmse_ratio_lo']:.2f}, "
        ratio += f"{r['den_tmse_ratio_hi']:.2f}]"
        lines.append(
            f"- {group_title(group_key(r))}, {r['spp']} spp, {r['denoiser']}: {r['strategy']} "
            f"flickers more than white after the denoiser, tMSE {ratio} of white's."
        )
    return [*lines, ""]


def _judged(row: dict, rival: dict | None) -> dict:
    """The row a headline cell's verdict is on: its best strategy's, or, where white is lowest,
    its lowest rival's (white's own when no rival was measured)."""
    if row["strategy"] != baseline() and row.get("den_mse_ratio") is not None:
        return row
    return rival if rival is not None and rival.get("den_mse_ratio") is not None else row


def _headline_said(row: dict | None, rivals: int, rival: dict | None) -> str | None:
    """The verdict a headline cell states (on :func:`_judged`'s row; ``"worse"`` where white is
    lowest and no rival was measured); None when not measured."""
    if row is None:
        return None
    judged = _judged(row, rival)
    if judged.get("den_mse_ratio") is None or judged["strategy"] == baseline():
        return "worse"
    return verdict(corrected(judged, rivals))


def _headline_cell(row: dict | None, rivals: int, rival: dict | None) -> str:
    """``**name ratio** (n)`` below white beyond the corrected interval, ``name ratio ≈ (n)``
    equal to white within the margin, ``name ratio open (n)`` open at the n seed sets it reached
    (the cap, or a fixed design's); ``white (n)`` when no strategy was lower, marked by its lowest
    ``rival``'s verdict unless that is worse (``white ≈ (n)``, ``white open (n)``); ``-`` when
    not measured. n: the seed sets the verdict rests on."""
    said = _headline_said(row, rivals, rival)
    if row is None or said is None:
        return "-"
    if row["strategy"] == baseline() or row.get("den_mse_ratio") is None:
        mark = "" if said == "worse" else _MARKS[said]
        return f"{row['strategy']}{mark} ({_judged(row, rival)['seed_sets']})"
    text = f"{row['strategy']} {row['den_mse_ratio']:.2f}"
    sets = f" ({row['seed_sets']})"
    return f"**{text}**{sets}" if said == "better" else text + _MARKS[said] + sets


def _in_all(group: tuple) -> tuple:
    """``group`` (:func:`benchmarks.reports.groups.group_key`) with its region set to every
    pixel."""
    return (*group[:3], "all", *group[4:])


def _headline_cells(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    exclude: Sequence[str],
    region: str = "all",
) -> list[tuple[str, int, list[tuple[dict | None, int, dict | None]]]]:
    """The headline's rows: (scene, spp, per denoiser the best row, its m and the lowest rival),
    for the scenes without a condition but ``region``, in ``scenes``' order."""
    best = best_rows(rows, exclude)
    lowest = best_rows(rows, [*exclude, baseline()])
    rivals = rival_counts(rows, exclude)
    plain = {  # the scene's own condition, in ``region``
        k[0] for k in best if k[0][3] == region and group_title(_in_all(k[0])) == k[0][0]
    }
    return [
        (
            scene,
            spp,
            [
                (
                    best.get((group, spp, d)),
                    rivals.get((group, spp, d), 1),
                    lowest.get((group, spp, d)),
                )
                for d in denoisers
            ],
        )
        for scene in scenes
        for group in sorted((g for g in plain if g[0] == scene), key=group_order)
        for spp in sorted({k[1] for k in best if k[0] == group})
    ]


def headline_table(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    exclude: Sequence[str] | None = None,
    region: str = "all",
) -> str:
    """The README's headline: the decision table of ``scenes`` in that order, each without a
    condition (the scene's own motion, depth, the default sampler) in pixel ``region`` (every
    pixel by default), one column per denoiser of ``denoisers``, each cell the best strategy,
    its ratio to white and the seed sets its verdict rests on (bold: below white beyond the
    interval). Markdown lines, no title."""
    cells = _headline_cells(rows, denoisers, scenes, _excludes(rows, exclude), region)
    body = [[scene, str(spp)] + [_headline_cell(*c) for c in row] for scene, spp, row in cells]
    return "\n".join(table_lines(["scene", "spp", *denoisers], body)) + "\n"


def headline_summary(
    rows: Sequence[dict],
    denoisers: Sequence[str],
    scenes: Sequence[str],
    exclude: Sequence[str] | None = None,
    region: str = "all",
) -> str:
    """The README's count of the headline's verdicts (:func:`headline_table`'s, in ``region``),
    one sentence: how many of its cells are bold (a strategy below white), equal to white within
    the margin, worse (white lowest and its rival above it) and open at the seed sets they
    reached, and the seed sets the cells took (median and largest)."""
    excluded = _excludes(rows, exclude)
    cells = [
        c for _, _, row in _headline_cells(rows, denoisers, scenes, excluded, region) for c in row
    ]
    said = [_headline_said(*c) for c in cells]
    count = {v: said.count(v) for v in ("better", "equal", "worse", "open")}
    sets = sorted(_judged(c[0], c[2])["seed_sets"] for c in cells if c[0] is not None)
    measured = len(sets)
    settled = measured - count["open"]
    median = sets[len(sets) // 2] if sets else 0
    return (
        f"Of the {measured} cells {settled} carry a verdict: {count['better']} bold, "
        f'{count["equal"]} "≈" and {count["worse"]} where white is lowest and its rival worse; '
        f"{count['open']} are open at the seed sets they reached (median {median}, "
        f"at most {sets[-1] if sets else 0} seed sets a cell)."
    )
