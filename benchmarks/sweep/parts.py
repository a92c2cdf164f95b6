"""The parts the benchmark drives (scenes, renderer, strategies, denoisers), as typed callables.

The runner reaches every part through :class:`Parts`, so that it can be tested with stand-ins and
stays generic: it never branches on a strategy's or denoiser's name. :func:`real_parts` gives the
project's own parts; :func:`known_names` the names their registries know (for checking the
command line's overrides).

The protocols say what the runner needs of each part and nothing more: a scene has
``dimensions`` (D, the sampler dimensions one path consumes); a strategy has ``frame(t, render)``
and ``overhead_ms``; a denoiser maps a :class:`bnerr.frame.Frame` to a ``[3, H, W]`` image and may
expose ``params()``.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import torch

import denoisers
import renderers
from benchmarks.sweep.plugins import load_specs
from benchmarks.sweep.version import code_version
from bnerr import metrics, sequences, strategies
from bnerr.errors import ValueRangeError, check_device
from bnerr.frame import Frame
from denoisers import tuning
from renderers.cycles import CYCLES_STRATEGIES, CyclesPattern, make_pattern_strategy

if TYPE_CHECKING:
    from bnerr.sequences import Sampler
    from denoisers.tuning import TuneResult

__all__ = [
    "BatchRenderer",
    "BoundRender",
    "Denoiser",
    "Parts",
    "Renderer",
    "Scene",
    "StatefulDenoiser",
    "Strategy",
    "known_names",
    "real_parts",
    "render_any",
    "render_batch_any",
]


class Scene(Protocol):
    """What the runner reads of a scene."""

    @property
    def dimensions(self) -> int: ...


class Renderer(Protocol):
    """``render(scene, t, seeds [H, W] int64, sampler, spp, *, compile=None) -> Frame``.

    The frame reports the render's wall time in ``timings["render"]`` (milliseconds). ``compile``
    is the tracer's (:func:`renderers.render`): None is eager unless the environment says
    otherwise, True runs its per-vertex stage through ``torch.compile``. The strategies' renders
    pass nothing; the references pass :func:`benchmarks.sweep.references.reference_compile`.
    """

    def __call__(
        self,
        scene: Scene,
        t: int,
        seeds: torch.Tensor,
        sampler: Sampler,
        spp: int,
        *,
        compile: bool | None = None,
    ) -> Frame: ...


class BatchRenderer(Protocol):
    """``render_batch(scene, t, seeds [K, H, W] int64, sampler, spp) -> list[Frame]``: the K
    frames of :class:`Renderer` (called without ``compile``) for ``seeds[k]``, bit-identical to
    them, at once (:func:`renderers.render_batch`)."""

    def __call__(
        self, scene: Scene, t: int, seeds: torch.Tensor, sampler: Sampler, spp: int
    ) -> list[Frame]: ...


#: A seed strategy: the library's :class:`bnerr.strategies.Strategy`, because the runner plays it
#: with :func:`bnerr.strategies.play`. Of it the runner reads ``frame(t, render)``,
#: ``overhead_ms``, ``sampler_name`` (the sampler its renders use: the run's per-pixel ``sampler``
#: condition, or the one the strategy dictates, :data:`bnerr.strategies.OWN_SAMPLERS`; the records
#: keep it) and ``stateful`` (whether a frame depends on the earlier frames); a stand-in needs
#: those alone.
Strategy = strategies.Strategy


class Denoiser(Protocol):
    """``denoiser(frame) -> [3, H, W]`` float32 image."""

    def __call__(self, frame: Frame) -> torch.Tensor: ...


class StatefulDenoiser(Protocol):
    """A denoiser whose output depends on the frames it saw (``stateful`` true: ``taa``,
    ``svgf``): told each frame's index, reset at the start of a sequence."""

    stateful: bool

    def __call__(self, frame: Frame, *, t: int) -> torch.Tensor: ...

    def reset(self) -> None: ...


