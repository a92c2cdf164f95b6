"""Statistics over frames: pooled means of ``(numerator, denominator)`` pairs and their intervals.

Every metric update (:mod:`bnerr.metrics.frames`) reduces one frame to a pair ``(numerator,
denominator)``; the pooled mean over frames is ``sum(numerators) / sum(denominators)``
(:func:`pooled_mean`).

**Intervals** (docs/METHODS.md, section 6, "Intervals"). The unit of replication is the
independent seed set: frames of one temporal run share its seeds, so they are neither independent
nor exchangeable with another run's frames. :func:`paired_ratio` and :func:`bootstrap_interval`
therefore reduce each seed set to one number (its pooled mean over its frames, or for a ratio the
log of the ratio of the two strategies' pooled means) and put a Student t-interval with S - 1
degrees of freedom on those S numbers (Student 1908; for the log ratio, the paired comparison of
Cox & Hinkley 1974, section 4.4), centred on the estimate from all the data. The coverage study
:mod:`bnerr.metrics.coverage` measured why: at the suites' 4 seed sets x 3 frames the former
two-stage percentile bootstrap (Efron & Tibshirani 1993) missed a true ratio of 1 in 13 % of
trials at 95 % with a 5 % seed-set effect, and in 5 % at 99.69 % (nominal 0.31 %), while the
t-interval stays at its nominal rate. The bootstrap stays available as ``method="bootstrap"``,
with its pieces (:func:`resample_weights`, :func:`resampled_values`,
:func:`percentile_interval`), to compare with.

With one seed set (per-frame values ``[F]``) there is nothing to replicate over; the interval then
falls back to a t-interval over the frames (F - 1 degrees of freedom), which is a within-run
interval and too narrow for a temporal run whose frames are correlated (say so where it is
quoted); with a single value it is infinite.

**Building blocks.** A statistic that is neither a mean nor a ratio of two means (the share of a
gap, :mod:`benchmarks.reports.gap`) is built from the same pieces, so that its interval rests on
the same replicates as the others: :func:`as_stats` (values to ``[S, F, 2]`` pairs),
:func:`replicates` (one pooled mean per seed set), :func:`t_interval` and :func:`check_bootstrap`
(the arguments' checks); the bootstrap's :func:`resample_weights`, :func:`resampled_values` and
:func:`percentile_interval` remain for ``method="bootstrap"``.

**Claims with margins.** :func:`better`, :func:`not_worse` and :func:`equivalent` turn an
interval of a ratio (lower is better, as for an MSE) into the three kinds of claim the tests and
reports make: superiority (``hi < 1``), non-inferiority within ``1 + margin`` and equivalence
within ``1 -+ margin``. A claim is only as good as its margin: state it and why next to the call.

**Determinism.** Every sum over frames, seed sets and resamples runs in a fixed order
(:func:`bnerr.reduce.fixed_sum`): the same inputs give the same bits whatever torch's thread count.

Not for: hypothesis tests other than these interval checks, or data with fewer than two
independent replicates where an honest interval is wanted.
"""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from bnerr.errors import (
    ShapeError,
    ValueRangeError,
    check_finite,
    check_name,
    check_positive_int,
    check_range,
    check_tensor,
)
from bnerr.reduce import fixed_sum

__all__ = [
    "METHODS",
    "Estimate",
    "PerFrameValues",
    "as_stats",
    "better",
    "bootstrap_interval",
    "check_bootstrap",
    "equivalent",
    "exp_bound",
    "not_worse",
    "paired_differences",
    "paired_ratio",
    "paired_ratios",
    "percentile_interval",
    "pooled_intervals",
    "pooled_mean",
    "relevel_difference",
    "relevel_ratio",
    "replicates",
    "resample_weights",
    "resampled_values",
    "set_means",
    "t_interval",
    "t_quantile",
]

