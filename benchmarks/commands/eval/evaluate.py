"""``bnerr eval``: measure frames rendered anywhere, exactly as ``bnerr bench`` measures its own.

A frame folder (:mod:`benchmarks.commands.eval.frame_folder`, docs/EVAL.md) holds, per method and
seed set, the noisy frames a renderer wrote, and the references. :func:`evaluate` turns each method
into a :class:`benchmarks.sweep.plan.Run` (one scene, spp and condition, every seed set) and
measures it with the sweep's own code (:func:`benchmarks.sweep.measure.measure_run`: every metric of
the metric table raw and after each denoiser, the blurred-error ratios, the spectra, the coherent
region where the buffers allow it, the crops), through parts that read instead of render:

- the **strategy** of a method and seed set is a stand-in whose ``frame(t, render)`` reads frame
  ``t`` from the folder (:class:`FolderStrategy`); the renderer is never called. The frames were
  rendered with whatever state the method carries, so the stand-in is stateless: only the
  measured frames are read, unless a stateful denoiser must see the warmup frames in order;
- the **references** come from ``DIR/reference`` (:class:`FolderReferences`);
- the **denoisers** (shipped or plug-in specs) are tuned as the sweep tunes them
  (:func:`benchmarks.sweep.tuning.tune_denoisers`, on white's held-out seed set, ``NAME:own`` on
  the method's own) when the manifest names a ``tuning_seed_set``; without one they keep their
  default parameters.

The records are the sweep's :class:`~benchmarks.sweep.records.Record` (with each plug-in's
identity), so ``cells.jsonl`` and the tables, charts and page
(:func:`benchmarks.reports.write_report`) are those of ``bnerr bench``; for the same frames and
references the metrics are the same, bit for bit.

Not for: rendering (``bnerr bench``), or reading the folder
(:mod:`benchmarks.commands.eval.frame_folder`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from benchmarks.commands.eval.frame_folder import FrameFolder, Manifest, check_folder
from benchmarks.sweep.measure import measure_run
from benchmarks.sweep.parts import Denoiser, Parts, Scene, real_parts
from benchmarks.sweep.plan import Run
from benchmarks.sweep.plugins import with_plugins
from benchmarks.sweep.records import Record, write_records
from benchmarks.sweep.tuning import (
    TUNING_SEED_SET,
    make_denoisers,
    split_own,
    tune_denoisers,
)
from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from bnerr.metrics import METRIC_TABLE
from bnerr.strategies import Strategy
from denoisers.tuning import ParamStore

__all__ = [
    "FolderReferences",
    "FolderScene",
    "FolderStrategy",
    "Evaluation",
    "default_metrics",
    "evaluate",
    "folder_parts",
    "folder_runs",
    "measure_evaluation",
    "plan_evaluation",
]

#: The tuning seed sets' frames: as many as the sweep tunes on (tuning.tune_missing).
_TUNING_FRAMES = 4


def default_metrics() -> tuple[str, ...]:
    """The metric table's default metrics (every shipped one but ``flip``), in table order."""
    return tuple(name for name, metric in dict(METRIC_TABLE).items() if metric.default)


@dataclass(frozen=True)
class FolderScene:
    """The scene as measuring reads it: its sampler dimensions (the manifest's, 0 if unknown)."""

    dimensions: int


@dataclass
class FolderStrategy:
    """A method's seed set read back from the folder: ``frame(t, render)`` reads frame ``t`` and
    never renders (see the module docstring)."""

    folder: FrameFolder
    method: str
    seed_set: str
    sampler_name: str
    overhead_ms: float = 0.0
    stateful: bool = False

    def frame(self, t: int, render: Callable[..., Frame]) -> Frame:
        return self.folder.frame(self.method, self.seed_set, t)


class FolderReferences:
    """The folder's references, read once each (``get(run, scene, t_render)`` of
    :class:`benchmarks.sweep.measure.References`; a static folder's run asks for frame 0)."""

    def __init__(self, folder: FrameFolder) -> None:
        self.folder = folder
        self._frames: dict[int, Frame] = {}

    def get(self, run: Run, scene: Scene, t_render: int) -> Frame:
        if t_render not in self._frames:
            self._frames[t_render] = self.folder.reference(t_render)
        return self._frames[t_render]


