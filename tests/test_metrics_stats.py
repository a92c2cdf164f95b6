"""Tests of bnerr.metrics.stats: pooled means, bootstrap intervals and their building blocks."""

import math

import numpy as np
import pytest
import torch

from bnerr.errors import DtypeError, NonFiniteError, ShapeError, ValueRangeError
from bnerr.metrics import (
    Estimate,
    as_stats,
    bootstrap_interval,
    check_bootstrap,
    paired_ratio,
    percentile_interval,
    pooled_mean,
    resample_weights,
    resampled_values,
)


def test_bootstrap_is_deterministic_and_brackets_the_mean():
    values = torch.tensor([1.0, 2.0, 4.0, 3.0, 5.0, 2.5, 3.5])
    a = bootstrap_interval(values, seed=3)
    assert a == bootstrap_interval(values, seed=3)
    assert a.value == pytest.approx(values.double().mean().item())
    assert a.lo < a.value < a.hi
    assert bootstrap_interval(torch.full((9,), 2.0)) == Estimate(2.0, 2.0, 2.0, 9)


def test_bootstrap_interval_covers_the_true_mean_at_its_level():
    # 200 independent data sets of 30 normal values: the count of intervals holding the true mean is
    # binomial; the percentile bootstrap must stay within 3 binomial standard deviations of 95%.
    gen = torch.Generator().manual_seed(1)
    data = 1.0 + torch.randn(200, 30, generator=gen, dtype=torch.float64)
    intervals = [bootstrap_interval(row, resamples=1000, seed=i) for i, row in enumerate(data)]
    hits = sum(e.lo <= 1.0 <= e.hi for e in intervals)
    band = 3 * math.sqrt(0.95 * 0.05 / 200)
    assert abs(hits / 200 - 0.95) <= band


def test_two_stage_bootstrap_is_wider_when_seed_sets_differ():
    # Seed sets with different means: the two-stage interval must see that spread, which a plain
    # bootstrap over the pooled frames understates.
    gen = torch.Generator().manual_seed(2)
    values = torch.tensor([[1.0], [3.0], [5.0]], dtype=torch.float64) + 0.1 * torch.randn(
        3, 8, generator=gen
    )
    grouped = bootstrap_interval(values)
    flat = bootstrap_interval(values.flatten())
    assert grouped.value == pytest.approx(flat.value)
    assert grouped.hi - grouped.lo > flat.hi - flat.lo


def test_paired_ratio_removes_the_shared_frame_variation():
    # Frames differ a lot in content; a strategy at exactly 0.6x white on every frame must get a
    # ratio of 0.6 with no width at all, because the pairing cancels the content.
    content = torch.tensor([0.1, 5.0, 0.7, 2.0, 9.0, 0.3], dtype=torch.float64)
    exact = paired_ratio(0.6 * content, content)
    assert (exact.value, exact.lo, exact.hi, exact.n) == (
        pytest.approx(0.6),
        pytest.approx(0.6),
        pytest.approx(0.6),
        6,
    )
    gen = torch.Generator().manual_seed(4)
    noisy = 0.6 * content * (1 + 0.05 * torch.randn(6, generator=gen, dtype=torch.float64))
    r = paired_ratio(noisy, content)
    assert r.lo < r.value < r.hi and r.hi < 1.0
    with pytest.raises(ShapeError, match=r"values: expected the shape of baseline \[1, 6, 2\]"):
        paired_ratio(content[:5], content)


def test_bootstrap_checks_its_arguments():
    with pytest.raises(ShapeError, match="values: expected per-frame values"):
        bootstrap_interval(torch.zeros(2, 2, 2, 2))
    with pytest.raises(ValueRangeError, match="level: expected a value in"):
        bootstrap_interval([1.0, 2.0], level=1.5)
    with pytest.raises(NonFiniteError, match="values: expected finite"):
        bootstrap_interval([1.0, math.nan])


# -- the building blocks ---------------------------------------------------------------------------


def test_pooled_mean_is_the_ratio_of_the_sums():
    gen = torch.Generator().manual_seed(5)
    stats = torch.rand(3, 4, 2, generator=gen, dtype=torch.float64) + 0.5
    want = stats[..., 0].sum() / stats[..., 1].sum()
    assert pooled_mean(stats).item() == pytest.approx(want.item(), rel=1e-15)
    assert pooled_mean(torch.tensor([6.0, 3.0], dtype=torch.float64)).item() == 2.0


