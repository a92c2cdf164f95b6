"""``bnerr render`` as a user runs it, a whole new process, against a Mitsuba 3 LLVM process:
``python -m benchmarks.speed.process``.

Each round runs, one after the other, as new processes and timed from start to exit (wall time):

- **cold**: ``bnerr render --scene S --res WxH --spp N --frames 1`` with empty caches (a fresh
  ``BNERR_CACHE_DIR`` and ``TORCHINDUCTOR_CACHE_DIR``; ``BNERR_BACKGROUND_BUILD=0`` so that no
  build outlives the timing): what a first render on a machine costs;
- **warm**: the same command with the caches a previous render filled (the compiled stage's
  package of :mod:`renderers.aot`, built once before the rounds, untimed);
- **eager**: the same with ``--no-compile``, the path the choice must never be slower than;
- **mitsuba_llvm**: a Python process that imports Mitsuba 3, loads the same scene in its
  ``llvm_ad_rgb`` variant (the scene dictionary of :func:`renderers.mitsuba.to_mitsuba`, handed
  over as JSON so that the process imports neither torch nor bnerr), renders it at the same size
  and spp and writes the image: the anchor.

Reported: each command's fastest and median wall seconds, and the median over rounds of its
per-round ratio to Mitsuba's process. Without Mitsuba (or LLVM) the anchor says why and the
ratios are absent.
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
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from benchmarks.reports.markdown import table_lines
from benchmarks.speed.formatting import DASH, fmt
from benchmarks.speed.tracer import DEFAULT_LLVM
from renderers import get_scene
from renderers.mitsuba import mitsuba_available

__all__ = ["GOALS", "main", "measure", "table"]

#: The goals of issue 27: a process at most this many times Mitsuba LLVM's process.
GOALS = {"warm": 2.0, "cold": 5.0}
_ROOT = Path(__file__).resolve().parent.parent.parent

#: The Mitsuba process: imports Mitsuba only, loads the JSON scene, renders, writes the image.
_MITSUBA = """
import json, sys
import drjit as dr
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
def build(x):
    if isinstance(x, dict):
        if "__matrix__" in x:
            return mi.ScalarAffineTransform4f(x["__matrix__"])
        return {k: build(v) for k, v in x.items()}
    return x
scene = mi.load_dict(build(json.load(open(sys.argv[1]))))
image = mi.render(scene, spp=int(sys.argv[3]))
dr.eval(image)
mi.util.write_bitmap(sys.argv[2], image)
"""


def _plain(value: Any) -> Any:
    """A Mitsuba scene dictionary as JSON types (transforms as ``{"__matrix__": rows}``)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (str, int, float, bool, list)) or value is None:
        return value
    import numpy as np

    return {"__matrix__": np.array(value.matrix, dtype=np.float64).tolist()}


def _mitsuba_job(
    scene_name: str, width: int, height: int, spp: int, folder: Path
) -> tuple[list[str], dict[str, str]] | str:
    """The Mitsuba process's command and environment, or the reason it cannot run."""
    if not mitsuba_available():
        return "mitsuba is not installed (pip install 'bnerr[reference]')"
    env = dict(os.environ)
    if "DRJIT_LIBLLVM_PATH" not in env:
        if not Path(DEFAULT_LLVM).exists():
            return f"no LLVM for drjit: install Debian's libllvm19 ({DEFAULT_LLVM})"
        env["DRJIT_LIBLLVM_PATH"] = DEFAULT_LLVM
    import mitsuba as mi

    from renderers.mitsuba import to_mitsuba

    mi.set_variant("llvm_ad_rgb")
    scene = get_scene(scene_name, animated=False)
    spec = to_mitsuba(scene, 0, width=width, height=height, spp=spp)
    path = folder / "scene.json"
    path.write_text(json.dumps(_plain(spec)))
    cmd = [sys.executable, "-c", _MITSUBA, str(path), str(folder / "mitsuba.exr"), str(spp)]
    return cmd, env


