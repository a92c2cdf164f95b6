"""The sweep runner behind ``bnerr bench``: render, permute, denoise and measure every cell of a suite.

For each **run** (scene x strategy x spp x motion/depth condition, see :mod:`benchmarks.suites`)
and each independent seed set, the runner builds the strategy, lets it drive the renderer for
``warmup + frames`` frames (the warmup frames are rendered but not measured, so that the temporal
strategies have converged; stateless strategies skip them, see :class:`Parts`), and, for each
measured frame, compares the raw frame and every denoiser's output with the reference of that
frame (:class:`bnerr.metrics.FrameMetrics`), once per pixel region. One run yields one record per cell (denoiser x region): per-frame metric pairs (so
that the report can bootstrap intervals and pair strategies on the same frames), per-frame
timings, and the error spectra.

- **References** are rendered once per scene, frame, resolution, spp, motion/depth condition and
  renderer version with Owen-scrambled Sobol and seeds that no strategy uses, and cached as EXR
  under ``cache/references/``. The renderer version is the package's ``RENDERER_VERSION`` when it
  declares one, plus a hash of its source files, so that a change to the tracer never reuses a
  stale reference. The reference's own noise adds its variance to every strategy's MSE alike; the
  records keep it (``reference.floor``) so that a reader can see when it matters.
- **Fair denoisers**: each filter's parameters are tuned once per scene, condition and spp on
  white-noise frames (:func:`tune_denoisers`, :mod:`denoisers.tuning`), saved in
  ``<out>/tuned_params.json``, and used unchanged for every strategy.
- **Timings** per measured frame: ``render_ms`` (time inside the renderer, summed over the
  strategy's renders: the oracle renders K candidates), ``perm_ms`` (``strategy.overhead_ms``,
  everything the strategy does outside the renderer) and ``denoise_ms``.
- **Results** go to ``<out>/cells.jsonl``, rewritten atomically after every run, so an interrupted
  sweep loses at most the run in progress; ``resume=True`` keeps what the file holds and skips the
  cells already there.

The parts (scenes, renderer, strategies, denoisers) come through :class:`Parts`, so the runner
can be tested with stand-ins and stays generic: it never branches on a strategy's or denoiser's
name. Not for: timing the parts in isolation at 1080p (that is the ``speed`` suite's scripts).
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.frame import Frame
from bnerr.io import atomic_write, read_frame, write_frame
from bnerr.metrics import FrameMetrics, edge_mask
from bnerr.spectrum import radial_power_spectrum
from benchmarks.suites import Suite, Sweep

__all__ = [
    "RESULTS_FILE",
    "TUNED_PARAMS_FILE",
    "Cell",
    "Parts",
    "ReferenceCache",
    "Run",
    "known_names",
    "load_records",
    "measure_run",
    "plan",
    "real_parts",
    "reference_seeds",
    "run_speed",
    "run_suite",
    "tune_denoisers",
]

#: Name of the per-cell results file inside the output folder.
RESULTS_FILE = "cells.jsonl"

#: Name of the tuned denoiser parameters file inside the output folder.
TUNED_PARAMS_FILE = "tuned_params.json"

_REFERENCE_SALT = 0x5EED_BA5E  # keeps reference seeds apart from every strategy's seeds
_REFERENCE_FORMAT = "r1"  # bump when the reference seeds, sampler or file layout change
_REFERENCES_IN_MEMORY = 16  # a run revisits its measured frames once per seed set
_TUNING_SEED_SET = 1_000_003  # the white frames the denoisers are tuned on: no measured run uses it
_SPECTRUM_TILE = 64
_CROP = 64


# --------------------------------------------------------------------------------------------------
# The parts the runner drives


@dataclass(frozen=True)
class Parts:
    """The renderer, strategies and denoisers, as the runner calls them.

    Attributes:
        get_scene: ``(name, animated) -> scene``; the scene has ``dimensions`` and ``max_depth``.
        render: ``(scene, t, seeds [H, W] int64, sampler, spp) -> Frame``.
        make_strategy: ``(name, scene, height, width, seed, sampler) -> Strategy`` with
            ``frame(t, render) -> Frame`` and ``overhead_ms``.
        stateful: ``(strategy) -> bool``: whether a frame depends on the earlier frames (the
            temporal strategies). Only those render the warmup frames; a stateless strategy's
            frame t is the same whether or not frames 0..t-1 were rendered, so the runner skips
            them (the oracle's warmup would cost K renders per frame for nothing).
        make_denoiser: ``(name, params) -> Denoiser`` (``params`` from :func:`tune_denoiser`,
            or None for a denoiser without parameters).
        tune_denoiser: ``(name, frames, references) -> TuneResult | None``: grid-search the
            denoiser's parameters on white-noise frames (:func:`denoisers.tuning.tune`); None
            for a denoiser that has nothing to tune.
        reference_sampler: ``() -> Sampler`` used for the references.
        with_depth: ``(scene, depth) -> scene`` with its maximum path depth replaced.
        renderer_version: a string that changes whenever the renderer's output could change.
    """

    get_scene: Callable[[str, bool], Any]
    render: Callable[..., Frame]
    make_strategy: Callable[[str, Any, int, int, int, str], Any]
    stateful: Callable[[Any], bool]
    make_denoiser: Callable[[str, dict | None], Any]
    tune_denoiser: Callable[[str, list[Frame], list[torch.Tensor]], Any]
    reference_sampler: Callable[[], Any]
    with_depth: Callable[[Any, int], Any]
    renderer_version: str


def _source_hash(package: str) -> str:
    """Short hash of a package's ``.py`` sources (sorted by path), for cache keys."""
    root = Path(importlib.import_module(package).__file__).parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def real_parts() -> Parts:
    """The project's own parts: ``renderers``, :mod:`bnerr.strategies` and ``denoisers``."""
    import denoisers
    import renderers
    from bnerr import sequences
    from denoisers import tuning

    def make_denoiser(name: str, params: dict | None):
        return denoisers.get_denoiser(name, **(params or {}))

    def tune_denoiser(name: str, frames: list[Frame], refs: list[torch.Tensor]):
        return tuning.tune(name, frames, refs) if name in tuning.GRIDS else None

    def make_strategy(name: str, scene: Any, height: int, width: int, seed: int, sampler: str):
        from bnerr import strategies

        return strategies.make_strategy(
            name, height, width, seed=seed, sampler=sampler, dimensions=scene.dimensions
        )

    def stateful(strategy: Any) -> bool:
        from bnerr import strategies

        return isinstance(strategy, strategies.TemporalStrategy)

    def reference_sampler():
        # Owen-scrambled Sobol converges faster than white noise at equal spp, so the reference
        # noise floor is lower for the same render time; it is unbiased like white noise.
        return sequences.make_sampler("owen_sobol")

    version = f"{getattr(renderers, 'RENDERER_VERSION', '0')}-{_source_hash('renderers')}"
    return Parts(
        get_scene=lambda name, animated: renderers.get_scene(name, animated=animated),
        render=renderers.render,
        make_strategy=make_strategy,
        stateful=stateful,
        make_denoiser=make_denoiser,
        tune_denoiser=tune_denoiser,
        reference_sampler=reference_sampler,
        with_depth=lambda scene, depth: dataclasses.replace(scene, max_depth=depth),
        renderer_version=version,
    )


# --------------------------------------------------------------------------------------------------
# Planning: suite -> runs -> cells


@dataclass(frozen=True)
class Cell:
    """One row of the results table (see :mod:`benchmarks.suites` for the axes)."""

    scene: str
    strategy: str
    spp: int
    denoiser: str
    motion: int
    depth: int | None
    region: str
    sampler: str
    frames: int
    warmup: int
    width: int
    height: int
    seed_sets: int
    reference_spp: int

    def key(self) -> str:
        """A stable string identifying the cell in the results file."""
        return json.dumps(dataclasses.asdict(self), sort_keys=True)


@dataclass(frozen=True)
class Run:
    """Everything rendered together: one strategy on one scene/spp/condition, all seed sets.

    The cells of a run share its renders and differ only in denoiser and pixel region.
    """

    scene: str
    strategy: str
    spp: int
    motion: int
    depth: int | None
    sampler: str
    frames: int
    warmup: int
    width: int
    height: int
    seed_sets: int
    reference_spp: int
    denoisers: tuple[str, ...]
    regions: tuple[str, ...]
    metrics: tuple[str, ...]
    crops: bool

    def cells(self) -> list[Cell]:
        common = dict(
            scene=self.scene, strategy=self.strategy, spp=self.spp, motion=self.motion,
            depth=self.depth, sampler=self.sampler, frames=self.frames, warmup=self.warmup, width=self.width,
            height=self.height, seed_sets=self.seed_sets, reference_spp=self.reference_spp,
        )
        return [Cell(denoiser=d, region=r, **common) for d in self.denoisers for r in self.regions]

    @property
    def label(self) -> str:
        extra = (
            (f" motion={self.motion}" if self.motion != 1 else "")
            + (f" depth={self.depth}" if self.depth is not None else "")
            + (f" sampler={self.sampler}" if self.sampler != "owen_sobol" else "")
        )
        return f"{self.scene} {self.strategy} {self.spp}spp{extra}"


def _sweep_runs(sweep: Sweep, crops: bool) -> list[Run]:
    renders: dict[tuple[int, int | None, str], list[str]] = {}
    for cond in sweep.conditions:
        regions = renders.setdefault((cond.motion, cond.depth, cond.sampler), [])
        if cond.region not in regions:
            regions.append(cond.region)
    runs = []
    for scene in sweep.scenes:
        for (motion, depth, sampler), regions in renders.items():
            for spp in sweep.spp:
                for strategy in sweep.strategies:
                    runs.append(
                        Run(
                            scene=scene, strategy=strategy, spp=spp, motion=motion, depth=depth,
                            sampler=sampler,
                            frames=sweep.frames, warmup=sweep.warmup, width=sweep.res[0],
                            height=sweep.res[1], seed_sets=sweep.seed_sets,
                            reference_spp=sweep.reference_spp, denoisers=sweep.denoisers,
                            regions=tuple(regions), metrics=sweep.metrics,
                            crops=crops and spp == min(sweep.spp),
                        )
                    )
    return runs


def plan(suite: Suite) -> list[Run]:
    """The runs of a suite, in order, with duplicate runs (same renders) merged."""
    merged: dict[tuple, Run] = {}
    for sweep in suite.sweeps:
        for run in _sweep_runs(sweep, suite.crops):
            key = dataclasses.astuple(dataclasses.replace(run, denoisers=(), regions=(), crops=False))
            old = merged.get(key)
            if old is None:
                merged[key] = run
                continue
            merged[key] = dataclasses.replace(
                old,
                denoisers=tuple(dict.fromkeys(old.denoisers + run.denoisers)),
                regions=tuple(dict.fromkeys(old.regions + run.regions)),
                crops=old.crops or run.crops,
            )
    return list(merged.values())


# --------------------------------------------------------------------------------------------------
# References


def _hash32(x: torch.Tensor) -> torch.Tensor:
    """A 32-bit integer mix (the ``0x45d9f3b`` hash) on int64 tensors holding 32-bit values."""
    mask = 0xFFFFFFFF
    x = (((x >> 16) ^ x) * 0x45D9F3B) & mask
    x = (((x >> 16) ^ x) * 0x45D9F3B) & mask
    return (x >> 16) ^ x


def reference_seeds(height: int, width: int, t: int) -> torch.Tensor:
    """Distinct-looking seeds ``[H, W]`` int64 for the reference of frame ``t``.

    Keyed by a salt that no strategy uses, so that a reference never shares a sequence with the
    frame it judges (a shared sequence would correlate their errors and understate the MSE).
    """
    index = torch.arange(height * width, dtype=torch.int64)
    return _hash32(_hash32(index ^ _REFERENCE_SALT) ^ (t & 0xFFFFFFFF)).reshape(height, width)


class ReferenceCache:
    """High-spp references, rendered on first use and kept as EXR files.

    The file name holds every input of the render: scene, motion/depth condition, the frame the
    renderer sees, resolution, spp, the reference format and the renderer version. Static scenes
    (motion 0) share one reference across frames. The last few are also kept in memory.

    Args:
        root: cache folder (``cache/references`` by default in the CLI; git-ignored).
        parts: the parts that render.
    """

    def __init__(self, root: str | Path, parts: Parts) -> None:
        self.root = Path(root)
        self.parts = parts
        self._memory: dict[str, Frame] = {}

    def path(self, run: Run, t_render: int) -> Path:
        """The cache file of ``run``'s reference at renderer frame ``t_render``."""
        depth = "d" if run.depth is None else f"d{run.depth}"
        version = self.parts.renderer_version.replace("/", "_")
        size = f"{run.width}x{run.height}"
        name = (f"{run.scene}_m{run.motion}_{depth}_t{t_render}_{size}_spp{run.reference_spp}"
                f"_{_REFERENCE_FORMAT}_{version}.exr")
        return self.root / run.scene / name

    def get(self, run: Run, scene: Any, t_render: int) -> Frame:
        """The reference Frame of ``scene`` at renderer frame ``t_render`` for ``run``'s settings."""
        path = self.path(run, t_render)
        key = str(path)
        if key in self._memory:
            return self._memory[key]
        if path.exists():
            try:
                frame = read_frame(path)
            except FileFormatError:
                frame = None  # a torn or corrupt cache file: render it again
        else:
            frame = None
        if frame is None:
            seeds = reference_seeds(run.height, run.width, t_render)
            frame = self.parts.render(scene, t_render, seeds, self.parts.reference_sampler(), run.reference_spp)
            path.parent.mkdir(parents=True, exist_ok=True)
            write_frame(path, frame)
        if len(self._memory) >= _REFERENCES_IN_MEMORY:
            self._memory.pop(next(iter(self._memory)))
        self._memory[key] = frame
        return frame


# --------------------------------------------------------------------------------------------------
# Measuring one run


def _sync(x: torch.Tensor) -> torch.Tensor:
    """Wait for the device so that wall-clock timings cover the work (no-op on the CPU)."""
    if x.is_cuda:
        torch.cuda.synchronize(x.device)
    return x


class _TimedRender:
    """The ``render(seeds, sampler)`` a strategy calls, with scene, t and spp bound; sums its time."""

    def __init__(self, parts: Parts, scene: Any, spp: int) -> None:
        self.parts, self.scene, self.spp = parts, scene, spp
        self.t_render = 0
        self.ms = 0.0

    def __call__(self, seeds: torch.Tensor, sampler: Any) -> Frame:
        start = time.perf_counter()
        frame = self.parts.render(self.scene, self.t_render, seeds, sampler, self.spp)
        _sync(frame.color)
        self.ms += (time.perf_counter() - start) * 1e3
        return frame


def _tonemap_u8(color: torch.Tensor) -> np.ndarray:
    """``[3, H, W]`` linear radiance -> ``[H, W, 3]`` uint8: Reinhard ``x / (1 + x)`` then sRGB gamma."""
    x = color.detach().to("cpu", torch.float32).clamp_min(0.0)
    x = (x / (1.0 + x)) ** (1.0 / 2.2)
    return (x.permute(1, 2, 0).numpy() * 255.0 + 0.5).astype(np.uint8)


def _center_crop(x: torch.Tensor, size: int) -> torch.Tensor:
    h, w = x.shape[-2:]
    ch, cw = min(size, h), min(size, w)
    y0, x0 = (h - ch) // 2, (w - cw) // 2
    return x[..., y0 : y0 + ch, x0 : x0 + cw]


class _SpectrumMean:
    """Running mean of the radially averaged power spectrum of error images."""

    def __init__(self) -> None:
        self.freq: list[float] | None = None
        self.total: torch.Tensor | None = None
        self.count = 0

    def add(self, err: torch.Tensor) -> None:
        freq, power = radial_power_spectrum(err.to(torch.float64), tile=_SPECTRUM_TILE)
        self.freq = freq.tolist()
        self.total = power.cpu() if self.total is None else self.total + power.cpu()
        self.count += 1

    def result(self) -> dict[str, list[float]]:
        return {"freq": self.freq or [], "power": (self.total / self.count).tolist() if self.count else []}


def _scene_for(run: Run, parts: Parts) -> Any:
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
                f"reference of {run.scene!r}: expected an object_id buffer for region 'edges', got none"
            )
        else:
            masks[region] = edge_mask(ref.object_id, radius=1)
    return masks


