"""Pinhole camera: primary rays for continuous pixel positions, and projection back to pixels.

Conventions match Mitsuba 3's ``perspective`` sensor (``look_at`` pose, ``fov_axis``): the camera
looks along ``forward = normalize(target - origin)``, ``right = normalize(forward x up)``, and
continuous pixel coordinates run from (0, 0) at the top-left corner of the image to (W, H) at the
bottom-right, pixel (x, y) covering [x, x + 1) x [y, y + 1). Mitsuba builds the same rays from
``sample_to_camera``; we skip its near clip (0.01 by default), which no scene here comes close to.

Not for: depth of field, lens distortion, or orthographic views.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from renderers.geometry import where
from renderers.scene import Camera

__all__ = ["CameraFrame", "camera_frame", "generate_rays", "project"]


@dataclass(frozen=True)
class CameraFrame:
    """One camera pose resolved for a ``width x height`` image.

    Attributes:
        origin, right, up, forward: ``[3]`` float32 tensors (orthonormal right, up, forward).
        tan_x, tan_y: tangents of the half field of view along x and y.
        width, height: image size in pixels.
    """

    origin: torch.Tensor
    right: torch.Tensor
    up: torch.Tensor
    forward: torch.Tensor
    tan_x: float
    tan_y: float
    width: int
    height: int


def camera_frame(
    camera: Camera, t: int, width: int, height: int, device: torch.device | str = "cpu"
) -> CameraFrame:
    """Resolve ``camera`` at frame ``t`` for a ``width x height`` image on ``device``."""
    origin, target, up = (np.asarray(v, dtype=np.float64) for v in camera.pose(t))
    forward = target - origin
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    aspect = width / height
    axis = camera.fov_axis
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    tan_half = math.tan(math.radians(camera.fov) / 2)
    tan_x, tan_y = (tan_half, tan_half / aspect) if axis == "x" else (tan_half * aspect, tan_half)

    def as_tensor(v: np.ndarray) -> torch.Tensor:
        return torch.tensor(v, dtype=torch.float32, device=device)

    return CameraFrame(
        as_tensor(origin),
        as_tensor(right),
        as_tensor(true_up),
        as_tensor(forward),
        tan_x,
        tan_y,
        width,
        height,
    )


def generate_rays(
    cam: CameraFrame, px: torch.Tensor, py: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Primary rays through continuous pixel positions.

    Args:
        cam: the resolved camera.
        px, py: ``[N]`` float32 pixel coordinates (x right, y down), in [0, W] x [0, H].

    Returns:
        ``origin [3, N]`` and unit ``direction [3, N]`` (component-major, like every ray in
        :mod:`renderers`).
    """
    # The same operations in the same order as the plain expressions (kept in the comments), in
    # place where a temporary can be reused: fewer fresh [3, N] buffers, bit-identical results.
    sx = torch.mul(px, 2.0).div_(cam.width).sub_(1.0).mul_(cam.tan_x)  # (2 px / W - 1) tan_x
    sy = torch.mul(py, 2.0).div_(cam.height).neg_().add_(1.0).mul_(cam.tan_y)  # (1 - 2 py / H) ..
    # sx right + sy up + forward, then times rsqrt(sx^2 + sy^2 + 1) (right, up, forward orthonormal)
    direction = sx * cam.right[:, None]
    direction += sy * cam.up[:, None]
    direction += cam.forward[:, None]
    norm = torch.mul(sx, sx).add_(torch.mul(sy, sy)).add_(1.0).rsqrt_()
    direction *= norm
    return cam.origin[:, None].expand_as(direction), direction


def project(
    cam: CameraFrame, points: torch.Tensor, *, directions: bool = False
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Continuous pixel coordinates of world points (or of directions, i.e. points at infinity).

    Args:
        cam: the resolved camera.
        points: ``[3, N]`` world positions, or world directions if ``directions``.

    Returns:
        ``px [N]``, ``py [N]`` and ``in_front [N]`` (bool: strictly in front of the camera; the
        coordinates are meaningless elsewhere).
    """
    v = points if directions else points - cam.origin[:, None]
    z = cam.forward @ v
    in_front = z > 0
    z_safe = where(in_front, z, torch.ones_like(z))
    sx = (cam.right @ v) / (z_safe * cam.tan_x)
    sy = (cam.up @ v) / (z_safe * cam.tan_y)
    return (sx + 1.0) * 0.5 * cam.width, (1.0 - sy) * 0.5 * cam.height, in_front
