"""A small image and its noisy copy, for the metrics tests."""

import torch


def noisy_pair(seed=0, shape=(3, 24, 20), noise=0.1):
    """``(pred, ref)``: ``ref`` uniform in [0.1, 1.1), ``pred = ref + noise * N(0, 1)``; float32."""
    gen = torch.Generator().manual_seed(seed)
    ref = torch.rand(shape, generator=gen) + 0.1
    pred = ref + noise * torch.randn(shape, generator=gen)
    return pred, ref
