"""Measuring one run: render through the strategy, denoise, compare with the references.

For each seed set of a :class:`benchmarks.sweep.plan.Run`, :func:`measure_run` builds the strategy,
lets it drive the renderer for ``warmup + frames`` frames (the warmup frames are rendered but not
measured, so that the temporal strategies have converged; stateless strategies skip them, see
:class:`benchmarks.sweep.parts.Parts`), and, for each measured frame, compares the raw frame and
every denoiser's output with the reference of that frame (:class:`bnerr.metrics.FrameMetrics`), once
per pixel region. One run yields one :class:`benchmarks.sweep.records.Record` per cell (denoiser x
region).

- **Timings** per measured frame, one stopwatch each: ``render_ms`` is the frame's
  ``timings["render"]`` (the renderer's own clock, summed over the strategy's renders: the oracle
  renders K candidates), ``perm_ms`` its ``timings["strategy"]`` (everything the strategy does
  outside the renderer) and ``denoise_ms`` a :class:`bnerr.timing.Stopwatch` around the denoiser.
- **Samplers**: a record keeps ``render_sampler``, the sampler the strategy's renders used
  (``strategy.sampler_name``): the run's per-pixel ``sampler`` condition, or the strategy's own
  (bnds, bnds_st, zsobol, cycles_blue, zsobol_t, temporal_zsobol ignore the condition). The
  cell's ``sampler`` stays the condition, so every record pairs with white's under it.
- **Stateful denoisers** (``denoiser.stateful``: ``taa``, ``svgf``): reset at the start of each
  seed set (a sequence) and fed every frame in order, warmup frames included, as
  ``denoiser(frame, t=t)``; a run with one renders the warmup frames of a stateless strategy
  too. Only the measured frames' outputs are measured and timed.
- **Denoisers** come tuned (:mod:`benchmarks.sweep.tuning`: fair on white noise, or
  ``NAME:own`` on the strategy's own frames).
- **Crops**: a centre crop of the reference, the raw frame and every denoised frame of the first
  measured frame, as 8-bit sRGB previews (:func:`bnerr.color.preview_u8`), saved per run.

Not for: timing the parts in isolation at 1080p (the ``speed`` suite, :mod:`benchmarks.speed`).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, TypeGuard

import numpy as np
import torch

from benchmarks.sweep.parts import BoundRender, Denoiser, Parts, Scene, StatefulDenoiser
from benchmarks.sweep.plan import Cell, Run
from benchmarks.sweep.records import MetricPairs, Record, ReferenceInfo, Spectrum, Timings
from benchmarks.sweep.reuse import extend
from bnerr.color import preview_u8
from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from bnerr.io import atomic_write
from bnerr.metrics import (
    FrameMetrics,
    ImagePair,
    PreparedReference,
    coherent_mask,
    edge_mask,
    light_mask,
    temporal_correlation,
)
from bnerr.metrics.spectrum import radial_power_spectrum
from bnerr.strategies import first_frame, play
from bnerr.timing import Stopwatch

__all__ = [
    "References",
    "SeedSetResult",
    "denoise_frame",
    "feed_stateful",
    "finish_run",
    "is_stateful",
    "measure_run",
    "measure_seed_set",
    "merge_seed_sets",
    "reset_stateful",
    "scene_for",
    "t_reference",
    "t_render",
]

_SPECTRUM_TILE = 64
_CROP = 64


class References(Protocol):
    """The references as measuring reads them (:class:`benchmarks.sweep.references.ReferenceCache`,
    or the frames a Ray task was handed)."""

    def get(self, run: Run, scene: Scene, t_render: int) -> Frame: ...


def _center_crop(x: torch.Tensor, size: int) -> torch.Tensor:
    h, w = x.shape[-2:]
    ch, cw = min(size, h), min(size, w)
    y0, x0 = (h - ch) // 2, (w - cw) // 2
    return x[..., y0 : y0 + ch, x0 : x0 + cw]


def scene_for(run: Run, parts: Parts) -> Scene:
    """The run's scene: animated unless motion 0, with its depth condition."""
    scene = parts.get_scene(run.scene, run.motion != 0)
    if run.depth is not None:
        scene = parts.with_depth(scene, run.depth)
    return scene


