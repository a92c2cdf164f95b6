"""Shared by the end-to-end ordering tests: the sweeps' common settings and the runner's records
keyed by cell."""

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
