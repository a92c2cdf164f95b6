"""The named benchmark suites, as data: which cells ``bnerr bench --suite NAME`` measures.

A **cell** is one scene x strategy x spp x denoiser x condition, measured over ``frames`` frames
(after ``warmup`` frames that are rendered but not measured, so that the temporal strategies have
converged) in each of ``seed_sets`` independent seed sets. A **condition** is what the stability
suite varies besides the scene: camera motion (static, normal, fast), the path depth (hence the
dimension count), and the pixel region the metrics are restricted to (all pixels, or only those
near object edges).

A suite is a list of :class:`Sweep` s, each a full cross product, so that the stability suite can
vary one axis at a time instead of multiplying them all. :func:`resolve` applies the command line's
overrides to every sweep of a suite.

The four suites (issue 6):

- ``quick``: two scenes, the strategies that bracket the method (white, temporal, oracle), with
  OpenQMC's two blue-noise samplers beside it (a production renderer's a-priori blue noise), and
  two cheap denoisers at 128x128, with the perceptual metrics (FLIP and ColorVideoVDP) beside
  the MSE; at most 5 minutes on the 2-core development machine (on one thread when the machine
  is shared: ``--threads 1``); ``make run``.
- ``quality``: every scene, the strategies a renderer could adopt (:data:`_QUALITY_STRATEGIES`:
  white, the mask, the permutation and its variants on hashed seeds and ZSobol keys, ZSobol,
  Cycles' pattern, LDBN on 64- and 128-pixel tiles, OpenQMC's two blue-noise samplers; not the
  bounds, which the gap suite measures) and every denoiser (kornia filters, U-Net, OIDN, the
  temporal taa and svgf, and gaussian, atrous and guided also tuned on each strategy's own frames)
  at 1, 4 and 16 spp, 128x128, over every pixel and away from visible lights. Its verdicts are
  settled by adaptive seed sets: ``bnerr bench --suite quality --until-resolved --ray local``
  (looks at 4, 8, 16 and 32 seed sets where the unlit region's verdicts are open, a settled cell
  stopping: 66.6 minutes from scratch with two Ray workers). Where its time went before: by the
  round-3 records' timings about 105 core-minutes of rendering (the oracle's 61, two thirds of
  it at 16 spp), 28 for the denoisers (tuning included) and about 14 for the metrics; a run from
  scratch with the oracle and the ``vertical`` bound took 93 minutes with two Ray workers, of
  which the bounds were 68 worker-minutes. A profile of the serial run on a cheap scene:
  denoisers 48 %, metrics 20 %, tuning 15 %, rendering 16 %.
- ``speed``: the throughput and timing scripts (``benchmarks/speed/``).
- ``gap``: the ablation of the temporal variants (docs/METHODS.md, section 8; issue 14): each
  option alone (:data:`GAP_SINGLE`), then the best combination on hashed seeds and on ZSobol keys
  (:data:`GAP_BEST`), next to white, temporal and the oracle, so that
  :func:`benchmarks.reports.gap.gap_shares` gives each one's share of the white-to-oracle distance
  after the sigma-1 and sigma-2 blurs and after each denoiser. Every scene at 1 and 4 spp with the
  scene's animation (all pixels and object edges: one render serves both regions), at 16 spp the
  same with the best combinations only (white, temporal, :data:`GAP_BEST` but the reprojecting
  one, oracle), then at 4 spp:
  white per-pixel sequences (direct, snooker), a static camera (direct, snooker) and the
  animation 8 times faster (indirect, snooker). Sized for at most 60 minutes on the 2-core
  development machine on one thread: 2 seed sets x 2 frames after 4 warmup frames (the sort
  converges within about 3), the two cheap denoisers (gaussian, atrous; ``--denoisers`` adds the
  others), only the MSE measures, no crops. The oracle's 32 renders per frame are half of it.
- ``seed``: the seed talk's conditions (issue 26, docs/METHODS.md, section 11), 64x64, 3 seed
  sets x 2 frames after 6 warmup frames, with crops at every spp for the figures of
  :mod:`benchmarks.reports.seed`. Measured with ``--seed-sets 2``: 4.4 CPU-minutes on one thread
  (10.5 minutes of wall time at load 9), so about 7 minutes unloaded with 3 seed sets. The
  ``vertical`` bound, which renders the oracle's 32 candidates and searches, was 57 % of the
  suite's time at every spp and both cameras (measured at 32x32 x 2 seed sets); it runs at 16
  and 64 spp on the slow camera only.
- ``stability``: the cases where the temporal method is expected to fail: textured against
  untextured snooker, object edges, static against fast camera motion, Owen-Sobol against white
  per-pixel sequences, 1 to 64 spp, 1 to 8 bounces; reported as each strategy's post-denoise MSE
  ratio to white with its interval. The rivals (:data:`RIVALS`) run in every sweep but the
  per-pixel sequences one: they dictate their own sampler (``bnerr.strategies.OWN_SAMPLERS``), so
  that condition would render them twice alike. The best temporal variant on hashed seeds
  (``temporal+relative+demod+groups``, :data:`GAP_BEST`) runs in every sweep beside ``temporal``.

Not for: per-scene parameter tuning (the denoisers' parameters come from :mod:`denoisers.tuning`,
tuned on white noise), or anything that changes what a strategy does.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypedDict, cast

from bnerr.errors import ValueRangeError, check_name, check_positive_int
from bnerr.metrics import METRIC_TABLE
from bnerr.sequences import per_pixel_samplers
from bnerr.strategies import check_strategy_name
from renderers.catalog import SCENES

__all__ = [
    "CYCLES_SCENES",
    "GAP_BEST",
    "GAP_SINGLE",
    "REGIONS",
    "RIVALS",
    "SAMPLERS",
    "SUITES",
    "Condition",
    "Suite",
    "Sweep",
    "get_suite",
    "resolve",
    "with_white",
]

#: Pixel regions the metrics can be restricted to.
REGIONS: tuple[str, ...] = ("all", "edges", "coherent", "unlit")

#: Per-pixel samplers a strategy can draw its sequences from (the strategies with their own
#: sampler, bnds and the rivals, ignore the choice); plug-in samplers too
#: (:func:`bnerr.sequences.per_pixel_samplers`).
SAMPLERS: tuple[str, ...] = ("owen_sobol", "white")


@dataclass(frozen=True)
class Condition:
    """What a cell varies besides scene, strategy, spp and denoiser.

    Attributes:
        motion: camera speed multiplier: 0 renders the scene's static variant
            (``get_scene(name, animated=False)``), 1 its animation, k > 1 the animation k times
            faster (the renderer sees frame ``k * t``).
        depth: ``scene.max_depth`` override in Mitsuba's convention (longest path in segments:
            2 is direct lighting, ``depth - 1`` scattering vertices), or None for the scene's own.
        region: ``"all"`` pixels, or ``"edges"``: pixels within one pixel of an object-id
            discontinuity of the reference (:func:`bnerr.metrics.edge_mask`), or
            ``"coherent"``: the spatio-temporally coherent pixels where the seed paper says its
            method works (:func:`bnerr.metrics.coherent_mask`). The named suites measure it in
            every run (``Suite.coherent``): its renders are shared. Or ``"unlit"``: every pixel
            but those within one pixel of a light the camera sees (:func:`bnerr.metrics.
            light_mask`), whose edge, decided by the pixel jitter alone, otherwise holds most of
            the squared error (the Cornell box's, docs/FINDINGS.md); every pixel in a scene
            whose lights are out of view.
        sampler: the per-pixel sequences of white, temporal, temporal_sort and oracle:
            ``"owen_sobol"`` (the strategies' default) or ``"white"`` (a hash). The strategies
            with their own sampler (bnds and the rivals, ``bnerr.strategies.OWN_SAMPLERS``) ignore
            it; their records say what they rendered with (``Record.render_sampler``).
            It matters: a seed's error must carry over to the neighbouring pixel it is moved to,
            and the stratified error of Owen-scrambled Sobol carries over less than white noise's.
    """

    motion: int = 1
    depth: int | None = None
    region: str = "all"
    sampler: str = "owen_sobol"

    def __post_init__(self) -> None:
        check_positive_int(self.motion, "Condition.motion", minimum=0)
        if self.depth is not None:
            check_positive_int(self.depth, "Condition.depth", minimum=2)
        check_name(self.region, REGIONS, "region")
        check_name(self.sampler, per_pixel_samplers(), "per-pixel sampler")


@dataclass(frozen=True)
class Sweep:
    """A cross product of cells with shared settings.

    Attributes:
        scenes, strategies, spp, denoisers, conditions: the axes of the cross product.
        frames: measured frames per seed set; warmup: unmeasured frames before them.
        res: ``(width, height)`` in pixels.
        seed_sets: independent seed sets (each restarts the strategy from fresh seeds).
        reference_spp: samples per pixel of the cached references.
        metrics: names from :data:`bnerr.metrics.METRICS`.
    """

    scenes: tuple[str, ...]
    strategies: tuple[str, ...]
    spp: tuple[int, ...]
    denoisers: tuple[str, ...]
    frames: int = 3
    warmup: int = 6
    res: tuple[int, int] = (128, 128)
    seed_sets: int = 4
    reference_spp: int = 1024
    conditions: tuple[Condition, ...] = (Condition(),)
    metrics: tuple[str, ...] = (
        "mse",
        "relmse",
        "psnr",
        "ssim",
        "mse_blur1",
        "mse_blur2",
        "lowfreq",
        "tmse",
        "trelmse",
        "mse_tavg",
    )

    def __post_init__(self) -> None:
        for axis in ("scenes", "strategies", "spp", "denoisers", "conditions"):
            if not getattr(self, axis):
                raise ValueRangeError(f"Sweep.{axis}: expected at least one entry, got none")
        for n in self.spp:
            check_positive_int(n, "Sweep.spp")
        check_positive_int(self.frames, "Sweep.frames")
        check_positive_int(self.warmup, "Sweep.warmup", minimum=0)
        check_positive_int(self.seed_sets, "Sweep.seed_sets")
        check_positive_int(self.reference_spp, "Sweep.reference_spp")
        if len(self.res) != 2:
            raise ValueRangeError(f"Sweep.res: expected (width, height), got {self.res!r}")
        for n in self.res:
            check_positive_int(n, "Sweep.res")

    @property
    def runs(self) -> int:
        """Number of strategy runs (one per scene x strategy x spp x motion/depth x seed set)."""
        renders = {(c.motion, c.depth, c.sampler) for c in self.conditions}
        return (
            len(self.scenes) * len(self.strategies) * len(self.spp) * len(renders) * self.seed_sets
        )


@dataclass(frozen=True)
class Suite:
    """A named list of sweeps (or, for ``speed``, of timing scripts).

    Attributes:
        name: the suite's name, also the folder under ``results/``.
        description: one line for ``bnerr bench --help`` and the report.
        sweeps: the cell sweeps.
        scripts: for the speed suite, module names under :mod:`benchmarks` (``speed.permute``)
            whose measuring function the runner calls.
        crops: whether the runner saves side-by-side crops for the report (of each sweep's
            smallest spp).
        crops_every_spp: with ``crops``, save them at every spp of the sweeps (the seed
            suite's figures, :mod:`benchmarks.reports.seed`, show every spp).
        coherent: every run measures the coherent region too, besides its sweep's regions
            (:func:`benchmarks.sweep.plan.plan`; the renders are shared, so it costs only the
            metrics). True for every named suite; False keeps a hand-built suite's cells as
            its sweeps' conditions say.
        coherent_skips: metrics the coherent region leaves out although its sweep measures
            them (:meth:`benchmarks.sweep.plan.Run.metrics_of`): the slow perceptual ones where
            a suite's time is tight and the region is a diagnostic, not a verdict's.
        resolve: with ``bnerr bench --until-resolved``, the pixel regions whose open verdicts
            add seed sets (:func:`benchmarks.sweep.adaptive.run_until_resolved`); empty: every
            region's (``--resolve`` overrides it).
        stop_settled: with ``--until-resolved``, a cell whose verdict is settled gets no more
            seed sets although its run grows for another cell: the run keeps only the denoisers
            with an open cell (``--stop-settled`` sets it). Off: every cell of a growing run is
            judged again at each look.
    """

    name: str
    description: str
    sweeps: tuple[Sweep, ...] = ()
    scripts: tuple[str, ...] = ()
    crops: bool = True
    crops_every_spp: bool = False
    coherent: bool = False
    coherent_skips: tuple[str, ...] = ()
    resolve: tuple[str, ...] = ()
    stop_settled: bool = False

    def __post_init__(self) -> None:
        for region in self.resolve:
            check_name(region, REGIONS, "resolve region")
        for name in self.coherent_skips:
            check_name(name, tuple(METRIC_TABLE), "coherent_skips metric")


class _Sets(TypedDict):
    """Settings several sweeps share, spread into each with ``**`` (fields of :class:`Sweep`)."""

    seed_sets: int
    frames: int
    warmup: int


class _GapSets(_Sets):
    """The gap suite's shared settings: :class:`_Sets` and its resolution and reference spp."""

    res: tuple[int, int]
    reference_spp: int


class _Overrides(TypedDict, total=False):
    """The command line's overrides of a sweep (:func:`resolve`; the fields of :class:`Sweep`)."""

    scenes: tuple[str, ...]
    strategies: tuple[str, ...]
    spp: tuple[int, ...]
    denoisers: tuple[str, ...]
    frames: int
    warmup: int
    res: tuple[int, int]
    seed_sets: int
    reference_spp: int
    metrics: tuple[str, ...]


#: Every registered scene (:data:`renderers.catalog.SCENES`).
_ALL_SCENES = tuple(SCENES)
#: The a-priori patterns and the temporal method over ZSobol (issue 13), measured against the rest
#: in the stability suite (``ldbn_zorder``: LDBN's keys over a Z-ordered sequence, the a-priori
#: strategy that keeps most past 16 spp in the gap suite, issue 40); the quality suite lists its own
#: (:data:`_QUALITY_STRATEGIES`).
RIVALS: tuple[str, ...] = (
    *("zsobol", "cycles_blue", "zsobol_t", "bnds_st", "temporal_zsobol"),
    *("ldbn", "ldbn128", "ldbn_zorder", "ldbn_st", "ldbn_fast", "ldbn_atrous"),
    *("openqmc_sobolbn", "openqmc_latticebn"),
)
_ALL_DENOISERS = (
    "gaussian",
    "bilateral",
    "joint_bilateral",
    "guided",
    "median",
    "atrous",
    "unet",
    "unet_blue",
    "oidn",
    "taa",
    "svgf",
)
#: The quality suite's: every strategy a renderer could adopt, not the bounds. The oracle (32
#: candidate renders a frame) and ``vertical`` (the oracle's candidates searched again) were 51 and
#: 17 of the suite's 186 worker-minutes at 4 seed sets, although the headline and the decision
#: table leave bounds out; they are measured in the gap suite, where a share of their dividend is
#: computed, so the adaptive design's extra seed sets go to the strategies whose verdicts are read.
#: Nor the variants that the round-3 quality suite found no better than their base (the share of
#: its 252 scene, spp and denoiser cells where the variant was below the base beyond a per-cell
#: 95 % t-interval over 4 seed sets, about 5 % by chance alone): ``ldbn_fast`` against ``ldbn``
#: 7 of 252 (median ratio 1.007), ``zsobol_t`` against ``zsobol`` 7 (1.103), nor ``ldbn_atrous``
#: (0.99 of ``ldbn`` after the a-trous filter, docs/METHODS.md section 10), nor ``bnds``, which
#: ``bnds_st`` beats in 67 of 252 (median 0.941), nor yet ``ldbn_zorder`` (issue 40; measured in the
#: quick, gap and stability suites): adding a strategy here needs the suite's regeneration (a
#: ``--until-resolved --resume`` with nothing new to measure ran 2,883 tasks in 43 minutes on the
#: 2-core machine, replaying the compacted records' looks). Every strategy added to a cell widens
#: its best-of-m correction and costs one render per frame and seed set, repeated by the adaptive
#: seed sets (``--until-resolved``) up to their cap. The gap, stability and seed suites keep them.
_QUALITY_STRATEGIES = (
    *("white", "bnds_st", "temporal", "temporal_sort", "temporal_zsobol", "zsobol"),
    *("cycles_blue", "ldbn", "ldbn128", "ldbn_st", "openqmc_sobolbn", "openqmc_latticebn"),
)
#: Filters also tuned on each strategy's own frames (``NAME:own``; the fair columns stay tuned on
#: white noise): the cheap ones whose tuned width decides most of their error.
_OWN_TUNED = ("gaussian:own", "atrous:own", "guided:own")
_CHEAP_DENOISERS = ("gaussian", "atrous")
#: The gap suite's variants with one option each (bnerr.strategies.parse_variant).
GAP_SINGLE: tuple[str, ...] = (
    "temporal+residual",
    "temporal+relative",
    "temporal+demod",
    "temporal+groups",
    "temporal+shift",
    "temporal+reproject",
    "temporal+fast",
)
#: The best combination (relative key on demodulated radiance, groups by object id), on hashed
#: seeds, with forward reprojection (for the moving conditions) and on ZSobol keys. Chosen on the
#: quick ablation recorded in tests/test_ordering.py (snooker and direct, 128x128, 4 spp): the
#: grid shift and the normal bins did not help there and are left out.
GAP_BEST: tuple[str, ...] = (
    "temporal+relative+demod+groups",
    "temporal+relative+demod+groups+reproject",
    "temporal_zsobol+relative+demod+groups",
)
#: The a-priori samplers whose share of the gap the table shows beside the temporal variants'
#: (stateless and cheap: one render per frame): LDBN's (issue 25; ``ldbn_zorder``, its keys over a
#: Z-ordered sequence, issue 40), and the rivals the 16-64 spp goals are measured against, ZSobol
#: and OpenQMC's two blue-noise samplers (issue 40).
#: Not ldbn_st, made for temporal accumulation, which the gap's denoisers are not; nor in the
#: sequence and motion sweeps: these strategies dictate their own sampler and do not move seeds.
_GAP_APRIORI = (
    *("ldbn", "ldbn128", "ldbn_zorder", "ldbn_fast", "ldbn_atrous"),
    *("zsobol", "openqmc_sobolbn", "openqmc_latticebn"),
)
_GAP_STRATEGIES = ("white", "temporal", *GAP_SINGLE, *GAP_BEST, "oracle")
#: The stability suite's temporal variant: the best combination on hashed seeds (issue 14's goal:
#: never worse than white beyond the interval on any of its failure cases).
_BEST = GAP_BEST[0]
_GAP_STILL = tuple(s for s in GAP_BEST if not s.endswith("+reproject"))
_GAP_SETS = _GapSets(seed_sets=2, frames=2, warmup=4, res=(128, 128), reference_spp=256)
#: The 64-spp sweep's: the gap suite's with a 1024-spp reference (at 256 the reference's own
#: noise would be a quarter of white's error at 64 spp, and more of the oracle's blurred error).
_GAP_SETS_64 = _GAP_SETS.copy()
_GAP_SETS_64["reference_spp"] = 1024
_GAP_METRICS = ("mse", "mse_blur1", "mse_blur2", "tmse", "trelmse", "mse_tavg")

# Why 4 seed sets x 3 frames and not 1 x 12: a temporal run reuses one set of seeds for all its
# frames, so its frames are correlated and only independent seed sets make an honest interval
# (bnerr.metrics.paired_ratio: a t-interval over seed sets). Why 4 and not 8: the power
# calculation (bnerr.metrics.power, docs/METHODS.md) says 4 seed sets resolve a 10 % reduction in
# the median cell (power 0.92) but a 5 % one in fewer than half (0.42), 8 would resolve 5 % in the
# median cell (0.87); 8 doubles the quality suite's time (55 min with two Ray workers here), past
# the 30 min the suites are allowed, so the tables keep 4 and say "open" where a cell's interval
# neither excludes nor brackets white within 5 % (``bnerr bench --until-resolved`` adds seed sets
# only to those, benchmarks.sweep.adaptive); the ordering tests, which make
# the claims the README rests on, use 8. Stateless strategies (white, bnds, oracle) render the same
# 12 measured frames either way and skip the warmup; the temporal ones pay 4 warmups. The sort
# converges within about 3 frames; 6 warmup frames leave a margin.
# Why 128x128: at 64x64 the scenes' features vary inside a 4x4 block, the sort orders by that
# signal instead of by the error, and the temporal method's gain after denoising is not measurable
# (tests/test_ordering.py's docstring has the figures).
_SETS = _Sets(seed_sets=4, frames=3, warmup=6)

#: The ``cycles`` suite's three scenes, built in Blender by code (renderers/cycles/builders.py).
CYCLES_SCENES: tuple[str, ...] = ("cycles_interior", "cycles_product", "cycles_outdoor")
#: Cycles' own denoiser, bnerr's OIDN fed Cycles' denoising passes, the Gaussian tuned on white
#: noise, the U-Net and temporal accumulation.
_CYCLES_DENOISERS = ("cycles_oidn", "oidn", "gaussian", "unet", "taa")
_SAME_SCENE_DENOISERS = ("oidn", "gaussian", "unet", "taa")
#: 4 seed sets of 3 frames after 2 (TAA's history), 128x128, 1024-spp references rendered by
#: Cycles with seeds no strategy uses.
_CYCLES_SETS = _GapSets(seed_sets=4, frames=3, warmup=2, res=(128, 128), reference_spp=1024)

#: The default metrics and what a viewer sees beside them: FLIP per frame, ColorVideoVDP per
#: sequence (the perceptual decision table, perceptual.md). The suites cheap enough to carry both
#: (quick, seed, cycles: Blender's render dwarfs the metric) do.
_PERCEPTUAL = (*Sweep.metrics, "flip", "cvvdp")
#: The quality suite's: ColorVideoVDP only, its verdicts' metric. FLIP on its sequences would
#: cost about 1.7 times ColorVideoVDP again (0.104 s against 0.059 s a sequence of 128x128
#: frames); ColorVideoVDP alone took the suite from 67 to 131 minutes (docs/FINDINGS.md).
_QUALITY_METRICS = (*Sweep.metrics, "cvvdp")

SUITES: dict[str, Suite] = {
    "quick": Suite(
        name="quick",
        coherent=True,
        description=(
            "direct and indirect, white/temporal/LDBN over Z-order/OpenQMC's blue-noise "
            "samplers/oracle, 1 and 4 spp, gaussian and atrous, 128x128"
        ),
        sweeps=(
            Sweep(
                scenes=("direct", "indirect"),
                # the method, our best a-priori keys, a production renderer's blue-noise
                # samplers, and the bound
                strategies=(
                    *("white", "temporal", "ldbn_zorder"),
                    *("openqmc_sobolbn", "openqmc_latticebn", "oracle"),
                ),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=512,
                metrics=_PERCEPTUAL,
                **_SETS,
            ),
        ),
    ),
    "quality": Suite(
        name="quality",
        coherent=True,
        description=(
            "every scene, adoptable strategy and denoiser at 1, 4 and 16 spp, 128x128, every "
            "pixel and away from visible lights; --until-resolved to 32 seed sets where the "
            "unlit region's verdicts are open, a settled cell stopping"
        ),
        # The verdicts read (the README's headline) are the unlit region's: on the Cornell box,
        # the one scene that shows its light, the light's edge pixels hold 91-100 % of white's
        # post-denoise error over every pixel (docs/FINDINGS.md); elsewhere the two regions are
        # the same pixels. Every pixel and the coherent region ride on the same renders.
        resolve=("unlit",),
        stop_settled=True,
        # The coherent region is a diagnostic of the MSE family (docs/METHODS.md, section 6);
        # scoring its sequences in JOD too would cost about 20 minutes more.
        coherent_skips=("cvvdp",),
        sweeps=(
            Sweep(
                scenes=_ALL_SCENES,
                strategies=_QUALITY_STRATEGIES,
                spp=(1, 4, 16),
                denoisers=_ALL_DENOISERS + _OWN_TUNED,
                conditions=(Condition(region="all"), Condition(region="unlit")),
                res=(128, 128),
                reference_spp=1024,
                metrics=_QUALITY_METRICS,
                **_SETS,
            ),
        ),
    ),
    "gap": Suite(
        name="gap",
        coherent=True,
        description=(
            "ablation of the temporal variants: share of the white-to-oracle gap closed, every "
            "scene at 1, 4, 16 spp (a-priori samplers on direct and indirect to 64), sequences, "
            "static/x8 motion, edges; --until-resolved "
            "--seed-set-cap 4: about 41 min with --ray local"
        ),
        crops=False,
        sweeps=(
            Sweep(
                scenes=_ALL_SCENES,
                strategies=(*_GAP_STRATEGIES, *_GAP_APRIORI),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(region="all"), Condition(region="edges")),
                metrics=_GAP_METRICS,
                **_GAP_SETS,
            ),
            # 16 spp: the best combinations only (single options there would add ~10 minutes),
            # without reprojection (which needs motion of a pixel or more per frame: see x8).
            Sweep(
                scenes=_ALL_SCENES,
                strategies=("white", "temporal", *_GAP_STILL, *_GAP_APRIORI, "oracle"),
                spp=(16,),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(region="all"), Condition(region="edges")),
                metrics=_GAP_METRICS,
                **_GAP_SETS,
            ),
            # 64 spp, where offline renderers work (issue 40's goals: a third of the oracle's
            # dividend kept): the a-priori samplers, and Cycles' blue-noise pattern (a rival of
            # the quality suite, which stops at 16 spp), against white and the oracle on the two
            # goal scenes (the temporal variants stop at 16 spp). The oracle's 32 candidates cost
            # 2-7 s a frame here.
            Sweep(
                scenes=("direct", "indirect"),
                strategies=("white", *_GAP_APRIORI, "cycles_blue", "oracle"),
                spp=(64,),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(region="all"),),
                metrics=_GAP_METRICS,
                **_GAP_SETS_64,
            ),
            # The vertical bound (issue 26), whose share past 1 says how far the oracle is from
            # the best per-pixel choice of candidate: the goal scenes at 16 spp, where the seed
            # claim and the LDBN goals are furthest from the oracle (it renders the oracle's 32
            # candidates and searches about 3.6 s a frame; every scene and spp would add about 12
            # core-minutes to a suite already at its hour).
            Sweep(
                scenes=("direct", "indirect"),
                strategies=("vertical",),
                spp=(16,),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(region="all"), Condition(region="edges")),
                metrics=_GAP_METRICS,
                **_GAP_SETS,
            ),
            Sweep(
                scenes=("direct", "snooker"),
                strategies=_GAP_STRATEGIES,
                spp=(4,),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(sampler="white"), Condition(motion=0)),
                metrics=_GAP_METRICS,
                **_GAP_SETS,
            ),
            Sweep(
                scenes=("indirect", "snooker"),
                strategies=_GAP_STRATEGIES,
                spp=(4,),
                denoisers=_CHEAP_DENOISERS,
                conditions=(Condition(motion=8),),
                metrics=_GAP_METRICS,
                **_GAP_SETS,
            ),
        ),
    ),
    "seed": Suite(
        name="seed",
        coherent=True,
        crops_every_spp=True,
        description=(
            "the seed talk's conditions: sphere on a checkerboard (indirect) static and slowly "
            "moving, 1-64 spp, Owen-Sobol and white sequences, fog at 32 spp; images, insets "
            "and coherent-region spectra (~7 minutes on one unloaded core)"
        ),
        sweeps=(
            # The talk's figure: direct + indirect light on a checkerboard, a slow camera and a
            # static one, 1 to 64 spp; the oracle bounds every spp (its share of the dividend in
            # the coherent region is the seed's claim at 16 and 64 spp).
            Sweep(
                scenes=("indirect",),
                strategies=("white", "temporal", _BEST, "oracle"),
                spp=(1, 4, 16, 64),
                denoisers=("gaussian",),
                res=(64, 64),
                reference_spp=1024,
                conditions=(Condition(motion=0), Condition(motion=1)),
                seed_sets=3,
                metrics=_PERCEPTUAL,
                frames=2,
                warmup=6,
            ),
            # The vertical bound beside the oracle (the same candidates, chosen for the whole
            # image's blurred error) only where the claim is made, 16 and 64 spp on the slow
            # camera: at 1-64 spp and both cameras it was 57 % of the suite's time (measured at
            # 32x32 x 2 seed sets), and its cost does not fall with spp.
            Sweep(
                scenes=("indirect",),
                strategies=("vertical",),
                spp=(16, 64),
                denoisers=("gaussian",),
                res=(64, 64),
                reference_spp=1024,
                conditions=(Condition(motion=1),),
                seed_sets=3,
                metrics=_PERCEPTUAL,
                frames=2,
                warmup=6,
            ),
            # "Randomly assigned sequences": white per-pixel sequences, and 32 spp.
            Sweep(
                scenes=("indirect",),
                strategies=("white", "temporal", _BEST),
                spp=(1, 4, 16, 32, 64),
                denoisers=("gaussian",),
                res=(64, 64),
                reference_spp=1024,
                conditions=(Condition(motion=1, sampler="white"),),
                seed_sets=3,
                metrics=_PERCEPTUAL,
                frames=2,
                warmup=6,
            ),
            # The fog box: many dimensions at 32 spp ("scales in sample count").
            Sweep(
                scenes=("medium",),
                strategies=("white", "temporal", _BEST),
                spp=(1, 32),
                denoisers=("gaussian",),
                res=(64, 64),
                reference_spp=1024,
                seed_sets=3,
                metrics=_PERCEPTUAL,
                frames=2,
                warmup=6,
            ),
        ),
    ),
    "speed": Suite(
        name="speed",
        description=(
            "renderer throughput against Mitsuba 3 (in-process and as a new process), the "
            "permutation op and each denoiser at 1080p"
        ),
        scripts=(
            "speed.tracer",
            "speed.process",
            "speed.permute",
            "speed.denoise",
            "speed.masks",
            "speed.sequences",
        ),
        crops=False,
    ),
    "stability": Suite(
        name="stability",
        coherent=True,
        description=(
            "failure cases: texture, edges, motion, sequences, 1-64 spp, "
            "1-8 bounces; ratio to white"
        ),
        sweeps=(
            # Texture: the paper's failure case, against the same table without its texture; and
            # object edges, where a seed moved across an edge lands on another object.
            Sweep(
                scenes=("snooker", "snooker_plain"),
                strategies=("white", "temporal", "temporal_sort", _BEST, "oracle", *RIVALS),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=512,
                conditions=(Condition(region="all"), Condition(region="edges")),
                **_SETS,
            ),
            # Motion: static camera, the scene's animation, and the animation 8 times faster.
            Sweep(
                scenes=("direct", "indirect"),
                strategies=("white", "temporal", "temporal_sort", _BEST, *RIVALS),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=512,
                conditions=(
                    Condition(motion=0),
                    Condition(motion=1),
                    Condition(motion=8),
                    Condition(motion=1, region="edges"),
                ),
                **_SETS,
            ),
            # Per-pixel sequences: the temporal method needs a seed's error to carry over to the
            # neighbouring pixel it is moved to; stratified (Owen-Sobol) error carries over less
            # than white noise's, most visibly at 4 spp.
            Sweep(
                scenes=("direct", "indirect"),
                strategies=("white", "temporal", "temporal_sort", _BEST, "oracle"),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=512,
                conditions=(Condition(sampler="owen_sobol"), Condition(sampler="white")),
                **_SETS,
            ),
            # Sample count: the gain of a blue-noise error should shrink as spp grows. The oracle
            # (32 renders per frame) stops at 16 spp, as in the quality suite.
            Sweep(
                scenes=("indirect",),
                strategies=("white", "bnds", "temporal", _BEST, *RIVALS),
                spp=(1, 2, 4, 8, 16, 32, 64),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=1024,
                **_SETS,
            ),
            # Depth: 1, 2, 4 and 8 bounces (max_depth 2, 3, 5, 9; D = 4 to 32 with one light).
            # Dimensions grow by 4 per bounce, which is where BNDS stops working (its vector mask
            # covers the first few) and where the temporal method should not care.
            Sweep(
                scenes=("cornell",),
                strategies=("white", "bnds", "temporal", _BEST, *RIVALS),
                spp=(1, 4),
                denoisers=_CHEAP_DENOISERS,
                res=(128, 128),
                reference_spp=512,
                conditions=tuple(Condition(depth=d) for d in (2, 3, 5, 9)),
                **_SETS,
            ),
        ),
    ),
    "cycles": Suite(
        name="cycles",
        coherent=True,
        description=(
            "Blender Cycles as it ships: its classic pattern (white) against its blue-noise "
            "default, after Cycles' own OIDN, bnerr's OIDN, the Gaussian, the U-Net and TAA, on "
            "three scenes built by code at 1-64 spp, the adaptive and scrambled variants, and "
            "cycles_blue against Cycles' pattern on the same scenes; --until-resolved"
        ),
        sweeps=(
            # The answer for Cycles users: its default against its classic pattern, as shipped
            # (the scenes keep Blender's default light paths, filter and clamping).
            Sweep(
                scenes=CYCLES_SCENES,
                strategies=("white", "blue_noise"),
                spp=(1, 4, 16, 64),
                denoisers=_CYCLES_DENOISERS,
                metrics=_PERCEPTUAL,
                **_CYCLES_SETS,
            ),
            # The options that change how Cycles spreads its error over the screen.
            Sweep(
                scenes=CYCLES_SCENES,
                strategies=(
                    "white",
                    "blue_noise_adaptive",
                    "classic_adaptive",
                    "classic_scrambled",
                ),
                spp=(4, 16),
                denoisers=("cycles_oidn", "gaussian"),
                metrics=_PERCEPTUAL,
                **_CYCLES_SETS,
            ),
            # The same scenes in both renderers: Cycles' own pattern against bnerr's
            # reproduction of it (cycles_blue) in bnerr's tracer, after the same denoisers.
            Sweep(
                scenes=("cycles_direct", "cycles_indirect"),
                strategies=("white", "blue_noise"),
                spp=(1, 4),
                denoisers=("cycles_oidn", *_SAME_SCENE_DENOISERS),
                metrics=_PERCEPTUAL,
                **_CYCLES_SETS,
            ),
            Sweep(
                scenes=("direct", "indirect"),
                strategies=("white", "cycles_blue"),
                spp=(1, 4),
                denoisers=_SAME_SCENE_DENOISERS,
                metrics=_PERCEPTUAL,
                **_CYCLES_SETS,
            ),
        ),
    ),
}


