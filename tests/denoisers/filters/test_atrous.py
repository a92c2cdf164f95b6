"""Tests of denoisers/filters.py: the kornia filters and the edge-avoiding a-trous filter.

The slow twins (:mod:`_twins`: ``atrous_reference``, ``guided_reference``) write every constant
out themselves, so a wrong tap or window in the code under test fails here.
"""

import math

import pytest
import torch
import torch.nn.functional as F

from bnerr.errors import DtypeError, ValueRangeError
from bnerr.frame import Frame
from denoisers import get_denoiser, native
from denoisers.filters import (
    ATrous,
    Bilateral,
    Gaussian,
    Guided,
    JointBilateral,
    Median,
    atrous_filter,
    atrous_planes,
    atrous_torch,
    gaussian_filter,
    guided_filter,
    joint_bilateral_filter,
    median_filter,
)
from tests._images import random_frame
from tests._twins import atrous_reference, guided_reference

FILTERS = [Gaussian(), Bilateral(), JointBilateral(), Guided(), Median(), ATrous()]


def _two_surfaces(h=24, w=24, noise=0.0, seed=0, gradient=0.2):
    """Left half: red albedo facing +z at depth 2; right half: grey albedo facing +x at depth 3.

    Lighting rises linearly from top to bottom by ``gradient``; color = albedo * lighting *
    (1 + noise * N(0, 1)) clamped at 0.
    """
    g = torch.Generator().manual_seed(seed)
    left = torch.arange(w) < w // 2
    albedo = torch.where(
        left, torch.tensor([0.8, 0.1, 0.1])[:, None, None], torch.full((3, 1, 1), 0.5)
    )
    albedo = albedo.expand(3, h, w).clone()
    normal = torch.where(
        left, torch.tensor([0.0, 0.0, 1.0])[:, None, None], torch.tensor([1.0, 0, 0])[:, None, None]
    )
    normal = normal.expand(3, h, w).clone()
    depth = torch.where(left, 2.0, 3.0).expand(1, h, w).clone()
    light = 1.0 + gradient * torch.linspace(0, 1, h)[:, None].expand(h, w)
    clean = albedo * light
    color = (clean * (1 + noise * torch.randn(3, h, w, generator=g))).clamp_min(0.0)
    return Frame(color=color, albedo=albedo, normal=normal, depth=depth), clean


