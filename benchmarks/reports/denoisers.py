"""How the denoisers respond to each strategy's noise: ``denoisers.md`` (issue 15).

The report's tables give every (strategy, denoiser) ratio to white on its own. This module reads
the same rows (:func:`benchmarks.reports.table.summarize`) and records across denoisers, to answer
the questions an adopter asks of them:

1. **Temporal accumulation** (:func:`accumulation`): the ratio to white after the single-frame
   Gaussian, after ``taa`` and after ``svgf``; the raw error's frame-to-frame correlation
   (``Record.tcorr``) next to white's; the accumulation factor ``(taa MSE / raw MSE)`` of the
   strategy over the same for white (above 1: its error averages out less over time than white's);
   and a flag (:func:`accumulation_flag`) when the strategy loses under accumulation, or loses the
   gain it had on single frames.
2. **OIDN on blue-noise input of the same raw MSE** (:func:`oidn_response`): for the strategies
   whose raw-MSE interval contains white's, the ratio after the Gaussian, OIDN and the U-Nets and
   a verdict on OIDN (:func:`oidn_verdict`); the strategies left out are named with their raw
   ratio.
3. **Each strategy with its best denoiser** (:func:`best_denoisers`): the lowest post-denoise MSE
   of each strategy over every denoiser measured (white-tuned and ``NAME:own``), and the best
   strategy's over white's, with the issue's goal (at most 0.7 at 4 spp on ``direct``,
   ``snooker_plain`` and ``medium``) stated as met or not.
4. **The U-Net trained on blue noise** (:func:`unet_gains`): each strategy's ratio and gain after
   ``unet`` and ``unet_blue``, white's own ``unet_blue`` MSE over its ``unet`` MSE (paired
   interval), and the goal (temporal's gain at 4 spp at least doubled, white no worse).

:func:`denoise_markdown` puts the sections together, each only when its denoisers are in the
records; :func:`write_denoise_tables` writes ``denoisers.md`` (the one call the report makes).

Not for: choosing a strategy (``decision.md``) or the white-to-oracle shares
(:mod:`benchmarks.reports.gap`). It groups, orders and titles its rows through
:mod:`benchmarks.reports.groups`, as the table does, so that the two line up.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from benchmarks.highlights import (
    BLUE_TRAINED,
    HEADLINE_METHOD,
    PLAIN_ACCUMULATOR,
    SINGLE_FRAME,
    WHITE_TRAINED,
)
from benchmarks.reports.groups import group_key, group_order, group_title, strategy_order
from benchmarks.reports.markdown import table_lines
from benchmarks.sweep.records import Record
from bnerr.io import atomic_write
from bnerr.metrics import paired_ratio
from bnerr.strategies import baseline, strategy_identity
from denoisers import denoisers_of_kind

__all__ = [
    "BEST_GOAL",
    "BEST_GOAL_SCENES",
    "DENOISERS_MD",
    "Accumulation",
    "BestDenoisers",
    "OidnResponse",
    "UnetGain",
    "accumulation",
    "accumulation_flag",
    "accumulators",
    "best_denoisers",
    "denoise_markdown",
    "mean_tcorr",
    "oidn_response",
    "oidn_verdict",
    "unet_gains",
    "write_denoise_tables",
]

#: File name :func:`write_denoise_tables` writes.
DENOISERS_MD = "denoisers.md"
#: Section 3's goal: the best strategy's best MSE at most this fraction of white's, at 4 spp ...
BEST_GOAL = 0.7
#: ... on these scenes.
BEST_GOAL_SCENES: tuple[str, ...] = ("direct", "snooker_plain", "medium")
_GOAL_SPP = 4
_OWN = ":own"

#: ``(value, lo, hi)`` of a ratio and its 95% paired interval (:func:`bnerr.metrics.paired_ratio`).
Interval = tuple[float, float, float]


# --------------------------------------------------------------------------------------------------
# Lookups shared by the sections


def accumulators() -> tuple[str, ...]:
    """The temporal denoisers of section 1 (kind ``"temporal"``): the plain accumulator first,
    then the others by name."""
    found = denoisers_of_kind("temporal")
    return tuple(sorted(found, key=lambda d: (d != PLAIN_ACCUMULATOR, d)))


def _single_frame_columns() -> tuple[str, ...]:
    """Section 2's denoisers: the single-frame filter, the reference (OIDN), the learned ones."""
    return (SINGLE_FRAME, *denoisers_of_kind("reference"), *denoisers_of_kind("learned"))


