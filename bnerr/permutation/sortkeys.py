"""Sort keys and group labels for the sorting pass (docs/METHODS.md, sections 4 and 8).

Heitz & Belcour 2019 sort each block by the frame's luminance, which assumes every pixel of a
block has the same expected value, so that a difference in value is a difference in error.
Texture, shading gradients and edges break that. The keys here estimate each pixel's *error*
instead; the group labels restrict a block's sort to pixels that look alike.

**Keys** (:func:`sort_key`, ``[H, W]`` float32, passed to
:func:`bnerr.permutation.permute.sort_pass` as its ``values``):

- ``"luminance"``: ``lum(I)``, Rec. 709 (:func:`bnerr.color.luminance`), bit for bit the key
  the sorting pass takes from an RGB frame: Heitz & Belcour's.
- ``"residual"``: ``lum(I) - S(lum(I))``, with ``S`` the smoothing below: an estimate of the
  pixel's error.
- ``"relative"``: ``residual / (|S(lum(I))| + eps)``: the error relative to the local level, so
  that a bright region does not own the extremes of every mixed block.
- ``demodulate=True`` (any kind): the radiance is divided by the albedo first, per channel where
  the albedo is > 0 (kept elsewhere), so that a texture does not read as a difference in error.

**The smoothing S** (:func:`smooth_luminance`): at pixel p, the mean of the finite values of the
*other* pixels q in the ``(2r + 1)^2`` window (r = 1 by default: 8 neighbours) with the same
label as p (:func:`group_labels`: object id, normal bin, optionally depth bin; no labels: every
neighbour); p's own value where no neighbour qualifies (residual 0). Why this one: (1) leaving p
out makes ``S(p)`` independent of p's own noise, so the residual is p's error minus the mean
error of its neighbours (whose variance shrinks as 1/n); (2) a cross (joint) box filter guided by
labels keeps silhouettes, creases and other objects out of the estimate, which are exactly what
luminance mistakes for error, and demodulation takes care of texture; (3) it costs a fixed ~3
elementwise passes per tap, no sort, no data-dependent control flow, integer label equality
(exact on every device) and float32 additions in a fixed order, so it is deterministic and
identical on every device. A continuous joint bilateral (weights from normal and albedo
distances) was tried first and cost several times as much per tap (1080p, one loaded thread:
1.6 to 4.6 s against 0.27 s) for an estimate that only differs near feature edges. The block
is 4 x 4, so a 3 x 3 or 5 x 5 window is the scale the sort compares at.

**Groups** (:func:`group_labels`, ``[H, W]`` int64, :func:`bnerr.permutation.permute.sort_pass`'s
``groups``): the object id, optionally with the normal's dominant axis and sign (6 bins) and a
logarithmic depth bin folded in.

Slow twins: :func:`smooth_luminance_reference` (Python loops over pixels in numpy float32, the
same additions in the same order) and :func:`group_labels_reference`.

Not for: denoising (the smoothed image is only used to rank pixels inside a block).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from bnerr.color import luminance
from bnerr.errors import (
    FLOAT_DTYPES,
    INT_DTYPES,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_name,
    check_positive_int,
    check_range,
    check_shape,
    check_tensor,
)
from bnerr.frame import Frame

__all__ = [
    "KINDS",
    "demodulated",
    "frame_sort_key",
    "group_labels",
    "group_labels_reference",
    "smooth_luminance",
    "smooth_luminance_reference",
    "sort_key",
]

#: Kinds of :func:`sort_key`.
KINDS: tuple[str, ...] = ("luminance", "residual", "relative")
_MAX_RADIUS = 4


def _check_buffer(
    x: object, channels: int, name: str, h: int, w: int, device: torch.device
) -> torch.Tensor:
    """A ``[channels, H, W]`` floating buffer like the color's."""
    x = check_tensor(x, name)
    size = check_shape(x, f"{channels} H W", name)
    check_dtype(x, FLOAT_DTYPES, name)
    if (size["H"], size["W"]) != (h, w):
        raise ShapeError(f"{name}: expected H x W = {h} x {w}, got {size['H']} x {size['W']}")
    if x.device != device:
        raise ValueRangeError(f"{name}: expected a tensor on {device}, got {x.device}")
    return x


