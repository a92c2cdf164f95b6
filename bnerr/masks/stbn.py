"""Spatiotemporal blue-noise masks (STBN; Wolfe, Morrical, Akenine-Moeller, Ramamoorthi 2022).

A spatiotemporal mask is a stack of ``F`` tiles of ``T x T`` pixels, toroidal in x, y and t. Each
slice is a blue-noise mask in space and each pixel's series over the slices is blue in time, so
frame ``t`` uses slice ``t mod F`` (:func:`stbn_frame`) instead of one 2D mask shifted by the R2
step (docs/METHODS.md, sections 2, 5 and 7).

Layouts (slice first, so that ``mask[t]`` has the layout of a 2D mask of bnerr.masks):

- scalar: ``[F, T, T]`` float32, made by :func:`stbn_scalar`. Every slice holds each value
  ``(rank + 0.5) / T^2``, rank = 0 .. T^2 - 1, exactly once.
- vector: ``[F, D, T, T]`` float32, made by :func:`stbn_vector` (D = 2 for a 2D sample). In every
  slice, every channel holds each value ``(k + 0.5) / T^2`` exactly once.

The energy is the separable "2D x 1D" one of the paper: two samples interact when they lie in the
same slice (a 2D Gaussian of their toroidal pixel distance, sigma 1.9) or at the same pixel (a 1D
Gaussian of their toroidal distance in t, sigma_t 1.9); samples at another pixel *and* another
slice do not interact. The kernel is::

    K(dt, dy, dx) = exp(-(dy^2 + dx^2) / (2 sigma^2))  if dt = 0
                  + exp(-dt^2 / (2 sigma_t^2))          if (dy, dx) = (0, 0) and dt != 0

(K(0, 0, 0) = 1, each distance the shorter way round the torus). It is *not* the product
``exp(-|dxy|^2 / (2 s^2)) exp(-dt^2 / (2 s_t^2))`` over all pairs: that 3D kernel would make the
volume blue in 3D, which keeps neither each slice nor each pixel's series as blue as this one.

Scalar masks are void and cluster (Ulichney 1993) over the volume with this energy, with ranks
given per slice in lockstep: each rank is given once in every slice (the slices take their turn in
a seeded random order that changes every rank), so every slice is a permutation of the ranks.
Vector masks are Georgiev-Fajardo masks (greedy swaps of whole vectors within a slice) whose pixel
weight is this kernel. All random choices come from a counter-based hash of the seed
(bnerr.hashing.lowbias32), drawn on the CPU; the work runs on ``device``. The scalar generator is a
sequence of float64 additions, argmax and argmin (ties to the lowest index), so it gives the same
mask on every device; the vector generator is deterministic per device.

Not for: building masks per frame at run time (64 x 64 x 32 takes about 20 s (scalar) and a
minute (vector) on one core): ship them (:func:`load_stbn`; the commands are in
``bnerr/data/README.md``).
"""

from __future__ import annotations

import functools
import math
import operator

import numpy as np
import torch

from bnerr.errors import (
    FLOAT_DTYPES,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
    check_device,
    check_dtype,
    check_finite,
    check_name,
    check_positive_int,
    check_range,
    check_shape,
    check_tensor,
)
from bnerr.hashing import MASK32, lowbias32, lowbias32_host, signed32
from bnerr.resources import load_array, shipped_files

__all__ = [
    "DEFAULT_SIGMA",
    "load_stbn",
    "shipped_stbn",
    "stbn_energy_field",
    "stbn_energy_field_reference",
    "stbn_frame",
    "stbn_scalar",
    "stbn_vector",
    "stbn_vector_energy",
    "stbn_vector_energy_reference",
    "temporal_low_frequency_fraction",
]

#: The paper's Gaussian width, in pixels and in frames.
DEFAULT_SIGMA = 1.9

_MAX_SIZE = 256
_MAX_FRAMES = 256
_MAX_DIMS = 8


# ------------------------------------------------------------------------------------------------
# Checks and deterministic random numbers
# ------------------------------------------------------------------------------------------------


def _check_common(size: object, frames: object, seed: object, minimum: int = 2) -> None:
    size = check_positive_int(size, "size", minimum=minimum)
    if size > _MAX_SIZE:
        raise ValueRangeError(f"size: expected an integer <= {_MAX_SIZE}, got {size}")
    frames = check_positive_int(frames, "frames")
    if frames > _MAX_FRAMES:
        raise ValueRangeError(f"frames: expected an integer <= {_MAX_FRAMES}, got {frames}")
    seed = check_positive_int(seed, "seed", minimum=0)
    if seed > MASK32:
        raise ValueRangeError(f"seed: expected an integer < 2**32, got {seed}")


def _check_device(device: object) -> torch.device:
    return torch.device("cpu") if device is None else check_device(device)


