"""Coverage study of the interval behind every comparison: which method gives its nominal rate.

``python -m bnerr.metrics.coverage`` prints the table of docs/METHODS.md, section 6
("Intervals"). Each trial simulates one suite cell with a true ratio of 1: two strategies, S
independent seed sets of F frames, per-frame MSE values built as the committed results show them
(``results/quality`` and ``results/stability``, ``cells.jsonl``: per-frame coefficient of
variation of the MSE inside a seed set median 3.5 %, 90th percentile 11-16 %; correlation of the
two strategies' per-frame deviations median 0.05-0.07; per-seed-set log ratios with standard
deviation median 0.03, 90th percentile 0.09-0.14):

- a frame content factor, log-normal with sd :data:`CONTENT_SD`, shared by both strategies and by
  every seed set (frame i of every seed set is the same scene frame);
- a seed-set effect per strategy, log-normal with sd ``set_sd`` (0, 5 % or 15 %), drawn
  independently for the two strategies (they render with their own seeds);
- frame noise, log-normal with sd :data:`FRAME_CV` for each strategy, correlation :data:`RHO`
  between the two strategies on the same frame.

Both strategies are drawn alike, so the ratio of their expected MSE is 1 and a miss is an interval
that excludes 1. Candidates: ``bootstrap``, the former two-stage percentile bootstrap exactly as
:func:`bnerr.metrics.paired_ratio` ran it (2000 resamples, weights of seed 0); ``t``, the
t-interval on per-seed-set log ratios with S - 1 degrees of freedom that replaced it; and
``studentized``, a studentized bootstrap of those log ratios over seed sets (1000 resamples).

Every interval is computed batched over trials (the same arithmetic as :mod:`bnerr.metrics.stats`
but for the bootstrap's sums, which are matrix products here: their rounding does not matter for
a coverage count). Not for: the intervals themselves; use :func:`bnerr.metrics.paired_ratio`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import torch

from bnerr.metrics.sequential import Design, looks, naive_design, run_sequential
from bnerr.metrics.share import share_interval
from bnerr.metrics.stats import resample_weights, set_means, t_interval, t_quantile

__all__ = [
    "CONTENT_SD",
    "FRAME_CV",
    "LEVELS",
    "RHO",
    "Coverage",
    "PerceptualCoverage",
    "SequentialCoverage",
    "ShareCoverage",
    "bootstrap_intervals",
    "coverage",
    "main",
    "perceptual_coverage",
    "sequential_coverage",
    "share_coverage",
    "share_intervals",
    "simulate",
    "simulate_levels",
    "studentized_intervals",
    "t_intervals",
]

FRAME_CV = 0.05  # per-frame log-sd of the MSE inside a seed set (data: median 0.035)
RHO = 0.1  # correlation of the two strategies' frame noise (data: median 0.05-0.07)
CONTENT_SD = 0.3  # log-sd of the scene frames' content, shared by both strategies
#: The levels the suites and tests use: 95 % and the ordering tests' Bonferroni levels
#: (tests/test_ordering.py: 1 - 0.05/6 failure cases and gap, 1 - 0.05/8 raw MSE and rivals,
#: 1 - 0.05/16 orderings).
LEVELS = (0.95, 1 - 0.05 / 6, 1 - 0.05 / 8, 1 - 0.05 / 16)

Intervals = list[tuple[torch.Tensor, torch.Tensor]]  # per level: (lo [T], hi [T]) of the ratio


def simulate(
    trials: int,
    seed_sets: int,
    frames: int,
    set_sd: float,
    generator: torch.Generator,
    *,
    effect: float = 0.0,
    skewed: bool = False,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-frame MSE of two strategies whose expected MSE has the ratio ``1 - effect``: ``(a,
    b)``, each ``[trials, seed_sets, frames]`` float64 (the model of the module docstring).
    ``skewed``: the seed-set effects are a centred exponential times ``set_sd`` (mean 0, sd
    ``set_sd``, skewness 2: a seed set that is rarely but much worse) instead of normal."""
    shape = (trials, seed_sets, frames)

    def normal(*size: int) -> torch.Tensor:
        return torch.randn(size, generator=generator, dtype=torch.float64)

    content = CONTENT_SD * normal(trials, 1, frames)
    set_a, set_b = (_set_effect(trials, seed_sets, set_sd, generator, skewed) for _ in range(2))
    z1, z2 = normal(*shape), normal(*shape)
    noise_a = FRAME_CV * z1
    noise_b = FRAME_CV * (RHO * z1 + math.sqrt(1 - RHO * RHO) * z2)
    scale = math.log1p(-effect)
    return torch.exp(content + set_a + noise_a + scale), torch.exp(content + set_b + noise_b)


