"""The scenes built in Blender by code: each builds, is lit, has its camera keyframed over its
frames, and moves."""

import pytest
import torch

import renderers
from bnerr.sequences import make_sampler
from tests._cycles import skip_without_bpy

#: builders.KINDS (builders.py imports bpy: it runs only under Blender's Python).
KINDS = ("interior", "outdoor", "product")


@pytest.mark.parametrize("kind", KINDS)
def test_each_scene_builds_lit_and_moving(kind):
    skip_without_bpy()
    name = f"cycles_{kind}"
    renderers.load_scene(name)
    scene = renderers.get_scene(name)
    assert scene.info["frame_end"] - scene.info["frame_start"] + 1 == 64
    assert scene.info["objects"] >= 5
    frame = scene.render(3, torch.zeros(12, 12, dtype=torch.int64), make_sampler("owen_sobol"), 4)
    assert 0.01 < float(frame.color.mean()) < 10.0
    assert frame.motion.abs().max() > 0
    assert len(frame.object_id.unique()) >= 2
