"""The trade of short moves (issue 26, item 4): a seed's error carried over against the mask.

The retargeting pass (:mod:`bnerr.permutation.retarget`) moves every seed after the sort so that the
mask value it was ranked like is close to the value the next frame's (shifted) mask wants at its new
pixel. The shipped field lets a seed move up to 6 px per axis. The method only works if the seed's
error moves with it: a seed moved far lands on a pixel whose integrand differs, and its error
there is a new draw. A field with shorter moves (at most ``r`` px per axis, optimized the same
way, :func:`bnerr.permutation.retarget.optimize_retarget` with ``method="exact"``) keeps more of the
error, but matches the next frame's mask worse. Two measures of each side, on a static camera (only
the sort and the retargeting move seeds):

- :func:`seed_carryover`: the Pearson correlation, over seeds, of a seed's error (luminance) at
  frame t with its error at frame t + 1 at the pixel it moved to; 1 when the error travels with
  the seed, 0 when it is a fresh draw;
- the field's energy :func:`bnerr.permutation.retarget.retarget_energy`,
  ``mean |M(q + d(q)) - M(q + s)|``, as a fraction of the identity field's (no retargeting): how far
  the mask a seed was ranked for is from the mask it meets (0: the mask moves with the seeds; 1: as
  if not retargeted);
- :func:`mean_move`: how far seeds move per frame (px), the sorting pass's moves included;
- the outcome: the sigma-2 blurred MSE over the coherent pixels, as a fraction of white's.

``python -m benchmarks.studies.short_moves`` prints the table for ``direct`` and ``indirect``
at 16 spp on 64 x 64 frames, fields of radius 1, 2, 3 and the shipped 6, with the luminance and
the residual sort key (a diagnosis, not a benchmark: nothing is written under ``results/``).

The finding it measures: docs/FINDINGS.md, "How much of the gap to the oracle the temporal variants
close" (a seed's error does not carry over to the pixel it is moved to, and shorter moves keep
little more of it while matching the mask worse); the table is in docs/METHODS.md, section 11.

Not for: optimizing fields to ship (``bnerr retarget``).
"""

from __future__ import annotations

import numpy as np
import torch

from bnerr.color import luminance
from bnerr.errors import ShapeError
from bnerr.frame import Frame
from bnerr.sequences import Sampler

__all__ = ["mean_move", "measure_field", "seed_carryover"]

#: The retargeting radii compared (6 is the shipped field's).
RADII = (1, 2, 3, 6)