def _set_effect(
    trials: int, seed_sets: int, set_sd: float, generator: torch.Generator, skewed: bool
) -> torch.Tensor:
    """``[trials, seed_sets, 1]`` log seed-set effects: normal with sd ``set_sd``, or (``skewed``)
    a centred exponential times ``set_sd``."""
    if not skewed:
        return set_sd * torch.randn(
            (trials, seed_sets, 1), generator=generator, dtype=torch.float64
        )
    u = torch.rand((trials, seed_sets, 1), generator=generator, dtype=torch.float64)
    return set_sd * (-torch.log1p(-u) - 1.0)


def _pairs(x: torch.Tensor) -> torch.Tensor:
    return torch.stack([x, torch.ones_like(x)], dim=-1)


def t_intervals(a: torch.Tensor, b: torch.Tensor, levels: Sequence[float]) -> Intervals:
    """The t-interval of :func:`bnerr.metrics.paired_ratio` for every trial of ``a, b [T, S, F]``
    (S >= 2): log ratios of the seed sets' pooled means, centred on the pooled ratio."""
    logs = torch.log(set_means(_pairs(a)) / set_means(_pairs(b)))  # [T, S]
    centre = torch.log(a.sum(dim=(1, 2)) / b.sum(dim=(1, 2)))  # [T]
    out = []
    for level in levels:
        lo, hi = t_interval(logs, centre, level)
        out.append((torch.exp(lo), torch.exp(hi)))
    return out


def bootstrap_intervals(
    a: torch.Tensor, b: torch.Tensor, levels: Sequence[float], chunk: int = 2000
) -> Intervals:
    """The former two-stage percentile bootstrap of :func:`bnerr.metrics.paired_ratio` (2000
    resamples, weights of seed 0, torch's linear quantiles) for every trial of ``a, b``."""
    trials, s, f = a.shape
    weights = resample_weights((s, f), 2000, 0).T  # [S * F, R]
    alphas = [(1 - level) / 2 for level in levels]
    q = torch.tensor([p for al in alphas for p in (al, 1 - al)], dtype=torch.float64)
    parts = []
    for i in range(0, trials, chunk):
        ratio = (a[i : i + chunk].reshape(-1, s * f) @ weights) / (
            b[i : i + chunk].reshape(-1, s * f) @ weights
        )
        parts.append(torch.quantile(ratio, q, dim=1))  # [2 * levels, chunk]
    bounds = torch.cat(parts, dim=1)
    return [(bounds[2 * k], bounds[2 * k + 1]) for k in range(len(levels))]


