"""Frame folders for ``bnerr eval`` (:mod:`benchmarks.commands.eval.frame_folder`), rendered by
bnerr's tracer called directly through a strategy's :func:`bnerr.strategies.play`, not through
``bnerr bench``: the same frames and references a bench run of the same settings renders, written in
the layout."""

from __future__ import annotations

import math
from pathlib import Path

import torch

import renderers
from benchmarks.commands.eval.frame_folder import MANIFEST, frame_name
from benchmarks.sweep.references import reference_seeds
from benchmarks.sweep.tuning import TUNING_SEED_SET
from bnerr import sequences, strategies
from bnerr.io import write_exr, write_frame

#: The auxiliary buffers the tracer writes (all but variance): the coherent region's among them.
TRACER_BUFFERS = ("albedo", "normal", "depth", "motion", "object_id")


def _render_at(scene, spp: int):
    def render_at(k: int):
        return lambda seeds, sampler: renderers.render(scene, k, seeds, sampler, spp)

    return render_at


def manifest_text(
    *,
    scene: str = "direct",
    spp: int = 1,
    res: tuple[int, int] = (16, 16),
    methods: tuple[str, ...] = ("white", "temporal"),
    seed_sets: int = 2,
    frames: int = 2,
    warmup: int = 1,
    reference_spp: int = 8,
    tuning: bool = True,
    buffers: tuple[str, ...] = TRACER_BUFFERS,
) -> str:
    """The manifest of :func:`render_folder`'s folder with these settings."""
    lines = [
        f'scene = "{scene}"',
        f"spp = {spp}",
        f"resolution = [{res[0]}, {res[1]}]",
        "methods = [" + ", ".join(f'"{m}"' for m in methods) + "]",
        "seed_sets = [" + ", ".join(f'"{i}"' for i in range(seed_sets)) + "]",
        f"frames = {frames}",
        f"warmup = {warmup}",
        "buffers = [" + ", ".join(f'"{b}"' for b in buffers) + "]",
        f"reference_spp = {reference_spp}",
    ]
    if tuning:
        lines.append('tuning_seed_set = "tune"')
    return "\n".join(lines) + "\n"


def render_folder(root: Path, **settings) -> Path:
    """Render ``root`` as a frame folder (:func:`manifest_text`'s settings): each method's seed
    sets ``0 .. S-1`` (the strategy's seed is the seed set, as in ``bnerr bench``) and white's
    held-out tuning set ``tune`` (seed :data:`TUNING_SEED_SET`), frames ``0 .. warmup + frames - 1``
    each, and the references at ``reference_spp`` with the sweep's reference seeds and sampler."""
    text = manifest_text(**settings)
    get = {k: v for k, v in manifest_text.__kwdefaults__.items()}
    get.update(settings)
    (width, height), spp = get["res"], get["spp"]
    scene = renderers.get_scene(get["scene"], animated=True)
    shown = range(get["warmup"], get["warmup"] + get["frames"])
    for method in get["methods"]:
        groups = [(i, str(i)) for i in range(get["seed_sets"])]
        if method == "white" and get["tuning"]:
            groups.append((TUNING_SEED_SET, "tune"))
        for seed, name in groups:
            strategy = strategies.make_strategy(
                method, height, width, seed=seed, spp=spp, dimensions=scene.dimensions
            )
            (root / method / name).mkdir(parents=True, exist_ok=True)
            for t, frame in strategies.play(strategy, _render_at(scene, spp), shown, in_order=True):
                write_frame(root / method / name / frame_name(t), frame)
    (root / "reference").mkdir(parents=True, exist_ok=True)
    sampler = sequences.make_sampler("owen_sobol")
    for t in range(max(get["warmup"] - 1, 0), shown.stop):  # the coherent region's t - 1 too
        seeds = reference_seeds(height, width, t)
        ref = renderers.render(scene, t, seeds, sampler, get["reference_spp"], compile=False)
        write_frame(root / "reference" / frame_name(t), ref)
    (root / MANIFEST).write_text(text)
    return root


def _toml_string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""

    def escape(c: str) -> str:
        if c not in '"\\' and c.isprintable() and ord(c) != 0x7F:
            return c
        return f"\\u{ord(c):04x}" if ord(c) < 0x10000 else f"\\U{ord(c):08x}"

    return '"' + "".join(escape(c) for c in text) + '"'


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_string(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return _toml_string(v) if isinstance(v, str) else repr(v)


def toml_text(table: dict) -> str:
    """A TOML table of strings, numbers, booleans, lists and inline tables of them (any string:
    escaped; nan and inf as TOML writes them)."""
    return "".join(f"{_toml_string(k)} = {_toml_value(v)}\n" for k, v in table.items())


#: The manifest of :func:`synthetic_folder` (overridden key by key).
SYNTHETIC = {
    "scene": "gradient",
    "spp": 1,
    "resolution": [8, 8],
    "methods": ["white", "mine"],
    "seed_sets": ["0", "1"],
    "frames": 2,
}


def synthetic_folder(root: Path, *, layers: dict | None = None, **manifest) -> Path:
    """A frame folder of 8x8 synthetic frames, no renderer: a smooth reference per frame 0 ..
    warmup + frames - 1, white noise for ``white`` and high-passed noise for the other methods,
    seeded per seed set; ``layers`` (name -> ``[C, H, W]``) are written as layers of every
    frame. ``manifest`` overrides :data:`SYNTHETIC`'s keys (None drops one)."""
    table = {k: v for k, v in {**SYNTHETIC, **manifest}.items() if v is not None}
    width, height = table["resolution"]
    count = table.get("warmup", 0) + table["frames"]
    y, x = torch.meshgrid(torch.linspace(0, 1, height), torch.linspace(0, 1, width), indexing="ij")
    reference = torch.stack([x, y, 0.5 * (x + y)]) + 0.2
    aux = dict(layers or {})
    (root / "reference").mkdir(parents=True, exist_ok=True)
    for t in range(count):
        write_exr(root / "reference" / frame_name(t), {"color": reference, **aux})
    sets = list(table["seed_sets"]) + (
        [table["tuning_seed_set"]] if "tuning_seed_set" in table else []
    )
    for i, seed_set in enumerate(sets):
        generator = torch.Generator().manual_seed(i)
        for method in table["methods"]:
            (root / method / seed_set).mkdir(parents=True, exist_ok=True)
            for t in range(count):
                noise = 0.1 * torch.randn(3, height, width, generator=generator)
                if method != "white":
                    noise = noise - noise.mean(dim=(1, 2), keepdim=True)
                color = reference + noise
                write_exr(root / method / seed_set / frame_name(t), {"color": color, **aux})
    (root / MANIFEST).write_text(toml_text(table))
    return root
