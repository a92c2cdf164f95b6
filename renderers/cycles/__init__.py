"""Blender Cycles as bnerr's renderer: any ``.blend`` file, or a scene built in Blender by code.

- :mod:`renderers.cycles.scene`: :class:`CyclesScene`, a scene that renders itself through
  Cycles (``bnerr bench --scenes path/to/scene.blend``, or a built scene of :data:`BUILT`), and
  the frame read from Cycles' passes;
- :mod:`renderers.cycles.patterns`: Cycles' sampling patterns as the strategies of a Cycles scene
  (``white`` is the classic pattern, ``blue_noise`` Blender 4.4's default, and their variants);
- :mod:`renderers.cycles.session`: the long-lived Blender process that holds a scene;
- :mod:`renderers.cycles.checks`: the door's checks, made before a command writes anything;
- ``worker.py`` and ``builders.py``: the Blender side, run under the Python that has ``bpy``
  (``make cycles``), never imported by bnerr itself.

Blender (and so ``bpy``) is GPL; bnerr talks to it as a separate program over a pipe and imports
none of it. docs/CYCLES.md is the user's page.
"""

from renderers.cycles.checks import check_cells, is_cycles_name
from renderers.cycles.patterns import (
    CYCLES_STRATEGIES,
    CyclesPattern,
    make_pattern_strategy,
    refusal,
)
from renderers.cycles.scene import (
    BUILT,
    CyclesScene,
    built_scene,
    load_blend,
    recipe_of_scene,
    save_blend,
    settings_record,
)

__all__ = [
    "BUILT",
    "CYCLES_STRATEGIES",
    "CyclesPattern",
    "CyclesScene",
    "built_scene",
    "check_cells",
    "is_cycles_name",
    "load_blend",
    "make_pattern_strategy",
    "recipe_of_scene",
    "refusal",
    "save_blend",
    "settings_record",
]
