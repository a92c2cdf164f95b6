"""Why blue noise fades past 4 spp in the a-priori keys: the tracer's own integrands, measured.

With the pixel jitter pinned at the pixel centre
(:class:`benchmarks.studies.jitter_loss.FixedJitter`'s rule), a pixel of ``direct`` integrates one
2D function, its light integrand ``f_p(u, v)``: the luminance of the path through the point
``(u, v)`` of the light's square (dimensions 2-3). :func:`pair_integrands` tabulates it at the
centres of a ``G x G`` grid for every pixel, by ``G^2`` renders at one sample (:class:`GridPair`
pins every dimension), so that any key tile's error can then be computed without render noise: a
texel's points read ``f_p`` at the cell they fall in, against the mean over the cells
(:func:`keyed_errors`). On deeper scenes the same tabulates one pair with the others pinned at
their midpoint (``indirect``: the light sample or the bounce direction at the first hit), a slice
of the path space.

Three measurements, each over many tile offsets:

- :func:`edge_motion`: where the function is zero in part of the square (the *penumbra*, for
  the light pair: some of the light hidden), how many of the square's cells change between zero
  and not from a pixel to its right and lower neighbour, in ``1 / 64`` of the square (a straight
  edge moving by ``k / 64`` across the square flips about ``k / 64`` of it): the scale of
  :func:`bnerr.ldbn.quality.blurred_share`'s ``drift``.
- :func:`arrangement_ratio`: the keys' error after a sigma-2 blur over the same point sets placed
  at random texels (which keeps each pixel's raw error and makes neighbours independent), over
  every pixel, the penumbra and the pixels whose function is nowhere zero (*lit*); and the same
  with the penumbra *frozen*: every penumbra pixel integrates one penumbra pixel's function (the
  band's shape and place kept, the change from pixel to pixel taken away), the experiment that
  separates the integrand's motion from the band's geometry.
- :func:`carried_correlation`: how much of a point set's error carries over to the neighbour's
  function.

``python -m benchmarks.studies.integrand_motion`` prints the tables for ``direct``'s frame 6 at
128 x 128 with a 64 x 64 grid and the shipped Z-ordered and per-pixel keys (about a minute;
``--scene indirect --pair 2`` for the bounce direction; ``--fit FRAMES`` fits the light pair's
keys on other frames' integrands and measures them on this one). A diagnosis: nothing is written
under ``results/``; docs/METHODS.md, section 10, has the figures.

The finding it measures: docs/FINDINGS.md, "Flicker, matched keys, larger keys, the GPU",
"Keys over a Z-ordered global sequence" (the shadow edge moves 2-4/64 of the light's square per
pixel, and the keys' arrangement survives less of that change the more samples it has).

Not for: the benchmark's tables.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

import renderers
from bnerr.color import luminance
from bnerr.errors import ShapeError, ValueRangeError, check_positive_int
from bnerr.ldbn.keys import SHIPPED_SEED0
from bnerr.ldbn.quality import pair_points
from bnerr.ldbn.swaps import Evaluate, energy, energy_kernel, joint_swap_descent
from bnerr.metrics import blurred_mse
from bnerr.resources import load_array
from bnerr.sequences import Sampler
from bnerr.sequences.ldbn_bases import base_table, keyed_words
from bnerr.strategies import pixel_seeds

__all__ = [
    "GridPair",
    "KEY_SETS",
    "Ratios",
    "arrangement_ratio",
    "carried_correlation",
    "edge_motion",
    "key_points",
    "keyed_errors",
    "fit_light_pair",
    "main",
    "pair_integrands",
    "window_error",
    "windows",
]

#: The key sets of the default table: file under ``bnerr/data`` and the base it reads.
KEY_SETS = {
    "ldbn_zorder": ("ldbn_zorder_64.npy", "zorder"),
    "ldbn": ("ldbn_screen_64.npy", "sobol"),
}
#: The light-position pair of ``direct`` (dimensions 2-3).
LIGHT_PAIR = 1
_SIGMA = 2.0


class GridPair(Sampler):
    """Every lane's path pinned: the jitter (dimensions 0-1) at the pixel centre, dimension pair
    ``pair`` at ``(u, v)`` and every other dimension at ``rest``."""

    def __init__(self, pair: int, u: float, v: float, rest: float = 0.5) -> None:
        if not (0.0 <= u < 1.0 and 0.0 <= v < 1.0 and 0.0 <= rest < 1.0):
            raise ValueRangeError(
                f"(u, v), rest: expected points of [0, 1), got ({u}, {v}), {rest}"
            )
        self.pair = check_positive_int(pair, "pair")
        self.point = (float(u), float(v))
        self.rest = float(rest)

    def _sample(
        self,
        seed: torch.Tensor,
        index: torch.Tensor,
        dim: int,
        count: int,
        pixel: torch.Tensor | None,
    ) -> torch.Tensor:
        out = torch.full((seed.shape[0], count), self.rest, dtype=torch.float32, device=seed.device)
        for d in range(dim, dim + count):
            if d < 2:
                out[:, d - dim] = 0.5
            elif d // 2 == self.pair:
                out[:, d - dim] = self.point[d % 2]
        return out

    def __repr__(self) -> str:
        return f"GridPair(pair={self.pair}, u={self.point[0]}, v={self.point[1]}, rest={self.rest})"


def pair_integrands(
    scene_name: str, t: int = 6, size: int = 128, grid: int = 64, pair: int = LIGHT_PAIR
) -> torch.Tensor:
    """``[H, W, G, G]`` float32: pixel ``(y, x)``'s luminance with dimension pair ``pair`` at the
    centre of cell ``(j, i)`` (``u = (i + 0.5) / G``, ``v = (j + 0.5) / G``), the jitter at the
    pixel centre and every other dimension at 0.5, frame ``t`` of the animated scene (``G^2``
    renders at one sample). On ``direct`` (D = 4) the light pair is all a pixel integrates; on a
    deeper scene it is one slice of the path space through the others' midpoint."""
    size = check_positive_int(size, "size", minimum=2)
    grid = check_positive_int(grid, "grid", minimum=2)
    scene = renderers.get_scene(scene_name, animated=True)
    pairs = scene.layout.dimensions // 2
    if not 1 <= pair < pairs:
        raise ValueRangeError(
            f"pair: expected a pair past the jitter, 1 to {pairs - 1} on {scene_name!r} (D = "
            f"{scene.layout.dimensions}), got {pair}"
        )
    seeds = pixel_seeds(size, size, 0x5EED)
    out = torch.empty(size, size, grid, grid, dtype=torch.float32)
    for j in range(grid):
        for i in range(grid):
            sampler = GridPair(pair, (i + 0.5) / grid, (j + 0.5) / grid)
            frame = renderers.render(scene, t, seeds, sampler, 1)
            out[:, :, j, i] = luminance(frame.color, dtype=torch.float32)
    return out


