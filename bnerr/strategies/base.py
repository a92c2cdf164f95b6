"""The strategy interface: :class:`Strategy`, the render callback it drives, its registry, seeds,
memory, and :func:`play`, the one loop that plays a strategy through its frames.

A strategy drives the renderer for its frame, rather than the renderer asking for seeds:
``strategy.frame(t, render)`` calls ``render(seeds [H, W] int64, sampler) -> Frame`` as often as
it needs (the caller binds scene, t and spp) and returns the frame to show.

**A new strategy is one file**: a subclass of :class:`Strategy` with a non-empty ``name``
registers itself in :data:`REGISTRY` (``bnerr.strategies.STRATEGIES``) when its module is
imported, and carries everything the rest of bnerr asks of it as class attributes and one class
method: its ``name``, the sampler it dictates (``own_sampler``, or None for the per-pixel sampler
it is given), its seed ``stream`` (distinct per class), its memory per pixel
(``bytes_per_pixel``, or :meth:`Strategy.peak_bytes_per_pixel`), whether it is ``stateful``, and
:meth:`Strategy.create`, which builds it from the :class:`BuildOptions` of
:func:`bnerr.strategies.make_strategy`.

**Timings: one stopwatch per render.** A render reports its own time in its frame's
``timings["render"]`` (the tracer fills it); the strategy does not time the renders again. The
returned frame's ``timings["render"]`` is the sum over the strategy's renders (the oracle renders
K candidates) and ``timings["strategy"]`` (also ``strategy.overhead_ms``) is the wall time of the
whole :meth:`Strategy.frame` minus that sum: seed generation, sorting, retargeting, selection. A
render that reports no time counts as 0 ms, so its time lands in the overhead.

**Memory.** :func:`bnerr.strategies.make_strategy` and the constructors refuse a frame size whose
estimated memory exceeds what the device has available (:func:`bnerr.errors.check_memory`),
before allocating anything.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import torch

from bnerr.errors import (
    DtypeError,
    ShapeError,
    ValueRangeError,
    check_memory,
    check_name,
    check_positive_int,
)
from bnerr.frame import Frame
from bnerr.hashing import MASK32, lowbias32_, lowbias32_host, signed32
from bnerr.masks import r2_step
from bnerr.sequences import Sampler, make_sampler, per_pixel_samplers
from bnerr.strategies.registry import REGISTRY
from bnerr.strategies.variants import TemporalOptions
from bnerr.timing import Stopwatch, sync

__all__ = [
    "FRAME_BYTES",
    "BuildOptions",
    "RenderFn",
    "Strategy",
    "as_render",
    "first_frame",
    "offset_cycle",
    "per_pixel_sampler",
    "pixel_seeds",
    "play",
    "power_of_two_spp",
    "stream_key",
]

# Salts that keep the seed streams of the strategies apart (arbitrary odd 32-bit constants).
_SALT_FRAME = 0x9E3779B9
_SALT_STREAM = 0x85EBCA6B

# A rendered Frame with every buffer: color, albedo, normal, variance (3 each), motion (2), depth
# and object_id (1 each): 16 float32 channels.
FRAME_BYTES = 16 * 4


# --------------------------------------------------------------------------------------------------
# Seeds


def stream_key(seed: int, t: int, stream: int, k: int = 0) -> int:
    """The 32-bit key of seed set ``seed``, frame ``t``, a strategy's ``stream`` and candidate k.

    Distinct streams (each class's :attr:`Strategy.stream`) give unrelated keys for the same seed
    set and frame, so that no two strategies share their seeds by accident.
    """
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


def offset_cycle(size: int) -> int:
    """How many distinct offsets ``frame_offset(t, T)`` takes: the lcm of T / gcd(step_i, T)."""
    dy, dx = r2_step(size)
    return math.lcm(size // math.gcd(dy, size), size // math.gcd(dx, size))


def per_pixel_sampler(name: str) -> Sampler:
    """The per-pixel sampler of white, temporal, temporal_sort and oracle (checked by name):
    ``owen_sobol``, ``white`` or a plug-in sampler (:func:`bnerr.sequences.per_pixel_samplers`)."""
    return make_sampler(check_name(name, per_pixel_samplers(), "per-pixel sampler"))


def power_of_two_spp(spp: object, strategy: str) -> int:
    """``spp`` checked: an int >= 1 and a power of two (the Z-order samplers' block length)."""
    if spp is None:
        raise ValueRangeError(f"spp: expected the samples per pixel for {strategy}, got None")
    spp = check_positive_int(spp, "spp")
    if spp & (spp - 1):
        raise ValueRangeError(
            f"spp: expected a power of two for {strategy} (its per-pixel blocks), got {spp}"
        )
    return spp


def check_fits(what: str, height: int, width: int, per_pixel: int, device: torch.device) -> None:
    """Refuse a frame size whose ``height * width * per_pixel`` bytes exceed free memory.

    Raises:
        ValueRangeError: more than 2^31 pixels. MemoryLimitError: more bytes than ``device`` has
            (:func:`bnerr.errors.check_memory`).
    """
    if height * width > 1 << 31:
        raise ValueRangeError(
            f"height * width: expected at most 2^31 pixels, got {width} x {height} = "
            f"{height * width}"
        )
    name = f"{what} strategy at {width} x {height} ({per_pixel} bytes per pixel)"
    check_memory(height * width * per_pixel, name, device)


# --------------------------------------------------------------------------------------------------
# The render callback


@runtime_checkable
class RenderFn(Protocol):
    """The renderer as a strategy sees it, with scene, t and spp bound by the caller.

    ``render(seeds [H, W] int64, sampler) -> Frame`` renders one seed image;
    ``render.batch(seeds [K, H, W], sampler) -> list[Frame]`` renders K of them, the same frames
    bit for bit (at once where the renderer can: :func:`renderers.tracer.render_batch`; the oracle
    uses it). :func:`as_render` gives a plain function a ``batch`` that renders one at a time.
    """

    def __call__(self, seeds: torch.Tensor, sampler: Sampler) -> Frame: ...

    def batch(self, seeds: torch.Tensor, sampler: Sampler) -> list[Frame]: ...


class _Render:
    """A :class:`RenderFn` from a one-image render and, optionally, its batch form."""

    def __init__(
        self,
        one: Callable[[torch.Tensor, Sampler], Frame],
        many: Callable[[torch.Tensor, Sampler], list[Frame]] | None = None,
    ) -> None:
        self.one, self.many = one, many

    def __call__(self, seeds: torch.Tensor, sampler: Sampler) -> Frame:
        return self.one(seeds, sampler)

    def batch(self, seeds: torch.Tensor, sampler: Sampler) -> list[Frame]:
        if self.many is not None:
            return list(self.many(seeds, sampler))
        return [self.one(s, sampler) for s in seeds]


def as_render(
    render: Callable[[torch.Tensor, Sampler], Frame],
    batch: Callable[[torch.Tensor, Sampler], list[Frame]] | None = None,
) -> RenderFn:
    """``render`` as a :class:`RenderFn`: its own ``batch`` if it has one (or ``batch`` given),
    else one render per seed image."""
    if batch is None and isinstance(render, RenderFn):
        return render
    return _Render(render, batch)


class _MotionScaled:
    """A :class:`RenderFn` whose frames' motion buffers are multiplied by ``scale``."""

    def __init__(self, render: RenderFn, scale: int) -> None:
        self.render, self.scale = render, scale

    def _scaled(self, frame: Frame) -> Frame:
        if self.scale != 1 and isinstance(frame, Frame) and frame.motion is not None:
            return dataclasses.replace(frame, motion=frame.motion * self.scale)
        return frame

    def __call__(self, seeds: torch.Tensor, sampler: Sampler) -> Frame:
        return self._scaled(self.render(seeds, sampler))

    def batch(self, seeds: torch.Tensor, sampler: Sampler) -> list[Frame]:
        return [self._scaled(f) for f in self.render.batch(seeds, sampler)]


# --------------------------------------------------------------------------------------------------
# What make_strategy passes on


@dataclass(frozen=True)
class BuildOptions:
    """What :func:`bnerr.strategies.make_strategy` was asked for, passed to :meth:`Strategy.create`
    (each strategy takes what it needs and ignores the rest; see make_strategy's arguments)."""

    seed: int = 0
    sampler: str = "owen_sobol"
    spp: int | None = None
    mask_size: int = 64
    block: int = 4
    K: int = 32
    dimensions: int | None = None
    mask_dims: int | None = None
    device: torch.device | str = "cpu"

    @property
    def common(self) -> dict:
        """The arguments every strategy's constructor takes: ``seed`` and ``device``."""
        return {"seed": self.seed, "device": self.device}


# --------------------------------------------------------------------------------------------------
# The interface


class Strategy:
    """Base class: :meth:`frame` checks and times the call, subclasses implement ``_frame``.

    Class attributes (a subclass with a ``name`` registers itself in :data:`REGISTRY`):
        name: the registry name (``make_strategy(name)``); instances of the temporal strategies
            carry their variant's name (``temporal+relative``).
        own_sampler: the sampler this strategy dictates, whatever per-pixel sampler it is given
            (``bnds``, ``zsobol``, ...), or None: it renders with the per-pixel sampler given.
        stream: the seed stream that keeps its seeds apart from every other strategy's
            (:func:`stream_key`): a class that sets one must not reuse another's; a subclass
            that inherits it shares its parent's seeds on purpose (temporal_sort, temporal).
        bytes_per_pixel: working memory per pixel of one frame beyond the frame it renders
            (:meth:`peak_bytes_per_pixel` adds the frame; measured, see the subclasses).
        stateful: whether frame t depends on the frames before it (the temporal strategies); a
            stateless strategy's frame t is the same whether or not frames 0..t-1 were made.
        family: what kind of strategy it is, for the reports' colours, line styles and verdicts:
            ``"baseline"`` (white, the control), ``"rival"`` (a-priori patterns), ``"temporal"``
            (a-posteriori permutations), ``"ldbn"``, ``"bound"`` (renders several candidates per
            frame: a bound, not a strategy to adopt) or a new family's own name (``"other"``: none
            declared).
        rank: its place in the reports' tables and legends, lower first (ties by name); the
            shipped strategies use 0..130, one not declaring any comes after them.
        raw_mse_note: why its raw MSE may differ from white's (what it samples differently, and
            where that was measured); ``""`` when it should not differ.
        bound_note: for a bound, why the decision table leaves it out; ``""`` otherwise.
        color: its fixed ``#rrggbb`` colour in every chart, or None: a shade of its family's hue
            (:mod:`benchmarks.reports.palette`). Not inherited: a subclass that sets none gets
            a shade of its family's hue, not its parent's colour.
        Subclasses inherit the others unless they set their own;
        :func:`bnerr.strategies.strategy_identity` reads them by name (a temporal variant takes
        its base's).

    Attributes:
        height, width: the image size every render must return.
        overhead_ms: wall milliseconds of the last :meth:`frame` spent outside ``render``.
        sampler_name: the sampler the renders use: ``own_sampler`` or the per-pixel one given.
    """

    name: str = ""
    own_sampler: ClassVar[str | None] = None
    stream: ClassVar[int] = 0
    bytes_per_pixel: ClassVar[int] = 44
    stateful: ClassVar[bool] = False
    family: ClassVar[str] = "other"
    rank: ClassVar[int] = 1000
    raw_mse_note: ClassVar[str] = ""
    bound_note: ClassVar[str] = ""
    color: ClassVar[str | None] = None
    sampler_name: str = ""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__ and cls.name:
            REGISTRY.add(cls)

    def __init__(
        self, height: int, width: int, *, seed: int = 0, device: torch.device | str = "cpu"
    ) -> None:
        self.height = check_positive_int(height, "height")
        self.width = check_positive_int(width, "width")
        self.seed = check_positive_int(seed, "seed", minimum=0)
        self.device = torch.device(device)
        self.overhead_ms = 0.0
        if self.own_sampler is not None:
            self.sampler_name = self.own_sampler
        check_fits(self.name, height, width, self._bytes_per_pixel(), self.device)

    @classmethod
    def peak_bytes_per_pixel(cls, K: int = 32, options: TemporalOptions | None = None) -> int:
        """Estimated peak bytes per pixel of one frame: the rendered frame and the working memory
        (``K``: the oracle's candidates, ``options``: a temporal variant's; others ignore them)."""
        return FRAME_BYTES + cls.bytes_per_pixel

    def _bytes_per_pixel(self) -> int:
        return self.peak_bytes_per_pixel()

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        """Build this strategy from :func:`bnerr.strategies.make_strategy`'s arguments."""
        raise NotImplementedError(f"{cls.__qualname__}.create")

    def frame(self, t: int, render: Callable[[torch.Tensor, Sampler], Frame]) -> Frame:
        """Choose seeds, render (once or more) and return frame ``t``.

        Args:
            t: frame index >= 0 (it selects the masks' offset and the fresh seeds).
            render: a :class:`RenderFn`, or a plain ``render(seeds [H, W] int64, sampler) ->
                Frame`` (:func:`as_render`), of size ``H x W``, that reports its time in
                ``timings["render"]`` (milliseconds).

        Returns:
            The frame to show, with ``timings["render"]`` (the sum over this frame's renders,
            when they report it) and ``timings["strategy"] = overhead_ms``.
        """
        t = check_positive_int(t, "t", minimum=0)
        checked = _Checked(as_render(render), self.height, self.width)
        sync(self.device)
        watch = Stopwatch()
        out = self._frame(t, checked)
        self.overhead_ms = max(0.0, watch.ms(out.color) - sum(checked.render_ms))
        timings = {**out.timings, "strategy": self.overhead_ms}
        if checked.render_ms:
            timings["render"] = sum(checked.render_ms)
        return dataclasses.replace(out, timings=timings)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.height}x{self.width}, seed={self.seed})"


