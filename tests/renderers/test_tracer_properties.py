"""Property tests of the tensorized path tracer (issue 28, item 5): a white furnace, no NaN or
negative radiance for random valid variations of the catalog's scenes, and spp-additivity.

**Disjoint sample indices.** ``renderers.render(scene, t, seeds, sampler, spp)`` traces paths
``i = 0 .. spp - 1`` of pixel (y, x) with ``sampler.sample(seeds[y, x], i, 0, D, (y, x))``: the API
has no argument for a first sample index. It takes any :class:`bnerr.sequences.Sampler`, though,
so the test wraps the sampler in one that adds ``N`` to every index: a render at N spp through the
wrapper traces exactly paths N .. 2N - 1 of the same sequence, and the mean of that render and the
plain N-spp one must equal the 2N-spp render (up to float32 rounding of the per-pixel sums).

Renders are 8x8 to 16x16 at 1..8 spp on one thread (milliseconds each, eager mode).
"""

from __future__ import annotations

import dataclasses
import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from bnerr.sequences import Sampler, make_sampler
from bnerr.strategies import pixel_seeds
from renderers import render
from renderers.catalog import get_scene
from renderers.scene import Camera, Diffuse, Fixed, Rectangle, Scene

pytestmark = pytest.mark.usefixtures("one_thread")


class _Offset(Sampler):
    """``inner`` with every sample index shifted by ``offset``: paths offset .. offset + spp - 1."""

    def __init__(self, inner: Sampler, offset: int) -> None:
        self.inner, self.offset = inner, offset
        self.name, self.needs_pixel = inner.name, inner.needs_pixel

    def _sample(self, seed, index, dim, count, pixel):
        return self.inner.sample(seed, index + self.offset, dim, count, pixel)


# --------------------------------------------------------------------------------------------------
# White furnace: a closed box whose six inward faces all emit Le and reflect with albedo a


def _furnace(albedo: float, le: float, depth: int, fov: float) -> Scene:
    m = Diffuse((albedo, albedo, albedo))
    e = (le, le, le)
    x, y, z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    mz = (0.0, 0.0, -1.0)
    faces = (
        Rectangle("floor", (0.0, -1.0, 0.0), x, mz, m, e),
        Rectangle("ceiling", (0.0, 1.0, 0.0), x, z, m, e),
        Rectangle("left", (-1.0, 0.0, 0.0), y, z, m, e),
        Rectangle("right", (1.0, 0.0, 0.0), z, y, m, e),
        Rectangle("back", (0.0, 0.0, -1.0), x, y, m, e),
        Rectangle("front", (0.0, 0.0, 1.0), y, x, m, e),
    )
    for f in faces:  # every emitting (front) side faces the inside of the box
        assert sum(c * n for c, n in zip(f.center, f.normal, strict=True)) < 0, f.name
    camera = Camera(Fixed((0.1, -0.2, 0.3)), Fixed((0.2, 0.1, -1.0)), (0.0, 1.0, 0.0), fov)
    return Scene("furnace", "a closed emitting diffuse box", camera, faces, depth)


@given(
    st.sampled_from([0.0, 0.2, 0.5, 0.8, 1.0]),
    st.sampled_from([0.5, 1.0, 4.0]),
    st.integers(2, 4),
    st.floats(20.0, 120.0),
    st.integers(0, 2**20),
    st.sampled_from(["owen_sobol", "white"]),
)
@settings(max_examples=15)
def test_a_white_furnace_returns_the_truncated_neumann_series(albedo, le, depth, fov, key, name):
    # Every path of `depth` segments sees Le at each vertex, weighted by a^k after k bounces:
    # L = Le (1 + a + ... + a^(depth - 1)) in every pixel and every channel.
    want = le * sum(albedo**k for k in range(depth))
    frame = render(
        _furnace(albedo, le, depth, fov), 0, pixel_seeds(12, 12, key), make_sampler(name), 4
    )
    c = frame.color.double()
    assert torch.isfinite(c).all() and (c >= 0).all()
    # pixels have distinct seeds: 144 independent estimates x 3 identical channels
    per_pixel = c.mean(dim=0).reshape(-1)
    mean = float(per_pixel.mean())
    sem = float(per_pixel.std()) / math.sqrt(per_pixel.numel())
    margin = 5.0 * sem + 1e-5 * want  # five standard errors, plus float32 rounding
    assert abs(mean - want) <= margin, (mean, want, margin)
    if albedo == 0.0:  # only the emission is seen: exact in every pixel
        assert torch.allclose(c, torch.full_like(c, le), rtol=1e-6)


