"""``bnerr bench``: run a named suite (with overrides), write its results and print the table.

Examples::

    bnerr bench --suite quick
    bnerr bench --suite quality --scenes direct cornell --spp 1 4 --out /tmp/q --resume
    bnerr bench --suite stability --res 48x48 --frames 4
    bnerr bench --suite quality --ray HEAD:6379      # every seed set a task on a Ray cluster

Results go to ``results/<suite>/`` unless ``--out`` says otherwise: ``cells.jsonl`` (the raw
records; ``cells.jsonl.xz`` with ``--compress`` or where the folder held an archive already,
as the committed ``results/`` do; ``--report-only --compact`` also rounds an older folder's
records to the precision runs keep, :meth:`benchmarks.sweep.records.Record.rounded`),
``table.csv``, ``table.md``, the charts and the page ``index.html`` (:mod:`benchmarks.reports`);
the folder above gets ``index.html``, linking every suite's page.
References are cached under ``--cache`` (default ``cache/references``). ``--resume`` keeps the
results already in the output folder and measures only the missing cells; without it, a folder that
already holds finished cells is refused unless ``--overwrite`` says to discard them.
``--remeasure DENOISER ..`` discards those denoisers' cells of the suite as given (the overrides
narrow it) and their tuned parameters, then resumes: after a denoiser's code changed, its cells
are measured again (their runs rendered again for it alone) and every other cell stays as
measured. The command
holds the output folder's write lock (:func:`bnerr.outputs.output_lock`) for the whole run, so a
second ``bnerr bench`` into the same ``--out`` refuses at once instead of losing cells.

**Plug-ins** (:mod:`bnerr.plugins`): ``--scenes``, ``--strategies``, ``--denoisers``,
``--samplers`` (the per-pixel sampler condition) and ``--metrics`` take, besides registered names
(installed entry points among them), specs ``pkg.mod:attr`` and ``path/to/file.py:Name`` (and
manifest or scene files ending in ``.toml`` / ``.json`` for denoisers and scenes); each is loaded,
registered under its name, and loaded again in every worker. The white baseline is always run
(added, with a note on stderr, when no sweep has it). Each record carries its plug-ins' specs and
fingerprints, and ``--resume`` refuses to mix in cells of a plug-in that changed; ``--report-only``
loads them again from those specs (relative paths from the directory the run started in) before
it builds the report, so the report is the measuring run's.

**Any renderer** (:mod:`renderers.external`, docs/RENDERER_PROTOCOL.md): ``--renderer
MANIFEST.toml`` or ``--renderer-cmd "TEMPLATE"`` (split into argv with shlex, never run through a
shell) runs every strategy whose sampler the program implements through it, one run per frame
(the oracle's K candidates: K runs), on its one scene, named after its manifest
(:mod:`benchmarks.sweep.external_renderer`); the references are its own renders at the reference
spp. ``--scenes`` does not go with them.

``--until-resolved [--seed-set-cap N] [--batch B]`` (:mod:`benchmarks.sweep.adaptive`): after
the suite's seed sets, the runs of every scene, condition and spp whose decision-table verdict is
still open are measured again at the next look (doubled seed sets, or B more), up to the cap
(default 32), under a group-sequential design that keeps every verdict's 95 % coverage
(:mod:`bnerr.metrics.sequential`); ``--resume`` continues an interrupted run to the same
verdicts. ``--resolve REGION...`` lets only those pixel regions' open verdicts add seed sets
(default: the suite's ``resolve``, else every region); ``--stop-settled`` gives a settled cell
no more seed sets although its run grows for another one.

``--ray [auto|local|HOST:PORT]`` runs the same cells as Ray tasks
(:mod:`benchmarks.sweep.ray_runner`; the ``cluster`` extra): ``auto`` (the default when the flag has
no value) joins the cluster this machine belongs to (``ray start``, or ``RAY_ADDRESS``) or else
starts a local instance; ``HOST:PORT`` joins a head node. The records are the serial runner's bit
for bit (timings aside); ``--resume`` works the same. ``--ray-cpus`` sets the CPUs (and torch
threads) of each task.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
from collections.abc import Callable
from pathlib import Path

import torch

from benchmarks import suites
from benchmarks.commands._args import (
    MAX_COUNT,
    names,
    nonnegative_int,
    parse_resolution,
    positive_int,
)
from benchmarks.reports import write_report
from benchmarks.reports.page import write_index
from benchmarks.speed import rewrite_speed_report, run_speed
from benchmarks.suites import REGIONS, SUITES, Suite
from benchmarks.sweep import runner
from benchmarks.sweep.adaptive import DEFAULT_CAP, run_until_resolved
from benchmarks.sweep.external_renderer import external_parts, renderer_regions, renderer_suite
from benchmarks.sweep.parts import known_names, real_parts
from benchmarks.sweep.plan import plan
from benchmarks.sweep.plugins import load_names, load_recorded
from benchmarks.sweep.ray_runner import require_ray, run_suite_ray
from benchmarks.sweep.records import (
    ARCHIVES,
    DIGITS,
    TIMING_DIGITS,
    Record,
    compact_records,
    compress_records,
    load_records,
)
from bnerr.errors import DtypeError, ValueRangeError, check_device, check_positive_int
from bnerr.io import atomic_write
from bnerr.metrics.regions import REGION_BUFFERS
from bnerr.outputs import check_folder_path, output_lock
from renderers.cycles import CYCLES_STRATEGIES, check_cells, is_cycles_name, settings_record
from renderers.external import ExternalRenderer, command_manifest, load_renderer_manifest

__all__ = ["register"]

_OVERRIDES = (
    "scenes",
    "strategies",
    "spp",
    "denoisers",
    "frames",
    "warmup",
    "seed_sets",
    "reference_spp",
    "res",
    "samplers",
    "metrics",
    "renderer",
    "renderer_cmd",
)


def _ints(values: list[str] | None, flag: str) -> list[int] | None:
    given = names(values)
    if given is None:
        return None
    try:
        numbers = [int(v) for v in given]
    except ValueError as err:
        raise DtypeError(f"{flag}: expected positive integers, got {values!r}") from err
    for n in numbers:
        if check_positive_int(n, flag) > MAX_COUNT:  # the same bound as every count's type
            raise ValueRangeError(f"{flag}: expected integers <= {MAX_COUNT}, got {n}")
    return numbers


def _count(value: int | None, flag: str, minimum: int = 1) -> int | None:
    return None if value is None else check_positive_int(value, flag, minimum=minimum)


def _res(text: str | None) -> tuple[int, int] | None:
    return None if text is None else parse_resolution(text)


def _add_resume_options(parser: argparse.ArgumentParser) -> None:
    """What happens to the results already in ``--out``: one of --resume, --report-only,
    --overwrite."""
    resume = parser.add_mutually_exclusive_group()
    resume.add_argument(
        "--resume", action="store_true", help="keep existing results, measure only missing cells"
    )
    resume.add_argument(
        "--report-only",
        action="store_true",
        help="measure nothing: rewrite the tables and charts from the cells already in --out "
        "(after a change to the report, or when the suite gained cells not measured yet)",
    )
    resume.add_argument(
        "--overwrite",
        action="store_true",
        help="discard the finished cells already in --out (without it a fresh run into a folder "
        "with results refuses)",
    )
    resume.add_argument(
        "--remeasure",
        nargs="+",
        metavar="DENOISER",
        help="discard these denoisers' cells of the suite as given (and their tuned "
        "parameters) in --out and measure them again, keeping every other cell: after a "
        "denoiser's code changed (an interrupted run goes on with --resume)",
    )


def _add_renderer_options(parser: argparse.ArgumentParser) -> None:
    """Which renderer: bnerr's tracer (neither), --renderer or --renderer-cmd."""
    external = parser.add_mutually_exclusive_group()
    external.add_argument(
        "--renderer",
        type=Path,
        metavar="MANIFEST",
        help="render with an external program through the seed protocol: its manifest (.toml, "
        ".json; docs/RENDERER_PROTOCOL.md)",
    )
    external.add_argument(
        "--renderer-cmd",
        metavar="TEMPLATE",
        help="the same with a command line: argv with {seeds} {out} {spp} {frame} {width} "
        "{height} {sampler} placeholders (split with shlex, no shell)",
    )


