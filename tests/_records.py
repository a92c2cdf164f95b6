"""A small benchmark record for report tests: 16x16 frames, metrics given as per-frame pairs; and
those pairs built from per-frame values."""

from benchmarks.sweep.plan import Cell
from benchmarks.sweep.records import Record, ReferenceInfo, Spectrum, Timings


def small_record(
    strategy, denoiser, *, raw, den, frames, seed_sets, spp=4, scene="direct", motion=1, tcorr=None
):
    """A :class:`Record` of ``seed_sets x frames`` frames whose ``raw`` and ``den`` are metric ->
    ``[S][F][2]`` pairs as given; timings 1 ms, a flat spectrum, no crop."""
    cell = Cell(
        scene=scene, strategy=strategy, spp=spp, denoiser=denoiser, motion=motion, depth=None,
        region="all", sampler="owen_sobol", frames=frames, warmup=2, width=16, height=16,
        seed_sets=seed_sets, reference_spp=64,
    )  # fmt: skip
    ms = [[1.0] * frames] * seed_sets
    return Record(
        cell=cell,
        dimensions=4,
        t=list(range(2, 2 + frames)),
        raw=raw,
        den=den,
        denoiser_params={},
        timings=Timings(render_ms=ms, perm_ms=ms, denoise_ms=ms),
        reference=ReferenceInfo(spp=64, floor=None, version="test"),
        spectrum={k: Spectrum(freq=[0.1], power=[1.0]) for k in ("raw", "den")},
        crop=None,
        tcorr=tcorr,
    )


def metric_pairs(values, count=256.0):
    """A record's per-frame metric pairs ``(value * count, count)`` from ``[S][F]`` values (seed
    sets x frames): the sum and the pixel count the runner stores for each frame."""
    return [[[v * count, count] for v in row] for row in values]


def table_row(
    strategy,
    spp,
    mse=1.0,
    *,
    jod=None,
    mse_half=0.03,
    jod_half=0.1,
    den="gaussian",
    scene="direct",
    seed_sets=4,
    **extra,
):
    """A ``table.csv`` row as the reports read it: ``strategy``'s post-denoise MSE ``mse`` and,
    for a rival of white, its ratio ``mse`` +- ``mse_half`` (relative); with ``jod``, its
    ColorVideoVDP difference to white +- ``jod_half``; ``extra`` fields added as given."""
    rival = strategy != "white"
    row = {
        "scene": scene,
        "motion": 1,
        "depth": None,
        "region": "all",
        "sampler": "owen_sobol",
        "strategy": strategy,
        "spp": spp,
        "denoiser": den,
        "frames": 3,
        "seed_sets": seed_sets,
        "den_mse": mse,
        "den_mse_ratio": mse if rival else None,
        "den_mse_ratio_lo": mse * (1 - mse_half) if rival else None,
        "den_mse_ratio_hi": mse * (1 + mse_half) if rival else None,
        **extra,
    }
    if jod is not None:
        row.update(
            den_cvvdp_diff=jod, den_cvvdp_diff_lo=jod - jod_half, den_cvvdp_diff_hi=jod + jod_half
        )
    return row
