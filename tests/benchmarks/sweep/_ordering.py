"""Shared by the end-to-end ordering tests: the sweeps' common settings and the runner's records
keyed by cell, the paired ratio of two strategies on one cell, and the raw-MSE margins."""

import numpy as np

from bnerr.metrics import paired_ratio

COMMON = dict(frames=3, warmup=4, res=(128, 128), seed_sets=8, reference_spp=256)


FAILURE_COMMON = dict(COMMON, res=(64, 64))


def index_records(records):
    """The runner's :class:`benchmarks.sweep.records.Record` s keyed by scene, spp, denoiser,
    strategy, motion and region."""
    return {
        (
            r.cell.scene,
            r.cell.spp,
            r.cell.denoiser,
            r.cell.strategy,
            r.cell.motion,
            r.cell.region,
        ): r
        for r in records
    }


# Equivalence margins of the raw MSE ratio to white. temporal permutes white's seeds, so its raw
# MSE is white's in expectation: the claim is equality within 5 %, the smallest round margin 8 seed
# sets resolve at 99.375 % (measured half-widths 1.7-4.4 %, largest on direct at 4 spp, whose
# Owen-Sobol raw MSE varies most between seed sets; 3 % would need about 16 seed sets there).
RAW_MARGIN = {"temporal": 0.05, "oracle": 0.10}


def cell_ratio(records, a, b, kind, level, scene, spp, denoiser, motion=1, region="all"):
    """Paired ratio of strategy ``a``'s MSE to ``b``'s (``kind`` raw or den) on one cell."""

    def stats(strategy):
        record = records[scene, spp, denoiser, strategy, motion, region]
        return np.asarray(getattr(record, kind)["mse"])

    return paired_ratio(stats(a), stats(b), level=level)
