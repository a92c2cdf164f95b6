"""``bnerr animate``: per scene, an MP4 and a small GIF comparing the strategies frame by frame.

    bnerr animate --scene cornell --strategies white,temporal --frames 16 --out results/animations
    bnerr animate --scenes direct indirect --res 96x96 --spp 4 --reference-spp 256 --threads 1

Each file is a grid: columns ``reference | <strategies>`` (default: white, temporal and the
registered rivals bnds_st, zsobol_t, temporal_zsobol), rows raw and after ``--denoiser`` (with
the parameters the benchmark tuned for that scene, resolution and spp in ``--params`` when it
holds them, else the denoiser's defaults: the caption says which), labelled on the frames and
tone-mapped with the project's tone map. The frames are the ones a benchmark run renders for seed
set ``--seed-set``: the strategy's warmup frames first (temporal strategies), then
``t = warmup .. warmup + frames - 1``; the references come from the benchmark's cache
(``--cache``). ``<scene>.mp4`` holds every frame at full size, ``<scene>.gif`` the first
``--gif-frames`` frames of a ``--gif-crop`` centre crop of each tile (benchmarks.animate).

``--params`` names a ``tuned_params.json`` or the ``bnerr bench`` folder holding one; omitted, it
is ``results/quality/tuned_params.json`` when that exists, else the denoiser's defaults (a note
says so). A given path that holds no such file, or a file that is not valid, is a one-line error
before any rendering: a mistyped path should not quietly animate untuned denoisers.

``--scenes``, ``--strategies`` and ``--denoiser`` take plug-ins too (:mod:`bnerr.plugins`): specs
``pkg.mod:attr`` and ``path/to/file.py:Name``, a scene file (``.toml``, ``.json``) and an executable
denoiser's manifest, each loaded and shown under its registered name.

Every name, number and the output folder are checked before any rendering; the command holds
the folder's lock while it writes.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from benchmarks.animate import Animation, AnimationResult, animate, default_strategies, load_store
from benchmarks.commands._args import (
    names,
    nonnegative_int,
    parse_resolution,
    positive_int,
    seed_int,
)
from benchmarks.sweep.parts import known_names
from benchmarks.sweep.plugins import load_names
from benchmarks.sweep.runner import TUNED_PARAMS_FILE
from bnerr.errors import FileFormatError, check_positive_int
from bnerr.outputs import check_folder_path
from bnerr.strategies import strategy_identity
from renderers import get_scene
from renderers.budget import SHOW_ESTIMATE_S, TIME_LIMIT_S, check_render_time, format_seconds

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "animate",
        help="write per-scene MP4 and GIF comparisons of the strategies, raw and denoised",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add = parser.add_argument
    add(
        "--scene",
        "--scenes",
        dest="scenes",
        nargs="+",
        required=True,
        metavar="NAME",
        help="scene name(s), space- or comma-separated (or scene files, pkg.mod:make_scene)",
    )
    add(
        "--strategies",
        nargs="+",
        metavar="NAME",
        help="strategy columns (default: see above; plug-ins: pkg.mod:Cls, path/file.py:Cls)",
    )
    add(
        "--denoiser",
        default="gaussian",
        help="denoiser of the second row (default gaussian; or pkg.mod:attr, a manifest .toml)",
    )
    add("--frames", type=positive_int, default=16, help="frames shown (default 16)")
    add("--warmup", type=nonnegative_int, default=6, help="frames rendered before them (default 6)")
    add("--res", default="128x128", help="WIDTHxHEIGHT (default 128x128)")
    add("--spp", type=positive_int, default=4, help="samples per pixel (default 4)")
    add("--seed-set", type=seed_int, default=0, help="the benchmark seed set (default 0)")
    add("--reference-spp", type=positive_int, default=1024, help="reference spp (default 1024)")
    add("--fps", type=positive_int, default=8, help="frames per second (default 8)")
    add(
        "--gif-crop",
        type=positive_int,
        default=64,
        help="centre crop of each GIF tile (default 64)",
    )
    add(
        "--gif-frames",
        type=nonnegative_int,
        default=8,
        help="frames in the GIF (default 8; 0: all)",
    )
    add(
        "--params",
        type=Path,
        help=f"tuned denoiser parameters: a tuned_params.json, or the bnerr bench folder holding "
        f"one (default {DEFAULT_PARAMS} if it exists, else the denoiser's defaults)",
    )
    add("--cache", type=Path, default=Path("cache/references"), help="reference cache folder")
    add("--out", type=Path, default=Path("results/animations"), help="output folder")
    add("--threads", type=positive_int, help="torch intra-op threads; 1 on a shared machine")
    add("--force", action="store_true", help="render even if the estimate exceeds 1 h")
    parser.set_defaults(func=run)


def _specs(args: argparse.Namespace) -> list:

    width, height = parse_resolution(args.res)
    specs: list[tuple[str, str]] = []  # plug-ins: loaded, registered and named here
    scenes = load_names("bnerr.scenes", names(args.scenes), specs) or []
    strategies = tuple(
        load_names("bnerr.strategies", names(args.strategies), specs) or default_strategies()
    )
    denoiser = (load_names("bnerr.denoisers", [args.denoiser], specs) or [args.denoiser])[0]
    known = known_names()
    return [
        Animation(
            scene=scene,
            strategies=strategies,
            denoiser=denoiser,
            frames=args.frames,
            warmup=args.warmup,
            width=width,
            height=height,
            spp=args.spp,
            seed_set=args.seed_set,
            reference_spp=args.reference_spp,
            fps=args.fps,
            gif_crop=args.gif_crop,
            gif_frames=args.gif_frames,
        ).check(known)
        for scene in scenes
    ]


#: The oracle's candidates per frame (``make_strategy``'s default K), each a full render.
ORACLE_K = 32


def _animation_paths(spec: Animation) -> int:
    """Paths traced for ``spec``, at most: every strategy's warmup and shown frames (the
    bounds' K renders each) and the shown frames' references (counted even when cached)."""
    # A bound (the oracle, vertical) renders K candidates per frame.
    renders = sum(ORACLE_K if strategy_identity(n).bound else 1 for n in spec.strategies)
    pixels = spec.width * spec.height
    strategies = pixels * spec.spp * (spec.warmup + spec.frames) * renders
    return strategies + pixels * spec.reference_spp * spec.frames


def _check_time(specs: list[Animation]) -> None:
    """Refuse a scene's animation beyond :data:`TIME_LIMIT_S` by the time model
    (:mod:`renderers.budget`, the scene's measured throughput); print the total beyond 10 s."""
    total = 0.0
    for spec in specs:
        what = f"--scene {spec.scene} --res {spec.width}x{spec.height} --spp {spec.spp}"
        paths = _animation_paths(spec)
        total += check_render_time(get_scene(spec.scene), paths, what, limit_s=TIME_LIMIT_S)
    if total > SHOW_ESTIMATE_S:
        print(f"bnerr animate: estimated {format_seconds(total)} of rendering", flush=True)


#: The tuned parameters ``--params`` defaults to: those of the committed quality suite.
DEFAULT_PARAMS = Path("results/quality/tuned_params.json")


def params_file(given: Path | None) -> Path | None:
    """The tuned-parameters file ``--params`` names, checked and read before any work.

    Omitted: :data:`DEFAULT_PARAMS` if it exists, else None (the denoiser's defaults; a note
    says so). Given: the file, or ``tuned_params.json`` in the folder it names (a ``bnerr bench``
    output folder); a name that is neither is an error, not a silent fall back to defaults (a
    mistyped path would otherwise animate untuned denoisers). A file that is not a valid
    tuned-parameters file is an error either way.

    Raises:
        FileFormatError: a given path that is missing or holds no tuned_params.json, or a
            file that is not valid JSON of the tuned-parameters format.
    """
    if given is None:
        if not DEFAULT_PARAMS.is_file():
            print(f"bnerr animate: no {DEFAULT_PARAMS} here; the denoiser runs with its defaults")
            return None
        path = DEFAULT_PARAMS
    else:
        path = given / TUNED_PARAMS_FILE if given.is_dir() else given
        if not path.is_file():
            raise FileFormatError(
                f"--params {given}: expected a {TUNED_PARAMS_FILE} or a bnerr bench folder "
                f"holding one, got no such file (omit --params for {DEFAULT_PARAMS} or the "
                "denoiser's defaults)"
            )
    load_store(path)  # a corrupt file: a one-line error now, not after the first scene
    return path


def run(args: argparse.Namespace) -> int:
    """Check everything, then render and write each scene, printing its files and timings."""

    if args.threads is not None:
        torch.set_num_threads(check_positive_int(args.threads, "--threads"))
    specs = _specs(args)
    args.params = params_file(args.params)
    if not args.force:
        _check_time(specs)
    check_folder_path(args.cache, "--cache")  # a file there: refused before any render
    start = time.perf_counter()

    def report(spec: Animation, result: AnimationResult) -> None:
        seconds = "  ".join(f"{k} {v:.1f}s" for k, v in result["seconds"].items())
        sizes = "  ".join(
            f"{result[k]} ({Path(result[k]).stat().st_size / 1024:.0f} KiB)" for k in ("mp4", "gif")
        )
        print(f"{spec.scene}: {sizes}\n  {seconds}", flush=True)

    animate(specs, args.out, cache_dir=args.cache, params=args.params, on_scene=report)
    print(f"{len(specs)} animation(s) written to {args.out} in {time.perf_counter() - start:.0f} s")
    return 0
