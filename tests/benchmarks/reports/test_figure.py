"""Tests of benchmarks.reports.figure: the README's opening picture is written from the committed
results (their cells file's hash in it, its tiles the committed crops), and how it is laid out."""

import hashlib

import numpy as np
import pytest
from PIL import Image

from benchmarks.reports.figure import FIGURE, SCALE, figure_rows, render_figure, tile_box
from benchmarks.sweep.records import RESULTS_ARCHIVE, load_records
from bnerr.errors import FileFormatError
from tests._paths import RESULTS


def _tiles(seed: int, size: int = 8) -> list[tuple[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    return [(f"tile {i}", rng.integers(0, 256, (size, size, 3), dtype=np.uint8)) for i in range(5)]


def test_each_tile_is_its_crop_enlarged_without_smoothing():
    rows = [("first row", _tiles(0)), ("second row", _tiles(1))]
    image = render_figure(rows)
    for r, (_, tiles) in enumerate(rows):
        for c, (_, tile) in enumerate(tiles):
            top, left, bottom, right = tile_box(r, c, tile.shape[0])
            want = np.repeat(np.repeat(tile, SCALE, axis=0), SCALE, axis=1)
            assert np.array_equal(image[top:bottom, left:right], want)
    assert image.shape[1] == tile_box(0, 4, 8)[3] + 6  # the last tile, then the margin
    with pytest.raises(FileFormatError, match="figure: expected crops of white and a rival"):
        render_figure([])


def test_the_committed_figure_was_written_from_the_committed_results():
    """The README shows results/figure.png: its source is the committed quality cells (their
    SHA-256), and each of its tiles is the committed crop it names, so rewriting the results
    without rewriting the picture (python -m benchmarks.reports.figure) fails here."""
    path = RESULTS / FIGURE
    with Image.open(path) as image:
        source = image.text["source"]
        pixels = np.asarray(image.convert("RGB"))
    cells = RESULTS / "quality" / RESULTS_ARCHIVE
    assert (
        source
        == f"quality/{RESULTS_ARCHIVE} sha256:{hashlib.sha256(cells.read_bytes()).hexdigest()}"
    )
    rows = figure_rows(RESULTS / "quality", load_records(RESULTS / "quality"), "direct",
                       ("gaussian:own", "oidn"))  # fmt: skip
    assert rows and pixels.shape == render_figure(rows).shape
    for r, (title, tiles) in enumerate(rows):
        assert title.startswith("direct, 1 spp, ") and "of white's [" in title
        for c, (_, tile) in enumerate(tiles):
            top, left, bottom, right = tile_box(r, c, tile.shape[0])
            want = np.repeat(np.repeat(tile, SCALE, axis=0), SCALE, axis=1)
            assert np.array_equal(pixels[top:bottom, left:right], want), (title, c)
