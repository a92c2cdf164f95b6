"""Time each denoiser on a 1920 x 1080 frame: ``python -m benchmarks.speed.denoise``.

The frame is synthetic (random color, albedo, normal, depth, motion, object id): the filters' and
networks' cost does not depend on the image content. Each denoiser runs once to warm up
(allocations, OIDN's device, oneDNN's kernel choice) and then ``repeats`` times; the median is
reported. A stateful denoiser (TAA, SVGF) is reset first and then fed the frame as one sequence,
so the timed calls reproject a history, as every frame of a sequence but its first does.
Denoisers whose optional extra is missing are skipped and reported as such.

Timings depend on the machine and on what else runs on it; report them with the machine.
"""

from __future__ import annotations

import argparse
import inspect
import math
import statistics
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import torch

from benchmarks.reports.markdown import table_lines
from benchmarks.speed.formatting import fmt, number, ratio
from bnerr.errors import FileFormatError, MissingExtraError
from bnerr.frame import Frame
from bnerr.timing import Stopwatch
from denoisers import DENOISERS, get_denoiser

__all__ = ["GOALS", "goal_met", "table", "main", "measure", "synthetic_frame"]

#: The goals of issue 27 at 1080p: ``{name: (bound, anchored)}``, at most ``bound`` seconds per
#: frame (``anchored`` False) or ``bound`` times OIDN's time in the same run (True).
GOALS: dict[str, tuple[float, bool]] = {"atrous": (0.5, False), "unet": (0.7, True)}


def synthetic_frame(height: int = 1080, width: int = 1920, seed: int = 0) -> Frame:
    """A random frame with every buffer a denoiser may read (color, albedo, normal, depth, motion
    ``[2, H, W]`` of at most half a pixel, object_id ``[1, H, W]`` all 0)."""
    g = torch.Generator().manual_seed(seed)
    return Frame(
        color=torch.rand(3, height, width, generator=g).square() * 4.0,
        albedo=torch.rand(3, height, width, generator=g),
        normal=torch.nn.functional.normalize(torch.randn(3, height, width, generator=g), dim=0),
        depth=torch.rand(1, height, width, generator=g) + 1.0,
        motion=torch.rand(2, height, width, generator=g) - 0.5,
        object_id=torch.zeros(1, height, width),
    )


def measure(
    names: Sequence[str] | None = None,
    height: int = 1080,
    width: int = 1920,
    repeats: int = 3,
) -> dict[str, float | None]:
    """Median seconds per frame of each denoiser (default parameters) at ``height x width``.

    Returns ``{name: seconds}``; None for a denoiser that could not be built here (a missing extra
    or missing weights).
    """
    frame = synthetic_frame(height, width)
    results: dict[str, float | None] = {}
    for name in names if names is not None else list(DENOISERS):
        try:
            denoiser = get_denoiser(name)
        except (MissingExtraError, FileFormatError):
            results[name] = None
            continue
        denoiser.reset()
        denoiser(frame, t=0)  # warm-up (and a stateful one's first frame: no history yet)
        times = []
        for t in range(1, repeats + 1):
            watch = Stopwatch()
            out = denoiser(frame, t=t)
            times.append(watch.ms(out) / 1e3)
        results[name] = statistics.median(times)
    return results


def goal_met(name: str, seconds: Any, oidn: Any) -> str:
    """The goal of ``name`` ("0.5 s", "0.7x OIDN") and whether ``seconds`` met it ("-" for a
    denoiser without a goal or a missing figure)."""
    if name not in GOALS:
        return "-"
    bound, anchored = GOALS[name]
    s, anchor = number(seconds), number(oidn)
    goal = f"{fmt(bound)}x OIDN" if anchored else f"{fmt(bound)} s"
    if anchored:
        limit = None if anchor is None else bound * anchor
    else:
        limit = bound
    if s is None or limit is None:
        return f"{goal}: -"
    return f"{goal}: {'yes' if s <= limit else 'no'}"


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The denoisers against OIDN."""
    defaults = inspect.signature(measure).parameters
    height, width = defaults["height"].default, defaults["width"].default
    anchor = values.get("oidn")
    lines = [
        "## Denoisers against OIDN (`speed.denoise`)",
        "",
        f"Median seconds per {width} x {height} frame of each denoiser with its default "
        "parameters (a stateful one with its history); ratio: over OIDN's time in the same run "
        '(below 1: faster than OIDN). "-": not available on the machine that ran it. Goals of '
        "issue 27: a-trous at most 0.5 s, the U-Net at most 0.7x OIDN's time.",
        "",
    ]
    rows = []
    for name, seconds in sorted(values.items(), key=lambda kv: number(kv[1]) or math.inf):
        s = number(seconds)
        rows.append(
            [name, fmt(s), fmt(None if s is None else 1 / s), ratio(s, anchor)]
            if name != "oidn"
            else [name, fmt(s), fmt(None if s is None else 1 / s), "1 (anchor)"]
        )
        rows[-1].append(goal_met(name, s, anchor))
    header = ["denoiser", "s / frame", "frames / s", "/ OIDN", "goal met"]
    return lines + table_lines(header, rows) + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.denoise", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--size", nargs=2, type=int, default=(1920, 1080), metavar=("W", "H"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--denoiser", action="append", help="only these (repeatable)")
    args = parser.parse_args(argv)
    width, height = args.size
    print(
        f"denoise time at {width}x{height}, {torch.get_num_threads()} torch threads, "
        f"median of {args.repeats}"
    )
    for name, seconds in measure(args.denoiser, height, width, args.repeats).items():
        print(f"  {name:16s} {'unavailable' if seconds is None else f'{seconds:8.3f} s'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
