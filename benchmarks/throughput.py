"""Renderer throughput against Mitsuba 3: ``python -m benchmarks.throughput``.

Renders the same frame (our scene exported with :func:`renderers.mitsuba.to_mitsuba`: same
camera, geometry, materials, lights, box filter and max depth, Russian roulette off) with our
tracer and with Mitsuba 3's ``scalar_rgb`` and ``llvm_ad_rgb`` variants, and reports samples
(pixels x spp) per second for each, and our ratio to each. The work differs in one way that
favours Mitsuba slightly: it traces one more ray per path (a BSDF sample at the last vertex).

Each renderer gets one warm-up render (our ``torch.compile``, Mitsuba's LLVM kernel compilation)
and then ``repeats`` timed renders; the figures are from the fastest (the least disturbed by
other processes on a shared machine) and the median. Mitsuba runs in a subprocess per variant, so
that a missing or crashing LLVM (LLVM 15 and 16 crash on some processors; Debian's libllvm19
works, found through ``DRJIT_LIBLLVM_PATH``) is reported as an error string instead of ending the
benchmark; without Mitsuba installed the Mitsuba entries say so.

Both sides use all the threads they are given: torch's intra-op threads for us (``threads``,
default: torch's current setting), Mitsuba's thread pool (default: all cores, or ``threads``).
Timings depend on the machine and on its load: report them with both.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import torch

__all__ = ["main", "measure", "measure_mitsuba", "measure_ours"]

DEFAULT_LLVM = "/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def _seeds(width: int, height: int) -> torch.Tensor:
    from bnerr.strategies import pixel_seeds

    return pixel_seeds(height, width, 0)


def measure_ours(scene_name: str, width: int, height: int, spp: int, repeats: int = 3,
                 compile: bool = True, sampler: str = "white") -> dict[str, float]:
    """Seconds per render of our tracer: ``{"best_s", "median_s", "warmup_s", "samples_per_s"}``."""
    from bnerr.sequences import make_sampler
    from renderers import get_scene, render

    scene = get_scene(scene_name, animated=False)
    seeds = _seeds(width, height)
    s = make_sampler(sampler)
    start = time.perf_counter()
    render(scene, 0, seeds, s, spp, compile=compile)
    warmup = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        render(scene, 0, seeds, s, spp, compile=compile)
        times.append(time.perf_counter() - start)
    best = min(times)
    return {"best_s": best, "median_s": statistics.median(times), "warmup_s": warmup,
            "samples_per_s": width * height * spp / best}


def _mitsuba_worker(variant: str, scene_name: str, width: int, height: int, spp: int,
                    repeats: int, threads: int | None) -> dict[str, float]:
    """Runs inside the subprocess: time ``mi.render`` of the exported scene."""
    import mitsuba as mi

    mi.set_variant(variant)
    from renderers import get_scene
    from renderers.mitsuba import to_mitsuba

    import drjit as dr

    if threads:
        dr.set_thread_count(threads)  # Mitsuba 3 renders on drjit's thread pool in every variant
    scene = mi.load_dict(to_mitsuba(get_scene(scene_name, animated=False), 0,
                                    width=width, height=height, spp=spp))
    def timed(seed: int) -> float:
        start = time.perf_counter()
        image = mi.render(scene, spp=spp, seed=seed)
        dr.eval(image)  # the LLVM variant is lazy: wait for the kernels
        dr.sync_thread()
        return time.perf_counter() - start

    warmup = timed(0)
    times = [timed(k + 1) for k in range(repeats)]
    best = min(times)
    return {"best_s": best, "median_s": statistics.median(times), "warmup_s": warmup,
            "samples_per_s": width * height * spp / best}


def measure_mitsuba(variant: str, scene_name: str, width: int, height: int, spp: int,
                    repeats: int = 3, threads: int | None = None, timeout: float = 900.0
                    ) -> dict[str, float] | str:
    """Mitsuba's figures (as :func:`measure_ours`) from a subprocess, or an error string."""
    from renderers.mitsuba import mitsuba_available

    if not mitsuba_available():
        return "mitsuba is not installed (pip install 'bnerr[reference]')"
    env = dict(os.environ)
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in env:
        if not Path(DEFAULT_LLVM).exists():
            return f"no LLVM for drjit: install Debian's libllvm19 ({DEFAULT_LLVM}) or set DRJIT_LIBLLVM_PATH"
        env["DRJIT_LIBLLVM_PATH"] = DEFAULT_LLVM
    args = [sys.executable, "-m", "benchmarks.throughput", "--worker", variant, scene_name,
            str(width), str(height), str(spp), str(repeats), str(threads or 0)]
    try:
        done = subprocess.run(args, capture_output=True, text=True, timeout=timeout, env=env,
                              cwd=Path(__file__).resolve().parent.parent)
    except subprocess.TimeoutExpired:
        return f"{variant}: timed out after {timeout:.0f} s"
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or [f"exit code {done.returncode}"]
        return f"{variant} failed (exit code {done.returncode}): {tail[0]}"
    return json.loads(lines[-1])


