"""The sweep behind ``bnerr bench``: measure every cell of a suite and keep the results file.

:func:`run_suite` plans the suite (:mod:`benchmarks.sweep.plan`), skips the cells already in the
output folder when resuming, tunes the denoisers once per scene, condition and spp on white noise
(:func:`benchmarks.sweep.tuning.tune_denoisers`, saved in ``<out>/tuned_params.json``), measures
each pending run (:func:`benchmarks.sweep.measure.measure_run`) against cached references
(:mod:`benchmarks.sweep.references`), and writes ``<out>/cells.jsonl`` after every run
(:mod:`benchmarks.sweep.records`: whole and atomically the first time, then each run's lines
appended), so an interrupted sweep loses at most the run in progress.

The unit of work is one seed set of a run (:func:`benchmarks.sweep.measure.measure_seed_set`); the
serial loop here and the Ray tasks of :mod:`benchmarks.sweep.ray_runner` both compute it and merge a
run's seed sets the same way, so their records are the same bit for bit (timings aside); both
start from :func:`start_sweep` and write through :meth:`SweepState.add`.

The parts (scenes, renderer, strategies, denoisers) come through
:class:`benchmarks.sweep.parts.Parts`, so the runner can be tested with stand-ins. One writer per
output folder is the caller's job (``bnerr bench`` holds :func:`bnerr.outputs.output_lock` on
``--out`` for the whole run).

Not for: the speed suite (:mod:`benchmarks.speed`) or the tables and charts
(:mod:`benchmarks.reports`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import torch
from tqdm import tqdm

from benchmarks.suites import Suite
from benchmarks.sweep.measure import measure_run
from benchmarks.sweep.parts import Parts, real_parts
from benchmarks.sweep.plan import Run, pending, plan
from benchmarks.sweep.plugins import check_resume, load_specs, with_plugins
from benchmarks.sweep.records import (
    RESULTS_FILE,
    Record,
    append_records,
    bare_key,
    check_no_results,
    load_records,
    write_records,
)
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.reuse import with_reuse
from benchmarks.sweep.tuning import TuningStore, store_key, tune_denoisers
from benchmarks.sweep.version import device_info
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.outputs import clean_stale_temporaries
from denoisers.tuning import ParamStore

__all__ = [
    "TUNED_PARAMS_FILE",
    "SweepState",
    "forget_cells",
    "load_params",
    "run_suite",
    "start_sweep",
]

#: Name of the tuned denoiser parameters file inside the output folder.
TUNED_PARAMS_FILE = "tuned_params.json"


@dataclass
class SweepState:
    """A sweep in progress: its output folder, parts, records, tuned parameters and pending runs.

    Records are written in one order whatever the order runs finish in, and whatever a resumed
    sweep kept: the kept records of cells outside the suite's plan first (in file order), then
    every planned cell in plan order. The first write replaces the file atomically (so a fresh
    run keeps the old file until a run has finished); later ones append the run's lines, and
    :meth:`finish` rewrites the file once if runs finished out of plan order (Ray, or a resumed
    Ray sweep whose first pass finished them so), so the file ends as an uninterrupted serial
    run leaves it.
    """

    out: Path
    parts: Parts
    records: dict[str, Record]
    store: TuningStore
    todo: list[Run]
    order: list[str] = field(default_factory=list)
    written: list[str] | None = None  # the keys in the file, in file order; None: not written yet
    resumed: bool = False  # a resumed run's crops join the crop file it left (measure.finish_run)
    device: dict[str, str] | None = None  # what the records say of a device off the CPU

    @property
    def params_path(self) -> Path:
        return self.out / TUNED_PARAMS_FILE

    def save_params(self) -> None:
        self.store.save(self.params_path)

    def add(self, measured: list[Record]) -> None:
        """Keep a finished run's records and write them: appended to the file this sweep wrote,
        or the whole file the first time (and when a record replaces one already written)."""
        # at the precision a record keeps (Record.rounded), so the records in memory, and the
        # report a run writes from them, are the file's; with what identifies each plug-in used
        measured = [with_plugins(r).rounded() for r in measured]
        if self.device is not None:  # off the CPU: where they were measured, torch's version
            measured = [dataclasses.replace(r, device=self.device) for r in measured]
        fresh = [r for r in measured if r.key not in self.records]
        self.records.update((r.key, r) for r in measured)
        if self.written is None or len(fresh) != len(measured):
            self.write()
            return
        append_records(self.out, fresh)
        self.written.extend(r.key for r in fresh)

    def ordered(self) -> list[Record]:
        """The records: kept ones outside the plan first, then the planned cells in plan
        order."""
        rank = {key: i for i, key in enumerate(self.order)}
        keys = sorted(self.records, key=lambda k: rank.get(k, len(rank)))
        return [self.records[k] for k in keys]

    def write(self) -> None:
        """Replace the file atomically with every record, in :meth:`ordered` order."""
        records = self.ordered()
        write_records(self.out, records)
        self.written = [r.key for r in records]

    def finish(self) -> None:
        """End the sweep with the file in :meth:`ordered` order (rewritten only if it is not)."""
        if self.written != [r.key for r in self.ordered()]:
            self.write()


def load_params(path: Path) -> ParamStore:
    """The tuned parameters a resumed sweep keeps: ``path``'s, an empty store if there is no
    such file, and an empty one with a warning if it is not a valid tuned-parameters file (the
    denoisers are tuned again, deterministically, so the same parameters come back; the file is
    replaced atomically at the next save)."""
    if not path.exists():
        return ParamStore()
    try:
        return ParamStore.load(path)
    except FileFormatError as err:
        warnings.warn(f"{err}; the denoisers are tuned again", stacklevel=3)
        return ParamStore()


def forget_cells(out_dir: str | Path, runs: Sequence[Run], denoisers: Collection[str]) -> int:
    """Discard from ``out_dir``'s results the cells of ``runs`` whose denoiser is one of
    ``denoisers``, at every look, and those denoisers' tuned parameters for the runs' scenes,
    conditions and spp (so that they are tuned again), keeping every other cell; return how many
    cells went.

    What ``bnerr bench --remeasure`` does before it resumes: after a denoiser's code changed, its
    cells of the suite as given (``--scenes`` and the other overrides narrow it) are measured
    again, their runs rendered again for it alone, while every other cell stays as measured. The
    results file is rewritten atomically (plain, as a resumed run appends to it); a folder
    without results is left alone.

    Raises:
        FileFormatError: the folder's results file is not valid.
    """
    out = Path(out_dir)
    planned = {bare_key(c) for run in runs for c in run.cells() if c.denoiser in denoisers}
    records = load_records(out)
    kept = [r for r in records if bare_key(r.cell) not in planned]
    if len(kept) != len(records):
        write_records(out, kept)
    params = out / TUNED_PARAMS_FILE
    if params.exists():
        store = load_params(params)
        if _forget_params(store, runs, denoisers):
            store.save(params)
    return len(records) - len(kept)


def _forget_params(store: ParamStore, runs: Sequence[Run], denoisers: Collection[str]) -> bool:
    """Drop ``denoisers``' parameters for ``runs`` from ``store``; return whether any went."""
    gone = False
    for run in runs:
        for name in set(run.denoisers) & set(denoisers):
            by_key = store.entries.get(name, {})
            key, spp = store_key(run, name), str(run.spp)
            if spp not in by_key.get(key, {}):
                continue
            del by_key[key][spp]
            gone = True
            if not by_key[key]:  # no entries left empty in the file
                del by_key[key]
            if not by_key:
                del store.entries[name]
    return gone


