"""Does the pixel jitter take the a-priori samplers' blue noise away at high spp? Measured by
rendering with the jitter fixed.

A pixel's radiance integrates its jitter (dimensions 0-1) and the later pairs together; keys
that arrange each pair on its own leave the pairs' interaction unshaped (docs/METHODS.md,
section 10). :class:`FixedJitter` wraps a sampler and pins dimensions 0-1 at the pixel centre, so
the later pairs alone decide the pixel's error; :func:`measure` renders a scene with each
strategy's sampler both ways (``white`` first, the reference at ``ref_spp`` with the same jitter
rule) and gives the raw MSE and the MSE after a sigma-2 blur as ratios to white's, each with its
95 % paired t-interval over the seed sets (:func:`bnerr.metrics.paired_ratio`). If the jitter
were what the keys lose at high spp, the blurred ratio would fall with the jitter fixed.

``python -m benchmarks.studies.jitter_loss`` prints the table for ``direct`` and ``indirect`` at
128 x 128, 4 / 16 / 64 spp, 8 seed sets, frame 6 (a diagnosis: nothing is written under
``results/``).

The finding it measures: docs/FINDINGS.md, "Flicker, matched keys, larger keys, the GPU",
"Keys over a Z-ordered global sequence" (on ``direct`` pinning the jitter gains nothing at 16-64
spp); the table is in docs/METHODS.md, section 10.

Not for: the benchmark's tables (:mod:`benchmarks.reports`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass

import torch

import renderers
from benchmarks.studies.snooker_raw_mse import Context, Draw, capture
from bnerr.color import luminance
from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.metrics import Estimate, blurred_mse, paired_ratio
from bnerr.sequences import Sampler, make_sampler
from bnerr.strategies import make_strategy, pixel_seeds

__all__ = ["FixedJitter", "Row", "main", "measure"]

#: The strategies of the default table: the a-priori samplers that keep most past 16 spp.
STRATEGIES = ("ldbn_zorder", "ldbn128", "zsobol")


class FixedJitter(Sampler):
    """``inner``'s values with dimensions 0-1 (the pixel jitter) pinned at 0.5."""

    needs_pixel = True

    def __init__(self, inner: Sampler) -> None:
        self.inner = inner

    def _sample(
        self,
        seed: torch.Tensor,
        index: torch.Tensor,
        dim: int,
        count: int,
        pixel: torch.Tensor | None,
    ) -> torch.Tensor:
        out = self.inner.sample(seed, index, dim, count, pixel).clone()  # [N, count]
        out[:, : max(2 - dim, 0)] = 0.5  # the columns of dims dim .. 1, none from dim 2 on
        return out

    def __repr__(self) -> str:
        return f"FixedJitter({self.inner!r})"


@dataclass(frozen=True)
class Row:
    """One strategy at one spp, jitter free or fixed: its raw and sigma-2 blurred MSE over
    white's, each a paired ratio with its 95 % interval over the seed sets."""

    strategy: str
    spp: int
    fixed: bool
    raw: Estimate
    blurred: Estimate


def _draw(name: str, ctx: Context, s: int) -> Draw:
    strategy = make_strategy(name, ctx.size, ctx.size, seed=s, spp=ctx.spp)
    return capture(strategy, ctx)


def _errors(
    scene: renderers.Scene,
    names: Sequence[str],
    ctx: Context,
    sets: int,
    fixed: bool,
    ref: torch.Tensor,
) -> dict[str, torch.Tensor]:
    """``{name: [S, 2]}`` each seed set's raw and blurred MSE."""
    out = {}
    for name in names:
        rows = []
        for s in range(sets):
            seeds, sampler = _draw(name, ctx, s)
            sampler = FixedJitter(sampler) if fixed else sampler
            frame = renderers.render(scene, ctx.t, seeds, sampler, ctx.spp)
            lum = luminance(frame.color, dtype=torch.float64)[None]
            rows.append([float((lum - ref).square().mean()), float(blurred_mse(lum, ref, 2.0))])
        out[name] = torch.tensor(rows, dtype=torch.float64)
    return out


def measure(
    scene_name: str,
    strategies: Sequence[str] = STRATEGIES,
    spps: Sequence[int] = (4, 16, 64),
    *,
    size: int = 128,
    sets: int = 8,
    t: int = 6,
    ref_spp: int = 1024,
) -> list[Row]:
    """Frame ``t`` of the animated scene with each strategy, jitter free then fixed, at each spp
    of ``spps``, seed sets ``0 .. sets - 1``, against a ``ref_spp`` Owen-Sobol reference made
    with the same jitter rule."""
    checks = [(size, "size", 1), (sets, "sets", 2), (ref_spp, "ref_spp", 1)]
    for value, what, least in checks + [(spp, "spp", 1) for spp in spps]:
        check_positive_int(value, what, minimum=least)
    if "white" in strategies:
        raise ValueRangeError("strategies: expected the ones compared with white, got 'white'")
    scene = renderers.get_scene(scene_name, animated=True)
    rows = []
    for fixed in (False, True):
        wrap = FixedJitter if fixed else (lambda sampler: sampler)
        seeds = pixel_seeds(size, size, 0x5EED)
        frame = renderers.render(scene, t, seeds, wrap(make_sampler("owen_sobol")), ref_spp)
        ref = luminance(frame.color, dtype=torch.float64)[None]
        for spp in spps:
            ctx = Context(size, spp, t, scene.layout)
            errs = _errors(scene, ("white", *strategies), ctx, sets, fixed, ref)
            white = errs["white"]
            for name in strategies:  # [S, 1]: one frame per seed set
                raw, blurred = (
                    paired_ratio(errs[name][:, k : k + 1], white[:, k : k + 1]) for k in (0, 1)
                )
                rows.append(Row(name, spp, fixed, raw, blurred))
    return rows


def main(argv: list[str] | None = None) -> None:
    """Print the table (markdown) for the scenes asked."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.studies.jitter_loss")
    parser.add_argument("--scenes", nargs="+", default=["direct", "indirect"])
    parser.add_argument("--strategies", nargs="+", default=list(STRATEGIES))
    parser.add_argument("--spp", nargs="+", type=int, default=[4, 16, 64])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--sets", type=int, default=8)
    args = parser.parse_args(argv)
    print(
        "| scene | strategy | spp | blurred MSE / white, jitter free | jitter fixed | "
        "raw MSE / white, free / fixed |"
    )
    print("|---|---|---|---|---|---|")
    for scene in args.scenes:
        rows = measure(scene, args.strategies, args.spp, size=args.size, sets=args.sets)
        cells = {(r.strategy, r.spp, r.fixed): r for r in rows}
        for name in args.strategies:
            for spp in args.spp:
                free, pinned = cells[(name, spp, False)], cells[(name, spp, True)]
                print(
                    f"| {scene} | {name} | {spp} | {_ratio(free.blurred)} | "
                    f"{_ratio(pinned.blurred)} | {_ratio(free.raw)} / {_ratio(pinned.raw)} |",
                    flush=True,
                )


def _ratio(e: Estimate) -> str:
    return f"{e.value:.2f} [{e.lo:.2f}, {e.hi:.2f}]"


if __name__ == "__main__":
    main()