class _Measurement:
    """Everything measured in one run: metrics, timings, spectra and crops, per cell."""

    def __init__(self, run: Run, denoisers: dict[str, Any]) -> None:
        self.run = run
        self.denoisers = denoisers
        self.raw = {r: FrameMetrics(run.metrics, tile=_SPECTRUM_TILE) for r in run.regions}
        self.den = {(d, r): FrameMetrics(run.metrics, tile=_SPECTRUM_TILE) for d in denoisers for r in run.regions}
        self.spectra = {"raw": _SpectrumMean(), **{d: _SpectrumMean() for d in denoisers}}
        self.timings: dict[str, list[list[float]]] = {
            "render_ms": [], "perm_ms": [], **{f"denoise_ms/{d}": [] for d in denoisers}
        }
        self.measured_t: list[int] = []
        self.floors: list[float] = []
        self.crop: dict[str, np.ndarray] = {}

    def start_seed_set(self) -> None:
        for series in self.timings.values():
            series.append([])

    def add(self, group: int, t: int, frame: Frame, ref: Frame, render_ms: float, perm_ms: float) -> None:
        """Measure one frame of seed set ``group`` against its reference."""
        if group == 0:
            self.measured_t.append(t)
        if ref.variance is not None:
            self.floors.append(float(ref.variance.to(torch.float64).mean()))
        masks = _region_masks(self.run, ref)
        self.timings["render_ms"][-1].append(render_ms)
        self.timings["perm_ms"][-1].append(perm_ms)
        for region, mask in masks.items():
            self.raw[region].update(frame.color, ref.color, mask, group=group)
        self.spectra["raw"].add(frame.color - ref.color)
        outputs = {}
        for name, denoiser in self.denoisers.items():
            start = time.perf_counter()
            out = _sync(denoiser(frame))
            self.timings[f"denoise_ms/{name}"][-1].append((time.perf_counter() - start) * 1e3)
            outputs[name] = out
            self.spectra[name].add(out - ref.color)
            for region, mask in masks.items():
                self.den[name, region].update(out, ref.color, mask, group=group)
        if self.run.crops and group == 0 and not self.crop:
            images = {"reference": ref.color, "raw": frame.color, **{f"denoised/{n}": o for n, o in outputs.items()}}
            self.crop = {k: _tonemap_u8(_center_crop(v, _CROP)) for k, v in images.items()}

    def records(self, scene: Any, version: str, crop_file: str | None) -> list[dict]:
        reference = {
            "spp": self.run.reference_spp,
            "floor": float(np.mean(self.floors)) if self.floors else None,
            "version": version,
        }
        metrics = self.run.metrics
        return [
            {
                "key": cell.key(),
                "cell": dataclasses.asdict(cell),
                "dimensions": int(getattr(scene, "dimensions", 0)),
                "t": self.measured_t,
                "raw": {m: self.raw[cell.region].stats(m).tolist() for m in metrics},
                "den": {m: self.den[cell.denoiser, cell.region].stats(m).tolist() for m in metrics},
                "denoiser_params": _params(self.denoisers[cell.denoiser]),
                "timings": {
                    "render_ms": self.timings["render_ms"],
                    "perm_ms": self.timings["perm_ms"],
                    "denoise_ms": self.timings[f"denoise_ms/{cell.denoiser}"],
                },
                "reference": reference,
                "spectrum": {"raw": self.spectra["raw"].result(), "den": self.spectra[cell.denoiser].result()},
                "crop": crop_file,
            }
            for cell in self.run.cells()
        ]


