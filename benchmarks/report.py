"""Tables and charts from the runner's records: ``table.csv``, ``table.md`` and PNG charts.

Everything here is derived from ``<out>/cells.jsonl``
(:func:`benchmarks.sweep.records.load_records`), so a report can be rebuilt without rendering
anything (``python -m benchmarks.report DIR``).

- ``table.csv``: one row per cell (scene, strategy, spp, denoiser, condition) with the raw and
  denoised MSE and their 95% bootstrap intervals, relMSE, PSNR, SSIM, the blurred MSEs, the error's
  low-frequency fraction, the ratio of each strategy to white noise on the same frames (paired
  bootstrap interval, :func:`bnerr.metrics.paired_ratio`), and the render, permutation and denoise
  milliseconds per frame.
- ``table.md``: the headline (temporal and oracle against white, per scene, spp and denoiser); per
  scene and condition, each strategy's post-denoise MSE as a fraction of white's,
  the raw error's ratios (MSE, blurred MSEs) and spectrum summary, the time per frame; and the list
  of cells where a strategy is worse than white beyond its interval.
- ``decision.md`` (:func:`decision_table`): for each scene, condition, spp and denoiser, the
  strategy with the lowest post-denoise MSE, its ratio to white with the interval, and its cost
  per frame (render + permutation ms): the table a renderer team choosing a strategy reads.
- ``denoisers.md`` (:mod:`benchmarks.denoise_response`, when the records hold taa/svgf, oidn, a
  ``NAME:own`` filter or unet_blue): how each denoiser responds to each strategy's noise.
- Charts (matplotlib, drawn on ``Figure`` objects with the Agg canvas, no pyplot state):
  ``error_vs_time_<group>.png`` (post-denoise MSE against render + permutation + denoise time per
  frame, one line per strategy through its spp values, one panel per denoiser),
  ``spectra_<group>.png`` (radially averaged power spectrum of the raw and denoised error per
  strategy), ``crops_<group>.png`` (reference, raw and denoised crops side by side).

Not for: deciding anything. The report states the measured ratios and their intervals; a cell is
flagged "worse than white" only when the whole interval lies above 1.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from benchmarks.denoise_response import write_denoise_tables
from benchmarks.gap import write_gap_tables
from benchmarks.groups import group_key, group_order, group_slug, group_title, strategy_order
from benchmarks.markdown import table_lines
from benchmarks.sweep.records import Record, load_records
from bnerr.io import atomic_write
from bnerr.metrics import bootstrap_interval, paired_ratio

__all__ = [
    "COLUMNS",
    "HEADLINE_STRATEGIES",
    "RAW_CAUSES",
    "DECISION_EXCLUDES",
    "best_rows",
    "decision_table",
    "markdown_table",
    "render_sampler",
    "summarize",
    "write_charts",
    "write_report",
]

_CELL = (
    "scene",
    "strategy",
    "spp",
    "denoiser",
    "motion",
    "depth",
    "region",
    "sampler",
    "width",
    "height",
    "frames",
    "warmup",
    "seed_sets",
)
_RATIO = ("den_mse", "raw_mse", "raw_mse_blur1", "raw_mse_blur2", "den_mse_blur1", "den_mse_blur2")
_INTERVAL = ("raw_mse", "den_mse")

#: Columns of ``table.csv``, in order.
COLUMNS: tuple[str, ...] = (
    *_CELL,
    "dimensions",
    "raw_mse",
    "raw_mse_lo",
    "raw_mse_hi",
    "den_mse",
    "den_mse_lo",
    "den_mse_hi",
    *(f"{m}_ratio{s}" for m in _RATIO for s in ("", "_lo", "_hi")),
    "raw_relmse",
    "den_relmse",
    "raw_psnr",
    "den_psnr",
    "raw_ssim",
    "den_ssim",
    "raw_mse_blur1",
    "raw_mse_blur2",
    "den_mse_blur1",
    "den_mse_blur2",
    "raw_lowfreq",
    "den_lowfreq",
    "render_ms",
    "perm_ms",
    "denoise_ms",
    "total_ms",
    "reference_spp",
    "reference_floor",
    "worse_than_white",
    "raw_differs_from_white",
    "render_sampler",
)


def _stats(record: Record, kind: str, metric: str) -> np.ndarray | None:
    """``[S][F][2]`` per-frame pairs of ``metric`` (``kind`` ``raw`` or ``den``), or None."""
    values = getattr(record, kind).get(metric)
    return None if values is None else np.asarray(values, dtype=np.float64)


def _baseline_key(record: Record) -> tuple:
    return dataclasses.astuple(dataclasses.replace(record.cell, strategy="white"))


def _mean_ms(series: list[list[float]]) -> float:
    flat = [v for row in series for v in row]
    return float(np.mean(flat)) if flat else math.nan


def _metric_columns(row: dict, rec: Record, resamples: int, seed: int) -> None:
    """The pooled value of every metric and the bootstrap intervals of :data:`_INTERVAL`."""
    for kind in ("raw", "den"):
        for metric in getattr(rec, kind):
            stats = _stats(rec, kind, metric)
            row[f"{kind}_{metric}"] = float(stats[..., 0].sum() / stats[..., 1].sum())  # pooled
    for name in _INTERVAL:
        kind, metric = name.split("_", 1)
        stats = _stats(rec, kind, metric)
        if stats is not None:
            est = bootstrap_interval(stats, resamples=resamples, seed=seed)
            row[name], row[f"{name}_lo"], row[f"{name}_hi"] = est.value, est.lo, est.hi


def _ratio_columns(row: dict, rec: Record, white: Record | None, resamples: int, seed: int) -> None:
    """The paired ratios of :data:`_RATIO` to the white record of the same cell."""
    for name in _RATIO:
        kind, metric = name.split("_", 1)
        mine = _stats(rec, kind, metric)
        base = None if white is None else _stats(white, kind, metric)
        if mine is None or base is None or mine.shape != base.shape:
            continue
        est = paired_ratio(mine, base, resamples=resamples, seed=seed)
        row[f"{name}_ratio"], row[f"{name}_ratio_lo"], row[f"{name}_ratio_hi"] = (
            est.value,
            est.lo,
            est.hi,
        )


def _row(rec: Record, white: Record | None, resamples: int, seed: int) -> dict:
    row: dict = {k: getattr(rec.cell, k) for k in _CELL}
    row["dimensions"] = rec.dimensions
    _metric_columns(row, rec, resamples, seed)
    _ratio_columns(row, rec, white, resamples, seed)
    row["render_ms"] = _mean_ms(rec.timings.render_ms)
    row["perm_ms"] = _mean_ms(rec.timings.perm_ms)
    row["denoise_ms"] = _mean_ms(rec.timings.denoise_ms)
    row["total_ms"] = row["render_ms"] + row["perm_ms"] + row["denoise_ms"]
    row["reference_spp"] = rec.reference.spp
    row["reference_floor"] = rec.reference.floor
    lo = row.get("den_mse_ratio_lo")
    row["worse_than_white"] = None if lo is None else bool(lo > 1.0)
    raw_lo, raw_hi = row.get("raw_mse_ratio_lo"), row.get("raw_mse_ratio_hi")
    row["raw_differs_from_white"] = None if raw_lo is None else bool(raw_lo > 1.0 or raw_hi < 1.0)
    row["render_sampler"] = render_sampler(rec)
    return {c: row.get(c) for c in COLUMNS}


def render_sampler(record: Record) -> str:
    """The sampler a record's frames were rendered with: the recorded one, or for files written
    before it was recorded the strategy's own (:data:`bnerr.strategies.OWN_SAMPLERS`), else the
    cell's per-pixel sampler condition."""
    from bnerr.strategies import OWN_SAMPLERS

    if record.render_sampler:
        return record.render_sampler
    return OWN_SAMPLERS.get(record.cell.strategy, record.cell.sampler)


