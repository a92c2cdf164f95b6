"""The "vertical" bound: each pixel picks one of its K candidate estimates so that the blurred error
of the whole image is as small as possible (after Chizhov, Georgiev, Myszkowski, Singh 2022).

The histogram oracle (:mod:`bnerr.strategies.oracle`) picks, per pixel, the candidate at the rank
the blue-noise mask gives: a choice made pixel by pixel, blind to the reference. Here the choice
knows a target (the reference, or the best estimate a renderer holding the K renders has: their
mean) and is made for the whole image at once, with no permutation constraint: it bounds what any
per-pixel choice of sequence can reach (docs/METHODS.md, section 11).

**Objective.** With ``x`` the chosen image and ``r`` the target,
``J = sum_c sum_q (G * (x - r))_c(q)^2`` where ``G`` is a normalized Gaussian of ``sigma`` with
``2 ceil(3 sigma) + 1`` taps and zero padding (the error outside the image is zero; the metrics'
blur reflects at the border instead, which differs only within ``3 sigma`` of it).

**Greedy coordinate descent.** Changing pixel ``p`` by ``d`` (one value per channel) changes
``J`` by ``2 d . (G * B)(p) + |d|^2 n(p)`` where ``B = G * (x - r)`` and ``n(p) = sum_q G(q - p)^2``
(the kernel is symmetric, so ``G^T = G``). Pixels at least ``2 ceil(3 sigma) + 1`` apart have
disjoint footprints, so all pixels of one phase of that grid move at once and each move is exact;
a sweep visits every phase in a fixed order, and sweeps repeat until no pixel improves (or
``sweeps`` runs out). ``J`` never rises, so starting from the oracle's choice the result is never
worse than the oracle's under this objective.

:func:`blurred_objective` evaluates ``J``; :func:`exhaustive_select` finds its exact minimum on a
tiny frame (every one of the ``K^(H W)`` choices), the check of the greedy search.

Not for: a strategy's per-frame bookkeeping (:mod:`bnerr.strategies.oracle` renders the
candidates and assembles the chosen buffers).
"""

from __future__ import annotations

import math

import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_range, check_shape

__all__ = ["blurred_objective", "exhaustive_select", "vertical_select"]

_EXHAUSTIVE_LIMIT = 1 << 16