def get_suite(name: str) -> Suite:
    """The suite called ``name`` (``quick``, ``quality``, ``gap``, ``seed``, ``speed``,
    ``stability``)."""
    return SUITES[check_name(name, tuple(SUITES), "suite")]


def _known(
    values: Sequence[str] | None, known: Sequence[str] | None, what: str
) -> tuple[str, ...] | None:
    if values is None:
        return None
    return tuple(v if known is None else check_name(v, known, what) for v in values)


def _known_strategies(
    values: Sequence[str] | None, known: Sequence[str] | None
) -> tuple[str, ...] | None:
    """As :func:`_known`, and a temporal variant ``base+option+...`` passes when well formed
    (:func:`bnerr.strategies.check_strategy_name`), registered or not."""
    if values is None or known is None:
        return _known(values, known, "strategy")

    return tuple(
        check_strategy_name(v) if "+" in v and v not in known else check_name(v, known, "strategy")
        for v in values
    )


def resolve(
    suite: Suite,
    *,
    scenes: Sequence[str] | None = None,
    strategies: Sequence[str] | None = None,
    spp: Sequence[int] | None = None,
    denoisers: Sequence[str] | None = None,
    frames: int | None = None,
    warmup: int | None = None,
    res: tuple[int, int] | None = None,
    seed_sets: int | None = None,
    reference_spp: int | None = None,
    samplers: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    known_scenes: Sequence[str] | None = None,
    known_strategies: Sequence[str] | None = None,
    known_denoisers: Sequence[str] | None = None,
    known_samplers: Sequence[str] | None = None,
    known_metrics: Sequence[str] | None = None,
) -> Suite:
    """``suite`` with the command line's overrides applied to every sweep.

    An override replaces the axis in every sweep (``--scenes direct`` makes every sweep render
    only ``direct``); None keeps the suite's value. Names are checked against ``known_*`` when
    given (the registries of the installed parts), raising :class:`UnknownNameError`; a
    strategy named as a temporal variant (``temporal+residual+groups``) needs only be well
    formed (:func:`bnerr.strategies.parse_variant`). ``samplers`` replaces the per-pixel sampler
    of every sweep's conditions (each condition once per sampler); ``metrics`` the measured
    metrics.
    """
    given = {
        "scenes": _known(scenes, known_scenes, "scene"),
        "strategies": _known_strategies(strategies, known_strategies),
        "spp": tuple(spp) if spp is not None else None,
        "denoisers": _known(denoisers, known_denoisers, "denoiser"),
        "frames": frames,
        "warmup": warmup,
        "res": res,
        "seed_sets": seed_sets,
        "reference_spp": reference_spp,
        "metrics": _known(metrics, known_metrics, "metric"),
    }
    # The keys are _Overrides' and each value given has its type.
    changes = cast(_Overrides, {k: v for k, v in given.items() if v is not None})
    sweeps = tuple(dataclasses.replace(s, **changes) for s in suite.sweeps)
    chosen = _known(samplers, known_samplers, "per-pixel sampler")
    if chosen is not None:
        sweeps = tuple(_with_samplers(s, chosen) for s in sweeps)
    return dataclasses.replace(suite, sweeps=sweeps)


def _with_samplers(sweep: Sweep, samplers: tuple[str, ...]) -> Sweep:
    conditions = tuple(
        dict.fromkeys(dataclasses.replace(c, sampler=s) for c in sweep.conditions for s in samplers)
    )
    return dataclasses.replace(sweep, conditions=conditions)


def with_white(suite: Suite) -> tuple[Suite, bool]:
    """``suite`` with the white-noise baseline in every sweep when no sweep has it (the ratios to
    white need its cells), and whether it was added."""
    if any("white" in s.strategies for s in suite.sweeps) or suite.scripts:
        return suite, False
    sweeps = tuple(
        dataclasses.replace(s, strategies=("white", *s.strategies)) for s in suite.sweeps
    )
    return dataclasses.replace(suite, sweeps=sweeps), True