def t_render(run: Run, t: int) -> int:
    """The frame the renderer sees: ``motion`` times faster; a static scene ignores it."""
    return t * max(run.motion, 1)


def t_reference(run: Run, t: int) -> int:
    """Static scenes (motion 0) look the same at every t: one reference serves every frame."""
    return t_render(run, t) if run.motion else 0


def _coherent(run: Run, ref: Frame, prev: Frame | None) -> torch.Tensor:
    """The reference's coherent pixels (:func:`bnerr.metrics.coherent_mask`); with motion, seen
    at the same surface in the previous shown frame's reference (the renderer's motion buffer
    covers one renderer frame: scaled by the speed-up, as the strategies see it)."""
    if prev is None or not run.motion or ref.motion is None:
        return coherent_mask(ref)
    scaled = dataclasses.replace(ref, motion=ref.motion * max(run.motion, 1))
    return coherent_mask(scaled, prev)


def _region_masks(
    run: Run, ref: Frame, prev: Frame | None, lights: tuple[int, ...] = ()
) -> dict[str, torch.Tensor | None]:
    """Each region's pixel mask from the reference (None: every pixel). ``unlit``: every pixel
    but those within one pixel of a visible light (``lights``, the scene's; None where the
    camera sees none, so that the region's metrics are the whole image's bit for bit)."""
    masks: dict[str, torch.Tensor | None] = {}
    for region in run.regions:
        if region == "all":
            masks[region] = None
        elif ref.object_id is None:
            raise ValueRangeError(
                f"reference of {run.scene!r}: expected an object_id buffer for region "
                f"{region!r}, got none"
            )
        elif region == "coherent":
            masks[region] = _coherent(run, ref, prev)
        elif region == "unlit":
            lit = light_mask(ref.object_id, lights, radius=1)
            masks[region] = ~lit if bool(lit.any()) else None
        else:
            masks[region] = edge_mask(ref.object_id, radius=1)
    return masks


def _params(denoiser: Denoiser) -> dict:
    params = getattr(denoiser, "params", None)
    return dict(params()) if callable(params) else {}


@dataclass
class SeedSetResult:
    """What one seed set of a run measured: the unit of work both schedulers compute
    (:func:`measure_seed_set`), picklable, merged into records by :func:`merge_seed_sets`.

    Per measured frame, in order (F frames): ``raw[region][metric]`` and
    ``den[(denoiser, region)][metric]`` are ``[F, 2]`` float64 ``(numerator, denominator)``
    pairs (:meth:`bnerr.metrics.FrameMetrics.stats`); ``power[kind]`` the error's radial power
    spectrum per frame (``kind`` ``"raw"`` or a denoiser name; ``[F]`` tensors of ``[B]``
    float64 at ``freq``); ``timings[series]`` milliseconds ``[F]``; ``floors`` the reference's
    mean variance per frame (frames without a variance buffer add none); ``tcorr`` the raw
    error's correlation with the previous measured frame's along the motion
    (:func:`bnerr.metrics.temporal_correlation`), ``[F - 1]``. ``crop``: the previews
    of the first measured frame (seed set 0 of a run with crops only), else empty.
    ``coverage[region]``: the fraction of the pixels in the region per measured frame ``[F]``,
    for every region but ``"all"``.
    """

    group: int
    dimensions: int
    render_sampler: str
    measured_t: list[int]
    raw: dict[str, dict[str, torch.Tensor]]
    den: dict[tuple[str, str], dict[str, torch.Tensor]]
    freq: list[float]
    power: dict[str, list[torch.Tensor]]
    timings: dict[str, list[float]]
    floors: list[float]
    denoiser_params: dict[str, dict] = field(default_factory=dict)
    crop: dict[str, np.ndarray] = field(default_factory=dict)
    tcorr: list[float] = field(default_factory=list)
    coverage: dict[str, list[float]] = field(default_factory=dict)


def is_stateful(denoiser: Denoiser) -> TypeGuard[StatefulDenoiser]:
    """Whether ``denoiser`` carries state from frame to frame (a stand-in may have no
    ``stateful`` at all: it is then stateless)."""
    return bool(getattr(denoiser, "stateful", False))


