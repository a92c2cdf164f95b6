"""The seed permutation of Heitz & Belcour 2019: the block sorting pass and histogram sampling.

Heitz & Belcour, "Distributing Monte Carlo Errors as a Blue Noise in Screen Space by Permuting
Pixel Seeds Between Frames", EGSR 2019 (Computer Graphics Forum 38(4)); docs/METHODS.md,
section 4.

- :func:`sort_pass` (the temporal algorithm's core, the talk's "for each 4x4 block: sort the
  frame pixels, sort the blue-noise pixels, NewSequences(BlueNoisePixels[i]) =
  Sequences(FramePixels[i])"): inside each ``B x B`` block, the seed whose pixel had the k-th
  smallest luminance moves to the pixel with the k-th smallest mask value. A bijection inside
  every block, whatever the values.
- :func:`histogram_select` (the paper's section 3, the "a-posteriori theory"): from K candidate
  estimates per pixel, the index of the one at rank ``floor(b * K)`` of their sorted values, ``b``
  the pixel's mask value. The ``oracle`` strategy is built on it.
- :func:`sort_pass_reference`: the slow, obviously correct twin of :func:`sort_pass` (a Python
  loop over blocks with Python's stable ``sorted``); the tests check that they agree exactly.

**Order.** Values are compared as float32 (float64 input is rounded to float32 first, which can
only turn near-ties into ties). ``-0.0`` equals ``+0.0``, ``-inf`` is the smallest value, ``+inf``
the largest finite-or-infinite one, and every NaN (any sign or payload) is larger than ``+inf``
and equal to every other NaN. Equal values keep the order of their pixels in the block, row-major
(a stable sort). The mask is ordered the same way. Internally a float is compared through its
*ordered key*: its bit pattern as an int32, with negative values' magnitude bits flipped, so that
signed integer comparison orders floats; NaN is first mapped to one canonical NaN. Integer
comparisons are exact and identical on every device.

**Borders.** Blocks at the right and bottom borders may be partial (``H`` or ``W`` not a multiple
of ``B``); a partial block sorts only its own pixels.

**Options for closing the gap to the oracle** (docs/METHODS.md, section 8). ``groups [H, W]``:
inside each block, each group of equal labels is sorted on its own (its pixels in mask order take
its seeds in value order); a bijection inside every group, so inside every block.
``grid_offset=(oy, ox)`` in ``[0, B)^2``: pixel (y, x) lies in block ``((y + oy) // B,
(x + ox) // B)``, so blocks are partial at every border; a strategy that changes it between
frames (e.g. ``(B/2, B/2)`` every other frame) lets seeds cross the previous frame's block
boundaries. The plan depends on it (:func:`plan_sort`'s ``grid_offset``); the retargeting pass
does not (it takes the mask offset). Neither option changes the pass without it: no groups and a
zero offset call the op exactly as before and give bit-identical output.

**Speed.** What depends only on the mask and the block size (each block's pixels in mask order)
is computed once into a :class:`SortPlan` (:func:`plan_sort`) and cached, keyed by the mask
tensor's identity and version, so that passing the same mask tensor every frame reuses it.

**The op.** The pass itself is the torch custom op ``torch.ops.bnerr.sort_pass(seeds, values,
order, block)`` (with a fake implementation for shape propagation, so it composes with
``torch.compile``), dispatched by device: on the CPU the optional C kernel of
:mod:`bnerr.native` (a few ms at 1920x1080 on two threads, built with the system C compiler at
first use; ``BNERR_NATIVE=0`` turns it off), checked once against the torch path before it is
trusted; elsewhere, or without a C compiler, the torch path (a row sort of packed 64-bit keys;
a few tens of ms at 1080p on CPU, fast on CUDA). All paths give bit-identical output.
:func:`luminance` is :func:`bnerr.color.luminance`, re-exported here.

Not for: sorting by anything but one scalar per pixel (pass your own key as ``values [H, W]``,
e.g. :func:`bnerr.permutation.sortkeys.sort_key`), or permutations that cross the blocks of one
frame (that is :mod:`bnerr.permutation.retarget`, and :mod:`bnerr.permutation.reproject` along
motion).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS, luminance
from bnerr.errors import (
    FLOAT_DTYPES,
    INT_DTYPES,
    DtypeError,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_finite,
    check_offset,
    check_positive_int,
    check_shape,
    check_tensor,
)
from bnerr.tensor_memo import TensorMemo

__all__ = [
    "SortPass",
    "SortPlan",
    "histogram_select",
    "luminance",
    "ordered_keys",
    "plan_sort",
    "sort_pass",
    "sort_pass_reference",
    "sort_torch",
]

_MIN_BLOCK, _MAX_BLOCK = 2, 8
_INT32_MIN = -(2**31)
_CANONICAL_NAN = 0x7FC00000
_PAD_KEY = 2**31 - 1  # above the canonical NaN's key: padding sorts after every real pixel
_POSITION_BITS = 6  # block positions 0 .. 63 (B <= 8)
_PAD_LABEL = 2**63 - 1  # group label of padding: after every real label (stable sorts keep order)


# --------------------------------------------------------------------------------------------------
# Checks and keys


def _check_block(block: object) -> int:
    if isinstance(block, bool) or not isinstance(block, int):
        raise DtypeError(
            f"block: expected an integer in [{_MIN_BLOCK}, {_MAX_BLOCK}], got {block!r}"
        )
    if not _MIN_BLOCK <= block <= _MAX_BLOCK:
        raise ValueRangeError(
            f"block: expected an integer in [{_MIN_BLOCK}, {_MAX_BLOCK}], got {block}"
        )
    return block


def _check_values(values: object, height: int, width: int) -> torch.Tensor:
    """``values [H, W]`` or ``[C, H, W]`` (C = 1 or 3), floating point, matching ``H x W``."""
    values = check_tensor(values, "values")
    if values.ndim == 2:
        size = check_shape(values, "H W", "values")
    elif values.ndim == 3 and values.shape[0] in (1, 3):
        size = check_shape(values, "C H W", "values")
    else:
        raise ShapeError(
            f"values: expected [H, W] or [C, H, W] with C = 1 or 3, got shape {list(values.shape)}"
        )
    check_dtype(values, FLOAT_DTYPES, "values")
    if (size["H"], size["W"]) != (height, width):
        raise ShapeError(
            f"values: expected H x W = {height} x {width} like seeds, got {size['H']} x {size['W']}"
        )
    return values


def _check_grid_offset(grid_offset: object, block: int) -> tuple[int, int]:
    """``(oy, ox)``, each in ``[0, B)``."""
    oy, ox = check_offset(grid_offset, "grid_offset")
    if not (0 <= oy < block and 0 <= ox < block):
        raise ValueRangeError(
            f"grid_offset: expected (oy, ox) in [0, {block})^2 for block {block}, got {(oy, ox)}"
        )
    return oy, ox


def _check_groups(groups: object, height: int, width: int, device: torch.device) -> torch.Tensor:
    """``groups [H, W]`` integer labels on ``device``, as int64."""
    groups = check_tensor(groups, "groups")
    size = check_shape(groups, "H W", "groups")
    check_dtype(groups, INT_DTYPES, "groups")
    if (size["H"], size["W"]) != (height, width):
        raise ShapeError(
            f"groups: expected H x W = {height} x {width} like seeds, got {size['H']} x {size['W']}"
        )
    if groups.device != device:
        raise ValueRangeError(
            f"groups: expected a tensor on {device} like seeds, got {groups.device}"
        )
    return groups.to(torch.int64)


def _check_seeds(seeds: object) -> tuple[int, int]:
    seeds = check_tensor(seeds, "seeds")
    size = check_shape(seeds, "H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    return size["H"], size["W"]


def _check_mask(mask: object, height: int, width: int, device: torch.device) -> torch.Tensor:
    mask = check_tensor(mask, "mask")
    size = check_shape(mask, "H W", "mask")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    if (size["H"], size["W"]) != (height, width):
        raise ShapeError(
            f"mask: expected H x W = {height} x {width} like seeds, got {size['H']} x {size['W']}"
        )
    if mask.device != device:
        raise ValueRangeError(f"mask: expected a tensor on {device} like seeds, got {mask.device}")
    return mask


def ordered_keys(x: torch.Tensor) -> torch.Tensor:
    """int32 keys whose signed order is the float32 order of ``x`` (see the module docstring)."""
    bits = x.to(torch.float32).contiguous().view(torch.int32)
    nan = (bits & 0x7FFFFFFF) > 0x7F800000
    bits = torch.where(nan, torch.full_like(bits, _CANONICAL_NAN), bits)
    bits = torch.where(bits == _INT32_MIN, torch.zeros_like(bits), bits)  # -0.0 -> +0.0
    return torch.where(bits < 0, bits ^ 0x7FFFFFFF, bits)


# --------------------------------------------------------------------------------------------------
# The plan: what depends only on the mask and the block size


@dataclass(frozen=True, eq=False)
class SortPlan:
    """Each block's pixels in mask order, for one mask image and one block size.

    Attributes:
        block: block size B (2..8).
        height, width: the image size ``H x W`` the plan is for.
        order: ``[nby * nbx, B * B]`` uint8 on the mask's device; row ``by * nbx + bx`` lists the
            block's positions ``a * B + b`` (row ``a``, column ``b`` inside the block) by
            increasing mask value, ties by position; positions outside the image (partial blocks)
            come last. ``nby = ceil((H + oy) / B)``, ``nbx = ceil((W + ox) / B)``.
        grid_offset: ``(oy, ox)`` in ``[0, B)^2``, the block grid's offset: pixel (y, x) lies in
            block ``((y + oy) // B, (x + ox) // B)`` at position ``((y + oy) % B, (x + ox) % B)``
            (the convention of :func:`bnerr.masks.tile_mask`'s offset). ``(0, 0)``: blocks start
            at the top-left pixel, the paper's grid.

    Build it with :func:`plan_sort`. Reuse it while the mask image is the same (for a mask tiled
    at a per-frame offset, one plan per offset). It holds ``H * W`` bytes (2 MB at 1080p). A
    hand-made plan is checked for shape and dtype only (the native kernel also refuses positions
    outside their block rather than write out of bounds).
    """

    block: int
    height: int
    width: int
    order: torch.Tensor
    grid_offset: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        _check_block(self.block)
        check_positive_int(self.height, "SortPlan.height", minimum=0)
        check_positive_int(self.width, "SortPlan.width", minimum=0)
        oy, ox = _check_grid_offset(self.grid_offset, self.block)
        object.__setattr__(self, "grid_offset", (oy, ox))
        blocks = -(-(self.height + oy) // self.block) * -(-(self.width + ox) // self.block)
        check_shape(
            check_tensor(self.order, "SortPlan.order"),
            f"{blocks} {self.block**2}",
            "SortPlan.order",
        )
        check_dtype(self.order, torch.uint8, "SortPlan.order")

    @property
    def device(self) -> torch.device:
        return self.order.device

    def to(self, device: torch.device | str) -> SortPlan:
        """The same plan on ``device``."""
        return replace(self, order=self.order.to(device))


def _blocks(
    x: torch.Tensor, block: int, fill: int, offset: tuple[int, int] = (0, 0)
) -> torch.Tensor:
    """``[H, W]`` -> ``[nby * nbx, B * B]``: pad to whole blocks with ``fill`` (``oy`` rows on top
    and ``ox`` columns on the left for a grid offset, the rest at the bottom and right), a row per
    block."""
    h, w = x.shape
    oy, ox = offset
    pad_h, pad_w = -(h + oy) % block, -(w + ox) % block
    if pad_h or pad_w or oy or ox:  # (F.pad takes its fill as a double: not every int64 fits)
        padded = x.new_full((oy + h + pad_h, ox + w + pad_w), fill)
        padded[oy : oy + h, ox : ox + w] = x
        x = padded
    nby, nbx = x.shape[0] // block, x.shape[1] // block
    return x.reshape(nby, block, nbx, block).permute(0, 2, 1, 3).reshape(nby * nbx, block * block)


def _unblocks(
    x: torch.Tensor, block: int, height: int, width: int, offset: tuple[int, int] = (0, 0)
) -> torch.Tensor:
    """Inverse of :func:`_blocks` (without the padding)."""
    oy, ox = offset
    nby, nbx = -(-(height + oy) // block), -(-(width + ox) // block)
    full = x.reshape(nby, nbx, block, block).permute(0, 2, 1, 3).reshape(nby * block, nbx * block)
    return full[oy : oy + height, ox : ox + width]


def _block_order(keys: torch.Tensor, block: int, offset: tuple[int, int] = (0, 0)) -> torch.Tensor:
    """Per block, positions sorted by (key, position): ``[nby * nbx, B * B]`` int64.

    Keys are packed with their position into distinct int64s, so one unstable row sort is a
    stable sort of the keys; padding gets the largest key and sorts last.
    """
    packed = _blocks(keys, block, _PAD_KEY, offset).to(torch.int64) << _POSITION_BITS
    packed |= torch.arange(block * block, device=keys.device)
    return packed.sort(dim=1).values & ((1 << _POSITION_BITS) - 1)


def plan_sort(
    mask: torch.Tensor, block: int = 4, grid_offset: tuple[int, int] = (0, 0)
) -> SortPlan:
    """Precompute the mask side of :func:`sort_pass` for one mask image, block size and grid.

    Args:
        mask: ``[H, W]`` floating point, the frame's mask values (already tiled and offset, e.g.
            ``bnerr.masks.tile_mask(M, H, W, frame_offset(t, T))``); NaN and infinities are
            ordered like values.
        block: B in 2..8.
        grid_offset: ``(oy, ox)`` in ``[0, B)^2``, the block grid's offset (see
            :class:`SortPlan`); a strategy that shifts the grid per frame needs one plan per
            (mask offset, grid offset) pair.

    Returns:
        A :class:`SortPlan` on ``mask``'s device.
    """
    size = check_shape(check_tensor(mask, "mask"), "H W", "mask")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    block = _check_block(block)
    grid = _check_grid_offset(grid_offset, block)
    order = _block_order(ordered_keys(mask), block, grid).to(torch.uint8).contiguous()
    return SortPlan(block=block, height=size["H"], width=size["W"], order=order, grid_offset=grid)


#: The last few plans, keyed by the mask tensor (its identity and in-place version), block size
#: and grid offset.
_PLANS: TensorMemo[SortPlan] = TensorMemo()


# --------------------------------------------------------------------------------------------------
# The sorting pass: the torch path, the native path and the custom op that dispatches between them


def _group_stable(ranked: torch.Tensor, labels: torch.Tensor | None) -> torch.Tensor:
    """Reorder each row of block positions ``ranked [nb, B*B]`` stably by the positions' group
    labels ``labels [nb, B*B]`` (None: unchanged). Value order and mask order regrouped alike put
    every group in the same rank range of both, so rank k still maps to rank k."""
    if labels is None:
        return ranked
    regroup = labels.gather(1, ranked).sort(dim=1, stable=True).indices
    return ranked.gather(1, regroup)


def _sort_blocks_torch(
    seeds: torch.Tensor,
    lum: torch.Tensor,
    order: torch.Tensor,
    block: int,
    groups: torch.Tensor | None = None,
    offset: tuple[int, int] = (0, 0),
) -> torch.Tensor:
    """The torch path: sort each block's packed (key, position), then move seeds rank by rank.

    With ``groups [H, W]`` int64, both orders are then stably regrouped by label (two more row
    sorts); padding's label sorts last, so padded positions stay last in both.
    """
    h, w = seeds.shape
    source = _block_order(ordered_keys(lum), block, offset)  # position of the k-th smallest value
    target = order.long()
    if groups is not None:
        labels = _blocks(groups, block, _PAD_LABEL, offset)
        source, target = _group_stable(source, labels), _group_stable(target, labels)
    blocks = _blocks(seeds, block, -1, offset)
    out = torch.empty_like(blocks).scatter_(1, target, blocks.gather(1, source))
    return _unblocks(out, block, h, w, offset).contiguous()


def sort_torch(
    seeds: torch.Tensor, lum: torch.Tensor, plan: SortPlan, groups: torch.Tensor | None = None
) -> torch.Tensor:
    """The torch path of :func:`sort_pass` for ``lum [H, W]`` float32, a plan and optional
    ``groups [H, W]`` int64: what the native kernel is checked against and falls back to (public
    for the speed suite, which times both paths side by side)."""
    return _sort_blocks_torch(seeds, lum, plan.order, plan.block, groups, plan.grid_offset)


def _native_threads(seeds: torch.Tensor) -> int:
    return torch.get_num_threads() if seeds.numel() >= 1 << 16 else 1


def _self_check(kernels: native.Kernels) -> bool:
    """Compare the native kernel with the torch path on small adversarial inputs (odd sizes,
    partial blocks, NaN, infinities, signed zeros, ties, grid offsets, groups): True if
    bit-identical."""
    gen = torch.Generator().manual_seed(1234)
    for block, (h, w) in ((3, (37, 53)), (4, (40, 70)), (8, (19, 141))):
        color = torch.randint(0, 5, (3, h, w), generator=gen).float() / 4
        color[0, 0, :5] = float("nan")
        color[1, 1, :3] = float("inf")
        color[2, 2, :4] = -0.0
        seeds = torch.randperm(h * w, generator=gen).view(h, w)
        groups = torch.randint(0, 3, (h, w), generator=gen)
        for grid, labels in (((0, 0), None), ((block - 1, 1), None), ((1, 0), groups)):
            plan = plan_sort(torch.rand(h, w, generator=gen), block, grid)
            want = sort_torch(seeds, luminance(color), plan, labels)
            for values in (color, luminance(color)):
                got = native.native_sort_blocks(
                    kernels, seeds, values, plan.order, block, LUMINANCE_WEIGHTS,
                    groups=labels, grid_offset=grid,
                )  # fmt: skip
                if got is None or not torch.equal(got, want):
                    return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = native.SelfCheckedKernels(
    _self_check, "bnerr.permutation.permute: the native sort kernel"
)


# The op, registered with the low-level torch.library API: its dispatch costs a few microseconds
# per call, where torch.library.custom_op's Python wrappers cost about 30 (measured).
_LIBRARY = torch.library.Library("bnerr", "FRAGMENT")
_LIBRARY.define(
    "sort_pass(Tensor seeds, Tensor values, Tensor order, int block, Tensor? groups=None, "
    "int oy=0, int ox=0) -> Tensor"
)


def _sort_pass_default(
    seeds: torch.Tensor,
    values: torch.Tensor,
    order: torch.Tensor,
    block: int,
    groups: torch.Tensor | None = None,
    oy: int = 0,
    ox: int = 0,
) -> torch.Tensor:
    """``torch.ops.bnerr.sort_pass(seeds, values, order, block, groups, oy, ox)``: the sorting
    pass as a torch op.

    ``seeds [H, W]`` int64, ``values [H, W]`` or ``[3, H, W]`` float32 (RGB: its Rec. 709
    luminance is the key), ``order`` a :class:`SortPlan`'s ``order`` for the grid offset
    ``(oy, ox)``, ``groups [H, W]`` int64 or None; returns ``[H, W]`` int64. Inputs are not
    checked here (:func:`sort_pass` checks them). This default kernel (CUDA and every other
    device but the CPU) is the torch path.
    """
    return _sort_blocks_torch(seeds, luminance(values), order, block, groups, (oy, ox))


def _sort_pass_cpu(
    seeds: torch.Tensor,
    values: torch.Tensor,
    order: torch.Tensor,
    block: int,
    groups: torch.Tensor | None = None,
    oy: int = 0,
    ox: int = 0,
) -> torch.Tensor:
    """CPU kernel of the op: the native kernel where it loads and passed its check, else torch."""
    kernels = _native_kernels()
    if kernels is not None:
        threads = _native_threads(seeds)
        out = native.native_sort_blocks(
            kernels, seeds, values, order, block, LUMINANCE_WEIGHTS, threads,
            groups=groups, grid_offset=(oy, ox),
        )  # fmt: skip
        if out is not None:
            return out
    return _sort_blocks_torch(seeds, luminance(values), order, block, groups, (oy, ox))


@torch.library.register_fake("bnerr::sort_pass")
def _sort_pass_fake(
    seeds: torch.Tensor,
    values: torch.Tensor,
    order: torch.Tensor,
    block: int,
    groups: torch.Tensor | None = None,
    oy: int = 0,
    ox: int = 0,
) -> torch.Tensor:
    """Shape propagation for ``torch.compile``: the output is like ``seeds``."""
    return torch.empty_like(seeds, memory_format=torch.contiguous_format)


_LIBRARY.impl("sort_pass", _sort_pass_cpu, "CPU")
_LIBRARY.impl("sort_pass", _sort_pass_default, "CompositeExplicitAutograd")


def _resolve_plan(
    mask: object,
    block: int,
    h: int,
    w: int,
    device: torch.device,
    grid: object,
) -> SortPlan:
    if isinstance(mask, SortPlan):
        if mask.block != block:
            raise ValueRangeError(
                f"block: expected the plan's block size {mask.block}, got {block}"
            )
        if grid is not None and _check_grid_offset(grid, block) != mask.grid_offset:
            raise ValueRangeError(
                f"grid_offset: expected the plan's grid offset {mask.grid_offset}, got {grid}"
            )
        if (mask.height, mask.width) != (h, w):
            raise ShapeError(
                f"mask: expected a plan for H x W = {h} x {w} like seeds, "
                f"got one for {mask.height} x {mask.width}"
            )
        if mask.device != device:
            raise ValueRangeError(
                f"mask: expected a plan on {device} like seeds, got {mask.device}"
            )
        return mask
    grid = (0, 0) if grid is None else _check_grid_offset(grid, block)
    checked = _check_mask(mask, h, w, device)
    return _PLANS.get(checked, (block, grid), lambda: plan_sort(checked, block, grid))


def _check_pass(
    seeds: object,
    values: object,
    mask: object,
    block: object,
    groups: object,
    grid_offset: object,
) -> tuple[torch.Tensor, SortPlan, torch.Tensor | None]:
    """:func:`sort_pass`'s checks: ``(values, plan, groups as int64 or None)``."""
    seeds = check_tensor(seeds, "seeds")
    h, w = _check_seeds(seeds)
    block = _check_block(block)
    values = _check_values(values, h, w)
    if values.device != seeds.device:
        raise ValueRangeError(
            f"values: expected a tensor on {seeds.device} like seeds, got {values.device}"
        )
    plan = _resolve_plan(mask, block, h, w, seeds.device, grid_offset)
    labels = None if groups is None else _check_groups(groups, h, w, seeds.device)
    return values, plan, labels


