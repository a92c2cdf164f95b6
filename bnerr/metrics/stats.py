"""Statistics over frames: pooled means of ``(numerator, denominator)`` pairs, bootstrap intervals.

Every metric update (:mod:`bnerr.metrics.frames`) reduces one frame to a pair ``(numerator,
denominator)``; the pooled mean over frames is ``sum(numerators) / sum(denominators)``
(:func:`pooled_mean`).

**Intervals.** :func:`bootstrap_interval` and :func:`paired_ratio` give percentile-bootstrap 95%
intervals (Efron & Tibshirani 1993) over frames, two-stage when frames come in independent seed
sets (resample seed sets, then frames inside each), with a fixed ``torch.Generator`` seed so that
the same inputs give the same interval. Frames of one temporal run are not independent (the seed
image carries over), so the frame-level bootstrap is a within-run estimate; independent seed sets
are the unit that makes it honest, and the suites use them where the budget allows.

**Building blocks.** A statistic that is neither a mean nor a ratio of two means (the share of a
gap, :mod:`benchmarks.reports.gap`) is built from the same pieces, so that its interval
resamples the frames exactly as the others do: :func:`as_stats` (values to ``[S, F, 2]`` pairs),
:func:`resample_weights` (the two-stage draws, shared by every quantity of one comparison),
:func:`resampled_values` (a pooled mean per resample), :func:`percentile_interval` and
:func:`check_bootstrap` (the arguments' checks).

**Determinism.** Every sum over frames and resamples runs in a fixed order
(:func:`bnerr.reduce.fixed_sum`): the same inputs give the same bits whatever torch's thread count.

Not for: hypothesis tests or intervals other than the percentile bootstrap.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch

from bnerr.errors import (
    ShapeError,
    check_finite,
    check_positive_int,
    check_range,
    check_tensor,
)
from bnerr.reduce import fixed_sum

__all__ = [
    "Estimate",
    "as_stats",
    "bootstrap_interval",
    "check_bootstrap",
    "paired_ratio",
    "percentile_interval",
    "pooled_mean",
    "resample_weights",
    "resampled_values",
]


def pooled_mean(stats: torch.Tensor) -> torch.Tensor:
    """``sum(numerator) / sum(denominator)`` over the leading axes of ``stats [..., 2]``: a 0-dim
    tensor of ``stats``' dtype and device (the compute half of every metric)."""
    total = fixed_sum(stats.reshape(-1, 2), dim=0)
    return total[0] / total[1]


@dataclass(frozen=True)
class Estimate:
    """A point estimate with its bootstrap interval.

    Attributes:
        value: the estimate on all the data (not the mean of the resamples).
        lo, hi: the percentile-bootstrap interval at ``level``.
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
    x = torch.as_tensor(check_tensor(values, name) if isinstance(values, torch.Tensor) else values)
    x = x.detach().to("cpu", torch.float64)
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


def bootstrap_interval(
    values: torch.Tensor | Sequence[float],
    level: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
) -> Estimate:
    """Mean of per-frame values with a percentile-bootstrap interval.

    Args:
        values: per-frame values ``[F]``, or ``[S, F]`` for S independent seed sets of F frames
            each (two-stage bootstrap: seed sets, then frames), or ``[S, F, 2]`` pairs
            ``(numerator, denominator)`` from the metric updates, whose mean is the ratio of sums.
        level: confidence level in [0.5, 0.999].
        resamples: bootstrap resamples (>= 100).
        seed: seed of the ``torch.Generator`` that draws the resamples; fixed, so the same values
            always give the same interval.

    Returns:
        :class:`Estimate`; with a single frame the interval collapses to the value.
    """
    check_bootstrap(level, resamples)
    stats = as_stats(values, "values")
    samples = resampled_values(
        stats, resample_weights((stats.shape[0], stats.shape[1]), resamples, seed)
    )
    lo, hi = percentile_interval(samples, level)
    return Estimate(float(pooled_mean(stats)), lo, hi, stats.shape[0] * stats.shape[1], level)


def paired_ratio(
    values: torch.Tensor | Sequence[float],
    baseline: torch.Tensor | Sequence[float],
    level: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
) -> Estimate:
    """Ratio ``mean(values) / mean(baseline)`` with a paired bootstrap interval.

    Frame i of ``values`` and frame i of ``baseline`` show the same scene frame (the same
    reference), rendered by two strategies; resampling the same frame indices for both removes the
    frame-to-frame variation of the content from the interval (the comparison docs/METHODS.md asks
    for: "pairwise on the same scene and frames"). A ratio whose interval lies above 1 is worse
    than the baseline beyond its statistical error.

    Args:
        values, baseline: per-frame values of the same shape, ``[F]``, ``[S, F]`` or ``[S, F, 2]``
            as in :func:`bootstrap_interval`.
        level, resamples, seed: as in :func:`bootstrap_interval`.
    """
    check_bootstrap(level, resamples)
    a = as_stats(values, "values")
    b = as_stats(baseline, "baseline")
    if a.shape != b.shape:
        raise ShapeError(
            f"values: expected the shape of baseline {list(b.shape)} (the same frames), "
            f"got {list(a.shape)}"
        )
    weights = resample_weights((a.shape[0], a.shape[1]), resamples, seed)
    samples = resampled_values(a, weights) / resampled_values(b, weights)
    lo, hi = percentile_interval(samples, level)
    return Estimate(float(pooled_mean(a) / pooled_mean(b)), lo, hi, a.shape[0] * a.shape[1], level)
