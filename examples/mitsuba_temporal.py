"""bnerr's temporal blue-noise strategy driving Mitsuba 3, against white noise.

Renders ``mitsuba_temporal.xml`` (a sphere on a floor under a small area light, 64 x 64) for a few
frames at 1 spp with two strategies, ``white`` (fresh random seeds every frame) and ``temporal``
(Heitz & Belcour 2019: each frame's seeds are the previous frame's, sorted against a blue-noise
mask and retargeted), both with Owen-scrambled Sobol sequences drawn through the ``"bnerr"``
Mitsuba sampler plugin, and prints the error ratios against a 1024-spp Mitsuba reference:

- raw MSE ratio: about 1 (the permutation moves the error around, it does not shrink it);
- sigma-1 blurred MSE ratio: below 1 (the error left is blue noise, which a blur removes).

Frame 0 is left out of the ratios: the temporal strategy sorts from frame 0 on, so its first
frame is still white noise. Run from the repository root (needs ``pip install '.[reference]'``)::

    python examples/mitsuba_temporal.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import torch

from bnerr.metrics import blurred_mse, mse, paired_ratio
from bnerr.strategies import make_strategy
from renderers.mitsuba_render import mitsuba_reference, mitsuba_render_fn, unavailable_reason

SCENE = Path(__file__).with_name("mitsuba_temporal.xml")
SPP, FRAMES, REFERENCE_SPP, SEED = 1, 16, 1024, 0


def main() -> int:
    reason = unavailable_reason("llvm_ad_rgb")
    if reason is not None:
        print(reason, file=sys.stderr)
        return 1
    torch.set_num_threads(1)
    start = time.perf_counter()
    render = mitsuba_render_fn(SCENE, spp=SPP)  # a RenderFn: render(seeds, sampler) -> Frame
    reference = mitsuba_reference(SCENE, spp=REFERENCE_SPP)
    errors: dict[str, dict[str, list[float]]] = {}
    for name in ("white", "temporal"):
        strategy = make_strategy(name, render.height, render.width, seed=SEED)
        errors[name] = {"mse": [], "blurred": []}
        for t in range(FRAMES):
            frame = strategy.frame(t, render)
            if t == 0:
                continue
            errors[name]["mse"].append(float(mse(frame.color, reference)))
            errors[name]["blurred"].append(float(blurred_mse(frame.color, reference, 1.0)))
    print(
        f"{SCENE.name}: {render.width}x{render.height}, {SPP} spp, frames 1..{FRAMES - 1}, "
        f"reference {REFERENCE_SPP} spp ({time.perf_counter() - start:.1f} s)"
    )
    for metric, label in (("mse", "raw MSE"), ("blurred", "sigma-1 blurred MSE")):
        ratio = paired_ratio(errors["temporal"][metric], errors["white"][metric])
        white = sum(errors["white"][metric]) / len(errors["white"][metric])
        print(
            f"  {label:20s} white {white:.3e}   temporal / white = {ratio.value:.3f} "
            f"[{ratio.lo:.3f}, {ratio.hi:.3f}]"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