def studentized_intervals(
    a: torch.Tensor, b: torch.Tensor, levels: Sequence[float], chunk: int = 2000
) -> Intervals:
    """Studentized (bootstrap-t) intervals of the mean per-seed-set log ratio: 1000 resamples of
    the seed sets (seed 1); a resample of one repeated seed set has no spread, its t is infinite,
    and the quantiles are the conservative order statistics (lower for the low tail)."""
    logs = torch.log(set_means(_pairs(a)) / set_means(_pairs(b)))  # [T, S]
    trials, s = logs.shape
    draws = torch.randint(s, (1000, s), generator=torch.Generator().manual_seed(1))
    mean, se = logs.mean(dim=1), logs.std(dim=1) / math.sqrt(s)
    parts = []
    for i in range(0, trials, chunk):
        star = logs[i : i + chunk][:, draws]  # [chunk, R, S]
        t = (star.mean(dim=2) - mean[i : i + chunk, None]) / (star.std(dim=2) / math.sqrt(s))
        parts.append(torch.sort(torch.nan_to_num(t, nan=0.0, posinf=math.inf), dim=1).values)
    tstar = torch.cat(parts)  # [T, R]
    r = tstar.shape[1] - 1
    out = []
    for level in levels:
        alpha = (1 - level) / 2
        t_lo, t_hi = tstar[:, math.floor(alpha * r)], tstar[:, math.ceil((1 - alpha) * r)]
        out.append((torch.exp(mean - t_hi * se), torch.exp(mean - t_lo * se)))
    return out


METHODS: dict[str, Callable[[torch.Tensor, torch.Tensor, Sequence[float]], Intervals]] = {
    "bootstrap": bootstrap_intervals,
    "t": t_intervals,
    "studentized": studentized_intervals,
}


@dataclass(frozen=True)
class Coverage:
    """One method's record at one setting: the share of trials whose interval misses 1, its
    binomial standard error, and the intervals' mean and median width (inf when any is infinite,
    with the share of infinite intervals)."""

    method: str
    seed_sets: int
    set_sd: float
    level: float
    trials: int
    miss: float
    miss_se: float
    mean_width: float
    median_width: float
    infinite: float


def coverage(
    method: str,
    seed_sets: int,
    set_sd: float,
    trials: int,
    levels: Sequence[float] = LEVELS,
    frames: int = 3,
    seed: int = 0,
) -> list[Coverage]:
    """Simulate ``trials`` cells (``seed`` fixes them) and measure ``method`` at each level."""
    a, b = simulate(trials, seed_sets, frames, set_sd, torch.Generator().manual_seed(seed))
    rows = []
    for level, (lo, hi) in zip(levels, METHODS[method](a, b, levels), strict=True):
        miss = float(((lo > 1) | (hi < 1)).double().mean())
        width = hi - lo
        rows.append(
            Coverage(
                method,
                seed_sets,
                set_sd,
                level,
                trials,
                miss,
                math.sqrt(miss * (1 - miss) / trials),
                float(width.mean()),
                float(width.median()),
                float((~torch.isfinite(width)).double().mean()),
            )
        )
    return rows


@dataclass(frozen=True)
class SequentialCoverage:
    """The adaptive procedure's record at one setting (:func:`sequential_coverage`): the share of
    cells whose reported interval misses the true ratio, its binomial standard error, the
    early-stopping bias of the reported ratio (mean of ``log(reported / true)``, and its
    standard error), the mean and largest seed sets used, and the share open at the cap."""

    name: str
    looks: tuple[int, ...]
    effect: float
    set_sd: float
    skewed: bool
    rivals: int
    trials: int
    miss: float
    miss_se: float
    bias: float
    bias_se: float
    mean_seed_sets: float
    open_share: float