class _Checked:
    """A :class:`RenderFn` that checks every frame's type and size and collects render times."""

    def __init__(self, render: RenderFn, height: int, width: int) -> None:
        self.render, self.height, self.width = render, height, width
        self.render_ms: list[float] = []

    def _check(self, out: object) -> Frame:
        if not isinstance(out, Frame):
            raise DtypeError(f"render: expected a Frame, got {type(out).__name__}")
        if (out.height, out.width) != (self.height, self.width):
            raise ShapeError(
                f"render: expected a {self.width} x {self.height} frame (width x height), "
                f"got {out.width} x {out.height}"
            )
        if "render" in out.timings:
            self.render_ms.append(float(out.timings["render"]))
        return out

    def __call__(self, seeds: torch.Tensor, sampler: Sampler) -> Frame:
        return self._check(self.render(seeds, sampler))

    def batch(self, seeds: torch.Tensor, sampler: Sampler) -> list[Frame]:
        return [self._check(out) for out in self.render.batch(seeds, sampler)]


# --------------------------------------------------------------------------------------------------
# Playing a strategy through its frames


def first_frame(strategy: Strategy, frames: range, in_order: bool = False) -> int:
    """The first frame :func:`play` renders: 0 for a stateful strategy (or ``in_order``, e.g. for
    a stateful denoiser that must see every frame), else ``frames.start``."""
    return 0 if in_order or strategy.stateful else frames.start


