"""Tests of bnerr.sequences.owen_sobol (and its direction tables, tables.py): the twin's direction
numbers are Joe and Kuo's, dimension pairs are (0, m, 2)-nets, and why dimensions are padded by
pairs."""

from __future__ import annotations

import torch

from bnerr.sequences import (
    OwenSobolSampler,
    tables,
)
from tests.bnerr.sequences._samplers import sobol_directions, sobol_point


def test_twin_direction_numbers_are_joe_kuo():
    # Joe & Kuo's dimension 2 (s = 1, a = 0, m = 1) is the Pascal matrix mod 2.
    assert [hex(v) for v in sobol_directions(1)[:5]] == [
        "0x80000000", "0xc0000000", "0xa0000000", "0xf0000000", "0x88000000",
    ]  # fmt: skip


def _is_net(points: torch.Tensor, m: int) -> bool:
    """Every elementary interval of area 2^-m of every shape holds exactly one point."""
    cells = (points.double() * 2**24).long()  # exact: values are multiples of 2^-24
    for a in range(m + 1):
        cell = (cells[:, 0] >> (24 - a)) * 2 ** (m - a) + (cells[:, 1] >> (24 - (m - a)))
        if not bool((torch.bincount(cell, minlength=2**m) == 1).all()):
            return False
    return True


def test_owen_sobol_pairs_are_nets():
    sampler = OwenSobolSampler()
    n = 256
    index = torch.arange(n, dtype=torch.int64)
    for seed in (0, 1, 12345, 2**32 - 1, -7):
        values = sampler.sample(torch.full((n,), seed, dtype=torch.int64), index, 0, 12)
        for pair in range(6):
            for m in range(1, 9):
                assert _is_net(values[: 2**m, 2 * pair : 2 * pair + 2], m), (seed, pair, m)


def test_sobol_dimensions_2_3_are_not_nets_which_is_why_we_pad_by_pairs():
    # The docstring's reason for padding by 2D pairs: Joe-Kuo's Sobol dimensions 2 and 3
    # (polynomials x^2 + x + 1 and x^3 + x + 1) fail the net test for m = 2, while (0, 1) pass.
    def points(*directions: list[int]) -> torch.Tensor:
        words = [[sobol_point(i, v) for v in directions] for i in range(4)]
        return torch.tensor(words, dtype=torch.float64) / 2**32

    dim2 = tables.sobol_directions(2, 1, (1, 3))
    dim3 = tables.sobol_directions(3, 1, (1, 3, 1))
    assert _is_net(points(sobol_directions(0), sobol_directions(1)), 2)
    assert not _is_net(points(dim2, dim3), 2)
