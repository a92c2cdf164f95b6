"""``bnerr render``: render frames of a named scene to EXR files with PNG previews.

    bnerr render --scene cornell --res 256x256 --spp 16 --frames 4 --sampler owen_sobol --out out
    bnerr render --scene snooker --res 320x180 --spp 4 --frames 1 --static --out out/snooker
    bnerr render --scene cornell --res 128x128 --spp 4 --strategy temporal --frames 8 --out out/t

Frame t is written to ``DIR/<scene>_<t>.exr`` (color, albedo, normal, depth, motion, object_id and
variance layers, timings in the header; read it back with ``bnerr.io.read_frame``) and
``DIR/<scene>_<t>.png`` (tone-mapped sRGB preview). Every frame gets its own seed image
(``bnerr.strategies.pixel_seeds`` with a key made of ``--seed`` and t), so frames are independent
white-noise or Owen-Sobol renders.

With ``--strategy NAME`` (any registered strategy, :data:`bnerr.strategies.STRATEGIES`) the
strategy chooses the seeds instead, its state carried from frame to frame: frame t is the frame
``bnerr bench`` renders at t for seed set ``--seed-set`` (the strategy's seed) under the
``--sampler`` condition (default ``owen_sobol``, the benchmark's), bit for bit. A stateful
strategy (the temporal ones) renders frames ``0 .. --start - 1`` too, unwritten, to carry its
state; a stateless one starts at ``--start``, as the benchmark skips its warmup.

The tracer runs compiled (its vertex stage as an ahead-of-time compiled package,
:mod:`renderers.aot`: fused C++ kernels, about 4x faster than eager, loaded in milliseconds) when
a fixed-seed render traces at least 2^21 paths in all (``W * H * spp * frames``, e.g. 256x256 at
32 spp) and the scene's package is cached; eagerly below. The first such render of a scene on a
machine renders eagerly and then starts a niced background process that builds the package
(about a minute), so that later processes start compiled; a render long enough to repay the
build (:data:`AOT_BUILD_S`) builds it first instead. ``--compile`` (build if needed, then compiled)
and ``--no-compile`` decide instead. With ``--strategy`` the default is eager, the benchmark's
path, so that its frames stay the benchmark's bit for bit. Each output line says which path ran.

Before rendering, the resolution is checked against the memory it needs and ``DIR`` against its
kind, writability and free space; while it writes, ``bnerr render`` holds ``DIR``'s lock
(:func:`bnerr.outputs.output_lock`), so a second writer into ``DIR`` refuses. Its time is
estimated too, from the tracer's throughput measured on this machine for the scene
(:mod:`renderers.budget`, a fraction of a second, skipped for renders of under 2^18 paths, 2^22
compiled): an estimate over 10 s is printed, one over an hour refused unless ``--force``. From 2
frames on, a progress bar on stderr counts the frames written (``--no-progress``: none); the
per-frame lines stay on stdout.

A long run keeps its memory flat: ``--strategy temporal --frames 1000`` at 64x64 measured 586.1
MiB resident at frame 100 and 586.6 MiB at frame 1000 (the strategy's caches are bounded by
their cycle; nothing is kept per frame), with the seed image still a permutation of frame 0's.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import torch
from tqdm import tqdm

from benchmarks.commands._args import (
    EXPOSURE,
    nonnegative_int,
    parse_resolution,
    positive_int,
    seed_int,
)
from benchmarks.sweep.parts import render_any as render  # the tracer, or a Mitsuba scene's own
from bnerr.errors import (
    FileFormatError,
    ValueRangeError,
    check_memory,
    check_name,
    check_positive_int,
)
from bnerr.frame import Frame
from bnerr.io import IMAGE_SUFFIXES, write_frame, write_png
from bnerr.outputs import check_output, clean_stale_temporaries, output_lock
from bnerr.sequences import Sampler, load_sampler, make_sampler, per_pixel_samplers
from bnerr.strategies import Strategy, first_frame, make_strategy, pixel_seeds, play
from renderers import Scene, aot, get_scene, renders_itself
from renderers.budget import (
    COMPILE_SPEEDUP,
    SHOW_ESTIMATE_S,
    TIME_LIMIT_S,
    check_render_time,
    estimate_seconds,
    format_seconds,
)
from renderers.memory import render_bytes
from renderers.tracer import StageSource

__all__ = ["AOT_BUILD_S", "AUTO_COMPILE_PATHS", "compile_choice", "register", "run"]

#: Fixed-seed renders of at least this many paths in all run the compiled tracer by default
#: when its package is cached (loading it takes milliseconds; it pays from about 2^18 paths,
#: kept at 2^21 so that small renders never start a background build).
AUTO_COMPILE_PATHS = 1 << 21
#: Compiled renders of fewer paths are not estimated (as eager ones below
#: :data:`renderers.budget.UNMEASURED_PATHS`): at the slowest scene's compiled rate here (about
#: 1.6 M paths/s) they take under 3 s, and a cached 256x256, 32 spp render's process spent 7 % of
#: its time calibrating.
COMPILED_UNMEASURED_PATHS = 1 << 22
#: Seconds building the compiled package takes when it is not cached (measured 45 s of CPU, up
#: to 2 min on the loaded 2-core machine): renders whose eager time exceeds this plus their
#: compiled time build it first.
AOT_BUILD_S = 90.0


#: Disk bytes per pixel and frame at most: 16 float32 EXR channels (ZIP never grows them much)
#: and the 8-bit RGB preview.
OUTPUT_BYTES_PER_PIXEL = 16 * 4 + 3


def _check_args(args: argparse.Namespace) -> tuple[int, int, Path]:
    """Every check of ``bnerr render`` that needs no rendering: numbers, memory, output folder."""

    if Path(args.out).suffix.lower() in IMAGE_SUFFIXES:
        # A folder named frame.png would hold frame.png/direct_0.exr: the user meant a file.
        raise FileFormatError(
            f"--out {args.out}: expected a folder (frames are written as DIR/<scene>_<t>.exr and "
            f"DIR/<scene>_<t>.png), got a name ending in {Path(args.out).suffix}"
        )
    width, height = parse_resolution(args.res)
    check_positive_int(args.spp, "--spp")
    check_positive_int(args.frames, "--frames")
    check_positive_int(args.start, "--start", minimum=0)
    if args.strategy is None and args.seed_set is not None:
        raise ValueRangeError(
            f"--seed-set: expected it with --strategy only, got --seed-set {args.seed_set}"
        )
    if args.strategy is not None and args.seed is not None:
        raise ValueRangeError(
            f"--seed: expected no --seed with --strategy (the strategy's seeds come from "
            f"--seed-set), got --seed {args.seed}"
        )
    if args.seed_set is not None:
        check_positive_int(args.seed_set, "--seed-set", minimum=0)
    if args.sampler is not None:  # a plug-in spec loaded, registered and named
        args.sampler = check_name(load_sampler(args.sampler), per_pixel_samplers(), "--sampler")
    check_memory(render_bytes(width, height), f"--res {width}x{height}")
    need = OUTPUT_BYTES_PER_PIXEL * width * height * args.frames
    return width, height, check_output(args.out, "dir", need_bytes=need)


def compile_choice(args: argparse.Namespace, width: int, height: int) -> bool | StageSource:
    """The vertex stage to run, as :func:`renderers.render`'s ``compile``: eager (False) or the
    ahead-of-time compiled package (:func:`renderers.aot.stage`).

    ``--no-compile``: eager; ``--compile``: the package, built first if it is not cached. Else
    eager with ``--strategy`` (the benchmark's path) and below :data:`AUTO_COMPILE_PATHS` paths
    in all; above, the package when it is cached, and when it is not, whichever is faster:
    building it now (:data:`AOT_BUILD_S`) and rendering compiled, or rendering eagerly while a
    background process builds it for the next render (``args.build_later``)."""
    args.build_later = False
    if args.compile is not None:
        return aot.stage if args.compile else False
    paths = width * height * args.spp * args.frames
    if args.strategy is not None or paths < AUTO_COMPILE_PATHS:
        return False
    if aot.has_package(args.scene, args.static):
        return aot.stage
    eager = estimate_seconds(get_scene(args.scene, animated=not args.static), paths)
    if eager > AOT_BUILD_S + eager / COMPILE_SPEEDUP:
        return aot.stage
    args.build_later = os.environ.get("BNERR_BACKGROUND_BUILD", "1") != "0"
    return False


def _check_time(
    args: argparse.Namespace, scene: Scene, strategy: Strategy | None, width: int, height: int
) -> None:
    """Estimate the render's time from the tracer's throughput measured on this machine
    (:mod:`renderers.budget`): refuse it beyond :data:`TIME_LIMIT_S` unless ``--force``, print
    the estimate beyond :data:`SHOW_ESTIMATE_S`. Counts every render: a stateful strategy's
    unwritten frames before ``--start`` and the oracle's K renders per frame."""
    if args.force:
        return
    frames = range(args.start, args.start + args.frames)
    first = args.start if strategy is None else first_frame(strategy, frames)
    renders = getattr(strategy, "K", 1)  # the oracle renders K candidates per frame
    paths = width * height * args.spp * (frames.stop - first) * renders
    what = f"--res {width}x{height} --spp {args.spp} --frames {args.frames}"
    compiled = bool(args.compile_now)
    if compiled and paths < COMPILED_UNMEASURED_PATHS:
        return  # seconds at most: the calibration (0.2-0.3 s) would cost more than it tells
    seconds = check_render_time(scene, paths, what, limit_s=TIME_LIMIT_S, compile=compiled)
    if seconds > SHOW_ESTIMATE_S:
        print(f"bnerr render: estimated {format_seconds(seconds)} ({paths:.3g} paths)", flush=True)


def _report(
    stem: Path, elapsed: float, width: int, height: int, spp: int, scene: Scene, path: str
) -> None:
    elapsed = max(elapsed, 1e-9)
    rate = width * height * spp / elapsed / 1e6
    tqdm.write(  # above the progress bar, if there is one
        f"{stem}.exr  {width}x{height} {spp} spp D={scene.dimensions} "
        f"{elapsed:.2f} s ({rate:.2f} M samples/s, {path})",
        file=sys.stdout,
    )


#: ``(t, frame, seconds)`` of the frames a render writes.
_Frames = Iterator[tuple[int, Frame, float]]


def _fixed_seed_frames(args: argparse.Namespace, scene: Scene, height: int, width: int) -> _Frames:
    """``(t, frame, seconds)`` of the fixed-seed renders: every frame its own seed image."""

    sampler = make_sampler(args.sampler or "white")
    seed = args.seed or 0
    for t in range(args.start, args.start + args.frames):
        seeds = pixel_seeds(height, width, (seed * 100003 + t) * height * width)
        start = time.perf_counter()
        frame = render(scene, t, seeds, sampler, args.spp, compile=args.compile_now)
        yield t, frame, time.perf_counter() - start


def _strategy_frames(args: argparse.Namespace, strategy: Strategy, scene: Scene) -> _Frames:
    """``(t, frame, seconds)`` of ``strategy``'s frames ``--start ..``, played as the benchmark
    plays them (:func:`bnerr.strategies.play`, the renderer's frame t): a stateful strategy's
    earlier frames are rendered, not yielded, and not counted in the seconds."""

    def render_at(k: int) -> Callable[[torch.Tensor, Sampler], Frame]:
        return functools.partial(render, scene, k, spp=args.spp, compile=args.compile_now)

    shown = range(args.start, args.start + args.frames)
    start = time.perf_counter()
    for t, frame in play(strategy, render_at, shown):
        if t >= args.start:
            yield t, frame, time.perf_counter() - start
        start = time.perf_counter()


def run(args: argparse.Namespace) -> int:

    width, height, out = _check_args(args)
    scene = get_scene(args.scene, animated=not args.static)
    if renders_itself(scene):  # a Mitsuba XML scene: Mitsuba renders, the tracer's stage is moot
        args.compile_now, args.build_later = False, False
    else:
        args.compile_now = compile_choice(args, width, height)
    strategy = None
    if args.strategy is None:
        frames = _fixed_seed_frames(args, scene, height, width)
    else:  # built before the lock: a bad name or spp is refused before anything is written
        strategy = make_strategy(
            args.strategy,
            height,
            width,
            seed=args.seed_set or 0,
            sampler=args.sampler or "owen_sobol",
            spp=args.spp,
            dimensions=scene.dimensions,
        )
        frames = _strategy_frames(args, strategy, scene)
    _check_time(args, scene, strategy, width, height)
    quiet = args.no_progress or args.frames < 2
    with (
        output_lock(out, "bnerr render"),
        tqdm(
            total=args.frames, unit="frame", disable=quiet, dynamic_ncols=True, file=sys.stderr
        ) as bar,
    ):
        clean_stale_temporaries(out)
        for t, frame, seconds in frames:
            stem = out / f"{scene.name}_{t:04d}"
            write_frame(stem.with_suffix(".exr"), frame)
            write_png(stem.with_suffix(".png"), frame.color, exposure=args.exposure)
            path = "compiled" if args.compile_now else "eager"
            path = "mitsuba" if renders_itself(scene) else path
            _report(stem, seconds, width, height, args.spp, scene, path)
            bar.update(1)
    if args.build_later:
        aot.start_background_build(args.scene, args.static)
        print(
            f"bnerr render: building the compiled tracer for {scene.name} in the background "
            f"(about a minute, niced; BNERR_BACKGROUND_BUILD=0 turns this off): later renders "
            f"of it start compiled"
        )
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "render",
        help="render frames of a named scene to EXR (+ PNG preview)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "--scene",
        required=True,
        help="scene name (see: bnerr scenes), scene file (.toml, .json) or plug-in "
        "(pkg.mod:make_scene, path/file.py:make_scene)",
    )
    p.add_argument("--res", default="256x256", metavar="WxH", help="resolution (default 256x256)")
    p.add_argument("--spp", type=positive_int, default=16, help="samples per pixel (default 16)")
    p.add_argument("--frames", type=positive_int, default=1, help="number of frames (default 1)")
    p.add_argument(
        "--start", type=nonnegative_int, default=0, help="first frame index t (default 0)"
    )
    p.add_argument(
        "--sampler",
        metavar="NAME",
        help="per-pixel sequence: white, owen_sobol or a plug-in (pkg.mod:Cls, path/file.py:Cls) "
        "(default white; owen_sobol with --strategy, the benchmark's condition)",
    )
    p.add_argument("--seed", type=seed_int, help="seed-image key without --strategy (default 0)")
    p.add_argument(
        "--strategy",
        metavar="NAME",
        help="render with a seed strategy (temporal, white, zsobol_t..., or a plug-in: "
        "pkg.mod:Cls, path/file.py:Cls), its state carried from frame to frame: the frames "
        "bnerr bench renders for --seed-set",
    )
    p.add_argument(
        "--seed-set", type=seed_int, help="the strategy's seed set, as in bnerr bench (default 0)"
    )
    p.add_argument("--static", action="store_true", help="the scene's static variant (no motion)")
    p.add_argument(
        "--compile",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the compiled tracer, built first if needed (default: from 2^21 paths in all if "
        "built, not with --strategy)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help=f"render even if the estimated time exceeds {TIME_LIMIT_S / 3600:.0f} h",
    )
    p.add_argument("--exposure", type=EXPOSURE, default=0.0, help="PNG preview exposure in stops")
    p.add_argument(
        "--no-progress", action="store_true", help="no progress bar (shown from 2 frames on stderr)"
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.set_defaults(func=run, fast_exit=True)  # benchmarks.cli.entry: no teardown to wait for
