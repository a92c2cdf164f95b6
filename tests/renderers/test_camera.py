"""Tests for renderers.camera: rays and projection are inverse; fov and axes as in Mitsuba."""

import math

import pytest
import torch

from renderers.camera import camera_frame, generate_rays, project
from renderers.scene import Camera, Fixed


def make_camera(fov_axis="x", fov=50.0) -> Camera:
    return Camera(Fixed((1.0, 2.0, 5.0)), Fixed((0.0, 0.5, 0.0)), (0.0, 1.0, 0.0), fov, fov_axis)


@pytest.mark.parametrize("fov_axis", ["x", "y", "smaller", "larger"])
def test_project_inverts_generate_rays(fov_axis):
    cam = camera_frame(make_camera(fov_axis), 0, 40, 30)
    g = torch.Generator().manual_seed(0)
    px, py = torch.rand(500, generator=g) * 40, torch.rand(500, generator=g) * 30
    o, d = generate_rays(cam, px, py)
    assert o.shape == d.shape == (3, 500)
    torch.testing.assert_close(d.norm(dim=0), torch.ones(500))
    for depth in (0.5, 7.0):
        x, y, front = project(cam, o + depth * d)
        assert bool(front.all())
        torch.testing.assert_close(x, px, atol=2e-4, rtol=0)
        torch.testing.assert_close(y, py, atol=2e-4, rtol=0)
    x, y, front = project(cam, d, directions=True)
    torch.testing.assert_close(x, px, atol=2e-4, rtol=0)
    assert not bool(project(cam, -d, directions=True)[2].any())


def test_field_of_view_and_orientation():
    width, height = 64, 32
    cam = camera_frame(make_camera("x", 60.0), 0, width, height)
    _, d = generate_rays(
        cam, torch.tensor([0.0, width / 2, width / 2]), torch.tensor([height / 2, height / 2, 0.0])
    )
    forward = cam.forward
    # The left edge of the image is fov/2 away from the view direction along x ...
    assert math.degrees(math.acos(float(d[:, 0] @ forward))) == pytest.approx(30.0, abs=1e-3)
    assert float(d[:, 0] @ cam.right) < 0  # ... on the left
    torch.testing.assert_close(d[:, 1], forward)
    # ... and the top edge is tan^-1(tan(30 deg) * H / W) away, upwards.
    expected = math.degrees(math.atan(math.tan(math.radians(30.0)) * height / width))
    assert math.degrees(math.acos(float(d[:, 2] @ forward))) == pytest.approx(expected, abs=1e-3)
    assert float(d[:, 2] @ cam.up) > 0


def test_smaller_and_larger_axes():
    wide = camera_frame(make_camera("smaller"), 0, 64, 32)
    assert wide.tan_y == pytest.approx(math.tan(math.radians(25.0)))
    tall = camera_frame(make_camera("smaller"), 0, 32, 64)
    assert tall.tan_x == pytest.approx(math.tan(math.radians(25.0)))
    assert camera_frame(make_camera("larger"), 0, 64, 32).tan_x == pytest.approx(
        math.tan(math.radians(25.0))
    )
