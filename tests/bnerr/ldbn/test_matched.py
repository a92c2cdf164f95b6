"""Tests of bnerr.ldbn.matched: the options for a measured kernel, and the command line writing a
key set in the shipped layout (tiny tile, few iterations), deterministically."""

from __future__ import annotations

import numpy as np
import pytest

from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.ldbn.matched import main, matched_options


def _kernel() -> np.ndarray:
    d = np.arange(-2, 3)
    return np.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / 2.0)


def test_options_take_the_kernel_and_the_levels():
    opts = matched_options(_kernel(), spp=4, size=8, iterations=3)
    assert opts.levels == 3 and opts.dims == 8 and opts.size == 8
    assert np.allclose(np.array(opts.kernel), _kernel())
    assert opts.device == "cpu"
    assert matched_options(_kernel(), spp=4, device="cuda:1").device == "cuda:1"
    with pytest.raises(ValueRangeError, match="power of two"):
        matched_options(_kernel(), spp=3)


def test_the_command_writes_keys_and_a_rerun_is_the_same(tmp_path, capsys):
    np.save(tmp_path / "k.npy", _kernel())
    args = ["--kernel", str(tmp_path / "k.npy"), "--spp", "2", "--size", "8"]
    args += ["--iterations", "2", "--threads", "1"]
    assert main([*args, "--out", str(tmp_path / "a.npy")]) == 0
    assert main([*args, "--out", str(tmp_path / "b.npy")]) == 0
    a, b = np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy")
    assert a.shape == (2, 1, 8, 8, 12) and a.dtype == np.int32 and np.array_equal(a, b)
    assert not (tmp_path / "a.ckpt.npz").exists() and "sha256" in capsys.readouterr().out
    with pytest.raises(FileFormatError, match=".npy"):
        main([*args, "--out", str(tmp_path / "a.txt")])