def denoise_frame(denoiser: Denoiser, frame: Frame, t: int) -> torch.Tensor:
    """A stateful denoiser is told the frame's index (it checks the order); a stateless one
    is called with the frame alone."""
    return denoiser(frame, t=t) if is_stateful(denoiser) else denoiser(frame)


def reset_stateful(denoisers: Iterable[Denoiser]) -> None:
    """Start a sequence: every stateful one of ``denoisers`` forgets the frames it saw."""
    for denoiser in denoisers:
        if is_stateful(denoiser):
            denoiser.reset()


def feed_stateful(denoisers: Iterable[Denoiser], t: int, frame: Frame) -> None:
    """Feed warmup frame ``t`` to the stateful ones of ``denoisers`` (their output is dropped)."""
    for denoiser in denoisers:
        if is_stateful(denoiser):
            denoiser(frame, t=t)


def _update_regions(
    accs: Mapping[str, FrameMetrics],
    pred: torch.Tensor,
    target: PreparedReference,
    masks: Mapping[str, torch.Tensor | None],
) -> None:
    """One image's metrics in every region (its whole-image maps computed once for all of
    them); a region without pixels adds a weightless frame."""
    whole = ImagePair(pred, target, tile=_SPECTRUM_TILE)
    for region, mask in masks.items():
        if mask is not None and not bool(mask.any()):
            accs[region].update_empty()
        else:
            accs[region].update_pair(whole.in_region(mask))


