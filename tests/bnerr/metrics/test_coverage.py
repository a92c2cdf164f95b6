"""The coverage study's gap shares (bnerr.metrics.coverage --shares): the gap share's interval
and the seed suite's verdict on the best of m variants keep their stated miss rates at 2, 3, 4
and 8 seed sets, with normal and skewed seed-set effects, at 95 % and at the family level; the
uncorrected best of m does not; and the perceptual verdicts keep theirs at the looks the MSE's
adaptive rule stopped at (--perceptual). (The ratio's coverage is tested in test_stats.py, the
adaptive procedure's in test_sequential.py.)"""

from __future__ import annotations

import math

import pytest
import torch

from benchmarks.reports.gap import gap_shares
from bnerr.metrics.coverage import (
    perceptual_coverage,
    share_coverage,
    share_intervals,
    simulate_levels,
)
from bnerr.metrics.sequential import Design, looks, naive_design
from tests._records import metric_pairs, small_record

# Simulated cells per setting: 6000 put the band below at 3 binomial standard errors (0.84 % at
# a miss rate of 5 %, 0.60 % at 2.5 %), the file at a few seconds on one core.
TRIALS = 6000


def band(rate: float, trials: int = TRIALS) -> float:
    """The most a miss rate of ``rate`` may show in ``trials`` cells: 3 binomial standard errors
    above it."""
    return rate + 3 * math.sqrt(rate * (1 - rate) / trials)


def test_the_batched_share_is_the_gap_tables():
    # The study computes the share batched over trials; it must be benchmarks.reports.gap's.
    # (values a float32 holds exactly: as_stats reads nested lists through torch's default dtype)
    drawn = simulate_levels(3, 4, 2, 0.05, torch.Generator().manual_seed(2), [1.0, 0.7, 0.4])
    w, v, o = (x.float().double() for x in drawn)
    share, lo, hi = share_intervals(w, v, o, 0.95)
    for i in range(3):
        records = [
            small_record(
                name,
                "gaussian",
                raw={},
                den={"mse": metric_pairs(x[i].tolist())},
                frames=2,
                seed_sets=4,
            )  # fmt: skip
            for name, x in (("white", w), ("temporal", v), ("oracle", o))
        ]
        (row,) = gap_shares(records)
        assert (row.share, row.lo, row.hi) == pytest.approx(
            (float(share[i]), float(lo[i]), float(hi[i])), rel=1e-12
        )
        assert row.seed_sets == 4


# Seed sets, gap (W - O) / W, true share, seed-set effect and skew: the suites' seed sets (the
# gap suite runs 2, the quality suite 4, the adaptive looks go on), the committed gaps' range
# (0.23-0.89) and seed-set effects of 5-15 %, normal and skewed (a rare, much worse seed set).
SHARE_SETTINGS = [
    (2, 0.3, 0.0, 0.15, True),
    (2, 0.8, 0.5, 0.05, False),
    (3, 0.8, 0.5, 0.15, True),
    (4, 0.3, 0.5, 0.05, False),
    (4, 0.8, 0.0, 0.15, True),
    (8, 0.8, 0.5, 0.15, False),
    (8, 0.3, 0.0, 0.15, True),
]


@pytest.mark.parametrize(("seed_sets", "gap", "share", "set_sd", "skewed"), SHARE_SETTINGS)
def test_the_gap_share_interval_keeps_its_level(seed_sets, gap, share, set_sd, skewed):
    rows = share_coverage(
        seed_sets, gap, share, set_sd, TRIALS, (0.95, 0.975), skewed=skewed, seed=3
    )
    for r in rows:
        assert r.miss <= band(r.stated), f"{r.level}: missed {r.miss:.4f} > {band(r.stated):.4f}"


@pytest.mark.parametrize(("seed_sets", "rivals", "skewed"), [(2, 2, False), (4, 4, True)])
def test_the_best_of_m_shares_needs_the_corrected_level(seed_sets, rivals, skewed):
    # m variants with the same true share of 0.5 (the worst case for picking the highest); the
    # seed suite's verdict reads the best's interval at 1 - 0.05/m. The family's 5 % holds there
    # and not at the plain 95 % (measured at 40 000 trials: docs/METHODS.md, section 8).
    plain, corrected = share_coverage(
        seed_sets, 0.8, 0.5, 0.15, TRIALS, (0.95, 1 - 0.05 / rivals),
        rivals=rivals, skewed=skewed, seed=4,
    )  # fmt: skip
    assert corrected.miss <= band(0.05), f"corrected: missed {corrected.miss:.4f}"
    if rivals >= 4:  # at m = 2 the uncorrected excess (6-7 %) is within this run's band
        assert plain.miss > band(0.05), f"uncorrected: missed only {plain.miss:.4f}"


@pytest.mark.parametrize("rho", [0.0, 0.9, 1.0])
@pytest.mark.parametrize("effect", [0.0, 0.05])
def test_a_perceptual_verdict_keeps_its_level_at_the_looks_the_mse_rule_stopped_at(effect, rho):
    """The JOD verdict of benchmarks/reports/perceptual.py takes the look an adaptive cell's MSE
    verdict settled at and that look's level: each look spends its share of alpha, so whatever
    the MSE rule (even a JOD that moves with the MSE seed set by seed set, rho = 1) the miss rate
    stays within alpha (the union bound), here measured."""
    design = Design(looks(4, 32))
    found = perceptual_coverage(design, effect, rho, TRIALS, seed=7)
    assert found.miss <= band(0.05), found
    assert found.mean_seed_sets > 4  # the rule did add seed sets


def test_the_same_check_fails_a_design_that_spends_alpha_at_every_look():
    """Where each look spends the whole alpha (the naive "add until significant"), a JOD that
    moves with the MSE is stopped when it looks significant too: the check above sees it."""
    found = perceptual_coverage(naive_design(32), 0.0, 1.0, TRIALS, seed=7)
    assert found.miss > band(0.05), found
