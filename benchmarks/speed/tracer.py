"""Renderer throughput against Mitsuba 3: ``python -m benchmarks.speed.tracer``.

Renders the same frame (our scene exported with :func:`renderers.mitsuba.to_mitsuba`: same
camera, geometry, materials, lights, box filter and max depth, Russian roulette off) with our
tracer and with Mitsuba 3's ``scalar_rgb`` and ``llvm_ad_rgb`` variants, and reports samples
(pixels x spp) per second for each, and our ratio to each. The work differs in one way that
favours Mitsuba slightly: it traces one more ray per path (a BSDF sample at the last vertex).

Our tracer runs its vertex stage as ``compile`` says: ``"aot"`` (the default), the ahead-of-time
compiled package that ``bnerr render`` loads (:mod:`renderers.aot`; built before the timing if
missing); ``"torch"``, ``torch.compile`` in the process (the benchmark's references); or
``"eager"``. Each renderer gets one warm-up render (our loading or compilation, Mitsuba's LLVM
kernel compilation),
then ``repeats`` rounds; a round renders once with each renderer, back to back, so that the
load of a shared machine, which drifts over seconds, hits the renderers of a round alike. Each
Mitsuba variant lives in its own subprocess for the whole measurement (it answers "render" on
stdin with the seconds it took), so that a missing or crashing LLVM (LLVM 15 and 16 crash on
some processors; Debian's libllvm19 works, found through ``DRJIT_LIBLLVM_PATH``) is reported as an
error string instead of ending the benchmark; without Mitsuba the Mitsuba entries say so.
Reported: each renderer's fastest and median time, samples per second at the fastest, and the
median over rounds of our per-round speed ratio.

Both sides use the threads they are given: torch's thread count for us (``threads``, default:
torch's current setting; the tracer runs that many chunks at once), drjit's thread pool for
Mitsuba (default: all cores, or ``threads``). Timings depend on the machine and on its load:
report them with both.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import torch

from benchmarks.reports.markdown import table_lines
from benchmarks.resolution import parse_resolution
from benchmarks.speed.formatting import DASH, fmt, number
from bnerr.errors import UnknownNameError
from bnerr.io import atomic_write
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds
from renderers import aot, get_scene, render
from renderers.mitsuba import mitsuba_available, to_mitsuba
from renderers.tracer import StageSource

__all__ = ["table", "main", "measure", "measure_mitsuba", "measure_ours"]

DEFAULT_LLVM = "/lib/x86_64-linux-gnu/libLLVM.so.19.1"
#: How our vertex stage runs: the name -> :func:`renderers.render`'s ``compile`` argument.
STAGES: dict[str, bool | StageSource] = {"aot": aot.stage, "torch": True, "eager": False}

#: The table's words for each stage.
_STAGE_WORDS = {
    "aot": "the AOT-compiled package `bnerr render` loads",
    "torch": "torch.compile",
    "eager": "eager",
}


def _stage(compile: str) -> bool | StageSource:
    """:data:`STAGES`' entry, or :class:`~bnerr.errors.UnknownNameError` naming the choices."""
    if compile not in STAGES:
        raise UnknownNameError(f"compile: expected one of {sorted(STAGES)}, got {compile!r}")
    return STAGES[compile]


def _figures(times: list[float], warmup: float, samples: int) -> dict[str, float]:
    best = min(times)
    return {
        "best_s": best,
        "median_s": statistics.median(times),
        "warmup_s": warmup,
        "samples_per_s": samples / best,
    }


class _Ours:
    """Our tracer on one scene: ``warm()`` once, then ``__call__()`` -> seconds per render."""

    def __init__(
        self,
        scene_name: str,
        width: int,
        height: int,
        spp: int,
        compile: str,
        sampler: str = "white",
    ) -> None:
        self.scene = get_scene(scene_name, animated=False)
        self.seeds = pixel_seeds(height, width, 0)
        self.sampler = make_sampler(sampler)
        self.spp, self.compile = spp, _stage(compile)

    def __call__(self) -> float:
        """Seconds of one render, by the renderer's own clock (its frame's ``timings``)."""
        frame = render(self.scene, 0, self.seeds, self.sampler, self.spp, compile=self.compile)
        return frame.timings["render"] / 1e3