#: The interval methods of :func:`bootstrap_interval` and :func:`paired_ratio`: ``"t"`` (the
#: default, a t-interval over seed sets) and ``"bootstrap"`` (the former two-stage percentile
#: bootstrap, which undercovers at 4 seed sets; kept for comparison and for old results).
METHODS = ("t", "bootstrap")

#: The largest log a float64 holds the exp of (709.78...).
_LOG_MAX = math.log(sys.float_info.max)

#: What :func:`as_stats` reads: per-frame values ``[F]``, ``[S, F]`` or pairs ``[S, F, 2]``, as a
#: tensor, a NumPy array or nested sequences (a record's ``MetricPairs`` entry).
PerFrameValues = (
    torch.Tensor
    | np.ndarray
    | Sequence[float]
    | Sequence[Sequence[float]]
    | Sequence[Sequence[Sequence[float]]]
)


def pooled_mean(stats: torch.Tensor) -> torch.Tensor:
    """``sum(numerator) / sum(denominator)`` over the leading axes of ``stats [..., 2]``: a 0-dim
    tensor of ``stats``' dtype and device (the compute half of every metric)."""
    total = fixed_sum(stats.reshape(-1, 2), dim=0)
    return total[0] / total[1]


def set_means(stats: torch.Tensor) -> torch.Tensor:
    """Each seed set's pooled mean over its frames: ``stats [..., S, F, 2]`` -> ``[..., S]``."""
    total = fixed_sum(stats, dim=-2)  # [..., S, 2]
    return total[..., 0] / total[..., 1]


@dataclass(frozen=True)
class Estimate:
    """A point estimate with its interval.

    Attributes:
        value: the estimate on all the data (the pooled mean, or the ratio of two pooled means).
        lo, hi: the interval at ``level`` (by default the t-interval over seed sets of
            :func:`paired_ratio` and :func:`bootstrap_interval`).
        n: number of frames it rests on (seed sets x frames).
        level: confidence level of ``(lo, hi)``.
    """

    value: float
    lo: float
    hi: float
    n: int
    level: float = 0.95

    def __str__(self) -> str:
        return f"{self.value:.4g} [{self.lo:.4g}, {self.hi:.4g}]"


def as_stats(values: object, name: str) -> torch.Tensor:
    """Per-frame values ``[F]``, ``[S, F]`` or pairs ``[S, F, 2]`` -> pairs ``[S, F, 2]``, float64.

    Plain values ``v`` become the pairs ``(v, 1)``, so that their pooled mean is the plain mean;
    ``[F]`` is one seed set (``S = 1``). ``values`` may be a tensor (on any device: the result is
    on the CPU), an array or nested lists.

    Raises:
        ShapeError: another shape, or no frame (the message names ``name``).
        NonFiniteError: a NaN or infinite value.
    """
    if isinstance(values, torch.Tensor):
        x = check_tensor(values, name).detach().to("cpu", torch.float64)
    else:  # lists and arrays straight to float64: through torch's default float32 they lose digits
        x = torch.as_tensor(values, dtype=torch.float64)
    if x.ndim == 1:
        x = x[None]
    if x.ndim == 2:
        x = torch.stack([x, torch.ones_like(x)], dim=-1)
    if x.ndim != 3 or x.shape[-1] != 2 or x.numel() == 0:
        raise ShapeError(
            f"{name}: expected per-frame values [F] or [S, F] (or pairs [S, F, 2]), "
            f"got shape {list(x.shape)}"
        )
    check_finite(x, name)
    return x