def sort_pass(
    seeds: torch.Tensor,
    values: torch.Tensor,
    mask: torch.Tensor | SortPlan,
    block: int = 4,
    *,
    groups: torch.Tensor | None = None,
    grid_offset: tuple[int, int] | None = None,
) -> torch.Tensor:
    """Permute seeds inside each ``B x B`` block so that their values follow the mask's order.

    In each block, the seed of the pixel with the k-th smallest value moves to the pixel with the
    k-th smallest mask value (Heitz & Belcour 2019, section 5, "sorting pass"). Rendered again, the
    frame's error inside each block then follows the mask: blue noise if the mask is blue noise.

    With ``groups``, a block sorts each group separately (docs/METHODS.md, section 8, "permute
    only similar pixels"): the group's pixels, ordered by mask value, receive the group's seeds
    ordered by value; a pixel alone in its group in a block keeps its seed. With ``grid_offset``
    the block grid is shifted (blocks partial at every border), so that a strategy shifting it
    between frames lets seeds travel past block boundaries.

    Args:
        seeds: ``[H, W]`` int64, the seed image that rendered ``values``.
        values: ``[H, W]`` floating point (the sort key, e.g. luminance or a
            :func:`bnerr.permutation.sortkeys.sort_key`), or ``[3, H, W]`` linear RGB (its Rec. 709
            :func:`luminance` is taken), or ``[1, H, W]``. Compared as float32; NaN and infinities
            are allowed (see the module docstring for the order).
        mask: ``[H, W]`` floating point, the frame's mask values already tiled and offset; or a
            :class:`SortPlan` from :func:`plan_sort`. A mask tensor's plan is cached while the
            same tensor object is passed unchanged.
        block: block size B, an integer in 2..8 (the paper uses 4).
        groups: ``[H, W]`` integer labels on ``seeds``' device (e.g.
            :func:`bnerr.permutation.sortkeys.group_labels`), or None (one group per block, the
            paper's). Only equality matters. Costs: two more row sorts on the torch path; on the CPU
            the native kernel's scalar code (see ``benchmarks/speed/permute.py``).
        grid_offset: ``(oy, ox)`` in ``[0, B)^2``: pixel (y, x) lies in block
            ``((y + oy) // B, (x + ox) // B)``. None: the plan's (a :class:`SortPlan` carries
            its own), or ``(0, 0)`` for a mask tensor. Independent of the mask's toroidal offset;
            the retargeting pass after it takes the mask offset as before.

    Returns:
        ``[H, W]`` int64 on ``seeds``' device, a new tensor: inside every block (and group), a
        permutation of its input seeds. Bit-identical for equal inputs, on every path and thread
        count; with no groups and a zero offset, identical to the paper's pass.

    Raises:
        ShapeError: shapes that do not match. DtypeError: seeds not int64, values or mask not
        floating point, groups not integer, block not an int. ValueRangeError: block outside
        2..8, a grid offset outside ``[0, B)^2`` or unlike the plan's, tensors on different
        devices.
    """
    values, plan, labels = _check_pass(seeds, values, mask, block, groups, grid_offset)
    if seeds.numel() == 0:
        return seeds.clone()
    rgb = values.ndim == 3 and values.shape[0] == 3
    keys = values.detach().to(torch.float32) if rgb else luminance(values.detach())
    oy, ox = plan.grid_offset
    if labels is None and oy == 0 and ox == 0:  # the paper's pass: the op's original call
        return torch.ops.bnerr.sort_pass.default(seeds, keys, plan.order, block)
    return torch.ops.bnerr.sort_pass.default(seeds, keys, plan.order, block, labels, oy, ox)


