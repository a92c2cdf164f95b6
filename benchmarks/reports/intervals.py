"""The intervals of a table's cells, computed together: every pooled-mean interval and every
paired ratio (or difference, :func:`bnerr.metrics.paired_differences`) to white that
:func:`benchmarks.reports.table.summarize` asks for, batched by shape.

A suite's table asks for thousands of small intervals (the quality suite: about 150,000, each
over 8-16 seed sets of 3 frames), and one call of :func:`bnerr.metrics.bootstrap_interval` or
:func:`bnerr.metrics.paired_ratio` per interval spends most of its time in torch's per-call cost.
:class:`Intervals` collects them while the rows are built, then computes each group of one
shape with :func:`bnerr.metrics.pooled_intervals` and :func:`bnerr.metrics.paired_ratios`, which
give the same bits as the single calls (every sum is a fixed-order sum along one axis, element by
element across the batch), so the committed tables regenerate byte for byte. Cells with one
seed set (a within-run interval over frames) and a group the batched call refuses (a
non-positive seed-set mean, a non-finite value) go through the single calls, which keep their
behaviour and errors.

Not for: the statistics (:mod:`bnerr.metrics.stats`) or the table's columns
(:mod:`benchmarks.reports.table`).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from bnerr.errors import BnerrError
from bnerr.metrics import (
    Estimate,
    bootstrap_interval,
    paired_differences,
    paired_ratio,
    paired_ratios,
    pooled_intervals,
)

__all__ = ["Intervals"]


def _batched(
    items: Sequence[tuple[np.ndarray, ...]],
    many: Callable[..., list[Estimate]],
    one: Callable[..., Estimate],
) -> list[Estimate]:
    """``one(*item)`` of every item, through ``many`` over the stacked items where it takes
    them (items of one shape, S >= 2 seed sets)."""
    if items[0][0].shape[0] >= 2:
        try:
            return many(*(np.stack(column) for column in zip(*items, strict=True)))
        except BnerrError:  # the single calls say which cell, as they always did
            pass
    return [one(*item) for item in items]


@dataclass
class Intervals:
    """The intervals a table's rows ask for, filled into the rows by :meth:`fill`.

    Each entry is ``(row, column, arrays)``: :meth:`fill` writes ``row[column]``,
    ``row[column + "_lo"]`` and ``row[column + "_hi"]``.
    """

    resamples: int = 2000
    seed: int = 0
    singles: list[tuple[dict, str, np.ndarray]] = field(default_factory=list)
    pairs: list[tuple[dict, str, np.ndarray, np.ndarray]] = field(default_factory=list)
    differences: list[tuple[dict, str, np.ndarray, np.ndarray]] = field(default_factory=list)

    def interval(self, row: dict, column: str, stats: np.ndarray) -> None:
        """Ask for the pooled mean of ``stats [S, F, 2]`` with its interval."""
        self.singles.append((row, column, stats))

    def ratio(self, row: dict, column: str, mine: np.ndarray, base: np.ndarray) -> None:
        """Ask for the paired ratio of ``mine`` to ``base`` (both ``[S, F, 2]``, one shape)."""
        self.pairs.append((row, column, mine, base))

    def difference(self, row: dict, column: str, mine: np.ndarray, base: np.ndarray) -> None:
        """Ask for the paired difference ``mine - base`` (both ``[S, F, 2]``, one shape)."""
        self.differences.append((row, column, mine, base))

    def _one(self, stats: np.ndarray) -> Estimate:
        return bootstrap_interval(stats, resamples=self.resamples, seed=self.seed)

    def _one_ratio(self, mine: np.ndarray, base: np.ndarray) -> Estimate:
        return paired_ratio(mine, base, resamples=self.resamples, seed=self.seed)

    def fill(self) -> None:
        """Compute every interval asked for, by groups of one shape, into its row; then forget
        them."""
        _fill(self.singles, pooled_intervals, self._one)
        _fill(self.pairs, paired_ratios, self._one_ratio)
        _fill(self.differences, paired_differences, _one_difference)
        self.singles, self.pairs, self.differences = [], [], []


def _one_difference(mine: np.ndarray, base: np.ndarray) -> Estimate:
    (found,) = paired_differences(mine[None], base[None])
    return found


def _fill(
    entries: Sequence[tuple],
    many: Callable[..., list[Estimate]],
    one: Callable[..., Estimate],
) -> None:
    """Each ``(row, column, *arrays)`` entry's interval into its row, computed by groups of one
    shape (:func:`_batched`)."""
    groups: dict[tuple, list[tuple]] = defaultdict(list)
    for entry in entries:
        groups[entry[2].shape].append(entry)
    for group in groups.values():
        found = _batched([tuple(arrays) for _, _, *arrays in group], many, one)
        for (row, column, *_), est in zip(group, found, strict=True):
            row[column], row[f"{column}_lo"], row[f"{column}_hi"] = est.value, est.lo, est.hi
