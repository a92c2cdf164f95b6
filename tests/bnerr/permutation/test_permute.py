"""Tests for bnerr.permutation.permute: the sorting pass against its reference twin (native, torch
and slow paths bit for bit), the torch op, its properties (groups and grid offsets:
test_permute_groups.py), histogram sampling, and typed errors."""

import math

import pytest
import torch
from hypothesis import example, given
from hypothesis import strategies as st

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS
from bnerr.errors import DtypeError, NonFiniteError, ShapeError, ValueRangeError
from bnerr.permutation import permute
from bnerr.permutation.permute import (
    SortPass,
    SortPlan,
    histogram_select,
    luminance,
    plan_sort,
    sort_pass,
    sort_pass_reference,
    sort_torch,
)
from tests._images import block_multisets
from tests._twins import REC709
from tests.bnerr.permutation._permute_cases import adversarial_values, permute_case


@given(
    h=st.integers(1, 37),
    w=st.integers(1, 53),
    block=st.integers(2, 8),
    channels=st.sampled_from([0, 1, 3]),
    special=st.sampled_from([0.0, 0.3, 1.0]),
    seed=st.integers(0, 2**16),
)
@example(h=37, w=53, block=8, channels=3, special=0.3, seed=1)
@example(h=37, w=53, block=5, channels=0, special=1.0, seed=2)
@example(h=1, w=1, block=2, channels=3, special=1.0, seed=3)
def test_fast_op_equals_reference_and_permutes_inside_blocks(h, w, block, channels, special, seed):
    seeds, values, mask = permute_case(seed, h, w, channels, special)
    want = sort_pass_reference(seeds, values, mask, block)
    got = sort_pass(seeds, values, mask, block)  # native kernel where available
    plan = plan_sort(mask, block)
    torch_path = sort_torch(seeds, luminance(values), plan)
    assert torch.equal(got, want)
    assert torch.equal(torch_path, want)
    kernels = permute._native_kernels()
    if kernels is not None:  # the fast path itself, called directly, on luminance and on planes
        for keys in {luminance(values), values.float()} if channels == 3 else {luminance(values)}:
            fast = native.native_sort_blocks(
                kernels, seeds, keys, plan.order, block, LUMINANCE_WEIGHTS
            )
            assert torch.equal(fast, want)
    assert got.dtype == torch.int64 and got.shape == (h, w)
    assert block_multisets(got, block) == block_multisets(seeds, block)


@given(
    h=st.integers(1, 24), w=st.integers(1, 24), block=st.integers(2, 8), seed=st.integers(0, 2**16)
)
def test_sorted_seeds_follow_the_mask_order(h, w, block, seed):
    # If a seed's value is a fixed function of the seed, re-rendering after the pass must give
    # values whose order inside every block is the mask's order (distinct values and mask).
    gen = torch.Generator().manual_seed(seed)
    seeds = torch.randperm(h * w, generator=gen).view(h, w)
    value_of = torch.rand(h * w, generator=gen)
    mask = torch.rand(h, w, generator=gen)
    out = sort_pass(seeds, value_of[seeds], mask, block)
    again = value_of[out]
    for y in range(0, h, block):
        for x in range(0, w, block):
            v = again[y : y + block, x : x + block].reshape(-1)
            m = mask[y : y + block, x : x + block].reshape(-1)
            assert torch.equal(torch.argsort(v), torch.argsort(m))


def test_nan_and_infinities_order_deterministically():
    # One 2x2 block: mask ranks 0..3 at (0,0), (0,1), (1,0), (1,1).
    seeds = torch.tensor([[10, 11], [12, 13]])
    mask = torch.tensor([[0.1, 0.2], [0.3, 0.4]])
    values = torch.tensor([[float("nan"), float("inf")], [-0.0, float("-inf")]])
    # Order: -inf (13), -0.0 (12), +inf (11), NaN (10).
    assert sort_pass(seeds, values, mask, 2).tolist() == [[13, 12], [11, 10]]
    # Every NaN is equal (any sign, any payload): ties keep the pixel order.
    nans = torch.tensor([0x7FC00000, -0x00400000, 0x7F800001, 0x7FFFFFFF], dtype=torch.int32).view(
        torch.float32
    )
    assert sort_pass(seeds, nans.view(2, 2), mask, 2).tolist() == [[10, 11], [12, 13]]
    # -0.0 equals +0.0: a tie, stable.
    zeros = torch.tensor([[0.0, -0.0], [0.0, -0.0]])
    assert sort_pass(seeds, zeros, mask, 2).tolist() == [[10, 11], [12, 13]]


