"""Seed strategies: how each frame's per-pixel seeds are chosen, and the renders that takes.

A strategy drives the renderer for its frame, rather than the renderer asking for seeds:
``strategy.frame(t, render)`` calls ``render(seeds [H, W] int64, sampler) -> Frame`` as often as
it needs (the caller binds scene, t and spp) and returns the frame to show.

**Timings: one stopwatch per render.** A render reports its own time in its frame's
``timings["render"]`` (the tracer fills it); the strategy does not time the renders again. The
returned frame's ``timings["render"]`` is the sum over the strategy's renders (the oracle renders
K candidates) and ``timings["strategy"]`` (also ``strategy.overhead_ms``) is the wall time of the
whole :meth:`Strategy.frame` minus that sum: seed generation, sorting, retargeting, selection. A
render that reports no time counts as 0 ms, so its time lands in the overhead.

**Memory.** :func:`make_strategy` and the constructors refuse a frame size whose estimated memory
(:func:`estimate_bytes`) exceeds what the device has available, before allocating anything.

Names, as the benchmark tables name them (docs/METHODS.md, sections 3 and 4):

- ``white``: fresh, distinct seeds every frame (a bijective 32-bit hash of the pixel index keyed
  by (seed, t)); the classic white-noise image and the control every other strategy is compared
  with.
- ``bnds``: blue-noise dithered sampling (Georgiev & Fajardo 2016): one shared Owen-Sobol
  sequence per frame, Cranley-Patterson rotated per pixel by the vector mask at the frame's R2
  offset (``make_sampler("bnds", ...)``); dimensions beyond the mask's fall back to per-pixel
  white noise keyed by white's seeds.
- ``temporal``: Heitz & Belcour 2019's temporal algorithm: render with the seed image S_t, then
  ``S_t+1 = retarget(sort_pass(S_t, lum(I_t), M_t), o_t)`` (:mod:`bnerr.permute`,
  :mod:`bnerr.retarget`); S_0 is distinct hashed seeds, and S_t stays a permutation of S_0.
- ``temporal_sort``: the sorting pass only (no retargeting): seeds never leave their block. The
  mask still moves by the R2 step each frame, as in ``temporal``, so the two differ only by the
  retargeting pass.
- ``oracle``: the a-posteriori histogram sampling of the paper's section 3: K renders with K
  distinct seed images, per pixel the candidate at rank ``floor(b K)`` of the candidates'
  luminance (``b`` the scalar mask at the frame's offset), its buffers assembled into one frame.
  K renders per frame: the upper bound that the temporal algorithm approximates.

The rivals (docs/METHODS.md, sections 5 and 7): a-priori patterns that need no previous frame,
and the temporal method over a Z-order sampler. Their seed image holds each pixel's *key* (the
lane's seed that the Z-order samplers read, :func:`bnerr.sequences.zsobol_keys`,
:func:`bnerr.sequences.cycles_keys`), and they need ``spp`` at construction (the samplers' blocks
are ``spp`` long):

- ``zsobol``: pbrt-v4's ZSobolSampler: the identity key image ``zsobol_keys(H, W)`` and the
  ``zsobol`` sampler built with ``(width, height, spp, seed)``; the scramble's seed is fresh every
  frame (pbrt's ``seed`` option keyed by (seed set, t), as an animation with a changing seed), so
  frames are independent like white's. spp must be a power of two (pbrt's blocks).
- ``cycles_blue``: Blender Cycles' ``BLUE_NOISE_PURE`` for final frames: keys
  ``cycles_keys(H, W, seed_t)`` with a fresh seed every frame (Cycles' animated seed) and the
  ``cycles_pure`` sampler over one global Owen-Sobol sequence of seed 0, as in Cycles.
- ``zsobol_t``: temporal Z-order: the identity key image and the ``zsobol_t`` sampler at frame t
  (:meth:`bnerr.sequences.ZSobolTSampler.at_frame`), one scramble seed per seed set for all
  frames, so consecutive frames take neighbouring blocks of one sequence. spp a power of two.
- ``bnds_st``: ``bnds`` with spatiotemporal blue-noise slices (:func:`bnerr.stbn.load_stbn`,
  vector, 64x64x32, D = 2 per slice) instead of one mask shifted by the R2 step: frame t rotates
  dimension pair k (dimensions 2k, 2k + 1) by slice ``(t + k * F // P) mod F`` of the STBN mask,
  ``P`` the number of pairs and F = 32 its slices, unshifted. Each pair thus gets its own slice
  (pairs never share a rotation within a frame) and each pixel's rotation of one pair follows the
  mask's blue series along t. ``P`` is the channel count ``bnds`` would take (the shipped vector
  mask with the fewest channels covering the scene's D, 2, 4 or 8) divided by 2, so ``bnds_st``
  and ``bnds`` rotate the same dimensions and both fall back to white noise beyond them.
- ``temporal_zsobol``: Heitz & Belcour's sort and retarget passes (as ``temporal``) permuting
  ZSobol's keys instead of hashed seeds: S_0 is the identity key image, the sampler is ``zsobol``
  with one scramble seed per seed set (a key must keep its sequence from frame to frame for the
  sort to mean anything), and S_t stays a permutation of the keys.

**Temporal variants** (docs/METHODS.md, section 8): ``base+option+option...``, base ``temporal``
or ``temporal_zsobol``, options in this order, at most one of each group:

- sort key: ``residual`` or ``relative`` (:func:`bnerr.sortkeys.sort_key`; default luminance),
  and ``demod`` (radiance divided by albedo first; alone, it demodulates the luminance key);
- groups: ``groups`` (object id), ``groups_normal`` (and the normal's dominant axis) or
  ``groups_depth`` (and a depth bin): each block sorts each group on its own;
- grid shift: ``shift`` ((B/2, B/2) on odd frames) or ``shift_r2`` (an R2 point in [0, B)^2,
  period B^2): the block grid moves between frames so that seeds cross block boundaries;
- ``reproject``: after sorting and retargeting, each seed moves along the frame's motion buffer
  (forward prediction: the renderer is bound to frame t by the caller, so the next frame's motion
  is not reachable; a constant-velocity guess from frame t's own t-1 -> t motion);
- ``fast``: sort against the shipped FAST mask (:func:`bnerr.fast.load_fast_mask`, optimized for
  the Gaussian denoiser's tuned sigma) instead of the void-and-cluster mask, and retarget with the
  field optimized for it (:func:`bnerr.fast.load_fast_retarget`).

e.g. ``temporal+relative+demod+groups``. :func:`make_strategy` builds any well-formed one
(:func:`parse_variant`, :class:`TemporalOptions`); :data:`VARIANTS` lists those registered in
:data:`STRATEGIES` for the benchmark's command line. ``temporal_zsobol+...`` renders with the
``zsobol`` sampler, whose raw MSE differs from the per-pixel samplers'.

**Which sampler renders.** Every strategy has ``sampler_name``, the sampler its renders use.
``white``, ``temporal``, ``temporal_sort`` and ``oracle`` take the per-pixel sampler they are
given (the benchmark's ``sampler`` condition); the others dictate their own
(:data:`OWN_SAMPLERS`: ``bnds`` and ``bnds_st`` the ``bnds`` sampler, ``zsobol`` and
``temporal_zsobol`` ``zsobol``, ``cycles_blue`` ``cycles_pure``, ``zsobol_t`` ``zsobol_t``) and
ignore the condition; the benchmark records ``sampler_name`` with each cell.

**Sampler.** The paper gives every pixel its own sequence, selected by the pixel's seed; which
sequence family is orthogonal to the method. ``white``, ``temporal``, ``temporal_sort`` and
``oracle`` all use the same per-pixel sampler (``sampler="owen_sobol"`` by default, Owen-scrambled
Sobol; ``"white"`` for a hash), so the set of sequences a frame uses is statistically the same and
raw MSE must agree across them: only where the error lands differs. ``bnds`` uses its own
dithered sampler by definition.

**Mask offsets.** Frame t uses the masks shifted toroidally by ``frame_offset(t, T)`` (the R2
step). Frames are meant to be rendered in order t = 0, 1, 2, ...; the temporal strategies carry
their seed image from one call to the next whatever t is.

**Device.** Seeds are made on ``device``; after each render the strategy's state follows the
device of the returned frame.

Not for: strategies that need the next frame's buffers before rendering it (backward
reprojection with frame t + 1's motion: the render callback is bound to t), or choosing seeds for
a renderer that draws its own random numbers.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable
from dataclasses import dataclass

import torch

from bnerr.color import luminance
from bnerr.errors import (
    DtypeError,
    ShapeError,
    ValueRangeError,
    check_name,
    check_positive_int,
    check_tensor,
)
from bnerr.fast import load_fast_mask, load_fast_retarget
from bnerr.frame import Frame
from bnerr.hashing import MASK32, lowbias32_, lowbias32_host, signed32
from bnerr.masks import frame_offset, load_mask, r2_step, shipped_masks, tile_mask
from bnerr.permute import SortPass, SortPlan, histogram_select, plan_sort
from bnerr.reproject import collision_depth, reproject_seeds
from bnerr.retarget import Retarget, load_retarget
from bnerr.sequences import Sampler, cycles_keys, make_sampler, zsobol_keys
from bnerr.sortkeys import group_labels, sort_key
from bnerr.stbn import load_stbn, stbn_frame
from bnerr.timing import Stopwatch, sync

__all__ = [
    "OWN_SAMPLERS",
    "STRATEGIES",
    "VARIANT_BASES",
    "VARIANT_OPTIONS",
    "BNDSSTStrategy",
    "BNDSStrategy",
    "CyclesBlueStrategy",
    "OracleStrategy",
    "RenderFn",
    "Strategy",
    "TemporalOptions",
    "TemporalStrategy",
    "TemporalZSobolStrategy",
    "VARIANTS",
    "WhiteStrategy",
    "ZSobolStrategy",
    "ZSobolTStrategy",
    "check_strategy_name",
    "estimate_bytes",
    "make_strategy",
    "parse_variant",
    "pixel_seeds",
]

#: ``render(seeds [H, W] int64, sampler) -> Frame``, with scene, t and spp bound by the caller.
RenderFn = Callable[[torch.Tensor, Sampler], Frame]

# Salts that keep the seed streams of the strategies apart (arbitrary odd 32-bit constants).
_SALT_FRAME = 0x9E3779B9
_SALT_STREAM = 0x85EBCA6B
_STREAM_WHITE, _STREAM_TEMPORAL, _STREAM_BNDS, _STREAM_ORACLE = 1, 2, 3, 4
_STREAM_ZSOBOL, _STREAM_CYCLES, _STREAM_ZSOBOL_T, _STREAM_BNDS_ST = 5, 6, 7, 8
_STREAM_TEMPORAL_ZSOBOL = 9
# Memory the temporal strategies may spend on cached per-offset tables (plans, gather indices).
_CACHE_BYTES = 64 << 20


# --------------------------------------------------------------------------------------------------
# Seeds


def _stream_key(seed: int, t: int, stream: int, k: int = 0) -> int:
    key = lowbias32_host(seed ^ lowbias32_host(stream * _SALT_STREAM))
    key = lowbias32_host(key + t * _SALT_FRAME)
    return lowbias32_host(key + k * _SALT_STREAM)


def pixel_seeds(
    height: int,
    width: int,
    key: int,
    device: torch.device | str = "cpu",
) -> torch.Tensor:
    """Distinct 32-bit seeds for every pixel: ``lowbias32((y * W + x + key) mod 2^32)``.

    Args:
        height, width: H, W >= 1 (H * W <= 2^31).
        key: any int; different keys give unrelated seed images.
        device: where the seeds are made.

    Returns:
        ``[H, W]`` int64 in [0, 2^32), all distinct (lowbias32 is a bijection of 32-bit words).
    """
    height = check_positive_int(height, "height")
    width = check_positive_int(width, "width")
    if height * width > 1 << 31:
        raise ValueRangeError(f"height * width: expected at most 2^31 pixels, got {height * width}")
    words = torch.arange(height * width, dtype=torch.int32, device=device).add_(signed32(key))
    return (lowbias32_(words).to(torch.int64) & MASK32).view(height, width)


def _offset_cycle(size: int) -> int:
    """How many distinct offsets ``frame_offset(t, T)`` takes: the lcm of T / gcd(step_i, T)."""
    dy, dx = r2_step(size)
    return math.lcm(size // math.gcd(dy, size), size // math.gcd(dx, size))


# --------------------------------------------------------------------------------------------------
# Memory: refuse a frame size before allocating

# A rendered Frame with every buffer: color, albedo, normal, variance (3 each), motion (2), depth
# and object_id (1 each): 16 float32 channels.
_FRAME_BYTES = 16 * 4
# Working memory beyond the frames held, per pixel, rounded up from the peak RSS growth measured
# over construction and four frames at 2048x2048 on the CPU with preallocated stand-in frames:
# white 22-43 (a seed image: int32 words, their int64 copy, the masked result), temporal 81 and
# temporal_sort 52-108 (the seed image carried, luminance, the sort and retargeting passes' keys,
# indices and output; the higher figure on the torch path), oracle with K = 4 172. The rivals,
# measured the same way with spp 4: zsobol and zsobol_t 33 (the key image, made once through a
# few int64 temporaries), bnds_st 34 (as bnds: fresh seeds), cycles_blue 87 (fresh keys every
# frame: Morton code, base-4 scramble in int32 and int64 copies), temporal_zsobol 54 (as
# temporal).
_SEED_BYTES = 44
_CYCLES_BYTES = 96
_TEMPORAL_BYTES = 112
# The oracle holds K candidate frames and their luminance (4), then the choice (8), the assembled
# frame and one temporary of torch.where per buffer (2 frames) and a seed image.
_ORACLE_CANDIDATE_BYTES = _FRAME_BYTES + 4
_ORACLE_ONCE_BYTES = 8 + 2 * _FRAME_BYTES + _SEED_BYTES
# A temporal variant's passes beyond temporal's, counted from their buffers (not measured): the
# key and the smoothing's sum, count and window temporaries (float32, about 6 x 4), group labels
# (int64, 2 x 8 with the smoothing's), reprojection (float64 landing coordinates, int64 landing,
# priority, best and sources: about 7 x 8).
_VARIANT_BYTES = 96


def _per_pixel(name: str, K: int) -> int:
    """Estimated peak bytes per pixel of one frame of strategy ``name`` (K: oracle candidates)."""
    if "+" in name:
        return _FRAME_BYTES + _TEMPORAL_BYTES + _VARIANT_BYTES
    if name == "oracle":
        return K * _ORACLE_CANDIDATE_BYTES + _ORACLE_ONCE_BYTES
    if name in ("temporal", "temporal_sort", "temporal_zsobol"):
        return _FRAME_BYTES + _TEMPORAL_BYTES
    if name == "cycles_blue":
        return _FRAME_BYTES + _CYCLES_BYTES
    return _FRAME_BYTES + _SEED_BYTES


def estimate_bytes(name: str, height: int, width: int, K: int = 32) -> int:
    """Estimated peak bytes of one frame of strategy ``name`` at ``height x width``.

    Counts the strategy's own state and working memory and the rendered frames it holds at once
    (a frame with every buffer is 64 bytes per pixel); not the renderer's own working memory.

    Args:
        name: one of :data:`STRATEGIES`, or a temporal variant (:func:`parse_variant`).
        height, width: the frame size.
        K: the oracle's number of candidates.

    Returns:
        Bytes (an int).
    """
    check_strategy_name(name)
    pixels = check_positive_int(height, "height") * check_positive_int(width, "width")
    return pixels * _per_pixel(name, check_positive_int(K, "K"))


def _available_bytes(device: torch.device) -> int | None:
    """Free memory on ``device``: CUDA's free bytes, or the host's MemAvailable; None if unknown."""
    if device.type == "cuda":
        return int(torch.cuda.mem_get_info(device)[0])
    if device.type != "cpu":
        return None
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_fits(what: str, height: int, width: int, per_pixel: int, device: torch.device) -> None:
    """Raise :class:`ValueRangeError` if ``height * width * per_pixel`` bytes exceed free memory."""
    if height * width > 1 << 31:
        raise ValueRangeError(
            f"height * width: expected at most 2^31 pixels, got {height} x {width} = "
            f"{height * width}"
        )
    need = height * width * per_pixel
    free = _available_bytes(device)
    if free is not None and need > free:
        raise ValueRangeError(
            f"height x width: expected a frame size whose {what} strategy fits in memory, got "
            f"{height} x {width}, which needs about {need / 1e9:.1f} GB "
            f"({per_pixel} bytes per pixel) with {free / 1e9:.1f} GB available on {device}"
        )


def _per_pixel_sampler(name: str) -> Sampler:
    """The per-pixel sampler of white, temporal, temporal_sort and oracle (checked by name)."""
    return make_sampler(check_name(name, ("owen_sobol", "white"), "per-pixel sampler"))


def _power_of_two_spp(spp: object, strategy: str) -> int:
    """``spp`` checked: an int >= 1 and a power of two (the Z-order samplers' block length)."""
    if spp is None:
        raise ValueRangeError(f"spp: expected the samples per pixel for {strategy}, got None")
    spp = check_positive_int(spp, "spp")
    if spp & (spp - 1):
        raise ValueRangeError(
            f"spp: expected a power of two for {strategy} (its per-pixel blocks), got {spp}"
        )
    return spp


# --------------------------------------------------------------------------------------------------
# Temporal variants: the options of docs/METHODS.md, section 8, named ``base+option+option``

#: The strategies a variant name may start with.
VARIANT_BASES: tuple[str, ...] = ("temporal", "temporal_zsobol")
#: The options a variant name may carry, in the order they must appear (one per group at most).
VARIANT_OPTIONS: tuple[str, ...] = (
    "residual",
    "relative",
    "demod",
    "groups",
    "groups_normal",
    "groups_depth",
    "shift",
    "shift_r2",
    "reproject",
    "fast",
)
# Options that exclude each other: one sort key, one kind of group, one grid shift.
_EXCLUSIVE: tuple[tuple[str, ...], ...] = (
    ("residual", "relative"),
    ("groups", "groups_normal", "groups_depth"),
    ("shift", "shift_r2"),
)
# The R2 sequence's generator for two dimensions (1 / plastic number and its square).
_R2_ALPHA = (0.7548776662466927, 0.5698402909980532)


@dataclass(frozen=True)
class TemporalOptions:
    """What a temporal variant changes in the per-frame passes (all off: Heitz & Belcour's).

    Attributes:
        key: the sort key, ``"luminance"``, ``"residual"`` or ``"relative"``
            (:func:`bnerr.sortkeys.sort_key`; the smoothing is guided by the group labels of the
            object id and normal where the frame has them).
        demodulate: divide the radiance by the albedo before taking the key.
        groups: None, or sort only among pixels sharing ``"object"`` (the object id),
            ``"normal"`` (and the normal's dominant axis) or ``"depth"`` (and a depth bin):
            :func:`bnerr.sortkeys.group_labels`.
        shift: None, or the block grid's per-frame offset: ``"half"`` (B/2, B/2) on odd frames,
            (0, 0) on even ones; ``"r2"`` the R2 sequence's point ``t mod B^2`` scaled to
            ``[0, B)^2`` (so that the offsets cycle with period B^2).
        reproject: after the sort and retarget passes, move each seed along the frame's motion
            (forward prediction: frame t's motion t-1 -> t stands for t -> t + 1;
            :func:`bnerr.reproject.reproject_seeds`, collisions resolved by depth).
        fast: sort against the FAST mask (:mod:`bnerr.fast`) and retarget with its field
            instead of the void-and-cluster mask's; :func:`make_strategy` loads both.
    """

    key: str = "luminance"
    demodulate: bool = False
    groups: str | None = None
    shift: str | None = None
    reproject: bool = False
    fast: bool = False

    @property
    def suffix(self) -> str:
        """The options as a name suffix, ``"+residual+groups+shift+reproject+fast"`` ('' for
        none)."""
        parts = [] if self.key == "luminance" else [self.key]
        parts += ["demod"] if self.demodulate else []
        parts += [] if self.groups is None else [_GROUP_OPTION[self.groups]]
        parts += [] if self.shift is None else [_SHIFT_OPTION[self.shift]]
        parts += ["reproject"] if self.reproject else []
        parts += ["fast"] if self.fast else []
        return "".join("+" + p for p in parts)

    @property
    def plain(self) -> bool:
        """Whether every option is off (the paper's passes, bit for bit)."""
        return self == TemporalOptions()

    def grid_offset(self, t: int, block: int) -> tuple[int, int]:
        """Frame ``t``'s block grid offset ``(oy, ox)`` in ``[0, B)^2``."""
        if self.shift == "half":
            return (block // 2, block // 2) if t % 2 else (0, 0)
        if self.shift == "r2":
            k = t % (block * block)
            return tuple(int(block * ((0.5 + k * a) % 1.0)) for a in _R2_ALPHA)
        return (0, 0)

    def grid_period(self, block: int) -> int:
        """Frames after which :meth:`grid_offset` repeats."""
        return {None: 1, "half": 2, "r2": block * block}[self.shift]


_GROUP_OPTION = {"object": "groups", "normal": "groups_normal", "depth": "groups_depth"}
_SHIFT_OPTION = {"half": "shift", "r2": "shift_r2"}


def parse_variant(name: object) -> tuple[str, TemporalOptions]:
    """``(base, options)`` of a strategy name; a name without ``+`` has no options.

    Args:
        name: ``base`` or ``base+option+...``: base one of :data:`VARIANT_BASES` (with options)
            or :data:`STRATEGIES`; options from :data:`VARIANT_OPTIONS`, in that order, at most
            one of each exclusive group (one key kind, one kind of groups, one shift).

    Raises:
        UnknownNameError: an unknown base or option. ValueRangeError: options repeated, out of
        order or exclusive (the message gives the accepted spelling).
    """
    if not isinstance(name, str) or "+" not in name:
        return check_name(name, STRATEGIES, "strategy"), TemporalOptions()
    base, *opts = name.split("+")
    check_name(base, VARIANT_BASES, "variant base")
    for opt in opts:
        check_name(opt, VARIANT_OPTIONS, "temporal option")
    ranks = [VARIANT_OPTIONS.index(o) for o in opts]
    clash = next((g for g in _EXCLUSIVE if len(set(opts) & set(g)) > 1), None)
    if clash is not None or ranks != sorted(set(ranks)):
        why = f"at most one of {'/'.join(clash)}" if clash else "each option once"
        order = "+".join(VARIANT_OPTIONS)
        raise ValueRangeError(
            f"strategy: expected options in the order {order}, {why}, got {name!r}"
        )
    groups = {v: k for k, v in _GROUP_OPTION.items()}
    shifts = {v: k for k, v in _SHIFT_OPTION.items()}
    return base, TemporalOptions(
        key=next((o for o in opts if o in ("residual", "relative")), "luminance"),
        demodulate="demod" in opts,
        groups=next((groups[o] for o in opts if o in groups), None),
        shift=next((shifts[o] for o in opts if o in shifts), None),
        reproject="reproject" in opts,
        fast="fast" in opts,
    )


def check_strategy_name(name: object) -> str:
    """``name`` checked: a registered strategy or a well-formed variant (:func:`parse_variant`)."""
    parse_variant(name)
    return name


# --------------------------------------------------------------------------------------------------
# The interface


class Strategy:
    """Base class: :meth:`frame` checks and times the call, subclasses implement ``_frame``.

    Attributes:
        name: the registry name (``make_strategy(name)``).
        height, width: the image size every render must return.
        overhead_ms: wall milliseconds of the last :meth:`frame` spent outside ``render``.
        sampler_name: the sampler the renders use: the per-pixel sampler given, or the one a
            strategy dictates (:data:`OWN_SAMPLERS`).
        stateful: whether frame t depends on the frames before it (the temporal strategies); a
            stateless strategy's frame t is the same whether or not frames 0..t-1 were made.
    """

    name: str = ""
    sampler_name: str = ""
    stateful: bool = False

    def __init__(
        self, height: int, width: int, *, seed: int = 0, device: torch.device | str = "cpu"
    ) -> None:
        self.height = check_positive_int(height, "height")
        self.width = check_positive_int(width, "width")
        self.seed = check_positive_int(seed, "seed", minimum=0)
        self.device = torch.device(device)
        self.overhead_ms = 0.0
        _check_fits(self.name, height, width, self._bytes_per_pixel(), self.device)

    def _bytes_per_pixel(self) -> int:
        """Estimated peak bytes per pixel of one :meth:`frame` (see :func:`estimate_bytes`)."""
        return _per_pixel(self.name, 0)

    def frame(self, t: int, render: RenderFn) -> Frame:
        """Choose seeds, render (once or more) and return frame ``t``.

        Args:
            t: frame index >= 0 (it selects the masks' offset and the fresh seeds).
            render: ``render(seeds [H, W] int64, sampler) -> Frame`` of size ``H x W`` that
                reports its time in ``timings["render"]`` (milliseconds). It may also have
                ``render.batch(seeds [K, H, W], sampler) -> list[Frame]``, the same K renders at
                once (:func:`renderers.tracer.render_batch`), which the oracle then uses.

        Returns:
            The frame to show, with ``timings["render"]`` (the sum over this frame's renders,
            when they report it) and ``timings["strategy"] = overhead_ms``.
        """
        t = check_positive_int(t, "t", minimum=0)
        render_ms: list[float] = []

        def checked(seeds: torch.Tensor, sampler: Sampler) -> Frame:
            return checked_frame(render(seeds, sampler))

        def checked_frame(out: object) -> Frame:
            if not isinstance(out, Frame):
                raise DtypeError(f"render: expected a Frame, got {type(out).__name__}")
            if (out.height, out.width) != (self.height, self.width):
                raise ShapeError(
                    f"render: expected a {self.height} x {self.width} frame, "
                    f"got {out.height} x {out.width}"
                )
            if "render" in out.timings:
                render_ms.append(float(out.timings["render"]))
            return out

        batch = getattr(render, "batch", None)
        if batch is not None:  # K renders at once (the oracle), through the same checks

            def checked_batch(seeds: torch.Tensor, sampler: Sampler) -> list[Frame]:
                frames = batch(seeds, sampler)
                return [checked_frame(out) for out in frames]

            checked.batch = checked_batch  # type: ignore[attr-defined]

        sync(self.device)
        watch = Stopwatch()
        out = self._frame(t, checked)
        self.overhead_ms = max(0.0, watch.ms(out.color) - sum(render_ms))
        timings = {**out.timings, "strategy": self.overhead_ms}
        if render_ms:
            timings["render"] = sum(render_ms)
        return dataclasses.replace(out, timings=timings)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.height}x{self.width}, seed={self.seed})"


