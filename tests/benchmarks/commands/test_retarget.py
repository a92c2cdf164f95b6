"""Tests for benchmarks.commands.retarget (``bnerr retarget``): a valid field written from a mask,
bad suffixes and files refused, a constant or shift-invariant mask refused before any work."""

import numpy as np
import pytest
import torch

from benchmarks.cli import main as cli_main
from benchmarks.commands.retarget import _identity_energy, _mask
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.permutation.retarget import check_displacement


def test_command_writes_a_valid_field_and_refuses_bad_files(tmp_path, capsys):
    np.save(
        tmp_path / "mask.npy",
        torch.rand(16, 16, generator=torch.Generator().manual_seed(1)).numpy(),
    )
    out = tmp_path / "r.npy"
    code = cli_main(
        [
            "retarget",
            "--mask",
            str(tmp_path / "mask.npy"),
            "--method",
            "anneal",
            "--iterations",
            "50",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "energy" in text and "identity" in text and "ratio" in text
    check_displacement(torch.from_numpy(np.load(out)).long())
    assert (
        cli_main(
            ["retarget", "--mask", str(tmp_path / "mask.npy"), "--out", str(tmp_path / "r.txt")]
        )
        == 2
    )
    with pytest.raises(FileFormatError, match=r"expected a \.npy array"):
        (tmp_path / "bad.npy").write_text("nope")
        _mask(type("A", (), {"mask": tmp_path / "bad.npy", "size": 16})())


def test_command_refuses_a_constant_mask_before_writing(tmp_path, capsys):
    # A constant mask gives every field energy 0: once a ZeroDivisionError after the output was
    # written; now a typed error before any work, and no file.
    np.save(tmp_path / "flat.npy", np.full((16, 16), 0.5, np.float32))
    out = tmp_path / "r.npy"
    args = ["retarget", "--mask", str(tmp_path / "flat.npy"), "--method", "anneal"]
    assert cli_main([*args, "--iterations", "5", "--out", str(out)]) == 2
    assert "mask: expected at least two distinct values" in capsys.readouterr().err
    assert not out.exists()
    # Not constant, but equal to its own shift by the step: refused the same way.
    stripes = torch.arange(16.0).repeat(16, 1) % 2  # period 2 along x; the step (0, 2) keeps it
    with pytest.raises(ValueRangeError, match=r"mask: expected a mask that changes under"):
        _identity_energy(stripes, (0, 2))
    assert _identity_energy(stripes, (0, 1)) == 1.0