def _params(denoiser: Any) -> dict:
    params = getattr(denoiser, "params", None)
    return dict(params()) if callable(params) else {}


def measure_run(
    run: Run,
    parts: Parts,
    references: ReferenceCache,
    denoisers: dict[str, Any],
    *,
    crops_dir: Path | None = None,
    on_frame: Callable[[], None] | None = None,
) -> list[dict]:
    """Render, denoise and measure every frame of ``run``; return one record per cell.

    Args:
        run: what to measure (see :func:`plan`).
        parts: the parts that render and permute.
        references: the reference cache.
        denoisers: name -> denoiser (with its tuned parameters) for every name in ``run.denoisers``.
        crops_dir: where to save the side-by-side crops (if ``run.crops``), or None.
        on_frame: called after every rendered frame (the progress bar).

    Returns:
        One JSON-ready dict per cell of ``run.cells()``; see :func:`load_records`.
    """
    scene = _scene_for(run, parts)
    measurement = _Measurement(run, {name: denoisers[name] for name in run.denoisers})
    render = _TimedRender(parts, scene, run.spp)
    for group in range(run.seed_sets):
        strategy = parts.make_strategy(run.strategy, scene, run.height, run.width, group, run.sampler)
        measurement.start_seed_set()
        first = 0 if parts.stateful(strategy) else run.warmup
        if on_frame is not None:
            for _ in range(first):  # the skipped warmup frames count as done
                on_frame()
        for t in range(first, run.warmup + run.frames):
            render.t_render, render.ms = _t_render(run, t), 0.0
            frame = strategy.frame(t, render)
            if on_frame is not None:
                on_frame()
            if t >= run.warmup:
                ref = references.get(run, scene, _t_reference(run, t))
                measurement.add(group, t, frame, ref, render.ms, float(strategy.overhead_ms))
    crop_file = _save_crop(run, measurement.crop, crops_dir) if measurement.crop and crops_dir else None
    return measurement.records(scene, parts.renderer_version, crop_file)


