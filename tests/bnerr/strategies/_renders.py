"""Stand-in renders and statistics shared by the strategy tests: a cheap hash render with every
buffer, and the analytic integrand (a soft shadow whose penumbra edge moves across the image).

Pixel (y, x) of frame t sees a fraction c_t(y, x) of an area light: a ramp from 0 to 1 over 0.75 W
pixels whose edge follows a sine in y and moves 1.5 pixels to the right per frame. One sample per
pixel draws two dimensions from the sampler: the light point is visible iff u0 < c, and the light's
radiance there is 0.5 + u1 (mean 1). The reference is exactly c."""

import math

import torch

from bnerr.frame import Frame
from bnerr.metrics import Estimate, t_quantile
from bnerr.strategies import make_strategy


def hash_render(record: list | None = None, special: bool = False):
    """A render whose every buffer is a fixed function of the pixel's seed (like a real renderer,
    whose pixel estimate is a function of its seed); optionally NaN and inf in some pixels."""

    def render(seeds: torch.Tensor, sampler) -> Frame:
        if record is not None:
            record.append((seeds.clone(), sampler))
        h, w = seeds.shape
        u = ((seeds * 2654435761) % 1000003).float() / 1000003
        color = torch.stack([u, u * u, 1 - u])
        if special:
            color[0][seeds % 97 == 0] = float("nan")
            color[1][seeds % 89 == 0] = float("inf")
        return Frame(
            color=color,
            albedo=torch.stack([1 - u, u, u * 0.5]),
            depth=(seeds % 7).float()[None],
            **features(h, w),
            timings={"render": 1.0},
        )

    return render


