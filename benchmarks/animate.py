"""Animated comparisons: per scene, an MP4 and a small GIF of the strategies side by side.

The grid's columns are the reference and each strategy (``reference | white | temporal | ...``);
its rows the raw frames and the same frames after one denoiser. Every tile is tone-mapped with
the project's one tone map (:func:`bnerr.color.preview_u8`) and labelled on the frame (text drawn
with matplotlib's Agg renderer, no other font dependency).

**What the animation shows is what the tables measure.** A strategy's frames are rendered the
way a benchmark run renders them (:mod:`benchmarks.sweep.measure`): the strategy is built for seed
set ``seed_set`` with the run's per-pixel sampler, a temporal (stateful) strategy renders the
``warmup`` frames before the first frame shown and a stateless one skips them, the renderer sees
frame ``t * motion``, and the shown frames are ``t = warmup .. warmup + frames - 1``. The
references come from the benchmark's reference cache
(:class:`benchmarks.sweep.references.ReferenceCache`, the same seeds, sampler and files). The
denoiser takes the parameters the benchmark tuned on white noise for that scene, condition,
resolution and spp when a tuned-parameters file holds them (``results/quality/tuned_params.json``),
else its defaults; the caption says which.

- :func:`render_tiles`: the linear ``[3, H, W]`` tiles of every column and row, frame by frame.
- :func:`compose_frame`: one labelled grid frame ``[H, W, 3]`` uint8 from them.
- :func:`animate_scene`: both files of one scene; :func:`write_animations`: every scene of a
  suite, the call ``bnerr bench`` makes at the end of a suite.

The MP4 goes through imageio's ffmpeg plugin (libx264, yuv420p, one encoder thread); the GIF
through imageio's pillow plugin, from a centre crop of each tile and the first few frames, to stay
small. Both are written atomically (:func:`bnerr.io.atomic_write`).

Not for: measuring (:mod:`benchmarks.sweep.measure`), or single frames (``bnerr render``).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import torch

from benchmarks.suites import Suite, get_suite
from benchmarks.sweep.measure import scene_for, t_reference
from benchmarks.sweep.parts import BoundRender, Denoiser, Parts, known_names, real_parts
from benchmarks.sweep.plan import Run
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.tuning import TuningStore, stored_params, tuning_key
from bnerr.color import preview_u8
from bnerr.errors import DtypeError, MissingExtraError, check_name, check_positive_int
from bnerr.frame import Frame
from bnerr.io import atomic_write
from bnerr.outputs import check_output, clean_stale_temporaries, output_lock
from bnerr.strategies import STRATEGIES, make_strategy, play
from denoisers.tuning import ParamStore

__all__ = [
    "MANIFEST",
    "require_ffmpeg",
    "SHOWN_RIVALS",
    "Animation",
    "AnimationResult",
    "Tiles",
    "animate_scene",
    "compose_frame",
    "default_strategies",
    "manifest",
    "render_tiles",
    "write_animations",
    "write_gif",
    "write_mp4",
]

#: Strategies shown after white and temporal by default, when registered (in this order): the
#: rival with the lowest post-Gaussian error at 4 spp in the quick comparison of the rivals
#: (zsobol; cycles_blue leads at 1 spp), and the temporal variant that closed most of the gap to
#: the oracle in the ablation (docs/METHODS.md, section 8). Revisit both when results/quality
#: holds the rivals and results/gap the variants.
SHOWN_RIVALS: tuple[str, ...] = ("zsobol", "temporal+relative+demod+groups")
_REFERENCE = "reference"
#: The folder's description, written with the animations.
MANIFEST = "README.md"
_HEADER = 14  # pixels of the column-name strip
_CAPTION = 13  # pixels per caption line
_ROW_LABEL = 14  # pixels of the rotated row-name strip
_BLOCK = 16  # the MP4 frame is padded to a multiple of this (libx264's macro block)


def default_strategies() -> tuple[str, ...]:
    """``white``, ``temporal`` and the registered :data:`SHOWN_RIVALS` (a variant name counts as
    registered when :mod:`bnerr.strategies` builds it)."""

    return ("white", "temporal") + tuple(s for s in SHOWN_RIVALS if s in STRATEGIES)


@dataclass(frozen=True)
class Animation:
    """One scene's animated comparison: what is rendered and how it is written.

    Attributes:
        scene: scene name (``renderers.SCENES``).
        strategies: the strategy columns after the reference.
        denoiser: the second row's denoiser (``denoisers.DENOISERS``).
        frames: frames shown (``t = warmup .. warmup + frames - 1``); warmup: frames before them.
        width, height: frame size in pixels; spp: samples per pixel of the strategies' renders.
        seed_set: the benchmark seed set the strategies start from (0 is a run's first).
        sampler: the strategies' per-pixel sampler; motion: camera speed (as a benchmark
            condition: 0 static, k the animation k times faster).
        reference_spp: samples per pixel of the references (the benchmark's cache).
        fps: frames per second of both files.
        gif_crop: side of the centre crop of each tile in the GIF (the whole tile if larger).
        gif_frames: frames in the GIF (the first ones).
    """

    scene: str
    strategies: tuple[str, ...]
    denoiser: str = "gaussian"
    frames: int = 16
    warmup: int = 6
    width: int = 128
    height: int = 128
    spp: int = 4
    seed_set: int = 0
    sampler: str = "owen_sobol"
    motion: int = 1
    reference_spp: int = 1024
    fps: int = 8
    gif_crop: int = 64
    gif_frames: int = 8

    def check(self, known: dict[str, tuple[str, ...]]) -> Animation:
        """Check names against ``known`` (:func:`benchmarks.sweep.parts.known_names`) and sizes.

        Raises:
            UnknownNameError: an unknown scene, strategy or denoiser.
            DtypeError, ValueRangeError: a count that is not a positive integer.
        """
        check_name(self.scene, known["known_scenes"], "scene")
        if not self.strategies:
            raise DtypeError("strategies: expected at least one strategy, got none")
        for name in self.strategies:
            check_name(name, known["known_strategies"], "strategy")
        check_name(self.denoiser, known["known_denoisers"], "denoiser")
        for name in ("frames", "width", "height", "spp", "reference_spp", "fps", "gif_crop"):
            check_positive_int(getattr(self, name), name)
        for name in ("warmup", "seed_set", "motion", "gif_frames"):
            check_positive_int(getattr(self, name), name, minimum=0)
        return self

    def run(self) -> Run:
        """The benchmark run whose references and tuned parameters this animation shares."""
        return Run(
            scene=self.scene,
            strategy=_REFERENCE,
            spp=self.spp,
            motion=self.motion,
            depth=None,
            sampler=self.sampler,
            frames=self.frames,
            warmup=self.warmup,
            width=self.width,
            height=self.height,
            seed_sets=self.seed_set + 1,
            reference_spp=self.reference_spp,
            denoisers=(self.denoiser,),
            regions=("all",),
            metrics=(),
            crops=False,
        )

    @property
    def times(self) -> range:
        """The frames shown, as the benchmark numbers them."""
        return range(self.warmup, self.warmup + self.frames)


@dataclass
class Tiles:
    """The linear images of one animation, before tone mapping.

    Attributes:
        columns: column names, ``("reference", *strategies)``.
        raw, den: column -> one ``[3, H, W]`` float32 image per shown frame (the reference's
            ``den`` is the reference itself: it is not denoised).
        denoiser_label: what the second row shows (denoiser and where its parameters came from).
        seconds: column -> seconds spent rendering (and denoising) it.
    """

    columns: tuple[str, ...]
    raw: dict[str, list[torch.Tensor]]
    den: dict[str, list[torch.Tensor]]
    denoiser_label: str
    seconds: dict[str, float] = field(default_factory=dict)


def render_strategy(parts: Parts, spec: Animation, name: str) -> list[Frame]:
    """Strategy ``name``'s frames at ``spec.times``, rendered as a benchmark run renders them.

    A stateful strategy (its ``stateful``) renders the warmup frames first; a stateless one
    starts at the first shown frame (its frame t does not depend on earlier frames).
    """

    run = spec.run()
    scene = scene_for(run, parts)
    strategy = make_strategy(
        name,
        spec.height,
        spec.width,
        seed=spec.seed_set,
        sampler=spec.sampler,
        spp=spec.spp,
        dimensions=scene.dimensions,
    )
    render_at = functools.partial(BoundRender, parts, scene, spec.spp)
    shown = range(spec.warmup, spec.warmup + spec.frames)
    played = play(strategy, render_at, shown, max(run.motion, 1))
    return [frame for t, frame in played if t >= spec.warmup]


def render_references(parts: Parts, references: ReferenceCache, spec: Animation) -> list[Frame]:
    """The reference frames at ``spec.times`` (from the benchmark's cache, rendered if missing)."""
    run = spec.run()
    scene = scene_for(run, parts)
    return [references.get(run, scene, t_reference(run, t)) for t in spec.times]


def _format_params(params: dict) -> str:
    return " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in params.items())


def tuned_denoiser(
    parts: Parts, spec: Animation, store: TuningStore | None
) -> tuple[Denoiser, str]:
    """The denoiser with the parameters the benchmark tuned for this scene, condition,
    resolution and spp in ``store`` (a :class:`denoisers.tuning.ParamStore`, or None), else its
    defaults; and a label saying which."""
    stored = (
        None
        if store is None
        else stored_params(store, spec.denoiser, tuning_key(spec.run()), spec.spp)
    )
    denoiser = parts.make_denoiser(spec.denoiser, stored)
    params = getattr(denoiser, "params", None)
    shown = _format_params(dict(params())) if callable(params) else ""
    source = "tuned on white noise" if stored is not None else "default parameters"
    return denoiser, f"{spec.denoiser} {shown} ({source})".replace("  ", " ")


def render_tiles(
    parts: Parts, references: ReferenceCache, spec: Animation, store: TuningStore | None = None
) -> Tiles:
    """Render every column of ``spec``: the references and each strategy, raw and denoised.

    Returns:
        :class:`Tiles`; ``raw[name][i]`` is the ``color [3, H, W]`` of the frame the strategy
        renders at ``spec.times[i]`` (bit for bit), ``den[name][i]`` the denoiser's output on it.
    """
    denoiser, label = tuned_denoiser(parts, spec, store)
    tiles = Tiles(columns=(_REFERENCE, *spec.strategies), raw={}, den={}, denoiser_label=label)
    start = time.perf_counter()
    refs = [f.color for f in render_references(parts, references, spec)]
    tiles.raw[_REFERENCE] = tiles.den[_REFERENCE] = refs
    tiles.seconds[_REFERENCE] = time.perf_counter() - start
    for name in spec.strategies:
        start = time.perf_counter()
        frames = render_strategy(parts, spec, name)
        tiles.raw[name] = [f.color for f in frames]
        tiles.den[name] = [denoiser(f) for f in frames]
        tiles.seconds[name] = time.perf_counter() - start
    return tiles


# --------------------------------------------------------------------------------------------------
# Drawing


@functools.lru_cache(maxsize=512)
def text_strip(
    text: str, width: int, height: int, size_px: float, rotate: bool = False
) -> np.ndarray:
    """``text`` in white on black, centred in a ``[height, width, 3]`` uint8 strip (read-only).

    Drawn with matplotlib's Agg renderer and its bundled DejaVu Sans at ``size_px`` pixels, so it
    is the same on every machine with the same matplotlib; ``rotate`` writes upwards.
    """
    # matplotlib (2 s to import) and imageio are needed only once frames are drawn and written
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="black")
    canvas = FigureCanvasAgg(fig)
    fig.text(
        0.5,
        0.5,
        text,
        color="white",
        ha="center",
        va="center",
        rotation=90 if rotate else 0,
        fontsize=size_px * 72 / dpi,
        family="DejaVu Sans",
    )
    canvas.draw()
    strip = np.asarray(canvas.buffer_rgba())[:height, :width, :3].copy()
    strip.setflags(write=False)
    return strip


def fit_size(texts: Sequence[str], along: int, across: int) -> float:
    """One font size in pixels at which each of ``texts`` fits a strip ``along`` pixels long and
    ``across`` pixels high (DejaVu Sans averages about 0.6 em per character)."""
    longest = max((len(t) for t in texts), default=1)
    return min(across * 0.8, along / max(longest * 0.62, 1.0))


def _crop(image: torch.Tensor, size: int | None) -> torch.Tensor:
    if size is None:
        return image
    h, w = image.shape[-2:]
    ch, cw = min(size, h), min(size, w)
    y0, x0 = (h - ch) // 2, (w - cw) // 2
    return image[..., y0 : y0 + ch, x0 : x0 + cw]


def _tile(image: torch.Tensor, crop: int | None, scale: int) -> np.ndarray:
    u8 = preview_u8(_crop(image, crop))
    return np.repeat(np.repeat(u8, scale, axis=0), scale, axis=1) if scale > 1 else u8


def compose_frame(
    tiles: Tiles, index: int, caption: Sequence[str], *, crop: int | None = None, scale: int = 1
) -> np.ndarray:
    """Frame ``index`` of the grid as ``[H, W, 3]`` uint8: caption lines, column names, then the
    raw row and the denoised row (each tile tone-mapped by :func:`bnerr.color.preview_u8`, centre
    cropped to ``crop`` and enlarged ``scale`` times by pixel repetition)."""
    rows = []  # (row name, [th, n * tw, 3] tiles)
    for label, images in (("raw", tiles.raw), (tiles.denoiser_label.split()[0], tiles.den)):
        row = np.concatenate([_tile(images[c][index], crop, scale) for c in tiles.columns], axis=1)
        rows.append((label, row))
    th, tw = rows[0][1].shape[0], rows[0][1].shape[1] // len(tiles.columns)
    size = fit_size(tiles.columns, tw, _HEADER)
    header = np.concatenate([text_strip(c, tw, _HEADER, size) for c in tiles.columns], axis=1)
    body = np.concatenate([header] + [row for _, row in rows], axis=0)
    left = np.concatenate(
        [np.zeros((_HEADER, _ROW_LABEL, 3), np.uint8)]
        + [text_strip(label, _ROW_LABEL, th, size, rotate=True) for label, _ in rows],
        axis=0,
    )
    grid = np.concatenate([left, body], axis=1)
    size = fit_size(caption, grid.shape[1], _CAPTION)
    lines = [text_strip(line, grid.shape[1], _CAPTION, size) for line in caption]
    return np.ascontiguousarray(np.concatenate([*lines, grid], axis=0))


def _pad(frame: np.ndarray, multiple: int) -> np.ndarray:
    h, w = frame.shape[:2]
    ph, pw = -h % multiple, -w % multiple
    return np.pad(frame, ((0, ph), (0, pw), (0, 0))) if ph or pw else frame


# --------------------------------------------------------------------------------------------------
# Writing


def require_ffmpeg() -> None:
    """Raise :class:`~bnerr.errors.MissingExtraError` unless imageio's ffmpeg plugin
    (``imageio-ffmpeg``, which ships the ffmpeg binary) is installed."""
    if importlib.util.find_spec("imageio_ffmpeg") is None:
        raise MissingExtraError(
            "mp4", "ffmpeg", "imageio-ffmpeg (imageio's ffmpeg)", "no module named 'imageio_ffmpeg'"
        )


def write_mp4(path: str | Path, frames: Sequence[np.ndarray], fps: int, quality: int = 7) -> Path:
    """Write ``frames`` (each ``[H, W, 3]`` uint8, all one size) as an H.264 MP4, atomically.

    Frames are padded with black to a multiple of 16 pixels (so ffmpeg does not resize them);
    libx264 runs on one thread, yuv420p, imageio's ``quality`` scale (0-10).
    """
    require_ffmpeg()
    import imageio.v2 as imageio  # see text_strip: imported where the files are written

    path = Path(path)
    with atomic_write(path) as tmp:
        writer = imageio.get_writer(
            tmp,
            format="FFMPEG",
            mode="I",
            fps=fps,
            codec="libx264",
            quality=quality,
            pixelformat="yuv420p",
            macro_block_size=_BLOCK,
            ffmpeg_log_level="error",
            ffmpeg_params=["-threads", "1"],
        )
        try:
            for frame in frames:
                writer.append_data(_pad(frame, _BLOCK))
        finally:
            writer.close()
    return path


def write_gif(path: str | Path, frames: Sequence[np.ndarray], fps: int) -> Path:
    """Write ``frames`` (each ``[H, W, 3]`` uint8) as a looping GIF, atomically.

    The palette is one median-cut palette of at most 128 colours made from the first frame and
    used for every frame, without dithering (noise dithered compresses badly); the same frames
    give the same bytes.
    """
    import imageio.v3 as iio  # see text_strip: imported where the files are written
    from PIL import Image

    first = Image.fromarray(frames[0])
    palette = first.quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    indexed = [
        np.asarray(
            Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE).convert("RGB")
        )
        for f in frames
    ]
    path = Path(path)
    with atomic_write(path) as tmp:
        iio.imwrite(
            tmp,
            np.stack(indexed),
            extension=".gif",
            plugin="pillow",
            duration=round(1000 / fps),
            loop=0,
        )
    return path