# --------------------------------------------------------------------------------------------------
# Random valid scenes: no NaN, no negative radiance


def _vary(scene: Scene, draw) -> Scene:
    """The scene with each untextured albedo, each emission and the camera's fov redrawn within
    their valid ranges ([0, 1], >= 0, (0, 180))."""
    shapes = []
    for shape in scene.shapes:
        changes = {}
        if isinstance(shape.material, Diffuse) and not shape.material.textured:
            rgb = tuple(draw(st.floats(0.0, 1.0)) for _ in range(3))
            changes["material"] = Diffuse(rgb)
        if isinstance(shape, Rectangle) and shape.emission is not None:
            scale = draw(st.sampled_from([0.0, 1e-3, 1.0, 50.0, 1e4]))
            changes["emission"] = tuple(scale * draw(st.floats(0.0, 1.0)) for _ in range(3))
        shapes.append(dataclasses.replace(shape, **changes))
    camera = dataclasses.replace(scene.camera, fov=draw(st.floats(5.0, 150.0)))
    return dataclasses.replace(scene, shapes=tuple(shapes), camera=camera)


@st.composite
def scene_renders(draw):
    name = draw(st.sampled_from(["direct", "indirect", "cornell", "snooker_plain", "medium"]))
    scene = _vary(get_scene(name, animated=draw(st.booleans())), draw)
    h = draw(st.integers(4, 8))
    w = draw(st.integers(4, 8))
    return (
        scene,
        draw(st.integers(0, 30)),
        pixel_seeds(h, w, draw(st.integers(0, 2**20))),
        draw(st.sampled_from(["owen_sobol", "white"])),
        draw(st.integers(1, 4)),
    )


@given(scene_renders())
@settings(max_examples=25)
def test_random_valid_scenes_give_finite_non_negative_radiance(case):
    scene, t, seeds, sampler, spp = case
    frame = render(scene, t, seeds, make_sampler(sampler), spp)
    assert frame.color.shape == (3, *seeds.shape)
    for name, value in frame.buffers().items():
        assert torch.isfinite(value).all(), name
    assert (frame.color >= 0).all(), float(frame.color.min())
    if frame.variance is not None:
        assert (frame.variance >= 0).all()


# --------------------------------------------------------------------------------------------------
# spp-additivity


@given(
    st.sampled_from(["direct", "indirect", "cornell"]),
    st.integers(1, 4),
    st.integers(0, 2**20),
    st.sampled_from(["owen_sobol", "white"]),
    st.integers(0, 10),
)
@settings(max_examples=12)
def test_two_renders_with_disjoint_sample_indices_average_to_the_render_at_twice_the_spp(
    name, n, key, sampler_name, t
):
    scene = get_scene(name)
    seeds = pixel_seeds(8, 8, key)
    sampler = make_sampler(sampler_name)
    first = render(scene, t, seeds, sampler, n)
    second = render(scene, t, seeds, _Offset(sampler, n), n)
    both = render(scene, t, seeds, sampler, 2 * n)
    mean = (first.color.double() + second.color.double()) / 2
    # float32 per-pixel sums of n and 2n paths: a few ulps of the pixel's largest path values
    tol = 1e-5 * (1.0 + both.color.double().abs())
    assert ((mean - both.color.double()).abs() <= tol).all(), float((mean - both.color).abs().max())
    # the geometric buffers of a pixel do not depend on how its paths are split
    assert torch.equal(first.object_id, both.object_id)
    # and the offset render did trace other paths (the property is not vacuous)
    assert not torch.equal(first.color, second.color)


def test_the_offset_sampler_draws_the_plain_samplers_later_indices():
    inner = make_sampler("owen_sobol")
    seed = torch.arange(5, dtype=torch.int64) * 977
    index = torch.arange(5, dtype=torch.int64)
    got = _Offset(inner, 3).sample(seed, index, 0, 4)
    assert torch.equal(got, inner.sample(seed, index + 3, 0, 4))