def _cells(rows: Iterable[dict]) -> dict[tuple, dict[tuple[str, str], dict]]:
    """(group key, spp) -> (strategy, denoiser) -> row, in the report's group and spp order."""
    out: dict[tuple, dict[tuple[str, str], dict]] = defaultdict(dict)
    for row in rows:
        out[(group_key(row), row["spp"])][(row["strategy"], row["denoiser"])] = row
    return {k: out[k] for k in sorted(out, key=lambda k: (group_order(k[0]), k[1]))}


def _record_index(records: Iterable[Record]) -> dict[tuple, Record]:
    """(group key, spp, strategy, denoiser) -> record."""
    out = {}
    for r in records:
        c = r.cell
        out[((c.scene, c.motion, c.depth, c.region, c.sampler), c.spp, c.strategy, c.denoiser)] = r
    return out


def _ratio(row: dict | None, name: str = "den_mse") -> Interval | None:
    """The row's ratio to white of ``name`` with its interval, or None."""
    if row is None or row.get(f"{name}_ratio") is None:
        return None
    return (row[f"{name}_ratio"], row[f"{name}_ratio_lo"], row[f"{name}_ratio_hi"])


def _fmt(iv: Interval | None) -> str:
    return "-" if iv is None else f"{iv[0]:.2f} [{iv[1]:.2f}, {iv[2]:.2f}]"


def _num(x: float | None, spec: str = ".2f") -> str:
    return "-" if x is None or not math.isfinite(x) else format(x, spec)


def _denoisers(records: Iterable[Record] | Iterable[dict]) -> set[str]:
    return {r.cell.denoiser if isinstance(r, Record) else r["denoiser"] for r in records}


# --------------------------------------------------------------------------------------------------
# 1. Temporal accumulation


@dataclass(frozen=True)
class Accumulation:
    """One strategy under temporal accumulation, on one scene, condition and spp.

    Attributes:
        group: the report's title of the scene and condition.
        spp: samples per pixel.
        strategy: the strategy.
        ratios: ``"gaussian"``, ``"taa"``, ``"svgf"`` -> post-denoise MSE over white's with its
            interval (None where not measured).
        mse: the same denoisers -> the strategy's pooled post-denoise MSE (None where not
            measured).
        tcorr, white_tcorr: the mean frame-to-frame correlation of the raw error (over seed sets
            and frames) of the strategy and of white; None when not recorded.
        factor: ``(taa MSE / raw MSE)`` of the strategy over the same of white; None without taa.
        flag: :func:`accumulation_flag` of the Gaussian and taa ratios ('' for white).
    """

    group: str
    spp: int
    strategy: str
    ratios: dict[str, Interval | None]
    mse: dict[str, float | None]
    tcorr: float | None
    white_tcorr: float | None
    factor: float | None
    flag: str


def accumulation_flag(gaussian: Interval | None, taa: Interval | None) -> str:
    """``"loses under accumulation"`` when the taa ratio's interval lies above 1; ``"gain lost
    under accumulation"`` when the Gaussian ratio's lies below 1 and the taa ratio's does not;
    else ''."""
    if taa is not None and taa[1] > 1.0:
        return "loses under accumulation"
    if gaussian is not None and gaussian[2] < 1.0 and (taa is not None and taa[2] >= 1.0):
        return "gain lost under accumulation"
    return ""


