"""``table.csv`` and ``table.md`` from the runner's records.

- ``table.csv`` (:func:`summarize`, :func:`csv_text`): one row per cell (scene, strategy, spp,
  denoiser, condition) with the raw and denoised MSE and their 95% intervals, relMSE,
  PSNR, SSIM, the blurred MSEs, the error's low-frequency fraction, the ratio of each strategy to
  white noise on the same frames (paired t-interval over seed sets,
  :func:`bnerr.metrics.paired_ratio`), the JOD's difference to white's where ``cvvdp`` was
  measured (``<kind>_cvvdp_diff``, :func:`bnerr.metrics.paired_differences`: higher is better),
  and the render, permutation and denoise milliseconds per frame. The metric columns come from
  :data:`bnerr.metrics.METRIC_TABLE` (:func:`table_columns`): a metric added there reaches the
  table with no change here. The other reports read these rows too.
- ``table.md`` (:func:`markdown_table`): the headline (temporal and oracle against white, per
  scene, spp and denoiser); per scene and condition, each strategy's post-denoise MSE as a
  fraction of white's, the raw error's ratios (MSE, blurred MSEs) and spectrum summary, the time
  per frame; and the list of cells where a strategy is worse than white beyond its interval.

Not for: deciding anything (:mod:`benchmarks.reports`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence

import numpy as np

from benchmarks.highlights import HEADLINE_METHOD
from benchmarks.reports.groups import group_key, group_title, strategy_order
from benchmarks.reports.intervals import Intervals
from benchmarks.reports.markdown import table_lines
from benchmarks.sweep.plan import Cell
from benchmarks.sweep.records import Record, bare_key, collector_paused, earlier_look
from bnerr import plugins
from bnerr.metrics import METRIC_TABLE, Metric, check_bootstrap
from bnerr.strategies import OWN_SAMPLERS, baseline, bounds, strategy_identity

__all__ = [
    "COLUMNS",
    "csv_text",
    "headline_strategies",
    "markdown_table",
    "render_sampler",
    "summarize",
    "table_columns",
]

#: The cell's columns of ``table.csv``, from :class:`benchmarks.sweep.plan.Cell`'s fields: its
#: identity first (scene, strategy, spp, denoiser and the condition), then the rest in the order
#: the cell declares them; ``reference_spp`` sits with the reference's columns.
_IDENTITY = ("scene", "strategy", "spp", "denoiser", "motion", "depth", "region", "sampler")
_CELL = _IDENTITY + tuple(
    f.name
    for f in dataclasses.fields(Cell)
    if f.name not in _IDENTITY and f.name != "reference_spp"
)
_KINDS = ("raw", "den")
_BOUNDS = ("", "_lo", "_hi")
#: The ratio the verdicts rest on (worse than white, the headline, the decision table): first.
_HEADLINE_RATIO = "den_mse"
_TIMES_AND_FLAGS = (
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


def _tabled() -> dict[str, Metric]:
    """The metrics of :data:`bnerr.metrics.METRIC_TABLE` that tables show, in its order (read at
    every call, so that an entry added to the table reaches ``table.csv`` with no change here)."""
    return {name: metric for name, metric in METRIC_TABLE.items() if metric.tabled}


def _interval_names() -> list[str]:
    """``raw_<m>``, ``den_<m>`` of every metric given an interval (``mse``)."""
    return [f"{k}_{name}" for name, m in _tabled().items() if m.interval for k in _KINDS]


def _ratio_names() -> list[str]:
    """``<kind>_<m>`` of every metric given a ratio to white: the headline's first, then the raw
    ones, then the denoised ones, each in table order."""
    names = [f"{k}_{name}" for k in _KINDS for name, m in _tabled().items() if m.ratio]
    return sorted(names, key=lambda name: name != _HEADLINE_RATIO)  # stable: the rest keep order


def _difference_names() -> list[str]:
    """``<kind>_<m>`` of every metric given a difference to white (a score on an interval scale:
    ``cvvdp``'s JOD), the raw ones, then the denoised ones, each in table order."""
    return [f"{k}_{name}" for k in _KINDS for name, m in _tabled().items() if m.difference]


def _value_names() -> list[str]:
    """``<kind>_<m>`` of the other metrics: per group (one metric, or the blurred MSEs), the raw
    values, then the denoised ones."""
    groups: dict[str, list[str]] = {}
    for name, m in _tabled().items():
        if not m.interval:
            groups.setdefault(m.group or name, []).append(name)
    return [f"{k}_{name}" for names in groups.values() for k in _KINDS for name in names]


def table_columns() -> tuple[str, ...]:
    """Columns of ``table.csv``, in order: the cell, then each metric's columns as its
    :class:`bnerr.metrics.Metric` entry asks (interval, ratio to white, group), then the times
    and flags. Read from the metrics' table at every call."""
    return (
        *_CELL,
        "dimensions",
        *(f"{name}{b}" for name in _interval_names() for b in _BOUNDS),
        *(f"{name}_ratio{b}" for name in _ratio_names() for b in _BOUNDS),
        *(f"{name}_diff{b}" for name in _difference_names() for b in _BOUNDS),
        *_value_names(),
        *_TIMES_AND_FLAGS,
    )


#: Columns of ``table.csv``, in order, as :func:`table_columns` gives them at import.
COLUMNS: tuple[str, ...] = table_columns()


def _stats(record: Record, kind: str, metric: str) -> np.ndarray | None:
    """``[S][F][2]`` per-frame pairs of ``metric`` (``kind`` ``raw`` or ``den``), or None when
    not measured: absent (a record written before the metric existed) or with no weight in any
    frame (a temporal metric over a single measured frame)."""
    values = getattr(record, kind).get(metric)
    if values is None:
        return None
    stats = np.asarray(values, dtype=np.float64)
    return stats if stats.size and stats[..., 1].sum() > 0 else None


def _baseline_key(record: Record, white: str) -> tuple:
    return dataclasses.astuple(dataclasses.replace(record.cell, strategy=white))


def _mean_ms(series: list[list[float]]) -> float:
    flat = [v for row in series for v in row]
    return float(np.mean(flat)) if flat else math.nan


Arrays = dict[str, np.ndarray | None]


def _arrays(record: Record) -> Arrays:
    """Every measured metric's pairs (:func:`_stats`) by column name (``raw_mse``), read once
    per record: a white record is every strategy's baseline."""
    return {f"{k}_{m}": _stats(record, k, m) for k in _KINDS for m in getattr(record, k)}


def _metric_columns(row: dict, arrays: Arrays, intervals: Intervals) -> None:
    """The pooled value of every metric, and the interval of those that have one asked of
    ``intervals``."""
    for name, pairs in arrays.items():
        if pairs is not None:
            row[name] = float(pairs[..., 0].sum() / pairs[..., 1].sum())
    for name in _interval_names():
        stats = arrays.get(name)
        if stats is not None:
            intervals.interval(row, name, stats)


def _ratio_columns(row: dict, arrays: Arrays, white: Arrays | None, intervals: Intervals) -> None:
    """The paired ratios (and differences) to the white record of the same cell, of the metrics
    that have one, asked of ``intervals``."""
    for name in _ratio_names():
        mine = arrays.get(name)
        base = None if white is None else white.get(name)
        if mine is None or base is None or mine.shape != base.shape:
            continue
        intervals.ratio(row, f"{name}_ratio", mine, base)
    for name in _difference_names():
        mine = arrays.get(name)
        base = None if white is None else white.get(name)
        if mine is not None and base is not None and mine.shape == base.shape:
            intervals.difference(row, f"{name}_diff", mine, base)


def _row(rec: Record, arrays: Arrays, white: Arrays | None, intervals: Intervals) -> dict:
    """A record's columns (its metrics' ``arrays``, and its white record's) but those that need
    its intervals (asked of ``intervals``) and the flags read from them (:func:`_flags`)."""
    row: dict = {k: getattr(rec.cell, k) for k in _CELL}
    row["dimensions"] = rec.dimensions
    _metric_columns(row, arrays, intervals)
    _ratio_columns(row, arrays, white, intervals)
    row["render_ms"] = _mean_ms(rec.timings.render_ms)
    row["perm_ms"] = _mean_ms(rec.timings.perm_ms)
    row["denoise_ms"] = _mean_ms(rec.timings.denoise_ms)
    row["total_ms"] = row["render_ms"] + row["perm_ms"] + row["denoise_ms"]
    row["reference_spp"] = rec.reference.spp
    row["reference_floor"] = rec.reference.floor
    row["render_sampler"] = render_sampler(rec)
    return row


def _flags(row: dict) -> None:
    """Worse than white, and raw MSE different from white's, from the row's ratio intervals."""
    lo = row.get("den_mse_ratio_lo")
    row["worse_than_white"] = None if lo is None else bool(lo > 1.0)
    raw_lo, raw_hi = row.get("raw_mse_ratio_lo"), row.get("raw_mse_ratio_hi")
    row["raw_differs_from_white"] = (
        None if raw_lo is None or raw_hi is None else bool(raw_lo > 1.0 or raw_hi < 1.0)
    )


def render_sampler(record: Record) -> str:
    """The sampler a record's frames were rendered with: the recorded one, or for files written
    before it was recorded the strategy's own (:data:`bnerr.strategies.OWN_SAMPLERS`), else the
    cell's per-pixel sampler condition."""
    if record.render_sampler:
        return record.render_sampler
    return OWN_SAMPLERS.get(record.cell.strategy, record.cell.sampler)


def _latest_whites(records: Sequence[Record], white: str) -> dict[str, Record]:
    """White's adaptive record with the most seed sets, by its cell's bare key."""
    latest: dict[str, Record] = {}
    for r in records:
        if r.cell.strategy == white and r.looks:
            key = bare_key(r.cell)
            if key not in latest or r.cell.seed_sets > latest[key].cell.seed_sets:
                latest[key] = r
    return latest


def _white_of(record: Record, white: str, latest: dict[str, Record]) -> Record | None:
    return latest.get(bare_key(dataclasses.replace(record.cell, strategy=white)))


def _earlier_whites(
    records: Sequence[Record], white: str, latest: dict[str, Record]
) -> dict[tuple, Record]:
    """White's records at the earlier looks its rivals stopped at: where a rival's adaptive
    record has fewer seed sets than white's record of the same cell (white went on for another
    sweep's rival, or the run stopped between white's look and the rival's), white's first seed
    sets (:func:`benchmarks.sweep.records.earlier_look`), keyed as :func:`_baseline_key`."""
    found = {}
    for r in records:
        w, n = _white_of(r, white, latest), r.cell.seed_sets
        rival = r.cell.strategy != white
        if rival and w is not None and n < w.cell.seed_sets and n in (w.looks or ()):
            found[_baseline_key(r, white)] = earlier_look(w, n)
    return found


def _at_whites_look(
    records: Sequence[Record], white: str, latest: dict[str, Record]
) -> list[Record]:
    """``records`` with each rival that went a look past white's (a run stopped between the
    rival's look and white's) taken back to white's look, where both were measured."""
    out = []
    for r in records:
        w = _white_of(r, white, latest)
        n = None if w is None else w.cell.seed_sets
        if r.cell.strategy != white and n is not None and n < r.cell.seed_sets:
            r = earlier_look(r, n) if n in (r.looks or ()) else r
        out.append(r)
    return out


def summarize(records: Iterable[Record], resamples: int = 2000, seed: int = 0) -> list[dict]:
    """One row per record: the columns of :func:`table_columns` (missing values as None).

    Ratios to white pair each record with the white record of the same cell (same scene, spp,
    denoiser, condition, frames and seed sets), or with that record's first seed sets where
    white went on to a later look (:func:`_earlier_whites`); a rival a look past white's is
    shown at white's look (:func:`_at_whites_look`). None when the suite has no such white
    record.
    """
    check_bootstrap(0.95, resamples)
    white = baseline()
    latest = _latest_whites(records := list(records), white)
    records = _at_whites_look(records, white, latest)
    whites = {_baseline_key(r, white): r for r in records if r.cell.strategy == white}
    whites = {**_earlier_whites(records, white, latest), **whites}
    columns = table_columns()
    intervals = Intervals(resamples, seed)
    out = []
    with collector_paused():
        baselines = {key: _arrays(r) for key, r in whites.items()}
        rows = []
        for rec in records:
            key = _baseline_key(rec, white)
            mine = baselines[key] if whites.get(key) is rec else _arrays(rec)
            rows.append(_row(rec, mine, baselines.get(key), intervals))
        intervals.fill()  # every interval of every row, batched by shape
        for rec, row in zip(records, rows, strict=True):
            _flags(row)
            done = {c: row.get(c) for c in columns}
            if rec.looks:  # an adaptive run's design, for its verdicts (not a table.csv column)
                done["looks"] = tuple(rec.looks)
            out.append(done)
    return out


def _unmeasured_plugin_columns(rows: Sequence[dict]) -> set[str]:
    """The columns of plug-in metrics (not shipped: :func:`bnerr.plugins.loaded`) that no row
    fills: an installed metric the records never measured adds no empty columns (issue 54)."""
    names = [m for m in _tabled() if plugins.loaded("bnerr.metrics", m) is not None]
    empty = set()
    for column in table_columns():
        base = column.removesuffix("_lo").removesuffix("_hi")
        base = base.removesuffix("_ratio").removesuffix("_diff")
        if base.partition("_")[2] in names and all(r.get(column) is None for r in rows):
            empty.add(column)
    return empty


def csv_text(rows: Sequence[dict]) -> str:
    """The text of ``table.csv``: the :data:`COLUMNS` header, one line per row, floats to 6
    significant digits, None as an empty field."""
    buffer = io.StringIO()
    unused = _unmeasured_plugin_columns(rows)  # a report is a function of its records
    fields = [c for c in table_columns() if c not in unused]
    writer = csv.DictWriter(buffer, fieldnames=fields, lineterminator="\n", extrasaction="ignore")
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


def _spp_denoiser_grid(
    rows: list[dict], strategies: list[str], cell: Callable[[dict | None, dict | None], str]
) -> list[list[str]]:
    """One table row per spp and denoiser: the two, then ``cell(row, white_row)`` per strategy
    (None where the strategy, or the white baseline, has no row there)."""
    by = {(r["spp"], r["denoiser"], r["strategy"]): r for r in rows}
    base = baseline()
    body = []
    for spp in sorted({r["spp"] for r in rows}):
        for d in sorted({r["denoiser"] for r in rows}):
            white = by.get((spp, d, base))
            body.append([str(spp), d, *(cell(by.get((spp, d, s)), white) for s in strategies)])
    return body


def _den_cell(row: dict | None, white: dict | None) -> str:
    """White's (or a strategy without a white row's) post-denoise MSE, the others' ratios."""
    if row is white or white is None:
        return "-" if row is None else f"{row['den_mse']:.4g}"
    return _ratio_text(row, "den_mse")


def _den_body(rows: list[dict], strategies: list[str]) -> list[list[str]]:
    """Post-denoise MSE per spp and denoiser: white's value, the others' ratios to it."""
    return _spp_denoiser_grid(rows, strategies, _den_cell)


def _flicker_cell(row: dict | None, white: dict | None) -> str:
    """White's (or a strategy without a white row's) tMSE and MSE of the temporal average after
    the denoiser, every other strategy's ratios to white's; "not measured" for a record written
    before the temporal metrics existed, or measured over a single frame."""
    if row is None:
        return "-"
    if row.get("den_tmse") is None:
        return "not measured"
    if white is None or row is white:
        tavg = row.get("den_mse_tavg")
        return f"{row['den_tmse']:.4g} / " + ("-" if tavg is None else f"{tavg:.4g}")
    tavg = row.get("den_mse_tavg_ratio")
    return _ratio_text(row, "den_tmse") + " / " + ("-" if tavg is None else f"{tavg:.3f}")


def _flicker_lines(rows: list[dict], strategies: list[str]) -> list[str]:
    """The group's flicker after denoising (:mod:`bnerr.metrics.temporal`); no lines when no row
    measured it (results written before it existed keep their table.md byte for byte)."""
    if all(r.get("den_tmse") is None for r in rows):
        return []
    body = _spp_denoiser_grid(rows, strategies, _flicker_cell)
    return [
        "Flicker after denoising: the MSE of the frame-to-frame change against the reference's "
        "own change (tMSE) with its 95% paired interval, then the MSE of the mean of up to 4 "
        "consecutive frames; white's absolute values, every other strategy's as a fraction of "
        "white's ((worse): its tMSE above white's beyond the interval).",
        "",
        *table_lines(["spp", "denoiser", *strategies], body),
        "",
    ]


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
        "(95% paired interval: a Student t-interval on the seed sets' log ratios).",
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
    lines += [""] + _flicker_lines(rows, strategies)
    lines += ["Milliseconds per frame: render + permutation (strategy overhead).", ""]
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


def _raw_causes(strategies: Sequence[str]) -> list[str]:
    """One line per strategy of the raw-difference table: its measured cause (its class's
    ``raw_mse_note``, a temporal variant's base's), or that none is established."""
    lines = []
    for name in strategies:
        cause = strategy_identity(name).raw_mse_note
        lines.append(f"- {name}: " + (cause or "cause not established."))
    return lines + [""]


def headline_strategies() -> tuple[str, ...]:
    """The strategies the headline compares with the baseline, in its cells' order: the method
    under test and the first registered bound (temporal, oracle)."""
    return (HEADLINE_METHOD, *bounds()[:1])


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
    headline = headline_strategies()
    body = []
    for key in order:
        by = {(r["spp"], r["denoiser"], r["strategy"]): r for r in groups[key]}
        if not any(s in headline for _, _, s in by):
            continue
        for spp in sorted({r["spp"] for r in groups[key]}):
            cells = [
                " / ".join(_headline_ratio(by.get((spp, d, s))) for s in headline)
                for d in denoisers
            ]
            body.append([group_title(key), str(spp), *cells])
    if not body:
        return []
    return [
        "## Headline: " + " / ".join(headline) + " post-denoise MSE as a fraction of white's",
        "",
        "Bold: below white beyond the 95% paired interval (a superiority claim: the whole "
        "t-interval over seed sets below 1); ↑: above white beyond it; -: not measured. "
        "Intervals and absolute values are in the sections below.",
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
