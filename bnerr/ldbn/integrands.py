"""The test integrands of the LDBN optimizer and the error features they give each key.

A key's *error vector* is what the N samples it selects estimate for every test integrand; the
exact integrals cancel in every difference the optimizer uses (docs/METHODS.md, section 10). The
tests are 2D, one dimension pair at a time:

- **Heavisides** (half of them): a random direction ``n`` and a random point ``c`` of the unit
  square that the edge passes through, ``f(x) = [n . (x - c) > 0]``: visibility and shading
  edges;
- **smooth bumps** (the other half): ``f(x) = exp(-|x - mu|^2 / (2 s^2))`` with ``mu`` uniform
  in the square and ``s`` uniform in [0.05, 0.5]: soft shading, area-light falloff.

With ``dims = 4`` (the joint optimization of a pair with the pixel-jitter pair: coordinates 0-1
the jitter, 2-3 the other pair) the tests are what a light sample meets when each jittered sample
shades another point: an edge in the other pair's square whose position moves *a little* with the
jitter sample, normal ``(c m, n)`` with ``n`` and ``m`` random unit 2D directions and the
coupling ``c`` uniform in [0, 0.5], through a random point of the 4-cube; and bumps of width
``s`` (as above) in the other pair's square times a broad one (width 1) in the jitter's. A test
family with isotropic 4D normals was measured first: it halves the blur-kept share on such tests
but loses the 2D blue noise of the pair itself and does not help the renders
(docs/METHODS.md, section 10).

Every test's estimates are standardized over the keys (mean 0, variance 1), so that the smooth
tests, whose errors are small, weigh as much as the edges, then projected on their leading
principal components (:func:`error_features`): swapping two keys' error vectors is the same as
swapping their coordinates, so the energy needs only the components that carry the variance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_shape

__all__ = [
    "FeatureBasis",
    "Integrands",
    "error_features",
    "estimates",
    "feature_basis",
    "make_integrands",
]

# Lanes evaluated at once (keys x samples x tests floats): bounds the working memory to ~256 MB.
_CHUNK = 1 << 26


class Integrands:
    """``count`` random test integrands of ``dims`` (2 or 4) dimensions (module docstring),
    evaluated on point sets.

    Attributes:
        normal: ``[H, dims]`` the Heavisides' edge normals (4D: the jitter's part first);
            ``offset``: ``[H]`` their ``n . c``.
        centre: ``[S, dims]`` the bumps' centres; ``inv_two_s2``: ``[S]`` their ``1 / (2 s^2)``.
    """

    def __init__(self, count: int, seed: int = 0, dims: int = 2) -> None:
        count = check_positive_int(count, "count", minimum=2)
        if dims not in (2, 4):
            raise ValueRangeError(f"dims: expected 2 or 4, got {dims}")
        gen = torch.Generator().manual_seed(check_positive_int(seed, "seed", minimum=0))
        edges, bumps = count // 2, count - count // 2
        angle = torch.rand(edges, generator=gen, dtype=torch.float64) * (2 * math.pi)
        normal = torch.stack([angle.cos(), angle.sin()], 1)
        if dims == 4:  # the jitter's part first: c m, c in [0, 0.5]
            turn = torch.rand(edges, generator=gen, dtype=torch.float64) * (2 * math.pi)
            c = 0.5 * torch.rand(edges, generator=gen, dtype=torch.float64)
            normal = torch.cat([torch.stack([turn.cos(), turn.sin()], 1) * c[:, None], normal], 1)
        self.normal = normal.float()
        point = torch.rand(edges, dims, generator=gen, dtype=torch.float64).float()
        self.offset = (self.normal * point).sum(1)
        self.centre = torch.rand(bumps, dims, generator=gen, dtype=torch.float64).float()
        s = 0.05 + 0.45 * torch.rand(bumps, generator=gen, dtype=torch.float64).float()
        self.inv_two_s2 = 1.0 / (2 * s * s)

    def __len__(self) -> int:
        return self.normal.shape[0] + self.centre.shape[0]

    @property
    def dims(self) -> int:
        return self.normal.shape[1]

    def __call__(self, points: torch.Tensor) -> torch.Tensor:
        """``points [..., dims]`` -> ``[..., count]`` the integrands' values (edges first)."""
        normal, offset = self.normal.to(points), self.offset.to(points)
        edge = (points @ normal.T > offset).to(points.dtype)
        centre, inv = self.centre.to(points), self.inv_two_s2.to(points)
        if self.dims == 2:
            delta = points.unsqueeze(-2) - centre
            exponent = (delta * delta).sum(-1) * inv
        else:  # width s in the pair's square, 1 in the jitter's
            exponent = _square_distance(points[..., 2:], centre[:, 2:]) * inv
            exponent = exponent + _square_distance(points[..., :2], centre[:, :2]) * 0.5
        return torch.cat([edge, torch.exp(-exponent)], -1)