def _caption(spec: Animation, tiles: Tiles, t: int) -> list[str]:
    return [
        f"{spec.scene}  {spec.width}x{spec.height}  {spec.spp} spp  t={t}  seed set "
        f"{spec.seed_set}  {spec.sampler}  reference {spec.reference_spp} spp",
        f"row 2: {tiles.denoiser_label}",
    ]


class AnimationResult(TypedDict):
    """What :func:`animate_scene` wrote: the two files, and the seconds spent on each column and
    on the encoding (``"encode"``)."""

    mp4: Path
    gif: Path
    seconds: dict[str, float]


def animate_scene(
    parts: Parts,
    references: ReferenceCache,
    spec: Animation,
    out_dir: str | Path,
    store: TuningStore | None = None,
) -> AnimationResult:
    """Render ``spec`` and write ``<scene>.mp4`` (every frame, whole tiles) and ``<scene>.gif``
    (the first ``gif_frames`` frames, centre crops of ``gif_crop`` pixels) into ``out_dir``.

    Returns:
        ``{"mp4": path, "gif": path, "seconds": {column: s, "encode": s}}``.
    """
    out = Path(out_dir)
    tiles = render_tiles(parts, references, spec, store)
    start = time.perf_counter()
    frames = [compose_frame(tiles, i, _caption(spec, tiles, t)) for i, t in enumerate(spec.times)]
    mp4 = write_mp4(out / f"{spec.scene}.mp4", frames, spec.fps)
    crop = spec.gif_crop if spec.gif_crop < max(spec.width, spec.height) else None
    shown = list(spec.times)[: spec.gif_frames or spec.frames]
    small = [
        compose_frame(tiles, i, _caption(spec, tiles, t), crop=crop) for i, t in enumerate(shown)
    ]
    gif = write_gif(out / f"{spec.scene}.gif", small, spec.fps)
    seconds = dict(tiles.seconds, encode=time.perf_counter() - start)
    return AnimationResult(mp4=mp4, gif=gif, seconds=seconds)


