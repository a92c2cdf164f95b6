"""``bnerr eval DIR``: the tables, charts and page of ``bnerr bench`` for frames rendered anywhere.

Examples::

    bnerr eval frames/
    bnerr eval frames/ --denoisers gaussian atrous --out /tmp/eval
    bnerr eval frames/ --denoisers my_denoiser.py:Denoiser --metrics my_metric.py:score

``DIR`` is a frame folder (docs/EVAL.md, :mod:`benchmarks.commands.eval.frame_folder`):
``manifest.toml``, ``reference/<tttt>.exr`` and ``<method>/<seed_set>/<tttt>.exr``, white among
the methods. Every method is measured as ``bnerr bench`` measures a strategy
(:mod:`benchmarks.commands.eval.evaluate`), and
``--out`` (default ``DIR/results``) gets ``cells.jsonl``, ``table.csv``, ``table.md``,
``decision.md``, the charts and ``index.html``. A folder that already holds finished cells is
refused unless ``--overwrite``; the command holds ``--out``'s write lock while it runs. Any
problem with the folder is one line naming the file, found before anything is written (every
file is read to its last pixel first); a failure after that (a plug-in that raises mid-run)
removes what the run had written, the lock file and a folder it created included.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from benchmarks.commands._args import names, positive_int
from benchmarks.commands.eval.evaluate import measure_evaluation, plan_evaluation
from benchmarks.commands.eval.frame_folder import FrameFolder
from benchmarks.reports import write_report
from benchmarks.sweep.parts import known_names
from benchmarks.sweep.plan import Run
from benchmarks.sweep.plugins import load_names
from benchmarks.sweep.records import check_no_results
from bnerr.errors import check_name, check_positive_int
from bnerr.outputs import check_folder_path, undo_on_failure

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "eval",
        help="measure frames rendered anywhere (a folder of EXR frames) like bnerr bench",
        description="Measure a frame folder (manifest.toml, reference/, <method>/<seed_set>/, "
        "see docs/EVAL.md): every metric raw and after each denoiser, ratios to white with "
        "intervals over seed sets; write the tables, charts and page of bnerr bench.",
    )
    add = parser.add_argument
    add("dir", type=Path, metavar="DIR", help="the frame folder")
    spec = " (or a plug-in: pkg.mod:attr, path/file.py:Name)"
    add(
        "--denoisers",
        nargs="+",
        metavar="NAME",
        default=["gaussian"],
        help="denoisers to run (default gaussian; NAME:own is tuned on the method's own "
        "tuning frames)" + spec,
    )
    add("--metrics", nargs="+", metavar="NAME", help="metrics (default: the table's)" + spec)
    add("--out", type=Path, help="output folder (default DIR/results)")
    add("--overwrite", action="store_true", help="discard the finished cells already in --out")
    add("--threads", type=positive_int, help="torch intra-op threads (default: torch's own)")
    add("--no-charts", action="store_true", help="write the tables only")
    add("--quiet", action="store_true", help="no progress, no table on stdout")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Measure ``DIR`` into ``--out`` while holding its lock; print the table unless ``--quiet``."""
    if args.threads is not None:
        torch.set_num_threads(check_positive_int(args.threads, "--threads"))
    specs: list[tuple[str, str]] = []
    chosen = load_names("bnerr.denoisers", names(args.denoisers), specs) or []
    metrics = load_names("bnerr.metrics", names(args.metrics), specs)
    known = known_names()
    for name in chosen:
        check_name(name, known["known_denoisers"], "denoiser")
    for name in metrics or ():
        check_name(name, known["known_metrics"], "metric")
    folder = FrameFolder(args.dir)  # the folder and its manifest, before --out is created
    out = args.out if args.out is not None else args.dir / "results"
    check_folder_path(out, "--out")
    if not args.overwrite:
        check_no_results(out, resumable=False)
    plan = plan_evaluation(  # every file to its last pixel: a refusal writes nothing
        folder, denoisers=chosen, metrics=metrics, specs=tuple(dict.fromkeys(specs))
    )

    def say(run: Run) -> None:
        if not args.quiet:
            print(f"bnerr eval: measuring {run.strategy}", file=sys.stderr)

    with undo_on_failure(out, "bnerr eval"):  # its lock, and on failure nothing left behind
        if not args.overwrite:
            check_no_results(out, resumable=False)  # again: another run may have finished
        records = measure_evaluation(plan, out, on_run=say)
        for note in plan.notes:
            print(f"bnerr eval: note: {note}", file=sys.stderr)
        text = write_report(out, records, title=f"bnerr eval {args.dir}", charts=not args.no_charts)
    if not args.quiet:
        print(text)
    print(f"results written to {out}")
    return 0
