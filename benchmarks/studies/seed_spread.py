"""Why a scene's seed sets disagree: the error its directly visible lights hold.

The quality suite's verdicts on the Cornell box stay open at 32 seed sets because its seed sets
disagree three times more than the other scenes' (the spread of their log ratios to white). This
diagnosis finds where that spread lives. It renders seed sets of white and one rival in a scene
of the quality suite, at the suite's settings (its frames, its references, its denoisers with
the parameters tuned in ``results/quality``), and splits each seed set's pooled post-denoise
squared error between the pixels next to a directly visible light (:func:`bnerr.metrics.light_mask`:
the reference's first hit is a light, grown by ``grow`` pixels) and the rest:

- ``share``: the fraction of white's squared error in the light's pixels;
- ``spread``: the standard deviation over seed sets of ``log(rival MSE / white MSE)``, over every
  pixel and over the rest (what the verdict's interval is made of, :mod:`bnerr.metrics.power`).

``python -m benchmarks.studies.seed_spread`` (its defaults: ``--scene cornell --spp 4 --rival
cycles_blue --seed-sets 16``) prints both per denoiser (a diagnosis: nothing is written under
``results/``).

The finding it measures: docs/FINDINGS.md, "Which strategy to use", "Why the Cornell box's seed
sets disagree: its light's silhouette".

Not for: the verdicts themselves (:mod:`benchmarks.reports.decision`) or a scene without a
directly visible light (then the light's pixels are empty and the rest is every pixel).
"""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.metrics import light_mask, paired_ratio

if TYPE_CHECKING:
    from benchmarks.sweep.measure import References
    from benchmarks.sweep.parts import Denoiser, Parts, Scene
    from benchmarks.sweep.plan import Run

__all__ = ["log_ratio_spread", "seed_set_errors"]


def seed_set_errors(errors: Sequence[torch.Tensor], mask: torch.Tensor) -> tuple[float, float]:
    """One seed set's pooled MSE over its frames' squared errors ``[3, H, W]`` (float64 sums):
    over every pixel, and over the pixels outside ``mask [H, W]``."""
    if not errors:
        raise ValueRangeError("errors: expected at least one frame, got none")
    total = sum(float(e.sum(dtype=torch.float64)) for e in errors)
    rest = sum(float(e[:, ~mask].sum(dtype=torch.float64)) for e in errors)
    pixels = errors[0].shape[0] * errors[0].shape[1] * errors[0].shape[2]
    kept = errors[0].shape[0] * int((~mask).sum())
    if kept == 0:
        raise ValueRangeError("mask: expected some pixels outside it, got every pixel")
    return total / (len(errors) * pixels), rest / (len(errors) * kept)


def log_ratio_spread(values: Sequence[float], baseline: Sequence[float]) -> float:
    """The sample standard deviation of ``log(values[s] / baseline[s])`` over seed sets s."""
    if len(values) != len(baseline) or len(values) < 2:
        raise ValueRangeError(
            f"values, baseline: expected two equal lists of at least 2 seed sets, got "
            f"{len(values)} and {len(baseline)}"
        )
    logs = [math.log(v / b) for v, b in zip(values, baseline, strict=True)]
    mean = sum(logs) / len(logs)
    return math.sqrt(sum((x - mean) ** 2 for x in logs) / (len(logs) - 1))


def _errors(
    run: Run,
    parts: Parts,
    refs: References,
    denoisers: dict[str, Denoiser],
    group: int,
    scene: Scene,
) -> dict[str, list[torch.Tensor]]:
    """Per denoiser (and ``raw``): the squared error of each measured frame of seed set
    ``group`` of ``run`` (a stateless strategy; the stateful denoisers see the warmup frames)."""
    from benchmarks.sweep.measure import (
        denoise_frame,
        feed_stateful,
        is_stateful,
        reset_stateful,
        t_reference,
    )
    from benchmarks.sweep.parts import BoundRender
    from bnerr.strategies import play

    strategy = parts.make_strategy(
        run.strategy, scene, run.height, run.width, group, run.sampler, run.spp
    )
    in_order = strategy.stateful or any(is_stateful(d) for d in denoisers.values())
    shown = range(run.warmup, run.warmup + run.frames)
    out: dict[str, list[torch.Tensor]] = {"raw": [], **{name: [] for name in denoisers}}
    render_at = functools.partial(BoundRender, parts, scene, run.spp)
    reset_stateful(denoisers.values())
    for t, frame in play(strategy, render_at, shown, max(run.motion, 1), in_order=in_order):
        if t < run.warmup:
            feed_stateful(denoisers.values(), t, frame)
            continue
        images = {name: denoise_frame(d, frame, t) for name, d in denoisers.items()}
        ref = refs.get(run, scene, t_reference(run, t)).color
        out["raw"].append((frame.color - ref).double() ** 2)
        for name, image in images.items():
            out[name].append((image - ref).double() ** 2)
    return out


