"""The sweep behind ``bnerr bench``: measure every cell of a suite and keep the results file.

:func:`run_suite` plans the suite (:mod:`benchmarks.plan`), skips the cells already in the output
folder when resuming, tunes the denoisers once per scene, condition and spp on white noise
(:func:`benchmarks.measure.tune_denoisers`, saved in ``<out>/tuned_params.json``), measures each
pending run (:func:`benchmarks.measure.measure_run`) against cached references
(:mod:`benchmarks.references`), and rewrites ``<out>/cells.jsonl`` atomically after every run
(:mod:`benchmarks.records`), so an interrupted sweep loses at most the run in progress.

The parts (scenes, renderer, strategies, denoisers) come through :class:`benchmarks.parts.Parts`,
so the runner can be tested with stand-ins. One writer per output folder is the caller's job
(``bnerr bench`` holds :func:`bnerr.outputs.output_lock` on ``--out`` for the whole run).

Not for: the speed suite (:mod:`benchmarks.speed`) or the tables and charts
(:mod:`benchmarks.report`).
"""

from __future__ import annotations

from pathlib import Path

from benchmarks.measure import measure_run, tune_denoisers
from benchmarks.parts import Parts, real_parts
from benchmarks.plan import pending
from benchmarks.records import Record, check_no_results, load_records, write_records
from benchmarks.references import ReferenceCache
from benchmarks.suites import Suite

__all__ = ["TUNED_PARAMS_FILE", "run_suite"]

#: Name of the tuned denoiser parameters file inside the output folder.
TUNED_PARAMS_FILE = "tuned_params.json"


def run_suite(
    suite: Suite,
    out_dir: str | Path,
    *,
    parts: Parts | None = None,
    cache_dir: str | Path = "cache/references",
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = True,
) -> list[Record]:
    """Measure every cell of ``suite`` and write ``<out_dir>/cells.jsonl``; return all records.

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
    from tqdm import tqdm

    from denoisers.tuning import ParamStore

    out = Path(out_dir)
    if not resume and not overwrite:
        check_no_results(out)
    records = {r.key: r for r in load_records(out)} if resume else {}
    parts = real_parts() if parts is None else parts
    out.mkdir(parents=True, exist_ok=True)
    params_path = out / TUNED_PARAMS_FILE
    store = ParamStore.load(params_path) if resume and params_path.exists() else ParamStore()
    todo = pending(suite, records)
    references = ReferenceCache(cache_dir, parts)
    total = sum(r.seed_sets * (r.warmup + r.frames) for r in todo)
    with tqdm(total=total, unit="frame", disable=not progress, dynamic_ncols=True) as bar:
        for run in todo:
            bar.set_description(run.label)
            denoisers = tune_denoisers(run, parts, references, store)
            store.save(params_path)
            measured = measure_run(
                run,
                parts,
                references,
                denoisers,
                crops_dir=out / "crops",
                on_frame=lambda: bar.update(1),
            )
            records.update((r.key, r) for r in measured)
            write_records(out, records.values())
    if not todo:
        write_records(out, records.values())
    return list(records.values())
