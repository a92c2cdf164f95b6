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

Not for: strategies that need more than the color of the previous frame (reprojection along
motion vectors, feature-aware grouping: future work in docs/METHODS.md), or choosing seeds for a
renderer that draws its own random numbers.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable

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
from bnerr.frame import Frame
from bnerr.hashing import MASK32, lowbias32_, lowbias32_host, signed32
from bnerr.masks import frame_offset, load_mask, r2_step, shipped_masks, tile_mask
from bnerr.permute import SortPass, SortPlan, histogram_select, plan_sort
from bnerr.retarget import Retarget, load_retarget
from bnerr.sequences import Sampler, make_sampler
from bnerr.timing import Stopwatch, sync

__all__ = [
    "STRATEGIES",
    "BNDSStrategy",
    "OracleStrategy",
    "RenderFn",
    "Strategy",
    "TemporalStrategy",
    "WhiteStrategy",
    "estimate_bytes",
    "make_strategy",
    "pixel_seeds",
]

#: ``render(seeds [H, W] int64, sampler) -> Frame``, with scene, t and spp bound by the caller.
RenderFn = Callable[[torch.Tensor, Sampler], Frame]

# Salts that keep the seed streams of the strategies apart (arbitrary odd 32-bit constants).
_SALT_FRAME = 0x9E3779B9
_SALT_STREAM = 0x85EBCA6B
_STREAM_WHITE, _STREAM_TEMPORAL, _STREAM_BNDS, _STREAM_ORACLE = 1, 2, 3, 4
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
# indices and output; the higher figure on the torch path), oracle with K = 4 172.
_SEED_BYTES = 44
_TEMPORAL_BYTES = 112
# The oracle holds K candidate frames and their luminance (4), then the choice (8), the assembled
# frame and one temporary of torch.where per buffer (2 frames) and a seed image.
_ORACLE_CANDIDATE_BYTES = _FRAME_BYTES + 4
_ORACLE_ONCE_BYTES = 8 + 2 * _FRAME_BYTES + _SEED_BYTES


def _per_pixel(name: str, K: int) -> int:
    """Estimated peak bytes per pixel of one frame of strategy ``name`` (K: oracle candidates)."""
    if name == "oracle":
        return K * _ORACLE_CANDIDATE_BYTES + _ORACLE_ONCE_BYTES
    if name in ("temporal", "temporal_sort"):
        return _FRAME_BYTES + _TEMPORAL_BYTES
    return _FRAME_BYTES + _SEED_BYTES


def estimate_bytes(name: str, height: int, width: int, K: int = 32) -> int:
    """Estimated peak bytes of one frame of strategy ``name`` at ``height x width``.

    Counts the strategy's own state and working memory and the rendered frames it holds at once
    (a frame with every buffer is 64 bytes per pixel); not the renderer's own working memory.

    Args:
        name: one of :data:`STRATEGIES`.
        height, width: the frame size.
        K: the oracle's number of candidates.

    Returns:
        Bytes (an int).
    """
    check_name(name, STRATEGIES, "strategy")
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


# --------------------------------------------------------------------------------------------------
# The interface


