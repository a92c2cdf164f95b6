"""Tests for renderers.geometry: rays aimed at known surface points hit them, with their normal."""

import numpy as np
import pytest
import torch

from renderers.geometry import intersect, medium_interval, scene_tensors, surface_at, where
from renderers.scene import (
    Box,
    Camera,
    Checker,
    Diffuse,
    Fixed,
    HomogeneousMedium,
    Rectangle,
    Scene,
    Sphere,
    affine,
)

RED = Diffuse((0.9, 0.1, 0.1))
LIGHT = Rectangle("light", (0.0, 50.0, 0.0), (0.5, 0, 0), (0, 0, 0.5), RED, (1.0, 1.0, 1.0))


def scene_of(*shapes, medium=None) -> Scene:
    camera = Camera(Fixed((0, 0, 10)), Fixed((0, 0, 0)), (0, 1, 0), 40.0)
    return Scene("geometry", "test", camera, (*shapes, LIGHT), 3, medium)


def aim(points: np.ndarray, normals: np.ndarray, rng: np.random.Generator):
    """Origins in the open half-space in front of each surface point, and unit directions to it."""
    d = rng.normal(size=points.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where((d * normals).sum(1, keepdims=True) < 0, -d, d)  # away from the surface ...
    d = (d + 0.2 * normals) / np.linalg.norm(d + 0.2 * normals, axis=1, keepdims=True)
    dist = rng.uniform(0.5, 4.0, size=(len(points), 1))
    origins = points + dist * d
    return (
        torch.tensor(origins.T, dtype=torch.float32),
        torch.tensor(-d.T, dtype=torch.float32),
        dist[:, 0],
    )


def check_hits(scene, points, normals, object_id, rng):
    st = scene_tensors(scene, 0)
    o, d, dist = aim(points, normals, rng)
    t, obj = intersect(st, o, d)
    assert bool((obj == object_id).all())
    np.testing.assert_allclose(t.numpy(), dist, rtol=1e-4, atol=1e-5)
    hit = surface_at(st, o, d, t, obj)
    np.testing.assert_allclose(hit.normal.T.numpy(), normals, atol=1e-4)
    np.testing.assert_allclose(hit.position.T.numpy(), points, atol=1e-4)
    t_only, none = intersect(st, o, d, with_object=False)
    assert none is None and torch.equal(t_only, t)


def test_sphere_hits():
    rng = np.random.default_rng(0)
    center, radius = np.array([0.3, -0.2, 0.5]), 1.7
    n = rng.normal(size=(400, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    check_hits(
        scene_of(Sphere("s", Fixed(tuple(center)), radius, RED)), center + radius * n, n, 0, rng
    )


def test_rectangle_hits():
    rng = np.random.default_rng(1)
    m = affine((0.2, 0.1, -0.3), ((1, 2, 3), 40.0), (1.5, 0.7, 1.0))
    rect = Rectangle.from_transform("r", m, RED)
    ab = rng.uniform(-1, 1, size=(400, 2))
    points = (
        np.asarray(rect.center) + ab[:, :1] * np.asarray(rect.u) + ab[:, 1:] * np.asarray(rect.v)
    )
    check_hits(scene_of(rect), points, np.tile(rect.normal, (400, 1)), 0, rng)


def test_box_hits():
    rng = np.random.default_rng(2)
    m = np.asarray(affine((0.5, -0.4, 0.2), ((0, 1, 0), 18.25), (0.3, 0.61, 0.3)))
    face = rng.integers(0, 6, size=600)
    local = rng.uniform(-0.98, 0.98, size=(600, 3))
    axis, sign = face // 2, np.where(face % 2 == 0, -1.0, 1.0)
    local[np.arange(600), axis] = sign
    points = local @ m[:, :3].T + m[:, 3]
    normals = np.linalg.inv(m[:, :3])[axis] * sign[:, None]  # rows of the inverse: face normals
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    check_hits(scene_of(Box("b", tuple(map(tuple, m)), RED)), points, normals, 0, rng)


def test_nearest_of_several_and_misses():
    scene = scene_of(
        Sphere("far", Fixed((0, 0, -5)), 1.0, RED), Sphere("near", Fixed((0, 0, 0)), 1.0, RED)
    )
    st = scene_tensors(scene, 0)
    o = torch.tensor([[0.0, 0.0, 5.0], [5.0, 5.0, 5.0]]).T
    d = torch.tensor([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]]).T
    t, obj = intersect(st, o, d)
    assert obj.tolist() == [1, -1]
    assert t[0].item() == pytest.approx(4.0) and torch.isinf(t[1])
    hit = surface_at(st, o, d, t, obj)
    assert hit.albedo[:, 1].tolist() == [0.0, 0.0, 0.0]  # escaped lanes hold zeros


def test_texture_lookup_uses_cells_of_the_rectangle():
    checker = Checker((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), 4, 2)
    rect = Rectangle("floor", (0, 0, 0), (2.0, 0, 0), (0, 0, -1.0), Diffuse(checker))
    st = scene_tensors(scene_of(rect), 0)
    # Texture u runs along +x (the u edge), v along -z (the v edge); cell (iu, iv) is 1 x 1.
    xs = torch.tensor([-1.5, -0.5, 0.5, -1.5])
    zs = torch.tensor([0.5, 0.5, 0.5, -0.5])
    o = torch.stack([xs, torch.ones(4), zs])
    d = torch.tensor([0.0, -1.0, 0.0])[:, None].expand(3, 4)
    t, obj = intersect(st, o, d)
    albedo = surface_at(st, o, d, t, obj).albedo[0]
    expected = [checker.texels()[iv, iu, 0] for iu, iv in [(0, 0), (1, 0), (2, 0), (0, 1)]]
    assert albedo.tolist() == expected == [1.0, 0.0, 1.0, 0.0]


def test_medium_interval():
    medium = HomogeneousMedium((-1, -1, -1), (1, 2, 1), 1.0, (0.5, 0.5, 0.5))
    st = scene_tensors(scene_of(medium=medium), 0)
    o = torch.tensor([[0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [5.0, 5.0, 5.0]]).T
    d = torch.tensor([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]).T
    t0, t1 = medium_interval(st, o, d)
    assert t0.tolist()[:2] == [4.0, 0.0] and t1.tolist()[:2] == [6.0, 2.0]
    assert t0[2] >= t1[2]  # a miss is an empty interval


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64, torch.int32, torch.int64])
def test_where_is_torch_where_bit_for_bit(dtype):
    """The bitwise blend equals torch.where: NaN payloads, -0, inf, scalars, broadcasting."""
    g = torch.Generator().manual_seed(3)
    n = 257
    mask = torch.rand(n, generator=g) > 0.5
    if dtype.is_floating_point:
        a = torch.randn(3, n, generator=g, dtype=dtype)
        b = torch.randn(3, n, generator=g, dtype=dtype)
        a[0, :9] = torch.tensor([float("nan"), -0.0, 0.0, float("inf"), -float("inf")] * 2)[:9]
        scalars = [0.0, -0.0, 1.0, -1.5, float("inf"), 0.1]
    else:
        a = torch.randint(-(2**31), 2**31 - 1, (3, n), generator=g).to(dtype)
        b = torch.randint(-(2**31), 2**31 - 1, (3, n), generator=g).to(dtype)
        scalars = [0, -1, 7]
    cases = [(a, b), (a[:, :1], b), (a, b[1]), (a[0], b[2])]
    cases += [(a, s) for s in scalars] + [(s, b[0]) for s in scalars]
    cases += [(scalars[1], scalars[2])]
    bits = {1: torch.uint8, 4: torch.int32, 8: torch.int64}
    for x, y in cases:
        want, got = torch.where(mask, x, y), where(mask, x, y)
        assert got.dtype == want.dtype and got.shape == want.shape
        size = want.element_size()
        assert torch.equal(got.view(bits[size]), want.view(bits[size]))


def test_where_falls_back_for_bool():
    mask = torch.tensor([True, False, True])
    x, y = torch.tensor([True, True, False]), torch.tensor([False, False, True])
    assert torch.equal(where(mask, x, y), torch.tensor([True, False, False]))


def test_box_normals_do_not_depend_on_the_lane_count():
    """The fast normalization (per-row norms) equals torch's norm for every lane count."""
    box = Box("box", affine((0.3, -0.2, 0.1), ((1.0, 2.0, 0.5), 33.0), (0.7, 1.3, 0.4)), RED)
    st = scene_tensors(scene_of(box), 0)
    rng = np.random.default_rng(4)
    points = torch.tensor(rng.normal(size=(3, 300)), dtype=torch.float32)
    o = points + 5.0
    d = -o / o.norm(dim=0, keepdim=True)
    t, obj = intersect(st, o, d)
    full = surface_at(st, o, d, t, obj).normal
    for n in (1, 2, 3, 17, 300):
        part = surface_at(st, o[:, :n], d[:, :n], t[:n], obj[:n]).normal
        assert torch.equal(part, full[:, :n])


@pytest.mark.parametrize("name", ["cornell", "snooker", "medium"])
def test_constants_by_gather_equal_the_running_select(name):
    """The eager gather of per-object constants equals its select twin, bit for bit."""
    from renderers import get_scene
    from renderers.geometry import _constants_by_gather, _constants_by_select

    st = scene_tensors(get_scene(name), 1)
    obj = torch.arange(-1, st.num_objects).repeat(5)
    p = torch.zeros(3, obj.shape[0])
    for fast, slow in zip(_constants_by_gather(st, obj), _constants_by_select(st, obj, p)):
        assert torch.equal(fast.view(torch.int32), slow.view(torch.int32))
