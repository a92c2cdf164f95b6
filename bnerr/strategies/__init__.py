"""Seed strategies: how each frame's per-pixel seeds are chosen, and the renders that takes.

A strategy drives the renderer for its frame, rather than the renderer asking for seeds:
``strategy.frame(t, render)`` calls ``render(seeds [H, W] int64, sampler) -> Frame`` as often as
it needs (the caller binds scene, t and spp) and returns the frame to show; :func:`play` is the one
loop that plays a strategy through its frames. The interface, timings, memory and registry are in
:mod:`bnerr.strategies.base`; one module per family holds its strategies (docs/METHODS.md,
sections 3, 4, 5, 7 and 8):

- ``white``: ``white``, fresh hashed seeds every frame: the control;
- ``dithered``: ``bnds``, ``bnds_st``, one sequence rotated per pixel by a blue-noise mask;
- ``zorder``: ``zsobol``, ``cycles_blue``, ``zsobol_t``: pbrt-v4's ZSobol, Cycles' blue-noise
  pattern, temporal Z-order;
- ``openqmc``: ``openqmc_sobolbn``, ``openqmc_latticebn``: OpenQMC's blue-noise samplers, per-pixel
  ranks and keys from its 256x256 tables over Sobol or a rank-1 lattice;
- ``ldbn``: ``ldbn``, ``ldbn_st``, ``ldbn_fast``, ``ldbn_atrous``: per-pixel ranking and
  scrambling keys over one shared sequence (Heitz et al. 2019), optimized here for the screen,
  for time and for the denoisers (a Gaussian; the a-trous filter's measured kernel);
- ``temporal``: ``temporal``, ``temporal_sort``, ``temporal_zsobol``, ``temporal_ldbn``: Heitz &
  Belcour 2019's sort and retarget passes (over hashed seeds, ZSobol's keys, LDBN's keys), and
  their variants ``temporal+option...`` (``variants``);
- ``oracle``: ``oracle``, K renders per frame, the a-posteriori bound.
- ``vertical``: ``vertical``, the oracle's K renders chosen per pixel for the whole image's
  sigma-2 blurred error (a second bound, :mod:`bnerr.permutation.vertical`).

**Which sampler renders.** Every strategy has ``sampler_name``, the sampler its renders use.
``white``, ``temporal``, ``temporal_sort`` and ``oracle`` take the per-pixel sampler they are
given (the benchmark's ``sampler`` condition: ``"owen_sobol"`` by default, ``"white"`` for a
hash), so the set of sequences a frame uses is statistically the same and raw MSE must agree
across them: only where the error lands differs. The others dictate their own (their class's
``own_sampler``, collected in :data:`OWN_SAMPLERS`) and ignore the condition; the benchmark
records ``sampler_name`` with each cell.

**A new strategy** is one module in this package: a :class:`Strategy` subclass with a ``name``
registers itself when imported (import it here, or from anywhere before ``make_strategy``). It
carries its identity for the reports as class attributes (``family``, ``rank``,
``raw_mse_note``, ...); :func:`strategy_identity` reads it by name alone (a variant takes its
base's, an unknown name a neutral one: :mod:`bnerr.strategies.identity`).
Outside bnerr it is a plug-in (:mod:`bnerr.plugins`): ``make_strategy("path/file.py:Cls")``
or ``"pkg.mod:Cls"``, or an entry point of the group ``bnerr.strategies``; it subclasses
:class:`Strategy` (or a shipped strategy) and declares ``family``.

**Device.** Seeds are made on ``device``; after each render the strategy's state follows the
device of the returned frame.

Not for: strategies that need the next frame's buffers before rendering it (backward
reprojection with frame t + 1's motion: the render callback is bound to t), or choosing seeds for
a renderer that draws its own random numbers.
"""

from __future__ import annotations

from collections.abc import Mapping

import torch

from bnerr import plugins
from bnerr.errors import check_positive_int
from bnerr.strategies.base import (
    BuildOptions,
    RenderFn,
    Strategy,
    as_render,
    check_fits,
    first_frame,
    pixel_seeds,
    play,
    stream_key,
)
from bnerr.strategies.dithered import STBN_MASK, BNDSStrategy, BNDSSTStrategy
from bnerr.strategies.identity import StrategyIdentity, baseline, bounds, strategy_identity
from bnerr.strategies.ldbn import (
    LDBNATrousStrategy,
    LDBNFastStrategy,
    LDBNStrategy,
    LDBNSTStrategy,
)
from bnerr.strategies.openqmc import OpenQMCLatticeBNStrategy, OpenQMCSobolBNStrategy
from bnerr.strategies.oracle import OracleStrategy
from bnerr.strategies.registry import REGISTRY
from bnerr.strategies.temporal import (
    TemporalLDBNStrategy,
    TemporalSortStrategy,
    TemporalStrategy,
    TemporalZSobolStrategy,
)
from bnerr.strategies.variants import (
    VARIANT_BASES,
    VARIANT_OPTIONS,
    VARIANTS,
    TemporalOptions,
    check_strategy_name,
    parse_variant,
)
from bnerr.strategies.vertical import VerticalStrategy
from bnerr.strategies.white import WhiteStrategy
from bnerr.strategies.zorder import CyclesBlueStrategy, ZSobolStrategy, ZSobolTStrategy
from bnerr.views import LiveMapping

