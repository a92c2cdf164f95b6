"""Tests for bnerr.permutation.permute's grouped and offset sort pass (docs/METHODS.md, section 8):
groups and grid offsets agree on every path (native, torch, slow twin), the plain pass is the
paper's bit for bit, each group sorts against its own mask values, typed errors, CUDA against the
CPU."""

import pytest
import torch
from hypothesis import example, given
from hypothesis import strategies as st

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS
from bnerr.errors import DtypeError, ShapeError, ValueRangeError
from bnerr.permutation import permute
from bnerr.permutation.permute import (
    SortPass,
    SortPlan,
    luminance,
    plan_sort,
    sort_pass,
    sort_pass_reference,
    sort_torch,
)
from tests.bnerr.permutation._permute_cases import permute_case


def _groups(gen: torch.Generator, h: int, w: int, kind: str) -> torch.Tensor | None:
    """Adversarial group labels: none, all one group, one pixel per group, few, huge values."""
    if kind == "none":
        return None
    if kind == "one":
        return torch.zeros(h, w, dtype=torch.int64)
    if kind == "each":
        return torch.randperm(h * w, generator=gen).view(h, w)
    if kind == "extreme":  # the padding's label itself, and the smallest int64
        table = torch.tensor([2**63 - 1, -(2**63), 0])
        return table[torch.randint(0, 3, (h, w), generator=gen)]
    return torch.randint(-1, 3, (h, w), generator=gen).to(torch.int32)


@given(
    h=st.integers(1, 30),
    w=st.integers(1, 30),
    block=st.integers(2, 8),
    oy=st.integers(0, 7),
    ox=st.integers(0, 7),
    kind=st.sampled_from(["none", "one", "each", "few", "extreme"]),
    channels=st.sampled_from([0, 3]),
    special=st.sampled_from([0.0, 0.3]),
    seed=st.integers(0, 2**16),
)
@example(h=30, w=30, block=8, oy=7, ox=7, kind="few", channels=3, special=0.3, seed=1)
@example(h=1, w=1, block=2, oy=1, ox=1, kind="each", channels=0, special=1.0, seed=2)
@example(h=17, w=29, block=4, oy=2, ox=2, kind="extreme", channels=0, special=0.3, seed=3)
def test_groups_and_grid_offsets_agree_on_every_path(
    h, w, block, oy, ox, kind, channels, special, seed
):
    oy, ox = oy % block, ox % block
    seeds, values, mask = permute_case(seed, h, w, channels, special)
    groups = _groups(torch.Generator().manual_seed(seed + 1), h, w, kind)
    want = sort_pass_reference(seeds, values, mask, block, groups=groups, grid_offset=(oy, ox))
    got = sort_pass(seeds, values, mask, block, groups=groups, grid_offset=(oy, ox))
    plan = plan_sort(mask, block, (oy, ox))
    labels = None if groups is None else groups.long()
    assert torch.equal(got, want)
    assert torch.equal(sort_torch(seeds, luminance(values), plan, labels), want)
    kernels = permute._native_kernels()
    if kernels is not None:
        fast = native.native_sort_blocks(
            kernels, seeds, values.float(), plan.order, block, LUMINANCE_WEIGHTS,
            groups=labels, grid_offset=(oy, ox),
        )  # fmt: skip
        assert torch.equal(fast, want)
    # A bijection inside every shifted block and, with groups, inside every group of it.
    for y0 in range(-oy, h, block):
        for x0 in range(-ox, w, block):
            ys, xs = slice(max(y0, 0), y0 + block), slice(max(x0, 0), x0 + block)
            before, after = seeds[ys, xs].reshape(-1), got[ys, xs].reshape(-1)
            if groups is None:
                assert sorted(before.tolist()) == sorted(after.tolist())
                continue
            g = groups[ys, xs].reshape(-1).tolist()
            for label in set(g):
                picked = [i for i, v in enumerate(g) if v == label]
                assert sorted(before[picked].tolist()) == sorted(after[picked].tolist())


def test_one_pixel_groups_keep_every_seed_and_one_group_is_the_plain_pass():
    seeds, values, mask = permute_case(21, 23, 19, 3, 0.3)
    each = torch.arange(23 * 19).view(23, 19)
    assert torch.equal(sort_pass(seeds, values, mask, 4, groups=each), seeds)
    one = torch.full((23, 19), 5)
    assert torch.equal(
        sort_pass(seeds, values, mask, 4, groups=one), sort_pass(seeds, values, mask)
    )


