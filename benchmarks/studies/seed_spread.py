"""Why a scene's seed sets disagree: the error a few pixels hold.

The quality suite's verdicts on the Cornell box stay open at 32 seed sets because its seed sets
disagree three times more than the other scenes' (the spread of their log ratios to white), and
the Cycles suite's product shot stays open for the same reason. This diagnosis finds where that
spread lives. It renders seed sets of white and one rival in a scene of a suite, at the suite's
settings (its frames, its references, its denoisers with the parameters tuned in its results),
and splits each seed set's pooled post-denoise squared error between a region of each frame and
the rest. The region (``--mask``) is either the pixels next to a directly visible light
(``light``, :func:`bnerr.metrics.light_mask`: the reference's first hit is a light) or the
pixels a display clips (``highlights``, :func:`bnerr.metrics.highlight_mask`: the reference
brighter than Filmic's or AgX's white with the frame's mean at mid-grey), grown by ``--grow``
pixels. Per denoiser (and raw) it prints:

- ``share``: the fraction of white's squared error in the region;
- ``top``: the fraction of white's squared error in its ``--top`` worst pixels;
- ``spread``: the standard deviation over seed sets of ``log(rival MSE / white MSE)``, over every
  pixel and over the rest (what the verdict's interval is made of, :mod:`bnerr.metrics.power`);
- the rival's MSE as a fraction of white's, with its paired interval, over every pixel and over
  the rest, and the range of the seed sets' own ratios.

``python -m benchmarks.studies.seed_spread`` (its defaults: ``--scene cornell --spp 4 --rival
cycles_blue --seed-sets 16``) measures the Cornell box's light; ``python -m
benchmarks.studies.seed_spread --suite cycles --scene cycles_product --rival blue_noise --mask
highlights --denoisers cycles_oidn oidn gaussian`` the product shot's highlights. A diagnosis:
nothing is written under ``results/`` (the references go to the suite's cache).

The findings it measures: docs/FINDINGS.md, "Which strategy to use", "Why the Cornell box's seed
sets disagree: its light's silhouette", and "Blender Cycles as it ships", the product shot.

Not for: the verdicts themselves (:mod:`benchmarks.reports.decision`).
"""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.metrics import highlight_mask, light_mask, paired_ratio

if TYPE_CHECKING:
    from benchmarks.sweep.measure import References
    from benchmarks.sweep.parts import Denoiser, Parts, Scene
    from benchmarks.sweep.plan import Run
    from bnerr.frame import Frame

__all__ = ["log_ratio_spread", "seed_set_errors", "top_share"]


def seed_set_errors(
    errors: Sequence[torch.Tensor], masks: Sequence[torch.Tensor]
) -> tuple[float, float, float]:
    """One seed set's pooled errors over its frames' squared errors ``[3, H, W]`` (float64 sums),
    each frame with its region ``masks[t] [H, W]``: the MSE over every pixel, the MSE over the
    pixels outside the regions, and the regions' share of the squared error."""
    if not errors or len(masks) != len(errors):
        raise ValueRangeError(
            f"errors, masks: expected one mask per frame and at least one frame, got "
            f"{len(errors)} frames and {len(masks)} masks"
        )
    total = sum(float(e.sum(dtype=torch.float64)) for e in errors)
    rest = sum(float(e[:, ~m].sum(dtype=torch.float64)) for e, m in zip(errors, masks, strict=True))
    kept = sum(errors[0].shape[0] * int((~m).sum()) for m in masks)
    if kept == 0:
        raise ValueRangeError("masks: expected some pixels outside them, got every pixel")
    pixels = len(errors) * errors[0].numel()
    return total / pixels, rest / kept, 1.0 - rest / total if total > 0 else 0.0


def top_share(errors: Sequence[torch.Tensor], k: int) -> float:
    """The fraction of a seed set's pooled squared error (``[3, H, W]`` frames) held by its ``k``
    worst pixels (pixels of every frame ranked together by their error summed over channels)."""
    check_positive_int(k, "k")
    per_pixel = torch.cat([e.sum(dim=0, dtype=torch.float64).flatten() for e in errors])
    total = float(per_pixel.sum())
    return float(per_pixel.topk(min(k, per_pixel.numel())).values.sum()) / total if total else 0.0


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
    region: Callable[[Frame], torch.Tensor],
) -> tuple[dict[str, list[torch.Tensor]], list[torch.Tensor]]:
    """Per denoiser (and ``raw``): the squared error of each measured frame of seed set
    ``group`` of ``run`` (the stateful denoisers see the warmup frames), and each measured
    frame's region (``region`` of its reference)."""
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
    masks: list[torch.Tensor] = []
    render_at = functools.partial(BoundRender, parts, scene, run.spp)
    reset_stateful(denoisers.values())
    for t, frame in play(strategy, render_at, shown, max(run.motion, 1), in_order=in_order):
        if t < run.warmup:
            feed_stateful(denoisers.values(), t, frame)
            continue
        images = {name: denoise_frame(d, frame, t) for name, d in denoisers.items()}
        ref = refs.get(run, scene, t_reference(run, t))
        masks.append(region(ref))
        out["raw"].append((frame.color - ref.color).double() ** 2)
        for name, image in images.items():
            out[name].append((image - ref.color).double() ** 2)
    return out, masks