class WhiteStrategy(Strategy):
    """``white``: fresh distinct seeds every frame, one render: the white-noise control."""

    name = "white"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        sampler: str = "owen_sobol",
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = _per_pixel_sampler(sampler)
        self.sampler_name = sampler

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_WHITE)
        return render(pixel_seeds(self.height, self.width, key, self.device), self.sampler)


class BNDSStrategy(Strategy):
    """``bnds``: one shared sequence per frame, dithered per pixel by the vector mask at offset o_t.

    The shared sequence's seed changes every frame (like white's seeds), and the per-pixel seeds
    (used by the dimensions beyond the mask's) are fresh every frame.
    """

    name = "bnds"
    sampler_name = "bnds"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        mask: torch.Tensor,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, device=device)
        check_tensor(mask, "mask")
        self.mask = mask
        self.mask_size = mask.shape[-1]

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_BNDS)
        sampler = make_sampler(
            "bnds",
            mask=self.mask,
            offset=frame_offset(t, self.mask_size),
            seed0=lowbias32_host(key + 1),
        )
        return render(pixel_seeds(self.height, self.width, key, self.device), sampler)


class ZSobolStrategy(Strategy):
    """``zsobol``: pbrt-v4's ZSobolSampler, the identity key image and a fresh scramble per frame.

    Args:
        spp: samples per pixel, a power of two (pbrt's per-pixel blocks).
    """

    name = "zsobol"
    sampler_name = "zsobol"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        self.spp = _power_of_two_spp(spp, self.name)
        super().__init__(height, width, seed=seed, device=device)
        self.keys = zsobol_keys(height, width, self.device)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_ZSOBOL)
        sampler = make_sampler(
            "zsobol", width=self.width, height=self.height, spp=self.spp, seed=key
        )
        return render(self.keys, sampler)


