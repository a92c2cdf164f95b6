"""Tests for renderers.aot: the package's key and cache, its exported graph against the eager
stage (building a package takes about a minute, so the C++ build itself is not run here: the
exported program it compiles is, and the speed suite's process figures load real packages)."""

import pytest
import torch

from renderers import aot, get_scene, integrator, render
from renderers.camera import camera_frame
from renderers.geometry import scene_tensors

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BNERR_CACHE_DIR", str(tmp_path))
    return tmp_path


def _lanes(scene, n: int, seed: int):
    g = torch.Generator().manual_seed(seed)
    u = torch.rand(scene.layout.dimensions, n, generator=g)
    cam = camera_frame(scene.camera, 0, 32, 32, torch.device("cpu"))
    px, py = torch.randint(0, 32, (n,), generator=g), torch.randint(0, 32, (n,), generator=g)
    o, d = integrator.camera_rays(cam, px, py, u[0:2])
    return u, o.contiguous(), d


@pytest.mark.parametrize("name", ["cornell", "medium", "snooker"])
def test_the_exported_stage_is_the_eager_stage_bit_for_bit(name):
    scene = get_scene(name)
    st = scene_tensors(scene, 3, torch.device("cpu"))
    layout = scene.layout
    has = (layout.distance(0) is not None, layout.light_choice(0) is not None)
    program = torch.export.export(aot._Stage(st, *has), aot._example(st, layout, 64), strict=False)
    u, o, d = _lanes(scene, 64, 1)
    k = min(1, layout.vertices - 1)  # a middle vertex where there is one
    rows = [layout.distance(k), layout.light_choice(k)]
    args = (o, d, torch.ones_like(d), torch.zeros_like(d), torch.ones(64, dtype=torch.bool))
    args += (torch.full((64,), 0.3),)
    args += tuple(None if r is None else u[r] for r in rows)
    light, direction = layout.light(k), layout.direction(k)
    direction = light if direction is None else direction  # trace's stand-in at the last vertex
    args += (u[light : light + 2], u[direction : direction + 2])
    args += ((torch.tensor(False), torch.tensor(False)),)
    got = program.module()(*aot._flat(st, aot._split(st)[0], args))
    want = integrator.vertex_step(st, *args)
    for a, b in zip(got, want, strict=True):
        assert torch.equal(a, b)


def test_no_package_means_none_and_the_key_follows_the_layout(cache):
    cornell = scene_tensors(get_scene("cornell"), 0)
    assert aot.load(cornell) is None and not aot.has_package("cornell")
    path = aot.package_path(cornell)
    assert path.parent == cache / "aot" and path.suffix == ".pt2"
    assert aot.package_path(scene_tensors(get_scene("cornell"), 5)) == path  # frames share it
    assert aot.package_path(scene_tensors(get_scene("cornell", animated=False), 0)) == path
    assert aot.package_path(scene_tensors(get_scene("direct"), 0)) != path


def test_a_damaged_package_is_ignored_with_a_warning(cache):
    st = scene_tensors(get_scene("direct"), 0)
    path = aot.package_path(st)
    path.parent.mkdir(mode=0o700, parents=True)
    path.write_bytes(b"not a package")
    with pytest.warns(RuntimeWarning, match="ignoring"):
        assert aot.load(st) is None


def test_a_failed_build_renders_eagerly_with_a_warning(cache, monkeypatch):
    def broken(st, layout):
        raise RuntimeError("no compiler")

    monkeypatch.setattr(aot, "build", broken)
    scene = get_scene("direct")
    seeds = torch.arange(16, dtype=torch.int64).reshape(4, 4)
    from bnerr.sequences import make_sampler

    white = make_sampler("white")
    with pytest.warns(RuntimeWarning, match="eager mode"):
        frame = render(scene, 0, seeds, white, 2, compile=aot.stage)
    assert torch.equal(frame.color, render(scene, 0, seeds, white, 2, compile=False).color)
