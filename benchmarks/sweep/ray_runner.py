"""The sweep behind ``bnerr bench --ray``: the serial runner's work as Ray tasks, on one machine or
a cluster.

The unit of work is the serial runner's: one seed set of a run (scene, strategy, spp, condition,
seed set), computed by :func:`benchmarks.sweep.measure.measure_seed_set` in a Ray task and merged by
:func:`benchmarks.sweep.measure.finish_run` on the driver once every seed set of the run is back, so
the records are the serial runner's bit for bit (timings aside). Three kinds of task:

- **references**: one task per distinct reference (scene, condition, frame, resolution, spp; the
  cache file name, :meth:`benchmarks.sweep.references.ReferenceCache.path`), so no two tasks render
  the same reference. The task reads the cache folder if the file is there (a resumed sweep, shared
  storage) and writes it otherwise (atomically); the frame itself travels to the tasks that need
  it through the object store, so nodes need not share the cache folder.
- **tuning**: one task per (scene, condition, resolution, spp, frames' strategy) whose
  denoisers are not in ``tuned_params.json`` yet (:func:`benchmarks.sweep.tuning.tune_missing`, the
  tuning seed set; white noise for the fair column, the run's strategy for ``NAME:own``). The
  driver stores the parameters and saves the file when it returns, and only then
  submits the measuring tasks that need them.
- **measuring**: one task per seed set of each pending run.

As in the serial runner, each run's lines are appended to ``cells.jsonl`` when its last seed set
comes back (the first write replaces the file atomically), and the sweep ends with the file in
plan order whatever the order runs finished in (:class:`benchmarks.sweep.runner.SweepState`); an
interrupted sweep (Ctrl-C, a failed task, a lost node) loses the runs in progress, and ``--resume``
measures only the missing cells. A failed task cancels the others and its error is raised on the
driver. Every task checks that its node runs the driver's renderer and sampler code
(:func:`benchmarks.sweep.version.code_version`) and refuses otherwise. Each task sets
torch's threads to the CPUs Ray gave it (``cpus_per_task``). The progress bar counts finished
tasks.

Not for: choosing what to measure (:mod:`benchmarks.sweep.plan`), or the speed suite.
"""

from __future__ import annotations

import functools
import socket
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import torch
from tqdm import tqdm

from benchmarks.suites import Suite
from benchmarks.sweep.measure import (
    SeedSetResult,
    finish_run,
    measure_seed_set,
    scene_for,
    t_reference,
)
from benchmarks.sweep.parts import Parts
from benchmarks.sweep.plan import Run
from benchmarks.sweep.records import Record
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.runner import SweepState, start_sweep
from benchmarks.sweep.tuning import (
    make_denoisers,
    missing_tuning,
    store_tuned,
    tune_missing,
    tuned_params,
    tuning_key,
)
from benchmarks.sweep.version import code_version
from bnerr.errors import BnerrError, MissingExtraError, ValueRangeError, check_positive_int
from bnerr.frame import Frame

__all__ = [
    "CodeVersionError",
    "WorkerLostError",
    "require_ray",
    "run_suite_ray",
]


def require_ray() -> ModuleType:
    """Import ``ray``, or raise :class:`~bnerr.errors.MissingExtraError` naming its install."""
    try:
        import ray  # the optional cluster extra: a missing one is this typed error
    except ImportError as err:
        raise MissingExtraError("--ray", "cluster", "ray", f"{type(err).__name__}: {err}") from None
    return ray


# --------------------------------------------------------------------------------------------------
# Tasks (plain functions: the scheduler wraps them with ray.remote)


def _use_task_cpus() -> None:
    """Set torch's intra-op threads to the CPUs Ray assigned to the running task (at least 1)."""
    import ray  # runs inside a Ray task: the extra is there

    cpus = ray.get_runtime_context().get_assigned_resources().get("CPU", 1.0)
    torch.set_num_threads(max(1, int(cpus)))


@functools.lru_cache(maxsize=1)
def _node_code_version() -> str:
    return code_version()


class CodeVersionError(BnerrError, ValueError):
    """A node runs other renderer or sampler code than the driver."""


