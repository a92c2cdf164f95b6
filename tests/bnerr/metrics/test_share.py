"""bnerr.metrics.share: the gap share's linearized interval, its unresolved cases, and the level of
a verdict on the best of m (the coverage is simulated in test_coverage.py)."""

from __future__ import annotations

import math

import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.metrics import best_level, relevel_share, share_interval, t_quantile


def _t(*values: float) -> torch.Tensor:
    return torch.tensor(values, dtype=torch.float64)


def test_the_interval_is_the_t_interval_of_the_linearized_replicates():
    w, v, o = _t(1.0, 1.2, 0.9), _t(0.8, 0.9, 0.75), _t(0.5, 0.6, 0.4)
    pooled = (w.mean(), v.mean(), o.mean())
    share, lo, hi = share_interval((w, v, o), pooled, 0.95)
    expected = (pooled[0] - pooled[1]) / (pooled[0] - pooled[2])
    assert float(share) == pytest.approx(float(expected), rel=1e-12)
    z = expected + ((w - v) - expected * (w - o)) / (pooled[0] - pooled[2])
    half = t_quantile(0.95, 2) * float(z.std()) / math.sqrt(3)
    assert (float(lo), float(hi)) == pytest.approx((float(share) - half, float(share) + half))


def test_a_seed_set_without_a_gap_is_unresolved_and_no_pooled_gap_has_no_share():
    w, v, o = _t(1.0, 0.5), _t(0.8, 0.5), _t(0.5, 0.6)  # seed set 1: the oracle above white
    pooled = (w.mean(), v.mean(), o.mean())
    share, lo, hi = share_interval((w, v, o), pooled, 0.95)
    assert math.isfinite(float(share)) and (float(lo), float(hi)) == (-math.inf, math.inf)
    flat = (_t(1.0, 1.0), _t(0.9, 0.9), _t(1.0, 1.0))
    assert all(
        math.isnan(float(x)) for x in share_interval(flat, (_t(1.0), _t(0.9), _t(1.0)), 0.95)
    )
    with pytest.raises(ValueRangeError, match="level"):
        share_interval((w, v, o), pooled, 1.5)


def test_the_best_of_m_is_read_at_the_bonferroni_level():
    assert best_level(0.95, 1) == 0.95 and best_level(0.95, 4) == pytest.approx(0.9875)
    lo, hi = relevel_share(0.6, 0.52, 0.68, 0.95, 0.975, 4)
    scale = t_quantile(0.975, 3) / t_quantile(0.95, 3)
    assert (lo, hi) == pytest.approx((0.6 - 0.08 * scale, 0.6 + 0.08 * scale))
    assert relevel_share(0.5, -math.inf, math.inf, 0.95, 0.99, 4) == (-math.inf, math.inf)
    with pytest.raises(ValueRangeError, match="rivals"):
        best_level(0.95, 0)
    with pytest.raises(ValueRangeError, match="seed_sets"):
        relevel_share(0.6, 0.5, 0.7, 0.95, 0.99, 1)
