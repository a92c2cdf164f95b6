"""Planning a suite: its sweeps become runs (what is rendered together) and cells (table rows).

A **cell** (:class:`Cell`) is one row of the results table: scene x strategy x spp x denoiser x
motion/depth/sampler condition x pixel region, with the measurement's sizes. A **run**
(:class:`Run`) is everything rendered together: one strategy on one scene, spp and condition, all
seed sets; its cells share its renders and differ only in denoiser and pixel region. :func:`plan`
turns a :class:`benchmarks.suites.Suite` into its runs, merging runs that two sweeps both ask for;
:func:`pending` narrows them to the cells not yet measured.

Not for: rendering or measuring (:mod:`benchmarks.sweep.measure`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Collection, Sequence
from dataclasses import dataclass

from benchmarks.suites import Suite, Sweep

__all__ = ["ALWAYS_REGION", "Cell", "Run", "RunSpec", "pending", "plan"]

#: The region every run of a suite with ``coherent=True`` (every named suite) measures besides its
#: sweep's: the spatio-temporally coherent pixels (:func:`bnerr.metrics.coherent_mask`), where the
#: seed paper says the temporal method works. Its cells come after the sweep's regions', so the
#: tables of the others keep their rows.
ALWAYS_REGION = "coherent"


@dataclass(frozen=True)
class RunSpec:
    """What a run renders and how it is measured: the fields a run and each of its cells share,
    declared once here (see :mod:`benchmarks.suites` for the axes). :class:`Cell` and
    :class:`Run` inherit them, :meth:`Run.cells` copies them by :func:`dataclasses.fields`, and
    ``table.csv`` takes its cell columns from them (:mod:`benchmarks.reports.table`)."""

    scene: str
    strategy: str
    spp: int
    motion: int
    depth: int | None
    sampler: str
    width: int
    height: int
    frames: int
    warmup: int
    seed_sets: int
    reference_spp: int


@dataclass(frozen=True)
class Cell(RunSpec):
    """One row of the results table: a run's fields, one of its denoisers and one of its pixel
    regions."""

    denoiser: str
    region: str

    def key(self) -> str:
        """A stable string identifying the cell in the results file (its fields as sorted JSON)."""
        return json.dumps(dataclasses.asdict(self), sort_keys=True)


@dataclass(frozen=True)
class Run(RunSpec):
    """Everything rendered together: one strategy on one scene/spp/condition, all seed sets.

    The cells of a run share its renders and differ only in denoiser and pixel region.
    """

    denoisers: tuple[str, ...]
    regions: tuple[str, ...]
    metrics: tuple[str, ...]
    crops: bool
    #: Metrics the coherent region leaves out (``Suite.coherent_skips``): :meth:`metrics_of`.
    coherent_skips: tuple[str, ...] = ()
    #: The seed-set counts of the group-sequential design the run's seed sets are added under
    #: (``bnerr bench --until-resolved``, :mod:`benchmarks.sweep.adaptive`); empty for a fixed
    #: number. Recorded with its cells (``Record.looks``), not part of their key.
    looks: tuple[int, ...] = ()
    #: Seed sets ``0 .. reuse - 1`` come from the cells' records at the previous look (that
    #: look's seed-set count) and are not measured again (:mod:`benchmarks.sweep.reuse`); 0:
    #: every seed set is measured. Set by the runner on the runs it measures, not by a plan.
    reuse: int = 0

    @property
    def groups(self) -> range:
        """The seed sets the run measures: ``reuse .. seed_sets - 1``."""
        return range(self.reuse, self.seed_sets)

    def metrics_of(self, region: str) -> tuple[str, ...]:
        """The metrics a region's cells measure: the run's, less ``coherent_skips`` in the
        coherent region."""
        if region != ALWAYS_REGION:
            return self.metrics
        return tuple(m for m in self.metrics if m not in self.coherent_skips)

    def cells(self) -> list[Cell]:
        """Its cells: every denoiser x region, in that order."""
        shared = {f.name: getattr(self, f.name) for f in dataclasses.fields(RunSpec)}
        return [Cell(denoiser=d, region=r, **shared) for d in self.denoisers for r in self.regions]

    @property
    def label(self) -> str:
        """A short description for the progress bar."""
        extra = (
            (f" motion={self.motion}" if self.motion != 1 else "")
            + (f" depth={self.depth}" if self.depth is not None else "")
            + (f" sampler={self.sampler}" if self.sampler != "owen_sobol" else "")
        )
        return f"{self.scene} {self.strategy} {self.spp}spp{extra}"


def _sweep_runs(suite: Suite, sweep: Sweep) -> list[Run]:
    crops, coherent, every_spp = suite.crops, suite.coherent, suite.crops_every_spp
    renders: dict[tuple[int, int | None, str], list[str]] = {}
    for cond in sweep.conditions:
        regions = renders.setdefault((cond.motion, cond.depth, cond.sampler), [])
        if cond.region not in regions:
            regions.append(cond.region)
    for regions in renders.values():  # the coherent pixels too: the renders are shared
        if coherent and ALWAYS_REGION not in regions:
            regions.append(ALWAYS_REGION)
    runs = []
    for scene in sweep.scenes:
        for (motion, depth, sampler), regions in renders.items():
            for spp in sweep.spp:
                for strategy in sweep.strategies:
                    runs.append(
                        Run(
                            scene=scene,
                            strategy=strategy,
                            spp=spp,
                            motion=motion,
                            depth=depth,
                            sampler=sampler,
                            frames=sweep.frames,
                            warmup=sweep.warmup,
                            width=sweep.res[0],
                            height=sweep.res[1],
                            seed_sets=sweep.seed_sets,
                            reference_spp=sweep.reference_spp,
                            denoisers=sweep.denoisers,
                            regions=tuple(regions),
                            metrics=sweep.metrics,
                            crops=crops and (every_spp or spp == min(sweep.spp)),
                            coherent_skips=suite.coherent_skips,
                        )
                    )
    return runs


def plan(suite: Suite) -> list[Run]:
    """The runs of a suite, in order, with duplicate runs (same renders) merged."""
    merged: dict[tuple, Run] = {}
    for sweep in suite.sweeps:
        for run in _sweep_runs(suite, sweep):
            bare = dataclasses.replace(run, denoisers=(), regions=(), crops=False)
            key = dataclasses.astuple(bare)
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


def pending(suite: Suite, done: Collection[str], runs: Sequence[Run] | None = None) -> list[Run]:
    """The runs (``runs``, by default :func:`plan`'s) with cells whose key is not in ``done``,
    narrowed to their missing denoisers and regions (a run is rendered again for those only)."""
    todo = []
    for run in plan(suite) if runs is None else runs:
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