def _taps(sigma: float, dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    radius = math.ceil(3 * sigma)
    x = torch.arange(-radius, radius + 1, dtype=dtype, device=device)
    g = torch.exp(-0.5 * (x / sigma) ** 2)
    return g / g.sum()


def _band(taps: torch.Tensor, n: int) -> torch.Tensor:
    """The ``[n, n]`` matrix of a zero-padded 1-D convolution with the symmetric ``taps``."""
    r = taps.numel() // 2
    i = torch.arange(n, device=taps.device)
    off = i[None, :] - i[:, None]
    return torch.where(off.abs() <= r, taps[(off + r).clamp(0, 2 * r)], taps.new_zeros(()))


def _blur(img: torch.Tensor, taps: torch.Tensor) -> torch.Tensor:
    """Zero-padded separable blur of ``img [..., H, W]`` with the 1-D ``taps``: ``Gy img Gx``
    (two matrix products: far faster on the CPU than a grouped float64 convolution)."""
    h, w = img.shape[-2:]
    return _Blur(taps, h, w)(img)


class _Blur:
    """:func:`_blur` with its two band matrices built once."""

    def __init__(self, taps: torch.Tensor, h: int, w: int) -> None:
        self.gy, self.gx = _band(taps, h), _band(taps, w)

    def __call__(self, img: torch.Tensor) -> torch.Tensor:
        return self.gy @ img @ self.gx


def _check(candidates: torch.Tensor, target: torch.Tensor, sigma: float) -> None:
    size = check_shape(candidates, "K C H W", "candidates")
    check_shape(target, f"{size['C']} {size['H']} {size['W']}", "target")
    check_range(sigma, "sigma", 1e-3, 64.0)
    if not (candidates.is_floating_point() and target.is_floating_point()):
        raise ValueRangeError("candidates, target: expected floating-point images, got integers")


def _gather(candidates: torch.Tensor, choice: torch.Tensor) -> torch.Tensor:
    index = choice[None, None].expand(1, candidates.shape[1], -1, -1)
    return candidates.gather(0, index)[0]


def blurred_objective(image: torch.Tensor, target: torch.Tensor, sigma: float = 2.0) -> float:
    """``J``: the sum of the squared zero-padded Gaussian blur of ``image - target``
    (``[C, H, W]`` each), in float64."""
    _check(image[None], target, sigma)
    err = image.to(torch.float64) - target.to(torch.float64)
    return float(_blur(err, _taps(sigma, torch.float64, err.device)).square().sum())


def _check_choice(choice: torch.Tensor, k: int, h: int, w: int) -> torch.Tensor:
    check_shape(choice, f"{h} {w}", "init")
    if choice.is_floating_point() or bool(((choice < 0) | (choice >= k)).any()):
        raise ValueRangeError(f"init: expected integer candidate indices in [0, {k}), got others")
    return choice.long()


def _phase_moves(
    cands: torch.Tensor, x: torch.Tensor, grad: torch.Tensor, norm2: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """For the phase's pixels (``cands [K, C, N]``, ``x``/``grad [C, N]``, ``norm2 [N]``): the
    best candidate and its change of ``J`` (0 or less)."""
    d = cands - x[None]
    delta = 2 * (d * grad[None]).sum(1) + d.square().sum(1) * norm2[None]
    best, k = delta.min(0)
    return k, best


def vertical_select(
    candidates: torch.Tensor,
    target: torch.Tensor,
    *,
    sigma: float = 2.0,
    init: torch.Tensor | None = None,
    sweeps: int = 16,
) -> torch.Tensor:
    """The per-pixel candidate choice ``[H, W]`` (int64) that greedily minimizes ``J``.

    Args:
        candidates: ``[K, C, H, W]`` the K candidate estimates of every pixel.
        target: ``[C, H, W]`` what the blurred error is measured against.
        sigma: the blur's standard deviation in pixels.
        init: ``[H, W]`` the starting choice (the oracle's, for a result never worse than it), or
            None for each pixel's candidate nearest the target.
        sweeps: the most passes over all pixels (>= 1); the search stops earlier when a pass
            moves no pixel.

    Raises:
        ShapeError, ValueRangeError: inputs of the wrong shape, dtype or range.
    """
    _check(candidates, target, sigma)
    check_positive_int(sweeps, "sweeps")
    cands = candidates.to(torch.float64)
    ref = target.to(torch.float64)
    k, _, h, w = cands.shape
    if init is None:
        choice = (cands - ref[None]).square().sum(1).argmin(0)
    else:
        choice = _check_choice(init, k, h, w).clone()
    taps = _taps(sigma, torch.float64, cands.device)
    stride = taps.numel()
    norm2 = _blur(torch.ones(1, h, w, dtype=torch.float64, device=cands.device), taps.square())[0]
    blur = _Blur(taps, h, w)
    x = _gather(cands, choice)
    for _ in range(sweeps):
        moved = False
        for oy in range(min(stride, h)):
            for ox in range(min(stride, w)):
                grad = blur(blur(x - ref))[:, oy::stride, ox::stride]
                sub = cands[:, :, oy::stride, ox::stride]
                best_k, best = _phase_moves(
                    sub, x[:, oy::stride, ox::stride], grad, norm2[oy::stride, ox::stride]
                )
                better = best < -1e-12 * (1.0 + norm2[oy::stride, ox::stride])
                if bool(better.any()):
                    moved = True
                    view = choice[oy::stride, ox::stride]
                    view[better] = best_k[better]
                    x[:, oy::stride, ox::stride] = _gather(sub, view)
        if not moved:
            break
    return choice


def exhaustive_select(
    candidates: torch.Tensor, target: torch.Tensor, *, sigma: float = 2.0
) -> torch.Tensor:
    """The exact minimizer of ``J`` over every choice (ties: the first in lexicographic order of
    the pixels' indices, row-major, the last pixel fastest): ``[H, W]`` int64.

    Raises:
        ValueRangeError: more than 2^16 choices (``K^(H W)``).
    """
    _check(candidates, target, sigma)
    k, c, h, w = candidates.shape
    n = h * w
    if k**n > _EXHAUSTIVE_LIMIT:
        raise ShapeError(f"exhaustive_select: expected at most 2^16 choices, got {k}^{n}")
    cands = candidates.to(torch.float64).reshape(k, c, n)
    codes = torch.arange(k**n, device=cands.device)
    digits = torch.stack([(codes // k ** (n - 1 - i)) % k for i in range(n)], 1)  # [M, n]
    images = cands[digits, :, torch.arange(n, device=cands.device)]  # [M, n, C]
    err = images.permute(0, 2, 1).reshape(-1, c, h, w) - target.to(torch.float64)[None]
    taps = _taps(sigma, torch.float64, cands.device)
    blurred = _blur(err.reshape(-1, h, w), taps).reshape(-1, c, h, w)
    best = int(blurred.square().sum((1, 2, 3)).argmin())
    return digits[best].reshape(h, w)
