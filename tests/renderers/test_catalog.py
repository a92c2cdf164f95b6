"""Tests for renderers.catalog: the registry, D per scene, animation and static variants, scene
files loaded as plug-ins (a shipped scene's file is that scene)."""

import pytest
import torch

from bnerr import plugins
from bnerr.errors import PluginError, UnknownNameError
from bnerr.sequences import make_sampler
from renderers import SCENES, get_scene, load_scene, render
from renderers.scene import Sphere
from tests._paths import EXAMPLES

EXPECTED = {  # name: (D, max_depth, lights, medium)
    "direct": (4, 2, 1, False),
    "indirect": (8, 3, 1, False),
    "cornell": (20, 6, 1, False),
    "snooker": (10, 3, 2, False),
    "snooker_plain": (10, 3, 2, False),
    "medium": (40, 9, 1, True),
}


def test_registry_and_dimensions():
    assert set(SCENES) == set(EXPECTED)
    for name, (dims, depth, lights, medium) in EXPECTED.items():
        scene = get_scene(name)
        assert scene.name == name and scene.description
        assert (scene.dimensions, scene.max_depth, len(scene.lights), scene.medium is not None) == (
            dims,
            depth,
            lights,
            medium,
        ), name


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_animated_and_static_variants(name):
    animated, static = get_scene(name), get_scene(name, animated=False)
    assert animated.animated and not static.animated
    assert animated.camera.pose(0) == static.camera.pose(0) == static.camera.pose(40)
    assert animated.camera.pose(40) != animated.camera.pose(0)  # every scene moves its camera
    for shape in static.shapes:
        if isinstance(shape, Sphere):
            assert shape.center.at(40) == shape.center.at(0)


def test_snooker_variants_differ_only_in_the_felt_texture():
    textured, plain = get_scene("snooker"), get_scene("snooker_plain")
    assert textured.shapes[0].material.textured and not plain.shapes[0].material.textured
    assert textured.shapes[1:] == plain.shapes[1:]
    assert plain.shapes[0].material.albedo == pytest.approx(
        textured.shapes[0].material.albedo.mean()
    )


def test_balls_roll_without_overlapping():
    scene = get_scene("snooker")
    balls = [s for s in scene.shapes if isinstance(s, Sphere)]
    assert any(b.center.at(0) != b.center.at(1) for b in balls)
    for t in range(0, 121, 5):
        for i, a in enumerate(balls):
            for b in balls[i + 1 :]:
                gap = sum((p - q) ** 2 for p, q in zip(a.center.at(t), b.center.at(t))) ** 0.5
                assert gap >= a.radius + b.radius, (t, a.name, b.name)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_every_scene_renders(name):
    frame = render(
        get_scene(name), 1, torch.arange(48, dtype=torch.int64).view(6, 8), make_sampler("white"), 2
    )
    assert torch.isfinite(frame.color).all() and (frame.color >= 0).all()
    assert frame.color.mean() > 0.005  # lit and in view


def test_unknown_scene():
    with pytest.raises(UnknownNameError, match="unknown scene 'Cornell': expected one of cornell"):
        get_scene("Cornell")


def test_a_shipped_scene_written_as_a_file_is_the_shipped_scene():
    path = EXAMPLES / "scenes" / "direct.toml"
    assert load_scene(str(path)) == "direct"
    assert plugins.loaded("bnerr.scenes", "direct") is None  # shipped: no plug-in record


def test_a_changed_scene_under_a_shipped_name_is_refused(tmp_path):
    text = (EXAMPLES / "scenes" / "direct.toml").read_text().replace("radius = 6.0", "radius = 7.0")
    (tmp_path / "direct.toml").write_text(text)
    with pytest.raises(
        PluginError, match=r"expected a name other than a shipped scene's .* 'direct'"
    ):
        load_scene(str(tmp_path / "direct.toml"))


def test_a_scene_file_loads_once_under_its_name_with_its_path_as_spec(tmp_path, forget):
    text = (EXAMPLES / "scenes" / "direct.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text.replace('name = "direct"', 'name = "cat_mine"'))
    forget.append(("bnerr.scenes", "cat_mine"))
    assert load_scene(str(path)) == "cat_mine"
    builder = SCENES["cat_mine"]
    assert load_scene(str(path)) == "cat_mine"  # again (each unit of work): the same entry
    assert SCENES["cat_mine"] is builder
    assert plugins.loaded("bnerr.scenes", "cat_mine").spec == str(path)
    assert get_scene(str(path)).name == "cat_mine"


def test_a_built_cycles_scene_is_shipped_not_a_plug_in_and_keyed_by_its_version():
    """Its records carry no plug-in identity (a resume follows its version through the
    references' key, not edits of renderers/cycles/scene.py); Blender is not started."""
    from renderers import scene_version
    from renderers.cycles import built_scene

    try:
        assert load_scene("cycles_outdoor") == "cycles_outdoor"
        assert plugins.loaded("bnerr.scenes", "cycles_outdoor") is None
        assert scene_version("cycles_outdoor") == built_scene("cycles_outdoor")().version
        assert scene_version("direct") == ""
    finally:
        dict.pop(SCENES, "cycles_outdoor", None)
