"""Bijective reprojection of the seed image along screen-space motion (docs/METHODS.md, section 8).

Heitz & Belcour 2019 name it as future work: move each pixel's seed with its surface to the next
frame before the sorting pass, so that a seed keeps meeting the values it was sorted by, and keep
the seed image a permutation of the initial seeds (no seed lost or duplicated, ever).

:func:`reproject_seeds` does it in one of two directions:

- ``"forward"`` (push): ``motion`` is the motion from frame t to frame t + 1 at frame t's pixels;
  the seed at (x, y) moves to ``(x + motion[0], y + motion[1])``, rounded to the nearest pixel
  (``floor(v + 0.5)``, in float64). A renderer rarely has that buffer; the constant-velocity
  prediction is frame t's own :class:`bnerr.frame.Frame` ``motion`` (t-1 -> t: a pixel that moved
  by m last frame moves by m again), so ``reproject_seeds(seeds, frame.motion, depth)`` is the
  cheap choice. ``depth`` is frame t's (the surface that carries the seed).
- ``"backward"`` (pull): ``motion`` is frame t + 1's own motion buffer (the Frame convention:
  pixel q of frame t + 1 was at ``q - motion(q)`` in frame t), e.g. from the renderer's cheap
  primary-ray pass at the next camera pose; pixel q claims the seed at ``q - motion(q)``, rounded
  likewise. ``depth`` is frame t + 1's (the surface that claims).

**Collisions.** Several claims on one pixel (forward: seeds landing on one target; backward:
targets pulling one source): the claim whose surface is nearer (smaller depth) wins; equal depths:
the lower pixel index (``y * W + x`` of the claiming pixel: the source forward, the target
backward) wins. The others go to the pool. **Pool.** Seeds that moved off screen, lost a
collision or were pulled by nobody, ordered by their source pixel index, go one by one to the
pixels nobody claimed (disocclusions), in raster order. The result is always a permutation of
the input seeds.

**Non-finite input.** NaN in either motion component: the pixel does not move (both components
read as 0). Infinite motion: off screen, to the pool. NaN depth: farther than every number (after
``+inf``), so it loses every collision against a real depth. Depth order is the float32 order of
:mod:`bnerr.permutation.permute` (``-0.0 == +0.0``). The Frame's depth holds 0 where the ray escaped
(the background would win every collision): pass :func:`collision_depth` instead, which puts the
background at ``+inf``.

**Where a strategy calls it.** Per frame t: render S_t, sort against M_t, retarget at o_t (the
mask-space passes, in frame t's screen space), then ``reproject_seeds`` to carry the result to
frame t + 1's screen. Only the reprojection looks at motion; the sort and retarget passes need no
change.

- :func:`reproject_seeds`: the op (vectorised: one ``scatter_reduce`` with ``amin`` resolves the
  collisions, ``nonzero`` lists the pool and the free pixels; device-following, deterministic).
- :func:`reproject_sources`: the same as gather indices (``out = seeds.view(-1)[src]``).
- :func:`reproject_seeds_reference`: the slow, obviously correct twin (Python loops).

Not for: sub-pixel reprojection or blending (a seed is an integer that lands on one pixel).
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import (
    FLOAT_DTYPES,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_name,
    check_shape,
    check_tensor,
)
from bnerr.permutation.permute import ordered_keys  # the sorting pass's float32 order, one copy

__all__ = [
    "DIRECTIONS",
    "collision_depth",
    "reproject_seeds",
    "reproject_seeds_reference",
    "reproject_sources",
]

#: Directions of :func:`reproject_seeds`.
DIRECTIONS: tuple[str, ...] = ("forward", "backward")
_INDEX_BITS = 31  # pixel indices below 2^31, under a 32-bit depth key: 63 bits in all


def _check_seeds(seeds: object, motion: object) -> None:
    """Seeds ``[H, W]`` int64 like ``motion [2, H, W]``, on its device."""
    seeds = check_tensor(seeds, "seeds")
    size = check_shape(seeds, "H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    motion = check_tensor(motion, "motion")
    msize = check_shape(motion, "2 H W", "motion")
    if (msize["H"], msize["W"]) != (size["H"], size["W"]):
        raise ShapeError(
            f"motion: expected H x W = {size['H']} x {size['W']} like seeds, "
            f"got {msize['H']} x {msize['W']}"
        )
    if motion.device != seeds.device:
        raise ValueRangeError(
            f"motion: expected a tensor on {seeds.device} like seeds, got {motion.device}"
        )


def _check_inputs(motion: object, depth: object) -> tuple[int, int, torch.Tensor | None]:
    """``(H, W, depth [H, W] or None)`` after checking shapes, dtypes and devices."""
    motion = check_tensor(motion, "motion")
    msize = check_shape(motion, "2 H W", "motion")
    check_dtype(motion, FLOAT_DTYPES, "motion")
    h, w = msize["H"], msize["W"]
    if h * w >= 2**_INDEX_BITS:
        raise ValueRangeError(f"motion: expected fewer than 2^31 pixels, got {h} x {w}")
    if depth is None:
        return h, w, None
    depth = check_tensor(depth, "depth")
    if depth.ndim == 3:
        dsize = check_shape(depth, "1 H W", "depth")
    else:
        dsize = check_shape(depth, "H W", "depth")
    check_dtype(depth, FLOAT_DTYPES, "depth")
    if (dsize["H"], dsize["W"]) != (h, w):
        raise ShapeError(
            f"depth: expected H x W = {h} x {w} like motion, got {dsize['H']} x {dsize['W']}"
        )
    if depth.device != motion.device:
        raise ValueRangeError(
            f"depth: expected a tensor on {motion.device} like motion, got {depth.device}"
        )
    return h, w, depth.reshape(h, w)


def collision_depth(depth: torch.Tensor, object_id: torch.Tensor | None = None) -> torch.Tensor:
    """The depth to resolve collisions with: ``+inf`` where the ray escaped.

    Args:
        depth: ``[1, H, W]`` floating, the Frame's first-hit distance (0 where escaped).
        object_id: ``[1, H, W]`` the Frame's object index (-1 where escaped), or None (then a
            depth of exactly 0 marks the background).

    Returns:
        ``[1, H, W]`` float32, a new tensor on ``depth``'s device.
    """
    size = check_shape(check_tensor(depth, "depth"), "1 H W", "depth")
    check_dtype(depth, FLOAT_DTYPES, "depth")
    if object_id is not None:
        osize = check_shape(check_tensor(object_id, "object_id"), "1 H W", "object_id")
        if osize != size or object_id.device != depth.device:
            raise ShapeError(
                f"object_id: expected [1, {size['H']}, {size['W']}] on {depth.device} like depth, "
                f"got {list(object_id.shape)} on {object_id.device}"
            )
    escaped = depth == 0 if object_id is None else object_id < 0
    return depth.to(torch.float32).masked_fill(escaped, math.inf)


def _claims(motion: torch.Tensor, h: int, w: int, sign: float) -> tuple[torch.Tensor, torch.Tensor]:
    """``(landing [H*W] int64, on_screen [H*W] bool)``: where each pixel's claim lands, the
    pixel ``p + sign * motion(p)`` rounded; NaN motion reads as 0, off screen is not a claim."""
    mx, my = motion[0].to(torch.float64), motion[1].to(torch.float64)
    still = torch.isnan(mx) | torch.isnan(my)
    ys = torch.arange(h, device=motion.device, dtype=torch.float64)[:, None]
    xs = torch.arange(w, device=motion.device, dtype=torch.float64)[None, :]
    tx = torch.floor(xs + (sign * mx).masked_fill_(still, 0.0) + 0.5)
    ty = torch.floor(ys + (sign * my).masked_fill_(still, 0.0) + 0.5)
    inside = (tx >= 0) & (tx < w) & (ty >= 0) & (ty < h)  # false for infinities
    landing = torch.where(inside, ty * w + tx, 0.0).to(torch.int64)
    return landing.reshape(-1), inside.reshape(-1)


def reproject_sources(
    motion: torch.Tensor,
    depth: torch.Tensor | None = None,
    *,
    direction: str = "forward",
) -> torch.Tensor:
    """The reprojection as gather indices: ``out.view(-1) = seeds.view(-1)[src]``.

    Args and rules as :func:`reproject_seeds` (without the seeds).

    Returns:
        ``[H * W]`` int64 on ``motion``'s device, a permutation of ``0 .. H*W - 1``.
    """
    h, w, depth2 = _check_inputs(motion, depth)
    direction = check_name(direction, DIRECTIONS, "reprojection direction")
    n = h * w
    device = motion.device
    index = torch.arange(n, device=device)
    landing, inside = _claims(motion, h, w, 1.0 if direction == "forward" else -1.0)
    # One claim per pixel i: forward, source i -> target landing[i]; backward, target i <- source
    # landing[i]. Contested: the landing pixel. Priority: (depth key, i), smallest wins.
    if depth2 is None:
        priority = index
    else:
        key = ordered_keys(depth2).reshape(-1).to(torch.int64) + 2**31  # in [0, 2^32)
        priority = (key << _INDEX_BITS) | index
    never = torch.iinfo(torch.int64).max  # the priority of no claim: it never wins
    priority = torch.where(inside, priority, never)
    best = torch.full((n,), never, dtype=torch.int64, device=device)
    best.scatter_reduce_(0, landing, priority, "amin")
    win = inside & (best.gather(0, landing) == priority)  # claimant side, [n]
    contested = best != never  # landing side: has a winner, [n]
    # No boolean indexing below (each would be a nonzero pass): losers scatter into a spare slot.
    if direction == "forward":  # claimant = source i, landing = target
        spare = torch.empty(n + 1, dtype=torch.int64, device=device)
        spare.scatter_(0, torch.where(win, landing, n), index)
        src, claimed, used = spare[:n], contested, win
    else:  # claimant = target i, landing = source
        src, claimed, used = torch.where(win, landing, -1), win, contested
    # The wins form a partial bijection, so as many sources are unused as targets unclaimed.
    src[torch.nonzero(~claimed).reshape(-1)] = torch.nonzero(~used).reshape(-1)
    return src


def reproject_seeds(
    seeds: torch.Tensor,
    motion: torch.Tensor,
    depth: torch.Tensor | None = None,
    *,
    direction: str = "forward",
) -> torch.Tensor:
    """Move each seed along the screen-space motion, keeping the seed image a permutation.

    Args:
        seeds: ``[H, W]`` int64 seed image of frame t (H * W < 2^31).
        motion: ``[2, H, W]`` floating, ``(dx, dy)`` in pixels. ``direction="forward"``: the
            motion from t to t + 1 at frame t's pixels (frame t's own Frame ``motion``, t-1 -> t,
            is the constant-velocity prediction of it). ``direction="backward"``: frame t + 1's
            Frame ``motion`` (t -> t + 1 at frame t + 1's pixels). See the module docstring.
        depth: ``[1, H, W]`` or ``[H, W]`` floating, the claiming surfaces' depth (forward: frame
            t's, backward: frame t + 1's; :func:`collision_depth` puts the background at +inf),
            or None (collisions go to the lower pixel index).
        direction: ``"forward"`` (push) or ``"backward"`` (pull).

    Returns:
        ``[H, W]`` int64 on ``seeds``' device, a new tensor: a permutation of ``seeds``.
        Deterministic (integer comparisons only), identical on every device.

    Raises:
        ShapeError, DtypeError: shapes or dtypes that do not match. ValueRangeError: tensors on
        different devices, or 2^31 pixels or more. UnknownNameError: an unknown direction.
    """
    _check_seeds(seeds, motion)
    h, w = seeds.shape
    src = reproject_sources(motion, depth, direction=direction)
    return seeds.reshape(-1).index_select(0, src).reshape(h, w)


def _python_depth_key(value: float) -> tuple[int, float]:
    return (1, 0.0) if value != value else (0, value)


def reproject_seeds_reference(
    seeds: torch.Tensor,
    motion: torch.Tensor,
    depth: torch.Tensor | None = None,
    *,
    direction: str = "forward",
) -> torch.Tensor:
    """The slow twin of :func:`reproject_seeds`: Python loops over pixels, same rules.

    For tests and reading; seconds at 256 x 256.
    """
    _check_seeds(seeds, motion)
    h, w, depth2 = _check_inputs(motion, depth)
    direction = check_name(direction, DIRECTIONS, "reprojection direction")
    sign = 1.0 if direction == "forward" else -1.0
    mx, my = (c.to(torch.float64).cpu().tolist() for c in motion)
    dep = None if depth2 is None else depth2.to(torch.float32).cpu().tolist()
    flat = seeds.reshape(-1).cpu().tolist()
    # landing -> (priority, claimant), the priority being (depth key, claimant)
    winner: dict[int, tuple[tuple[tuple[int, float], int], int]] = {}
    for i in range(h * w):
        y, x = divmod(i, w)
        dx, dy = mx[y][x], my[y][x]
        if dx != dx or dy != dy:
            dx = dy = 0.0
        fx, fy = x + sign * dx + 0.5, y + sign * dy + 0.5
        if not (math.isfinite(fx) and math.isfinite(fy)):
            continue
        tx, ty = math.floor(fx), math.floor(fy)
        if not (0 <= tx < w and 0 <= ty < h):
            continue
        priority = (_python_depth_key(dep[y][x]) if dep is not None else (0, 0.0), i)
        landing = ty * w + tx
        if landing not in winner or priority < winner[landing][0]:
            winner[landing] = (priority, i)
    out: list[int | None] = [None] * (h * w)
    used = [False] * (h * w)
    for landing, (_, claimant) in winner.items():
        source, target = (claimant, landing) if direction == "forward" else (landing, claimant)
        out[target] = flat[source]
        used[source] = True
    pool = iter([flat[s] for s in range(h * w) if not used[s]])
    filled = [v if v is not None else next(pool) for v in out]
    return torch.tensor(filled, dtype=torch.int64, device=seeds.device).reshape(h, w)