def _add_adaptive_options(parser: argparse.ArgumentParser) -> None:
    """Adaptive seed sets: --until-resolved with its cap and batch."""
    add = parser.add_argument
    add(
        "--until-resolved",
        action="store_true",
        help="add seed sets, in batches, only to the cells whose verdict is still open, up to "
        "--seed-set-cap (a group-sequential design keeps every verdict's 95 %% coverage)",
    )
    add(
        "--seed-set-cap",
        type=positive_int,
        help=f"with --until-resolved: the most seed sets a cell gets (default {DEFAULT_CAP})",
    )
    add(
        "--batch",
        type=positive_int,
        help="with --until-resolved: seed sets added per look (default: doubled each look)",
    )
    add(
        "--resolve",
        nargs="+",
        choices=REGIONS,
        metavar="REGION",
        help="with --until-resolved: the pixel regions whose open verdicts add seed sets "
        f"(default: the suite's, else every region; from {', '.join(REGIONS)})",
    )
    add(
        "--stop-settled",
        action="store_true",
        default=None,
        help="with --until-resolved: a settled cell gets no more seed sets although its run "
        "grows for another cell (default: the suite's setting)",
    )


def _add_machine_options(parser: argparse.ArgumentParser) -> None:
    """Where the cells compute: --threads and --device."""
    parser.add_argument(
        "--threads",
        type=positive_int,
        help="torch intra-op threads (default: torch's own, one per core); 1 on a shared, loaded "
        "machine, where OpenMP barriers stall whenever a thread is descheduled",
    )
    parser.add_argument(
        "--device",
        default="cpu",
        help="torch device the cells render, denoise and measure on: cpu (default), cuda, "
        "cuda:N; the records say which (not with --ray or an external renderer)",
    )


