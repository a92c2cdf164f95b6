"""The spatio-temporally coherent pixels: where the seed paper says its temporal method works.

Heitz & Belcour's talk shows the error distributed as blue noise "in spatio-temporally coherent
regions" (the checkerboard's squares, the middle of the teapot) and as white noise at object
borders (docs/METHODS.md, section 11). :func:`coherent_mask` makes that region a measurable set of
pixels from a frame's auxiliary buffers, so that every metric can be restricted to it, as it can
to object edges (:func:`bnerr.metrics.edge_mask`).

A pixel is coherent when, in its ``(2r + 1) x (2r + 1)`` neighbourhood (5 x 5 by default):

- every pixel shows the same object (``object_id``, the background excluded);
- every normal is within ``normal_cos`` (cosine) of the centre's;
- every depth is within ``depth_tol`` (relative) of the centre's;
- every albedo luminance is within ``albedo_tol`` (relative) of the centre's (no texture edge);
- every pixel was visible at the same surface in the previous frame: the nearest pixel to
  ``p - motion(p)`` is on screen and shows the same object, with a normal within ``normal_cos``
  and a depth within ``depth_tol`` (no disocclusion). Without a previous frame (a static camera
  measured against itself) this test is skipped.

Pixels closer than ``r`` to the image border are never coherent (their window leaves the image).

Not for: object edges (:func:`bnerr.metrics.edge_mask`).
"""

from __future__ import annotations

import torch

from bnerr.color import luminance
from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_range
from bnerr.frame import Frame

__all__ = ["REGION_BUFFERS", "coherent_mask"]

_AUX = ("object_id", "normal", "depth", "albedo")

#: The auxiliary buffers of the reference each pixel region is computed from: ``all`` none,
#: ``edges`` and ``unlit`` the object ids, ``coherent`` the four of :func:`coherent_mask`. A
#: renderer or a frame folder without them cannot measure the region.
REGION_BUFFERS: dict[str, tuple[str, ...]] = {
    "all": (),
    "edges": ("object_id",),
    "unlit": ("object_id",),
    "coherent": ("albedo", "normal", "depth", "object_id"),
}


def _buffers(frame: Frame, name: str) -> dict[str, torch.Tensor]:
    missing = [b for b in _AUX if getattr(frame, b) is None]
    if missing:
        raise ValueRangeError(
            f"coherent_mask: expected {name} with {', '.join(_AUX)} buffers, got none for "
            f"{', '.join(missing)}"
        )
    out = {b: getattr(frame, b).to(torch.float64) for b in _AUX}
    out["albedo"] = luminance(out["albedo"], keepdim=True)
    return out


def _window_agrees(
    aux: dict[str, torch.Tensor], r: int, cos: float, dtol: float, atol: float
) -> torch.Tensor:
    """``[H, W]`` bool: every pixel of the centre's window agrees with the centre."""
    ids, nrm, dep, alb = aux["object_id"][0], aux["normal"], aux["depth"][0], aux["albedo"][0]
    h, w = ids.shape
    ok = torch.zeros((h, w), dtype=torch.bool, device=ids.device)
    if h <= 2 * r or w <= 2 * r:
        return ok
    ys, xs = slice(r, h - r), slice(r, w - r)
    c_id, c_n, c_d, c_a = ids[ys, xs], nrm[:, ys, xs], dep[ys, xs], alb[ys, xs]
    inner = c_id >= 0
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            sy, sx = slice(r + dy, h - r + dy), slice(r + dx, w - r + dx)
            inner &= ids[sy, sx] == c_id
            inner &= (nrm[:, sy, sx] * c_n).sum(0) >= cos
            inner &= (dep[sy, sx] - c_d).abs() <= dtol * c_d
            inner &= (alb[sy, sx] - c_a).abs() <= atol * c_a.clamp_min(1e-3)
    ok[ys, xs] = inner
    return ok


def _seen_before(
    aux: dict[str, torch.Tensor],
    prev: dict[str, torch.Tensor],
    motion: torch.Tensor,
    cos: float,
    dtol: float,
) -> torch.Tensor:
    """``[H, W]`` bool: the pixel's surface was visible at ``p - motion(p)`` in the previous
    frame."""
    ids = aux["object_id"][0]
    h, w = ids.shape
    dev = ids.device
    sy = torch.arange(h, device=dev, dtype=torch.float64)[:, None] - motion[1].double()
    sx = torch.arange(w, device=dev, dtype=torch.float64)[None, :] - motion[0].double()
    iy, ix = torch.round(sy).long(), torch.round(sx).long()
    inside = (iy >= 0) & (iy < h) & (ix >= 0) & (ix < w)
    iy, ix = iy.clamp(0, h - 1), ix.clamp(0, w - 1)
    same = prev["object_id"][0][iy, ix] == ids
    same &= (prev["normal"][:, iy, ix] * aux["normal"]).sum(0) >= cos
    depth = aux["depth"][0]
    same &= (prev["depth"][0][iy, ix] - depth).abs() <= dtol * depth
    return inside & same


def coherent_mask(
    frame: Frame,
    prev: Frame | None = None,
    *,
    radius: int = 2,
    normal_cos: float = 0.9,
    depth_tol: float = 0.1,
    albedo_tol: float = 0.1,
) -> torch.Tensor:
    """The spatio-temporally coherent pixels of ``frame``: ``[H, W]`` bool on its device.

    Args:
        frame: the frame (a reference: its buffers are the scene's, not a seed's) with
            ``object_id``, ``normal``, ``depth`` and ``albedo``; its ``motion`` (from the previous
            frame to this one, in pixels) is used with ``prev``.
        prev: the previous frame with the same buffers, or None to skip the disocclusion test
            (a static camera).
        radius: the window's half size (2: 5 x 5 pixels), >= 1.
        normal_cos: the smallest cosine between a neighbour's normal and the centre's.
        depth_tol, albedo_tol: the largest relative difference of depth, and of albedo
            luminance, from the centre's.

    Raises:
        ValueRangeError: a buffer is missing, a tolerance is out of range, or ``prev`` is given
            and ``frame`` has no motion buffer.
        ShapeError: ``prev`` does not have ``frame``'s size.
    """
    check_positive_int(radius, "radius")
    cos = check_range(normal_cos, "normal_cos", -1.0, 1.0)
    dtol = check_range(depth_tol, "depth_tol", 0.0, float("inf"))
    atol = check_range(albedo_tol, "albedo_tol", 0.0, float("inf"))
    aux = _buffers(frame, "frame")
    ok = _window_agrees(aux, radius, cos, dtol, atol)
    if prev is None:
        return ok
    if (prev.height, prev.width) != (frame.height, frame.width):
        raise ShapeError(
            f"coherent_mask: expected prev of {frame.width} x {frame.height} like frame, got "
            f"{prev.width} x {prev.height}"
        )
    if frame.motion is None:
        raise ValueRangeError("coherent_mask: expected frame with a motion buffer, got none")
    seen = _seen_before(aux, _buffers(prev, "prev"), frame.motion, cos, dtol)
    size = 2 * radius + 1
    unseen = torch.nn.functional.max_pool2d(
        (~seen)[None, None].to(torch.float32), size, stride=1, padding=radius
    )[0, 0]
    return ok & (unseen == 0)