def _square_distance(points: torch.Tensor, centre: torch.Tensor) -> torch.Tensor:
    """``|x - mu|^2`` of ``points [..., k]`` to every ``centre [S, k]``: ``[..., S]``, expanded
    as a matrix product (~9x faster than the differences)."""
    d2 = (points * points).sum(-1, keepdim=True) - 2 * points @ centre.T
    return (d2 + (centre * centre).sum(1)).clamp_min(0)


def make_integrands(count: int, seed: int = 0, dims: int = 2) -> Integrands:
    """:class:`Integrands` of ``count`` tests of ``dims`` dimensions drawn from ``seed`` (half
    edges, half bumps)."""
    return Integrands(count, seed, dims)


def estimates(points: torch.Tensor, tests: Integrands) -> torch.Tensor:
    """``points [K, N, dims]`` (K point sets of N samples) -> ``[K, tests]`` their sample means."""
    check_shape(points, "K N D", "points")
    if points.shape[2] != tests.dims:
        raise ShapeError(f"points: expected {tests.dims} coordinates, got {points.shape[2]}")
    keys, n = points.shape[:2]
    rows = max(1, _CHUNK // max(1, n * len(tests)))
    out = torch.empty(keys, len(tests), dtype=points.dtype, device=points.device)
    for start in range(0, keys, rows):
        out[start : start + rows] = tests(points[start : start + rows]).mean(1)
    return out


@dataclass(frozen=True)
class FeatureBasis:
    """A fixed standardization and projection of error vectors (:func:`feature_basis`).

    Attributes:
        mean: ``[tests]`` float64; scale: ``[tests]`` the divisors; axes: ``[c, tests]``.
    """

    mean: torch.Tensor
    scale: torch.Tensor
    axes: torch.Tensor

    def project(self, values: torch.Tensor) -> torch.Tensor:
        """``values [K, tests]`` -> ``[K, c]`` float32 coordinates on the basis."""
        check_shape(values, "K T", "values")
        return (((values.double() - self.mean) / self.scale) @ self.axes.T).float()


def feature_basis(values: torch.Tensor, components: int = 32) -> FeatureBasis:
    """The per-test standardization of ``values [K, tests]`` and its leading principal axes
    (``c = min(components, tests, K)``, sign fixed: each axis's largest entry positive)."""
    check_shape(values, "K T", "values")
    if values.shape[0] < 2:
        raise ShapeError(f"values: expected at least 2 keys, got {values.shape[0]}")
    x = values.double()
    mean = x.mean(0)
    x = x - mean
    std = x.std(0)
    scale = torch.where(std > 1e-12, std, torch.ones_like(std))
    x = x / scale
    c = min(components, x.shape[1], x.shape[0])
    # the principal axes: the eigenvectors of the tests' Gram matrix (x's right singular
    # vectors), largest eigenvalue first; [tests, tests] whatever the number of keys
    _, vectors = torch.linalg.eigh(x.T @ x)
    axes = vectors.flip(1)[:, :c].T
    sign = torch.sign(axes.gather(1, axes.abs().argmax(1, keepdim=True)))
    return FeatureBasis(mean, scale, axes * sign)


def error_features(values: torch.Tensor, components: int = 32) -> torch.Tensor:
    """Standardize ``values [K, tests]`` per test and keep the leading principal components.

    Returns:
        ``[K, c]`` float32, ``c = min(components, tests, K)``: the keys' coordinates on the
        leading principal axes of the standardized estimates (squared distances between rows
        are those of the full vectors, less the variance of the discarded axes).
    """
    return feature_basis(values, components).project(values)
