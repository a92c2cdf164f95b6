"""Tests of benchmarks.reports.previews: the crops kept as lossless WebP strips."""

import numpy as np
import pytest
from PIL import Image

from benchmarks.reports.previews import crop_strip, load_crop
from bnerr.errors import FileFormatError


def _crop(tmp_path):
    (tmp_path / "crops").mkdir()
    images = {
        "reference": np.full((4, 4, 3), 100, np.uint8),
        "raw": np.arange(48, dtype=np.uint8).reshape(4, 4, 3),
        "denoised__oidn": np.full((4, 4, 3), 95, np.uint8),
    }
    np.savez_compressed(tmp_path / "crops" / "c.npz", **images)
    return "crops/c.npz", {k.replace("__", "/"): v for k, v in images.items()}


def test_the_npz_becomes_a_lossless_strip_that_loads_in_its_place(tmp_path):
    crop, images = _crop(tmp_path)
    rel, names = crop_strip(tmp_path, crop)
    assert rel == "crops/c.webp" and names == ["reference", "raw", "denoised/oidn"]
    assert not (tmp_path / "crops" / "c.npz").exists()
    assert np.asarray(Image.open(tmp_path / rel)).shape == (4, 12, 3)  # at the crop's size
    loaded = load_crop(tmp_path, crop)  # the record still names the .npz
    assert list(loaded) == names and all(np.array_equal(loaded[n], images[n]) for n in names)
    assert crop_strip(tmp_path, crop) == (rel, names)  # the second time: read, not written


def test_missing_crops_are_none_and_bad_files_are_typed_errors(tmp_path):
    assert load_crop(tmp_path, None) is None and load_crop(tmp_path, "crops/x.npz") is None
    assert crop_strip(tmp_path, "crops/x.npz") is None and crop_strip(tmp_path, None) is None
    (tmp_path / "bad.npz").write_text("not a zip")
    with pytest.raises(FileFormatError, match="bad.npz"):
        load_crop(tmp_path, "bad.npz")
    Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "plain.png")
    with pytest.raises(FileFormatError, match="plain.png"):
        load_crop(tmp_path, "plain.npz")  # a PNG without the tile names


def test_an_older_png_strip_becomes_a_webp_strip_with_the_same_tiles(tmp_path):
    from PIL.PngImagePlugin import PngInfo

    crop, images = _crop(tmp_path)
    (tmp_path / "crops" / "c.npz").unlink()
    info = PngInfo()
    info.add_text("tiles", '["reference", "raw", "denoised/oidn"]')
    strip = np.concatenate(list(images.values()), axis=1)
    Image.fromarray(strip).save(tmp_path / "crops" / "c.png", pnginfo=info)
    assert list(load_crop(tmp_path, crop)) == list(images)  # read from the PNG
    rel, names = crop_strip(tmp_path, crop)
    assert rel == "crops/c.webp" and not (tmp_path / "crops" / "c.png").exists()
    loaded = load_crop(tmp_path, crop)
    assert all(np.array_equal(loaded[n], images[n]) for n in names)


def test_a_strip_keeps_the_tiles_a_page_shows(tmp_path):
    crop, images = _crop(tmp_path)
    shown = ["raw", "reference"]  # the strip keeps the crops' order
    assert crop_strip(tmp_path, crop, keep=shown) == ("crops/c.webp", ["reference", "raw"])
    assert np.asarray(Image.open(tmp_path / "crops" / "c.webp")).shape == (4, 8, 3)
    loaded = load_crop(tmp_path, crop)
    assert list(loaded) == ["reference", "raw"]
    assert all(np.array_equal(loaded[n], images[n]) for n in loaded)
    # a strip already holding only kept tiles is read, not written again
    written = (tmp_path / "crops" / "c.webp").stat().st_mtime_ns
    assert crop_strip(tmp_path, crop, keep=[*shown, "denoised/oidn"])[1] == ["reference", "raw"]
    assert (tmp_path / "crops" / "c.webp").stat().st_mtime_ns == written
    assert crop_strip(tmp_path, crop, keep=["denoised/taa"]) is None  # nothing to keep


def test_an_existing_strip_with_more_tiles_is_written_again_without_them(tmp_path):
    crop, images = _crop(tmp_path)
    crop_strip(tmp_path, crop)  # every tile
    assert crop_strip(tmp_path, crop, keep=["reference", "denoised/oidn"])[1] == [
        "reference",
        "denoised/oidn",
    ]
    loaded = load_crop(tmp_path, crop)
    assert all(np.array_equal(loaded[n], images[n]) for n in ["reference", "denoised/oidn"])
