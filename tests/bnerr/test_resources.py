"""Tests for bnerr.resources: the shipped arrays load checked, a mismatch is a FileFormatError."""

import numpy as np
import pytest

from bnerr.errors import FileFormatError
from bnerr.resources import data_dir, load_array, shipped_files


def test_shipped_masks_are_listed_and_load_as_owned_arrays():
    names = shipped_files("scalar_")
    assert "scalar_128.npy" in names and names == sorted(names)
    a = load_array("scalar_128.npy", np.float32, (128, 128))
    a[0, 0] = -1.0  # a copy: the next load is unchanged
    assert load_array("scalar_128.npy", np.float32, (128, 128))[0, 0] != -1.0
    assert data_dir().joinpath("scalar_128.npy").is_file()


@pytest.mark.parametrize(
    ("name", "dtype", "shape", "message"),
    [
        ("scalar_128.npy", np.float64, (128, 128), "expected float64"),
        ("scalar_128.npy", np.float32, (64, 64), r"of shape \[64, 64\]"),
        ("no_such_file.npy", np.float32, (1,), "unreadable"),
    ],
)
def test_a_mismatch_names_the_file(name, dtype, shape, message):
    with pytest.raises(FileFormatError, match=message):
        load_array(name, dtype, shape)
