"""The temporal variants against temporal and white, end to end (docs/METHODS.md, section 8).
Margins and levels as in test_ordering.py's docstring."""

import numpy as np
import pytest

from benchmarks.suites import Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import better, equivalent, paired_ratio
from tests.benchmarks.sweep._ordering import (
    COMMON,
    RAW_MARGIN,
    index_records,
)

pytestmark = pytest.mark.usefixtures("one_thread")

# Closing the gap to the oracle (issue 14, docs/METHODS.md, section 8): the best temporal variant
# against temporal, on textured snooker (where the luminance key mistakes texture for error) and
# on direct, at 4 spp after the tuned Gaussian. Quick ablation behind the choice (128x128, 4 spp,
# 4 seed sets x 3 frames after 6 warmup, 256-spp references, Gaussian; share of the white-to-oracle
# distance closed after the Gaussian, temporal -> best): snooker 0.42 -> 0.67, direct 0.13 -> 0.28.
BEST = "temporal+relative+demod+groups"


_GAP_STRATEGIES = ("white", "temporal", BEST, "temporal+shift", "temporal+reproject")


_GAP_LEVEL = 1 - 0.05 / 6  # six comparisons below


_GAP_SHIFT = (
    "Shifting the block grid by (2, 2) every other frame does not help: the retargeting pass "
    "already moves seeds across block boundaries every frame, and the shifted grid's partial "
    "border blocks sort fewer seeds; measured with this test's own run (128x128, 8 seed sets, "
    "t-interval at 1 - 0.05/6) temporal+shift / temporal after the Gaussian on snooker 0.997 "
    "[0.957, 1.038], after a sigma-2 blur 0.997 [0.803, 1.236]."
)


_GAP_REPROJECT = (
    "Forward reprojection changes nothing measurable at the scenes' own speed: the animation "
    "moves about half a pixel per frame (snooker: median 0.53 px, at most 0.98 px), so rounding "
    "moves half the seeds by one pixel, where the error was nearly as well predicted in place; "
    "measured with this test's own run (128x128, 8 seed sets, t-interval at 1 - 0.05/6) "
    "temporal+reproject / temporal after the Gaussian on snooker 0.995 [0.962, 1.028], after a "
    "sigma-2 blur 0.958 [0.871, 1.054]. The x8 motion case would need the strategy to see the "
    "motion between the frames it renders (the runner's frame k*t reports the motion from "
    "k*t - 1)."
)


@pytest.fixture(scope="module")
def gap(tmp_path_factory, shared_references):
    sweep = Sweep(
        scenes=("snooker", "direct"),
        strategies=_GAP_STRATEGIES,
        spp=(4,),
        denoisers=("gaussian",),
        metrics=("mse", "mse_blur2"),
        **COMMON,
    )
    suite = Suite("gap", "test", sweeps=(sweep,), crops=False)
    return index_records(
        run_suite(
            suite, tmp_path_factory.mktemp("gap"), cache_dir=shared_references, progress=False
        )
    )


def _gap_ratio(records, a, b, kind, metric, scene):
    def stats(strategy):
        return np.asarray(getattr(records[scene, 4, "gaussian", strategy, 1, "all"], kind)[metric])

    return paired_ratio(stats(a), stats(b), level=_GAP_LEVEL)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("strategy", "scene"),
    [
        (BEST, "snooker"),
        # Established with 8 seed sets: 0.964 [0.939, 0.990] at 99.17 % (with 4 seed sets the
        # quick ablation's 0.969 [0.929, 1.014] was not).
        (BEST, "direct"),
        pytest.param(
            "temporal+shift",
            "snooker",
            marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=_GAP_SHIFT),
        ),
        pytest.param(
            "temporal+reproject",
            "snooker",
            marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=_GAP_REPROJECT),
        ),
    ],
)
def test_variant_beats_temporal_after_a_gaussian(gap, strategy, scene):
    ratio = _gap_ratio(gap, strategy, "temporal", "den", "mse", scene)
    assert better(ratio), f"{strategy} / temporal = {ratio}"


@pytest.mark.slow
def test_best_variant_beats_temporal_after_a_sigma2_blur_on_textured_snooker(gap):
    ratio = _gap_ratio(gap, BEST, "temporal", "raw", "mse_blur2", "snooker")
    assert better(ratio), f"{BEST} / temporal = {ratio}"


@pytest.mark.slow
def test_best_variant_keeps_whites_raw_mse(gap):
    # A permutation of white's seeds: the temporal raw-MSE margin (RAW_MARGIN); measured 0.992
    # [0.970, 1.015] at 99.17 %.
    ratio = _gap_ratio(gap, BEST, "white", "raw", "mse", "snooker")
    assert equivalent(ratio, RAW_MARGIN["temporal"]), f"raw {BEST} / white = {ratio}"