def mean_tcorr(record: Record | None) -> float | None:
    """The mean of a record's ``tcorr`` over seed sets and frames (finite values), or None."""
    if record is None or not record.tcorr:
        return None
    values = [v for row in record.tcorr for v in row if v is not None and math.isfinite(v)]
    return sum(values) / len(values) if values else None


def _tcorrs(index: dict[tuple, Record]) -> dict[tuple, float | None]:
    """(group key, spp, strategy) -> the strategy's mean tcorr on the cell (the raw frames'
    figure: taa's record first, else the first denoiser's in the records' order that has one),
    in one pass over the records (a scan per cell took 3 s of the quality suite's report)."""
    chosen: dict[tuple, Record] = {}
    for k, r in index.items():
        if not r.tcorr:
            continue
        best = chosen.get(k[:3])
        if best is None or (
            best.cell.denoiser != PLAIN_ACCUMULATOR and r.cell.denoiser == PLAIN_ACCUMULATOR
        ):
            chosen[k[:3]] = r
    return {cell: mean_tcorr(r) for cell, r in chosen.items()}


def _taa_over_raw(row: dict | None) -> float | None:
    if row is None or row.get("den_mse") is None or not row.get("raw_mse"):
        return None
    return row["den_mse"] / row["raw_mse"]


def accumulation(rows: Iterable[dict], records: Iterable[Record]) -> list[Accumulation]:
    """One :class:`Accumulation` per strategy of every (scene and condition, spp) that has a taa
    or svgf row (:func:`accumulators`); white first, then the report's strategy order."""
    tcorrs = _tcorrs(_record_index(records))
    out = []
    white, plain = baseline(), PLAIN_ACCUMULATOR
    for (key, spp), by in _cells(rows).items():
        if not any(d in accumulators() for _, d in by):
            continue
        white_tcorr = tcorrs.get((key, spp, white))
        white_factor = _taa_over_raw(by.get((white, plain)))
        names = (SINGLE_FRAME, *accumulators())
        for s in strategy_order(s for s, d in by if d in names):
            ratios = {d: _ratio(by.get((s, d))) for d in names}
            mine = _taa_over_raw(by.get((s, plain)))
            factor = None if mine is None or not white_factor else mine / white_factor
            out.append(
                Accumulation(
                    group=group_title(key),
                    spp=spp,
                    strategy=s,
                    ratios=ratios,
                    mse={d: (by[(s, d)]["den_mse"] if (s, d) in by else None) for d in names},
                    tcorr=tcorrs.get((key, spp, s)),
                    white_tcorr=white_tcorr,
                    factor=factor,
                    flag=""
                    if s == white
                    else accumulation_flag(ratios[SINGLE_FRAME], ratios[plain]),
                )
            )
    return out


def _accumulation_cells(a: Accumulation) -> list[str]:
    names = (SINGLE_FRAME, *accumulators())
    if a.strategy == baseline():
        den = [f"MSE {_num(a.mse[d], '.4g')}" if a.mse[d] is not None else "-" for d in names]
    else:
        den = [_fmt(a.ratios[d]) for d in names]
    return [
        str(a.spp),
        a.strategy,
        *den,
        _num(a.tcorr),
        _num(a.white_tcorr),
        _num(a.factor),
        a.flag,
    ]


