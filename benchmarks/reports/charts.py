"""The PNG charts of a results folder, drawn from the table's rows and the records.

Matplotlib, drawn on ``Figure`` objects with the Agg canvas, no pyplot state; one set per group
(a scene with its condition, :mod:`benchmarks.reports.groups`), whole-image region only. Every
strategy keeps its colour of :mod:`benchmarks.reports.palette`, and every legend sits outside the
panels, right of them (constrained layout keeps titles, labels and ticks apart):

- ``error_vs_time_<group>.png``: post-denoise MSE as a ratio to white's on the same frames, with
  its interval, against render + permutation + denoise milliseconds per frame, one line per
  strategy through its spp values (marker size grows with spp), one panel per key denoiser
  (:data:`KEY_DENOISERS`, the ones an adopter chooses among, and every plug-in denoiser; all of
  them when none is run);
- ``error_vs_time_<group>_other.png``: the same for every other denoiser;
- ``oracle_share_<group>.png``: each strategy's share of the white-to-oracle gap
  (:mod:`benchmarks.reports.gap`) against spp, one panel per measure;
- ``spectra_<group>.png``: radially averaged power spectrum of the raw and denoised error per
  strategy.

The crops are shown by the results page (:mod:`benchmarks.reports.page`), where any two can be
compared with a slider or a flip, instead of a chart of them.

:func:`error_vs_time_figure` and :func:`oracle_share_figure` return the figures unsaved, for the
test that no text overlaps text or data.
"""

from __future__ import annotations

import dataclasses
import io
import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from benchmarks.highlights import KEY_DENOISERS, SHARE_DENOISERS
from benchmarks.reports.gap import GapShare
from benchmarks.reports.groups import group_key, group_slug, group_title, strategy_order
from benchmarks.reports.palette import strategy_style
from benchmarks.sweep.records import Record
from bnerr import plugins
from bnerr.io import atomic_write

if TYPE_CHECKING:  # matplotlib takes 2 s to import: only when charts are drawn
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "KEY_DENOISERS",
    "error_vs_time_figure",
    "key_denoisers",
    "oracle_share_figure",
    "share_slug",
    "write_charts",
]

#: Pixels per inch of the PNG charts: a three-panel chart 1040 pixels wide, which the results page
#: (1200 pixels at most) shows at its own size rather than scaled down from a larger file.
DPI = 80
#: Measures of the oracle-share chart, when present: the blurred raw error and the key denoisers.
_SHARE_MEASURES = ("raw mse_blur1", *(f"{d} mse" for d in SHARE_DENOISERS))


def key_denoisers(denoisers: Sequence[str]) -> list[str]:
    """The key denoisers among ``denoisers`` (the first present name of each
    :data:`KEY_DENOISERS` entry), then every plug-in denoiser (:mod:`bnerr.plugins`: the one its
    user came to measure); all of them, sorted, when none is key."""
    present = set(denoisers)
    keys = [
        next(n for n in names if n in present) for names in KEY_DENOISERS if present & set(names)
    ]
    keys += [
        n
        for n in sorted(present - set(keys))
        if plugins.loaded("bnerr.denoisers", n.removesuffix(":own")) is not None
    ]
    return keys or sorted(present)


def _save(fig: Figure, path: Path) -> None:
    """Save as PNG in 256 colours (a third of the bytes of a line chart, no visible change), at
    :data:`DPI`."""
    from PIL import Image

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    buffer.seek(0)
    with Image.open(buffer) as png:
        image = png.convert("RGB").quantize(
            colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
        )
        with atomic_write(path) as tmp:
            image.save(tmp, format="PNG", optimize=True)


def _figure(panels: int, width: float = 3.6, height: float = 3.0) -> tuple[Figure, list[Axes]]:
    from matplotlib.figure import Figure  # 2 s to import: only when charts are drawn

    cols = min(3, panels)
    rows = math.ceil(panels / cols)
    fig = Figure(figsize=(width * cols + 2.2, height * rows + 0.6), layout="constrained")
    return fig, [fig.add_subplot(rows, cols, i + 1) for i in range(panels)]


