"""Time the samplers: ``python -m benchmarks.speed.sequences``.

Each sampler fills ``count`` dimensions for ``n`` lanes (distinct seeds, 64 sample indices, pixels
of a 1024-wide image), the way the renderer calls it. One warm-up call (tables, allocations),
then ``repeats`` calls; the median is reported as seconds per call and values per second.
``bnds`` uses a random 8-channel 64 x 64 mask: its first 8 dimensions are rotated, the rest are
white noise; ``ldbn`` random 64 x 64 key tiles for 8 dimensions (level 64 spp), the rest the
pixel's own Owen-Sobol. The Z-order samplers (``zsobol``, ``zsobol_t``, ``cycles_*``) read the
lane's seed as the pixel's key, built for a film 1024 wide and 64 spp.

The render figure (:func:`measure_render`) is what the goal of issue 27 is stated in: each
sampler drives an eager ``renderers.render`` of the Cornell box (128 x 128, 16 spp) with the seed
image its strategy uses (Morton keys for the Z-order samplers, Cycles' scrambled keys for its
patterns, the shipped screen-space keys for ``ldbn`` and the Z-ordered ones for ``ldbn_zorder``,
a constant image and frame 3 for OpenQMC's two samplers, random seeds for the others); the renders
take turns, so every sampler sees the same load, and the ratio is over per-pixel
``owen_sobol``'s time (goal: at most 1.2x).

Timings depend on the machine, on the number of torch threads and on what else runs on it;
report them with the machine.
"""

from __future__ import annotations

import argparse
import inspect
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

import torch

from benchmarks.reports.markdown import table_lines
from benchmarks.speed.formatting import fmt, get, number, ratio
from bnerr.sequences import SAMPLERS, LDBNKeys, cycles_keys, make_sampler, zsobol_keys
from bnerr.strategies import make_strategy
from bnerr.strategies.ldbn import LDBNStrategy
from bnerr.timing import Stopwatch, sync

__all__ = ["table", "main", "measure", "measure_render", "measure_samples"]

#: The samplers of the render figure, in the order of the table.
RENDERED = (
    *("white", "owen_sobol", "zsobol", "zsobol_t", "cycles_pure", "cycles_first", "ldbn"),
    *("ldbn_zorder", "openqmc_sobolbn", "openqmc_latticebn"),
)
#: The render figure's goal: at most this times per-pixel Owen-Sobol's render time.
RENDER_GOAL = 1.2