def _check_labels(labels: object, h: int, w: int, device: torch.device) -> torch.Tensor:
    labels = check_tensor(labels, "labels")
    size = check_shape(labels, "H W", "labels")
    check_dtype(labels, INT_DTYPES, "labels")
    if (size["H"], size["W"]) != (h, w):
        raise ShapeError(f"labels: expected H x W = {h} x {w}, got {size['H']} x {size['W']}")
    if labels.device != device:
        raise ValueRangeError(f"labels: expected a tensor on {device}, got {labels.device}")
    return labels


def demodulated(color: torch.Tensor, albedo: torch.Tensor) -> torch.Tensor:
    """``color / albedo`` per channel where ``albedo > 0``, ``color`` elsewhere (``[3, H, W]``
    float32, a new tensor)."""
    c, a = color.to(torch.float32), albedo.to(torch.float32)
    return torch.where(a > 0, c / torch.where(a > 0, a, 1.0), c)


def _pad(x: torch.Tensor, r: int, fill: float | bool) -> torch.Tensor:
    out = x.new_full((x.shape[0] + 2 * r, x.shape[1] + 2 * r), fill)
    out[r : r + x.shape[0], r : r + x.shape[1]] = x
    return out


def smooth_luminance(
    lum: torch.Tensor, labels: torch.Tensor | None = None, radius: int = 1
) -> torch.Tensor:
    """Leave-one-out mean of the finite neighbours with the same label (the module's ``S``).

    Args:
        lum: ``[H, W]`` floating, the (possibly demodulated) luminance.
        labels: ``[H, W]`` integer (:func:`group_labels`) or None (every neighbour qualifies).
        radius: r in 1..4, the window is ``(2r + 1)^2``.

    Returns:
        ``[H, W]`` float32 on ``lum``'s device: the qualifying neighbours' values added in
        float32 in the window's raster order, divided by their count; ``lum`` itself where none
        qualifies.
    """
    check_shape(check_tensor(lum, "lum"), "H W", "lum")
    check_dtype(lum, FLOAT_DTYPES, "lum")
    radius = check_positive_int(radius, "radius")
    if radius > _MAX_RADIUS:
        raise ValueRangeError(f"radius: expected an integer in [1, {_MAX_RADIUS}], got {radius}")
    h, w = lum.shape
    lum = lum.to(torch.float32)
    finite = torch.isfinite(lum)
    r = radius
    values = _pad(torch.where(finite, lum, 0.0), r, 0.0)  # 0 where not finite or off screen
    usable = _pad(finite, r, False)
    same = None if labels is None else _pad(_check_labels(labels, h, w, lum.device), r, 0)
    acc = torch.zeros_like(lum)
    count = torch.zeros_like(lum)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            if dy == 0 and dx == 0:
                continue
            window = (slice(r + dy, r + dy + h), slice(r + dx, r + dx + w))
            ok = usable[window]
            if same is not None:
                ok = ok & (same[window] == labels)
                acc.add_(torch.where(ok, values[window], 0.0))
            else:  # values are already 0 where not usable: adding 0 changes nothing
                acc.add_(values[window])
            count.add_(ok)
    return torch.where(count > 0, acc / count.clamp(min=1), lum)


