"""The tracer's time model: the rough seconds a render will take on this machine, for the checks
that print or refuse a long render before it starts (``bnerr render``).

``seconds ~= paths * seconds_per_path(scene)``, paths = ``W * H * spp * renders``. Seconds per
path is measured once per scene and process (:func:`seconds_per_path`): two tiny eager renders of
the scene (a few ms each), whose difference removes the fixed per-call cost, so that the slope is
the marginal cost of a path. Scene depth is in it: cornell's paths cost several times direct's.

Not for: memory (:mod:`renderers.memory`), the compiled tracer's start-up (seconds to a minute,
:func:`renderers.tracer.render`), or the strategies' own overhead (small next to their renders).
"""

from __future__ import annotations

import functools
import time

import torch

from bnerr.errors import ValueRangeError
from bnerr.sequences import make_sampler
from renderers.catalog import renders_itself
from renderers.scene import Scene
from renderers.tracer import render

__all__ = [
    "SHOW_ESTIMATE_S",
    "TIME_LIMIT_S",
    "CALIBRATION_SPP",
    "COMPILE_SPEEDUP",
    "UNMEASURED_PATHS",
    "check_render_time",
    "estimate_seconds",
    "format_seconds",
    "seconds_per_path",
]

#: A command refuses work estimated to take longer than this unless ``--force``: an hour is far
#: beyond what the benchmark's, the animations' and the training data's sizes need on this
#: machine, and usually means a mistyped number.
TIME_LIMIT_S = 3600.0
#: A command prints its estimate before starting work estimated to take longer than this.
SHOW_ESTIMATE_S = 10.0

#: Samples per pixel of the two calibration renders of 8 x 8 pixels (4096 and 32768 paths). A
#: render has a fixed cost per call (about 17 ms for cornell, 4 ms for direct: the per-vertex ops'
#: dispatch) that the difference removes; the larger render is tens of ms for the deepest scene,
#: so the calibration costs about 0.1 to 0.3 s per scene.
CALIBRATION_SPP = (64, 512)
#: How much faster the compiled tracer traces a path than the eager one once built (measured
#: about 5x, ``results/speed``); the estimate for a compiled render divides by it.
COMPILE_SPEEDUP = 4.0
#: Renders below this many paths are not estimated: at the slowest scene's rate measured here
#: (about 0.4 M paths/s eager) they take about a second, and skipping spares the calibration.
UNMEASURED_PATHS = 1 << 18


def _timed_render(scene: Scene, spp: int) -> float:
    seeds = torch.arange(64, dtype=torch.int64).reshape(8, 8)
    start = time.perf_counter()
    render(scene, 0, seeds, make_sampler("white"), spp, compile=False)
    return time.perf_counter() - start


@functools.cache
def _calibrate(scene: Scene) -> float:
    low, high = CALIBRATION_SPP
    _timed_render(scene, low)  # first call of a process: warms allocators and caches
    # Best of two: a render on a shared machine is only ever slowed down, never sped up.
    t_low = min(_timed_render(scene, low) for _ in range(2))
    t_high = min(_timed_render(scene, high) for _ in range(2))
    per_path = (t_high - t_low) / (64 * (high - low))
    # Never below a tenth of the all-in cost: timer noise must not make the slope vanish.
    return max(per_path, t_high / (64 * high) / 10)


def seconds_per_path(scene: Scene) -> float:
    """Measured eager seconds per path of ``scene`` on this machine (cached per process)."""
    return _calibrate(scene)


def estimate_seconds(scene: Scene, paths: int, *, compile: bool = False) -> float:
    """Rough wall seconds of tracing ``paths`` paths of ``scene`` (all frames and renders).

    The calibration traces one small chunk on one thread. A large render runs
    ``torch.get_num_threads()`` chunks of 2^16 paths at once but each path costs more in them
    (caches): measured on a shared 2-core machine the two about cancel, so neither is counted
    (at 128x128, 16 spp: estimated 0.1 s for direct, 0.5 s for cornell; took 0.11 s, 0.77 s)."""
    speedup = COMPILE_SPEEDUP if compile else 1.0
    return paths * seconds_per_path(scene) / speedup


def format_seconds(seconds: float) -> str:
    """``"42 s"``, ``"12 min"``, ``"3.5 h"`` or ``"41 days"``: an estimate, to two figures."""
    if seconds < 60:
        return f"{seconds:.2g} s"
    if seconds < 3600:
        return f"{seconds / 60:.2g} min"
    if seconds < 86400 * 2:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.3g} days"


def check_render_time(
    scene: Scene, paths: int, name: str, *, limit_s: float, compile: bool = False
) -> float:
    """Estimate the seconds of tracing ``paths`` paths of ``scene``; refuse beyond ``limit_s``.

    Renders of fewer than :data:`UNMEASURED_PATHS` paths return 0.0 without calibrating: they
    take seconds at most, and a tiny render stays as fast as it was; so does a scene that
    renders itself (a Mitsuba XML scene, :func:`renderers.catalog.renders_itself`): the
    tracer's throughput says nothing of its time.

    Raises:
        ValueRangeError: ``"<name>: expected a render of at most <limit>, got an estimate of
            <time> (...); pass --force to render anyway"``.
    """
    if paths < UNMEASURED_PATHS or renders_itself(scene):
        return 0.0
    seconds = estimate_seconds(scene, paths, compile=compile)
    if seconds > limit_s:
        rate = 1.0 / seconds_per_path(scene) / 1e6
        raise ValueRangeError(
            f"{name}: expected a render of at most {format_seconds(limit_s)}, got an estimate of "
            f"{format_seconds(seconds)} ({paths:.3g} paths of {scene.name} at {rate:.2g} M "
            f"paths/s measured here{', compiled' if compile else ''}); pass --force to render "
            f"anyway"
        )
    return seconds