class _SeedSetMeasurement:
    """Everything measured in one seed set: metrics, timings, spectra and crops, per cell."""

    def __init__(
        self, run: Run, group: int, denoisers: dict[str, Denoiser], lights: tuple[int, ...] = ()
    ) -> None:
        self.run, self.group, self.denoisers, self.lights = run, group, denoisers, lights
        regions = run.regions
        self.raw = {r: FrameMetrics(run.metrics_of(r), tile=_SPECTRUM_TILE) for r in regions}
        self.den = {
            d: {r: FrameMetrics(run.metrics_of(r), tile=_SPECTRUM_TILE) for r in regions}
            for d in denoisers
        }
        self.freq: list[float] = []
        self.power: dict[str, list[torch.Tensor]] = {"raw": [], **{d: [] for d in denoisers}}
        self.timings: dict[str, list[float]] = {
            "render_ms": [],
            "perm_ms": [],
            **{f"denoise_ms/{d}": [] for d in denoisers},
        }
        self.measured_t: list[int] = []
        self.floors: list[float] = []
        self.crop: dict[str, np.ndarray] = {}
        self.tcorr: list[float] = []
        self.coverage: dict[str, list[float]] = {r: [] for r in regions if r != "all"}
        # regions whose mask was every pixel in every frame so far (an unlit region where the
        # camera sees no light): their pairs are the whole image's (see result)
        self.whole = {r for r in regions if r != "all"} if "all" in regions else set()
        self._prev_err: torch.Tensor | None = None

    def _spectrum(self, kind: str, err: torch.Tensor) -> None:
        freq, power = radial_power_spectrum(err.to(torch.float64), tile=_SPECTRUM_TILE)
        self.freq = freq.tolist()
        self.power[kind].append(power.cpu())

    def _coherent_spectrum(self, err: torch.Tensor, mask: torch.Tensor) -> None:
        """The error's spectrum over the coherent pixels: the error zeroed elsewhere, scaled by
        ``1 / sqrt(share)`` so that the power is per coherent pixel (the mask's own spectrum
        convolves it; a frame without coherent pixels adds nothing)."""
        share = float(mask.double().mean())
        if share > 0:
            self.power.setdefault("coherent", [])
            self._spectrum("coherent", err * mask.to(err.dtype) / share**0.5)

    def reset(self) -> None:
        """Start a sequence: every stateful denoiser forgets the frames it saw."""
        reset_stateful(self.denoisers.values())

    def feed_warmup(self, t: int, frame: Frame) -> None:
        """Feed warmup frame ``t`` to the stateful denoisers (their output is not measured)."""
        feed_stateful(self.denoisers.values(), t, frame)

    def add(self, t: int, frame: Frame, ref: Frame, prev: Frame | None = None) -> None:
        """Measure frame ``t`` (with its timings) against its reference (``prev``: the previous
        shown frame's reference, for the coherent region's disocclusion test)."""
        self.measured_t.append(t)
        if ref.variance is not None:
            self.floors.append(float(ref.variance.to(torch.float64).mean()))
        masks = _region_masks(self.run, ref, prev, self.lights)
        for region, mask in masks.items():
            if region in self.coverage:
                self.coverage[region].append(1.0 if mask is None else float(mask.double().mean()))
            if mask is not None:
                self.whole.discard(region)
        self.timings["render_ms"].append(float(frame.timings.get("render", 0.0)))
        self.timings["perm_ms"].append(float(frame.timings.get("strategy", 0.0)))
        target = PreparedReference(ref.color)  # the reference's share of the metrics, once
        _update_regions(self.raw, frame.color, target, masks)
        err = frame.color - ref.color
        self._spectrum("raw", err)
        coherent = masks.get("coherent")
        if coherent is not None:
            self._coherent_spectrum(err, coherent)
        if self._prev_err is not None:
            self.tcorr.append(temporal_correlation(err, self._prev_err, frame.motion))
        self._prev_err = err
        outputs = {}
        for name, denoiser in self.denoisers.items():
            watch = Stopwatch()
            out = denoise_frame(denoiser, frame, t)
            self.timings[f"denoise_ms/{name}"].append(watch.ms(out))
            outputs[name] = out
            self._spectrum(name, out - ref.color)
            _update_regions(self.den[name], out, target, masks)
        if self.run.crops and self.group == 0 and not self.crop:
            images = {"reference": ref.color, "raw": frame.color}
            images.update({f"denoised/{n}": o for n, o in outputs.items()})
            self.crop = {k: preview_u8(_center_crop(v, _CROP)) for k, v in images.items()}

    def result(self, dimensions: int, render_sampler: str) -> SeedSetResult:
        """The seed set's measurements. A region that held every pixel in every frame takes the
        whole image's pairs: the same numbers (the same images, no mask), without scoring its
        sequence metrics a second time (ColorVideoVDP: 0.07 s a sequence)."""

        def pairs(accs: Mapping[str, FrameMetrics], region: str) -> dict[str, torch.Tensor]:
            acc = accs["all" if region in self.whole else region]
            return {m: acc.stats(m)[0] for m in self.run.metrics_of(region)}

        return SeedSetResult(
            group=self.group,
            dimensions=dimensions,
            render_sampler=render_sampler,
            measured_t=list(self.measured_t),
            raw={r: pairs(self.raw, r) for r in self.raw},
            den={(d, r): pairs(accs, r) for d, accs in self.den.items() for r in accs},
            freq=self.freq,
            power=self.power,
            timings=self.timings,
            floors=self.floors,
            denoiser_params={name: _params(d) for name, d in self.denoisers.items()},
            crop=self.crop,
            tcorr=list(self.tcorr),
            coverage={r: list(v) for r, v in self.coverage.items()},
        )


def _mean_spectrum(freq: list[float], per_frame: list[torch.Tensor]) -> Spectrum:
    """The mean of the per-frame spectra, summed in frame order (as one running sum would)."""
    if not per_frame:
        return Spectrum(freq=[], power=[])
    total = per_frame[0]
    for power in per_frame[1:]:
        total = total + power
    return Spectrum(freq=freq, power=(total / len(per_frame)).tolist())


def merge_seed_sets(
    run: Run, results: list[SeedSetResult], version: str, crop_file: str | None
) -> list[Record]:
    """One record per cell of ``run.cells()`` from its seed sets' results (any order in, seed
    set order used): ``[S][F]`` arrays stacked by seed set, spectra and floors averaged over
    every measured frame in seed set then frame order. With ``run.reuse``, the records of the
    new seed sets only (:func:`benchmarks.sweep.reuse.extend` joins the kept ones).

    Raises:
        ValueRangeError: the results are not exactly seed sets ``run.groups``.
    """
    ordered = sorted(results, key=lambda r: r.group)
    if [r.group for r in ordered] != list(run.groups):
        raise ValueRangeError(
            f"merge_seed_sets {run.label}: expected seed sets {run.reuse}..{run.seed_sets - 1}, "
            f"got {[r.group for r in ordered]}"
        )
    floors = [f for r in ordered for f in r.floors]
    reference = ReferenceInfo(
        spp=run.reference_spp, floor=float(np.mean(floors)) if floors else None, version=version
    )
    return [_cell_record(run, cell, ordered, reference, crop_file) for cell in run.cells()]