def sort_key(
    color: torch.Tensor,
    kind: str = "luminance",
    *,
    demodulate: bool = False,
    albedo: torch.Tensor | None = None,
    labels: torch.Tensor | None = None,
    radius: int = 1,
    eps: float = 1e-3,
) -> torch.Tensor:
    """The sorting pass's key for one frame (see the module docstring).

    Args:
        color: ``[3, H, W]`` floating linear radiance (the frame).
        kind: ``"luminance"``, ``"residual"`` or ``"relative"``.
        demodulate: divide by ``albedo`` first (needs ``albedo [3, H, W]``).
        labels: ``[H, W]`` integer, the smoothing's guide (:func:`group_labels`), or None.
        radius: the smoothing window's radius (1: 3 x 3).
        eps: the ``"relative"`` kind's ``eps`` in ``residual / (|S| + eps)``, in radiance units.

    Returns:
        ``[H, W]`` float32 on ``color``'s device. NaN or infinite pixels keep a non-finite key
        (the sorting pass orders them last) and are left out of their neighbours' smoothing.

    Raises:
        ShapeError, DtypeError: buffers of the wrong shape or dtype. UnknownNameError: an unknown
        kind. ValueRangeError: ``demodulate`` without albedo, a bad radius or eps.
    """
    check_shape(check_tensor(color, "color"), "3 H W", "color")
    check_dtype(color, FLOAT_DTYPES, "color")
    kind = check_name(kind, KINDS, "sort key")
    eps = check_range(eps, "eps", 0.0, math.inf)
    if demodulate:
        if albedo is None:
            raise ValueRangeError("demodulate: expected an albedo buffer, got albedo=None")
        _check_buffer(albedo, 3, "albedo", color.shape[1], color.shape[2], color.device)
        color = demodulated(color, albedo)
    lum = luminance(color)
    if kind == "luminance":
        return lum
    smooth = smooth_luminance(lum, labels, radius)
    residual = lum - smooth
    return residual if kind == "residual" else residual / (smooth.abs() + eps)


def frame_sort_key(
    frame: Frame,
    kind: str = "luminance",
    demodulate: bool = False,
    *,
    labels: torch.Tensor | None = None,
    radius: int = 1,
    eps: float = 1e-3,
) -> torch.Tensor:
    """:func:`sort_key` of a :class:`bnerr.frame.Frame` (``[H, W]`` float32).

    ``labels`` None: :func:`group_labels` of the frame's object id and normal where it has them
    (no guide otherwise); pass the labels the sort pass gets, to compute them once.
    """
    if labels is None and kind != "luminance" and frame.object_id is not None:
        labels = group_labels(frame.object_id, frame.normal)
    return sort_key(
        frame.color,
        kind,
        demodulate=demodulate,
        albedo=frame.albedo,
        labels=labels,
        radius=radius,
        eps=eps,
    )