def _check_integrands(f: torch.Tensor) -> None:
    if f.dim() != 4 or f.shape[2] != f.shape[3] or f.shape[2] < 2:
        raise ShapeError(f"integrands: expected [H, W, G, G] with G >= 2, got {list(f.shape)}")


def penumbra(f: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(penumbra, lit)`` ``[H, W]`` bool: pixels whose function is zero in part of the square
    and in none of it (for the light pair: the light partly hidden, and in full view)."""
    _check_integrands(f)
    visible = (f > 0).float().mean((2, 3))
    return (visible > 0) & (visible < 1), visible == 1


def edge_motion(f: torch.Tensor, quantiles: Sequence[float] = (0.25, 0.5, 0.75, 0.9)) -> dict:
    """How many of the light's cells change visibility between horizontal and vertical
    neighbours that are both in the penumbra, in ``1 / 64`` of the square: ``{"x": [...], "y":
    [...]}`` the quantiles asked, with ``"pixels"`` the penumbra's size and ``"pairs"`` the
    neighbour pairs counted per axis."""
    pen, _ = penumbra(f)
    if int(pen.sum()) < 2:
        raise ValueRangeError("integrands: expected a penumbra of two pixels or more, got fewer")
    visible = (f > 0).float()
    q = torch.tensor(list(quantiles), dtype=torch.float32)
    out: dict = {"pixels": int(pen.sum()), "pairs": {}}
    for axis, (a, b, both) in {
        "x": (visible[:, :-1], visible[:, 1:], pen[:, :-1] & pen[:, 1:]),
        "y": (visible[:-1], visible[1:], pen[:-1] & pen[1:]),
    }.items():
        flipped = 64 * (a - b).abs().mean((2, 3))[both]
        out["pairs"][axis] = int(both.sum())
        out[axis] = flipped.quantile(q).tolist() if flipped.numel() else [float("nan")] * len(q)
    return out


def key_points(keys: np.ndarray, base: str, spp: int, pair: int = LIGHT_PAIR) -> torch.Tensor:
    """``[T^2, spp, 2]`` each texel's first ``spp`` points in ``pair`` of a key file's array
    ``[L, 1, T, T, 3 D / 2]`` (scrambling keys then ranks), as the sampler reads them: from the
    level for ``spp``, or past the last level from the last (its keys permute every aligned
    block of the shared ``sobol`` sequence; the other bases have no points past it)."""
    needed = (check_positive_int(spp, "spp") - 1).bit_length()
    if keys.ndim != 5 or keys.shape[1] != 1 or keys.shape[-1] % 3:
        raise ShapeError(f"keys: expected [L, 1, T, T, 3 D / 2], got {list(keys.shape)}")
    level = min(needed, keys.shape[0] - 1)
    if needed > level and base != "sobol":
        raise ShapeError(
            f"keys: expected a level for {spp} spp on the {base!r} base, got {keys.shape[0]} "
            f"levels (up to {1 << level} spp)"
        )
    dims = keys.shape[-1] * 2 // 3
    tile = keys[level, 0]
    read = (SHIPPED_SEED0, base, max(level, needed))
    return pair_points(tile[..., :dims], tile[..., dims:], spp, pair, read)


def _cell_index(points: torch.Tensor, grid: int) -> torch.Tensor:
    """The flat grid cell ``j G + i`` that each point ``(u, v)`` of ``points [..., 2]`` falls in."""
    cells = (points * grid).long().clamp_(0, grid - 1)
    return cells[..., 1] * grid + cells[..., 0]


def keyed_errors(
    f: torch.Tensor,
    points: torch.Tensor,
    offset: tuple[int, int] = (0, 0),
    perm: torch.Tensor | None = None,
) -> torch.Tensor:
    """``[H, W]`` float64 each pixel's error: the mean of ``f_p`` at the cells its texel's
    points ``[T^2, n, 2]`` fall in, minus ``f_p``'s mean over the cells. Pixel ``(y, x)`` reads
    texel ``((y + oy) mod T, (x + ox) mod T)``; ``perm [T^2]`` places texel ``perm[k]``'s
    points at texel ``k`` instead."""
    _check_integrands(f)
    height, width, grid = f.shape[0], f.shape[1], f.shape[2]
    size = round(points.shape[0] ** 0.5)
    if points.dim() != 3 or points.shape[2] != 2 or size * size != points.shape[0]:
        raise ShapeError(f"points: expected [T^2, n, 2], got {list(points.shape)}")
    flat = _cell_index(points, grid)  # [T^2, n]
    if perm is not None:
        flat = flat[perm]
    y = (torch.arange(height)[:, None] + offset[0]) % size
    x = (torch.arange(width)[None, :] + offset[1]) % size
    values = f.reshape(height * width, grid * grid).double()
    estimate = torch.gather(values, 1, flat[(y * size + x).reshape(-1)]).mean(1)
    return (estimate - values.mean(1)).reshape(height, width)


@dataclass(frozen=True)
class Ratios:
    """The keys' blurred error over a random arrangement's, per pixel group, with the share
    of the random arrangement's raw and blurred error the penumbra holds and the keys' raw
    error over the random arrangement's (1 but for the offsets' draw: the same point sets)."""

    spp: int
    every: float
    penumbra: float
    lit: float
    frozen: float
    penumbra_raw: float
    penumbra_blurred: float
    raw: float


def _blurred(e: torch.Tensor, mask: torch.Tensor | None) -> float:
    """The blurred MSE of the error ``e`` over ``mask`` (NaN when it selects no pixel)."""
    if mask is not None and not bool(mask.any()):
        return float("nan")
    zero = torch.zeros_like(e)
    return float(blurred_mse(e[None], zero[None], _SIGMA, mask))


def _frozen(f: torch.Tensor, pen: torch.Tensor, source: int) -> torch.Tensor:
    """``f`` with every penumbra pixel's function replaced by pixel ``source``'s."""
    out = f.clone()
    out[pen] = f.reshape(-1, *f.shape[2:])[source]
    return out


def arrangement_ratio(
    f: torch.Tensor, points: torch.Tensor, *, offsets: int = 8, seed: int = 0
) -> Ratios:
    """:class:`Ratios` over ``offsets`` random tile offsets (each with its own random
    arrangement of the same point sets); the frozen ratio over the penumbra uses one source
    pixel per offset, drawn among the penumbra pixels that see 20-80 % of the light."""
    pen, lit = penumbra(f)
    visible = (f > 0).float().mean((2, 3)).reshape(-1)
    sources = ((visible > 0.2) & (visible < 0.8)).nonzero()[:, 0]
    if sources.numel() == 0:
        raise ValueRangeError("integrands: expected pixels seeing 20-80 % of the light, got none")
    size = round(points.shape[0] ** 0.5)
    gen = torch.Generator().manual_seed(seed)
    sums = np.zeros((2, 6))  # keys, random x (every, penumbra, lit, frozen, raw all, raw pen)
    for _ in range(check_positive_int(offsets, "offsets")):
        oy, ox = (int(v) for v in torch.randint(0, size, (2,), generator=gen))
        perm = torch.randperm(size * size, generator=gen)
        source = sources[torch.randint(0, sources.numel(), (1,), generator=gen)]
        frozen = _frozen(f, pen, int(source))
        for row, arrangement in enumerate((None, perm)):
            e = keyed_errors(f, points, (oy, ox), arrangement)
            e_frozen = keyed_errors(frozen, points, (oy, ox), arrangement)
            sums[row] += [
                _blurred(e, None),
                _blurred(e, pen),
                _blurred(e, lit),
                _blurred(e_frozen, pen),
                float(e.square().sum()),
                float(e[pen].square().sum()),
            ]
    ratio = sums[0] / sums[1]
    rand = sums[1]
    return Ratios(
        spp=points.shape[1],
        every=float(ratio[0]),
        penumbra=float(ratio[1]),
        lit=float(ratio[2]),
        frozen=float(ratio[3]),
        penumbra_raw=float(rand[5] / rand[4]),
        penumbra_blurred=float(rand[1] * pen.sum() / (rand[0] * pen.numel())),
        raw=float(ratio[4]),
    )


def carried_correlation(
    f: torch.Tensor,
    points: torch.Tensor,
    *,
    pairs: int = 512,
    keys: int = 512,
    seed: int = 0,
    quantiles: Sequence[float] = (0.25, 0.5, 0.75),
) -> list[float]:
    """How much of a point set's error carries over to the neighbour's integrand: for pairs of
    horizontal or vertical neighbours in the penumbra, the correlation over point sets (texels'
    keys) of each set's error on ``f_p`` and on ``f_q``; its quantiles over the pairs. An
    arrangement can cancel neighbours' errors only as far as this is near 1 (on a fixed
    integrand it is 1)."""
    pen, _ = penumbra(f)
    grid = f.shape[2]
    gen = torch.Generator().manual_seed(seed)
    right = (pen[:, :-1] & pen[:, 1:]).nonzero()
    down = (pen[:-1] & pen[1:]).nonzero()
    every = torch.cat(  # [M, 4]: (y, x) of p, then of q
        [
            torch.cat([right, right + torch.tensor([0, 1])], 1),
            torch.cat([down, down + torch.tensor([1, 0])], 1),
        ]
    )
    if every.shape[0] == 0:
        raise ValueRangeError("integrands: expected neighbours in the penumbra, got none")
    every = every[torch.randperm(every.shape[0], generator=gen)[:pairs]]
    chosen = torch.randperm(points.shape[0], generator=gen)[:keys]
    flat = _cell_index(points[chosen], grid)  # [K, n]
    errs = []
    for y, x in ((every[:, 0], every[:, 1]), (every[:, 2], every[:, 3])):
        values = f[y, x].reshape(every.shape[0], -1).double()  # [M, G^2]
        e = values[:, flat].mean(-1) - values.mean(1, keepdim=True)  # [M, K]
        errs.append(e - e.mean(1, keepdim=True))
    norms = (errs[0].norm(dim=1) * errs[1].norm(dim=1)).clamp_min(1e-300)
    corr = (errs[0] * errs[1]).sum(1) / norms
    return corr.quantile(torch.tensor(list(quantiles), dtype=torch.float64)).tolist()


@dataclass(frozen=True)
class Windows:
    """Training windows over tabulated integrands: texel ``t``'s pixel in window ``c``
    (``pixels [T^2, C]``, flat over the stacked frames) and its exact integral there."""

    values: torch.Tensor  # [F H W G^2] float32, flat
    grid: int
    pixels: torch.Tensor  # [T^2, C] int64
    exact: torch.Tensor  # [T^2, C] float64


def windows(frames: Sequence[torch.Tensor], size: int, per_frame: int, seed: int = 1) -> Windows:
    """``per_frame`` random tile offsets in each of ``frames`` (``[H, W, G, G]`` each, H and W
    multiples of ``size``): texel ``t`` at offset ``o`` reads every pixel ``(t - o) mod T + T c``,
    so toroidal neighbours of the tile are neighbours in the image (but at the copies' seams)."""
    if not frames or any(f.shape != frames[0].shape for f in frames):
        raise ShapeError("frames: expected one or more integrand tables of one shape")
    _check_integrands(frames[0])
    height, width, grid = frames[0].shape[:3]
    if height % size or width % size:
        raise ShapeError(f"frames: expected H and W multiples of {size}, got {height} x {width}")
    stacked = torch.stack(list(frames)).reshape(len(frames), height * width, grid * grid)
    gen = torch.Generator().manual_seed(seed)
    ty, tx = (c.reshape(-1) for c in torch.meshgrid(*[torch.arange(size)] * 2, indexing="ij"))
    per_frame = check_positive_int(per_frame, "per_frame")
    offsets = torch.randint(0, size, (len(frames), per_frame, 2), generator=gen).tolist()
    cols = []
    for k in range(len(frames)):
        for oy, ox in offsets[k]:
            for cy in range(height // size):
                for cx in range(width // size):
                    py, px = (ty - oy) % size + size * cy, (tx - ox) % size + size * cx
                    cols.append(k * height * width + py * width + px)
    pixels = torch.stack(cols, 1)
    exact = stacked.double().mean(2).reshape(-1)[pixels]
    return Windows(stacked.reshape(-1), grid, pixels, exact)


def _window_errors(keys: np.ndarray, level: int, train: Windows) -> tuple[Evaluate, torch.Tensor]:
    """``(errors, chunks)``: ``errors(texels [M], rows [M]) -> [M, C]`` the errors of the light
    pair's chunk ``rows[i]`` of ``level`` (read with texel ``texels[i]``'s ranks) on texel
    ``texels[i]``'s windows; ``chunks [T^2, 2]`` the level's chunk keys."""
    size = keys.shape[2]
    n = 1 << level
    dims = keys.shape[-1] * 2 // 3
    tile = torch.from_numpy(keys[level, 0].reshape(size * size, -1)).long()
    chunks = tile[:, 2 * LIGHT_PAIR : 2 * LIGHT_PAIR + 2]
    index = torch.arange(n)[None, :] ^ tile[:, dims + LIGHT_PAIR, None]
    table = base_table("zorder", SHIPPED_SEED0, LIGHT_PAIR, level, size * size)
    grid = train.grid

    def errors(texels: torch.Tensor, rows: torch.Tensor) -> torch.Tensor:
        words = keyed_words("zorder", table, index[texels], chunks[rows], n)
        flat = _cell_index(words.float() / (1 << 24), grid)  # [M, n]
        at = train.pixels[texels][:, :, None] * (grid * grid) + flat[:, None, :]
        return train.values[at].double().mean(2) - train.exact[texels]

    return errors, chunks


def window_error(keys: np.ndarray, level: int, train: Windows) -> float:
    """The blurred squared error of the light pair's ``level`` over ``train``'s windows, in
    units of the blur's autocorrelation: ``sum_p |e_p|^2 + sum_{p != q} w(p - q) <e_p, e_q>``
    (toroidal, what :func:`fit_light_pair` lowers)."""
    errors, _ = _window_errors(keys, level, train)
    every = torch.arange(keys.shape[2] * keys.shape[3])
    e = errors(every, every)
    kernel = energy_kernel(keys.shape[2], sigma=_SIGMA, autocorrelation=True)
    return float(e.square().sum()) + energy(e, kernel)


def fit_light_pair(
    keys: np.ndarray, level: int, train: Windows, iterations: int = 200, seed: int = 0
) -> np.ndarray:
    """A copy of ``zorder`` keys ``[L, 1, T, T, 3 D / 2]`` with the light pair's chunks of
    ``level`` permuted over the tile to lower :func:`window_error`, raw part included (each
    texel's ranks kept; :func:`bnerr.ldbn.swaps.joint_swap_descent` with ``w(0) = 1``, the
    autocorrelation's)."""
    errors, chunks = _window_errors(keys, level, train)
    size = keys.shape[2]
    kernel = energy_kernel(size, sigma=_SIGMA, autocorrelation=True)
    gen = torch.Generator().manual_seed(seed)
    perm = joint_swap_descent(errors, kernel, iterations, gen, self_weight=1.0)
    out = keys.copy()
    out[level, 0, ..., 2 * LIGHT_PAIR : 2 * LIGHT_PAIR + 2] = (
        chunks[perm].reshape(size, size, 2).numpy()
    )
    return out


def _load(name: str) -> np.ndarray:
    return load_array(KEY_SETS[name][0], np.int32, (None, 1, None, None, None))


def _print_motion(f: torch.Tensor) -> None:
    motion = edge_motion(f)
    print(f"penumbra: {motion['pixels']} of {f.shape[0] * f.shape[1]} pixels")
    print("| axis | neighbour pairs | cells changing visibility, / 64: p25 | p50 | p75 | p90 |")
    print("|---|---|---|---|---|---|")
    for axis in ("x", "y"):
        cells = " | ".join(f"{v:.1f}" for v in motion[axis])
        print(f"| {axis} | {motion['pairs'][axis]} | {cells} |")


def _print_ratios(
    f: torch.Tensor, names: Sequence[str], spps: Sequence[int], offsets: int, pair: int
) -> None:
    print(
        "| keys | spp | penumbra's share of raw / blurred error | blurred / random arrangement: "
        "every pixel | penumbra | lit | penumbra frozen | error carried to the neighbour's "
        "integrand, correlation p25 / p50 / p75 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        keys = _load(name)
        for spp in spps:
            points = key_points(keys, KEY_SETS[name][1], spp, pair)
            r = arrangement_ratio(f, points, offsets=offsets)
            carried = " / ".join(f"{c:.2f}" for c in carried_correlation(f, points))
            print(
                f"| `{name}` | {spp} | {r.penumbra_raw:.2f} / {r.penumbra_blurred:.2f} | "
                f"{r.every:.3f} | {r.penumbra:.3f} | {r.lit:.3f} | {r.frozen:.3f} | {carried} |",
                flush=True,
            )


def _print_fit(f: torch.Tensor, args: argparse.Namespace) -> None:
    """Fit ``ldbn_zorder``'s light pair on the training frames' integrands at each spp and
    compare with the shipped keys on the training windows and on the measured frame."""
    tables = [pair_integrands(args.scene, t, args.size, args.fit_grid) for t in args.fit]
    train = windows(tables, 64, args.windows)
    shipped = _load("ldbn_zorder")
    print(
        f"Keys fitted on frames {args.fit} ({train.pixels.shape[1]} windows, grid "
        f"{args.fit_grid}), measured on frame {args.frame}:"
    )
    print(
        "| spp | training windows: blurred error, fitted / shipped | frame: blurred / random "
        "arrangement, shipped | fitted | raw, fitted / random |"
    )
    print("|---|---|---|---|---|")
    for spp in args.spp:
        level = (spp - 1).bit_length()
        fitted = fit_light_pair(shipped, level, train, args.iterations)
        held = window_error(fitted, level, train) / window_error(shipped, level, train)
        old, new = (
            arrangement_ratio(f, key_points(k, "zorder", spp), offsets=args.offsets)
            for k in (shipped, fitted)
        )
        print(
            f"| {spp} | {held:.3f} | {old.every:.3f} | {new.every:.3f} | {new.raw:.3f} |",
            flush=True,
        )


def main(argv: list[str] | None = None) -> None:
    """Print the edge motion and the arrangement ratios (markdown) for the key sets asked;
    with ``--fit FRAMES``, fit the light pair on those frames instead and compare."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.studies.integrand_motion")
    parser.add_argument("--scene", default="direct")
    parser.add_argument("--frame", type=int, default=6)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--grid", type=int, default=64)
    parser.add_argument("--pair", type=int, default=LIGHT_PAIR, help="the dimension pair tabulated")
    parser.add_argument("--keys", nargs="+", default=list(KEY_SETS), choices=list(KEY_SETS))
    parser.add_argument("--spp", nargs="+", type=int, default=[4, 16, 64])
    parser.add_argument("--offsets", type=int, default=8)
    parser.add_argument("--fit", nargs="+", type=int, default=None, metavar="FRAME")
    parser.add_argument("--fit-grid", type=int, default=32)
    parser.add_argument("--windows", type=int, default=8, help="tile offsets per fitted frame")
    parser.add_argument("--iterations", type=int, default=200)
    args = parser.parse_args(argv)
    if args.fit and args.frame in args.fit:
        parser.error(f"--fit: the measured frame {args.frame} must not be a training frame")
    if args.fit and args.pair != LIGHT_PAIR:
        parser.error(f"--fit: fits the light pair ({LIGHT_PAIR}) only, got --pair {args.pair}")
    f = pair_integrands(args.scene, args.frame, args.size, args.grid, args.pair)
    if args.fit:
        _print_fit(f, args)
        return
    _print_motion(f)
    print()
    _print_ratios(f, args.keys, args.spp, args.offsets, args.pair)


if __name__ == "__main__":
    main()