@pytest.mark.parametrize("denoiser", FILTERS, ids=lambda d: d.name)
def test_constant_image_is_a_fixed_point(denoiser):
    frame = Frame(
        color=torch.full((3, 16, 20), 0.7),
        albedo=torch.full((3, 16, 20), 0.5),
        normal=torch.tensor([0.0, 1.0, 0.0])[:, None, None].expand(3, 16, 20).clone(),
        depth=torch.full((1, 16, 20), 4.0),
    )
    torch.testing.assert_close(denoiser(frame), frame.color, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("denoiser", FILTERS, ids=lambda d: d.name)
def test_deterministic_and_float64_follows_input(denoiser):
    frame, _ = _two_surfaces(noise=0.5)
    a, b = denoiser(frame), denoiser(frame)
    assert torch.equal(a, b)
    assert a.dtype == torch.float32


@pytest.mark.parametrize("denoiser", FILTERS, ids=lambda d: d.name)
def test_lowers_error_on_noisy_two_surface_image(denoiser):
    frame, clean = _two_surfaces(noise=0.5, seed=1)
    noisy_mse = float((frame.color - clean).square().mean())
    mse = float((denoiser(frame) - clean).square().mean())
    assert mse < 0.5 * noisy_mse, (mse, noisy_mse)


def test_gaussian_removes_white_noise_variance_as_theory_says():
    # A unit-sum kernel k turns white noise of variance v into variance v * sum(k^2); for a
    # sampled Gaussian of sigma s that is close to 1 / (4 pi s^2).
    noise = torch.randn(3, 256, 256, generator=torch.Generator().manual_seed(2))
    sigma = 2.0
    out = gaussian_filter(noise, sigma)[:, 16:-16, 16:-16]
    expected = 1.0 / (4 * math.pi * sigma**2)
    # The estimate of the variance of ~ 3 * 224^2 / (4 pi s^2 * 4) independent values has a relative
    # standard error of about sqrt(2 / N_eff) = 1.5 %; allow 4 standard errors.
    assert abs(float(out.var()) / expected - 1) < 0.06


def test_feature_guided_filters_keep_geometry_edges_that_gaussian_blurs():
    # Constant lighting: then the only thing to blur is the edge between the two surfaces.
    frame, clean = _two_surfaces(noise=0.0, gradient=0.0)
    edge = slice(10, 14)  # the two columns either side of the material / normal / depth edge
    for out in (
        joint_bilateral_filter(frame.color, frame.albedo, frame.normal, 2.0, 0.05, 100.0),
        atrous_filter(frame.color, frame.normal, frame.depth),
    ):
        assert float((out - clean)[:, :, edge].abs().max()) < 1e-3
    blurred = gaussian_filter(frame.color, 2.0)
    assert float((blurred - clean)[:, :, edge].abs().max()) > 0.05


def test_median_removes_an_isolated_firefly():
    color = torch.full((3, 9, 9), 0.5)
    color[:, 4, 4] = 100.0
    assert torch.equal(median_filter(color, 3), torch.full((3, 9, 9), 0.5))


def test_atrous_does_not_mix_background_and_surfaces():
    frame, clean = _two_surfaces(noise=0.0, gradient=0.0)
    frame.normal[:, :, :4] = 0.0  # escaped rays: no normal, no albedo, depth 0
    frame.albedo[:, :, :4] = 0.0
    frame.depth[:, :, :4] = 0.0
    frame.color[:, :, :4] = 3.0
    out = atrous_filter(frame.color, frame.normal, frame.depth)
    torch.testing.assert_close(out[:, :, :4], frame.color[:, :, :4], rtol=1e-5, atol=1e-5)
    assert float((out[:, :, 4:] - clean[:, :, 4:]).abs().max()) < 1e-3


def test_parameters_are_checked():
    with pytest.raises(ValueRangeError, match="bilateral: sigma_space: expected a value in"):
        Bilateral(sigma_space=0.0)
    with pytest.raises(DtypeError, match="guided: radius: expected an integer, got float"):
        Guided(radius=2.5)
    with pytest.raises(
        ValueRangeError, match=r"atrous: iterations: expected a value in \[1, 10\], got 11"
    ):
        ATrous(iterations=11)
    with pytest.raises(
        DtypeError, match="joint_bilateral: sigma_color: expected a number, got str"
    ):
        JointBilateral(sigma_color="wide")


def test_params_round_trip_through_constructor():
    for denoiser in FILTERS:
        again = type(denoiser)(**denoiser.params())
        assert again.params() == denoiser.params()


# -- values a renderer writes: fireflies and infinite depth (issue 18) ----------------------------


@pytest.mark.parametrize("firefly", [1e20, 3e38])
@pytest.mark.parametrize("name", ["atrous", "guided", "joint_bilateral", "bilateral", "median"])
def test_one_huge_finite_firefly_gives_a_finite_image(name, firefly):
    # A single 1e20 made atrous's output all NaN (its squared luminance overflowed float32),
    # and a 3e38 one guided's.
    frame = random_frame(24, 24, seed=5)
    frame.color[1, 5, 7] = firefly
    out = get_denoiser(name)(frame)
    assert out.dtype == torch.float32 and torch.isfinite(out).all()
    assert not torch.equal(out, torch.zeros_like(out))


def test_atrous_reads_infinite_depth_as_the_background_depth():
    frame = random_frame(24, 24, seed=5)
    frame.depth[:, :8] = 0.0
    frame.normal[:, :8] = 0.0  # escaped rays: no normal, the tracer's depth 0
    want = get_denoiser("atrous")(frame)
    frame.depth[:, :8] = float("inf")  # the same pixels as another renderer marks them
    assert torch.equal(get_denoiser("atrous")(frame), want)


def test_atrous_float64_switch_agrees_with_float32_on_ordinary_frames():
    frame = random_frame(24, 24, seed=5)
    narrow = atrous_filter(frame.color, frame.normal, frame.depth)
    wide = atrous_filter(frame.color.double(), frame.normal.double(), frame.depth.double())
    torch.testing.assert_close(narrow, wide.float(), rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize(
    ("name", "params", "match"),
    [
        ("median", {"kernel_size": 2001}, "median: kernel_size 2001 on 24x24: expected a size"),
        ("guided", {"radius": 100000}, "guided: radius 100000 on 24x24: expected a size"),
    ],
)
def test_absurd_windows_are_refused_before_allocating(name, params, match):
    from bnerr.errors import MemoryLimitError

    with pytest.raises(MemoryLimitError, match=match + r" that fits in memory .* got an estimate"):
        get_denoiser(name, **params)(random_frame(24, 24, seed=5))


# -- an initial luminance variance (SVGF's temporal estimate) -------------------------------------


def test_atrous_variance_nan_is_the_spatial_estimate_and_none_the_default():
    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    plain = atrous_filter(*args)
    h, w = frame.color.shape[1:]
    assert torch.equal(atrous_filter(*args, variance=torch.full((h, w), float("nan"))), plain)
    # The variance every pass starts from (the native kernel's where atrous_filter runs it).
    spatial = atrous_planes(*args, None, native.FILTERS.load())[1][0]
    given = torch.rand(h, w, generator=torch.Generator().manual_seed(5))
    mixed = torch.where(torch.arange(w) < w // 2, given, float("nan"))
    want = atrous_filter(*args, variance=torch.where(mixed.isnan(), spatial, mixed))
    assert torch.equal(atrous_filter(*args, variance=mixed), want)


def test_atrous_variance_sets_how_much_luminance_difference_is_noise():
    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    h, w = frame.color.shape[1:]
    # Zero variance: every neighbour of another luminance is an edge, the image stays as it is.
    kept = atrous_filter(*args, variance=torch.zeros(h, w))
    torch.testing.assert_close(kept, frame.color, rtol=0, atol=1e-6)
    # A larger variance lets more neighbours in: the output is smoother.
    rough = [
        float(atrous_filter(*args, variance=torch.full((h, w), v)).diff(dim=2).abs().mean())
        for v in (1e-4, 1e-2, 1.0)
    ]
    assert rough[0] > rough[1] > rough[2]


def test_atrous_variance_is_checked():
    from bnerr.errors import ShapeError

    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    h, w = frame.color.shape[1:]
    with pytest.raises(ShapeError, match="atrous_filter: variance"):
        atrous_filter(*args, variance=torch.zeros(1, h, w))
    bad = torch.zeros(h, w)
    bad[3, 4], bad[5, 1] = -1.0, float("inf")
    with pytest.raises(
        ValueRangeError,
        match=r"variance: expected values >= 0 and finite .* got 2 others, first "
        r"-1.0 at pixel \(y, x\) = \(3, 4\)",
    ):
        atrous_filter(*args, variance=bad)


# -- the fast a-trous pass against its slow twin (issue 16) ---------------------------------------
#
# Tolerance: relative 1e-4 of each output value (absolute 1e-6 near 0) for sigma_normal up to 128,
# the value every tuned and default filter uses. The fast pass computes each weight as one
# exp(sigma_normal * log(cos) - ...) instead of exp(...) * cos ** sigma_normal, and the cosine with
# fused multiply-adds: a one-ulp change of the cosine (6e-8) moves cos ** 128 by 128 times that,
# about 8e-6 per pass, measured up to 1.9e-5 after 5 passes. Weights below exp(-80) become exp(-80)
# (see _ATROUS_MIN_LOG_WEIGHT): 1e-35 of a value, far below a float32 ulp. The twin estimates the
# spatial variance with another box sum (avg_pool2d, not kornia's box_blur) and normalizes the
# normals with torch.norm: a few ulps more, far inside the tolerance.


def _atrous_case(h=70, w=53, seed=1):
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[1, 10, 12] = 40.0  # a firefly
    tilt = torch.randn(3, h, w, generator=g) * 0.2 + torch.tensor([0.0, 0.0, 1.0])[:, None, None]
    normal = F.normalize(tilt, dim=0)
    normal[:, :20, :15] = 0.0  # escaped rays
    depth = torch.rand(1, h, w, generator=g) + 1.0
    depth[:, :20, :15] = 0.0
    return color, normal, depth


@pytest.mark.parametrize(
    ("iterations", "sigma_color", "sigma_normal", "sigma_depth"),
    [(5, 4.0, 128.0, 1.0), (1, 1.0, 128.0, 1.0), (3, 16.0, 0.5, 0.1), (2, 64.0, 0.0, 10.0)],
)
def test_fast_atrous_matches_its_slow_twin(iterations, sigma_color, sigma_normal, sigma_depth):
    color, normal, depth = _atrous_case()
    sigmas = (sigma_color, sigma_normal, sigma_depth)
    want = atrous_reference(color, normal, depth, iterations, *sigmas)
    got = atrous_filter(color, normal, depth, iterations, *sigmas)  # native where it loads
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)
    torch_path = atrous_torch(atrous_planes(color, normal, depth, None), iterations, sigmas)
    torch.testing.assert_close(torch_path, want, rtol=1e-4, atol=1e-6)
    variance = torch.rand(70, 53, generator=torch.Generator().manual_seed(2))
    variance[::3] = float("nan")
    want = atrous_reference(color, normal, depth, iterations, *sigmas, initial=variance)
    got = atrous_filter(color, normal, depth, iterations, *sigmas, variance=variance)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)


def test_fast_atrous_strips_meet_without_a_seam(monkeypatch):
    import denoisers.filters.atrous as filters

    color, normal, depth = _atrous_case(h=45)
    planes = atrous_planes(color, normal, depth, None)  # the torch path (strips are its own)
    whole = atrous_torch(planes, 3, (4.0, 128.0, 1.0))
    monkeypatch.setattr(filters, "_ATROUS_ROWS", 7)  # strips of 7 rows, taps up to 8 rows away
    assert torch.equal(atrous_torch(planes, 3, (4.0, 128.0, 1.0)), whole)


# -- the fast guided filter against kornia's guided_blur (its slow twin) --------------------------
#
# Tolerance: 1e-5 of the image's largest value, relative and absolute. Both compute the same
# window statistics in float32, in another order (separable sums against a 2-D convolution), and
# solve the same 7 x 7 system per pixel (Cholesky against LU): at eps >= 1e-2 (the grid's
# smallest) the system's condition number is below 1e3, so a rounding of 6e-8 in the statistics
# moves the output by at most about 6e-5 relative; measured below 2e-6 of the largest value.


@pytest.mark.parametrize(("radius", "eps"), [(1, 1e-2), (2, 1.0), (3, 0.1), (5, 10.0)])
def test_fast_guided_matches_kornia(radius, eps):
    g = torch.Generator().manual_seed(radius)
    color = torch.rand(3, 41, 37, generator=g).square() * 4.0
    color[0, 7, 9] = 60.0
    albedo = torch.rand(3, 41, 37, generator=g)
    albedo[:, :, :10] = 0.5  # a flat region: a singular covariance but for eps
    normal = F.normalize(torch.randn(3, 41, 37, generator=g), dim=0)
    want = guided_reference(color, albedo, normal, radius, eps)
    got = guided_filter(color, albedo, normal, radius, eps)
    scale = float(want.abs().amax())
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5 * scale)
