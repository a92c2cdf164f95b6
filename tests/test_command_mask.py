"""``bnerr mask``: writes the mask it reports, in every format, and rejects bad arguments."""

import numpy as np
import pytest

from benchmarks.cli import main
from bnerr.io import read_exr
from bnerr.masks import void_and_cluster


def test_npy_holds_the_generated_mask_and_the_report_names_the_fraction(tmp_path, capsys):
    out = tmp_path / "m.npy"
    assert main(["mask", "--size", "16", "--seed", "3", "--out", str(out)]) == 0
    saved = np.load(out)
    assert np.array_equal(saved, void_and_cluster(16, seed=3).numpy())
    printed = capsys.readouterr().out
    assert "low-frequency fraction" in printed and " s -> " in printed


def test_exr_round_trips_a_vector_mask(tmp_path):
    out = tmp_path / "v.exr"
    assert main(["mask", "--size", "16", "--dims", "2", "--iterations", "2", "--out", str(out)]) == 0
    mask = read_exr(out)["mask"]
    assert mask.shape == (2, 16, 16)
    for channel in mask:  # swaps of whole vectors keep each channel a permutation of (k+0.5)/N
        assert np.allclose(np.sort(channel.numpy().ravel()), (np.arange(256) + 0.5) / 256)


def test_png_stores_the_mask_values_as_8_bit(tmp_path):
    from skimage.io import imread

    out = tmp_path / "m.png"
    assert main(["mask", "--size", "16", "--out", str(out)]) == 0
    stored = imread(out)[..., 0].astype(np.float64)
    expected = np.round(255 * void_and_cluster(16).numpy().astype(np.float64))
    assert np.abs(stored - expected).max() <= 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--size", "16", "--out", "m.tiff"], "expected a .npy, .exr, .png file"),
        (["--size", "-4", "--out", "m.npy"], "size"),
    ],
)
def test_bad_arguments_exit_2_with_a_message(tmp_path, capsys, argv, message):
    argv = [a if not a.startswith("m.") else str(tmp_path / a) for a in argv]
    assert main(["mask", *argv]) == 2
    assert message in capsys.readouterr().err