def test_as_stats_turns_values_into_pairs_of_seed_sets_and_frames():
    one = as_stats([1.0, 2.0, 4.0], "v")
    assert one.shape == (1, 3, 2) and one.dtype == torch.float64
    assert one[0].tolist() == [[1.0, 1.0], [2.0, 1.0], [4.0, 1.0]]
    two = as_stats(torch.ones(2, 3, dtype=torch.float32), "v")
    assert two.shape == (2, 3, 2) and two.dtype == torch.float64
    pairs = np.arange(12, dtype=np.float64).reshape(2, 3, 2)
    assert as_stats(pairs, "v").numpy().tolist() == pairs.tolist()
    with pytest.raises(
        ShapeError, match=r"den mse: expected per-frame values .* got shape \[1, 0, 2\]"
    ):
        as_stats([], "den mse")
    with pytest.raises(ShapeError, match=r"got shape \[2, 3, 3\]"):
        as_stats(np.zeros((2, 3, 3)), "v")
    with pytest.raises(NonFiniteError, match="v: expected finite"):
        as_stats([1.0, math.inf], "v")


def test_resample_weights_draw_whole_seed_sets_then_frames_inside_them():
    weights = resample_weights((3, 4), 500, seed=7)
    assert weights.shape == (500, 12) and weights.dtype == torch.float64
    assert torch.equal(weights, resample_weights((3, 4), 500, seed=7))
    assert not torch.equal(weights, resample_weights((3, 4), 500, seed=8))
    assert bool((weights.sum(dim=1) == 12).all())  # S x F draws per resample
    per_set = weights.reshape(500, 3, 4).sum(dim=2)
    assert bool((per_set % 4 == 0).all())  # a drawn seed set brings F frame draws
    assert bool((per_set == 0).any())  # and a seed set can be left out of a resample
    assert bool((resample_weights((1, 5), 50, seed=0).sum(dim=1) == 5).all())


def test_resampled_values_are_the_weighted_pooled_means():
    stats = as_stats(torch.tensor([[1.0, 2.0], [3.0, 5.0]]), "v")
    weights = torch.tensor([[1.0, 1.0, 1.0, 1.0], [2.0, 0.0, 0.0, 2.0], [0.0, 0.0, 4.0, 0.0]])
    assert resampled_values(stats, weights).tolist() == [2.75, 3.0, 3.0]


def test_percentile_interval_takes_the_two_tail_quantiles():
    samples = torch.arange(101, dtype=torch.float64)
    assert percentile_interval(samples, 0.9) == pytest.approx((5.0, 95.0))
    assert percentile_interval(samples.flip(0), 0.5) == pytest.approx((25.0, 75.0))


def test_check_bootstrap_names_the_wrong_setting():
    check_bootstrap(0.95, 100)
    with pytest.raises(ValueRangeError, match=r"level: expected a value in \[0.5, 0.999\]"):
        check_bootstrap(0.4, 2000)
    with pytest.raises(ValueRangeError, match="resamples: expected an integer >= 100, got 99"):
        check_bootstrap(0.95, 99)
    with pytest.raises(DtypeError, match="resamples: expected an integer"):
        check_bootstrap(0.95, 100.0)


@pytest.mark.parametrize("seed", [0, 3])
def test_the_intervals_are_built_from_the_public_pieces_bit_for_bit(seed):
    # benchmarks/gap.py builds its share's interval from the same pieces: it must resample the
    # frames exactly as bootstrap_interval and paired_ratio do.
    gen = torch.Generator().manual_seed(seed)
    a = torch.rand(3, 4, generator=gen, dtype=torch.float64) + 0.1
    b = torch.rand(3, 4, generator=gen, dtype=torch.float64) + 0.1
    sa, sb = as_stats(a, "a"), as_stats(b, "b")
    weights = resample_weights((3, 4), 400, seed)
    lo, hi = percentile_interval(resampled_values(sa, weights), 0.9)
    want = Estimate(float(pooled_mean(sa)), lo, hi, 12, 0.9)
    assert bootstrap_interval(a, level=0.9, resamples=400, seed=seed) == want
    ratio = resampled_values(sa, weights) / resampled_values(sb, weights)
    lo, hi = percentile_interval(ratio, 0.9)
    want = Estimate(float(pooled_mean(sa) / pooled_mean(sb)), lo, hi, 12, 0.9)
    assert paired_ratio(a, b, level=0.9, resamples=400, seed=seed) == want
