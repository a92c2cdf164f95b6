"""The Cycles door's checks, made before a command writes anything.

:func:`check_cells` takes the scenes and strategies a run will pair and refuses, in one line each:
a ``.blend`` that is missing, unreadable or not a ``.blend``; a Python without ``bpy``; a file
Blender cannot open or whose scene has no camera; a Blender whose Cycles lacks the blue-noise
pattern a strategy asks for; a bnerr strategy (per-pixel seeds) on a Cycles scene; and Cycles' own
patterns on one of bnerr's scenes. Opening the scene starts its Blender process, which the run
then uses (:func:`renderers.cycles.session.session` keeps it).
"""

from __future__ import annotations

from collections.abc import Iterable

from bnerr.errors import ValueRangeError
from renderers.cycles.patterns import CYCLES_STRATEGIES, pattern_class, refusal
from renderers.cycles.scene import BUILT, CyclesScene

__all__ = ["check_cells", "is_cycles_name"]


def is_cycles_name(name: str) -> bool:
    """Whether scene ``name`` is a Cycles scene: a ``.blend`` file or a built Cycles scene."""
    return name.endswith(".blend") or name in BUILT


def check_cells(scene: str, strategies: Iterable[str]) -> dict | None:
    """Refuse a run that pairs scene ``scene`` with ``strategies`` and cannot work (module
    docstring); a Cycles scene is opened in Blender to check it, and what Blender found in it is
    returned (:attr:`CyclesScene.info`; None for bnerr's scenes).

    Raises:
        FileFormatError, MissingExtraError, ExternalProcessError, ValueRangeError: one line each.
    """
    strategies = tuple(strategies)
    if not is_cycles_name(scene):
        own = [s for s in strategies if s in CYCLES_STRATEGIES and s != "white"]
        if own:
            raise ValueRangeError(
                f"--strategies {own[0]}: expected a Cycles scene (a .blend file or one of "
                f"{', '.join(BUILT)}) for Cycles' own pattern, got bnerr's scene {scene!r}"
            )
        return None
    for name in strategies:
        if name not in CYCLES_STRATEGIES:
            raise ValueRangeError(refusal(name, scene))
    from renderers.catalog import get_scene

    cycles = get_scene(scene)
    assert isinstance(cycles, CyclesScene)
    info = cycles.info  # opens it: no bpy, an unreadable file, no camera raise here
    for name in strategies:
        pattern = pattern_class(name)
        if pattern is not None and pattern not in info["patterns"]:
            raise ValueRangeError(
                f"--strategies {name}: expected a Blender whose Cycles has the {pattern} sampling "
                f"pattern (4.4 or later), got Blender {info['blender']} with "
                f"{', '.join(info['patterns']) or 'no pattern list'}"
            )
    return info