class CyclesBlueStrategy(Strategy):
    """``cycles_blue``: Cycles' ``BLUE_NOISE_PURE``, keys scrambled by a fresh seed every frame.

    Args:
        spp: samples per pixel (each pixel's block of the global sequence is spp long; any spp,
            though only a power of two keeps the blocks aligned, as in Cycles).
    """

    name = "cycles_blue"
    sampler_name = "cycles_pure"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        if spp is None:
            raise ValueRangeError("spp: expected the samples per pixel for cycles_blue, got None")
        self.spp = check_positive_int(spp, "spp")
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = make_sampler("cycles_pure", spp=self.spp, seed0=0)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_CYCLES)
        return render(cycles_keys(self.height, self.width, key, self.device), self.sampler)


class ZSobolTStrategy(Strategy):
    """``zsobol_t``: temporal Z-order, the identity key image and the sampler at frame t.

    One scramble seed per seed set for every frame: frame t's blocks neighbour frame t - 1's in
    the same sequence. Frame t depends on t alone, not on earlier frames (stateless).

    Args:
        spp: samples per pixel, a power of two.
    """

    name = "zsobol_t"
    sampler_name = "zsobol_t"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        self.spp = _power_of_two_spp(spp, self.name)
        super().__init__(height, width, seed=seed, device=device)
        key = _stream_key(self.seed, 0, _STREAM_ZSOBOL_T)
        self.sampler = make_sampler("zsobol_t", width=width, height=height, spp=self.spp, seed=key)
        self.keys = zsobol_keys(height, width, self.device)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        return render(self.keys, self.sampler.at_frame(t))


