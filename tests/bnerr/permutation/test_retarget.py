"""Tests for bnerr.permutation.retarget: the optimizer, the shipped fields, the op that applies a
field (native, torch and loop paths bit for bit; the torch op) and its file (the ``bnerr retarget``
command is tested in tests/benchmarks/commands/test_retarget.py)."""

import importlib.util

import numpy as np
import pytest
import torch
from hypothesis import example, given
from hypothesis import strategies as st

from bnerr import native
from bnerr.errors import DtypeError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.masks import frame_offset, load_mask, r2_step
from bnerr.permutation import retarget as retarget_module
from bnerr.permutation.retarget import (
    MAX_DISPLACEMENT,
    Retarget,
    check_displacement,
    inverse_field,
    load_retarget,
    optimize_retarget,
    retarget,
    retarget_energy,
    retarget_sources,
    save_retarget,
    shipped_retargets,
)

needs_scipy = pytest.mark.skipif(importlib.util.find_spec("scipy") is None, reason="needs scipy")


def _random_field(size: int, seed: int) -> torch.Tensor:
    """A random valid field: annealing at a temperature where nearly every legal swap is taken."""
    mask = torch.rand(size, size, generator=torch.Generator().manual_seed(seed))
    return optimize_retarget(
        mask, (1, 2), method="anneal", iterations=30, temperature=1.0, seed=seed
    )


def _retarget_reference(
    seeds: torch.Tensor, field: torch.Tensor, offset: tuple[int, int]
) -> torch.Tensor:
    """Loop version of the documented rule: p takes p + d(q); targets pointing off screen take the
    unclaimed sources, both in row-major order."""
    h, w = seeds.shape
    size = field.shape[-1]
    source, lost = {}, []
    for y in range(h):
        for x in range(w):
            qy, qx = (y + offset[0]) % size, (x + offset[1]) % size
            sy, sx = y + int(field[0, qy, qx]), x + int(field[1, qy, qx])
            if 0 <= sy < h and 0 <= sx < w:
                source[y, x] = (sy, sx)
            else:
                lost.append((y, x))
    claimed = set(source.values())
    free = [(y, x) for y in range(h) for x in range(w) if (y, x) not in claimed]
    source.update(zip(lost, free))
    out = torch.empty_like(seeds)
    for (y, x), (sy, sx) in source.items():
        out[y, x] = seeds[sy, sx]
    return out


# --------------------------------------------------------------------------------------------------
# The op


@given(
    h=st.integers(1, 40),
    w=st.integers(1, 40),
    size=st.sampled_from([8, 12, 16]),
    oy=st.integers(-20, 20),
    ox=st.integers(-20, 20),
    seed=st.integers(0, 2**16),
)
@example(h=37, w=29, size=16, oy=3, ox=-5, seed=0)
@example(h=1, w=1, size=8, oy=0, ox=0, seed=1)
@example(h=40, w=37, size=12, oy=5, ox=-7, seed=2)
def test_retarget_is_a_permutation_and_equals_the_loop_reference(h, w, size, oy, ox, seed):
    field = _random_field(size, seed)
    seeds = torch.randperm(h * w, generator=torch.Generator().manual_seed(seed)).view(h, w) + 100
    out = retarget(seeds, field, (oy, ox))  # the native gather where available
    by_indices = seeds.reshape(-1)[retarget_sources(h, w, field, (oy, ox)).long()].view(h, w)
    assert torch.equal(out.reshape(-1).sort().values, seeds.reshape(-1).sort().values)
    want = _retarget_reference(seeds, field, (oy, ox))
    assert torch.equal(out, want)
    assert torch.equal(by_indices, want)
    kernels = retarget_module._native_kernels()
    if kernels is not None:  # the fast path itself, called directly
        form = native.retarget_field(field, inverse_field(field))
        fast = native.native_retarget_gather(kernels, seeds, form, (oy, ox))
        assert torch.equal(fast, want)


def test_shipped_field_keeps_seeds_a_permutation_over_100_frames():
    field = load_retarget(64)
    module = Retarget(field, cache=4)
    initial = torch.randperm(67 * 101, generator=torch.Generator().manual_seed(0)).view(67, 101)
    by_module = by_function = initial
    for t in range(100):
        by_module = module(by_module, frame_offset(t, 64))
        by_function = retarget(by_function, field, frame_offset(t, 64))
    assert torch.equal(by_module, by_function)
    assert torch.equal(by_module.reshape(-1).sort().values, initial.reshape(-1).sort().values)
    assert not torch.equal(by_module, initial)


