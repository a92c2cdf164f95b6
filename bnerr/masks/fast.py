"""Filter-adapted scalar masks (FAST; Donnelly, Wolfe, Buetepage, Valdes 2024, "Filter-Adapted
Spatio-Temporal Sampling for Real-Time Rendering", I3D).

A void-and-cluster mask (:func:`bnerr.masks.void_and_cluster`) is blue for a generic Gaussian of
sigma 1.5; the error it shapes is then seen through whatever filter follows. FAST optimizes the
mask for that filter instead. Our version (docs/METHODS.md, sections 7 and 8) minimizes

    ``E(x) = sum_{p, q} F(p - q) K(x_p, x_q)``,  ``K(a, b) = -|a - b|``,

over the arrangements ``x`` of the start mask's values, with ``F`` the autocorrelation of the
filter: for a Gaussian of sigma ``s``, a Gaussian of sigma ``s sqrt(2)``, taken here as
``F(d) = exp(-|d|^2 / (4 s^2))`` (the constant factor does not move the optimum) over the toroidal
offset ``d``, cut at ``|d| <= 4 s sqrt(2)`` (the footprint; the weights beyond are below 3e-4 of
the centre's). Pairs that the filter mixes are pushed apart in value, so the filtered mask, and
the error sorted against it, loses what the filter keeps. The sum runs over ordered pairs, so each
unordered pair counts twice.

:func:`fast_mask` anneals by swapping two pixels' values, so the result is a permutation of the
start's values (its histogram stays the uniform ranks ``(k + 0.5) / T^2`` of the void-and-cluster
start). Each step is a batch of swaps whose energy changes are independent: the first pixels sit
on a lattice of spacing ``2 R + 1`` (``R`` the footprint's reach in pixels per axis) at a random
offset, the second pixels at one random displacement within ``R`` of them, so no pixel of one swap
lies in the footprint of another's and the changes, computed from the footprint only, add up
exactly. Swaps are accepted by the Metropolis rule at a temperature falling quadratically to zero
(its start is a multiple of the mean ``|change|`` of the first candidate swaps, so one setting
suits every sigma), and the lowest-energy arrangement met is returned (never worse than the
start).

The random choices come from a counter-based hash of the seed (:func:`bnerr.hashing.lowbias32`),
so the same seed gives the same mask everywhere.

What it gains depends on the filter: the void-and-cluster start is itself blue for a Gaussian of
1.5, so for sigma >= 1 it is already a local minimum of this energy (at T = 64 and sigma 1, 1 in
700 candidate swaps lowers it, by at most 1% of a typical change, and annealing leaves the basin
without finding a better one); for sigma 0.75, the narrow filter the shipped mask is made for,
2% of the candidates gain and the energy falls by about 1% (``bnerr/data/README.md``).

The temporal strategy's ``fast`` option (:mod:`bnerr.strategies`) sorts against the shipped mask
(:func:`load_fast_mask`) and retargets with the field optimized for it
(:func:`load_fast_retarget`); ``bnerr mask --fast SIGMA`` makes one (``bnerr/data/README.md``).

Not for: spatiotemporal FAST masks (the paper's full method also optimizes along t), filters other
than a Gaussian, or vector masks.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from bnerr.errors import (
    FLOAT_DTYPES,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
    check_dtype,
    check_finite,
    check_positive_int,
    check_range,
    check_shape,
    check_tensor,
)
from bnerr.hashing import MASK32, lowbias32, lowbias32_host, signed32
from bnerr.masks.spatial import void_and_cluster
from bnerr.permutation.retarget import read_shipped_field
from bnerr.resources import load_array, shipped_files

__all__ = [
    "DEFAULT_ITERATIONS",
    "DEFAULT_TEMPERATURE",
    "SHIPPED_SIGMA",
    "fast_energy",
    "fast_mask",
    "load_fast_mask",
    "load_fast_retarget",
    "shipped_fast_masks",
]

#: The Gaussian sigma (pixels) the shipped ``fast_gauss_<T>.npy`` is optimized for: the median
#: over the scenes of the Gaussian denoiser's tuned sigma at 4 spp (``bnerr/data/README.md``).
SHIPPED_SIGMA = 0.75
#: Candidate swaps per pixel of :func:`fast_mask`.
DEFAULT_ITERATIONS = 512
#: Initial annealing temperature of :func:`fast_mask`, in units of the mean ``|change|`` of the
#: first candidate swaps on the start (the best of 0.05, 0.1 and 0.2 at sigma 0.75 and T = 64,
#: 4096 swaps per pixel; at 512, greedy swaps (0) gained 60% of what 0.03-0.3 gained).
DEFAULT_TEMPERATURE = 0.05

# The footprint's radius in units of the autocorrelation's sigma (s sqrt(2)).
_CUT = 4.0
# Keys the swap stream apart from the other counter-based streams (an arbitrary constant).
_SALT = 0x46A57
_MAX_ITERATIONS = 100_000
# Batches whose random words are drawn at once (a few MB of words).
_CHUNK = 2048


# --------------------------------------------------------------------------------------------------
# The footprint and the energy


def _check_sigma(sigma: object) -> float:
    return float(check_range(sigma, "sigma", 0.25, 16.0))


def _window(sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The footprint of ``F``: ``(dy [W], dx [W], weight [W], reach)``, every offset ``d != 0``
    with ``|d| <= 4 sigma sqrt(2)``, weight ``exp(-|d|^2 / (4 sigma^2))``; ``reach`` the largest
    ``|dy|`` (and ``|dx|``) among them."""
    cut = _CUT * sigma * math.sqrt(2.0)
    reach = max(1, int(math.floor(cut)))
    span = np.arange(-reach, reach + 1)
    grid_y, grid_x = np.meshgrid(span, span, indexing="ij")
    dy, dx = grid_y.ravel(), grid_x.ravel()
    r2 = dy**2 + dx**2
    keep = (r2 > 0) & (r2 <= max(cut * cut, 1.0))
    return dy[keep], dx[keep], np.exp(-r2[keep] / (4.0 * sigma * sigma)), reach