def test_partial_blocks_sort_only_their_own_pixels():
    seeds = torch.arange(15).view(3, 5)
    values = -torch.arange(15.0).view(3, 5)  # reversed order everywhere
    mask = torch.arange(15.0).view(3, 5)
    out = sort_pass(seeds, values, mask, 4)
    # Blocks: rows 0-2 x cols 0-3 (12 pixels) and rows 0-2 x col 4 (3 pixels), each reversed.
    assert out[:, :4].reshape(-1).tolist() == [13, 12, 11, 10, 8, 7, 6, 5, 3, 2, 1, 0]
    assert out[:, 4].tolist() == [14, 9, 4]


def test_thread_count_and_repeats_give_bit_identical_output():
    gen = torch.Generator().manual_seed(5)
    h, w = 301, 263  # above the kernel's threading threshold, partial blocks on both borders
    seeds = torch.randperm(h * w, generator=gen).view(h, w)
    color = adversarial_values(gen, (3, h, w), 0.05)
    mask = torch.rand(h, w, generator=gen)
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = sort_pass(seeds, color, mask, 4)
        torch.set_num_threads(2)
        two = sort_pass(seeds, color, mask, 4)
    finally:
        torch.set_num_threads(before)
    assert torch.equal(one, two)
    assert torch.equal(one, sort_pass(seeds, color, mask, 4))
    assert torch.equal(one, sort_torch(seeds, luminance(color), plan_sort(mask, 4)))


def test_native_kernel_status_is_reported():
    # The kernel is optional; whichever way it went, the reason is stated.
    assert isinstance(native.status(), str) and native.status()
    assert native.available() == (native.load() is not None)
    if native.available():
        assert permute._native_kernels() is native.load()  # passed its self-check


def test_sort_pass_is_a_torch_op_with_a_fake_implementation():
    seeds, values, mask = permute_case(11, 13, 18, 3, 0.3)
    plan = plan_sort(mask, 4)
    op = torch.ops.bnerr.sort_pass
    assert torch.equal(op(seeds, values, plan.order, 4), sort_pass(seeds, values, plan, 4))
    assert torch.equal(
        op.default(seeds, values[0], plan.order, 4), sort_pass(seeds, values[0], plan)
    )
    with torch._subclasses.fake_tensor.FakeTensorMode() as mode:
        fake = op(
            mode.from_tensor(seeds), mode.from_tensor(values), mode.from_tensor(plan.order), 4
        )
    assert fake.shape == seeds.shape and fake.dtype == torch.int64


def test_sort_pass_op_composes_with_torch_compile():
    # aot_eager traces through the fake implementation without generating code: small and fast.
    if not torch._dynamo.is_dynamo_supported():
        pytest.skip("torch.compile is unavailable here (dynamo does not support this Python)")
    from torch._dynamo.testing import CompileCounterWithBackend

    seeds, values, mask = permute_case(12, 12, 16, 3, 0.0)
    order = plan_sort(mask, 4).order

    def step(seeds, values, order):
        return torch.ops.bnerr.sort_pass(seeds, values * 2.0, order, 4) + 1

    counter = CompileCounterWithBackend("aot_eager")
    got = torch.compile(step, backend=counter, fullgraph=False)(seeds, values, order)
    assert torch.equal(got, step(seeds, values, order))
    assert counter.frame_count == 1  # one graph: the op did not break it


def test_plan_is_cached_per_mask_tensor_and_renewed_after_in_place_edits():
    gen = torch.Generator().manual_seed(3)
    seeds = torch.randperm(64).view(8, 8)
    values = torch.rand(8, 8, generator=gen)
    mask = torch.rand(8, 8, generator=gen)
    first = sort_pass(seeds, values, mask, 4)
    mask.mul_(-1)  # reverses the mask order in place
    second = sort_pass(seeds, values, mask, 4)
    assert torch.equal(second, sort_pass_reference(seeds, values, mask, 4))
    assert not torch.equal(first, second)