def _legend(fig: Figure, axes: Sequence[Axes]) -> None:
    """One legend for the figure, right of the panels, one entry per strategy."""
    seen: dict[str, Artist] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, handle)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="outside right upper", fontsize=8)


def _ratio_panel(ax: Axes, rows: list[dict], denoiser: str) -> None:
    sizes = sorted({r["spp"] for r in rows})
    for s in strategy_order(r["strategy"] for r in rows):
        pts = sorted(
            (
                r
                for r in rows
                if r["denoiser"] == denoiser
                and r["strategy"] == s
                and r["den_mse_ratio"] is not None
                and r["total_ms"]
            ),
            key=lambda r: r["spp"],
        )
        if not pts:
            continue
        x = [r["total_ms"] for r in pts]
        y = [r["den_mse_ratio"] for r in pts]
        err = [
            [
                max(0.0, r["den_mse_ratio"] - (r["den_mse_ratio_lo"] or r["den_mse_ratio"]))
                for r in pts
            ],
            [
                max(0.0, (r["den_mse_ratio_hi"] or r["den_mse_ratio"]) - r["den_mse_ratio"])
                for r in pts
            ],
        ]
        style: dict[str, Any] = strategy_style(s)  # matplotlib keywords
        ax.errorbar(x, y, yerr=err, capsize=2, lw=1.2, ms=0, label=s, **style)
        ax.scatter(
            x, y, s=[12 + 10 * sizes.index(r["spp"]) for r in pts], color=style["color"], zorder=3
        )
    ax.axhline(1.0, color="#8c8c8c", lw=0.8)
    _log_ms_axis(ax)
    ax.set_title(denoiser, fontsize=9)
    ax.set_xlabel("ms per frame", fontsize=8)
    ax.set_ylabel("MSE / white's", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="both", alpha=0.3)


def _log_ms_axis(ax: Axes) -> None:
    """A log x axis labelled in plain numbers at 1-2-5 steps (1 per decade past two decades),
    minor ticks unlabelled, so that labels never run into each other."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    lo, hi = ax.get_xlim()
    subs = (1.0, 2.0, 5.0) if math.log10(hi / lo) <= 2 else (1.0,)
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=subs))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def error_vs_time_figure(title: str, rows: list[dict], denoisers: Sequence[str]) -> Figure:
    """The error-against-time figure of one group's rows: one panel per denoiser."""
    fig, axes = _figure(len(denoisers))
    for ax, d in zip(axes, denoisers, strict=True):
        _ratio_panel(ax, rows, d)
    _legend(fig, axes)
    sizes = ", ".join(str(s) for s in sorted({r["spp"] for r in rows}))
    fig.suptitle(
        f"{title}: error after denoising / white's, against time (spp {sizes})", fontsize=10
    )
    return fig


def share_slug(share: GapShare) -> str:
    """The group slug (:func:`benchmarks.reports.groups.group_slug`) of a gap share's cell."""
    tokens = share.condition.split()
    motion = int(tokens[0][1:])
    depth = int(tokens[1][1:]) if len(tokens) == 4 else None
    region, sampler = tokens[-2], tokens[-1]
    return group_slug((share.scene, motion, depth, region, sampler))


def oracle_share_figure(title: str, shares: Sequence[GapShare]) -> Figure:
    """Each strategy's share of the white-to-oracle gap against spp, one panel per measure."""
    from matplotlib.ticker import NullLocator

    present = {s.measure for s in shares}
    measures = [m for m in _SHARE_MEASURES if m in present] or sorted(present)
    fig, axes = _figure(len(measures), height=2.8)
    for ax, measure in zip(axes, measures, strict=True):
        rows = [s for s in shares if s.measure == measure]
        for name in strategy_order(s.strategy for s in rows):
            pts = sorted((s for s in rows if s.strategy == name), key=lambda s: s.spp)
            lo = [p.share - p.lo if math.isfinite(p.lo) else 0.0 for p in pts]
            hi = [p.hi - p.share if math.isfinite(p.hi) else 0.0 for p in pts]
            x = [p.spp for p in pts]
            style: dict[str, Any] = strategy_style(name)  # matplotlib keywords
            ax.errorbar(
                x,
                [p.share for p in pts],
                yerr=[lo, hi],
                capsize=2,
                label=name,
                **style,
            )
        ax.axhline(0.0, color="#8c8c8c", lw=0.8)
        ax.axhline(1.0, color="#000000", lw=0.8, ls="--")
        ax.set_xscale("log", base=2)
        ax.set_xticks(
            sorted({s.spp for s in rows}), [str(v) for v in sorted({s.spp for s in rows})]
        )
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_ylim(-0.5, 1.5)
        ax.set_title(measure, fontsize=9)
        ax.set_xlabel("spp", fontsize=8)
        ax.set_ylabel("share of the oracle's gain", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.3)
    _legend(fig, axes)
    fig.suptitle(f"{title}: share of the white-to-oracle gap (0: white, 1: oracle)", fontsize=10)
    return fig


