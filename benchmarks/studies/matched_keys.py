"""Do LDBN keys matched to a denoiser's measured kernel beat the generic ones after it?

``python -m benchmarks.studies.matched_keys --out DIR`` renders the static ``direct`` and
``indirect`` scenes at 128 x 128 and 4 spp with ``white``, ``ldbn``, ``ldbn_fast`` and
``ldbn_atrous`` (and any key set given with ``--keys NAME=PATH``, read like ``ldbn``), ``seeds``
seed sets x ``frames`` frames each, denoises every frame with the tuned a-trous filter, the U-Net
and OIDN (when ``pyoidn`` is installed), and writes ``DIR/matched.json`` and ``DIR/matched.md``:
each strategy's MSE to a ``ref_spp`` reference after each denoiser (and raw), as a paired ratio
(:func:`bnerr.metrics.paired_ratio`, paired by seed set) to white's and to ``ldbn``'s.

The finding it measures: docs/FINDINGS.md, "Flicker, matched keys, larger keys, the GPU",
"Keys matched to our denoisers do not beat generic ones" (the kernels themselves:
:mod:`benchmarks.studies.denoiser_kernels`); the tables are in docs/METHODS.md, section 10.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

import renderers
from benchmarks.studies.denoiser_kernels import tuned_denoise
from benchmarks.training_data import pixel_seeds
from bnerr.io import atomic_write
from bnerr.ldbn.keys import keys_from_array
from bnerr.metrics import paired_ratio
from bnerr.sequences import make_sampler
from bnerr.strategies import make_strategy
from bnerr.strategies.base import Strategy
from bnerr.strategies.ldbn import LDBNStrategy
from denoisers.oidn import available_denoisers

__all__ = ["compare", "main", "ratio_table"]

_STRATEGIES = ("white", "ldbn", "ldbn_fast", "ldbn_atrous")


def _strategy(name: str, size: int, seed: int, spp: int, keys: dict[str, Path]) -> Strategy:
    if name not in keys:
        return make_strategy(name, size, size, seed=seed, spp=spp)
    loaded = keys_from_array(np.load(keys[name]), str(keys[name]))[0]  # D from the table
    return LDBNStrategy(size, size, seed=seed, keys=[loaded], spp=spp)


def compare(
    scene: str,
    strategies: Sequence[str],
    denoisers: Sequence[str],
    keys: dict[str, Path],
    size: int = 128,
    spp: int = 4,
    seeds: int = 8,
    frames: int = 4,
    ref_spp: int = 2048,
) -> dict[str, dict[str, list[list[float]]]]:
    """``{denoiser or "raw": {strategy: mse [seeds][frames]}}`` on the static ``scene``."""
    scene_obj = renderers.get_scene(scene, animated=False)
    ref = renderers.render(
        scene_obj, 0, pixel_seeds(size, size, 99), make_sampler("owen_sobol"), ref_spp
    ).color
    run = {d: tuned_denoise(d, scene, spp) for d in denoisers}
    out: dict[str, dict[str, list[list[float]]]] = {d: {} for d in ("raw", *denoisers)}
    for name in strategies:
        for d in out:
            out[d][name] = [[] for _ in range(seeds)]
        for s in range(seeds):
            strategy = _strategy(name, size, 1 + s, spp, keys)
            for t in range(frames):
                frame = strategy.frame(
                    t, lambda sd, smp: renderers.render(scene_obj, 0, sd, smp, spp)
                )
                out["raw"][name][s].append(float(((frame.color - ref) ** 2).mean()))
                for d, denoise in run.items():
                    out[d][name][s].append(float(((denoise(frame) - ref) ** 2).mean()))
    return out


def ratio_table(results: dict[str, dict[str, dict[str, list[list[float]]]]]) -> list[dict]:
    """One row per (scene, denoiser, strategy): its paired ratio to white's and to ldbn's."""
    rows = []
    for scene, by_denoiser in results.items():
        for denoiser, by_strategy in by_denoiser.items():
            for name, values in by_strategy.items():
                row: dict = {"scene": scene, "denoiser": denoiser, "strategy": name}
                for base in ("white", "ldbn"):
                    if base in by_strategy and base != name:
                        e = paired_ratio(np.array(values), np.array(by_strategy[base]))
                        row[f"vs_{base}"] = [e.value, e.lo, e.hi]
                rows.append(row)
    return rows


def _markdown(rows: list[dict]) -> str:
    def cell(v: list[float] | None) -> str:
        return "" if v is None else f"{v[0]:.3f} [{v[1]:.3f}, {v[2]:.3f}]"

    lines = [
        "| scene | denoiser | strategy | MSE / white's | MSE / ldbn's |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['denoiser']} | {r['strategy']} | "
            f"{cell(r.get('vs_white'))} | {cell(r.get('vs_ldbn'))} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.studies.matched_keys", description=__doc__
    )
    parser.add_argument("--scenes", nargs="+", default=["direct", "indirect"])
    parser.add_argument("--denoisers", nargs="+", default=["atrous", "unet", "oidn"])
    parser.add_argument("--keys", nargs="*", default=[], help="NAME=PATH: a key set read like ldbn")
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--ref-spp", type=int, default=2048)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)

    keys = {k: Path(v) for k, v in (item.split("=", 1) for item in args.keys)}
    names = [*_STRATEGIES, *keys]
    results = {
        scene: compare(
            scene,
            names,
            available_denoisers(args.denoisers),
            keys,
            args.size,
            4,
            args.seeds,
            args.frames,
            args.ref_spp,
        )
        for scene in args.scenes
    }
    rows = ratio_table(results)
    args.out.mkdir(parents=True, exist_ok=True)
    for path, text in (
        (args.out / "matched.json", json.dumps({"mse": results, "ratios": rows})),
        (args.out / "matched.md", _markdown(rows)),
    ):
        with atomic_write(path) as tmp:
            Path(tmp).write_text(text)
    print(_markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
