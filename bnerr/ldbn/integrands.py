"""The test integrands of the LDBN optimizer and the error features they give each key.

A key's *error vector* is what the N samples it selects estimate for every test integrand; the
exact integrals cancel in every difference the optimizer uses (docs/METHODS.md, section 10). The
tests are 2D, one dimension pair at a time:

- **Heavisides** (half of them): a random direction ``n`` and a random point ``c`` of the unit
  square that the edge passes through, ``f(x) = [n . (x - c) > 0]``: visibility and shading
  edges;
- **smooth bumps** (the other half): ``f(x) = exp(-|x - mu|^2 / (2 s^2))`` with ``mu`` uniform
  in the square and ``s`` uniform in [0.05, 0.5]: soft shading, area-light falloff.

Every test's estimates are standardized over the keys (mean 0, variance 1), so that the smooth
tests, whose errors are small, weigh as much as the edges, then projected on their leading
principal components (:func:`error_features`): swapping two keys' error vectors is the same as
swapping their coordinates, so the energy needs only the components that carry the variance.
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import ShapeError, check_positive_int, check_shape

__all__ = ["Integrands", "error_features", "estimates", "make_integrands"]

# Lanes evaluated at once (keys x samples x tests floats): bounds the working memory to ~256 MB.
_CHUNK = 1 << 26


class Integrands:
    """``count`` random 2D test integrands (module docstring), evaluated on point sets.

    Attributes:
        normal: ``[H, 2]`` the Heavisides' edge normals; ``offset``: ``[H]`` their ``n . c``.
        centre: ``[S, 2]`` the bumps' centres; ``inv_two_s2``: ``[S]`` their ``1 / (2 s^2)``.
    """

    def __init__(self, count: int, seed: int = 0) -> None:
        count = check_positive_int(count, "count", minimum=2)
        gen = torch.Generator().manual_seed(check_positive_int(seed, "seed", minimum=0))
        edges, bumps = count // 2, count - count // 2
        angle = torch.rand(edges, generator=gen, dtype=torch.float64) * (2 * math.pi)
        self.normal = torch.stack([angle.cos(), angle.sin()], 1).float()
        point = torch.rand(edges, 2, generator=gen, dtype=torch.float64).float()
        self.offset = (self.normal * point).sum(1)
        self.centre = torch.rand(bumps, 2, generator=gen, dtype=torch.float64).float()
        s = 0.05 + 0.45 * torch.rand(bumps, generator=gen, dtype=torch.float64).float()
        self.inv_two_s2 = 1.0 / (2 * s * s)

    def __len__(self) -> int:
        return self.normal.shape[0] + self.centre.shape[0]

    def __call__(self, points: torch.Tensor) -> torch.Tensor:
        """``points [..., 2]`` -> ``[..., count]`` the integrands' values (edges first)."""
        normal, offset = self.normal.to(points), self.offset.to(points)
        edge = (points @ normal.T > offset).to(points.dtype)
        delta = points.unsqueeze(-2) - self.centre.to(points)
        bump = torch.exp(-(delta * delta).sum(-1) * self.inv_two_s2.to(points))
        return torch.cat([edge, bump], -1)


def make_integrands(count: int, seed: int = 0) -> Integrands:
    """:class:`Integrands` of ``count`` tests drawn from ``seed`` (half edges, half bumps)."""
    return Integrands(count, seed)


def estimates(points: torch.Tensor, tests: Integrands) -> torch.Tensor:
    """``points [K, N, 2]`` (K point sets of N samples) -> ``[K, tests]`` their sample means."""
    check_shape(points, "K N 2", "points")
    keys, n = points.shape[:2]
    rows = max(1, _CHUNK // max(1, n * len(tests)))
    out = torch.empty(keys, len(tests), dtype=points.dtype, device=points.device)
    for start in range(0, keys, rows):
        out[start : start + rows] = tests(points[start : start + rows]).mean(1)
    return out


def error_features(values: torch.Tensor, components: int = 32) -> torch.Tensor:
    """Standardize ``values [K, tests]`` per test and keep the leading principal components.

    Returns:
        ``[K, c]`` float32, ``c = min(components, tests, K)``: the keys' coordinates on the
        leading principal axes of the standardized estimates (squared distances between rows
        are those of the full vectors, less the variance of the discarded axes).
    """
    check_shape(values, "K T", "values")
    if values.shape[0] < 2:
        raise ShapeError(f"values: expected at least 2 keys, got {values.shape[0]}")
    x = values.double()
    x = x - x.mean(0)
    std = x.std(0)
    x = x / torch.where(std > 1e-12, std, torch.ones_like(std))
    c = min(components, x.shape[1], x.shape[0])
    # the right singular vectors of x are the principal axes (fixed sign: largest entry positive)
    _, _, vh = torch.linalg.svd(x, full_matrices=False)
    axes = vh[:c]
    sign = torch.sign(axes.gather(1, axes.abs().argmax(1, keepdim=True)))
    return (x @ (axes * sign).T).float()