def resample_weights(shape: tuple[int, int], resamples: int, seed: int) -> torch.Tensor:
    """Two-stage bootstrap weights: how often each of the ``S * F`` frames is drawn, ``[R, S * F]``.

    Stage 1 draws S seed sets with replacement, stage 2 draws F frames with replacement inside each
    drawn set. With S = 1 this is the ordinary bootstrap over frames. Counts (float64) instead of
    indices, so that a resample's sums are one weighted sum (:func:`resampled_values`), which is
    several times faster than gathering ``[R, N, 2]`` for the small N of a benchmark cell.

    Pass the same weights to :func:`resampled_values` for every quantity of one comparison (a
    strategy and its baseline): each resample then draws the same frames for all of them, which is
    what makes a comparison paired. ``shape`` is ``(S, F)``; ``seed`` seeds the
    ``torch.Generator`` (the same arguments give the same weights).
    """
    s, f = shape
    gen = torch.Generator().manual_seed(seed)
    sets = torch.randint(s, (resamples, s, 1), generator=gen)
    frames = torch.randint(f, (resamples, s, f), generator=gen)
    index = (sets * f + frames).reshape(resamples, s * f)
    weights = torch.zeros(resamples, s * f, dtype=torch.float64)
    return weights.scatter_add_(1, index, torch.ones_like(weights))


