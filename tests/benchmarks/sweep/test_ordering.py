"""Post-denoise MSE ordering oracle < temporal < white, end to end through the benchmark runner.

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

import numpy as np
import pytest

from benchmarks.suites import Condition, Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import better, equivalent, not_worse, paired_ratio
from tests.benchmarks.sweep._ordering import COMMON, FAILURE_COMMON, index_records

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


pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("references")


@pytest.fixture(scope="module")
def ordering(tmp_path_factory, cache):
    sweep = Sweep(
        scenes=SCENES,
        strategies=("white", "temporal", "oracle"),
        spp=SPP,
        denoisers=DENOISERS,
        **COMMON,
    )
    suite = Suite("ordering", "test", sweeps=(sweep,), crops=False)
    return index_records(
        run_suite(suite, tmp_path_factory.mktemp("ordering"), cache_dir=cache, progress=False)
    )


def _ratio(records, a, b, kind, level, scene, spp, denoiser, motion=1, region="all"):
    """Paired ratio of strategy ``a``'s MSE to ``b``'s (``kind`` raw or den) on one cell."""

    def stats(strategy):
        record = records[scene, spp, denoiser, strategy, motion, region]
        return np.asarray(getattr(record, kind)["mse"])

    return paired_ratio(stats(a), stats(b), level=level)


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp", "denoiser"), _cells("temporal"))
def test_temporal_beats_white_after_denoising(ordering, scene, spp, denoiser):
    ratio = _ratio(
        ordering, "temporal", "white", "den", _ORDER_LEVEL, scene=scene, spp=spp, denoiser=denoiser
    )
    assert better(ratio), f"temporal / white = {ratio}"


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp", "denoiser"), _cells("oracle"))
def test_oracle_beats_temporal_after_denoising(ordering, scene, spp, denoiser):
    ratio = _ratio(
        ordering, "oracle", "temporal", "den", _ORDER_LEVEL, scene=scene, spp=spp, denoiser=denoiser
    )
    assert better(ratio), f"oracle / temporal = {ratio}"


# Equivalence margins of the raw MSE ratio to white. temporal permutes white's seeds, so its raw
# MSE is white's in expectation: the claim is equality within 5 %, the smallest round margin 8 seed
# sets resolve at 99.375 % (measured half-widths 1.7-4.4 %, largest on direct at 4 spp, whose
# Owen-Sobol raw MSE varies most between seed sets; 3 % would need about 16 seed sets there).
_RAW_MARGIN = {"temporal": 0.05, "oracle": 0.10}


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp"), [(s, n) for s in SCENES for n in SPP])
def test_temporals_raw_mse_equals_whites(ordering, scene, spp):
    ratio = _ratio(
        ordering, "temporal", "white", "raw", _RAW_LEVEL, scene=scene, spp=spp, denoiser="gaussian"
    )
    assert equivalent(ratio, _RAW_MARGIN["temporal"]), f"raw temporal / white = {ratio}"


# The oracle is no permutation: it shows one of K = 32 candidates per pixel, picked by rank against
# the mask, so its raw MSE is not white's in expectation and equality is not claimed (measured
# here on direct at 4 spp 0.956 [0.922, 0.991], which excludes 1; 1.24x on the Cornell box,
# docs/METHODS.md section 6). What is claimed is a bound on the difference, so that its gains after
# denoising (test_oracle_beats_temporal_after_denoising) are not raw-MSE differences beyond it:
# the raw MSE ratio's interval lies inside [0.90, 1.10].
@pytest.mark.slow
@pytest.mark.parametrize(("scene", "spp"), [(s, n) for s in SCENES for n in SPP])
def test_oracles_raw_mse_is_within_10_percent_of_whites(ordering, scene, spp):
    ratio = _ratio(
        ordering, "oracle", "white", "raw", _RAW_LEVEL, scene=scene, spp=spp, denoiser="gaussian"
    )
    assert equivalent(ratio, _RAW_MARGIN["oracle"]), f"raw oracle / white = {ratio}"


# The failure cases: where the temporal method is expected to degrade to white noise, never worse.
_FAILURES = [
    (
        "snooker",
        1,
        "all",
    ),  # textured felt: a seed's value says more about the texture than the seed
    ("snooker", 1, "edges"),  # object edges: a seed moved across an edge lands on another object
    ("indirect", 8, "all"),  # camera motion 8x faster: the seed's neighbourhood changes every frame
]


_FAILURE_LEVEL = 1 - 0.05 / (len(_FAILURES) * len(DENOISERS))


# Non-inferiority margins, per denoiser: the smallest round margins 8 seed sets x 3 frames of 64x64
# resolve at 99.17 %. Measured half-widths (log scale): Gaussian 8-9 %, a-trous 12-25 % (its
# colour weights react to the noise, so its MSE varies most between seed sets; snooker's edges
# are the widest). The claim is "not more than 10 % (Gaussian) / 25 % (a-trous) worse than white";
# a-trous at 10 % would need about 4x the seed sets.
_FAILURE_MARGIN = {"gaussian": 0.10, "atrous": 0.25}


@pytest.fixture(scope="module")
def failures(tmp_path_factory, cache):
    sweeps = (
        Sweep(
            scenes=("snooker",),
            strategies=("white", "temporal"),
            spp=(1,),
            denoisers=DENOISERS,
            conditions=(Condition(), Condition(region="edges")),
            **FAILURE_COMMON,
        ),
        Sweep(
            scenes=("indirect",),
            strategies=("white", "temporal"),
            spp=(1,),
            denoisers=DENOISERS,
            conditions=(Condition(motion=8),),
            **FAILURE_COMMON,
        ),
    )
    suite = Suite("failures", "test", sweeps=sweeps, crops=False)
    return index_records(
        run_suite(suite, tmp_path_factory.mktemp("failures"), cache_dir=cache, progress=False)
    )


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "motion", "region"), _FAILURES)
@pytest.mark.parametrize("denoiser", DENOISERS)
def test_temporal_is_never_worse_than_white_on_the_failure_cases(
    failures, scene, motion, region, denoiser
):
    cell = dict(scene=scene, spp=1, denoiser=denoiser, motion=motion, region=region)
    ratio = _ratio(failures, "temporal", "white", "den", _FAILURE_LEVEL, **cell)
    assert not_worse(ratio, _FAILURE_MARGIN[denoiser]), f"temporal / white = {ratio}"


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
def gap(tmp_path_factory, cache):
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
        run_suite(suite, tmp_path_factory.mktemp("gap"), cache_dir=cache, progress=False)
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
    # A permutation of white's seeds: the temporal raw-MSE margin (_RAW_MARGIN); measured 0.992
    # [0.970, 1.015] at 99.17 %.
    ratio = _gap_ratio(gap, BEST, "white", "raw", "mse", "snooker")
    assert equivalent(ratio, _RAW_MARGIN["temporal"]), f"raw {BEST} / white = {ratio}"


# The rivals (issue 13, docs/METHODS.md, sections 5 and 7): the a-priori patterns need no previous
# frame, so on the untextured direct-lighting scene their gain should hold at 4 and 16 spp, where
# the temporal method's has faded (_OWEN_SOBOL_4SPP). Each against white after the tuned Gaussian;
# and each not worse than white in raw MSE by more than the permutations' equivalence margin
# (_RAW_MARGIN["temporal"], 5 %: they are other samplers, not a permutation of white's seeds, so
# equality is not the claim, but a raw excess beyond what 8 seed sets resolve is a finding).
# LDBN (issue 25) with the keys shipped in bnerr/data, measured here: after the Gaussian 0.901
# [0.855, 0.950] at 4 spp and 0.953 [0.916, 0.991] at 16; raw 1.006 [0.973, 1.039] and 0.927
# [0.874, 0.983] (this test's own run: 8 seed sets, 1 - 0.05/12 = 99.58 %), the lowest of the
# three at both sample counts.
RIVAL_CLAIMS = ("zsobol", "cycles_blue", "ldbn")


_RIVAL_SPP = (4, 16)


_RIVAL_LEVEL = 1 - 0.05 / (2 * len(RIVAL_CLAIMS) * len(_RIVAL_SPP))  # den and raw per cell


_RIVAL_16SPP = (
    "Not established at 16 spp: after the Gaussian tuned on white (sigma 0.5 px at 16 spp, so "
    "narrow that little low-frequency error is removed either way) zsobol / white measured "
    "0.978 [0.954, 1.003] in this test's own run (8 seed sets, t-interval at 1 - 0.05/12) and "
    "0.974 [0.950, 1.004] in results/quality (1024-spp references, the former bootstrap); at 4 "
    "spp the gain is clear (0.962 [0.937, 0.988] here)."
)


_SHARED_SCRAMBLE = (
    "cycles_blue and zsobol take each pixel's samples as an aligned block of one sequence under "
    "one scramble shared by all pixels, so the image's raw MSE is one draw per scramble instead "
    "of an average over per-pixel scrambles (docs/METHODS.md, section 7; tests/test_sequences.py). "
    "Cycles fixes its sequence seed, so its draw on direct at 4 spp (1.072 [1.030, 1.115] in "
    "this test's own run at 1 - 0.05/12, "
    "1.067 [1.035, 1.099] in results/quality) never changes; ZSobol draws a fresh scramble per "
    "frame and shows no excess on average on toy integrands, but its MSE varies from frame to "
    "frame 2.4 times as much as white's, so these 24 frames' interval reaches past the 5 % "
    "margin (1.127 [1.024, 1.239] at 4 spp, 1.016 [0.960, 1.075] at 16 here; 1.018 [0.969, "
    "1.083] and 1.003 [0.965, 1.046] in results/quality, the former bootstrap). The rivals' "
    "design, not a defect in our samplers."
)


_RIVAL_FAILURES = {
    ("den", "zsobol", 16): _RIVAL_16SPP,
    ("raw", "zsobol", 4): _SHARED_SCRAMBLE,
    ("raw", "zsobol", 16): _SHARED_SCRAMBLE,
    ("raw", "cycles_blue", 4): _SHARED_SCRAMBLE,
}


def _rival_cells(kind):
    return [
        pytest.param(
            s,
            n,
            marks=pytest.mark.xfail(
                strict=True, raises=AssertionError, reason=_RIVAL_FAILURES[kind, s, n]
            ),
        )
        if (kind, s, n) in _RIVAL_FAILURES
        else (s, n)
        for s in RIVAL_CLAIMS
        for n in _RIVAL_SPP
    ]


@pytest.fixture(scope="module")
def rivals(tmp_path_factory, cache):
    sweep = Sweep(
        scenes=("direct",),
        strategies=("white", *RIVAL_CLAIMS),
        spp=_RIVAL_SPP,
        denoisers=("gaussian",),
        metrics=("mse",),
        **COMMON,
    )
    suite = Suite("rivals", "test", sweeps=(sweep,), crops=False)
    return index_records(
        run_suite(suite, tmp_path_factory.mktemp("rivals"), cache_dir=cache, progress=False)
    )


@pytest.mark.slow
@pytest.mark.parametrize(("strategy", "spp"), _rival_cells("den"))
def test_rival_beats_white_after_a_gaussian_on_direct(rivals, strategy, spp):
    cell = dict(scene="direct", spp=spp, denoiser="gaussian")
    ratio = _ratio(rivals, strategy, "white", "den", _RIVAL_LEVEL, **cell)
    assert better(ratio), f"{strategy} / white = {ratio}"


@pytest.mark.slow
@pytest.mark.parametrize(("strategy", "spp"), _rival_cells("raw"))
def test_rival_raw_mse_is_not_worse_than_whites_on_direct(rivals, strategy, spp):
    cell = dict(scene="direct", spp=spp, denoiser="gaussian")
    ratio = _ratio(rivals, strategy, "white", "raw", _RIVAL_LEVEL, **cell)
    assert not_worse(ratio, _RAW_MARGIN["temporal"]), f"raw {strategy} / white = {ratio}"
