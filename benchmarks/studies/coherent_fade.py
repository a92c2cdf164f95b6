"""Why the temporal method's gain fades with spp in coherent regions: the causes, measured.

The sorting pass orders each block's pixels by their value and hands the seed of the k-th
smallest value to the k-th smallest mask value. That moves *error* into blue noise only while the
values' differences inside a block are differences of error; once the signal varies more inside a
block than the error does (the error shrinks as ``1/sqrt(spp)``, the shading gradient does not),
the key orders the signal. Two measures of that, per frame, over the blocks that lie wholly in the
coherent region (:func:`bnerr.metrics.coherent_mask`):

- :func:`block_spread`: the ratio of the reference's within-block standard deviation (luminance)
  to the error's; above 1 the signal dominates the key;
- :func:`key_error_correlation`: the mean Spearman rank correlation, inside those blocks, of the
  sort key (the frame's luminance) with the error's luminance: 1 when the key ranks the error.

``python -m benchmarks.studies.coherent_fade`` prints both, with the oracle and the vertical
bound's blurred MSE over the coherent pixels (as fractions of white's), for ``direct`` and
``indirect`` at 4, 16 and 64 spp on small frames (a diagnosis, not a benchmark: nothing is written
under ``results/``).

The finding it measures: docs/FINDINGS.md, "How much of the gap to the oracle the temporal variants
close", "The seed's claim, in coherent regions" (the measured cause on ``direct``: the sort key
ranks the shading, not the error); the table is in docs/METHODS.md, section 11.

Not for: the benchmark's tables (:mod:`benchmarks.reports`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch

from bnerr.color import luminance
from bnerr.errors import ShapeError, check_positive_int

if TYPE_CHECKING:
    from bnerr.frame import Frame
    from renderers import Scene

__all__ = ["block_spread", "coherent_blocks", "key_error_correlation"]


def coherent_blocks(mask: torch.Tensor, block: int = 4) -> torch.Tensor:
    """``[Hb, Wb]`` bool: the ``block x block`` tiles (from the top-left corner, whole tiles only)
    whose every pixel is in ``mask [H, W]``."""
    check_positive_int(block, "block")
    h, w = (mask.shape[0] // block) * block, (mask.shape[1] // block) * block
    if h == 0 or w == 0:
        raise ShapeError(
            f"mask: expected at least {block} x {block} pixels, got {tuple(mask.shape)}"
        )
    tiles = mask[:h, :w].reshape(h // block, block, w // block, block)
    return tiles.all(3).all(1)


def _tiles(img: torch.Tensor, keep: torch.Tensor, block: int) -> torch.Tensor:
    """The luminance of ``img [3, H, W]`` in the kept tiles: ``[N, block * block]`` float64."""
    lum = luminance(img, dtype=torch.float64)
    hb, wb = keep.shape
    t = lum[: hb * block, : wb * block].reshape(hb, block, wb, block).permute(0, 2, 1, 3)
    return t.reshape(hb, wb, block * block)[keep]


def block_spread(ref: torch.Tensor, err: torch.Tensor, mask: torch.Tensor, block: int = 4) -> float:
    """Mean within-block standard deviation of the reference's luminance over the error's, over
    the blocks wholly in ``mask`` (NaN when there is none)."""
    keep = coherent_blocks(mask, block)
    r, e = _tiles(ref, keep, block), _tiles(err, keep, block)
    if r.shape[0] == 0:
        return float("nan")
    return float(r.std(1).mean() / e.std(1).mean())


def _ranks(x: torch.Tensor) -> torch.Tensor:
    return x.argsort(1).argsort(1).to(torch.float64)


def key_error_correlation(
    frame: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor, block: int = 4
) -> float:
    """Mean Spearman correlation, inside the blocks wholly in ``mask``, between the sort key
    (the luminance of ``frame``) and the error's luminance (``frame - ref``); NaN without
    blocks."""
    keep = coherent_blocks(mask, block)
    key, err = _tiles(frame, keep, block), _tiles(frame - ref, keep, block)
    if key.shape[0] == 0:
        return float("nan")
    a, b = _ranks(key), _ranks(err)
    a, b = a - a.mean(1, keepdim=True), b - b.mean(1, keepdim=True)
    corr = (a * b).sum(1) / (a.square().sum(1) * b.square().sum(1)).sqrt().clamp_min(1e-300)
    return float(corr.mean())


# --------------------------------------------------------------------------------------------------
# The diagnosis (python -m benchmarks.studies.coherent_fade)


def _render(
    scene: Scene, t: int, key: int, size: int, spp: int, sampler: str = "owen_sobol"
) -> Frame:
    import renderers
    from benchmarks.training_data import pixel_seeds
    from bnerr.sequences import make_sampler

    return renderers.render(scene, t, pixel_seeds(size, size, key), make_sampler(sampler), spp)


def diagnose(name: str, spp: int, *, size: int = 64, K: int = 8, ref_spp: int = 512) -> dict:
    """One scene and spp at frame 6 of its animation: the coherent region's share, the two cause
    measures on a white-noise frame, and the blurred (sigma 2) MSE over the coherent pixels of
    the histogram oracle and of the vertical bound (started from the oracle's choice, against
    the reference), as fractions of white's (the mean over the K candidates)."""
    import renderers
    from bnerr.masks import load_mask, tile_mask
    from bnerr.metrics import blurred_mse, coherent_mask
    from bnerr.permutation.permute import histogram_select
    from bnerr.permutation.vertical import vertical_select

    scene = renderers.get_scene(name, animated=True)
    ref, prev = (_render(scene, t, 90_000 + t, size, ref_spp) for t in (6, 5))
    mask = coherent_mask(ref, prev)
    cands = [_render(scene, 6, 1000 + k, size, spp) for k in range(K)]
    colors = torch.stack([f.color for f in cands])
    b = tile_mask(load_mask("scalar", 64), size, size)
    oracle = histogram_select(torch.stack([luminance(c) for c in colors]), b)
    vertical = vertical_select(colors, ref.color, sigma=2.0, init=oracle)

    def pick(choice: torch.Tensor) -> torch.Tensor:
        return colors.gather(0, choice[None, None].expand(1, *colors.shape[1:]))[0]

    def mse2(img: torch.Tensor) -> float:
        return float(blurred_mse(img, ref.color, 2.0, mask))

    white = sum(mse2(c) for c in colors) / K
    return {
        "scene": name,
        "spp": spp,
        "coherent": float(mask.double().mean()),
        "spread": block_spread(ref.color, colors[0] - ref.color, mask),
        "key_corr": key_error_correlation(colors[0], ref.color, mask),
        "oracle": mse2(pick(oracle)) / white,
        "vertical": mse2(pick(vertical)) / white,
    }


def main() -> None:
    """Print the diagnosis table for ``direct`` and ``indirect`` at 4, 16 and 64 spp."""
    torch.set_num_threads(1)
    print("| scene | spp | coherent | ref/err spread | key-error rank corr | oracle / white "
          "(sigma 2) | vertical / white (sigma 2) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name in ("direct", "indirect"):
        for spp in (4, 16, 64):
            d = diagnose(name, spp)
            print(
                f"| {name} | {spp} | {100 * d['coherent']:.0f} % | {d['spread']:.2f} | "
                f"{d['key_corr']:.2f} | {d['oracle']:.2f} | {d['vertical']:.2f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
