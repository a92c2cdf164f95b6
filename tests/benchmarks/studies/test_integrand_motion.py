"""benchmarks.studies.integrand_motion: the grid pins every dimension, its cells average to
the jitter-pinned render, the edge motion reads a known edge's speed, and the arrangement
ratios behave as their definitions say on integrands built by hand."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import renderers
from benchmarks.studies.integrand_motion import (
    GridPair,
    arrangement_ratio,
    carried_correlation,
    edge_motion,
    fit_light_pair,
    key_points,
    keyed_errors,
    main,
    pair_integrands,
    penumbra,
    window_error,
    windows,
)
from benchmarks.studies.jitter_loss import FixedJitter
from bnerr.color import luminance
from bnerr.errors import ShapeError, ValueRangeError
from bnerr.resources import load_array
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds


def _zorder_keys() -> np.ndarray:
    return load_array("ldbn_zorder_64.npy", np.int32, (None, 1, None, None, None))


def test_grid_pins_jitter_pair_and_every_other_dimension():
    n = 32
    seed = torch.arange(n, dtype=torch.int64)
    pixel = torch.stack([torch.arange(n) // 8, torch.arange(n) % 8], 1)
    index = torch.arange(n, dtype=torch.int64) % 4
    got = GridPair(2, 0.25, 0.75, rest=0.125).sample(seed, index, 1, 6, pixel)
    want = torch.tensor([0.5, 0.125, 0.125, 0.25, 0.75, 0.125])  # dimensions 1 .. 6
    assert got.shape == (n, 6) and torch.equal(got, want.expand(n, 6))


def test_grid_points_lie_in_the_unit_square_and_pair_0_is_the_jitter():
    with pytest.raises(ValueRangeError, match=r"\[0, 1\)"):
        GridPair(1, 1.0, 0.5)
    with pytest.raises(ValueRangeError, match="pair"):
        GridPair(0, 0.5, 0.5)


def test_the_cells_average_to_the_jitter_pinned_render():
    f = pair_integrands("direct", t=6, size=16, grid=16)
    assert f.shape == (16, 16, 16, 16) and bool((f >= 0).all())
    scene = renderers.get_scene("direct", animated=True)
    seeds = pixel_seeds(16, 16, 0x5EED)
    frame = renderers.render(scene, 6, seeds, FixedJitter(make_sampler("owen_sobol")), 1024)
    ref = luminance(frame.color, dtype=torch.float32)
    # Both estimate the same integral; the grid's midpoint rule is exact on lit pixels up to
    # the cosine terms' curvature and off by at most an edge's cells in the penumbra.
    rel = float((f.mean((2, 3)) - ref).abs().sum() / ref.abs().sum())
    assert rel < 0.02


def test_pairs_past_the_scenes_dimensions_are_refused_and_deeper_scenes_tabulate():
    with pytest.raises(ValueRangeError, match=r"1 to 1 on 'direct'"):
        pair_integrands("direct", size=8, grid=2, pair=2)
    f = pair_integrands("indirect", size=8, grid=2, pair=2)  # the bounce direction at vertex 0
    assert f.shape == (8, 8, 2, 2) and bool(torch.isfinite(f).all())


def _moving_edge(k: int, size: int = 8, grid: int = 64) -> torch.Tensor:
    """A vertical edge in the light's square that moves by k cells per pixel to the right."""
    i = torch.arange(grid)
    x = torch.arange(size)
    lit = (i[None, :] >= 8 + k * x[:, None]).float()  # [W, G]: u-cells lit per column x
    return lit[None, :, None, :].expand(size, size, grid, grid).contiguous()


@pytest.mark.parametrize("k", [1, 3, 5])
def test_edge_motion_reads_a_known_edge_speed(k):
    motion = edge_motion(_moving_edge(k))
    assert motion["x"] == pytest.approx([k] * 4)
    assert motion["y"] == pytest.approx([0.0] * 4)
    assert motion["pixels"] == 64 and motion["pairs"] == {"x": 56, "y": 56}


def test_edge_motion_needs_a_penumbra():
    with pytest.raises(ValueRangeError, match="penumbra"):
        edge_motion(torch.ones(4, 4, 8, 8))


def test_penumbra_and_lit_split_by_visible_cells():
    f = torch.zeros(1, 3, 2, 2)
    f[0, 1, 0, 0] = 1.0
    f[0, 2] = 2.0
    pen, lit = penumbra(f)
    assert pen.tolist() == [[False, True, False]] and lit.tolist() == [[False, False, True]]


def test_key_points_lie_in_the_square_and_check_their_input():
    points = key_points(_zorder_keys(), "zorder", 16)
    assert points.shape == (64 * 64, 16, 2)
    assert float(points.min()) >= 0 and float(points.max()) < 1
    with pytest.raises(ShapeError, match="level for 256 spp"):
        key_points(_zorder_keys(), "zorder", 256)


