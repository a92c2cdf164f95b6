"""Small images and frames for tests: a noisy copy of an image (the metrics tests), a random
frame with every buffer a denoiser reads (the denoiser and command tests) and a frame of two
surfaces with known clean colour (the filter tests)."""

import torch

from bnerr.frame import Frame


def noisy_pair(seed=0, shape=(3, 24, 20), noise=0.1):
    """``(pred, ref)``: ``ref`` uniform in [0.1, 1.1), ``pred = ref + noise * N(0, 1)``; float32."""
    gen = torch.Generator().manual_seed(seed)
    ref = torch.rand(shape, generator=gen) + 0.1
    pred = ref + noise * torch.randn(shape, generator=gen)
    return pred, ref


def random_frame(h=12, w=10, seed=0, *, scale=1.0, drop=(), **fields) -> Frame:
    """An ``h x w`` frame of seeded random buffers: color uniform in [0, scale), albedo uniform,
    unit normals, depth in [1, 2), motion in [-0.5, 0.5), object 0; the buffers named in ``drop``
    left out (drawn all the same, so the others do not change); ``fields`` added (``timings``);
    ``own_denoised`` holds a random ``cycles_oidn`` image unless given."""
    g = torch.Generator().manual_seed(seed)
    buffers = dict(
        color=scale * torch.rand(3, h, w, generator=g),
        albedo=torch.rand(3, h, w, generator=g),
        normal=torch.nn.functional.normalize(torch.randn(3, h, w, generator=g), dim=0),
        depth=torch.rand(1, h, w, generator=g) + 1.0,
        motion=torch.rand(2, h, w, generator=g) - 0.5,
        object_id=torch.zeros(1, h, w),
    )
    for name in drop:
        buffers.pop(name)
    if "own_denoised" not in fields:  # a renderer's own denoised image, as Cycles' frames carry
        own = torch.Generator().manual_seed(seed + 7919)
        fields["own_denoised"] = {"cycles_oidn": torch.rand(3, h, w, generator=own)}
    return Frame(**buffers, **fields)


def two_surfaces(h=24, w=24, noise=0.0, seed=0, gradient=0.2) -> tuple[Frame, torch.Tensor]:
    """``(frame, clean)``. Left half: red albedo facing +z at depth 2; right half: grey albedo
    facing +x at depth 3.

    Lighting rises linearly from top to bottom by ``gradient``; color = albedo * lighting *
    (1 + noise * N(0, 1)) clamped at 0; ``clean`` is the colour without noise.
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


def block_multisets(x: torch.Tensor, block: int) -> list[list[int]]:
    """The sorted values of each ``block x block`` block of ``[H, W]`` ``x``, row by row: what a
    permutation inside blocks keeps."""
    h, w = x.shape
    return [
        sorted(x[y : y + block, c : c + block].reshape(-1).tolist())
        for y in range(0, h, block)
        for c in range(0, w, block)
    ]