def _region(args: argparse.Namespace, scene: Scene) -> Callable[[Frame], torch.Tensor]:
    """``--mask`` as a function of a reference frame."""
    if args.mask == "highlights":
        return lambda ref: highlight_mask(ref.color, radius=args.grow)
    # a scene that renders itself (Mitsuba XML) names no lights here: then no pixel is the light's
    lights = getattr(scene, "lights", ())

    def light(ref: Frame) -> torch.Tensor:
        if ref.object_id is None:
            raise ValueRangeError(f"{args.scene}: expected a reference with an object_id buffer")
        return light_mask(ref.object_id, lights, args.grow)

    return light


def _runs(args: argparse.Namespace) -> dict[str, Run]:
    """The suite's first run of white and of the rival on the scene at the spp."""
    from benchmarks.suites import get_suite
    from benchmarks.sweep.plan import plan

    runs: dict[str, Run] = {}
    for r in plan(get_suite(args.suite)):
        if r.scene == args.scene and r.spp == args.spp and r.strategy in ("white", args.rival):
            runs.setdefault(r.strategy, r)
    if set(runs) != {"white", args.rival}:
        raise ValueRangeError(
            f"--scene/--spp/--rival: expected a run of the {args.suite} suite for white and "
            f"{args.rival} on {args.scene} at {args.spp} spp, got {sorted(runs)}"
        )
    return runs


def _measure(args: argparse.Namespace) -> None:
    from benchmarks.sweep.measure import scene_for
    from benchmarks.sweep.parts import real_parts
    from benchmarks.sweep.references import ReferenceCache
    from benchmarks.sweep.runner import TUNED_PARAMS_FILE, load_params
    from benchmarks.sweep.tuning import tune_denoisers

    torch.set_num_threads(1)
    runs = _runs(args)
    parts = real_parts()
    refs = ReferenceCache(args.cache, parts)
    store = load_params(Path(args.results or f"results/{args.suite}") / TUNED_PARAMS_FILE)
    scenes = {name: scene_for(run, parts) for name, run in runs.items()}
    region = _region(args, scenes["white"])
    per: dict[str, dict[str, list[tuple[float, float, float, float]]]] = {}
    pixels: list[int] = []
    for name, run in runs.items():
        tuned = tune_denoisers(run, parts, refs, store)
        denoisers = {k: v for k, v in tuned.items() if k in args.denoisers}
        for group in range(args.seed_sets):
            errors, masks = _errors(run, parts, refs, denoisers, group, scenes[name], region)
            pixels = [int(m.sum()) for m in masks]
            for den, errs in errors.items():
                row = (*seed_set_errors(errs, masks), top_share(errs, args.top))
                per.setdefault(name, {}).setdefault(den, []).append(row)
    _print(args, pixels, per)


def _print(args: argparse.Namespace, pixels: list[int], per: dict) -> None:
    print(
        f"{args.scene}, {args.spp} spp, {args.seed_sets} seed sets: {pixels} pixels of each "
        f"measured frame in the region ({args.mask}, grow {args.grow})"
    )
    print(
        f"| denoiser | region's share of white's error | its {args.top} worst pixels' share | "
        f"spread, every pixel | spread, the rest | {args.rival} / white, every pixel | "
        f"seed sets' range | the rest | seed sets' range |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for den, whites in per["white"].items():
        rival = per[args.rival][den]
        share = sum(w[2] for w in whites) / len(whites)
        top = sum(w[3] for w in whites) / len(whites)
        cols = [f"{share:.3f}", f"{top:.3f}"]
        pairs = [([r[i] for r in rival], [w[i] for w in whites]) for i in (0, 1)]
        cols += [f"{log_ratio_spread(mine, base):.3f}" for mine, base in pairs]
        for mine, base in pairs:
            e = paired_ratio(torch.tensor(mine)[:, None], torch.tensor(base)[:, None])
            each = [m / b for m, b in zip(mine, base, strict=True)]
            cols += [f"{e.value:.3f} [{e.lo:.3f}, {e.hi:.3f}]", f"{min(each):.2f}-{max(each):.2f}"]
        print(f"| {den} | " + " | ".join(cols) + " |")


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", default="quality", help="the suite whose runs are measured")
    parser.add_argument("--scene", default="cornell")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--rival", default="cycles_blue")
    parser.add_argument("--seed-sets", type=int, default=16)
    parser.add_argument("--mask", choices=("light", "highlights"), default="light")
    parser.add_argument("--grow", type=int, default=1)
    parser.add_argument("--top", type=int, default=10, help="the worst pixels whose share is shown")
    parser.add_argument("--denoisers", nargs="+", default=["gaussian", "oidn", "taa"])
    parser.add_argument("--results", default=None, help="tuned parameters: results/SUITE")
    parser.add_argument("--cache", default="cache/references")
    args = parser.parse_args(argv)
    check_positive_int(args.seed_sets, "--seed-sets", minimum=2)
    check_positive_int(args.top, "--top")
    _measure(args)


if __name__ == "__main__":
    main()
