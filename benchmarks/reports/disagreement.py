"""Where the eye and the MSE disagree: the pictures of the cells where one verdict says better
and the other does not.

:func:`benchmarks.reports.perceptual.disagreeing` finds the cells (scene, condition, spp, denoiser)
whose MSE verdict and perceptual verdict differ in that way; this module shows each as one row of
``disagree_<metric>.webp`` in the suite's folder (lossless at WebP's fastest effort: 0.13 s
against 4.3 s at its slowest, for a quarter more bytes, about half a PNG's): the reference,
then white's frame after the denoiser, the MSE's lowest rival's and the perceptual metric's best
rival's (once when they are the same strategy, "both picks"), then each one's error
``|frame - reference|`` in sRGB times :data:`benchmarks.reports.previews.ERROR_GAIN`, the
map the page draws. The tiles are the run's
crops (:mod:`benchmarks.reports.previews`: the centre of seed set 0's first measured frame),
enlarged as the README's picture is (:func:`benchmarks.reports.figure.render_figure`); the row's
title gives both verdicts with their corrected intervals. A cell of a pixel region shows the whole
crop (the verdict is the region's). A cell whose runs saved no crop at its spp is left out of the
picture (``perceptual.md`` still lists it).

Not for: finding the cells (:mod:`benchmarks.reports.perceptual`) or the crops
(:mod:`benchmarks.sweep.measure`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks.reports.decision import best_rows, corrected, decision_excludes, rival_counts
from benchmarks.reports.figure import render_figure
from benchmarks.reports.groups import group_title
from benchmarks.reports.perceptual import JUDGES, Judge, Judged, disagreeing, judged
from benchmarks.reports.previews import ERROR_GAIN, load_crop
from benchmarks.sweep.records import Record
from bnerr.io import atomic_write
from bnerr.strategies import baseline

__all__ = ["MAX_ROWS", "disagreement_rows", "picture_name", "shown_tiles", "write_disagreements"]

#: The most cells one picture shows (the first in the report's order; the rest are listed).
MAX_ROWS = 8

Tiles = list[tuple[str, np.ndarray]]


def picture_name(judge: Judge) -> str:
    """The file of ``judge``'s picture in the suite's folder."""
    return f"disagree_{judge.metric}.webp"


def _crops(records: Sequence[Record]) -> dict[tuple, str]:
    """Each run's crop file by (scene, motion, depth, sampler, strategy, spp)."""
    return {
        (c.scene, c.motion, c.depth, c.sampler, c.strategy, c.spp): r.crop
        for r in records
        if r.crop
        for c in (r.cell,)
    }