def _accumulation_markdown(items: Sequence[Accumulation]) -> list[str]:
    lines = [
        f"## Temporal accumulation ({', '.join(accumulators())})",
        "",
        "Post-denoise MSE as a fraction of white's (95% paired interval; white's row: its absolute "
        "MSE) after the single-frame Gaussian, after taa and after svgf, next to the raw error's "
        "mean frame-to-frame correlation (tcorr) and the accumulation factor (taa MSE / raw MSE "
        "over white's; above 1, the error averages out less over time than white's): a strategy "
        "whose ratio rises from the Gaussian column to the taa column keeps less of its gain "
        "when frames are accumulated.",
        "",
    ]
    head = ["spp", "strategy", SINGLE_FRAME, *accumulators(), "tcorr", "white tcorr", "acc. factor"]
    for group in dict.fromkeys(a.group for a in items):
        mine = [a for a in items if a.group == group]
        lines += [
            f"### {group}",
            "",
            *table_lines([*head, "flag"], map(_accumulation_cells, mine)),
            "",
        ]
    flagged = [a for a in items if a.flag]
    lines += ["Flagged strategies and the measured cause:", ""]
    if not flagged:
        return lines + ["- none: no strategy loses, or loses its gain, under accumulation.", ""]
    for a in flagged:
        lines.append(
            f"- {a.group}, {a.spp} spp, {a.strategy}: {a.flag} "
            f"({PLAIN_ACCUMULATOR} {_fmt(a.ratios[PLAIN_ACCUMULATOR])}); "
            f"tcorr {_num(a.tcorr)} against white's {_num(a.white_tcorr)}, accumulation factor "
            f"{_num(a.factor)}."
        )
    return lines + [""]


# --------------------------------------------------------------------------------------------------
# 2. OIDN on blue-noise input of the same raw MSE


@dataclass(frozen=True)
class OidnResponse:
    """One strategy whose raw MSE matches white's, through OIDN and the other denoisers.

    Attributes:
        group, spp, strategy: the cell (group: the report's title of scene and condition).
        raw: the raw MSE over white's, with its interval (it contains 1).
        raw_blur2: the same after a sigma-2 blur (None where not measured).
        ratios: ``"gaussian"``, ``"oidn"``, ``"unet"``, ``"unet_blue"`` -> post-denoise MSE over
            white's with its interval (None where not measured).
        verdict: :func:`oidn_verdict` of the OIDN ratio.
    """

    group: str
    spp: int
    strategy: str
    raw: Interval
    raw_blur2: Interval | None
    ratios: dict[str, Interval | None]
    verdict: str


def oidn_verdict(ratio: Interval) -> str:
    """``"worse than on white"`` when the ratio's interval lies above 1, ``"better"`` when it lies
    below, else ``"same within the interval"``."""
    if ratio[1] > 1.0:
        return "worse than on white"
    if ratio[2] < 1.0:
        return "better"
    return "same within the interval"


def oidn_response(
    rows: Iterable[dict],
) -> tuple[list[OidnResponse], list[tuple[str, int, str, Interval]]]:
    """OIDN on input of the same raw MSE as white's, per (scene and condition, spp).

    Returns:
        The :class:`OidnResponse` of every non-white strategy with an OIDN ratio whose raw-MSE
        interval contains 1, and ``(group, spp, strategy, raw ratio)`` of those left out because
        their raw MSE differs from white's beyond the interval.
    """
    kept, left = [], []
    reference = denoisers_of_kind("reference")[:1]
    for (key, spp), by in _cells(rows).items():
        for s in strategy_order(s for s, d in by if d in reference and s != baseline()):
            row = by[(s, reference[0])]
            raw, oidn = _ratio(row, "raw_mse"), _ratio(row)
            if raw is None or oidn is None:
                continue
            if raw[1] > 1.0 or raw[2] < 1.0:
                left.append((group_title(key), spp, s, raw))
                continue
            ratios = {d: _ratio(by.get((s, d))) for d in _single_frame_columns()}
            blur2 = _ratio(row, "raw_mse_blur2")
            title = group_title(key)
            kept.append(OidnResponse(title, spp, s, raw, blur2, ratios, oidn_verdict(oidn)))
    return kept, left