def test_past_the_last_level_the_sobol_keys_permute_each_aligned_block():
    keys = load_array("ldbn_screen_64.npy", np.int32, (None, 1, None, None, None))
    last = 1 << (keys.shape[0] - 1)
    more = key_points(keys, "sobol", 4 * last)
    assert torch.equal(more[:, :last], key_points(keys, "sobol", last))
    # Each later block of the last level's size is a (0, m, 2)-net too: one point per
    # elementary interval of its size along u.
    block = more[:, last : 2 * last, 0]
    cells = (block * last).long().sort(1).values
    assert torch.equal(cells, torch.arange(last).expand_as(cells))


def test_keyed_errors_vanish_on_constant_integrands_and_follow_the_arrangement():
    points = key_points(_zorder_keys(), "zorder", 4)
    assert bool((keyed_errors(torch.full((8, 8, 4, 4), 3.0), points) == 0).all())
    f = _moving_edge(2, size=8, grid=16)
    identity = torch.arange(points.shape[0])
    assert torch.equal(keyed_errors(f, points, (3, 5)), keyed_errors(f, points, (3, 5), identity))
    with pytest.raises(ShapeError, match=r"\[T\^2, n, 2\]"):
        keyed_errors(f, points[:10])


def test_frozen_equals_penumbra_when_every_pixel_integrates_the_same_function():
    # The same half-lit square in every pixel: freezing changes nothing, and keys optimized for
    # fixed integrands keep well under a random arrangement's blurred error at 4 spp.
    f = _slanted(16, 1, 2, 20).expand(64, 64, 16, 16).contiguous()
    r = arrangement_ratio(f, key_points(_zorder_keys(), "zorder", 4), offsets=2)
    assert r.frozen == r.penumbra == r.every
    assert r.penumbra_raw == 1.0 and r.penumbra < 0.6
    assert np.isnan(r.lit)  # no pixel sees the whole light


def test_main_prints_both_tables(capsys):
    main(["--size", "32", "--grid", "8", "--keys", "ldbn_zorder", "--spp", "4", "--offsets", "1"])
    out = capsys.readouterr().out
    assert out.startswith("penumbra: ")
    assert "| x |" in out and "| `ldbn_zorder` | 4 |" in out


def _slanted(grid: int, a: int, b: int, c: int) -> torch.Tensor:
    """``[G, G]`` a half-plane edge ``a i + b j < c`` over the cells (slanted: an edge along a
    grid line would be integrated exactly by every stratified set)."""
    j, i = torch.meshgrid(torch.arange(grid), torch.arange(grid), indexing="ij")
    return (a * i + b * j < c).float()


def test_error_carries_over_fully_between_identical_integrands_and_not_between_unrelated():
    points = key_points(_zorder_keys(), "zorder", 16)
    f = _slanted(32, 1, 2, 40).expand(8, 8, 32, 32).contiguous()  # one function everywhere
    assert carried_correlation(f, points, keys=256) == pytest.approx([1.0] * 3)
    # Columns alternate between edges of other slants: horizontal neighbours' errors are
    # related only in part (0.38 measured), vertical ones identical.
    g = f.clone()
    g[:, 1::2] = _slanted(32, 2, -1, 10)
    low, _, high = carried_correlation(g, points, keys=256)
    assert low < 0.6 and high == pytest.approx(1.0)


def test_windows_read_each_texel_at_its_pixels_in_every_copy_of_the_tile():
    size = 4
    pixel = torch.arange(8 * 8, dtype=torch.float32).reshape(8, 8, 1, 1)
    f = pixel.expand(8, 8, 2, 2).contiguous()  # every cell holds the pixel's index
    w = windows([f, f + 1000], size, per_frame=3, seed=5)
    assert w.pixels.shape == (16, 2 * 3 * 4) and w.grid == 2
    values = w.values.reshape(-1, 4)[:, 0]
    # Window c of texel t: its value is the pixel index (plus 1000 in frame 1), and texels
    # that are toroidal neighbours read image neighbours but at the seam.
    read = values[w.pixels]
    y, x = (read % 1000) // 8, (read % 1000) % 8
    assert torch.equal(w.exact, read.double())
    right = torch.arange(16).reshape(4, 4).roll(-1, 1).reshape(-1)
    step = (x[right] - x) % 8
    assert bool(((step == 1) | (step == 8 - size + 1)).all()) and bool((y[right] == y).all())
    with pytest.raises(ShapeError, match="multiples of 3"):
        windows([f], 3, per_frame=1)


def test_fitting_moves_only_the_light_pair_of_its_level_and_lowers_the_window_error():
    keys = _zorder_keys()
    f = torch.zeros(64, 64, 8, 8)
    for x in range(64):  # an edge that moves across the light's square from pixel to pixel
        f[:, x] = _slanted(8, 1, 2, 2 + x // 4)
    train = windows([f], 64, per_frame=2)
    fitted = fit_light_pair(keys, 2, train, iterations=10)
    changed = np.argwhere((fitted != keys).any(axis=(1, 2, 3)))
    assert {tuple(c) for c in changed} <= {(2, 2), (2, 3)}
    chunks = lambda k: np.sort(k[2, 0, ..., 2].reshape(-1))  # noqa: E731
    assert np.array_equal(chunks(fitted), chunks(keys))
    assert window_error(fitted, 2, train) <= window_error(keys, 2, train)