class SortPass(torch.nn.Module):
    """Module form of :func:`sort_pass` holding the block size (kornia's ``MedianBlur`` shape).

    ``SortPass(block=4)(seeds, values, mask)`` equals ``sort_pass(seeds, values, mask, 4)``.
    """

    def __init__(self, block: int = 4) -> None:
        super().__init__()
        self.block = _check_block(block)

    def forward(
        self,
        seeds: torch.Tensor,
        values: torch.Tensor,
        mask: torch.Tensor | SortPlan,
        *,
        groups: torch.Tensor | None = None,
        grid_offset: tuple[int, int] | None = None,
    ) -> torch.Tensor:
        return sort_pass(seeds, values, mask, self.block, groups=groups, grid_offset=grid_offset)

    def extra_repr(self) -> str:
        return f"block={self.block}"


#: The reference's own Rec. 709 luminance weights of linear R, G, B, written out from their
#: definition (ITU-R BT.709-6, item 3.2; docs/METHODS.md, section 4: HB19 sort by luminance), not
#: taken from :data:`bnerr.color.LUMINANCE_WEIGHTS`, so that a wrong weight there makes the fast
#: op and its twin disagree.
_REFERENCE_REC709 = (0.2126, 0.7152, 0.0722)


def _reference_luminance(values: torch.Tensor) -> list[list[float]]:
    """The reference's key per pixel: ``values [H, W]`` or ``[1, H, W]`` rounded to float32, or
    ``(w0 R + w1 G) + w2 B`` of ``[3, H, W]`` in float32, one float32 operation at a time (the
    order :func:`bnerr.color.luminance` documents as its contract)."""
    v = values.to(torch.float32).cpu()
    if v.ndim == 3 and v.shape[0] == 1:
        v = v[0]
    if v.ndim == 2:
        return v.tolist()
    f32 = np.float32  # numpy float32 scalars: every product and sum rounded to float32
    w0, w1, w2 = (f32(c) for c in _REFERENCE_REC709)
    rgb = v.numpy()
    h, w = rgb.shape[1:]
    return [
        [float((w0 * rgb[0, y, x] + w1 * rgb[1, y, x]) + w2 * rgb[2, y, x]) for x in range(w)]
        for y in range(h)
    ]


