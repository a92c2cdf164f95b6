"""Every Cycles test leaves the scene registry as it found it: the Cycles scenes it loaded
(registered process-wide, as a plug-in scene is) are forgotten after it, so that a later test
file in the same worker sees the shipped scenes only."""

import pytest


@pytest.fixture(autouse=True, scope="module")
def _forget_cycles_scenes():
    import renderers
    from bnerr import plugins

    before = set(renderers.SCENES)
    yield
    for name in set(renderers.SCENES) - before:
        dict.pop(renderers.SCENES, name, None)
        plugins._LOADED.pop(("bnerr.scenes", name), None)