def test_interior_pixels_move_by_the_field():
    field = load_retarget(64)
    seeds = torch.arange(100 * 100).view(100, 100)
    out = retarget(seeds, field, (5, 9))
    y, x = 50, 60
    qy, qx = (y + 5) % 64, (x + 9) % 64
    assert int(out[y, x]) == int(seeds[y + field[0, qy, qx], x + field[1, qy, qx]])


def test_module_and_function_agree_with_and_without_cache(monkeypatch):
    # The index cache serves the torch path: take the native kernel away.
    monkeypatch.setattr(retarget_module, "_native_kernels", lambda: None)
    field = _random_field(16, 3)
    seeds = torch.randperm(30 * 20).view(30, 20)
    cached, uncached = Retarget(field, cache=2), Retarget(field)
    for t in range(5):
        offset = (t * 7, t * 3)
        want = retarget(seeds, field, offset)
        assert torch.equal(cached(seeds, offset), want)
        assert torch.equal(uncached(seeds, offset), want)
    assert len(cached._sources) == 2 and not uncached._sources
    assert "tile=16x16" in repr(cached)


def test_module_converts_its_field_once_and_sees_an_edit_in_place(monkeypatch):
    native_here = retarget_module._native_kernels() is not None  # its self-check runs first
    made = []
    real = native.retarget_field
    monkeypatch.setattr(native, "retarget_field", lambda *a: made.append(1) or real(*a))
    first, second = _random_field(12, 6), _random_field(12, 7)
    seeds = torch.randperm(23 * 31, generator=torch.Generator().manual_seed(6)).view(23, 31)
    module = Retarget(first.clone())
    for t in range(4):
        assert torch.equal(module(seeds, (t, 2 * t)), retarget(seeds, first, (t, 2 * t)))
    assert len(made) == (2 if native_here else 0)  # once for the module's field, once for first
    with torch.no_grad():
        module.displacement.copy_(second)  # what load_state_dict does
    assert torch.equal(module(seeds, (1, 5)), retarget(seeds, second, (1, 5)))


def test_a_field_that_is_not_a_permutation_is_a_typed_error():
    field = torch.zeros(2, 4, 4, dtype=torch.int64)
    field[1, :, 3], field[0, 1, 0] = 1, 1  # column 3 points off screen; two targets share a source
    with pytest.raises(ValueRangeError, match="4 targets outside but 5 free seeds"):
        retarget_sources(4, 4, field, (0, 0))


def test_retarget_is_a_torch_op_with_a_fake_implementation():
    field = _random_field(16, 5)
    seeds = torch.randperm(21 * 34, generator=torch.Generator().manual_seed(5)).view(21, 34)
    op = torch.ops.bnerr.retarget
    want = retarget(seeds, field, (3, 7))
    assert torch.equal(op(seeds, field, None, 3, 7), want)
    assert torch.equal(op.default(seeds, field, inverse_field(field), 3, 7), want)
    with torch._subclasses.fake_tensor.FakeTensorMode() as mode:
        fake = op(mode.from_tensor(seeds), mode.from_tensor(field), None, 3, 7)
    assert fake.shape == seeds.shape and fake.dtype == torch.int64


def test_retarget_op_composes_with_torch_compile():
    if not torch._dynamo.is_dynamo_supported():
        pytest.skip("torch.compile is unavailable here (dynamo does not support this Python)")
    from torch._dynamo.testing import CompileCounterWithBackend

    field = _random_field(8, 6)
    seeds = torch.randperm(11 * 13, generator=torch.Generator().manual_seed(6)).view(11, 13)

    def step(seeds, field):
        return torch.ops.bnerr.retarget(seeds * 3, field, None, 2, 5) - 1

    counter = CompileCounterWithBackend("aot_eager")
    got = torch.compile(step, backend=counter, fullgraph=False)(seeds, field)
    assert torch.equal(got, step(seeds, field))
    assert counter.frame_count == 1  # one graph: the op did not break it


def test_retarget_rejects_bad_input():
    field = load_retarget(64)
    seeds = torch.arange(12).view(3, 4)
    with pytest.raises(DtypeError, match=r"seeds: expected dtype int64, got int32"):
        retarget(seeds.int(), field, (0, 0))
    with pytest.raises(ShapeError, match=r"seeds: expected 2 dimensions"):
        retarget(seeds.view(-1), field, (0, 0))
    with pytest.raises(DtypeError, match=r"offset: expected a pair of integers"):
        retarget(seeds, field, (0.5, 0))
    with pytest.raises(
        DtypeError, match=r"displacement: expected dtype int8 or int16 or int32 or int64"
    ):
        retarget(seeds, field.float(), (0, 0))
    broken = field.clone()
    broken[:, 0, 0] = broken[:, 0, 1] + torch.tensor([0, 1])  # two targets, one source
    with pytest.raises(
        ValueRangeError, match=r"displacement: expected a permutation of the 64x64 tile"
    ):
        retarget(seeds, broken, (0, 0))