def _save_crop(run: Run, crop: dict[str, np.ndarray], crops_dir: Path) -> str:
    """Save the tonemapped crops of a run as one compressed ``.npz``; return its name."""
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


def tune_denoisers(run: Run, parts: Parts, references: ReferenceCache, store: Any) -> dict[str, Any]:
    """The run's denoisers with parameters tuned on white noise for its scene, condition and spp.

    Parameters missing from ``store`` (a :class:`denoisers.tuning.ParamStore`) are tuned now, on
    ``min(frames, 4)`` frames rendered with the ``white`` strategy from a seed set no measured run
    uses, against the same references, and put in the store; then every strategy's run uses them
    unchanged (issue 5, "fair parameters").
    """
    key = _tuning_key(run)
    missing = [d for d in run.denoisers if _stored(store, d, key, run.spp) is None]
    if missing:
        scene = _scene_for(run, parts)
        render = _TimedRender(parts, scene, run.spp)
        strategy = parts.make_strategy("white", scene, run.height, run.width, _TUNING_SEED_SET, run.sampler)
        frames, refs = [], []
        for t in range(run.warmup, run.warmup + min(run.frames, 4)):
            render.t_render = _t_render(run, t)
            frames.append(strategy.frame(t, render))
            refs.append(references.get(run, scene, _t_reference(run, t)).color)
        for name in missing:
            result = parts.tune_denoiser(name, frames, refs)
            if result is not None:
                store.put(result, key, run.spp)
    return {name: parts.make_denoiser(name, _stored(store, name, key, run.spp)) for name in run.denoisers}