def _warn_unmeasured(records: dict[str, Record], runs: Sequence[Run]) -> None:
    """Warn when ``--resume`` keeps cells that lack metrics their runs now measure (cells
    measured before a metric existed, such as the temporal ones): the reports show those
    metrics as not measured for them, and only ``--overwrite`` (or another ``--out``)
    measures them; the kept cells are not rendered again behind the user's back."""
    lacking: dict[str, int] = {}
    for run in runs:
        for cell in run.cells():
            record = records.get(cell.key())
            if record is None:
                continue
            for name in run.metrics_of(cell.region):
                if name not in record.den or name not in record.raw:
                    lacking[name] = lacking.get(name, 0) + 1
    if lacking:
        counts = ", ".join(f"{name} ({n} cells)" for name, n in lacking.items())
        warnings.warn(
            f"--resume: kept cells measured without {counts}; the reports show these metrics "
            "as not measured for them: measure again with --overwrite to fill them in",
            stacklevel=3,
        )


def _where(device: dict[str, str] | None) -> str:
    return "cpu" if device is None else f"{device['device']} ({device['name']})"


def _check_same_device(kept: Iterable[Record], device: dict[str, str] | None, out: Path) -> None:
    """Refuse to resume into cells measured on another kind of device (a CPU sweep's records
    beside a CUDA sweep's would mix last-bit differences and timings in one table)."""
    kind = "cpu" if device is None else torch.device(device["device"]).type
    for record in kept:
        theirs = "cpu" if record.device is None else torch.device(record.device["device"]).type
        if theirs != kind:
            raise ValueRangeError(
                f"{out}: expected kept cells measured on {kind} to resume on {_where(device)}, "
                f"got {record.key} measured on {_where(record.device)}; resume with that "
                f"--device, or measure into another --out"
            )


