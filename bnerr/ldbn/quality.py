"""How blue a key tile's errors are: the share of their variance a Gaussian blur keeps.

Belcour & Heitz 2021's criterion, ``Var[k_sigma * e]``, on test integrands the optimizer never
saw (another seed): each texel's error on each test is the estimate of its first ``m`` keyed
samples minus the mean over texels; the tile of errors is blurred toroidally by a Gaussian of
``sigma`` pixels (in the Fourier domain) and the kept share is ``|blurred|^2 / |raw|^2``, averaged
over the tests (and frames). Errors of independent pixels keep about ``1 / (4 pi sigma^2)``
(0.020 at sigma 2); blue-noise errors keep less.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int
from bnerr.ldbn.integrands import estimates, make_integrands
from bnerr.ldbn.keys import SHIPPED_SEED0
from bnerr.sequences.ldbn_bases import base_table, keyed_words

__all__ = ["blurred_share", "pair_points", "white_share"]

_TWO_24 = 1 << 24


def _gauss_response(size: int, sigma: float) -> torch.Tensor:
    """``[T, T // 2 + 1]`` the transfer function of a toroidal Gaussian blur (rfft2 layout)."""
    fy = torch.fft.fftfreq(size, dtype=torch.float64)
    fx = torch.fft.rfftfreq(size, dtype=torch.float64)
    return torch.exp(-2 * (math.pi * sigma) ** 2 * (fy[:, None] ** 2 + fx[None, :] ** 2))


def white_share(size: int, sigma: float = 2.0) -> float:
    """The share independent errors keep on a ``T x T`` torus: ``mean |H(f)|^2``."""
    h = _gauss_response(check_positive_int(size, "size", minimum=2), sigma)
    full = torch.cat([h, h[:, 1 : (size + 1) // 2].flip(1)], 1)  # the mirrored half-spectrum
    return float((full**2).mean())


def blurred_share(
    scramble: np.ndarray,
    rank: np.ndarray,
    spp: int,
    pair: int | tuple[int, ...] = 0,
    sigma: float = 2.0,
    tests: int = 256,
    seed0: int = SHIPPED_SEED0,
    base: str = "sobol",
    level: int | None = None,
    drift: int = 0,
) -> float:
    """The share of the error variance a Gaussian blur keeps (module docstring).

    Args:
        scramble: ``[F, T, T, D]`` one level's scrambling keys; rank: ``[F, T, T, D // 2]``.
        spp: the prefix measured (the first ``spp`` samples of each texel).
        pair: the dimension pair measured, or two pairs measured together on test
            integrands of all their dimensions (each pair read through its own keys and ranks,
            as the sampler reads them): the error of their joint point set, which the per-pair
            optimization does not see.
        seed0: the shared sequence's seed the keys were optimized for.
        base: the base point set the keys act on (:mod:`bnerr.sequences.ldbn_bases`).
        level: the keys' level (their tile's ``2^l`` samples; ``zorder`` chunks are ``2^l``
            long); default: the smallest that holds every ranked index.
        drift: how far each texel's test integrands are moved from its left and upper
            neighbour's, in units of ``1 / T`` of each pair's square: texel ``(y, x)``
            evaluates the tests at its points plus ``drift (x, y) / T`` modulo 1 (an integer, so
            the shift wraps with the tile). 0: every texel integrates the same functions, as
            the optimizer assumed; in a render neighbouring pixels integrate different ones (a
            shadow edge moves in the light's square from pixel to pixel).
    """
    if scramble.ndim != 4 or rank.shape[:3] != scramble.shape[:3]:
        raise ShapeError(
            f"scramble, rank: expected [F, T, T, D] and [F, T, T, D // 2], got "
            f"{list(scramble.shape)} and {list(rank.shape)}"
        )
    frames, size = scramble.shape[0], scramble.shape[1]
    spp = check_positive_int(spp, "spp")
    pairs = _check_pairs(pair, rank.shape[3])
    if level is None:
        level = max(int(rank[..., p].max()) for p in pairs).bit_length()
        level = max(level, (spp - 1).bit_length())
    points = torch.cat(
        [pair_points(scramble, rank, spp, p, (seed0, base, level)) for p in pairs], 2
    )
    if check_positive_int(drift, "drift", minimum=0):
        points = (points + _drift(frames, size, drift).repeat(1, len(pairs))[:, None]) % 1
    seed = 1_000_003 + pairs[0] if len(pairs) == 1 else 2_000_003 + 7919 * pairs[0] + pairs[-1]
    err = estimates(points, make_integrands(tests, seed, 2 * len(pairs))).double()
    err = err.reshape(frames, size, size, -1).permute(0, 3, 1, 2)
    err = err - err.mean((2, 3), keepdim=True)
    blurred = torch.fft.irfft2(torch.fft.rfft2(err) * _gauss_response(size, sigma), s=(size, size))
    raw = (err**2).sum((2, 3))
    kept = (blurred**2).sum((2, 3))
    valid = raw > 0
    return float((kept[valid] / raw[valid]).mean())


def _check_pairs(pair: int | tuple[int, ...], count: int) -> tuple[int, ...]:
    """``pair`` as a tuple of one or two distinct pairs among the keys' ``count``."""
    pairs = (pair,) if isinstance(pair, int) else tuple(pair)
    bad = any(not 0 <= p < count for p in pairs) or len(set(pairs)) < len(pairs)
    if bad or not 1 <= len(pairs) <= 2:
        raise ValueRangeError(
            f"pair: expected one or two distinct pairs in [0, {count}) (the keys' dimension "
            f"pairs; the test integrands have 2 or 4 dimensions), got {pair!r}"
        )
    return pairs


def _drift(frames: int, size: int, drift: int) -> torch.Tensor:
    """``[F T^2, 2]`` each texel's shift ``drift (x, y) / T`` of its points (``blurred_share``)."""
    coords = torch.arange(size, dtype=torch.float32) * drift / size
    y, x = torch.meshgrid(coords, coords, indexing="ij")
    return torch.stack([x, y], -1).reshape(-1, 2).repeat(frames, 1)


def pair_points(
    scramble: np.ndarray, rank: np.ndarray, spp: int, pair: int, read: tuple[int, str, int]
) -> torch.Tensor:
    """``[P, spp, 2]`` the first ``spp`` points of every texel in ``pair`` (``read``: the
    shared sequence's seed, the base and the keys' level)."""
    seed0, base, level = read
    keys = torch.from_numpy(scramble[..., 2 * pair : 2 * pair + 2].reshape(-1, 2)).long()
    ranks = torch.from_numpy(rank[..., pair].reshape(-1)).long()
    index = torch.arange(spp)[None, :] ^ ranks[:, None]  # [P, spp]
    table = base_table(base, seed0, pair, level, keys.shape[0])
    return keyed_words(base, table, index, keys, 1 << level).float() / _TWO_24