def summarize(records: Iterable[Record], resamples: int = 2000, seed: int = 0) -> list[dict]:
    """One row per record: the columns of :data:`COLUMNS` (missing values as None).

    Ratios to white pair each record with the white record of the same cell (same scene, spp,
    denoiser, condition, frames and seed sets); None when the suite has no such white record.
    """
    records = list(records)
    whites = {_baseline_key(r): r for r in records if r.cell.strategy == "white"}
    return [_row(rec, whites.get(_baseline_key(rec)), resamples, seed) for rec in records]


def _csv_text(rows: Sequence[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow(
            {
                k: ("" if v is None else (f"{v:.6g}" if isinstance(v, float) else v))
                for k, v in row.items()
            }
        )
    return buffer.getvalue()


# --------------------------------------------------------------------------------------------------
# Markdown


def _ratio_text(row: dict | None, name: str) -> str:
    if row is None or row.get(f"{name}_ratio") is None:
        return "-"
    text = (
        f"{row[f'{name}_ratio']:.3f} [{row[f'{name}_ratio_lo']:.3f}, {row[f'{name}_ratio_hi']:.3f}]"
    )
    return text + (" (worse)" if row[f"{name}_ratio_lo"] > 1.0 else "")


def _den_body(rows: list[dict], strategies: list[str]) -> list[list[str]]:
    """Post-denoise MSE per spp and denoiser: white's value, the others' ratios to it."""
    by = {(r["spp"], r["denoiser"], r["strategy"]): r for r in rows}
    body = []
    for spp in sorted({r["spp"] for r in rows}):
        for d in sorted({r["denoiser"] for r in rows}):
            white = by.get((spp, d, "white"))
            cells = [str(spp), d]
            for s in strategies:
                row = by.get((spp, d, s))
                if s == "white" or white is None:
                    cells.append("-" if row is None else f"{row['den_mse']:.4g}")
                else:
                    cells.append(_ratio_text(row, "den_mse"))
            body.append(cells)
    return body


def _raw_cell(row: dict | None) -> str:
    if row is None:
        return "-"
    ratios = [row.get(f"{m}_ratio") for m in ("raw_mse", "raw_mse_blur1", "raw_mse_blur2")]
    text = " / ".join("-" if v is None else f"{v:.3f}" for v in ratios)
    low = row.get("raw_lowfreq")
    return text + ("" if low is None else f"; lf {low:.3f}")


def _time_cell(row: dict | None) -> str:
    return "-" if row is None else f"{row['render_ms']:.1f} + {row['perm_ms']:.2f}"


def _group_markdown(key: tuple, rows: list[dict]) -> list[str]:
    strategies = strategy_order(r["strategy"] for r in rows)
    spps = sorted({r["spp"] for r in rows})
    denoisers = sorted({r["denoiser"] for r in rows})
    first_denoiser = {(r["spp"], r["strategy"]): r for r in rows if r["denoiser"] == denoisers[0]}
    first = rows[0]
    lines = [
        f"### {group_title(key)}",
        "",
        f"{first['width']}x{first['height']}, {first['frames']} measured frames after "
        f"{first['warmup']} warmup, {first['seed_sets']} seed set(s), "
        f"D = {first['dimensions']}, reference {first['reference_spp']} spp.",
        "",
        "Post-denoise MSE: white's absolute value, every other strategy as a fraction of white's "
        "(95% paired bootstrap interval).",
        "",
    ]
    lines += _sampler_note(rows)
    lines += table_lines(["spp", "denoiser", *strategies], _den_body(rows, strategies))
    lines += [
        "",
        "Raw error as a fraction of white's: MSE / MSE after a sigma-1 blur / after a sigma-2 "
        "blur; low-frequency fraction of the error spectrum (white noise ~0.05).",
        "",
    ]
    body = [[str(n)] + [_raw_cell(first_denoiser.get((n, s))) for s in strategies] for n in spps]
    lines += table_lines(["spp", *strategies], body)
    lines += ["", "Milliseconds per frame: render + permutation (strategy overhead).", ""]
    body = [[str(n)] + [_time_cell(first_denoiser.get((n, s))) for s in strategies] for n in spps]
    lines += table_lines(["spp", *strategies], body)
    times = {d: np.mean([r["denoise_ms"] for r in rows if r["denoiser"] == d]) for d in denoisers}
    lines += [
        "",
        "Denoise ms per frame: " + ", ".join(f"{d} {t:.1f}" for d, t in times.items()) + ".",
        "",
    ]
    return lines


def _sampler_note(rows: list[dict]) -> list[str]:
    """A line naming the strategies that rendered with their own sampler instead of the group's
    per-pixel sampler condition (none: no line, so older tables stay as they were)."""
    condition = rows[0]["sampler"]
    own: dict[str, list[str]] = defaultdict(list)
    for s in strategy_order(r["strategy"] for r in rows):
        used = {r["render_sampler"] for r in rows if r["strategy"] == s} - {condition, None}
        for name in sorted(used):
            own[name].append(s)
    if not own:
        return []
    listed = "; ".join(f"{', '.join(names)}: {sampler}" for sampler, names in own.items())
    return [
        f"Samplers: {condition} per-pixel sequences, except the strategies that dictate their "
        f"own ({listed}); every ratio is to white under the same condition.",
        "",
    ]


def _raw_differences(rows: Sequence[dict]) -> list[str]:
    """Cells whose raw MSE differs from white's beyond the interval (one row per run, not per
    denoiser): permuting seeds only moves error, so such a difference is a finding to explain."""
    seen, body = set(), []
    for r in rows:
        key = (group_key(r), r["strategy"], r["spp"])
        if r["raw_differs_from_white"] and key not in seen:
            seen.add(key)
            title = group_title(group_key(r))
            body.append(
                [r["scene"], title, r["strategy"], str(r["spp"]), _ratio_text(r, "raw_mse")]
            )
    lines = ["## Raw MSE different from white beyond the interval", ""]
    if not body:
        return lines + ["No cell: every strategy's raw MSE interval contains white's.", ""]
    lines += table_lines(["scene", "condition", "strategy", "spp", "raw MSE / white"], body) + [""]
    return lines + _raw_causes(sorted({b[2] for b in body}))


_SHARED_SCRAMBLE = (
    "one scramble shared by all pixels, each pixel an aligned block of one sequence: the image's "
    "raw MSE is one draw per scramble instead of an average over per-pixel scrambles; "
)
_SCRAMBLE_SOURCE = " (docs/METHODS.md, section 7; tests/test_sequences.py)."
#: The measured cause of a strategy's raw MSE differing from white's, by strategy (a temporal
#: variant by its base name): what the strategy samples differently, with where it was measured.
RAW_CAUSES: dict[str, str] = {
    "bnds": "Cranley-Patterson rotation of one sequence shared by all pixels: an independently "
    "written sampler that shifts the shared sequence by uniform random offsets, with no mask, has "
    "the same excess over per-pixel Owen-scrambled Sobol (docs/METHODS.md, section 3).",
    "zsobol": _SHARED_SCRAMBLE + "ZSobol draws a fresh scramble each frame, so its MSE varies "
    "more from frame to frame and not on average" + _SCRAMBLE_SOURCE,
    "cycles_blue": "one scramble shared by all pixels with a fixed sequence seed: its raw MSE is "
    "one draw that never changes, above or below white's depending on the scene and spp "
    "(docs/METHODS.md, section 7; tests/test_sequences.py).",
}
RAW_CAUSES["bnds_st"] = RAW_CAUSES["bnds"]
RAW_CAUSES["zsobol_t"] = RAW_CAUSES["temporal_zsobol"] = (
    _SHARED_SCRAMBLE + "this strategy keeps one scramble per seed set, so a suite's few seed sets "
    "are few draws" + _SCRAMBLE_SOURCE
)


def _raw_causes(strategies: Sequence[str]) -> list[str]:
    """One line per strategy of the raw-difference table: its measured cause, or that none is
    established."""
    lines = []
    for name in strategies:
        cause = RAW_CAUSES.get(name.split("+")[0])
        lines.append(f"- {name}: " + (cause or "cause not established."))
    return lines + [""]


#: Strategies the headline compares with white, in its cells' order.
HEADLINE_STRATEGIES: tuple[str, ...] = ("temporal", "oracle")


def _headline_ratio(row: dict | None) -> str:
    if row is None or row.get("den_mse_ratio") is None:
        return "-"
    value = f"{row['den_mse_ratio']:.2f}"
    if row["den_mse_ratio_hi"] < 1.0:
        return f"**{value}**"
    return value + ("↑" if row["den_mse_ratio_lo"] > 1.0 else "")


def _headline(groups: dict[tuple, list[dict]], order: list[tuple]) -> list[str]:
    """One line per scene, condition and spp; one column per denoiser; in each cell the
    post-denoise MSE of temporal / oracle as a fraction of white's (the headline figures)."""
    denoisers = sorted({r["denoiser"] for rows in groups.values() for r in rows})
    body = []
    for key in order:
        by = {(r["spp"], r["denoiser"], r["strategy"]): r for r in groups[key]}
        if not any(s in HEADLINE_STRATEGIES for _, _, s in by):
            continue
        for spp in sorted({r["spp"] for r in groups[key]}):
            cells = [
                " / ".join(_headline_ratio(by.get((spp, d, s))) for s in HEADLINE_STRATEGIES)
                for d in denoisers
            ]
            body.append([group_title(key), str(spp), *cells])
    if not body:
        return []
    return [
        "## Headline: "
        + " / ".join(HEADLINE_STRATEGIES)
        + " post-denoise MSE as a fraction of white's",
        "",
        "Bold: below white beyond the 95% paired interval; ↑: above white beyond it; "
        "-: not measured. Intervals and absolute values are in the sections below.",
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
    ]


def markdown_table(rows: Sequence[dict], title: str = "Results") -> str:
    """The readable report: the headline, one section per scene and condition, then the flagged
    cells."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        groups[group_key(row)].append(row)
    order = sorted(groups, key=lambda k: (k[0], k[1], -1 if k[2] is None else k[2], k[3], k[4]))
    lines = [f"# {title}", "", *_headline(groups, order)]
    for key in order:
        lines += _group_markdown(key, groups[key])
    lines += _raw_differences(rows)
    flagged = [r for r in rows if r["worse_than_white"]]
    lines += ["## Worse than white beyond the interval", ""]
    if not flagged:
        lines += [
            "No cell: every strategy's post-denoise MSE interval reaches down to white's or below.",
            "",
        ]
    else:
        lines += table_lines(
            ["scene", "condition", "strategy", "spp", "denoiser", "ratio to white"],
            (
                [
                    r["scene"],
                    group_title(group_key(r)),
                    r["strategy"],
                    str(r["spp"]),
                    r["denoiser"],
                    _ratio_text(r, "den_mse"),
                ]
                for r in flagged
            ),
        )
        lines.append("")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------------
# Decision table


#: Left out of the decision table by default: the oracle renders K candidates per frame (an
#: upper bound on what the temporal method approximates, not a strategy to adopt).
DECISION_EXCLUDES: tuple[str, ...] = ("oracle",)


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
    why = {"oracle": "it renders K candidates per frame: an upper bound, not a strategy to adopt"}
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
        "its MSE as a fraction of white's with the 95% paired bootstrap interval, and its cost per "
        "frame (render + permutation ms). Bold: below white beyond the interval; a strategy named "
        "without bold is lowest by its point estimate only; white: no strategy was lower."
        + _left_out(exclude),
        "",
        *table_lines(["scene", "spp", *denoisers], body),
        "",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------------
# Charts


def _save(fig, path: Path) -> None:
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")


def _error_vs_time(slug: str, title: str, rows: list[dict], out: Path) -> Path:
    from matplotlib.figure import Figure

    denoisers = sorted({r["denoiser"] for r in rows})
    cols = min(4, len(denoisers))
    nrows = math.ceil(len(denoisers) / cols)
    fig = Figure(figsize=(4.2 * cols, 3.4 * nrows))
    for i, d in enumerate(denoisers):
        ax = fig.add_subplot(nrows, cols, i + 1)
        for s in strategy_order(r["strategy"] for r in rows):
            pts = sorted(
                (r for r in rows if r["denoiser"] == d and r["strategy"] == s),
                key=lambda r: r["spp"],
            )
            if not pts:
                continue
            x = [r["total_ms"] for r in pts]
            y = [r["den_mse"] for r in pts]
            err = [
                [r["den_mse"] - r["den_mse_lo"] for r in pts],
                [r["den_mse_hi"] - r["den_mse"] for r in pts],
            ]
            ax.errorbar(x, y, yerr=err, marker="o", capsize=2, label=s)
            for r in pts:
                ax.annotate(
                    f"{r['spp']}",
                    (r["total_ms"], r["den_mse"]),
                    fontsize=7,
                    textcoords="offset points",
                    xytext=(3, 3),
                )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(d, fontsize=9)
        ax.set_xlabel("ms per frame (render + permutation + denoise)", fontsize=8)
        ax.set_ylabel("post-denoise MSE", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{title}: error after denoising against time (labels: spp)")
    path = out / f"error_vs_time_{slug}.png"
    _save(fig, path)
    return path


def _spectra(
    slug: str, title: str, rows: list[dict], records: dict[tuple, Record], out: Path
) -> Path | None:
    from matplotlib.figure import Figure

    spp = min(r["spp"] for r in rows)
    denoiser = sorted({r["denoiser"] for r in rows})[0]
    fig = Figure(figsize=(9, 3.4))
    drawn = False
    for j, (kind, label) in enumerate((("raw", "raw error"), ("den", f"error after {denoiser}"))):
        ax = fig.add_subplot(1, 2, j + 1)
        for s in strategy_order(r["strategy"] for r in rows):
            rec = records.get((slug, s, spp, denoiser))
            spec = None if rec is None else rec.spectrum.get(kind)
            if spec is None or not spec.freq:
                continue
            freq, power = np.asarray(spec.freq)[1:], np.asarray(spec.power)[1:]
            ax.semilogy(freq, np.maximum(power, 1e-30), label=s)
            drawn = True
        ax.axvline(0.125, color="gray", lw=0.8, ls="--")
        ax.set_xlabel("cycles / pixel", fontsize=8)
        ax.set_ylabel("power", fontsize=8)
        ax.set_title(f"{label}, {spp} spp", fontsize=9)
        ax.legend(fontsize=7)
    if not drawn:
        return None
    fig.suptitle(f"{title}: radially averaged error spectrum")
    path = out / f"spectra_{slug}.png"
    _save(fig, path)
    return path


def _crops(
    slug: str, title: str, rows: list[dict], records: dict[tuple, Record], out: Path
) -> Path | None:
    from matplotlib.figure import Figure

    spp = min(r["spp"] for r in rows)
    denoiser = sorted({r["denoiser"] for r in rows})[0]
    images = []
    for s in strategy_order(r["strategy"] for r in rows):
        rec = records.get((slug, s, spp, denoiser))
        if rec is None or not rec.crop or not (out / rec.crop).exists():
            continue
        with np.load(out / rec.crop) as data:
            images.append((s, {k.replace("__", "/"): data[k] for k in data.files}))
    if not images:
        return None
    columns = ["reference", "raw"] + sorted(k for k in images[0][1] if k.startswith("denoised/"))
    fig = Figure(figsize=(1.9 * len(columns), 1.9 * len(images) + 0.4))
    for i, (strategy, crop) in enumerate(images):
        for j, col in enumerate(columns):
            ax = fig.add_subplot(len(images), len(columns), i * len(columns) + j + 1)
            if col in crop:
                ax.imshow(crop[col], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(col.removeprefix("denoised/"), fontsize=8)
            if j == 0:
                ax.set_ylabel(strategy, fontsize=8)
    fig.suptitle(f"{title}, {spp} spp: centre crops", fontsize=9)
    path = out / f"crops_{slug}.png"
    _save(fig, path)
    return path


def write_charts(
    rows: Sequence[dict], records: Sequence[Record], out_dir: str | Path
) -> list[Path]:
    """Draw every chart for the rows (whole-image region only); return the files written."""
    out = Path(out_dir)
    by_slug: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        if row["region"] == "all":
            by_slug[group_slug(group_key(row))].append(row)
    lookup = {}
    for rec in records:
        c = rec.cell
        if c.region == "all":
            slug = group_slug((c.scene, c.motion, c.depth, c.region, c.sampler))
            lookup[(slug, c.strategy, c.spp, c.denoiser)] = rec
    written = []
    for slug, group in sorted(by_slug.items()):
        title = group_title(group_key(group[0]))
        written.append(_error_vs_time(slug, title, group, out))
        for chart in (_spectra, _crops):
            path = chart(slug, title, group, lookup, out)
            if path is not None:
                written.append(path)
    return written


def write_report(
    out_dir: str | Path,
    records: Sequence[Record] | None = None,
    title: str | None = None,
    charts: bool = True,
) -> str:
    """Write ``table.csv``, ``table.md``, ``decision.md``, ``gap.md`` / ``gap.csv`` (when the
    records hold white and the oracle: :mod:`benchmarks.gap`) and the charts into ``out_dir``;
    return the Markdown of ``table.md``.

    Args:
        out_dir: the suite's output folder (holding ``cells.jsonl`` unless ``records`` is given).
        records: the runner's records; read from ``out_dir`` when None.
        title: heading of ``table.md`` (default: the folder's name).
        charts: draw the PNG charts too.
    """
    out = Path(out_dir)
    records = load_records(out) if records is None else list(records)
    rows = summarize(records)
    text = markdown_table(rows, title or f"bnerr bench: {out.name}")
    with atomic_write(out / "table.csv") as tmp:
        Path(tmp).write_text(_csv_text(rows))
    with atomic_write(out / "table.md") as tmp:
        Path(tmp).write_text(text)
    with atomic_write(out / "decision.md") as tmp:
        Path(tmp).write_text(decision_table(rows))
    write_gap_tables(out, records)
    write_denoise_tables(out, records, rows)
    if charts:
        write_charts(rows, records, out)
    return text


if __name__ == "__main__":
    import sys

    print(write_report(sys.argv[1]))