def _stored(store: Any, name: str, key: str, spp: int) -> dict | None:
    """The stored parameters, or None for a denoiser without any (nothing to tune)."""
    return store.params(name, key, spp) if str(spp) in store.entries.get(name, {}).get(key, {}) else None


# --------------------------------------------------------------------------------------------------
# Results file and the whole suite


def load_records(out_dir: str | Path) -> list[dict]:
    """The records in ``<out_dir>/cells.jsonl`` (empty if there is none).

    Each record: ``key``, ``cell`` (the :class:`Cell` fields), ``dimensions``, ``t`` (measured
    frame indices), ``raw`` and ``den`` (metric -> per-frame pairs ``[S][F][2]``),
    ``denoiser_params``, ``timings`` (``render_ms``, ``perm_ms``, ``denoise_ms``: ``[S][F]``
    milliseconds), ``reference`` (spp, noise floor = mean variance of the reference pixel means,
    renderer version), ``spectrum`` (``raw`` and ``den``: ``freq`` and ``power`` lists) and
    ``crop`` (file name or None).
    """
    path = Path(out_dir) / RESULTS_FILE
    if not path.exists():
        return []
    records = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError as err:
            raise FileFormatError(f"{path}: expected one JSON record per line, got bad line {number}: {err}") from err
    return records