class BNDSSTStrategy(Strategy):
    """``bnds_st``: Georgiev-Fajardo dithering with spatiotemporal blue-noise slices.

    Frame t rotates dimension pair k by slice ``(t + k * (F // P)) mod F`` of the vector STBN mask
    ``[F, 2, T, T]`` (``P = channels // 2`` pairs; see the module docstring), unshifted. As in
    ``bnds``, the shared sequence's seed and the per-pixel seeds of the dimensions beyond the
    mask's are fresh every frame.

    Args:
        stbn: ``[F, 2, T, T]`` float32 vector STBN mask in [0, 1) (:func:`bnerr.stbn.load_stbn`).
        channels: rotated dimensions, even, >= 2 (pairs of slices).
    """

    name = "bnds_st"
    sampler_name = "bnds"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        stbn: torch.Tensor,
        channels: int = 2,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, device=device)
        check_tensor(stbn, "stbn")
        if stbn.ndim != 4 or stbn.shape[1] != 2 or stbn.shape[0] < 1:
            raise ShapeError(f"stbn: expected [F, 2, T, T] with F >= 1, got {list(stbn.shape)}")
        channels = check_positive_int(channels, "channels", minimum=2)
        if channels % 2:
            raise ValueRangeError(f"channels: expected an even number, got {channels}")
        self.stbn = stbn
        self.pairs = channels // 2
        self.slice_step = max(1, stbn.shape[0] // self.pairs)

    def slices(self, t: int) -> list[int]:
        """The STBN slice of each dimension pair in frame ``t``: ``[P]`` indices in [0, F)."""
        frames = self.stbn.shape[0]
        return [(t + k * self.slice_step) % frames for k in range(self.pairs)]

    def mask(self, t: int) -> torch.Tensor:
        """Frame ``t``'s vector mask ``[2P, T, T]``: the pairs' slices stacked, in order."""
        return torch.cat([stbn_frame(self.stbn, i) for i in self.slices(t)])

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_BNDS_ST)
        sampler = make_sampler(
            "bnds", mask=self.mask(t), offset=(0, 0), seed0=lowbias32_host(key + 1)
        )
        return render(pixel_seeds(self.height, self.width, key, self.device), sampler)


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
    :func:`bnerr.sortkeys.sort_key` of the frame (``key``, ``demodulate``; the smoothing guided by
    the object id and normal where the frame has them), the sort runs per group of
    :func:`bnerr.sortkeys.group_labels` (``groups``) on the block grid shifted by
    :meth:`TemporalOptions.grid_offset` (``shift``; the plans are then cached per (mask offset,
    grid offset) over their common period), the retargeting pass is unchanged (it takes the mask
    offset whatever the grid), and with ``reproject`` the seeds then move along the frame's motion
    buffer to where its surfaces are predicted to be in the next frame (forward, constant
    velocity: the strategy only sees frame t's buffers, and the renderer it is given is bound to t
    by the caller, so frame t + 1's motion is not reachable from here). Each pass is a bijection,
    so S_t stays a permutation of S_0. Options the frame lacks a buffer for (object id, albedo,
    motion, depth) raise :class:`ValueRangeError`. No options: the paper's passes, bit for bit.
    ``fast`` changes no pass, only the ``mask`` and ``retarget`` field the caller gives (the FAST
    mask and its field, as :func:`make_strategy` loads them); it names the variant.
    """

    stateful = True

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
        cycle = _offset_cycle(self.mask_size)
        plan_cycle = math.lcm(cycle, self.options.grid_period(block))
        self._plans: dict[tuple, SortPlan] = {}
        self._plan_slots = plan_cycle if plan_cycle * height * width <= _CACHE_BYTES else 0
        index_slots = cycle if cycle * 4 * height * width <= _CACHE_BYTES else 0
        self.retarget = None if retarget is None else Retarget(retarget, cache=index_slots)
        self.seeds, self.sampler = self._initial(sampler)
        self.sampler_name = self.sampler.name

    def _variant(self, retarget: bool) -> str:
        """The registry name of this variant."""
        return "temporal" if retarget else "temporal_sort"

    def _initial(self, sampler: str) -> tuple[torch.Tensor, Sampler]:
        """S_0 (distinct hashed seeds ``[H, W]`` int64) and the per-pixel sampler."""
        seeds = pixel_seeds(
            self.height, self.width, _stream_key(self.seed, 0, _STREAM_TEMPORAL), self.device
        )
        return seeds, _per_pixel_sampler(sampler)

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

    Args:
        spp: samples per pixel, a power of two (the sampler's blocks).
        (the others as :class:`TemporalStrategy`; ``sampler`` is not taken: it is ``zsobol``.)
    """

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
        self.spp = _power_of_two_spp(spp, "temporal_zsobol")
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

    def _variant(self, retarget: bool) -> str:
        return "temporal_zsobol"

    def _initial(self, sampler: str) -> tuple[torch.Tensor, Sampler]:
        key = _stream_key(self.seed, 0, _STREAM_TEMPORAL_ZSOBOL)
        zsobol = make_sampler(
            "zsobol", width=self.width, height=self.height, spp=self.spp, seed=key
        )
        return zsobol_keys(self.height, self.width, self.device), zsobol


class OracleStrategy(Strategy):
    """``oracle``: K candidate renders, per pixel the candidate at rank floor(b K) by luminance.

    The K renders go through ``render.batch`` when the renderer offers one (the tracer's
    :func:`renderers.tracer.render_batch`: the same frames bit for bit, faster at low spp).

    Every buffer of the chosen candidate is assembled per pixel (color, albedo, normal, ...), so
    the frame is one the renderer could have produced with the per-pixel chosen seed. Memory: the
    K candidate frames are held until the selection (K times one frame).
    """

    name = "oracle"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        sampler: str = "owen_sobol",
        mask: torch.Tensor,
        K: int = 32,
        device: torch.device | str = "cpu",
    ) -> None:
        self.K = check_positive_int(K, "K")
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = _per_pixel_sampler(sampler)
        self.sampler_name = sampler
        self.mask = mask
        self.mask_size = mask.shape[-1]

    def _bytes_per_pixel(self) -> int:
        return _per_pixel("oracle", self.K)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        seeds = [
            pixel_seeds(
                self.height, self.width, _stream_key(self.seed, t, _STREAM_ORACLE, k), self.device
            )
            for k in range(self.K)
        ]
        batch = getattr(render, "batch", None)  # the K renders at once, bit-identical
        if batch is not None:
            frames = batch(torch.stack(seeds), self.sampler)
        else:
            frames = [render(s, self.sampler) for s in seeds]
        device = frames[0].color.device
        lum = torch.stack([luminance(f.color.to(device)) for f in frames])
        b = tile_mask(
            self.mask.to(device), self.height, self.width, frame_offset(t, self.mask_size)
        )
        choice = histogram_select(lum, b)
        buffers = {}
        for name, first in frames[0].buffers().items():
            chosen = first.to(device).clone()
            for k in range(1, self.K):
                buf = getattr(frames[k], name)
                if buf is not None:
                    chosen = torch.where(choice == k, buf.to(device), chosen)
            buffers[name] = chosen
        timings: dict[str, float] = {}
        for f in frames:
            for key, ms in f.timings.items():
                timings[key] = timings.get(key, 0.0) + ms
        return Frame(**buffers, timings=timings)


