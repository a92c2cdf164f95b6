"""``bnerr export``: every format holds the shipped arrays in the documented layout."""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.commands.export import export_array
from bnerr.io import read_exr
from bnerr.masks.fast import load_fast_mask


def _keys() -> np.ndarray:
    rng = np.random.default_rng(0)
    scramble = rng.integers(0, 1 << 24, (3, 4, 4, 4), dtype=np.int32)
    rank = rng.integers(0, 4, (3, 4, 4, 2), dtype=np.int32)
    return np.concatenate([scramble, rank], -1)


def test_exr_holds_the_keys_exactly_and_npy_as_shipped(tmp_path):
    keys = _keys()
    paths = export_array(tmp_path, "k", keys, "exr", keys=True)
    assert len(paths) == 3
    for s, path in enumerate(paths):
        got = read_exr(path)["c"].numpy()  # [C, T, T]
        assert np.array_equal(got.transpose(1, 2, 0).astype(np.int64), keys[s])
    (npy,) = export_array(tmp_path, "k", keys, "npy", keys=True)
    assert np.array_equal(np.load(npy), keys)


def test_png_holds_the_top_16_bits_of_scrambling_keys_and_the_ranks(tmp_path):
    from skimage.io import imread

    keys = _keys()
    paths = export_array(tmp_path, "k", keys, "png", keys=True)
    assert len(paths) == 3 * 6
    assert np.array_equal(imread(tmp_path / "k_1_c2.png"), keys[1, ..., 2] >> 8)
    assert np.array_equal(imread(tmp_path / "k_2_c5.png"), keys[2, ..., 5])


def test_header_is_pixel_major(tmp_path):
    keys = _keys()
    (path,) = export_array(tmp_path, "k", keys, "h", keys=True)
    text = path.read_text()
    assert "#define K_SLICES 3" in text and "#define K_CHANNELS 6" in text
    values = [int(v) for v in re.findall(r"(\d+)u", text.split("{", 1)[1])]
    assert values == keys.reshape(-1).tolist()


def test_command_exports_the_fast_mask_and_an_ldbn_set(tmp_path, capsys):
    assert main(["export", "--fast", "--format", "npy", "--out", str(tmp_path)]) == 0
    assert np.array_equal(np.load(tmp_path / "fast_gauss_64.npy")[0, ..., 0], load_fast_mask(64))
    assert main(["export", "--ldbn", "screen", "--format", "npy", "--out", str(tmp_path)]) == 0
    shipped = np.load(tmp_path / "ldbn_screen_64.npy")
    assert shipped.shape == (5, 64, 64, 12)
    assert "ldbn_screen_64: [5, 64, 64, 12]" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["--format", "npy"], ["--fast", "--format", "tiff"]])
def test_bad_arguments_exit_2(tmp_path, argv):
    assert main(["export", *argv, "--out", str(tmp_path)]) == 2
