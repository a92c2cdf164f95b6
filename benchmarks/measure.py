"""Measuring one run: render through the strategy, denoise, compare with the references.

For each seed set of a :class:`benchmarks.plan.Run`, :func:`measure_run` builds the strategy, lets
it drive the renderer for ``warmup + frames`` frames (the warmup frames are rendered but not
measured, so that the temporal strategies have converged; stateless strategies skip them, see
:class:`benchmarks.parts.Parts`), and, for each measured frame, compares the raw frame and every
denoiser's output with the reference of that frame (:class:`bnerr.metrics.FrameMetrics`), once per
pixel region. One run yields one :class:`benchmarks.records.Record` per cell (denoiser x region).

- **Timings** per measured frame, one stopwatch each: ``render_ms`` is the frame's
  ``timings["render"]`` (the renderer's own clock, summed over the strategy's renders: the oracle
  renders K candidates), ``perm_ms`` its ``timings["strategy"]`` (everything the strategy does
  outside the renderer) and ``denoise_ms`` a :class:`bnerr.timing.Stopwatch` around the denoiser.
- **Samplers**: a record keeps ``render_sampler``, the sampler the strategy's renders used
  (``strategy.sampler_name``): the run's per-pixel ``sampler`` condition, or the strategy's own
  (bnds, bnds_st, zsobol, cycles_blue, zsobol_t, temporal_zsobol ignore the condition). The
  cell's ``sampler`` stays the condition, so every record pairs with white's under it.
- **Fair denoisers** (:func:`tune_denoisers`): each filter's parameters are tuned once per scene,
  condition and spp on white-noise frames (:mod:`denoisers.tuning`) and used unchanged for every
  strategy.
- **Crops**: a centre crop of the reference, the raw frame and every denoised frame of the first
  measured frame, as 8-bit sRGB previews (:func:`bnerr.color.preview_u8`), saved per run.

Not for: timing the parts in isolation at 1080p (the ``speed`` suite, :mod:`benchmarks.speed`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch

from benchmarks.parts import Denoiser, Parts, Scene
from benchmarks.plan import Run
from benchmarks.records import Record, ReferenceInfo, Spectrum, Timings
from benchmarks.references import ReferenceCache
from bnerr.color import preview_u8
from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from bnerr.io import atomic_write
from bnerr.metrics import FrameMetrics, edge_mask
from bnerr.spectrum import radial_power_spectrum
from bnerr.timing import Stopwatch

__all__ = ["TUNING_SEED_SET", "ParamStore", "measure_run", "tune_denoisers"]

#: The seed set of the white frames the denoisers are tuned on: no measured run uses it.
TUNING_SEED_SET = 1_000_003
_SPECTRUM_TILE = 64
_CROP = 64


class ParamStore(Protocol):
    """The tuned parameters (:class:`denoisers.tuning.ParamStore`), as :func:`tune_denoisers`
    uses them."""

    entries: dict

    def put(self, result: Any, scene: str, spp: int) -> None: ...

    def params(self, denoiser: str, scene: str, spp: int) -> dict: ...


class _BoundRender:
    """The ``render(seeds, sampler)`` a strategy calls, with scene, t and spp bound (no clock:
    the frame carries the renderer's own time)."""

    def __init__(self, parts: Parts, scene: Scene, spp: int) -> None:
        self.parts, self.scene, self.spp = parts, scene, spp
        self.t_render = 0

    def __call__(self, seeds: torch.Tensor, sampler: Any) -> Frame:
        return self.parts.render(self.scene, self.t_render, seeds, sampler, self.spp)


def _center_crop(x: torch.Tensor, size: int) -> torch.Tensor:
    h, w = x.shape[-2:]
    ch, cw = min(size, h), min(size, w)
    y0, x0 = (h - ch) // 2, (w - cw) // 2
    return x[..., y0 : y0 + ch, x0 : x0 + cw]


class _SpectrumMean:
    """Running mean of the radially averaged power spectrum of ``[3, H, W]`` error images."""

    def __init__(self) -> None:
        self.freq: list[float] | None = None
        self.total: torch.Tensor | None = None
        self.count = 0

    def add(self, err: torch.Tensor) -> None:
        freq, power = radial_power_spectrum(err.to(torch.float64), tile=_SPECTRUM_TILE)
        self.freq = freq.tolist()
        self.total = power.cpu() if self.total is None else self.total + power.cpu()
        self.count += 1

    def result(self) -> Spectrum:
        power = (self.total / self.count).tolist() if self.count else []
        return Spectrum(freq=self.freq or [], power=power)


def _scene_for(run: Run, parts: Parts) -> Scene:
    scene = parts.get_scene(run.scene, run.motion != 0)
    if run.depth is not None:
        scene = parts.with_depth(scene, run.depth)
    return scene


def _t_render(run: Run, t: int) -> int:
    """The frame the renderer sees: ``motion`` times faster; a static scene ignores it."""
    return t * max(run.motion, 1)


def _t_reference(run: Run, t: int) -> int:
    """Static scenes (motion 0) look the same at every t: one reference serves every frame."""
    return _t_render(run, t) if run.motion else 0


def _region_masks(run: Run, ref: Frame) -> dict[str, torch.Tensor | None]:
    masks: dict[str, torch.Tensor | None] = {}
    for region in run.regions:
        if region == "all":
            masks[region] = None
        elif ref.object_id is None:
            raise ValueRangeError(
                f"reference of {run.scene!r}: expected an object_id buffer for region 'edges', "
                "got none"
            )
        else:
            masks[region] = edge_mask(ref.object_id, radius=1)
    return masks


def _params(denoiser: Denoiser) -> dict:
    params = getattr(denoiser, "params", None)
    return dict(params()) if callable(params) else {}


class _Measurement:
    """Everything measured in one run: metrics, timings, spectra and crops, per cell."""

    def __init__(self, run: Run, denoisers: dict[str, Denoiser]) -> None:
        self.run = run
        self.denoisers = denoisers
        metrics, regions = run.metrics, run.regions
        self.raw = {r: FrameMetrics(metrics, tile=_SPECTRUM_TILE) for r in regions}
        self.den = {
            (d, r): FrameMetrics(metrics, tile=_SPECTRUM_TILE) for d in denoisers for r in regions
        }
        self.spectra = {"raw": _SpectrumMean(), **{d: _SpectrumMean() for d in denoisers}}
        self.timings: dict[str, list[list[float]]] = {
            "render_ms": [],
            "perm_ms": [],
            **{f"denoise_ms/{d}": [] for d in denoisers},
        }
        self.measured_t: list[int] = []
        self.render_sampler = run.sampler
        self.floors: list[float] = []
        self.crop: dict[str, np.ndarray] = {}

    def start_seed_set(self) -> None:
        for series in self.timings.values():
            series.append([])

    def add(self, group: int, t: int, frame: Frame, ref: Frame) -> None:
        """Measure frame ``t`` of seed set ``group`` (with its timings) against its reference."""
        if group == 0:
            self.measured_t.append(t)
        if ref.variance is not None:
            self.floors.append(float(ref.variance.to(torch.float64).mean()))
        masks = _region_masks(self.run, ref)
        self.timings["render_ms"][-1].append(float(frame.timings.get("render", 0.0)))
        self.timings["perm_ms"][-1].append(float(frame.timings.get("strategy", 0.0)))
        for region, mask in masks.items():
            self.raw[region].update(frame.color, ref.color, mask, group=group)
        self.spectra["raw"].add(frame.color - ref.color)
        outputs = {}
        for name, denoiser in self.denoisers.items():
            watch = Stopwatch()
            out = denoiser(frame)
            self.timings[f"denoise_ms/{name}"][-1].append(watch.ms(out))
            outputs[name] = out
            self.spectra[name].add(out - ref.color)
            for region, mask in masks.items():
                self.den[name, region].update(out, ref.color, mask, group=group)
        if self.run.crops and group == 0 and not self.crop:
            self._keep_crop(frame, ref, outputs)

    def _keep_crop(self, frame: Frame, ref: Frame, outputs: dict[str, torch.Tensor]) -> None:
        images = {"reference": ref.color, "raw": frame.color}
        images.update({f"denoised/{n}": o for n, o in outputs.items()})
        self.crop = {k: preview_u8(_center_crop(v, _CROP)) for k, v in images.items()}

    def records(self, scene: Scene, version: str, crop_file: str | None) -> list[Record]:
        floor = float(np.mean(self.floors)) if self.floors else None
        reference = ReferenceInfo(spp=self.run.reference_spp, floor=floor, version=version)
        metrics = self.run.metrics
        return [
            Record(
                cell=cell,
                dimensions=int(getattr(scene, "dimensions", 0)),
                t=list(self.measured_t),
                raw={m: self.raw[cell.region].stats(m).tolist() for m in metrics},
                den={m: self.den[cell.denoiser, cell.region].stats(m).tolist() for m in metrics},
                denoiser_params=_params(self.denoisers[cell.denoiser]),
                timings=Timings(
                    render_ms=self.timings["render_ms"],
                    perm_ms=self.timings["perm_ms"],
                    denoise_ms=self.timings[f"denoise_ms/{cell.denoiser}"],
                ),
                reference=reference,
                spectrum={
                    "raw": self.spectra["raw"].result(),
                    "den": self.spectra[cell.denoiser].result(),
                },
                crop=crop_file,
                render_sampler=self.render_sampler,
            )
            for cell in self.run.cells()
        ]


def measure_run(
    run: Run,
    parts: Parts,
    references: ReferenceCache,
    denoisers: dict[str, Denoiser],
    *,
    crops_dir: Path | None = None,
    on_frame: Callable[[], None] | None = None,
) -> list[Record]:
    """Render, denoise and measure every frame of ``run``; return one record per cell.

    Args:
        run: what to measure (:func:`benchmarks.plan.plan`).
        parts: the parts that render and permute.
        references: the reference cache.
        denoisers: name -> denoiser (with its tuned parameters) for every name in ``run.denoisers``.
        crops_dir: where to save the side-by-side crops (if ``run.crops``), or None.
        on_frame: called after every rendered frame (the progress bar).

    Returns:
        One :class:`~benchmarks.records.Record` per cell of ``run.cells()``, in that order.
    """
    scene = _scene_for(run, parts)
    measurement = _Measurement(run, {name: denoisers[name] for name in run.denoisers})
    render = _BoundRender(parts, scene, run.spp)
    tick = on_frame if on_frame is not None else (lambda: None)
    for group in range(run.seed_sets):
        strategy = parts.make_strategy(
            run.strategy, scene, run.height, run.width, group, run.sampler, run.spp
        )
        measurement.render_sampler = getattr(strategy, "sampler_name", "") or run.sampler
        measurement.start_seed_set()
        first = 0 if parts.stateful(strategy) else run.warmup
        for _ in range(first):  # the skipped warmup frames count as done
            tick()
        for t in range(first, run.warmup + run.frames):
            render.t_render = _t_render(run, t)
            frame = strategy.frame(t, render)
            tick()
            if t >= run.warmup:
                ref = references.get(run, scene, _t_reference(run, t))
                measurement.add(group, t, frame, ref)
    crop_file = None
    if measurement.crop and crops_dir is not None:
        crop_file = _save_crop(run, measurement.crop, crops_dir)
    return measurement.records(scene, parts.code_version, crop_file)


def _save_crop(run: Run, crop: dict[str, np.ndarray], crops_dir: Path) -> str:
    """Save the tone-mapped crops of a run as one compressed ``.npz``; return its name relative to
    the output folder."""
    depth = "" if run.depth is None else f"_d{run.depth}"
    name = f"{run.scene}_{run.strategy}_{run.spp}spp_m{run.motion}{depth}_{run.sampler}.npz"
    crops_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(crops_dir / name) as tmp:
        with open(tmp, "wb") as handle:
            np.savez_compressed(handle, **{k.replace("/", "__"): v for k, v in crop.items()})
    return f"{crops_dir.name}/{name}"


# --------------------------------------------------------------------------------------------------
# Fair denoiser parameters


def _tuning_key(run: Run) -> str:
    """What the tuned parameters depend on besides spp: scene, condition, sampler and resolution."""
    depth = "" if run.depth is None else f"/d{run.depth}"
    return f"{run.scene}/m{run.motion}{depth}/{run.sampler}/{run.width}x{run.height}"


def _stored(store: ParamStore, name: str, key: str, spp: int) -> dict | None:
    """The stored parameters, or None for a denoiser without any (nothing to tune)."""
    if str(spp) in store.entries.get(name, {}).get(key, {}):
        return store.params(name, key, spp)
    return None


def tune_denoisers(
    run: Run, parts: Parts, references: ReferenceCache, store: ParamStore
) -> dict[str, Denoiser]:
    """The run's denoisers with parameters tuned on white noise for its scene, condition and spp.

    Parameters missing from ``store`` are tuned now, on ``min(frames, 4)`` frames rendered with
    the ``white`` strategy from a seed set no measured run uses (:data:`TUNING_SEED_SET`), against
    the same references, and put in the store; then every strategy's run uses them unchanged.
    """
    key = _tuning_key(run)
    missing = [d for d in run.denoisers if _stored(store, d, key, run.spp) is None]
    if missing:
        scene = _scene_for(run, parts)
        render = _BoundRender(parts, scene, run.spp)
        strategy = parts.make_strategy(
            "white", scene, run.height, run.width, TUNING_SEED_SET, run.sampler, run.spp
        )
        frames, refs = [], []
        for t in range(run.warmup, run.warmup + min(run.frames, 4)):
            render.t_render = _t_render(run, t)
            frames.append(strategy.frame(t, render))
            refs.append(references.get(run, scene, _t_reference(run, t)).color)
        for name in missing:
            result = parts.tune_denoiser(name, frames, refs)
            if result is not None:
                store.put(result, key, run.spp)
    return {
        name: parts.make_denoiser(name, _stored(store, name, key, run.spp))
        for name in run.denoisers
    }