def load_store(path: str | Path | None) -> ParamStore | None:
    """The tuned parameters at ``path`` (:class:`denoisers.tuning.ParamStore`), or None when
    ``path`` is None or no such file exists (the denoiser then runs with its defaults)."""

    if path is None or not Path(path).is_file():
        return None
    return ParamStore.load(path)


def write_animations(
    suite: Suite | str,
    out_dir: str | Path,
    *,
    cache_dir: str | Path = "cache/references",
    params: str | Path | None = None,
    scenes: Sequence[str] | None = None,
    strategies: Sequence[str] | None = None,
    **options: Any,
) -> list[AnimationResult]:
    """One animation per scene of ``suite`` (a :class:`benchmarks.suites.Suite` or its name),
    written into ``out_dir`` (checked first, then locked for the whole run).

    The suite's first sweep gives the scenes, resolution, warmup and reference spp, and the spp:
    4 when the sweep measures it (the animations' usual setting), else its smallest.
    ``strategies`` defaults to :func:`default_strategies`; ``params`` is the tuned-parameters file
    (``<suite out>/tuned_params.json``; missing: the denoiser's defaults). ``options`` set or
    override any other field of :class:`Animation` (``frames``, ``reference_spp``, ``denoiser``,
    ``fps``, ...).

    Returns:
        :func:`animate_scene`'s result per scene.
    """

    sweep = (get_suite(suite) if isinstance(suite, str) else suite).sweeps[0]
    base = Animation(
        scene="",
        strategies=tuple(strategies or default_strategies()),
        warmup=sweep.warmup,
        width=sweep.res[0],
        height=sweep.res[1],
        spp=4 if 4 in sweep.spp else min(sweep.spp),
        reference_spp=sweep.reference_spp,
    )
    known = known_names()
    specs = [
        dataclasses.replace(base, scene=name, **options).check(known)
        for name in (scenes or sweep.scenes)
    ]
    return animate(specs, out_dir, cache_dir=cache_dir, params=params)


