"""The a-priori rivals against white on direct at 4 and 16 spp, end to end (docs/METHODS.md,
sections 5 and 7). Margins and levels as in test_ordering.py's docstring."""

import pytest

from benchmarks.suites import Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import better, not_worse
from tests.benchmarks.sweep._ordering import (
    COMMON,
    RAW_MARGIN,
    cell_ratio,
    index_records,
)

pytestmark = pytest.mark.usefixtures("one_thread")

# The rivals (issue 13, docs/METHODS.md, sections 5 and 7): the a-priori patterns need no previous
# frame, so on the untextured direct-lighting scene their gain should hold at 4 and 16 spp, where
# the temporal method's has faded (_OWEN_SOBOL_4SPP). Each against white after the tuned Gaussian;
# and each not worse than white in raw MSE by more than the permutations' equivalence margin
# (RAW_MARGIN["temporal"], 5 %: they are other samplers, not a permutation of white's seeds, so
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
def rivals(tmp_path_factory, shared_references):
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
        run_suite(
            suite, tmp_path_factory.mktemp("rivals"), cache_dir=shared_references, progress=False
        )
    )


@pytest.mark.slow
@pytest.mark.parametrize(("strategy", "spp"), _rival_cells("den"))
def test_rival_beats_white_after_a_gaussian_on_direct(rivals, strategy, spp):
    cell = dict(scene="direct", spp=spp, denoiser="gaussian")
    ratio = cell_ratio(rivals, strategy, "white", "den", _RIVAL_LEVEL, **cell)
    assert better(ratio), f"{strategy} / white = {ratio}"


@pytest.mark.slow
@pytest.mark.parametrize(("strategy", "spp"), _rival_cells("raw"))
def test_rival_raw_mse_is_not_worse_than_whites_on_direct(rivals, strategy, spp):
    cell = dict(scene="direct", spp=spp, denoiser="gaussian")
    ratio = cell_ratio(rivals, strategy, "white", "raw", _RIVAL_LEVEL, **cell)
    assert not_worse(ratio, RAW_MARGIN["temporal"]), f"raw {strategy} / white = {ratio}"
