"""Time the mask generators: ``python -m benchmarks.speed_masks``.

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
import os
import statistics
import time
from collections.abc import Sequence

from bnerr.masks import vector_mask, void_and_cluster
from bnerr.spectrum import low_frequency_fraction

__all__ = ["main", "measure"]


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
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            mask = void_and_cluster(size)
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed_masks", description=__doc__.split("\n\n")[0]
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