def _words(seed: int, stream: int, count: int) -> torch.Tensor:
    """``count`` random 32-bit words ``[count]`` int64 in [0, 2^32), keyed by (seed, stream).

    Counter-based (two rounds of lowbias32 of the counter under two keys), on the CPU.
    """
    key1 = lowbias32_host(seed ^ lowbias32_host(stream + 0x9E3779B9))
    key2 = lowbias32_host(key1 + 0x632BE5AB)
    counter = (torch.arange(count, dtype=torch.int64) ^ key1) & MASK32
    x = torch.where(counter >= 1 << 31, counter - (1 << 32), counter).to(torch.int32)
    x = lowbias32(lowbias32(x) ^ signed32(key2))
    return x.to(torch.int64) & MASK32


def _permutations(seed: int, stream: int, rows: int, n: int) -> torch.Tensor:
    """``rows`` independent random permutations of range(n): ``[rows, n]`` int64 on the CPU."""
    keys = _words(seed, stream, rows * n).view(rows, n) * n + torch.arange(n)
    return keys.argsort(dim=1)


def _check_sigmas(sigma: object, sigma_t: object) -> tuple[float, float]:
    sigma = float(check_range(sigma, "sigma", 0.1, 100.0))
    sigma_t = float(check_range(sigma_t, "sigma_t", 0.1, 100.0))
    return sigma, sigma_t


# ------------------------------------------------------------------------------------------------
# The energy: kernels, the FFT energy field and its slow twin
# ------------------------------------------------------------------------------------------------


def _toroidal_gauss(n: int, sigma: float) -> torch.Tensor:
    """``exp(-d^2 / (2 sigma^2))`` of the toroidal distance ``d = min(i, n - i)``: ``[n]`` f64."""
    d = torch.arange(n, dtype=torch.float64)
    d = torch.minimum(d, n - d)
    return torch.exp(-d.square() / (2.0 * sigma * sigma))


def _kernels(size: int, frames: int, sigma: float, sigma_t: float) -> tuple[torch.Tensor, ...]:
    """The STBN kernel's two parts on the CPU, float64: ``(kxy [T, T], kt [F])``.

    ``kxy[dy, dx]`` is the in-slice weight of offset (dy, dx) mod T (1 at the origin), ``kt[dt]``
    the same-pixel weight of offset dt mod F (0 at dt = 0, so the origin counts once).
    """
    g = _toroidal_gauss(size, sigma)
    kt = _toroidal_gauss(frames, sigma_t)
    kt[0] = 0.0
    return torch.outer(g, g), kt


def _check_pattern(pattern: object) -> torch.Tensor:
    pattern = check_tensor(pattern, "pattern")
    size = check_shape(pattern, "F T T", "pattern")["T"]
    if size < 1 or pattern.shape[0] < 1:
        raise ShapeError(f"pattern: expected a non-empty [F, T, T], got {list(pattern.shape)}")
    check_dtype(pattern, (torch.bool, *FLOAT_DTYPES), "pattern")
    if pattern.dtype != torch.bool:
        check_finite(pattern, "pattern")
    return pattern


def stbn_energy_field(
    pattern: torch.Tensor, sigma: float = DEFAULT_SIGMA, sigma_t: float = DEFAULT_SIGMA
) -> torch.Tensor:
    """The STBN energy at every sample of ``pattern``: ``E[p] = sum_q pattern[q] K(p - q)``.

    Circular convolution with the module's kernel K by FFT: a 2D convolution within each slice plus
    a 1D one along t at each pixel. This is the energy void and cluster keeps incrementally.

    Args:
        pattern: ``[F, T, T]`` bool (a binary pattern) or floating point (weights), finite.
        sigma, sigma_t: Gaussian widths in pixels and in frames, in [0.1, 100].

    Returns:
        ``[F, T, T]`` float64 on the pattern's device.
    """
    pattern = _check_pattern(pattern)
    sigma, sigma_t = _check_sigmas(sigma, sigma_t)
    frames, size = pattern.shape[0], pattern.shape[-1]
    kxy, kt = (k.to(pattern.device) for k in _kernels(size, frames, sigma, sigma_t))
    x = pattern.to(torch.float64)
    spatial = torch.fft.ifft2(torch.fft.fft2(x) * torch.fft.fft2(kxy)).real
    temporal = torch.fft.ifft(torch.fft.fft(x, dim=0) * torch.fft.fft(kt)[:, None, None], dim=0)
    return spatial + temporal.real


def stbn_energy_field_reference(
    pattern: torch.Tensor, sigma: float = 1.9, sigma_t: float = 1.9
) -> torch.Tensor:
    """Slow twin of :func:`stbn_energy_field`: the double sum over samples in plain Python.

    Every pair (p, q) with ``K(p - q) != 0`` is visited with the kernel written out from its
    definition (``math.exp`` of the shorter toroidal distances). For tiny patterns only (F T^2 up
    to a few hundred). Returns ``[F, T, T]`` float64 on the CPU.

    The default widths are the literal 1.9 of Wolfe et al. 2022 (the module docstring), not
    :data:`DEFAULT_SIGMA`, so that a wrong default there makes the twins disagree.
    """
    pattern = _check_pattern(pattern)
    sigma, sigma_t = _check_sigmas(sigma, sigma_t)
    frames, size = pattern.shape[0], pattern.shape[-1]
    w = pattern.to(torch.float64).cpu().tolist()

    def wrap(d: int, n: int) -> int:
        return min(d % n, n - d % n)

    out = [[[0.0] * size for _ in range(size)] for _ in range(frames)]
    for t in range(frames):
        for y in range(size):
            for x in range(size):
                e = 0.0
                for qy in range(size):  # same slice
                    for qx in range(size):
                        r2 = wrap(y - qy, size) ** 2 + wrap(x - qx, size) ** 2
                        e += w[t][qy][qx] * math.exp(-r2 / (2.0 * sigma**2))
                for qt in range(frames):  # same pixel, other slices
                    if qt != t:
                        dt = wrap(t - qt, frames)
                        e += w[qt][y][x] * math.exp(-(dt**2) / (2.0 * sigma_t**2))
                out[t][y][x] = e
    return torch.tensor(out, dtype=torch.float64)