def _task_setup(expected_version: str) -> None:
    """Torch threads from the task's CPUs; refuse a node whose renderer or sampler code differs
    from the driver's (its references and frames would not be the driver's)."""
    _use_task_cpus()
    here = _node_code_version()
    if here != expected_version:
        raise CodeVersionError(
            f"node {socket.gethostname()}: expected the driver's code version "
            f"{expected_version}, got {here}; install the same bnerr commit on every node"
        )


class _GivenReferences:
    """The references a task was handed, by renderer frame (``get`` as ReferenceCache's)."""

    def __init__(self, t_refs: list[int], frames: tuple[Frame, ...]) -> None:
        self.frames = dict(zip(t_refs, frames, strict=True))

    def get(self, run: Run, scene: Any, t_render: int) -> Frame:
        return self.frames[t_render]


def _reference_task(run: Run, parts: Parts, cache_root: str, t_ref: int, version: str) -> Frame:
    """Read or render (and cache) ``run``'s reference at renderer frame ``t_ref``."""
    _task_setup(version)
    # a node that cannot write the cache warns and goes on: the object store carries the frame
    return ReferenceCache(cache_root, parts).get(run, scene_for(run, parts), t_ref)


def _tune_task(
    run: Run,
    parts: Parts,
    version: str,
    names: list[str],
    source: str,
    t_refs: list[int],
    *frames: Frame,
) -> dict[str, Any]:
    """:func:`benchmarks.sweep.tuning.tune_missing` against the references handed in."""
    _task_setup(version)
    return tune_missing(run, parts, _GivenReferences(t_refs, frames), names, source)


def _measure_task(
    run: Run,
    group: int,
    parts: Parts,
    version: str,
    params: dict[str, dict | None],
    t_refs: list[int],
    *frames: Frame,
) -> SeedSetResult:
    """:func:`benchmarks.sweep.measure.measure_seed_set` with denoisers built from ``params``."""
    _task_setup(version)
    denoisers = make_denoisers(parts, params)
    return measure_seed_set(run, parts, _GivenReferences(t_refs, frames), denoisers, group)


# --------------------------------------------------------------------------------------------------
# The driver


def _measured_refs(run: Run, count: int | None = None) -> list[int]:
    """The renderer frames of the references of ``run``'s measured frames (the first ``count``),
    without repeats (a static scene has one)."""
    frames = range(run.warmup, run.warmup + (run.frames if count is None else count))
    return list(dict.fromkeys(t_reference(run, t) for t in frames))


def _measure_refs(run: Run) -> list[int]:
    """The references a measuring task needs: the measured frames', and with a moving camera
    and the coherent region the one before them (its disocclusion test)."""
    before = [t_reference(run, run.warmup - 1)] if "coherent" in run.regions and run.motion else []
    return list(dict.fromkeys(before + _measured_refs(run)))


#: A tuning task: (tuning key, spp, the strategy whose frames it tunes on).
_TuneKey = tuple[str, int, str]


@dataclass
class _Job:
    """A task in flight: its kind and what the driver does when it returns."""

    kind: str  # "reference", "tune" or "measure"
    run: Run | None = None
    tkey: _TuneKey | None = None