def _write_records(out_dir: Path, records: Iterable[dict]) -> None:
    text = "".join(json.dumps(r, sort_keys=True) + "\n" for r in records)
    with atomic_write(out_dir / RESULTS_FILE) as tmp:
        Path(tmp).write_text(text)


def _pending(suite: Suite, done: dict[str, dict]) -> list[Run]:
    """The runs with cells not in ``done``, narrowed to their missing denoisers and regions."""
    todo = []
    for run in plan(suite):
        missing = [c for c in run.cells() if c.key() not in done]
        if missing:
            todo.append(
                dataclasses.replace(
                    run,
                    denoisers=tuple(dict.fromkeys(c.denoiser for c in missing)),
                    regions=tuple(dict.fromkeys(c.region for c in missing)),
                )
            )
    return todo


def run_suite(
    suite: Suite,
    out_dir: str | Path,
    *,
    parts: Parts | None = None,
    cache_dir: str | Path = "cache/references",
    resume: bool = False,
    progress: bool = True,
) -> list[dict]:
    """Measure every cell of ``suite`` and write ``<out_dir>/cells.jsonl``; return all records.

    Without ``resume`` the results file and the tuned parameters (``tuned_params.json``) are
    started afresh (the old files are replaced at the first write); with ``resume`` they are kept,
    and the cells already measured are not measured again. A run whose cells are all done is
    skipped; a run with some missing denoisers or regions is rendered again for those only.
    """
    from tqdm import tqdm

    from denoisers.tuning import ParamStore

    parts = real_parts() if parts is None else parts
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    params_path = out / TUNED_PARAMS_FILE
    records = {r["key"]: r for r in load_records(out)} if resume else {}
    store = ParamStore.load(params_path) if resume and params_path.exists() else ParamStore()
    todo = _pending(suite, records)
    references = ReferenceCache(cache_dir, parts)
    total = sum(r.seed_sets * (r.warmup + r.frames) for r in todo)
    with tqdm(total=total, unit="frame", disable=not progress, dynamic_ncols=True) as bar:
        for run in todo:
            bar.set_description(run.label)
            denoisers = tune_denoisers(run, parts, references, store)
            store.save(params_path)
            for record in measure_run(run, parts, references, denoisers, crops_dir=out / "crops",
                                      on_frame=lambda: bar.update(1)):
                records[record["key"]] = record
            _write_records(out, records.values())
    if not todo:
        _write_records(out, records.values())
    return list(records.values())