def measure(scenes: Sequence[str] = ("direct", "cornell"), width: int = 256, height: int = 256,
            spp: int = 32, repeats: int = 3, compile: bool = True,
            variants: Sequence[str] = ("scalar_rgb", "llvm_ad_rgb"), threads: int | None = None
            ) -> dict[str, object]:
    """Throughput of our tracer and of Mitsuba 3 on each scene, side by side.

    Returns ``{"settings": {...}, scene: {"bnerr": figures, "mitsuba_<variant>": figures or an
    error string, "ratio_<variant>": ours / Mitsuba's samples per second (None if Mitsuba
    failed)}}``, figures being ``{"best_s", "median_s", "warmup_s", "samples_per_s"}``.
    """
    if threads:
        torch.set_num_threads(threads)
    out: dict[str, object] = {"settings": {
        "width": width, "height": height, "spp": spp, "repeats": repeats, "compile": compile,
        "torch_threads": torch.get_num_threads(), "cpu_count": os.cpu_count(),
        "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }}
    for name in scenes:
        ours = measure_ours(name, width, height, spp, repeats, compile)
        row: dict[str, object] = {"bnerr": ours}
        for variant in variants:
            theirs = measure_mitsuba(variant, name, width, height, spp, repeats, threads)
            row[f"mitsuba_{variant}"] = theirs
            row[f"ratio_{variant}"] = (ours["samples_per_s"] / theirs["samples_per_s"]
                                       if isinstance(theirs, dict) else None)
        out[name] = row
    return out


def _print(result: dict[str, object]) -> None:
    settings = result["settings"]
    print(f"# {settings['width']}x{settings['height']} at {settings['spp']} spp, best of "
          f"{settings['repeats']}, torch threads {settings['torch_threads']}, "
          f"compile {settings['compile']}, load average {settings['load_average']}")
    for name, row in result.items():
        if name == "settings":
            continue
        for key, value in row.items():
            if isinstance(value, dict):
                print(f"{name:8s} {key:22s} {value['samples_per_s'] / 1e6:8.3f} M samples/s "
                      f"(best {value['best_s']:.3f} s, median {value['median_s']:.3f} s, "
                      f"warm-up {value['warmup_s']:.1f} s)")
            elif key.startswith("ratio"):
                print(f"{name:8s} {key:22s} {'n/a' if value is None else f'{value:8.2f}x'}")
            else:
                print(f"{name:8s} {key:22s} {value}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--worker"]:
        variant, scene, w, h, spp, repeats, threads = argv[1:8]
        figures = _mitsuba_worker(variant, scene, int(w), int(h), int(spp), int(repeats), int(threads) or None)
        print(json.dumps(figures))
        return 0
    p = argparse.ArgumentParser(prog="python -m benchmarks.throughput", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", default=["direct", "cornell"])
    p.add_argument("--res", default="256x256", metavar="WxH")
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=None, help="threads for both renderers")
    p.add_argument("--no-compile", dest="compile", action="store_false", help="our tracer in eager mode")
    p.add_argument("--variants", nargs="*", default=["scalar_rgb", "llvm_ad_rgb"])
    p.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = p.parse_args(argv)
    from benchmarks.commands.render import parse_resolution

    width, height = parse_resolution(args.res)
    result = measure(args.scenes, width, height, args.spp, args.repeats, args.compile, args.variants, args.threads)
    _print(result)
    if args.json:
        from bnerr.io import atomic_write

        with atomic_write(args.json) as tmp:
            Path(tmp).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
