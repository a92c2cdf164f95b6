"""The speed suite: each timing script's ``measure()``, written to ``speed.json`` and ``speed.md``.

Each script of the suite (:attr:`benchmarks.suites.Suite.scripts`, e.g.
``benchmarks.speed_permute``) returns its figures as a (nested) dict; :func:`run_speed` stores them
as they come in ``speed.json`` and :func:`speed_markdown` writes ``speed.md``: one table per part,
each figure with its unit and its ratio to the part's anchor:

- the tracer (``throughput``) against Mitsuba 3's ``scalar_rgb`` and ``llvm_ad_rgb`` variants;
- the permutation passes (``speed_permute``) against a memory copy of the bytes each reads and
  writes (``speed_copy``, which :func:`run_speed` runs right after ``speed_permute``, in the same
  run), and the closing-the-gap options (its ``gap`` figures) against the plain sort pass;
- the samplers (``speed_sequences``) against independent ``white`` values;
- the masks (``speed_masks``): the time to make each, and its low-frequency fraction against
  white noise's;
- the denoisers (``speed_denoise``) against OIDN.

A script without a table here is listed figure by figure under its path. A figure the JSON lacks
(a script older than its table, a failed or missing renderer) shows as "-" with a note.

Not for: the per-cell sweeps (:mod:`benchmarks.sweep.runner`).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import math
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from benchmarks.reports.markdown import table_lines
from benchmarks.suites import Suite
from bnerr.errors import FileFormatError
from bnerr.io import atomic_write

__all__ = ["ANCHOR_SCRIPTS", "rewrite_speed_report", "run_speed", "speed_markdown"]

#: Script -> the script that measures its anchor, run right after it by :func:`run_speed` (when
#: the suite does not list it itself), so that both are measured in the same run.
ANCHOR_SCRIPTS: dict[str, str] = {"speed_permute": "speed_copy"}
#: White noise's low-frequency fraction at the masks' cutoff of 0.125 cycles per pixel: the area
#: of the disc of that radius in the unit frequency square, pi / 64.
WHITE_LOW_FREQUENCY = math.pi * 0.125**2
_DASH = "-"


def _jsonable(value: Any) -> Any:
    """``value`` with tensors, numpy scalars, tuples and dataclasses turned into JSON types."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.generic, torch.Tensor)):
        return value.item() if value.ndim == 0 else value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _jsonable(dataclasses.asdict(value))
    return value


