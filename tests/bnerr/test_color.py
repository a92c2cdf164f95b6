"""Tests for bnerr.color: luminance, the tone maps and the 8-bit preview."""

import numpy as np
import pytest
import torch

from bnerr.color import LUMINANCE_WEIGHTS, TONEMAPS, luminance, preview_u8, srgb_encode, tonemap
from bnerr.errors import ShapeError, UnknownNameError


def test_luminance_repeats_its_documented_operation_order():
    rgb = torch.rand(3, 5, 7, generator=torch.Generator().manual_seed(0))
    w0, w1, w2 = LUMINANCE_WEIGHTS
    assert torch.equal(luminance(rgb), w0 * rgb[0] + w1 * rgb[1] + w2 * rgb[2])
    assert torch.equal(luminance(rgb[:1]), rgb[0])  # a scalar image passes through
    assert luminance(rgb.double()).dtype == torch.float32
    with pytest.raises(ShapeError):
        luminance(torch.rand(2, 4, 4))


def test_luminance_keepdim_and_dtype_are_the_filters_convention():
    # The filters stack the luminance with other planes and keep float64 (their firefly switch):
    # the same values, in the same operation order, as the sort key's.
    rgb = torch.rand(3, 5, 7, generator=torch.Generator().manual_seed(1)).double()
    w0, w1, w2 = LUMINANCE_WEIGHTS
    got = luminance(rgb, keepdim=True, dtype=None)
    assert got.shape == (1, 5, 7) and got.dtype == torch.float64
    assert torch.equal(got[0], w0 * rgb[0] + w1 * rgb[1] + w2 * rgb[2])
    assert torch.equal(luminance(rgb.float(), keepdim=True)[0], luminance(rgb.float()))
    assert luminance(rgb[:1], keepdim=True, dtype=None).shape == (1, 5, 7)
    torch.testing.assert_close(luminance(torch.ones(3, 2, 2), keepdim=True), torch.ones(1, 2, 2))


@pytest.mark.parametrize("name", TONEMAPS)
def test_tonemaps_map_into_the_unit_interval(name):
    x = torch.tensor([-1.0, 0.0, 0.5, 1.0, 10.0, 1e6])
    y = tonemap(x, name)
    assert float(y.min()) >= 0.0 and float(y.max()) <= 1.0
    assert torch.all(y[1:].diff() >= 0)


def test_unknown_tonemap_and_srgb_curve():
    with pytest.raises(UnknownNameError):
        tonemap(torch.ones(1), "filmic")
    x = torch.tensor([0.0, 0.0031308, 0.5, 1.0])
    torch.testing.assert_close(srgb_encode(x)[[0, 3]], torch.tensor([0.0, 1.0]))
    assert abs(float(srgb_encode(x)[1]) - 12.92 * 0.0031308) < 1e-6


def test_preview_is_uint8_hwc_and_nan_becomes_black():
    color = torch.full((3, 2, 4), 0.5)
    color[:, 0, 0] = float("nan")
    out = preview_u8(color)
    assert out.dtype == np.uint8 and out.shape == (2, 4, 3)
    assert out[0, 0].tolist() == [0, 0, 0]
    expected = round(float(srgb_encode(torch.tensor(0.5 / 1.5))) * 255)
    assert int(out[1, 1, 0]) == expected