def test_explicit_plan_and_module_equal_the_function():
    gen = torch.Generator().manual_seed(4)
    seeds = torch.randperm(10 * 13, generator=gen).view(10, 13)
    color = torch.rand(3, 10, 13, generator=gen)
    mask = torch.rand(10, 13, generator=gen)
    plan = plan_sort(mask, 3)
    assert (
        isinstance(plan, SortPlan)
        and plan.order.shape == (4 * 5, 9)
        and plan.order.dtype == torch.uint8
    )
    want = sort_pass(seeds, color, mask, 3)
    assert torch.equal(sort_pass(seeds, color, plan, 3), want)
    module = SortPass(block=3)
    assert torch.equal(module(seeds, color, mask), want)
    assert "block=3" in repr(module)


def test_luminance_uses_rec709_weights_in_float32():
    rgb = torch.tensor([1.0, 0.0, 0.0]).view(3, 1, 1) * torch.ones(3, 2, 2)
    assert torch.allclose(luminance(rgb), torch.full((2, 2), REC709[0]))
    color = torch.rand(3, 4, 5, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    lum = luminance(color)
    assert lum.dtype == torch.float32 and lum.shape == (4, 5)
    c = color.float()
    w0, w1, w2 = REC709  # the test's own copy of ITU-R BT.709-6, item 3.2 (tests/_twins.py)
    assert LUMINANCE_WEIGHTS == REC709
    assert torch.equal(lum, w0 * c[0] + w1 * c[1] + w2 * c[2])
    assert torch.equal(luminance(c[:1]), c[0])
    assert torch.equal(luminance(c[0]), c[0])
    with pytest.raises(ShapeError, match=r"values: expected .*3"):
        luminance(torch.rand(2, 4, 5))


def test_sort_pass_rejects_bad_input_with_typed_errors():
    seeds = torch.arange(16).view(4, 4)
    values = torch.rand(4, 4)
    mask = torch.rand(4, 4)
    with pytest.raises(DtypeError, match=r"seeds: expected dtype int64, got int32"):
        sort_pass(seeds.int(), values, mask)
    with pytest.raises(DtypeError, match=r"values: expected dtype .*float32.*, got int64"):
        sort_pass(seeds, seeds, mask)
    with pytest.raises(DtypeError, match=r"mask: expected dtype .*float32.*, got int64"):
        sort_pass(seeds, values, seeds)
    with pytest.raises(ValueRangeError, match=r"block: expected an integer in \[2, 8\], got 9"):
        sort_pass(seeds, values, mask, 9)
    with pytest.raises(ValueRangeError, match=r"block: expected an integer in \[2, 8\], got 1"):
        sort_pass(seeds, values, mask, 1)
    with pytest.raises(DtypeError, match=r"block: expected an integer"):
        sort_pass(seeds, values, mask, 2.0)
    with pytest.raises(ShapeError, match=r"values: expected H x W = 4 x 4 like seeds, got 4 x 5"):
        sort_pass(seeds, torch.rand(4, 5), mask)
    with pytest.raises(
        ShapeError, match=r"values: expected \[H, W\] or \[C, H, W\] with C = 1 or 3"
    ):
        sort_pass(seeds, torch.rand(2, 4, 4), mask)
    with pytest.raises(ShapeError, match=r"mask: expected H x W = 4 x 4 like seeds, got 5 x 4"):
        sort_pass(seeds, values, torch.rand(5, 4))
    with pytest.raises(ShapeError, match=r"seeds: expected 2 dimensions"):
        sort_pass(seeds.view(-1), values, mask)
    with pytest.raises(DtypeError, match=r"seeds: expected a torch.Tensor, got list"):
        sort_pass([[1]], values, mask)
    with pytest.raises(ValueRangeError, match=r"block: expected the plan's block size 2, got 4"):
        sort_pass(seeds, values, plan_sort(mask, 2), 4)
    with pytest.raises(ShapeError, match=r"mask: expected a plan for H x W = 4 x 4"):
        sort_pass(seeds, values, plan_sort(torch.rand(8, 8), 4), 4)
    with pytest.raises(ValueRangeError, match=r"block: expected an integer in \[2, 8\], got 0"):
        SortPass(0)


def test_hand_made_plans_are_checked():
    with pytest.raises(ShapeError, match=r"SortPlan.order: expected shape \[4, 16\]"):
        SortPlan(block=4, height=8, width=8, order=torch.zeros(4, 9, dtype=torch.uint8))
    with pytest.raises(DtypeError, match=r"SortPlan.order: expected dtype uint8, got int64"):
        SortPlan(block=4, height=8, width=8, order=torch.zeros(4, 16, dtype=torch.int64))
    if permute._native_kernels() is not None:  # the kernel refuses positions outside the block
        bad = SortPlan(block=4, height=5, width=5, order=torch.full((4, 16), 15, dtype=torch.uint8))
        with pytest.raises(ValueRangeError, match=r"mask: expected a plan made by plan_sort"):
            sort_pass(torch.arange(25).view(5, 5), torch.rand(5, 5), bad, 4)


def test_empty_image_passes_through():
    seeds = torch.zeros(0, 5, dtype=torch.int64)
    assert sort_pass(seeds, torch.zeros(0, 5), torch.zeros(0, 5)).shape == (0, 5)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_matches_cpu():
    seeds, values, mask = permute_case(7, 37, 53, 3, 0.3)
    want = sort_pass(seeds, values, mask, 4)
    got = sort_pass(seeds.cuda(), values.cuda(), mask.cuda(), 4)
    assert got.device.type == "cuda" and torch.equal(got.cpu(), want)
    cand = adversarial_values(torch.Generator().manual_seed(1), (8, 37, 53), 0.3)
    assert torch.equal(
        histogram_select(cand.cuda(), mask.abs().nan_to_num(0).cuda()).cpu(),
        histogram_select(cand, mask.abs().nan_to_num(0)),
    )


def _select_reference(candidates: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    k, h, w = candidates.shape
    out = torch.empty(h, w, dtype=torch.int64)
    for y in range(h):
        for x in range(w):
            column = candidates[:, y, x].tolist()
            order = sorted(
                range(k), key=lambda i: (1, 0.0) if math.isnan(column[i]) else (0, column[i])
            )
            rank = min(max(math.floor(float(mask[y, x]) * k), 0), k - 1)
            out[y, x] = order[rank]
    return out


@given(
    k=st.integers(1, 9),
    h=st.integers(1, 9),
    w=st.integers(1, 9),
    special=st.sampled_from([0.0, 0.4]),
    seed=st.integers(0, 2**16),
)
def test_histogram_select_picks_the_rank_of_the_sorted_candidates(k, h, w, special, seed):
    gen = torch.Generator().manual_seed(seed)
    candidates = adversarial_values(gen, (k, h, w), special)
    mask = torch.rand(h, w, generator=gen) * 1.2 - 0.1  # some below 0 and above 1: clamped
    index = histogram_select(candidates, mask)
    assert index.dtype == torch.int64 and index.shape == (h, w)
    assert torch.equal(index, _select_reference(candidates, mask))


def test_histogram_select_equals_sorting_and_puts_nan_last():
    gen = torch.Generator().manual_seed(0)
    candidates = torch.rand(16, 6, 7, generator=gen)
    mask = torch.rand(6, 7, generator=gen)
    index = histogram_select(candidates, mask)
    rank = torch.floor(mask.double() * 16).long()
    expected = candidates.sort(dim=0).values.gather(0, rank[None])[0]
    assert torch.equal(candidates.gather(0, index[None])[0], expected)
    candidates[3] = float("nan")
    assert torch.equal(
        histogram_select(candidates, torch.full((6, 7), 0.999)), torch.full((6, 7), 3)
    )


def test_histogram_select_rejects_bad_input():
    with pytest.raises(NonFiniteError, match=r"mask: expected finite values, got 1 NaN"):
        histogram_select(torch.rand(4, 2, 2), torch.tensor([[0.1, float("nan")], [0.2, 0.3]]))
    with pytest.raises(
        ShapeError, match=r"mask: expected H x W = 2 x 2 like candidates, got 3 x 2"
    ):
        histogram_select(torch.rand(4, 2, 2), torch.rand(3, 2))
    with pytest.raises(DtypeError, match=r"candidates: expected dtype .*, got int64"):
        histogram_select(torch.ones(4, 2, 2, dtype=torch.int64), torch.rand(2, 2))
    with pytest.raises(ShapeError, match=r"candidates: expected 3 dimensions"):
        histogram_select(torch.rand(2, 2), torch.rand(2, 2))
    with pytest.raises(
        ValueRangeError, match=r"candidates.shape\[0\]: expected an integer >= 1, got 0"
    ):
        histogram_select(torch.rand(0, 2, 2), torch.rand(2, 2))
