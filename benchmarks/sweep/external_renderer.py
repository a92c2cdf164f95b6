"""The sweep's parts with a renderer driven through the seed protocol (:mod:`renderers.external`).

``bnerr bench --renderer MANIFEST`` (or ``--renderer-cmd "TEMPLATE"``) measures the same cells as
with bnerr's tracer, on the one scene the program renders (named after its manifest): the
strategies and denoisers are :func:`benchmarks.sweep.parts.real_parts`', only the scene, the
renders and the references' renders come from the program. The references are the program's too,
at the suite's reference spp, with Owen-scrambled Sobol on the references' own white seeds
(:func:`benchmarks.sweep.references.reference_seeds`), cached under a key that holds the
program's fingerprint (:meth:`renderers.external.ExternalRenderer.fingerprint`).

Which strategies run (:func:`renderer_suite`): those whose renders use a sampler the manifest
lists: every per-pixel one (``white``, ``temporal`` and its variants, ``temporal_sort``, the
oracle) when it lists the sweep's per-pixel sampler (``owen_sobol``), and those that dictate
their own sampler (``ldbn``, ...) when it lists that one. A suite's strategies that cannot run
are left out with a note; one named on the command line is refused.

Which pixel regions (:func:`renderer_regions`): those whose buffers the manifest's ``buffers``
list (``coherent`` needs albedo, normal, depth and object_id; ``edges`` and ``unlit`` the object
ids: :data:`bnerr.metrics.regions.REGION_BUFFERS`). A renderer that gives colour only measures
every pixel; the regions left out are said once, before the first render.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import torch

from benchmarks.suites import Suite
from benchmarks.sweep.parts import Parts, Scene, real_parts
from benchmarks.sweep.plugins import load_specs
from bnerr import sequences
from bnerr.errors import UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from bnerr.metrics.regions import REGION_BUFFERS
from bnerr.strategies import OWN_SAMPLERS, parse_variant
from renderers.external import ExternalRenderer

__all__ = [
    "ExternalScene",
    "external_parts",
    "renderer_regions",
    "renderer_suite",
    "strategy_sampler",
]


@dataclass(frozen=True)
class ExternalScene:
    """The scene an external renderer draws, as the runner sees it: its name and the sampler
    dimensions one of its paths takes (the manifest's ``dimensions``)."""

    name: str
    dimensions: int


def external_parts(renderer: ExternalRenderer, specs: tuple[tuple[str, str], ...] = ()) -> Parts:
    """:func:`benchmarks.sweep.parts.real_parts` with ``renderer`` as the scene and renderer
    (module docstring). A depth condition is refused: the program's path length is its own."""
    base = real_parts(specs)

    def get_scene(name: str, animated: bool) -> Scene:
        load_specs(specs)
        if name != renderer.name:
            raise UnknownNameError(
                f"unknown scene {name!r}: expected the external renderer's {renderer.name!r}"
            )
        return ExternalScene(renderer.name, renderer.dimensions)

    def render(
        scene: Scene,
        t: int,
        seeds: torch.Tensor,
        sampler: Any,
        spp: int,
        *,
        compile: bool | None = None,
    ) -> Frame:
        return renderer.render(t, seeds, sampler, spp)

    def render_batch(scene: Scene, t: int, seeds: torch.Tensor, sampler: Any, spp: int) -> list:
        return renderer.render_batch(t, seeds, sampler, spp)

    def with_depth(scene: Scene, depth: int) -> Scene:
        raise ValueRangeError(
            f"{renderer.manifest.label}: expected no depth condition (its paths are its own), "
            f"got depth {depth}"
        )

    return dataclasses.replace(
        base,
        get_scene=get_scene,
        render=render,
        render_batch=render_batch,
        with_depth=with_depth,
        reference_sampler=lambda: sequences.make_sampler("owen_sobol"),
        code_version=f"{base.code_version}+{renderer.name}-{renderer.fingerprint()}",
    )


def strategy_sampler(name: str, per_pixel: str) -> str:
    """The sampler strategy ``name``'s renders use: its own (``OWN_SAMPLERS``), else the
    sweep's per-pixel sampler ``per_pixel``."""
    return OWN_SAMPLERS.get(parse_variant(name)[0], per_pixel)


def renderer_suite(
    suite: Suite, renderer: ExternalRenderer, named: bool
) -> tuple[Suite, tuple[str, ...]]:
    """``suite`` on the renderer's scene with the strategies it can render (module docstring),
    and the names left out. ``named``: the strategies were named on the command line, so one
    that cannot run is refused instead of left out.

    Raises:
        ValueRangeError: a named strategy (or a sweep's per-pixel sampler) whose sampler the
            manifest does not list, or a sweep left with no strategy.
    """
    listed = renderer.manifest.samplers
    sweeps, dropped = [], []
    for sweep in suite.sweeps:
        keep = []
        for name in sweep.strategies:
            samplers = {strategy_sampler(name, c.sampler) for c in sweep.conditions}
            if samplers <= set(listed):
                keep.append(name)
            elif named:
                raise ValueRangeError(
                    f"--strategies {name}: expected a strategy whose sampler "
                    f"{renderer.manifest.label} lists ({', '.join(listed)}), got one that "
                    f"renders with {', '.join(sorted(samplers - set(listed)))}"
                )
            else:
                dropped.append(name)
        if "white" not in keep:
            raise ValueRangeError(
                f"{renderer.manifest.label}: expected to render the white baseline, got no "
                f"sampler for it among {', '.join(listed)}"
            )
        sweeps.append(dataclasses.replace(sweep, scenes=(renderer.name,), strategies=tuple(keep)))
    return dataclasses.replace(suite, sweeps=tuple(sweeps)), tuple(dict.fromkeys(dropped))


def renderer_regions(suite: Suite, renderer: ExternalRenderer) -> tuple[Suite, tuple[str, ...]]:
    """``suite`` without the pixel regions whose buffers the renderer's manifest does not list
    (module docstring), and the regions left out, before anything renders.

    Raises:
        ValueRangeError: a sweep left with no region to measure (every condition of it needs a
            buffer the renderer does not give).
    """
    given = set(renderer.manifest.buffers)

    def can(region: str) -> bool:
        return set(REGION_BUFFERS.get(region, ())) <= given

    dropped = [c.region for s in suite.sweeps for c in s.conditions if not can(c.region)]
    if suite.coherent and not can("coherent"):
        dropped.append("coherent")
    sweeps = []
    for sweep in suite.sweeps:
        kept = tuple(c for c in sweep.conditions if can(c.region))
        if not kept:
            need = sorted({b for c in sweep.conditions for b in REGION_BUFFERS.get(c.region, ())})
            raise ValueRangeError(
                f"{renderer.manifest.label}: expected the buffers {', '.join(need)} for the "
                f"regions {', '.join(sorted({c.region for c in sweep.conditions}))}, got "
                f"buffers {', '.join(renderer.manifest.buffers)}"
            )
        sweeps.append(dataclasses.replace(sweep, conditions=kept))
    coherent = suite.coherent and can("coherent")
    out = dataclasses.replace(suite, sweeps=tuple(sweeps), coherent=coherent)
    return out, tuple(dict.fromkeys(dropped))