def _oidn_markdown(kept: Sequence[OidnResponse], left: Sequence[tuple]) -> list[str]:
    shown = [d for d in _single_frame_columns() if any(k.ratios[d] is not None for k in kept)]
    lines = [
        "## OIDN on blue-noise input of the same raw MSE",
        "",
        "For each strategy whose raw MSE equals white's within the 95% paired interval: its raw "
        "ratio to white, the ratio after a sigma-2 blur, and its post-denoise MSE over white's "
        "after each denoiser, with a verdict on OIDN: 'worse than on white' means OIDN's output "
        "is worse on this correlated noise than on white noise of the same raw error, beyond the "
        "interval.",
        "",
    ]
    body = [
        [k.group, str(k.spp), k.strategy, _fmt(k.raw), _fmt(k.raw_blur2)]
        + [_fmt(k.ratios[d]) for d in shown]
        + [k.verdict]
        for k in kept
    ]
    if body:
        head = ["scene", "spp", "strategy", "raw", "raw blur2", *shown, "OIDN verdict"]
        lines += [*table_lines(head, body), ""]
    else:
        lines += ["No strategy's raw MSE equals white's within the interval.", ""]
    if left:
        named = "; ".join(f"{g} {spp} spp {s} {_fmt(raw)}" for g, spp, s, raw in left)
        lines += [f"Left out, raw MSE different from white's (raw ratio): {named}.", ""]
    return lines


# --------------------------------------------------------------------------------------------------
# 3. Each strategy with its best denoiser


@dataclass(frozen=True)
class BestDenoisers:
    """Each strategy's best denoiser on one scene, condition and spp.

    Attributes:
        group, scene, spp: the cell (group: the report's title of scene and condition).
        best: strategy -> ``(denoiser, pooled post-denoise MSE)`` of its lowest MSE over every
            denoiser measured, in the report's strategy order.
        challenger: the non-white, non-oracle strategy with the lowest best MSE (None if none).
        ratio: the challenger's best MSE over white's best MSE (a ratio of point estimates: the
            two come from different denoisers); None without white or a challenger.
    """

    group: str
    scene: str
    spp: int
    best: dict[str, tuple[str, float]]
    challenger: str | None
    ratio: float | None


def best_denoisers(rows: Iterable[dict]) -> list[BestDenoisers]:
    """One :class:`BestDenoisers` per (scene and condition, spp), the oracle included in ``best``
    (as a bound) but never the challenger; ties go to the denoiser named first alphabetically and
    to the strategy first in the report's order."""
    out = []
    for (key, spp), by in _cells(rows).items():
        best: dict[str, tuple[str, float]] = {}
        for (s, d), row in sorted(by.items(), key=lambda item: item[0][1]):
            mse = row.get("den_mse")
            if mse is not None and (s not in best or mse < best[s][1]):
                best[s] = (d, mse)
        best = {s: best[s] for s in strategy_order(best)}
        white = baseline()
        rivals = [s for s in best if s != white and not strategy_identity(s).bound]
        challenger = min(rivals, key=lambda s: best[s][1]) if rivals else None
        ratio = None
        if challenger is not None and best.get(white, (None, 0.0))[1] > 0:
            ratio = best[challenger][1] / best[white][1]
        out.append(BestDenoisers(group_title(key), key[0], spp, best, challenger, ratio))
    return out


def _best_cell(best: tuple[str, float] | None) -> str:
    return "-" if best is None else f"{best[0]} {best[1]:.4g}"


def _goal_lines(items: Sequence[BestDenoisers]) -> list[str]:
    """The issue's goal on each (scene, 4 spp) of :data:`BEST_GOAL_SCENES` that was measured."""
    lines = []
    for b in items:
        if b.scene not in BEST_GOAL_SCENES or b.spp != _GOAL_SPP:
            continue
        if b.ratio is None:
            lines.append(f"- {b.group}, {b.spp} spp: not measured (no white or no other strategy).")
            continue
        met = "met" if b.ratio <= BEST_GOAL else "not met"
        lines.append(
            f"- {b.group}, {b.spp} spp: goal at most {BEST_GOAL} of white's: {met} "
            f"({b.challenger} at {b.ratio:.2f})."
        )
    return lines + [""] if lines else []


