"""Adaptive seed sets: a cell is looked at after batches of seed sets and stops when settled.

A suite cell compares the best of m strategies with white by the t-interval of
:func:`bnerr.metrics.paired_ratio` (docs/METHODS.md, section 6, "Intervals"). With more seed sets
added only where the verdict is still open, the cell is looked at several times, and an interval
at the plain level after each look would miss more often than stated (the "add until significant"
procedure: :func:`naive_design`, which the coverage study shows failing). This module keeps the
stated level with a **group-sequential design whose alpha is spent by the union bound** (the
Bonferroni inequality over the looks; Jennison & Turnbull 2000, sections 1.3 and 7.2, on
alpha spending; Pocock 1977 for equal spending):

- the looks are fixed before the first seed set: ``n_1 < n_2 < ... < n_K`` seed sets
  (:func:`looks`: the suite's seed sets, then doubled, or ``batch`` more each time, to the cap);
- look k spends ``alpha_k = alpha / K`` (equal spending, Pocock's shape), ``sum alpha_k = alpha``;
- at look k the interval of the log ratio is the t-interval of :func:`paired_ratio` at level
  ``1 - alpha_k / m`` (Bonferroni for the best of ``m`` rivals on top):
  ``log r_hat -+ t_{n_k - 1}(1 - alpha_k / (2 m)) * sd_k / sqrt(n_k)``;
- the cell stops at the first look where its verdict is settled (:func:`settle`: ``better``, the
  interval below 1; ``worse``, above 1; ``equal``, inside ``1 -+ margin``), else at the last look
  it is ``open`` at the cap.

**Why it keeps coverage.** The interval reported is the one at the look the cell stopped at, so
it misses the true ratio only if some look's interval missed it: by the union bound the chance is
at most ``sum_k alpha_k / m = alpha / m`` per rival, and ``alpha`` for the family of m. The bound
holds whatever the dependence between the looks and whatever the stopping rule, given each look's
t-interval is valid (normal log ratios over independent seed sets); it is conservative against an
exact Pocock boundary, which uses the looks' correlation (at K = 4 Pocock's nominal level is
0.0182 against 0.0125 here). A single look (a fixed number of seed sets, every suite run without
``--until-resolved``) spends all of ``alpha`` there: the plain interval.

**Bias.** Stopping when the interval leaves 1 selects estimates that lie far from 1, so the ratio
reported at the stop is biased away from 1 (Whitehead 1986); :mod:`bnerr.metrics.coverage`
measures how much (``--sequential``), docs/METHODS.md states the bound.

Not for: the intervals themselves (:mod:`bnerr.metrics.stats`) or running the suites
(``bnerr bench --until-resolved``, :mod:`benchmarks.sweep.adaptive`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from bnerr.errors import ValueRangeError, check_positive_int, check_range
from bnerr.metrics.stats import Estimate, relevel_ratio, t_quantile

__all__ = [
    "ALPHA",
    "MAX_LOOKS",
    "VERDICTS",
    "Design",
    "looks",
    "naive_design",
    "run_sequential",
    "settle",
]

#: The family error rate every verdict keeps (95 % coverage).
ALPHA = 0.05
#: Most looks in one design: each spends alpha / K, so a design of thousands of looks (a cap of
#: 10^6 seed sets in batches of 1) could never resolve, and its list alone would fill memory.
MAX_LOOKS = 64
#: What a look can say: superiority, inferiority, equivalence within the margin, or none.
VERDICTS = ("better", "worse", "equal", "open")


def looks(first: int, cap: int, batch: int | None = None) -> tuple[int, ...]:
    """The seed-set counts a cell is looked at: ``first``, then ``first + batch``, ... (or, with
    no ``batch``, doubled each time), ending at ``cap`` (the last look is the cap itself).

    Raises:
        ValueRangeError: ``first`` < 2 (an interval needs two seed sets), ``cap`` < ``first``,
            or more than :data:`MAX_LOOKS` looks, refused before they are listed.
    """
    check_positive_int(first, "first", minimum=2)
    check_positive_int(cap, "cap", minimum=2)
    if batch is not None:
        check_positive_int(batch, "batch")
    if cap < first:
        raise ValueRangeError(f"cap: expected at least the first look's {first}, got {cap}")
    if batch:
        count = 1 + -(-(cap - first) // batch)
    else:  # doubling: about log2(cap / first) looks, counted (cheap) rather than estimated
        count, n = 1, first
        while n < cap:
            count, n = count + 1, 2 * n
    if count > MAX_LOOKS:
        raise ValueRangeError(
            f"looks: expected at most {MAX_LOOKS} looks from {first} to the cap {cap}"
            f"{f' in batches of {batch}' if batch else ''}, got {count}"
        )
    counts = [first]
    while counts[-1] < cap:
        counts.append(min(cap, counts[-1] + batch if batch else 2 * counts[-1]))
    return tuple(counts)


@dataclass(frozen=True)
class Design:
    """A group-sequential design: the looks (seed-set counts) and the alpha each one spends.

    Attributes:
        looks: increasing seed-set counts, fixed before the first seed set.
        alpha: the family error rate (``sum(spent) <= alpha``).
        spent: ``alpha_k`` per look; by default ``alpha / K`` each (Pocock's equal spending).
    """

    looks: tuple[int, ...]
    alpha: float = ALPHA
    spent: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not self.looks or list(self.looks) != sorted(set(self.looks)) or self.looks[0] < 2:
            raise ValueRangeError(
                f"looks: expected increasing seed-set counts from 2, got {list(self.looks)}"
            )
        # up to K: the naive design spends alpha at every look (naive_design)
        check_range(self.alpha, "alpha", 1e-6, float(len(self.looks)))
        if not self.spent:
            object.__setattr__(self, "spent", (self.alpha / len(self.looks),) * len(self.looks))
        if len(self.spent) != len(self.looks) or sum(self.spent) > self.alpha * (1 + 1e-9):
            raise ValueRangeError(
                f"spent: expected one alpha per look summing to at most {self.alpha}, got "
                f"{list(self.spent)}"
            )

    @property
    def cap(self) -> int:
        return self.looks[-1]

    def level(self, seed_sets: int, rivals: int = 1) -> float:
        """The two-sided level of the interval at the look of ``seed_sets``, corrected for the
        best of ``rivals``: ``1 - alpha_k / rivals``.

        Raises:
            ValueRangeError: ``seed_sets`` is not one of the looks.
        """
        if seed_sets not in self.looks:
            raise ValueRangeError(
                f"seed_sets: expected one of the design's looks {list(self.looks)}, got {seed_sets}"
            )
        return 1.0 - self.spent[self.looks.index(seed_sets)] / max(rivals, 1)

    def interval(self, estimate: Estimate, seed_sets: int, rivals: int = 1) -> Estimate:
        """``estimate`` (a t-interval of a ratio over ``seed_sets`` seed sets, at any level) at
        this design's level for that look (:func:`bnerr.metrics.relevel_ratio`)."""
        return relevel_ratio(estimate, self.level(seed_sets, rivals), seed_sets - 1)

    def verdict(
        self, estimate: Estimate, seed_sets: int, rivals: int = 1, margin: float = 0.05
    ) -> str:
        """:func:`settle` on the look's interval, ``"open"`` if unsettled (more seed sets to come,
        or, at the cap, open at the cap)."""
        return settle(self.interval(estimate, seed_sets, rivals), margin)


def naive_design(cap: int, alpha: float = ALPHA) -> Design:
    """ "Add a seed set until significant": a look after every seed set from 2 to ``cap``, each at
    the full ``alpha`` (what the union bound forbids; the coverage study shows it failing)."""
    counts = tuple(range(2, cap + 1))
    return Design(counts, alpha * len(counts), (alpha,) * len(counts))


def settle(estimate: Estimate, margin: float = 0.05) -> str:
    """The verdict of an interval of a ratio (lower is better): ``"better"`` (``hi < 1``),
    ``"worse"`` (``lo > 1``), ``"equal"`` (inside ``1 -+ margin``, equivalence) or ``"open"``."""
    check_range(margin, "margin", 0.0, 1.0)
    if estimate.hi < 1.0:
        return "better"
    if estimate.lo > 1.0:
        return "worse"
    if 1.0 - margin <= estimate.lo and estimate.hi <= 1.0 + margin:
        return "equal"
    return "open"


def run_sequential(
    logs: torch.Tensor,
    centres: torch.Tensor,
    design: Design,
    rivals: int = 1,
    margin: float = 0.05,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """The whole procedure on many cells at once (the coverage study's batched form).

    Args:
        logs: ``[T, N]`` float64 per-seed-set log ratios, ``N >= design.cap``.
        centres: ``[T, K]`` the log of the pooled ratio over the first ``n_k`` seed sets, the
            estimate each look's interval is centred on.
        design, rivals, margin: as :meth:`Design.verdict`.

    Returns:
        ``(stop, centre, lo, hi)``, each ``[T]``: the look index each cell stopped at (K - 1
        when open at the cap) and its log ratio with the log interval there.
    """
    trials = logs.shape[0]
    stop = torch.full((trials,), len(design.looks) - 1, dtype=torch.long)
    done = torch.zeros(trials, dtype=torch.bool)
    out = [torch.zeros(trials, dtype=torch.float64) for _ in range(3)]
    for k, n in enumerate(design.looks):
        sub = logs[:, :n]
        sd = sub.std(dim=1)
        half = t_quantile(design.level(n, rivals), n - 1) * sd / math.sqrt(n)
        centre = centres[:, k]
        lo, hi = centre - half, centre + half
        settled = (hi < 0) | (lo > 0)
        settled |= (lo >= math.log(1 - margin)) & (hi <= math.log(1 + margin))
        take = ~done & (settled | (k == len(design.looks) - 1))
        stop[take & settled] = k
        for tensor, value in zip(out, (centre, lo, hi), strict=True):
            tensor[take] = value[take]
        done |= take
    return stop, out[0], out[1], out[2]
