"""Tests of denoisers/native/filters.py: the C kernels of the a-trous and (joint) bilateral filters
against their torch paths (``atrous_torch``, ``bilateral_torch`` of denoisers.filters: the
a-trous passes and spatial variance, kornia's bilateral blurs), the thread count, the dispatch
(CPU float32 only), the fallback when the library is unavailable, and where the C sources live.

The native comparisons skip, with the reason, when the library cannot be built or loaded here
(no C compiler, or ``BNERR_NATIVE=0``); the dispatch and fallback tests run everywhere.

Tolerances, from the largest differences measured over 4 seeds of these cases:

- a-trous, relative 1e-4 of each value (absolute 1e-6 near 0) for sigma_normal up to 128: the
  kernel takes the same steps in the same order (no fused multiply-add), but its exp and log are
  polynomials of about 1 ulp, not torch's; a one-ulp change of log(cos) moves cos ** 128 by about
  128 ulp (8e-6), measured up to 2.2e-5 after 5 passes (5e-7 at sigma_normal 0.5 or 0).
- bilateral and joint bilateral, relative 1e-4 of each value (absolute 1e-6 of the largest):
  the weights agree to about 2 ulp (the same exponent, another exp); kornia's unfold path (small
  images) sums each window by rows, then the rows, where the kernel adds its taps in order,
  which moves a sum of 81 terms by up to ~80 ulp; measured up to 3.5e-5 (firefly of 3e38).
"""

import math
from importlib import resources

import pytest
import torch
import torch.nn.functional as F

from bnerr import native as bnerr_native
from bnerr.color import LUMINANCE_WEIGHTS
from denoisers import filters, native
from denoisers.filters import (
    atrous_filter,
    atrous_native,
    atrous_planes,
    atrous_torch,
    bilateral_filter,
    bilateral_torch,
    guided_filter,
    guided_torch,
    joint_bilateral_filter,
)

ATROUS_CORNERS = [
    (5, 4.0, 128.0, 1.0),
    (1, 1.0, 128.0, 1.0),
    (3, 16.0, 0.5, 0.1),
    (2, 64.0, 0.0, 10.0),
]


@pytest.fixture
def kernels():
    """The loaded filter kernels, or a skip that says why there are none."""
    loaded = native.FILTERS.load()
    if loaded is None:
        pytest.skip(f"native filter kernels unavailable: {native.FILTERS.status()}")
    return loaded


@pytest.fixture
def no_native(monkeypatch):
    """The library switched off (``BNERR_NATIVE=0``), and looked up again after the test."""
    monkeypatch.setenv("BNERR_NATIVE", "0")
    bnerr_native.reset()
    yield
    monkeypatch.undo()
    bnerr_native.reset()


def _frame(h=70, w=53, seed=1, firefly=40.0):
    """Color with a firefly, tilted normals, escaped pixels (no normal, depth 0), albedo."""
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[1, 10, 12] = firefly
    tilt = torch.randn(3, h, w, generator=g) * 0.2 + torch.tensor([0.0, 0.0, 1.0])[:, None, None]
    normal = F.normalize(tilt, dim=0)
    normal[:, :20, :15] = 0.0
    depth = torch.rand(1, h, w, generator=g) + 1.0
    depth[:, :20, :15] = 0.0
    albedo = torch.rand(3, h, w, generator=g)
    return color, normal, depth, albedo


def _run_atrous(kernels, planes, params, threads=2):
    iterations, *sigmas = params
    return atrous_native(kernels, planes, iterations, tuple(sigmas), threads)


def _odd(radius: float) -> int:
    """The bilateral filters' window: 2 ceil(radius) + 1 pixels (2 sigma_space either side)."""
    return 2 * math.ceil(radius) + 1


# -- a-trous ------------------------------------------------------------------------------------


@pytest.mark.parametrize("params", ATROUS_CORNERS)
@pytest.mark.parametrize("with_variance", [False, True])
def test_atrous_matches_the_torch_path(kernels, params, with_variance):
    color, normal, depth, _ = _frame()
    initial = None
    if with_variance:
        initial = torch.rand(70, 53, generator=torch.Generator().manual_seed(2))
        initial[::3] = float("nan")  # those rows take the spatial estimate
    planes = atrous_planes(color, normal, depth, initial)
    want = atrous_torch(planes, params[0], params[1:])
    got = _run_atrous(kernels, planes, params)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize(("h", "w"), [(1, 1), (1, 9), (9, 1), (3, 300), (41, 37)])
def test_atrous_on_tiny_and_odd_sizes(kernels, h, w):
    # Hole spacing 16 on a 1-pixel image: every tap is clamped onto the image (replicate border).
    color, normal, depth, _ = _frame(max(h, 21), max(w, 16))
    planes = atrous_planes(color[:, :h, :w], normal[:, :h, :w], depth[:, :h, :w], None)
    want = atrous_torch(planes, 5, (4.0, 128.0, 1.0))
    got = _run_atrous(kernels, planes, (5, 4.0, 128.0, 1.0))
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)