def _best_markdown(items: Sequence[BestDenoisers]) -> list[str]:
    strategies = strategy_order(s for b in items for s in b.best)
    head = [f"{s} (bound)" if strategy_identity(s).bound else s for s in strategies]
    body = [
        [b.group, str(b.spp)]
        + [_best_cell(b.best.get(s)) for s in strategies]
        + ["-" if b.ratio is None else f"{b.challenger} {b.ratio:.2f}"]
        for b in items
    ]
    return [
        "## Each strategy with its best denoiser",
        "",
        "For each strategy, the denoiser with its lowest post-denoise MSE over every denoiser "
        "measured (tuned on white noise and `:own`, tuned on the strategy's own frames) and that "
        "MSE; the last column is the best strategy other than white and the oracle (a bound, "
        "not a choice) with its best MSE over white's best (point estimates: the two come from "
        "different denoisers), so below 1 means the adopter who picks both strategy and "
        "denoiser does better than with white noise.",
        "",
        *table_lines(["scene", "spp", *head, "best / white's best"], body),
        "",
        *_goal_lines(items),
    ]


# --------------------------------------------------------------------------------------------------
# 4. The U-Net trained on blue noise


@dataclass(frozen=True)
class UnetGain:
    """One strategy after the white-trained and the blue-trained U-Net.

    Attributes:
        group, scene, spp, strategy: the cell (group: the report's title of scene and condition).
        unet, unet_blue: post-denoise MSE over white's after each network, with its interval.
        gain_unet, gain_blue: ``1 - ratio`` under each (None where not measured).
        gain_ratio: ``gain_blue / gain_unet``; None unless ``gain_unet > 0``.
        white: white's post-``unet_blue`` MSE over its post-``unet`` MSE on the same frames, with
            its paired interval (the same for every strategy of the cell; None without both).
    """

    group: str
    scene: str
    spp: int
    strategy: str
    unet: Interval | None
    unet_blue: Interval | None
    gain_unet: float | None
    gain_blue: float | None
    gain_ratio: float | None
    white: Interval | None


def _white_blue_over_white(index: dict[tuple, Record], key: tuple, spp: int) -> Interval | None:
    """White's post-unet_blue MSE over its post-unet MSE, paired over the same frames."""
    blue, plain = (index.get((key, spp, baseline(), d)) for d in (BLUE_TRAINED, WHITE_TRAINED))
    if blue is None or plain is None or "mse" not in blue.den or "mse" not in plain.den:
        return None
    a, b = blue.den["mse"], plain.den["mse"]
    if len(a) != len(b) or any(len(x) != len(y) for x, y in zip(a, b)):
        return None
    est = paired_ratio(a, b)
    return (est.value, est.lo, est.hi)


def unet_gains(rows: Iterable[dict], records: Iterable[Record]) -> list[UnetGain]:
    """One :class:`UnetGain` per non-white strategy of every (scene and condition, spp) that has
    a ``unet_blue`` row, in the report's strategy order."""
    index = _record_index(records)
    out = []
    for (key, spp), by in _cells(rows).items():
        if not any(d == BLUE_TRAINED for _, d in by):
            continue
        white = _white_blue_over_white(index, key, spp)
        nets = (WHITE_TRAINED, BLUE_TRAINED)
        names = [s for s, d in by if d in nets and s != baseline()]
        for s in strategy_order(names):
            plain, blue = (_ratio(by.get((s, d))) for d in nets)
            g_plain = None if plain is None else 1.0 - plain[0]
            g_blue = None if blue is None else 1.0 - blue[0]
            g_ratio = g_blue / g_plain if g_blue is not None and g_plain and g_plain > 0 else None
            title = group_title(key)
            out.append(
                UnetGain(title, key[0], spp, s, plain, blue, g_plain, g_blue, g_ratio, white)
            )
    return out