# --------------------------------------------------------------------------------------------------
# Construction by name

#: The registered temporal variants (docs/METHODS.md, section 8): each option alone, then the
#: combinations the ablation measures. :func:`make_strategy` builds any well-formed variant
#: (:func:`parse_variant`); these are the ones the benchmark's command line knows by name.
VARIANTS: tuple[str, ...] = (
    "temporal+residual",
    "temporal+relative",
    "temporal+demod",
    "temporal+relative+demod",
    "temporal+groups",
    "temporal+groups_normal",
    "temporal+shift",
    "temporal+shift_r2",
    "temporal+reproject",
    "temporal+fast",
    "temporal+relative+demod+groups",
    "temporal+relative+demod+groups+reproject",
    "temporal_zsobol+relative+demod+groups",
)

#: The strategy names, as the benchmark tables name them.
STRATEGIES: tuple[str, ...] = tuple(
    sorted(
        (
            "bnds",
            "bnds_st",
            "cycles_blue",
            "oracle",
            "temporal",
            "temporal_sort",
            "temporal_zsobol",
            "white",
            "zsobol",
            "zsobol_t",
            *VARIANTS,
        )
    )
)

#: Strategy -> the sampler it dictates, whatever per-pixel sampler it is given; the strategies
#: not listed render with the per-pixel sampler they are given.
OWN_SAMPLERS: dict[str, str] = {
    "bnds": "bnds",
    "bnds_st": "bnds",
    "cycles_blue": "cycles_pure",
    "temporal_zsobol": "zsobol",
    "zsobol": "zsobol",
    "zsobol_t": "zsobol_t",
}

