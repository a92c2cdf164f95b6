"""The temporal method on its failure cases (textured felt, fast motion, object edges), end to end:
never worse than white beyond a stated margin. Margins and levels as in test_ordering.py's
docstring."""

import pytest

from benchmarks.suites import Condition, Suite, Sweep
from benchmarks.sweep.runner import run_suite
from bnerr.metrics import not_worse
from tests.benchmarks.sweep._ordering import (
    FAILURE_COMMON,
    cell_ratio,
    index_records,
)

pytestmark = pytest.mark.usefixtures("one_thread")

DENOISERS = ("gaussian", "atrous")


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
def failures(tmp_path_factory, shared_references):
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
        run_suite(
            suite, tmp_path_factory.mktemp("failures"), cache_dir=shared_references, progress=False
        )
    )


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "motion", "region"), _FAILURES)
@pytest.mark.parametrize("denoiser", DENOISERS)
def test_temporal_is_never_worse_than_white_on_the_failure_cases(
    failures, scene, motion, region, denoiser
):
    cell = dict(scene=scene, spp=1, denoiser=denoiser, motion=motion, region=region)
    ratio = cell_ratio(failures, "temporal", "white", "den", _FAILURE_LEVEL, **cell)
    assert not_worse(ratio, _FAILURE_MARGIN[denoiser]), f"temporal / white = {ratio}"