def test_atrous_does_not_depend_on_the_thread_count(kernels):
    color, normal, depth, _ = _frame(h=67, w=300)
    planes = atrous_planes(color, normal, depth, None)
    one = _run_atrous(kernels, planes, (3, 4.0, 128.0, 1.0), threads=1)
    for threads in (2, 3, 67, 200):
        assert torch.equal(_run_atrous(kernels, planes, (3, 4.0, 128.0, 1.0), threads), one)


def test_atrous_filter_dispatches_cpu_float32_to_the_kernel(kernels):
    color, normal, depth, _ = _frame()
    planes = atrous_planes(color, normal, depth, None, kernels)
    want = _run_atrous(kernels, planes, (5, 4.0, 128.0, 1.0))
    assert torch.equal(atrous_filter(color, normal, depth), want)


@pytest.mark.parametrize(("h", "w"), [(70, 53), (1, 1), (2, 9), (9, 2), (5, 300)])
def test_spatial_variance_matches_the_torch_path(kernels, h, w):
    # The 7 x 7 box sums in another order: a few ulps of the sums, which the difference of the
    # mean square and the squared mean scales up by at most mean^2 / variance (measured below
    # 3.3e-6 relative, within 1e-4 by far).
    color, normal, depth, _ = _frame(max(h, 21), max(w, 16))
    args = (color[:, :h, :w], normal[:, :h, :w], depth[:, :h, :w], None)
    want = atrous_planes(*args)[1]
    got = atrous_planes(*args, kernels)[1]
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)
    one = native.native_luminance_variance(kernels, args[0], 3, LUMINANCE_WEIGHTS, 1)
    for threads in (2, 3, 200):
        got = native.native_luminance_variance(kernels, args[0], 3, LUMINANCE_WEIGHTS, threads)
        assert torch.equal(got, one)


def test_atrous_float64_and_fireflies_keep_the_torch_path():
    # float64 (and the float64 switch a firefly above 1e18 makes) never reaches the kernel.
    color, normal, depth, _ = _frame()
    wide = [t.double() for t in (color, normal, depth)]
    want = atrous_torch(atrous_planes(*wide, None), 5, (4.0, 128.0, 1.0))
    assert torch.equal(atrous_filter(*wide, 5, 4.0, 128.0, 1.0), want)
    color[0, 3, 3] = 1e20
    out = atrous_filter(color, normal, depth)
    assert out.dtype == torch.float32 and torch.isfinite(out).all()


def test_atrous_without_the_library_runs_the_torch_path(no_native):
    assert native.FILTERS.load() is None
    color, normal, depth, _ = _frame()
    want = atrous_torch(atrous_planes(color, normal, depth, None), 5, (4.0, 128.0, 1.0))
    assert torch.equal(atrous_filter(color, normal, depth), want)


# -- bilateral and joint bilateral --------------------------------------------------------------

# (sigma_color, sigma_space) corners: the defaults, the classes' limits, a wide window.
BILATERAL_CORNERS = [(1.0, 1.5), (1e-3, 0.1), (1e3, 16.0), (0.3, 2.5)]


def _bilateral_case(firefly, size=(41, 37)):
    color, normal, _, albedo = _frame(*size, firefly=firefly)
    return color, normal, albedo


@pytest.mark.parametrize("firefly", [40.0, 1e20, 3e38])
@pytest.mark.parametrize(("sigma_color", "sigma_space"), BILATERAL_CORNERS)
def test_bilateral_matches_kornia(kernels, firefly, sigma_color, sigma_space):
    color, _, _ = _bilateral_case(firefly)
    k = _odd(2.0 * sigma_space)
    image = color / color.mean()
    want = bilateral_torch(image, None, k, sigma_color, sigma_space)
    got = native.native_bilateral(kernels, image, None, k, sigma_color, sigma_space, 2)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6 * float(want.abs().amax()))


@pytest.mark.parametrize("firefly", [40.0, 1e20, 3e38])
@pytest.mark.parametrize(("sigma_color", "sigma_space"), BILATERAL_CORNERS)
def test_joint_bilateral_matches_kornia(kernels, firefly, sigma_color, sigma_space):
    color, normal, albedo = _bilateral_case(firefly)
    k = _odd(2.0 * sigma_space)
    guide = torch.cat([albedo / 0.3, normal / 0.3, color / color.mean() / sigma_color])
    want = bilateral_torch(color, guide, k, 1.0, sigma_space)
    got = native.native_bilateral(kernels, color, guide, k, 1.0, sigma_space, 2)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6 * float(want.abs().amax()))


def test_bilateral_filters_match_kornia_on_an_image_kornia_filters_by_taps(kernels):
    # 3 x 160 x 139 values: above kornia's threshold for its tap loop (65536), which adds the
    # taps in the kernel's order; the unfold path of the small cases sums rows first.
    color, normal, albedo = _bilateral_case(40.0, size=(160, 139))
    scale = color.mean()
    want = bilateral_torch(color / scale, None, 7, 1.0, 1.5) * scale
    torch.testing.assert_close(bilateral_filter(color, 1.0, 1.5), want, rtol=1e-4, atol=1e-6)
    guide = torch.cat([albedo / 0.3, normal / 0.3, color / scale / 4.0])
    want = bilateral_torch(color, guide, 9, 1.0, 2.0)
    got = joint_bilateral_filter(color, albedo, normal, 2.0, 0.3, 4.0)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize(("h", "w"), [(1, 1), (1, 9), (9, 1), (3, 300)])