def _no_render(*args: Any, **kwargs: Any) -> Frame:
    raise ValueRangeError("bnerr eval: expected frames read from the folder, got a render call")


def folder_parts(folder: FrameFolder, specs: Sequence[tuple[str, str]] = ()) -> Parts:
    """The sweep's parts over ``folder``: the project's denoisers (with the plug-ins of
    ``specs``), strategies that read the folder's frames, no renderer.

    A strategy's seed ``group`` is the manifest's ``group``-th seed set;
    :data:`~benchmarks.sweep.tuning.TUNING_SEED_SET` is its ``tuning_seed_set``.
    """
    m = folder.manifest

    def make_strategy(
        name: str, scene: Scene, height: int, width: int, seed: int, sampler: str, spp: int
    ) -> FolderStrategy:
        if seed == TUNING_SEED_SET and m.tuning_seed_set is not None:
            return FolderStrategy(folder, name, m.tuning_seed_set, sampler)
        if not 0 <= seed < len(m.seed_sets):
            raise ValueRangeError(
                f"bnerr eval: expected a seed set in [0, {len(m.seed_sets)}), got {seed}"
            )
        return FolderStrategy(folder, name, m.seed_sets[seed], sampler)

    return dataclasses.replace(
        real_parts(tuple(specs)),
        get_scene=lambda name, animated: FolderScene(m.dimensions),
        render=_no_render,
        # a FolderStrategy plays a Strategy's part: what the measuring reads of one (frame,
        # stateful, sampler_name, overhead_ms) and nothing else
        make_strategy=cast(Callable[..., Strategy], make_strategy),
        with_depth=lambda scene, depth: scene,
        code_version=folder.fingerprint(),
        render_batch=None,
    )


def folder_runs(m: Manifest, denoisers: Sequence[str], metrics: Sequence[str]) -> list[Run]:
    """One run per method, white first: the manifest's scene, spp, resolution, frames and seed
    sets, ``denoisers`` x the manifest's regions."""
    methods = ["white", *(k for k in m.methods if k != "white")]
    return [
        Run(
            scene=m.scene,
            strategy=method,
            spp=m.spp,
            motion=0 if m.static else 1,
            depth=None,
            sampler=m.sampler,
            width=m.width,
            height=m.height,
            frames=m.frames,
            warmup=m.warmup,
            seed_sets=len(m.seed_sets),
            reference_spp=m.reference_spp,
            denoisers=tuple(denoisers),
            regions=m.regions,
            metrics=tuple(metrics),
            crops=True,
        )
        for method in methods
    ]


def _any_stateful(parts: Parts, denoisers: Sequence[str]) -> bool:
    built = (parts.make_denoiser(split_own(name)[0], None) for name in denoisers)
    return any(bool(getattr(d, "stateful", False)) for d in built)


def _check_files(folder: FrameFolder, runs: list[Run], stateful: bool) -> None:
    """Every file the runs will read, before anything is written (:func:`check_folder`): the
    measured frames (from frame 0 with a stateful denoiser), the references, and the tuning seed
    sets' frames; their headers first, then their pixels."""
    m = folder.manifest
    first = 0 if stateful else m.warmup
    methods = {run.strategy: list(m.seed_sets) for run in runs}
    tuned: dict[str, list[str]] = {}
    times = range(m.warmup, m.warmup + min(m.frames, _TUNING_FRAMES))
    if m.tuning_seed_set is not None:
        own = [run.strategy for run in runs if any(split_own(d)[1] for d in run.denoisers)]
        tuned = {k: [m.tuning_seed_set] for k in ["white", *own]}
    for pixels in (False, True):  # every header before any pixel: the cheap refusals first
        check_folder(folder, methods, range(first, m.warmup + m.frames), pixels=pixels)
        if tuned:
            check_folder(folder, tuned, times, pixels=pixels)


