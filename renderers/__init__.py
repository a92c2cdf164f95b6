"""renderers: a tensorized CPU path tracer, its declarative scenes and a Mitsuba 3 cross-check.

- :func:`render` (:mod:`renderers.tracer`): ``render(scene, t, seeds [H, W] int64, sampler, spp)
  -> bnerr.frame.Frame``, a pure function of its inputs whose every random number comes from the
  sampler (seed image, sample index, dimension); :func:`render_batch` (same module): K such
  renders of one frame with K seed images at once, each bit-identical to its own render.
- :func:`get_scene` and :data:`SCENES` (:mod:`renderers.catalog`): the named scenes, each animated
  over frames t with a static variant; ``scene.dimensions`` is D and ``scene.max_depth`` the
  depth in Mitsuba's convention; a Mitsuba XML scene (:mod:`renderers.mitsuba_scene`) is a
  scene that renders itself (:func:`renders_itself`).
- :mod:`renderers.scene`: the scene description; :mod:`renderers.layout`: which dimension feeds
  what; :mod:`renderers.mitsuba`: the same scene as a Mitsuba 3 dictionary (optional dependency);
  :mod:`renderers.compare`: the statistical test that two Monte Carlo images agree, used by the
  Mitsuba cross-check.

This package imports :mod:`bnerr` only, never :mod:`denoisers` or :mod:`benchmarks`.
"""

from renderers.catalog import (
    SCENES,
    get_scene,
    is_cycles,
    load_scene,
    renders_itself,
    scene_version,
)
from renderers.layout import Layout
from renderers.scene import Scene
from renderers.tracer import render, render_batch

__all__ = [
    "Layout",
    "SCENES",
    "Scene",
    "get_scene",
    "is_cycles",
    "load_scene",
    "render",
    "render_batch",
    "renders_itself",
    "scene_version",
]