def animate(
    specs: Sequence[Animation],
    out_dir: str | Path,
    *,
    cache_dir: str | Path,
    params: str | Path | None = None,
    parts: Parts | None = None,
    on_scene: Callable[[Animation, AnimationResult], object] | None = None,
) -> list[AnimationResult]:
    """Write every animation of ``specs`` into ``out_dir``: the folder is checked
    (:func:`bnerr.outputs.check_output`) and the tuned parameters read before any render, and
    the folder's lock (:func:`bnerr.outputs.output_lock`) is held throughout (the temporaries a
    killed run left for these files are removed first). ``on_scene`` is called with each scene's
    result."""

    require_ffmpeg()  # before any render, not at the first MP4
    out = check_output(out_dir, "dir", need_bytes=2**20 * len(specs))
    store = load_store(params)
    parts = real_parts() if parts is None else parts
    references = ReferenceCache(cache_dir, parts)
    results = []
    with output_lock(out, "bnerr animate"):
        clean_stale_temporaries(out, [f"{s.scene}.{ext}" for s in specs for ext in ("mp4", "gif")])
        for spec in specs:
            result = animate_scene(parts, references, spec, out, store)
            results.append(result)
            if on_scene is not None:
                on_scene(spec, result)
        with atomic_write(out / MANIFEST) as tmp:
            Path(tmp).write_text(manifest(specs, results, out))
    return results


