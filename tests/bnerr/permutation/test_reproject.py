"""Tests for bnerr.permutation.reproject: the bijective reprojection against its slow twin (ties,
NaN, motion off screen, disocclusions), a 200-frame run that stays a permutation of the initial
seeds, the temporal pipeline with every option (groups, grid offsets, retargeting, reprojection),
errors."""

import math

import pytest
import torch
from hypothesis import example, given
from hypothesis import strategies as st

from bnerr.errors import DtypeError, ShapeError, UnknownNameError
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.permutation.permute import sort_pass
from bnerr.permutation.reproject import (
    collision_depth,
    reproject_seeds,
    reproject_seeds_reference,
    reproject_sources,
)
from bnerr.permutation.retarget import load_retarget, retarget


def _motion(gen: torch.Generator, h: int, w: int, scale: float, special: float) -> torch.Tensor:
    """Half-pixel motion (rounding ties), some NaN and infinities, some far off screen."""
    m = (torch.randn(2, h, w, generator=gen) * scale * 2).round() / 2
    pick = torch.rand(2, h, w, generator=gen)
    m[pick < special] = math.nan
    m[(pick >= special) & (pick < 1.5 * special)] = math.inf
    m[(pick >= 1.5 * special) & (pick < 2 * special)] = -1e30
    return m


def _depth(gen: torch.Generator, h: int, w: int, special: float) -> torch.Tensor:
    d = torch.randint(0, 3, (1, h, w), generator=gen).float()  # many ties
    pick = torch.rand(1, h, w, generator=gen)
    d[pick < special] = math.nan
    d[(pick >= special) & (pick < 1.5 * special)] = -0.0
    d[(pick >= 1.5 * special) & (pick < 2 * special)] = math.inf
    return d


def _is_permutation(a: torch.Tensor, b: torch.Tensor) -> bool:
    return torch.equal(a.reshape(-1).sort().values, b.reshape(-1).sort().values)


@given(
    h=st.integers(1, 17),
    w=st.integers(1, 17),
    scale=st.sampled_from([0.0, 0.5, 2.0, 20.0]),
    special=st.sampled_from([0.0, 0.1, 0.5]),
    with_depth=st.booleans(),
    direction=st.sampled_from(["forward", "backward"]),
    seed=st.integers(0, 2**16),
)
@example(h=17, w=17, scale=2.0, special=0.1, with_depth=True, direction="forward", seed=1)
@example(h=1, w=1, scale=20.0, special=0.5, with_depth=True, direction="backward", seed=2)
def test_fast_equals_reference_and_is_a_permutation(
    h, w, scale, special, with_depth, direction, seed
):
    gen = torch.Generator().manual_seed(seed)
    seeds = torch.randperm(h * w, generator=gen).view(h, w) * 5 + 2
    motion = _motion(gen, h, w, scale, special)
    depth = _depth(gen, h, w, special) if with_depth else None
    got = reproject_seeds(seeds, motion, depth, direction=direction)
    want = reproject_seeds_reference(seeds, motion, depth, direction=direction)
    assert got.dtype == torch.int64 and got.shape == (h, w)
    assert torch.equal(got, want)
    assert _is_permutation(got, seeds)
    src = reproject_sources(motion, depth, direction=direction)
    assert torch.equal(src.sort().values, torch.arange(h * w))


def test_uniform_motion_shifts_and_the_disoccluded_column_takes_the_pool():
    seeds = torch.arange(12).view(3, 4)
    motion = torch.zeros(2, 3, 4)
    motion[0] = 1.0  # everything moves one pixel right
    out = reproject_seeds(seeds, motion)
    assert out[:, 1:].tolist() == seeds[:, :3].tolist()
    # The right column fell off screen; its seeds fill the uncovered left column, in order.
    assert out[:, 0].tolist() == [3, 7, 11]
    # The same motion pulled (backward, frame t + 1's buffer) gives the same image.
    assert torch.equal(reproject_seeds(seeds, motion, direction="backward"), out)


def test_collisions_keep_the_nearer_surface_then_the_lower_index():
    seeds = torch.tensor([[10, 11, 12]])
    motion = torch.tensor([[[1.0, 0.0, -1.0]], [[0.0, 0.0, 0.0]]])  # all three land on (0, 1)
    near_right = torch.tensor([[[2.0, 3.0, 1.0]]])
    out = reproject_seeds(seeds, motion, near_right)
    assert out.tolist() == [[10, 12, 11]]  # 12 wins; pool (10, 11) fills (0, 0), (0, 2)
    assert reproject_seeds(seeds, motion, torch.ones(1, 1, 3)).tolist() == [[11, 10, 12]]
    nan_left = torch.tensor([[[math.nan, math.nan, math.inf]]])  # NaN is farther than inf
    assert reproject_seeds(seeds, motion, nan_left).tolist() == [[10, 12, 11]]
    nan_motion = motion.clone()
    nan_motion[1, 0, 0] = math.nan  # pixel 0 does not move: it keeps (0, 0)
    assert reproject_seeds(seeds, nan_motion).tolist()[0][0] == 10


