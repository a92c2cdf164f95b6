"""Post-denoise MSE ordering oracle < temporal < white, end to end through the benchmark runner
(the failure cases, the temporal variants and the rivals are in test_ordering_failures.py,
test_ordering_variants.py and test_ordering_rivals.py, so that xdist runs them side by side;
they share one reference cache, tests/benchmarks/sweep/conftest.py).

Issue 6's "done when": on ``direct`` and ``indirect`` at 1 and 4 spp, for the Gaussian and a-trous
denoisers, post-denoise MSE must order oracle < temporal < white; raw MSE must be equal across
strategies (they only move errors); and on the failure cases (textured felt, fast camera motion,
object edges) temporal must never be worse than white.

How the margins are made: every comparison is a paired ratio over the same frames and seed sets
(:func:`bnerr.metrics.paired_ratio`): a t-interval with 7 degrees of freedom on the log ratios of 8
independent seed sets x 3 frames (issue 24; its coverage at these settings and levels is tested in
tests/bnerr/metrics/test_stats.py). The seed set is the unit that matters: a temporal run reuses one
set of seeds for all its frames, so its frames are correlated. With the former two-stage bootstrap
over 4 seed sets the intervals missed far more often than their level said; the t-interval at 4 seed
sets is honest but 2.8x wider at the orderings' level (t quantile 8.8 with 3 degrees of freedom
against 4.4 with 7, and half the seed sets), so the suites here use 8 seed sets: about twice the
render time, the cheapest way to the power. The confidence level is Bonferroni-corrected for the
number of comparisons each test makes, so that the family of checks, not each one, has a 5% false-
alarm rate. The claims (:mod:`bnerr.metrics.stats`): an ordering is superiority, the whole interval
below 1 (:func:`~bnerr.metrics.better`); "equal raw MSE" is equivalence, the whole interval inside
``1 -+ d`` (:func:`~bnerr.metrics.equivalent`); "never worse" is non-inferiority, the interval's
upper end at most ``1 + d`` (:func:`~bnerr.metrics.not_worse`), with each d stated below and why.

The references have 256 spp: their noise adds the same constant to every strategy's MSE (it is
independent of the frames), which pulls every ratio towards 1; it can hide an ordering, never create
one.

Resolution: 128x128 for the orderings, 64x64 for the failure cases. Smaller images are not a fair
test of the method: the scenes' features then vary inside a 4x4 block, the sort orders by that
signal instead of by the error, and the filters tuned on white noise are so narrow (sigma 0.5-1 px)
that their bias is 20-46% of the post-denoise MSE; measured at 64x64, temporal's gain over white was
established in none of the eight cells, at 32x32 its point estimates were 0.96-1.01. Everything else
is the benchmark's default: the runner's white-noise tuning of the denoisers, animated scenes, the
strategies' defaults (Owen-scrambled Sobol per-pixel sequences, K = 32 oracle candidates, 4x4
blocks, 64x64 masks, 4 warmup frames: the sort converges within about 3 frames).

Expected orderings that do not hold are marked ``xfail(strict=True)`` with the measured reason."""

import pytest

from benchmarks.suites import Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import better, equivalent
from tests.benchmarks.sweep._ordering import (
    COMMON,
    RAW_MARGIN,
    cell_ratio,
    index_records,
)

pytestmark = pytest.mark.usefixtures("one_thread")

SCENES = ("direct", "indirect")


SPP = (1, 4)


DENOISERS = ("gaussian", "atrous")


_CELLS = [(s, n, d) for s in SCENES for n in SPP for d in DENOISERS]


_ORDER_LEVEL = 1 - 0.05 / (2 * len(_CELLS))  # two orderings per cell


_RAW_LEVEL = 1 - 0.05 / (2 * len(SCENES) * len(SPP))  # temporal and oracle against white


# Measured failures of the expected ordering (issue 6: "do not bend the test: find out why").
# strict=True: if one starts to hold, the run says so and the mark must go.
_OWEN_SOBOL_4SPP = (
    "At 4 spp with the strategies' default Owen-scrambled Sobol sequences the temporal method "
    "leaves the error nearly white: the stratified error of a seed does not carry over to the "
    "neighbouring pixel the sort moves it to (raw MSE after a sigma-1 blur, temporal / white, "
    "direct 128x128 4 spp: 0.92 [0.84, 1.05] with Owen-Sobol against 0.67 [0.63, 0.72] with white "
    "per-pixel sequences), and the denoisers tuned on white noise at 4 spp are narrow (Gaussian "
    "sigma 0.5 px), so no post-denoise gain is left to measure."
)


