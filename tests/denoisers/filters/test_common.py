"""Tests of denoisers/filters/common.py: the torch path of the two bilateral filters
(:func:`bilateral_torch`; its native twin is tested in tests/denoisers/native/test_filters.py)."""

import torch

from denoisers.filters import bilateral_torch


def test_an_image_guiding_itself_is_the_plain_bilateral_filter():
    image = torch.rand(3, 17, 23, generator=torch.Generator().manual_seed(4)).square() * 4.0
    plain = bilateral_torch(image, None, 5, 1.0, 1.25)
    torch.testing.assert_close(bilateral_torch(image, image, 5, 1.0, 1.25), plain)
    assert plain.shape == image.shape and not torch.equal(plain, image)


def test_a_constant_image_is_a_fixed_point_of_any_window():
    image = torch.full((2, 9, 11), 0.3, dtype=torch.float64)
    guide = torch.rand(4, 9, 11, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    for size in (3, 7, 15):  # 15: the window is wider than the image (replicated border)
        out = bilateral_torch(image, guide, size, 0.5, size / 4)
        assert out.dtype == torch.float64
        torch.testing.assert_close(out, image, rtol=1e-12, atol=0)