class Strategy:
    """Base class: :meth:`frame` checks and times the call, subclasses implement ``_frame``.

    Attributes:
        name: the registry name (``make_strategy(name)``).
        height, width: the image size every render must return.
        overhead_ms: wall milliseconds of the last :meth:`frame` spent outside ``render``.
    """

    name: str = ""

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
                reports its time in ``timings["render"]`` (milliseconds).

        Returns:
            The frame to show, with ``timings["render"]`` (the sum over this frame's renders,
            when they report it) and ``timings["strategy"] = overhead_ms``.
        """
        t = check_positive_int(t, "t", minimum=0)
        render_ms: list[float] = []

        def checked(seeds: torch.Tensor, sampler: Sampler) -> Frame:
            out = render(seeds, sampler)
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
        self.sampler = make_sampler(
            check_name(sampler, ("owen_sobol", "white"), "per-pixel sampler")
        )

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = _stream_key(self.seed, t, _STREAM_WHITE)
        return render(pixel_seeds(self.height, self.width, key, self.device), self.sampler)


class BNDSStrategy(Strategy):
    """``bnds``: one shared sequence per frame, dithered per pixel by the vector mask at offset o_t.

    The shared sequence's seed changes every frame (like white's seeds), and the per-pixel seeds
    (used by the dimensions beyond the mask's) are fresh every frame.
    """

    name = "bnds"

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


class TemporalStrategy(Strategy):
    """``temporal`` (sort and retarget) and ``temporal_sort`` (sort only), Heitz & Belcour 2019.

    State: the seed image S_t, a permutation of S_0 forever. Per frame: render S_t, then sort
    against the mask at offset o_t and, with ``retarget=True``, apply the retargeting field at
    o_t. The offsets cycle (16 distinct ones for T = 64, 128 for T = 128); the mask plans (1 byte
    per pixel) and the retargeting indices (4 bytes per pixel) of every offset are cached when a
    full cycle of them fits in 64 MB each, and not at all otherwise (a cache smaller than the cycle
    would never hit). At 1920x1080 with T = 64 the plans are cached and the indices are not.
    """

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
        device: torch.device | str = "cpu",
    ) -> None:
        self.name = "temporal" if retarget is not None else "temporal_sort"
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = make_sampler(
            check_name(sampler, ("owen_sobol", "white"), "per-pixel sampler")
        )
        self.mask = mask
        self.mask_size = mask.shape[-1]
        self.sorter = SortPass(block)
        cycle = _offset_cycle(self.mask_size)
        self._plans: dict[tuple, SortPlan] = {}
        self._plan_slots = cycle if cycle * height * width <= _CACHE_BYTES else 0
        index_slots = cycle if cycle * 4 * height * width <= _CACHE_BYTES else 0
        self.retarget = None if retarget is None else Retarget(retarget, cache=index_slots)
        self.seeds = pixel_seeds(
            height, width, _stream_key(self.seed, 0, _STREAM_TEMPORAL), self.device
        )

    def _plan(self, offset: tuple[int, int], device: torch.device) -> SortPlan:
        key = (offset, device)
        plan = self._plans.get(key)
        if plan is None:
            tiled = tile_mask(self.mask.to(device), self.height, self.width, offset)
            plan = plan_sort(tiled, self.sorter.block)
            if self._plan_slots:
                if len(self._plans) >= self._plan_slots:  # another device: start over
                    self._plans.clear()
                self._plans[key] = plan
        return plan

    def _frame(self, t: int, render: RenderFn) -> Frame:
        out = render(self.seeds, self.sampler)
        device = out.color.device
        offset = frame_offset(t, self.mask_size)
        seeds = self.sorter(self.seeds.to(device), out.color, self._plan(offset, device))
        if self.retarget is not None:
            seeds = self.retarget(seeds, offset)
        self.seeds = seeds
        return out


class OracleStrategy(Strategy):
    """``oracle``: K candidate renders, per pixel the candidate at rank floor(b K) by luminance.

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
        self.sampler = make_sampler(
            check_name(sampler, ("owen_sobol", "white"), "per-pixel sampler")
        )
        self.mask = mask
        self.mask_size = mask.shape[-1]

    def _bytes_per_pixel(self) -> int:
        return _per_pixel("oracle", self.K)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        frames = [
            render(
                pixel_seeds(
                    self.height,
                    self.width,
                    _stream_key(self.seed, t, _STREAM_ORACLE, k),
                    self.device,
                ),
                self.sampler,
            )
            for k in range(self.K)
        ]
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

#: The strategy names, as the benchmark tables name them.
STRATEGIES: tuple[str, ...] = ("bnds", "oracle", "temporal", "temporal_sort", "white")


def _vector_mask(size: int, dimensions: int | None, mask_dims: int | None) -> torch.Tensor:
    """The shipped vector mask of size T with the fewest channels covering ``dimensions``."""
    if mask_dims is None:
        dims = sorted(m[2] for m in shipped_masks() if m[0] == "vector" and m[1] == size)
        wanted = 2 if dimensions is None else dimensions
        mask_dims = next((d for d in dims if d >= wanted), dims[-1] if dims else wanted)
    return load_mask("vector", size, mask_dims)


def make_strategy(
    name: str,
    height: int,
    width: int,
    *,
    seed: int = 0,
    sampler: str = "owen_sobol",
    mask_size: int = 64,
    block: int = 4,
    K: int = 32,
    dimensions: int | None = None,
    mask_dims: int | None = None,
    device: torch.device | str = "cpu",
) -> Strategy:
    """Build the strategy registered as ``name`` for ``height x width`` frames.

    Args:
        name: one of :data:`STRATEGIES`.
        height, width: the frame size.
        seed: seed set index (>= 0): different seeds give independent runs.
        sampler: the per-pixel sampler of white, temporal, temporal_sort and oracle:
            ``"owen_sobol"`` (default) or ``"white"``.
        mask_size: T of the shipped masks (scalar for temporal, temporal_sort and oracle; vector
            for bnds) and of the shipped retargeting field.
        block: the sorting pass's block size (2..8).
        K: the oracle's number of candidates.
        dimensions: the integrand's dimensionality D (``scene.dimensions``); bnds takes the shipped
            vector mask with the fewest channels >= D (the most channels if none covers D).
        mask_dims: force the vector mask's channel count instead.
        device: where the seeds are made.

    Raises:
        UnknownNameError: unknown strategy or sampler name, or no shipped mask/field of that size.
        ValueRangeError: a frame size whose estimated memory (:func:`estimate_bytes`) exceeds
            what ``device`` has free; refused before anything is allocated.
    """
    need = estimate_bytes(name, height, width, K)
    _check_fits(name, height, width, need // (height * width), torch.device(device))
    common = {"seed": seed, "device": device}
    if name == "white":
        return WhiteStrategy(height, width, sampler=sampler, **common)
    if name == "bnds":
        return BNDSStrategy(
            height, width, mask=_vector_mask(mask_size, dimensions, mask_dims), **common
        )
    scalar = load_mask("scalar", mask_size)
    if name == "oracle":
        return OracleStrategy(height, width, sampler=sampler, mask=scalar, K=K, **common)
    field = load_retarget(mask_size) if name == "temporal" else None
    return TemporalStrategy(
        height, width, sampler=sampler, mask=scalar, block=block, retarget=field, **common
    )