def _cell_record(
    run: Run,
    cell: Cell,
    ordered: list[SeedSetResult],
    reference: ReferenceInfo,
    crop_file: str | None,
) -> Record:
    """The record of one of ``run``'s cells from its seed sets' results, in seed-set order."""
    first, last = ordered[0], ordered[-1]

    def stacked(tables: list[dict[str, torch.Tensor]]) -> MetricPairs:
        """Per metric, the seed sets' ``[F, 2]`` pairs stacked in seed-set order."""
        names = run.metrics_of(cell.region)
        return {m: torch.stack([table[m] for table in tables]).tolist() for m in names}

    def series(name: str) -> list[list[float]]:
        return [list(r.timings[name]) for r in ordered]

    def spectrum(kind: str) -> Spectrum:
        return _mean_spectrum(first.freq, [p for r in ordered for p in r.power.get(kind, [])])

    return Record(
        cell=cell,
        dimensions=first.dimensions,
        t=list(first.measured_t),
        raw=stacked([r.raw[cell.region] for r in ordered]),
        den=stacked([r.den[(cell.denoiser, cell.region)] for r in ordered]),
        denoiser_params=dict(last.denoiser_params[cell.denoiser]),
        timings=Timings(
            render_ms=series("render_ms"),
            perm_ms=series("perm_ms"),
            denoise_ms=series(f"denoise_ms/{cell.denoiser}"),
        ),
        reference=reference,
        spectrum={
            "raw": spectrum("raw"),
            "den": spectrum(cell.denoiser),
            **({"coherent": spectrum("coherent")} if "coherent" in run.regions else {}),
        },
        crop=crop_file,
        render_sampler=last.render_sampler,
        tcorr=[list(r.tcorr) for r in ordered],
        coverage=[list(r.coverage[cell.region]) for r in ordered] if cell.region != "all" else None,
        looks=list(run.looks) or None,
    )


def _previous_reference(run: Run, scene: Scene, references: References, t: int) -> Frame | None:
    """The reference of shown frame ``t - 1`` where the coherent region needs it (a moving
    camera), else None."""
    if "coherent" not in run.regions or not run.motion:
        return None
    return references.get(run, scene, t_reference(run, t - 1))


def measure_seed_set(
    run: Run,
    parts: Parts,
    references: References,
    denoisers: dict[str, Denoiser],
    group: int,
    *,
    on_frame: Callable[[], None] | None = None,
) -> SeedSetResult:
    """Render, denoise and measure seed set ``group`` of ``run``: the unit of work of both the
    serial loop (:func:`measure_run`) and the Ray tasks (:mod:`benchmarks.sweep.ray_runner`).

    Args:
        run: what to measure (:func:`benchmarks.sweep.plan.plan`).
        parts: the parts that render and permute.
        references: the references (:class:`~benchmarks.sweep.references.ReferenceCache`, or
            anything with its ``get(run, scene, t_render)``).
        denoisers: name -> denoiser (with its tuned parameters) for every name in
            ``run.denoisers``.
        group: the seed set, ``0 <= group < run.seed_sets`` (the strategy's seed).
        on_frame: called after every frame, rendered or skipped (the progress bar).
    """
    if not 0 <= group < run.seed_sets:
        raise ValueRangeError(
            f"measure_seed_set: expected a seed set in [0, {run.seed_sets}), got {group}"
        )
    scene = scene_for(run, parts)
    chosen = {name: denoisers[name] for name in run.denoisers}
    # a scene that renders itself (a Mitsuba XML scene) names no lights: its unlit region is all
    lights = tuple(getattr(scene, "lights", ()))
    measurement = _SeedSetMeasurement(run, group, chosen, lights)
    tick = on_frame if on_frame is not None else (lambda: None)
    strategy = parts.make_strategy(
        run.strategy, scene, run.height, run.width, group, run.sampler, run.spp
    )
    # a stateful strategy, or a stateful denoiser, needs the warmup frames in order
    in_order = strategy.stateful or any(is_stateful(d) for d in chosen.values())
    shown = range(run.warmup, run.warmup + run.frames)
    for _ in range(first_frame(strategy, shown, in_order)):  # skipped warmup frames count as done
        tick()
    measurement.reset()
    render_at = functools.partial(BoundRender, parts, scene, run.spp)
    for t, frame in play(strategy, render_at, shown, max(run.motion, 1), in_order=in_order):
        tick()
        if t >= run.warmup:
            ref = references.get(run, scene, t_reference(run, t))
            measurement.add(t, frame, ref, _previous_reference(run, scene, references, t))
        else:
            measurement.feed_warmup(t, frame)
    return measurement.result(scene.dimensions, strategy.sampler_name or run.sampler)