class _Mitsuba:
    """A Mitsuba variant in a subprocess that renders the scene on request."""

    def __init__(
        self,
        variant: str,
        scene_name: str,
        width: int,
        height: int,
        spp: int,
        threads: int | None,
        timeout: float,
    ) -> None:
        self.variant, self.timeout = variant, timeout
        self.error: str | None = None
        self.proc: subprocess.Popen[str] | None = None
        self.warmup = 0.0
        if not mitsuba_available():
            self.error = "mitsuba is not installed (pip install 'bnerr[reference]')"
            return
        env = dict(os.environ)
        if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in env:
            if not Path(DEFAULT_LLVM).exists():
                self.error = (
                    f"no LLVM for drjit: install Debian's libllvm19 ({DEFAULT_LLVM}) "
                    "or set DRJIT_LIBLLVM_PATH"
                )
                return
            env["DRJIT_LIBLLVM_PATH"] = DEFAULT_LLVM
        args = [
            sys.executable,
            "-m",
            "benchmarks.speed.tracer",
            "--serve",
            variant,
            scene_name,
            str(width),
            str(height),
            str(spp),
            str(threads or 0),
        ]
        # stderr to a file: a full pipe would block a chatty child while we wait on stdout.
        self.stderr = tempfile.TemporaryFile(mode="w+")
        self.proc = subprocess.Popen(
            args,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.stderr,
            text=True,
            env=env,
            cwd=Path(__file__).resolve().parent.parent,
        )
        reply = self._read()
        if reply is not None:
            self.warmup = reply

    def _child(self) -> tuple[subprocess.Popen[str], IO[str], IO[str]]:
        """The child and its stdin and stdout pipes: there whenever ``error`` is None."""
        proc = self.proc
        assert proc is not None and proc.stdin is not None and proc.stdout is not None
        return proc, proc.stdin, proc.stdout

    def _read(self) -> float | None:
        proc, _, stdout = self._child()
        line = stdout.readline()
        try:
            return float(line)
        except ValueError:
            proc.kill()
            proc.wait(timeout=self.timeout)
            self.stderr.seek(0)
            err = self.stderr.read()
            tail = (err or line).strip().splitlines()[-1:] or [f"exit code {proc.returncode}"]
            self.error = f"{self.variant} failed (exit code {proc.returncode}): {tail[0]}"
            return None

    def __call__(self) -> float | None:
        if self.error is not None:
            return None
        _, stdin, _ = self._child()
        stdin.write("render\n")
        stdin.flush()
        return self._read()

    def close(self) -> None:
        if self.proc is not None:
            if self.proc.poll() is None:
                _, stdin, _ = self._child()
                stdin.close()
                self.proc.wait(timeout=self.timeout)
            self.stderr.close()


def _serve(
    variant: str, scene_name: str, width: int, height: int, spp: int, threads: int | None
) -> None:
    """Runs inside the subprocess: load the scene, render once, then once per ``render`` line."""
    import drjit as dr  # the optional 'reference' extra, in the subprocess only
    import mitsuba as mi

    mi.set_variant(variant)
    if threads:
        dr.set_thread_count(threads)  # Mitsuba 3 renders on drjit's thread pool in every variant
    scene = mi.load_dict(
        to_mitsuba(get_scene(scene_name, animated=False), 0, width=width, height=height, spp=spp)
    )
    seed = 0

    def timed() -> float:
        nonlocal seed
        start = time.perf_counter()
        image = mi.render(scene, spp=spp, seed=seed)  # type: ignore[arg-type]  # stubs: UInt32
        dr.eval(image)  # the LLVM variant is lazy: wait for its kernels
        dr.sync_thread()
        seed += 1
        return time.perf_counter() - start

    print(timed(), flush=True)
    for line in sys.stdin:
        if line.strip() == "render":
            print(timed(), flush=True)