def _python_key(value: float) -> tuple[int, float]:
    """Sort key of one float for the reference: NaN after everything, else the value itself."""
    return (1, 0.0) if value != value else (0, value)


def _reference_block(
    pixels: list[tuple[int, int]], lum: list, mvals: list, labels: list | None
) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """``(source, target)`` pixel pairs of one block: per group, by value against by mask."""
    if labels is None:
        groups = [pixels]
    else:
        by_label: dict[int, list[tuple[int, int]]] = {}
        for y, x in pixels:
            by_label.setdefault(labels[y][x], []).append((y, x))
        groups = list(by_label.values())
    pairs: list[tuple[tuple[int, int], tuple[int, int]]] = []
    for members in groups:  # members stay in row-major order: Python's sort is stable
        by_value = sorted(members, key=lambda p: _python_key(lum[p[0]][p[1]]))
        by_mask = sorted(members, key=lambda p: _python_key(mvals[p[0]][p[1]]))
        pairs.extend(zip(by_value, by_mask))
    return pairs


def sort_pass_reference(
    seeds: torch.Tensor,
    values: torch.Tensor,
    mask: torch.Tensor,
    block: int = 4,
    *,
    groups: torch.Tensor | None = None,
    grid_offset: tuple[int, int] = (0, 0),
) -> torch.Tensor:
    """The slow twin of :func:`sort_pass`: a Python loop over blocks with Python's stable sort.

    Same arguments, checks and result as :func:`sort_pass` (``mask`` must be a tensor). Values
    and mask go through float32 exactly as in the fast op, an RGB frame through the twin's own
    Rec. 709 luminance (its own weights, numpy float32 scalars); Python compares ``-0.0 == 0.0`` and
    orders infinities natively, and NaN is keyed after everything. Blocks are enumerated with
    the grid offset (pixel (y, x) in block ``((y + oy) // B, (x + ox) // B)``), each group of a
    block separately. For tests and for reading, not for use: it takes seconds on 256 x 256.
    """
    h, w = _check_seeds(seeds)
    block = _check_block(block)
    values = _check_values(values, h, w)
    mask = _check_mask(mask, h, w, seeds.device)
    oy, ox = _check_grid_offset(grid_offset, block)
    labels = None if groups is None else _check_groups(groups, h, w, seeds.device).cpu().tolist()
    lum = _reference_luminance(values)
    mvals = mask.to(torch.float32).cpu().tolist()
    src = seeds.cpu().tolist()
    out = [row[:] for row in src]
    for y0 in range(-oy, h, block):
        for x0 in range(-ox, w, block):
            pixels = [
                (y, x)
                for y in range(max(y0, 0), min(y0 + block, h))
                for x in range(max(x0, 0), min(x0 + block, w))
            ]
            for (vy, vx), (my, mx) in _reference_block(pixels, lum, mvals, labels):
                out[my][mx] = src[vy][vx]
    return torch.tensor(out, dtype=torch.int64, device=seeds.device).reshape(h, w)