def test_zero_offset_and_no_groups_stay_bit_identical_to_the_paper_pass():
    seeds, values, mask = permute_case(22, 41, 67, 3, 0.2)
    plain = sort_pass(seeds, values, mask, 4)
    assert torch.equal(sort_pass(seeds, values, mask, 4, grid_offset=(0, 0)), plain)
    assert torch.equal(sort_pass(seeds, values, plan_sort(mask, 4, (0, 0)), 4), plain)
    assert torch.equal(sort_pass_reference(seeds, values, mask, 4), plain)
    # The op's original four-argument call is unchanged.
    assert torch.equal(torch.ops.bnerr.sort_pass(seeds, values, plan_sort(mask, 4).order, 4), plain)


def test_grid_offset_moves_the_block_boundaries():
    # One 4x4 grid shifted by (2, 2): the top-left block holds only pixels (0..1, 0..1).
    seeds = torch.arange(36).view(6, 6)
    values = -torch.arange(36.0).view(6, 6)  # reversed everywhere
    mask = torch.arange(36.0).view(6, 6)
    out = sort_pass(seeds, values, mask, 4, grid_offset=(2, 2))
    assert out[:2, :2].reshape(-1).tolist() == [7, 6, 1, 0]
    assert out[2:6, 2:6].reshape(-1).tolist() == [
        v for v in reversed(seeds[2:6, 2:6].reshape(-1).tolist())
    ]


def test_groups_sort_each_group_against_its_own_mask_values():
    # One 2x2 block, groups {a: (0,0), (1,1)} and {b: (0,1), (1,0)}.
    seeds = torch.tensor([[10, 11], [12, 13]])
    groups = torch.tensor([[0, 1], [1, 0]])
    values = torch.tensor([[5.0, 1.0], [2.0, 4.0]])  # a: 13 < 10; b: 11 < 12
    mask = torch.tensor([[0.1, 0.4], [0.2, 0.3]])  # a: (0,0) < (1,1); b: (1,0) < (0,1)
    out = sort_pass(seeds, values, mask, 2, groups=groups)
    assert out.tolist() == [[13, 12], [11, 10]]


def test_groups_and_grid_offset_errors_are_typed():
    seeds, values, mask = permute_case(23, 8, 8, 0, 0.0)
    with pytest.raises(ValueRangeError, match=r"grid_offset: expected \(oy, ox\) in \[0, 4\)"):
        sort_pass(seeds, values, mask, 4, grid_offset=(4, 0))
    with pytest.raises(DtypeError, match=r"grid_offset: expected a pair of integers"):
        sort_pass(seeds, values, mask, 4, grid_offset=(1.0, 0))
    with pytest.raises(ValueRangeError, match=r"grid_offset: expected the plan's grid offset"):
        sort_pass(seeds, values, plan_sort(mask, 4, (1, 1)), 4, grid_offset=(0, 0))
    with pytest.raises(DtypeError, match=r"groups: expected dtype .*, got float32"):
        sort_pass(seeds, values, mask, 4, groups=values)
    with pytest.raises(ShapeError, match=r"groups: expected H x W = 8 x 8 like seeds, got 8 x 7"):
        sort_pass(seeds, values, mask, 4, groups=torch.zeros(8, 7, dtype=torch.int64))
    with pytest.raises(ShapeError, match=r"SortPlan.order: expected shape \[6, 16\]"):
        SortPlan(block=4, height=8, width=8, order=torch.zeros(4, 16, dtype=torch.uint8),
                 grid_offset=(1, 0))  # fmt: skip
    plan = plan_sort(mask, 4, (3, 1))
    assert plan.grid_offset == (3, 1) and plan.order.shape == (3 * 3, 16)
    module = SortPass(4)
    assert torch.equal(
        module(seeds, values, mask, grid_offset=(3, 1)), sort_pass(seeds, values, plan, 4)
    )


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_groups_and_offsets_match_cpu():
    seeds, values, mask = permute_case(24, 37, 53, 3, 0.3)
    groups = _groups(torch.Generator().manual_seed(3), 37, 53, "few")
    want = sort_pass(seeds, values, mask, 4, groups=groups, grid_offset=(1, 3))
    got = sort_pass(
        seeds.cuda(), values.cuda(), mask.cuda(), 4, groups=groups.cuda(), grid_offset=(1, 3)
    )
    assert torch.equal(got.cpu(), want)
