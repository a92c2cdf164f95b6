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
  (:func:`joint_swap_descent`; with ``y_a = x_b``, ``y_b = x_a`` it is the plain swap's), plus
  ``w(0) (|y_a|^2 - |x_a|^2 + |y_b|^2 - |x_b|^2)`` when the raw part is weighed too
  (``self_weight``: it changes only when the features depend on the texel).

Moves with ``dE < 0`` are kept, each with probability ``q``: moves made at once interact through
their neighbours, and ``q`` (halved whenever an iteration raised the energy, raised slowly
otherwise) keeps the interaction small. Greedy, as in both public implementations: no
temperature. The lowest-energy arrangement met is returned.

Matchings: texel ``i`` is paired with ``i XOR m`` for a random mask ``m`` when every side of the
tile is a power of two (the components of ``m`` have a random number of bits, so partners are
near as often as far), else with its partner in a random perfect matching.

**Batches and devices.** :func:`swap_descents` and :func:`flip_descents` run B independent
descents of one tile shape at once (the LDBN optimizer batches every (level, pair) job of a round:
one FFT over B x C channels per iteration), on the device of their input, with no host
synchronization inside the loop. Their random numbers (the masks, the acceptance draws, the
starting choices) are counter-based hashes of a per-descent seed (:func:`uniforms`), not a
generator's stream: a descent's draws do not depend on which others share its batch, nor on the
device. The arithmetic does (FFT and reduction orders differ between CPU and CUDA, and a
different rounding can change a kept move), so CPU and CUDA give different keys, each
reproducible on its device. With a ``deadline`` (``time.monotonic()`` seconds) a descent returns
None at the first iteration that starts past it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_shape
from bnerr.hashing import lowbias32, lowbias32_host, signed32, srl32

__all__ = [
    "Evaluate",
    "Progress",
    "energy",
    "energy_kernel",
    "flip_descent",
    "flip_descents",
    "joint_swap_descent",
    "measured_kernel",
    "swap_descent",
    "swap_descents",
    "uniforms",
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
        autocorrelation: ``[K, K]``, K odd, centred (entry ``[K // 2 + dy, K // 2 + dx]`` the weight
            at offset ``(dy, dx)``), e.g. ``benchmarks.studies.denoiser_kernels``'
            ``*_autocorr.npy``; it is symmetrized (``w(d) = w(-d)``, as the energy needs), scaled to
            1 at its centre and wrapped onto the T x T torus (offsets that meet there add up).
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
    """``w * x`` for ``x [..., P]`` on the torus of ``shape`` (F, T, T): ``[..., P]``."""
    grid = x.reshape(*x.shape[:-1], *shape)
    dims = (-3, -2, -1)
    out = torch.fft.irfftn(torch.fft.rfftn(grid, dim=dims) * kernel_fft, s=shape, dim=dims)
    return out.reshape(x.shape)


def energy(x: torch.Tensor, kernel: torch.Tensor) -> float:
    """``E = sum_{p != q} w(p - q) <x_p, x_q>`` of features ``x [P, C]`` on ``kernel``'s torus."""
    shape = tuple(kernel.shape)
    check_shape(x, "P C", "x")
    if x.shape[0] != math.prod(shape):
        raise ShapeError(f"x: expected {math.prod(shape)} rows for a {list(shape)} tile")
    kfft = torch.fft.rfftn(kernel.double(), dim=(0, 1, 2))
    xt = x.double().T.contiguous()
    return float((xt * _field(xt, kfft, shape)).sum())


_TWO_24 = float(1 << 24)


def uniforms(seeds: torch.Tensor, counter: int, count: int) -> torch.Tensor:
    """``[B, count]`` float64 uniforms in [0, 1) (24 bits), a hash of each descent's int32 seed
    ``seeds [B]``, the ``counter`` (the draw) and the lane: the same on every device."""
    key = lowbias32(seeds ^ signed32(lowbias32_host(counter)))
    lanes = torch.arange(count, dtype=torch.int32, device=seeds.device)
    return srl32(lowbias32(key[:, None] ^ lanes), 8).double() / _TWO_24


def _late(deadline: float | None) -> bool:
    return deadline is not None and time.monotonic() > deadline


class _Acceptance:
    """Per descent: the probability ``q`` of keeping a move, adapted to the energy's course, and
    the lowest-energy state met (tensors on the descents' device, never read by the host)."""

    def __init__(self, count: int, device: torch.device) -> None:
        self.q = torch.full((count,), 0.5, dtype=torch.float64, device=device)
        self.last = torch.full((count,), math.inf, dtype=torch.float64, device=device)
        self.best_e = self.last.clone()
        self.best: torch.Tensor | None = None

    def observe(self, e: torch.Tensor, state: torch.Tensor, adapt: bool = True) -> None:
        """The energies ``e [B]`` of ``state [B, P]``: keep the best; adapt ``q``."""
        better = e < self.best_e
        self.best = (
            state.clone() if self.best is None else torch.where(better[:, None], state, self.best)
        )
        self.best_e = torch.where(better, e, self.best_e)
        if adapt:
            up, down = (self.q * 1.05).clamp_max(1.0), (self.q * 0.5).clamp_min(0.02)
            self.q = torch.where(e > self.last, down, up)
            self.last = e

    def accept(self, change: torch.Tensor, seeds: torch.Tensor, counter: int) -> torch.Tensor:
        """``change [B, M]`` -> which moves to make: improving ones, each with probability q."""
        draw = uniforms(seeds, counter, change.shape[1])
        return (change < 0) & (draw < self.q[:, None])


def _pairs(
    shape: tuple[int, ...], seeds: torch.Tensor, counter: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """One random perfect matching of the texels per descent (module docstring): ``(a, b)``
    each ``[B, P / 2]`` on the seeds' device."""
    n, count, device = math.prod(shape), seeds.shape[0], seeds.device
    if not (all(s & (s - 1) == 0 for s in shape) and n > 1):
        order = uniforms(seeds, counter, n - n % 2).argsort(dim=1, stable=True)
        return order[:, : n // 2], order[:, n // 2 :]
    words = (uniforms(seeds, counter, 2 * len(shape)) * _TWO_24).long()
    mask = torch.zeros(count, dtype=torch.int64, device=device)
    for k, side in enumerate(shape):
        bits = words[:, 2 * k] % side.bit_length()
        mask = mask * side + (words[:, 2 * k + 1] & ((1 << bits) - 1)) % side
    mask = torch.where(mask == 0, 1, mask)[:, None]
    high = torch.zeros_like(mask)  # the highest set bit of the mask
    for j in range(1, (n - 1).bit_length()):
        high += ((mask >> j) > 0).long()
    lane = torch.arange(n // 2, device=device)[None, :]
    a = ((lane >> high) << (high + 1)) | (lane & ((1 << high) - 1))  # bit `high` cleared
    return a, a ^ mask


def _matching(shape: tuple[int, ...], gen: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """One matching of :func:`_pairs` from a generator's seed: ``(a, b)`` each ``[P / 2]``."""
    a, b = _pairs(shape, _seed_of(gen), 0)
    return a[0], b[0]


def _seed_of(gen: torch.Generator, device: torch.device | str = "cpu") -> torch.Tensor:
    """A ``[1]`` int32 descent seed drawn from ``gen`` (the single-descent wrappers)."""
    value = int(torch.randint(-(2**31), 2**31, (1,), generator=gen))
    return torch.tensor([value], dtype=torch.int32, device=device)


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


def _take(x: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """``x [B, C, P]`` at the texels ``index [B, M]``: ``[B, C, M]``."""
    return x.gather(2, index[:, None, :].expand(-1, x.shape[1], -1))


def _energies(cur: torch.Tensor, field: torch.Tensor) -> torch.Tensor:
    return (cur * field).sum((1, 2))


def _seeds(seeds: torch.Tensor, count: int, device: torch.device) -> torch.Tensor:
    if seeds.shape != (count,) or seeds.dtype != torch.int32:
        raise ShapeError(
            f"seeds: expected int32 of shape [{count}], got {seeds.dtype} {list(seeds.shape)}"
        )
    return seeds.to(device)


def swap_descents(
    x: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    seeds: torch.Tensor,
    progress: Progress | None = None,
    deadline: float | None = None,
) -> torch.Tensor | None:
    """Permute the rows of each ``x[b] [P, C]`` over the tile to lower :func:`energy`: B
    descents at once on ``x``'s device, descent b drawing from ``seeds[b]`` (module docstring).

    Returns:
        ``perm [B, P]`` int64 (texel p of descent b takes row ``perm[b, p]``), or None when the
        ``deadline`` passed first.
    """
    check_shape(x, "B P C", "x")
    shape, device = tuple(kernel.shape), x.device
    feats = x.double().transpose(1, 2).contiguous()  # [B, C, P]
    count, n = feats.shape[0], feats.shape[2]
    seeds = _seeds(seeds, count, device)
    kern = kernel.double().to(device)
    kfft = torch.fft.rfftn(kern, dim=(0, 1, 2))
    perm = torch.arange(n, device=device).repeat(count, 1)
    acc = _Acceptance(count, device)
    for it in range(check_positive_int(iterations, "iterations")):
        if _late(deadline):
            return None
        cur = _take(feats, perm)
        field = _field(cur, kfft, shape)
        acc.observe(_energies(cur, field), perm)
        a, b = _pairs(shape, seeds, 2 * it)
        d = _take(cur, b) - _take(cur, a)
        w = _offsets_weight(a, b, kern, shape)
        change = 2 * (d * (_take(field, a) - _take(field, b))).sum(1) - 2 * w * (d * d).sum(1)
        keep = acc.accept(change, seeds, 2 * it + 1)
        pa, pb = perm.gather(1, a), perm.gather(1, b)
        perm.scatter_(1, a, torch.where(keep, pb, pa))
        perm.scatter_(1, b, torch.where(keep, pa, pb))
        if progress is not None:
            progress(count)
    cur = _take(feats, perm)
    acc.observe(_energies(cur, _field(cur, kfft, shape)), perm, adapt=False)
    return acc.best


def flip_descents(
    options: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    seeds: torch.Tensor,
    progress: Progress | None = None,
    deadline: float | None = None,
) -> torch.Tensor | None:
    """Choose one of two feature rows per texel, ``options [B, 2, P, C]``, to lower
    :func:`energy`: B descents at once on the options' device (module docstring).

    Returns:
        ``choice [B, P]`` int64 in {0, 1}, starting from a random choice, or None when the
        ``deadline`` passed first.
    """
    check_shape(options, "B 2 P C", "options")
    shape, device = tuple(kernel.shape), options.device
    opts = options.double().transpose(2, 3).contiguous()  # [B, 2, C, P]
    count, n = opts.shape[0], opts.shape[3]
    seeds = _seeds(seeds, count, device)
    kfft = torch.fft.rfftn(kernel.double().to(device), dim=(0, 1, 2))
    choice = (uniforms(seeds, -1, n) < 0.5).long()
    acc = _Acceptance(count, device)
    for it in range(check_positive_int(iterations, "iterations")):
        if _late(deadline):
            return None
        upper = choice[:, None, :].bool()
        cur = torch.where(upper, opts[:, 1], opts[:, 0])
        field = _field(cur, kfft, shape)
        acc.observe(_energies(cur, field), choice)
        change = 2 * ((torch.where(upper, opts[:, 0], opts[:, 1]) - cur) * field).sum(1)
        choice = torch.where(acc.accept(change, seeds, it), 1 - choice, choice)
        if progress is not None:
            progress(count)
    cur = torch.where(choice[:, None, :].bool(), opts[:, 1], opts[:, 0])
    acc.observe(_energies(cur, _field(cur, kfft, shape)), choice, adapt=False)
    return acc.best


def swap_descent(
    x: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
) -> torch.Tensor:
    """Permute the rows of ``x [P, C]`` over the tile to lower :func:`energy` (one descent of
    :func:`swap_descents`, its seed drawn from ``gen``).

    Returns:
        ``perm [P]`` int64: texel p takes row ``perm[p]`` of ``x``.
    """
    check_shape(x, "P C", "x")
    perm = swap_descents(x[None], kernel, iterations, _seed_of(gen, x.device), progress)
    assert perm is not None  # no deadline
    return perm[0]


def flip_descent(
    options: torch.Tensor,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
) -> torch.Tensor:
    """Choose one of two feature rows per texel, ``options [2, P, C]``, to lower :func:`energy`
    (one descent of :func:`flip_descents`, its seed drawn from ``gen``).

    Returns:
        ``choice [P]`` int64 in {0, 1}, starting from a random choice.
    """
    check_shape(options, "2 P C", "options")
    seed = _seed_of(gen, options.device)
    choice = flip_descents(options[None], kernel, iterations, seed, progress)
    assert choice is not None  # no deadline
    return choice[0]


def joint_swap_descent(
    evaluate: Evaluate,
    kernel: torch.Tensor,
    iterations: int,
    gen: torch.Generator,
    progress: Progress | None = None,
    self_weight: float = 0.0,
) -> torch.Tensor:
    """Permute P keys over the tile to lower :func:`energy` when a key's features depend on the
    texel that holds it (module docstring): ``evaluate`` gives them. The moves and draws are
    :func:`swap_descent`'s (one descent, on the CPU).

    ``self_weight`` ``w(0)`` adds ``w(0) sum_p |x_p|^2``, which a move changes too when the
    features depend on the texel: with a filter's autocorrelation as the kernel and 1 here the
    descent lowers the filtered error itself, raw part included; 0 (the ``--joint`` keys'
    rule) lowers only the cross terms.

    Returns:
        ``perm [P]`` int64: texel p takes key ``perm[p]``, starting from the identity.
    """
    shape = tuple(kernel.shape)
    n = math.prod(shape)
    seeds = _seed_of(gen)
    kern = kernel.double()
    kfft = torch.fft.rfftn(kern, dim=(0, 1, 2))
    perm = torch.arange(n)
    cur = evaluate(perm, perm).double().T.contiguous()[None]  # [1, C, P]
    acc = _Acceptance(1, cur.device)
    for it in range(check_positive_int(iterations, "iterations")):
        field = _field(cur, kfft, shape)
        acc.observe(_energies(cur, field) + self_weight * cur.square().sum((1, 2)), perm[None])
        pa, pb = _pairs(shape, seeds, 2 * it)
        a, b = pa[0], pb[0]
        da = evaluate(a, perm[b]).double().T - cur[0][:, a]
        db = evaluate(b, perm[a]).double().T - cur[0][:, b]
        w = _offsets_weight(a, b, kern, shape)
        change = 2 * ((da * field[0][:, a]).sum(0) + (db * field[0][:, b]).sum(0))
        change = change + 2 * w * (da * db).sum(0)
        if self_weight:
            own = (da * (2 * cur[0][:, a] + da)).sum(0) + (db * (2 * cur[0][:, b] + db)).sum(0)
            change = change + self_weight * own
        keep = acc.accept(change[None], seeds, 2 * it + 1)[0]
        a, b, da, db = a[keep], b[keep], da[:, keep], db[:, keep]
        cur[0][:, a] += da
        cur[0][:, b] += db
        perm[a], perm[b] = perm[b].clone(), perm[a].clone()
        if progress is not None:
            progress(1)
    final = _energies(cur, _field(cur, kfft, shape)) + self_weight * cur.square().sum((1, 2))
    acc.observe(final, perm[None], adapt=False)
    assert acc.best is not None
    return acc.best[0]
