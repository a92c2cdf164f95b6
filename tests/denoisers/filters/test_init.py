"""Tests of denoisers/filters/__init__.py, the package's public face: what every filter does
(a constant image is a fixed point, determinism, less error on a noisy image, parameters that
round-trip, a finite image from a huge firefly) and how the feature-guided filters differ from
the linear blur at a geometry edge.
"""

import pytest
import torch

from bnerr.frame import Frame
from denoisers import get_denoiser
from denoisers.filters import (
    ATrous,
    Bilateral,
    Gaussian,
    Guided,
    JointBilateral,
    Median,
    atrous_filter,
    gaussian_filter,
    joint_bilateral_filter,
)
from tests._images import random_frame, two_surfaces

FILTERS = [Gaussian(), Bilateral(), JointBilateral(), Guided(), Median(), ATrous()]


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
    frame, _ = two_surfaces(noise=0.5)
    a, b = denoiser(frame), denoiser(frame)
    assert torch.equal(a, b)
    assert a.dtype == torch.float32


@pytest.mark.parametrize("denoiser", FILTERS, ids=lambda d: d.name)
def test_lowers_error_on_noisy_two_surface_image(denoiser):
    frame, clean = two_surfaces(noise=0.5, seed=1)
    noisy_mse = float((frame.color - clean).square().mean())
    mse = float((denoiser(frame) - clean).square().mean())
    assert mse < 0.5 * noisy_mse, (mse, noisy_mse)


def test_params_round_trip_through_constructor():
    for denoiser in FILTERS:
        again = type(denoiser)(**denoiser.params())
        assert again.params() == denoiser.params()


def test_feature_guided_filters_keep_geometry_edges_that_gaussian_blurs():
    # Constant lighting: then the only thing to blur is the edge between the two surfaces.
    frame, clean = two_surfaces(noise=0.0, gradient=0.0)
    edge = slice(10, 14)  # the two columns either side of the material / normal / depth edge
    for out in (
        joint_bilateral_filter(frame.color, frame.albedo, frame.normal, 2.0, 0.05, 100.0),
        atrous_filter(frame.color, frame.normal, frame.depth),
    ):
        assert float((out - clean)[:, :, edge].abs().max()) < 1e-3
    blurred = gaussian_filter(frame.color, 2.0)
    assert float((blurred - clean)[:, :, edge].abs().max()) > 0.05


# -- values a renderer writes: fireflies (issue 18; the float64 switch of filters/common.py) ------


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
