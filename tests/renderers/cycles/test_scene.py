"""Cycles scenes: a .blend refused before Blender when it is not one, bnerr's scenes rebuilt in
Blender's axes, Cycles' passes read as bnerr's buffers, and the rebuilt scene agreeing with
bnerr's tracer on the same frame."""

import json

import numpy as np
import pytest
import torch

import renderers
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.sequences import make_sampler
from renderers.cycles.patterns import CyclesPattern
from renderers.cycles.scene import (
    BUILT,
    built_scene,
    load_blend,
    motion_from_vector,
    recipe_of_scene,
    save_blend,
)
from tests._cycles import skip_without_bpy


def test_a_missing_or_foreign_file_is_refused_before_blender_starts(tmp_path):
    with pytest.raises(FileFormatError, match=r"missing\.blend: expected a readable \.blend file"):
        load_blend(tmp_path / "missing.blend")
    (tmp_path / "text.blend").write_text("not blender")
    with pytest.raises(FileFormatError, match=r"text\.blend: expected a \.blend file.*b'not ble'"):
        load_blend(tmp_path / "text.blend")


def test_a_blend_is_named_after_its_file_and_versioned_by_its_bytes(tmp_path):
    path = tmp_path / "shot.blend"
    path.write_bytes(b"BLENDER-v405" + bytes(64))
    first = load_blend(path)()
    path.write_bytes(b"BLENDER-v405" + bytes(65))
    assert first.name == "shot" and load_blend(path)().version != first.version
    assert json.loads(first.source) == {"op": "open", "blend": str(path.resolve())}
    assert first.static().animated is False and first.animated


def test_the_motion_of_cycles_vector_pass_is_bnerr_s():
    vector = np.array([[[2.0]], [[3.0]]], dtype=np.float32)  # to t-1: 2 right... in Cycles' y up
    assert motion_from_vector(vector).reshape(-1).tolist() == [-2.0, 3.0]


def test_bnerr_s_scenes_are_rebuilt_in_blender_axes():
    recipe = recipe_of_scene(renderers.get_scene("indirect"), frames=2)
    floor = next(r for r in recipe["rectangles"] if r["name"] == "floor")
    assert floor["center"] == [0.0, -0.5, 0.0]  # bnerr (0, 0, 0.5), y up -> Blender (x, -z, y)
    assert floor["checker"]["cells_u"] == 10 and recipe["max_bounces"] == 1
    light = next(r for r in recipe["rectangles"] if "radiance" in r)
    assert light["center"][2] == 4.5 and len(recipe["poses"]) == 2
    assert recipe["spheres"][0]["center"] == [0.0, 0.0, 1.0]


@pytest.mark.parametrize("name", ["cornell", "medium", "snooker"])
def test_what_the_rebuild_cannot_carry_is_refused(name):
    with pytest.raises(ValueRangeError, match=rf"^{name}: expected spheres, rectangles and "):
        recipe_of_scene(renderers.get_scene(name))


def test_every_built_scene_has_a_recipe_and_a_version():
    versions = {built_scene(name)().version for name in BUILT}
    assert len(versions) == len(BUILT)


@pytest.fixture(scope="module")
def direct():
    skip_without_bpy()
    renderers.load_scene("cycles_direct")
    return renderers.get_scene("cycles_direct")


def _render(scene, t=2, spp=4, pattern=None, size=(16, 16)):
    seeds = torch.full(size, 12345, dtype=torch.int64)
    return scene.render(t, seeds, pattern or make_sampler("owen_sobol"), spp)


def test_a_frame_holds_every_buffer_and_cycles_own_denoised_image(direct):
    frame = _render(direct)
    assert frame.color.shape == (3, 16, 16) and frame.timings["render"] > 0
    for name in ("albedo", "normal", "depth", "motion", "object_id"):
        assert getattr(frame, name) is not None and torch.isfinite(getattr(frame, name)).all()
    assert frame.own_denoised["cycles_oidn"].shape == (3, 16, 16)
    ids = set(frame.object_id.unique().tolist())
    assert -1.0 in ids and len(ids) >= 3  # the background, the floor, the sphere (and light)
    assert (frame.depth[frame.object_id < 0] == 0).all() and (frame.depth > 0).any()
    assert frame.motion.abs().max() > 0  # the orbiting camera
    assert _render(direct, t=0).motion.abs().max() == 0  # nothing before frame 0


def test_same_seed_same_frame_and_each_pattern_its_own(direct):
    a, b = _render(direct), _render(direct)
    assert torch.equal(a.color, b.color)
    blue = _render(direct, pattern=CyclesPattern("blue_noise", "BLUE_NOISE", 12345))
    assert not torch.equal(a.color, blue.color)
    static = direct.static()
    assert torch.equal(_render(static, t=3).color, _render(static, t=0).color)


def test_the_rebuilt_scene_renders_what_bnerr_s_tracer_renders(direct):
    """Both renderers' mean colour over a 32 x 32 frame at 64 spp, 3 seeds each: equal within
    four standard errors of their difference, computed from the seeds' spread."""
    tracer_scene = renderers.get_scene("direct")
    ours, theirs = [], []
    for k in range(3):
        seeds = torch.arange(32 * 32, dtype=torch.int64).reshape(32, 32) * 7919 + k
        ours.append(renderers.render(tracer_scene, 2, seeds, make_sampler("owen_sobol"), 64))
        theirs.append(direct.render(2, seeds + 1000 * k, make_sampler("owen_sobol"), 64))
    a = torch.stack([f.color.mean() for f in ours])
    b = torch.stack([f.color.mean() for f in theirs])
    error = float(torch.sqrt(a.var() / 3 + b.var() / 3)) + 1e-4
    assert abs(float(a.mean() - b.mean())) < 4 * error, (a, b)


def test_a_built_scene_saves_as_a_blend_that_renders_the_same(direct, tmp_path):
    path = save_blend("cycles_direct", tmp_path / "direct.blend")
    saved = load_blend(path)()
    assert saved.info["frame_start"] == 1 and saved.info["camera"] == "camera"
    assert torch.equal(_render(saved).color, _render(direct).color)