def register(subparsers: argparse._SubParsersAction) -> None:

    parser = subparsers.add_parser(
        "bench",
        help="run a benchmark suite and write tables and charts",
        description="Run a named benchmark suite (with overrides), write its tables and charts, "
        "print the table.\n\nSuites:\n"
        + "\n".join(f"  {s.name:10s} {s.description}" for s in SUITES.values()),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add = parser.add_argument
    add("--suite", default="quick", choices=sorted(SUITES), help="named suite (default quick)")
    spec = " (or a plug-in: pkg.mod:attr, path/file.py:Name)"
    add("--scenes", nargs="+", metavar="NAME", help="override the scenes" + spec)
    add("--strategies", nargs="+", metavar="NAME", help="override the strategies" + spec)
    add("--spp", nargs="+", metavar="N", help="override the samples per pixel")
    add("--denoisers", nargs="+", metavar="NAME", help="override the denoisers" + spec)
    add(
        "--samplers",
        nargs="+",
        metavar="NAME",
        help="override the per-pixel sampler condition (owen_sobol, white" + spec + ")",
    )
    add("--metrics", nargs="+", metavar="NAME", help="override the metrics measured" + spec)
    _add_renderer_options(parser)
    add("--frames", type=positive_int, help="measured frames per seed set")
    add("--warmup", type=nonnegative_int, help="frames rendered before measuring (not measured)")
    add("--seed-sets", type=positive_int, help="independent seed sets")
    add("--reference-spp", type=positive_int, help="samples per pixel of the references")
    add("--res", help="resolution WIDTHxHEIGHT")
    add("--out", type=Path, help="output folder (default results/<suite>)")
    add("--cache", type=Path, default=Path("cache/references"), help="reference cache folder")
    _add_resume_options(parser)
    _add_machine_options(parser)
    add(
        "--ray",
        nargs="?",
        const="auto",
        metavar="ADDRESS",
        help="run the cells as Ray tasks: auto (default: this machine's cluster, else a local "
        "instance), local, or HOST:PORT of a head node (needs: pip install '.[cluster]')",
    )
    add("--ray-cpus", type=positive_int, default=1, help="CPUs (and torch threads) per Ray task")
    _add_adaptive_options(parser)
    add("--no-charts", action="store_true", help="write the tables only")
    compress = "keep the cells as cells.jsonl.xz (a folder holding an archive keeps it so anyway)"
    add("--compress", action="store_true", help=compress)
    compact = (
        "with --report-only: round the folder's records to the precision runs record now "
        f"({DIGITS} significant digits, timings {TIMING_DIGITS}) and compress them, before the "
        "reports"
    )
    add("--compact", action="store_true", help=compact)
    add("--quiet", action="store_true", help="no progress bar, no table on stdout")
    scripts = (
        "speed suite: measure only these scripts (e.g. speed.permute; with their anchors) and "
        "keep the other figures of --out's speed.json"
    )
    add("--scripts", nargs="+", metavar="NAME", help=scripts)
    parser.set_defaults(func=run)


def _run_speed(args: argparse.Namespace, suite: Suite, out: Path) -> str:

    given = [f"--{n.replace('_', '-')}" for n in _OVERRIDES if getattr(args, n) is not None]
    given += [
        flag for flag in ("--resume", "--overwrite", "--remeasure") if getattr(args, flag[2:])
    ]
    given += ["--ray"] if args.ray is not None else []
    given += ["--device"] if args.device != "cpu" else []
    if given:
        raise ValueRangeError(
            f"--suite {suite.name}: expected no cell overrides (it runs timing scripts), got "
            f"{', '.join(given)}"
        )
    if args.report_only:
        return rewrite_speed_report(suite, out)
    return run_speed(suite, out, progress=not args.quiet, only=args.scripts)


def _report_only(args: argparse.Namespace, suite: Suite, out: Path, compress: bool) -> str:
    """The report of the cells in ``out`` (rounded first with ``--compact``, compressed first
    with ``compress``), measuring nothing."""
    given = [f"--{n.replace('_', '-')}" for n in _OVERRIDES if getattr(args, n) is not None]
    given += ["--ray"] if args.ray is not None else []
    given += ["--device"] if args.device != "cpu" else []
    if given:
        raise ValueRangeError(
            f"--report-only: expected no cell overrides (it measures nothing), got "
            f"{', '.join(given)}"
        )
    if args.compact:
        compact_records(out)
    elif compress:
        compress_records(out)
    records = load_records(out)
    if not records:
        raise ValueRangeError(f"--report-only: expected finished cells in {out}, got none")
    for note in load_recorded(records):  # the plug-ins measured, for their columns and panels
        print(f"bnerr bench: {note}", file=sys.stderr)
    title = f"bnerr bench --suite {suite.name}"
    return write_report(out, records, title=title, charts=not args.no_charts)


def _renderer(args: argparse.Namespace) -> ExternalRenderer | None:
    """The external renderer of ``--renderer`` / ``--renderer-cmd``, or None (bnerr's tracer)."""
    if args.renderer is None and args.renderer_cmd is None:
        return None
    if args.scenes is not None:
        raise ValueRangeError(
            "--scenes: expected none with --renderer / --renderer-cmd (the program renders its "
            f"one scene), got {' '.join(args.scenes)}"
        )
    if args.renderer is not None:
        return ExternalRenderer(load_renderer_manifest(args.renderer))
    return ExternalRenderer(command_manifest(args.renderer_cmd))


def _check_adaptive(args: argparse.Namespace) -> None:
    """--seed-set-cap, --batch, --resolve and --stop-settled only with --until-resolved, which
    measures (no --report-only)."""
    if not args.until_resolved:
        options = ("seed_set_cap", "batch", "resolve", "stop_settled")
        given = [f for f in options if getattr(args, f) is not None]
        if given:
            flags = ", ".join("--" + f.replace("_", "-") for f in given)
            raise ValueRangeError(f"{flags}: expected with --until-resolved, got without it")
    elif args.report_only:
        raise ValueRangeError("--until-resolved: expected a run that measures, got --report-only")


def _measure(
    args: argparse.Namespace,
    suite: Suite,
    out: Path,
    measure: Callable[..., list[Record]],
    common: dict,
) -> list[Record]:
    """The suite's records: measured once, or with --until-resolved look by look."""
    if not args.until_resolved:
        return measure(suite, out, **common)
    return run_until_resolved(
        suite,
        out,
        cap=DEFAULT_CAP if args.seed_set_cap is None else args.seed_set_cap,
        batch=args.batch,
        measure=measure,
        resolve=args.resolve,
        stop_settled=args.stop_settled,
        **common,
    )


def _for_renderer(suite: Suite, renderer: ExternalRenderer, named: bool) -> Suite:
    """``suite`` with the strategies and pixel regions an external renderer can give, what is
    left out said once on stderr, before the first render."""
    suite, dropped = renderer_suite(suite, renderer, named=named)
    label = renderer.manifest.label
    if dropped:
        print(
            f"bnerr bench: left out {', '.join(dropped)}: {label} lists no sampler for them",
            file=sys.stderr,
        )
    suite, regions = renderer_regions(suite, renderer)
    if regions:
        need = sorted({b for r in regions for b in REGION_BUFFERS[r]})
        print(
            f"bnerr bench: left out the region(s) {', '.join(regions)}: {label} gives no "
            f"{', '.join(need)} buffer (its manifest's buffers: "
            f"{', '.join(renderer.manifest.buffers)})",
            file=sys.stderr,
        )
    return suite


def _forget(denoisers: list[str], suite: Suite, out: Path) -> None:
    """--remeasure: discard the suite's cells of ``denoisers`` (each one of the suite's) from
    ``out``, saying how many on stderr; the run then resumes and measures them again."""
    runs = plan(suite)
    known = list(dict.fromkeys(d for run in runs for d in run.denoisers))
    unknown = [d for d in denoisers if d not in known]
    if unknown:
        raise ValueRangeError(
            f"--remeasure: expected denoisers of the suite ({', '.join(known)}), got "
            f"{', '.join(unknown)}"
        )
    gone = runner.forget_cells(out, runs, denoisers)
    print(
        f"bnerr bench: --remeasure: discarded {gone} cells of {', '.join(denoisers)} in {out}; "
        "measuring them again",
        file=sys.stderr,
    )


def _run_cells(args: argparse.Namespace, suite: Suite, out: Path, compress: bool) -> str:
    """Measure the suite's cells into ``out`` (or only report them), compress the cells if
    ``compress``, then write the report: last, so that the page links the file the folder holds."""
    _check_adaptive(args)
    if args.compact and not args.report_only:
        raise ValueRangeError("--compact: expected with --report-only, got a run that measures")
    if args.report_only:
        return _report_only(args, suite, out, compress)

    renderer = _renderer(args)
    specs: list[tuple[str, str]] = []
    suite = suites.resolve(
        suite,
        scenes=load_names("bnerr.scenes", names(args.scenes), specs),
        strategies=load_names("bnerr.strategies", names(args.strategies), specs),
        spp=_ints(args.spp, "--spp"),
        denoisers=load_names("bnerr.denoisers", names(args.denoisers), specs),
        samplers=load_names("bnerr.samplers", names(args.samplers), specs),
        metrics=load_names("bnerr.metrics", names(args.metrics), specs),
        frames=_count(args.frames, "--frames"),
        warmup=_count(args.warmup, "--warmup", minimum=0),
        res=_res(args.res),
        seed_sets=_count(args.seed_sets, "--seed-sets"),
        reference_spp=_count(args.reference_spp, "--reference-spp"),
        **known_names(),
    )
    suite, added = suites.with_white(suite)
    if added:
        print("bnerr bench: added the white baseline (every ratio is to white)", file=sys.stderr)
    specs = list(dict.fromkeys(specs))
    parts = real_parts(tuple(specs), device=args.device)
    if renderer is not None:
        suite = _for_renderer(suite, renderer, named=args.strategies is not None)
        parts = external_parts(renderer, tuple(specs))
    if args.remeasure:
        _forget(args.remeasure, suite, out)
    common = dict(
        cache_dir=args.cache,
        resume=args.resume or bool(args.remeasure),
        overwrite=args.overwrite,
        progress=not args.quiet,
        parts=parts,
    )
    measure: Callable[..., list[Record]] = runner.run_suite
    if args.ray is not None:
        measure = functools.partial(run_suite_ray, address=args.ray, cpus_per_task=args.ray_cpus)
    records = _measure(args, suite, out, measure, common)
    if compress:  # before the page is written: it links the file the folder then holds
        compress_records(out)
    device = "" if args.device == "cpu" else f" --device {args.device}"
    title = f"bnerr bench --suite {suite.name}{device}"
    return write_report(out, records, title=title, charts=not args.no_charts)


def _check_device(args: argparse.Namespace) -> None:
    """--device: available here (:func:`bnerr.errors.check_device`), and off the CPU neither with
    --ray (its tasks ask Ray for CPUs only) nor with an external renderer (it renders where it
    renders); ``args.device`` becomes the canonical name (``cuda`` -> ``cuda``, ``cuda:1``)."""
    args.device = str(check_device(args.device, "--device"))
    if args.device == "cpu":
        return
    given = [f for f, v in (("--ray", args.ray), ("--renderer", args.renderer)) if v is not None]
    given += ["--renderer-cmd"] if args.renderer_cmd is not None else []
    if given:
        raise ValueRangeError(
            f"--device {args.device}: expected it without {', '.join(given)} (Ray tasks and "
            "external renderers run on the CPU), got both; drop one"
        )


def _on_cycles(args: argparse.Namespace, suite: Suite) -> Suite:
    """``suite`` with Cycles' strategies only when ``--scenes`` names only Cycles scenes and
    ``--strategies`` names none: those of its strategies Cycles runs, else ``white`` and
    ``blue_noise`` (a note says what was left out)."""
    scenes = names(args.scenes)
    if not scenes or args.strategies is not None or not all(map(is_cycles_name, scenes)):
        return suite
    sweeps, dropped = [], []
    for sweep in suite.sweeps:
        kept = tuple(s for s in sweep.strategies if s in CYCLES_STRATEGIES)
        dropped += [s for s in sweep.strategies if s not in kept]
        sweeps.append(
            dataclasses.replace(
                sweep, strategies=kept if len(kept) > 1 else ("white", "blue_noise")
            )
        )
    if dropped:
        print(
            f"bnerr bench: left out {', '.join(dict.fromkeys(dropped))}: a Cycles scene runs "
            f"Cycles' own patterns ({', '.join(CYCLES_STRATEGIES)})",
            file=sys.stderr,
        )
    return dataclasses.replace(suite, sweeps=tuple(sweeps))


def _check_cycles(args: argparse.Namespace, suite: Suite) -> dict[str, dict]:
    """Each scene against the strategies its sweeps pair it with (the command line's overrides
    applied): a Cycles scene opened in Blender and given Cycles' patterns only, bnerr's scenes
    none of them (:func:`renderers.cycles.check_cells`). Returns what Blender found in each
    Cycles scene, by name."""
    pairs: dict[str, list[str]] = {}
    for sweep in suite.sweeps:
        scenes = names(args.scenes) or sweep.scenes
        strategies = names(args.strategies) or sweep.strategies
        for scene in scenes:
            known = pairs.setdefault(scene, [])
            known += [s for s in strategies if s not in known]
    found = {scene: check_cells(scene, strategies) for scene, strategies in pairs.items()}
    return {Path(scene).stem: info for scene, info in found.items() if info is not None}


def _write_cycles_record(out: Path, infos: dict[str, dict]) -> None:
    """``cycles_scenes.json`` in ``out``: Blender's version and every setting bnerr changed in
    each Cycles scene, with the file's own values (:func:`renderers.cycles.settings_record`)."""
    with atomic_write(Path(out) / "cycles_scenes.json") as path:
        path.write_text(json.dumps(settings_record(infos), indent=1, sort_keys=True) + "\n")


def run(args: argparse.Namespace) -> int:
    """Run the suite while holding ``--out``'s write lock; print the table unless ``--quiet``."""

    if args.threads is not None:
        torch.set_num_threads(check_positive_int(args.threads, "--threads"))
    _check_device(args)
    if args.ray is not None:  # before any work: say how to install it
        require_ray()
        check_positive_int(args.ray_cpus, "--ray-cpus")
    suite = suites.get_suite(args.suite)
    if args.scripts is not None and not suite.scripts:
        raise ValueRangeError(
            f"--scripts: expected a suite of timing scripts (speed), got --suite {suite.name}"
        )
    out = args.out or Path("results") / suite.name
    if args.cache is not None and not suite.scripts:  # a file there: refused before any render
        check_folder_path(args.cache, "--cache")
    infos: dict[str, dict] = {}
    if not suite.scripts and args.renderer is None and args.renderer_cmd is None:
        suite = _on_cycles(args, suite)
        infos = _check_cycles(args, suite)  # before the lock: a refused run writes nothing
    with output_lock(out, "bnerr bench"):
        compress = args.compress or any((Path(out) / name).exists() for name in ARCHIVES)
        if suite.scripts:
            text = _run_speed(args, suite, out)
        else:
            text = _run_cells(args, suite, out, compress)
        if infos:
            _write_cycles_record(out, infos)
    write_index(Path(out).resolve().parent)  # the results page of every suite beside it
    if not args.quiet:
        print(text)
    print(f"results written to {out}")
    return 0