def _denoisers(
    run: Run, parts: Parts, references: FolderReferences, store: ParamStore, tuned: bool
) -> dict[str, Denoiser]:
    if tuned:
        return tune_denoisers(run, parts, references, store)
    own = [name for name in run.denoisers if split_own(name)[1]]
    if own:
        raise ValueRangeError(
            f"bnerr eval: {', '.join(own)}: expected a tuning_seed_set in the manifest to tune "
            "on the method's own frames, got none"
        )
    return make_denoisers(parts, dict.fromkeys(run.denoisers))


@dataclass(frozen=True)
class Evaluation:
    """A frame folder checked and ready to measure (:func:`plan_evaluation`): nothing written yet.

    Attributes:
        folder: the frame folder.
        runs: one run per method, white first (:func:`folder_runs`).
        parts: the sweep's parts over the folder (:func:`folder_parts`).
        notes: what the user is told (one seed set, no tuning seed set).
    """

    folder: FrameFolder
    runs: tuple[Run, ...]
    parts: Parts
    notes: tuple[str, ...]


def plan_evaluation(
    root: str | Path | FrameFolder,
    *,
    denoisers: Sequence[str] = ("gaussian",),
    metrics: Sequence[str] | None = None,
    specs: Sequence[tuple[str, str]] = (),
) -> Evaluation:
    """Check the frame folder ``root`` for a measurement with these denoisers and metrics (as in
    :func:`evaluate`), every file it will read to its last pixel, and write nothing.

    Raises:
        FileFormatError, ShapeError, NonFiniteError, UnknownNameError, ValueRangeError: the
            folder's (see :mod:`benchmarks.commands.eval.frame_folder`).
    """
    folder = root if isinstance(root, FrameFolder) else FrameFolder(root)
    m = folder.manifest
    runs = folder_runs(m, denoisers, metrics or default_metrics())
    parts = folder_parts(folder, specs)
    _check_files(folder, runs, _any_stateful(parts, denoisers))
    notes = []
    if len(m.seed_sets) < 2:
        notes.append("one seed set: the intervals over seed sets need two (none are given)")
    if m.tuning_seed_set is None:
        notes.append("no tuning_seed_set in the manifest: the denoisers keep their defaults")
    return Evaluation(folder, tuple(runs), parts, tuple(notes))


def measure_evaluation(
    plan: Evaluation, out: str | Path, on_run: Callable[[Run], None] | None = None
) -> list[Record]:
    """Measure a checked folder (:func:`plan_evaluation`) into ``<out>/cells.jsonl`` and
    ``<out>/crops``; return the records."""
    m = plan.folder.manifest
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    references, store = FolderReferences(plan.folder), ParamStore()
    records: list[Record] = []
    for run in plan.runs:
        if on_run is not None:
            on_run(run)
        chosen = _denoisers(run, plan.parts, references, store, m.tuning_seed_set is not None)
        measured = measure_run(run, plan.parts, references, chosen, crops_dir=out / "crops")
        records.extend(with_plugins(r).rounded() for r in measured)  # as bnerr bench keeps them
    write_records(out, records)
    return records


def evaluate(
    root: str | Path | FrameFolder,
    out: str | Path,
    *,
    denoisers: Sequence[str] = ("gaussian",),
    metrics: Sequence[str] | None = None,
    specs: Sequence[tuple[str, str]] = (),
    on_run: Callable[[Run], None] | None = None,
) -> tuple[list[Record], list[str]]:
    """Measure every method of the frame folder ``root`` and write ``<out>/cells.jsonl`` (and the
    crops); return the records and the notes for the user (:func:`plan_evaluation`, then
    :func:`measure_evaluation`).

    Args:
        root: the frame folder (``DIR``), or it read already.
        out: the output folder (created).
        denoisers: registered names (``NAME:own`` too) of the denoisers to run on every frame.
        metrics: the metric names (default: :func:`default_metrics`).
        specs: the plug-in specs behind those names, ``(group, spec)`` pairs.
        on_run: told each run before it is measured (the command's progress line).

    Raises:
        FileFormatError, ShapeError, NonFiniteError, UnknownNameError, ValueRangeError: the
            folder's (see :mod:`benchmarks.commands.eval.frame_folder`), before anything is written.
    """
    plan = plan_evaluation(root, denoisers=denoisers, metrics=metrics, specs=specs)
    return measure_evaluation(plan, out, on_run), list(plan.notes)