class _Scheduler:
    """Submits the tasks of a sweep and handles them as they finish."""

    def __init__(self, ray: ModuleType, sweep: SweepState, cache_root: str, cpus: int) -> None:
        self.ray, self.sweep, self.cache_root = ray, sweep, cache_root
        options = dict(num_cpus=cpus, max_retries=0)
        self.reference_fn = ray.remote(**options)(_reference_task)
        self.tune_fn = ray.remote(**options)(_tune_task)
        self.measure_fn = ray.remote(**options)(_measure_task)
        self.parts_ref = ray.put(sweep.parts)
        self.version = _node_code_version()  # the driver's; every task checks its node's
        self.naming = ReferenceCache(cache_root, sweep.parts)
        self.references: dict[str, Any] = {}
        self.inflight: dict[Any, _Job] = {}
        self.waiting: dict[_TuneKey, list[Run]] = defaultdict(list)
        self.blocked: dict[Run, int] = {}  # run -> tunings it still waits for
        self.results: dict[Run, list[SeedSetResult]] = defaultdict(list)

    def _references(self, run: Run, t_refs: list[int]) -> list[Any]:
        """The object refs of ``run``'s references at ``t_refs``, submitting each once."""
        refs = []
        for t_ref in t_refs:
            name = str(self.naming.path(run, t_ref))
            if name not in self.references:
                ref = self.reference_fn.remote(
                    run, self.parts_ref, self.cache_root, t_ref, self.version
                )
                self.references[name] = ref
                self.inflight[ref] = _Job("reference")
            refs.append(self.references[name])
        return refs

    def submit_all(self) -> None:
        """Tuning tasks for the parameters not stored yet (one per scene, condition, spp and
        frames' strategy); measuring tasks for the runs that need none."""
        names: dict[_TuneKey, list[str]] = {}
        first: dict[_TuneKey, Run] = {}
        for run in self.sweep.todo:
            missing = missing_tuning(run, self.sweep.store)
            self.blocked[run] = len(missing)
            for source, missing_names in missing.items():
                tkey = (tuning_key(run), run.spp, source)
                have = names.setdefault(tkey, [])
                have.extend(n for n in missing_names if n not in have)
                first.setdefault(tkey, run)
                self.waiting[tkey].append(run)
            if not missing:
                self._submit_measures(run)
        for tkey, tune_names in names.items():
            run = first[tkey]
            t_refs = _measured_refs(run, min(run.frames, 4))
            frames = self._references(run, t_refs)
            ref = self.tune_fn.remote(
                run, self.parts_ref, self.version, tune_names, tkey[2], t_refs, *frames
            )
            self.inflight[ref] = _Job("tune", run=run, tkey=tkey)

    def _submit_measures(self, run: Run) -> None:
        params = tuned_params(run, self.sweep.store)
        t_refs = _measure_refs(run)
        frames = self._references(run, t_refs)
        for group in run.groups:
            ref = self.measure_fn.remote(
                run, group, self.parts_ref, self.version, params, t_refs, *frames
            )
            self.inflight[ref] = _Job("measure", run=run)

    def handle(self, ref: Any) -> None:
        """Act on a finished task (raises its error if it failed)."""
        job = self.inflight.pop(ref)
        if job.kind == "reference":
            return  # a failed reference fails the tasks that need it
        value = self.ray.get(ref)
        if job.kind == "tune":
            assert job.run is not None and job.tkey is not None  # a tuning carries both
            store_tuned(job.run, self.sweep.store, value, job.tkey[2])
            self.sweep.save_params()
            for run in self.waiting.pop(job.tkey):
                self.blocked[run] -= 1
                if not self.blocked[run]:
                    self._submit_measures(run)
            return
        measured = job.run
        assert measured is not None  # a measure job carries its run
        done = self.results[measured]
        done.append(value)
        if len(done) == len(measured.groups):
            del self.results[measured]
            crops = self.sweep.out / "crops"
            version, merge = self.sweep.parts.code_version, self.sweep.resumed
            self.sweep.add(
                finish_run(
                    measured, done, version, crops, merge_crops=merge, kept=self.sweep.records
                )
            )

    def cancel(self) -> None:
        for ref in list(self.inflight):
            try:
                self.ray.cancel(ref)
            except Exception:  # a task that just finished cannot be cancelled
                pass
        self.inflight.clear()


def _task_count(sweep: SweepState) -> int:
    """Every task the sweep will run: references, tunings and seed sets (for the progress bar)."""
    naming = ReferenceCache(None, sweep.parts)
    refs: set[Path] = set()
    tunings: set[_TuneKey] = set()
    for run in sweep.todo:
        refs.update(naming.path(run, t) for t in _measure_refs(run))
        for source in missing_tuning(run, sweep.store):
            tunings.add((tuning_key(run), run.spp, source))
    return len(refs) + len(tunings) + sum(len(r.groups) for r in sweep.todo)


def _connect(ray: ModuleType, address: str) -> bool:
    """Join ``address`` (``auto``: the cluster this machine belongs to, else a new local
    instance) unless Ray is already initialised; return whether this call started it."""
    if ray.is_initialized():
        return False
    ray.init(address=None if address == "auto" else address, include_dashboard=False)
    return True