def measure_ours(
    scene_name: str,
    width: int,
    height: int,
    spp: int,
    repeats: int = 3,
    compile: str = "aot",
    sampler: str = "white",
) -> dict[str, float]:
    """Our tracer alone: ``{"best_s", "median_s", "warmup_s", "samples_per_s"}``."""
    ours = _Ours(scene_name, width, height, spp, compile, sampler)
    warmup = ours()
    return _figures([ours() for _ in range(repeats)], warmup, width * height * spp)


def measure_mitsuba(
    variant: str,
    scene_name: str,
    width: int,
    height: int,
    spp: int,
    repeats: int = 3,
    threads: int | None = None,
    timeout: float = 900.0,
) -> dict[str, float] | str:
    """One Mitsuba variant alone: figures as :func:`measure_ours`, or an error string."""
    worker = _Mitsuba(variant, scene_name, width, height, spp, threads, timeout)
    try:
        times: list[float] = []
        while worker.error is None and len(times) < repeats:
            seconds = worker()
            if seconds is not None:  # else the worker failed: its error says why
                times.append(seconds)
        if worker.error is not None:
            return worker.error
        return _figures(times, worker.warmup, width * height * spp)
    finally:
        worker.close()


def _scene_row(
    name: str,
    width: int,
    height: int,
    spp: int,
    repeats: int,
    compile: str,
    variants: Sequence[str],
    threads: int | None,
) -> dict[str, object]:
    """One scene's figures: ours and each Mitsuba variant's, rendered in interleaved rounds."""
    ours = _Ours(name, width, height, spp, compile)
    ours_warmup = ours()
    workers = {v: _Mitsuba(v, name, width, height, spp, threads, 900.0) for v in variants}
    ours_times: list[float] = []
    their_times: dict[str, list[float]] = {v: [] for v in variants}
    ratios: dict[str, list[float]] = {v: [] for v in variants}
    try:
        for _ in range(repeats):
            mine = ours()
            ours_times.append(mine)
            for v, worker in workers.items():
                theirs = worker()
                if theirs is not None:
                    their_times[v].append(theirs)
                    ratios[v].append(theirs / mine)
    finally:
        for worker in workers.values():
            worker.close()
    samples = width * height * spp
    row: dict[str, object] = {"bnerr": _figures(ours_times, ours_warmup, samples)}
    for v, worker in workers.items():
        ok = worker.error is None and their_times[v]
        row[f"mitsuba_{v}"] = (
            _figures(their_times[v], worker.warmup, samples) if ok else worker.error
        )
        row[f"ratio_{v}"] = statistics.median(ratios[v]) if ok else None
    return row