def start_sweep(
    suite: Suite,
    out_dir: str | Path,
    parts: Parts | None,
    *,
    resume: bool,
    overwrite: bool,
    runs: Sequence[Run] | None = None,
) -> SweepState:
    """Check the output folder, load what ``resume`` keeps and plan the pending runs (of
    ``runs``, by default ``plan(suite)``'s: :mod:`benchmarks.sweep.adaptive` passes the runs
    with the seed sets each has reached).

    The temporaries of the results and parameters files that a killed writer left are removed
    (the caller is the folder's one writer).

    Raises:
        ResultsExistError: finished cells in ``out_dir`` and neither ``resume`` nor
            ``overwrite``; nothing is written.
        FileFormatError: with ``resume``, a results file that is not valid (a tuned-parameters
            file that is not valid is a warning: the denoisers are tuned again).
        PluginError: with ``resume``, kept cells measured with a plug-in that changed since.
        ValueRangeError: with ``resume``, kept cells measured on another kind of device than
            ``parts.device`` (cpu, cuda).
    """
    out = Path(out_dir)
    if not resume and not overwrite:
        check_no_results(out)
    records = {r.key: r for r in load_records(out, torn_tail=True)} if resume else {}
    parts = real_parts() if parts is None else parts
    load_specs(parts.plugins)
    check_resume(records.values())  # no cells of a plug-in that changed since
    device = device_info(parts.device)
    _check_same_device(records.values(), device, out)
    out.mkdir(parents=True, exist_ok=True)
    clean_stale_temporaries(out, [RESULTS_FILE, TUNED_PARAMS_FILE])  # a killed writer's, if any
    store = load_params(out / TUNED_PARAMS_FILE) if resume else ParamStore()
    runs = plan(suite) if runs is None else list(runs)
    _warn_unmeasured(records, runs)
    version = parts.code_version
    todo = [with_reuse(run, records, version) for run in pending(suite, records, runs)]
    planned = {c.key(): None for run in runs for c in run.cells()}  # ordered, no repeats
    order = [k for k in records if k not in planned] + list(planned)
    return SweepState(
        out=out,
        parts=parts,
        records=records,
        store=store,
        todo=todo,
        order=order,
        resumed=resume,
        device=device,
    )


def run_suite(
    suite: Suite,
    out_dir: str | Path,
    *,
    parts: Parts | None = None,
    cache_dir: str | Path = "cache/references",
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = True,
    runs: Sequence[Run] | None = None,
) -> list[Record]:
    """Measure every cell of ``suite`` (of ``runs``, by default ``plan(suite)``'s) and write
    ``<out_dir>/cells.jsonl``; return all records.

    With ``resume`` the results file and the tuned parameters (``tuned_params.json``) are kept,
    and the cells already measured are not measured again: a run whose cells are all done is
    skipped; a run with some missing denoisers or regions is rendered again for those only.
    Without it both files are started afresh (replaced at the first write), which a folder
    holding finished cells allows only with ``overwrite``.

    Raises:
        ResultsExistError: finished cells in ``out_dir`` and neither ``resume`` nor
            ``overwrite``; nothing is written.
        FileFormatError: with ``resume``, a results file that is not valid (the message names
            the file and line).
    """
    sweep = start_sweep(suite, out_dir, parts, resume=resume, overwrite=overwrite, runs=runs)
    references = ReferenceCache(cache_dir, sweep.parts)
    total = sum(len(r.groups) * (r.warmup + r.frames) for r in sweep.todo)
    with tqdm(total=total, unit="frame", disable=not progress, dynamic_ncols=True) as bar:
        for run in sweep.todo:
            label = run.label  # bound now: the callback below reads it while this run measures

            def say(what: str, label: str = label) -> None:
                bar.set_description(f"{label}: {what}" if what else label, refresh=True)

            references.on_render = say
            say("tuning the denoisers")
            denoisers = tune_denoisers(run, sweep.parts, references, sweep.store)
            sweep.save_params()
            say("")
            measured = measure_run(
                run,
                sweep.parts,
                references,
                denoisers,
                crops_dir=sweep.out / "crops",
                on_frame=lambda: bar.update(1),
                merge_crops=sweep.resumed,
                kept=sweep.records,
            )
            sweep.add(measured)
    sweep.finish()
    return sweep.ordered()
