"""The share of a gap a strategy closes, ``(W - V) / (W - O)``, and its interval over seed sets.

``W``, ``V`` and ``O`` are the pooled mean errors of the baseline (white), a strategy and the
bound (the oracle) over the same frames and seed sets; 0 is the baseline's error, 1 the bound's
(the gap suite's table, :mod:`benchmarks.reports.gap`, docs/METHODS.md, section 8).

**The interval** (:func:`share_interval`) is the linearized (delta-method) t-interval of a ratio
of means, the ratio estimator's (Cochran 1977, *Sampling Techniques*, section 6.4): with
``w_s, v_s, o_s`` seed set s's pooled means and ``share`` the pooled share, the S replicates

    share + ((w_s - v_s) - share * (w_s - o_s)) / (W - O)

have the pooled share as their mean (the seed sets weigh alike) and the share's first-order
variation as their spread; the t-interval over them (S - 1 degrees of freedom,
:func:`bnerr.metrics.t_interval`) is the share's. It replaced the t-interval of the per-seed-set
shares ``(w_s - v_s) / (w_s - o_s)``, whose spread is not the pooled share's: with skewed 15 %
seed-set effects and a gap of 0.8 that interval missed 6.2-6.6 % at 8 seed sets and 7.5-7.7 % at
16 (nominal 5 %, 40 000 trials); this one 5.0-5.5 % and 5.2-5.7 %. ``python -m
bnerr.metrics.coverage --shares`` gives its table at 2, 3, 4 and 8 seed sets (docs/METHODS.md,
section 8).

A seed set whose bound is not below the baseline (no gap in it) makes the interval unbounded
(``-inf, inf``: not resolved), as with one seed set; no gap in the pooled means makes the share
itself NaN.

**Best of m** (:func:`relevel_share`): a verdict on the highest share of m strategies (the seed
suite's "best variant", :mod:`benchmarks.reports.seed`) reads its interval at the Bonferroni
level ``1 - (1 - level) / m``, as the decision table does for the lowest ratio of m.

Not for: ratios of two strategies (:func:`bnerr.metrics.paired_ratio`).
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import ValueRangeError, check_range
from bnerr.metrics.stats import t_interval, t_quantile

__all__ = ["best_level", "relevel_share", "share_interval"]


def share_interval(
    reps: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    pooled: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    level: float,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The share of the pooled means and its interval (module docstring).

    Args:
        reps: ``(w, v, o)`` per-seed-set pooled means, each ``[..., S]`` float64 (the batch axes
            let the coverage study run many cells at once).
        pooled: ``(W, V, O)`` the pooled means over every seed set, each ``[...]``.
        level: the interval's confidence level.

    Returns:
        ``(share, lo, hi)``, each ``[...]``: NaN everywhere where ``W <= O``; ``lo = -inf``,
        ``hi = inf`` where a seed set has ``w_s <= o_s`` or ``S < 2``.
    """
    check_range(level, "level", 0.5, 1.0 - 1e-12)
    w, v, o = reps
    pw, pv, po = pooled
    gap = pw - po
    share = (pw - pv) / gap
    nan = torch.full_like(share, math.nan)
    if w.shape[-1] < 2:
        unbounded = torch.ones_like(share, dtype=torch.bool)
        lo, hi = share, share
    else:
        z = share[..., None] + ((w - v) - share[..., None] * (w - o)) / gap[..., None]
        lo, hi = t_interval(z, share, level)
        unbounded = ~(w > o).all(dim=-1)
    lo = torch.where(unbounded, -math.inf, lo)
    hi = torch.where(unbounded, math.inf, hi)
    no_gap = ~(gap > 0)
    return (
        torch.where(no_gap, nan, share),
        torch.where(no_gap, nan, lo),
        torch.where(no_gap, nan, hi),
    )


def best_level(level: float, rivals: int) -> float:
    """The Bonferroni level of a verdict on the best of ``rivals``: ``1 - (1 - level) / m``."""
    if rivals < 1:
        raise ValueRangeError(f"rivals: expected at least 1, got {rivals}")
    return 1.0 - (1.0 - level) / rivals


def relevel_share(
    share: float, lo: float, hi: float, level: float, new_level: float, seed_sets: int
) -> tuple[float, float]:
    """The interval ``[lo, hi]`` of ``share`` (a t-interval at ``level`` over ``seed_sets``) at
    ``new_level``: the half-widths scaled by the ratio of the t quantiles (unbounded and NaN
    ends stay as they are).

    Raises:
        ValueRangeError: ``seed_sets`` < 2.
    """
    if seed_sets < 2:
        raise ValueRangeError(f"seed_sets: expected at least 2 to relevel, got {seed_sets}")
    scale = t_quantile(new_level, seed_sets - 1) / t_quantile(level, seed_sets - 1)
    return share - (share - lo) * scale, share + (hi - share) * scale
