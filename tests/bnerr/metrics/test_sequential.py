"""The adaptive procedure of bnerr.metrics.sequential: its looks, levels and verdicts, and its
coverage simulated through bnerr.metrics.coverage (the naive "add until significant" procedure
failing the same test)."""

from __future__ import annotations

import math
import re

import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.metrics import Estimate, paired_ratio
from bnerr.metrics.coverage import sequential_coverage
from bnerr.metrics.sequential import ALPHA, Design, looks, naive_design, run_sequential, settle

# Simulated cells per setting: 4000 put the binomial band at 3 standard errors (1.0 % at a miss
# rate of 5 %) and the whole file under a minute on one core.
TRIALS = 4000


def _stated_bias_bound() -> float:
    """The early-stopping bias bound docs/METHODS.md states ("the stated bound is N %")."""
    from tests._paths import ROOT

    text = " ".join((ROOT / "docs/METHODS.md").read_text().split())
    match = re.search(r"the stated bound is (\d+(?:\.\d+)?) %", text)
    assert match is not None, "docs/METHODS.md states no early-stopping bias bound"
    return float(match.group(1)) / 100


#: The early-stopping bias bound of docs/METHODS.md (2 %).
BIAS_BOUND = _stated_bias_bound()


def band(rate: float, trials: int = TRIALS) -> float:
    """The most a miss rate of ``rate`` may show in ``trials`` cells: 3 binomial standard errors
    above it (a false alarm once in 700 runs)."""
    return rate + 3 * math.sqrt(rate * (1 - rate) / trials)


def test_looks_double_or_add_a_batch_and_end_at_the_cap() -> None:
    assert looks(4, 32) == (4, 8, 16, 32)
    assert looks(4, 20) == (4, 8, 16, 20)
    assert looks(4, 16, batch=4) == (4, 8, 12, 16)
    assert looks(3, 3) == (3,)
    with pytest.raises(ValueRangeError, match="cap"):
        looks(4, 2)
    with pytest.raises(ValueRangeError, match="first"):
        looks(1, 8)


def test_equal_spending_sums_to_alpha_and_a_single_look_is_the_plain_interval() -> None:
    design = Design(looks(4, 32))
    assert design.spent == (ALPHA / 4,) * 4
    assert design.level(8) == pytest.approx(1 - 0.0125)
    assert design.level(8, rivals=6) == pytest.approx(1 - 0.0125 / 6)
    assert Design((4,)).level(4, rivals=6) == pytest.approx(1 - 0.05 / 6)  # the fixed design
    with pytest.raises(ValueRangeError, match="looks"):
        design.level(5)
    with pytest.raises(ValueRangeError, match="spent"):
        Design((4, 8), spent=(0.04, 0.04))
    with pytest.raises(ValueRangeError, match="looks"):
        Design((8, 4))


def test_settle_names_each_verdict() -> None:
    assert settle(Estimate(0.8, 0.7, 0.9, 4)) == "better"
    assert settle(Estimate(1.2, 1.1, 1.3, 4)) == "worse"
    assert settle(Estimate(1.0, 0.96, 1.04, 4)) == "equal"
    assert settle(Estimate(1.0, 0.9, 1.1, 4)) == "open"


def test_a_later_look_widens_the_interval_of_the_same_data() -> None:
    # The same 4 seed sets judged as the first of 4 looks spend 0.0125, not 0.05: wider.
    gen = torch.Generator().manual_seed(3)
    a = torch.exp(0.05 * torch.randn(4, 3, generator=gen, dtype=torch.float64))
    b = torch.exp(0.1 + 0.05 * torch.randn(4, 3, generator=gen, dtype=torch.float64))
    est = paired_ratio(a, b)
    wide = Design(looks(4, 32)).interval(est, 4)
    assert wide.lo < est.lo and wide.hi > est.hi and wide.value == est.value
    assert Design((4,)).interval(est, 4).hi == pytest.approx(est.hi)


def test_run_sequential_stops_at_the_first_settled_look() -> None:
    design = Design((2, 4))
    logs = torch.tensor([[-0.5, -0.51, -0.49, -0.5], [0.3, -0.3, 0.2, -0.2]], dtype=torch.float64)
    centres = torch.stack([logs[:, :2].mean(1), logs.mean(1)], dim=1)
    stop, centre, lo, hi = run_sequential(logs, centres, design)
    assert stop.tolist() == [0, 1]  # a clear effect at the first look; the other open at the cap
    assert hi[0] < 0 and lo[1] < 0 < hi[1]
    assert centre.tolist() == pytest.approx([-0.505, 0.0])


# Every effect of the issue with the seed-set effects of the committed suites (median spread of
# log ratios 0.04, 90th percentile 0.14) and a skewed one, at the levels in use (95 % and the
# decision table's 1 - 0.05/6 for 6 rivals), and first looks of 2, 3 and 4 seed sets.
SETTINGS = [
    (looks(4, 32), 0.0, 0.05, False, 1),
    (looks(4, 32), 0.0, 0.15, True, 1),
    (looks(4, 32), 0.05, 0.05, False, 1),
    (looks(4, 32), 0.10, 0.15, False, 6),
    (looks(2, 16), 0.02, 0.15, True, 1),
    (looks(3, 24), 0.0, 0.0, False, 6),
]


@pytest.mark.parametrize(("counts", "effect", "set_sd", "skewed", "rivals"), SETTINGS)
def test_the_adaptive_procedure_keeps_its_coverage(
    counts: tuple[int, ...], effect: float, set_sd: float, skewed: bool, rivals: int
) -> None:
    r = sequential_coverage(
        Design(counts), effect, set_sd, TRIALS, rivals=rivals, skewed=skewed, seed=11
    )
    stated = ALPHA / rivals
    assert r.miss <= band(stated), f"missed {r.miss:.4f} > {band(stated):.4f} (nominal {stated})"
    # Early stopping biases the reported ratio away from 1; docs/METHODS.md (section 6) states a
    # bound of 2 %. The margin comes from the data as the miss-rate band does (issue 54: it was a
    # flat 3 %, which no defect reached): the bound must hold with 3 standard errors of the
    # simulated bias to spare, and with no effect and symmetric seed-set noise, where stopping
    # cannot favour a side, the bias is 0 within 3 standard errors (a centre off by a bias
    # fails it).
    bias, margin = math.expm1(r.bias), 3 * r.bias_se
    assert abs(bias) + margin <= BIAS_BOUND, f"bias {bias:+.4f} ± {margin:.4f} > {BIAS_BOUND}"
    if effect == 0.0 and not skewed:
        assert abs(r.bias) <= margin + 1e-12, f"bias {r.bias:+.5f} beyond ±{margin:.5f}"


def test_adding_seed_sets_until_significant_fails_the_same_test() -> None:
    r = sequential_coverage(naive_design(32), 0.0, 0.05, TRIALS, name="naive", seed=11)
    assert r.miss > band(ALPHA), f"the naive procedure missed only {r.miss:.4f}"