def error_tile(tile: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``|tile - reference|`` of two sRGB uint8 tiles times ERROR_GAIN, clipped to 255."""
    diff = np.abs(tile.astype(np.int32) - reference.astype(np.int32)) * ERROR_GAIN
    return np.clip(diff, 0, 255).astype(np.uint8)


def _title(key: tuple, mse: str, mse_row: dict, rivals: int, judge: Judge, found: Judged) -> str:
    group, spp, den = key
    est, seen = corrected(mse_row, rivals), found.estimate
    fmt = "{:+.2f}" if judge.higher else "{:.2f}"
    return (
        f"{group_title(group)}, {spp} spp, {den}: MSE says {mse} ({mse_row['strategy']} "
        f"{est.value:.2f} [{est.lo:.2f}, {est.hi:.2f}]), {judge.unit} says {found.verdict} "
        f"({found.row['strategy']} {fmt.format(seen.value)} "
        f"[{fmt.format(seen.lo)}, {fmt.format(seen.hi)}]), {found.row['seed_sets']} seed sets"
    )


def _files(crops: dict[tuple, str], key: tuple, shown: dict[str, str]) -> list[str | None]:
    """The crop file of each strategy ``shown`` in the cell ``key`` (None: its run has none)."""
    (scene, motion, depth, _, sampler), spp, _ = key
    return [crops.get((scene, motion, depth, sampler, s, spp)) for s in shown]


def _tiles(out: Path, files: list[str | None], name: str, shown: dict[str, str]) -> Tiles:
    """The row's tiles from the crop ``files`` of the strategies ``shown`` (strategy -> its
    label), or [] when one lacks the tile ``name`` (the cell's denoiser's)."""
    found = [load_crop(out, f) for f in files]
    tiles = [t[name] for t in found if t is not None and name in t and "reference" in t]
    if len(tiles) < len(shown):
        return []
    ref = found[0]["reference"]  # type: ignore[index]  # checked above
    labels = list(shown.values())
    return [
        ("reference", ref),
        *((f"{label}, denoised", tile) for label, tile in zip(labels, tiles)),
        *((f"{label}, error x{ERROR_GAIN}", error_tile(t, ref)) for label, t in zip(labels, tiles)),
    ]


def _shown(white: str, mse: str, seen: str, unit: str) -> dict[str, str]:
    """The strategies a row shows, labelled by role (their names are in the title)."""
    shown = {white: "white", mse: "MSE's pick"}
    shown[seen] = "both picks" if seen == mse else f"{unit}'s pick"
    return shown


def _shown_cells(
    out: Path, records: Sequence[Record], rows: Sequence[dict], judge: Judge
) -> list[tuple[str, Tiles, dict[str, str]]]:
    """Per disagreeing cell whose crops hold every strategy shown (at most :data:`MAX_ROWS`):
    the row's title, its tiles, and the tile each crop file gave (crop file -> tile name)."""
    exclude = decision_excludes(r["strategy"] for r in rows)
    lowest = best_rows(rows, [*exclude, baseline()])
    rivals = rival_counts(rows, exclude)
    crops = _crops(records)
    found = []
    for key, mse, seen in disagreeing(rows, judge, exclude):
        mse_row = lowest[key]
        shown = _shown(baseline(), mse_row["strategy"], seen.row["strategy"], judge.unit)
        files, name = _files(crops, key, shown), f"denoised/{key[2]}"
        tiles = _tiles(out, files, name, shown)
        if tiles:
            used = {f: name for f in files if f}
            title = _title(key, mse, mse_row, rivals.get(key, 1), judge, seen)
            found.append((title, tiles, used))
        if len(found) == MAX_ROWS:
            break
    return found


def disagreement_rows(
    out: Path, records: Sequence[Record], rows: Sequence[dict], judge: Judge
) -> list[tuple[str, Tiles]]:
    """Per disagreeing cell whose crops hold every strategy shown (at most :data:`MAX_ROWS`):
    the row's title and its tiles."""
    return [(title, tiles) for title, tiles, _ in _shown_cells(out, records, rows, judge)]


def shown_tiles(out: Path, records: Sequence[Record], rows: Sequence[dict]) -> dict[str, set[str]]:
    """The tiles the pictures draw, by crop file (crop file -> tile names): the page's strips
    keep them (:func:`benchmarks.reports.page.write_suite_page`), so that the pictures come out
    the same when the report is written again from the strips (``--report-only``)."""
    kept: dict[str, set[str]] = {}
    for judge in JUDGES:
        if judged(rows, judge):
            for _, _, used in _shown_cells(out, records, rows, judge):
                for crop, tile in used.items():
                    kept.setdefault(crop, set()).add(tile)
    return kept


def write_disagreements(
    out: Path, records: Sequence[Record], rows: Sequence[dict]
) -> dict[str, str]:
    """Write each judge's picture into ``out`` (removing a stale one where no cell can be shown);
    return judge metric -> file name of those written."""
    from PIL import Image

    written = {}
    for judge in JUDGES:
        path = out / picture_name(judge)
        found = disagreement_rows(out, records, rows, judge) if judged(rows, judge) else []
        if not found:
            path.unlink(missing_ok=True)
            continue
        with atomic_write(path) as tmp:
            Image.fromarray(render_figure(found)).save(
                tmp, format="WEBP", lossless=True, quality=100, method=0
            )
        written[judge.metric] = path.name
    return written
