"""Tests for renderers.scene: motions, static variants, shapes, textures and typed errors."""

import math

import numpy as np
import pytest

from bnerr.errors import DtypeError, UnknownNameError, ValueRangeError
from renderers.scene import (
    Box,
    Camera,
    Checker,
    Diffuse,
    Felt,
    Fixed,
    HomogeneousMedium,
    Linear,
    Orbit,
    Rectangle,
    Scene,
    Sphere,
    affine,
    rotation,
)

WHITE = Diffuse((0.5, 0.5, 0.5))
LIGHT = Rectangle("light", (0, 2, 0), (0.5, 0, 0), (0, 0, 0.5), WHITE, (1.0, 1.0, 1.0))


def make_scene(**changes) -> Scene:
    args = dict(
        name="test",
        description="a test scene",
        camera=Camera(Orbit((0, 0, 0), 5.0, 1.0, 0.0, 2.0), Fixed((0, 0, 0)), (0, 1, 0), 40.0),
        shapes=(Sphere("ball", Linear((0, 1, 0), (0.1, 0, 0)), 1.0, WHITE), LIGHT),
        max_depth=3,
    )
    args.update(changes)
    return Scene(**args)


def test_motions():
    assert Fixed((1, 2, 3)).at(7) == (1, 2, 3)
    assert Linear((0, 0, 0), (1, 2, 3)).at(2) == (2, 4, 6)
    orbit = Orbit((1, 0, 0), 2.0, 0.5, 90.0, 90.0)
    np.testing.assert_allclose(orbit.at(0), (3.0, 0.5, 0.0), atol=1e-12)
    np.testing.assert_allclose(orbit.at(1), (1.0, 0.5, -2.0), atol=1e-12)
    assert orbit.frozen().at(5) == orbit.at(0)


def test_static_variant_freezes_camera_and_objects():
    scene = make_scene()
    static = scene.static()
    assert not static.animated and scene.animated
    assert scene.camera.pose(3) != scene.camera.pose(0)
    assert static.camera.pose(3) == static.camera.pose(0) == scene.camera.pose(0)
    assert static.shapes[0].center.at(3) == scene.shapes[0].center.at(0)
    assert static.dimensions == scene.dimensions


def test_lights_and_dimensions():
    scene = make_scene()
    assert scene.lights == (1,)
    assert scene.dimensions == scene.layout.dimensions == 8


def test_rectangle_frame():
    rect = Rectangle("r", (0, 0, 0), (2, 0, 0), (0, 0, -1), WHITE)
    assert rect.normal == (0.0, 1.0, 0.0)
    assert rect.area == pytest.approx(8.0)
    m = affine((1, 2, 3), ((1, 0, 0), -90.0), (2.0, 3.0, 1.0))
    from_m = Rectangle.from_transform("f", m, WHITE)
    np.testing.assert_allclose(from_m.center, (1, 2, 3))
    np.testing.assert_allclose(from_m.normal, (0, 1, 0), atol=1e-12)  # rotate -90 about x: z -> y