@dataclass(frozen=True)
class Parts:
    """The renderer, strategies and denoisers, as the runner calls them.

    Attributes:
        get_scene: ``(name, animated) -> scene``.
        render: the :class:`Renderer`.
        make_strategy: ``(name, scene, height, width, seed, sampler, spp) -> Strategy``:
            ``sampler`` the per-pixel sampler condition (a strategy with its own sampler ignores
            it), ``spp`` the samples per pixel its renders take (the Z-order samplers' block
            length).
        make_denoiser: ``(name, params) -> Denoiser`` (``params`` from ``tune_denoiser``, or None
            for a denoiser without parameters).
        tune_denoiser: ``(name, frames, references [3, H, W]) -> TuneResult | None``: grid-search
            the denoiser's parameters on white-noise frames (:func:`denoisers.tuning.tune`); None
            for a denoiser that has nothing to tune.
        reference_sampler: ``() -> Sampler`` used for the references.
        with_depth: ``(scene, depth) -> scene`` with its maximum path depth replaced.
        code_version: a string that changes whenever a reference's pixels could change: the
            renderer's and the samplers' source code
            (:func:`benchmarks.sweep.version.code_version`).
        render_batch: the :class:`BatchRenderer` (the oracle's K candidates at once, each
            bit-identical to its :attr:`render`), or None to render them one by one.
        plugins: the command line's plug-in specs, ``(group, spec)`` pairs
            (:mod:`benchmarks.sweep.plugins`): :func:`real_parts`' callables load them again
            wherever they run (a Ray worker), so the cells' names resolve there too.
        scene_version: ``(name) -> str``, what identifies a scene's content beyond
            ``code_version`` ("" for the shipped scenes; a plug-in scene's file hash, a Mitsuba
            scene's files and Mitsuba's version): enters the references' cache key.
        device: the torch device the sweep renders, denoises and measures on (``bnerr bench
            --device``): :func:`real_parts` makes the strategies' seeds there and moves every
            seed image its render gets there, so the frames, the denoised images and the metrics
            follow; the references are moved there (:mod:`benchmarks.sweep.references`).

    Whether a strategy's frame depends on the earlier frames is its own ``stateful``
    (:class:`Strategy`): only those render the warmup frames; a stateless strategy's frame t is
    the same whether or not frames 0..t-1 were rendered, so the runner skips them (the oracle's
    warmup would cost K renders per frame for nothing).
    """

    get_scene: Callable[[str, bool], Scene]
    render: Renderer
    make_strategy: Callable[[str, Scene, int, int, int, str, int], Strategy]
    make_denoiser: Callable[[str, dict | None], Denoiser]
    tune_denoiser: Callable[[str, list[Frame], list[torch.Tensor]], TuneResult | None]
    reference_sampler: Callable[[], Sampler]
    with_depth: Callable[[Scene, int], Scene]
    code_version: str
    render_batch: BatchRenderer | None = None
    plugins: tuple[tuple[str, str], ...] = ()
    scene_version: Callable[[str], str] = lambda name: ""
    device: str = "cpu"


class BoundRender:
    """The ``render(seeds, sampler)`` a strategy calls (:class:`bnerr.strategies.RenderFn`), with
    scene, the renderer's frame ``t_render`` and spp bound (no clock: the frame carries the
    renderer's own time). ``render_at`` of :func:`bnerr.strategies.play`, which also scales the
    motion of a faster animation: ``play(strategy, lambda k: BoundRender(parts, scene, spp, k),
    frames, motion)``.
    """

    def __init__(self, parts: Parts, scene: Scene, spp: int, t_render: int = 0) -> None:
        self.parts, self.scene, self.spp, self.t_render = parts, scene, spp, t_render

    def __call__(self, seeds: torch.Tensor, sampler: Any) -> Frame:
        return self.parts.render(self.scene, self.t_render, seeds, sampler, self.spp)

    def batch(self, seeds: torch.Tensor, sampler: Any) -> list[Frame]:
        """The renders of ``seeds [K, H, W]`` (the oracle's candidates): at once where the parts
        have a batch render, else one by one (the same frames bit for bit)."""
        if self.parts.render_batch is None:
            return [self(s, sampler) for s in seeds]
        return self.parts.render_batch(self.scene, self.t_render, seeds, sampler, self.spp)


def render_any(
    scene: Scene,
    t: int,
    seeds: torch.Tensor,
    sampler: Sampler,
    spp: int,
    *,
    compile: bool | None = None,
    device: torch.device | str | None = None,
) -> Frame:
    """The :class:`Renderer` of :func:`real_parts`: bnerr's tracer (:func:`renderers.render`),
    or the scene's own ``render(t, seeds, sampler, spp)`` for a scene that renders itself (a
    Mitsuba XML scene, :class:`renderers.mitsuba_scene.MitsubaScene`; ``compile`` is the
    tracer's and does not apply). ``device``: where the tracer renders (the seeds are moved
    there; None: where they are); a scene that renders itself renders where it renders."""
    if renderers.renders_itself(scene):
        return scene.render(t, seeds, sampler, spp)  # type: ignore[attr-defined]
    if isinstance(sampler, CyclesPattern):
        raise ValueRangeError(
            f"--strategies {sampler.name}: expected a Cycles scene for Cycles' own pattern, got "
            f"bnerr's scene {getattr(scene, 'name', scene)!r}"
        )
    if device is not None:
        seeds = seeds.to(device)
    return renderers.render(_own(scene), t, seeds, sampler, spp, compile=compile)