def _measure(args: argparse.Namespace) -> None:
    from benchmarks.suites import get_suite
    from benchmarks.sweep.measure import scene_for, t_reference
    from benchmarks.sweep.parts import real_parts
    from benchmarks.sweep.plan import plan
    from benchmarks.sweep.references import ReferenceCache
    from benchmarks.sweep.runner import TUNED_PARAMS_FILE, load_params
    from benchmarks.sweep.tuning import tune_denoisers

    torch.set_num_threads(1)
    runs: dict = {}
    for r in plan(get_suite("quality")):
        if r.scene == args.scene and r.spp == args.spp and r.strategy in ("white", args.rival):
            runs.setdefault(r.strategy, r)
    if set(runs) != {"white", args.rival}:
        raise ValueRangeError(
            f"--scene/--spp/--rival: expected a run of the quality suite for white and "
            f"{args.rival} on {args.scene} at {args.spp} spp, got {sorted(runs)}"
        )
    parts = real_parts()
    refs = ReferenceCache(args.cache, parts)
    store = load_params(Path(args.results) / TUNED_PARAMS_FILE)
    white = runs["white"]
    scene = scene_for(white, parts)
    ref = refs.get(white, scene, t_reference(white, white.warmup))
    if ref.object_id is None:
        raise ValueRangeError(f"{args.scene}: expected a reference with an object_id buffer")
    # a scene that renders itself (Mitsuba XML) names no lights here: then no pixel is the light's
    mask = light_mask(ref.object_id, getattr(scene, "lights", ()), args.grow)
    per: dict[str, dict[str, list[tuple[float, float]]]] = {"white": {}, args.rival: {}}
    for name, run in runs.items():
        denoisers = {
            k: v for k, v in tune_denoisers(run, parts, refs, store).items() if k in args.denoisers
        }
        for group in range(args.seed_sets):
            for den, errs in _errors(run, parts, refs, denoisers, group, scene).items():
                per[name].setdefault(den, []).append(seed_set_errors(errs, mask))
    _print(args, mask, per)


def _print(args: argparse.Namespace, mask: torch.Tensor, per: dict) -> None:
    print(
        f"{args.scene}, {args.spp} spp, {args.seed_sets} seed sets: {int(mask.sum())} of "
        f"{mask.numel()} pixels next to a visible light (grow {args.grow})"
    )
    print(
        f"| denoiser | light's share of white's error | spread, every pixel | spread, the rest | "
        f"{args.rival} / white, every pixel | the rest |"
    )
    print("|---|---|---|---|---|---|")
    for den, whites in per["white"].items():
        rival = per[args.rival][den]
        rest = (mask.numel() - int(mask.sum())) / mask.numel()  # the rest's share of the pixels
        share = sum(1 - r * rest / a for a, r in whites) / len(whites)
        all_spread = log_ratio_spread([a for a, _ in rival], [a for a, _ in whites])
        rest_spread = log_ratio_spread([r for _, r in rival], [r for _, r in whites])
        ratios = [
            paired_ratio(torch.tensor(mine)[:, None], torch.tensor(base)[:, None])
            for mine, base in (
                ([a for a, _ in rival], [a for a, _ in whites]),
                ([r for _, r in rival], [r for _, r in whites]),
            )
        ]
        said = " | ".join(f"{e.value:.3f} [{e.lo:.3f}, {e.hi:.3f}]" for e in ratios)
        print(f"| {den} | {share:.2f} | {all_spread:.3f} | {rest_spread:.3f} | {said} |")


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="cornell")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--rival", default="cycles_blue")
    parser.add_argument("--seed-sets", type=int, default=16)
    parser.add_argument("--grow", type=int, default=1)
    parser.add_argument("--denoisers", nargs="+", default=["gaussian", "oidn", "taa"])
    parser.add_argument("--results", default="results/quality")
    parser.add_argument("--cache", default="cache/references")
    args = parser.parse_args(argv)
    check_positive_int(args.seed_sets, "--seed-sets", minimum=2)
    _measure(args)


if __name__ == "__main__":
    main()
