"""Training data for the U-Net, from our own renderer: random scenes, noisy renders, references.

Every scene here is drawn at random from its integer seed (numpy's PCG64, so the same seed gives the
same scene on every machine) out of the renderer's declarative scene description
(:mod:`renderers.scene`): a room with a random subset of walls, random constant or textured
albedos (checker, felt), one to three spheres and boxes, one or two rectangle lights of random
size, color and power, a random camera inside the room, a random maximum path depth, and
sometimes a homogeneous medium. The benchmark's named scenes (``renderers.SCENES``) are never
drawn or used: :func:`check_held_out` verifies it, by name and by content.

Each training pair is a noisy render at a random low spp with white-noise seeds (or, for the
``white+blue`` mix, every odd-numbered pair's input made by one of the benchmark's blue-noise
strategies, :data:`BLUE_STRATEGIES`, as the benchmark makes it: see :func:`blue_input`) and a
reference of the same scene at ``reference_spp`` (64 by default here, 256 for ``bnerr train``,
which the shipped weights use) with other seeds.
The reference is itself a Monte Carlo estimate, but its noise is independent of the input's: under
an L2 loss it only adds a constant and the optimum is unchanged (Lehtinen et al. 2018,
"Noise2Noise"); under L1 the optimum is the median of the reference's noise instead of its mean,
nearly the same at 16 times the input's spp.

This module lives in :mod:`benchmarks` because :mod:`denoisers` must not import :mod:`renderers`.

Not for: benchmarking (the benchmark renders its named scenes); training a production denoiser
(the scenes are simple boxes and spheres with diffuse materials).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

import renderers
from bnerr.errors import ValueRangeError, check_name, check_positive_int
from bnerr.frame import Frame
from bnerr.sequences import make_sampler
from bnerr.strategies import make_strategy, play
from renderers.memory import render_bytes
from renderers.scene import (
    Box,
    Camera,
    Checker,
    Diffuse,
    Felt,
    Fixed,
    HomogeneousMedium,
    Rectangle,
    Scene,
    Sphere,
    affine,
)

__all__ = [
    "BLUE_STRATEGIES",
    "BLUE_WARMUP",
    "MIXES",
    "TrainingSpec",
    "blue_input",
    "check_held_out",
    "input_spp",
    "make_pairs",
    "pixel_seeds",
    "random_scene",
    "render_pair",
    "training_set_bytes",
]

#: Noise mixes of ``bnerr train --mix``.
MIXES = ("white", "white+blue")
#: Per-pixel samplers of the white-noise training inputs (``bnerr train --sampler``):
#: independent ``white`` values, or ``owen_sobol``, which every benchmark strategy renders with.
SAMPLERS = ("white", "owen_sobol")
#: Input spp of the training renders and how often each is drawn (4 spp, the benchmark's headline
#: setting, most often).
SPP_CHOICES = (1, 2, 4, 4, 8, 16)
#: The strategies that make the blue inputs of the ``white+blue`` mix, in turn: blue pair ``j``
#: (pair ``i = 2 j + 1``) uses ``BLUE_STRATEGIES[j % 4]``. The benchmark's headline method,
#: ``temporal`` (permuted seeds, Heitz & Belcour 2019), makes half of them; the a-priori rivals
#: ``zsobol`` (Ahmed & Wonka 2020) and ``cycles_blue`` (Cycles' blue-noise sequence) a quarter
#: each. Every power-of-two spp of :data:`SPP_CHOICES` suits all three.
BLUE_STRATEGIES = ("temporal", "zsobol", "temporal", "cycles_blue")
#: Frames a stateful strategy (``temporal``) renders before the one kept as the input, as the
#: benchmark's quality suite warms up before it measures (its sort converges in about 3 frames).
BLUE_WARMUP = 6

_NAME_PREFIX = "train-"


@dataclass(frozen=True)
class TrainingSpec:
    """What :func:`make_pairs` renders.

    Attributes:
        scenes: number of random scenes (one pair each).
        size: image side in pixels (square images).
        reference_spp: spp of each reference.
        mix: ``"white"`` or ``"white+blue"`` (every odd-numbered pair's input made by one of
            :data:`BLUE_STRATEGIES`, :func:`make_pairs`).
        sampler: per-pixel sampler of the non-blue inputs, one of :data:`SAMPLERS`. A denoiser
            learns the noise it is shown: Owen-Sobol error is smaller and differently distributed
            than independent samples' at the same spp (denoisers/weights/README.md measures it).
        seed: first scene seed; scene ``i`` uses seed ``seed + i``.
    """

    scenes: int = 128
    size: int = 64
    reference_spp: int = 64
    mix: str = "white"
    seed: int = 0
    sampler: str = "white"

    def __post_init__(self) -> None:
        check_positive_int(self.scenes, "TrainingSpec.scenes")
        check_positive_int(self.size, "TrainingSpec.size", minimum=8)
        check_positive_int(self.reference_spp, "TrainingSpec.reference_spp")
        check_name(self.mix, MIXES, "training mix")
        check_name(self.sampler, SAMPLERS, "training sampler")
        check_positive_int(self.seed, "TrainingSpec.seed", minimum=0)


def training_paths(spec: TrainingSpec) -> int:
    """Paths traced to render ``spec``'s pairs, at most: each pair's reference, and its input at
    the largest spp of :data:`SPP_CHOICES` with a stateful strategy's :data:`BLUE_WARMUP` frames
    (an upper bound; the time model's rough estimate, :mod:`renderers.budget`)."""
    per_pixel = spec.reference_spp + (BLUE_WARMUP + 1) * max(SPP_CHOICES)
    return spec.scenes * spec.size * spec.size * per_pixel


def training_set_bytes(spec: TrainingSpec, stored: bool = False) -> int:
    """Rough bytes of the training set of ``spec``: stored (``stored=True``: the network's inputs
    and targets, 12 float32 channels per pixel, as in the ``OUT.data`` cache), or the peak while
    it is made (every pair's frame, 16 float32 buffers, and reference, the stacked set, and one
    render's working set)."""
    pixels = spec.size * spec.size
    kept = spec.scenes * pixels * 12 * 4
    if stored:
        return kept
    return kept + spec.scenes * pixels * (16 + 3) * 4 + render_bytes(spec.size, spec.size)


# ----------------------------------------------------------------------------------------------
# Random scenes


def _triple(values: Iterable[Any]) -> tuple[float, float, float]:
    """Three numbers (numpy scalars, an array of 3) as a tuple of Python floats."""
    x, y, z = (float(v) for v in values)
    return x, y, z


def _albedo(
    rng: np.random.Generator, lo: float = 0.05, hi: float = 0.85
) -> tuple[float, float, float]:
    """A random RGB albedo, each channel in [lo, hi]: a tinted grey, or (half the time) a
    saturated color with one or two strong channels, like a snooker table's felt and balls."""
    if rng.uniform() < 0.5:
        grey = rng.uniform(lo, hi)
        tint = rng.uniform(-1.0, 1.0, 3) * rng.uniform(0.0, 0.6)
        return _triple(np.clip(grey * (1.0 + t), lo, hi) for t in tint)
    strong = rng.uniform(0.3, 1.0) * hi
    weak = rng.uniform(0.0, 0.4) * strong
    mask = rng.permutation([True, rng.uniform() < 0.3, False])
    return _triple(np.clip(strong if m else weak * rng.uniform(0.5, 1.0), lo, hi) for m in mask)


def _material(rng: np.random.Generator, textured: bool) -> Diffuse:
    """Constant albedo, or (on rectangles) a checker or felt texture."""
    kind = rng.integers(3) if textured else 0
    if kind == 0:
        return Diffuse(_albedo(rng))
    cells = int(rng.integers(2, 24))
    if kind == 1:
        return Diffuse(Checker(_albedo(rng), _albedo(rng), cells, int(rng.integers(2, 24))))
    return Diffuse(
        Felt(
            _albedo(rng, 0.1, 0.7),
            8 * cells,
            8 * cells,
            grain=float(rng.uniform(0.05, 0.4)),
            nap=float(rng.uniform(0.0, 0.2)),
            bands=int(rng.integers(1, 8)),
            seed=int(rng.integers(1 << 16)),
        )
    )


def _frame_towards(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit ``u``, ``v`` with ``u x v = normal`` (a right-handed frame around ``normal``)."""
    helper = np.array([0.0, 1.0, 0.0]) if abs(normal[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def _light(
    rng: np.random.Generator, index: int, room: float, height: float, ceiling_only: bool
) -> Rectangle:
    """A rectangle light of random size, color and power: on the ceiling, free and aimed at the
    room's middle, or (often) standing in front of the back wall, facing the camera.

    Its own albedo (what the albedo buffer shows on it) is black or, as for the Cornell box's
    light, a diffuse color like the surface it sits in.
    """
    half = rng.uniform(0.1, 0.45) * room * np.array([1.0, rng.uniform(0.3, 1.0)])
    temperature = rng.uniform(-0.35, 0.35)  # warm (red) to cool (blue) white
    color = np.array([1.0 + temperature, 1.0, 1.0 - temperature])
    area = 4.0 * half[0] * half[1]
    # Power spans 1.5 decades: auto-exposure must see bright and dark scenes.
    power = 10.0 ** rng.uniform(0.5, 2.0) * room * room
    emission = _triple(color * power / area)
    material = Diffuse((0.0, 0.0, 0.0)) if rng.uniform() < 0.5 else Diffuse(_albedo(rng, 0.3, 0.9))
    kind = rng.uniform()
    if kind < 0.45 or ceiling_only:  # ceiling light facing down
        center = (rng.uniform(-0.5, 0.5) * room, height - 1e-3, rng.uniform(-0.7, 0.3) * room)
        normal = np.array([0.0, -1.0, 0.0])
    elif kind < 0.75:  # a panel in front of the back wall, facing the camera: seen directly
        center = (
            rng.uniform(-0.6, 0.6) * room,
            rng.uniform(0.3, 0.9) * height,
            rng.uniform(-0.95, -0.7) * room,
        )
        normal = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.1), 1.0])
        normal /= np.linalg.norm(normal)
    else:  # a free panel above the floor, aimed at a point near the room's middle
        angle = rng.uniform(0.0, 2.0 * math.pi)
        center = (
            0.8 * room * math.sin(angle),
            rng.uniform(0.5, 0.9) * height,
            0.8 * room * math.cos(angle),
        )
        aim = np.array([rng.uniform(-0.3, 0.3) * room, rng.uniform(0.0, 0.3) * height, 0.0])
        normal = aim - np.asarray(center)
        normal /= np.linalg.norm(normal)
    u, v = _frame_towards(normal)

    return Rectangle(
        f"light{index}",
        _triple(center),
        _triple(u * half[0]),
        _triple(v * half[1]),
        material,
        emission,
    )


def _room(rng: np.random.Generator, room: float, height: float) -> list[Rectangle]:
    """Floor (always), back wall, side walls and ceiling (each sometimes); open front.

    Without walls the background is black, as around the benchmark's snooker table and fog box.
    """
    r, h = room, height
    walls = [
        Rectangle("floor", (0.0, 0.0, 0.0), (r, 0.0, 0.0), (0.0, 0.0, -r), _material(rng, True))
    ]
    if rng.uniform() < 0.6:
        walls.append(
            Rectangle(
                "back", (0.0, h / 2, -r), (r, 0.0, 0.0), (0.0, h / 2, 0.0), _material(rng, True)
            )
        )
    if rng.uniform() < 0.5:
        walls.append(
            Rectangle(
                "left", (-r, h / 2, 0.0), (0.0, h / 2, 0.0), (0.0, 0.0, r), _material(rng, True)
            )
        )
    if rng.uniform() < 0.5:
        walls.append(
            Rectangle(
                "right", (r, h / 2, 0.0), (0.0, 0.0, r), (0.0, h / 2, 0.0), _material(rng, True)
            )
        )
    if rng.uniform() < 0.5:
        walls.append(
            Rectangle("ceiling", (0.0, h, 0.0), (r, 0.0, 0.0), (0.0, 0.0, r), _material(rng, True))
        )
    return walls


def _objects(
    rng: np.random.Generator, room: float, x_range: tuple[float, float]
) -> list[Sphere | Box]:
    """One to three spheres and boxes standing on the floor, x within ``x_range`` (of ``room``)."""
    shapes: list[Sphere | Box] = []
    for i in range(int(rng.integers(1, 4))):
        x = rng.uniform(*x_range) * room
        z = rng.uniform(-0.7, 0.3) * room
        size = rng.uniform(0.12, 0.3) * room
        if rng.uniform() < 0.5:
            shapes.append(Sphere(f"sphere{i}", Fixed((x, size, z)), size, _material(rng, False)))
        else:
            scale = (
                size * rng.uniform(0.5, 1.0),
                size * rng.uniform(0.5, 1.5),
                size * rng.uniform(0.5, 1.0),
            )
            to_world = affine((x, scale[1], z), ((0.0, 1.0, 0.0), rng.uniform(0.0, 90.0)), scale)
            shapes.append(Box(f"box{i}", to_world, _material(rng, False)))
    return shapes


def random_scene(seed: int) -> Scene:
    """A random static scene drawn from ``seed`` (same seed, same scene, on every machine).

    Scene units: the room spans x, z in [-room, room] (room in [2, 5]) and y in [0, height];
    the front (+z) is open and the camera stands inside, looking toward -z.
    """
    check_positive_int(seed, "random_scene: seed", minimum=0)
    rng = np.random.default_rng([seed, 0x5EED])
    room = rng.uniform(2.0, 5.0)
    height = room * rng.uniform(0.8, 1.6)
    medium = None
    x_range = (-0.6, 0.6)
    if rng.uniform() < 0.3:
        # A fog box over one side of the room, below the ceiling lights; the objects stand on the
        # other side (their extent is at most 0.45 room), since no shape may lie inside a medium.
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        lo = (min(0.3 * side, 0.95 * side) * room, 1e-2, -room * 0.95)
        hi = (max(0.3 * side, 0.95 * side) * room, height * rng.uniform(0.4, 0.95), room * 0.5)
        medium = HomogeneousMedium(
            lo, hi, float(10.0 ** rng.uniform(-1.3, 0.2)), _albedo(rng, 0.5, 0.99)
        )
        x_range = (-0.6, -0.15) if side > 0 else (0.15, 0.6)
    shapes: list = _room(rng, room, height) + _objects(rng, room, x_range)
    lights = 1 + int(rng.uniform() < 0.35)
    shapes += [_light(rng, i, room, height, ceiling_only=medium is not None) for i in range(lights)]
    eye = (
        rng.uniform(-0.5, 0.5) * room,
        rng.uniform(0.15, 0.8) * height,
        rng.uniform(0.6, 0.95) * room,
    )
    # Looking down at the objects, or (40 %) up at the back wall and ceiling, so that lights are
    # often seen directly, as in the Cornell box: a denoiser must learn to keep them sharp.
    look_up = rng.uniform() < 0.4
    target_y = rng.uniform(0.5, 1.0) if look_up else rng.uniform(0.05, 0.4)
    target = (rng.uniform(-0.3, 0.3) * room, target_y * height, rng.uniform(-0.6, 0.0) * room)
    camera = Camera(Fixed(eye), Fixed(target), (0.0, 1.0, 0.0), float(rng.uniform(35.0, 75.0)))
    return Scene(
        name=f"{_NAME_PREFIX}{seed}",
        description=f"random training scene {seed}",
        camera=camera,
        shapes=tuple(shapes),
        max_depth=int(rng.integers(2, 6)),
        medium=medium,
        animated=False,
    )


def check_held_out(scenes: Sequence[Scene], named: Sequence[Scene]) -> None:
    """Raise :class:`ValueRangeError` if a training scene is, by name or content, a named scene."""
    names = {s.name for s in named}
    contents = {(s.shapes, s.camera.frozen(), s.medium) for s in named}
    for scene in scenes:
        if scene.name in names or (scene.shapes, scene.camera.frozen(), scene.medium) in contents:
            raise ValueRangeError(
                f"training scene {scene.name!r}: expected a held-out scene, "
                "got benchmark scene content"
            )


# ----------------------------------------------------------------------------------------------
# Rendering pairs


def pixel_seeds(height: int, width: int, key: int) -> torch.Tensor:
    """Distinct seeds ``[H, W]`` int64 for one render, different for every ``key``.

    ``key * H * W + pixel index``, masked to 31 bits: distinct within a render, and renders with
    different keys share no seed as long as ``key * H * W`` stays below 2^31.
    """
    index = torch.arange(height * width, dtype=torch.int64).reshape(height, width)
    return (index + key * height * width) & 0x7FFFFFFF


def blue_input(scene: Scene, size: int, spp: int, key: int, strategy: str, sampler: str) -> Frame:
    """The blue-noise input of a ``white+blue`` pair: a ``size x size`` frame of ``scene`` at
    ``spp`` made by ``strategy`` (one of :data:`BLUE_STRATEGIES`) as the benchmark makes it.

    ``bnerr.strategies.make_strategy(strategy, size, size, seed=key, sampler=sampler, spp=spp,
    dimensions=scene.dimensions)``; a stateful strategy (``temporal``) renders frames
    ``t = 0 .. BLUE_WARMUP`` in order and its last frame is returned (the seeds then sorted
    against the blue-noise mask for :data:`BLUE_WARMUP` frames); a stateless one (``zsobol``,
    ``cycles_blue``, which dictate their own sampler) returns its frame ``t = 0``. The scene is
    static, so every frame renders the same image with other samples.
    """

    name = check_name(strategy, BLUE_STRATEGIES, "blue training strategy")
    made = make_strategy(
        name, size, size, seed=key, sampler=sampler, spp=spp, dimensions=scene.dimensions
    )
    last = BLUE_WARMUP if made.stateful else 0
    played = play(
        made,
        lambda t: functools.partial(renderers.render, scene, t, spp=spp),
        range(last, last + 1),
    )
    return [frame for _, frame in played][-1]


def render_pair(
    scene: Scene,
    size: int,
    spp: int,
    reference_spp: int,
    key: int,
    blue: str | None = None,
    sampler: str = "white",
) -> tuple[Frame, torch.Tensor]:
    """A noisy render of ``scene`` at ``spp`` and its reference color ``[3, size, size]``.

    The noisy render uses white-noise seeds ``pixel_seeds(.., 2 key)`` with ``sampler`` (``white``
    or ``owen_sobol``), or with ``blue`` (a name of :data:`BLUE_STRATEGIES`)
    ``blue_input(scene, size, spp, key, blue, sampler)``; the reference uses
    ``pixel_seeds(.., 2 key + 1)`` and the white sampler, whatever the input.
    """

    sampler = check_name(sampler, SAMPLERS, "training sampler")
    if blue is None:
        frame = renderers.render(
            scene, 0, pixel_seeds(size, size, 2 * key), make_sampler(sampler), spp
        )
    else:
        frame = blue_input(scene, size, spp, key, blue, sampler)
    reference = renderers.render(
        scene, 0, pixel_seeds(size, size, 2 * key + 1), make_sampler("white"), reference_spp
    )
    return frame, reference.color


def input_spp(seed: int) -> int:
    """The input spp of the pair of scene ``seed``: drawn from :data:`SPP_CHOICES` by the seed."""
    return int(SPP_CHOICES[np.random.default_rng([seed, 0x5BB]).integers(len(SPP_CHOICES))])


def make_pairs(spec: TrainingSpec, progress: bool = True) -> list[tuple[Frame, torch.Tensor]]:
    """Render the training set described by ``spec``: one (noisy frame, reference) per scene.

    Pair ``i``: scene ``random_scene(spec.seed + i)``, input spp drawn from :data:`SPP_CHOICES`
    by the scene seed, key ``spec.seed + i + 1``; the input rendered with ``spec.sampler`` and
    white-noise seeds, except, when ``spec.mix == "white+blue"``, for odd ``i``: made by
    ``BLUE_STRATEGIES[(i // 2) % 4]`` (:func:`blue_input`). The even pairs of a ``white+blue``
    set, and every reference, equal the ``white`` set's bit for bit.
    """

    pairs = []
    scenes = [random_scene(spec.seed + i) for i in range(spec.scenes)]
    named = [renderers.get_scene(name, animated=False) for name in renderers.SCENES]
    # a scene that renders itself (a Mitsuba XML plug-in) shares no content with these
    check_held_out(scenes, [s for s in named if not renderers.renders_itself(s)])
    for i, scene in enumerate(tqdm(scenes, desc="render training set", disable=not progress)):
        seed = spec.seed + i
        spp = input_spp(seed)
        blue = None
        if spec.mix == "white+blue" and i % 2 == 1:
            blue = BLUE_STRATEGIES[(i // 2) % len(BLUE_STRATEGIES)]
        pairs.append(
            render_pair(
                scene,
                spec.size,
                int(spp),
                spec.reference_spp,
                key=seed + 1,
                blue=blue,
                sampler=spec.sampler,
            )
        )
    return pairs
