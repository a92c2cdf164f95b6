"""The tiny suite the runner tests and the sweep-fault tests run end to end: ``direct`` at 16x12,
white and temporal at 1 spp, two denoisers, 2 seed sets x 2 frames after 1 warm-up frame."""

from benchmarks.suites import Suite, Sweep


def tiny_suite(**sweep) -> Suite:
    """The tiny suite, with ``sweep`` overriding any of its sweep's fields."""
    base = dict(
        scenes=("direct",),
        strategies=("white", "temporal"),
        spp=(1,),
        denoisers=("gaussian", "median"),
        frames=2,
        warmup=1,
        res=(16, 12),
        reference_spp=16,
        seed_sets=2,
    )
    base.update(sweep)
    return Suite(name="tiny", description="test", sweeps=(Sweep(**base),))