def _unet_goal(items: Sequence[UnetGain], group: str) -> str:
    """The goal line of one scene and condition: temporal's gain at 4 spp at least doubled
    after unet_blue (and positive), white's unet_blue/unet interval not above 1."""
    at4 = [u for u in items if u.group == group and u.spp == _GOAL_SPP]
    temporal = next((u for u in at4 if u.strategy == HEADLINE_METHOD), None)
    if temporal is None or temporal.gain_blue is None or temporal.gain_unet is None:
        return f"- {group}: not measured (temporal at {_GOAL_SPP} spp after both U-Nets)."
    doubled = temporal.gain_blue > 0 and temporal.gain_blue >= 2 * temporal.gain_unet
    white = temporal.white
    white_ok = white is not None and white[1] <= 1.0
    met = "met" if doubled and white_ok else "not met"
    return (
        f"- {group}: goal (temporal's gain at {_GOAL_SPP} spp at least twice as large after "
        f"unet_blue, with white no worse): {met} (gain {temporal.gain_unet:.2f} after unet, "
        f"{temporal.gain_blue:.2f} after unet_blue; white unet_blue/unet {_fmt(white)})."
    )


def _unet_markdown(items: Sequence[UnetGain]) -> list[str]:
    body = [
        [u.group, str(u.spp), u.strategy, _fmt(u.unet), _fmt(u.unet_blue), _num(u.gain_unet)]
        + [_num(u.gain_blue), _num(u.gain_ratio)]
        for u in items
    ]
    cells = dict.fromkeys((u.group, u.spp, u.white) for u in items)
    whites = [[g, str(spp), _fmt(w)] for g, spp, w in cells]
    nets = (WHITE_TRAINED, BLUE_TRAINED)
    head = ["scene", "spp", "strategy", *nets, *(f"gain {d}" for d in nets)]
    return [
        "## U-Net trained on blue noise",
        "",
        "Each strategy's post-denoise MSE over white's after the white-trained U-Net (unet) and "
        "after the one trained on white and blue noise (unet_blue), with the gain (1 - ratio) "
        "under each and their ratio: a gain ratio above 1 means the blue-trained network keeps "
        "more of the strategy's gain; white's own unet_blue MSE over its unet MSE (below) says "
        "what the blue training costs on white noise.",
        "",
        *table_lines([*head, "gain ratio"], body),
        "",
        *table_lines(["scene", "spp", "white: unet_blue / unet MSE"], whites),
        "",
        *(_unet_goal(items, g) for g in dict.fromkeys(u.group for u in items)),
        "",
    ]


# --------------------------------------------------------------------------------------------------
# The file


def denoise_markdown(records: Sequence[Record], rows: Sequence[dict]) -> str:
    """``denoisers.md``: each section whose denoisers the records hold (taa or svgf; oidn; a
    ``NAME:own``; unet_blue); '' when none."""
    present = _denoisers(records) | _denoisers(rows)
    lines: list[str] = []
    if present & set(accumulators()):
        lines += _accumulation_markdown(accumulation(rows, records))
    if present & set(denoisers_of_kind("reference")[:1]):
        lines += _oidn_markdown(*oidn_response(rows))
    if any(d.endswith(_OWN) for d in present):
        lines += _best_markdown(best_denoisers(rows))
    if BLUE_TRAINED in present:
        lines += _unet_markdown(unet_gains(rows, records))
    if not lines:
        return ""
    return "\n".join(["# How the denoisers respond to each strategy's noise", "", *lines])


def write_denoise_tables(
    out_dir: str | Path, records: Sequence[Record], rows: Sequence[dict]
) -> bool:
    """Write ``denoisers.md`` into ``out_dir`` (atomically) when the records hold any of the
    denoisers its sections need; return whether it wrote. Nothing else is written or removed.

    Args:
        out_dir: the results folder.
        records: the runner's records (:func:`benchmarks.sweep.records.load_records`).
        rows: :func:`benchmarks.reports.table.summarize` of the same records.
    """
    text = denoise_markdown(list(records), list(rows))
    if not text:
        return False
    with atomic_write(Path(out_dir) / DENOISERS_MD) as tmp:
        Path(tmp).write_text(text)
    return True