def play(
    strategy: Strategy,
    render_at: Callable[[int], Callable[[torch.Tensor, Sampler], Frame]],
    frames: range,
    motion: int = 1,
    *,
    in_order: bool = False,
) -> Iterator[tuple[int, Frame]]:
    """Play ``strategy`` through ``frames``: yield ``(t, frame)`` for each frame it renders.

    The one loop every caller uses (the benchmark's measuring and tuning, animations, ``bnerr
    render``, the training data), so that they all see the same frames bit for bit.

    Args:
        strategy: a fresh strategy (a stateful one carries its seeds from call to call).
        render_at: ``render_at(k) -> render``: the renderer bound to its own frame ``k`` (a
            :class:`RenderFn` or a plain function, :func:`as_render`).
        frames: the frames wanted, ``range(start, stop)``. Frames before ``start`` are rendered
            (and yielded: the caller filters ``t >= frames.start``) when the strategy is stateful
            or ``in_order`` is set (:func:`first_frame`).
        motion: the animation's speed-up ``k >= 1``: strategy frame t is the renderer's frame
            ``k t``, whose motion buffer says how far a pixel moved since renderer frame
            ``k t - 1``; the strategy's previous frame is ``k (t - 1)``, so the motion it (and a
            temporal denoiser) sees is scaled by ``k`` (exact for linear motion, a first-order
            estimate for orbits).
    """
    motion = check_positive_int(motion, "motion")
    for t in range(first_frame(strategy, frames, in_order), frames.stop):
        render = _MotionScaled(as_render(render_at(motion * t)), motion)
        yield t, strategy.frame(t, render)