def _command(specs: Sequence[Animation], out: Path) -> str:
    """The ``bnerr animate`` command that makes ``specs`` (the first scene's settings)."""
    s = specs[0]
    return (
        f"bnerr animate --scenes {' '.join(x.scene for x in specs)} --strategies "
        f"{' '.join(s.strategies)} --denoiser {s.denoiser} --frames {s.frames} --warmup "
        f"{s.warmup} --res {s.width}x{s.height} --spp {s.spp} --seed-set {s.seed_set} "
        f"--reference-spp {s.reference_spp} --out {out}"
    )


def manifest(specs: Sequence[Animation], results: Sequence[AnimationResult], out: Path) -> str:
    """``README.md`` of an animation folder: the command, what the grids show, files and times."""
    s = specs[0]
    lines = [
        "# Animated comparisons",
        "",
        f"Written by `bnerr animate` (`benchmarks/animate.py`):\n\n    {_command(specs, out)}",
        "",
        f"Columns: reference | {' | '.join(s.strategies)}; rows: raw, and after {s.denoiser} "
        "(the benchmark's tuned parameters where stored; each file's caption says which). Frames "
        f"t = {s.warmup}..{s.warmup + s.frames - 1} of seed set {s.seed_set}, {s.sampler} "
        f"per-pixel sequences unless a strategy dictates its own, {s.spp} spp; the reference "
        f"column at {s.reference_spp} spp is there for the eye, not for measuring. Tiles are "
        "tone-mapped with `bnerr.color.preview_u8`. `<scene>.mp4` holds every frame at full "
        f"size, `<scene>.gif` the first {s.gif_frames} frames of a {s.gif_crop}-pixel centre crop.",
        "",
        "| scene | MP4 | GIF | seconds |",
        "|---|---|---|---|",
    ]
    for spec, result in zip(specs, results, strict=True):
        size = {k: Path(result[k]).stat().st_size // 1024 for k in ("mp4", "gif")}
        seconds = ", ".join(f"{k} {v:.0f}" for k, v in result["seconds"].items())
        lines.append(f"| {spec.scene} | {size['mp4']} KiB | {size['gif']} KiB | {seconds} |")
    return "\n".join(lines) + "\n"