def _pairs(seeds_t: torch.Tensor, seeds_u: torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
    """Flat pixel indices ``(i, j)``: the seed at pixel ``i`` of ``seeds_t`` is at ``j`` of
    ``seeds_u`` (seeds in both images only)."""
    if seeds_t.shape != seeds_u.shape or seeds_t.dim() != 2:
        raise ShapeError(
            f"seeds: expected two [H, W] images of one shape, got {list(seeds_t.shape)} and "
            f"{list(seeds_u.shape)}"
        )
    a, b = seeds_t.reshape(-1).cpu().numpy(), seeds_u.reshape(-1).cpu().numpy()
    _, i, j = np.intersect1d(a, b, assume_unique=True, return_indices=True)
    return i, j


def seed_carryover(
    seeds_t: torch.Tensor, err_t: torch.Tensor, seeds_u: torch.Tensor, err_u: torch.Tensor
) -> float:
    """Pearson correlation over seeds between the error at frame t (``err_t [H, W]``, where
    ``seeds_t [H, W]`` put each seed) and at frame t + 1 at the seed's new pixel (``seeds_u``,
    ``err_u``); NaN with fewer than two shared seeds or a constant error."""
    i, j = _pairs(seeds_t, seeds_u)
    if len(i) < 2:
        return float("nan")
    x = err_t.reshape(-1).double().cpu().numpy()[i]
    y = err_u.reshape(-1).double().cpu().numpy()[j]
    x, y = x - x.mean(), y - y.mean()
    den = float(np.sqrt((x * x).sum() * (y * y).sum()))
    return float((x * y).sum() / den) if den > 0 else float("nan")


def mean_move(seeds_t: torch.Tensor, seeds_u: torch.Tensor) -> float:
    """Mean Euclidean distance (px) from a seed's pixel in ``seeds_t`` to its pixel in
    ``seeds_u`` (seeds in both only; NaN when none is)."""
    i, j = _pairs(seeds_t, seeds_u)
    if len(i) == 0:
        return float("nan")
    w = seeds_t.shape[1]
    dy, dx = i // w - j // w, i % w - j % w
    return float(np.hypot(dy, dx).mean())


# --------------------------------------------------------------------------------------------------
# The measurement (python -m benchmarks.studies.short_moves)


def _field(mask: torch.Tensor, radius: int) -> torch.Tensor:
    from bnerr.permutation.retarget import load_retarget, optimize_retarget

    if radius == 6:
        return load_retarget(mask.shape[-1])  # the shipped field: exact at radius 6
    return optimize_retarget(mask, method="exact", radius=radius)


def measure_field(
    name: str, spp: int, radius: int, key: str, *, size: int = 64, warmup: int = 6, frames: int = 8
) -> dict:
    """The four measures for the temporal method with a field of ``radius`` and sort ``key``
    (``"luminance"`` or ``"residual"``), on the static ``name`` at ``spp`` (means over
    ``frames`` measured frames after ``warmup``; the MSE as a ratio of means, white's frames
    rendered from fresh seeds each)."""
    import renderers
    from benchmarks.training_data import pixel_seeds
    from bnerr.masks import load_mask
    from bnerr.metrics import blurred_mse, coherent_mask
    from bnerr.permutation.retarget import retarget_energy
    from bnerr.sequences import make_sampler
    from bnerr.strategies.temporal import TemporalStrategy
    from bnerr.strategies.variants import TemporalOptions

    scene = renderers.get_scene(name, animated=False)
    sobol = make_sampler("owen_sobol")
    ref = renderers.render(scene, 0, pixel_seeds(size, size, 90_000), sobol, 512)
    region = coherent_mask(ref, ref)
    mask = load_mask("scalar", 64)
    field = _field(mask, radius)
    strategy = TemporalStrategy(
        size, size, mask=mask, retarget=field, options=TemporalOptions(key=key)
    )

    def render(seeds: torch.Tensor, sampler: Sampler) -> Frame:
        return renderers.render(scene, 0, seeds, sampler, spp)

    seeds, errs, mine, white_mse = [], [], [], []
    for t in range(warmup + frames):
        before = strategy.seeds.clone()
        frame = strategy.frame(t, render)
        if t < warmup:
            continue
        seeds.append(before)
        errs.append(luminance(frame.color - ref.color, dtype=torch.float64))
        white = renderers.render(scene, 0, pixel_seeds(size, size, 1000 + t), sobol, spp)
        mine.append(float(blurred_mse(frame.color, ref.color, 2.0, region)))
        white_mse.append(float(blurred_mse(white.color, ref.color, 2.0, region)))
    steps = range(frames - 1)
    identity = retarget_energy(mask, torch.zeros_like(field))
    return {
        "scene": name,
        "spp": spp,
        "radius": radius,
        "key": key,
        "carryover": float(
            np.mean([seed_carryover(seeds[k], errs[k], seeds[k + 1], errs[k + 1]) for k in steps])
        ),
        "move": float(np.mean([mean_move(seeds[k], seeds[k + 1]) for k in steps])),
        "mask_mismatch": retarget_energy(mask, field) / identity,
        "blur2_vs_white": float(np.mean(mine) / np.mean(white_mse)),
    }


def main() -> None:
    """Print the table: ``direct`` and ``indirect`` at 16 spp, radii 1-3 and 6, both keys."""
    torch.set_num_threads(1)
    print("| scene | spp | radius | key | seed error carry-over (corr) | mean move (px) | "
          "mask mismatch (/ identity) | sigma-2 MSE / white (coherent) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for name in ("direct", "indirect"):
        for key in ("luminance", "residual"):
            for radius in RADII:
                d = measure_field(name, 16, radius, key)
                print(
                    f"| {name} | {d['spp']} | {radius} | {key} | {d['carryover']:.2f} | "
                    f"{d['move']:.1f} | {d['mask_mismatch']:.2f} | {d['blur2_vs_white']:.2f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