#: The STBN mask ``bnds_st`` dithers with: ``load_stbn("vector", 64, 32)``.
STBN_MASK = ("vector", 64, 32)


def _vector_dims(size: int, dimensions: int | None, mask_dims: int | None) -> int:
    """Channels of the shipped vector mask of size T with the fewest covering ``dimensions``."""
    if mask_dims is not None:
        return mask_dims
    dims = sorted(m[2] for m in shipped_masks() if m[0] == "vector" and m[1] == size)
    wanted = 2 if dimensions is None else dimensions
    return next((d for d in dims if d >= wanted), dims[-1] if dims else wanted)


def _vector_mask(size: int, dimensions: int | None, mask_dims: int | None) -> torch.Tensor:
    """The shipped vector mask of size T with the fewest channels covering ``dimensions``."""
    return load_mask("vector", size, _vector_dims(size, dimensions, mask_dims))


def _rival(
    name: str, height: int, width: int, spp: int | None, common: dict, channels: int
) -> Strategy:
    """The a-priori rivals: zsobol, cycles_blue, zsobol_t, bnds_st."""
    if name == "zsobol":
        return ZSobolStrategy(height, width, spp=spp, **common)
    if name == "cycles_blue":
        return CyclesBlueStrategy(height, width, spp=spp, **common)
    if name == "zsobol_t":
        return ZSobolTStrategy(height, width, spp=spp, **common)
    stbn = load_stbn(*STBN_MASK)
    return BNDSSTStrategy(height, width, stbn=stbn, channels=channels, **common)