def _timed(cmd: list[str], env: Mapping[str, str]) -> float | str:
    """Wall seconds of the process ``cmd``, or its error's last line."""
    start = time.perf_counter()
    done = subprocess.run(cmd, env=dict(env), cwd=_ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
        return f"exit code {done.returncode}: {tail[0]}"
    return seconds


def _ours(scene: str, width: int, height: int, spp: int, out: Path, *extra: str) -> list[str]:
    cli = [sys.executable, "-m", "benchmarks.cli", "render", "--scene", scene]
    size = ["--res", f"{width}x{height}", "--spp", str(spp), "--frames", "1"]
    return cli + size + ["--static", "--out", str(out), *extra]


def _jobs(scene: str, width: int, height: int, spp: int, folder: Path) -> dict[str, Any]:
    """name -> (command, environment) of each timed process, or the reason it cannot run."""
    base = dict(os.environ, BNERR_BACKGROUND_BUILD="0")
    cold = dict(base, BNERR_CACHE_DIR="", TORCHINDUCTOR_CACHE_DIR="")
    jobs: dict[str, Any] = {
        "cold": (_ours(scene, width, height, spp, folder / "cold"), cold),
        "warm": (_ours(scene, width, height, spp, folder / "warm"), base),
        "eager": (_ours(scene, width, height, spp, folder / "eager", "--no-compile"), base),
        "mitsuba_llvm": _mitsuba_job(scene, width, height, spp, folder),
    }
    return jobs


def _round(jobs: Mapping[str, Any], folder: Path, k: int) -> dict[str, float | str]:
    """One round: each process once; the cold one gets fresh, empty cache folders."""
    times: dict[str, float | str] = {}
    for name, job in jobs.items():
        if isinstance(job, str):
            times[name] = job
            continue
        cmd, env = job
        if name == "cold":
            env = dict(env)
            for var in ("BNERR_CACHE_DIR", "TORCHINDUCTOR_CACHE_DIR"):
                env[var] = tempfile.mkdtemp(prefix=f"cold{k}_", dir=folder)
        times[name] = _timed(cmd, env)
    return times


def _figures(rounds: list[dict[str, float | str]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in rounds[0]:
        ok = [v for r in rounds if isinstance(v := r[name], float)]
        if not ok:
            out[name] = {"error": next(str(r[name]) for r in rounds)}
            continue
        out[name] = {"best_s": min(ok), "median_s": statistics.median(ok), "runs": len(ok)}
        ratios = [
            r[name] / r["mitsuba_llvm"]  # type: ignore[operator]
            for r in rounds
            if isinstance(r[name], float) and isinstance(r.get("mitsuba_llvm"), float)
        ]
        if ratios and name != "mitsuba_llvm":
            out[name]["ratio_to_mitsuba"] = statistics.median(ratios)
    return out


def measure(
    scene: str = "cornell", width: int = 256, height: int = 256, spp: int = 32, repeats: int = 3
) -> dict[str, Any]:
    """Whole-process wall time of ``bnerr render`` (cold, warm and ``--no-compile``) against a
    Mitsuba 3 ``llvm_ad_rgb`` process rendering the same frame, in interleaved rounds."""
    with tempfile.TemporaryDirectory(prefix="bnerr_process_") as tmp:
        folder = Path(tmp)
        jobs = _jobs(scene, width, height, spp, folder)
        build = [sys.executable, "-m", "renderers.aot", scene, "--static"]
        built = _timed(build, dict(os.environ))  # the warm rounds' package (untimed if cached)
        rounds = [_round(jobs, folder, k) for k in range(repeats)]
    figures = _figures(rounds)
    settings = {
        "scene": scene,
        "res": f"{width}x{height}",
        "spp": spp,
        "repeats": repeats,
        "package_build": built,
        "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }
    return {"processes": figures, "settings": settings}


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The speed report's part: each process's wall time and its ratio to Mitsuba's."""
    s = values.get("settings", {})
    lines = ["## `bnerr render` as a new process (speed.process)", ""]
    lines += [
        f"{s.get('scene')} {s.get('res')}, {s.get('spp')} spp, 1 frame; whole processes, wall "
        f"time, {s.get('repeats')} interleaved rounds; load average {s.get('load_average')}. "
        f"Goals: warm at most {GOALS['warm']:g}x, cold at most {GOALS['cold']:g}x the Mitsuba "
        "LLVM process.",
        "",
    ]
    rows = []
    for name, row in values.get("processes", {}).items():
        if "error" in row:
            rows.append([name, DASH, DASH, f"{DASH} ({row['error']})"])
            continue
        ratio = row.get("ratio_to_mitsuba")
        shown = "anchor" if name == "mitsuba_llvm" else (f"{fmt(ratio)}x" if ratio else DASH)
        rows.append([name, fmt(row["best_s"]), fmt(row["median_s"]), shown])
    header = ["process", "best s", "median s", "median ratio to Mitsuba LLVM"]
    return lines + table_lines(header, rows) + [""]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="cornell")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    print(json.dumps(measure(args.scene, repeats=args.repeats), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
