"""Tests of benchmarks.reports.disagreement: the pictures of the cells where the eye and the MSE
disagree, drawn from the runs' crops."""

from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from benchmarks.reports import disagreement
from benchmarks.reports.figure import tile_box
from benchmarks.reports.perceptual import JUDGES, perceptual_report
from benchmarks.reports.previews import ERROR_GAIN
from tests._records import table_row

_JOD = JUDGES[0]
_SIZE = 8


def _rows():
    """Two cells: ldbn better in both judges at 1 spp; better by MSE, worse in JOD at 4 spp."""
    return [
        table_row("white", 1, jod=0.0),
        table_row("ldbn", 1, 0.8, jod=0.5),
        table_row("white", 4, jod=0.0),
        table_row("ldbn", 4, 0.8, jod=-0.6),
    ]


def _crops(tmp_path, spp_levels=(1, 4)):
    """Records with crops: the reference grey 100, white's denoised frame 110 and ldbn's 90."""
    records = []
    (tmp_path / "crops").mkdir()
    for strategy, value in (("white", 110), ("ldbn", 90)):
        for spp in spp_levels:
            name = f"crops/direct_{strategy}_{spp}spp.npz"
            tile = np.full((_SIZE, _SIZE, 3), value, np.uint8)
            np.savez(
                tmp_path / name,
                reference=np.full((_SIZE, _SIZE, 3), 100, np.uint8),
                raw=tile,
                denoised__gaussian=tile,
            )
            cell = SimpleNamespace(
                scene="direct",
                motion=1,
                depth=None,
                sampler="owen_sobol",
                strategy=strategy,
                spp=spp,
            )
            records.append(SimpleNamespace(cell=cell, crop=name))
    return records


def test_a_disagreeing_cell_shows_white_and_the_picks_denoised_and_their_errors(tmp_path):
    (row,) = disagreement.disagreement_rows(tmp_path, _crops(tmp_path), _rows(), _JOD)
    title, tiles = row
    assert title.startswith("direct, 4 spp, gaussian: MSE says better (ldbn 0.80 [")
    assert "JOD says worse (ldbn -0.60 [" in title
    labels = [label for label, _ in tiles]
    assert labels == [
        "reference",
        "white, denoised",
        "both picks, denoised",
        f"white, error x{ERROR_GAIN}",
        f"both picks, error x{ERROR_GAIN}",
    ]
    assert tiles[3][1].max() == 10 * ERROR_GAIN and tiles[4][1].max() == 10 * ERROR_GAIN


def test_the_error_tile_clips_at_white():
    a = np.full((2, 2, 3), 250, np.uint8)
    b = np.zeros((2, 2, 3), np.uint8)
    assert disagreement.error_tile(a, b).max() == 255


def test_a_cell_without_crops_at_its_spp_is_left_out_of_the_picture(tmp_path):
    assert disagreement.disagreement_rows(tmp_path, _crops(tmp_path, (1,)), _rows(), _JOD) == []


def test_the_picture_is_written_and_perceptual_md_shows_it_and_a_stale_one_goes(tmp_path):
    records = _crops(tmp_path)
    written = disagreement.write_disagreements(tmp_path, records, _rows())
    assert written == {"cvvdp": "disagree_cvvdp.webp"}  # FLIP was not measured
    with Image.open(tmp_path / "disagree_cvvdp.webp") as image:
        picture = np.asarray(image.convert("RGB"))
    top, left, bottom, right = tile_box(0, 2, _SIZE)  # ldbn's denoised tile, lossless
    assert (picture[top:bottom, left:right] == 90).all()
    text = perceptual_report(_rows(), pictures=written)
    assert "](disagree_cvvdp.webp)" in text
    agreeing = [r for r in _rows() if r["spp"] == 1]
    assert disagreement.write_disagreements(tmp_path, records, agreeing) == {}
    assert not (tmp_path / "disagree_cvvdp.webp").exists()


@pytest.mark.parametrize("differ", [True, False])
def test_perceptual_md_links_a_picture_only_where_cells_disagree(differ):
    rows = _rows() if differ else _rows()[:2]
    text = perceptual_report(rows, pictures={"cvvdp": "disagree_cvvdp.webp"})
    assert ("](disagree_cvvdp.webp)" in text) == differ


def test_the_tiles_shown_are_kept_in_the_pages_strips_and_draw_the_same_picture_again(tmp_path):
    # The page strips each crop to the tiles it shows (its key denoisers); a disagreeing cell's
    # denoiser need not be one, and --report-only draws the pictures from the strips.
    from benchmarks.reports import page

    records = _crops(tmp_path)
    first = disagreement.write_disagreements(tmp_path, records, _rows())
    before = (tmp_path / first["cvvdp"]).read_bytes()
    kept = disagreement.shown_tiles(tmp_path, records, _rows())
    assert kept == {
        "crops/direct_white_4spp.npz": {"denoised/gaussian"},
        "crops/direct_ldbn_4spp.npz": {"denoised/gaussian"},
    }
    page._options(tmp_path, [r for r in records if r.cell.spp == 4], ["atrous"], kept)
    assert not list((tmp_path / "crops").glob("*4spp.npz"))  # stripped
    again = disagreement.write_disagreements(tmp_path, records, _rows())
    assert again == first and (tmp_path / first["cvvdp"]).read_bytes() == before