def test_rotation_is_right_handed():
    r = rotation((0, 1, 0), 90.0)
    np.testing.assert_allclose(r @ np.array([1.0, 0, 0]), (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)


def test_textures():
    checker = Checker((1, 0, 0), (0, 0, 1), 3, 2).texels()
    assert checker.shape == (2, 3, 3)
    np.testing.assert_array_equal(checker[0, 0], (1, 0, 0))
    np.testing.assert_array_equal(checker[0, 1], (0, 0, 1))
    np.testing.assert_array_equal(checker[1, 1], (1, 0, 0))
    felt = Felt((0.1, 0.4, 0.2), 32, 16, seed=3)
    a, b = felt.texels(), felt.texels()
    np.testing.assert_array_equal(a, b)
    assert a.shape == (16, 32, 3) and a.min() >= 0 and a.max() <= 1
    assert len(np.unique(a[..., 1])) > 100  # a real grain, not a constant
    np.testing.assert_allclose(felt.mean(), a.reshape(-1, 3).mean(0), rtol=1e-6)
    assert not np.array_equal(Felt((0.1, 0.4, 0.2), 32, 16, seed=4).texels(), a)


def _lowbias32_numpy(x: np.ndarray) -> np.ndarray:
    """The plain uint32 numpy form of Wellons' lowbias32 (the twin of bnerr.hashing's)."""
    x = x.astype(np.uint32)
    x ^= x >> np.uint32(16)
    x *= np.uint32(0x7FEB352D)
    x ^= x >> np.uint32(15)
    x *= np.uint32(0x846CA68B)
    x ^= x >> np.uint32(16)
    return x


@pytest.mark.parametrize("seed", [0, 3, 2**31 + 7, 2**32 + 5, 2**63 + 11])
def test_felt_texels_are_the_uint32_hash_of_their_cell(seed):
    """Felt's grain, computed through bnerr.hashing's int32 tensor form, is bit for bit the
    uint32 numpy computation the shipped scenes and results were made with."""
    felt = Felt((0.1, 0.5, 0.2), 37, 23, grain=0.3, nap=0.05, bands=5, seed=seed)
    iv, iu = np.meshgrid(np.arange(23), np.arange(37), indexing="ij")
    key = (iu.astype(np.uint64) * 73856093) ^ (iv.astype(np.uint64) * 19349663) ^ seed
    h = _lowbias32_numpy(_lowbias32_numpy((key & 0xFFFFFFFF).astype(np.uint32)))
    g = (h >> np.uint32(8)).astype(np.float64) / float(1 << 24) * 2.0 - 1.0
    scale = 1.0 + 0.3 * g + 0.05 * np.cos(2.0 * math.pi * 5 * iu / 37)
    twin = np.clip(scale[..., None] * np.asarray((0.1, 0.5, 0.2)), 0.0, 1.0).astype(np.float32)
    np.testing.assert_array_equal(felt.texels(), twin)


def test_typed_errors():
    with pytest.raises(ValueRangeError, match="expected at least one emitting Rectangle"):
        make_scene(shapes=(Sphere("b", Fixed((0, 0, 0)), 1.0, WHITE),))
    with pytest.raises(ValueRangeError, match="max_depth: expected an integer >= 2"):
        make_scene(max_depth=1)
    with pytest.raises(DtypeError, match="expected Sphere, Rectangle or Box, got str"):
        make_scene(shapes=(LIGHT, "sphere"))
    with pytest.raises(ValueRangeError, match="radius: expected > 0"):
        Sphere("b", Fixed((0, 0, 0)), -1.0, WHITE)
    with pytest.raises(ValueRangeError, match="Diffuse.albedo: expected values in \\[0, 1\\]"):
        Diffuse((1.5, 0, 0))
    with pytest.raises(ValueRangeError, match="fov: expected degrees in \\(0, 180\\)"):
        Camera(Fixed((0, 0, 0)), Fixed((0, 0, 1)), (0, 1, 0), 180.0)
    with pytest.raises(UnknownNameError, match="unknown fov_axis 'diagonal'"):
        Camera(Fixed((0, 0, 0)), Fixed((0, 0, 1)), (0, 1, 0), 40.0, "diagonal")
    with pytest.raises(ValueRangeError, match="non-parallel u and v"):
        Rectangle("r", (0, 0, 0), (1, 0, 0), (2, 0, 0), WHITE)
    with pytest.raises(ValueRangeError, match="emission: expected >= 0"):
        Rectangle("r", (0, 0, 0), (1, 0, 0), (0, 1, 0), WHITE, (-1, 0, 0))
    with pytest.raises(ValueRangeError, match="det > 0"):
        Rectangle.from_transform("r", affine(scale=(-1.0, 1.0, 1.0)), WHITE)
    with pytest.raises(ValueRangeError, match="invertible 3 x 4"):
        Box("b", affine(scale=(1.0, 0.0, 1.0)), WHITE)
    with pytest.raises(ValueRangeError, match="bounds_min < bounds_max"):
        HomogeneousMedium((0, 0, 0), (1, 0, 1), 1.0, (0.5, 0.5, 0.5))
    with pytest.raises(ValueRangeError, match="sigma_t: expected > 0"):
        HomogeneousMedium((0, 0, 0), (1, 1, 1), 0.0, (0.5, 0.5, 0.5))
    with pytest.raises(DtypeError, match="u: expected 3 numbers"):
        Rectangle("r", (0, 0, 0), 1.0, (0, 1, 0), WHITE)
    assert math.isfinite(make_scene().dimensions)