def sequential_coverage(
    design: Design,
    effect: float,
    set_sd: float,
    trials: int,
    *,
    name: str = "sequential",
    rivals: int = 1,
    skewed: bool = False,
    frames: int = 3,
    seed: int = 0,
) -> SequentialCoverage:
    """Simulate ``trials`` cells with a true ratio of ``1 - effect`` run through the whole
    adaptive procedure of :func:`bnerr.metrics.sequential.run_sequential` with ``design``; a
    miss is a reported interval (at the look the cell stopped at) that excludes the truth."""
    gen = torch.Generator().manual_seed(seed)
    a, b = simulate(trials, design.cap, frames, set_sd, gen, effect=effect, skewed=skewed)
    logs = torch.log(set_means(_pairs(a)) / set_means(_pairs(b)))  # [T, N]
    sa, sb = a.sum(dim=2).cumsum(dim=1), b.sum(dim=2).cumsum(dim=1)  # [T, N] running sums
    index = torch.tensor([n - 1 for n in design.looks])
    centres = torch.log(sa[:, index] / sb[:, index])  # [T, K]
    stop, centre, lo, hi = run_sequential(logs, centres, design, rivals)
    truth = math.log1p(-effect)
    missed = ((lo > truth) | (hi < truth)).double()
    err = centre - truth
    looks = torch.tensor(design.looks, dtype=torch.float64)
    settled_last = (lo > 0) | (hi < 0) | ((lo >= math.log(0.95)) & (hi <= math.log(1.05)))
    open_at_cap = (stop == len(design.looks) - 1) & ~settled_last
    miss = float(missed.mean())
    return SequentialCoverage(
        name,
        design.looks,
        effect,
        set_sd,
        skewed,
        rivals,
        trials,
        miss,
        math.sqrt(miss * (1 - miss) / trials),
        float(err.mean()),
        float(err.std() / math.sqrt(trials)),
        float(looks[stop].mean()),
        float(open_at_cap.double().mean()),
    )


@dataclass(frozen=True)
class PerceptualCoverage:
    """A second metric's verdict at the look the MSE's adaptive procedure stopped at
    (:func:`perceptual_coverage`): the share of cells whose interval of the second metric's
    difference misses its truth, its binomial standard error, and the mean seed sets used."""

    looks: tuple[int, ...]
    effect: float
    rho: float
    rivals: int
    trials: int
    miss: float
    miss_se: float
    mean_seed_sets: float


def perceptual_coverage(
    design: Design,
    effect: float,
    rho: float,
    trials: int,
    *,
    set_sd: float = 0.05,
    rivals: int = 1,
    frames: int = 3,
    seed: int = 0,
) -> PerceptualCoverage:
    """The perceptual verdict's coverage when the seed sets are added by the MSE's rule
    (:mod:`benchmarks.reports.perceptual`): cells of true MSE ratio ``1 - effect`` run through
    :func:`bnerr.metrics.sequential.run_sequential`, and per seed set a JOD difference to white
    of truth 0 whose deviation has correlation ``-rho`` with the seed set's MSE log ratio (a
    seed set lucky in MSE is lucky in JOD: the stopping rule then selects the JOD too). At the
    look each cell stopped at, the JOD's t-interval at that look's level (the design's, as the
    perceptual table uses) misses the truth or not. A miss rate above ``design.alpha`` would
    mean the MSE's looks are not the JOD verdict's to use."""
    gen = torch.Generator().manual_seed(seed)
    a, b = simulate(trials, design.cap, frames, set_sd, gen, effect=effect)
    logs = torch.log(set_means(_pairs(a)) / set_means(_pairs(b)))  # [T, N]
    sa, sb = a.sum(dim=2).cumsum(dim=1), b.sum(dim=2).cumsum(dim=1)
    index = torch.tensor([n - 1 for n in design.looks])
    stop, _, _, _ = run_sequential(logs, torch.log(sa[:, index] / sb[:, index]), design, rivals)
    z = (logs - logs.mean()) / logs.std()  # each seed set's MSE luck, standardized
    own = torch.randn(logs.shape, generator=gen, dtype=torch.float64)
    jod = -(rho * z + math.sqrt(max(0.0, 1.0 - rho * rho)) * own)  # truth 0
    missed = []
    for n in design.looks:
        sub = jod[:, :n]
        half = t_quantile(design.level(n, rivals), n - 1) * sub.std(dim=1) / math.sqrt(n)
        missed.append(sub.mean(dim=1).abs() > half)
    miss_at = torch.stack(missed, dim=1).gather(1, stop[:, None])[:, 0].double()
    miss = float(miss_at.mean())
    counts = torch.tensor(design.looks, dtype=torch.float64)
    return PerceptualCoverage(
        design.looks,
        effect,
        rho,
        rivals,
        trials,
        miss,
        math.sqrt(miss * (1 - miss) / trials),
        float(counts[stop].mean()),
    )


