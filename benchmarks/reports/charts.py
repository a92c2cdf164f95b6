"""The PNG charts of a results folder, drawn from the table's rows and the records.

Matplotlib, drawn on ``Figure`` objects with the Agg canvas, no pyplot state; one set per group
(a scene with its condition, :mod:`benchmarks.reports.groups`), whole-image region only:

- ``error_vs_time_<group>.png``: post-denoise MSE against render + permutation + denoise time per
  frame, one line per strategy through its spp values, one panel per denoiser;
- ``spectra_<group>.png``: radially averaged power spectrum of the raw and denoised error per
  strategy;
- ``crops_<group>.png``: reference, raw and denoised crops side by side.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks.reports.groups import group_key, group_slug, group_title, strategy_order
from benchmarks.sweep.records import Record
from bnerr.io import atomic_write

__all__ = ["write_charts"]


def _save(fig, path: Path) -> None:
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")


def _error_vs_time(slug: str, title: str, rows: list[dict], out: Path) -> Path:
    from matplotlib.figure import Figure  # 2 s to import: only when charts are drawn

    denoisers = sorted({r["denoiser"] for r in rows})
    cols = min(4, len(denoisers))
    nrows = math.ceil(len(denoisers) / cols)
    fig = Figure(figsize=(4.2 * cols, 3.4 * nrows))
    for i, d in enumerate(denoisers):
        ax = fig.add_subplot(nrows, cols, i + 1)
        for s in strategy_order(r["strategy"] for r in rows):
            pts = sorted(
                (r for r in rows if r["denoiser"] == d and r["strategy"] == s),
                key=lambda r: r["spp"],
            )
            if not pts:
                continue
            x = [r["total_ms"] for r in pts]
            y = [r["den_mse"] for r in pts]
            err = [
                [r["den_mse"] - r["den_mse_lo"] for r in pts],
                [r["den_mse_hi"] - r["den_mse"] for r in pts],
            ]
            ax.errorbar(x, y, yerr=err, marker="o", capsize=2, label=s)
            for r in pts:
                ax.annotate(
                    f"{r['spp']}",
                    (r["total_ms"], r["den_mse"]),
                    fontsize=7,
                    textcoords="offset points",
                    xytext=(3, 3),
                )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(d, fontsize=9)
        ax.set_xlabel("ms per frame (render + permutation + denoise)", fontsize=8)
        ax.set_ylabel("post-denoise MSE", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{title}: error after denoising against time (labels: spp)")
    path = out / f"error_vs_time_{slug}.png"
    _save(fig, path)
    return path


def _spectra(
    slug: str, title: str, rows: list[dict], records: dict[tuple, Record], out: Path
) -> Path | None:
    from matplotlib.figure import Figure  # 2 s to import: only when charts are drawn

    spp = min(r["spp"] for r in rows)
    denoiser = sorted({r["denoiser"] for r in rows})[0]
    fig = Figure(figsize=(9, 3.4))
    drawn = False
    for j, (kind, label) in enumerate((("raw", "raw error"), ("den", f"error after {denoiser}"))):
        ax = fig.add_subplot(1, 2, j + 1)
        for s in strategy_order(r["strategy"] for r in rows):
            rec = records.get((slug, s, spp, denoiser))
            spec = None if rec is None else rec.spectrum.get(kind)
            if spec is None or not spec.freq:
                continue
            freq, power = np.asarray(spec.freq)[1:], np.asarray(spec.power)[1:]
            ax.semilogy(freq, np.maximum(power, 1e-30), label=s)
            drawn = True
        ax.axvline(0.125, color="gray", lw=0.8, ls="--")
        ax.set_xlabel("cycles / pixel", fontsize=8)
        ax.set_ylabel("power", fontsize=8)
        ax.set_title(f"{label}, {spp} spp", fontsize=9)
        ax.legend(fontsize=7)
    if not drawn:
        return None
    fig.suptitle(f"{title}: radially averaged error spectrum")
    path = out / f"spectra_{slug}.png"
    _save(fig, path)
    return path


def _crops(
    slug: str, title: str, rows: list[dict], records: dict[tuple, Record], out: Path
) -> Path | None:
    from matplotlib.figure import Figure  # 2 s to import: only when charts are drawn

    spp = min(r["spp"] for r in rows)
    denoiser = sorted({r["denoiser"] for r in rows})[0]
    images = []
    for s in strategy_order(r["strategy"] for r in rows):
        rec = records.get((slug, s, spp, denoiser))
        if rec is None or not rec.crop or not (out / rec.crop).exists():
            continue
        with np.load(out / rec.crop) as data:
            images.append((s, {k.replace("__", "/"): data[k] for k in data.files}))
    if not images:
        return None
    columns = ["reference", "raw"] + sorted(k for k in images[0][1] if k.startswith("denoised/"))
    fig = Figure(figsize=(1.9 * len(columns), 1.9 * len(images) + 0.4))
    for i, (strategy, crop) in enumerate(images):
        for j, col in enumerate(columns):
            ax = fig.add_subplot(len(images), len(columns), i * len(columns) + j + 1)
            if col in crop:
                ax.imshow(crop[col], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(col.removeprefix("denoised/"), fontsize=8)
            if j == 0:
                ax.set_ylabel(strategy, fontsize=8)
    fig.suptitle(f"{title}, {spp} spp: centre crops", fontsize=9)
    path = out / f"crops_{slug}.png"
    _save(fig, path)
    return path


def write_charts(
    rows: Sequence[dict], records: Sequence[Record], out_dir: str | Path
) -> list[Path]:
    """Draw every chart for the rows (whole-image region only); return the files written."""
    out = Path(out_dir)
    by_slug: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        if row["region"] == "all":
            by_slug[group_slug(group_key(row))].append(row)
    lookup = {}
    for rec in records:
        c = rec.cell
        if c.region == "all":
            slug = group_slug(group_key(dataclasses.asdict(c)))
            lookup[(slug, c.strategy, c.spp, c.denoiser)] = rec
    written = []
    for slug, group in sorted(by_slug.items()):
        title = group_title(group_key(group[0]))
        written.append(_error_vs_time(slug, title, group, out))
        for chart in (_spectra, _crops):
            path = chart(slug, title, group, lookup, out)
            if path is not None:
                written.append(path)
    return written
