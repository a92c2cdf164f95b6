"""How many seed sets a claim needs: the power of the t-interval of :func:`paired_ratio`.

A suite resolves a strategy's ratio to white when the whole interval lies on one side of 1
(:func:`bnerr.metrics.better`). With S seed sets whose log ratios scatter with standard deviation
``sd`` around ``log(r)``, the interval's upper end is ``log(r) + t(S - 1) * sd_hat / sqrt(S)``;
the chance that it lies below 0 is the upper tail of a noncentral t with S - 1 degrees of freedom
and noncentrality ``-log(r) sqrt(S) / sd`` beyond the two-sided quantile (Cohen 1988, chapter 2,
for the paired t-test; scipy's ``nctdtr``). :func:`resolve_power` gives that chance,
:func:`seed_sets_needed` the fewest S that reach a wanted power, and :func:`seed_sets_to_settle`
the fewest S that give a cell a verdict whatever its true ratio (an open cell's "how many more").

The spread ``sd`` is measured, not assumed: :func:`seed_set_spread` takes it from a cell's
per-frame values (the standard deviation of its per-seed-set log ratios). On the committed
``quality`` and ``stability`` suites (4 seed sets x 3 frames) it is 0.04 in the median cell,
0.08 at the 75th and 0.14 at the 90th percentile (docs/METHODS.md, section 6).

Not for: claims with a margin (equivalence and non-inferiority shift the bound from 1 to
``1 -+ d``: use ``effect`` relative to that bound).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.metrics.stats import as_stats, set_means, t_quantile

__all__ = ["resolve_power", "seed_set_spread", "seed_sets_needed", "seed_sets_to_settle"]


def _check(effect: float, sd: float, level: float, power: float | None = None) -> None:
    if not 0.0 < effect < 1.0:
        raise ValueRangeError(f"effect: expected a relative reduction in (0, 1), got {effect}")
    if not sd > 0.0 or math.isinf(sd):
        raise ValueRangeError(f"sd: expected a positive, finite spread, got {sd}")
    if not 0.5 <= level < 1.0:
        raise ValueRangeError(f"level: expected a confidence level in [0.5, 1), got {level}")
    if power is not None and not 0.0 < power < 1.0:
        raise ValueRangeError(f"power: expected a probability in (0, 1), got {power}")


def resolve_power(effect: float, sd: float, seed_sets: int, level: float = 0.95) -> float:
    """The chance that ``seed_sets`` seed sets put a true ratio of ``1 - effect`` below white
    beyond the two-sided interval at ``level``, when the seed sets' log ratios scatter by ``sd``.

    Example: a 5 % reduction with the median spread of the committed suites, ``effect=0.05,
    sd=0.04``, is resolved with probability 0.42 by 4 seed sets and 0.87 by 8 (two-sided 95 %).
    """
    from scipy.special import nctdtr  # 0.4 s of import that `bnerr --help` need not pay

    _check(effect, sd, level)
    seed_sets = check_positive_int(seed_sets, "seed_sets", minimum=2)
    df = seed_sets - 1
    shift = -math.log1p(-effect) * math.sqrt(seed_sets) / sd
    return float(1.0 - nctdtr(df, shift, t_quantile(level, df)))


def seed_sets_needed(
    effect: float, sd: float, level: float = 0.95, power: float = 0.8, most: int = 1024
) -> int | None:
    """The fewest seed sets (>= 2) that resolve a reduction of ``effect`` with ``power``
    (:func:`resolve_power`), or None when even ``most`` do not."""
    _check(effect, sd, level, power)
    for seed_sets in range(2, check_positive_int(most, "most", minimum=2) + 1):
        if resolve_power(effect, sd, seed_sets, level) >= power:
            return seed_sets
    return None


def seed_set_spread(
    values: torch.Tensor | Sequence[float], baseline: torch.Tensor | Sequence[float]
) -> float:
    """The standard deviation of the per-seed-set log ratios ``log(mean(values) /
    mean(baseline))`` of one cell: per-frame values ``[S, F]`` or ``[S, F, 2]`` (S >= 2), as
    :func:`bnerr.metrics.paired_ratio` takes them."""
    a, b = as_stats(values, "values"), as_stats(baseline, "baseline")
    if a.shape != b.shape or a.shape[0] < 2:
        raise ValueRangeError(
            f"values: expected [S, F] like baseline with S >= 2 seed sets, got {list(a.shape)} "
            f"and {list(b.shape)}"
        )
    return float(torch.log(set_means(a) / set_means(b)).std())


def seed_sets_to_settle(
    sd: float, margin: float = 0.05, level: float = 0.95, most: int = 100_000
) -> int | None:
    """The fewest seed sets (>= 2) whose interval at ``level`` settles a cell whatever its true
    ratio, when the seed sets' log ratios scatter by ``sd``: the interval's half-width
    ``t(level, S - 1) * sd / sqrt(S)`` at most ``log(1 + margin) / 2``. An interval that narrow
    lies below 1, above 1, or inside ``1 -+ margin`` (better, worse or equal:
    :func:`bnerr.metrics.sequential.settle`), wherever it is centred. None when even ``most`` do
    not. With ``sd`` read from S seed sets it is an estimate, as good as that spread."""
    if not sd > 0.0 or math.isinf(sd):
        raise ValueRangeError(f"sd: expected a positive, finite spread, got {sd}")
    if not 0.0 < margin < 1.0 or not 0.5 <= level < 1.0:
        raise ValueRangeError(
            f"margin, level: expected a margin in (0, 1) and a level in [0.5, 1), got {margin} "
            f"and {level}"
        )
    most = check_positive_int(most, "most", minimum=2)
    bound = math.log1p(margin) / 2.0

    def narrow(seed_sets: int) -> bool:
        return t_quantile(level, seed_sets - 1) * sd / math.sqrt(seed_sets) <= bound

    if not narrow(most):
        return None
    lo, hi = 1, most  # narrow(hi) holds; the half-width falls as S grows
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if narrow(mid) else (mid, hi)
    return max(hi, 2)
