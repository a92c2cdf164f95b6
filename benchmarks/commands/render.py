"""``bnerr render``: render frames of a named scene to EXR files with PNG previews.

    bnerr render --scene cornell --res 256x256 --spp 16 --frames 4 --sampler owen_sobol --out out
    bnerr render --scene snooker --res 320x180 --spp 4 --frames 1 --static --out out/snooker

Frame t is written to ``DIR/<scene>_<t>.exr`` (color, albedo, normal, depth, motion, object_id and
variance layers, timings in the header; read it back with ``bnerr.io.read_frame``) and
``DIR/<scene>_<t>.png`` (tone-mapped sRGB preview). Every frame gets its own seed image
(``bnerr.strategies.pixel_seeds`` with a key made of ``--seed`` and t), so frames are independent
white-noise or Owen-Sobol renders; strategies that choose seeds live in ``bnerr bench``.

Before rendering, the resolution is checked against the memory it needs and ``DIR`` against its
kind, writability and free space; while it writes, ``bnerr render`` holds ``DIR``'s lock
(:func:`bnerr.outputs.output_lock`), so a second writer into ``DIR`` refuses.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bnerr.errors import DtypeError, ValueRangeError

__all__ = ["parse_resolution", "register", "render_bytes", "run"]

SAMPLER_NAMES = ("white", "owen_sobol")


def parse_resolution(text: str) -> tuple[int, int]:
    """``"320x240"`` -> ``(320, 240)`` (width, height), both >= 1.

    Raises:
        DtypeError: not of the form ``WxH`` with integers.
        ValueRangeError: a size < 1.
    """
    w, sep, h = str(text).lower().partition("x")
    try:
        width, height = int(w), int(h)
    except ValueError:
        raise DtypeError(
            f"--res: expected WxH with integers (e.g. 320x240), got {text!r}"
        ) from None
    if not sep:
        raise DtypeError(f"--res: expected WxH with integers (e.g. 320x240), got {text!r}")
    if width < 1 or height < 1:
        raise ValueRangeError(f"--res: expected width and height >= 1, got {width}x{height}")
    return width, height


#: Rough peak memory of one frame per pixel: the seeds, the tracer's per-pixel sums and guide
#: buffers, the Frame, and the EXR and PNG writers' copies. Measured at 1024 x 1024 (cornell):
#: 270 B/px at 1 spp, 430 B/px at 4 spp, including the chunks' fixed working set.
RENDER_BYTES_PER_PIXEL = 448
#: The tracer's working set for its chunks of paths, whatever the resolution (rough).
RENDER_FIXED_BYTES = 256 * 2**20
#: Disk bytes per pixel and frame at most: 16 float32 EXR channels (ZIP never grows them much)
#: and the 8-bit RGB preview.
OUTPUT_BYTES_PER_PIXEL = 16 * 4 + 3


def render_bytes(width: int, height: int) -> int:
    """Rough peak memory of rendering and writing one ``width x height`` frame."""
    return RENDER_FIXED_BYTES + RENDER_BYTES_PER_PIXEL * width * height


def _check_args(args: argparse.Namespace) -> tuple[int, int, Path]:
    """Every check of ``bnerr render`` that needs no rendering: numbers, memory, output folder."""
    from bnerr.errors import check_memory, check_positive_int
    from bnerr.outputs import check_output

    width, height = parse_resolution(args.res)
    check_positive_int(args.spp, "--spp")
    check_positive_int(args.frames, "--frames")
    check_positive_int(args.start, "--start", minimum=0)
    check_memory(render_bytes(width, height), f"--res {width}x{height}")
    need = OUTPUT_BYTES_PER_PIXEL * width * height * args.frames
    return width, height, check_output(args.out, "dir", need_bytes=need)


def run(args: argparse.Namespace) -> int:
    from bnerr.io import write_frame, write_png
    from bnerr.outputs import clean_stale_temporaries, output_lock
    from bnerr.sequences import make_sampler
    from bnerr.strategies import pixel_seeds
    from renderers import get_scene, render

    width, height, out = _check_args(args)
    scene = get_scene(args.scene, animated=not args.static)
    sampler = make_sampler(args.sampler)
    with output_lock(out, "bnerr render"):
        clean_stale_temporaries(out)
        for t in range(args.start, args.start + args.frames):
            seeds = pixel_seeds(height, width, (args.seed * 100003 + t) * height * width)
            start = time.perf_counter()
            frame = render(scene, t, seeds, sampler, args.spp, compile=args.compile or None)
            elapsed = time.perf_counter() - start
            stem = out / f"{scene.name}_{t:04d}"
            write_frame(stem.with_suffix(".exr"), frame)
            write_png(stem.with_suffix(".png"), frame.color, exposure=args.exposure)
            rate = width * height * args.spp / elapsed / 1e6
            print(
                f"{stem}.exr  {width}x{height} {args.spp} spp D={scene.dimensions} "
                f"{elapsed:.2f} s ({rate:.2f} M samples/s)"
            )
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "render",
        help="render frames of a named scene to EXR (+ PNG preview)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--scene", required=True, help="scene name (see: bnerr scenes)")
    p.add_argument("--res", default="256x256", metavar="WxH", help="resolution (default 256x256)")
    p.add_argument("--spp", type=int, default=16, help="samples per pixel (default 16)")
    p.add_argument("--frames", type=int, default=1, help="number of frames (default 1)")
    p.add_argument("--start", type=int, default=0, help="first frame index t (default 0)")
    p.add_argument(
        "--sampler", choices=SAMPLER_NAMES, default="white", help="sequence (default white)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed-image key (default 0)")
    p.add_argument("--static", action="store_true", help="the scene's static variant (no motion)")
    p.add_argument(
        "--compile",
        action="store_true",
        help="torch.compile the tracer (faster for large renders; compiles on first use)",
    )
    p.add_argument("--exposure", type=float, default=0.0, help="PNG preview exposure in stops")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.set_defaults(func=run)