# --------------------------------------------------------------------------------------------------
# Histogram sampling


def histogram_select(candidates: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Per pixel, the index of the candidate at rank ``floor(b * K)`` of the sorted candidates.

    Heitz & Belcour 2019, section 3 ("histogram sampling"; the talk's "sample the sorted list
    using the random number provided by the blue-noise texture"): with ``b`` a blue-noise mask
    value, the chosen estimates' errors inherit the mask's spatial correlation, and since
    ``floor(b * K)`` is uniform over the ranks when ``b`` is uniform, each pixel's chosen estimate
    has the distribution of one plain estimate.

    Args:
        candidates: ``[K, H, W]`` floating point, K >= 1 candidate values per pixel (e.g. the
            luminance of K renders with distinct seeds); compared as float32 in the order of the
            module docstring (NaN after ``+inf``; ties by candidate index).
        mask: ``[H, W]`` floating point, finite, the frame's mask values ``b``; the rank
            ``floor(b * K)`` is clamped to ``[0, K - 1]`` (so ``b >= 1`` picks the largest).

    Returns:
        ``[H, W]`` int64 in ``[0, K)`` on ``candidates``' device.

    Raises:
        ShapeError, DtypeError as :func:`sort_pass`; NonFiniteError if the mask holds NaN or inf.
    """
    size = check_shape(check_tensor(candidates, "candidates"), "K H W", "candidates")
    check_dtype(candidates, FLOAT_DTYPES, "candidates")
    msize = check_shape(check_tensor(mask, "mask"), "H W", "mask")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    if (msize["H"], msize["W"]) != (size["H"], size["W"]):
        raise ShapeError(
            f"mask: expected H x W = {size['H']} x {size['W']} like candidates, "
            f"got {msize['H']} x {msize['W']}"
        )
    if mask.device != candidates.device:
        raise ValueRangeError(f"mask: expected a tensor on {candidates.device}, got {mask.device}")
    check_positive_int(size["K"], "candidates.shape[0]")
    check_finite(mask, "mask")
    k = size["K"]
    # (key, candidate index) packed into one int64: distinct, so the sort is stable by index.
    packed = (ordered_keys(candidates).to(torch.int64) << 32) | torch.arange(
        k, device=candidates.device
    ).view(k, 1, 1)
    ranked = packed.sort(dim=0).values
    rank = torch.floor(mask.to(torch.float64) * k).clamp_(0, k - 1).to(torch.int64)
    return ranked.gather(0, rank[None])[0] & 0xFFFFFFFF