def test_check_displacement():
    identity = torch.zeros(2, 8, 8, dtype=torch.int8)
    assert check_displacement(identity).dtype == torch.int64
    shift = torch.zeros(2, 8, 8, dtype=torch.int64)
    shift[1] = 7  # every pixel takes the one 7 to its right: a permutation, but too far
    with pytest.raises(ValueRangeError, match=r"displacement: expected \|dy\|, \|dx\| <= 6, got 7"):
        check_displacement(shift)
    assert torch.equal(check_displacement(shift, radius=None), shift)
    with pytest.raises(ShapeError, match=r"displacement: expected 3 dimensions"):
        check_displacement(torch.zeros(8, 8, dtype=torch.int64))
    with pytest.raises(
        ShapeError, match=r"displacement: expected shape \[2, T, T\] \(T equal on every axis\)"
    ):
        check_displacement(torch.zeros(2, 8, 9, dtype=torch.int64))


# --------------------------------------------------------------------------------------------------
# The optimizer and the shipped fields


def test_annealing_lowers_the_energy_and_is_deterministic():
    mask = load_mask("scalar", 64)[:16, :16].contiguous()
    step = (5, 11)
    identity = retarget_energy(mask, torch.zeros(2, 16, 16, dtype=torch.int64), step)
    a = optimize_retarget(mask, step, method="anneal", iterations=300, seed=7)
    b = optimize_retarget(mask, step, method="anneal", iterations=300, seed=7)
    assert torch.equal(a, b)
    check_displacement(a, radius=MAX_DISPLACEMENT)
    assert retarget_energy(mask, a, step) < 0.5 * identity


@needs_scipy
def test_exact_matching_is_at_least_as_good_as_annealing():
    mask = torch.rand(16, 16, generator=torch.Generator().manual_seed(2))
    step = (9, 4)
    exact = optimize_retarget(mask, step, method="exact", radius=3)
    annealed = optimize_retarget(mask, step, method="anneal", radius=3, iterations=500)
    check_displacement(exact, radius=3)
    assert retarget_energy(mask, exact, step) <= retarget_energy(mask, annealed, step) + 1e-12
    # Small torus: offsets alias (radius 6 on an 8x8 tile); the result is still a valid field.
    small = optimize_retarget(
        torch.rand(8, 8, generator=torch.Generator().manual_seed(0)), (3, 5), method="exact"
    )
    check_displacement(small)


@pytest.mark.parametrize("size", [64, 128])
def test_shipped_fields_are_valid_and_fit_the_shipped_masks(size):
    assert size in shipped_retargets()
    field = load_retarget(size)
    assert field.shape == (2, size, size) and field.dtype == torch.int64
    check_displacement(field, radius=MAX_DISPLACEMENT)
    mask = load_mask("scalar", size)
    identity = retarget_energy(mask, torch.zeros_like(field))
    final = retarget_energy(mask, field)
    assert abs(identity - 1 / 3) < 0.02  # a blue-noise mask against its R2 shift: ~independent
    # A field optimized for another mask would score near the identity; this one is ~80x lower.
    assert final < 0.05 * identity
    assert retarget_energy(mask, field, r2_step(size)) == final


def test_load_retarget_errors():
    with pytest.raises(
        UnknownNameError, match=r"retarget size 7: expected one of the shipped sizes"
    ):
        load_retarget(7)
    with pytest.raises(ValueRangeError, match=r"size: expected an integer >= 1, got 0"):
        load_retarget(0)


def test_optimizer_rejects_bad_input():
    with pytest.raises(UnknownNameError, match=r"unknown retarget method 'greedy'"):
        optimize_retarget(torch.rand(8, 8), method="greedy")
    with pytest.raises(ShapeError, match=r"mask: expected shape \[T, T\]"):
        optimize_retarget(torch.rand(8, 9))
    with pytest.raises(DtypeError, match=r"step: expected a pair of integers"):
        optimize_retarget(torch.rand(8, 8), (1.5, 2))
    with pytest.raises(
        ValueRangeError, match=r"temperature: expected a value in \[0.0, 1.0\], got 2"
    ):
        optimize_retarget(torch.rand(8, 8), temperature=2)


def test_save_writes_an_int8_array(tmp_path):
    field = _random_field(8, 0)
    save_retarget(tmp_path / "f.npy", field)
    loaded = np.load(tmp_path / "f.npy")
    assert loaded.dtype == np.int8 and np.array_equal(loaded, field.numpy())