def make_strategy(
    name: str,
    height: int,
    width: int,
    *,
    seed: int = 0,
    sampler: str = "owen_sobol",
    spp: int | None = None,
    mask_size: int = 64,
    block: int = 4,
    K: int = 32,
    dimensions: int | None = None,
    mask_dims: int | None = None,
    device: torch.device | str = "cpu",
) -> Strategy:
    """Build the strategy registered as ``name`` for ``height x width`` frames.

    Args:
        name: one of :data:`STRATEGIES`, or any temporal variant ``base+option+...``
            (:func:`parse_variant`: base ``temporal`` or ``temporal_zsobol``, options from
            :data:`VARIANT_OPTIONS` in that order, e.g. ``temporal+residual+groups+shift``).
        height, width: the frame size.
        seed: seed set index (>= 0): different seeds give independent runs.
        sampler: the per-pixel sampler of white, temporal, temporal_sort and oracle:
            ``"owen_sobol"`` (default) or ``"white"``; the strategies of :data:`OWN_SAMPLERS`
            ignore it (their ``sampler_name`` says what they render with).
        spp: samples per pixel the renders will take: required by zsobol, zsobol_t and
            temporal_zsobol (a power of two) and cycles_blue; ignored by the others.
        mask_size: T of the shipped masks (scalar for temporal and its kin and oracle, FAST with
            ``fast``, vector for bnds) and of the shipped retargeting fields.
        block: the sorting pass's block size (2..8).
        K: the oracle's number of candidates.
        dimensions: the integrand's dimensionality D (``scene.dimensions``); bnds takes the shipped
            vector mask with the fewest channels >= D (the most channels if none covers D), and
            bnds_st rotates as many dimensions with STBN slices.
        mask_dims: force the vector mask's channel count instead.
        device: where the seeds are made.

    Raises:
        UnknownNameError: unknown strategy or sampler name, or no shipped mask/field of that size.
        ValueRangeError: a frame size whose estimated memory (:func:`estimate_bytes`) exceeds
            what ``device`` has free, refused before anything is allocated; spp missing or not a
            power of two for a strategy that needs one.
    """
    _check_fits(name, height, width, estimate_bytes(name, 1, 1, K), torch.device(device))
    base, options = parse_variant(name)
    common = {"seed": seed, "device": device}
    if name == "white":
        return WhiteStrategy(height, width, sampler=sampler, **common)
    if name == "bnds":
        return BNDSStrategy(
            height, width, mask=_vector_mask(mask_size, dimensions, mask_dims), **common
        )
    if name in ("zsobol", "cycles_blue", "zsobol_t", "bnds_st"):
        channels = _vector_dims(mask_size, dimensions, mask_dims)
        return _rival(name, height, width, spp, common, channels)
    if name == "oracle":
        scalar = load_mask("scalar", mask_size)
        return OracleStrategy(height, width, sampler=sampler, mask=scalar, K=K, **common)
    return _temporal(base, height, width, sampler, spp, options, mask_size, block, common)


def _temporal(
    name: str,
    height: int,
    width: int,
    sampler: str,
    spp: int | None,
    options: TemporalOptions,
    mask_size: int,
    block: int,
    common: dict,
) -> TemporalStrategy:
    """temporal, temporal_sort and temporal_zsobol (``name``, the base) with ``options``, the
    shipped scalar mask and retargeting field of size T (with ``fast``, the shipped FAST mask of
    size T and its field)."""
    if options.fast:
        mask, field = load_fast_mask(mask_size), load_fast_retarget(mask_size)
    else:
        mask = load_mask("scalar", mask_size)
        field = load_retarget(mask_size) if name != "temporal_sort" else None
    passes = {"mask": mask, "block": block, "retarget": field, "options": options}
    if name == "temporal_zsobol":
        return TemporalZSobolStrategy(height, width, spp=spp, **passes, **common)
    return TemporalStrategy(height, width, sampler=sampler, **passes, **common)