def _perceptual_table(trials: int) -> None:
    """Print the perceptual verdicts' table (``--perceptual``): the quality suite's looks (4 to
    32 seed sets), one rival and its m = 11, MSE effects 0 to 10 %, correlations 0 to 1."""
    print("| looks | m | MSE effect | correlation | JOD miss % (nominal 5) | mean seed sets |")
    print("|---|---|---|---|---|---|")
    design = Design(looks(4, 32))
    for rivals in (1, 11):
        for effect in (0.0, 0.05, 0.10):
            for rho in (0.0, 0.5, 0.9, 1.0):
                r = perceptual_coverage(design, effect, rho, trials, rivals=rivals)
                print(
                    f"| 4-8-16-32 | {rivals} | {effect:.0%} | {rho:.1f} | "
                    f"{100 * r.miss:.2f} ± {100 * r.miss_se:.2f} | {r.mean_seed_sets:.1f} |",
                    flush=True,
                )


def simulate_levels(
    trials: int,
    seed_sets: int,
    frames: int,
    set_sd: float,
    generator: torch.Generator,
    levels: Sequence[float],
    *,
    skewed: bool = False,
) -> list[torch.Tensor]:
    """Per-frame MSE of strategies whose expected MSE is ``levels[i]`` times a common one: each
    ``[trials, seed_sets, frames]`` float64, the frame content shared (the model of the module
    docstring), the seed-set effect and frame noise each strategy's own (independent: the
    correlation :data:`RHO` of the ratio's model is left out)."""
    content = CONTENT_SD * torch.randn(
        (trials, 1, frames), generator=generator, dtype=torch.float64
    )
    out = []
    for level in levels:
        sets = _set_effect(trials, seed_sets, set_sd, generator, skewed)
        noise = FRAME_CV * torch.randn(
            (trials, seed_sets, frames), generator=generator, dtype=torch.float64
        )
        out.append(level * torch.exp(content + sets + noise))
    return out