# ------------------------------------------------------------------------------------------------
# Scalar masks: void and cluster over the volume, ranks given per slice in lockstep
# ------------------------------------------------------------------------------------------------


class _Splatter:
    """Adds or subtracts the STBN kernel centred at one sample, in place (``[F, T, T]`` float64).

    The kernels are tiled twice (``[2T, 2T]`` and ``[2F]``) so that the kernel centred at (t, y, x)
    is a view (``kxy2[T - y : 2T - y, T - x : 2T - x]`` within slice t, ``kt2[F - t : 2F - t]``
    along the pixel's series): no roll, no copy, no truncation.
    """

    def __init__(
        self, size: int, frames: int, sigma: float, sigma_t: float, device: torch.device
    ) -> None:
        kxy, kt = _kernels(size, frames, sigma, sigma_t)
        self.size, self.frames = size, frames
        self.kxy2 = kxy.repeat(2, 2).to(device)
        self.kt2 = kt.repeat(2).to(device)

    def __call__(self, field: torch.Tensor, t: int, flat: int, sign: float) -> None:
        size, frames = self.size, self.frames
        y, x = divmod(flat, size)
        field[t].add_(self.kxy2[size - y : 2 * size - y, size - x : 2 * size - x], alpha=sign)
        field[:, y, x].add_(self.kt2[frames - t : 2 * frames - t], alpha=sign)


def _initial_pattern(
    size: int, frames: int, seed: int, splat: _Splatter, device: torch.device
) -> tuple[torch.Tensor, torch.Tensor]:
    """Ulichney's initial pattern, per slice: ``(ones [F, T, T] bool, energy [F, T, T] float64)``.

    ``max(1, round(0.1 T^2))`` ones at random pixels of every slice; then, slice after slice, the
    tightest cluster (highest energy among ones) moves to the largest void (lowest energy among
    zeros), in rounds over all slices until a whole round moves nothing (capped at T^2 rounds).
    """
    n = size * size
    count = max(1, round(0.1 * n))
    start = _permutations(seed, 0, frames, n)[:, :count]
    ones = torch.zeros(frames, n, dtype=torch.bool).scatter_(1, start, True)
    ones = ones.view(frames, size, size).to(device)
    energy = torch.zeros(frames, size, size, dtype=torch.float64, device=device)
    for t, row in enumerate(start.tolist()):
        for flat in row:
            splat(energy, t, flat, 1.0)
    for _ in range(n):
        moved = False
        for t in range(frames):
            cluster = int(torch.where(ones[t], energy[t], -math.inf).argmax())
            ones[t].view(-1)[cluster] = False
            splat(energy, t, cluster, -1.0)
            void = int(torch.where(ones[t], math.inf, energy[t]).argmin())
            ones[t].view(-1)[void] = True
            splat(energy, t, void, 1.0)
            moved = moved or void != cluster
        if not moved:
            break
    return ones, energy


def _rank_slices(
    ones: torch.Tensor, energy: torch.Tensor, splat: _Splatter, order: list[list[int]]
) -> torch.Tensor:
    """Void and cluster's phases 1-3, each rank given once per slice: ranks ``[F, T^2]`` int64.

    Phase 1 removes the tightest cluster of each slice in turn (ranks count down from the number
    of ones minus 1 to 0); phases 2 and 3 fill the largest void of each slice in turn (ranks count
    up to T^2 - 1). On the torus the kernel sums to the same constant at every sample, so the
    energy of the inverted pattern is that constant minus the energy: Ulichney's phase 3 (tightest
    cluster of the inverted pattern) is the largest void of the original, and phases 2 and 3 are
    one loop. ``order[r]`` is the order in which the slices take rank r.
    """
    frames, size = ones.shape[0], ones.shape[-1]
    count = int(ones[0].sum())
    picks = [[0] * (size * size) for _ in range(frames)]
    # Score = energy of the candidates, -inf (+inf) elsewhere: the kernel update keeps the taken
    # samples at -inf (+inf), so each step is one argmax (argmin) and one in-place update.
    score = torch.where(ones, energy, -math.inf)
    for r in range(count - 1, -1, -1):
        for t in order[r]:
            flat = int(score[t].view(-1).argmax())
            picks[t][r] = flat
            splat(score, t, flat, -1.0)
            score[t].view(-1)[flat] = -math.inf
    score = torch.where(ones, math.inf, energy)
    for r in range(count, size * size):
        for t in order[r]:
            flat = int(score[t].view(-1).argmin())
            picks[t][r] = flat
            splat(score, t, flat, 1.0)
            score[t].view(-1)[flat] = math.inf
    picked = torch.tensor(picks, dtype=torch.int64, device=ones.device)
    ranks = torch.arange(size * size, device=ones.device).expand(frames, -1)
    return torch.empty_like(picked).scatter_(1, picked, ranks)