_KNOWN_FAILURES = {
    ("temporal", "direct", 4, "gaussian"): _OWEN_SOBOL_4SPP,
    ("temporal", "direct", 4, "atrous"): _OWEN_SOBOL_4SPP,
    ("temporal", "indirect", 4, "gaussian"): _OWEN_SOBOL_4SPP,
    ("temporal", "indirect", 4, "atrous"): _OWEN_SOBOL_4SPP,
    ("temporal", "indirect", 1, "atrous"): (
        "Not established at this power: temporal / white after a-trous on indirect at 1 spp "
        "measured 0.956 [0.894, 1.023] (8 seed sets, 99.69 %); the edge-avoiding filter's colour "
        "weights react to the noise itself, so its MSE varies strongly between seed sets. (The "
        "former bootstrap over 4 seed sets called it established, 0.949 [0.876, 0.995]: too "
        "narrow.)"
    ),
}


def _cells(strategy):
    return [
        pytest.param(
            *c, marks=pytest.mark.xfail(strict=True, reason=_KNOWN_FAILURES[(strategy, *c)])
        )
        if (strategy, *c) in _KNOWN_FAILURES
        else c
        for c in _CELLS
    ]


@pytest.fixture(scope="module")
def ordering(tmp_path_factory, shared_references):
    sweep = Sweep(
        scenes=SCENES,
        strategies=("white", "temporal", "oracle"),
        spp=SPP,
        denoisers=DENOISERS,
        **COMMON,
    )
    suite = Suite("ordering", "test", sweeps=(sweep,), crops=False)
    return index_records(
        run_suite(
            suite, tmp_path_factory.mktemp("ordering"), cache_dir=shared_references, progress=False
        )
    )


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp", "denoiser"), _cells("temporal"))
def test_temporal_beats_white_after_denoising(ordering, scene, spp, denoiser):
    ratio = cell_ratio(
        ordering, "temporal", "white", "den", _ORDER_LEVEL, scene=scene, spp=spp, denoiser=denoiser
    )
    assert better(ratio), f"temporal / white = {ratio}"


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp", "denoiser"), _cells("oracle"))
def test_oracle_beats_temporal_after_denoising(ordering, scene, spp, denoiser):
    ratio = cell_ratio(
        ordering, "oracle", "temporal", "den", _ORDER_LEVEL, scene=scene, spp=spp, denoiser=denoiser
    )
    assert better(ratio), f"oracle / temporal = {ratio}"


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp"), [(s, n) for s in SCENES for n in SPP])
def test_temporals_raw_mse_equals_whites(ordering, scene, spp):
    ratio = cell_ratio(
        ordering, "temporal", "white", "raw", _RAW_LEVEL, scene=scene, spp=spp, denoiser="gaussian"
    )
    assert equivalent(ratio, RAW_MARGIN["temporal"]), f"raw temporal / white = {ratio}"


# The oracle is no permutation: it shows one of K = 32 candidates per pixel, picked by rank against
# the mask, so its raw MSE is not white's in expectation and equality is not claimed (measured
# here on direct at 4 spp 0.956 [0.922, 0.991], which excludes 1; 1.24x on the Cornell box,
# docs/METHODS.md section 6). What is claimed is a bound on the difference, so that its gains after
# denoising (test_oracle_beats_temporal_after_denoising) are not raw-MSE differences beyond it:
# the raw MSE ratio's interval lies inside [0.90, 1.10].
@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp"), [(s, n) for s in SCENES for n in SPP])
def test_oracles_raw_mse_is_within_10_percent_of_whites(ordering, scene, spp):
    ratio = cell_ratio(
        ordering, "oracle", "white", "raw", _RAW_LEVEL, scene=scene, spp=spp, denoiser="gaussian"
    )
    assert equivalent(ratio, RAW_MARGIN["oracle"]), f"raw oracle / white = {ratio}"