def _error_vs_time(slug: str, title: str, rows: list[dict], out: Path) -> list[Path]:
    denoisers = sorted({r["denoiser"] for r in rows})
    keys = key_denoisers(denoisers)
    others = [d for d in denoisers if d not in keys]
    written = []
    for suffix, names in (("", keys), ("_other", others)):
        path = out / f"error_vs_time_{slug}{suffix}.png"
        if names:
            _save(error_vs_time_figure(title, rows, names), path)
            written.append(path)
        elif path.exists():
            path.unlink()  # a chart of a former run's denoisers would mislead
    return written


def _spectra(
    slug: str, title: str, rows: list[dict], records: dict[tuple, Record], out: Path
) -> Path | None:
    spp = min(r["spp"] for r in rows)
    denoiser = key_denoisers(sorted({r["denoiser"] for r in rows}))[0]
    fig, axes = _figure(2, width=4.2)
    drawn = False
    for ax, (kind, label) in zip(
        axes, (("raw", "raw error"), ("den", f"after {denoiser}")), strict=True
    ):
        for s in strategy_order(r["strategy"] for r in rows):
            rec = records.get((slug, s, spp, denoiser))
            spec = None if rec is None else rec.spectrum.get(kind)
            if spec is None or not spec.freq:
                continue
            freq, power = np.asarray(spec.freq)[1:], np.asarray(spec.power)[1:]
            ax.semilogy(freq, np.maximum(power, 1e-30), label=s, color=strategy_style(s)["color"])
            drawn = True
        ax.axvline(0.125, color="gray", lw=0.8, ls="--")
        ax.set_xlabel("cycles / pixel", fontsize=8)
        ax.set_ylabel("power", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_title(f"{label}, {spp} spp", fontsize=9)
    if not drawn:
        return None
    _legend(fig, axes)
    fig.suptitle(f"{title}: radially averaged error spectrum", fontsize=10)
    path = out / f"spectra_{slug}.png"
    _save(fig, path)
    return path


def _by_group(rows: Sequence[dict], records: Sequence[Record]) -> tuple[dict, dict]:
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
    return by_slug, lookup


def write_charts(
    rows: Sequence[dict],
    records: Sequence[Record],
    out_dir: str | Path,
    shares: Sequence[GapShare] = (),
) -> list[Path]:
    """Draw every chart for the rows (whole-image region only) and the gap ``shares``
    (:func:`benchmarks.reports.gap.gap_shares`); return the files written."""
    out = Path(out_dir)
    by_slug, lookup = _by_group(rows, records)
    share_groups: dict[str, list[GapShare]] = defaultdict(list)
    for share in shares:
        share_groups[share_slug(share)].append(share)
    written = []
    for slug, group in sorted(by_slug.items()):
        title = group_title(group_key(group[0]))
        written += _error_vs_time(slug, title, group, out)
        if share_groups.get(slug):
            path = out / f"oracle_share_{slug}.png"
            _save(oracle_share_figure(title, share_groups[slug]), path)
            written.append(path)
        spectra = _spectra(slug, title, group, lookup, out)
        if spectra is not None:
            written.append(spectra)
        (out / f"crops_{slug}.png").unlink(missing_ok=True)  # a former chart: the page shows them
    return written