def stbn_scalar(
    size: int,
    frames: int,
    seed: int = 0,
    sigma: float = DEFAULT_SIGMA,
    sigma_t: float = DEFAULT_SIGMA,
    *,
    device: torch.device | str | None = None,
) -> torch.Tensor:
    """A scalar spatiotemporal blue-noise mask ``[F, T, T]`` (void and cluster, 2D x 1D energy).

    The energy is the module's kernel (a Gaussian of sigma within each slice plus one of sigma_t
    along each pixel's series, toroidal in x, y and t), kept incrementally in float64 (the whole
    kernel is added or subtracted at each step). Void and cluster as in bnerr.masks, except that
    every phase gives each rank once in every slice: for rank r the slices take their turn in a
    random order drawn from ``seed`` (a new order for every r), each choosing its own tightest
    cluster or largest void under the energy of the whole volume, so each choice sees the slices
    that have already taken rank r. Ties go to the lowest flat index ``y * T + x``.

    Cost: ``F T^2`` steps of O(T^2 + F); 64 x 64 x 32 takes about 20 s on one CPU core.

    Args:
        size: T, 2 to 256.
        frames: F, 1 to 256 (F = 1 gives a 2D void-and-cluster mask of this sigma).
        seed: integer in [0, 2**32): initial patterns and slice orders.
        sigma, sigma_t: Gaussian widths in pixels and frames, in [0.1, 100]; 1.9 as in the paper.
        device: where the energy lives (default CPU); the result is the same on every device.

    Returns:
        ``[F, T, T]`` float32 on ``device``, values ``(rank + 0.5) / T^2``: every slice holds each
        rank 0 .. T^2 - 1 exactly once.
    """
    _check_common(size, frames, seed)
    sigma, sigma_t = _check_sigmas(sigma, sigma_t)
    device = _check_device(device)
    splat = _Splatter(size, frames, sigma, sigma_t, device)
    ones, energy = _initial_pattern(size, frames, seed, splat, device)
    order = _permutations(seed, 1, size * size, frames).tolist()
    ranks = _rank_slices(ones, energy, splat, order)
    values = (ranks.to(torch.float64) + 0.5) / (size * size)
    return values.to(torch.float32).view(frames, size, size)


# ------------------------------------------------------------------------------------------------
# Vector masks: Georgiev-Fajardo swaps within slices, pixel weight = the STBN kernel
# ------------------------------------------------------------------------------------------------


class _Window:
    """The truncated STBN kernel as neighbour offsets, on the CPU.

    ``dt, dy, dx, weight`` (``[W]`` each): the in-slice offsets ``0 < |(dy, dx)| <= radius sigma``
    (dt = 0) with weight ``exp(-|d|^2 / (2 sigma^2))``, then the same-pixel offsets: each residue
    dt mod F (dt != 0) whose shorter toroidal distance is at most ``radius sigma_t``, with weight
    ``exp(-dt^2 / (2 sigma_t^2))`` (each residue once, so short volumes count no pair twice).
    ``reach`` bounds |dy| and |dx|; ``table [2 reach + 1, 2 reach + 1]`` holds the in-slice
    weights by offset (0 outside the window).
    """

    def __init__(self, frames: int, sigma: float, sigma_t: float, radius: float) -> None:
        cut = radius * sigma
        self.reach = reach = int(math.floor(cut))
        d = torch.arange(-reach, reach + 1)
        dy, dx = (a.flatten() for a in torch.meshgrid(d, d, indexing="ij"))
        r2 = dy.square() + dx.square()
        keep = (r2 > 0) & (r2 <= cut * cut)
        self.table = torch.zeros(2 * reach + 1, 2 * reach + 1, dtype=torch.float64)
        ws = torch.exp(-r2[keep].to(torch.float64) / (2.0 * sigma * sigma))
        self.table[dy[keep] + reach, dx[keep] + reach] = ws
        residue = torch.arange(1, frames)
        dist = torch.minimum(residue, frames - residue)
        near = dist <= radius * sigma_t
        wt = torch.exp(-dist[near].to(torch.float64).square() / (2.0 * sigma_t * sigma_t))
        zeros_s = torch.zeros(int(keep.sum()), dtype=torch.int64)
        zeros_t = torch.zeros(int(near.sum()), dtype=torch.int64)
        self.dt = torch.cat([zeros_s, residue[near]])
        self.dy = torch.cat([dy[keep], zeros_t])
        self.dx = torch.cat([dx[keep], zeros_t])
        self.weight = torch.cat([ws, wt])
        self.temporal = residue[near]

    def bind(self, size: int, frames: int, device: torch.device) -> _Window:
        """Precompute the in-slice neighbours of every pixel for ``T = size`` on ``device``."""
        self.size, self.frames = size, frames
        y, x = torch.arange(size)[:, None], torch.arange(size)[None, :]
        dy, dx = self.dy[self.dt == 0], self.dx[self.dt == 0]
        ny = (y.reshape(-1, 1, 1) + dy) % size  # [T, 1, Ws]
        nx = (x.reshape(1, -1, 1) + dx) % size  # [1, T, Ws]
        self.table = self.table.to(device)
        self.spatial = (ny * size + nx).reshape(size * size, -1).to(device)  # [T^2, Ws]
        self.dts = self.temporal.to(device)
        self.weights = self.weight.to(device)
        return self

    def neighbours(self, flat: torch.Tensor) -> torch.Tensor:
        """Flat indices ``[K, W]`` of the window's neighbours of samples ``flat [K]`` (bound)."""
        n = self.size * self.size
        t, pix = flat // n, flat % n
        spatial = (t * n)[:, None] + self.spatial[pix]
        temporal = ((t[:, None] + self.dts) % self.frames) * n + pix[:, None]
        return torch.cat([spatial, temporal], dim=1)