def render_batch_any(
    scene: Scene,
    t: int,
    seeds: torch.Tensor,
    sampler: Sampler,
    spp: int,
    *,
    device: torch.device | str | None = None,
) -> list[Frame]:
    """:func:`renderers.render_batch` (K seed images ``[K, H, W]`` at once), or one by one for a
    scene that renders itself (:func:`render_any`); ``device`` as :func:`render_any`'s."""
    if renderers.renders_itself(scene):
        return [render_any(scene, t, s, sampler, spp) for s in seeds]
    if device is not None:
        seeds = seeds.to(device)
    return renderers.render_batch(_own(scene), t, seeds, sampler, spp)


def real_parts(specs: tuple[tuple[str, str], ...] = (), device: str = "cpu") -> Parts:
    """The project's own parts: ``renderers`` (and a scene's own renderer, :func:`render_any`),
    :mod:`bnerr.strategies` and ``denoisers``, with the plug-ins of ``specs`` (``(group, spec)``
    pairs) loaded again by each call, rendering on ``device`` (:attr:`Parts.device`).

    Raises:
        ValueRangeError: ``device`` is not available here (:func:`bnerr.errors.check_device`).
    """
    where = str(check_device(device, "device"))

    def get_scene(name: str, animated: bool) -> Scene:
        load_specs(specs)  # first in every unit of work: a fresh worker registers the plug-ins
        return renderers.get_scene(name, animated=animated)

    def make_denoiser(name: str, params: dict | None) -> Denoiser:
        load_specs(specs)
        return denoisers.get_denoiser(name, **(params or {}))

    def tune_denoiser(
        name: str, frames: list[Frame], refs: list[torch.Tensor]
    ) -> TuneResult | None:
        return tuning.tune(name, frames, refs) if name in tuning.GRIDS else None

    def make_strategy(
        name: str, scene: Scene, height: int, width: int, seed: int, sampler: str, spp: int
    ) -> Strategy:
        load_specs(specs)
        return _strategy_on(scene, name, (height, width), seed, sampler, spp, where)

    def scene_version(name: str) -> str:
        load_specs(specs)
        return renderers.scene_version(name)

    def reference_sampler() -> Sampler:
        # Owen-scrambled Sobol converges faster than white noise at equal spp, so the reference
        # noise floor is lower for the same render time; it is unbiased like white noise.
        return sequences.make_sampler("owen_sobol")

    return Parts(
        get_scene=get_scene,
        render=functools.partial(render_any, device=where),
        make_strategy=make_strategy,
        make_denoiser=make_denoiser,
        tune_denoiser=tune_denoiser,
        reference_sampler=reference_sampler,
        with_depth=lambda scene, depth: dataclasses.replace(_own(scene), max_depth=depth),
        code_version=code_version(),
        render_batch=functools.partial(render_batch_any, device=where),
        plugins=tuple(specs),
        scene_version=scene_version,
        device=where,
    )


def _strategy_on(
    scene: Scene,
    name: str,
    size: tuple[int, int],
    seed: int,
    sampler: str,
    spp: int,
    device: str,
) -> Strategy:
    """Strategy ``name`` for ``scene`` at ``size`` (H, W): one of Cycles' own patterns on a Cycles
    scene (Cycles takes one seed per frame, not per pixel), else bnerr's strategy."""
    height, width = size
    if renderers.is_cycles(scene):
        where = getattr(scene, "name", "")
        return make_pattern_strategy(name, height, width, seed=seed, scene=where, device=device)
    return strategies.make_strategy(
        name,
        height,
        width,
        seed=seed,
        sampler=sampler,
        spp=spp,
        dimensions=scene.dimensions,
        device=device,
    )


def _own(scene: Scene) -> renderers.Scene:
    """The renderer's own scene behind the runner's view of it: what :func:`real_parts`'
    ``get_scene`` made."""
    assert isinstance(scene, renderers.Scene)  # real_parts' scenes are the renderer's
    return scene


def known_names() -> dict[str, tuple[str, ...]]:
    """The installed registries (plug-ins included), for checking ``--scenes``, ``--strategies``,
    ``--denoisers``, ``--samplers`` and ``--metrics``.

    The denoisers include ``NAME:own`` for every one with a tuning grid (tuned on the strategy's
    own frames, :mod:`benchmarks.sweep.measure`).
    """
    own = tuple(f"{name}:own" for name in denoisers.DENOISERS if name in tuning.GRIDS)
    return {
        "known_scenes": tuple(renderers.SCENES),
        "known_strategies": tuple(dict.fromkeys((*strategies.STRATEGIES, *CYCLES_STRATEGIES))),
        "known_denoisers": tuple(denoisers.DENOISERS) + own,
        "known_samplers": sequences.per_pixel_samplers(),
        "known_metrics": tuple(metrics.METRIC_TABLE),
    }
