"""Tests of benchmarks.reports.previews: the preview strips and their error maps."""

import numpy as np
import pytest
from PIL import Image

from benchmarks.reports.previews import ERROR_GAIN, load_crop, tile_names, write_previews
from bnerr.errors import FileFormatError


def _crop(tmp_path):
    (tmp_path / "crops").mkdir()
    ref = np.full((4, 4, 3), 100, np.uint8)
    raw = np.full((4, 4, 3), 110, np.uint8)
    den = np.full((4, 4, 3), 95, np.uint8)
    np.savez_compressed(
        tmp_path / "crops" / "c.npz", reference=ref, raw=raw, denoised__oidn=den, denoised__box=den
    )
    return "crops/c.npz"


def test_a_strip_holds_reference_raw_and_key_denoisers_with_error_maps(tmp_path):
    rel, names = write_previews(tmp_path, _crop(tmp_path), ["oidn", "taa"])
    assert rel == "previews/c.png"
    assert names == ["reference", "raw", "raw/error", "denoised/oidn", "denoised/oidn/error"]
    strip = np.asarray(Image.open(tmp_path / rel))
    assert strip.shape == (4, 4 * len(names), 3)  # at the crop's size
    assert strip[0, 8, 0] == 10 * ERROR_GAIN and strip[0, 16, 0] == 5 * ERROR_GAIN


def test_missing_crops_are_none_and_a_bad_file_is_a_typed_error(tmp_path):
    assert load_crop(tmp_path, None) is None and load_crop(tmp_path, "crops/x.npz") is None
    assert write_previews(tmp_path, "crops/x.npz", ["oidn"]) is None
    (tmp_path / "bad.npz").write_text("not a zip")
    with pytest.raises(FileFormatError, match="bad.npz"):
        load_crop(tmp_path, "bad.npz")


def test_tile_names_skip_denoisers_the_crop_lacks():
    crop = {"reference": 0, "raw": 0, "denoised/oidn": 0}
    assert tile_names(crop, ["taa"]) == ["reference", "raw", "raw/error"]