def features(h: int, w: int) -> dict:
    """Geometric buffers that depend on the pixel only: 3 objects and the background in vertical
    bands, normals by band, a motion of (1.4, -0.6) px that takes the right border off screen."""
    x = torch.arange(w).expand(h, w)
    band = (x * 4 // w).float()
    return {
        "object_id": (band - 1)[None],
        "normal": torch.stack([band - 1.5, torch.ones(h, w), torch.zeros(h, w)]),
        "motion": torch.stack([torch.full((h, w), 1.4), torch.full((h, w), -0.6)]),
    }


SIZE = 64


FRAMES = 16


MEASURED = range(8, FRAMES)  # the temporal strategies start from white noise; frames 8..15 count


TILE = 8  # 8x8 tiles (two 4x4 sort blocks across) are the independent units of the statistics


def coverage(t: int) -> torch.Tensor:
    y = torch.arange(SIZE, dtype=torch.float64).view(SIZE, 1)
    x = torch.arange(SIZE, dtype=torch.float64).view(1, SIZE)
    edge = 0.1 * SIZE + 0.15 * SIZE * torch.sin(2 * math.pi * y / SIZE) + 1.5 * t
    return ((x - edge) / (0.75 * SIZE) + 0.5).clamp(0, 1)


def soft_shadow_render(t: int):
    c = coverage(t).reshape(-1)
    ys, xs = torch.meshgrid(torch.arange(SIZE), torch.arange(SIZE), indexing="ij")
    pixel = torch.stack([ys.reshape(-1), xs.reshape(-1)], dim=1)

    def render(seeds: torch.Tensor, sampler) -> Frame:
        u = sampler.sample(
            seeds.reshape(-1), torch.zeros(SIZE * SIZE, dtype=torch.int64), 0, 2, pixel
        )
        value = (u[:, 0].double() < c).double() * (0.5 + u[:, 1].double())
        return Frame(color=value.float().view(1, SIZE, SIZE).expand(3, SIZE, SIZE).contiguous())

    return render


def shadow_errors(strategy) -> torch.Tensor:
    """``[F, H, W]`` float64 errors (one channel; all three are equal) of the measured frames."""
    errs = []
    for t in range(FRAMES):
        frame = strategy.frame(t, soft_shadow_render(t))
        if t in MEASURED:
            errs.append(frame.color[0].double() - coverage(t))
    return torch.stack(errs)


def tiles(squared: torch.Tensor) -> torch.Tensor:
    """Mean over frames and over each TILE x TILE tile: ``[(H / TILE) * (W / TILE)]``."""
    per_pixel = squared.mean(dim=0)
    return per_pixel.view(SIZE // TILE, TILE, SIZE // TILE, TILE).mean(dim=(1, 3)).reshape(-1)


def paired(a: torch.Tensor, b: torch.Tensor) -> tuple[float, float]:
    """Mean and standard error of the tile-paired difference ``a - b`` (same tile and coverage)."""
    d = a - b
    return float(d.mean()), float(d.std() / math.sqrt(d.numel()))


# Equivalence margin of the raw MSE ratio to white. The smallest round margin these 64 tiles x 8
# frames resolve: the tile-paired difference has a relative standard error of 0.7-1.9 % (measured:
# temporal_sort 1.7-1.9 %, the others 0.7-1.1 %), so the 99.5 % interval's half-width is up to
# 2.9 x 1.9 = 5.5 %; a 3 % margin would need about 4x the tiles. Measured ratios 0.988-1.010.
RAW_MARGIN = 0.07


RAW_LEVEL = 1 - 0.05 / 10  # 5 strategies x 2 samplers


def paired_ratio(a: torch.Tensor, b: torch.Tensor, level: float) -> Estimate:
    """``mean(a) / mean(b)`` with the t-interval of the tile-paired difference (tiles are the
    independent units), divided by ``mean(b)``."""
    diff, se = paired(a, b)
    base = float(b.mean())
    half = t_quantile(level, a.numel() - 1) * se
    return Estimate(1 + diff / base, 1 + (diff - half) / base, 1 + (diff + half) / base, 0, level)


def pixels(h: int, w: int) -> torch.Tensor:
    ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
    return torch.stack([ys.reshape(-1), xs.reshape(-1)], dim=1)


# A small real render: direct (animated), 48x48, 4 spp, 8 frames, against 256-spp references.
REAL = dict(size=48, spp=4, frames=8, tile=4)


#: Non-inferiority margin of raw MSE ratios on that render, fixed by what the test is for and not
#: by the data: catching a gross loss, the doubled raw MSE that repeated or shared seeds cause
#: (bnds_st here: 2.29x). The claim is "less than half a doubling on the log scale worse than the
#: sampler compared with": raw MSE ratio's Bonferroni interval below sqrt(2) = 1.414. Its 144
#: tiles x 8 frames give a relative standard error of 6-9 % per comparison (interval -+20 %), so
#: a 2x loss fails it by far and no smaller claim is resolved here; equivalence within the strict
#: RAW_MARGIN is tested on the analytic integrand, which resolves it. (It was 0.35, set just
#: above the measured upper ends, 1.30.)
REAL_MARGIN = math.sqrt(2.0) - 1.0


def small_render_errors(names) -> dict[str, torch.Tensor]:
    """Per-tile raw MSE of each named strategy on a small real render (direct, animated, at
    :data:`REAL`'s size, spp and frames, against 256-spp references): name -> ``[tiles]``."""
    import renderers
    from benchmarks.sweep.references import reference_seeds
    from bnerr.sequences import make_sampler

    n, spp, frames, tile = (REAL[k] for k in ("size", "spp", "frames", "tile"))
    scene = renderers.get_scene("direct", animated=True)
    refs = [
        renderers.render(scene, t, reference_seeds(n, n, t), make_sampler("owen_sobol"), 256)
        for t in range(frames)
    ]
    out = {}
    for name in names:
        strategy = make_strategy(name, n, n, seed=0, spp=spp, dimensions=scene.dimensions)
        squared = []
        for t in range(frames):
            frame = strategy.frame(t, lambda s, smp, t=t: renderers.render(scene, t, s, smp, spp))
            squared.append((frame.color.double() - refs[t].color.double()).square().mean(0))
        per_pixel = torch.stack(squared).mean(0)
        out[name] = per_pixel.view(n // tile, tile, n // tile, tile).mean(dim=(1, 3)).reshape(-1)
    return out
