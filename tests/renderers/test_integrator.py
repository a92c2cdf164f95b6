"""Tests for renderers.integrator, the per-path physics: :func:`trace` and :func:`vertex_step` on
one emitting square (a path that misses everything, a camera ray on a light), the
:class:`PathVertex` state by name, the compiled stage's uniform arguments and its one graph.

The light transport as a whole (a white furnace, random valid scenes) is tested through
``render`` in test_tracer_properties.py.
"""

import dataclasses

import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.sequences import make_sampler
from renderers import get_scene
from renderers.camera import camera_frame
from renderers.geometry import scene_tensors
from renderers.integrator import PathVertex, camera_rays, trace, vertex_step
from renderers.scene import Camera, Diffuse, Fixed, Rectangle, Scene

pytestmark = pytest.mark.usefixtures("one_thread")

WHITE = make_sampler("white")
LE = (3.0, 1.5, 0.25)


def _square(center: tuple[float, float, float], depth: int = 3) -> Scene:
    """One black emitting square of half edge 2 facing +z, seen by a camera at the origin that
    looks down -z with a 30 degree field of view (at z = -3 it sees 0.8 either side)."""
    light = Rectangle("light", center, (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), Diffuse((0.0,) * 3), LE)
    camera = Camera(Fixed((0.0, 0.0, 0.0)), Fixed((0.0, 0.0, -1.0)), (0.0, 1.0, 0.0), 30.0)
    return Scene("square", "one emitting square", camera, (light,), depth)


