"""The seed's claim in spatio-temporally coherent regions at 16 spp, end to end through the
benchmark runner (issue 26): the oracle beats white after a sigma-2 blur in direct's coherent
region, the temporal method does not (a measured failure), and it does on the untextured snooker
table. Split from test_ordering.py: its scenes and sizes share no reference with the sweeps there.
"""

import numpy as np
import pytest

from benchmarks.suites import Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import better, paired_ratio
from tests.benchmarks.sweep._ordering import FAILURE_COMMON, index_records

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("references")


# Issue 26: the seed's claim in spatio-temporally coherent regions at 16 spp (64x64, 8 seed sets,
# the region of bnerr.metrics.coherent_mask, raw error after a sigma-2 blur). Two comparisons.
_COHERENT_LEVEL = 1 - 0.05 / 2


_COHERENT_FAILURE = (
    "In coherent regions of direct at 16 spp the sort key ranks the shading, not the error: inside "
    "coherent 4x4 blocks the reference's spread is 7.5x the error's and the key's rank "
    "correlation with the error 0.05 (python -m benchmarks.studies.coherent_fade; "
    "docs/METHODS.md, section 11). "
    "Measured with this test's own run (64x64, 8 seed sets x 3 frames, t-interval at 1 - 0.05/2): "
    "temporal / white after a sigma-2 blur 1.103 [0.688, 1.768], against the oracle's 0.214 "
    "[0.150, 0.305]."
)


@pytest.fixture(scope="module")
def coherent(tmp_path_factory, cache):
    sweep = Sweep(
        scenes=("direct",),
        strategies=("white", "temporal", "oracle"),
        spp=(16,),
        denoisers=("gaussian",),
        **FAILURE_COMMON,
    )
    suite = Suite("coherent", "test", sweeps=(sweep,), crops=False, coherent=True)
    records = run_suite(suite, tmp_path_factory.mktemp("coherent"), cache_dir=cache, progress=False)
    return index_records(records)


def _coherent_ratio(records, a, b):
    def stats(strategy):
        record = records["direct", 16, "gaussian", strategy, 1, "coherent"]
        return np.asarray(record.raw["mse_blur2"])

    return paired_ratio(stats(a), stats(b), level=_COHERENT_LEVEL)


@pytest.mark.slow
def test_the_oracle_beats_white_after_a_sigma2_blur_in_coherent_regions_at_16spp(coherent):
    ratio = _coherent_ratio(coherent, "oracle", "white")
    assert better(ratio), f"oracle / white = {ratio}"


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason=_COHERENT_FAILURE)
def test_temporal_beats_white_after_a_sigma2_blur_in_coherent_regions_at_16spp(coherent):
    ratio = _coherent_ratio(coherent, "temporal", "white")
    assert better(ratio), f"temporal / white = {ratio}"


# Where the seed's claim holds (issue 26): the untextured snooker table's coherent region at 16
# spp, where the quality suite measured the temporal method keeping 0.73 [0.69, 0.77] of the
# oracle's dividend after a sigma-2 blur (128x128, 4 seed sets). One comparison, at 95 %. At
# 64x64 (a quarter of the pixels; the set-up took 16 s here, about a minute at 128x128) the claim
# holds as clearly: temporal / white measured 0.563 [0.476, 0.667] there (8 seed sets; 0.368
# [0.307, 0.440] at 128x128 with 4).
@pytest.fixture(scope="module")
def coherent_plain(tmp_path_factory, cache):
    sweep = Sweep(
        scenes=("snooker_plain",),
        strategies=("white", "temporal"),
        spp=(16,),
        denoisers=("gaussian",),
        **FAILURE_COMMON,
    )
    suite = Suite("coherent_plain", "test", sweeps=(sweep,), crops=False, coherent=True)
    out = tmp_path_factory.mktemp("coherent_plain")
    return index_records(run_suite(suite, out, cache_dir=cache, progress=False))


@pytest.mark.slow
def test_temporal_beats_white_after_a_sigma2_blur_in_plain_snookers_coherent_region(
    coherent_plain,
):
    def stats(strategy):
        record = coherent_plain["snooker_plain", 16, "gaussian", strategy, 1, "coherent"]
        return np.asarray(record.raw["mse_blur2"])

    ratio = paired_ratio(stats("temporal"), stats("white"))
    assert better(ratio), f"temporal / white = {ratio}"