def _check_fits(size: int, sigma: float, reach: int, what: str) -> None:
    """The footprint must not wrap onto itself: ``size >= 2 reach + 1``."""
    if size < 2 * reach + 1:
        raise ValueRangeError(
            f"{what}: expected a tile of at least {2 * reach + 1} pixels for sigma {sigma} "
            f"(the filter's footprint must not wrap onto itself), got {size}"
        )


def _neighbours(size: int, dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``[T^2, W]`` flat indices of every pixel's footprint, toroidally."""
    y, x = np.divmod(np.arange(size * size), size)
    return ((y[:, None] + dy) % size) * size + (x[:, None] + dx) % size


def _energy(values: np.ndarray, nbr: np.ndarray, weight: np.ndarray) -> float:
    """``-sum_p sum_d F(d) |x_p - x_{p + d}|`` of flat ``values [T^2]`` (float64)."""
    return -float((np.abs(values[:, None] - values[nbr]) @ weight).sum())


def _check_mask(mask: object, name: str) -> np.ndarray:
    """A ``[T, T]`` floating, finite tensor as a flat float64 numpy array."""
    mask = check_tensor(mask, name)
    check_shape(mask, "T T", name)
    check_dtype(mask, FLOAT_DTYPES, name)
    check_finite(mask, name)
    if mask.shape[0] == 0:
        raise ShapeError(f"{name}: expected a non-empty [T, T] tile, got shape {list(mask.shape)}")
    return mask.detach().to("cpu", torch.float64).numpy().reshape(-1).copy()


def fast_energy(mask: torch.Tensor, sigma: float) -> float:
    """The FAST energy ``E = sum_{p, q} F(p - q) K(x_p, x_q)`` of a scalar mask (lower is better).

    Args:
        mask: ``[T, T]`` floating, finite scalar mask, tiled toroidally.
        sigma: the sigma (pixels) of the Gaussian filter that follows, in [0.25, 16]; ``F`` is
            the Gaussian of sigma ``sigma sqrt(2)``, cut at 4 of its sigmas (module docstring).

    Returns:
        The energy, a negative float (float64 sums; each unordered pair counted twice). It is
        what :func:`fast_mask` minimizes, term for term.

    Raises:
        DtypeError, ShapeError, NonFiniteError: not a finite floating ``[T, T]`` tensor.
        ValueRangeError: sigma out of range, or a tile smaller than the footprint.
    """
    values = _check_mask(mask, "mask")
    sigma = _check_sigma(sigma)
    dy, dx, weight, reach = _window(sigma)
    size = mask.shape[0]
    _check_fits(size, sigma, reach, "mask")
    return _energy(values, _neighbours(size, dy, dx), weight)


# --------------------------------------------------------------------------------------------------
# Annealing


def _words(seed: int, start: int, count: int) -> np.ndarray:
    """Random 32-bit words ``[count]`` int64 for counters ``start .. start + count - 1`` (below
    2^32), keyed by ``seed``: two rounds of lowbias32 under two keys."""
    key1 = lowbias32_host(seed ^ lowbias32_host(_SALT))
    key2 = lowbias32_host(key1 + 0x632BE5AB)
    counter = (torch.arange(start, start + count, dtype=torch.int64) ^ key1) & MASK32
    x = torch.where(counter >= 1 << 31, counter - (1 << 32), counter).to(torch.int32)
    x = lowbias32(lowbias32(x) ^ signed32(key2))
    return (x.to(torch.int64) & MASK32).numpy()


def _swap_deltas(
    values: np.ndarray,
    p: np.ndarray,
    q: np.ndarray,
    nbr: np.ndarray,
    weight: np.ndarray,
    pair_weight: float,
) -> np.ndarray:
    """Energy change ``[K]`` of swapping the values at ``p [K]`` and ``q [K]``, each alone.

    Only the pairs holding p or q change: with ``S(a, v) = sum_d F(d) |v - x_{a + d}|``, the
    change is ``-2 (S(p, x_q) + S(q, x_p) - S(p, x_p) - S(q, x_q) + 2 F(q - p) |x_p - x_q|)``;
    the last term takes out the p-q pair, which the sums count though it keeps its distance.
    ``pair_weight`` is ``F(q - p)`` (0 outside the footprint), the same for the whole batch.
    """
    pix = np.concatenate([p, q])
    partner = np.concatenate([q, p])
    near = values[nbr[pix]]  # [2K, W]
    own = np.abs(values[pix][:, None] - near) @ weight
    moved = np.abs(values[partner][:, None] - near) @ weight
    k = p.size
    gap = np.abs(values[p] - values[q])
    return -2.0 * (moved[:k] + moved[k:] - own[:k] - own[k:] + 2.0 * pair_weight * gap)


class _Batches:
    """The candidate swaps of :func:`fast_mask`: per batch one lattice offset, one displacement
    ``d`` (``|dy|, |dx| <= step``, not 0) and a uniform number per swap.

    The lattice's spacing is ``reach + 1 + step`` (``reach`` the footprint's): a first pixel is
    then more than ``reach`` from every other swap's first pixel and, since all second pixels are
    shifted by the same ``d``, from every other swap's second pixel and (being at least spacing
    minus ``step`` away) from its first pixel, so no two swaps share a pair term.
    """

    def __init__(self, size: int, reach: int, step: int, seed: int) -> None:
        m = max(1, size // (reach + 1 + step))
        lattice = (np.arange(m) * size) // m
        ly, lx = np.meshgrid(lattice, lattice, indexing="ij")
        self.ly, self.lx = ly.ravel(), lx.ravel()
        self.size, self.step, self.seed = size, step, seed
        self.width = 3 + self.ly.size  # words per batch

    @property
    def count(self) -> int:
        """Swaps per batch."""
        return self.ly.size

    def draw(self, first: int, n: int) -> np.ndarray:
        """The words of batches ``first .. first + n - 1``: ``[n, 3 + K]`` int64."""
        return _words(self.seed, first * self.width, n * self.width).reshape(n, self.width)

    def swaps(self, words: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, int, np.ndarray]:
        """``(p [K], q [K], dy, dx, uniform [K])`` of one batch's words."""
        t, span = self.size, 2 * self.step + 1
        oy, ox = int(words[0]) % t, int(words[1]) % t
        j = int(words[2]) % (span * span - 1)
        j += j >= (span * span) // 2  # skip d = 0
        dy, dx = j // span - self.step, j % span - self.step
        py, px = (self.ly + oy) % t, (self.lx + ox) % t
        p = py * t + px
        q = ((py + dy) % t) * t + (px + dx) % t
        return p, q, dy, dx, (words[3:] + 0.5) * 2.0**-32


class _Footprint:
    """The footprint as the annealer uses it: neighbour table, weights and the weight by offset."""

    def __init__(self, size: int, window: tuple[np.ndarray, np.ndarray, np.ndarray, int]) -> None:
        dy, dx, self.weight, self.reach = window
        self.nbr = _neighbours(size, dy, dx)
        self.table = np.zeros((2 * self.reach + 1, 2 * self.reach + 1))
        self.table[dy + self.reach, dx + self.reach] = self.weight

    def deltas(
        self, values: np.ndarray, p: np.ndarray, q: np.ndarray, d: tuple[int, int]
    ) -> np.ndarray:
        """:func:`_swap_deltas` of the swaps ``p <-> q = p + d``."""
        pair = self.table[d[0] + self.reach, d[1] + self.reach]
        return _swap_deltas(values, p, q, self.nbr, self.weight, pair)


def _typical_change(values: np.ndarray, foot: _Footprint, batches: _Batches, total: int) -> float:
    """Mean ``|change|`` of the first (up to 64) batches' candidate swaps on ``values``: the unit
    of the annealing temperature, so that one setting suits every sigma."""
    changes = []
    for row in batches.draw(0, min(64, total)):
        p, q, dy, dx, _ = batches.swaps(row)
        changes.append(foot.deltas(values, p, q, (dy, dx)))
    return float(np.abs(np.concatenate(changes)).mean())


def _anneal(
    values: np.ndarray, foot: _Footprint, batches: _Batches, total: int, temperature: float
) -> np.ndarray:
    """Run ``total`` batches of Metropolis swaps on flat ``values`` (in place), the temperature
    ``temperature * _typical_change`` falling quadratically to 0; return the lowest-energy
    arrangement met (a copy)."""
    temp0 = temperature * _typical_change(values, foot, batches, total)
    energy = best_energy = _energy(values, foot.nbr, foot.weight)
    best = values.copy()
    for first in range(0, total, _CHUNK):
        words = batches.draw(first, min(_CHUNK, total - first))
        for i, row in enumerate(words):
            p, q, dy, dx, uniform = batches.swaps(row)
            delta = foot.deltas(values, p, q, (dy, dx))
            temp = temp0 * (1.0 - (first + i) / total) ** 2
            with np.errstate(over="ignore"):
                accept = (delta < 0.0) | (uniform < np.exp(-delta / max(temp, 1e-300)))
            p, q = p[accept], q[accept]
            values[p], values[q] = values[q], values[p].copy()
            energy += float(delta[accept].sum())
            if energy < best_energy:
                best_energy = energy
                best[:] = values
    return best


def _start_values(start: object, size: int) -> np.ndarray:
    """The start mask as flat float64 values: ``start`` checked, or the void-and-cluster mask."""
    if start is None:
        return void_and_cluster(size).to(torch.float64).numpy().reshape(-1).copy()
    start = check_tensor(start, "start")
    values = _check_mask(start, "start")
    if start.shape[0] != size:
        raise ShapeError(f"start: expected a [{size}, {size}] mask, got {list(start.shape)}")
    return values


def fast_mask(
    size: int,
    sigma: float,
    *,
    seed: int = 0,
    iterations: int = DEFAULT_ITERATIONS,
    start: torch.Tensor | None = None,
    temperature: float = DEFAULT_TEMPERATURE,
) -> torch.Tensor:
    """A ``size x size`` scalar mask optimized for a Gaussian filter of ``sigma`` (FAST).

    Anneals :func:`fast_energy` by swaps of two pixels' values (see the module docstring), from
    ``start`` (default: ``void_and_cluster(size)``, the shipped scalar mask's generator).

    Args:
        size: T; at least the footprint's width ``2 floor(4 sigma sqrt(2)) + 1`` (9 for sigma
            0.75, 11 for 1, 23 for 2) and at most 512.
        sigma: the Gaussian's sigma in pixels, in [0.25, 16].
        seed: integer in [0, 2^32): the candidate swaps and the Metropolis draws.
        iterations: candidate swaps per pixel, 1 to 100000 (``ceil(iterations T^2 / K)`` batches
            of K swaps, K = ``(T // (2 R + 1))^2``, R the footprint's reach). At T = 64, 512 take
            about 5 s on one core for sigma 0.75 (K = 49) and about a minute for sigma 2 (K = 4).
        start: ``[T, T]`` floating, finite mask to start from; the result holds exactly its values.
        temperature: initial temperature in units of the mean ``|change|`` of the first
            candidate swaps on the start, in [0, 1] (0: greedy); it falls quadratically to 0.

    Returns:
        ``[T, T]`` float32 on the CPU: the start's values permuted, with an energy at most the
        start's; a deterministic function of the arguments.

    Raises:
        DtypeError, ShapeError, NonFiniteError: a bad ``start``. ValueRangeError: an argument out
        of range, or a tile smaller than the footprint.
    """
    size = check_positive_int(size, "size")
    if size > 512:
        raise ValueRangeError(f"size: expected an integer <= 512, got {size}")
    sigma = _check_sigma(sigma)
    seed = check_positive_int(seed, "seed", minimum=0)
    if seed >= 1 << 32:
        raise ValueRangeError(f"seed: expected an integer < 2**32, got {seed}")
    iterations = check_positive_int(iterations, "iterations")
    if iterations > _MAX_ITERATIONS:
        raise ValueRangeError(
            f"iterations: expected an integer in [1, {_MAX_ITERATIONS}], got {iterations}"
        )
    temperature = float(check_range(temperature, "temperature", 0.0, 1.0))
    window = _window(sigma)
    _check_fits(size, sigma, window[3], "size")
    values = _start_values(start, size)
    batches = _Batches(size, window[3], window[3], seed)
    total = math.ceil(iterations * size * size / batches.count)
    if total * batches.width >= 1 << 32:
        raise ValueRangeError(
            f"iterations: expected fewer than {(1 << 32) // (size * size * 2)} for a "
            f"{size}x{size} mask (the random stream's length), got {iterations}"
        )
    best = _anneal(values, _Footprint(size, window), batches, total, temperature)
    return torch.from_numpy(best.astype(np.float32).reshape(size, size))


# --------------------------------------------------------------------------------------------------
# Shipped files


def shipped_fast_masks() -> list[int]:
    """Tile sizes T with a shipped ``fast_gauss_<T>.npy``, sorted."""
    stems = (
        n.removeprefix("fast_gauss_").removesuffix(".npy") for n in shipped_files("fast_gauss_")
    )
    return sorted(int(stem) for stem in stems if stem.isdigit())


def _check_shipped(size: object, what: str) -> int:
    size = check_positive_int(size, "size")
    shipped = shipped_fast_masks()
    if size not in shipped:
        raise UnknownNameError(
            f"{what} size {size}: expected one of the shipped sizes {shipped or 'none shipped'}"
        )
    return size


def load_fast_mask(size: int = 64) -> torch.Tensor:
    """The shipped FAST mask ``fast_gauss_<T>.npy`` (for a Gaussian of :data:`SHIPPED_SIGMA`).

    Returns:
        ``[T, T]`` float32 on the CPU, a fresh tensor: a permutation of the shipped scalar mask's
        values ``(rank + 0.5) / T^2``.

    Raises:
        UnknownNameError: no FAST mask of that size is shipped. FileFormatError: the file is
        unreadable or of the wrong shape or dtype.
    """
    size = _check_shipped(size, "FAST mask")
    array = load_array(f"fast_gauss_{size}.npy", np.float32, (size, size))
    return torch.from_numpy(array)


def load_fast_retarget(size: int = 64) -> torch.Tensor:
    """The retargeting field of the shipped FAST mask (``retarget_fast_<T>.npy``): the field of
    :mod:`bnerr.permutation.retarget` optimized for ``load_fast_mask(T)`` and the R2 step of T.

    Returns:
        ``[2, T, T]`` int64 on the CPU, checked (a permutation of the tile, ``|d| <= 6``).

    Raises:
        UnknownNameError: no FAST mask (or field) of that size is shipped. FileFormatError: the
        file is missing, unreadable or not a valid field.
    """
    size = _check_shipped(size, "FAST retargeting field")
    return read_shipped_field(f"retarget_fast_{size}.npy", size)
