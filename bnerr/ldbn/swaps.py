"""The LDBN optimizer's two moves over a toroidal tile: swapping two pixels' keys, and flipping
one pixel's binary choice (a ranking key's bit), both vectorized in torch.

The energy of an arrangement of error vectors ``x_p`` (one per texel p of an ``F x T x T`` tile,
F = 1 for a screen tile) is

    ``E = sum_{p != q} w(p - q) <x_p, x_q>``,

``w`` a toroidal kernel with ``w(0) = 0`` (:func:`energy_kernel`). Heitz et al. maximize
``sum w |x_p - x_q|^2`` over permutations of a fixed set of keys; since ``sum_p |x_p|^2`` does not
change under a permutation, that is the same as minimizing ``E``. With ``w`` the autocorrelation
of a filter ``g`` (``w = g * g~``), ``E`` plus a constant is ``|g * x|^2``: the error the filter
leaves, which is how ``ldbn_fast`` targets the denoiser.

Each iteration computes the field ``phi = w * x`` by FFT (exact, every pixel), proposes a perfect
matching of the texels (swaps) or every texel (flips), and evaluates each move's exact change
alone:

- swap of a and b, ``d = x_b - x_a``: ``dE = 2 <d, phi_a - phi_b> - 2 w(a - b) |d|^2``;
- flip of a from ``x_a`` to ``y_a``: ``dE = 2 <y_a - x_a, phi_a>``;
- swap of a and b when a key's error vector depends on the texel it sits in (the joint
  optimization: the light pair's keys meet each texel's own fixed jitter samples), a from ``x_a``
  to ``y_a`` and b from ``x_b`` to ``y_b`` at once:
  ``dE = 2 <d_a, phi_a> + 2 <d_b, phi_b> + 2 w(a - b) <d_a, d_b>``, ``d = y - x``
  (:func:`joint_swap_descent`; with ``y_a = x_b``, ``y_b = x_a`` it is the plain swap's).

Moves with ``dE < 0`` are kept, each with probability ``q``: moves made at once interact through
their neighbours, and ``q`` (halved whenever an iteration raised the energy, raised slowly
otherwise) keeps the interaction small. Greedy, as in both public implementations: no
temperature. The lowest-energy arrangement met is returned.

Matchings: texel ``i`` is paired with ``i XOR m`` for a random mask ``m`` when every side of the
tile is a power of two (the components of ``m`` have a random number of bits, so partners are
near as often as far), else with its partner in a random perfect matching.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_shape

__all__ = [
    "Evaluate",
    "Progress",
    "energy",
    "energy_kernel",
    "flip_descent",
    "joint_swap_descent",
    "measured_kernel",
    "swap_descent",
]

Progress = Callable[[int], None]
#: ``evaluate(texels [M], rows [M]) -> [M, C]``: the features of key ``rows[i]`` in texel
#: ``texels[i]`` (:func:`joint_swap_descent`).
Evaluate = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]


def energy_kernel(
    size: int,
    frames: int = 1,
    sigma: float = 2.1,
    sigma_t: float = 1.9,
    autocorrelation: bool = False,
) -> torch.Tensor:
    """The toroidal kernel ``w [F, T, T]`` of the energy, ``w(0) = 0``.

    Screen-space part at offset ``r`` (pixels): ``exp(-r^2 / sigma^2)`` (Heitz et al.'s weight,
    sigma 2.1), or with ``autocorrelation`` ``exp(-r^2 / (4 sigma^2))``, the autocorrelation of a
    Gaussian filter of ``sigma`` (FAST's target for that filter). With ``frames`` > 1 the
    separable "2D x 1D" form of spatiotemporal blue noise: the spatial part within a frame plus
    ``exp(-dt^2 / sigma_t^2)`` between frames at one pixel.
    """
    size = check_positive_int(size, "size", minimum=2)
    frames = check_positive_int(frames, "frames")
    scale = 4 * sigma * sigma if autocorrelation else sigma * sigma
    d = torch.arange(size, dtype=torch.float64)
    d = torch.minimum(d, size - d)
    r2 = d[:, None] ** 2 + d[None, :] ** 2
    kernel = torch.zeros(frames, size, size, dtype=torch.float64)
    kernel[0] = torch.exp(-r2 / scale)
    return _finish(kernel, sigma_t)


def _finish(kernel: torch.Tensor, sigma_t: float) -> torch.Tensor:
    """``kernel [F, T, T]`` (float64, its spatial part in slice 0) with the temporal part between
    frames at one pixel and ``w(0) = 0``, as float32."""
    frames = kernel.shape[0]
    if frames > 1:
        t = torch.arange(frames, dtype=torch.float64)
        t = torch.minimum(t, frames - t)
        kernel[:, 0, 0] = torch.exp(-(t**2) / (sigma_t * sigma_t))
    kernel[0, 0, 0] = 0.0
    return kernel.float()


def measured_kernel(
    autocorrelation: torch.Tensor, size: int, frames: int = 1, sigma_t: float = 1.9
) -> torch.Tensor:
    """The toroidal kernel ``w [F, T, T]`` of a measured filter's autocorrelation.

    Args:
        autocorrelation: ``[K, K]``, K odd, centred (entry ``[K // 2 + dy, K // 2 + dx]`` the
            weight at offset ``(dy, dx)``), e.g. ``benchmarks.kernels``' ``*_autocorr.npy``; it
            is symmetrized (``w(d) = w(-d)``, as the energy needs), scaled to 1 at its centre and
            wrapped onto the T x T torus (offsets that meet there add up).
        size, frames, sigma_t: as :func:`energy_kernel` (the temporal part is the same).

    Raises:
        ShapeError: not a square array of odd side. ValueRangeError: not finite, or a centre
        that is not positive.
    """
    size = check_positive_int(size, "size", minimum=2)
    frames = check_positive_int(frames, "frames")
    a = autocorrelation.detach().to("cpu", torch.float64)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] % 2 == 0:
        raise ShapeError(f"autocorrelation: expected [K, K] with K odd, got {list(a.shape)}")
    half = a.shape[0] // 2
    if not bool(torch.isfinite(a).all()) or float(a[half, half]) <= 0:
        raise ValueRangeError("autocorrelation: expected finite values and a positive centre")
    a = (a + a.flip(0, 1)) / (2 * a[half, half])
    d = torch.arange(-half, half + 1) % size
    spatial = torch.zeros(size * size, dtype=torch.float64)
    spatial.index_add_(0, (d[:, None] * size + d[None, :]).reshape(-1), a.reshape(-1))
    kernel = torch.zeros(frames, size, size, dtype=torch.float64)
    kernel[0] = spatial.reshape(size, size)
    return _finish(kernel, sigma_t)


def _field(x: torch.Tensor, kernel_fft: torch.Tensor, shape: tuple[int, ...]) -> torch.Tensor:
    """``w * x`` for ``x [C, P]`` on the torus of ``shape`` (F, T, T): ``[C, P]``."""
    grid = x.reshape(x.shape[0], *shape)
    out = torch.fft.irfftn(
        torch.fft.rfftn(grid, dim=(1, 2, 3)) * kernel_fft, s=shape, dim=(1, 2, 3)
    )
    return out.reshape(x.shape[0], -1)


def energy(x: torch.Tensor, kernel: torch.Tensor) -> float:
    """``E = sum_{p != q} w(p - q) <x_p, x_q>`` of features ``x [P, C]`` on ``kernel``'s torus."""
    shape = tuple(kernel.shape)
    check_shape(x, "P C", "x")
    if x.shape[0] != math.prod(shape):
        raise ShapeError(f"x: expected {math.prod(shape)} rows for a {list(shape)} tile")
    kfft = torch.fft.rfftn(kernel.double(), dim=(0, 1, 2))
    xt = x.double().T.contiguous()
    return float((xt * _field(xt, kfft, shape)).sum())


class _Acceptance:
    """The probability ``q`` of keeping a move, adapted to the energy's course."""

    def __init__(self) -> None:
        self.q, self.last = 0.5, math.inf

    def update(self, e: float) -> None:
        self.q = max(0.02, self.q * 0.5) if e > self.last else min(1.0, self.q * 1.05)
        self.last = e


def _matching(shape: tuple[int, ...], gen: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """A random perfect matching of the texels (module docstring): ``(a, b)`` each ``[P / 2]``."""
    n = math.prod(shape)
    if all(s & (s - 1) == 0 for s in shape) and n > 1:
        mask = 0
        for side in shape:
            bits = int(torch.randint(0, side.bit_length(), (1,), generator=gen))
            mask = mask * side + int(torch.randint(0, 1 << bits, (1,), generator=gen)) % side
        if mask == 0:
            mask = 1
        i = torch.arange(n)
        j = i ^ mask
        keep = i < j
        return i[keep], j[keep]
    order = torch.randperm(n - n % 2, generator=gen)
    return order[: n // 2], order[n // 2 :]


def _uniform(n: int, gen: torch.Generator, device: torch.device) -> torch.Tensor:
    """``n`` uniform float64 draws from the CPU generator ``gen``, on ``device`` (the same draws
    on every device)."""
    return torch.rand(n, generator=gen, dtype=torch.float64).to(device)


def _offsets_weight(
    a: torch.Tensor, b: torch.Tensor, kernel: torch.Tensor, shape: tuple[int, ...]
) -> torch.Tensor:
    """``w(a - b)`` for texel pairs, toroidal in every axis."""
    out = torch.zeros_like(a)
    stride = 1
    for side in reversed(shape):
        ca, cb = (a // stride) % side, (b // stride) % side
        out = out + ((ca - cb) % side) * stride
        stride *= side
    return kernel.reshape(-1)[out]


def swap_descent(
    x: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
) -> torch.Tensor:
    """Permute the rows of ``x [P, C]`` over the tile to lower :func:`energy`.

    Returns:
        ``perm [P]`` int64: texel p takes row ``perm[p]`` of ``x``.
    """
    shape, dev = tuple(kernel.shape), x.device
    feats = x.double().T.contiguous()
    kfft = torch.fft.rfftn(kernel.to(dev, torch.float64), dim=(0, 1, 2))
    perm = torch.arange(feats.shape[1], device=dev)
    best, best_e, acc = perm.clone(), math.inf, _Acceptance()
    for _ in range(check_positive_int(iterations, "iterations")):
        cur = feats[:, perm]
        field = _field(cur, kfft, shape)
        e = float((cur * field).sum())
        if e < best_e:
            best, best_e = perm.clone(), e
        acc.update(e)
        a, b = (i.to(dev) for i in _matching(shape, gen))
        d = cur[:, b] - cur[:, a]
        w = _offsets_weight(a, b, kernel.to(dev, torch.float64), shape)
        change = 2 * (d * (field[:, a] - field[:, b])).sum(0) - 2 * w * (d * d).sum(0)
        keep = (change < 0) & (_uniform(a.shape[0], gen, dev) < acc.q)
        a, b = a[keep], b[keep]
        perm[a], perm[b] = perm[b].clone(), perm[a].clone()
        if progress is not None:
            progress(1)
    cur = feats[:, perm]
    if float((cur * _field(cur, kfft, shape)).sum()) < best_e:
        best = perm
    return best


def flip_descent(
    options: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
) -> torch.Tensor:
    """Choose one of two feature rows per texel, ``options [2, P, C]``, to lower :func:`energy`.

    Returns:
        ``choice [P]`` int64 in {0, 1}, starting from a random choice.
    """
    shape, dev = tuple(kernel.shape), options.device
    check_shape(options, "2 P C", "options")
    opts = options.double().transpose(1, 2).contiguous()  # [2, C, P]
    kfft = torch.fft.rfftn(kernel.to(dev, torch.float64), dim=(0, 1, 2))
    n = opts.shape[2]
    choice = torch.randint(0, 2, (n,), generator=gen).to(dev)
    best, best_e, acc = choice.clone(), math.inf, _Acceptance()
    cols = torch.arange(n, device=dev)
    for _ in range(check_positive_int(iterations, "iterations")):
        cur = opts[choice, :, cols].T
        field = _field(cur, kfft, shape)
        e = float((cur * field).sum())
        if e < best_e:
            best, best_e = choice.clone(), e
        acc.update(e)
        alt = opts[1 - choice, :, cols].T
        change = 2 * ((alt - cur) * field).sum(0)
        keep = (change < 0) & (_uniform(n, gen, dev) < acc.q)
        choice = torch.where(keep, 1 - choice, choice)
        if progress is not None:
            progress(1)
    cur = opts[choice, :, cols].T
    if float((cur * _field(cur, kfft, shape)).sum()) < best_e:
        best = choice
    return best


def joint_swap_descent(
    evaluate: Evaluate,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
) -> torch.Tensor:
    """Permute P keys over the tile to lower :func:`energy` when a key's features depend on the
    texel that holds it (module docstring): ``evaluate`` gives them.

    Returns:
        ``perm [P]`` int64: texel p takes key ``perm[p]``, starting from the identity.
    """
    shape = tuple(kernel.shape)
    n = math.prod(shape)
    kfft = torch.fft.rfftn(kernel.double(), dim=(0, 1, 2))
    perm = torch.arange(n)
    cur = evaluate(perm, perm).double().T.contiguous()  # [C, P]
    best, best_e, acc = perm.clone(), math.inf, _Acceptance()
    for _ in range(check_positive_int(iterations, "iterations")):
        field = _field(cur, kfft, shape)
        e = float((cur * field).sum())
        if e < best_e:
            best, best_e = perm.clone(), e
        acc.update(e)
        a, b = _matching(shape, gen)
        da = evaluate(a, perm[b]).double().T - cur[:, a]
        db = evaluate(b, perm[a]).double().T - cur[:, b]
        w = _offsets_weight(a, b, kernel.double(), shape)
        change = 2 * ((da * field[:, a]).sum(0) + (db * field[:, b]).sum(0))
        change = change + 2 * w * (da * db).sum(0)
        keep = (change < 0) & (torch.rand(a.shape, generator=gen, dtype=torch.float64) < acc.q)
        a, b, da, db = a[keep], b[keep], da[:, keep], db[:, keep]
        cur[:, a] += da
        cur[:, b] += db
        perm[a], perm[b] = perm[b].clone(), perm[a].clone()
        if progress is not None:
            progress(1)
    if float((cur * _field(cur, kfft, shape)).sum()) < best_e:
        best = perm
    return best
