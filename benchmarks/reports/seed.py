"""The seed talk's kind of evidence: images side by side with a zoomed inset, the error's
spectrum over the coherent region, and a README that says where the claim holds.

The ``seed`` suite (:data:`benchmarks.suites.SUITES`) saves crops at every spp
(``Suite.crops_every_spp``) and its records hold the raw error's spectrum over the coherent
pixels (``Record.spectrum["coherent"]``). From those alone:

- :func:`seed_figure`: for one group (scene and condition) and spp, the reference and each
  strategy's raw frame side by side, each with an inset of the same square enlarged about
  2x (nearest neighbour), and a last panel with each strategy's coherent-region error spectrum,
  in the strategies' colours (:mod:`benchmarks.reports.palette`);
- :func:`write_seed_report`: every figure as ``seed_<group>_<spp>spp.png`` and ``README.md``:
  per group, the share of the oracle's dividend each strategy keeps in the coherent region after
  a sigma-2 blur (:func:`benchmarks.reports.gap.gap_shares`, with its interval) at every spp,
  the issue's goal (half at 16 spp, a third at 64) checked against the best of ``temporal`` and
  its variants (its interval at the Bonferroni level for the best of the m variants measured,
  ``1 - 0.05 / m``: picking the highest of m shares would otherwise miss more often than 5 %;
  ``python -m bnerr.metrics.coverage --shares`` simulates both), and the figures.

Groups without crops or without a coherent spectrum are left out; a folder without any writes
nothing (the other suites).

Not for: the tables of every suite (:mod:`benchmarks.reports.table`).
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from benchmarks.highlights import HEADLINE_METHOD
from benchmarks.reports.charts import _legend, _save
from benchmarks.reports.gap import GapShare
from benchmarks.reports.groups import (
    group_key,
    group_order,
    group_slug,
    group_title,
    strategy_order,
)
from benchmarks.reports.palette import family, strategy_style
from benchmarks.reports.previews import load_crop
from benchmarks.suites import SUITES
from benchmarks.sweep.records import Record
from bnerr.io import atomic_write
from bnerr.metrics import best_level, relevel_share

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["GOALS", "seed_figure", "write_seed_report"]

#: The issue's goal: the share of the oracle's dividend to keep at these spp (sigma-2 blur,
#: coherent region).
GOALS: dict[int, float] = {16: 0.5, 64: 1 / 3}
_MEASURE = "raw mse_blur2"


def _inset_box(size: int) -> tuple[int, int, int]:
    """``(y0, x0, side)`` of the zoomed square: a quarter of the crop, below its centre (the
    floor's checkerboard in front of the object of the seed scenes)."""
    side = max(size // 4, 1)
    return min(size * 9 // 16, size - side), (size - side) // 2, side


def seed_figure(title: str, images: dict[str, np.ndarray], spectra: dict[str, tuple]) -> Figure:
    """The figure: ``images`` (name -> uint8 ``H x W x 3``, ``reference`` first) side by side
    with an inset each, then ``spectra`` (strategy -> ``(freq, power)``) on one log axis."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    n = len(images) + 1
    fig = Figure(figsize=(2.3 * n + 1.6, 2.9), layout="constrained")
    axes = [fig.add_subplot(1, n, i + 1) for i in range(n)]
    for ax, (name, img) in zip(axes, images.items(), strict=False):
        y0, x0, side = _inset_box(img.shape[0])
        ax.imshow(img, interpolation="nearest")
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), side, side, fill=False, ec="yellow", lw=0.8))
        inset = ax.inset_axes((0.52, 0.52, 0.48, 0.48))  # above the square
        inset.imshow(img[y0 : y0 + side, x0 : x0 + side], interpolation="nearest")
        for a in (ax, inset):
            a.set_xticks([])
            a.set_yticks([])
        for spine in inset.spines.values():
            spine.set_color("yellow")
        color = "black" if name == "reference" else strategy_style(name)["color"]
        ax.set_title(name, fontsize=8, color=color)
    ax = axes[-1]
    for name, (freq, power) in spectra.items():
        f, p = np.asarray(freq)[1:], np.asarray(power)[1:]
        ax.semilogy(f, np.maximum(p, 1e-30), label=name, color=strategy_style(name)["color"])
    ax.axvline(0.125, color="gray", lw=0.8, ls="--")
    ax.set_xlabel("cycles / pixel", fontsize=8)
    ax.set_title("error spectrum, coherent px", fontsize=8)
    ax.tick_params(labelsize=7)
    _legend(fig, [ax])
    fig.suptitle(title, fontsize=9)
    return fig


def _panels(out: Path, records: Sequence[Record]) -> dict[tuple, dict[int, dict[str, Record]]]:
    """Group key (region ``all``) -> spp -> strategy -> its record with crops and a coherent
    spectrum (one denoiser: the first in name order)."""
    found: dict[tuple, dict[int, dict[str, Record]]] = defaultdict(lambda: defaultdict(dict))
    for rec in sorted(records, key=lambda r: r.cell.denoiser):
        c = rec.cell
        if c.region != "all" or not rec.crop or "coherent" not in rec.spectrum:
            continue
        found[group_key(dataclasses.asdict(c))][c.spp].setdefault(c.strategy, rec)
    return found


def _figure_for(out: Path, title: str, by_strategy: dict[str, Record]) -> bool:
    """Draw one figure into ``out``; False when no record's crops could be read."""
    images: dict[str, np.ndarray] = {}
    spectra = {}
    for s in strategy_order(by_strategy):
        rec = by_strategy[s]
        crop = load_crop(out.parent, rec.crop)
        if crop is None:
            continue
        images.setdefault("reference", crop["reference"])
        images[s] = crop["raw"]
        spec = rec.spectrum["coherent"]
        if spec.freq:
            spectra[s] = (spec.freq, spec.power)
    if not images:
        return False
    _save(seed_figure(title, images, spectra), out)
    return True


def _share_lines(shares: list[GapShare], strategies: list[str]) -> list[str]:
    by = {(g.spp, g.strategy): g for g in shares}
    spps = sorted({g.spp for g in shares})
    lines = ["| spp | oracle gap (W-O)/W | " + " | ".join(strategies) + " |"]
    lines.append("|---" * (len(strategies) + 2) + "|")
    for spp in spps:
        gap = next((g.gap for g in shares if g.spp == spp), float("nan"))
        cells = [
            f"{by[spp, s].share:.2f} [{by[spp, s].lo:.2f}, {by[spp, s].hi:.2f}]"
            if (spp, s) in by
            else "-"
            for s in strategies
        ]
        lines.append(f"| {spp} | {gap:.2f} | " + " | ".join(cells) + " |")
    return lines


def _best_interval(best: GapShare, rivals: int) -> tuple[float, float, float]:
    """The level and interval of the best of ``rivals`` shares: its interval at the Bonferroni
    level (:func:`bnerr.metrics.best_level`), as the decision table reads the lowest of m
    ratios; as it is when one rival, or no seed sets recorded to relevel with."""
    level = best_level(best.level, rivals)
    if rivals == 1 or best.seed_sets < 2:
        return best.level, best.lo, best.hi
    lo, hi = relevel_share(best.share, best.lo, best.hi, best.level, level, best.seed_sets)
    return level, lo, hi


def _verdict(shares: list[GapShare]) -> list[str]:
    """One line per goal spp: the best share of the method's family (the temporal strategies and
    their variants) against the goal, its interval corrected for picking the best of the m
    members measured (Bonferroni, :func:`_best_interval`)."""
    lines = []
    for spp, goal in GOALS.items():
        method = family(HEADLINE_METHOD)
        mine = [g for g in shares if g.spp == spp and family(g.strategy) == method]
        if not mine:
            continue
        best = max(mine, key=lambda g: g.share)
        level, lo, hi = _best_interval(best, len(mine))
        held = "holds" if lo >= goal else ("not shown" if hi >= goal else "fails")
        lines.append(
            f"- {spp} spp: goal {goal:.2f} of the dividend; best {best.strategy} keeps "
            f"{best.share:.2f} [{lo:.2f}, {hi:.2f}] ({level:.2%} interval for the best of "
            f"{len(mine)}, {best.seed_sets} seed sets): **{held}**."
        )
    return lines


def _group_text(key: tuple, shares: list[GapShare], figures: list[str]) -> list[str]:
    title = group_title(key)
    lines = [f"## {title}", ""]
    if shares:
        strategies = strategy_order(g.strategy for g in shares)
        lines += [
            "Share of the oracle's dividend kept in the coherent region, sigma-2 blurred MSE "
            "(1: the oracle's, 0: white's), with its 95 % interval over seed sets:",
            "",
            *_share_lines(shares, strategies),
            "",
            *_verdict(shares),
            "",
        ]
    lines += [f"![{title}, {f.split('_')[-1][:-4]}]({f})" for f in figures] + [""]
    return lines


def _written_by(out: Path) -> str:
    """Whence the README: the suite where the folder is named after one, else the folder (a run
    into ``--out den`` is not the suite ``den``: issue 54)."""
    if out.name in SUITES:
        return (
            f"Written by `bnerr bench --suite {out.name}` from its records (do not edit; the "
            "folder's name is the suite's)."
        )
    return (
        f"Written by `bnerr bench` into `{out.name}` from its records (do not edit; "
        f"`bnerr bench --report-only --out {out.name}` writes it again)."
    )


def write_seed_report(
    out_dir: str | Path, records: Sequence[Record], shares: Sequence[GapShare]
) -> list[Path]:
    """Write the seed figures and ``README.md`` into ``out_dir`` (nothing without records that
    have crops and a coherent spectrum); return the files written."""
    out = Path(out_dir)
    panels = _panels(out, records)
    written: list[Path] = []
    text = [
        "# The seed talk's claim: blue error in coherent regions",
        "",
        _written_by(out) + " Each figure: the "
        "reference and each strategy's raw frame (first measured frame of seed set 0), an "
        "enlarged inset of the yellow square, and the raw error's power spectrum over the coherent "
        "pixels (blue noise: low power left of the dashed line at 1/8 cycle per pixel).",
        "",
    ]
    for key in sorted(panels, key=group_order):
        slug, figures = group_slug(key), []
        for spp, by_strategy in sorted(panels[key].items()):
            name = f"seed_{slug}_{spp}spp.png"
            if _figure_for(out / name, f"{group_title(key)}, {spp} spp", by_strategy):
                figures.append(name)
                written.append(out / name)
        mine = [
            g
            for g in shares
            if g.scene == key[0] and g.measure == _MEASURE and g.condition == _condition(key)
        ]
        text += _group_text(key, mine, figures)
    if not written:
        return written
    with atomic_write(out / "README.md") as tmp:
        Path(tmp).write_text("\n".join(text))
    return [*written, out / "README.md"]


def _condition(key: tuple) -> str:
    """The gap share's condition string for a group key, in its coherent region."""
    _, motion, depth, _, sampler = key
    return " ".join([f"m{motion}", *([] if depth is None else [f"d{depth}"]), "coherent", sampler])
