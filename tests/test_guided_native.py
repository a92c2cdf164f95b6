"""Tests of denoisers/native/guided.py: the guided filter's C kernel against the torch path and
kornia's guided_blur, its thread-count independence, its float64 switch, and the dispatch and
self-check of denoisers.filters."""

import pytest
import torch
import torch.nn.functional as F

from bnerr import native as bnerr_native
from denoisers import filters, native
from denoisers.filters import guided_filter, guided_torch
from tests._twins import guided_reference

KERNELS = native.GUIDED.load()
needs_kernel = pytest.mark.skipif(
    KERNELS is None, reason=f"the native guided kernel is unavailable: {native.GUIDED.status()}"
)
# The float64 switch of the filters: a float32 tensor holding a value above this (and no NaN,
# whose maximum is NaN) would overflow when squared. The kernel repeats the rule in C.
FLOAT32_SAFE = 1e18

# Tolerance, relative to the largest output value (and as rtol). The kernel repeats the torch
# path's operations in its order, but torch's own kernels fuse the multiply-adds of addcmul, sum
# the seven guide planes in another order, and neither computes 1 / sqrt exactly. Measured on
# these inputs (eps 1e-8 to 10): at most 2.7e-7 of the largest value against the torch path, and
# 2.6e-7 against kornia (which the torch path itself matches to 5.3e-6 on a 3 x 3 image with
# radius 10). The systems at eps >= 1e-2 have condition numbers below 1e3, so a few roundings of
# 6e-8 move the output by at most about 1e-5; a wrong window or border errs by the values' size.
TOLERANCE = 1e-5