# --------------------------------------------------------------------------------------------------
# The speed suite and the registries


def run_speed(suite: Suite, out_dir: str | Path, *, progress: bool = True) -> str:
    """Call ``measure()`` of every script of the speed suite; write ``speed.json`` and ``speed.md``.

    Each script (:data:`benchmarks.suites.Suite.scripts`, e.g. ``benchmarks.speed_permute``)
    returns its figures as a (nested) dict; they are stored as they come, and the Markdown lists
    every leaf value under its path. Returns the Markdown.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, Any] = {}
    summaries: dict[str, str] = {}  # what each script's figures are, with their units
    for script in suite.scripts:
        if progress:
            print(f"bnerr bench --suite {suite.name}: {script} ...", flush=True)
        module = importlib.import_module(f"benchmarks.{script}")
        figures[script] = _jsonable(module.measure())
        summaries[script] = " ".join((module.measure.__doc__ or "").strip().split("\n\n")[0].split())
    with atomic_write(out / "speed.json") as tmp:
        Path(tmp).write_text(json.dumps(figures, indent=1, sort_keys=True) + "\n")
    lines = [f"# bnerr bench --suite {suite.name}", "", suite.description, ""]
    for script, values in figures.items():
        summary = summaries[script]
        lines += [f"## {script}", "", *([summary, ""] if summary else []), "| figure | value |", "|---|---|"]
        lines += [f"| {path} | {value} |" for path, value in _leaves(values)]
        lines.append("")
    text = "\n".join(lines)
    with atomic_write(out / "speed.md") as tmp:
        Path(tmp).write_text(text)
    return text


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.generic, torch.Tensor)):
        return value.item() if value.ndim == 0 else value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _jsonable(dataclasses.asdict(value))
    return value


def _leaves(value: Any, prefix: str = "") -> Iterable[tuple[str, Any]]:
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{prefix}/{key}" if prefix else str(key))
    else:
        yield prefix, (f"{value:.6g}" if isinstance(value, float) else value)


def known_names() -> dict[str, tuple[str, ...]]:
    """The installed registries, for checking ``--scenes``, ``--strategies``, ``--denoisers``."""
    import denoisers
    import renderers
    from bnerr import strategies

    return {
        "known_scenes": tuple(renderers.SCENES),
        "known_strategies": tuple(strategies.STRATEGIES),
        "known_denoisers": tuple(denoisers.DENOISERS),
    }