class WorkerLostError(BnerrError, RuntimeError):
    """A Ray worker or node died under a task (killed, out of memory, a lost machine)."""


def _handle(ray: ModuleType, scheduler: _Scheduler, ref: Any) -> None:
    """``scheduler.handle(ref)``; a task's error of our own kind (bad input, a file) is raised as
    itself (one line on the command line), a dead worker as :class:`WorkerLostError`, any other
    with the task's traceback."""
    kind = scheduler.inflight[ref].kind
    try:
        scheduler.handle(ref)
    except ray.exceptions.RayTaskError as err:
        cause = getattr(err, "cause", None)
        if isinstance(cause, BnerrError):
            raise cause from None
        raise
    except ray.exceptions.RayError as err:  # the task never returned: its worker is gone
        reason = str(err).strip().splitlines()[0] if str(err).strip() else ""
        raise WorkerLostError(
            f"expected every Ray task to finish, got a {kind} task's worker lost "
            f"({type(err).__name__}: {reason[:200]}); the {len(scheduler.sweep.written or [])} "
            f"cells written to {scheduler.sweep.out} are kept: rerun with --resume"
        ) from None


def _drain(ray: ModuleType, scheduler: _Scheduler, *, progress: bool) -> None:
    """Submit the sweep's tasks and handle each as it finishes (:func:`_handle`, which submits
    what it unblocks) until none is in flight, with a progress bar over every task."""
    total = _task_count(scheduler.sweep)
    with tqdm(total=total, unit="task", disable=not progress, dynamic_ncols=True) as bar:
        scheduler.submit_all()
        while scheduler.inflight:
            ready, _ = ray.wait(list(scheduler.inflight), num_returns=1, fetch_local=False)
            for ref in ready:
                _handle(ray, scheduler, ref)
                bar.update(1)


def run_suite_ray(
    suite: Suite,
    out_dir: str | Path,
    *,
    address: str = "auto",
    parts: Parts | None = None,
    cache_dir: str | Path = "cache/references",
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = True,
    cpus_per_task: int = 1,
    runs: Sequence[Run] | None = None,
) -> list[Record]:
    """:func:`benchmarks.sweep.runner.run_suite` with every seed set of every run a Ray task.

    Args:
        address: the Ray cluster: ``auto`` (the one ``ray start`` made on this machine, or
            ``RAY_ADDRESS``; else a new local instance), ``local`` (a new local instance) or
            ``HOST:PORT`` of a head node. Ignored when Ray is already initialised.
        cpus_per_task: CPUs each task asks Ray for, and torch's threads inside it.
        suite, out_dir, parts, cache_dir, resume, overwrite, progress, runs: as ``run_suite``.

    Raises:
        MissingExtraError: ray is not installed.
        ValueRangeError: ``parts.device`` is not the CPU (the tasks ask Ray for CPUs only; a
            CUDA sweep runs serially, ``bnerr bench --device cuda`` without ``--ray``).
        ResultsExistError, FileFormatError: as ``run_suite``.
        WorkerLostError: a worker died under a task (killed, out of memory, a lost node); the
            finished runs' cells are kept for ``--resume``.
        Any error of a task, on the driver, after the others are cancelled.
    """
    if parts is not None and parts.device != "cpu":
        raise ValueRangeError(
            f"run_suite_ray: expected parts on the CPU (its tasks ask Ray for CPUs only), got "
            f"device {parts.device}; run a CUDA sweep serially (run_suite)"
        )
    ray = require_ray()
    cpus = check_positive_int(cpus_per_task, "cpus_per_task")
    sweep = start_sweep(suite, out_dir, parts, resume=resume, overwrite=overwrite, runs=runs)
    if not sweep.todo:
        sweep.write()
        return sweep.ordered()
    sweep.save_params()
    started = _connect(ray, address)
    scheduler = _Scheduler(ray, sweep, str(Path(cache_dir).resolve()), cpus)
    try:
        _drain(ray, scheduler, progress=progress)
    finally:
        scheduler.cancel()
        if started:
            ray.shutdown()
    sweep.finish()
    return sweep.ordered()
