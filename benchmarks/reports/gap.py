"""The share of the white-to-oracle distance each strategy closes (docs/METHODS.md, section 8).

For one scene, spp and condition, with ``W``, ``V`` and ``O`` the mean MSE of ``white``, a
strategy and ``oracle`` over the same frames and seed sets::

    share = (W - V) / (W - O)

0 is white's error, 1 the oracle's; below 0 the strategy is worse than white, above 1 better than
the oracle. White is the registered baseline and the oracle the first registered bound
(:func:`bnerr.strategies.baseline`, :func:`bnerr.strategies.bounds`). It is computed for each
*measure*: the raw frames' MSE after the sigma-1 and sigma-2
blurs (``raw mse_blur1``, ``raw mse_blur2``: where a blue-noise error pays off) and each
denoiser's output MSE (``den mse``, per denoiser). The interval is a Student t-interval over the
seed sets (:func:`bnerr.metrics.share_interval`, like every other interval of the reports): the
linearized (delta-method) interval of a ratio of means, from each seed set's pooled means of the
three strategies on the same frames (so the frame-to-frame variation of the content cancels),
centred on the share of the pooled means, S - 1 degrees of freedom; its coverage at 2, 3, 4 and 8
seed sets, with normal and skewed seed-set effects, is simulated by ``python -m
bnerr.metrics.coverage --shares`` (docs/METHODS.md, section 8). A seed set where the oracle is not
below white has no gap to share: the interval is then unbounded (not resolved). Each row carries
its seed sets (``seed_sets``, a verdict on the best of m reads the interval at the corrected level
from them: :func:`bnerr.metrics.relevel_share`). Next to it, ``gap`` is the distance itself
relative to white, ``(W - O) / W``: a share of a gap near 0 means little.

- :func:`gap_shares`: one :class:`GapShare` per (scene, spp, condition, measure, strategy).
- :func:`gap_markdown` / :func:`gap_csv`: the table, one row per (scene, spp, condition,
  measure), one column per strategy.
- :func:`write_gap_tables`: ``gap.md`` and ``gap.csv`` in a results folder (nothing when the
  records hold no white and oracle pair), the one call the report makes.

Cells without both a white and an oracle record of the same scene, spp and condition (and the
same frame counts) are left out. Raw measures come from each run's first denoiser's record (the
raw frames are the same for every denoiser of a run).

Not for: comparing two strategies directly (that is :func:`bnerr.metrics.paired_ratio`).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import torch

from benchmarks.sweep.records import Record
from bnerr.io import atomic_write
from bnerr.metrics import as_stats, check_bootstrap, replicates, share_interval
from bnerr.strategies import baseline, bounds

__all__ = [
    "GAP_CSV",
    "GAP_MD",
    "RAW_MEASURES",
    "GapShare",
    "gap_csv",
    "gap_markdown",
    "gap_shares",
    "write_gap_tables",
]

#: The raw-frame measures (metric names of the records' ``raw``).
RAW_MEASURES: tuple[str, ...] = ("mse_blur1", "mse_blur2")
#: File names :func:`write_gap_tables` writes.
GAP_MD, GAP_CSV = "gap.md", "gap.csv"


def _ends() -> tuple[str, str]:
    """The two ends of the gap: the baseline (white) and the first bound (the oracle)."""
    return (baseline(), bounds()[0])


@dataclass(frozen=True)
class GapShare:
    """One strategy's share of the white-to-oracle distance on one cell and measure.

    Attributes:
        scene, spp: the cell.
        condition: ``m<motion>``, ``d<depth>`` when set, the region and the per-pixel sampler,
            e.g. ``"m1 all owen_sobol"``.
        measure: ``"raw mse_blur1"``, ``"raw mse_blur2"`` or ``"<denoiser> mse"``.
        strategy: the strategy measured.
        share, lo, hi: ``(W - V) / (W - O)`` and its t-interval over seed sets at ``level``.
        gap: ``(W - O) / W``.
        level: the interval's confidence level.
        seed_sets: the seed sets the interval rests on (0: not recorded).
    """

    scene: str
    spp: int
    condition: str
    measure: str
    strategy: str
    share: float
    lo: float
    hi: float
    gap: float
    level: float
    seed_sets: int = 0


def _condition(record: Record) -> str:
    c = record.cell
    depth = "" if c.depth is None else f" d{c.depth}"
    return f"m{c.motion}{depth} {c.region} {c.sampler}"


#: Records measured on the same frames: scene, spp, condition, frames, seed sets, width, height.
_GroupKey = tuple[str, int, str, int, int, int, int]


def _group_key(record: Record) -> _GroupKey:
    c = record.cell
    return (c.scene, c.spp, _condition(record), c.frames, c.seed_sets, c.width, c.height)


def _measures(records: Iterable[Record]) -> dict[_GroupKey, dict[str, dict[str, torch.Tensor]]]:
    """group key -> measure -> strategy -> ``[S, F, 2]`` stats (raw: the first denoiser's)."""
    out: dict[_GroupKey, dict[str, dict[str, torch.Tensor]]] = {}
    for r in records:
        by_measure = out.setdefault(_group_key(r), {})
        wanted = [(f"raw {m}", r.raw.get(m)) for m in RAW_MEASURES]
        wanted.append((f"{r.cell.denoiser} mse", r.den.get("mse")))
        for measure, values in wanted:
            if values is not None:
                by_measure.setdefault(measure, {}).setdefault(
                    r.cell.strategy, as_stats(values, measure)
                )
    return out


def _share(
    w: torch.Tensor, v: torch.Tensor, o: torch.Tensor, level: float
) -> tuple[float, float, float, float]:
    """``(share, lo, hi, gap)`` of stats ``[S, F, 2]`` of white, the strategy and the oracle
    (:func:`bnerr.metrics.share_interval`: NaN where the oracle is no better than white's mean,
    unbounded where a seed set has no gap)."""
    pooled = tuple(x[..., 0].sum() / x[..., 1].sum() for x in (w, v, o))
    rw, rv, ro = (replicates(x) for x in (w, v, o))
    share, lo, hi = share_interval((rw, rv, ro), (pooled[0], pooled[1], pooled[2]), level)
    mean_w, mean_o = float(pooled[0]), float(pooled[2])
    gap = (mean_w - mean_o) / mean_w if mean_w else float("nan")
    return float(share), float(lo), float(hi), gap


def gap_shares(
    records: Iterable[Record], *, level: float = 0.95, resamples: int = 2000
) -> list[GapShare]:
    """Every strategy's share of the white-to-oracle distance, per cell and measure.

    Args:
        records: benchmark records (:func:`benchmarks.sweep.records.load_records`).
        level: the intervals' confidence level in [0.5, 0.999].
        resamples: checked and kept for callers of the former bootstrap (>= 100; unused).

    Returns:
        :class:`GapShare` s in the records' order of cells, measures and strategies; white and
        oracle themselves are left out (their shares are 0 and 1 by definition).
    """
    check_bootstrap(level, resamples)
    ends = _ends()
    rows = []
    for key, by_measure in _measures(records).items():
        for measure, by_strategy in by_measure.items():
            if not all(b in by_strategy for b in ends):
                continue
            w, o = (by_strategy[b] for b in ends)
            for strategy, v in by_strategy.items():
                if strategy in ends or v.shape != w.shape or o.shape != w.shape:
                    continue
                share, lo, hi, gap = _share(w, v, o, level)
                rows.append(
                    GapShare(*key[:3], measure, strategy, share, lo, hi, gap, level, key[4])
                )
    return rows


def _pivot(rows: Sequence[GapShare]) -> tuple[list[str], dict[tuple, dict[str, GapShare]]]:
    strategies = list(dict.fromkeys(r.strategy for r in rows))
    table: dict[tuple, dict[str, GapShare]] = {}
    for r in rows:
        table.setdefault((r.scene, r.spp, r.condition, r.measure), {})[r.strategy] = r
    return strategies, table


def gap_markdown(rows: Sequence[GapShare], title: str = "Share of the white-to-oracle gap") -> str:
    """A markdown table: one row per (scene, spp, condition, measure), a column per strategy
    holding ``share [lo, hi]``, and the gap ``(W - O) / W``; '' when there are no rows."""
    if not rows:
        return ""
    strategies, table = _pivot(rows)
    head = ["scene", "spp", "condition", "measure", "gap (W-O)/W", *strategies]
    lines = [
        f"## {title}",
        "",
        f"`(white - strategy) / (white - oracle)` of mean MSE, {rows[0].level:.0%} paired "
        "t-interval over the seed sets' shares ([-inf, inf]: a seed set without a gap, not "
        "resolved); 0 is white, 1 the oracle.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for (scene, spp, cond, measure), by in table.items():
        gap = next(iter(by.values())).gap
        cells = [
            f"{by[s].share:.2f} [{by[s].lo:.2f}, {by[s].hi:.2f}]" if s in by else ""
            for s in strategies
        ]
        lines.append(
            "| " + " | ".join([scene, str(spp), cond, measure, f"{gap:.3f}", *cells]) + " |"
        )
    return "\n".join(lines) + "\n"


def gap_csv(rows: Sequence[GapShare]) -> str:
    """The rows as CSV, one line per :class:`GapShare` (its fields as columns)."""
    buffer = io.StringIO()
    fields = list(GapShare.__dataclass_fields__)
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(fields)
    for r in rows:
        writer.writerow([getattr(r, f) for f in fields])
    return buffer.getvalue()


def write_gap_tables(out_dir: str | Path, records: Iterable[Record]) -> list[GapShare]:
    """Write ``gap.md`` and ``gap.csv`` into ``out_dir`` (atomically); none when no cell has
    both white and oracle. Returns the rows."""
    rows = gap_shares(records)
    if rows:
        for name, text in ((GAP_MD, gap_markdown(rows)), (GAP_CSV, gap_csv(rows))):
            with atomic_write(Path(out_dir) / name) as tmp:
                Path(tmp).write_text(text)
    return rows
