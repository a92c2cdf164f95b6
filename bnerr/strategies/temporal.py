"""Heitz & Belcour 2019's temporal algorithm and its variants: seeds permuted from frame to frame.

- ``temporal``: render with the seed image S_t, then
  ``S_t+1 = retarget(sort_pass(S_t, lum(I_t), M_t), o_t)`` (:mod:`bnerr.permutation.permute`,
  :mod:`bnerr.permutation.retarget`); S_0 is distinct hashed seeds, and S_t stays a permutation of
  S_0.
- ``temporal_sort``: the sorting pass only (no retargeting): seeds never leave their block. The
  mask still moves by the R2 step each frame, as in ``temporal``, so the two differ only by the
  retargeting pass.
- ``temporal_zsobol``: the sort and retarget passes permuting ZSobol's keys instead of hashed
  seeds: S_0 is the identity key image, the sampler is ``zsobol`` with one scramble seed per seed
  set (a key must keep its sequence from frame to frame for the sort to mean anything), and S_t
  stays a permutation of the keys.
- ``temporal_ldbn``: the same passes permuting LDBN's per-pixel keys (which texel of the
  screen-space key tile a pixel reads, :class:`bnerr.sequences.LDBNKeyedSampler`): S_0 is
  ``ldbn``'s frame 0, and the tile is not shifted per frame, so that a key keeps its sequence.
  Measured: no better than ``ldbn`` after a Gaussian anywhere, worse on direct at 4 spp (the
  class's docstring has the figures).
- ``temporal+option...``, ``temporal_zsobol+option...``: the variants of
  :mod:`bnerr.strategies.variants` (docs/METHODS.md, section 8).

**Mask offsets.** Frame t uses the masks shifted toroidally by ``frame_offset(t, T)`` (the R2
step). Frames are meant to be rendered in order t = 0, 1, 2, ...; the temporal strategies carry
their seed image from one call to the next whatever t is (:func:`bnerr.strategies.play`).
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import DtypeError, ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.ldbn.keys import load_ldbn_keys
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.masks.fast import load_fast_mask, load_fast_retarget
from bnerr.permutation.permute import SortPass, SortPlan, plan_sort
from bnerr.permutation.reproject import collision_depth, reproject_seeds
from bnerr.permutation.retarget import Retarget, load_retarget
from bnerr.permutation.sortkeys import group_labels, sort_key
from bnerr.sequences import (
    LDBNKeyedSampler,
    LDBNKeys,
    Sampler,
    ldbn_key_image,
    make_sampler,
    zsobol_keys,
)
from bnerr.strategies.base import (
    BuildOptions,
    RenderFn,
    Strategy,
    offset_cycle,
    per_pixel_sampler,
    pixel_seeds,
    power_of_two_spp,
    stream_key,
)
from bnerr.strategies.ldbn import LDBN_SETS, LDBNStrategy
from bnerr.strategies.variants import TemporalOptions
from bnerr.strategies.zorder import SCRAMBLE_PER_SEED_SET_NOTE

__all__ = [
    "TemporalLDBNStrategy",
    "TemporalSortStrategy",
    "TemporalStrategy",
    "TemporalZSobolStrategy",
]

# Memory the temporal strategies may spend on cached per-offset tables (plans, gather indices).
_CACHE_BYTES = 64 << 20
# A temporal variant's passes beyond temporal's, counted from their buffers (not measured): the
# key and the smoothing's sum, count and window temporaries (float32, about 6 x 4), group labels
# (int64, 2 x 8 with the smoothing's), reprojection (float64 landing coordinates, int64 landing,
# priority, best and sources: about 7 x 8).
VARIANT_BYTES = 96


class TemporalStrategy(Strategy):
    """``temporal`` (sort and retarget) and ``temporal_sort`` (sort only), Heitz & Belcour 2019,
    and their variants (``temporal+...``, :class:`TemporalOptions`).

    State: the seed image S_t, a permutation of S_0 forever. Per frame: render S_t, then sort
    against the mask at offset o_t and, with ``retarget=True``, apply the retargeting field at
    o_t. The offsets cycle (16 distinct ones for T = 64, 128 for T = 128); the mask plans (1 byte
    per pixel) and the retargeting indices (4 bytes per pixel) of every offset are cached when a
    full cycle of them fits in 64 MB each, and not at all otherwise (a cache smaller than the cycle
    would never hit). At 1920x1080 with T = 64 the plans are cached and the indices are not.

    With ``options`` (docs/METHODS.md, section 8), per frame: the sort key is
    :func:`bnerr.permutation.sortkeys.sort_key` of the frame (``key``, ``demodulate``; the smoothing
    guided by the object id and normal where the frame has them), the sort runs per group of
    :func:`bnerr.permutation.sortkeys.group_labels` (``groups``) on the block grid shifted by
    :meth:`TemporalOptions.grid_offset` (``shift``; the plans are then cached per (mask offset,
    grid offset) over their common period), the retargeting pass is unchanged (it takes the mask
    offset whatever the grid), and with ``reproject`` the seeds then move along the frame's motion
    buffer to where its surfaces are predicted to be in the next frame (forward, constant
    velocity: the strategy only sees frame t's buffers, and the renderer it is given is bound to t
    by the caller, so frame t + 1's motion is not reachable from here). Each pass is a bijection,
    so S_t stays a permutation of S_0. Options the frame lacks a buffer for (object id, albedo,
    motion, depth) raise :class:`ValueRangeError`. No options: the paper's passes, bit for bit.
    ``fast`` changes no pass, only the ``mask`` and ``retarget`` field the caller gives (the FAST
    mask and its field, as :meth:`create` loads them); it names the variant.

    Memory: 112 bytes per pixel beyond the frame (81 measured for temporal, 52-108 for
    temporal_sort: the seed image carried, luminance, the passes' keys, indices and output; the
    higher figure on the torch path), and :data:`VARIANT_BYTES` more with options.
    """

    name = "temporal"
    stream = 2
    bytes_per_pixel = 112
    stateful = True
    family = "temporal"
    rank = 100
    color = "#d62728"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        sampler: str = "owen_sobol",
        mask: torch.Tensor,
        block: int = 4,
        retarget: torch.Tensor | None = None,
        options: TemporalOptions | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        self.options = TemporalOptions() if options is None else options
        self.name = self._variant(retarget is not None) + self.options.suffix
        super().__init__(height, width, seed=seed, device=device)
        self.mask = mask
        self.mask_size = mask.shape[-1]
        self.sorter = SortPass(block)
        cycle = offset_cycle(self.mask_size)
        plan_cycle = math.lcm(cycle, self.options.grid_period(block))
        self._plans: dict[tuple, SortPlan] = {}
        self._plan_slots = plan_cycle if plan_cycle * height * width <= _CACHE_BYTES else 0
        index_slots = cycle if cycle * 4 * height * width <= _CACHE_BYTES else 0
        self.retarget = None if retarget is None else Retarget(retarget, cache=index_slots)
        self.seeds, self.sampler = self._initial(sampler)
        self.sampler_name = self.sampler.name

    @classmethod
    def peak_bytes_per_pixel(cls, K: int = 32, options: TemporalOptions | None = None) -> int:
        extra = 0 if options is None or options.plain else VARIANT_BYTES
        return super().peak_bytes_per_pixel(K) + extra

    def _bytes_per_pixel(self) -> int:
        return self.peak_bytes_per_pixel(options=self.options)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        passes = _passes(cls.name, build, options)
        return cls(height, width, sampler=build.sampler, **passes, **build.common)

    def _variant(self, retarget: bool) -> str:
        """The registry name of this variant."""
        return "temporal" if retarget else "temporal_sort"

    def _initial(self, sampler: str) -> tuple[torch.Tensor, Sampler]:
        """S_0 (distinct hashed seeds ``[H, W]`` int64) and the per-pixel sampler."""
        key = stream_key(self.seed, 0, self.stream)
        return pixel_seeds(self.height, self.width, key, self.device), per_pixel_sampler(sampler)

    def _plan(
        self, offset: tuple[int, int], device: torch.device, grid: tuple[int, int] = (0, 0)
    ) -> SortPlan:
        key = (offset, device) if grid == (0, 0) else (offset, device, grid)
        plan = self._plans.get(key)
        if plan is None:
            tiled = tile_mask(self.mask.to(device), self.height, self.width, offset)
            plan = plan_sort(tiled, self.sorter.block, grid)
            if self._plan_slots:
                if len(self._plans) >= self._plan_slots:  # another device: start over
                    self._plans.clear()
                self._plans[key] = plan
        return plan

    def _frame(self, t: int, render: RenderFn) -> Frame:
        out = render(self.seeds, self.sampler)
        device = out.color.device
        offset = frame_offset(t, self.mask_size)
        if self.options.plain:
            seeds = self.sorter(self.seeds.to(device), out.color, self._plan(offset, device))
        else:
            seeds = self._variant_sort(t, out, offset)
        if self.retarget is not None:
            seeds = self.retarget(seeds, offset)
        if self.options.reproject:
            motion = _needed(out.motion, "motion", self.name)
            depth = collision_depth(_needed(out.depth, "depth", self.name), out.object_id)
            seeds = reproject_seeds(seeds, motion, depth)
        self.seeds = seeds
        return out

    def _variant_sort(self, t: int, out: Frame, offset: tuple[int, int]) -> torch.Tensor:
        """The sorting pass with the options' key, groups and grid offset: ``[H, W]`` int64."""
        opts, device = self.options, out.color.device
        labels = groups = None
        if opts.groups is not None or (opts.key != "luminance" and out.object_id is not None):
            oid = _needed(out.object_id, "object_id", self.name)
            normal = None if opts.groups == "object" else out.normal
            depth = out.depth if opts.groups == "depth" else None
            labels = group_labels(oid, normal, depth)
            groups = labels if opts.groups is not None else None
        if opts.demodulate:
            _needed(out.albedo, "albedo", self.name)
        if opts.key == "luminance" and not opts.demodulate:
            values = out.color
        else:
            values = sort_key(
                out.color, opts.key, demodulate=opts.demodulate, albedo=out.albedo, labels=labels
            )
        grid = opts.grid_offset(t, self.sorter.block)
        plan = self._plan(offset, device, grid)
        return self.sorter(self.seeds.to(device), values, plan, groups=groups)


class TemporalSortStrategy(TemporalStrategy):
    """``temporal_sort``: :class:`TemporalStrategy` without the retargeting pass (same seeds)."""

    name = "temporal_sort"
    rank = 90
    color = "#ff7f0e"


def _passes(name: str, build: BuildOptions, options: TemporalOptions) -> dict:
    """The passes' arguments of ``name`` (the base): the shipped scalar mask and retargeting field
    of size T (with ``fast``, the shipped FAST mask of size T and its field; no field for
    temporal_sort)."""
    field: torch.Tensor | None
    if options.fast:
        mask, field = load_fast_mask(build.mask_size), load_fast_retarget(build.mask_size)
    else:
        mask = load_mask("scalar", build.mask_size)
        field = load_retarget(build.mask_size) if name != "temporal_sort" else None
    return {"mask": mask, "block": build.block, "retarget": field, "options": options}


def _needed(buffer: torch.Tensor | None, what: str, strategy: str) -> torch.Tensor:
    """``buffer``, or :class:`ValueRangeError`: ``strategy`` needs the frame's ``what``."""
    if buffer is None:
        raise ValueRangeError(
            f"render: expected a frame with a {what} buffer for {strategy}, got none"
        )
    return buffer


class TemporalZSobolStrategy(TemporalStrategy):
    """``temporal_zsobol``: the sort and retarget passes permuting ZSobol's per-pixel keys.

    S_0 is the identity key image ``zsobol_keys(H, W)``, so frame 0 is exactly pbrt's ZSobol;
    the sampler is ``zsobol`` with one scramble seed for the whole run (keyed by the seed set), so
    a key keeps its sample sequence from frame to frame, which is what lets its error be predicted
    from the previous frame. S_t stays a permutation of the keys (both passes are bijections).
    Memory as temporal's (54 bytes per pixel measured).

    Args:
        spp: samples per pixel, a power of two (the sampler's blocks).
        (the others as :class:`TemporalStrategy`; ``sampler`` is not taken: it is ``zsobol``.)
    """

    name = "temporal_zsobol"
    own_sampler = "zsobol"
    stream = 9
    rank = 110
    raw_mse_note = SCRAMBLE_PER_SEED_SET_NOTE
    color = "#8c564b"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        mask: torch.Tensor,
        block: int = 4,
        retarget: torch.Tensor,
        options: TemporalOptions | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        self.spp = power_of_two_spp(spp, "temporal_zsobol")
        super().__init__(
            height,
            width,
            seed=seed,
            mask=mask,
            block=block,
            retarget=retarget,
            options=options,
            device=device,
        )

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        passes = _passes(cls.name, build, options)
        return cls(height, width, spp=build.spp, **passes, **build.common)  # type: ignore[arg-type]

    def _variant(self, retarget: bool) -> str:
        return "temporal_zsobol"

    def _initial(self, sampler: str) -> tuple[torch.Tensor, Sampler]:
        key = stream_key(self.seed, 0, self.stream)
        zsobol = make_sampler(
            "zsobol", width=self.width, height=self.height, spp=self.spp, seed=key
        )
        return zsobol_keys(self.height, self.width, self.device), zsobol


class TemporalLDBNStrategy(TemporalStrategy):
    """``temporal_ldbn``: the sort and retarget passes permuting LDBN's per-pixel keys.

    The seed image holds, per pixel, ``u * T^2 + k`` (:func:`bnerr.sequences.ldbn_key_image`;
    for the shipped 64 x 64 tile ``u << 12 | k``): ``k = ty * T + tx`` is the texel of the
    screen-space key set (``ldbn``'s, :data:`bnerr.strategies.ldbn.LDBN_SETS`) whose ranking and
    scrambling keys the pixel reads, ``u`` a distinct 32-bit seed that gives the dimensions past
    the optimized ones the pixel's own Owen-Sobol sequence. S_0 is ``ldbn``'s frame 0 of the
    same seed set (its seeds at its offset), bit for bit; the passes then move whole (k, u)
    pairs, so S_t stays a permutation of S_0. Unlike ``ldbn``, the tile is **not** shifted per
    frame and ``u`` is not drawn again: a key must keep its sample sequence from frame to frame
    for the sort, which predicts a seed's error from the previous frame, to mean anything (as in
    ``temporal_zsobol``). Memory as temporal's.

    **Measured, and it does not help** (issue 25; kept for the record, in no suite). The passes
    undo what LDBN's keys were optimized for, the arrangement of neighbouring texels: after the
    first frame's passes only 0.6 % of the pixels of a 128 x 128 render (direct or snooker, 4 spp)
    still read their own texel, 0.15 % after the seventh. What the sort puts in its place does
    not carry the error at these spp on Owen-Sobol-like per-pixel sequences (as for ``temporal``,
    tests/test_ordering.py), so the post-Gaussian error is white's on direct and no better than
    ``ldbn``'s on snooker, where LDBN's gain is in the raw MSE (its per-pixel stratification,
    which moves with the keys). Through the bench
    (``quick`` suite overridden: direct and snooker 128x128, Gaussian, 8 seed sets x 3 frames after
    6 warmups, 1024-spp references), ratios of pooled MSE with 95 % paired t-intervals over seed
    sets (:func:`bnerr.metrics.paired_ratio`):

    ======= === ========================= ========================= =========================
    scene   spp temporal_ldbn / ldbn, den  temporal_ldbn / white, den temporal_ldbn / ldbn, raw
    ======= === ========================= ========================= =========================
    direct  4   1.100 [1.081, 1.119]       0.987 [0.966, 1.008]       1.013 [0.991, 1.035]
    snooker 4   0.993 [0.978, 1.009]       0.831 [0.813, 0.850]       0.990 [0.969, 1.012]
    direct  16  1.004 [0.974, 1.035]       0.985 [0.961, 1.010]       0.978 [0.945, 1.013]
    snooker 16  0.992 [0.969, 1.016]       0.854 [0.827, 0.881]       0.999 [0.981, 1.017]
    ======= === ========================= ========================= =========================

    (``ldbn`` / white after the Gaussian in the same runs: 0.898, 0.837, 0.981, 0.860.)

    Args:
        keys: the screen-space key tiles (:class:`LDBNKeys`, one slice).
        spp: the samples per pixel the renders take (selects the tiles' level).
        (the others as :class:`TemporalStrategy`; ``sampler`` is not taken: it is
        ``ldbn_keyed``.)
    """

    name = "temporal_ldbn"
    own_sampler = "ldbn_keyed"
    stream = 23
    family = "ldbn"
    rank = 85
    color = "#e377c2"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        keys: LDBNKeys,
        spp: int,
        mask: torch.Tensor,
        block: int = 4,
        retarget: torch.Tensor,
        options: TemporalOptions | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        if spp is None:
            raise ValueRangeError("spp: expected the samples per pixel for temporal_ldbn, got None")
        self.spp = check_positive_int(spp, "spp")
        if not isinstance(keys, LDBNKeys):
            raise DtypeError(f"keys: expected LDBNKeys, got {type(keys).__name__}")
        self.keys = keys
        super().__init__(
            height,
            width,
            seed=seed,
            mask=mask,
            block=block,
            retarget=retarget,
            options=options,
            device=device,
        )

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        passes = _passes(cls.name, build, options)
        kind, frames, levels = LDBN_SETS["ldbn"]
        keys = load_ldbn_keys(kind, build.mask_size, frames, levels)[0]
        return cls(height, width, keys=keys, spp=build.spp, **passes, **build.common)  # type: ignore[arg-type]

    def _variant(self, retarget: bool) -> str:
        return "temporal_ldbn"

    def _initial(self, sampler: str) -> tuple[torch.Tensor, Sampler]:
        ldbn = LDBNStrategy(
            self.height,
            self.width,
            seed=self.seed,
            keys=[self.keys],
            spp=self.spp,
            device=self.device,
        )
        image = ldbn_key_image(ldbn.seeds(0), self.keys.size, ldbn.sampler(0).offset)
        return image, LDBNKeyedSampler(self.keys, spp=self.spp)
