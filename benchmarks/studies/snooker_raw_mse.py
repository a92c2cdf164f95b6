"""The snooker raw-MSE puzzle, measured: how a sampler pairs the light-choice dimension with the
light-position pair (docs/METHODS.md, "The snooker raw-MSE puzzle").

On a scene with two lights the tracer picks the light of vertex 0 with one dimension (6 on the
snooker tables, paired with vertex 1's choice, :mod:`renderers.layout`) and the point on it with
the pair (2, 3). At 4 spp each light gets two of the pixel's samples, and whether those two are
spread over the light depends on how the sequence pairs dimension 6 with the pair (2, 3). In a
padded Owen-Sobol sequence the first binary digit of every pair's first coordinate is bit 0 of the
(shuffled) sample index, flipped by a constant that may depend on bit 1: so the two samples of a
light always share the light's u half or its v half, never neither. Which one is decided by the
two pairs' index shuffles: a coin per pixel for the per-pixel sequence (``white``'s Owen-Sobol),
one constant for every pixel for LDBN's shared sequence (its ``seed0``). :func:`stratified_lights`
reads that off the sampler's values; :func:`measure` renders each variant of :data:`VARIANTS` and
gives its per-pixel variance across seed sets, its raw MSE and its MSE after a sigma-2 blur, each
as a ratio to white's, with the share of pixels in each class and the MSE of the two classes.

``python -m benchmarks.studies.snooker_raw_mse`` prints the table for ``snooker_plain``,
``snooker`` and ``direct`` at 64x64, 4 spp, 12 seed sets, frame 6 (a diagnosis: nothing is written
under ``results/``).

The finding it measures: docs/FINDINGS.md, "Which strategy to use" (LDBN's low raw MSE on the
snooker tables is a lucky pairing of the light choice with the light's position, not blue noise).

Not for: the benchmark's tables (:mod:`benchmarks.reports`).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

import torch

import renderers
from bnerr.color import luminance
from bnerr.errors import ShapeError, ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.metrics import blurred_mse
from bnerr.sequences import LDBNKeys, Sampler, make_sampler
from bnerr.strategies import make_strategy, pixel_seeds
from bnerr.strategies.ldbn import LDBNStrategy
from renderers.layout import Layout

__all__ = [
    "VARIANTS",
    "Context",
    "PairMix",
    "ReusedChoice",
    "Row",
    "capture",
    "draw",
    "lane_values",
    "measure",
    "random_ldbn_keys",
    "stratified_lights",
]

#: (seeds [H, W], sampler) of seed set s: what a variant renders frame t with.
Draw = tuple[torch.Tensor, Sampler]


class PairMix(Sampler):
    """The values of ``keyed`` in the dimension pairs ``pairs``, of ``base`` elsewhere: which
    pairs carry a sampler's gain."""

    needs_pixel = True

    def __init__(self, base: Sampler, keyed: Sampler, pairs: tuple[int, ...]) -> None:
        self.base, self.keyed, self.pairs = base, keyed, frozenset(pairs)

    def _sample(self, seed, index, dim, count, pixel):
        base = self.base.sample(seed, index, dim, count, pixel)
        keyed = self.keyed.sample(seed, index, dim, count, pixel)
        dims = torch.arange(dim, dim + count, device=seed.device)
        use = torch.tensor([int(d) // 2 in self.pairs for d in dims], device=seed.device)
        return torch.where(use[None], keyed, base)

    def __repr__(self) -> str:
        return f"PairMix({self.base!r}, {self.keyed!r}, pairs={sorted(self.pairs)})"


class ReusedChoice(Sampler):
    """``inner`` with vertex 0's light chosen from the light pair's u (the choice dimension reads
    u, and u becomes ``frac(L u)``): the estimator that picks the light and the point on it from
    one stratified pair, emulated without changing the tracer."""

    needs_pixel = True

    def __init__(self, inner: Sampler, layout: Layout) -> None:
        choice = layout.light_choice(0)
        if choice is None:
            raise ValueRangeError("layout: expected a scene with several lights, got one light")
        self.inner, self.choice, self.light, self.lights = (
            inner,
            choice,
            layout.light(0),
            layout.lights,
        )

    def _sample(self, seed, index, dim, count, pixel):
        if dim != 0:
            raise ValueRangeError(f"dim: expected 0 (the tracer's whole path), got {dim}")
        u = self.inner.sample(seed, index, 0, count, pixel).clone()
        first = u[:, self.light].clone()
        u[:, self.choice] = first
        u[:, self.light] = (first * self.lights) % 1.0
        return u

    def __repr__(self) -> str:
        return f"ReusedChoice({self.inner!r})"


def lane_values(seeds: torch.Tensor, sampler: Sampler, spp: int, dims: int) -> torch.Tensor:
    """``[H * W, spp, dims]``: the values the tracer reads, pixel-major, sample i of pixel p
    ``sampler.sample(seeds[p], i, 0, dims, (y, x))``."""
    height, width = seeds.shape
    pix = torch.arange(height * width, device=seeds.device)
    py, px = (pix // width).repeat_interleave(spp), (pix % width).repeat_interleave(spp)
    index = torch.arange(spp, device=seeds.device).repeat(height * width)
    lanes = seeds.flatten().repeat_interleave(spp)
    u = sampler.sample(lanes, index, 0, dims, torch.stack([py, px], dim=1))
    return u.contiguous().view(height * width, spp, dims)


def _distinct_per_light(light: torch.Tensor, coord: torch.Tensor, lights: int) -> torch.Tensor:
    """``[P]`` bool: whether the samples of every light fall in distinct strata of ``coord``
    (width 1 / n, n the number of the pixel's samples that chose that light)."""
    spp = light.shape[1]
    n = torch.stack([(light == j).sum(1) for j in range(lights)], 1).gather(1, light)
    stratum = (coord * n).floor().long().clamp(max=spp - 1).minimum(n - 1)
    key = (light * spp + stratum).sort(1).values
    return (key[:, 1:] != key[:, :-1]).all(1)


def stratified_lights(values: torch.Tensor, layout: Layout) -> tuple[torch.Tensor, torch.Tensor]:
    """Two ``[P]`` bool tensors: whether the samples that choose each light at vertex 0 are
    stratified on it in u, and in v (:func:`lane_values`' ``[P, spp, D]``; a light with n of
    the pixel's samples: n distinct strata of width 1 / n)."""
    choice = layout.light_choice(0)
    if choice is None:
        raise ValueRangeError("layout: expected a scene with several lights, got one light")
    if values.dim() != 3 or values.shape[2] < layout.dimensions:
        raise ShapeError(
            f"values: expected [P, spp, D >= {layout.dimensions}], got {list(values.shape)}"
        )
    light = (values[..., choice] * layout.lights).floor().long().clamp(max=layout.lights - 1)
    first = layout.light(0)
    return tuple(  # type: ignore[return-value]
        _distinct_per_light(light, values[..., first + k], layout.lights) for k in (0, 1)
    )


def random_ldbn_keys(like: LDBNKeys, seed0: int, seed: int = 5) -> LDBNKeys:
    """Uniform random scrambling and ranking keys of ``like``'s shape over the shared sequence
    ``seed0``: LDBN's lookup without the optimization."""
    gen = torch.Generator().manual_seed(seed)
    scramble = torch.randint(0, 1 << 24, like.scramble.shape, generator=gen, dtype=torch.int32)
    size = like.rank.shape[1:]
    rank = [
        torch.randint(0, 1 << lv, size, generator=gen, dtype=torch.int32)
        for lv in range(like.levels)
    ]
    return LDBNKeys(scramble, torch.stack(rank), seed0)


# --------------------------------------------------------------------------------------------------
# The variants and the measurement


@dataclass(frozen=True)
class Context:
    """What every draw of one measurement shares."""

    size: int
    spp: int
    t: int
    layout: Layout


def _strategy_draw(name: str, ctx: Context, s: int, **options: object) -> Draw:
    """The seeds and sampler that strategy ``name`` (seed set ``s``) renders frame t with."""
    strategy = make_strategy(name, ctx.size, ctx.size, seed=s, spp=ctx.spp, **options)  # type: ignore[arg-type]
    return capture(strategy, ctx)


def capture(strategy: object, ctx: Context) -> Draw:
    """The seeds and sampler ``strategy`` renders frame ``ctx.t`` with: its one render call,
    captured instead of run (a ``ctx.size`` square image)."""
    got: list[Draw] = []

    def render(seeds: torch.Tensor, sampler: Sampler) -> Frame:
        got.append((seeds, sampler))
        return Frame(color=torch.zeros(3, ctx.size, ctx.size))

    strategy.frame(ctx.t, render)  # type: ignore[attr-defined]
    if len(got) != 1:
        raise ValueRangeError(f"strategy: expected one render per frame, got {len(got)}")
    return got[0]


def _random_ldbn(seed0: int) -> Callable[[Context, int], Draw]:
    def draw(ctx: Context, s: int) -> Draw:
        shipped = _strategy_draw("ldbn", ctx, s)[1]
        keys = random_ldbn_keys(shipped.keys, seed0)  # type: ignore[attr-defined]
        strategy = LDBNStrategy(ctx.size, ctx.size, seed=s, keys=[keys], spp=ctx.spp)
        return capture(strategy, ctx)

    return draw


def _mixed(pairs: tuple[int, ...], name: str = "ldbn") -> Callable[[Context, int], Draw]:
    def draw(ctx: Context, s: int) -> Draw:
        seeds, ldbn = _strategy_draw(name, ctx, s)
        return seeds, PairMix(make_sampler("owen_sobol"), ldbn, pairs)

    return draw


def _reused(name: str) -> Callable[[Context, int], Draw]:
    def draw(ctx: Context, s: int) -> Draw:
        seeds, sampler = _strategy_draw(name, ctx, s)
        return seeds, ReusedChoice(sampler, ctx.layout)

    return draw


#: Variant -> its draw of seed set s; the ratios are to ``white`` (per-pixel Owen-Sobol).
VARIANTS: dict[str, Callable[[Context, int], Draw]] = {
    "white": lambda ctx, s: _strategy_draw("white", ctx, s),
    "white, sampler white (iid)": lambda ctx, s: _strategy_draw("white", ctx, s, sampler="white"),
    "zsobol": lambda ctx, s: _strategy_draw("zsobol", ctx, s),
    "ldbn": lambda ctx, s: _strategy_draw("ldbn", ctx, s),
    "ldbn keys on pairs 0, 2 only": _mixed((0, 2)),
    "ldbn keys on pairs 1, 3 only": _mixed((1, 3)),
    "ldbn, random keys, seed0 18": _random_ldbn(18),
    "ldbn, random keys, seed0 3": _random_ldbn(3),
    "white, light chosen by u": _reused("white"),
    "ldbn, light chosen by u": _reused("ldbn"),
    "ldbn_zorder": lambda ctx, s: _strategy_draw("ldbn_zorder", ctx, s),
    "ldbn_zorder keys on pair 1 only": _mixed((1,), "ldbn_zorder"),
    "ldbn_zorder keys on pairs 0-2 only": _mixed((0, 1, 2), "ldbn_zorder"),
}


def draw(name: str, layout: Layout, s: int, *, size: int, spp: int = 4, t: int = 6) -> Draw:
    """The seeds and sampler variant ``name`` of :data:`VARIANTS` renders frame ``t`` with in
    seed set ``s`` (``size x size``, on a scene of ``layout``)."""
    if name not in VARIANTS:
        raise ValueRangeError(f"name: expected a variant among {list(VARIANTS)}, got {name!r}")
    return VARIANTS[name](Context(size, spp, t, layout), s)


@dataclass(frozen=True)
class Row:
    """One variant on one scene. Ratios are to white's per-pixel variance (across seed sets) or
    raw MSE; ``shares`` the fractions of (seed set, pixel) whose two-light samples are
    stratified in u only, v only and both (NaN with one light); ``mse_u``, ``mse_v`` the raw MSE
    of the u-only and v-only pixels over white's raw MSE (NaN where none); ``mse_sets`` each seed
    set's raw MSE over white's in that seed set (for an interval); ``blurred`` the MSE after a
    sigma-2 blur over white's."""

    name: str
    variance: float
    mse: float
    shares: tuple[float, float, float]
    mse_u: float
    mse_v: float
    #: each seed set's raw MSE over white's in the same seed set
    mse_sets: tuple[float, ...] = ()
    #: the MSE after a sigma-2 blur over white's (how much of the error is low-frequency)
    blurred: float = float("nan")


def _luma(frame: Frame) -> torch.Tensor:
    return luminance(frame.color, dtype=torch.float64)


_Moments = tuple[float, float, torch.Tensor, float]


def _moments(lum: torch.Tensor, ref: torch.Tensor) -> _Moments:
    """Per-pixel variance across seed sets, raw MSE, each seed set's raw MSE ``[S]`` and the
    MSE after a sigma-2 blur of ``lum [S, H, W]`` against ``ref``."""
    per_set = (lum - ref).square().flatten(1).mean(1)
    blurred = blurred_mse(lum, ref.expand_as(lum), 2.0)  # pooled over the S seed sets
    return float(lum.var(0).mean()), float(per_set.mean()), per_set, float(blurred)


def _row(
    name: str,
    lum: torch.Tensor,
    ref: torch.Tensor,
    strat: list,
    base: _Moments,
) -> Row:
    """The :class:`Row` of ``lum [S, H, W]`` against ``ref [H, W]``: ``strat`` the per-set
    (u, v) stratification of :func:`stratified_lights` (empty with one light), ``base`` white's
    :func:`_moments`."""
    err = (lum - ref).square().flatten(1)
    variance, mse, per_set, blurred = _moments(lum, ref)
    nan = float("nan")
    shares, mse_u, mse_v = (nan, nan, nan), nan, nan
    if strat:
        u, v = (torch.stack([x[k] for x in strat]) for k in (0, 1))
        classes = (u & ~v, ~u & v, u & v)
        shares = tuple(float(c.double().mean()) for c in classes)  # type: ignore[assignment]
        mse_u, mse_v = (float(err[c].mean()) if c.any() else nan for c in classes[:2])
    ratios = tuple((per_set / base[2]).tolist())
    return Row(
        name,
        variance / base[0],
        mse / base[1],
        shares,
        mse_u / base[1],
        mse_v / base[1],
        ratios,
        blurred / base[3],
    )


def measure(
    scene_name: str,
    names: list[str] | None = None,
    *,
    size: int = 64,
    spp: int = 4,
    sets: int = 12,
    t: int = 6,
    ref_spp: int = 256,
) -> list[Row]:
    """Render frame ``t`` of the animated scene with every variant in ``names`` (default: all of
    :data:`VARIANTS` that apply; ``white`` is always measured first, as the baseline) at
    ``size x size`` and ``spp``, seed sets ``0 .. sets - 1``, against a ``ref_spp`` reference."""
    for value, what in ((size, "size"), (spp, "spp"), (sets, "sets"), (ref_spp, "ref_spp")):
        check_positive_int(value, what, minimum=2 if what == "sets" else 1)
    scene = renderers.get_scene(scene_name, animated=True)
    several = scene.layout.lights > 1
    wanted = names if names is not None else [n for n in VARIANTS if several or "by u" not in n]
    unknown = [n for n in wanted if n not in VARIANTS]
    if unknown:
        raise ValueRangeError(f"names: expected variants among {list(VARIANTS)}, got {unknown}")
    seeds = pixel_seeds(size, size, 0x5EED)
    ref = _luma(renderers.render(scene, t, seeds, make_sampler("owen_sobol"), ref_spp))
    rows: list[Row] = []
    base: _Moments | None = None
    for name in ["white"] + [n for n in wanted if n != "white"]:
        lum, strat = [], []
        for s in range(sets):
            seeds, sampler = draw(name, scene.layout, s, size=size, spp=spp, t=t)
            lum.append(_luma(renderers.render(scene, t, seeds, sampler, spp)))
            if several:
                values = lane_values(seeds, sampler, spp, scene.layout.dimensions)
                strat.append(stratified_lights(values, scene.layout))
        stack = torch.stack(lum)
        base = base or _moments(stack, ref)
        rows.append(_row(name, stack, ref, strat, base))
    return rows if "white" in wanted else rows[1:]


def _table(scene: str, rows: list[Row]) -> list[str]:
    def f(x: float) -> str:
        return "-" if x != x else f"{x:.2f}"

    return [
        f"| {scene} | {r.name} | {r.variance:.3f} | {r.mse:.3f} | {r.blurred:.3f} | "
        f"{' / '.join(f(x) for x in r.shares)} | {f(r.mse_u)} / {f(r.mse_v)} |"
        for r in rows
    ]


def main(argv: list[str] | None = None) -> None:
    """Print the table (markdown) for the scenes asked (default: both snooker tables and
    ``direct``)."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.studies.snooker_raw_mse")
    parser.add_argument("--scenes", nargs="+", default=["snooker_plain", "snooker", "direct"])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--sets", type=int, default=12)
    parser.add_argument(
        "--variants",
        nargs="+",
        metavar="NAME",
        help=f"default: all that apply, of {list(VARIANTS)}",
    )
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    print("| scene | variant | per-pixel variance / white | raw MSE / white | sigma-2 blurred MSE"
          " / white | pixels stratified in u only / v only / both | MSE of u-only / v-only pixels"
          " / white's |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for scene in args.scenes:
        rows = measure(scene, args.variants, size=args.size, spp=args.spp, sets=args.sets)
        print("\n".join(_table(scene, rows)), flush=True)


if __name__ == "__main__":
    main()