def test_rounding_is_floor_of_value_plus_half():
    seeds = torch.arange(5).view(1, 5)
    motion = torch.zeros(2, 1, 5)
    motion[0, 0, 1] = 0.5  # 1.5 -> 2
    motion[0, 0, 3] = -0.5  # 2.5 -> 3: stays
    out = reproject_seeds(seeds, motion)
    assert out[0, 2] == 1 and out[0, 3] == 3


def test_collision_depth_puts_the_background_at_infinity():
    depth = torch.tensor([[[0.0, 2.0, 0.0]]])
    oid = torch.tensor([[[-1.0, 0.0, 3.0]]])
    assert collision_depth(depth, oid).tolist() == [[[math.inf, 2.0, 0.0]]]
    assert collision_depth(depth).tolist() == [[[math.inf, 2.0, math.inf]]]


def test_two_hundred_frames_of_motion_disocclusions_and_nan_stay_a_permutation():
    gen = torch.Generator().manual_seed(7)
    h, w = 24, 31
    initial = torch.randperm(h * w, generator=gen).view(h, w) * 3 + 1
    seeds = initial
    for t in range(200):
        if t % 17 == 5:  # a NaN frame
            motion = torch.full((2, h, w), math.nan)
            depth = torch.full((1, h, w), math.nan)
        else:
            # A moving camera pan, an object moving against it, random jitter and holes.
            motion = torch.zeros(2, h, w)
            motion[0] = (t % 7) - 3
            motion[:, 5:15, 8:20] = torch.tensor([4.0, -2.0]).view(2, 1, 1)
            motion += _motion(gen, h, w, 0.7, 0.02)
            depth = _depth(gen, h, w, 0.05)
        direction = "forward" if t % 2 else "backward"
        seeds = reproject_seeds(seeds, motion, depth, direction=direction)
        assert _is_permutation(seeds, initial), t


def test_temporal_pipeline_with_every_option_stays_a_permutation():
    # sort (groups, shifting grid) -> retarget (mask offset) -> reproject, over 40 frames.
    gen = torch.Generator().manual_seed(8)
    h, w, size = 29, 37, 64
    tile, field = load_mask("scalar", size), load_retarget(size)
    initial = torch.randperm(h * w, generator=gen).view(h, w)
    seeds = initial
    for t in range(40):
        offset = frame_offset(t, size)
        mask = tile_mask(tile, h, w, offset)
        values = torch.rand(3, h, w, generator=gen)
        values[:, t % h, :3] = math.nan
        groups = torch.randint(0, 3, (h, w), generator=gen)
        grid = (t % 4, (3 * t) % 4)
        seeds = sort_pass(seeds, values, mask, 4, groups=groups, grid_offset=grid)
        seeds = retarget(seeds, field, offset)  # the mask's offset, whatever the grid
        motion = _motion(gen, h, w, 1.5, 0.05)
        seeds = reproject_seeds(seeds, motion, _depth(gen, h, w, 0.05))
        assert _is_permutation(seeds, initial), t


def test_reproject_rejects_bad_input_with_typed_errors():
    seeds = torch.arange(12).view(3, 4)
    motion = torch.zeros(2, 3, 4)
    with pytest.raises(DtypeError, match=r"seeds: expected dtype int64, got int32"):
        reproject_seeds(seeds.int(), motion)
    with pytest.raises(ShapeError, match=r"motion: expected H x W = 3 x 4 like seeds, got 3 x 5"):
        reproject_seeds(seeds, torch.zeros(2, 3, 5))
    with pytest.raises(DtypeError, match=r"motion: expected dtype .*, got int64"):
        reproject_seeds(seeds, torch.zeros(2, 3, 4, dtype=torch.int64))
    with pytest.raises(ShapeError, match=r"depth: expected H x W = 3 x 4 like motion, got 4 x 3"):
        reproject_seeds(seeds, motion, torch.zeros(1, 4, 3))
    with pytest.raises(UnknownNameError, match=r"sideways"):
        reproject_seeds(seeds, motion, direction="sideways")
    assert reproject_seeds(seeds, motion, torch.zeros(3, 4)).tolist() == seeds.tolist()
    empty = torch.zeros(0, 4, dtype=torch.int64)
    assert reproject_seeds(empty, torch.zeros(2, 0, 4)).shape == (0, 4)
    with pytest.raises(ShapeError, match=r"object_id: expected \[1, 2, 2\] on cpu like depth"):
        collision_depth(torch.zeros(1, 2, 2), torch.zeros(1, 2, 3))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_matches_cpu():
    gen = torch.Generator().manual_seed(9)
    h, w = 67, 45
    seeds = torch.randperm(h * w, generator=gen).view(h, w)
    motion, depth = _motion(gen, h, w, 3.0, 0.05), _depth(gen, h, w, 0.05)
    for direction in ("forward", "backward"):
        want = reproject_seeds(seeds, motion, depth, direction=direction)
        got = reproject_seeds(seeds.cuda(), motion.cuda(), depth.cuda(), direction=direction)
        assert got.device.type == "cuda" and torch.equal(got.cpu(), want)