def test_bilateral_on_tiny_and_odd_sizes(kernels, h, w):
    color, normal, albedo = _bilateral_case(40.0, size=(max(h, 21), max(w, 16)))
    color, guide = color[:, :h, :w], torch.cat([albedo, normal])[:, :h, :w]
    for g, k in ((None, 5), (guide, 9)):
        want = bilateral_torch(color, g, k, 0.7, k / 4)
        got = native.native_bilateral(kernels, color, g, k, 0.7, k / 4, 2)
        torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6 * float(want.abs().amax()))


def test_bilateral_does_not_depend_on_the_thread_count(kernels):
    color, normal, albedo = _bilateral_case(40.0, size=(67, 300))
    guide = torch.cat([albedo, normal, color])
    for g in (None, guide):
        one = native.native_bilateral(kernels, color, g, 9, 0.5, 2.0, 1)
        for threads in (2, 3, 67, 200):
            assert torch.equal(
                native.native_bilateral(kernels, color, g, 9, 0.5, 2.0, threads), one
            )


def test_bilateral_kernel_refuses_what_it_cannot_do(kernels):
    # More than 16 image channels: None, and the caller keeps kornia's path.
    image = torch.rand(17, 8, 8)
    assert native.native_bilateral(kernels, image, None, 3, 1.0, 1.0, 1) is None
    scale = image.mean()
    want = bilateral_torch(image / scale, None, 5, 1.0, 1.0) * scale
    assert torch.equal(bilateral_filter(image, 1.0, 1.0), want)


def test_bilateral_float64_keeps_kornias_path():
    color, normal, albedo = _bilateral_case(40.0)
    wide = color.double()
    want = bilateral_torch(wide / wide.mean(), None, 7, 1.0, 1.5) * wide.mean()
    assert torch.equal(bilateral_filter(wide, 1.0, 1.5), want)


def test_bilateral_without_the_library_runs_kornia(no_native):
    assert native.FILTERS.load() is None
    color, normal, albedo = _bilateral_case(40.0)
    scale = color.mean()
    want = bilateral_torch(color / scale, None, 7, 1.0, 1.5) * scale
    assert torch.equal(bilateral_filter(color, 1.0, 1.5), want)
    guide = torch.cat([albedo / 0.3, normal / 0.3, color / scale / 4.0])
    want = bilateral_torch(color, guide, 9, 1.0, 2.0)
    assert torch.equal(joint_bilateral_filter(color, albedo, normal, 2.0, 0.3, 4.0), want)


# -- the library and its self-checks ------------------------------------------------------------


def test_self_checks_pass_and_eligibility(kernels):
    assert filters.atrous._native_atrous() is kernels
    assert filters.common._native_bilateral() is kernels
    assert not native.FILTERS.status().startswith("disabled")
    assert native.eligible(torch.zeros(2), torch.zeros(3))
    assert not native.eligible(torch.zeros(2), torch.zeros(3, dtype=torch.float64))
    assert native.threads_for(10) == 1


def test_the_c_sources_ship_with_the_denoisers_not_the_library():
    # Package data of denoisers.native (pyproject's package-data ships native/*.c); bnerr ships
    # only its own kernel, and builds these by package and file name.
    for name in ("filters.c", "guided.c"):
        assert resources.files("denoisers.native").joinpath(name).is_file()
        assert not resources.files("bnerr.native").joinpath(name).is_file()
    assert native.FILTERS.package == native.GUIDED.package == "denoisers.native"


def test_without_a_compiler_one_warning_and_the_torch_paths(monkeypatch, tmp_path):
    # Each library warns once, quoting what its torch path costs; every filter still runs.
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    monkeypatch.setenv("BNERR_CACHE_DIR", str(tmp_path / "cache"))
    bnerr_native.reset()
    try:
        color, normal, depth, albedo = _frame(h=21, w=16)
        with pytest.warns(RuntimeWarning) as caught:
            atrous = atrous_filter(color, normal, depth)
            bilateral_filter(color, 1.0, 1.5)
            guided = guided_filter(color, albedo, normal, 2, 1.0)
        messages = [str(w.message) for w in caught]
        assert len(messages) == 2, messages  # filters.c, guided.c: once each
        assert all("no-such-compiler" in m and "the torch path is used" in m for m in messages)
        assert native.FILTERS.load() is None and native.GUIDED.load() is None
        assert torch.equal(
            atrous, atrous_torch(atrous_planes(color, normal, depth, None), 5, (4.0, 128.0, 1.0))
        )
        assert torch.equal(guided, guided_torch(color, albedo, normal, 2, 1.0))
    finally:
        monkeypatch.undo()
        bnerr_native.reset()