def measure(
    scenes: Sequence[str] = ("direct", "cornell"),
    width: int = 256,
    height: int = 256,
    spp: int = 32,
    repeats: int = 5,
    compile: str = "aot",
    variants: Sequence[str] = ("scalar_rgb", "llvm_ad_rgb"),
    threads: int | None = None,
) -> dict[str, Any]:
    """Throughput of our tracer and of Mitsuba 3 on each scene, in interleaved rounds.

    Returns ``{"settings": {...}, scene: {"bnerr": figures, "mitsuba_<variant>": figures or an
    error string, "ratio_<variant>": median over rounds of Mitsuba's time / ours (our speed-up;
    None if Mitsuba failed)}}``, figures being ``{"best_s", "median_s", "warmup_s",
    "samples_per_s"}`` (samples per second at the best time).
    """
    _stage(compile)
    before = torch.get_num_threads()
    if threads:
        torch.set_num_threads(threads)
    out: dict[str, object] = {
        "settings": {
            "width": width,
            "height": height,
            "spp": spp,
            "repeats": repeats,
            "compile": compile,
            "torch_threads": torch.get_num_threads(),
            "cpu_count": os.cpu_count(),
            "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        }
    }
    try:
        for name in scenes:
            out[name] = _scene_row(name, width, height, spp, repeats, compile, variants, threads)
    finally:
        torch.set_num_threads(before)
    return out


def _print(result: Mapping[str, Any]) -> None:
    settings = result["settings"]
    print(
        f"# {settings['width']}x{settings['height']} at {settings['spp']} spp, "
        f"{settings['repeats']} interleaved rounds, torch threads {settings['torch_threads']}, "
        f"compile {settings['compile']}, load average {settings['load_average']}"
    )
    for name, row in result.items():
        if name == "settings":
            continue
        for key, value in row.items():
            if isinstance(value, dict):
                print(
                    f"{name:8s} {key:22s} {value['samples_per_s'] / 1e6:8.3f} M samples/s "
                    f"(best {value['best_s']:.3f} s, median {value['median_s']:.3f} s, "
                    f"warm-up {value['warmup_s']:.1f} s)"
                )
            elif key.startswith("ratio"):
                shown = "n/a" if value is None else f"{value:8.2f}x"
                print(f"{name:8s} {key:22s} {shown} (median per round)")
            else:
                print(f"{name:8s} {key:22s} {value}")


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The tracer against Mitsuba 3's variants."""
    s = values.get("settings", {})
    stage = _STAGE_WORDS.get(s.get("compile"), str(s.get("compile")))
    lines = [
        "## Tracer against Mitsuba 3 (`speed.tracer`)",
        "",
        f"{s.get('width')} x {s.get('height')} pixels at {s.get('spp')} spp, {s.get('repeats')} "
        f"interleaved rounds, our vertex stage: {stage}, {s.get('torch_threads')} torch "
        f"threads on {s.get('cpu_count')} CPUs, load average {fmt(s.get('load_average'), 2)} "
        "at the start. Times in seconds per frame; first call: the warm-up render (our "
        "compilation, Mitsuba's kernel compilation). Ratio: our time over the variant's, the "
        "median over rounds (below 1: ours is faster).",
        "",
    ]
    rows = []
    for scene, row in values.items():
        if scene == "settings" or not isinstance(row, Mapping):
            continue
        for renderer in ("bnerr", "mitsuba_scalar_rgb", "mitsuba_llvm_ad_rgb"):
            got = row.get(renderer)
            ratio = row.get(f"ratio_{renderer.removeprefix('mitsuba_')}")
            speedup = number(ratio)
            inverse = DASH if not speedup else f"{fmt(1 / speedup)}x"
            name = "bnerr" if renderer == "bnerr" else f"Mitsuba {renderer[8:]}"
            if not isinstance(got, Mapping):
                note = DASH if got is None else f"failed: {got}"
                rows.append([scene, name, note, DASH, DASH, DASH, DASH])
                continue
            rate = number(got.get("samples_per_s"))
            rows.append(
                [
                    scene,
                    name,
                    fmt(got.get("best_s")),
                    fmt(got.get("median_s")),
                    fmt(got.get("warmup_s")),
                    fmt(None if rate is None else rate / 1e6),
                    "1 (ours)" if renderer == "bnerr" else inverse,
                ]
            )
    header = ["scene", "renderer", "best s", "median s", "first call s", "Msamples/s"]
    return lines + table_lines(header + ["ours / this"], rows) + [""]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--serve"]:
        variant, scene, w, h, spp, threads = argv[1:7]
        _serve(variant, scene, int(w), int(h), int(spp), int(threads) or None)
        return 0
    p = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.tracer", description=__doc__.split("\n\n")[0]
    )
    p.add_argument("--scenes", nargs="+", default=["direct", "cornell"])
    p.add_argument("--res", default="256x256", metavar="WxH")
    p.add_argument("--spp", type=int, default=32)
    p.add_argument("--repeats", type=int, default=5, help="interleaved rounds")
    p.add_argument("--threads", type=int, default=None, help="threads for both renderers")
    p.add_argument(
        "--compile", choices=sorted(STAGES), default="aot",
        help="our vertex stage: the AOT package bnerr render loads (default), torch.compile, "
        "or eager",
    )  # fmt: skip
    p.add_argument("--variants", nargs="*", default=["scalar_rgb", "llvm_ad_rgb"])
    p.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = p.parse_args(argv)
    width, height = parse_resolution(args.res)
    result = measure(
        args.scenes,
        width,
        height,
        args.spp,
        args.repeats,
        args.compile,
        args.variants,
        args.threads,
    )
    _print(result)
    if args.json:
        with atomic_write(args.json) as tmp:
            Path(tmp).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