__all__ = [
    "OWN_SAMPLERS",
    "STBN_MASK",
    "STRATEGIES",
    "VARIANT_BASES",
    "VARIANT_OPTIONS",
    "BNDSSTStrategy",
    "BNDSStrategy",
    "BuildOptions",
    "CyclesBlueStrategy",
    "LDBNATrousStrategy",
    "LDBNFastStrategy",
    "LDBNSTStrategy",
    "LDBNStrategy",
    "OpenQMCLatticeBNStrategy",
    "OpenQMCSobolBNStrategy",
    "OracleStrategy",
    "RenderFn",
    "Strategy",
    "TemporalLDBNStrategy",
    "TemporalOptions",
    "TemporalSortStrategy",
    "TemporalStrategy",
    "TemporalZSobolStrategy",
    "VARIANTS",
    "VerticalStrategy",
    "WhiteStrategy",
    "ZSobolStrategy",
    "ZSobolTStrategy",
    "as_render",
    "check_strategy_name",
    "estimate_bytes",
    "first_frame",
    "make_strategy",
    "parse_variant",
    "pixel_seeds",
    "play",
    "stream_key",
    "StrategyIdentity",
    "baseline",
    "bounds",
    "strategy_identity",
]

for _variant in VARIANTS:
    REGISTRY.add_variant(_variant, _variant.split("+")[0])

#: The strategy names, as the benchmark tables name them: name -> class, iterated in sorted
#: order; the classes register themselves (:class:`Strategy`), the variants are
#: :data:`VARIANTS`.
STRATEGIES = REGISTRY


def _own_samplers() -> dict[str, str]:
    return {n: c.own_sampler for n, c in REGISTRY.classes().items() if c.own_sampler}


#: Strategy -> the sampler it dictates, whatever per-pixel sampler it is given (its class's
#: ``own_sampler``, read from the registry whenever asked, so that it cannot disagree with the
#: classes); the strategies not listed render with the per-pixel sampler they are given.
OWN_SAMPLERS: Mapping[str, str] = LiveMapping(_own_samplers)


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
    base, options = parse_variant(REGISTRY.name_of(name))
    pixels = check_positive_int(height, "height") * check_positive_int(width, "width")
    K = check_positive_int(K, "K")
    return pixels * STRATEGIES[base].peak_bytes_per_pixel(K, options)


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
            :data:`VARIANT_OPTIONS` in that order, e.g. ``temporal+residual+groups+shift``),
            or a plug-in spec ``pkg.mod:Cls`` / ``path/file.py:Cls`` (:mod:`bnerr.plugins`:
            loaded and registered under the class's ``name``; installed entry points of the
            group ``bnerr.strategies`` are registered names already).
        height, width: the frame size.
        seed: seed set index (>= 0): different seeds give independent runs.
        sampler: the per-pixel sampler of white, temporal, temporal_sort and oracle:
            ``"owen_sobol"`` (default) or ``"white"``; the strategies of :data:`OWN_SAMPLERS`
            ignore it (their ``sampler_name`` says what they render with).
        spp: samples per pixel the renders will take: required by zsobol, zsobol_t and
            temporal_zsobol (a power of two), cycles_blue and the ldbn strategies; ignored by the
            others.
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
        PluginError: a plug-in spec that cannot be loaded, or names no strategy class.
        MemoryLimitError: a frame size whose estimated memory (:func:`estimate_bytes`) exceeds
            what ``device`` has free, refused before anything is allocated.
        ValueRangeError: more than 2^31 pixels; spp missing or not a power of two for a strategy
            that needs one.
    """
    name = REGISTRY.name_of(name)
    per_pixel = estimate_bytes(name, 1, 1, K)
    check_fits(name, height, width, per_pixel, torch.device(device))
    base, options = parse_variant(name)
    build = BuildOptions(seed, sampler, spp, mask_size, block, K, dimensions, mask_dims, device)
    plugin = plugins.loaded("bnerr.strategies", base)
    if plugin is not None:  # a plug-in's constructor that raises is named, not a traceback
        create = STRATEGIES[base].create
        return plugins.call_plugin(plugin, "strategy", create, height, width, build, options)
    return STRATEGIES[base].create(height, width, build, options)