def _leaves(value: Any, prefix: str = "") -> Iterable[tuple[str, Any]]:
    """``(path, shown value)`` of every leaf of a nested dict; floats to 6 significant digits."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{prefix}/{key}" if prefix else str(key))
    else:
        yield prefix, (f"{value:.6g}" if isinstance(value, float) else value)


def _summary(measure: Any) -> str:
    """The first paragraph of a ``measure()`` docstring, on one line."""
    return " ".join((measure.__doc__ or "").strip().split("\n\n")[0].split())


# ----------------------------------------------------------------------------------------------
# Formatting


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None (missing, None, a string such as an error)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def _fmt(value: Any, digits: int = 3) -> str:
    """A number to ``digits`` significant digits (no exponent below a million), else "-"."""
    x = _number(value)
    if x is None:
        return _DASH
    if abs(x) < 10**digits:  # rounded first, so that 0.00999... shows as 0.0100
        x = float(f"{x:.{digits - 1}e}")
    if x == 0 or 1e-3 <= abs(x) < 1e6:
        places = max(digits - 1 - math.floor(math.log10(abs(x))), 0) if x else 0
        return f"{x:.{places}f}"
    return f"{x:.{digits - 1}e}"


def _ratio(value: Any, anchor: Any) -> str:
    """``value / anchor`` to 3 significant digits with a times sign, or "-" if either is missing."""
    a, b = _number(value), _number(anchor)
    if a is None or b is None or b == 0:
        return _DASH
    return f"{_fmt(a / b)}x"


def _default(script: str, parameter: str) -> Any:
    """The default of ``parameter`` of ``benchmarks.<script>.measure`` (what the suite ran)."""
    module = importlib.import_module(f"benchmarks.{script}")
    return inspect.signature(module.measure).parameters[parameter].default


def _get(values: Any, *path: str) -> Any:
    """``values[path[0]][path[1]]...``, or None where a level is missing or not a dict."""
    for key in path:
        if not isinstance(values, Mapping):
            return None
        values = values.get(key)
    return values


# ----------------------------------------------------------------------------------------------
# One table per part


def _tracer(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The tracer against Mitsuba 3's variants."""
    s = values.get("settings", {})
    lines = [
        "## Tracer against Mitsuba 3 (`throughput`)",
        "",
        f"{s.get('width')} x {s.get('height')} pixels at {s.get('spp')} spp, {s.get('repeats')} "
        f"interleaved rounds, torch.compile {s.get('compile')}, {s.get('torch_threads')} torch "
        f"threads on {s.get('cpu_count')} CPUs, load average {_fmt(s.get('load_average'), 2)} "
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
            inverse = _DASH if _number(ratio) in (None, 0) else f"{_fmt(1 / ratio)}x"
            name = "bnerr" if renderer == "bnerr" else f"Mitsuba {renderer[8:]}"
            if not isinstance(got, Mapping):
                note = _DASH if got is None else f"failed: {got}"
                rows.append([scene, name, note, _DASH, _DASH, _DASH, _DASH])
                continue
            rate = _number(got.get("samples_per_s"))
            rows.append(
                [
                    scene,
                    name,
                    _fmt(got.get("best_s")),
                    _fmt(got.get("median_s")),
                    _fmt(got.get("warmup_s")),
                    _fmt(None if rate is None else rate / 1e6),
                    "1 (ours)" if renderer == "bnerr" else inverse,
                ]
            )
    header = ["scene", "renderer", "best s", "median s", "first call s", "Msamples/s"]
    return lines + table_lines(header + ["ours / this"], rows) + [""]


def _permutation(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The permutation passes against a memory copy of the same bytes."""
    from benchmarks.speed_copy import JOB_BYTES, PASS_JOBS

    copy = figures.get("speed_copy")
    width, height = _size(values.get("size"))
    names = {
        "sort_pass_lum_ms": "sort pass, luminance key",
        "sort_pass_rgb_ms": "sort pass, color key",
        "torch_path_ms": "sort pass, torch path (fallback)",
        "argsort_ms": "sort pass, reshape + argsort baseline",
        "retarget_ms": "retargeting pass",
        "retarget_torch_ms": "retargeting pass, torch gather indices",
    }
    rows = []
    for key, name in names.items():
        job = PASS_JOBS[key]
        moved = _get(copy, job, "bytes")
        if moved is None and width is not None:
            moved = JOB_BYTES[job] * width * height
        ms = _number(values.get(key))
        rate = None if ms is None or moved is None else moved / (ms * 1e-3) / 1e9
        copy_ms = _get(copy, job, "copy_ms")
        rows.append(
            [
                name,
                _fmt(ms),
                _fmt(None if moved is None else moved / 1e6),
                _fmt(rate),
                _fmt(copy_ms),
            ]
            + [_ratio(ms, copy_ms)]
        )
    rows.append(["mask plan (once per mask offset)", _fmt(values.get("plan_ms"))] + [_DASH] * 4)
    lines = [
        "## Permutation passes against a memory copy (`speed_permute`, `speed_copy`)",
        "",
        f"{values.get('size')}, {values.get('threads')} threads on {values.get('device')}; "
        f"native kernels: {values.get('native')}. Median milliseconds per call over interleaved "
        "rounds. MB moved: the bytes the job reads and writes (`benchmarks/speed_copy.py`: "
        f"sort {JOB_BYTES['sort_lum']} bytes per pixel with a luminance key, "
        f"{JOB_BYTES['sort_rgb']} with a color key, retarget {JOB_BYTES['retarget']}); GB/s: "
        "those bytes over the time; copy: a memory copy of as many bytes, measured in the same "
        "run; ratio: the pass over that copy (1 would be the memory's speed).",
        "",
    ]
    header = ["pass", "ms", "MB moved", "GB/s", "copy ms", "pass / copy"]
    lines += table_lines(header, rows) + [""]
    if copy is None:
        lines += [
            "No memory-copy anchor in these figures: they predate `speed_copy`; the next "
            "`bnerr bench --suite speed` measures it in the same run.",
            "",
        ]
    return lines + _gap(values)


def _size(size: Any) -> tuple[int | None, int | None]:
    """``(width, height)`` from speed_permute's ``"1920x1080, block 4"``, or Nones."""
    try:
        width, height = str(size).split(",")[0].split("x")
        return int(width), int(height)
    except ValueError:
        return None, None


def _gap(values: Mapping[str, Any]) -> list[str]:
    """The closing-the-gap options against the plain sort pass."""
    lines = ["## Closing-the-gap options against the sort pass (`speed_permute`, `gap`)", ""]
    gap = values.get("gap")
    if not isinstance(gap, Mapping) or not gap:
        return lines + [
            "Not in these figures: they predate the timing of the docs/METHODS.md, section 8 "
            "options; the next `bnerr bench --suite speed` measures them.",
            "",
        ]
    anchor = values.get("sort_pass_lum_ms")
    lines += [
        f"{values.get('size')}: median milliseconds per call of each option's extra work "
        "(docs/METHODS.md, section 8); ratio: over the plain sort pass with a luminance key "
        f"({_fmt(anchor)} ms in the same run).",
        "",
    ]
    rows = [[name.removesuffix("_ms"), _fmt(ms), _ratio(ms, anchor)] for name, ms in gap.items()]
    return lines + table_lines(["option", "ms", "option / sort pass"], rows) + [""]


def _samplers(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The samplers against independent white values."""
    lanes = _default("speed_sequences", "n")
    counts = sorted(
        {c for row in values.values() if isinstance(row, Mapping) for c in row}, key=int
    )
    lines = [
        "## Samplers against independent values (`speed_sequences`)",
        "",
        f"Median milliseconds per `sample(seed, index, 0, count, pixel)` call for {lanes:,} "
        "lanes (pixel samples) with `count` dimensions each; Mvalues/s = lanes x count / time; "
        "ratio: the sampler's time over `white`'s (independent hashed values) at the same count.",
        "",
    ]
    header = ["sampler"]
    for c in counts:
        header += [f"ms, {c} dims", f"Mvalues/s, {c} dims", f"/ white, {c} dims"]
    white = values.get("white", {})
    rows = []
    for name, row in values.items():
        cells = [name]
        for c in counts:
            s = _number(_get(row, c))
            cells += [
                _fmt(None if s is None else s * 1e3),
                _fmt(None if s is None else lanes * int(c) / s / 1e6),
                _ratio(s, _get(white, c)),
            ]
        rows.append(cells)
    return lines + table_lines(header, rows) + [""]


def _masks(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The masks: time to make, low-frequency fraction against white noise's."""
    lines = [
        "## Masks (`speed_masks`)",
        "",
        "Seconds to generate each mask (scalar: void and cluster, median of runs; vector: one "
        "run), and its low-frequency fraction (the energy below 0.125 cycles per pixel) against "
        f"white noise's, pi / 64 = {_fmt(WHITE_LOW_FREQUENCY)} (below 1: bluer than white noise).",
        "",
    ]
    rows = []
    for name, row in values.items():
        low = _get(row, "low_frequency_fraction")
        size, _, dims = name.partition("_d")
        kind, _, side = size.partition("_")
        shape = f"{kind}, {side} x {side}" + (f", {dims} dims" if dims else "")
        rows.append(
            [shape, _fmt(_get(row, "seconds")), _fmt(low), _ratio(low, WHITE_LOW_FREQUENCY)]
        )
    header = ["mask", "seconds", "low-frequency fraction", "/ white noise's"]
    return lines + table_lines(header, rows) + [""]


def _denoisers(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The denoisers against OIDN."""
    height, width = _default("speed_denoise", "height"), _default("speed_denoise", "width")
    anchor = values.get("oidn")
    lines = [
        "## Denoisers against OIDN (`speed_denoise`)",
        "",
        f"Median seconds per {width} x {height} frame of each denoiser with its default "
        "parameters (a stateful one with its history); ratio: over OIDN's time in the same run "
        '(below 1: faster than OIDN). "-": not available on the machine that ran it.',
        "",
    ]
    rows = []
    for name, seconds in sorted(values.items(), key=lambda kv: _number(kv[1]) or math.inf):
        s = _number(seconds)
        rows.append(
            [name, _fmt(s), _fmt(None if s is None else 1 / s), _ratio(s, anchor)]
            if name != "oidn"
            else [name, _fmt(s), _fmt(None if s is None else 1 / s), "1 (anchor)"]
        )
    return lines + table_lines(["denoiser", "s / frame", "frames / s", "/ OIDN"], rows) + [""]


_Writer = Callable[[Mapping[str, Any], Mapping[str, Any]], list[str]]
#: Script -> the writer of its table(s); the scripts of :data:`ANCHOR_SCRIPTS`' values are shown
#: in their part's table, not on their own.
_TABLES: dict[str, _Writer] = {
    "throughput": _tracer,
    "speed_permute": _permutation,
    "speed_sequences": _samplers,
    "speed_masks": _masks,
    "speed_denoise": _denoisers,
}


def _listing(script: str, values: Any, summary: str) -> list[str]:
    """A script without a table: every figure under its path."""
    lines = [f"## {script}", ""]
    lines += [summary, ""] if summary else []
    lines += ["| figure | value |", "|---|---|"]
    lines += [f"| {path} | {value} |" for path, value in _leaves(values)]
    return lines + [""]


def speed_markdown(suite: Suite, figures: Mapping[str, Any], summaries: Mapping[str, str]) -> str:
    """The Markdown of ``speed.md``: one table per part, each figure with its unit and its ratio
    to the part's anchor; a script without a table lists its figures (its section headed by
    ``summaries[script]``)."""
    lines = [f"# bnerr bench --suite {suite.name}", "", suite.description, ""]
    anchors = set(ANCHOR_SCRIPTS.values())
    order = {script: i for i, script in enumerate(_TABLES)}
    for script in sorted(figures, key=lambda name: order.get(name, len(order))):
        values = figures[script]
        writer = _TABLES.get(script)
        if script in anchors and any(part in figures for part in ANCHOR_SCRIPTS):
            continue
        if writer is not None and isinstance(values, Mapping):
            lines += writer(values, figures)
        else:
            lines += _listing(script, values, summaries.get(script, ""))
    return "\n".join(lines)


def run_speed(suite: Suite, out_dir: str | Path, *, progress: bool = True) -> str:
    """Call ``measure()`` of every script of the speed suite, each followed by its anchor's
    (:data:`ANCHOR_SCRIPTS`) if the suite does not list that; write ``speed.json`` and
    ``speed.md`` into ``out_dir``; return the Markdown."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, Any] = {}
    summaries: dict[str, str] = {}
    scripts: list[str] = []
    for script in suite.scripts:
        scripts.append(script)
        anchor = ANCHOR_SCRIPTS.get(script)
        if anchor is not None and anchor not in suite.scripts:
            scripts.append(anchor)
    for script in scripts:
        if progress:
            print(f"bnerr bench --suite {suite.name}: {script} ...", flush=True)
        module = importlib.import_module(f"benchmarks.{script}")
        figures[script] = _jsonable(module.measure())
        summaries[script] = _summary(module.measure)
    with atomic_write(out / "speed.json") as tmp:
        Path(tmp).write_text(json.dumps(figures, indent=1, sort_keys=True) + "\n")
    return _write_markdown(suite, out, figures, summaries)


def _write_markdown(
    suite: Suite, out: Path, figures: Mapping[str, Any], summaries: Mapping[str, str]
) -> str:
    text = speed_markdown(suite, figures, summaries)
    with atomic_write(out / "speed.md") as tmp:
        Path(tmp).write_text(text)
    return text


def rewrite_speed_report(suite: Suite, out_dir: str | Path) -> str:
    """Rewrite ``speed.md`` from the figures in ``out_dir/speed.json`` without measuring (after a
    change to the tables); the summaries come from the scripts' ``measure`` docstrings.

    Raises:
        FileFormatError: ``speed.json`` is missing or not the speed suite's JSON object.
    """
    out = Path(out_dir)
    path = out / "speed.json"
    try:
        figures = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise FileFormatError(f"{path}: expected the speed suite's figures, got: {err}") from err
    if not isinstance(figures, dict):
        raise FileFormatError(f"{path}: expected a JSON object, got {type(figures).__name__}")
    known = set(suite.scripts) | set(ANCHOR_SCRIPTS.values())
    unknown = sorted(set(figures) - known)
    if unknown:
        raise FileFormatError(
            f"{path}: expected figures of the scripts {sorted(known)}, got {', '.join(unknown)}"
        )
    summaries = {
        script: _summary(importlib.import_module(f"benchmarks.{script}").measure)
        for script in figures
    }
    return _write_markdown(suite, out, figures, summaries)