def smooth_luminance_reference(
    lum: torch.Tensor, labels: torch.Tensor | None = None, radius: int = 1
) -> torch.Tensor:
    """The slow twin of :func:`smooth_luminance`: a Python loop over pixels and neighbours, in
    numpy float32 scalars with the same additions in the same order. For tests."""
    h, w = lum.shape
    f32 = np.float32
    v = lum.to(torch.float32).cpu().numpy()
    lab = None if labels is None else labels.cpu().tolist()
    out = np.empty((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            acc, count = f32(0.0), f32(0.0)
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    qy, qx = y + dy, x + dx
                    if (dy, dx) == (0, 0) or not (0 <= qy < h and 0 <= qx < w):
                        continue
                    if not np.isfinite(v[qy, qx]):
                        continue
                    if lab is not None and lab[qy][qx] != lab[y][x]:
                        continue
                    acc, count = f32(acc + v[qy, qx]), f32(count + 1)
            out[y, x] = f32(acc / count) if count > 0 else v[y, x]
    return torch.from_numpy(out).to(lum.device)


# --------------------------------------------------------------------------------------------------
# Group labels


def _normal_bin(normal: torch.Tensor) -> torch.Tensor:
    """0..5: the dominant axis (the first of equal magnitudes) times 2, plus 1 if it is negative;
    6 for a zero or non-finite normal. Elementwise comparisons only (an argmax over the channel
    dimension costs several times more)."""
    n = normal.to(torch.float32)
    a0, a1, a2 = n.abs().unbind(0)
    first = (a0 >= a1) & (a0 >= a2)
    second = ~first & (a1 >= a2)
    axis = torch.where(first, 0, torch.where(second, 1, 2))
    value = torch.where(first, n[0], torch.where(second, n[1], n[2]))
    bad = ~(torch.isfinite(a0) & torch.isfinite(a1) & torch.isfinite(a2))
    bad |= (a0 == 0) & (a1 == 0) & (a2 == 0)
    return torch.where(bad, 6, axis * 2 + (value < 0))


def group_labels(
    object_id: torch.Tensor,
    normal: torch.Tensor | None = None,
    depth: torch.Tensor | None = None,
    *,
    depth_bins_per_octave: int = 4,
) -> torch.Tensor:
    """Group labels for :func:`bnerr.permutation.permute.sort_pass`: object id, normal, depth bin.

    Args:
        object_id: ``[1, H, W]`` floating (the Frame's: -1 background), rounded to an integer;
            NaN reads as -2.
        normal: ``[3, H, W]`` floating or None: folds in the dominant axis and sign (6 bins, a
            7th for zero or non-finite normals).
        depth: ``[1, H, W]`` floating or None: folds in a bin per octave of depth (its binary
            exponent e, ``depth = m 2^e`` with m in [0.5, 1)) split into k =
            ``depth_bins_per_octave`` equal steps of m (exact: ``frexp``, no logarithm, so every
            device agrees); depth <= 0 or non-finite gets its own bin.

    Returns:
        ``[H, W]`` int64 on ``object_id``'s device; equal labels mean same object, same normal
        bin and same depth bin.
    """
    check_shape(check_tensor(object_id, "object_id"), "1 H W", "object_id")
    check_dtype(object_id, FLOAT_DTYPES, "object_id")
    k = check_positive_int(depth_bins_per_octave, "depth_bins_per_octave")
    h, w = object_id.shape[1:]
    oid = object_id[0].to(torch.float64)
    oid = torch.where(torch.isnan(oid), -2.0, oid).round_().clamp_(-(2**40), 2**40)
    label = oid.to(torch.int64) + 2  # >= 0 for the Frame's ids
    if normal is not None:
        normal = _check_buffer(normal, 3, "normal", h, w, object_id.device)
        label = label * 8 + _normal_bin(normal)
    if depth is not None:
        d = _check_buffer(depth, 1, "depth", h, w, object_id.device)[0].to(torch.float64)
        good = torch.isfinite(d) & (d > 0)
        mantissa, exponent = torch.frexp(torch.where(good, d, 1.0))
        step = torch.floor((mantissa * 2 - 1) * k).to(torch.int64)
        b = (exponent.to(torch.int64) * k + step).clamp(-4096, 4095)
        label = label * 8193 + torch.where(good, b + 4096, 8192)
    return label


def group_labels_reference(
    object_id: torch.Tensor,
    normal: torch.Tensor | None = None,
    depth: torch.Tensor | None = None,
    *,
    depth_bins_per_octave: int = 4,
) -> torch.Tensor:
    """The slow twin of :func:`group_labels` (Python loops over pixels)."""
    h, w = object_id.shape[1:]
    out = torch.empty((h, w), dtype=torch.int64)
    for y in range(h):
        for x in range(w):
            o = float(object_id[0, y, x])
            label = int(round(max(min(-2.0 if o != o else o, 2.0**40), -(2.0**40)))) + 2
            if normal is not None:
                n = [float(normal[c, y, x]) for c in range(3)]
                if not all(map(math.isfinite, n)) or all(v == 0 for v in n):
                    nb = 6
                else:
                    axis = max(range(3), key=lambda c: (abs(n[c]), -c))
                    nb = axis * 2 + (n[axis] < 0)
                label = label * 8 + nb
            if depth is not None:
                d = float(depth[0, y, x])
                if math.isfinite(d) and d > 0:
                    m, e = math.frexp(d)
                    db = e * depth_bins_per_octave + math.floor((m * 2 - 1) * depth_bins_per_octave)
                    db = min(max(db, -4096), 4095) + 4096
                else:
                    db = 8192
                label = label * 8193 + db
            out[y, x] = label
    return out.to(object_id.device)