def _inputs(h, w, seed=0):
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[0, h // 2, w // 3] = 60.0
    albedo = torch.rand(3, h, w, generator=g)
    albedo[:, :, : w // 4] = 0.5  # a flat region: a singular covariance but for eps
    normal = F.normalize(torch.randn(3, h, w, generator=g), dim=0)
    return color, albedo, normal


def _needs_float64(*tensors):
    return any(t.dtype == torch.float32 and bool(t.abs().amax() > FLOAT32_SAFE) for t in tensors)


def _close(got, want):
    scale = float(want.abs().amax())
    torch.testing.assert_close(got, want, rtol=TOLERANCE, atol=TOLERANCE * scale)


@needs_kernel
@pytest.mark.parametrize(
    ("h", "w", "radius", "eps"),
    [
        (13, 300, 2, 1e-2),  # two tiles of 256 columns, the last one partial
        (6, 530, 3, 1.0),  # three tiles
        (40, 257, 5, 10.0),  # the tuning grid's largest radius across a tile edge
        (41, 37, 3, 0.1),
        (9, 7, 1, 1.0),
        (5, 6, 4, 0.1),  # radius larger than the image: every window is the whole image
        (3, 3, 10, 1.0),
        (1, 1, 1, 1.0),
        (1, 140, 2, 1.0),  # one row
        (130, 1, 2, 1.0),  # one column
        (120, 97, 2, 1e-8),  # the smallest eps Guided accepts
    ],
)
def test_kernel_matches_the_torch_path(h, w, radius, eps):
    color, albedo, normal = _inputs(h, w, seed=h * w)
    want = guided_torch(color, albedo, normal, radius, eps)
    got = native.native_guided(KERNELS, color, albedo, normal, radius, eps)
    _close(got, want)


@needs_kernel
@pytest.mark.parametrize(("radius", "eps"), [(1, 1e-2), (2, 1.0), (3, 0.1), (5, 10.0)])
def test_kernel_matches_kornia(radius, eps):
    color, albedo, normal = _inputs(41, 150, seed=radius)
    want = guided_reference(color, albedo, normal, radius, eps)
    got = native.native_guided(KERNELS, color, albedo, normal, radius, eps, threads=2)
    _close(got, want)


@needs_kernel
def test_result_does_not_depend_on_the_thread_count():
    color, albedo, normal = _inputs(37, 200, seed=3)
    one = native.native_guided(KERNELS, color, albedo, normal, 2, 0.1, threads=1)
    for threads in (2, 3, 7, 64):
        got = native.native_guided(KERNELS, color, albedo, normal, 2, 0.1, threads=threads)
        assert torch.equal(got, one)


@needs_kernel
def test_views_are_read_as_their_values():
    color, albedo, normal = _inputs(20, 60, seed=4)
    want = native.native_guided(KERNELS, color, albedo, normal, 2, 1.0)
    wide = torch.zeros(3, 20, 120)
    wide[:, :, ::2] = color
    got = native.native_guided(KERNELS, wide[:, :, ::2], albedo, normal, 2, 1.0)
    assert torch.equal(got, want)


@needs_kernel
@pytest.mark.parametrize("buffer", [0, 1, 2])
def test_float64_switch_follows_the_torch_rule(buffer):
    # The kernel declines (None) exactly where guided_filter's float64 check fires: a value
    # above 1e18 (rounded to float32) in a tensor that holds no NaN.
    tensors = list(_inputs(12, 20, seed=5))
    threshold = torch.tensor(FLOAT32_SAFE, dtype=torch.float32)
    above = torch.nextafter(threshold, torch.tensor(float("inf")))
    for value, nan in ((threshold, False), (-above, False), (above, True), (float("inf"), False)):
        case = [t.clone() for t in tensors]
        case[buffer][1, 3, 4] = value
        if nan:
            case[buffer][0, 0, 0] = float("nan")
        got = native.native_guided(KERNELS, *case, 2, 1.0)
        assert (got is None) == _needs_float64(*case), (value, nan)


def test_a_firefly_frame_is_filtered_in_float64():
    color, albedo, normal = _inputs(16, 16, seed=6)
    color[1, 5, 7] = 1e20
    want = guided_torch(color.double(), albedo.double(), normal.double(), 2, 1.0).float()
    got = guided_filter(color, albedo, normal, 2, 1.0)
    assert torch.isfinite(got).all()
    torch.testing.assert_close(got, want, rtol=1e-6, atol=1e-6 * float(want.abs().amax()))


def test_dispatch_declines_other_dtypes():
    color, albedo, normal = _inputs(8, 8)
    assert filters._guided_native(color.double(), albedo, normal, 2, 1.0) is None
    got = guided_filter(color.double(), albedo.double(), normal.double(), 2, 1.0)
    assert got.dtype == torch.float64


def test_disabled_by_the_environment_the_torch_path_runs(monkeypatch):
    color, albedo, normal = _inputs(10, 11, seed=7)
    monkeypatch.setenv("BNERR_NATIVE", "0")
    bnerr_native.reset()
    try:
        assert filters._guided_native(color, albedo, normal, 2, 1.0) is None
        assert native.GUIDED.status() == "disabled by BNERR_NATIVE=0"
        want = guided_torch(color, albedo, normal, 2, 1.0)
        assert torch.equal(guided_filter(color, albedo, normal, 2, 1.0), want)
    finally:
        bnerr_native.reset()  # the next load reads the environment monkeypatch restores


@needs_kernel
def test_guided_filter_uses_the_kernel_on_cpu_float32():
    color, albedo, normal = _inputs(30, 50, seed=8)
    want = native.native_guided(KERNELS, color, albedo, normal, 3, 0.1)
    assert torch.equal(guided_filter(color, albedo, normal, 3, 0.1), want)
    assert filters._check_guided(KERNELS)
    assert filters._native_guided() is native.GUIDED.load()  # passed its self-check


@needs_kernel
def test_a_kernel_failing_its_self_check_is_not_used(monkeypatch):
    color, albedo, normal = _inputs(10, 12, seed=9)
    failing = bnerr_native.SelfCheckedKernels(lambda kernels: False, "a test kernel", native.GUIDED)
    monkeypatch.setattr(filters, "_native_guided", failing)
    with pytest.warns(RuntimeWarning, match="a test kernel disagrees with the torch path"):
        assert filters._guided_native(color, albedo, normal, 2, 1.0) is None
    want = guided_torch(color, albedo, normal, 2, 1.0)
    assert torch.equal(guided_filter(color, albedo, normal, 2, 1.0), want)