def _similarity(a: torch.Tensor, b: torch.Tensor, sigma_s: float) -> torch.Tensor:
    """``exp(-|a - b|^(D/2) / sigma_s^2)`` over the first axis (D = its size), broadcasting."""
    dims = a.shape[0]
    dist2 = (a[0] - b[0]).square()
    for c in range(1, dims):
        dist2 += (a[c] - b[c]).square()
    if dims == 2:
        dist2 = dist2.sqrt_()
    elif dims != 4:
        dist2 = dist2.pow_(dims / 4.0)
    return dist2.mul_(-1.0 / (sigma_s * sigma_s)).exp_()


def _swap_gain(
    values: torch.Tensor, p: torch.Tensor, q: torch.Tensor, window: _Window, sigma_s: float
) -> torch.Tensor:
    """Change ``[K]`` of the vector energy if the vectors at ``p [K]`` and ``q [K]`` were swapped.

    ``values [D, F T T]`` float64, p and q flat indices of samples of the same slice, ``window``
    bound to the mask's size. Only the pairs that contain p or q change; the p-q pair keeps its
    distance and its two vectors, so its terms are taken out of both sides (as in bnerr.masks'
    Georgiev-Fajardo swaps).
    """
    size = window.size
    pix, partner = torch.cat([p, q]), torch.cat([q, p])
    near = values[:, window.neighbours(pix)]  # [D, 2K, W]
    # Row sums rather than a matrix-vector product: each row is summed by one thread in a fixed
    # order, so the gains (and the accepted swaps) do not depend on the thread count.
    own = (_similarity(values[:, pix, None], near, sigma_s) * window.weights).sum(dim=1)
    moved = (_similarity(values[:, partner, None], near, sigma_s) * window.weights).sum(dim=1)
    reach = window.reach
    off_y = ((q // size - p // size) % size + size // 2) % size - size // 2
    off_x = ((q % size - p % size) + size // 2) % size - size // 2
    inside = (off_y.abs() <= reach) & (off_x.abs() <= reach)
    at = window.table[(off_y + reach).clamp(0, 2 * reach), (off_x + reach).clamp(0, 2 * reach)]
    w_pq = torch.where(inside, at, 0.0)
    f_pq = _similarity(values[:, p], values[:, q], sigma_s)
    k = p.shape[0]
    change = moved[:k] + moved[k:] - own[:k] - own[k:] - 2.0 * w_pq * (1.0 - f_pq)
    return 2.0 * change  # each unordered pair appears twice in E


def _candidates(
    seed: int, batch: int, size: int, frames: int, window: _Window
) -> tuple[torch.Tensor, torch.Tensor]:
    """Candidate swaps of one batch, before the conflict check: ``(p [K], q [K])`` flat indices.

    Every slice gets a lattice of first pixels (spacing >= 2 (reach + 1), a random offset per
    slice) and one random displacement to the second pixels: local (within reach + 1 pixels, which
    keeps the swaps of a slice clear of one another) or far (a random pixel half a lattice spacing
    off a lattice multiple), half and half. Swaps of displacement 0 are dropped.
    """
    reach = window.reach
    spacing = 2 * (reach + 1)
    m = max(1, size // spacing)
    lattice = (torch.arange(m) * size) // m
    w = _words(seed, 2 + batch, 6 * frames).view(6, frames, 1, 1)
    oy, ox, kind, axis, a, b = w
    span = 2 * (reach + 1) + 1
    far = spacing // 2 + spacing * (a % m)
    local = kind % 2 == 0
    dy = torch.where(local, a % span - (reach + 1), torch.where(axis % 2 == 0, far, b % size))
    dx = torch.where(local, b % span - (reach + 1), torch.where(axis % 2 == 0, b % size, far))
    py = ((lattice[None, :, None] + oy) % size).expand(frames, m, m)
    px = ((lattice[None, None, :] + ox) % size).expand(frames, m, m)
    t = torch.arange(frames)[:, None, None].expand(frames, m, m)
    qy, qx = (py + dy) % size, (px + dx) % size
    p = ((t * size + py) * size + px).flatten()
    q = ((t * size + qy) * size + qx).flatten()
    moving = ((dy % size != 0) | (dx % size != 0)).expand(frames, m, m).flatten()
    return p[moving], q[moving]


def _independent(
    p: torch.Tensor, q: torch.Tensor, window: _Window, size: int, frames: int
) -> torch.Tensor:
    """Which swaps ``(p [K], q [K])`` share no interacting pair with another swap: ``[K]`` bool.

    Two swaps interact when a sample of one lies in the window of a sample of the other (same
    slice within ``reach`` pixels per axis, or same pixel at a windowed dt); then the energy
    changes computed one by one would not add up. Counted on a ``[F, T, T]`` occupancy map: the
    window sum at each sample, less the sample itself and its own partner, must be 0.
    """
    pix = torch.cat([p, q])
    count = torch.zeros(frames * size * size, dtype=torch.int32, device=p.device)
    count.index_put_((pix,), torch.ones_like(pix, dtype=torch.int32), accumulate=True)
    count = count.view(frames, size, size)
    reach = window.reach
    # Integer sums, so the order of the additions does not matter (reduce, not sum: sum's start 0
    # would type the result as int | Tensor).
    rows: torch.Tensor = functools.reduce(
        operator.add, (torch.roll(count, d, dims=1) for d in range(-reach, reach + 1))
    )
    near: torch.Tensor = functools.reduce(
        operator.add, (torch.roll(rows, d, dims=2) for d in range(-reach, reach + 1))
    )
    for r in window.temporal.tolist():
        near = near + torch.roll(count, r, dims=0)
    k = p.shape[0]
    dy = ((q // size - p // size) % size + size // 2) % size - size // 2  # same slice
    dx = ((q % size - p % size) + size // 2) % size - size // 2
    own = 1 + ((dy.abs() <= reach) & (dx.abs() <= reach)).to(torch.int32)
    others = near.view(-1)[pix] - own.repeat(2)
    return (others[:k] == 0) & (others[k:] == 0)


def _check_vector_args(
    dims: object, sigma_s: object, iterations: object, radius: object, size: int, sigma: float
) -> float:
    dims = check_positive_int(dims, "dims", minimum=2)
    if dims > _MAX_DIMS:
        raise ValueRangeError(f"dims: expected an integer in [2, {_MAX_DIMS}], got {dims}")
    iterations = check_positive_int(iterations, "iterations")
    if iterations > 100_000:
        raise ValueRangeError(f"iterations: expected an integer in [1, 100000], got {iterations}")
    check_range(sigma_s, "sigma_s", 0.01, 100.0)
    radius = float(check_range(radius, "radius", 1.0, 5.0))
    spacing = 2 * (int(math.floor(radius * sigma)) + 1)
    if size < spacing:
        raise ValueRangeError(
            f"size: expected an integer >= {spacing} for sigma {sigma} and radius {radius}, "
            f"got {size}"
        )
    return radius


def stbn_vector(
    size: int,
    frames: int,
    dims: int = 2,
    seed: int = 0,
    sigma: float = DEFAULT_SIGMA,
    sigma_t: float = DEFAULT_SIGMA,
    sigma_s: float = 1.0,
    *,
    iterations: int = 64,
    radius: float = 3.0,
    device: torch.device | str | None = None,
) -> torch.Tensor:
    """A vector spatiotemporal blue-noise mask ``[F, D, T, T]`` (Georgiev-Fajardo swaps).

    Minimises ``E = sum_{p != q} K(p - q) exp(-|v_p - v_q|^(D/2) / sigma_s^2)`` with K the module's
    2D x 1D kernel truncated at ``radius sigma`` pixels and ``radius sigma_t`` frames, by greedy
    swaps of whole vectors between two pixels of one slice, accepted when they lower E. Each batch
    proposes a lattice of swaps in every slice (:func:`_candidates`: half local, half far), drops
    the ones that interact with another swap of the batch (:func:`_independent`), so every
    accepted change is exact and the batch's changes add up, then applies those with a negative
    gain. Start: in every slice, every channel holds the values ``(k + 0.5) / T^2`` in an
    independent random order; swaps within a slice keep that (each slice's channels stay
    stratified, and every pixel's series is shaped only through which slice values land there).

    Cost: about ``iterations T^2 / 25`` batches for T = 64 (one minute for 64 x 64 x 32 at the
    default iterations on one CPU core).

    Args:
        size: T, at least ``2 (floor(radius sigma) + 1)`` (12 at the defaults), at most 256.
        frames: F, 1 to 256.
        dims: D, 2 to 8.
        seed: integer in [0, 2**32): initial orders and candidate swaps.
        sigma, sigma_t: Gaussian widths in pixels and frames, in [0.1, 100].
        sigma_s: value-distance scale, in [0.01, 100].
        iterations: candidate swaps per sample, 1 to 100000.
        radius: kernel truncation in units of sigma (and sigma_t), in [1, 5].
        device: where the work runs (default CPU).

    Returns:
        ``[F, D, T, T]`` float32 on ``device``, a deterministic function of the arguments and the
        device type.
    """
    _check_common(size, frames, seed)
    sigma, sigma_t = _check_sigmas(sigma, sigma_t)
    radius = _check_vector_args(dims, sigma_s, iterations, radius, size, sigma)
    sigma_s = float(sigma_s)
    device = _check_device(device)
    window = _Window(frames, sigma, sigma_t, radius).bind(size, frames, device)
    n = size * size
    base = ((torch.arange(n, dtype=torch.float64) + 0.5) / n).to(torch.float32).double()
    order = _permutations(seed, 1, frames * dims, n).view(frames, dims, n)
    values = base[order].permute(1, 0, 2).reshape(dims, frames * n).to(device)
    _greedy_swaps(values, window, seed, iterations, sigma_s)
    return values.view(dims, frames, size, size).transpose(0, 1).float()


def _greedy_swaps(
    values: torch.Tensor, window: _Window, seed: int, iterations: int, sigma_s: float
) -> None:
    """Batches of independent candidate swaps on ``values [D, F T T]``, in place (see above)."""
    size, frames = window.size, window.frames
    m = max(1, size // (2 * (window.reach + 1)))
    for batch in range(math.ceil(iterations * size * size / (m * m))):
        p, q = _candidates(seed, batch, size, frames, window)
        p, q = p.to(values.device), q.to(values.device)
        keep = _independent(p, q, window, size, frames)
        p, q = p[keep], q[keep]
        accept = _swap_gain(values, p, q, window, sigma_s) < 0.0
        p, q = p[accept], q[accept]
        values[:, p], values[:, q] = values[:, q], values[:, p].clone()


def _check_vector_mask(mask: object) -> dict[str, int]:
    mask = check_tensor(mask, "mask")
    shape = check_shape(mask, "F D T T", "mask")
    if min(mask.shape) < 1:
        raise ShapeError(f"mask: expected a non-empty [F, D, T, T], got {list(mask.shape)}")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    check_finite(mask, "mask")
    return shape


def stbn_vector_energy(
    mask: torch.Tensor,
    sigma: float = DEFAULT_SIGMA,
    sigma_t: float = DEFAULT_SIGMA,
    sigma_s: float = 1.0,
    *,
    radius: float = 3.0,
) -> float:
    """The energy :func:`stbn_vector` minimises, of a vector mask ``[F, D, T, T]``.

    ``E = sum_p sum_{o in window} w(o) exp(-|v_p - v_{p+o}|^(D/2) / sigma_s^2)`` over the
    truncated 2D x 1D window (each unordered pair counted twice), in float64 on the mask's device.
    Lower is bluer; the same values shuffled within each slice are the white-noise control.
    """
    shape = _check_vector_mask(mask)
    sigma, sigma_t = _check_sigmas(sigma, sigma_t)
    _check_vector_args(shape["D"], sigma_s, 1, radius, shape["T"], sigma)
    size, frames, dims = shape["T"], shape["F"], shape["D"]
    window = _Window(frames, sigma, sigma_t, float(radius)).bind(size, frames, mask.device)
    values = mask.to(torch.float64).transpose(0, 1).reshape(dims, -1)
    total = torch.zeros((), dtype=torch.float64, device=mask.device)
    for chunk in torch.arange(values.shape[1], device=mask.device).split(4096):
        near = values[:, window.neighbours(chunk)]  # [D, k, W]
        f = _similarity(values[:, chunk, None], near, float(sigma_s))
        total = total + (f @ window.weights).sum()
    return float(total)


def stbn_vector_energy_reference(
    mask: torch.Tensor,
    sigma: float = 1.9,
    sigma_t: float = 1.9,
    sigma_s: float = 1.0,
    *,
    radius: float = 3.0,
) -> float:
    """Slow twin of :func:`stbn_vector_energy`: every ordered pair in plain Python.

    Pairs in one slice within ``radius sigma`` pixels (shorter toroidal distance) and pairs at one
    pixel within ``radius sigma_t`` frames, weights and similarity written out from their
    definitions. For tiny masks only. The default widths are the paper's literal 1.9, like
    :func:`stbn_energy_field_reference`'s.
    """
    shape = _check_vector_mask(mask)
    size, frames, dims = shape["T"], shape["F"], shape["D"]
    v = mask.to(torch.float64).cpu().permute(0, 2, 3, 1).tolist()  # [F][T][T][D]

    def wrap(d: int, n: int) -> int:
        return min(d % n, n - d % n)

    def sim(a: list[float], b: list[float]) -> float:
        dist = math.sqrt(sum((ai - bi) ** 2 for ai, bi in zip(a, b)))
        return math.exp(-(dist ** (dims / 2.0)) / sigma_s**2)

    total = 0.0
    for t in range(frames):
        for y in range(size):
            for x in range(size):
                for qy in range(size):
                    for qx in range(size):
                        r2 = wrap(y - qy, size) ** 2 + wrap(x - qx, size) ** 2
                        if 0 < r2 <= (radius * sigma) ** 2:
                            w = math.exp(-r2 / (2.0 * sigma**2))
                            total += w * sim(v[t][y][x], v[t][qy][qx])
                for qt in range(frames):
                    dt = wrap(t - qt, frames)
                    if qt != t and dt <= radius * sigma_t:
                        w = math.exp(-(dt**2) / (2.0 * sigma_t**2))
                        total += w * sim(v[t][y][x], v[qt][y][x])
    return total


# ------------------------------------------------------------------------------------------------
# Measuring, frames and the shipped masks
# ------------------------------------------------------------------------------------------------


def temporal_low_frequency_fraction(mask: torch.Tensor, cutoff: float = 0.125) -> float:
    """Fraction of the energy of every sample's series over t below ``cutoff`` cycles per frame.

    The series ``mask[:, ...]`` (one per pixel and channel) have their means removed; their
    periodograms along t are averaged, and the sum over frequencies ``0 < |f| < cutoff`` is divided
    by the sum over all. White noise gives ``count(0 < |k / F| < cutoff) / (F - 1)`` in
    expectation (6 / 31 = 0.194 for F = 32 at 0.125); a temporally blue mask gives near 0.

    Args:
        mask: ``[F, ...]`` floating point, finite, F >= 2 (a scalar or a vector STBN).
        cutoff: in [0, 0.5].

    Returns:
        A float in [0, 1]; 0.0 when every series is constant.
    """
    mask = check_tensor(mask, "mask")
    if mask.ndim < 1 or mask.shape[0] < 2 or mask.numel() == 0:
        raise ShapeError(f"mask: expected [F, ...] with F >= 2, got shape {list(mask.shape)}")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    check_finite(mask, "mask")
    check_range(cutoff, "cutoff", 0.0, 0.5)
    series = mask.to(torch.float64).reshape(mask.shape[0], -1)
    series = series - series.mean(dim=0, keepdim=True)
    spectrum = torch.fft.fft(series, dim=0)
    power = (spectrum.real.square() + spectrum.imag.square()).mean(dim=1)
    total = float(power.sum())
    if total == 0.0:
        return 0.0
    freq = torch.fft.fftfreq(mask.shape[0], dtype=torch.float64, device=mask.device).abs()
    return float(power[(freq > 0) & (freq < cutoff)].sum()) / total


def stbn_frame(mask: torch.Tensor, t: int) -> torch.Tensor:
    """The slice frame ``t >= 0`` uses: ``mask[t mod F]`` (``[T, T]`` or ``[D, T, T]``, a view)."""
    mask = check_tensor(mask, "mask")
    if mask.ndim not in (3, 4) or mask.shape[0] < 1:
        raise ShapeError(
            f"mask: expected [F, T, T] or [F, D, T, T] with F >= 1, got shape {list(mask.shape)}"
        )
    t = check_positive_int(t, "t", minimum=0)
    return mask[t % mask.shape[0]]


def _file_name(kind: str, size: int, frames: int) -> str:
    return f"stbn_{kind}_{size}x{frames}.npy"


def shipped_stbn() -> list[tuple[str, int, int]]:
    """The shipped spatiotemporal masks, sorted: ``(kind, T, F)`` tuples."""
    found = []
    for name in shipped_files("stbn_"):
        kind, _, dims = name.removeprefix("stbn_").removesuffix(".npy").partition("_")
        size, _, frames = dims.partition("x")
        if kind in ("scalar", "vector") and size.isdigit() and frames.isdigit():
            found.append((kind, int(size), int(frames)))
    return sorted(found)


def load_stbn(
    kind: str, size: int = 64, frames: int = 32, *, device: torch.device | str | None = None
) -> torch.Tensor:
    """A shipped spatiotemporal mask: ``load_stbn("scalar", T, F)`` or ``("vector", T, F)``.

    Shipped: 64 x 64 x 32 of each kind (``bnerr/data/stbn_<kind>_64x32.npy``, made by the commands
    in ``bnerr/data/README.md``); the vector mask has D = 2.

    Returns:
        ``[F, T, T]`` (scalar) or ``[F, 2, T, T]`` (vector) float32 on ``device`` (default CPU).

    Raises:
        UnknownNameError: ``kind`` is not "scalar" or "vector", or no such mask is shipped (the
            message lists the shipped ones).
        FileFormatError: the shipped file is unreadable or has the wrong shape or dtype.
    """
    check_name(kind, ("scalar", "vector"), "mask kind")
    check_positive_int(size, "size")
    check_positive_int(frames, "frames")
    device = _check_device(device)
    shipped = shipped_stbn()
    if (kind, size, frames) not in shipped:
        listing = ", ".join(f"load_stbn({k!r}, {s}, {f})" for k, s, f in shipped)
        raise UnknownNameError(
            f"stbn mask ({kind!r}, {size}, {frames}): expected one of the shipped masks: "
            f"{listing or 'none shipped'}"
        )
    shape = (frames, size, size) if kind == "scalar" else (frames, 2, size, size)
    array = load_array(_file_name(kind, size, frames), np.float32, shape)
    return torch.from_numpy(array).to(device)
