"""Time the mask generators: ``python -m benchmarks.speed.masks``.

Scalar void-and-cluster masks (64x64, 128x128; the project's bar is at most 2 s for 128x128) are
timed ``repeats`` times and the median is reported; vector masks (64x64, D = 2, 4, 8, default
``iterations``) take seconds each and are timed once. Each mask's low-frequency energy fraction is
reported with it (white noise: about 0.047 on one 64x64 tile), so a speed-up that costs quality
shows.

The generators are single-threaded numpy: timings depend on the CPU and on what else runs on it;
report them with the machine and its load.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from collections.abc import Mapping, Sequence
from typing import Any

from benchmarks.reports.markdown import table_lines
from benchmarks.speed.formatting import fmt, get, ratio
from bnerr.masks import vector_mask, void_and_cluster
from bnerr.metrics.spectrum import low_frequency_fraction

#: White noise's low-frequency fraction at the masks' cutoff of 0.125 cycles per pixel: the area
#: of the disc of that radius in the unit frequency square, pi / 64.
WHITE_LOW_FREQUENCY = math.pi * 0.125**2

__all__ = ["WHITE_LOW_FREQUENCY", "table", "main", "measure"]


def measure(
    scalar_sizes: Sequence[int] = (64, 128),
    vector_dims: Sequence[int] = (2, 4, 8),
    vector_size: int = 64,
    repeats: int = 3,
) -> dict[str, dict[str, float]]:
    """Seconds to generate each mask, and its low-frequency fraction.

    Returns ``{"scalar_<T>": {"seconds", "low_frequency_fraction"}, "vector_<T>_d<D>": {...}}``;
    scalar seconds are the median of ``repeats`` runs, vector seconds one run.
    """
    results: dict[str, dict[str, float]] = {}
    for size in scalar_sizes:
        start = time.perf_counter()
        mask = void_and_cluster(size)
        times = [time.perf_counter() - start]
        for _ in range(repeats - 1):
            start = time.perf_counter()
            void_and_cluster(size)
            times.append(time.perf_counter() - start)
        results[f"scalar_{size}"] = {
            "seconds": statistics.median(times),
            "low_frequency_fraction": low_frequency_fraction(mask, tile=size),
        }
    for dims in vector_dims:
        start = time.perf_counter()
        mask = vector_mask(vector_size, dims)
        seconds = time.perf_counter() - start
        results[f"vector_{vector_size}_d{dims}"] = {
            "seconds": seconds,
            "low_frequency_fraction": low_frequency_fraction(mask, tile=vector_size),
        }
    return results


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The masks: time to make, low-frequency fraction against white noise's."""
    lines = [
        "## Masks (`speed.masks`)",
        "",
        "Seconds to generate each mask (scalar: void and cluster, median of runs; vector: one "
        "run), and its low-frequency fraction (the energy below 0.125 cycles per pixel) against "
        f"white noise's, pi / 64 = {fmt(WHITE_LOW_FREQUENCY)} (below 1: bluer than white noise).",
        "",
    ]
    rows = []
    for name, row in values.items():
        low = get(row, "low_frequency_fraction")
        size, _, dims = name.partition("_d")
        kind, _, side = size.partition("_")
        shape = f"{kind}, {side} x {side}" + (f", {dims} dims" if dims else "")
        rows.append([shape, fmt(get(row, "seconds")), fmt(low), ratio(low, WHITE_LOW_FREQUENCY)])
    header = ["mask", "seconds", "low-frequency fraction", "/ white noise's"]
    return lines + table_lines(header, rows) + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.masks", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--repeats", type=int, default=3, help="scalar-mask runs (median)")
    parser.add_argument("--no-vector", action="store_true", help="time the scalar masks only")
    args = parser.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"mask generation time, {os.cpu_count()} CPUs, load average {load:.1f}")
    results = measure(vector_dims=() if args.no_vector else (2, 4, 8), repeats=args.repeats)
    for name, figures in results.items():
        print(
            f"  {name:16s} {figures['seconds']:8.3f} s   "
            f"low-frequency fraction {figures['low_frequency_fraction']:.6f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