def share_intervals(
    w: torch.Tensor, v: torch.Tensor, o: torch.Tensor, level: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The gap share of :mod:`benchmarks.reports.gap` (:func:`bnerr.metrics.share_interval`) for
    every trial of ``w, v, o [T, S, F]`` (white, the strategy, the oracle; equal pixel counts, so
    a pooled mean is the mean): ``(share, lo, hi)``, each ``[T]``."""
    reps = (w.mean(dim=2), v.mean(dim=2), o.mean(dim=2))
    pooled = (w.mean(dim=(1, 2)), v.mean(dim=(1, 2)), o.mean(dim=(1, 2)))
    return share_interval(reps, pooled, level)


@dataclass(frozen=True)
class ShareCoverage:
    """The gap share's record at one setting (:func:`share_coverage`): the share of trials whose
    interval (at ``level``) misses the true share, its binomial standard error, and the share of
    unbounded intervals (a seed set without a gap: not resolved, never a miss). ``rivals`` > 1:
    the best of that many strategies with the same true share, its interval at ``level`` (the
    family level ``1 - 0.05 / m`` for the corrected verdict)."""

    seed_sets: int
    gap: float
    share: float
    set_sd: float
    skewed: bool
    rivals: int
    level: float
    trials: int
    miss: float
    miss_se: float
    unbounded: float

    @property
    def stated(self) -> float:
        """The miss rate the interval claims: ``1 - level``, and for the best of m the family's
        0.05 (what an uncorrected verdict claims too, and what the Bonferroni level keeps)."""
        return 0.05 if self.rivals > 1 else 1.0 - self.level


def share_coverage(
    seed_sets: int,
    gap: float,
    share: float,
    set_sd: float,
    trials: int,
    levels: Sequence[float] = (0.95,),
    *,
    rivals: int = 1,
    skewed: bool = False,
    frames: int = 3,
    seed: int = 0,
) -> list[ShareCoverage]:
    """Simulate ``trials`` cells with white at 1, the oracle at ``1 - gap`` and ``rivals``
    strategies each at the true share ``share`` (``1 - share * gap``), and measure the interval
    of the one with the highest estimated share (of the one strategy when ``rivals`` is 1) at
    each of ``levels``: a miss is an interval that excludes ``share``."""
    gen = torch.Generator().manual_seed(seed)
    mse = simulate_levels(
        trials, seed_sets, frames, set_sd, gen,
        [1.0, 1.0 - gap, *[1.0 - share * gap] * rivals], skewed=skewed,
    )  # fmt: skip
    w, o, rivals_mse = mse[0], mse[1], torch.stack(mse[2:])  # [m, T, S, F]
    estimates = torch.stack([share_intervals(w, v, o, 0.95)[0] for v in rivals_mse])  # [m, T]
    best = rivals_mse[
        torch.nan_to_num(estimates, nan=-math.inf).argmax(dim=0), torch.arange(trials)
    ]
    rows = []
    for level in levels:
        _, lo, hi = share_intervals(w, best, o, level)
        missed = (lo > share) | (hi < share)  # NaN (no gap) is never a miss
        miss = float(missed.double().mean())
        rows.append(
            ShareCoverage(
                seed_sets,
                gap,
                share,
                set_sd,
                skewed,
                rivals,
                level,
                trials,
                miss,
                math.sqrt(miss * (1 - miss) / trials),
                float((~torch.isfinite(hi - lo)).double().mean()),
            )  # fmt: skip
        )
    return rows


def _shares_table(trials: int) -> None:
    """Print the gap shares' table (``--shares``): 2, 3, 4 and 8 seed sets, gaps of 0.3 and 0.8
    (the committed gap tables' range: 0.23-0.89), true shares 0 and 0.5, seed-set effects of 0,
    5 and 15 % (normal) and 15 % skewed, at 95 % and 97.5 % (the seed suite's family level for
    its m = 2 variants) and, for the best of m = 2, 4 and 8 variants with the same true share,
    at 95 % (uncorrected) and at the family level 1 - 0.05 / m: the miss rate stated for a best
    of m is the family's 5 % either way."""
    print(
        "| S | gap | share | seed-set sd | skewed | best of m | level | miss % (nominal) | "
        "unbounded % |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    settings = ((0.0, False), (0.05, False), (0.15, False), (0.15, True))
    rows = []
    for seed_sets in (2, 3, 4, 8):
        for gap in (0.3, 0.8):
            for share in (0.0, 0.5):
                for set_sd, skewed in settings:
                    rows += share_coverage(
                        seed_sets, gap, share, set_sd, trials, (0.95, 0.975), skewed=skewed
                    )
        for rivals in (2, 4, 8):
            for set_sd, skewed in settings[1:]:
                rows += share_coverage(
                    seed_sets, 0.8, 0.5, set_sd, trials, (0.95, 1 - 0.05 / rivals),
                    rivals=rivals, skewed=skewed,
                )  # fmt: skip
    for r in rows:
        print(
            f"| {r.seed_sets} | {r.gap:.1f} | {r.share:.1f} | {r.set_sd:.0%} | "
            f"{'yes' if r.skewed else 'no'} | {r.rivals} | {r.level:.5f} | "
            f"{100 * r.miss:.2f} ± {100 * r.miss_se:.2f} ({100 * r.stated:.2f}) | "
            f"{100 * r.unbounded:.1f} |",
            flush=True,
        )


def _sequential_table(trials: int) -> None:
    """Print the adaptive procedure's table (``--sequential``): every effect, seed-set effect
    (normal and skewed), first look (2, 3 or 4 seed sets, doubled to 8 times the first) and
    level in use (95 % and the decision table's 1 - 0.05/6), and the naive procedure."""
    print(
        "| design | looks | effect | seed-set sd | skewed | m | miss % (nominal 5) | "
        "bias of the ratio % | mean seed sets | open at cap % |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    designs = [("sequential", Design(looks(first, 8 * first))) for first in (2, 3, 4)]
    designs.append(("naive", naive_design(32)))
    for name, design in designs:
        for rivals in (1, 6) if name == "sequential" else (1,):
            for effect in (0.0, 0.02, 0.05, 0.10):
                for set_sd, skewed in ((0.0, False), (0.05, False), (0.15, False), (0.15, True)):
                    r = sequential_coverage(
                        design, effect, set_sd, trials, name=name, rivals=rivals, skewed=skewed
                    )
                    print(
                        f"| {name} | {'-'.join(map(str, r.looks)) if len(r.looks) < 6 else '2..32'}"
                        f" | {effect:.0%} | {set_sd:.0%} | {'yes' if skewed else 'no'} | {rivals}"
                        f" | {100 * r.miss:.2f} ± {100 * r.miss_se:.2f} | "
                        f"{100 * math.expm1(r.bias):+.2f} ± {100 * r.bias_se:.2f} | "
                        f"{r.mean_seed_sets:.1f} | {100 * r.open_share:.1f} |",
                        flush=True,
                    )


def _cell(row: Coverage) -> str:
    if row.infinite > 0:
        width = f"inf ({100 * row.infinite:.3g} % of trials)"
    elif row.mean_width > 10 * row.median_width:  # a few near-infinite intervals
        width = f"median {row.median_width:.3f} (mean {row.mean_width:.0e})"
    else:
        width = f"{row.mean_width:.3f}"
    return f"{100 * row.miss:.2f} ± {100 * row.miss_se:.2f} / {width}"


def main(argv: Sequence[str] | None = None) -> None:
    """Print the coverage table (markdown): miss rate in % ± its Monte Carlo standard error, and
    the mean width of the ratio's interval, per seed-set count, seed-set effect and level."""
    parser = argparse.ArgumentParser(prog="python -m bnerr.metrics.coverage", description=__doc__)
    parser.add_argument("--trials", type=int, default=40_000, help="trials per bootstrap setting")
    parser.add_argument("--t-trials", type=int, default=400_000, help="trials per t setting")
    parser.add_argument(
        "--shares",
        type=int,
        metavar="TRIALS",
        help="instead: the gap shares' and the best variant's table (bnerr.metrics.share)",
    )
    parser.add_argument(
        "--perceptual",
        type=int,
        metavar="TRIALS",
        help="instead: the perceptual verdicts' coverage at the MSE rule's looks, TRIALS per row",
    )
    parser.add_argument(
        "--sequential",
        type=int,
        metavar="TRIALS",
        help="instead: the adaptive procedure's table (bnerr.metrics.sequential), TRIALS per row",
    )
    args = parser.parse_args(argv)
    torch.set_num_threads(1)  # bit-identical tables, and fair to a shared machine
    if args.sequential:
        _sequential_table(args.sequential)
        return
    if args.perceptual:
        _perceptual_table(args.perceptual)
        return
    if args.shares:
        _shares_table(args.shares)
        return
    names = list(METHODS)
    print("| S | seed-set sd | level | nominal miss % | " + " | ".join(names) + " |")
    print("|---|---|---|---|" + "---|" * len(names))
    for seed_sets in (4, 8):
        for set_sd in (0.0, 0.05, 0.15):
            table = {
                m: coverage(m, seed_sets, set_sd, args.t_trials if m == "t" else args.trials)
                for m in names
            }
            for k, level in enumerate(LEVELS):
                cells = " | ".join(_cell(table[m][k]) for m in names)
                print(
                    f"| {seed_sets} | {set_sd:.0%} | {level:.5f} | {100 * (1 - level):.2f} | "
                    f"{cells} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
