"""The README's opening picture, written from the committed results (never by hand).

One scene's same frame, white noise against the strategy the decision finds lowest after a
denoiser, raw and after it: a row per (spp, denoiser) that the suite's crops hold for both, each
row ``reference | white raw | best raw | white denoised | best denoised``, the crops (the centre
crop of each run's first measured frame, :mod:`benchmarks.reports.previews`) enlarged without
smoothing so that the noise's grain shows, and the row's title the verdict the decision gives
(:mod:`benchmarks.reports.decision`: the ratio to white with its corrected interval). The PNG's
text chunk ``source`` names the suite's cells file and its SHA-256, so a test can tell the
picture was written from the committed results.

``python -m benchmarks.reports.figure [RESULTS] [OUT]`` writes it (by default from ``results``
into ``results/figure.png``). The quality suite saves crops at its smallest spp only (1 spp),
so today the picture has 1-spp rows; a suite run with crops at every spp gains the others.

Not for: choosing a flattering scene: the scene and the denoisers are the arguments' (by default
the headline's first scene, and the tuned Gaussian and OIDN, the production denoiser), the
strategy is the decision's.
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks.reports.decision import best_rows, corrected, decision_excludes, rival_counts
from benchmarks.reports.groups import group_key, group_title
from benchmarks.reports.previews import load_crop
from benchmarks.reports.table import summarize
from benchmarks.sweep.records import (
    RESULTS_ARCHIVE,
    Record,
    final_records,
    load_records,
)
from bnerr.errors import FileFormatError
from bnerr.io import atomic_write
from bnerr.strategies import baseline

__all__ = ["FIGURE", "SCALE", "figure_rows", "render_figure", "tile_box", "write_figure"]

#: Where the picture is written, under the results folder.
FIGURE = "figure.png"
#: How many screen pixels one rendered pixel becomes (nearest neighbour).
SCALE = 3
_GAP, _TITLE, _LABEL = 6, 22, 18


def _scene_records(records: Sequence[Record], scene: str) -> list[Record]:
    """The records of ``scene`` without a condition (its own motion, depth and sampler), over
    every pixel, as the README's headline reads them."""
    return [
        r
        for r in final_records(records)
        if r.has_pixels
        and r.cell.scene == scene
        and r.cell.region == "all"
        and group_title(group_key(r.cell.__dict__)) == scene
    ]


def figure_rows(
    out: Path, records: Sequence[Record], scene: str, denoisers: Sequence[str]
) -> list[tuple[str, list[tuple[str, np.ndarray]]]]:
    """Per (spp, denoiser) whose crops hold white's and the lowest rival's tiles: the row's title
    and its five ``(label, tile)``."""
    chosen = _scene_records(records, scene)
    rows = summarize(chosen)
    exclude = decision_excludes(r["strategy"] for r in rows)
    lowest = best_rows(rows, [*exclude, baseline()])
    rivals = rival_counts(rows, exclude)
    crops = {(r.cell.strategy, r.cell.spp): r.crop for r in chosen if r.crop}
    found = []
    for (group, spp, den), row in sorted(lowest.items(), key=lambda kv: (kv[0][1], kv[0][2])):
        if den not in denoisers or row.get("den_mse_ratio") is None:
            continue
        best, white = row["strategy"], baseline()
        tiles = [load_crop(out, crops.get((s, spp))) for s in (white, best)]
        name = f"denoised/{den}"
        if any(t is None or name not in t for t in tiles):
            continue
        w, b = tiles[0], tiles[1]
        assert w is not None and b is not None  # checked above
        est = corrected(row, rivals.get((group, spp, den), 1))
        title = (
            f"{scene}, {spp} spp, {den}: {best}'s MSE after it is {est.value:.2f} of white's "
            f"[{est.lo:.2f}, {est.hi:.2f}], {row['seed_sets']} seed sets"
        )
        found.append(
            (
                title,
                [
                    ("reference", w["reference"]),
                    (f"{white}, raw", w["raw"]),
                    (f"{best}, raw", b["raw"]),
                    (f"{white} + {den}", w[name]),
                    (f"{best} + {den}", b[name]),
                ],
            )
        )
    return found


def render_figure(rows: Sequence[tuple[str, Sequence[tuple[str, np.ndarray]]]]) -> np.ndarray:
    """The picture of :func:`figure_rows`' rows: ``H x W x 3`` uint8, white background."""
    from PIL import Image, ImageDraw, ImageFont

    if not rows:
        raise FileFormatError("figure: expected crops of white and a rival, got none")
    size = rows[0][1][0][1].shape[0] * SCALE
    columns = max(len(tiles) for _, tiles in rows)
    width = columns * size + (columns + 1) * _GAP
    band = _TITLE + _LABEL + size + _GAP
    canvas = Image.new("RGB", (width, len(rows) * band + _GAP), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default(size=13)
    for i, (title, tiles) in enumerate(rows):
        top = _GAP + i * band
        draw.text((_GAP, top + 3), title, fill=(17, 17, 17), font=font)
        for j, (label, tile) in enumerate(tiles):
            left = _GAP + j * (size + _GAP)
            draw.text((left, top + _TITLE), label, fill=(60, 60, 60), font=font)
            big = np.repeat(np.repeat(tile, SCALE, axis=0), SCALE, axis=1)
            canvas.paste(Image.fromarray(big), (left, top + _TITLE + _LABEL))
    return np.asarray(canvas)


def tile_box(row: int, column: int, tile: int) -> tuple[int, int, int, int]:
    """``(top, left, bottom, right)`` of tile ``column`` of row ``row`` in the picture, for a
    crop ``tile`` pixels wide."""
    size = tile * SCALE
    top = _GAP + row * (_TITLE + _LABEL + size + _GAP) + _TITLE + _LABEL
    left = _GAP + column * (size + _GAP)
    return top, left, top + size, left + size


def _cells_file(out: Path) -> Path:
    for name in (RESULTS_ARCHIVE, "cells.jsonl"):
        if (out / name).exists():
            return out / name
    raise FileFormatError(f"{out}: expected the suite's cells ({RESULTS_ARCHIVE}), got none")


def write_figure(
    results: str | Path = "results",
    path: str | Path | None = None,
    suite: str = "quality",
    scene: str = "direct",
    denoisers: Sequence[str] = ("gaussian:own", "oidn"),
) -> Path:
    """Write the picture of ``suite``'s ``scene`` (by default ``<results>/figure.png``), its
    ``source`` text chunk naming the cells file and its SHA-256; return its path."""
    from PIL import Image, PngImagePlugin

    out = Path(results) / suite
    cells = _cells_file(out)
    image = render_figure(figure_rows(out, load_records(out), scene, denoisers))
    digest = hashlib.sha256(cells.read_bytes()).hexdigest()
    info = PngImagePlugin.PngInfo()
    info.add_text("source", f"{suite}/{cells.name} sha256:{digest}")
    target = Path(path) if path is not None else Path(results) / FIGURE
    with atomic_write(target) as tmp:
        Image.fromarray(image).save(tmp, format="PNG", pnginfo=info, optimize=True)
    return target


if __name__ == "__main__":
    print(write_figure(*sys.argv[1:3]))