def resampled_values(stats: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    """``sum(num) / sum(den)`` per resample: ``stats [S, F, 2]``, ``weights [R, N]`` -> ``[R]``."""
    # A fixed-order sum over frames instead of a matrix product, whose BLAS kernel's order of
    # additions may depend on the thread count.
    total = fixed_sum(weights[:, :, None] * stats.reshape(1, -1, 2), dim=1)  # [R, 2]
    return total[:, 0] / total[:, 1]


def percentile_interval(samples: torch.Tensor, level: float) -> tuple[float, float]:
    """The percentile interval ``(lo, hi)`` at ``level`` of bootstrap ``samples [R]`` float64:
    their ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles (torch's linear interpolation)."""
    alpha = (1.0 - level) / 2.0
    lo, hi = torch.quantile(samples, torch.tensor([alpha, 1.0 - alpha], dtype=torch.float64))
    return float(lo), float(hi)


def check_bootstrap(level: float, resamples: int) -> None:
    """Check a bootstrap's settings: ``level`` in [0.5, 0.999], ``resamples`` an int >= 100.

    Raises:
        ValueRangeError: either one out of range; DtypeError: not a number, not an int.
    """
    check_range(level, "level", 0.5, 0.999)
    check_positive_int(resamples, "resamples", minimum=100)


@functools.lru_cache(maxsize=1024)
def t_quantile(level: float, df: int) -> float:
    """The two-sided Student t quantile of ``level`` with ``df`` degrees of freedom: the ``(1 +
    level) / 2`` quantile (scipy's ``stdtrit``), e.g. 3.182 for 0.95 and df = 3. Cached: a report
    asks for the same few (level, df) pairs about 90,000 times."""
    from scipy.special import stdtrit  # 0.4 s of import that `bnerr --help` need not pay

    return float(stdtrit(df, (1.0 + level) / 2.0))


def t_interval(
    samples: torch.Tensor, centre: torch.Tensor, level: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """Student t-interval ``centre -+ t * sd / sqrt(N)`` from N independent replicates.

    Args:
        samples: ``[..., N]`` float64, N >= 2 independent, identically distributed replicates
            (one per seed set); the batch axes let the coverage study run many trials at once.
        centre: ``[...]``, the estimate the interval is centred on (the estimate from all the
            data, which for equal weights is the replicates' mean).
        level: confidence level; the quantile has N - 1 degrees of freedom.

    Returns:
        ``(lo, hi)``, each ``[...]``.
    """
    n = samples.shape[-1]
    mean = fixed_sum(samples, dim=-1) / n
    var = fixed_sum((samples - mean[..., None]) ** 2, dim=-1) / (n - 1)
    half = t_quantile(level, n - 1) * torch.sqrt(var / n)
    return centre - half, centre + half


def _weighed_frames(*stats: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """With one seed set, ``stats`` ``[1, F, 2]`` left with the frames that weigh something in
    every one of them (a ``(0, 0)`` frame measured nothing: the first frame of a temporal metric,
    a region without pixels), unless none does; with more seed sets, as given."""
    if stats[0].shape[0] != 1:
        return stats
    keep = stats[0][0, :, 1] > 0
    for other in stats[1:]:
        keep = keep & (other[0, :, 1] > 0)
    return tuple(x[:, keep] for x in stats) if bool(keep.any()) else stats


def replicates(stats: torch.Tensor) -> torch.Tensor:
    """The independent replicates an interval rests on: ``stats [S, F, 2]`` -> ``[N]``.

    Each seed set's pooled mean (N = S) when there are S >= 2 seed sets; with one seed set, each
    frame's value (N = F, the frames that weigh nothing left out): frames of one run are the only
    replicates left, and they are correlated in a temporal run, so an interval over them is a
    within-run interval (module docstring).
    """
    if stats.shape[0] == 1:
        stats = _weighed_frames(stats)[0].reshape(-1, 1, 2)
    return set_means(stats)


def _check_method(level: float, resamples: int, method: str) -> None:
    check_bootstrap(level, resamples)
    check_name(method, METHODS, "interval method")


def bootstrap_interval(
    values: PerFrameValues,
    level: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
    *,
    method: str = "t",
) -> Estimate:
    """Pooled mean of per-frame values with its interval (the name is historical).

    Args:
        values: per-frame values ``[F]``, or ``[S, F]`` for S independent seed sets of F frames
            each, or ``[S, F, 2]`` pairs ``(numerator, denominator)`` from the metric updates,
            whose mean is the ratio of sums.
        level: confidence level in [0.5, 0.999].
        resamples, seed: the bootstrap's resamples (>= 100) and generator seed; checked, and used
            only by ``method="bootstrap"``.
        method: ``"t"`` (default): a t-interval with S - 1 degrees of freedom over the seed sets'
            pooled means, centred on the pooled mean (over frames when S = 1, see the module
            docstring; infinite with a single value). ``"bootstrap"``: the two-stage percentile
            bootstrap (seed sets, then frames inside them), which undercovers at few seed sets.

    Returns:
        :class:`Estimate`.
    """
    _check_method(level, resamples, method)
    stats = as_stats(values, "values")
    value = pooled_mean(stats)
    n = stats.shape[0] * stats.shape[1]
    if method == "bootstrap":
        weights = resample_weights((stats.shape[0], stats.shape[1]), resamples, seed)
        lo, hi = percentile_interval(resampled_values(stats, weights), level)
        return Estimate(float(value), lo, hi, n, level)
    reps = replicates(stats)
    if reps.numel() == 1:
        return Estimate(float(value), -math.inf, math.inf, n, level)
    t_lo, t_hi = t_interval(reps, value, level)
    return Estimate(float(value), float(t_lo), float(t_hi), n, level)


def paired_ratio(
    values: PerFrameValues,
    baseline: PerFrameValues,
    level: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
    *,
    method: str = "t",
) -> Estimate:
    """Ratio ``mean(values) / mean(baseline)`` with a paired interval.

    Frame i of ``values`` and frame i of ``baseline`` show the same scene frame, rendered by two
    strategies with seed set s; the comparison is paired by seed set (docs/METHODS.md: "pairwise
    on the same scene and frames"). With the default ``method="t"`` each seed set gives one log
    ratio ``log(mean_s(values) / mean_s(baseline))`` of its pooled means, and the interval is
    ``value * exp(-+ t * sd / sqrt(S))`` with S - 1 degrees of freedom, centred on the ratio of
    the pooled means over all the data (with one seed set: over the frames' log ratios, a
    within-run interval; with a single frame: ``(0, inf)``). Its coverage at the suites'
    settings is measured in :mod:`bnerr.metrics.coverage`. A ratio whose interval lies above 1 is
    worse than the baseline beyond its statistical error (:func:`better`, :func:`not_worse`,
    :func:`equivalent`).

    Args:
        values, baseline: per-frame values of the same shape, ``[F]``, ``[S, F]`` or ``[S, F, 2]``
            as in :func:`bootstrap_interval`; every seed set's (or with S = 1 every frame's) mean
            must be positive, since the interval is built on log ratios.
        level, resamples, seed, method: as in :func:`bootstrap_interval` (the bootstrap draws the
            same frames for both, which is what pairs it).

    Raises:
        ShapeError: the two shapes differ.
        ValueRangeError: with ``method="t"``, a mean that is not positive.
    """
    _check_method(level, resamples, method)
    a = as_stats(values, "values")
    b = as_stats(baseline, "baseline")
    if a.shape != b.shape:
        raise ShapeError(
            f"values: expected the shape of baseline {list(b.shape)} (the same frames), "
            f"got {list(a.shape)}"
        )
    value = pooled_mean(a) / pooled_mean(b)
    n = a.shape[0] * a.shape[1]
    if method == "bootstrap":
        weights = resample_weights((a.shape[0], a.shape[1]), resamples, seed)
        samples = resampled_values(a, weights) / resampled_values(b, weights)
        lo, hi = percentile_interval(samples, level)
        return Estimate(float(value), lo, hi, n, level)
    ra, rb = (replicates(x) for x in _weighed_frames(a, b))
    for reps, name in ((ra, "values"), (rb, "baseline")):
        if not bool((reps > 0).all()):
            raise ValueRangeError(
                f"{name}: expected positive means per seed set (the interval is built on log "
                f"ratios), got {[round(float(x), 6) for x in reps]}"
            )
    if ra.numel() == 1:
        return Estimate(float(value), 0.0, math.inf, n, level)
    log_lo, log_hi = t_interval(torch.log(ra / rb), torch.log(value), level)
    return Estimate(float(value), exp_bound(float(log_lo)), exp_bound(float(log_hi)), n, level)


def exp_bound(log_bound: float) -> float:
    """``exp(log_bound)``, a ratio's interval bound from its log: ``inf`` past float64's range
    (a log above 709.78, which ``math.exp`` refuses with an OverflowError; far below, exp is 0), so
    that a ratio whose interval spans more than float64 holds reads as unbounded on that side
    (one huge pixel, a firefly of 1e24, makes one seed set's mean dwarf another's)."""
    if log_bound > _LOG_MAX:
        return math.inf
    return math.exp(log_bound)


def _batch(values: torch.Tensor | np.ndarray, name: str) -> torch.Tensor:
    """A batch of pairs ``[B, S, F, 2]`` with S >= 2 seed sets, float64 on the CPU.

    Raises:
        ShapeError: another shape; NonFiniteError: a NaN or infinite value.
    """
    x = torch.as_tensor(values, dtype=torch.float64, device="cpu")
    if x.ndim != 4 or x.shape[-1] != 2 or x.shape[1] < 2 or x.shape[2] < 1:
        raise ShapeError(
            f"{name}: expected a batch of pairs [B, S, F, 2] with S >= 2 seed sets, "
            f"got shape {list(x.shape)}"
        )
    check_finite(x, name)
    return x


def _pooled(stats: torch.Tensor) -> torch.Tensor:
    """:func:`pooled_mean` of each of a batch ``[B, S, F, 2]`` -> ``[B]`` (the same tree of
    additions along the frames, element by element across the batch: the same bits)."""
    total = fixed_sum(stats.reshape(stats.shape[0], -1, 2), dim=1)
    return total[:, 0] / total[:, 1]


def pooled_intervals(values: torch.Tensor | np.ndarray, level: float = 0.95) -> list[Estimate]:
    """:func:`bootstrap_interval` (``method="t"``) of each of a batch of cells, in one pass:
    ``values [B, S, F, 2]`` with S >= 2 seed sets; bit for bit the Estimates that B calls give
    (every sum is :func:`bnerr.reduce.fixed_sum` along one axis, element by element across the
    batch). A report summarizes thousands of cells: one call instead of B saves torch's
    per-call cost, 25 s of the quality suite's table.

    Raises:
        ShapeError, NonFiniteError: see :func:`_batch`; ValueRangeError: ``level``.
    """
    check_bootstrap(level, 100)
    stats = _batch(values, "values")
    value = _pooled(stats)
    lo, hi = t_interval(set_means(stats), value, level)
    n = stats.shape[1] * stats.shape[2]
    return [
        Estimate(v, a, b, n, level)
        for v, a, b in zip(value.tolist(), lo.tolist(), hi.tolist(), strict=True)
    ]


def paired_ratios(
    values: torch.Tensor | np.ndarray, baseline: torch.Tensor | np.ndarray, level: float = 0.95
) -> list[Estimate]:
    """:func:`paired_ratio` (``method="t"``) of each of a batch of cells against its baseline,
    in one pass: ``values`` and ``baseline [B, S, F, 2]`` with S >= 2 seed sets; bit for bit the
    Estimates that B calls give (see :func:`pooled_intervals`).

    Raises:
        ShapeError: the shapes differ, or not a batch (:func:`_batch`); NonFiniteError;
        ValueRangeError: a seed set's mean that is not positive (the interval is built on log
            ratios), or ``level``.
    """
    check_bootstrap(level, 100)
    a, b = _batch(values, "values"), _batch(baseline, "baseline")
    if a.shape != b.shape:
        raise ShapeError(
            f"values: expected the shape of baseline {list(b.shape)} (the same frames), "
            f"got {list(a.shape)}"
        )
    value = _pooled(a) / _pooled(b)
    ra, rb = set_means(a), set_means(b)
    for reps, name in ((ra, "values"), (rb, "baseline")):
        if not bool((reps > 0).all()):
            raise ValueRangeError(
                f"{name}: expected positive means per seed set in every cell (the interval is "
                f"built on log ratios), got {int((reps <= 0).sum())} that are not"
            )
    log_lo, log_hi = t_interval(torch.log(ra / rb), torch.log(value), level)
    n = a.shape[1] * a.shape[2]
    return [
        Estimate(v, exp_bound(lo), exp_bound(hi), n, level)
        for v, lo, hi in zip(value.tolist(), log_lo.tolist(), log_hi.tolist(), strict=True)
    ]


def paired_differences(
    values: torch.Tensor | np.ndarray, baseline: torch.Tensor | np.ndarray, level: float = 0.95
) -> list[Estimate]:
    """The paired difference ``mean(values) - mean(baseline)`` of each of a batch of cells, with
    its t-interval over seed sets: for a score on an interval scale, where a ratio means nothing
    (ColorVideoVDP's JOD, :mod:`bnerr.metrics.cvvdp`). Each seed set gives one difference of its
    pooled means; the interval is ``d -+ t * sd / sqrt(S)`` with S - 1 degrees of freedom,
    centred on the difference of the pooled means over all the data. ``values`` and ``baseline``
    ``[B, S, F, 2]``; with one seed set (S = 1) the interval is unbounded, ``(-inf, inf)``.

    Raises:
        ShapeError: the shapes differ, or not pairs ``[B, S, F, 2]``; NonFiniteError.
    """
    check_bootstrap(level, 100)
    a = torch.as_tensor(values, dtype=torch.float64, device="cpu")
    b = torch.as_tensor(baseline, dtype=torch.float64, device="cpu")
    if a.shape != b.shape or a.ndim != 4 or a.shape[-1] != 2 or 0 in a.shape:
        raise ShapeError(
            f"values: expected pairs [B, S, F, 2] of the shape of baseline {list(b.shape)}, "
            f"got {list(a.shape)}"
        )
    check_finite(a, "values")
    check_finite(b, "baseline")
    value = _pooled(a) - _pooled(b)
    n = a.shape[1] * a.shape[2]
    if a.shape[1] < 2:
        return [Estimate(v, -math.inf, math.inf, n, level) for v in value.tolist()]
    lo, hi = t_interval(set_means(a) - set_means(b), value, level)
    return [
        Estimate(v, low, high, n, level)
        for v, low, high in zip(value.tolist(), lo.tolist(), hi.tolist(), strict=True)
    ]


def relevel_difference(estimate: Estimate, level: float, df: int) -> Estimate:
    """The same t-interval of a difference (:func:`paired_differences`, symmetric around
    ``value``) at another confidence ``level``: ``value -+ t(level) * se`` with the standard
    error read back from the interval at ``estimate.level`` (as :func:`relevel_ratio` for a
    ratio). An unbounded interval stays unbounded."""
    check_range(level, "level", 0.5, 1.0 - 1e-9)
    check_positive_int(df, "df")
    if not (-math.inf < estimate.lo <= estimate.value <= estimate.hi < math.inf):
        return Estimate(estimate.value, -math.inf, math.inf, estimate.n, level)
    se = (estimate.hi - estimate.value) / t_quantile(estimate.level, df)
    half = se * t_quantile(level, df)
    return Estimate(estimate.value, estimate.value - half, estimate.value + half, estimate.n, level)


def relevel_ratio(estimate: Estimate, level: float, df: int) -> Estimate:
    """The same t-interval of a ratio (:func:`paired_ratio`, symmetric in log space around
    ``log(value)``) at another confidence ``level``: ``value * exp(-+ t(level) * se)`` with the
    standard error ``se`` read back from the interval at ``estimate.level``.

    The decision table uses it to correct for choosing the best of m strategies (Bonferroni:
    ``level = 1 - (1 - estimate.level) / m``). ``df`` is the interval's degrees of freedom (seed
    sets - 1, or frames - 1 with one seed set). An unbounded interval stays unbounded.
    """
    check_range(level, "level", 0.5, 1.0 - 1e-9)
    check_positive_int(df, "df")
    if not (0.0 < estimate.lo <= estimate.value <= estimate.hi < math.inf):
        return Estimate(estimate.value, 0.0, math.inf, estimate.n, level)
    se = math.log(estimate.hi / estimate.value) / t_quantile(estimate.level, df)
    half = se * t_quantile(level, df)
    return Estimate(
        estimate.value,
        estimate.value * exp_bound(-half),
        estimate.value * exp_bound(half),
        estimate.n,
        level,
    )


# -- claims with margins ---------------------------------------------------------------------------


def _check_claim(estimate: Estimate, margin: float) -> None:
    if not isinstance(estimate, Estimate):
        raise TypeError(f"estimate: expected an Estimate, got {type(estimate).__name__}")
    check_range(margin, "margin", 0.0, 1.0)


def better(estimate: Estimate) -> bool:
    """Superiority of a ratio where lower is better (an MSE ratio): its whole interval lies below
    1, ``hi < 1``."""
    _check_claim(estimate, 0.0)
    return estimate.hi < 1.0


def not_worse(estimate: Estimate, margin: float) -> bool:
    """Non-inferiority within ``margin``: ``hi <= 1 + margin``, the ratio is at most ``margin``
    worse than the baseline at the interval's level. ``margin`` in [0, 1]; state why it is the
    right one (the effect that would matter, the data's power) next to the call."""
    _check_claim(estimate, margin)
    return estimate.hi <= 1.0 + margin


def equivalent(estimate: Estimate, margin: float) -> bool:
    """Equivalence within ``margin``: ``1 - margin <= lo and hi <= 1 + margin``.

    The two one-sided tests of Schuirmann (1987) at the interval's one-sided level: the whole
    interval inside the margin, so a wide interval fails instead of passing (the opposite of
    "the interval contains 1").
    """
    _check_claim(estimate, margin)
    return 1.0 - margin <= estimate.lo and estimate.hi <= 1.0 + margin
