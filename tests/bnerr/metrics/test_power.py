"""Tests for bnerr.metrics.power: the chance that the t-interval resolves a ratio, against a
simulation of paired_ratio itself, and the seed-set count it implies."""

import math

import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.metrics import paired_ratio
from bnerr.metrics.power import (
    resolve_power,
    seed_set_spread,
    seed_sets_needed,
    seed_sets_to_settle,
)


@pytest.mark.parametrize(("effect", "sd", "seed_sets"), [(0.05, 0.04, 4), (0.05, 0.04, 8)])
def test_the_power_is_the_share_of_simulated_cells_paired_ratio_resolves(effect, sd, seed_sets):
    # Seed-set log ratios scattered by sd around log(1 - effect), three equal frames each: the
    # share of cells whose paired_ratio interval lies below 1, within 4 binomial standard errors.
    trials = 1500
    gen = torch.Generator().manual_seed(seed_sets)
    hits = 0
    for _ in range(trials):
        noise = sd * torch.randn(seed_sets, generator=gen, dtype=torch.float64)
        baseline = torch.ones(seed_sets, 3, dtype=torch.float64)
        values = baseline * (math.log1p(-effect) + noise).exp()[:, None]
        hits += paired_ratio(values, baseline).hi < 1.0
    want = resolve_power(effect, sd, seed_sets)
    assert abs(hits / trials - want) <= 4 * math.sqrt(want * (1 - want) / trials)


def test_more_seed_sets_are_needed_for_smaller_effects_and_wider_spreads():
    assert resolve_power(0.05, 0.04, 8) > resolve_power(0.05, 0.04, 4)
    assert seed_sets_needed(0.10, 0.04) == 4  # the committed suites' median spread
    assert seed_sets_needed(0.05, 0.04) == 7
    assert seed_sets_needed(0.05, 0.08) > seed_sets_needed(0.10, 0.08) > 4
    assert resolve_power(0.05, 0.04, seed_sets_needed(0.05, 0.04)) >= 0.8
    assert resolve_power(0.05, 0.04, seed_sets_needed(0.05, 0.04) - 1) < 0.8
    assert seed_sets_needed(0.01, 1.0, most=16) is None


def test_the_spread_is_the_sd_of_the_seed_sets_log_ratios():
    baseline = torch.ones(4, 3, dtype=torch.float64)
    ratios = torch.tensor([0.9, 1.0, 0.95, 1.05], dtype=torch.float64)
    want = float(torch.log(ratios).std())
    assert seed_set_spread(baseline * ratios[:, None], baseline) == pytest.approx(want, rel=1e-12)
    with pytest.raises(ValueRangeError, match="S >= 2 seed sets"):
        seed_set_spread(torch.ones(1, 3), torch.ones(1, 3))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"effect": 0.0}, "effect: expected a relative reduction in"),
        ({"effect": 1.0}, "effect: expected a relative reduction in"),
        ({"sd": 0.0}, "sd: expected a positive, finite spread"),
        ({"sd": math.inf}, "sd: expected a positive, finite spread"),
        ({"level": 1.0}, "level: expected a confidence level"),
    ],
)
def test_bad_arguments_are_refused(kwargs, message):
    args = {"effect": 0.05, "sd": 0.04, "seed_sets": 4, **kwargs}
    with pytest.raises(ValueRangeError, match=message):
        resolve_power(**args)


@pytest.mark.parametrize(("sd", "level"), [(0.02, 0.95), (0.21, 0.95), (0.5, 1 - 0.05 / 4)])
def test_the_seed_sets_to_settle_give_an_interval_that_settles_wherever_it_is_centred(sd, level):
    from bnerr.metrics import Estimate, t_quantile
    from bnerr.metrics.sequential import settle

    n = seed_sets_to_settle(sd, 0.05, level)
    assert n is not None

    def half(s):
        return t_quantile(level, s - 1) * sd / math.sqrt(s)

    assert half(n) <= math.log1p(0.05) / 2 < half(n - 1)  # the fewest
    for centre in torch.linspace(-0.2, 0.2, 401).tolist():
        h = half(n)
        est = Estimate(math.exp(centre), math.exp(centre - h), math.exp(centre + h), n)
        assert settle(est, 0.05) != "open", centre


def test_a_spread_no_count_settles_says_none_and_bad_input_is_refused():
    assert seed_sets_to_settle(5.0, most=1000) is None
    assert seed_sets_to_settle(0.5) > seed_sets_to_settle(0.2) > seed_sets_to_settle(0.05)
    for bad in (
        {"sd": 0.0},
        {"sd": math.inf},
        {"sd": 0.1, "margin": 0.0},
        {"sd": 0.1, "level": 1.0},
    ):
        with pytest.raises(ValueRangeError):
            seed_sets_to_settle(**bad)