def _lanes(scene: Scene, width: int, height: int, t: int = 0):
    """The scene tensors, camera and one white-noise path per pixel: ``(st, cam, px, py, u)``."""
    st, cam = scene_tensors(scene, t), camera_frame(scene.camera, t, width, height)
    pix = torch.arange(width * height)
    rows = torch.stack([pix // width, pix % width], 1)
    u = WHITE.sample(pix * 7 + 1, torch.zeros_like(pix), 0, scene.dimensions, rows)
    return st, cam, pix % width, pix // width, u.T.contiguous()


def _recording(seen: list[PathVertex]):
    """:func:`vertex_step`, keeping every vertex it returns in ``seen``."""

    def step(*args):
        vertex = vertex_step(*args)
        seen.append(vertex)
        return vertex

    return step


def test_a_path_vertex_names_the_loop_state():
    assert PathVertex._fields == ("o", "d", "beta", "radiance", "alive", "pdf", "albedo", "normal")
    scene = _square((0.0, 0.0, -3.0))
    st, cam, px, py, u = _lanes(scene, 4, 3)
    seen: list[PathVertex] = []
    trace(st, cam, scene.layout, px, py, u, _recording(seen))
    assert len(seen) == scene.layout.vertices == 2 and all(type(v) is PathVertex for v in seen)
    assert seen[0].pdf.shape == (12,) and seen[0].alive.dtype == torch.bool


def test_a_path_that_misses_everything_gathers_nothing_and_dies_at_its_first_vertex():
    scene = _square((0.0, 0.0, 5.0), depth=4)  # the square is behind the camera
    st, cam, px, py, u = _lanes(scene, 5, 4)
    seen: list[PathVertex] = []
    paths = trace(st, cam, scene.layout, px, py, u, _recording(seen))
    assert len(seen) == 3
    for vertex in seen:
        assert not vertex.alive.any()
        assert torch.equal(vertex.beta, torch.zeros(3, 20))
        assert torch.equal(vertex.radiance, torch.zeros(3, 20))
    for buffer in (paths.radiance, paths.albedo, paths.normal):
        assert torch.equal(buffer, torch.zeros(3, 20))


def test_a_camera_ray_on_a_black_light_sees_its_radiance_and_nothing_more():
    # The camera ray's emission has full weight (no direction sample to share it with by MIS),
    # a black surface reflects nothing: every lane's estimate is exactly Le.
    scene = _square((0.0, 0.0, -3.0))
    st, cam, px, py, u = _lanes(scene, 6, 5)
    paths = trace(st, cam, scene.layout, px, py, u)
    torch.testing.assert_close(paths.radiance, torch.tensor(LE)[:, None].expand(3, 30))
    assert torch.equal(paths.albedo, torch.zeros(3, 30))
    assert torch.equal(paths.normal, torch.tensor([0.0, 0.0, 1.0])[:, None].expand(3, 30))


def test_a_medium_scene_needs_its_free_flight_sample():
    scene = get_scene("medium")
    st, cam, px, py, u = _lanes(scene, 2, 2)
    o, d = camera_rays(cam, px, py, u[0:2])
    alive = torch.ones_like(px, dtype=torch.bool)
    state = (o, d, torch.ones_like(d), torch.zeros_like(d), alive, None)
    with pytest.raises(ValueRangeError, match="vertex_step: u_distance: expected the free-flight"):
        vertex_step(st, *state, None, None, u[2:4], u[4:6])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cornell", "medium"])
def test_the_compiled_vertex_stage_traces_as_one_graph(name):
    """A graph break inside :func:`integrator.vertex_step` splits each compiled vertex into pieces
    that dynamo compiles and guards separately (it once made compiled cornell renders 6x slower:
    ``torch.result_type`` in ``geometry.where``). Dynamo's explain traces without compiling."""
    scene = get_scene(name)
    st, cam = scene_tensors(scene, 0), camera_frame(scene.camera, 0, 4, 4)
    pix = torch.arange(16)
    u = WHITE.sample(
        pix, torch.zeros_like(pix), 0, scene.dimensions, torch.stack([pix // 4, pix % 4], 1)
    )
    breaks, explained = [], {}

    def explained_step(*args):
        # Dynamo specializes on what _guard_signature keeps (shapes, dtypes, flags, Python
        # values), never on tensor values: vertices with one signature trace the same graph, so
        # each signature is explained once (one per scene: the compiled stage's one variant).
        key = _guard_signature(args)
        if key not in explained:
            explained[key] = torch._dynamo.explain(vertex_step)(*args).graph_break_count
        breaks.append(explained[key])
        return vertex_step(*args)

    explained_step.uniform = True  # the arguments the compiled stage gets
    trace(st, cam, scene.layout, pix % 4, pix // 4, u.T.contiguous(), explained_step)
    assert len(breaks) == scene.layout.vertices and breaks == [0] * len(breaks)
    assert len(explained) == 1  # every vertex of the scene is one compiled variant


def _guard_signature(value):
    """What dynamo's guards see of ``value``: tensors by shape, dtype and device, containers
    element by element, dataclasses field by field, anything else by its value."""
    if isinstance(value, torch.Tensor):
        return ("tensor", tuple(value.shape), value.dtype, value.device.type)
    if isinstance(value, (tuple, list)):
        return tuple(_guard_signature(v) for v in value)
    if dataclasses.is_dataclass(value):
        return tuple(_guard_signature(getattr(value, f.name)) for f in dataclasses.fields(value))
    return ("value", repr(value))


@pytest.mark.parametrize("name", ["cornell", "medium", "direct"])
def test_uniform_vertex_arguments_give_the_same_paths_bit_for_bit(name):
    """The compiled stage gets tensors and flags where the eager one gets None (one compiled
    variant per scene instead of three); the flags select exactly the values None selects."""
    scene = get_scene(name)
    st, cam = scene_tensors(scene, 1), camera_frame(scene.camera, 1, 6, 5)
    pix = torch.arange(30).repeat_interleave(3)
    index = torch.arange(3).repeat(30)
    rows = torch.stack([pix // 6, pix % 6], 1)
    u = WHITE.sample(pix * 7 + 1, index, 0, scene.dimensions, rows).T.contiguous()

    def uniform_step(*args):
        assert len(args) == 12 and all(args[i] is not None for i in (6, 10, 11))  # pdf, u, ends
        return vertex_step(*args)

    uniform_step.uniform = True
    plain = trace(st, cam, scene.layout, pix % 6, pix // 6, u)
    flagged = trace(st, cam, scene.layout, pix % 6, pix // 6, u, uniform_step)
    for field in ("radiance", "albedo", "normal"):
        assert torch.equal(getattr(plain, field), getattr(flagged, field)), field