def _lanes(n: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    lane = torch.arange(n, dtype=torch.int64, device=device)
    seed = (lane // 64) * 2654435761 % 2**32  # one seed per pixel, 64 samples each
    index = lane % 64
    pixel = torch.stack([(lane // 64) // 1024, (lane // 64) % 1024], dim=1)
    return seed, index, pixel


def _ldbn_strategy(size: int, spp: int, name: str = "ldbn") -> LDBNStrategy:
    strategy = make_strategy(name, size, size, seed=0, spp=spp)
    assert isinstance(strategy, LDBNStrategy)  # the classes registered as "ldbn", "ldbn_*"
    return strategy


def _ldbn_keys() -> LDBNKeys:
    """Random 64 x 64 key tiles for 8 dimensions and levels 1 .. 64 spp."""
    gen = torch.Generator().manual_seed(0)
    scramble = torch.randint(0, 1 << 24, (7, 64, 64, 8), generator=gen, dtype=torch.int32)
    rank = torch.stack([torch.randint(0, 1 << lv, (64, 64, 4), generator=gen) for lv in range(7)])
    return LDBNKeys(scramble, rank.to(torch.int32))


def measure() -> dict[str, Any]:
    """Median seconds per sampler call (``sample``: ``{name: {count: s}}``) and per eager render
    driven by each sampler (``render``: ``{name: s}``, the Cornell box at 128 x 128, 16 spp)."""
    return {"sample": measure_samples(), "render": measure_render()}


def _render_setups(size: int, spp: int) -> dict[str, tuple[Any, torch.Tensor]]:
    """Each rendered sampler with the seed image its strategy gives it."""
    seeds = torch.randint(0, 2**32, (size, size), generator=torch.Generator().manual_seed(0))
    film = {"width": size, "height": size, "spp": spp}
    morton = zsobol_keys(size, size)
    return {
        "white": (make_sampler("white"), seeds),
        "owen_sobol": (make_sampler("owen_sobol"), seeds),
        "zsobol": (make_sampler("zsobol", **film), morton),
        "zsobol_t": (make_sampler("zsobol_t", **film, frame=3), morton),
        "cycles_pure": (make_sampler("cycles_pure", spp=spp), cycles_keys(size, size)),
        "cycles_first": (make_sampler("cycles_first", spp=spp), cycles_keys(size, size)),
        "ldbn": (_ldbn_strategy(size, spp).sampler(0), seeds),
        "ldbn_zorder": (_ldbn_strategy(size, spp, "ldbn_zorder").sampler(0), seeds),
        # OpenQMC's strategies pass a constant seed image (not read) and a frame number
        "openqmc_sobolbn": (make_sampler("openqmc_sobolbn", frame=3), torch.zeros_like(seeds)),
        "openqmc_latticebn": (make_sampler("openqmc_latticebn", frame=3), torch.zeros_like(seeds)),
    }


def measure_render(size: int = 128, spp: int = 16, repeats: int = 3) -> dict[str, float]:
    """Median seconds of an eager Cornell-box render driven by each of :data:`RENDERED`, the
    renders taking turns (one warm-up each first)."""
    from renderers import get_scene, render

    scene = get_scene("cornell")
    setups = _render_setups(size, spp)
    times: dict[str, list[float]] = {name: [] for name in setups}
    for round_ in range(repeats + 1):
        for name, (sampler, seeds) in setups.items():
            watch = Stopwatch()
            render(scene, 0, seeds, sampler, spp, compile=False)
            if round_:
                times[name].append(watch.ms(torch.device("cpu")) / 1e3)
    return {name: statistics.median(values) for name, values in times.items()}


def measure_samples(
    names: Sequence[str] | None = None,
    n: int = 1 << 20,
    counts: Sequence[int] = (2, 8),
    repeats: int = 5,
    device: str | torch.device = "cpu",
) -> dict[str, dict[int, float]]:
    """Median seconds per ``sample(seed, index, 0, count, pixel)`` call with ``n`` lanes.

    Returns ``{sampler name: {count: seconds}}``; values per second is ``n * count / seconds``.
    """
    device = torch.device(device)
    seed, index, pixel = _lanes(n, device)
    mask = torch.rand(8, 64, 64, generator=torch.Generator().manual_seed(0)).to(device)
    film: dict[str, object] = {"width": 1024, "height": max(n // 64 // 1024, 1), "spp": 64}
    options: dict[str, dict[str, object]] = {
        "bnds": {"mask": mask, "offset": (3, 7), "seed0": 1},
        "zsobol": film,
        "zsobol_t": {**film, "frame": 3},
        "cycles_pure": {"spp": 64},
        "cycles_first": {"spp": 64},
        "ldbn": {"keys": _ldbn_keys(), "spp": 64},
        "ldbn_keyed": {"keys": _ldbn_keys(), "spp": 64},
    }
    results: dict[str, dict[int, float]] = {}
    for name in names if names is not None else sorted(SAMPLERS):
        sampler = make_sampler(name, **options.get(name, {}))
        results[name] = {}
        for count in counts:
            sampler.sample(seed, index, 0, count, pixel)  # warm-up
            times = []
            for _ in range(repeats):
                sync(device)
                watch = Stopwatch()
                sampler.sample(seed, index, 0, count, pixel)
                times.append(watch.ms(device) / 1e3)
            results[name][count] = statistics.median(times)
    return results


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The samplers against independent white values, then in a render against Owen-Sobol."""
    samples = values.get("sample", values) if "render" in values else values
    lines = _sample_table(samples)
    render = values.get("render")
    if isinstance(render, Mapping):
        lines += _render_table(render)
    return lines


def _sample_table(values: Mapping[str, Any]) -> list[str]:
    lanes = inspect.signature(measure_samples).parameters["n"].default
    counts = sorted(
        {c for row in values.values() if isinstance(row, Mapping) for c in row}, key=int
    )
    lines = [
        "## Samplers against independent values (`speed.sequences`)",
        "",
        f"Median milliseconds per `sample(seed, index, 0, count, pixel)` call for {lanes:,} "
        "lanes (pixel samples) with `count` dimensions each; Mvalues/s = lanes x count / time; "
        "ratio: the sampler's time over `white`'s (independent hashed values) at the same count.",
        "",
    ]
    header = ["sampler"]
    for c in counts:
        header += [f"ms, {c} dims", f"Mvalues/s, {c} dims", f"/ white, {c} dims"]
    white = values.get("white", {})
    rows = []
    for name, row in values.items():
        cells = [name]
        for c in counts:
            s = number(get(row, c))
            cells += [
                fmt(None if s is None else s * 1e3),
                fmt(None if s is None else lanes * int(c) / s / 1e6),
                ratio(s, get(white, c)),
            ]
        rows.append(cells)
    return lines + table_lines(header, rows) + [""]


def _render_table(values: Mapping[str, Any]) -> list[str]:
    lines = [
        "## Samplers in a render (`speed.sequences`)",
        "",
        "Median seconds of an eager `renderers.render` of the Cornell box, 128 x 128, 16 spp, "
        "driven by each sampler with its strategy's seed image, the renders taking turns; "
        f"goal: at most {RENDER_GOAL}x per-pixel `owen_sobol`'s time.",
        "",
    ]
    anchor = number(values.get("owen_sobol"))
    rows = []
    for name, seconds in values.items():
        s = number(seconds)
        met = "-" if s is None or anchor is None else ("yes" if s <= RENDER_GOAL * anchor else "no")
        rows.append([name, fmt(s), ratio(s, anchor), met])
    return lines + table_lines(["sampler", "s", "/ owen_sobol", "goal met"], rows) + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.sequences", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--n", type=int, default=1 << 20, help="lanes per call (default 2^20)")
    parser.add_argument("--count", type=int, action="append", help="dims per call (repeatable)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--sampler", action="append", help="only these (repeatable)")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--threads", type=int, help="torch threads (default: torch's choice)")
    parser.add_argument("--render", action="store_true", help="also time a render per sampler")
    parser.add_argument(
        "--render-repeats", type=int, default=3,
        help="timed rounds of the renders (default 3; more on a loaded machine, where one render's "
        "time varies by 20 %% with its page faults)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    if args.threads:
        torch.set_num_threads(args.threads)
    counts = args.count or [2, 8]
    print(
        f"sampler time, {args.n} lanes on {args.device}, {torch.get_num_threads()} torch threads, "
        f"median of {args.repeats}"
    )
    results = measure_samples(args.sampler, args.n, counts, args.repeats, args.device)
    for name, by_count in results.items():
        for count, seconds in by_count.items():
            rate = args.n * count / seconds / 1e6
            print(f"  {name:12s} count {count:3d}  {seconds * 1e3:9.2f} ms  {rate:9.1f} M values/s")
    if args.render:
        print("\n".join(_render_table(measure_render(repeats=args.render_repeats))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