def finish_run(
    run: Run,
    results: list[SeedSetResult],
    version: str,
    crops_dir: Path | None,
    *,
    merge_crops: bool = False,
    kept: Mapping[str, Record] | None = None,
) -> list[Record]:
    """Save the crops (if any, and ``crops_dir``) and merge the seed sets into records.

    ``merge_crops`` (a resumed sweep): the run may be narrowed to the denoisers whose cells were
    missing, so its crops join those of the crop file an earlier pass left (same names replaced)
    instead of replacing the file, whose other denoisers' crops the kept records still show.
    ``kept``: the records so far (key -> record), where a run with ``reuse`` finds the previous
    look's records its new seed sets join (:func:`benchmarks.sweep.reuse.extend`).
    """
    crop = next((r.crop for r in results if r.group == 0 and r.crop), None)
    crop_file = (
        _save_crop(run, crop, crops_dir, merge_crops) if crop and crops_dir is not None else None
    )
    return extend(run, merge_seed_sets(run, results, version, crop_file), kept or {})


def measure_run(
    run: Run,
    parts: Parts,
    references: References,
    denoisers: dict[str, Denoiser],
    *,
    crops_dir: Path | None = None,
    on_frame: Callable[[], None] | None = None,
    merge_crops: bool = False,
    kept: Mapping[str, Record] | None = None,
) -> list[Record]:
    """Render, denoise and measure every seed set of ``run`` in turn (``run.groups``: those
    not kept from the previous look); return one record per cell.

    Args:
        run, parts, references, denoisers, on_frame: as :func:`measure_seed_set`.
        crops_dir: where to save the side-by-side crops (if ``run.crops``), or None.
        merge_crops, kept: as :func:`finish_run`.

    Returns:
        One :class:`~benchmarks.sweep.records.Record` per cell of ``run.cells()``, in that order.
    """
    results = [
        measure_seed_set(run, parts, references, denoisers, group, on_frame=on_frame)
        for group in run.groups
    ]
    return finish_run(
        run, results, parts.code_version, crops_dir, merge_crops=merge_crops, kept=kept
    )


def _save_crop(run: Run, crop: dict[str, np.ndarray], crops_dir: Path, merge: bool = False) -> str:
    """Save the tone-mapped crops of a run as one compressed ``.npz`` (with ``merge``, joined to
    the crops already in that file); return its name relative to the output folder."""
    depth = "" if run.depth is None else f"_d{run.depth}"
    name = f"{run.scene}_{run.strategy}_{run.spp}spp_m{run.motion}{depth}_{run.sampler}.npz"
    crops_dir.mkdir(parents=True, exist_ok=True)
    arrays = {k.replace("/", "__"): v for k, v in crop.items()}
    if merge and (crops_dir / name).is_file():
        with np.load(crops_dir / name) as kept:
            arrays = {**{k: kept[k] for k in kept.files}, **arrays}
    with atomic_write(crops_dir / name) as tmp:
        with open(tmp, "wb") as handle:
            # numpy's stub lets a ** mapping reach the bool allow_pickle; these are arrays
            np.savez_compressed(handle, **arrays)  # type: ignore[arg-type]
    return f"{crops_dir.name}/{name}"
